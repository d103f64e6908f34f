//! The emission kernel ([`super::hit_rays`]) in AVX intrinsics, in two steps per group of eight
//! rays: every group box against the eight rays at once (the rays in the lanes, one `vmovmskps`
//! per box), the masks gathered into one `u64` of (group, ray) bits with no branch; then, for each
//! set bit, that ray against the group's eight lights at once (the lights in the lanes, the ray
//! broadcast): the rays that meet a box are tested, and only those, with no lane of the light
//! test idle (a light group has eight lights; a ray group meeting a box held five rays that meet
//! it on average, on the bench scene). One loop over the bits, rather than a branch per box and a
//! loop per met box, leaves one data-dependent branch per ray group (see the parent module's
//! fourth round).
//!
//! Written with `std::arch` rather than as portable lane loops: LLVM compiled such loops into
//! calls that reloaded their inputs and built lane masks with a shift and an `or` per lane, or,
//! inlined, left most lanes scalar (see the parent module). No FMA: each lane runs the scalar
//! test's IEEE operations in its order, so results are the same bits. `vminps`/`vmaxps` return
//! their second operand when either is NaN; operands are ordered so that this is
//! `f32::min`/`f32::max`'s choice wherever a NaN can occur (a NaN `tmax`).

use super::{LightShape, Ray, RayHit, LANES};
use crate::lights::area_groups::{self, GroupBox};
use lanekit::{Lanes, Lanes3};
use std::arch::x86_64::*;

/// Eight rays, transposed (lanes past a batch's end hold stale rays and are masked out).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct RayLanes {
    o: Lanes3,
    d: Lanes3,
    tmax: Lanes,
}

/// A group's eight lights, transposed, with the constants of the scalar tests (`r²` computed as
/// the scalar code does: the same bits).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct GroupLanes {
    center: Lanes3,
    /// Sphere lanes: `radius * radius`.
    radius2: Lanes,
    /// Rect and disk lanes: the emission normal.
    normal: Lanes3,
    /// The lanes that hold a sphere light.
    spheres: u32,
    /// The lanes that hold a rect or disk light.
    planars: u32,
}

/// The scene's area lights as the AVX kernel reads them: one [`GroupLanes`] per group of
/// [`area_groups::GROUP`] lights.
#[derive(Clone, Debug, Default)]
pub(super) struct Kernel {
    groups: Vec<GroupLanes>,
    /// Whether every group box is finite (one condition of [`box_mask`]'s `FINITE` path).
    finite_boxes: bool,
    /// Whether a group holds a rect or disk light (else the plane test is left out).
    planars: bool,
}

impl Kernel {
    /// `shapes` in [`crate::lights::Lights::area_lights`] order, `boxes` their groups' boxes.
    pub(super) fn new(shapes: &[LightShape], boxes: &[GroupBox]) -> Self {
        let groups: Vec<GroupLanes> = shapes
            .chunks(area_groups::GROUP)
            .map(|group| {
                let mut lanes = GroupLanes::default();
                for (k, shape) in group.iter().enumerate() {
                    let center = match *shape {
                        LightShape::Sphere { center, radius2 } => {
                            lanes.radius2[k] = radius2;
                            lanes.spheres |= 1 << k;
                            center
                        }
                        LightShape::Planar { center, normal, .. } => {
                            (0..3).for_each(|a| lanes.normal[a][k] = normal[a]);
                            lanes.planars |= 1 << k;
                            center
                        }
                    };
                    (0..3).for_each(|a| lanes.center[a][k] = center[a]);
                }
                lanes
            })
            .collect();
        let finite_boxes = boxes.iter().all(|b| b.lo.iter().chain(&b.hi).all(|x| x.is_finite()));
        let planars = groups.iter().any(|g| g.planars != 0);
        Kernel { groups, finite_boxes, planars }
    }
}

#[inline]
#[target_feature(enable = "avx")]
fn load(lanes: &Lanes) -> __m256 {
    // SAFETY: `lanes` is eight readable `f32`s, 32-byte aligned (`RayLanes`, `GroupLanes`).
    unsafe { _mm256_load_ps(lanes.as_ptr()) }
}

/// `(a[0]·b[0] + a[1]·b[1]) + a[2]·b[2]`: glam's `dot` order.
#[inline]
#[target_feature(enable = "avx")]
fn dot(a: [__m256; 3], b: [__m256; 3]) -> __m256 {
    _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])),
        _mm256_mul_ps(a[2], b[2]),
    )
}

/// Eight rays in registers.
#[derive(Clone, Copy)]
struct Rays {
    o: [__m256; 3],
    inv_d: [__m256; 3],
    tmax: __m256,
}

#[inline]
#[target_feature(enable = "avx")]
fn rays_of(ray: &RayLanes) -> Rays {
    Rays {
        o: ray.o.each_ref().map(|c| load(c)),
        // `1 / d` as `Vec3::recip` divides.
        inv_d: ray.d.each_ref().map(|c| _mm256_div_ps(_mm256_set1_ps(1.0), load(c))),
        tmax: load(&ray.tmax),
    }
}

impl Rays {
    /// Whether the lanes `live` have finite origins and inverse directions: then no slab of a
    /// finite box gives NaN (`(lo − o)·(1/d)` is a finite or infinite difference times a finite
    /// non-zero factor), and the box test can skip [`box_mask`]'s NaN selects. `x·0` is NaN
    /// exactly where `x` is not finite, and NaN survives the sum.
    #[inline]
    #[target_feature(enable = "avx")]
    fn finite(&self, live: u32) -> bool {
        let zero = _mm256_setzero_ps();
        let sum = [self.o, self.inv_d]
            .iter()
            .flatten()
            .fold(zero, |sum, &x| _mm256_add_ps(sum, _mm256_mul_ps(x, zero)));
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_ORD_Q>(sum, sum)) as u32 & live == live
    }
}

/// [`area_groups::ray_meets`] of the eight rays against `b`: bit `k` for ray `k` (the same
/// operations, lane by lane, as the scalar test). `FINITE` when no slab can give NaN
/// ([`Rays::finite`], and a finite box): the selects that skip a NaN slab are then left out
/// (45 rather than 54 instructions per box and ray group, loop included), with the same bits.
#[inline]
#[target_feature(enable = "avx")]
fn box_mask<const FINITE: bool>(b: &GroupBox, r: &Rays) -> u32 {
    let (mut near, mut far) = (_mm256_setzero_ps(), r.tmax);
    for a in 0..3 {
        let t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_broadcast_ss(&b.lo[a]), r.o[a]), r.inv_d[a]);
        let t1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_broadcast_ss(&b.hi[a]), r.o[a]), r.inv_d[a]);
        // `near` is never NaN; a NaN `far` (NaN `tmax`) gives way to the slab's far end, as
        // `f32::min` does.
        let nearer = _mm256_max_ps(near, _mm256_min_ps(t0, t1));
        let farther = _mm256_min_ps(far, _mm256_max_ps(t0, t1));
        if FINITE {
            (near, far) = (nearer, farther);
        } else {
            // Both ordered: the slab constrains (the scalar test skips it otherwise).
            let keep = _mm256_cmp_ps::<_CMP_ORD_Q>(t0, t1);
            near = _mm256_blendv_ps(near, nearer, keep);
            far = _mm256_blendv_ps(far, farther, keep);
        }
    }
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
}

/// The hits of ray `k` of `rays` (the batch's ray `j`) with group `g`'s lights (`lanes`),
/// appended to `hits` in light order: a cheap reject in lanes with the scalar test's own
/// operations (for a sphere `!(disc < 0)`, where `ray_sphere` goes on; for a rect or disk
/// `!(cos ≥ 0)`, `t > 0`, `t < tmax`, where `Light::intersect` goes on), then the exact scalar test
/// ([`tails`]) for the few lights that pass. The ray is broadcast from memory and the group's lanes
/// loaded for each pair: loads, where values kept in registers across the pairs were spilled.
#[inline]
#[target_feature(enable = "avx")]
fn ray_light_hits<const PLANARS: bool>(
    lanes: &GroupLanes,
    shapes: &[LightShape],
    (rays, k, j): (&RayLanes, usize, usize),
    g: usize,
    hits: &mut Vec<RayHit>,
) {
    let zero = _mm256_setzero_ps();
    let center = lanes.center.each_ref().map(|c| load(c));
    let o = [0, 1, 2].map(|a| _mm256_broadcast_ss(&rays.o[a][k]));
    let d = [0, 1, 2].map(|a| _mm256_broadcast_ss(&rays.d[a][k]));
    // The sphere reject in every group (no branch: `spheres` masks it).
    let oc = [0, 1, 2].map(|a| _mm256_sub_ps(o[a], center[a]));
    let bq = dot(oc, d);
    let c = _mm256_sub_ps(dot(oc, oc), load(&lanes.radius2));
    let disc = _mm256_sub_ps(_mm256_mul_ps(bq, bq), c);
    // `!(disc < 0)`, NaN included.
    let mut pass = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_NLT_UQ>(disc, zero)) as u32 & lanes.spheres;
    if PLANARS && lanes.planars != 0 {
        let normal = lanes.normal.each_ref().map(|n| load(n));
        let cos = dot(d, normal);
        let to = [0, 1, 2].map(|a| _mm256_sub_ps(center[a], o[a]));
        let t = _mm256_div_ps(dot(to, normal), cos);
        let ahead = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_NGE_UQ>(cos, zero),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_broadcast_ss(&rays.tmax[k])),
            ),
        );
        pass |= _mm256_movemask_ps(ahead) as u32 & lanes.planars;
    }
    if pass != 0 {
        tails(shapes, rays, k, j, g * area_groups::GROUP, pass, hits);
    }
}

/// The exact scalar tests ([`LightShape::hit`], the portable kernel's) of the lights `pass` of
/// group `g` with ray `k` of `rays` (ray `j` of the batch). They redo the lane arithmetic of the
/// reject, by the same operations (the same bits), rather than read it back: kept in registers
/// for this, the lane values were spilled for every ray (four stores per ray and group), while a
/// few rays in a hundred get here. Out of line for the same reason.
#[inline(never)]
#[cold]
fn tails(
    shapes: &[LightShape],
    rays: &RayLanes,
    k: usize,
    j: usize,
    first: usize,
    mut pass: u32,
    hits: &mut Vec<RayHit>,
) {
    let ray =
        Ray { o: [0, 1, 2].map(|a| rays.o[a][k]), d: [0, 1, 2].map(|a| rays.d[a][k]), tmax: rays.tmax[k] };
    while pass != 0 {
        let light = first + pass.trailing_zeros() as usize;
        pass &= pass - 1;
        if let Some(t) = shapes[light].hit(&ray) {
            hits.push(RayHit { ray: j as u32, light: light as u32, t });
        }
    }
}

/// [`super::hit_rays`] on AVX: the same hits, each ray's in the same order (the rays of a group
/// of eight come interleaved: group by group, then ray by ray).
///
/// # Safety
/// The CPU must support AVX.
#[target_feature(enable = "avx")]
pub(super) unsafe fn hit_rays(
    kernel: &Kernel,
    shapes: &[LightShape],
    boxes: &[GroupBox],
    n: usize,
    rays: impl Fn(usize) -> Ray,
    hits: &mut Vec<RayHit>,
) {
    // One box per group (`pair_loop` relies on it).
    let boxes = &boxes[..boxes.len().min(kernel.groups.len())];
    let mut lanes = RayLanes::default();
    for first in (0..n).step_by(LANES) {
        let m = (n - first).min(LANES);
        for k in 0..m {
            let ray = rays(first + k);
            for a in 0..3 {
                (lanes.o[a][k], lanes.d[a][k]) = (ray.o[a], ray.d[a]);
            }
            lanes.tmax[k] = ray.tmax;
        }
        let live = (1u32 << m) - 1;
        let v = rays_of(&lanes);
        let rays = (&lanes, &v, first, live);
        if kernel.finite_boxes && v.finite(live) {
            ray_group_hits::<true>(kernel, shapes, boxes, rays, hits);
        } else {
            ray_group_hits::<false>(kernel, shapes, boxes, rays, hits);
        }
    }
}

/// Groups whose box tests fill one `u64` of (group, ray) bits.
const GROUPS_PER_MASK: usize = 64 / LANES;

/// The hits of a group of eight rays (`lanes`, in registers `v`; the batch's rays `first..`, the
/// lanes `live`): [`box_mask::<FINITE>`] of up to eight group boxes into one `u64` (bit `8g + k`:
/// ray `k` meets box `g`), with no branch, then [`ray_light_hits`] for each set bit. Only the
/// bit loop's exit is a data-dependent branch (one per ray group, rather than one per box and one
/// per met box's ray loop). Scenes with at most eight groups (the usual case) take one `u64`, so
/// the rays in registers die before the light tests (live across them, they were reloaded from
/// the stack for every pair).
#[inline]
#[target_feature(enable = "avx")]
fn ray_group_hits<const FINITE: bool>(
    kernel: &Kernel,
    shapes: &[LightShape],
    boxes: &[GroupBox],
    (lanes, v, first, live): (&RayLanes, &Rays, usize, u32),
    hits: &mut Vec<RayHit>,
) {
    let live = u64::from(live) * 0x0101_0101_0101_0101;
    if boxes.len() <= GROUPS_PER_MASK {
        let pairs = box_masks::<FINITE>(boxes, v) & live;
        pair_hits(kernel, &kernel.groups, shapes, (lanes, first), (0, pairs), hits);
        return;
    }
    let chunks = boxes.chunks(GROUPS_PER_MASK).zip(kernel.groups.chunks(GROUPS_PER_MASK));
    for (c, (boxes, groups)) in chunks.enumerate() {
        let pairs = box_masks::<FINITE>(boxes, v) & live;
        pair_hits(kernel, groups, shapes, (lanes, first), (c * GROUPS_PER_MASK, pairs), hits);
    }
}

/// [`box_mask::<FINITE>`] of the rays `v` against up to eight boxes: bit `8g + k` for ray `k`
/// and box `g`.
#[inline]
#[target_feature(enable = "avx")]
fn box_masks<const FINITE: bool>(boxes: &[GroupBox], v: &Rays) -> u64 {
    let mut pairs = 0u64;
    for (g, b) in boxes.iter().take(GROUPS_PER_MASK).enumerate() {
        pairs |= u64::from(box_mask::<FINITE>(b, v)) << (LANES * g);
    }
    pairs
}

/// [`ray_light_hits`] for each (group, ray) bit of `pairs` (`groups` being the groups from
/// `first_group` on, one per box of the bits), in bit order: group by group, ray by ray. Scenes
/// without rect and disk lights (the usual case) take a loop without the plane test's branch.
#[inline]
#[target_feature(enable = "avx")]
fn pair_hits(
    kernel: &Kernel,
    groups: &[GroupLanes],
    shapes: &[LightShape],
    rays: (&RayLanes, usize),
    (first_group, pairs): (usize, u64),
    hits: &mut Vec<RayHit>,
) {
    if kernel.planars {
        pair_loop::<true>(groups, shapes, rays, (first_group, pairs), hits);
    } else {
        pair_loop::<false>(groups, shapes, rays, (first_group, pairs), hits);
    }
}

/// [`pair_hits`]' loop.
#[inline]
#[target_feature(enable = "avx")]
fn pair_loop<const PLANARS: bool>(
    groups: &[GroupLanes],
    shapes: &[LightShape],
    (lanes, first): (&RayLanes, usize),
    (first_group, mut pairs): (usize, u64),
    hits: &mut Vec<RayHit>,
) {
    while pairs != 0 {
        let bit = pairs.trailing_zeros() as usize;
        pairs &= pairs - 1;
        let (g, k) = (bit / LANES, bit % LANES);
        debug_assert!(g < groups.len());
        // SAFETY: `pairs` has bits only for the boxes given to `box_masks`, one per group of
        // `groups` (`hit_rays` cuts the boxes to the groups).
        let group = unsafe { groups.get_unchecked(g) };
        ray_light_hits::<PLANARS>(group, shapes, (lanes, k, first + k), first_group + g, hits);
    }
}

/// [`box_mask`] for tests: the box test of eight rays, by the path the kernel takes for them, and
/// whether that was the finite one.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(test)]
#[target_feature(enable = "avx")]
pub(super) unsafe fn box_bits(kernel: &Kernel, b: &GroupBox, rays: &[Ray], live: u32) -> (u32, bool) {
    let mut lanes = RayLanes::default();
    for (k, ray) in rays.iter().enumerate() {
        for a in 0..3 {
            (lanes.o[a][k], lanes.d[a][k]) = (ray.o[a], ray.d[a]);
        }
        lanes.tmax[k] = ray.tmax;
    }
    let v = rays_of(&lanes);
    if kernel.finite_boxes && v.finite(live) {
        (box_mask::<true>(b, &v), true)
    } else {
        (box_mask::<false>(b, &v), false)
    }
}

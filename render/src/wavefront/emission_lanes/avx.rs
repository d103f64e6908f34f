//! The emission kernel ([`super::hit_rays`]) in AVX intrinsics, in two steps per group of eight
//! rays: each group box against the eight rays at once (the rays in the lanes, one `vmovmskps`),
//! then, for each ray that meets the box, that ray against the group's eight lights at once (the
//! lights in the lanes, the ray broadcast): the rays that meet a box are tested, and only those,
//! with no lane of the light test idle (a light group has eight lights; a ray group meeting a box
//! held five rays that meet it on average, on the bench scene).
//!
//! Written with `std::arch` rather than as portable lane loops: LLVM compiled such loops into
//! calls that reloaded their inputs and built lane masks with a shift and an `or` per lane, or,
//! inlined, left most lanes scalar (see the parent module). No FMA: each lane runs the scalar
//! test's IEEE operations in its order, so results are the same bits. `vminps`/`vmaxps` return
//! their second operand when either is NaN; operands are ordered so that this is
//! `f32::min`/`f32::max`'s choice wherever a NaN can occur (a NaN `tmax`).

use super::{LightShape, Ray, RayHit, LANES};
use crate::area_groups::{self, GroupBox};
use std::arch::x86_64::*;

/// Eight rays, transposed (lanes past a batch's end hold stale rays and are masked out).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct RayLanes {
    o: [[f32; LANES]; 3],
    d: [[f32; LANES]; 3],
    tmax: [f32; LANES],
}

/// A group's eight lights, transposed, with the constants of the scalar tests (`r²` computed as
/// the scalar code does: the same bits).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct GroupLanes {
    center: [[f32; LANES]; 3],
    /// Sphere lanes: `radius * radius`.
    radius2: [f32; LANES],
    /// Rect and disk lanes: the emission normal.
    normal: [[f32; LANES]; 3],
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
}

impl Kernel {
    /// `shapes` in [`crate::lights::Lights::area_lights`] order, `boxes` their groups' boxes.
    pub(super) fn new(shapes: &[LightShape], boxes: &[GroupBox]) -> Self {
        let groups = shapes
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
        Kernel { groups, finite_boxes }
    }
}

#[inline]
#[target_feature(enable = "avx")]
fn load(lanes: &[f32; LANES]) -> __m256 {
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

/// The hits of the rays `meets` of `rays` (the batch's rays `first..first + 8`) with group `g`'s
/// lights (`lanes`), appended to `hits` ray by ray, in light order for each: a cheap reject in
/// lanes with the scalar test's own operations (for a sphere `!(disc < 0)`, where `ray_sphere`
/// goes on; for a rect or disk `!(cos ≥ 0)`, `t > 0`, `t < tmax`, where `Light::intersect` goes
/// on), then the exact scalar test ([`tails`]) for the few lights that pass. The group's lanes are
/// loaded once for all its rays; a group of spheres only (the usual case) skips the plane test.
#[inline]
#[target_feature(enable = "avx")]
fn group_hits(
    lanes: &GroupLanes,
    shapes: &[LightShape],
    (rays, first, mut meets): (&RayLanes, usize, u32),
    g: usize,
    hits: &mut Vec<RayHit>,
) {
    let zero = _mm256_setzero_ps();
    let center = lanes.center.each_ref().map(|c| load(c));
    let radius2 = load(&lanes.radius2);
    let sphere_rejects = |o: [__m256; 3], d: [__m256; 3]| {
        let oc = [0, 1, 2].map(|a| _mm256_sub_ps(o[a], center[a]));
        let bq = dot(oc, d);
        let c = _mm256_sub_ps(dot(oc, oc), radius2);
        let disc = _mm256_sub_ps(_mm256_mul_ps(bq, bq), c);
        // `!(disc < 0)`, NaN included.
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_NLT_UQ>(disc, zero)) as u32 & lanes.spheres
    };
    let broadcast = |k: usize| {
        (
            [0, 1, 2].map(|a| _mm256_broadcast_ss(&rays.o[a][k])),
            [0, 1, 2].map(|a| _mm256_broadcast_ss(&rays.d[a][k])),
        )
    };
    if lanes.planars == 0 {
        while meets != 0 {
            // `& 7`: no bounds check on the lanes (`meets` has eight bits).
            let k = meets.trailing_zeros() as usize & 7;
            meets &= meets - 1;
            let (o, d) = broadcast(k);
            let pass = sphere_rejects(o, d);
            if pass != 0 {
                tails(shapes, (rays, k, first + k), (g, pass), hits);
            }
        }
        return;
    }
    let normal = lanes.normal.each_ref().map(|n| load(n));
    while meets != 0 {
        let k = meets.trailing_zeros() as usize & 7;
        meets &= meets - 1;
        let (o, d) = broadcast(k);
        let spheres = if lanes.spheres != 0 { sphere_rejects(o, d) } else { 0 };
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
        let pass = spheres | _mm256_movemask_ps(ahead) as u32 & lanes.planars;
        if pass != 0 {
            tails(shapes, (rays, k, first + k), (g, pass), hits);
        }
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
    (rays, k, j): (&RayLanes, usize, usize),
    (g, mut pass): (usize, u32),
    hits: &mut Vec<RayHit>,
) {
    let ray =
        Ray { o: [0, 1, 2].map(|a| rays.o[a][k]), d: [0, 1, 2].map(|a| rays.d[a][k]), tmax: rays.tmax[k] };
    let first = g * area_groups::GROUP;
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

/// The hits of a group of eight rays (`lanes`, in registers `v`; the batch's rays `first..`, the
/// lanes `live`), by [`box_mask::<FINITE>`] then [`group_hits`] for every group box they meet.
#[inline]
#[target_feature(enable = "avx")]
fn ray_group_hits<const FINITE: bool>(
    kernel: &Kernel,
    shapes: &[LightShape],
    boxes: &[GroupBox],
    (lanes, v, first, live): (&RayLanes, &Rays, usize, u32),
    hits: &mut Vec<RayHit>,
) {
    for (g, (b, group)) in boxes.iter().zip(&kernel.groups).enumerate() {
        let meets = box_mask::<FINITE>(b, v) & live;
        if meets != 0 {
            group_hits(group, shapes, (lanes, first, meets), g, hits);
        }
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

//! The ray-lane emission kernel ([`super::hit_rays`]) in AVX intrinsics: the eight rays of a group
//! stay in `ymm` registers across every group box and light, each box test is ~25 instructions and
//! each light's reject ~15, and a lane mask is one `vmovmskps`.
//!
//! Written with `std::arch` rather than as portable lane loops: LLVM compiled those loops into a
//! call per light that reloaded the rays, stored three result columns, and built the lane mask
//! with a shift and an `or` per lane (57 instructions per sphere and ray group, 17 of them the
//! mask); inlined, its SLP vectorizer left most lanes scalar (see the parent module). No FMA: each
//! lane runs the scalar test's IEEE operations in its order, so results are the same bits.
//! `vminps`/`vmaxps` return their second operand when either is NaN; operands are ordered so that
//! this is `f32::min`/`f32::max`'s choice wherever a NaN can occur (a NaN `tmax`).

use super::{planar_inside, LightShape, RayHit, RayLanes, RejectLanes, LANES};
use crate::area_groups::{self, GroupBox};
use crate::lights::sphere_roots;
use std::arch::x86_64::*;

/// Eight rays in registers.
#[derive(Clone, Copy)]
struct Rays {
    o: [__m256; 3],
    d: [__m256; 3],
    inv_d: [__m256; 3],
    tmax: __m256,
}

#[inline]
#[target_feature(enable = "avx")]
fn load(lanes: &[f32; LANES]) -> __m256 {
    // SAFETY: `lanes` is eight readable `f32`s; the load is unaligned.
    unsafe { _mm256_loadu_ps(lanes.as_ptr()) }
}

#[inline]
#[target_feature(enable = "avx")]
fn store(lanes: &mut [f32; LANES], v: __m256) {
    // SAFETY: `lanes` is eight writable `f32`s; the store is unaligned.
    unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), v) }
}

#[inline]
#[target_feature(enable = "avx")]
fn rays_of(ray: &RayLanes) -> Rays {
    Rays {
        o: ray.o.each_ref().map(|c| load(c)),
        d: ray.d.each_ref().map(|c| load(c)),
        // `1 / d` as `Vec3::recip` divides.
        inv_d: ray.d.each_ref().map(|c| _mm256_div_ps(_mm256_set1_ps(1.0), load(c))),
        tmax: load(&ray.tmax),
    }
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

/// [`area_groups::ray_meets`] of the eight rays against `b`: bit `k` for ray `k`.
#[inline]
#[target_feature(enable = "avx")]
fn box_mask(b: &GroupBox, r: &Rays) -> u32 {
    let (mut near, mut far) = (_mm256_setzero_ps(), r.tmax);
    for a in 0..3 {
        let t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(b.lo[a]), r.o[a]), r.inv_d[a]);
        let t1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(b.hi[a]), r.o[a]), r.inv_d[a]);
        // Both ordered: the slab constrains (the scalar test skips it otherwise).
        let keep = _mm256_cmp_ps::<_CMP_ORD_Q>(t0, t1);
        // `near` is never NaN; a NaN `far` (NaN `tmax`) gives way to the slab's far end, as
        // `f32::min` does.
        let nearer = _mm256_max_ps(near, _mm256_min_ps(t0, t1));
        let farther = _mm256_min_ps(far, _mm256_max_ps(t0, t1));
        near = _mm256_blendv_ps(near, nearer, keep);
        far = _mm256_blendv_ps(far, farther, keep);
    }
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
}

/// The sphere lights of the groups made of nothing else, as `[centre, r²]` (the kernel broadcasts
/// them straight from memory and skips the per-light `match`: 41 → 32 instructions per sphere and
/// ray group).
#[derive(Clone, Debug, Default)]
pub(super) struct SphereGroups {
    /// Per light of [`Lights::area_lights`](crate::lights::Lights::area_lights): `[cx, cy, cz, r²]`
    /// (zeros for a planar light).
    spheres: Vec<[f32; 4]>,
    /// Per group: whether all its lights are spheres.
    only_spheres: Vec<bool>,
}

impl SphereGroups {
    pub(super) fn new(shapes: &[LightShape]) -> Self {
        let spheres = shapes
            .iter()
            .map(|shape| match *shape {
                LightShape::Sphere { center, radius2 } => [center[0], center[1], center[2], radius2],
                LightShape::Planar { .. } => [0.0; 4],
            })
            .collect();
        let only_spheres = shapes
            .chunks(area_groups::GROUP)
            .map(|group| group.iter().all(|shape| matches!(shape, LightShape::Sphere { .. })))
            .collect();
        SphereGroups { spheres, only_spheres }
    }

    /// Group `g`'s spheres when it holds nothing else.
    #[inline]
    pub(super) fn group(&self, g: usize) -> Option<&[[f32; 4]]> {
        let first = g * area_groups::GROUP;
        self.only_spheres[g]
            .then(|| &self.spheres[first..(first + area_groups::GROUP).min(self.spheres.len())])
    }
}

/// `ray_sphere` of the rays `meets` (ray group `r`) with sphere light `light` (`[centre, r²]`):
/// the discriminant's sign in lanes, then the roots of the rays that pass, one at a time.
#[inline]
#[target_feature(enable = "avx")]
fn sphere_test(
    v: &Rays,
    sphere: &[f32; 4],
    meets: u32,
    ray: &RayLanes,
    (r, light): (usize, u32),
    s: &mut RejectLanes,
    hits: &mut Vec<RayHit>,
) {
    let oc = [0, 1, 2].map(|a| _mm256_sub_ps(v.o[a], _mm256_broadcast_ss(&sphere[a])));
    let bq = dot(oc, v.d);
    let c = _mm256_sub_ps(dot(oc, oc), _mm256_broadcast_ss(&sphere[3]));
    let disc = _mm256_sub_ps(_mm256_mul_ps(bq, bq), c);
    // `!(disc < 0)`, NaN included: where `ray_sphere` goes on.
    let mut pass = meets & _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_NLT_UQ>(disc, _mm256_setzero_ps())) as u32;
    if pass == 0 {
        return;
    }
    store(&mut s.b, bq);
    store(&mut s.c, c);
    store(&mut s.disc, disc);
    while pass != 0 {
        let k = pass.trailing_zeros() as usize;
        pass &= pass - 1;
        if let Some(t) = sphere_roots(s.b[k], s.c[k], s.disc[k]).filter(|&t| t < ray.tmax[k]) {
            hits.push(RayHit { ray: (r * LANES + k) as u32, light, t });
        }
    }
}

/// [`super::hit_rays`] on AVX: the same hits in the same order.
///
/// # Safety
/// The CPU must support AVX.
#[target_feature(enable = "avx")]
pub(super) unsafe fn hit_rays(
    shapes: &[LightShape],
    boxes: &[GroupBox],
    spheres: &SphereGroups,
    rays: &[RayLanes],
    n: usize,
    s: &mut RejectLanes,
    hits: &mut Vec<RayHit>,
) {
    let zero = _mm256_setzero_ps();
    for (r, ray) in rays.iter().enumerate() {
        let live = (1u32 << (n - r * LANES).min(LANES)) - 1;
        let v = rays_of(ray);
        for (g, (group, b)) in shapes.chunks(area_groups::GROUP).zip(boxes).enumerate() {
            let meets = box_mask(b, &v) & live;
            if meets == 0 {
                continue;
            }
            let first = g * area_groups::GROUP;
            if let Some(group) = spheres.group(g) {
                for (l, sphere) in group.iter().enumerate() {
                    sphere_test(&v, sphere, meets, ray, (r, (first + l) as u32), s, hits);
                }
                continue;
            }
            for (l, shape) in group.iter().enumerate() {
                let light = (first + l) as u32;
                match *shape {
                    LightShape::Sphere { center, radius2 } => {
                        let sphere = [center[0], center[1], center[2], radius2];
                        sphere_test(&v, &sphere, meets, ray, (r, light), s, hits);
                    }
                    LightShape::Planar { center, normal, ex, ex_len2, ey, ey_len2, disk } => {
                        let nv = normal.map(|x| _mm256_set1_ps(x));
                        let cos = dot(v.d, nv);
                        let to = [0, 1, 2].map(|a| _mm256_sub_ps(_mm256_set1_ps(center[a]), v.o[a]));
                        let t = _mm256_div_ps(dot(to, nv), cos);
                        // `Light::intersect`'s early returns exactly: `!(cos ≥ 0)`, `t > 0`, `t < tmax`.
                        let ahead = _mm256_and_ps(
                            _mm256_cmp_ps::<_CMP_NGE_UQ>(cos, zero),
                            _mm256_and_ps(
                                _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero),
                                _mm256_cmp_ps::<_CMP_LT_OQ>(t, v.tmax),
                            ),
                        );
                        let mut pass = meets & _mm256_movemask_ps(ahead) as u32;
                        if pass == 0 {
                            continue;
                        }
                        store(&mut s.t, t);
                        while pass != 0 {
                            let k = pass.trailing_zeros() as usize;
                            pass &= pass - 1;
                            let (o, d) = ray.ray(k);
                            let t = s.t[k];
                            if planar_inside(o, d, t, center, (ex, ex_len2), (ey, ey_len2), disk) {
                                hits.push(RayHit { ray: (r * LANES + k) as u32, light, t });
                            }
                        }
                    }
                }
            }
        }
    }
}

/// [`box_mask`] for tests: the box test of eight rays.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(test)]
#[target_feature(enable = "avx")]
pub(super) unsafe fn box_bits(b: &GroupBox, ray: &RayLanes) -> u32 {
    box_mask(b, &rays_of(ray))
}

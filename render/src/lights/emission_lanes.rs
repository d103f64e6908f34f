//! Emission rays pick up from the area lights they cross ([`crate::lights::Lights::area_emission`],
//! the scalar reference), with the ray–light tests run eight at a time.
//!
//! Every camera and BSDF ray tests the rect, disk and sphere lights analytically (those of the groups
//! of eight lights whose box it meets, [`crate::lights::area_groups`]). The intersect stage hands over each
//! batch of up to [`MAX_RAYS`] rays it has just intersected, as a function from a ray's position in
//! the batch to its origin, direction and `tmax` (the hit distance) read straight from its path
//! state and hit ([`Ray`]). On AVX CPUs the kernel (`avx`) takes the rays eight at a time:
//! 1. per group box, the box test of the eight rays in lanes (the same bits as
//!    [`area_groups::ray_meets`]);
//! 2. for each ray that meets the box, that ray against the group's eight lights in lanes, a cheap
//!    reject with the scalar test's own IEEE operations: for a sphere the sign of the discriminant
//!    (`!(disc < 0)`, where `ray_sphere` goes on), for a rect or disk the facing test and the plane
//!    distance (`!(cos ≥ 0)`, `t > 0`, `t < tmax`, where `Light::intersect` goes on);
//! 3. for the few lights that pass (on the bench scene, exactly those hit), the exact scalar test
//!    ([`LightShape::hit`]).
//!
//! Other CPUs run [`hit_rays`], the scalar loop of `area_emission` (box, then each light of a met
//! group); both find the same hits, a test checks it. Each hit is recorded as (ray, light, t); each
//! ray's hits come in light order (groups in order, lanes in order), and
//! [`AreaLightLanes::emission`] adds their [`Lights::area_term`]s per ray in it, so the sum equals
//! [`Lights::area_emission`] bit for bit. A ray skips the lights of a group whose box it misses,
//! exactly as the scalar loop does; and neither drops a hit, because the boxes are conservative
//! (each is the union of its lights' bounds, padded for rounding: a light a ray hits lies in a box
//!
//! Measured in four rounds; each kept step with its reason: the ray against a group's eight lights in
//! the lanes (one test per ray–box pair, no idle lane, where eight rays against each light paid for
//! the rays that missed the box); the kernel in AVX intrinsics with the rays in registers and one
//! `vmovmskps` per test; `1/d` in lanes; sphere-only groups from a flat `[centre, r²]` table; a ray
//! group's box tests as one `u64` of bits walked by one loop (`avx::ray_group_hits`: one
//! data-dependent exit per ray group instead of mispredicted loop exits). Tried and lost: the rejects
//! inlined into the ray loop, the mask as bytes of a `u64`, a second level of boxes, each ray against
//! all six boxes at once, a union box of all area lights, boxes stored broadcast; measurements: `docs/perf.md#area-light-emission-lanes-lightsemissionlanesrs`.

#[cfg(target_arch = "x86_64")]
mod avx;

use crate::lights::area_groups::{self, GroupBox};
use crate::lights::light::{sphere_roots, Light, Shape};
use crate::lights::Lights;
use glam::Vec3;
use lanekit::LANES;

/// Rays a batch holds at most (the intersect stage's batch).
pub const MAX_RAYS: usize = 64;

/// A ray as the kernel reads it from the caller (the path state and hit of the intersect stage).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: [f32; 3],
    /// Unit direction.
    pub d: [f32; 3],
    /// The distance its emission is gathered up to (its hit; infinite when it escaped).
    pub tmax: f32,
}

/// One area light as the kernel tests it, with the per-light constants of the scalar test
/// precomputed by the scalar code's own operations (`r²`, `|ex|²`, `|ey|²`: the same bits).
#[derive(Clone, Copy, Debug)]
pub enum LightShape {
    /// A sphere light.
    Sphere {
        /// Centre.
        center: [f32; 3],
        /// `radius * radius`.
        radius2: f32,
    },
    /// A rect or disk light.
    Planar {
        /// Centre.
        center: [f32; 3],
        /// Emission normal.
        normal: [f32; 3],
        /// Half-axis X.
        ex: [f32; 3],
        /// `|ex|²`.
        ex_len2: f32,
        /// Half-axis Y.
        ey: [f32; 3],
        /// `|ey|²`.
        ey_len2: f32,
        /// An ellipse (`a² + b² ≤ 1`) rather than a parallelogram (`|a|, |b| ≤ 1`).
        disk: bool,
    },
}

impl LightShape {
    /// The shape of an area light; `None` for the kinds rays do not hit.
    pub fn of(light: &Light) -> Option<Self> {
        match light.shape {
            Shape::Sphere { center, radius } => {
                Some(LightShape::Sphere { center: center.to_array(), radius2: radius * radius })
            }
            Shape::Rect { center, ex, ey, normal, .. } | Shape::Disk { center, ex, ey, normal, .. } => {
                Some(LightShape::Planar {
                    center: center.to_array(),
                    normal: normal.to_array(),
                    ex: ex.to_array(),
                    ex_len2: ex.length_squared(),
                    ey: ey.to_array(),
                    ey_len2: ey.length_squared(),
                    disk: matches!(light.shape, Shape::Disk { .. }),
                })
            }
            _ => None,
        }
    }

    /// `Light::intersect`'s distance for this shape, by its operations in their order (the
    /// portable kernel's test).
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    #[inline(always)]
    pub(crate) fn hit(&self, r: &Ray) -> Option<f32> {
        let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        match *self {
            LightShape::Sphere { center, radius2 } => {
                let oc = [0, 1, 2].map(|a| r.o[a] - center[a]);
                let (b, c) = (dot(oc, r.d), dot(oc, oc) - radius2);
                let disc = b * b - c;
                if disc < 0.0 {
                    return None;
                }
                sphere_roots(b, c, disc).filter(|&t| t < r.tmax)
            }
            LightShape::Planar { center, normal, ex, ex_len2, ey, ey_len2, disk } => {
                let cos = dot(r.d, normal);
                if cos >= 0.0 {
                    return None;
                }
                let t = dot([0, 1, 2].map(|a| center[a] - r.o[a]), normal) / cos;
                if !(t > 0.0 && t < r.tmax) {
                    return None;
                }
                planar_inside(r.o, r.d, t, center, (ex, ex_len2), (ey, ey_len2), disk).then_some(t)
            }
        }
    }
}

/// A ray–light hit: the ray's position in its batch, the light's position in
/// [`Lights::area_lights`], and the ray parameter of the hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Ray (position in the batch).
    pub ray: u32,
    /// Light (position in the summation order).
    pub light: u32,
    /// Distance along the ray.
    pub t: f32,
}

/// The scene's area lights for the emission kernel, and one batch's hits and sums; built once per
/// worker (the scratch is allocated then and reused).
#[derive(Clone, Debug)]
pub struct AreaLightLanes {
    /// The lights in [`Lights::area_lights`] order.
    lights: Vec<Light>,
    shapes: Vec<LightShape>,
    /// The box of each run of [`area_groups::GROUP`] lights ([`Lights::area_boxes`]).
    boxes: Vec<GroupBox>,
    /// The lights transposed for the AVX kernel.
    #[cfg(target_arch = "x86_64")]
    kernel: avx::Kernel,
    /// Whether the CPU runs the AVX kernel (asked once here, not per batch).
    avx: bool,
    /// Hits of the batch, ray by ray, each ray's in light order.
    hits: Vec<RayHit>,
    /// Per ray of the batch: its emission.
    sums: Box<[Vec3; MAX_RAYS]>,
}

impl AreaLightLanes {
    /// The area lights of `lights`, in their summation order.
    pub fn new(lights: &Lights) -> Self {
        let all: Vec<Light> = lights.area_lights().copied().collect();
        let shapes = all.iter().filter_map(LightShape::of).collect::<Vec<_>>();
        // `area_lights` holds only the three kinds `LightShape` has.
        debug_assert_eq!(shapes.len(), all.len());
        let boxes = lights.area_boxes().to_vec();
        debug_assert_eq!(boxes.len(), all.len().div_ceil(area_groups::GROUP), "one box per group of eight");
        let avx = lanekit::cpu::has_avx();
        AreaLightLanes {
            lights: all,
            #[cfg(target_arch = "x86_64")]
            kernel: avx::Kernel::new(&shapes, &boxes),
            avx,
            shapes,
            boxes,
            hits: Vec::with_capacity(MAX_RAYS * LANES),
            sums: Box::new([Vec3::ZERO; MAX_RAYS]),
        }
    }

    /// Whether there is no area light (rays then pick up nothing).
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// [`Lights::area_emission`] of rays `0..n` of a batch (ray `j` is `ray(j)`), by ray,
    /// MIS-weighted against light sampling from `prev(j)` for ray `j`; `lights` must be the lights
    /// this was built from. `prev` is asked only for the rays that hit a light (a few in a hundred
    /// on the bench scene), so the caller's path states are not read for the others.
    pub fn emission(
        &mut self,
        lights: &Lights,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        prev: impl Fn(usize) -> Option<(Vec3, f32)>,
    ) -> &[Vec3] {
        assert!(n <= MAX_RAYS, "a batch holds at most {MAX_RAYS} rays");
        let sums = &mut self.sums[..n];
        sums.fill(Vec3::ZERO);
        if self.lights.is_empty() {
            return sums;
        }
        self.hits.clear();
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: the CPU has AVX (`self.avx` was detected in `new`).
            unsafe { avx::hit_rays(&self.kernel, &self.shapes, &self.boxes, n, &ray, &mut self.hits) };
        } else {
            hit_rays(&self.shapes, &self.boxes, n, &ray, &mut self.hits);
        }
        #[cfg(not(target_arch = "x86_64"))]
        hit_rays(&self.shapes, &self.boxes, n, &ray, &mut self.hits);
        for h in &self.hits {
            let j = h.ray as usize;
            let r = ray(j);
            sums[j] += lights.area_term(h.light as usize, r.o.into(), r.d.into(), h.t, prev(j));
        }
        sums
    }
}

/// The hits of rays `0..n` (ray `j` is `rays(j)`) with the lights `shapes` (boxed eight by eight
/// by `boxes`), appended to `hits` ray by ray, in light order within each: the portable kernel, for
/// CPUs without AVX (those with it run `avx::hit_rays`), and the reference the AVX kernel is tested
/// against. It is the scalar loop of [`Lights::area_emission`]: the box test per group, the exact
/// test per light of a met group.
fn hit_rays(
    shapes: &[LightShape],
    boxes: &[GroupBox],
    n: usize,
    rays: impl Fn(usize) -> Ray,
    hits: &mut Vec<RayHit>,
) {
    for j in 0..n {
        let ray = rays(j);
        // `1 / d` as `Vec3::recip` divides.
        let inv_d = ray.d.map(|x| 1.0 / x);
        for (g, (group, b)) in shapes.chunks(area_groups::GROUP).zip(boxes).enumerate() {
            if !area_groups::ray_meets(b, ray.o, inv_d, ray.tmax) {
                continue;
            }
            for (l, shape) in group.iter().enumerate() {
                if let Some(t) = shape.hit(&ray) {
                    hits.push(RayHit { ray: j as u32, light: (g * area_groups::GROUP + l) as u32, t });
                }
            }
        }
    }
}

/// `Light::intersect`'s rect/disk rest: whether the plane point at `t` lies inside the shape.
#[inline(always)]
pub fn planar_inside(
    o: [f32; 3],
    d: [f32; 3],
    t: f32,
    center: [f32; 3],
    (ex, ex_len2): ([f32; 3], f32),
    (ey, ey_len2): ([f32; 3], f32),
    disk: bool,
) -> bool {
    let r = [o[0] + d[0] * t - center[0], o[1] + d[1] * t - center[1], o[2] + d[2] * t - center[2]];
    let a = (r[0] * ex[0] + r[1] * ex[1] + r[2] * ex[2]) / ex_len2;
    let b = (r[0] * ey[0] + r[1] * ey[1] + r[2] * ey[2]) / ey_len2;
    if disk {
        a * a + b * b <= 1.0
    } else {
        a.abs() <= 1.0 && b.abs() <= 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::TAU;

    /// Both kernels (AVX where the CPU has it, and the portable one) equal the scalar
    /// `area_emission` bit for bit on 20,000+ rays in batches of every size from 1 to 64: rays
    /// aimed at light centres and at points on their edges (grazing: sphere silhouettes, rect
    /// corners, disk rims), from outside and from inside sphere lights, with finite and infinite
    /// `tmax`, camera rays and BSDF rays; over spheres, rects and disks in four groups of eight (the
    /// last one partly empty).
    #[test]
    fn ray_lanes_equal_the_scalar_area_emission_bit_for_bit() {
        let mut rng = crate::testscene::Rng(3);
        let mut u = || rng.next_f32();
        let records = crate::testscene::area_light_records(29, 2.0, (0.1, 0.5), (0.2, 1.0), &mut u);
        let bytes = crate::testscene::lights_only(records);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let area: Vec<Light> = lights.area_lights().copied().collect();
        let lanes = AreaLightLanes::new(&lights);
        let portable = AreaLightLanes { avx: false, ..lanes.clone() };
        let mut kernels = [lanes, portable];
        let bits = |v: Vec3| v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() });
        let (mut rays, mut met, mut inside, mut batch) = (0, 0, 0, 0usize);
        while rays < 20_480 {
            let n = batch % MAX_RAYS + 1;
            batch += 1;
            let mut expected = Vec::with_capacity(n);
            let mut prevs = Vec::with_capacity(n);
            let mut batch_rays = Vec::with_capacity(n);
            for j in 0..n {
                let i = rays + j;
                let light = &area[i % area.len()];
                let (target, center, from_inside) = match light.shape {
                    Shape::Sphere { center, radius } => {
                        let z = 1.0 - 2.0 * u();
                        let (r, phi) = ((1.0 - z * z).max(0.0).sqrt(), TAU * u());
                        let on = center + Vec3::new(r * phi.cos(), r * phi.sin(), z) * radius;
                        (on, center, Some(center + (on - center) * (0.9 * u())))
                    }
                    Shape::Rect { center, ex, ey, .. } => (
                        center + ex * if u() < 0.5 { 1.0 } else { -1.0 } + ey * (2.0 * u() - 1.0),
                        center,
                        None,
                    ),
                    Shape::Disk { center, ex, ey, .. } => {
                        let phi = TAU * u();
                        (center + ex * phi.cos() + ey * phi.sin(), center, None)
                    }
                    _ => unreachable!("area lights are spheres, rects and disks"),
                };
                let o = match from_inside {
                    Some(p) if i % 4 == 0 => {
                        inside += 1;
                        p
                    }
                    _ => Vec3::new(6.0 * u() - 3.0, 6.0 * u() - 3.0, 6.0 * u() - 3.0),
                };
                let aim = match i % 3 {
                    0 => target,
                    1 => center,
                    _ => Vec3::new(4.0 * u() - 2.0, 4.0 * u() - 2.0, 4.0 * u() - 2.0),
                };
                let d = (aim - o).normalize_or(Vec3::Z);
                let tmax = if i % 3 == 1 { f32::INFINITY } else { 5.0 * u() };
                let prev = (i % 2 == 0).then(|| (o - d * u(), 4.0 * u()));
                batch_rays.push(Ray { o: o.to_array(), d: d.to_array(), tmax });
                let e = lights.area_emission(o, d, tmax, prev);
                met += (e != Vec3::ZERO) as u32;
                expected.push((e, o, d, tmax));
                prevs.push(prev);
            }
            for lanes in &mut kernels {
                let avx = lanes.avx;
                let got = lanes.emission(&lights, n, |j| batch_rays[j], |j| prevs[j]);
                for (j, (&g, &(e, o, d, tmax))) in got.iter().zip(&expected).enumerate() {
                    assert_eq!(
                        bits(g),
                        bits(e),
                        "batch of {n}, ray {j} (AVX {avx}): o {o} d {d} tmax {tmax}"
                    );
                }
            }
            rays += n;
        }
        assert!(met > 8000, "only {met} of {rays} rays met a light");
        assert!(inside > 1000, "only {inside} rays from inside spheres");
    }

    /// The AVX kernel finds the same hits as the portable one, each ray's in the same order and
    /// with the same bits of `t`, and its box test gives [`area_groups::ray_meets`]'s bits by both
    /// of its paths (with the NaN selects, and without for finite rays), on random and degenerate
    /// rays (axis-parallel, zero directions, origins on box planes, `tmax` 0, ∞, NaN) over
    /// spheres, rects and disks, mixed and alone, in four and in nine groups (the last partial).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx_kernel_equals_the_portable_one() {
        if !lanekit::cpu::has_avx() {
            return;
        }
        // Mixed shapes, then spheres only and rects and disks only (groups skip the test of the
        // kind they lack).
        let kinds: [fn(u32) -> u32; 3] = [
            |kind| kind,
            |_| blob::light_kind::SPHERE,
            |kind| if kind == blob::light_kind::SPHERE { blob::light_kind::DISK } else { kind },
        ];
        for kinds in kinds {
            avx_equals_portable(kinds);
        }
    }

    #[cfg(target_arch = "x86_64")]
    fn avx_equals_portable(kinds: fn(u32) -> u32) {
        let mut rng = crate::testscene::Rng(41);
        let mut u = || rng.next_f32();
        // 29 lights: four groups, the last one partial; 71: nine groups.
        for count in [29, 71] {
            let mut records =
                crate::testscene::area_light_records(count, 2.0, (0.1, 0.5), (0.2, 1.0), &mut u);
            records.iter_mut().for_each(|r| r.kind = kinds(r.kind));
            let bytes = crate::testscene::lights_only(records);
            let view = blob::SceneView::parse(&bytes).expect("valid blob");
            let lights = Lights::new(&view);
            let lanes = AreaLightLanes::new(&lights);
            let (mut portable, mut vector) = (Vec::new(), Vec::new());
            let (mut found, mut met, mut paths) = (0, 0, [0; 2]);
            let mut rays = [Ray { o: [0.0; 3], d: [0.0; 3], tmax: 0.0 }; MAX_RAYS];
            for case in 0..600 {
                for (j, ray) in rays.iter_mut().enumerate() {
                    let mut o = Vec3::new(u(), u(), u()) * 6.0 - 3.0;
                    let b = &lanes.boxes[j % lanes.boxes.len()];
                    let mut d = (Vec3::new(u(), u(), u()) * 4.0 - 2.0 - o).normalize_or(Vec3::X);
                    // Half of the cases without degenerate rays: their ray groups take the
                    // kernel's finite box test.
                    match if case % 2 == 0 { (case + j) % 9 } else { 8 } {
                        0 => d = Vec3::new(d.x, 0.0, 0.0).normalize_or(Vec3::X),
                        1 => o.y = b.lo[1],
                        2 => (o.z, d) = (b.hi[2], Vec3::new(d.x, d.y, 0.0).normalize_or(Vec3::Y)),
                        3 => d = Vec3::ZERO,
                        _ => {}
                    }
                    let tmax = [f32::INFINITY, 5.0 * u(), 0.0, f32::NAN, 2.0][(case / 2 + j) % 5];
                    *ray = Ray { o: o.to_array(), d: d.to_array(), tmax };
                }
                let n = case % MAX_RAYS + 1;
                portable.clear();
                vector.clear();
                hit_rays(&lanes.shapes, &lanes.boxes, n, |j| rays[j], &mut portable);
                // SAFETY: AVX was detected by the caller.
                unsafe {
                    avx::hit_rays(&lanes.kernel, &lanes.shapes, &lanes.boxes, n, |j| rays[j], &mut vector)
                };
                // Each ray's hits in the same order (the AVX kernel interleaves a ray group's rays).
                vector.sort_by_key(|h| h.ray);
                let key = |h: &RayHit| (h.ray, h.light, h.t.to_bits());
                assert_eq!(
                    portable.iter().map(key).collect::<Vec<_>>(),
                    vector.iter().map(key).collect::<Vec<_>>(),
                    "{count} lights, case {case}"
                );
                found += portable.len();
                for (first, group) in rays[..n].chunks(LANES).enumerate() {
                    let live = (1 << group.len()) - 1;
                    for b in &lanes.boxes {
                        // SAFETY: AVX was detected by the caller.
                        let (bits, finite) = unsafe { avx::box_bits(&lanes.kernel, b, group, live) };
                        paths[finite as usize] += 1;
                        for (k, ray) in group.iter().enumerate() {
                            let inv_d = Vec3::from(ray.d).recip().to_array();
                            let scalar = area_groups::ray_meets(b, ray.o, inv_d, ray.tmax);
                            assert_eq!(bits >> k & 1 == 1, scalar, "case {case}, ray {}", first * LANES + k);
                            met += scalar as u32;
                        }
                    }
                }
            }
            assert!(found > 500, "only {found} hits ({count} lights)");
            assert!(met > 20_000, "only {met} box hits");
            assert!(paths.iter().all(|&p| p > 1000), "box tests by the NaN-safe and finite paths: {paths:?}");
        }
    }

    /// With no area light every ray picks up nothing (and the kernel is not run).
    #[test]
    fn no_area_light_gives_zero() {
        let bytes = crate::testscene::lights_only(vec![]);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let mut lanes = AreaLightLanes::new(&lights);
        assert!(lanes.is_empty());
        let ray = Ray { o: [0.0; 3], d: [1.0, 0.0, 0.0], tmax: f32::INFINITY };
        assert_eq!(lanes.emission(&lights, 1, |_| ray, |_| None), &[Vec3::ZERO]);
    }
}

//! Emission rays pick up from the area lights they cross ([`crate::lights::Lights::area_emission`],
//! the scalar reference), with the ray–light tests run on eight *rays* at a time.
//!
//! Every camera and BSDF ray tests the rect, disk and sphere lights analytically (those of the groups
//! of eight lights whose box it meets, [`crate::area_groups`]). The intersect stage hands over each
//! batch of up to [`MAX_RAYS`] rays it has just intersected; they are transposed into groups of eight
//! ([`RayLanes`]: origin, direction, `tmax` = the hit distance) and the kernel walks the lights in
//! [`Lights::area_lights`] order for each ray group (on AVX CPUs in intrinsics, `avx`, else the
//! portable lane loops of [`hit_rays`]; both find the same hits, a test checks it):
//! 1. per group of eight lights, the box test of the eight rays ([`area_groups::ray_meets_lanes`]);
//!    when no ray meets the box its eight lights are skipped;
//! 2. per light, the cheap reject on eight rays with the scalar test's own IEEE operations: for a
//!    sphere the sign of the discriminant (`!(disc < 0)`, as `ray_sphere` returns early), for a
//!    rect or disk the facing test and the plane distance (`min(t, −cos) > 0`: a superset of the
//!    scalar `cos < 0, t > 0`, see [`plane_rejects`]);
//! 3. only for the rays that pass both (few: most rays miss most lights), the rest of the scalar test
//!    from the lane values ([`sphere_roots`]; the exact plane tests, `t < tmax` and
//!    [`planar_inside`]), one ray at a time.
//!
//! Each hit is recorded as (ray, light, t); as the lights are walked in summation order, each ray's
//! hits come in that order too, and [`AreaLightLanes::emission`] then adds their
//! [`Lights::area_term`]s per ray in it, so the sum equals [`Lights::area_emission`] bit for bit.
//! A ray whose box test fails is masked out of that group's lights, exactly as the scalar loop skips
//! them, so both skip the same lights; and neither drops a hit, because the boxes are conservative
//! (each is the union of its lights' bounds, padded for rounding: a light a ray hits lies in a box
//! the ray meets; `lights::tests::culled_area_emission_equals_the_sum_over_every_light` checks it).
//!
//! # Measured (shading-heavy bench scene: 48 sphere lights, a dome, a sun; tractor: no area light)
//! The previous kernel ran the other way round: per ray, the eight lights of each met group in
//! lanes, with the square root and both divisions of the sphere and planar tests in all eight lanes
//! (every ray paid them for every met group). Callgrind, 120×80, 8 spp, 1 thread (instructions):
//!
//! | | before | after |
//! |---|---|---|
//! | shading-heavy: area-light kernel (`AreaLightLanes::emission`) | 146.0 M | 50.8 M |
//! | shading-heavy: the intersect stage's emission pass (with the dome and sun of escaped rays) | 166.7 M | 76.9 M |
//! | shading-heavy: whole process (the scalar integrator's `area_emission` alone: 248.7 M) | 943.3 M | 853.5 M |
//! | tractor: emission pass / whole process | 24.3 M / 556.5 M | 17.5 M / 549.7 M |
//! | simple: emission pass / whole process | 16.3 M / 213.2 M | 13.1 M / 210.1 M |
//!
//! perf (320×213, 16 spp, 1 thread, contended): the emission's share of the shading-heavy
//! wavefront render fell from 14.9 % (the old kernel 10.7 + 1.8, the pass 1.7, dome and sun 0.75)
//! to 6.0 % (the pass 2.1, the sphere rejects 1.9, the ray loop 1.3, dome and sun 0.7), against
//! 11.9 % for the scalar integrator's `area_emission` in the same build. `bench integrators`,
//! wavefront speed-up over scalar in CPU time, three runs each (contended, load ~16 on 2 cores):
//! shading-heavy 1.23/1.06/0.98× before, 1.32/1.19/1.25× after (shading+texturing+integration
//! 0.99/0.83/0.80× before, 1.31/1.08/1.24× after); tractor 1.22–1.31× before, 1.24–1.29× after;
//! simple 1.12–1.31× before, 1.17–1.29× after (those two within the noise).
//!
//! Tried and lost: the rejects inlined into the ray loop (LLVM left most lanes scalar: 70.0 M for
//! the kernel), and the mask as bytes of a `u64` (`vpacksswb` in the box test, but shuffles and
//! scalar compares in the others).
//!
//! # Measured, second round (main at 3db8d2d; same callgrind settings; images unchanged bit for bit)
//! Where the instructions were: the out-of-line sphere reject cost 57 instructions per light and
//! ray group (406 k calls), 17 of them building the lane mask with a shift and an `or` per lane,
//! the rest reloading the rays and storing three result columns; the box tests and the per-light
//! `match` another 26 M; and the stage's per-ray set-up three scalar divisions (`1/d`) and a copy
//! of the MIS vertex, which only 2,449 of the 156 k rays (those that hit a light) need. Now:
//! the kernel in AVX intrinsics with the eight rays in registers and one `vmovmskps` per test
//! (`avx`), `1/d` in lanes inside the kernels, sphere-only groups tested from a flat
//! `[centre, r²]` table without the `match`, and the previous vertex read only for hits.
//!
//! | shading-heavy, instructions | before | after |
//! |---|---|---|
//! | area-light kernel (`hit_rays` → `avx::hit_rays`) | 49.3 M | 26.4 M |
//! | `AreaLightLanes::emission` (with the hits' MIS terms) | 50.3 M | 27.4 M |
//! | the intersect stage's emission pass (`intersect::emission`) | 72.6 M | 45.7 M |
//! | whole process | 542.7 M | 515.7 M (−5.0 %) |
//!
//! Step by step (whole process): AVX kernel 524.2 M, `1/d` in lanes 522.6 M, sphere groups
//! 518.2 M, previous vertex for hits only 515.7 M. Tractor and simple (no area light) unchanged:
//! 333.55 / 132.08 M. perf, 320×213, 16 spp, 1 thread (contended, load ~5 on 2 cores), share of
//! the wavefront's samples: emission 7.8 % before (sphere reject 2.7, ray loop 2.1, the pass 2.5,
//! dome and sun 0.3, the rest 0.2) and 5.9 % after (AVX kernel 2.5, the pass 2.7, dome and sun
//! 0.3, the rest 0.4); task-clock over 12 alternating runs was within the noise (±15 %).
//! `bench integrators` (320×213, 16 spp, 2 threads, contended, two alternating runs each),
//! shading-heavy wavefront CPU s 1.021 / 0.891 before, 0.945 / 0.924 after; its shading phase
//! 19.1 / 19.2 % of the wavefront's time before, 16.6 / 15.7 % after; max |Δ| against the scalar
//! image 0 in every run.
//! What is left in the pass is memory-bound: its samples sit on the first reads of each ray's
//! path state (`w.states[i]` by queue index).
//!
//! Tried and lost: a second level of boxes (a box per half group, tested for the met groups
//! before their lights): 30.8 → 32.3 M for the kernel, the bench scene's lights being spread so
//! that a met group's halves are mostly met too.

#[cfg(target_arch = "x86_64")]
mod avx;

use super::bsdf_lanes::{Lanes, Lanes3};
use super::lanes::LANES;
use crate::area_groups::{self, GroupBox};
use crate::lights::{sphere_roots, Light, Lights, Shape};
use glam::Vec3;

/// Rays a batch holds at most (the intersect stage's batch).
pub const MAX_RAYS: usize = 64;
const RAY_GROUPS: usize = MAX_RAYS / LANES;

/// Eight rays, transposed. Lanes past a batch's end hold stale rays and are masked out.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct RayLanes {
    /// Origins.
    pub o: Lanes3,
    /// Unit directions (the kernels take `1 / d` for the box tests in lanes, eight divisions in
    /// one instruction, rather than three scalar divisions per ray here).
    pub d: Lanes3,
    /// The distance each ray's emission is gathered up to (its hit; infinite when it escaped).
    pub tmax: Lanes,
}

impl RayLanes {
    /// Lane `k`'s origin and direction, for the scalar tail of a test.
    #[inline(always)]
    pub fn ray(&self, k: usize) -> ([f32; 3], [f32; 3]) {
        ([self.o[0][k], self.o[1][k], self.o[2][k]], [self.d[0][k], self.d[1][k], self.d[2][k]])
    }
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

/// The scene's area lights for the ray-lane kernel, and one batch's rays and hits; built once per
/// worker (the scratch is allocated then and reused).
#[derive(Clone, Debug)]
pub struct AreaLightLanes {
    /// The lights in [`Lights::area_lights`] order.
    lights: Vec<Light>,
    shapes: Vec<LightShape>,
    /// The box of each run of [`area_groups::GROUP`] lights ([`Lights::area_boxes`]).
    boxes: Vec<GroupBox>,
    /// The sphere-only groups' spheres for the AVX kernel.
    #[cfg(target_arch = "x86_64")]
    spheres: avx::SphereGroups,
    /// The current batch: its rays transposed.
    rays: Box<[RayLanes; RAY_GROUPS]>,
    /// Hits of the batch, ray group by ray group, each ray's in light order.
    hits: Vec<RayHit>,
    /// The kernel's scratch.
    rejects: Box<RejectLanes>,
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
        AreaLightLanes {
            lights: all,
            #[cfg(target_arch = "x86_64")]
            spheres: avx::SphereGroups::new(&shapes),
            shapes,
            boxes,
            rays: Box::default(),
            hits: Vec::with_capacity(MAX_RAYS * LANES),
            rejects: Box::default(),
            sums: Box::new([Vec3::ZERO; MAX_RAYS]),
        }
    }

    /// Whether there is no area light (rays then pick up nothing).
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Sets ray `j` (< [`MAX_RAYS`]) of the batch: origin `o`, unit direction `d`, gathering up to
    /// `tmax`.
    #[inline]
    pub fn set_ray(&mut self, j: usize, o: Vec3, d: Vec3, tmax: f32) {
        let (group, k) = (&mut self.rays[j / LANES], j % LANES);
        for a in 0..3 {
            group.o[a][k] = o[a];
            group.d[a][k] = d[a];
        }
        group.tmax[k] = tmax;
    }

    /// [`Lights::area_emission`] of rays `0..n` of the batch (set by [`AreaLightLanes::set_ray`]),
    /// by ray, MIS-weighted against light sampling from `prev(j)` for ray `j`; `lights` must be the
    /// lights this was built from. `prev` is asked only for the rays that hit a light (a few in a
    /// hundred on the bench scene), so the caller's path states are not read for the others.
    pub fn emission(
        &mut self,
        lights: &Lights,
        n: usize,
        prev: impl Fn(usize) -> Option<(Vec3, f32)>,
    ) -> &[Vec3] {
        assert!(n <= MAX_RAYS, "a batch holds at most {MAX_RAYS} rays");
        let sums = &mut self.sums[..n];
        sums.fill(Vec3::ZERO);
        if self.lights.is_empty() {
            return sums;
        }
        self.hits.clear();
        let rays = &self.rays[..n.div_ceil(LANES)];
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (checked just above; std caches the answer).
            unsafe {
                avx::hit_rays(
                    &self.shapes,
                    &self.boxes,
                    &self.spheres,
                    rays,
                    n,
                    &mut self.rejects,
                    &mut self.hits,
                )
            };
        } else {
            hit_rays(&self.shapes, &self.boxes, rays, n, &mut self.rejects, &mut self.hits);
        }
        #[cfg(not(target_arch = "x86_64"))]
        hit_rays(&self.shapes, &self.boxes, rays, n, &mut self.rejects, &mut self.hits);
        for h in &self.hits {
            let j = h.ray as usize;
            let (group, k) = (&self.rays[j / LANES], j % LANES);
            let o = Vec3::new(group.o[0][k], group.o[1][k], group.o[2][k]);
            let d = Vec3::new(group.d[0][k], group.d[1][k], group.d[2][k]);
            sums[j] += lights.area_term(h.light as usize, o, d, h.t, prev(j));
        }
        sums
    }
}

/// Per-light lane values the cheap rejects leave for the scalar rest (scratch of the kernel).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct RejectLanes {
    /// Sphere: `oc·d`.
    pub b: Lanes,
    /// Sphere: `|oc|² − r²`.
    pub c: Lanes,
    /// Sphere: the discriminant `b² − c`.
    pub disc: Lanes,
    /// Rect/disk: `d·n`.
    pub cos: Lanes,
    /// Rect/disk: the distance to the plane.
    pub t: Lanes,
}

/// The hits of rays `0..n` (in groups of eight, `rays`) with the lights `shapes` (boxed eight by
/// eight by `boxes`), appended to `hits` ray group by ray group, in light order within each: the
/// portable kernel, for CPUs without AVX (those with it run `avx::hit_rays`, so this one has no
/// AVX2 clone any more) and as the reference the AVX kernel is tested against.
///
/// The two cheap rejects are nested functions kept out of line, as the BVH kernels are
/// ([`crate::accel`]), and write their lane values into `s`: inlined into this loop, or with
/// their values kept in registers, LLVM's SLP vectorizer left most of their lanes scalar
/// (callgrind, shading-heavy at 120×80, 8 spp: ~220 instructions per sphere and group of eight
/// rays inlined, ~60 out of line).
fn hit_rays(
    shapes: &[LightShape],
    boxes: &[GroupBox],
    rays: &[RayLanes],
    n: usize,
    s: &mut RejectLanes,
    hits: &mut Vec<RayHit>,
) {
    #[inline(never)]
    fn sphere(ray: &RayLanes, center: [f32; 3], radius2: f32, s: &mut RejectLanes) -> u32 {
        sphere_rejects(ray, center, radius2, s)
    }
    #[inline(never)]
    fn plane(ray: &RayLanes, center: [f32; 3], normal: [f32; 3], s: &mut RejectLanes) -> u32 {
        plane_rejects(ray, center, normal, s)
    }
    for (r, ray) in rays.iter().enumerate() {
        let live = (1u32 << (n - r * LANES).min(LANES)) - 1;
        let inv_d = recip(&ray.d);
        for (g, (group, b)) in shapes.chunks(area_groups::GROUP).zip(boxes).enumerate() {
            let meets = area_groups::ray_meets_lanes(b, &ray.o, &inv_d, &ray.tmax) & live;
            if meets == 0 {
                continue;
            }
            for (l, shape) in group.iter().enumerate() {
                let light = (g * area_groups::GROUP + l) as u32;
                let mut record =
                    |k: usize, t: f32| hits.push(RayHit { ray: (r * LANES + k) as u32, light, t });
                match *shape {
                    LightShape::Sphere { center, radius2 } => {
                        let mut pass = meets & sphere(ray, center, radius2, s);
                        while pass != 0 {
                            let k = pass.trailing_zeros() as usize;
                            pass &= pass - 1;
                            let t = sphere_roots(s.b[k], s.c[k], s.disc[k]).filter(|&t| t < ray.tmax[k]);
                            if let Some(t) = t {
                                record(k, t);
                            }
                        }
                    }
                    LightShape::Planar { center, normal, ex, ex_len2, ey, ey_len2, disk } => {
                        let mut pass = meets & plane(ray, center, normal, s);
                        while pass != 0 {
                            let k = pass.trailing_zeros() as usize;
                            pass &= pass - 1;
                            let (o, d) = ray.ray(k);
                            let t = s.t[k];
                            // The scalar test's early returns, exactly (the lane mask is wider).
                            #[allow(clippy::neg_cmp_op_on_partial_ord)]
                            let ahead = !(s.cos[k] >= 0.0) && t > 0.0 && t < ray.tmax[k];
                            if ahead && planar_inside(o, d, t, center, (ex, ex_len2), (ey, ey_len2), disk) {
                                record(k, t);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// `1 / d` per lane, as [`glam::Vec3::recip`] computes it (the same bits as the scalar
/// `area_emission`'s inverse direction).
#[inline(always)]
fn recip(d: &Lanes3) -> Lanes3 {
    d.map(|c| c.map(|x| 1.0 / x))
}

/// `ray_sphere`'s first part on eight rays (`b = oc·d`, `c = |oc|² − r²`, the discriminant
/// `b² − c`, with glam's `dot` order `(x·x' + y·y') + z·z'`) into `s`; bit `k` set where the
/// scalar code goes on (`!(disc < 0)`, NaN included, as the early return treats it).
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn sphere_rejects(ray: &RayLanes, center: [f32; 3], radius2: f32, s: &mut RejectLanes) -> u32 {
    let mut bits = [0u32; LANES];
    for k in 0..LANES {
        let oc = [ray.o[0][k] - center[0], ray.o[1][k] - center[1], ray.o[2][k] - center[2]];
        let b = oc[0] * ray.d[0][k] + oc[1] * ray.d[1][k] + oc[2] * ray.d[2][k];
        let c = (oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2]) - radius2;
        let disc = b * b - c;
        (s.b[k], s.c[k], s.disc[k]) = (b, c, disc);
        bits[k] = (!(disc < 0.0) as u32) << k;
    }
    bits.iter().fold(0, |a, b| a | b)
}

/// `Light::intersect`'s rect/disk part up to the plane on eight rays: `cos = d·n` and the distance
/// `t = ((c − o)·n) / cos` into `s`. Bit `k` is set where `min(t, −cos) > 0`: every ray that faces
/// the emitting side (`cos < 0`) and meets the plane ahead (`t > 0`), and a few more (NaN `t`); the
/// scalar rest then applies the exact tests. (The exact `!(cos ≥ 0) & t > 0 & t < tmax` in lanes
/// was left mostly scalar by LLVM.)
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn plane_rejects(ray: &RayLanes, center: [f32; 3], n: [f32; 3], s: &mut RejectLanes) -> u32 {
    let mut bits = [0u32; LANES];
    for k in 0..LANES {
        let cos = ray.d[0][k] * n[0] + ray.d[1][k] * n[1] + ray.d[2][k] * n[2];
        let to = [center[0] - ray.o[0][k], center[1] - ray.o[1][k], center[2] - ray.o[2][k]];
        let t = (to[0] * n[0] + to[1] * n[1] + to[2] * n[2]) / cos;
        (s.cos[k], s.t[k]) = (cos, t);
        bits[k] = ((t.min(-cos) > 0.0) as u32) << k;
    }
    bits.iter().fold(0, |a, b| a | b)
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

    /// The ray-lane kernel equals the scalar `area_emission` bit for bit on 20,000+ rays in batches
    /// of every size from 1 to 64: rays aimed at light centres and at points on their edges
    /// (grazing: sphere silhouettes, rect corners, disk rims), from outside and from inside sphere
    /// lights, with finite and infinite `tmax`, camera rays and BSDF rays; over spheres, rects and
    /// disks in four groups of eight (the last one partly empty).
    #[test]
    fn ray_lanes_equal_the_scalar_area_emission_bit_for_bit() {
        let mut rng = crate::testscene::Rng(3);
        let mut u = || rng.next_f32();
        let records = crate::testscene::area_light_records(29, 2.0, (0.1, 0.5), (0.2, 1.0), &mut u);
        let bytes = crate::testscene::lights_only(records);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let area: Vec<Light> = lights.area_lights().copied().collect();
        let mut lanes = AreaLightLanes::new(&lights);
        let bits = |v: Vec3| v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() });
        let (mut rays, mut met, mut inside, mut batch) = (0, 0, 0, 0usize);
        while rays < 20_480 {
            let n = batch % MAX_RAYS + 1;
            batch += 1;
            let mut expected = Vec::with_capacity(n);
            let mut prevs = Vec::with_capacity(n);
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
                lanes.set_ray(j, o, d, tmax);
                let e = lights.area_emission(o, d, tmax, prev);
                met += (e != Vec3::ZERO) as u32;
                expected.push((e, o, d, tmax));
                prevs.push(prev);
            }
            let got = lanes.emission(&lights, n, |j| prevs[j]);
            for (j, (&g, &(e, o, d, tmax))) in got.iter().zip(&expected).enumerate() {
                assert_eq!(bits(g), bits(e), "batch of {n}, ray {j}: o {o} d {d} tmax {tmax}");
            }
            rays += n;
        }
        assert!(met > 8000, "only {met} of {rays} rays met a light");
        assert!(inside > 1000, "only {inside} rays from inside spheres");
    }

    /// The AVX kernel finds the same hits, in the same order and with the same bits of `t`, as the
    /// portable one, and its box test gives [`area_groups::ray_meets`]'s bits, on random and
    /// degenerate rays (axis-parallel, zero directions, origins on box planes, `tmax` 0, ∞, NaN)
    /// over spheres, rects and disks.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx_kernel_equals_the_portable_one() {
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        // Mixed shapes, then spheres only (the kernel's sphere-group path, last group partial).
        for only_spheres in [false, true] {
            avx_equals_portable(only_spheres);
        }
    }

    #[cfg(target_arch = "x86_64")]
    fn avx_equals_portable(only_spheres: bool) {
        let mut rng = crate::testscene::Rng(41);
        let mut u = || rng.next_f32();
        let mut records = crate::testscene::area_light_records(29, 2.0, (0.1, 0.5), (0.2, 1.0), &mut u);
        if only_spheres {
            records.iter_mut().for_each(|r| r.kind = blob::light_kind::SPHERE);
        }
        let bytes = crate::testscene::lights_only(records);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let lanes = AreaLightLanes::new(&lights);
        assert_eq!(lanes.spheres.group(0).is_some(), only_spheres);
        let (mut rays, mut s) = (Box::new([RayLanes::default(); RAY_GROUPS]), RejectLanes::default());
        let (mut portable, mut vector) = (Vec::new(), Vec::new());
        let (mut found, mut met) = (0, 0);
        for case in 0..600 {
            for j in 0..MAX_RAYS {
                let mut o = Vec3::new(u(), u(), u()) * 6.0 - 3.0;
                let b = &lanes.boxes[j % lanes.boxes.len()];
                let mut d = (Vec3::new(u(), u(), u()) * 4.0 - 2.0 - o).normalize_or(Vec3::X);
                match (case + j) % 9 {
                    0 => d = Vec3::new(d.x, 0.0, 0.0).normalize_or(Vec3::X),
                    1 => o.y = b.lo[1],
                    2 => (o.z, d) = (b.hi[2], Vec3::new(d.x, d.y, 0.0).normalize_or(Vec3::Y)),
                    3 => d = Vec3::ZERO,
                    _ => {}
                }
                let tmax = [f32::INFINITY, 5.0 * u(), 0.0, f32::NAN, 2.0][(case / 2 + j) % 5];
                let (group, k) = (&mut rays[j / LANES], j % LANES);
                for a in 0..3 {
                    (group.o[a][k], group.d[a][k]) = (o[a], d[a]);
                }
                group.tmax[k] = tmax;
            }
            let n = case % MAX_RAYS + 1;
            let groups = &rays[..n.div_ceil(LANES)];
            portable.clear();
            vector.clear();
            hit_rays(&lanes.shapes, &lanes.boxes, groups, n, &mut s, &mut portable);
            // SAFETY: AVX was detected above.
            unsafe {
                avx::hit_rays(&lanes.shapes, &lanes.boxes, &lanes.spheres, groups, n, &mut s, &mut vector)
            };
            let key = |h: &RayHit| (h.ray, h.light, h.t.to_bits());
            assert_eq!(
                portable.iter().map(key).collect::<Vec<_>>(),
                vector.iter().map(key).collect::<Vec<_>>(),
                "case {case}"
            );
            found += portable.len();
            for (r, ray) in groups.iter().enumerate() {
                for b in &lanes.boxes {
                    // SAFETY: AVX was detected above.
                    let bits = unsafe { avx::box_bits(b, ray) };
                    for k in 0..LANES {
                        let at = |c: &Lanes3| [c[0][k], c[1][k], c[2][k]];
                        let inv_d = Vec3::from(at(&ray.d)).recip().to_array();
                        let scalar = area_groups::ray_meets(b, at(&ray.o), inv_d, ray.tmax[k]);
                        assert_eq!(bits >> k & 1 == 1, scalar, "case {case}, ray {}", r * LANES + k);
                        met += scalar as u32;
                    }
                }
            }
        }
        assert!(found > 1000, "only {found} hits (spheres only: {only_spheres})");
        assert!(met > 20_000, "only {met} box hits");
    }

    /// With no area light every ray picks up nothing (and the kernel is not run).
    #[test]
    fn no_area_light_gives_zero() {
        let bytes = crate::testscene::lights_only(vec![]);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let mut lanes = AreaLightLanes::new(&lights);
        assert!(lanes.is_empty());
        lanes.set_ray(0, Vec3::ZERO, Vec3::X, f32::INFINITY);
        assert_eq!(lanes.emission(&lights, 1, |_| None), &[Vec3::ZERO]);
    }
}

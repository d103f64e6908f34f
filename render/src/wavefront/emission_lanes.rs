//! Emission a ray picks up from the area lights it crosses ([`crate::lights::Lights::area_emission`],
//! the scalar reference), with the ray–light tests eight lights at a time.
//!
//! Every camera and BSDF ray tests the rect, disk and sphere lights analytically (those of the groups
//! whose box it meets, [`crate::area_groups`]), so with dozens of lights this loop outweighs the BVH
//! query (48 sphere lights: 29 % of the shading-heavy bench scene's instructions before the group
//! culling). The lane kernel runs the sphere and the planar test of [`crate::lights`] with the
//! same IEEE operations in the same order on eight lights (each lane keeps the one its light's kind
//! needs), and the lights it hits add their MIS-weighted emission through the scalar
//! [`crate::lights::Lights::area_term`] in list order, so the sum equals the scalar one bit for bit.

use super::bsdf_lanes::{Lanes, Lanes3};
use super::lanes::LANES;
use crate::area_groups::{ray_meets, GroupBox};
use crate::lights::{Light, Lights, Shape};
use glam::Vec3;

/// Eight area lights' shapes, transposed. Unused lanes have kind [`KIND_NONE`].
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct LightGroup {
    /// [`KIND_SPHERE`], [`KIND_RECT`], [`KIND_DISK`] or [`KIND_NONE`].
    pub kind: [u32; LANES],
    /// Centre.
    pub center: Lanes3,
    /// Sphere radius.
    pub radius: Lanes,
    /// Rect/disk half-axis X.
    pub ex: Lanes3,
    /// Rect/disk half-axis Y.
    pub ey: Lanes3,
    /// Rect/disk emission normal.
    pub normal: Lanes3,
    /// Every used lane is a sphere (the sphere-only kernel suffices).
    pub spheres_only: bool,
}

/// An empty lane.
pub const KIND_NONE: u32 = 0;
/// A sphere light.
pub const KIND_SPHERE: u32 = 1;
/// A rect light.
pub const KIND_RECT: u32 = 2;
/// A disk light.
pub const KIND_DISK: u32 = 3;

/// The scene's area lights in groups of eight, built once per worker.
#[derive(Clone, Debug, Default)]
pub struct AreaLightLanes {
    groups: Vec<LightGroup>,
    /// Each group's box ([`crate::area_groups`]): a ray that misses it skips the group.
    boxes: Vec<GroupBox>,
    /// The lights in [`Lights::area_lights`] order (lane `k` of group `g` is light `8g + k`).
    lights: Vec<Light>,
    /// Per group: hit distances and hit mask of the current ray (scratch, allocated once).
    t: Vec<[f32; LANES]>,
    masks: Vec<u32>,
}

impl AreaLightLanes {
    /// Transposes the area lights of `lights`.
    pub fn new(lights: &Lights) -> Self {
        let all: Vec<Light> = lights.area_lights().copied().collect();
        let mut groups = Vec::with_capacity(all.len().div_ceil(LANES));
        for chunk in all.chunks(LANES) {
            let mut g = LightGroup::default();
            for (k, light) in chunk.iter().enumerate() {
                let put = |dst: &mut Lanes3, v: Vec3| (dst[0][k], dst[1][k], dst[2][k]) = (v.x, v.y, v.z);
                match light.shape {
                    Shape::Sphere { center, radius } => {
                        g.kind[k] = KIND_SPHERE;
                        put(&mut g.center, center);
                        g.radius[k] = radius;
                    }
                    Shape::Rect { center, ex, ey, normal, .. }
                    | Shape::Disk { center, ex, ey, normal, .. } => {
                        g.kind[k] =
                            if matches!(light.shape, Shape::Rect { .. }) { KIND_RECT } else { KIND_DISK };
                        put(&mut g.center, center);
                        put(&mut g.ex, ex);
                        put(&mut g.ey, ey);
                        put(&mut g.normal, normal);
                    }
                    // `area_lights` holds only the three kinds above.
                    _ => {}
                }
            }
            g.spheres_only = g.kind.iter().all(|&k| k == KIND_SPHERE || k == KIND_NONE);
            groups.push(g);
        }
        let n = groups.len();
        let boxes = lights.area_boxes().to_vec();
        debug_assert_eq!(boxes.len(), n, "one box per group of eight");
        AreaLightLanes { groups, boxes, lights: all, t: vec![[0.0; LANES]; n], masks: vec![0; n] }
    }

    /// Whether there is no area light (rays then pick up nothing).
    pub fn is_empty(&self) -> bool {
        self.groups.is_empty()
    }

    /// [`Lights::area_emission`] for a ray from `o` along unit `d` up to `tmax`; `lights` must be
    /// the lights this was built from.
    pub fn emission(
        &mut self,
        lights: &Lights,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        prev: Option<(Vec3, f32)>,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        if self.groups.is_empty() {
            return sum;
        }
        let ray = (o.to_array(), d.to_array(), d.recip().to_array());
        hit_groups(&self.groups, &self.boxes, ray, tmax, &mut self.t, &mut self.masks);
        for (g, &mask) in self.masks.iter().enumerate() {
            let mut hits = mask;
            while hits != 0 {
                let lane = hits.trailing_zeros() as usize;
                hits &= hits - 1;
                let light = &self.lights[g * LANES + lane];
                sum += lights.area_term(light, light.radiance, o, d, self.t[g][lane], prev);
            }
        }
        sum
    }
}

/// [`hit_lanes`] over every group whose box the ray (origin, direction, inverse direction) meets,
/// one dispatch per ray.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
fn hit_groups(
    groups: &[LightGroup],
    boxes: &[GroupBox],
    (o, d, inv_d): ([f32; 3], [f32; 3], [f32; 3]),
    tmax: f32,
    t: &mut [[f32; LANES]],
    masks: &mut [u32],
) {
    for (((g, b), t), mask) in groups.iter().zip(boxes).zip(t.iter_mut()).zip(masks.iter_mut()) {
        *mask = if !ray_meets(b, o, inv_d, tmax) {
            0
        } else if g.spheres_only {
            hit_spheres(g, o, d, tmax, t)
        } else {
            hit_lanes(g, o, d, tmax, t)
        };
    }
}

/// [`hit_lanes`] for a group of spheres only: half the work.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
pub fn hit_spheres(g: &LightGroup, o: [f32; 3], d: [f32; 3], tmax: f32, t: &mut [f32; LANES]) -> u32 {
    let mut bits = [0u32; LANES];
    for k in 0..LANES {
        let (hit, ts) = sphere(g, k, o, d, tmax);
        t[k] = ts;
        bits[k] = ((hit && g.kind[k] == KIND_SPHERE) as u32) << k;
    }
    bits.iter().fold(0, |a, b| a | b)
}

#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] * b[0]) + (a[1] * b[1]) + (a[2] * b[2])
}

/// `ray_sphere` then `t < tmax` for lane `k`, its early returns as selects: (hit, t).
// `!(a <= b)` on purpose: it is how the scalar code's early return treats NaN (it does not return).
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn sphere(g: &LightGroup, k: usize, o: [f32; 3], d: [f32; 3], tmax: f32) -> (bool, f32) {
    let c = [g.center[0][k], g.center[1][k], g.center[2][k]];
    let radius = g.radius[k];
    let oc = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
    let b = dot(oc, d);
    let cc = dot(oc, oc) - radius * radius;
    let disc = b * b - cc;
    let sq = disc.sqrt();
    let q = if b > 0.0 { -b - sq } else { -b + sq };
    let (t0, t1) = (q, if q != 0.0 { cc / q } else { 0.0 });
    let (t0, t1) = if t0 > t1 { (t1, t0) } else { (t0, t1) };
    let ts = if t0 > 0.0 { t0 } else { t1 };
    (!(disc < 0.0) && (t0 > 0.0 || t1 > 0.0) && ts < tmax, ts)
}

/// Bit `k` set where the ray meets light `k` of `g` at `t[k]` in (0, `tmax`), as
/// `Light::intersect` decides it.
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
pub fn hit_lanes(g: &LightGroup, o: [f32; 3], d: [f32; 3], tmax: f32, t: &mut [f32; LANES]) -> u32 {
    let mut bits = [0u32; LANES];
    for k in 0..LANES {
        let c = [g.center[0][k], g.center[1][k], g.center[2][k]];
        let (sphere_hit, ts) = sphere(g, k, o, d, tmax);
        // The rect and disk test.
        let n = [g.normal[0][k], g.normal[1][k], g.normal[2][k]];
        let (ex, ey) = ([g.ex[0][k], g.ex[1][k], g.ex[2][k]], [g.ey[0][k], g.ey[1][k], g.ey[2][k]]);
        let cos = dot(d, n);
        let tp = dot([c[0] - o[0], c[1] - o[1], c[2] - o[2]], n) / cos;
        let r = [o[0] + d[0] * tp - c[0], o[1] + d[1] * tp - c[1], o[2] + d[2] * tp - c[2]];
        let a = dot(r, ex) / dot(ex, ex);
        let bb = dot(r, ey) / dot(ey, ey);
        let inside =
            if g.kind[k] == KIND_RECT { a.abs() <= 1.0 && bb.abs() <= 1.0 } else { a * a + bb * bb <= 1.0 };
        let planar_hit = !(cos >= 0.0) && tp > 0.0 && tp < tmax && inside;
        let kind = g.kind[k];
        let hit = if kind == KIND_SPHERE { sphere_hit } else { kind != KIND_NONE && planar_hit };
        t[k] = if kind == KIND_SPHERE { ts } else { tp };
        bits[k] = (hit as u32) << k;
    }
    bits.iter().fold(0, |a, b| a | b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_equal_the_scalar_area_emission_bit_for_bit() {
        let mut x = 3u32;
        let mut u = || {
            x = crate::sampler::hash_u32(x);
            (x >> 8) as f32 / 16_777_216.0
        };
        // 19 lights of all three kinds (three groups, the last one partly empty).
        let records = crate::testscene::area_light_records(19, 2.0, (0.1, 0.5), (0.2, 1.0), &mut u);
        let bytes = crate::testscene::lights_only(records);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let mut lanes = AreaLightLanes::new(&lights);
        let bits = |v: Vec3| v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() });
        let mut nonzero = 0;
        for i in 0..20_000 {
            let o = Vec3::new(6.0 * u() - 3.0, 6.0 * u() - 3.0, 6.0 * u() - 3.0);
            // Aimed at the lights' box, so many rays cross several lights.
            let target = Vec3::new(4.0 * u() - 2.0, 4.0 * u() - 2.0, 4.0 * u() - 2.0);
            let d = (target - o).normalize_or(Vec3::Z);
            let tmax = if i % 3 == 0 { f32::INFINITY } else { 5.0 * u() };
            let prev = (i % 2 == 0).then(|| (o - d * u(), 4.0 * u()));
            let expected = lights.area_emission(o, d, tmax, prev);
            let got = lanes.emission(&lights, o, d, tmax, prev);
            assert_eq!(bits(got), bits(expected), "ray {i}: o {o} d {d} tmax {tmax}");
            nonzero += (expected != Vec3::ZERO) as u32;
        }
        assert!(nonzero > 2000, "only {nonzero} rays met a light");
    }
}

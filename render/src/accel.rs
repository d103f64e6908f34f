//! Ray queries against the blob's compressed wide BVH: closest hit and any hit.
//!
//! The mapped [`blob::BvhNode`] slice is reinterpreted as `obvhs` CWBVH nodes (bit-identical by
//! construction, see the blob docs) and walked with `obvhs::traverse!`; node tests use obvhs' SIMD
//! child test, primitives use the watertight ray/triangle test of Woop, Benthin and Wald (JCGT 2013),
//! so rays through shared edges and vertices never slip between triangles.
//!
//! Limitation inherited from obvhs' node test: child boxes are entered only for t ≥ 1e-4 (its
//! `EPSILON`), so a hit closer than 1e-4 scene units to the ray origin can be missed. Ray origins are
//! offset by [`offset_ray_origin`], far less than that, so contact shadows finer than 1e-4 units are lost.

use glam::{UVec2, Vec3, Vec3A};
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::Traversal;
use obvhs::ray::Ray as BvhRay;
use obvhs::traverse;

/// A ray for the batch query [`Accel::trace_closest`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin, world space.
    pub origin: Vec3,
    /// Direction (need not be unit length; `t` is measured in multiples of it).
    pub direction: Vec3,
    /// Largest accepted hit distance.
    pub tmax: f32,
}

/// The closest intersection of a ray with the scene's triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Index into the blob's triangles.
    pub triangle: u32,
    /// Barycentric weight of the triangle's vertex 1.
    pub b1: f32,
    /// Barycentric weight of the triangle's vertex 2.
    pub b2: f32,
}

/// Read-only acceleration structure over mapped blob slices.
#[derive(Clone, Copy, Debug)]
pub struct Accel<'a> {
    /// CWBVH nodes, root first (the field name is what `obvhs::traverse!` expects).
    nodes: &'a [CwBvhNode],
    primitives: &'a [u32],
    positions: &'a [[f32; 3]],
    triangles: &'a [blob::Triangle],
}

impl<'a> Accel<'a> {
    /// Wraps the validated view's BVH and triangles.
    pub fn new(view: &blob::SceneView<'a>) -> Self {
        Accel {
            nodes: bytemuck::cast_slice::<blob::BvhNode, CwBvhNode>(view.bvh_nodes),
            primitives: view.bvh_primitives,
            positions: view.positions,
            triangles: view.triangles,
        }
    }

    /// The three world-space vertices of triangle `index`.
    #[inline]
    pub fn triangle_vertices(&self, index: u32) -> [Vec3; 3] {
        let tri = &self.triangles[index as usize];
        tri.vertices.map(|v| Vec3::from(self.positions[v as usize]))
    }

    /// Closest hit with `t` in (0, `tmax`).
    pub fn closest_hit(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let wray = WatertightRay::new(origin, direction);
        let mut ray = BvhRay::new(Vec3A::from(origin), Vec3A::from(direction), 0.0, tmax);
        let mut state = Traversal::default();
        state.reinit(ray.direction);
        let mut best = None;
        let mut node: &CwBvhNode;
        traverse!(self, node, state, node.intersect_ray(&ray, state.oct_inv4), {
            let triangle = self.primitives[state.primitive_id as usize];
            if let Some((t, b1, b2)) = wray.intersect(self.triangle_vertices(triangle), ray.tmax) {
                ray.tmax = t;
                best = Some(Hit { t, triangle, b1, b2 });
            }
        });
        best
    }

    /// True if any triangle for which `blocks(triangle)` holds is hit with `t` in (0, `tmax`).
    /// `blocks` lets the caller make partially transparent triangles stochastically transparent; it must
    /// be a pure function of the triangle, as a triangle may be visited more than once.
    pub fn any_hit(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        mut blocks: impl FnMut(u32) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let wray = WatertightRay::new(origin, direction);
        let ray = BvhRay::new(Vec3A::from(origin), Vec3A::from(direction), 0.0, tmax);
        let mut state = Traversal::default();
        state.reinit(ray.direction);
        let mut node: &CwBvhNode;
        let mut hit = false;
        'walk: {
            traverse!(self, node, state, node.intersect_ray(&ray, state.oct_inv4), {
                let triangle = self.primitives[state.primitive_id as usize];
                if wray.intersect(self.triangle_vertices(triangle), tmax).is_some() && blocks(triangle) {
                    hit = true;
                    break 'walk;
                }
            });
        }
        hit
    }

    /// Closest hits for a batch of rays (for benchmarks): one entry per ray, in order.
    pub fn trace_closest(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        rays.iter().map(|r| self.closest_hit(r.origin, r.direction, r.tmax)).collect()
    }

    /// Reference closest hit by testing every triangle (for tests).
    pub fn closest_hit_brute_force(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        let wray = WatertightRay::new(origin, direction);
        let mut best: Option<Hit> = None;
        for triangle in 0..self.triangles.len() as u32 {
            let limit = best.map_or(tmax, |h| h.t);
            if let Some((t, b1, b2)) = wray.intersect(self.triangle_vertices(triangle), limit) {
                best = Some(Hit { t, triangle, b1, b2 });
            }
        }
        best
    }
}

/// Per-ray precomputation of the watertight test: the axis permutation and shear that map the ray to
/// +Z through the origin.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl WatertightRay {
    /// Prepares `origin + t·direction`.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        let a = direction.abs();
        let kz = if a.x > a.y && a.x > a.z {
            0
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if direction[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = direction[kz];
        WatertightRay { origin, kx, ky, kz, sx: direction[kx] / dz, sy: direction[ky] / dz, sz: 1.0 / dz }
    }

    /// `(t, b1, b2)` if the ray hits the triangle with `0 < t < tmax`.
    #[inline]
    pub fn intersect(&self, [p0, p1, p2]: [Vec3; 3], tmax: f32) -> Option<(f32, f32, f32)> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let a = p0 - self.origin;
        let b = p1 - self.origin;
        let c = p2 - self.origin;
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Edge case: redo the 2D edge tests in double precision, as the paper prescribes.
            u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            v = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        if det > 0.0 {
            if t_scaled <= 0.0 || t_scaled >= tmax * det {
                return None;
            }
        } else if t_scaled >= 0.0 || t_scaled <= tmax * det {
            return None;
        }
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !t.is_finite() {
            return None;
        }
        Some((t, v * inv, w * inv))
    }
}

/// Offsets a surface point along its geometric normal `n` (pointing to the side the new ray leaves
/// towards) so the new ray cannot re-hit the surface it starts on: Wächter & Binder, "A Fast and Robust
/// Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6. Far from the origin the offset is a
/// fixed number of ULPs (scales with the magnitude of the point); near the origin a small absolute one.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let offset_axis = |p: f32, n: f32| {
        let of_i = (INT_SCALE * n) as i32;
        let bits = p.to_bits() as i32;
        let moved = f32::from_bits(bits.wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32);
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            moved
        }
    };
    Vec3::new(offset_axis(p.x, n.x), offset_axis(p.y, n.y), offset_axis(p.z, n.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene;

    #[test]
    fn watertight_test_hits_inside_and_misses_outside() {
        let tri = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let ray = WatertightRay::new(Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let (t, b1, b2) = ray.intersect(tri, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        assert!((b1 - 0.25).abs() < 1e-6 && (b2 - 0.5).abs() < 1e-6, "{b1} {b2}");
        assert!(ray.intersect(tri, 1.5).is_none(), "tmax respected");
        let miss = WatertightRay::new(Vec3::new(2.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(miss.intersect(tri, f32::INFINITY).is_none());
        let behind = WatertightRay::new(Vec3::new(0.0, 0.0, -2.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(behind.intersect(tri, f32::INFINITY).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of a quad; rays aimed exactly at the diagonal must hit one.
        let q = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        for i in 0..=100 {
            let s = i as f32 / 100.0;
            let ray = WatertightRay::new(Vec3::new(s, s, 1.0), Vec3::new(0.0, 0.0, -1.0));
            let a = ray.intersect([q[0], q[1], q[2]], f32::INFINITY).is_some();
            let b = ray.intersect([q[0], q[2], q[3]], f32::INFINITY).is_some();
            assert!(a || b, "gap at {s}");
        }
    }

    #[test]
    fn bvh_agrees_with_brute_force_on_10000_random_rays() {
        let scene = testscene::random_triangles(200, 0x5eed);
        let bytes = testscene::encode(&scene);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = Accel::new(&view);
        let mut rng = testscene::Rng(12345);
        let mut hits = 0;
        for _ in 0..10_000 {
            let origin = Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
            let target = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            let dir = (target - origin).normalize();
            let fast = accel.closest_hit(origin, dir, f32::INFINITY);
            let slow = accel.closest_hit_brute_force(origin, dir, f32::INFINITY);
            match (fast, slow) {
                (None, None) => {}
                (Some(f), Some(s)) => {
                    hits += 1;
                    assert!((f.t - s.t).abs() <= 1e-5 * s.t.max(1.0), "{f:?} vs {s:?}");
                    if f.triangle != s.triangle {
                        // Only acceptable for a tie in t (coplanar or shared edges).
                        assert!((f.t - s.t).abs() < 1e-6);
                    }
                }
                other => panic!("BVH and brute force disagree: {other:?}"),
            }
            let occluded = accel.any_hit(origin, dir, f32::INFINITY, |_| true);
            assert_eq!(occluded, slow.is_some());
        }
        assert!(hits > 2000, "the test should exercise many hits, got {hits}");
    }

    #[test]
    fn offset_origin_moves_off_the_surface() {
        let p = Vec3::new(1000.0, -0.01, 3.0);
        let n = Vec3::new(0.0, 0.0, 1.0);
        let o = offset_ray_origin(p, n);
        assert!(o.z > p.z && o.x == p.x && o.y == p.y);
        let o = offset_ray_origin(p, -n);
        assert!(o.z < p.z);
    }
}

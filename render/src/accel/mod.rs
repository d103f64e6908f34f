//! Ray queries against the blob's 8-wide BVH: closest hit and any hit.
//!
//! The blob stores an 8-wide BVH with uncompressed f32 child bounds, SoA per node ([`blob::BvhNode`]),
//! and leaves of four-triangle SoA blocks ([`blob::TriangleBlock`]), built at ingest from obvhs' PLOC
//! BVH2 (see scene-pack's `bvh`). A query walks it with an explicit stack, nearest child first:
//!
//! * **Node kernel** ([`Lanes::node`]): the eight slab tests as `[f32; 8]` lane loops. The near and far
//!   plane of each axis are picked once per ray from the direction's signs, so each lane needs one
//!   subtract and one multiply per plane and no min/max swap. A zero direction component gives an
//!   infinite reciprocal; `(plane − origin) · ∞` is NaN only when the origin lies on the plane, and
//!   the `if t > near { t } else { near }` selects (which compile to `maxps`/`minps` with the new value
//!   first) then ignore that slab, which is the right answer for a closed slab. Far distances are
//!   scaled by `1 + 2γ₃` (Ize, "Robust BVH Ray Traversal", JCGT 2013), so rounding never culls a box
//!   the ray touches and the traversal stays as watertight as the triangle test.
//! * **Triangle kernel** ([`Lanes::block`]): the watertight test of Woop, Benthin and Wald (JCGT 2013)
//!   on four triangles at once (one glam `Vec4` lane per triangle), lane for lane the same arithmetic
//!   as [`WatertightRay::intersect`]; a lane with an exactly zero edge function is handed, after the
//!   fast path, to `intersect` itself (its double-precision retry), so rays through shared edges and
//!   vertices never slip between triangles.
//! * **Dispatch**: the node kernel is plain safe Rust lane loops that LLVM vectorizes, the triangle
//!   kernel glam's `Vec4` (an SSE register on x86-64, four scalars elsewhere); the whole query function is
//!   compiled per target with `multiversion` (AVX2+FMA and a baseline fallback) and the CPU is checked
//!   once per call, outside the per-node loop.
//! * **Ties**: the closest hit is the least `(t, triangle index)` (`precedes`), and once a hit at
//!   `t` is known the walk goes on with the limit `tie_limit(t)`, 256 ulps beyond it, so no
//!   rounding of a limit equal to `t` culls a triangle met at exactly `t`. The answer is then
//!   independent of the order leaves are visited in: a tree with every node's children reversed
//!   gives the same hit (tested on a stack of identical triangles).
//! * **Scalar reference**: [`Scalar`] implements the same two kernels child by child and triangle by
//!   triangle (the latter with [`WatertightRay::intersect`]); the tests check that both kernels and
//!   both full traversals agree exactly, and that they agree with brute force.
//!
//! The stack is a fixed array of 32 entries on the CPU stack; a deeper walk (never seen on the bench
//! scenes) spills into a heap vector rather than fail, so no blob, however adversarial, can make a
//! query index out of bounds, and ordinary rays never allocate.
//!
//! The layout, the out-of-line `inherit_target` kernels, the masks in the triangle kernel, the
//! subtree-fits-first collapse (5.5 children per node), the branch-free `WatertightRay::new` and the
//! inlined `ClosestLeaf` were each measured against what they replaced; measurements and what was
//! not tried: `docs/perf.md#bvh-traversal-accelmodrs`.

pub mod curves;
pub mod deform;
pub mod instanced;
pub mod ray;
pub mod traverse;

pub use ray::{offset_ray_origin, Hit, Ray};
use traverse::{any, closest};
pub use traverse::{BlockHits, Kernels, Lanes, NodeRay, Scalar, WatertightRay};

use blob::{BvhNode, TriangleBlock, BVH_WIDTH};
use glam::Vec3;
use multiversion::multiversion;

/// Read-only acceleration structure over mapped blob slices: the world BVH over the top-level
/// triangles and, when the scene has instances, the two-level structure of [`crate::accel::instanced`].
#[derive(Clone, Copy, Debug)]
pub struct Accel<'a> {
    nodes: &'a [BvhNode],
    blocks: &'a [TriangleBlock],
    positions: &'a [[f32; 3]],
    triangles: &'a [blob::Triangle],
    instances: crate::accel::instanced::Instances<'a>,
    deform: crate::accel::deform::Deformation<'a>,
}

impl<'a> Accel<'a> {
    /// Wraps the validated view's BVH and triangles.
    pub fn new(view: &blob::SceneView<'a>) -> Self {
        Accel {
            nodes: view.bvh_nodes,
            blocks: view.bvh_blocks,
            positions: view.positions,
            triangles: view.triangles,
            instances: crate::accel::instanced::Instances::new(view),
            deform: crate::accel::deform::Deformation::new(view),
        }
    }

    /// The three vertices of triangle `index` as stored: world space for a top-level triangle,
    /// prototype space for a prototype triangle (see [`Accel::hit_vertices`]).
    #[inline]
    pub fn triangle_vertices(&self, index: u32) -> [Vec3; 3] {
        let tri = &self.triangles[index as usize];
        tri.vertices.map(|v| Vec3::from(self.positions[v as usize]))
    }

    /// The world-space vertices of the triangle `hit` found (transformed by its instance, or
    /// where its deforming mesh is at the hit's time).
    #[inline]
    pub fn hit_vertices(&self, hit: &Hit) -> [Vec3; 3] {
        let v = self.triangle_vertices(hit.triangle);
        if hit.instance == blob::NONE {
            self.deform.triangle_at(hit.triangle, hit.time).unwrap_or(v)
        } else {
            let placement = self.instances.placement(hit.instance, hit.time);
            v.map(|p| instanced::point_to_world(&placement, p))
        }
    }

    /// A normal of the triangle `hit` found, from its stored space to world space (by the inverse
    /// transpose of the instance transform); unchanged for top-level triangles. Not normalized.
    #[inline]
    pub fn normal_to_world(&self, hit: &Hit, n: Vec3) -> Vec3 {
        if hit.instance == blob::NONE {
            n
        } else {
            self.instances.to_world_normal(hit.instance, hit.time, n)
        }
    }

    /// The instancing tables (empty for a scene without instances).
    pub fn instances(&self) -> &crate::accel::instanced::Instances<'a> {
        &self.instances
    }

    /// The deforming meshes (empty for a scene without deformation).
    pub fn deformation(&self) -> &crate::accel::deform::Deformation<'a> {
        &self.deform
    }

    fn is_empty(&self) -> bool {
        self.nodes.is_empty() && self.instances.is_empty() && self.deform.is_empty()
    }

    /// Closest hit with `t` in (0, `tmax`), at time 0 (the frame).
    pub fn closest_hit(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        self.closest_hit_at(origin, direction, tmax, 0.0)
    }

    /// Closest hit with `t` in (0, `tmax`) of a ray at time `time` (time codes from the frame: moving
    /// instances are where they are then).
    pub fn closest_hit_at(&self, origin: Vec3, direction: Vec3, tmax: f32, time: f32) -> Option<Hit> {
        if self.is_empty() {
            return None;
        }
        closest_hit_simd(self, origin, direction, tmax, time)
    }

    /// True if any triangle for which `blocks(triangle, instance)` holds is hit with `t` in
    /// (0, `tmax`) (`instance` is [`blob::NONE`] for top-level triangles). `blocks` lets the caller
    /// make partially transparent triangles stochastically transparent; it must be a pure function
    /// of its arguments, as a triangle may be visited more than once.
    pub fn any_hit(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        blocks: impl FnMut(u32, u32) -> bool,
    ) -> bool {
        self.any_hit_at(origin, direction, tmax, 0.0, blocks)
    }

    /// [`Accel::any_hit`] for a ray at time `time` (see [`Accel::closest_hit_at`]).
    pub fn any_hit_at(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        time: f32,
        blocks: impl FnMut(u32, u32) -> bool,
    ) -> bool {
        if self.is_empty() {
            return false;
        }
        any_hit_simd(self, origin, direction, tmax, time, blocks)
    }

    /// [`Accel::closest_hit`] with the scalar reference kernels (for tests).
    pub fn closest_hit_scalar(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        if self.is_empty() {
            return None;
        }
        two_level_closest(self, origin, direction, tmax, 0.0, &Scalar::node, &Scalar::block)
    }

    /// [`Accel::any_hit`] with the scalar reference kernels (for tests).
    pub fn any_hit_scalar(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        mut blocks: impl FnMut(u32, u32) -> bool,
    ) -> bool {
        if self.is_empty() {
            return false;
        }
        two_level_any(self, origin, direction, tmax, 0.0, &Scalar::node, &Scalar::block, &mut blocks)
    }

    /// Closest hits for a batch of rays (for benchmarks): one entry per ray, in order.
    pub fn trace_closest(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        rays.iter().map(|r| self.closest_hit(r.origin, r.direction, r.tmax)).collect()
    }

    /// Reference closest hit by testing every triangle (for tests).
    pub fn closest_hit_brute_force(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        let wray = WatertightRay::new(origin, direction);
        let mut best: Option<Hit> = None;
        let top_level = self.instances.top_level_triangles(self.triangles.len());
        for triangle in 0..top_level as u32 {
            let limit = best.map_or(tmax, |h| h.t);
            if let Some((t, b1, b2)) = wray.intersect(self.triangle_vertices(triangle), limit) {
                best = Some(Hit { t, triangle, b1, b2, instance: blob::NONE, time: 0.0 });
            }
        }
        // Instances: every prototype triangle moved to world space.
        for instance in 0..self.instances.len() as u32 {
            for triangle in self.instances.prototype_triangles(instance) {
                let limit = best.map_or(tmax, |h| h.t);
                let hit = Hit { t: 0.0, triangle, b1: 0.0, b2: 0.0, instance, time: 0.0 };
                if let Some((t, b1, b2)) = wray.intersect(self.hit_vertices(&hit), limit) {
                    best = Some(Hit { t, b1, b2, ..hit });
                }
            }
        }
        best
    }
}

/// The two lane kernels ([`Lanes::node`], [`Lanes::block`]) compiled for the target of the
/// `#[multiversion]` clone this is expanded in, as a pair of closures `(node, block)` to hand to a
/// traversal. Every multiversioned traversal entry point (closest and any hit, one and two levels)
/// takes its kernels from here.
///
/// The kernels are nested `inherit_target` functions, deliberately not inlined: inlined into the
/// traversal loop, LLVM's SLP vectorizer split the 8-wide slab test into 4-wide halves with shuffles
/// and scalarized most of the triangle test (register pressure), and the out-of-line kernels were
/// faster (see the module docs). `#[target_feature]` functions do not implement `Fn`; closures
/// defined in the clone inherit its features, which makes the calls safe, so the closures are not
/// redundant.
macro_rules! lane_kernels {
    () => {{
        #[multiversion::inherit_target]
        #[inline(never)]
        fn node(
            node: &blob::BvhNode,
            ray: &$crate::accel::traverse::NodeRay,
            tmax: f32,
        ) -> (u32, [f32; blob::BVH_WIDTH]) {
            <$crate::accel::traverse::Lanes as $crate::accel::traverse::Kernels>::node(node, ray, tmax)
        }
        #[multiversion::inherit_target]
        #[inline(never)]
        fn block(
            block: &blob::TriangleBlock,
            ray: &$crate::accel::traverse::WatertightRay,
            tmax: f32,
        ) -> $crate::accel::traverse::BlockHits {
            <$crate::accel::traverse::Lanes as $crate::accel::traverse::Kernels>::block(block, ray, tmax)
        }
        #[allow(clippy::redundant_closure)]
        let kernels = (
            |n: &blob::BvhNode, r: &$crate::accel::traverse::NodeRay, t: f32| node(n, r, t),
            |b: &blob::TriangleBlock, r: &$crate::accel::traverse::WatertightRay, t: f32| block(b, r, t),
        );
        kernels
    }};
}

// The multiversioned entry points: one clone per target, the CPU checked once per query.
#[multiversion(targets("x86_64+avx2+fma"))]
fn closest_hit_simd(accel: &Accel, origin: Vec3, direction: Vec3, tmax: f32, time: f32) -> Option<Hit> {
    let (node, block) = lane_kernels!();
    two_level_closest(accel, origin, direction, tmax, time, &node, &block)
}

#[multiversion(targets("x86_64+avx2+fma"))]
fn any_hit_simd<F: FnMut(u32, u32) -> bool>(
    accel: &Accel,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    time: f32,
    mut blocks: F,
) -> bool {
    let (node, block) = lane_kernels!();
    two_level_any(accel, origin, direction, tmax, time, &node, &block, &mut blocks)
}

/// Closest hit over the top-level triangles, then over the instances closer than that hit. A scene
/// without instances takes only the first, single-level query.
#[inline(always)]
fn two_level_closest<
    N: Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    B: Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
>(
    accel: &Accel,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    time: f32,
    node_kernel: &N,
    block_kernel: &B,
) -> Option<Hit> {
    let mut best = if accel.nodes.is_empty() {
        None
    } else {
        closest(accel.nodes, accel.blocks, 0, origin, direction, tmax, node_kernel, block_kernel)
            .map(|(t, triangle, b1, b2)| Hit { t, triangle, b1, b2, instance: blob::NONE, time })
    };
    if !accel.deform.is_empty() {
        // The deforming triangles where they are at the ray's time, through the same kernels.
        let (nodes, blocks) = accel.deform.bvh();
        let moved = |b: &TriangleBlock, r: &WatertightRay, t: f32| {
            block_kernel(&accel.deform.block_at(b, time), r, t)
        };
        let limit = best.map_or(tmax, |h| h.t);
        if let Some((t, triangle, b1, b2)) =
            closest(nodes, blocks, 0, origin, direction, limit, node_kernel, &moved)
        {
            best = Some(Hit { t, triangle, b1, b2, instance: blob::NONE, time });
        }
    }
    if accel.instances.is_empty() {
        return best;
    }
    accel.instances.closest(origin, direction, tmax, time, best, node_kernel, block_kernel)
}

/// Any hit over the top-level triangles, then over the instances.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn two_level_any<
    N: Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    B: Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
>(
    accel: &Accel,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    time: f32,
    node_kernel: &N,
    block_kernel: &B,
    blocks: &mut impl FnMut(u32, u32) -> bool,
) -> bool {
    if !accel.nodes.is_empty() {
        let mut top = |t| blocks(t, blob::NONE);
        if any(accel.nodes, accel.blocks, 0, origin, direction, tmax, node_kernel, block_kernel, &mut top) {
            return true;
        }
    }
    if !accel.deform.is_empty() {
        let (nodes, blocks_of) = accel.deform.bvh();
        let moved = |b: &TriangleBlock, r: &WatertightRay, t: f32| {
            block_kernel(&accel.deform.block_at(b, time), r, t)
        };
        let mut top = |t| blocks(t, blob::NONE);
        if any(nodes, blocks_of, 0, origin, direction, tmax, node_kernel, &moved, &mut top) {
            return true;
        }
    }
    !accel.instances.is_empty()
        && accel.instances.any(origin, direction, tmax, time, node_kernel, block_kernel, blocks)
}

/// Test support, shared by the tests below and the integration tests' BVH checks (which cannot
/// see a `cfg(test)` item): closest hits must agree in `t`; a different triangle is only
/// acceptable for a tie in `t`. Panics naming `what` and both hits otherwise.
#[doc(hidden)]
pub fn assert_same_closest(fast: Option<Hit>, slow: Option<Hit>, what: &str) {
    match (fast, slow) {
        (None, None) => {}
        (Some(f), Some(s)) => {
            assert!((f.t - s.t).abs() <= 1e-5 * s.t.max(1.0), "{what}: {f:?} vs {s:?}");
            if f.triangle != s.triangle {
                assert!((f.t - s.t).abs() < 1e-6, "{what}: {f:?} vs {s:?}");
            }
        }
        other => panic!("{what}: BVH and brute force disagree: {other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::traverse::*;
    use super::*;
    use crate::testscene;
    use blob::BLOCK_WIDTH;

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

    /// The construction [`WatertightRay::new`] replaced (branches, a swap and three divisions).
    fn watertight_ray_by_branches(origin: Vec3, direction: Vec3) -> WatertightRay {
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
        WatertightRay {
            origin,
            origin_k: [origin[kx], origin[ky], origin[kz]],
            axes: [kx, ky, kz],
            sx: direction[kx] / dz,
            sy: direction[ky] / dz,
            sz: 1.0 / dz,
        }
    }

    #[test]
    fn branch_free_watertight_ray_equals_the_branchy_construction() {
        let mut rng = testscene::Rng(0x5a1e);
        let pick = |rng: &mut testscene::Rng| match (rng.next_f32() * 6.0) as u32 {
            // Ties between components, signed zeros and exact axis directions.
            0 => 0.0,
            1 => -0.0,
            2 => 0.5,
            3 => -0.5,
            _ => rng.range(-1.0, 1.0),
        };
        let mut seen = [false; 6];
        for _ in 0..100_000 {
            let origin = Vec3::new(rng.range(-9.0, 9.0), rng.range(-9.0, 9.0), rng.range(-9.0, 9.0));
            let dir = Vec3::new(pick(&mut rng), pick(&mut rng), pick(&mut rng));
            if dir == Vec3::ZERO {
                continue;
            }
            let (a, b) = (WatertightRay::new(origin, dir), watertight_ray_by_branches(origin, dir));
            assert_eq!(a.axes, b.axes, "{dir}");
            let bits = |r: &WatertightRay| {
                [r.origin_k[0], r.origin_k[1], r.origin_k[2], r.sx, r.sy, r.sz].map(f32::to_bits)
            };
            assert_eq!(bits(&a), bits(&b), "{dir}");
            seen[2 * a.axes[2] + (dir[a.axes[2]] < 0.0) as usize] = true;
        }
        assert_eq!(seen, [true; 6], "every permutation of the table exercised");
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

    /// Random rays aimed into the unit cube, with every fifth ray snapped to an axis so zero direction
    /// components (infinite reciprocals) are exercised.
    fn random_ray(rng: &mut testscene::Rng, reach: f32) -> (Vec3, Vec3) {
        let origin = Vec3::new(rng.range(-reach, reach), rng.range(-reach, reach), rng.range(-reach, reach));
        let target = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let mut dir = (target - origin).normalize();
        if rng.next_f32() < 0.2 {
            let axis = (rng.next_f32() * 3.0) as usize % 3;
            dir = Vec3::ZERO;
            dir[axis] = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
        }
        (origin, dir)
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
            let (origin, dir) = random_ray(&mut rng, 3.0);
            let fast = accel.closest_hit(origin, dir, f32::INFINITY);
            let slow = accel.closest_hit_brute_force(origin, dir, f32::INFINITY);
            hits += slow.is_some() as usize;
            assert_same_closest(fast, slow, "random triangles");
            assert_eq!(
                fast,
                accel.closest_hit_scalar(origin, dir, f32::INFINITY),
                "SIMD vs scalar traversal"
            );
            let occluded = accel.any_hit(origin, dir, f32::INFINITY, |_, _| true);
            assert_eq!(occluded, slow.is_some());
            assert_eq!(occluded, accel.any_hit_scalar(origin, dir, f32::INFINITY, |_, _| true));
            // A finite tmax just before and after the brute-force hit.
            if let Some(h) = slow {
                assert!(accel.any_hit(origin, dir, h.t * 1.001, |_, _| true));
                assert_same_closest(accel.closest_hit(origin, dir, h.t * 1.001), slow, "tmax after hit");
                let before = accel.closest_hit(origin, dir, h.t * 0.999);
                assert!(before.is_none_or(|b| b.t < h.t * 0.999), "tmax respected: {before:?}");
            }
        }
        assert!(hits > 2000, "the test should exercise many hits, got {hits}");
    }

    /// The exact reference for the closest hit: every triangle tested with no limit, the hit that
    /// [`precedes`] all others kept (nearest, then lowest index).
    fn closest_by_index(accel: &Accel, triangles: usize, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let wray = WatertightRay::new(origin, dir);
        let mut best: Option<Hit> = None;
        for triangle in 0..triangles as u32 {
            if let Some((t, b1, b2)) = wray.intersect(accel.triangle_vertices(triangle), f32::INFINITY) {
                if best.is_none_or(|b| precedes(t, triangle, b.t, b.triangle)) {
                    best = Some(Hit { t, triangle, b1, b2, instance: blob::NONE, time: 0.0 });
                }
            }
        }
        best
    }

    #[test]
    fn exact_ties_go_to_the_lowest_triangle_index() {
        // 24 identical triangles (three leaves at least) among 400 others: every ray through the
        // stack meets 24 hits at one t; the lowest index must win whichever leaf is visited first.
        let data = testscene::stacked_copies(24, 400, 0x71e5);
        let bytes = testscene::encode(&data);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = Accel::new(&view);
        let copies: Vec<u32> = (0..view.triangles.len() as u32)
            .filter(|&t| accel.triangle_vertices(t)[0] == Vec3::new(-2.0, -2.0, 0.0))
            .collect();
        assert_eq!(copies.len(), 24);
        let leaves_with_copies = accel
            .blocks
            .iter()
            .filter(|b| (0..BLOCK_WIDTH).any(|l| copies.contains(&b.triangles[l])))
            .count();
        assert!(leaves_with_copies >= 3, "copies in {leaves_with_copies} blocks");
        // The same tree with every node's children and every block's lanes in reverse order: leaves
        // (and lanes) with equal entry distances are visited the other way round, so a tie rule that
        // depended on the visiting order would answer differently on one of the two.
        let mirrored_nodes: Vec<BvhNode> = view
            .bvh_nodes
            .iter()
            .map(|n| {
                let mut m = *n;
                m.bounds.iter_mut().for_each(|b| b.reverse());
                m.children.reverse();
                m
            })
            .collect();
        let mirrored_blocks: Vec<TriangleBlock> = view
            .bvh_blocks
            .iter()
            .map(|b| {
                let mut m = *b;
                m.vertices.iter_mut().flatten().for_each(|axis| axis.reverse());
                m.triangles.reverse();
                m
            })
            .collect();
        let mirrored = |origin: Vec3, dir: Vec3| {
            let node = |n: &BvhNode, r: &NodeRay, t: f32| Lanes::node(n, r, t);
            let block = |b: &TriangleBlock, r: &WatertightRay, t: f32| Lanes::block(b, r, t);
            closest(&mirrored_nodes, &mirrored_blocks, 0, origin, dir, f32::INFINITY, &node, &block)
                .map(|(t, triangle, b1, b2)| Hit { t, triangle, b1, b2, instance: blob::NONE, time: 0.0 })
        };
        let mut rng = testscene::Rng(5);
        let mut ties = 0;
        for i in 0..3000 {
            let target = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.5, 0.0), 0.0);
            let origin = if i % 2 == 0 {
                target + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 3.0)
            } else {
                target - Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 3.0)
            };
            let dir = (target - origin).normalize();
            let expected = closest_by_index(&accel, view.triangles.len(), origin, dir);
            assert_eq!(accel.closest_hit(origin, dir, f32::INFINITY), expected, "ray {i}");
            assert_eq!(accel.closest_hit_scalar(origin, dir, f32::INFINITY), expected, "ray {i}");
            assert_eq!(mirrored(origin, dir), expected, "ray {i}, mirrored tree");
            ties += expected.is_some_and(|h| copies.contains(&h.triangle)) as u32;
            if let Some(h) = expected.filter(|h| copies.contains(&h.triangle)) {
                assert_eq!(h.triangle, copies[0], "ray {i}: the lowest index of the stack");
            }
        }
        assert!(ties > 1000, "{ties} rays ended on the stack of copies");
    }

    #[test]
    fn any_hit_calls_blocks_and_skips_non_blockers() {
        let scene = testscene::random_triangles(200, 0xface);
        let bytes = testscene::encode(&scene);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = Accel::new(&view);
        let mut rng = testscene::Rng(99);
        for _ in 0..2000 {
            let (origin, dir) = random_ray(&mut rng, 3.0);
            // Only even triangles block: the answer is whether brute force finds an even one.
            let wray = WatertightRay::new(origin, dir);
            let expected = (0..view.triangles.len() as u32)
                .any(|t| t % 2 == 0 && wray.intersect(accel.triangle_vertices(t), f32::INFINITY).is_some());
            assert_eq!(accel.any_hit(origin, dir, f32::INFINITY, |t, _| t % 2 == 0), expected);
            assert_eq!(accel.any_hit_scalar(origin, dir, f32::INFINITY, |t, _| t % 2 == 0), expected);
        }
    }

    #[test]
    fn simd_kernels_equal_scalar_kernels() {
        let mut rng = testscene::Rng(777);
        let mut on_edge = 0;
        for _ in 0..20_000 {
            let (origin, dir) = random_ray(&mut rng, 2.0);
            let nray = NodeRay::new(origin, dir);
            let mut node = BvhNode::default();
            for child in 0..BVH_WIDTH {
                for axis in 0..3 {
                    let (a, b) = (rng.range(-1.5, 1.5), rng.range(-1.5, 1.5));
                    node.bounds[axis][child] = a.min(b);
                    node.bounds[3 + axis][child] = a.max(b);
                }
                if rng.next_f32() < 0.1 {
                    // Planes through the origin (NaN slab distances for axis rays), and empty slots.
                    node.bounds[0][child] = origin.x;
                    node.bounds[4][child] = origin.y;
                }
                if rng.next_f32() < 0.1 {
                    for axis in 0..3 {
                        node.bounds[axis][child] = f32::INFINITY;
                        node.bounds[3 + axis][child] = f32::NEG_INFINITY;
                    }
                }
            }
            let tmax = if rng.next_f32() < 0.5 { f32::INFINITY } else { rng.range(0.0, 4.0) };
            assert_eq!(Lanes::node(&node, &nray, tmax), Scalar::node(&node, &nray, tmax));

            let wray = WatertightRay::new(origin, dir);
            let mut block = TriangleBlock::default();
            for lane in 0..BLOCK_WIDTH {
                let c = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                for corner in 0..3 {
                    let p =
                        c + 0.5 * Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                    for axis in 0..3 {
                        block.vertices[corner][axis][lane] = p[axis];
                    }
                }
                if rng.next_f32() < 0.1 {
                    // A vertex exactly on the ray: an exactly zero edge function (double-precision path).
                    for axis in 0..3 {
                        block.vertices[1][axis][lane] = (origin + dir)[axis];
                    }
                }
            }
            let (a, b) = (Lanes::block(&block, &wray, tmax), Scalar::block(&block, &wray, tmax));
            assert_eq!(a.mask, b.mask);
            for lane in 0..BLOCK_WIDTH {
                if a.mask & (1 << lane) != 0 {
                    assert_eq!((a.t[lane], a.b1[lane], a.b2[lane]), (b.t[lane], b.b1[lane], b.b2[lane]));
                }
                on_edge += has_zero_edge_function(&wray, block_triangle(&block, lane)) as u32;
            }
        }
        // The lanes the lane kernel hands to its out-of-line double-precision retry.
        assert!(on_edge > 1000, "{on_edge} lanes with an exactly zero edge function");
    }

    /// Whether a single-precision edge function of the watertight test is exactly zero for `tri`.
    fn has_zero_edge_function(ray: &WatertightRay, tri: [Vec3; 3]) -> bool {
        let [kx, ky, kz] = ray.axes;
        let [a, b, c] = tri.map(|p| {
            let p = p - ray.origin;
            (p[kx] - ray.sx * p[kz], p[ky] - ray.sy * p[kz])
        });
        [c.0 * b.1 - c.1 * b.0, a.0 * c.1 - a.1 * c.0, b.0 * a.1 - b.1 * a.0].contains(&0.0)
    }

    #[test]
    fn two_level_bvh_agrees_with_brute_force_and_scalar_on_transformed_instances() {
        let scene = testscene::instanced_spheres(40, 0xbeef);
        let bytes = testscene::bytes(&scene);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = Accel::new(&view);
        assert_eq!((accel.instances().len(), accel.instances().prototype_count()), (40, 1));
        let mut rng = testscene::Rng(31337);
        let (mut instance_hits, mut top_hits) = (0, 0);
        for _ in 0..6000 {
            let (origin, dir) = random_ray(&mut rng, 6.0);
            let fast = accel.closest_hit(origin, dir, f32::INFINITY);
            let slow = accel.closest_hit_brute_force(origin, dir, f32::INFINITY);
            assert_same_closest(fast, slow, "instances");
            assert_eq!(
                fast,
                accel.closest_hit_scalar(origin, dir, f32::INFINITY),
                "SIMD vs scalar traversal"
            );
            if let (Some(f), Some(s)) = (fast, slow) {
                if f.triangle == s.triangle {
                    assert_eq!(f.instance, s.instance);
                }
                if f.instance == blob::NONE {
                    top_hits += 1
                } else {
                    instance_hits += 1
                }
                // The world-space hit point lies on the ray.
                let [a, b, c] = accel.hit_vertices(&f);
                let p = a * (1.0 - f.b1 - f.b2) + b * f.b1 + c * f.b2;
                assert!((p - (origin + dir * f.t)).length() < 1e-4, "{p} vs {}", origin + dir * f.t);
                assert!(accel.any_hit(origin, dir, f.t * 1.001, |_, _| true));
                assert!(!accel.any_hit(origin, dir, f.t * 0.999, |_, _| true));
            }
            assert_eq!(accel.any_hit(origin, dir, f32::INFINITY, |_, _| true), slow.is_some());
            assert_eq!(accel.any_hit_scalar(origin, dir, f32::INFINITY, |_, _| true), slow.is_some());
            // Only instance 3 blocks: the answer is whether some hit along the ray is on it.
            let on_three = (0..accel.instances().len() as u32).any(|i| {
                i == 3
                    && accel.instances().prototype_triangles(i).any(|t| {
                        let hit = Hit { t: 0.0, triangle: t, b1: 0.0, b2: 0.0, instance: i, time: 0.0 };
                        WatertightRay::new(origin, dir)
                            .intersect(accel.hit_vertices(&hit), f32::INFINITY)
                            .is_some()
                    })
            });
            assert_eq!(accel.any_hit(origin, dir, f32::INFINITY, |_, i| i == 3), on_three);
        }
        assert!(
            instance_hits > 1000 && top_hits > 100,
            "{instance_hits} instance hits, {top_hits} top-level"
        );
    }

    #[test]
    fn instance_normals_use_the_inverse_transpose() {
        let scene = testscene::instanced_spheres(10, 7);
        let bytes = testscene::bytes(&scene);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = Accel::new(&view);
        // The flattened mesh of each instance holds the ingest-computed world normals: the render
        // transform of the prototype normals must agree with them.
        for (i, mesh) in scene.meshes.iter().enumerate().take(10) {
            let proto = mesh.instance.as_ref().unwrap();
            let inst = view
                .instancing
                .instances
                .iter()
                .position(|r| view.string(r.name) == format!("/S{i}"))
                .unwrap();
            let hit = Hit { t: 0.0, triangle: 0, b1: 0.0, b2: 0.0, instance: inst as u32, time: 0.0 };
            for (n_local, n_world) in proto.normals.iter().zip(&mesh.normals) {
                let n = accel.normal_to_world(&hit, *n_local).normalize();
                assert!((n - *n_world).length() < 1e-5, "{n} vs {n_world}");
            }
        }
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

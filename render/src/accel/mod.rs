//! Ray queries against the blob's 8-wide BVH: closest hit and any hit.
//!
//! The blob stores an 8-wide BVH with uncompressed f32 child bounds, SoA per node ([`blob::BvhNode`]),
//! and leaves of four-triangle SoA blocks ([`blob::TriangleBlock`]), built at ingest from obvhs' PLOC
//! BVH2 (see `ingest::bvh`). A query walks it with an explicit stack, nearest child first:
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
//!   independent of the order leaves are visited in: the wavefront's packets
//!   ([`crate::accel::packet`]) and a tree with every node's children reversed give the same
//!   hit (tested on a stack of identical triangles). Cost: within ±1 % of the traversal's
//!   instructions (cachegrind, the three `bench integrators` scenes).
//! * **Scalar reference**: [`Scalar`] implements the same two kernels child by child and triangle by
//!   triangle (the latter with [`WatertightRay::intersect`]); the tests check that both kernels and
//!   both full traversals agree exactly, and that they agree with brute force.
//!
//! The stack is a fixed array of 32 entries on the CPU stack; a deeper walk (never seen in the 2.5 M
//! bench rays of the three test scenes) spills into a heap vector rather than fail, so no blob,
//! however adversarial, can make a query index out of bounds, and ordinary rays never allocate.
//!
//! # Experiments (chess set, 1.43 M triangles; 2 shared cores, load average 4–8 during all of them)
//!
//! Wall-clock timings were too noisy on this machine (the same binary varied by ±20 %), so variants
//! were compared in Mrays per CPU-second of the tracing thread (`CLOCK_THREAD_CPUTIME_ID`) against
//! Embree 4 measured the same way on the same rays: Embree primary 19.4, incoherent 1.66.
//!
//! * Format 1 (obvhs CWBVH, 80-byte compressed nodes, `obvhs::traverse!`): `bench rays` wall clock
//!   incoherent 0.39 vs Embree 1.63 (ratio 0.24), primary 6.7 vs 13.5 (0.50).
//! * This layout with the kernels inlined into the traversal loop: primary 13.7, incoherent ~0.8. The
//!   generated code was poor: the slab test's far half was split into 4-wide pieces with shuffles and
//!   no `vmovmskps`, and the triangle test was mostly scalar `ss` code (register pressure in the big
//!   loop; the same lane loops compiled alone were perfect). Kernels as out-of-line `inherit_target`
//!   functions: primary 14.3–14.6, and the slab test is 6 sub, 6 mul, 3 max, 3 min, 1 cmp, 1 movmsk.
//!   A profile then shows the node kernel at 42 % and the block kernel at 29 % of the time, both
//!   dominated by cache misses on the node and block loads.
//! * Triangle kernel: the per-lane `if det > 0 { … } else { … }` and a branchy zero-edge check were
//!   scalarized; rewritten as masks (`&`/`|` on lane booleans, zero lanes collected as a bit mask).
//! * Tree shape (ingest `BuildParams`): leaves of ≤ 4 vs ≤ 8 vs ≤ 12 triangles, SAH node cost 0.3–2.0,
//!   with and without obvhs' spatial pre-splits: all within the noise (12–17 primary, 0.75–1.08
//!   incoherent). The plain largest-area-first collapse gave only 4.2 children per 8-wide node; opening
//!   first the children whose whole subtree fits in the remaining slots raised it to 5.5 and cut the
//!   node count from 89 k to 65 k (leaves ≤ 8, node cost 1.0), which is the default now.
//!
//! # Per-ray and per-block costs (tractor / shading-heavy / simple blobs of `bench integrators`)
//!
//! Measured on the bench scenes (none has instances: the `any_in_instances_simd::…` and `call_mut`
//! frames of earlier profiles were identical kernels merged under another clone's name and the
//! render-tile closure, not instance traversal).
//! * The triangle kernel as `[f32; 4]` lane loops compiled to 436 instructions in the AVX2 clone,
//!   125 of them scalar `ss` ops and 48 stack accesses: LLVM unrolls four-iteration loops and its SLP
//!   vectorizer then packed the arithmetic only partly, scalarized every comparison and mask, and
//!   the in-line zero-edge retry (indexing the lane arrays by a runtime lane) kept those arrays on
//!   the stack. Moving the retry out of line alone gave 360 instructions, and masks written as
//!   `u32` lanes changed nothing; as `Vec4` arithmetic with `cmp*`/`bitmask` it is 156 (97 packed
//!   ops, one `movmskps` per mask), 134 instructions per call instead of 454 (callgrind, tractor).
//! * `WatertightRay::new` (5.6 % of the tractor's scalar samples, 2 % of its instructions) was an
//!   out-of-line `if` chain and swap that mispredict on incoherent rays, a store-forwarding stall
//!   on the direction and three divisions; it is now branch-free (index arithmetic and a table),
//!   inlined, with one `divps`: bit-identical fields (tested against the old construction).
//! * The closest-hit leaf test was a closure LLVM kept out of line, compiled for the baseline target
//!   (the closure belongs to the generic walk, not to the AVX2 clone), with a `vzeroupper` before
//!   each call: 1.5 % of the tractor's instructions, 2–3 % of its samples. As `ClosestLeaf` on a
//!   struct with an `#[inline(always)]` method it is part of the clone's loop: −4 M instructions
//!   (−0.7 %) on the tractor's scalar render, the same traversal rates within the noise.
//! * Result, same rays, same hits, the images unchanged bit for bit: `bench integrators`
//!   traversal table, single-ray Mrays per CPU second, three runs each, contended (load 8–10
//!   before, 13–14 after):
//!
//!   | scene | queue | before | after |
//!   |---|---|---|---|
//!   | tractor | primary | 7.9–8.4 | 10.7–12.4 |
//!   | tractor | bounce | 7.9 | 12.1–12.3 |
//!   | tractor | shadow (closest) | 7.4–8.1 | 10.1–11.8 |
//!   | tractor | shadow (any hit) | 13.5–13.7 | 12.6–17.2 |
//!   | shading-heavy | primary | 5.6–6.0 | 7.7–7.7 |
//!   | shading-heavy | bounce | 3.6–4.0 | 4.5–5.0 |
//!   | shading-heavy | shadow (closest) | 4.7–4.8 | 5.0–6.2 |
//!   | shading-heavy | shadow (any hit) | 5.2–5.3 | 6.5–6.7 |
//!   | simple | primary | 12.3–12.6 | 17.0–18.5 |
//!   | simple | bounce | 4.2–5.4 | 8.5–8.9 |
//!   | simple | shadow (closest) | 5.3–5.5 | 7.5–8.1 |
//!   | simple | shadow (any hit) | 5.3–5.4 | 6.1–8.4 |
//!
//!   Whole renders (callgrind, 120×80, 8 spp, one thread), instructions before → after: tractor
//!   scalar 642.9 M → 540.6 M (−15.9 %), wavefront 556.5 M → 454.2 M (−18.4 %); shading-heavy
//!   scalar 1109.0 M → 972.5 M (−12.3 %), wavefront 943.3 M → 806.9 M (−14.5 %). Share of the
//!   traversal in perf samples (320×213, 16 spp, one thread): tractor scalar ~35 % → 26 %,
//!   wavefront ~41 % → 33 %. `bench instancing` (1,000 instanced spheres, one run each, wall
//!   clock): primary 1.98 → 2.50 Mrays/s, incoherent 0.63 → 0.73 (the instance entry builds its
//!   rays with the same, now inlined, constructors).
//! * Not tried (an instance entry still builds both rays from the transformed ray): transforming
//!   the world ray's shear constants per instance instead; the dominant axis changes under a
//!   rotation, so it would not be the same arithmetic as a fresh [`WatertightRay`].
//! * Not tried for lack of time: BVH4 (half the node bytes; nodes are 45 % empty at 5.5 children),
//!   8-wide triangle blocks, Möller–Trumbore on precomputed edges (not watertight), AVX-512, prefetching
//!   the second-nearest child, and processing leaf children at once instead of through the stack.

pub mod curves;
pub mod instanced;
pub mod packet;

use blob::{child_ref, BvhNode, TriangleBlock, BLOCK_WIDTH, BVH_WIDTH};
use glam::{Vec3, Vec4};
use multiversion::multiversion;

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
    /// Index into the blob's instances when `triangle` is a prototype triangle (then `t`, `b1` and
    /// `b2` are the same in prototype and world space), or [`blob::NONE`] for a top-level triangle.
    pub instance: u32,
}

/// Read-only acceleration structure over mapped blob slices: the world BVH over the top-level
/// triangles and, when the scene has instances, the two-level structure of [`crate::accel::instanced`].
#[derive(Clone, Copy, Debug)]
pub struct Accel<'a> {
    // Crate-visible for the wavefront's packet-traversal experiment (`wavefront::packet`).
    pub(crate) nodes: &'a [BvhNode],
    pub(crate) blocks: &'a [TriangleBlock],
    positions: &'a [[f32; 3]],
    triangles: &'a [blob::Triangle],
    instances: crate::accel::instanced::Instances<'a>,
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
        }
    }

    /// The three vertices of triangle `index` as stored: world space for a top-level triangle,
    /// prototype space for a prototype triangle (see [`Accel::hit_vertices`]).
    #[inline]
    pub fn triangle_vertices(&self, index: u32) -> [Vec3; 3] {
        let tri = &self.triangles[index as usize];
        tri.vertices.map(|v| Vec3::from(self.positions[v as usize]))
    }

    /// The world-space vertices of the triangle `hit` found (transformed by its instance).
    #[inline]
    pub fn hit_vertices(&self, hit: &Hit) -> [Vec3; 3] {
        let v = self.triangle_vertices(hit.triangle);
        if hit.instance == blob::NONE {
            v
        } else {
            v.map(|p| self.instances.to_world_point(hit.instance, p))
        }
    }

    /// A normal of the triangle `hit` found, from its stored space to world space (by the inverse
    /// transpose of the instance transform); unchanged for top-level triangles. Not normalized.
    #[inline]
    pub fn normal_to_world(&self, hit: &Hit, n: Vec3) -> Vec3 {
        if hit.instance == blob::NONE {
            n
        } else {
            self.instances.to_world_normal(hit.instance, n)
        }
    }

    /// The instancing tables (empty for a scene without instances).
    pub fn instances(&self) -> &crate::accel::instanced::Instances<'a> {
        &self.instances
    }

    fn is_empty(&self) -> bool {
        self.nodes.is_empty() && self.instances.is_empty()
    }

    /// Closest hit with `t` in (0, `tmax`).
    pub fn closest_hit(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        if self.is_empty() {
            return None;
        }
        closest_hit_simd(self, origin, direction, tmax)
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
        if self.is_empty() {
            return false;
        }
        any_hit_simd(self, origin, direction, tmax, blocks)
    }

    /// The instance level of [`Accel::closest_hit`]: `best`, the closest hit among the top-level
    /// triangles (found by any traversal of the world BVH, e.g. a packet), or a nearer instance hit.
    pub(crate) fn closest_in_instances(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        best: Option<Hit>,
    ) -> Option<Hit> {
        if self.instances.is_empty() {
            return best;
        }
        closest_in_instances_simd(self, origin, direction, tmax, best)
    }

    /// The instance level of [`Accel::any_hit`]: whether a prototype triangle for which
    /// `blocks(triangle, instance)` holds is hit.
    pub(crate) fn any_in_instances(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        blocks: impl FnMut(u32, u32) -> bool,
    ) -> bool {
        !self.instances.is_empty() && any_in_instances_simd(self, origin, direction, tmax, blocks)
    }

    /// [`Accel::closest_hit`] with the scalar reference kernels (for tests).
    pub fn closest_hit_scalar(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
        if self.is_empty() {
            return None;
        }
        two_level_closest(self, origin, direction, tmax, &Scalar::node, &Scalar::block)
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
        two_level_any(self, origin, direction, tmax, &Scalar::node, &Scalar::block, &mut blocks)
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
                best = Some(Hit { t, triangle, b1, b2, instance: blob::NONE });
            }
        }
        // Instances: every prototype triangle moved to world space.
        for instance in 0..self.instances.len() as u32 {
            for triangle in self.instances.prototype_triangles(instance) {
                let limit = best.map_or(tmax, |h| h.t);
                let hit = Hit { t: 0.0, triangle, b1: 0.0, b2: 0.0, instance };
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
/// traversal. Every multiversioned traversal entry point (closest and any hit here, packets in
/// [`crate::accel::packet`]) takes its kernels from here.
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
            ray: &$crate::accel::NodeRay,
            tmax: f32,
        ) -> (u32, [f32; blob::BVH_WIDTH]) {
            <$crate::accel::Lanes as $crate::accel::Kernels>::node(node, ray, tmax)
        }
        #[multiversion::inherit_target]
        #[inline(never)]
        fn block(
            block: &blob::TriangleBlock,
            ray: &$crate::accel::WatertightRay,
            tmax: f32,
        ) -> $crate::accel::BlockHits {
            <$crate::accel::Lanes as $crate::accel::Kernels>::block(block, ray, tmax)
        }
        #[allow(clippy::redundant_closure)]
        let kernels = (
            |n: &blob::BvhNode, r: &$crate::accel::NodeRay, t: f32| node(n, r, t),
            |b: &blob::TriangleBlock, r: &$crate::accel::WatertightRay, t: f32| block(b, r, t),
        );
        kernels
    }};
}
pub(crate) use lane_kernels;

// The multiversioned entry points: one clone per target, the CPU checked once per query.
#[multiversion(targets("x86_64+avx2+fma"))]
fn closest_hit_simd(accel: &Accel, origin: Vec3, direction: Vec3, tmax: f32) -> Option<Hit> {
    let (node, block) = lane_kernels!();
    two_level_closest(accel, origin, direction, tmax, &node, &block)
}

#[multiversion(targets("x86_64+avx2+fma"))]
fn any_hit_simd<F: FnMut(u32, u32) -> bool>(
    accel: &Accel,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    mut blocks: F,
) -> bool {
    let (node, block) = lane_kernels!();
    two_level_any(accel, origin, direction, tmax, &node, &block, &mut blocks)
}

#[multiversion(targets("x86_64+avx2+fma"))]
fn closest_in_instances_simd(
    accel: &Accel,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    best: Option<Hit>,
) -> Option<Hit> {
    let (node, block) = lane_kernels!();
    accel.instances.closest(origin, direction, tmax, best, &node, &block)
}

#[multiversion(targets("x86_64+avx2+fma"))]
fn any_in_instances_simd<F: FnMut(u32, u32) -> bool>(
    accel: &Accel,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    mut blocks: F,
) -> bool {
    let (node, block) = lane_kernels!();
    accel.instances.any(origin, direction, tmax, &node, &block, &mut blocks)
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
    node_kernel: &N,
    block_kernel: &B,
) -> Option<Hit> {
    let best = if accel.nodes.is_empty() {
        None
    } else {
        closest(accel.nodes, accel.blocks, 0, origin, direction, tmax, node_kernel, block_kernel)
            .map(|(t, triangle, b1, b2)| Hit { t, triangle, b1, b2, instance: blob::NONE })
    };
    if accel.instances.is_empty() {
        return best;
    }
    accel.instances.closest(origin, direction, tmax, best, node_kernel, block_kernel)
}

/// Any hit over the top-level triangles, then over the instances.
#[inline(always)]
fn two_level_any<
    N: Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    B: Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
>(
    accel: &Accel,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
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
    !accel.instances.is_empty()
        && accel.instances.any(origin, direction, tmax, node_kernel, block_kernel, blocks)
}

/// `1 + 2γ₃` with `γₙ = nε/(1 − nε)`, ε = 2⁻²⁴ (Ize 2013): scaling far slab distances by it makes the
/// box test conservative under rounding. (`f32::EPSILON` is 2⁻²³, hence the halving.)
const ROBUST_FAR: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Per-ray data of the node kernel.
#[derive(Clone, Copy, Debug)]
pub struct NodeRay {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    /// `inv_dir · (1 + 2γ₃)`, for far planes (one more rounding than Ize's `t · (1 + 2γ₃)`, still
    /// conservative: 2γ₃ ≈ 6ε exceeds the four roundings involved).
    inv_dir_far: [f32; 3],
    /// Index into [`BvhNode::bounds`] of the near plane per axis (min for a positive direction).
    near: [usize; 3],
    /// Index of the far plane per axis.
    far: [usize; 3],
}

impl NodeRay {
    /// Prepares `origin + t·direction`.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        let mut near = [0; 3];
        let mut far = [0; 3];
        for axis in 0..3 {
            let negative = direction[axis].is_sign_negative() as usize;
            near[axis] = axis + 3 * negative;
            far[axis] = axis + 3 * (1 - negative);
        }
        let inv_dir = direction.recip().to_array();
        NodeRay {
            origin: origin.to_array(),
            inv_dir,
            inv_dir_far: inv_dir.map(|i| i * ROBUST_FAR),
            near,
            far,
        }
    }
}

/// A node or leaf on the traversal stack with its entry distance.
#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    child: u32,
    t: f32,
}

/// Traversal stack: a fixed array, spilling to the heap only past its capacity (see module docs).
/// 32 entries (256 bytes) are zeroed inline per query; 64 compiled to a `memset` call, a visible cost
/// at ~250 cycles per primary ray.
struct Stack {
    items: [Entry; 32],
    len: usize,
    spill: Vec<Entry>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Stack { items: [Entry::default(); 32], len: 0, spill: Vec::new() }
    }

    #[inline(always)]
    fn push(&mut self, e: Entry) {
        if self.len == self.items.len() {
            self.spill.extend_from_slice(&self.items);
            self.len = 0;
        }
        self.items[self.len] = e;
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        if self.len > 0 {
            self.len -= 1;
            Some(self.items[self.len])
        } else {
            self.spill.pop()
        }
    }
}

/// The two kernels of a traversal. [`Lanes`] is the vectorizable one, [`Scalar`] the reference.
pub trait Kernels {
    /// Bit `i` set if child `i` of `node` overlaps the ray's `(0, tmax)` interval; with the entry
    /// distance per child.
    fn node(node: &BvhNode, ray: &NodeRay, tmax: f32) -> (u32, [f32; BVH_WIDTH]);
    /// Per lane `(hit, t, b1, b2)` as [`WatertightRay::intersect`] with this `tmax` would give.
    fn block(block: &TriangleBlock, ray: &WatertightRay, tmax: f32) -> BlockHits;
}

/// Result of a block test: lane mask of hits and the per-lane hit data (meaningful where hit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BlockHits {
    /// Bit `lane` set where the lane's triangle is hit.
    pub mask: u32,
    /// Ray parameter per lane.
    pub t: [f32; BLOCK_WIDTH],
    /// Barycentric of vertex 1 per lane.
    pub b1: [f32; BLOCK_WIDTH],
    /// Barycentric of vertex 2 per lane.
    pub b2: [f32; BLOCK_WIDTH],
}

/// The vectorizable kernels: fixed-width lane loops with branch-free bodies.
pub struct Lanes;

// Lane loops index several arrays by lane on purpose: that is the shape LLVM vectorizes.
#[allow(clippy::needless_range_loop)]
impl Kernels for Lanes {
    #[inline(always)]
    fn node(node: &BvhNode, ray: &NodeRay, tmax: f32) -> (u32, [f32; BVH_WIDTH]) {
        let mut near = [0.0f32; BVH_WIDTH];
        let mut far = [tmax; BVH_WIDTH];
        for axis in 0..3 {
            let lo = &node.bounds[ray.near[axis]];
            let (o, inv) = (ray.origin[axis], ray.inv_dir[axis]);
            for i in 0..BVH_WIDTH {
                let t0 = (lo[i] - o) * inv;
                near[i] = if t0 > near[i] { t0 } else { near[i] };
            }
        }
        for axis in 0..3 {
            let hi = &node.bounds[ray.far[axis]];
            let (o, inv) = (ray.origin[axis], ray.inv_dir_far[axis]);
            for i in 0..BVH_WIDTH {
                let t1 = (hi[i] - o) * inv;
                far[i] = if t1 < far[i] { t1 } else { far[i] };
            }
        }
        let bits: [u32; BVH_WIDTH] = std::array::from_fn(|i| ((near[i] <= far[i]) as u32) << i);
        (bits.iter().fold(0, |a, b| a | b), near)
    }

    #[inline(always)]
    fn block(block: &TriangleBlock, ray: &WatertightRay, tmax: f32) -> BlockHits {
        // One `Vec4` per quantity, lane = triangle: glam's `Vec4` is an SSE register on x86-64 (and
        // four scalars elsewhere), so this is the same IEEE arithmetic as `WatertightRay::intersect`
        // lane for lane, with no FMA contraction. See the module docs for why not `[f32; 4]` loops.
        let [kx, ky, kz] = ray.axes;
        let [ox, oy, oz] = ray.origin_k.map(Vec4::splat);
        let (sx, sy, sz) = (Vec4::splat(ray.sx), Vec4::splat(ray.sy), Vec4::splat(ray.sz));
        // A corner translated to the ray origin and sheared: (x, y) in the ray's 2D frame, and z.
        let corner = |p: &[[f32; BLOCK_WIDTH]; 3]| {
            let x = Vec4::from_array(p[kx]) - ox;
            let y = Vec4::from_array(p[ky]) - oy;
            let z = Vec4::from_array(p[kz]) - oz;
            (x - sx * z, y - sy * z, sz * z)
        };
        let [p0, p1, p2] = &block.vertices;
        let (ax, ay, az) = corner(p0);
        let (bx, by, bz) = corner(p1);
        let (cx, cy, cz) = corner(p2);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        // Rare: an edge function is exactly zero; those lanes are redone by the scalar test (which
        // retries in double precision) after the fast path, out of line.
        let on_edge = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask();
        // The scalar test's early returns as one mask. `(t_scaled > 0) & (t_scaled < tmax·det)`
        // differs from the scalar `!(t_scaled <= 0 | …)` only for NaN operands, and those make `t`
        // NaN, which the finiteness test rejects in both.
        let negative = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let positive = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let det = u + v + w;
        let t_scaled = u * az + v * bz + w * cz;
        let limit = Vec4::splat(tmax) * det;
        let front = det.cmpgt(zero) & t_scaled.cmpgt(zero) & t_scaled.cmplt(limit);
        let back = det.cmplt(zero) & t_scaled.cmplt(zero) & t_scaled.cmpgt(limit);
        let inv = Vec4::ONE / det;
        let t = t_scaled * inv;
        let hit = !(negative & positive) & (front | back) & t.abs().cmplt(Vec4::INFINITY);
        let hits = BlockHits {
            mask: hit.bitmask(),
            t: t.to_array(),
            b1: (v * inv).to_array(),
            b2: (w * inv).to_array(),
        };
        if on_edge != 0 {
            return redo_lanes(hits, on_edge, block, ray, tmax);
        }
        hits
    }
}

// The lane kernel holds one triangle per `Vec4` lane.
const _: () = assert!(BLOCK_WIDTH == 4);

/// The lanes of `on_edge` redone with the scalar test [`WatertightRay::intersect`]: its
/// double-precision retry of an exactly zero edge function. Out of line and cold, so the fast path
/// keeps its values in registers (an in-line retry indexed by lane forced the lane arrays onto the
/// stack and scalarized the test).
#[cold]
#[inline(never)]
fn redo_lanes(
    mut hits: BlockHits,
    mut on_edge: u32,
    block: &TriangleBlock,
    ray: &WatertightRay,
    tmax: f32,
) -> BlockHits {
    while on_edge != 0 {
        let lane = on_edge.trailing_zeros() as usize;
        on_edge &= on_edge - 1;
        hits.mask &= !(1 << lane);
        if let Some((t, b1, b2)) = ray.intersect(block_triangle(block, lane), tmax) {
            hits.mask |= 1 << lane;
            (hits.t[lane], hits.b1[lane], hits.b2[lane]) = (t, b1, b2);
        }
    }
    hits
}

/// The three corners of lane `lane` of a block.
#[inline]
fn block_triangle(block: &TriangleBlock, lane: usize) -> [Vec3; 3] {
    std::array::from_fn(|c| Vec3::from(std::array::from_fn(|axis| block.vertices[c][axis][lane])))
}

/// The reference kernels: one child, one triangle at a time.
pub struct Scalar;

// The child and lane indices address several SoA arrays at once.
#[allow(clippy::needless_range_loop)]
impl Kernels for Scalar {
    fn node(node: &BvhNode, ray: &NodeRay, tmax: f32) -> (u32, [f32; BVH_WIDTH]) {
        let mut mask = 0;
        let mut dist = [0.0; BVH_WIDTH];
        for child in 0..BVH_WIDTH {
            let (mut near, mut far) = (0.0f32, tmax);
            for axis in 0..3 {
                let mut t0 = (node.bounds[axis][child] - ray.origin[axis]) * ray.inv_dir[axis];
                let mut t1 = (node.bounds[3 + axis][child] - ray.origin[axis]) * ray.inv_dir_far[axis];
                if ray.inv_dir[axis].is_sign_negative() {
                    t0 = (node.bounds[3 + axis][child] - ray.origin[axis]) * ray.inv_dir[axis];
                    t1 = (node.bounds[axis][child] - ray.origin[axis]) * ray.inv_dir_far[axis];
                }
                // NaN (origin on the plane of a zero direction component): the slab does not constrain.
                if t0 > near {
                    near = t0;
                }
                if t1 < far {
                    far = t1;
                }
            }
            dist[child] = near;
            if near <= far {
                mask |= 1 << child;
            }
        }
        (mask, dist)
    }

    fn block(block: &TriangleBlock, ray: &WatertightRay, tmax: f32) -> BlockHits {
        let mut hits = BlockHits::default();
        for lane in 0..BLOCK_WIDTH {
            if let Some((t, b1, b2)) = ray.intersect(block_triangle(block, lane), tmax) {
                hits.mask |= 1 << lane;
                hits.t[lane] = t;
                hits.b1[lane] = b1;
                hits.b2[lane] = b2;
            }
        }
        hits
    }
}

/// Closest-hit traversal of the triangle BVH rooted at node `root` of `nodes`: `(t, triangle, b1, b2)`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn closest(
    nodes: &[BvhNode],
    blocks: &[TriangleBlock],
    root: u32,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
) -> Option<(f32, u32, f32, f32)> {
    let wray = WatertightRay::new(origin, direction);
    let nray = NodeRay::new(origin, direction);
    let mut leaves = TriangleLeaves { blocks, wray: &wray, tmax, block_kernel, best: None };
    walk_closest(nodes, root, &nray, tmax, node_kernel, &mut leaves);
    leaves.best
}

/// What a closest-hit walk ([`walk_closest`]) does at a leaf: test it and return the (possibly
/// shortened) limit. Closures `FnMut(leaf, tmax) -> tmax` implement it (the instance level); the
/// triangle level is [`TriangleLeaves`], a struct so that its test is forced inline into the walk
/// (`#[inline(always)]` cannot be put on a closure argument, and LLVM kept the closure out of line,
/// compiled for the baseline target with a `vzeroupper` per call: 2–3 % of the tractor's samples).
pub(crate) trait ClosestLeaf {
    /// Tests leaf `leaf` (a [`child_ref`]) with limit `tmax`; returns the new limit.
    fn visit(&mut self, leaf: u32, tmax: f32) -> f32;
}

impl<F: FnMut(u32, f32) -> f32> ClosestLeaf for F {
    #[inline(always)]
    fn visit(&mut self, leaf: u32, tmax: f32) -> f32 {
        self(leaf, tmax)
    }
}

/// The leaf test of a closest-hit query over triangles: the best `(t, triangle, b1, b2)` so far.
struct TriangleLeaves<'a, B> {
    blocks: &'a [TriangleBlock],
    wray: &'a WatertightRay,
    /// The query's own limit (a hit must lie before it even when ties widen the walk's limit).
    tmax: f32,
    block_kernel: &'a B,
    best: Option<(f32, u32, f32, f32)>,
}

impl<B: Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits> ClosestLeaf for TriangleLeaves<'_, B> {
    #[inline(always)]
    fn visit(&mut self, leaf: u32, limit: f32) -> f32 {
        let (first, count) = child_ref::leaf_range(leaf);
        for block in &self.blocks[first as usize..(first + count) as usize] {
            let hits = (self.block_kernel)(block, self.wray, limit);
            let mut m = hits.mask;
            while m != 0 {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                let (t, triangle) = (hits.t[lane], block.triangles[lane]);
                if t < self.tmax && self.best.is_none_or(|(bt, btri, ..)| precedes(t, triangle, bt, btri)) {
                    self.best = Some((t, triangle, hits.b1[lane], hits.b2[lane]));
                }
            }
        }
        self.best.map_or(self.tmax, |(t, ..)| tie_limit(t))
    }
}

/// Whether a hit at `t` on `triangle` wins over the best one so far: it is nearer, or exactly as near
/// on a lower triangle index. The order is total, so the closest hit does not depend on the order in
/// which leaves are visited (single rays and packets visit them differently).
#[inline(always)]
pub(crate) fn precedes(t: f32, triangle: u32, best_t: f32, best_triangle: u32) -> bool {
    t < best_t || (t == best_t && triangle < best_triangle)
}

/// `1 + 2⁻¹⁶`: see [`tie_limit`].
const TIE_WIDEN: f32 = 1.0 + 1.0 / 65536.0;

/// The traversal limit once a hit at `t` is known: a little beyond `t` (256 ulps) rather than `t`
/// itself, so that a triangle met at exactly `t` (the tie [`precedes`] settles) is never culled by
/// the box test's or the triangle test's own rounding of a limit equal to `t`. Without the margin
/// the first of two tied triangles visited would win, and a packet, which visits leaves in another
/// order, could return the other one. The margin costs a few box tests just past the hit.
#[inline(always)]
pub(crate) fn tie_limit(t: f32) -> f32 {
    t * TIE_WIDEN
}

/// The node walk of a closest-hit query: children visited nearest first, subtrees farther than the
/// best hit culled. `leaf(child_ref, tmax)` tests one leaf and returns the (possibly shortened) `tmax`.
#[inline(always)]
pub(crate) fn walk_closest(
    nodes: &[BvhNode],
    root: u32,
    nray: &NodeRay,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    leaf: &mut impl ClosestLeaf,
) {
    let mut tmax = tmax;
    let mut stack = Stack::new();
    let mut current = Entry { child: root, t: 0.0 };
    loop {
        if current.child & child_ref::LEAF != 0 {
            tmax = leaf.visit(current.child, tmax);
        } else {
            let node = &nodes[current.child as usize];
            let (mut mask, dist) = node_kernel(node, nray, tmax);
            if mask != 0 {
                if mask & (mask - 1) == 0 {
                    // One child hit: descend without touching the stack.
                    let i = mask.trailing_zeros() as usize;
                    current = Entry { child: node.children[i], t: dist[i] };
                    continue;
                }
                // Several: sort them far to near (insertion sort; at most eight), push all but the
                // nearest, descend into the nearest.
                let mut hit = [Entry::default(); BVH_WIDTH];
                let mut n = 0;
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let e = Entry { child: node.children[i], t: dist[i] };
                    let mut j = n;
                    while j > 0 && hit[j - 1].t < e.t {
                        hit[j] = hit[j - 1];
                        j -= 1;
                    }
                    hit[j] = e;
                    n += 1;
                }
                for &e in &hit[..n - 1] {
                    stack.push(e);
                }
                current = hit[n - 1];
                continue;
            }
        }
        loop {
            match stack.pop() {
                None => return,
                // Entirely behind the best hit so far.
                Some(e) if e.t > tmax => {}
                Some(e) => {
                    current = e;
                    break;
                }
            }
        }
    }
}

/// Any-hit traversal of the triangle BVH rooted at node `root`: true when a triangle for which
/// `blocks(triangle)` holds is hit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn any(
    nodes: &[BvhNode],
    blocks: &[TriangleBlock],
    root: u32,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
    blocker: &mut impl FnMut(u32) -> bool,
) -> bool {
    let wray = WatertightRay::new(origin, direction);
    let nray = NodeRay::new(origin, direction);
    walk_any(nodes, root, &nray, tmax, node_kernel, |leaf| {
        let (first, count) = child_ref::leaf_range(leaf);
        for block in &blocks[first as usize..(first + count) as usize] {
            let mut m = block_kernel(block, &wray, tmax).mask;
            while m != 0 {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                if blocker(block.triangles[lane]) {
                    return true;
                }
            }
        }
        false
    })
}

/// The node walk of an any-hit query: no ordering (any blocker ends the walk), early exit when
/// `leaf(child_ref)` returns true.
#[inline(always)]
pub(crate) fn walk_any(
    nodes: &[BvhNode],
    root: u32,
    nray: &NodeRay,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    mut leaf: impl FnMut(u32) -> bool,
) -> bool {
    let mut stack = Stack::new();
    let mut current = root;
    loop {
        if current & child_ref::LEAF != 0 {
            if leaf(current) {
                return true;
            }
        } else {
            let node = &nodes[current as usize];
            let (mut mask, _) = node_kernel(node, nray, tmax);
            if mask != 0 {
                current = node.children[mask.trailing_zeros() as usize];
                mask &= mask - 1;
                while mask != 0 {
                    stack.push(Entry { child: node.children[mask.trailing_zeros() as usize], t: 0.0 });
                    mask &= mask - 1;
                }
                continue;
            }
        }
        match stack.pop() {
            None => return false,
            Some(e) => current = e.child,
        }
    }
}

/// Edge functions in double precision (the watertight test's fallback when one is exactly zero).
#[inline]
fn edge_functions_f64(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> [f32; 3] {
    let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
    [(cx * by - cy * bx) as f32, (ax * cy - ay * cx) as f32, (bx * ay - by * ax) as f32]
}

/// Per-ray precomputation of the watertight test: the axis permutation and shear that map the ray to
/// +Z through the origin.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3,
    /// `origin[kx], origin[ky], origin[kz]`, so SIMD code needs no per-block component lookup.
    origin_k: [f32; 3],
    /// `[kx, ky, kz]`: `kz` is the dominant axis of the direction, `kx`, `ky` the other two, swapped
    /// when the direction's `kz` component is negative (keeps the triangles' winding).
    axes: [usize; 3],
    sx: f32,
    sy: f32,
    sz: f32,
}

/// `[kx, ky, kz]` by `2·kz + (direction[kz] < 0)`.
const AXES: [[usize; 3]; 6] = [[1, 2, 0], [2, 1, 0], [2, 0, 1], [0, 2, 1], [0, 1, 2], [1, 0, 2]];

impl WatertightRay {
    /// Prepares `origin + t·direction`.
    ///
    /// Built once per query (and per instance entered), so it is branch-free: the dominant axis
    /// comes from comparisons turned into an index and the permutation from a table (the `if`
    /// chain and a swap mispredicted on incoherent rays: 6 % of the tractor's samples), and the
    /// three quotients are one vector division (the same IEEE quotients as three scalar ones).
    #[inline(always)]
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        let a = direction.abs();
        // kz: x if it is strictly the largest, else y if larger than z, else z (ties as before).
        let x_wins = (a.x > a.y) & (a.x > a.z);
        let y_wins = a.y > a.z;
        let kz = (!x_wins as usize) * (2 - y_wins as usize);
        let d = direction.to_array();
        let dz = d[kz];
        let axes = AXES[2 * kz + (dz < 0.0) as usize];
        let [kx, ky, _] = axes;
        let o = origin.to_array();
        let [sx, sy, sz, _] = (Vec4::new(d[kx], d[ky], 1.0, 1.0) / Vec4::splat(dz)).to_array();
        WatertightRay { origin, origin_k: [o[kx], o[ky], o[kz]], axes, sx, sy, sz }
    }

    /// `(t, b1, b2)` if the ray hits the triangle with `0 < t < tmax`.
    #[inline]
    pub fn intersect(&self, [p0, p1, p2]: [Vec3; 3], tmax: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.axes;
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
            [u, v, w] = edge_functions_f64(ax, ay, bx, by, cx, cy);
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

    /// Closest hits must agree in `t`; a different triangle is only acceptable for a tie in `t`.
    fn assert_same_closest(fast: Option<Hit>, slow: Option<Hit>, what: &str) {
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
                    best = Some(Hit { t, triangle, b1, b2, instance: blob::NONE });
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
                .map(|(t, triangle, b1, b2)| Hit { t, triangle, b1, b2, instance: blob::NONE })
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
    fn bvh_agrees_with_brute_force_on_the_bundled_tractor() {
        let dir = tempfile::tempdir().unwrap();
        let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
        let out = dir.path().join("tractor.blob");
        ingest::pipeline::ingest_file(&example, &out, &Default::default()).expect("ingest the example");
        let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&out).unwrap());
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = Accel::new(&view);
        let lo = Vec3::from(view.info.bounds_min);
        let hi = Vec3::from(view.info.bounds_max);
        let mut rng = testscene::Rng(4242);
        let mut hits = 0;
        for i in 0..3000 {
            // Rays from outside towards points inside the bounds, and rays leaving surface points.
            let pick = |rng: &mut testscene::Rng| {
                lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
            };
            let (origin, dir) = if i % 2 == 0 {
                let target = pick(&mut rng);
                let origin = target + (hi - lo).length() * (pick(&mut rng) - target).normalize();
                (origin, (target - origin).normalize())
            } else {
                let t = (rng.next_f32() * view.triangles.len() as f32) as u32 % view.triangles.len() as u32;
                let [a, b, c] = accel.triangle_vertices(t);
                let n = (b - a).cross(c - a).normalize_or_zero();
                let p = (a + b + c) / 3.0;
                let d = (pick(&mut rng) - p).normalize_or_zero();
                (offset_ray_origin(p, if d.dot(n) >= 0.0 { n } else { -n }), d)
            };
            if dir == Vec3::ZERO || !dir.is_finite() {
                continue;
            }
            let fast = accel.closest_hit(origin, dir, f32::INFINITY);
            let slow = accel.closest_hit_brute_force(origin, dir, f32::INFINITY);
            hits += slow.is_some() as usize;
            assert_same_closest(fast, slow, "tractor");
            assert_eq!(
                fast,
                accel.closest_hit_scalar(origin, dir, f32::INFINITY),
                "SIMD vs scalar traversal"
            );
            assert_eq!(accel.any_hit(origin, dir, f32::INFINITY, |_, _| true), slow.is_some());
        }
        assert!(hits > 1000, "the test should exercise many hits, got {hits}");
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
                        let hit = Hit { t: 0.0, triangle: t, b1: 0.0, b2: 0.0, instance: i };
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
            let hit = Hit { t: 0.0, triangle: 0, b1: 0.0, b2: 0.0, instance: inst as u32 };
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

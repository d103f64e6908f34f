//! The breadth-first (wavefront) integrator, after MoonRay (Lee et al., HPG 2017, §4–7): the same
//! estimator as [`crate::integrator`], computed one *stage* at a time over a batch of paths instead of
//! one path at a time, with the per-path arithmetic in 8-lane AoSoA kernels.
//!
//! One worker (one rayon task per tile, each with its own [`Worker`] of preallocated pools and queues:
//! no locks, no allocation on the hot path) runs one of two drivers over the same stage kernels
//! ([`queues::Driver`]). The default, the *wave* driver, runs per tile and per chunk of that tile's
//! samples (bounce-synchronous: each stage over the whole wave of surviving paths):
//!
//! ```text
//! generate ─► ray queue ─► intersect (+ area-light emission, 8 rays per lane group)
//!                ▲            └► shade queue ─► sort (texture keys, radix sort, per-material segments)
//!                │                   └► shade, run by run (up to 8 hits on one material):
//!                │                        1a. per hit: surface; 8 hits at once: material program
//!                │                            + textures
//!                │                        1. per hit: opacity, normal map, emission ─► lane k of a group
//!                │                        2. per full group of 8: random numbers, BSDF construction, ray origins,
//!                │                           light sample ─► BSDF eval ─► MIS ─► occlusion queue
//!                │                           BSDF sample ─► throughput + roulette ──────────────┐
//!                └──────────────────────────────────────────────────────── next ray queue ◄─────┘
//! occlusion (any hit) ─► radiance; accumulate (per pixel, in sample order) ─► tile
//! ```
//!
//! The *queue* driver ([`queues`], MoonRay §4–6) runs the same kernels from bounded queues that are
//! flushed into their handler when full, with path regeneration and a drain ending each chunk:
//!
//! ```text
//! camera paths (into free pool slots) ─► ray queue ─(full: 1024)─► intersect + emission
//!   ▲                                      ▲          escaped: ended ┘ └─► shade queue of the hit's
//!   │                                      │                               material (one per material)
//!   │                                      │          ┌──────────(full: 256)──┘
//!   │                                      │          ▼
//!   │                                      │   sort keys ─► radix sort ─► shade (phase 1 runs,
//!   │                                      └── continuations ◄──────────  phase 2 groups of 8)
//!   │                       occlusion queue ◄── shadow rays ◄──────────────┘     └─► ended
//!   │   (full: 1024, and before every ray flush) ─► any hit ─► radiance += contribution
//!   │                                      then ended paths ─► radiance queue ─(full: 256)─► film
//!   └──────────────── their pool slots are free again ◄──┘    (a slot per (pixel, sample) of the chunk)
//! film ─► accumulate (per pixel, in sample order) ─► tile
//! ```
//!
//! Queue entries (bits): ray queue and occlusion queue 32 (a [`RayState`] index; the shadow ray in a
//! side table indexed the same way); shade queues 32 while waiting, 64 once flushed (`key << 32 |
//! index`, the key layout in [`sort`]); radiance queue [`queues`]' table (slot, radiance, first hit).
//!
//! Paths are the [`RayState`] pool; queue entries are 32-bit indices into it (the shade queue holds
//! 64-bit `key << 32 | index` entries, see [`sort`]). Every random number comes from the stateless
//! sampler keyed by (pixel, sample, vertex, dimension), and each path adds its radiance terms in the
//! scalar integrator's order, so the image equals the scalar one bit for bit: every lane kernel
//! ([`bsdf_lanes`], [`lanes`], [`roulette`], [`sampler_lanes`], [`emission_lanes`], [`light_lanes`],
//! [`material_lanes`] with `texture::sample_lanes_with`) performs the scalar code's IEEE operations in
//! the same order (no FMA contraction happens without fast-math) and has a test against its scalar
//! reference on random inputs; `equivalence_tests` and the scene tests compare whole images (max and
//! mean absolute difference 0).
//!
//! # Where it stands (idle 2-core machine, `bench integrators`, 320×213, 16 spp, three runs)
//! Wavefront/scalar CPU time: tractor 1.74–1.99×, shading-heavy 1.37–1.51×, simple 1.71–1.82×;
//! shading+texturing+integration 1.46–1.69×, 1.27–1.40×, 1.59–1.89× (images equal bit for bit), so the
//! wavefront is the default. The queue driver ([`queues`]) beside it: 1.60–1.96×, 1.33–1.51×,
//! 1.43–1.72×. Shading-heavy lost ground to the light tree ([`crate::lights::tree`], 1.5–1.9× lower
//! RMSE at equal spp there): its descent is the same scalar code per lane in both integrators (before
//! it the figures were 1.85–1.94×, 1.38–1.60×, 1.38–1.75×; 1.58–1.65×, 1.37–1.63×, 1.31–1.82×). What got it there, each step measured in its module's docs: area-light
//! emission with eight *rays* per light test ([`emission_lanes`], 146 M → 51 M instructions on the
//! shading-heavy scene, where the scalar loop takes 249 M), camera rays and the vertex's random
//! numbers truly 8-wide ([`generate`], [`sampler_lanes`]), light kernels specialised to the scene's
//! light kinds ([`light_lanes`]), one inlinable sin/cos for both integrators ([`crate::trig`]: the
//! lane kernels had called libm per lane), phase 1 run by run with surfaces built in their slots
//! ([`shade`]), and escaped rays' dome/distant emission once per batch. Shared work got faster in
//! both integrators too (the triangle block test on `Vec4` lanes in [`crate::accel`], `Scene::surface`,
//! texture lookups without libm). Still short of the ≥ 3× shading+integration goal: per hit, the
//! surface rebuild (gathers from the blob) and the texture gathers are memory-bound and stay scalar,
//! and the UsdPreviewSurface programs are three or four ops, so the lanes have little arithmetic to
//! win on. The sections below are the history of earlier steps, with the figures of their day.
//!
//! # Where it wins and where it loses (`bench integrators`; callgrind instruction counts, 1 thread)
//! Render instructions scalar → wavefront: tractor 292 M → 260 M (1.12×), shading-heavy (textured, 48
//! sphere lights) 513 M → 401 M (1.28×), simple 97 M → 86 M (1.13×). The BVH queries are the same
//! single-ray code in both (118 M, 168 M, 48 M of those), so outside them the wavefront runs 1.23×,
//! 1.48× and 1.29× fewer instructions. It also takes ~90× fewer instruction-cache misses (cachegrind,
//! shading-heavy at 120×80, 8 spp: 0.13 M against 11.9 M; each stage's loop stays hot). It loses on
//! data: 2.3× the L1 data misses there (4.8 M against 2.1 M:
//! path state, hits, the kept surfaces and the scatter points stream through L1 stage by stage, where
//! the depth-first loop keeps one path in registers). Timed on the loaded 2-core machine the CPU time
//! on that scene came out level with the scalar one (±8 % noise between runs) although it executes
//! 22 % fewer instructions; an idle machine is needed to settle it.
//!
//! Experiments that did not pay (kept out): building every hit's surface and sort key per 64-ray
//! batch inside the closest-hit stage, its triangle record and vertices prefetched during the
//! traversal (a 92-byte kept record; 2026-11-23): the surface work fell from ~9.7 % to 7.3 % of the
//! perf samples on shading-heavy, but the shade stage took its first touch (3.6 → 5.5 %) and the
//! prefetches' own loads landed in the traversal loop (1.5 → 3.1 %), +2.8 % instructions; with the
//! 2048-path pool the whole render came out level (untimed task-clock medians 905 / 916 ms;
//! non-traversal samples per traversal sample 0.848 / 0.862 over three alternating perf runs
//! each), so it only moved time from shading into intersection. A smaller path pool (1024 or 512
//! paths instead of 4096: the same L1 misses, within timing noise; later measured at L2, where
//! 2048 paths did pay: [`POOL_PATHS`]); rebuilding the surface in shading instead of keeping the one
//! the sort key reconstructs (5 % more instructions, 12 % fewer L1 misses, no clear time change);
//! packet traversal ([`packet`]: closest-hit packets for the camera wave and any-hit packets for
//! the occlusion queue ran 2–8 % more query instructions; its docs have the figures, and show the
//! traversal missing L1 *less* than the scalar integrator's); ordering the occlusion queue by
//! light (a sort by (light, path) before the any-hit stage, so shadow rays towards one light run
//! together): the same image, 1.4 % more instructions (the sort) and no fewer D1 misses (cachegrind,
//! shading-heavy at 120×80, 8 spp: 5.31 M against 5.29 M), occlusion time within the noise.
//!
//! Light sampling ([`light_lanes`]; first a pass of its own between per-hit shading and the BSDF
//! lanes, now inside the group pass, see below) runs its kernel in 13.6 M instructions where [`crate::lights::Lights::sample`] took 20.9 M
//! (cachegrind, shading-heavy: 48 sphere lights, a dome and a sun; 120×80, 8 spp, ~90 k shading
//! points); with the transposition and the shadow-ray set-up the whole process runs 1.0 % fewer
//! instructions there (940 M → 930 M), and 0.1–0.4 % more on the tractor and the simple scene,
//! whose one or two lights cost the scalar code little while the lanes evaluate every kind's
//! arithmetic and select (running the cone and the point-on-light arithmetic in separate loops,
//! each only when a lane needs it, cost 0.1–0.7 % more instructions on all three: kept out).
//!
//! # Shading and integration without transpositions
//! Phase 1 used to build each hit's BSDF (`Bsdf::from_inputs`) into a ~200-byte AoS scatter point;
//! a light pass transposed the chunk's points to lanes and back (13.8 M instructions of set-up
//! around a 13.6 M kernel), and phase 2 transposed them again for the BSDF kernels. Now phase 1
//! writes each hit's shading inputs, normals and sampler keys straight into its lane of an AoSoA
//! [`shade::ScatterGroup`], and phase 2 runs on the group, in lanes: the vertex's random numbers,
//! the BSDF construction
//! ([`crate::bsdf::lanes::from_inputs_lanes`]), the ray origins ([`crate::lights::mis::offset_origin_lanes`], shared by
//! the shadow and the continuation ray), the light sample, the BSDF evaluation, the MIS weight, the
//! BSDF sample and the roulette; shadow-ray set-up runs only for the samples MIS keeps. Callgrind,
//! whole process, 120×80, 8 spp, 1 thread (instructions; tractor D1 misses read + write):
//!
//! | step | shading-heavy | tractor | simple | tractor D1 misses |
//! |---|---|---|---|---|
//! | before | 950.8 M | 588.2 M | 215.7 M | 4.40 M |
//! | AoSoA groups written by phase 1, light sample inside the lane pass | 935.3 M | 574.5 M | 212.1 M | 3.91 M |
//! | + BSDF construction and ray origins in lanes | 919.5 M | 559.3 M | 209.5 M | 4.04 M |
//! | + a group runs as soon as it fills (one 2 KiB group stays in L1, where a chunk's 32 groups took 65 KiB) | 922.9 M | 562.8 M | 210.1 M | 3.33 M |
//! | + chunk surfaces as slots of the surface table (no 250-byte `Surface` moves) | 908.7 M | 554.8 M | 209.4 M | 2.97 M |
//! | + random numbers drawn per group from the keys phase 1 wrote (no pass of its own over the path states) | 905.6 M | 551.9 M | 208.9 M | 2.80 M |
//! | + the light kernel's path for lights at infinity (below) | 906.0 M | 547.6 M | 208.1 M | 2.80 M |
//! | + a chunk's rebuilt surfaces dropped when it ends (their memory reused: simple scene LL write misses 74 k → 62 k, as before) | 906.3 M | 547.9 M | 208.2 M | 2.80 M |
//!
//! The shading stage alone went from 239.6 M to 199.2 M instructions on the shading-heavy scene
//! (−17 %), 190.6 M to 153.2 M on the tractor (−20 %), 38.2 M to 31.8 M on the simple one; the whole
//! process −4.7 %, −6.9 %, −3.5 %. D1 misses fell 30 %, 36 % and 21 % (shading-heavy 6.48 M →
//! 4.55 M, simple 1.20 M → 0.95 M; I1 misses move by ±0.2 M between builds with code placement).
//! Contended timings (640×426, 16 spp, 1 thread, best of 5 interleaved runs, CPU seconds): tractor
//! 3.40 → 3.11 s, shading-heavy 6.58 → 6.55 s and 7.61 → 7.18 s in two series, simple 1.16 →
//! 1.19 s: only the tractor's gain stands above the ±6 % noise (the unchanged scalar integrator
//! timed 4.56 and 4.29 s in one such series). The tractor's wavefront render still takes 9× the
//! scalar one's D1 misses (2.80 M against 0.32 M): the depth-first loop keeps its path in
//! registers, the wavefront streams paths, hits and surfaces by sorted index. Flushing each group costs instructions (per-group zeroing of the lane
//! buffers) and 0.15 M more I1 misses, and was kept for the D1 misses: tractor at 640×426, 16 spp,
//! 1 thread, best of 5 CPU seconds (contended), 3.44 s before, 3.37 s with lanes, 3.28 s with the
//! flush. Tried and left out: chunks of 128 hits instead of 256 (the same instructions, 0.8 % fewer
//! D1 misses, 41 % more I1 misses).
//!
//! Why the tractor's wavefront "integration" phase took longer than the scalar one while running
//! fewer instructions (callgrind, 120×80, 8 spp; the phase holds phase 1's per-hit work, the lane
//! pass and the random numbers): its shading stage executed 190.6 M instructions against ~170 M
//! for the scalar loop's BSDF sampling and evaluation, light sampling, sampler calls and BSDF
//! construction, but took 3.0 M D1 misses where the whole scalar render takes 0.32 M: a chunk's
//! AoS scatter points (~50 KiB) and its moved `Surface`s (~64 KiB) streamed through L1 between
//! passes, besides the path states and hits read in sorted (not memory) order.
//! After the steps above: 153.2 M instructions and ~1.4 M D1 misses. The rest are the random
//! accesses to path states, hits and kept surfaces by sorted index. The light kernel also cost more
//! than `Lights::sample` there (19.8 M against 16.0 M: with a dome and a sun, every lane computed
//! every kind's arithmetic); groups whose lanes all picked a light at infinity now skip the other
//! kinds' (15.5 M; whole process tractor −0.8 %, simple −0.4 %, shading-heavy +0.04 % for the test).
//!
//! MoonRay-style queues that flush into their handler when full: built ([`queues`]), equal to the
//! scalar image bit for bit, and slower than the wave driver here (figures in [`queues`]), so the
//! wave driver stays the default ([`DEFAULT_DRIVER`]).
//!
//! # Surfaces, material programs and texture lookups in lanes
//! Phase 1a runs the material programs of runs of up to eight consecutive hits on one material
//! ([`material_lanes`]: one pass over the op list with `[f32; 8]` registers, texture ops through
//! `texture::sample_lanes_with`, whose MoonRay filter computes level, weights and blend in lane loops
//! and gathers texels per lane; the other filters loop the scalar lookup). A first lane version of
//! surface reconstruction (bit-exact against `Scene::surface`, tested) lost and was removed:
//! Callgrind, instructions inside the wavefront render, all three `bench integrators` scenes at 120 px
//! wide, 2 spp, 1 thread: before 859.5 M; with the material lanes clearing a 4 KiB register file per
//! group 886.7 M (the clear alone 34 M); with a reused file and a written-register mask the programs
//! cost 57.0 M against 65.8 M for the scalar evaluations they replace (−13 %). Those surface lanes took
//! 23.2 M (under AVX2 multiversion; 28.0 M without) for surfaces that cost 12.7 M as scalar calls:
//! every lane computed every branch (uv footprint, normal interpolation, instance transform gather),
//! with out-of-line helper calls per lane, always eight lanes, and only for the hits the sort stage
//! had not built. Final: 854.1 M (−0.6 %). The second version ([`surface_lanes`]) wins: each part
//! runs only when a lane of the group needs it, the lane loops are call- and branch-free (8-wide
//! `ymm` code in the AVX2 clone), groups of one or two hits stay scalar, and it serves both the
//! sort-key pass and shading; with the sort keys in lanes ([`key_lanes`]: per-material plans,
//! constant keys found once) the whole process runs 5.4 % fewer instructions on the tractor and on
//! shading-heavy and 2.6 % fewer on the simple scene (figures in [`surface_lanes`]). Timed
//! (contended, load average ~12 on the 2 cores, CPU seconds, wavefront/scalar side by side in one run
//! each): before tractor 1.26×, shading-heavy 1.03×, simple 1.31×; with the material lanes 1.28×,
//! 1.00×, 1.35× — within the ±10 % run-to-run noise there. Three more before/after pairs on a
//! quieter machine (load ~2, best of 3): shading-heavy 1.27/1.16/1.20× before against
//! 1.00/1.03/0.96× after, but the wavefront's own CPU time was level (1.79/1.92/1.62 s against
//! 1.87/1.88/1.74 s) while the *scalar* one dropped (2.28/2.22/1.95 s against 1.87/1.93/1.67 s: the
//! scalar evaluator and lookups are unchanged, so code placement and inlining moved). The texturing
//! phase fell from 9.2–10.6 % to 5.9–6.3 % of the wavefront's CPU time; intersection took the share. Texturing is ~9 % of the shading-heavy
//! scene's CPU time and programs are three or four ops, so lanes over them cannot move the total
//! much; the ≥ 1.5× goal needs the intersection share (50 %) down.

mod accumulate;
#[cfg(test)]
pub(crate) mod equivalence_tests;
mod generate;
mod intersect;
mod occlusion;
mod prefetch;
pub mod queue;
mod shade;
mod shade_curves;
pub mod sort;

use crate::accel::Hit;
use crate::camera::{Camera, RayCone};
use crate::film::Sampling;
use crate::film::{Tile, TileResult};
use crate::path::{FirstHit, PathSettings, RayCounts};
use crate::scene::Scene;
use crate::stats::{Counters, Phase, StageSeconds};
use glam::Vec3;
use std::time::Instant;
use texture::Touch;

/// Paths in flight per worker: a tile's samples are processed in chunks of at most this many paths
/// (a tile wider than this gets one path per pixel per chunk).
///
/// Sized for the 1 MiB L2 of a core: a path's state, hit, kept surface and shadow ray take ~300
/// bytes, so 4096 paths (1.2 MiB) streamed each stage through L3. Cachegrind with the last level
/// modelled as that L2 (120×80, 16 spp, one thread; instructions, D1 misses, L2 misses), 4096 → 2048
/// → 1024 paths: shading-heavy 919.5 / 920.6 / 922.0 M, 7.72 / 7.74 / 8.07 M, 2.31 / 1.33 / 0.72 M;
/// tractor 633.0 / 633.9 / 634.8 M, 3.47 / 3.51 / 3.61 M, 0.75 / 0.12 / 0.09 M; simple 249.4 /
/// 249.7 / 250.2 M, 1.34 / 1.34 / 1.39 M, 0.12 / 0.08 / 0.07 M; material-heavy 1008.5 / 1010.0 /
/// 1012.4 M, 8.70 / 8.46 / 8.87 M, 2.36 / 1.39 / 0.77 M. The misses that went were the shade
/// stage's first reads of path states, the material lanes', the accumulation's and the occlusion
/// stage's; 2048 keeps the L1 misses level where 1024 adds 4 %. Images are byte-identical.
pub const POOL_PATHS: usize = 2048;

/// The state of one path between stages: small, fixed-size, indices and floats only (MoonRay's
/// RayState grew to ~576 bytes; this one is [`RAY_STATE_BYTES`]). Texture footprint, MIS history and
/// counters; the hit and the shadow ray live in side tables indexed the same way.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayState {
    /// Ray origin of the current segment.
    pub origin: Vec3,
    /// Unit direction of the current segment.
    pub dir: Vec3,
    /// Path throughput.
    pub beta: Vec3,
    /// Radiance gathered so far.
    pub radiance: Vec3,
    /// Previous scattering vertex (for MIS of emission found by BSDF sampling).
    pub prev_p: Vec3,
    /// BSDF pdf at the previous vertex; negative for a camera ray (no previous vertex).
    pub prev_pdf: f32,
    /// Ray cone width at the origin.
    pub cone_width: f32,
    /// Ray cone spread angle.
    pub cone_spread: f32,
    /// Distance from the camera along pass-throughs (for the depth AOV).
    pub travelled: f32,
    /// Linear pixel index.
    pub pixel: u32,
    /// Sample index within the pixel.
    pub sample: u32,
    /// Sampler vertex counter.
    pub vertex: u32,
    /// Scattering events so far.
    pub bounces: u32,
}

/// Size of [`RayState`] in bytes.
pub const RAY_STATE_BYTES: usize = 92;
const _: () = assert!(std::mem::size_of::<RayState>() == RAY_STATE_BYTES);

impl RayState {
    fn prev(&self) -> Option<(Vec3, f32)> {
        (self.prev_pdf >= 0.0).then_some((self.prev_p, self.prev_pdf))
    }
    fn cone(&self) -> RayCone {
        RayCone { width: self.cone_width, spread: self.cone_spread }
    }
    /// Stochastic transparency: the path goes on straight through the surface it hit at distance `t`,
    /// from `origin` (a null event: no bounce). False when it has used up its null events.
    fn pass_through(&mut self, t: f32, footprint: f32, origin: Vec3, max_depth: u32) -> bool {
        self.vertex += 1;
        if self.vertex > max_depth + crate::path::MAX_NULL_EVENTS {
            return false;
        }
        self.travelled += t;
        self.cone_width = footprint;
        self.origin = origin;
        true
    }
}

/// A shadow ray waiting for the occlusion stage, indexed like its path.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShadowRay {
    /// Origin (offset off the surface).
    pub origin: Vec3,
    /// Unit direction to the light.
    pub dir: Vec3,
    /// Distance to stop short of the light.
    pub tmax: f32,
    /// MIS-weighted contribution added to the path if the light is visible.
    pub contribution: Vec3,
    /// Seed of the per-triangle pass-through decisions.
    pub seed: u32,
}

/// One worker's pools and queues, allocated once (before its first tile) and reused.
pub struct Worker {
    states: Vec<RayState>,
    hits: Vec<Hit>,
    /// Curve and point hits, valid where `hits` holds [`blob::NONE`] as the triangle.
    curve_hits: Vec<crate::accel::curves::CurveHit>,
    first_hits: Vec<Option<FirstHit>>,
    shadow: Vec<ShadowRay>,
    /// Incoherent ray queue being intersected, and the one shade fills for the next wave.
    rays: Vec<u32>,
    next_rays: Vec<u32>,
    /// Shade queue (`key << 32 | index`), its radix scratch, and the per-material buckets.
    shade: Vec<u64>,
    scratch: Vec<u64>,
    material_starts: Vec<u32>,
    /// Shaded hits waiting for the lane kernels; the first `scatter_points` lanes are in use.
    scatter: Box<shade::ScatterGroup>,
    scatter_points: usize,
    /// The area lights, eight per group, for the emission rays pick up.
    area_lights: crate::lights::emission_lanes::AreaLightLanes,
    /// Per material: its program reads a texture (else its sort key is 0 and is not computed).
    textured_materials: Vec<bool>,
    /// Per material: how its sort key is computed ([`key_lanes`]).
    key_plans: Vec<crate::shading::sort_key::KeyPlan>,
    /// Hits waiting for their surfaces ([`surface_lanes`]), with the kernel's columns (~2.5 KiB,
    /// allocated once rather than cleared per stage).
    surface_group: Box<crate::surface::lanes::HitGroup>,
    /// Surfaces reconstructed by the sort-key pass for textured hits (their sort key needs the uv
    /// footprint), used by shading instead of being rebuilt (`surface_slot` indexes it per path,
    /// `u32::MAX`: none kept). Shading builds the other hits' surfaces run by run on its stack.
    surfaces: Vec<crate::surface::Surface>,
    surface_slot: Vec<u32>,
    /// Per path: the material of its current hit (written by the sort-key pass in queue order):
    /// the material bucketing and shading's runs read these 4 bytes (16 KiB for the pool, in L1)
    /// instead of the 20-byte hit and the triangle's material record, by sorted index.
    materials: Vec<u32>,
    /// Register file of the material-program lanes.
    registers: Box<crate::shading::lanes::RegisterLanes>,
    /// Occlusion queue (path indices with a pending [`ShadowRay`]).
    occlusion: queue::Queue<u32>,
    /// Per-pixel running sums of the current tile.
    pixels: Vec<accumulate::PixelSum>,
    /// Stage timers.
    pub seconds: StageSeconds,
    /// Work and lane counters.
    pub counters: Counters,
    /// Phase timer (`--stats`) and shader evaluation count.
    pub clock: crate::stats::PhaseClock,
}

impl Worker {
    /// Pools for tiles of `tile_size²` pixels of `scene`; `phase_stats` times the phases
    /// ([`crate::stats::Phase`]).
    pub fn new(tile_size: u32, scene: &Scene, phase_stats: bool) -> Self {
        let view = &scene.view;
        let materials = view.materials.len();
        let textured_materials = view
            .materials
            .iter()
            .map(|m| {
                let program = &view.shader_ops[m.program_start as usize..][..m.program_len as usize];
                program.iter().any(|op| op.kind == blob::op_kind::TEXTURE)
            })
            .collect();
        let pixels = (tile_size * tile_size) as usize;
        let paths = POOL_PATHS.max(pixels);
        Worker {
            states: Vec::with_capacity(paths),
            hits: vec![Hit { t: 0.0, triangle: 0, b1: 0.0, b2: 0.0, instance: blob::NONE }; paths],
            curve_hits: vec![crate::accel::curves::CurveHit::default(); paths],
            first_hits: vec![None; paths],
            shadow: vec![ShadowRay::default(); paths],
            rays: Vec::with_capacity(paths),
            next_rays: Vec::with_capacity(paths),
            shade: Vec::with_capacity(paths),
            scratch: vec![0; paths],
            material_starts: vec![0; materials + 2],
            scatter: Box::default(),
            scatter_points: 0,
            textured_materials,
            key_plans: crate::shading::sort_key::plans(&scene.shading, materials),
            surface_group: Box::default(),
            area_lights: crate::lights::emission_lanes::AreaLightLanes::new(&scene.lights),
            surfaces: Vec::with_capacity(paths),
            surface_slot: vec![u32::MAX; paths],
            materials: vec![0; paths],
            registers: Box::default(),
            occlusion: queue::Queue::new(paths, paths),
            pixels: Vec::with_capacity(pixels),
            seconds: StageSeconds::default(),
            counters: Counters::default(),
            clock: crate::stats::PhaseClock::new(phase_stats),
        }
    }
}

/// What every stage reads: the scene, the camera and the settings.
pub struct Context<'s, 'a, T> {
    /// The scene.
    pub scene: &'s Scene<'a>,
    /// The camera.
    pub camera: &'s Camera,
    /// Image size, samples, seed and the camera rays' footprint.
    pub(crate) sampling: &'s Sampling,
    /// Depth and filter.
    pub settings: PathSettings,
    /// Texel-read reporting.
    pub touch: &'s T,
    /// The scene has texels (else every texture sort key is 0 and is not computed).
    pub textured: bool,
}

fn timed<R>(slot: &mut f64, f: impl FnOnce() -> R) -> R {
    let start = Instant::now();
    let r = f();
    *slot += start.elapsed().as_secs_f64();
    r
}

impl Worker {
    /// The storage of every queue and pool (to check that rendering allocates nothing).
    pub fn storage(&self) -> Vec<usize> {
        let s = vec![
            self.states.capacity(),
            self.rays.capacity(),
            self.next_rays.capacity(),
            self.shade.capacity(),
            self.scratch.capacity(),
            self.surfaces.capacity(),
            self.occlusion.storage(),
            self.pixels.capacity(),
        ];
        s
    }
}

/// Renders one tile breadth-first: per chunk of samples, waves of intersect, sort, shade and occlusion
/// until no path is left.
pub(crate) fn render(ctx: &Context<'_, '_, impl Touch>, w: &mut Worker, tile: &Tile) -> TileResult {
    let npix = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize;
    let spp = ctx.sampling.spp as usize;
    let mut rays = RayCounts::default();
    accumulate::begin(w, npix);
    let per_chunk = (w.states.capacity() / npix).clamp(1, spp);
    let mut s0 = 0;
    while s0 < spp {
        let samples = per_chunk.min(spp - s0);
        let mut secs = w.seconds;
        w.clock.lap(Phase::Overhead);
        timed(&mut secs.generate, || {
            generate::camera_rays(ctx, tile, s0 as u32, samples as u32, w, &mut rays)
        });
        w.clock.lap(Phase::Overhead);
        while !w.rays.is_empty() {
            timed(&mut secs.intersect, || intersect::closest(ctx, w));
            timed(&mut secs.sort, || intersect::sort_keys(ctx, w));
            w.clock.lap(Phase::Shading);
            timed(&mut secs.sort, || sort::shade_queue(w));
            w.clock.lap(Phase::Overhead);
            w.occlusion.clear();
            timed(&mut secs.shade, || shade::shade(ctx, w, &mut rays));
            timed(&mut secs.occlusion, || occlusion::any_hit(ctx, w, &mut rays));
            w.clock.lap(Phase::Intersect);
            std::mem::swap(&mut w.rays, &mut w.next_rays);
        }
        timed(&mut secs.accumulate, || accumulate::chunk(w, samples));
        w.clock.lap(Phase::Overhead);
        w.seconds = secs;
        s0 += samples;
    }
    accumulate::finish(w, spp as u32, rays)
}

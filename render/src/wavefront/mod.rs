//! The breadth-first (wavefront) integrator, after MoonRay (Lee et al., HPG 2017, §4–7): the same
//! estimator as [`crate::scalar`], computed one *stage* at a time over a batch of paths instead of
//! one path at a time, with the per-path arithmetic in 8-lane AoSoA kernels.
//!
//! One worker (one rayon task per tile, each with its own [`Worker`] of preallocated pools and queues:
//! no locks, no allocation on the hot path) runs per tile and per chunk of that tile's samples,
//! bounce-synchronous: each stage over the whole wave of surviving paths ([`render`]):
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
//! Paths are the [`RayState`] pool ([`POOL_PATHS`] per worker: the per-path records fit the L2);
//! queue entries are 32-bit indices into it (the shade queue holds 64-bit `key << 32 | index`
//! entries, see [`sort`]). Every random number comes from the stateless sampler keyed by (pixel,
//! sample, vertex, dimension), and each path adds its radiance terms in the scalar integrator's
//! order, so the image equals the scalar one bit for bit: every lane kernel ([`crate::bsdf::lanes`],
//! [`crate::surface::lanes`], [`crate::shading::lanes`] with `texture::sample_lanes_with`,
//! [`crate::shading::sort_key`], [`crate::sampler::lanes`], [`crate::lights::lanes`],
//! [`crate::lights::emission_lanes`], [`crate::lights::mis::weigh_lanes`],
//! [`crate::path::roulette::continue_lanes`], [`crate::hair::lanes`]) performs the scalar code's IEEE
//! operations in the same order (no FMA contraction happens without fast-math) and has a test
//! against its scalar reference on random inputs; `equivalence_tests` and the scene tests compare
//! whole images (max and mean absolute difference 0).
//!
//! What bounds it: per hit, the surface rebuild (gathers from the blob) and the texture gathers are
//! memory-bound, and the UsdPreviewSurface programs are three or four ops, so the lanes have little
//! arithmetic to win on; the wavefront loses on data (path states, hits and kept surfaces stream
//! through L1 stage by stage, where the depth-first loop keeps one path in registers) and wins on
//! instructions and instruction-cache misses. The decisions and the designs that lost (the queue
//! driver, packets, per-batch surfaces with traversal prefetch, smaller pools, occlusion ordered by light):
//! `ARCHITECTURE.md`; measurements: `docs/perf.md#wavefront-integrator-wavefrontmodrs`.

mod accumulate;
mod aovs;
#[cfg(test)]
pub(crate) mod equivalence_tests;
mod generate;
mod intersect;
mod occlusion;
mod prefetch;
mod shade;
mod shade_curves;
pub mod sort;

use crate::accel::Hit;
use crate::camera::{Camera, RayCone};
use crate::film::Sampling;
use crate::film::{PixelSum, TileJob, TileResult};
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
    /// The path's time in the shutter (every ray of the path, shadow rays included, is at it).
    pub time: f32,
}

/// Size of [`RayState`] in bytes.
pub const RAY_STATE_BYTES: usize = 96;
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
    /// The light is a delta light (point, distant): glass lets the ray through with its
    /// transmittance ([`crate::scene::Scene::shadow_transmittance`]).
    pub delta: bool,
    /// The light the ray goes to when the scene has light sets (shadow linking), else
    /// [`blob::NONE`].
    pub light: u32,
}

/// One worker's pools and queues, allocated once (before its first tile) and reused. Each stage
/// takes the parts it reads and writes, never the whole worker.
pub struct Worker {
    paths: PathPool,
    queues: StageQueues,
    kernels: KernelScratch,
    tables: WorkerTables,
    /// Per-pixel running sums of the current tile.
    film: Vec<PixelSum>,
    /// Stage timers, lane counters and the phase clock.
    pub stats: WorkerStats,
}

/// Per-path records, indexed by path (its index in `states`).
pub(crate) struct PathPool {
    states: Vec<RayState>,
    hits: Vec<Hit>,
    /// Curve and point hits, valid where `hits` holds [`blob::NONE`] as the triangle.
    curve_hits: Vec<crate::accel::curves::CurveHit>,
    first_hits: Vec<Option<FirstHit>>,
    /// The shadow ray a path waits on (valid while the path is in the occlusion queue).
    shadow: Vec<ShadowRay>,
    /// The material of the path's current hit (written by the sort-key pass in queue order): the
    /// material bucketing and shading's runs read these 4 bytes (16 KiB for the pool, in L1)
    /// instead of the 20-byte hit and the triangle's material record, by sorted index.
    materials: Vec<u32>,
    /// Surfaces reconstructed by the sort-key pass for textured hits (their sort key needs the uv
    /// footprint), used by shading instead of being rebuilt (`surface_slot` indexes it per path,
    /// `u32::MAX`: none kept). Shading builds the other hits' surfaces run by run on its stack.
    surfaces: Vec<crate::surface::Surface>,
    surface_slot: Vec<u32>,
    /// The light set of the path's previous scattering vertex (light linking of the emission its
    /// ray finds; read only where the state has a previous vertex). A side table, not a
    /// [`RayState`] field: scenes without linking never touch it.
    prev_light_set: Vec<u32>,
    /// The paths' AOV records, for a render whose plan traces ([`aovs`]).
    aov: aovs::AovColumns,
}

/// The queues between the stages: path indices (the shade queue `key << 32 | index`).
pub(crate) struct StageQueues {
    /// Incoherent ray queue being intersected, and the one shade fills for the next wave.
    rays: Vec<u32>,
    next_rays: Vec<u32>,
    /// Shade queue, its radix scratch, and the per-material buckets.
    shade: Vec<u64>,
    scratch: Vec<u64>,
    material_starts: Vec<u32>,
    /// Paths with a pending [`ShadowRay`].
    occlusion: Vec<u32>,
}

/// The columns the lane kernels fill and drain, allocated once rather than cleared per stage.
pub(crate) struct KernelScratch {
    /// Shaded hits waiting for the lane kernels; the first `scatter_points` lanes are in use.
    scatter: Box<shade::ScatterGroup>,
    scatter_points: usize,
    /// Hits waiting for their surfaces ([`crate::surface::lanes`]), with the kernel's columns
    /// (~2.5 KiB).
    surface_group: Box<crate::surface::lanes::HitGroup>,
    /// Register file of the material-program lanes.
    registers: Box<crate::shading::lanes::RegisterLanes>,
    /// The area lights, eight per group, and the emission kernel's columns.
    area_lights: crate::lights::emission_lanes::AreaLightLanes,
}

/// What the worker derives from the scene once, read by the stages.
pub(crate) struct WorkerTables {
    /// Per material: its program reads a texture (else its sort key is 0 and is not computed).
    textured_materials: Vec<bool>,
    /// Per material: how its sort key is computed ([`crate::shading::sort_key`]).
    key_plans: Vec<crate::shading::sort_key::KeyPlan>,
}

/// The parts of a worker the shading stage reads and writes, borrowed apart: the path pool, the
/// queues (the sorted shade queue in, the next ray queue and the occlusion queue out), the kernel
/// scratch, the worker's tables and its figures.
pub(crate) struct StageParts<'w> {
    paths: &'w mut PathPool,
    queues: &'w mut StageQueues,
    kernels: &'w mut KernelScratch,
    tables: &'w WorkerTables,
    stats: &'w mut WorkerStats,
}

/// A worker's figures, merged into the render's statistics when the worker is dropped.
pub struct WorkerStats {
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
            paths: PathPool {
                states: Vec::with_capacity(paths),
                hits: vec![
                    Hit { t: 0.0, triangle: 0, b1: 0.0, b2: 0.0, instance: blob::NONE, time: 0.0 };
                    paths
                ],
                curve_hits: vec![crate::accel::curves::CurveHit::default(); paths],
                first_hits: vec![None; paths],
                shadow: vec![ShadowRay::default(); paths],
                materials: vec![0; paths],
                surfaces: Vec::with_capacity(paths),
                surface_slot: vec![u32::MAX; paths],
                prev_light_set: vec![crate::lights::links::UNLINKED; paths],
                aov: aovs::AovColumns::default(),
            },
            queues: StageQueues {
                rays: Vec::with_capacity(paths),
                next_rays: Vec::with_capacity(paths),
                shade: Vec::with_capacity(paths),
                scratch: vec![0; paths],
                material_starts: vec![0; materials + 2],
                // Each path has at most one shadow ray waiting, so pushes never reallocate.
                occlusion: Vec::with_capacity(paths),
            },
            kernels: KernelScratch {
                scatter: Box::default(),
                scatter_points: 0,
                surface_group: Box::default(),
                registers: Box::default(),
                area_lights: crate::lights::emission_lanes::AreaLightLanes::new(&scene.lights),
            },
            tables: WorkerTables {
                textured_materials,
                key_plans: crate::shading::sort_key::plans(&scene.shading, materials),
            },
            film: Vec::with_capacity(pixels),
            stats: WorkerStats {
                seconds: StageSeconds::default(),
                counters: Counters::default(),
                clock: crate::stats::PhaseClock::new(phase_stats),
            },
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
    /// The render products' plan when its paths record AOVs ([`crate::aov::Plan::traces`]; `None`
    /// otherwise: the stages then never touch the pool's AOV columns). [`render`] sets it from
    /// the tile's job.
    pub(crate) aov: Option<&'s crate::aov::Plan>,
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
        let (p, q) = (&self.paths, &self.queues);
        vec![
            p.states.capacity(),
            q.rays.capacity(),
            q.next_rays.capacity(),
            q.shade.capacity(),
            q.scratch.capacity(),
            p.surfaces.capacity(),
            q.occlusion.capacity(),
            self.film.capacity(),
        ]
    }
}

/// Renders one tile breadth-first: per chunk of samples, waves of intersect, sort, shade and occlusion
/// until no path is left.
pub(crate) fn render(ctx: &Context<'_, '_, impl Touch>, w: &mut Worker, job: TileJob<'_>) -> TileResult {
    let TileJob { tile, sums: init, plan, aov: aov_init } = job;
    // The paths carry their AOV records only when the plan asks for more than the beauty's sums.
    let traced = plan.traces().then_some(plan);
    let ctx = &Context { aov: traced, ..*ctx };
    let Worker { paths, queues, kernels, tables, film, stats } = w;
    let npix = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize;
    let [first, end] = ctx.sampling.samples.map(|s| s as usize);
    let mut rays = RayCounts::default();
    accumulate::begin(film, init);
    if traced.is_some() {
        paths.aov.begin_tile(aov_init);
    }
    let per_chunk = (paths.states.capacity() / npix).clamp(1, (end - first).max(1));
    let mut s0 = first;
    while s0 < end {
        let samples = per_chunk.min(end - s0);
        let mut secs = stats.seconds;
        stats.clock.lap(Phase::Overhead);
        timed(&mut secs.generate, || {
            generate::camera_rays(ctx, tile, s0 as u32, samples as u32, paths, &mut queues.rays, &mut rays)
        });
        if let Some(plan) = traced {
            paths.aov.begin(plan, paths.states.len());
        }
        stats.clock.lap(Phase::Overhead);
        while !queues.rays.is_empty() {
            timed(&mut secs.intersect, || {
                intersect::closest(
                    ctx,
                    paths,
                    &queues.rays,
                    &mut queues.shade,
                    &mut kernels.area_lights,
                    &mut stats.clock,
                )
            });
            timed(&mut secs.sort, || intersect::sort_keys(ctx, paths, &mut queues.shade, kernels, tables));
            stats.clock.lap(Phase::Shading);
            timed(&mut secs.sort, || sort::shade_queue(queues, &paths.materials));
            stats.clock.lap(Phase::Overhead);
            queues.occlusion.clear();
            timed(&mut secs.shade, || {
                shade::shade(ctx, &mut StageParts { paths, queues, kernels, tables, stats }, &mut rays)
            });
            timed(&mut secs.occlusion, || {
                occlusion::any_hit(
                    ctx,
                    &mut paths.states,
                    &paths.shadow,
                    &mut paths.aov,
                    &mut queues.occlusion,
                )
            });
            stats.clock.lap(Phase::Intersect);
            std::mem::swap(&mut queues.rays, &mut queues.next_rays);
        }
        timed(&mut secs.accumulate, || {
            accumulate::chunk(film, paths, samples);
            if let Some(plan) = traced {
                let motion = crate::aov::MotionProjection::new(
                    ctx.camera,
                    ctx.settings.shutter,
                    ctx.sampling.width,
                    ctx.sampling.height,
                );
                paths.aov.chunk(plan, &motion, &paths.states, samples);
            }
        });
        stats.clock.lap(Phase::Overhead);
        stats.seconds = secs;
        s0 += samples;
    }
    let mut out = accumulate::finish(film, rays);
    if traced.is_some() {
        out.aov = paths.aov.finish();
    }
    out
}

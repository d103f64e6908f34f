//! Stage 4: shading. Reads the sorted shade queue (one segment per material) and the hit side table;
//! writes the occlusion queue, the shadow-ray side table and the next ray queue.
//!
//! The queue is shaded run by run ([`run_end`]): a curve or point hit alone, which takes its whole
//! vertex per hit ([`super::shade_curves`]), else up to eight consecutive triangle hits on one
//! material (the queue is grouped by material), in these phases:
//! 1a. the run's surfaces (the ones the sort key kept, else built together in lanes,
//!    [`crate::surface::lanes`]), then the
//!    material program over the run in lanes ([`crate::shading::lanes::evaluate_lanes`]; a lone hit runs
//!    the scalar program);
//! 1. per hit: stochastic transparency, the normal map, emission at the hit (the depth limit ends
//!    paths here), then its shading inputs, normals and sampler keys written straight into lane `k`
//!    of the AoSoA [`ScatterGroup`];
//! 2. as soon as the group holds eight points (and for the queue's last ones), its lane kernels:
//!    the vertex's random numbers ([`crate::sampler::lanes`]), the BSDFs ([`crate::bsdf::lanes::from_inputs_lanes`])
//!    and the first-hit albedos, the ray origins off the surfaces ([`crate::accel::ray::offset_origin_lanes`]),
//!    the light sample ([`crate::lights::lanes::sample_lanes`]; textured emitters per lane), the BSDF towards
//!    it ([`crate::bsdf::lanes::eval_lanes`]), the MIS weight ([`crate::lights::mis::weigh_lanes`]; kept samples enter
//!    the occlusion queue), the BSDF sample ([`crate::bsdf::lanes::sample_lanes`]) and the throughput update
//!    with Russian roulette ([`crate::path::roulette::continue_lanes`]); surviving paths enter the next ray queue.
//!
//! Nothing is transposed between phases 1 and 2: phase 1 writes each hit's values into its lane
//! (they are at hand there), and the group (~3.5 KiB with its kernels' outputs) is consumed while
//! it is still in L1.
//!
//! Design points, each measured (`docs/perf.md#shade-stage-wavefrontshaders`):
//! - Run by run, not in chunks of 256 hits: a run's surfaces, inputs and path states stay in L1 from
//!   the surface to the scatter group; the material bucketing reads the per-path material table the
//!   sort-key pass fills ([`super::sort::group_by_material`]).
//! - Written in place: a run's surfaces and shading inputs live in [`RunSlots`], where
//!   [`crate::shading::lanes::evaluate_lanes`] writes and [`prepare`] reads (no by-value returns).
//! - [`Lookahead`] prefetches ([`super::prefetch`]) path states, hits and surface slots 24 queue
//!   positions ahead and kept surfaces and first-hit records 16 ahead; the first-hit record is
//!   written field by field (a stack-built `Option<FirstHit>` copied out defeated store forwarding).
//! - The shadow rays' pass-through seeds are hashed eight at a time ([`shadow_seed_lanes`]).
//! - Kept out: rebuilding the sort key's kept surfaces here (−12 % L1 misses, +4–6 % instructions);
//!   putting the next ray and occlusion queues back in pool order (no coherence to win); a prefetch
//!   of each path's shadow-ray slot (no measurable win).

use super::{
    prefetch, sort, Context, KernelScratch, PathPool, ShadowRay, StageParts, StageQueues, WorkerStats,
};
use crate::accel::offset_ray_origin;
use crate::bsdf::lanes::{self as bsdf_lanes, BsdfLanes, EvalLanes, InputLanes, SampleInputs, SampleLanes};
use crate::bsdf::Bsdf;
use crate::lights::lanes::{self as light_lanes, LightInputs, LightSampleLanes};
use crate::lights::mis::{self as lanes, NeeLanes, NeeOut};
use crate::lights::power_heuristic;
use crate::path::roulette::{self as roulette, RouletteLanes, RouletteOut};
use crate::path::{shadow_tmax, FirstHit, RayCounts, CONE_WIDEN_PER_ALPHA, RR_START_BOUNCE};
use crate::sampler::lanes::{self as sampler_lanes, KeyLanes, DIMS};
use crate::sampler::{dim, hash_u32, sample_1d, shadow_seed, SampleKey};
use crate::scene::Scene;
use crate::shading::lanes as material_lanes;
use crate::shading::ShadingInputs;
use crate::stats::Phase;
use crate::surface::lanes as surface_lanes;
use crate::surface::Surface;
use glam::Vec3;
use lanekit::LANES;
use lanekit::{Lanes, Lanes3, V};
use texture::Touch;

/// Eight shaded hits waiting for the lane kernels, in AoSoA form: phase 1 writes them lane by lane
/// (each hit's values are at hand there), phase 2 reads whole columns, so nothing is transposed
/// between the passes. Lanes past a chunk's last hit hold stale values whose results are never read.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct ScatterGroup {
    /// Path indices.
    pub index: [u32; LANES],
    /// 1 where the hit is its path's first (its albedo goes to the first-hit AOV).
    pub first: [u32; LANES],
    /// How many lanes of `first` are 1: most groups have none, and skip the first-hit loop.
    pub firsts: u32,
    /// The hits' shading inputs and normals.
    pub inputs: InputLanes,
    /// The BSDFs at the hits (phase 2 builds them from `inputs`), with the directions towards the
    /// viewer (phase 1 writes those).
    pub bsdf: BsdfLanes,
    /// The paths' sampler keys at this vertex.
    pub keys: KeyLanes,
    /// Hit points, and the light choice and position samples (phase 2 draws those).
    pub light: LightInputs,
    /// Lobe choice and direction samples (drawn in phase 2).
    pub u: SampleInputs,
    /// Russian roulette samples (drawn in phase 2).
    pub u_rr: Lanes,
    /// Throughputs at the hits.
    pub beta: Lanes3,
    /// Cone widths at the hits.
    pub footprint: Lanes,
    /// 1 where Russian roulette is played after this bounce.
    pub play: [u32; LANES],
    /// The hits' light sets (light linking; written only when the scene has light sets).
    pub light_set: [u32; LANES],
    /// The kernels' inputs and outputs past the light sample.
    pub out: KernelLanes,
}

/// What phase 2's kernels write, kept with the group rather than zeroed on the stack for every
/// group: each kernel writes every lane of its outputs (lanes past the group's points get values
/// computed from stale inputs, never read), so nothing needs clearing. Clearing them per group
/// cost three `memset`s, ~110 instructions a group.
#[derive(Clone, Copy, Debug, Default)]
pub struct KernelLanes {
    /// The BSDF towards the light sample.
    pub eval: EvalLanes,
    /// The BSDF sample.
    pub sample: SampleLanes,
    /// The MIS kernel's inputs and outputs.
    pub nee: NeeLanes,
    /// See `nee`.
    pub nee_out: NeeOut,
    /// The roulette kernel's inputs and outputs.
    pub roulette: RouletteLanes,
    /// See `roulette`.
    pub roulette_out: RouletteOut,
    /// Origins of the rays leaving the hits.
    pub origin: Lanes3,
}

/// Shades every hit of the shade queue (`w.queues.shade`): curve and point hits one by one, the others run
/// by run. The continuations go to `w.queues.next_rays` (cleared first), the shadow rays are appended to the
/// occlusion queue.
pub(super) fn shade<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut StageParts<'_>, rays: &mut RayCounts) {
    w.queues.next_rays.clear();
    let shadow_rays_before = w.queues.occlusion.len();
    // The surfaces the sort kept, out of the worker while the runs borrow it mutably (a move of
    // the vector, no copy; put back below so its memory serves the next wave).
    let kept = std::mem::take(&mut w.paths.surfaces);
    let mut slots = RunSlots {
        built: [const { None }; LANES],
        inputs: [ShadingInputs::constant(&blob::Material::default()); LANES],
    };
    let mut fibres = super::shade_curves::CurveGroup::default();
    let n = w.queues.shade.len();
    let mut ahead = Lookahead::default();
    let mut start = 0;
    while start < n {
        ahead.advance(w, &kept, start, ctx.textured);
        let end = run_end(&w.queues.shade, start, &w.paths.materials, |i| {
            super::intersect::is_curve(&w.paths.hits[i])
        });
        let first = sort::index(w.queues.shade[start]);
        if super::intersect::is_curve(&w.paths.hits[first as usize]) {
            super::shade_curves::vertex(ctx, w, &mut fibres, first, rays);
        } else {
            run(ctx, w, &kept, &mut slots, start, end, rays);
        }
        start = end;
    }
    super::shade_curves::flush(ctx, w, &mut fibres, rays);
    if w.kernels.scatter_points > 0 {
        scatter(ctx, w, rays);
    }
    w.paths.surfaces = kept;
    rays.shadow += (w.queues.occlusion.len() - shadow_rays_before) as u64;
}

/// Software prefetch of what shading reads by sorted index, in two steps ([`super::prefetch`]): the
/// path states, hits and surface slots [`FAR`] queue positions ahead, then, [`NEAR`] positions
/// ahead (those states now in cache), each path's kept surface and, at its first bounce, its
/// first-hit record. Without it the first reads of `w.paths.hits[i]` / `w.paths.states[i]` in [`run_end`] and
/// [`prepare`] were the stage's hottest lines (misses: a wave holds 4096 paths).
#[derive(Default)]
struct Lookahead {
    /// Queue positions below these were prefetched by the far and the near step.
    far: usize,
    near: usize,
}

/// Queue positions ahead of the run being shaded: about one run (eight hits, a few thousand
/// instructions) for the near step, one more for the far one.
const NEAR: usize = 2 * LANES;
const FAR: usize = NEAR + LANES;

impl Lookahead {
    fn advance(&mut self, w: &StageParts<'_>, kept: &[Surface], start: usize, textured: bool) {
        let queue = &w.queues.shade;
        let far_end = (start + FAR).min(queue.len());
        for &e in &queue[self.far.min(far_end)..far_end] {
            let i = sort::index(e) as usize;
            prefetch::entry(&w.paths.states, i);
            prefetch::entry(&w.paths.hits, i);
            if textured {
                prefetch::entry(&w.paths.surface_slot, i);
            }
        }
        self.far = self.far.max(far_end);
        let near_end = (start + NEAR).min(queue.len());
        for &e in &queue[self.near.min(near_end)..near_end] {
            let i = sort::index(e) as usize;
            if textured {
                let slot = w.paths.surface_slot[i];
                if slot != NO_SURFACE {
                    prefetch::entry(kept, slot as usize);
                }
            }
            if w.paths.states[i].bounces == 0 {
                prefetch::entry(&w.paths.first_hits, i);
            }
        }
        self.near = self.near.max(near_end);
    }
}

/// The end of the run starting at queue position `start`: a curve or point hit alone (`curve(i)`
/// of its path `i`), else up to eight consecutive triangle hits on one material (`materials` by
/// path; the queue is grouped by material, so runs are full but at a material's last hits).
pub(super) fn run_end(
    queue: &[sort::ShadeEntry],
    start: usize,
    materials: &[u32],
    curve: impl Fn(usize) -> bool,
) -> usize {
    let path = |pos: usize| sort::index(queue[pos]) as usize;
    if curve(path(start)) {
        return start + 1;
    }
    let material = materials[path(start)];
    let mut end = start + 1;
    while end < queue.len() && end - start < LANES && materials[path(end)] == material && !curve(path(end)) {
        end += 1;
    }
    end
}

/// Phase 1 for the run of triangle hits at queue positions `start..end` (one material, at most
/// eight): their surfaces (kept by the sort key, or built here together, in lanes, into
/// [`RunSlots`]), their material program in lanes ([`material_lanes::evaluate_lanes`]; a lone hit runs the
/// scalar program), then per hit [`prepare`] into the scatter group, which runs as soon as it is
/// full. A degenerate triangle (no surface) ends its path here, as in the scalar integrator.
///
/// Phase 1 used to run in chunks of 256 hits, each pass over the whole chunk (surfaces into the
/// worker's surface table, programs into a per-chunk `Vec<Option<ShadingInputs>>`, then per hit):
/// 256 surfaces of 200 bytes and their inputs left L1 between the passes. See the module docs for
/// the figures.
fn run<T: Touch>(
    ctx: &Context<'_, '_, T>,
    w: &mut StageParts<'_>,
    kept: &[Surface],
    run_slots: &mut RunSlots,
    start: usize,
    end: usize,
    rays: &mut RayCounts,
) {
    let scene: &Scene = ctx.scene;
    let (filter, touch) = (ctx.settings.filter, ctx.touch);
    let RunSlots { built, inputs } = run_slots;
    let group = &mut *w.kernels.surface_group;
    // The members the sort key kept no surface for are built together, eight lanes at a time
    // ([`surface_lanes`]), into `built` in member order.
    let (mut paths, mut slots, mut built_at) = ([0u32; LANES], [NO_SURFACE; LANES], [0usize; LANES]);
    let mut count = end - start;
    group.clear();
    for (m, &e) in w.queues.shade[start..end].iter().enumerate() {
        let i = sort::index(e);
        let slot = if ctx.textured { w.paths.surface_slot[i as usize] } else { NO_SURFACE };
        (paths[m], slots[m]) = (i, slot);
        if slot == NO_SURFACE {
            let (hit, st) = (&w.paths.hits[i as usize], &w.paths.states[i as usize]);
            group.push(hit, -st.dir, st.cone().width_at(hit.t));
        }
    }
    if !group.is_empty() {
        surface_lanes::surfaces(scene, group, |k, s| built[k] = s);
        group.clear();
        // Keep the members with a surface (a degenerate triangle has none: its path ends here, as
        // in the scalar integrator), in place, and note where each built one is.
        let (mut with_surface, mut next_built) = (0, 0);
        for m in 0..count {
            if slots[m] == NO_SURFACE {
                next_built += 1;
                if built[next_built - 1].is_none() {
                    continue;
                }
                built_at[with_surface] = next_built - 1;
            }
            (paths[with_surface], slots[with_surface]) = (paths[m], slots[m]);
            with_surface += 1;
        }
        count = with_surface;
    }
    w.stats.clock.lap(Phase::Shading);
    if count == 0 {
        return;
    }
    let built = &*built;
    // Each member's surface resolved once (kept or built), not per use below. Filled by a loop:
    // `array::from_fn` stayed out of line here (+1.8 M instructions on the shading-heavy scene).
    // Lanes past `count` are not read.
    let surface = |k: usize| match slots[k] {
        NO_SURFACE => built[built_at[k]].as_ref().expect("a member without a kept surface has a built one"),
        slot => &kept[slot as usize],
    };
    let mut surfaces = [surface(0); LANES];
    for (k, s) in surfaces.iter_mut().enumerate().take(count).skip(1) {
        *s = surface(k);
    }
    let material = surfaces[0].material;
    if count == 1 {
        inputs[0] = scene.shade(surfaces[0], filter, touch);
    } else {
        let mut at = [&surfaces[0].uv; LANES];
        for (at, s) in at.iter_mut().zip(&surfaces).take(count).skip(1) {
            *at = &s.uv;
        }
        material_lanes::evaluate_lanes(
            &scene.shading,
            material,
            &at[..count],
            filter,
            touch,
            &mut w.kernels.registers,
            inputs,
        );
    }
    w.stats.clock.shader_evaluations += count as u64;
    if w.stats.clock.enabled() {
        w.stats.clock.lap(if w.tables.textured_materials[material as usize] {
            Phase::Texturing
        } else {
            Phase::Shading
        });
    }
    for ((&path, &s), inputs) in paths.iter().zip(&surfaces).zip(inputs.iter()).take(count) {
        prepare(ctx, w, path, s, inputs, rays);
        if w.kernels.scatter_points == LANES {
            scatter(ctx, w, rays);
        }
    }
    w.stats.clock.lap(Phase::Integration);
}

/// Where a run's surfaces (those the sort key did not keep) and shading inputs are written: one set
/// per shade stage, reused by every run, so that each surface and each lane's inputs are written
/// once, where they are read from (no per-run initialisation, no copy of a returned array).
///
/// They used to be a per-run stack array of surfaces, cleared per run, and the material program's
/// 640-byte array of returned inputs (a lone hit broadcast its inputs into all eight lanes); see the
/// module docs for the figures.
struct RunSlots {
    /// Surfaces built in [`run`], by position in the run.
    built: [Option<Surface>; LANES],
    /// The run's shading inputs, by position in the run; lanes past the run hold stale values.
    inputs: [ShadingInputs; LANES],
}

/// A run member whose surface is not kept by the sort key (`PathPool::surface_slot`).
const NO_SURFACE: u32 = u32::MAX;

/// Phase 1 for one hit `i` on surface `s` with shading inputs `inputs`.
fn prepare<T: Touch>(
    ctx: &Context<'_, '_, T>,
    w: &mut StageParts<'_>,
    i: u32,
    s: &Surface,
    inputs: &ShadingInputs,
    rays: &mut RayCounts,
) {
    let scene: &Scene = ctx.scene;
    let max_depth = ctx.settings.max_depth;
    let hit = &w.paths.hits[i as usize];
    let st = &mut w.paths.states[i as usize];
    let wo = -st.dir;
    let footprint = st.cone().width_at(hit.t);

    let opacity = inputs.effective_opacity();
    // The vertex's other random numbers are drawn in lanes in phase 2; this one decides phase 1.
    let key = SampleKey { pixel: st.pixel, sample: st.sample, seed: ctx.sampling.seed };
    if opacity < 1.0 && sample_1d(key, st.vertex, dim::OPACITY) >= opacity {
        if inputs.refracts() {
            // Glass: the whole vertex per hit, with the scalar integrator's code and numbers.
            let hit = *hit;
            super::shade_curves::glass_vertex(ctx, w, i, s, &hit, inputs, rays);
            return;
        }
        let origin = offset_ray_origin(s.p, -s.ng);
        if st.pass_through(hit.t, footprint, origin, max_depth) {
            rays.bounce += 1;
            w.queues.next_rays.push(i);
        }
        return;
    }
    let ns = match inputs.normal {
        Some(n) => Scene::mapped_normal(s, n, wo),
        None => s.ns,
    };
    // The first hit's albedo comes from the BSDF, built in lanes in phase 2 (here only when the
    // path ends at this hit).
    let first = &mut w.paths.first_hits[i as usize];
    // (`bounces` first: most hits are past the first bounce, and the first-hit table is read by
    // sorted index.)
    let is_first = st.bounces == 0 && first.is_none();
    if is_first {
        // Field by field: assigned whole, the `Option` was assembled on the stack by 4- and 8-byte
        // stores and copied out with 16-byte loads, which cannot be forwarded from those stores
        // (a store-forwarding stall: this line was ~20-30 % of the stage's own samples on the
        // tractor, perf, 1 thread).
        let record = first.insert(FirstHit::default());
        record.normal = ns;
        record.depth = st.travelled + hit.t;
        if ctx.aov.is_some() {
            w.paths.aov.first_hit(scene, i as usize, s, (hit.instance, st.time, ctx.settings.shutter));
        }
    }
    let le = inputs.emissive_color.max(Vec3::ZERO);
    if le != Vec3::ZERO {
        let mis = match st.prev() {
            None => 1.0,
            Some((p, bsdf_pdf)) => power_heuristic(bsdf_pdf, scene.lights.triangle_pdf(hit.triangle, p, s.p)),
        };
        let emitted = st.beta * le * mis;
        st.radiance += emitted;
        if let Some(mut k) = ctx.aov.and_then(|plan| w.paths.aov.sink(plan, i as usize)) {
            k.add_object(k.state, emitted);
        }
    }
    if st.bounces >= max_depth {
        if let (true, Some(first)) = (is_first, first.as_mut()) {
            first.albedo = Bsdf::from_inputs(inputs, ns, s.ng).diffuse_albedo();
        }
        return;
    }
    // The lobe this vertex chooses, labelling its light sample and its continuation: the scalar
    // integrator's [`crate::scalar::lobe_event`] of the scalar BSDF and the same lobe sample (the
    // lanes build their BSDFs in phase 2; an AOV render pays one scalar BSDF per hit for it).
    if ctx.aov.is_some_and(|p| p.lpe.is_some()) {
        let key = SampleKey { pixel: st.pixel, sample: st.sample, seed: ctx.sampling.seed };
        let bsdf = crate::surface::SurfaceBsdf::Preview(Bsdf::from_inputs(inputs, ns, s.ng));
        let u_lobe = sample_1d(key, st.vertex, dim::LOBE);
        w.paths.aov.lobe[i as usize] = crate::scalar::lobe_event(&bsdf, inputs, wo, s.ng, u_lobe, None);
    }

    let (beta, play) = (st.beta, (st.bounces + 1 >= RR_START_BOUNCE) as u32);
    let (g, k) = (&mut *w.kernels.scatter, w.kernels.scatter_points);
    // One check for the lane instead of one per column store below (the compiler cannot see that
    // `scatter` runs as soon as the group is full).
    assert!(k < LANES, "the scatter group runs when full");
    g.index[k] = i;
    g.first[k] = is_first as u32;
    g.firsts += is_first as u32;
    g.inputs.set_inputs(k, inputs, ns, s.ng);
    (g.bsdf.wo[0][k], g.bsdf.wo[1][k], g.bsdf.wo[2][k]) = (wo.x, wo.y, wo.z);
    (g.light.p[0][k], g.light.p[1][k], g.light.p[2][k]) = (s.p.x, s.p.y, s.p.z);
    (g.keys.pixel[k], g.keys.sample[k], g.keys.vertex[k]) = (st.pixel, st.sample, st.vertex);
    (g.beta[0][k], g.beta[1][k], g.beta[2][k]) = (beta.x, beta.y, beta.z);
    g.footprint[k] = footprint;
    g.play[k] = play;
    if let Some(links) = scene.lights.links() {
        g.light_set[k] = links.set_of(hit.triangle);
    }
    w.kernels.scatter_points += 1;
}

/// `out[k]` = the pass-through seed of lane `k`'s shadow ray, `hash_combine(hash_combine(seed_hash,
/// pixel), sample) ^ vertex` as the scalar integrator draws it: eight lanes at once (AVX2
/// `vpmulld`) instead of two scalar hash chains per kept shadow ray (1.78 M instructions on
/// shading-heavy at 120×80, 8 spp, one thread). Lanes past the group's points hash stale keys.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
fn shadow_seed_lanes(seed_hash: u32, keys: &KeyLanes, out: &mut [u32; LANES]) {
    for k in 0..LANES {
        out[k] = shadow_seed(seed_hash, keys.pixel[k], keys.sample[k], keys.vertex[k]);
    }
}

/// `|n · w|` per lane (glam's `dot` order), the cosine the estimators weigh by.
#[inline(always)]
fn abs_cos_lanes(n: &Lanes3, w: &Lanes3, out: &mut Lanes) {
    for (k, cos) in out.iter_mut().enumerate() {
        *cos = V::at(n, k).dot(V::at(w, k)).abs();
    }
}

/// Phase 2, run as soon as phase 1 has filled the scatter group (and on the chunk's last hits), so
/// the group stays in L1: the lane kernels over its points. The light sample
/// ([`light_lanes::sample_lanes`]; textured emitters read per lane), the BSDF towards it and the MIS
/// weight (kept samples enter the occlusion queue), then the BSDF sample, throughput and roulette.
// Lane loops index several columns by the same lane number.
#[allow(clippy::needless_range_loop)]
fn scatter<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut StageParts<'_>, rays: &mut RayCounts) {
    let scene: &Scene = ctx.scene;
    let table = (!scene.lights.is_empty()).then(|| scene.light_table());
    let (filter, touch) = (ctx.settings.filter, ctx.touch);
    let seed_hash = hash_u32(ctx.sampling.seed);
    let KernelScratch { scatter, scatter_points, .. } = &mut *w.kernels;
    let PathPool { states, first_hits, shadow, prev_light_set, aov, .. } = &mut *w.paths;
    let linked = scene.lights.links().is_some();
    let StageQueues { occlusion, next_rays, .. } = &mut *w.queues;
    let WorkerStats { counters, clock, .. } = &mut *w.stats;
    // `min`: the lane loops below then index the group's columns without bounds checks
    // (`scatter_points` never exceeds `LANES`).
    let (g, len) = (&mut **scatter, std::mem::take(scatter_points).min(LANES));
    // Without lights every lane's sample stays absent (these zeros are never read).
    let mut ls = LightSampleLanes::default();
    let KernelLanes {
        eval: ev,
        sample: smp,
        nee: nl,
        nee_out: nout,
        roulette: rl,
        roulette_out: rout,
        origin,
    } = &mut g.out;
    let at = |c: &Lanes3, k: usize| Vec3::new(c[0][k], c[1][k], c[2][k]);

    // The vertex's random numbers, eight paths at a time, straight into the kernels' columns.
    let mut u = [[0.0; LANES]; DIMS];
    sampler_lanes::vertex_lanes(seed_hash, &g.keys, &mut u);
    let d = |d: u32| u[d as usize];
    (g.light.u_select, g.light.u) = (d(dim::LIGHT_SELECT), [d(dim::LIGHT_UV), d(dim::LIGHT_UV + 1)]);
    (g.u.u_lobe, g.u.u0, g.u.u1) = (d(dim::LOBE), d(dim::BSDF_UV), d(dim::BSDF_UV + 1));
    g.u_rr = d(dim::RUSSIAN_ROULETTE);

    // The BSDFs, the first hits' albedos, and the origin of both rays leaving each hit.
    bsdf_lanes::from_inputs_lanes(&g.inputs, &mut g.bsdf);
    if std::mem::take(&mut g.firsts) > 0 {
        for k in 0..len {
            if g.first[k] != 0 {
                if let Some(first) = first_hits[g.index[k] as usize].as_mut() {
                    first.albedo = at(&g.bsdf.diffuse, k);
                }
            }
        }
    }
    crate::accel::ray::offset_origin_lanes(&g.light.p, &g.bsdf.ng, origin);

    // Next-event estimation: the light sample, the BSDF towards it, the MIS weight.
    let mut has_light = [false; LANES];
    // The light each lane's shadow ray goes to, with light sets (shadow linking).
    let mut light_of = [blob::NONE; LANES];
    if let Some(table) = table {
        light_lanes::sample_lanes(table, &g.light, &mut ls);
        // Once per group, not per lane: most scenes have no textured dome.
        let textured_dome = scene.lights.has_textured_dome();
        for k in 0..len {
            // Textured domes sample by their map on the scalar path (the kernel has no map lookups).
            if textured_dome && scene.lights.is_textured_dome(g.light.u_select[k]) {
                let u = [g.light.u[0][k], g.light.u[1][k]];
                let s = scene.lights.sample(at(&g.light.p, k), g.light.u_select[k], u);
                ls.ok[k] = s.is_some() as u32;
                if let Some(s) = s {
                    for c in 0..3 {
                        (ls.wi[c][k], ls.li[c][k]) = (s.wi[c], s.li[c]);
                    }
                    (ls.distance[k], ls.pdf[k], ls.delta[k]) = (s.distance, s.pdf, 0);
                    ls.triangle[k] = blob::NONE;
                }
            }
            if ls.ok[k] == 0 {
                continue;
            }
            // Light linking: the scalar integrator's choice of the light, dropped where it does
            // not light the point (before its emission is looked up, as there).
            if let Some(choice) =
                scene.lights.linked_choice(g.light_set[k], at(&g.light.p, k), g.light.u_select[k])
            {
                match choice {
                    Some(l) => light_of[k] = l as u32,
                    None => continue,
                }
            }
            has_light[k] = true;
            if ls.triangle[k] != blob::NONE {
                let li = scene.emission_at(ls.triangle[k], ls.b[0][k], ls.b[1][k], filter, touch);
                (ls.li[0][k], ls.li[1][k], ls.li[2][k]) = (li.x, li.y, li.z);
            }
        }
    }
    counters.bsdf_lane_groups += 1;
    counters.bsdf_lanes_active += len as u64;
    counters.light_lanes_active += has_light.iter().filter(|&&h| h).count() as u64;
    bsdf_lanes::eval_lanes(&g.bsdf, &ls.wi, ev);
    (nl.beta, nl.f, nl.li) = (g.beta, ev.f, ls.li);
    (nl.light_pdf, nl.bsdf_pdf, nl.delta) = (ls.pdf, ev.pdf, ls.delta);
    abs_cos_lanes(&g.bsdf.n, &ls.wi, &mut nl.cos);
    lanes::weigh_lanes(nl, nout);
    let mut seeds = [0; LANES];
    shadow_seed_lanes(seed_hash, &g.keys, &mut seeds);
    for k in 0..len {
        if !has_light[k] || nout.keep[k] == 0 {
            continue;
        }
        let (i, p, origin) = (g.index[k] as usize, at(&g.light.p, k), at(origin, k));
        shadow[i] = ShadowRay {
            origin,
            dir: at(&ls.wi, k),
            tmax: shadow_tmax(ls.distance[k], origin, p),
            contribution: at(&nout.contribution, k),
            seed: seeds[k],
            delta: ls.delta[k] != 0,
            light: light_of[k],
        };
        occlusion.push(i as u32);
        if let Some(plan) = ctx.aov {
            let lobe = aov.lobe[i];
            let emitter = ls.triangle[k] != blob::NONE;
            aov.light_sample(plan, scene, i, lobe, (emitter, p, g.light.u_select[k]));
        }
    }

    // BSDF sampling, throughput and Russian roulette: the continuation rays.
    bsdf_lanes::sample_lanes(&g.bsdf, &g.u, smp);
    (rl.beta, rl.f, rl.pdf, rl.u, rl.play) = (g.beta, smp.f, smp.pdf, g.u_rr, g.play);
    abs_cos_lanes(&g.bsdf.n, &smp.wi, &mut rl.cos);
    roulette::continue_lanes(rl, rout);
    for k in 0..len {
        if smp.ok[k] == 0 {
            continue;
        }
        let p = at(&g.light.p, k);
        let st = &mut states[g.index[k] as usize];
        st.beta = at(&rout.beta, k);
        st.prev_p = p;
        st.prev_pdf = smp.pdf[k];
        if linked {
            prev_light_set[g.index[k] as usize] = g.light_set[k];
        }
        if let Some(plan) = ctx.aov {
            aov.scatter(plan, g.index[k] as usize);
        }
        st.bounces += 1;
        if rout.alive[k] == 0 {
            continue;
        }
        st.vertex += 1;
        st.origin = at(origin, k);
        st.dir = at(&smp.wi, k);
        st.travelled = 0.0;
        st.cone_width = g.footprint[k];
        st.cone_spread += CONE_WIDEN_PER_ALPHA * smp.lobe_alpha[k];
        rays.bounce += 1;
        next_rays.push(g.index[k]);
    }
    clock.lap(Phase::Integration);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadow_seed_lanes_equal_the_scalar_seeds() {
        let mut rng = crate::sampler::hash_u32(17);
        let mut next = || {
            rng = crate::sampler::hash_u32(rng.wrapping_add(1));
            rng
        };
        for _ in 0..100 {
            let seed_hash = next();
            let mut keys = KeyLanes::default();
            for k in 0..LANES {
                (keys.pixel[k], keys.sample[k], keys.vertex[k]) = (next(), next() % 4096, next() % 64);
            }
            let mut seeds = [0; LANES];
            shadow_seed_lanes(seed_hash, &keys, &mut seeds);
            for (k, &seed) in seeds.iter().enumerate() {
                let scalar = crate::sampler::hash_combine(
                    crate::sampler::hash_combine(seed_hash, keys.pixel[k]),
                    keys.sample[k],
                ) ^ keys.vertex[k];
                assert_eq!(seed, scalar, "lane {k}");
            }
        }
    }

    #[test]
    fn runs_cover_the_queue_once_in_order_with_one_material_and_no_curves() {
        // 200 paths, listed in a shuffled order and grouped by material as the sort leaves them;
        // every seventh path hit a curve.
        let materials: Vec<u32> = (0..200u32).map(|i| crate::sampler::hash_u32(i) % 4).collect();
        let curve = |i: usize| i % 7 == 3;
        let mut queue: Vec<u64> =
            (0..200u32).map(|i| sort::entry(crate::sampler::hash_u32(i ^ 5), i)).collect();
        queue.sort_by_key(|&e| (materials[sort::index(e) as usize], sort::key(e)));
        let mut seen = Vec::new();
        let mut start = 0;
        while start < queue.len() {
            let end = run_end(&queue, start, &materials, curve);
            assert!(end > start && end - start <= LANES, "run {start}..{end}");
            let run: Vec<usize> = queue[start..end].iter().map(|&e| sort::index(e) as usize).collect();
            if curve(run[0]) {
                assert_eq!(run.len(), 1, "a curve hit is shaded alone");
            } else {
                assert!(run.iter().all(|&i| !curve(i) && materials[i] == materials[run[0]]), "{run:?}");
                // A run stops short of eight only at a material's end or before a curve hit.
                if run.len() < LANES && end < queue.len() {
                    let next = sort::index(queue[end]) as usize;
                    assert!(curve(next) || materials[next] != materials[run[0]]);
                }
            }
            seen.extend(run);
            start = end;
        }
        let queued: Vec<usize> = queue.iter().map(|&e| sort::index(e) as usize).collect();
        assert_eq!(seen, queued, "every queued path once, in queue order");
    }
}

//! Stage 4: shading. Reads the sorted shade queue (one segment per material) and the hit side table;
//! writes the occlusion queue, the shadow-ray side table and the next ray queue.
//!
//! The queue is shaded in chunks of [`CHUNK`] hits, each in these phases:
//! 1a. per hit: the surface (or the one the sort key kept; both stay in the worker's surface table
//!    and the chunk holds slots); then runs of up to eight consecutive hits on one material (the
//!    queue is sorted by material) through the material program in lanes
//!    ([`material_lanes::evaluate_lanes`]; a lone hit runs the scalar program);
//! 1. per hit (scalar, material by material): stochastic transparency, the normal map, emission at
//!    the hit (the depth limit ends paths here), then its shading inputs, normals and sampler keys
//!    written straight into lane `k` of the AoSoA [`ScatterGroup`]; curve and point hits take their
//!    whole vertex per hit ([`super::shade_curves`]);
//! 2. as soon as the group holds eight points (and for the chunk's last ones), its lane kernels:
//!    the vertex's random numbers ([`sampler_lanes`]), the BSDFs ([`bsdf_lanes::from_inputs_lanes`]) and the first-hit albedos, the ray origins off
//!    the surfaces ([`lanes::offset_origin_lanes`]), the light sample ([`light_lanes::sample_lanes`];
//!    textured emitters per lane), the BSDF towards it ([`bsdf_lanes::eval_lanes`]), the MIS weight
//!    ([`lanes::weigh_lanes`]; kept samples enter the occlusion queue), the BSDF sample
//!    ([`bsdf_lanes::sample_lanes`]) and the throughput update with Russian roulette
//!    ([`roulette::continue_lanes`]); surviving paths enter the next ray queue.
//!
//! Nothing is transposed between phases 1 and 2: phase 1 writes each hit's values into its lane
//! (they are at hand there), and the group (~2 KiB) is consumed while it is still in L1. See the
//! module docs of [`super`] for what each step saved.

use super::bsdf_lanes::{self, BsdfLanes, EvalLanes, InputLanes, Lanes, Lanes3, SampleInputs, SampleLanes};
use super::lanes::{self, NeeLanes, NeeOut, LANES};
use super::light_lanes::{self, LightInputs, LightSampleLanes};
use super::material_lanes;
use super::roulette::{self, RouletteLanes, RouletteOut};
use super::sampler_lanes::{self, KeyLanes, DIMS};
use super::{sort, Context, ShadowRay, Worker};
use crate::accel::offset_ray_origin;
use crate::bsdf::Bsdf;
use crate::integrator::{shadow_tmax, FirstHit, RayCounts, Surface, CONE_WIDEN_PER_ALPHA, RR_START_BOUNCE};
use crate::lights::power_heuristic;
use crate::sampler::{dim, hash_combine, hash_u32, sample_1d, SampleKey};
use crate::scene::Scene;
use crate::stats::Phase;
use glam::Vec3;
use texture::Touch;

/// Hits per shading chunk (phase 1 then phase 2).
pub const CHUNK: usize = 256;

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
}

/// Shades every queued hit, in chunks.
pub(super) fn shade<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, rays: &mut RayCounts) {
    w.next_rays.clear();
    w.occlusion.clear();
    let n = w.shade.len();
    // The surfaces the sort kept; each chunk appends its rebuilt ones after them and drops them when
    // done, so their memory is reused chunk after chunk (it stays in L2).
    let kept = w.surfaces.len();
    let mut start = 0;
    while start < n {
        let end = (start + CHUNK).min(n);
        surfaces(ctx, w, start, end);
        programs(ctx, w);
        for (pos, k) in (start..end).enumerate() {
            let i = sort::index(w.shade[k]);
            if super::intersect::is_curve(&w.hits[i as usize]) {
                super::shade_curves::vertex(ctx, w, i, rays);
            } else {
                prepare(ctx, w, i, pos, rays);
                if w.scatter_points == LANES {
                    scatter(ctx, w, rays);
                }
            }
        }
        if w.scatter_points > 0 {
            scatter(ctx, w, rays);
        }
        w.surfaces.truncate(kept);
        start = end;
    }
    rays.shadow += w.occlusion.len() as u64;
}

/// Phase 1a, first half: the chunk's surfaces, kept by the sort key or rebuilt per hit (a lane version
/// executed 1.8× the instructions of these calls; see the module docs of [`super`]). Rebuilt ones join
/// the kept ones in `w.surfaces` until the chunk ends (a wave has at most one per path, so it never
/// grows past its capacity) and the chunk records slots: a surface (~250 bytes) is written once and
/// never moved.
fn surfaces<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, start: usize, end: usize) {
    let scene: &Scene = ctx.scene;
    w.chunk_slots.clear();
    for &e in &w.shade[start..end] {
        let i = sort::index(e) as usize;
        let (hit, st) = (&w.hits[i], &w.states[i]);
        if super::intersect::is_curve(hit) {
            // Curve and point hits build their own surface in `shade_curves`.
            w.chunk_slots.push(NO_SURFACE);
            continue;
        }
        let kept = if ctx.textured { w.surface_slot[i] } else { NO_SURFACE };
        let slot = if kept != NO_SURFACE {
            kept
        } else if let Some(s) = scene.surface(hit, -st.dir, st.cone().width_at(hit.t)) {
            w.surfaces.push(Some(s));
            (w.surfaces.len() - 1) as u32
        } else {
            NO_SURFACE // a degenerate triangle
        };
        w.chunk_slots.push(slot);
    }
    w.clock.lap(Phase::Shading);
}

/// A chunk slot without a surface: a curve or point hit, or a degenerate triangle.
const NO_SURFACE: u32 = u32::MAX;

/// The surface in chunk slot `slot`.
#[inline]
fn slot_surface(surfaces: &[Option<Surface>], slot: u32) -> Option<&Surface> {
    surfaces.get(slot as usize).and_then(Option::as_ref)
}

/// Phase 1a, second half: the material programs of the chunk's surfaces, run by run of up to eight
/// consecutive hits on one material (a lone hit runs the scalar program).
fn programs<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker) {
    let scene: &Scene = ctx.scene;
    let n = w.chunk_slots.len();
    w.chunk_inputs.clear();
    w.chunk_inputs.resize(n, None);
    let (filter, touch) = (ctx.settings.filter, ctx.touch);
    let mut pos = 0;
    while pos < n {
        let Some(material) = slot_surface(&w.surfaces, w.chunk_slots[pos]).map(|s| s.material) else {
            pos += 1;
            continue;
        };
        // The run: up to eight hits on `material` from `pos` on (degenerate hits skipped).
        let (mut members, mut count) = ([0usize; LANES], 0);
        while pos < n && count < LANES {
            match slot_surface(&w.surfaces, w.chunk_slots[pos]) {
                Some(s) if s.material != material => break,
                Some(_) => {
                    members[count] = pos;
                    count += 1;
                }
                None => {}
            }
            pos += 1;
        }
        let surface =
            |k: usize| slot_surface(&w.surfaces, w.chunk_slots[members[k]]).expect("members have surfaces");
        if count == 1 {
            w.chunk_inputs[members[0]] = Some(scene.shade(surface(0), filter, touch));
        } else {
            let at: [&crate::shading::UvFootprint; LANES] =
                std::array::from_fn(|k| &surface(k.min(count - 1)).uv);
            let inputs = material_lanes::evaluate_lanes(
                &scene.shading,
                material,
                &at[..count],
                filter,
                touch,
                &mut w.registers,
            );
            for k in 0..count {
                w.chunk_inputs[members[k]] = Some(inputs[k]);
            }
        }
        w.clock.shader_evaluations += count as u64;
        if w.clock.enabled() {
            w.clock.lap(if w.textured_materials[material as usize] {
                Phase::Texturing
            } else {
                Phase::Shading
            });
        }
    }
}

/// Phase 1 for one hit, the `pos`-th of its chunk.
fn prepare<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, i: u32, pos: usize, rays: &mut RayCounts) {
    let scene: &Scene = ctx.scene;
    let max_depth = ctx.settings.max_depth;
    let hit = w.hits[i as usize];
    let st = &mut w.states[i as usize];
    let wo = -st.dir;
    let footprint = st.cone().width_at(hit.t);
    let (Some(s), Some(inputs)) = (slot_surface(&w.surfaces, w.chunk_slots[pos]), w.chunk_inputs[pos]) else {
        return;
    };

    let opacity = inputs.effective_opacity();
    // The vertex's other random numbers are drawn in lanes in phase 2; this one decides phase 1.
    let key = SampleKey { pixel: st.pixel, sample: st.sample, seed: ctx.options.seed };
    if opacity < 1.0 && sample_1d(key, st.vertex, dim::OPACITY) >= opacity {
        let origin = offset_ray_origin(s.p, -s.ng);
        if st.pass_through(hit.t, footprint, origin, max_depth) {
            rays.bounce += 1;
            w.next_rays.push(i);
        }
        return;
    }
    let ns = match inputs.normal {
        Some(n) => Scene::mapped_normal(s, n, wo),
        None => s.ns,
    };
    // The first hit's albedo comes from the BSDF, built in lanes in phase 2 (here only when the
    // path ends at this hit).
    let first = &mut w.first_hits[i as usize];
    let is_first = first.is_none() && st.bounces == 0;
    if is_first {
        *first = Some(FirstHit { albedo: Vec3::ZERO, normal: ns, depth: st.travelled + hit.t });
    }
    let le = inputs.emissive_color.max(Vec3::ZERO);
    if le != Vec3::ZERO {
        let mis = match st.prev() {
            None => 1.0,
            Some((p, bsdf_pdf)) => power_heuristic(bsdf_pdf, scene.lights.triangle_pdf(hit.triangle, p, s.p)),
        };
        st.radiance += st.beta * le * mis;
    }
    if st.bounces >= max_depth {
        if let (true, Some(first)) = (is_first, first.as_mut()) {
            first.albedo = Bsdf::from_inputs(&inputs, ns, s.ng).diffuse_albedo();
        }
        return;
    }

    let (beta, play) = (st.beta, (st.bounces + 1 >= RR_START_BOUNCE) as u32);
    let (g, k) = (&mut *w.scatter, w.scatter_points);
    g.index[k] = i;
    g.first[k] = is_first as u32;
    g.inputs.set(k, &inputs, ns, s.ng);
    (g.bsdf.wo[0][k], g.bsdf.wo[1][k], g.bsdf.wo[2][k]) = (wo.x, wo.y, wo.z);
    (g.light.p[0][k], g.light.p[1][k], g.light.p[2][k]) = (s.p.x, s.p.y, s.p.z);
    (g.keys.pixel[k], g.keys.sample[k], g.keys.vertex[k]) = (st.pixel, st.sample, st.vertex);
    (g.beta[0][k], g.beta[1][k], g.beta[2][k]) = (beta.x, beta.y, beta.z);
    g.footprint[k] = footprint;
    g.play[k] = play;
    w.scatter_points += 1;
    w.clock.lap(Phase::Integration);
}

/// `|n · w|` per lane (glam's `dot` order), the cosine the estimators weigh by.
#[inline(always)]
fn abs_cos_lanes(n: &Lanes3, w: &Lanes3, out: &mut Lanes) {
    for k in 0..LANES {
        out[k] = ((n[0][k] * w[0][k] + n[1][k] * w[1][k]) + n[2][k] * w[2][k]).abs();
    }
}

/// Phase 2, run as soon as phase 1 has filled the scatter group (and on the chunk's last hits), so
/// the group stays in L1: the lane kernels over its points. The light sample
/// ([`light_lanes::sample_lanes`]; textured emitters read per lane), the BSDF towards it and the MIS
/// weight (kept samples enter the occlusion queue), then the BSDF sample, throughput and roulette.
// Lane loops index several columns by the same lane number.
#[allow(clippy::needless_range_loop)]
fn scatter<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, rays: &mut RayCounts) {
    let scene: &Scene = ctx.scene;
    let table = (!scene.lights.is_empty()).then(|| scene.lights.lane_table());
    let (filter, touch) = (ctx.settings.filter, ctx.touch);
    let seed_hash = hash_u32(ctx.options.seed);
    let Worker {
        scatter,
        scatter_points,
        states,
        first_hits,
        shadow,
        occlusion,
        next_rays,
        counters,
        clock,
        ..
    } = w;
    let (g, len) = (&mut **scatter, std::mem::take(scatter_points));
    // Without lights every lane's sample stays absent (these zeros are never read).
    let mut ls = LightSampleLanes::default();
    let (mut ev, mut smp) = (EvalLanes::default(), SampleLanes::default());
    let (mut nl, mut nout) = (NeeLanes::default(), NeeOut::default());
    let (mut rl, mut rout) = (RouletteLanes::default(), RouletteOut::default());
    let mut origin = Lanes3::default();
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
    for k in 0..len {
        if g.first[k] != 0 {
            if let Some(first) = first_hits[g.index[k] as usize].as_mut() {
                first.albedo = at(&g.bsdf.diffuse, k);
            }
        }
    }
    lanes::offset_origin_lanes(&g.light.p, &g.bsdf.ng, &mut origin);

    // Next-event estimation: the light sample, the BSDF towards it, the MIS weight.
    let mut has_light = [false; LANES];
    if let Some(table) = table {
        light_lanes::sample_lanes(table, &g.light, &mut ls);
        for k in 0..len {
            // Textured domes sample by their map on the scalar path (the kernel has no map lookups).
            if scene.lights.is_textured_dome(g.light.u_select[k]) {
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
    bsdf_lanes::eval_lanes(&g.bsdf, &ls.wi, &mut ev);
    (nl.beta, nl.f, nl.li) = (g.beta, ev.f, ls.li);
    (nl.light_pdf, nl.bsdf_pdf, nl.delta) = (ls.pdf, ev.pdf, ls.delta);
    abs_cos_lanes(&g.bsdf.n, &ls.wi, &mut nl.cos);
    lanes::weigh_lanes(&nl, &mut nout);
    for k in 0..len {
        if !has_light[k] || nout.keep[k] == 0 {
            continue;
        }
        let (i, p, origin) = (g.index[k] as usize, at(&g.light.p, k), at(&origin, k));
        let st = &states[i];
        shadow[i] = ShadowRay {
            origin,
            dir: at(&ls.wi, k),
            tmax: shadow_tmax(ls.distance[k], origin, p),
            contribution: at(&nout.contribution, k),
            seed: hash_combine(hash_combine(seed_hash, st.pixel), st.sample) ^ st.vertex,
        };
        occlusion.push(i as u32);
    }

    // BSDF sampling, throughput and Russian roulette: the continuation rays.
    bsdf_lanes::sample_lanes(&g.bsdf, &g.u, &mut smp);
    (rl.beta, rl.f, rl.pdf, rl.u, rl.play) = (g.beta, smp.f, smp.pdf, g.u_rr, g.play);
    abs_cos_lanes(&g.bsdf.n, &smp.wi, &mut rl.cos);
    roulette::continue_lanes(&rl, &mut rout);
    for k in 0..len {
        if smp.ok[k] == 0 {
            continue;
        }
        let p = at(&g.light.p, k);
        let st = &mut states[g.index[k] as usize];
        st.beta = at(&rout.beta, k);
        st.prev_p = p;
        st.prev_pdf = smp.pdf[k];
        st.bounces += 1;
        if rout.alive[k] == 0 {
            continue;
        }
        st.vertex += 1;
        st.origin = at(&origin, k);
        st.dir = at(&smp.wi, k);
        st.travelled = 0.0;
        st.cone_width = g.footprint[k];
        st.cone_spread += CONE_WIDEN_PER_ALPHA * smp.lobe_alpha[k];
        rays.bounce += 1;
        next_rays.push(g.index[k]);
    }
    clock.lap(Phase::Integration);
}

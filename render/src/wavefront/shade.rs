//! Stage 4: shading. Reads the sorted shade queue (one segment per material) and the hit side table;
//! writes the occlusion queue, the shadow-ray side table and the next ray queue.
//!
//! The queue is shaded in chunks of [`CHUNK`] hits, each in these phases:
//! 0. eight paths at a time: every random number of the paths' vertices ([`sampler_lanes`]);
//! 1a. per hit: the surface (or the one the sort key kept); then runs of up to eight consecutive hits
//!    on one material (the queue is sorted by material) through the material program in lanes
//!    ([`material_lanes::evaluate_lanes`]; a lone hit runs the scalar program);
//! 1. per hit (scalar, material by material): stochastic transparency, the BSDF, the first-hit AOVs,
//!    emission at the hit, and the path's random numbers, into an AoS [`ScatterPoint`] (the depth
//!    limit ends paths here); curve and point hits take their whole vertex per hit ([`super::shade_curves`]);
//!    then eight points at a time, the light sample and its shadow ray ([`light_lanes`]);
//! 2. eight points at a time, transposed to AoSoA lanes: the BSDF towards the light
//!    ([`bsdf_lanes::eval_lanes`]), the MIS weight ([`lanes::weigh_lanes`], kept samples enter the
//!    occlusion queue), the BSDF sample ([`bsdf_lanes::sample_lanes`]) and the throughput update with
//!    Russian roulette ([`roulette::continue_lanes`]); surviving paths enter the next ray queue.
//!
//! A chunk's scatter points (~200 bytes each) stay in L2 between the phases: MoonRay's AoS → SoA
//! conversion "in cache-sized chunks".

use super::bsdf_lanes::{self, BsdfLanes, EvalLanes, Lanes3, SampleInputs, SampleLanes};
use super::lanes::{self, NeeLanes, NeeOut, LANES};
use super::light_lanes;
use super::material_lanes;
use super::roulette::{self, RouletteLanes, RouletteOut};
use super::sampler_lanes::{self, KeyLanes, DIMS};
use super::{sort, Context, ShadowRay, Worker};
use crate::accel::offset_ray_origin;
use crate::bsdf::Bsdf;
use crate::integrator::{FirstHit, RayCounts, CONE_WIDEN_PER_ALPHA, RR_START_BOUNCE};
use crate::lights::power_heuristic;
use crate::sampler::{dim, hash_u32};
use crate::scene::Scene;
use crate::stats::Phase;
use glam::Vec3;
use texture::Touch;

/// Hits per shading chunk (phase 1 then phase 2).
pub const CHUNK: usize = 256;

/// A shaded hit waiting for the lane kernels: its BSDF, the light sample and the random numbers.
#[derive(Clone, Copy, Debug)]
pub struct ScatterPoint {
    /// Path index.
    pub index: u32,
    /// The BSDF at the hit.
    pub bsdf: Bsdf,
    /// Direction towards the viewer.
    pub wo: Vec3,
    /// Hit point.
    pub p: Vec3,
    /// Cone width at the hit.
    pub footprint: f32,
    /// Lobe choice.
    pub u_lobe: f32,
    /// Direction sample.
    pub u_bsdf: [f32; 2],
    /// Russian roulette sample.
    pub u_rr: f32,
    /// Light choice.
    pub u_light_select: f32,
    /// Position sample on the light.
    pub u_light: [f32; 2],
    /// A light sample exists (the fields below are valid; [`light_lanes`] fills them).
    pub has_light: bool,
    /// Direction to the light.
    pub light_wi: Vec3,
    /// Radiance from the light sample.
    pub light_li: Vec3,
    /// Light pdf.
    pub light_pdf: f32,
    /// Delta light.
    pub light_delta: bool,
    /// Shadow ray origin.
    pub shadow_origin: Vec3,
    /// Shadow ray extent.
    pub shadow_tmax: f32,
    /// Shadow ray pass-through seed.
    pub shadow_seed: u32,
}

/// Shades every queued hit, in chunks.
pub(super) fn shade<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, rays: &mut RayCounts) {
    w.next_rays.clear();
    w.occlusion.clear();
    let n = w.shade.len();
    let mut start = 0;
    while start < n {
        let end = (start + CHUNK).min(n);
        draw(ctx, w, start, end);
        w.clock.lap(Phase::Integration);
        w.scatter.clear();
        surfaces(ctx, w, start, end);
        programs(ctx, w);
        for (pos, k) in (start..end).enumerate() {
            let i = sort::index(w.shade[k]);
            if super::intersect::is_curve(&w.hits[i as usize]) {
                super::shade_curves::vertex(ctx, w, i, pos, rays);
            } else {
                prepare(ctx, w, i, pos, rays);
            }
        }
        light_lanes::sample_scatter_points(ctx, w);
        scatter(w, rays);
        start = end;
    }
    rays.shadow += w.occlusion.len() as u64;
}

/// Phase 0: the random numbers of every queued path's vertex, eight paths at a time.
fn draw<T>(ctx: &Context<'_, '_, T>, w: &mut Worker, start: usize, end: usize) {
    let seed_hash = hash_u32(ctx.options.seed);
    let mut keys = KeyLanes::default();
    w.randoms.clear();
    for group in w.shade[start..end].chunks(LANES) {
        for (k, &e) in group.iter().enumerate() {
            let st = &w.states[sort::index(e) as usize];
            (keys.pixel[k], keys.sample[k], keys.vertex[k]) = (st.pixel, st.sample, st.vertex);
        }
        let mut out = [[0.0; LANES]; DIMS];
        sampler_lanes::vertex_lanes(seed_hash, &keys, &mut out);
        w.randoms.push(out);
    }
}

/// Phase 1a, first half: the chunk's surfaces, kept by the sort key or rebuilt per hit (a lane version
/// executed 1.8× the instructions of these calls; see the module docs of [`super`]).
fn surfaces<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, start: usize, end: usize) {
    let scene: &Scene = ctx.scene;
    w.chunk_surfaces.clear();
    for &e in &w.shade[start..end] {
        let i = sort::index(e) as usize;
        let slot = if ctx.textured { w.surface_slot[i] } else { u32::MAX };
        let kept = if slot != u32::MAX { w.surfaces[slot as usize].take() } else { None };
        let (hit, st) = (&w.hits[i], &w.states[i]);
        if super::intersect::is_curve(hit) {
            // Curve and point hits build their own surface in `shade_curves`.
            w.chunk_surfaces.push(None);
            continue;
        }
        w.chunk_surfaces.push(kept.or_else(|| scene.surface(hit, -st.dir, st.cone().width_at(hit.t))));
    }
    w.clock.lap(Phase::Shading);
}

/// Phase 1a, second half: the material programs of the chunk's surfaces, run by run of up to eight
/// consecutive hits on one material (a lone hit runs the scalar program).
fn programs<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker) {
    let scene: &Scene = ctx.scene;
    let n = w.chunk_surfaces.len();
    w.chunk_inputs.clear();
    w.chunk_inputs.resize(n, None);
    let (filter, touch) = (ctx.settings.filter, ctx.touch);
    let mut pos = 0;
    while pos < n {
        let Some(material) = w.chunk_surfaces[pos].as_ref().map(|s| s.material) else {
            pos += 1;
            continue;
        };
        // The run: up to eight hits on `material` from `pos` on (degenerate hits skipped).
        let (mut members, mut count) = ([0usize; LANES], 0);
        while pos < n && count < LANES {
            match &w.chunk_surfaces[pos] {
                Some(s) if s.material != material => break,
                Some(_) => {
                    members[count] = pos;
                    count += 1;
                }
                None => {}
            }
            pos += 1;
        }
        let surface = |k: usize| w.chunk_surfaces[members[k]].as_ref().expect("members have surfaces");
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
    let r = |d: u32| w.randoms[pos / LANES][d as usize][pos % LANES];
    let wo = -st.dir;
    let footprint = st.cone().width_at(hit.t);
    let (Some(mut s), Some(inputs)) = (w.chunk_surfaces[pos].take(), w.chunk_inputs[pos]) else { return };

    let opacity = inputs.effective_opacity();
    if opacity < 1.0 && r(dim::OPACITY) >= opacity {
        let origin = offset_ray_origin(s.p, -s.ng);
        if st.pass_through(hit.t, footprint, origin, max_depth) {
            rays.bounce += 1;
            w.next_rays.push(i);
        }
        return;
    }
    if let Some(n) = inputs.normal {
        s.ns = Scene::mapped_normal(&s, n, wo);
    }
    let bsdf = Bsdf::from_inputs(&inputs, s.ns, s.ng);
    let first = &mut w.first_hits[i as usize];
    if first.is_none() && st.bounces == 0 {
        *first = Some(FirstHit { albedo: bsdf.diffuse_albedo(), normal: s.ns, depth: st.travelled + hit.t });
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
        return;
    }

    let point = ScatterPoint {
        index: i,
        bsdf,
        wo,
        p: s.p,
        footprint,
        u_lobe: r(dim::LOBE),
        u_bsdf: [r(dim::BSDF_UV), r(dim::BSDF_UV + 1)],
        u_rr: r(dim::RUSSIAN_ROULETTE),
        u_light_select: r(dim::LIGHT_SELECT),
        u_light: [r(dim::LIGHT_UV), r(dim::LIGHT_UV + 1)],
        has_light: false,
        light_wi: Vec3::ZERO,
        light_li: Vec3::ZERO,
        light_pdf: 0.0,
        light_delta: false,
        shadow_origin: Vec3::ZERO,
        shadow_tmax: 0.0,
        shadow_seed: 0,
    };
    w.scatter.push(point);
    w.clock.lap(Phase::Integration);
}

/// Phase 2: the lane kernels over the chunk's scatter points.
#[allow(clippy::needless_range_loop)]
fn scatter(w: &mut Worker, rays: &mut RayCounts) {
    let Worker { scatter, states, shadow, occlusion, next_rays, counters, clock, .. } = w;
    let (mut bl, mut wi, mut u) = (BsdfLanes::default(), Lanes3::default(), SampleInputs::default());
    let (mut ev, mut smp) = (EvalLanes::default(), SampleLanes::default());
    let (mut nl, mut nout) = (NeeLanes::default(), NeeOut::default());
    let (mut rl, mut rout) = (RouletteLanes::default(), RouletteOut::default());
    for group in scatter.chunks(LANES) {
        // Transpose (AoS → AoSoA). Lanes past the group's end keep the previous group's values: their
        // results are never read.
        let mut lights = 0;
        for (k, sp) in group.iter().enumerate() {
            bl.set(k, &sp.bsdf, sp.wo);
            let st = &states[sp.index as usize];
            for c in 0..3 {
                wi[c][k] = sp.light_wi[c];
                nl.beta[c][k] = st.beta[c];
                nl.li[c][k] = sp.light_li[c];
                rl.beta[c][k] = st.beta[c];
            }
            nl.cos[k] = sp.bsdf.frame.n.dot(sp.light_wi).abs();
            nl.light_pdf[k] = sp.light_pdf;
            nl.delta[k] = sp.light_delta as u32;
            u.u_lobe[k] = sp.u_lobe;
            [u.u0[k], u.u1[k]] = sp.u_bsdf;
            rl.u[k] = sp.u_rr;
            rl.play[k] = (st.bounces + 1 >= RR_START_BOUNCE) as u32;
            lights += sp.has_light as u64;
        }
        clock.lap(Phase::Overhead);
        counters.bsdf_lane_groups += 1;
        counters.bsdf_lanes_active += group.len() as u64;
        counters.light_lanes_active += lights;

        // Next-event estimation: BSDF towards the light, then the MIS weight.
        bsdf_lanes::eval_lanes(&bl, &wi, &mut ev);
        nl.f = ev.f;
        nl.bsdf_pdf = ev.pdf;
        lanes::weigh_lanes(&nl, &mut nout);
        for (k, sp) in group.iter().enumerate() {
            if sp.has_light && nout.keep[k] != 0 {
                let contribution =
                    Vec3::new(nout.contribution[0][k], nout.contribution[1][k], nout.contribution[2][k]);
                shadow[sp.index as usize] = ShadowRay {
                    origin: sp.shadow_origin,
                    dir: sp.light_wi,
                    tmax: sp.shadow_tmax,
                    contribution,
                    seed: sp.shadow_seed,
                };
                occlusion.push(sp.index);
            }
        }

        // BSDF sampling, throughput and Russian roulette: the continuation rays.
        bsdf_lanes::sample_lanes(&bl, &u, &mut smp);
        rl.f = smp.f;
        rl.pdf = smp.pdf;
        for k in 0..group.len() {
            let n = group[k].bsdf.frame.n;
            rl.cos[k] = n.dot(Vec3::new(smp.wi[0][k], smp.wi[1][k], smp.wi[2][k])).abs();
        }
        roulette::continue_lanes(&rl, &mut rout);
        for (k, sp) in group.iter().enumerate() {
            if smp.ok[k] == 0 {
                continue;
            }
            let st = &mut states[sp.index as usize];
            st.beta = Vec3::new(rout.beta[0][k], rout.beta[1][k], rout.beta[2][k]);
            st.prev_p = sp.p;
            st.prev_pdf = smp.pdf[k];
            st.bounces += 1;
            if rout.alive[k] == 0 {
                continue;
            }
            st.vertex += 1;
            st.origin = offset_ray_origin(sp.p, sp.bsdf.ng);
            st.dir = Vec3::new(smp.wi[0][k], smp.wi[1][k], smp.wi[2][k]);
            st.travelled = 0.0;
            st.cone_width = sp.footprint;
            st.cone_spread += CONE_WIDEN_PER_ALPHA * smp.lobe_alpha[k];
            rays.bounce += 1;
            next_rays.push(sp.index);
        }
        clock.lap(Phase::Integration);
    }
}

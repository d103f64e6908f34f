//! Shading of curve and point hits inside stage 4 ([`super::shade`]). Their rays leave a fibre
//! from beyond its diameter rather than from an offset along the normal, so these hits skip the
//! triangles' AoS → AoSoA scatter phase and keep the scalar integrator's vertex, in its order, with
//! the scalar sampler's random numbers; the image stays bit for bit the scalar one.
//!
//! Fibre hits are shaded eight at a time: [`vertex`] runs the per-hit part (surface, material,
//! stochastic transparency, emission, the light sample) and parks the hit's hair BSDF in a
//! [`CurveGroup`]; when eight are parked (and at the end of the queue, [`flush`]) the hair lane
//! kernels ([`crate::hair::lanes`]) evaluate the eight light samples and draw the eight
//! continuations, and each hit queues its shadow ray and continuation as before. Points
//! (UsdPreviewSurface with per-point colours) finish their vertex at once, one at a time.
//!
//! `Surface` no longer carries the built hair BSDF (116 of its 248 bytes; now 148 bytes, moved
//! for every triangle hit too): the fibre's tangent, offset, colour and spawn distance stay, and
//! the BSDF is built from them where the hit is shaded.
//!
//! Figures (callgrind, the shade stage of a 20 000-strand groom): see [`crate::hair::lanes`]. On
//! the triangle-only bench scenes the smaller `Surface` left the instruction counts level (±0.2 %,
//! 120×80, 8 spp, 1 thread, both integrators: surfaces are built in place, not copied) and cut the
//! wavefront's D1 misses on shading-heavy from 4.20 M to 4.07 M (writes 1.03 M → 0.94 M; cachegrind,
//! same settings: the sort stage keeps a `Surface` per textured hit).

use super::{Context, ShadowRay, StageParts};
use crate::aov::lpe::Scatter;
use crate::bsdf::lanes::{EvalLanes, SampleInputs, SampleLanes};
use crate::bsdf::BsdfSample;
use crate::hair::lanes::{eval_lanes, sample_lanes, HairLanes};
use crate::lights::links::UNLINKED;
use crate::lights::mis::{self, NeeLane};
use crate::lights::{power_heuristic, LightSample};
use crate::path::roulette::{self, RouletteLane};
use crate::path::{shadow_tmax, FirstHit, RayCounts, CONE_WIDEN_PER_ALPHA, RR_START_BOUNCE};
use crate::sampler::{dim, hash_u32, sample_1d, shadow_seed, vertex_samples, SampleKey, DIMS};
use crate::scalar::lobe_event;
use crate::stats::Phase;
use crate::surface::{Surface, SurfaceBsdf};
use glam::Vec3;
use lanekit::Lanes3;
use lanekit::LANES;
use texture::Touch;

/// Fibre hits waiting for the hair lane kernels: the first `len` lanes are in use.
pub(super) struct CurveGroup {
    /// The hits' hair BSDFs and outgoing directions.
    hair: HairLanes,
    /// Direction of each hit's light sample (lanes without one hold a stale direction, unused).
    light_wi: Lanes3,
    /// Each hit's random numbers for the BSDF sample.
    u: SampleInputs,
    /// Per lane: the path, its surface, its ray cone's width at the hit and its light sample.
    parked: [Option<Parked>; LANES],
    len: usize,
}

/// What the second half of a fibre hit's vertex needs from the first.
struct Parked {
    path: u32,
    surface: Surface,
    footprint: f32,
    light: Option<LightSample>,
    /// The vertex's random numbers ([`vertex_samples`]): [`finish`] reads the light selection and
    /// roulette from them.
    u: [f32; DIMS],
    /// The lobes labelling the light sample and the continuation (light-path expressions; the
    /// scalar integrator's [`crate::scalar::lobe_event`]s).
    lobes: [Scatter; 2],
}

impl Default for CurveGroup {
    fn default() -> Self {
        CurveGroup {
            hair: HairLanes::default(),
            light_wi: [[0.0; LANES]; 3],
            u: SampleInputs::default(),
            parked: [const { None }; LANES],
            len: 0,
        }
    }
}

/// Shades path `i`'s curve or point hit up to its BSDF: emission and the light sample. A point
/// finishes its vertex here ([`finish`]); a fibre waits in `group` for the hair lane kernels, which
/// run when the group is full ([`flush`]).
pub(super) fn vertex<T: Touch>(
    ctx: &Context<'_, '_, T>,
    w: &mut StageParts<'_>,
    group: &mut CurveGroup,
    i: u32,
    rays: &mut RayCounts,
) {
    let scene = ctx.scene;
    let (max_depth, filter, touch) = (ctx.settings.max_depth, ctx.settings.filter, ctx.touch);
    let hit = w.paths.curve_hits[i as usize];
    let st = &mut w.paths.states[i as usize];
    // The scalar sampler (equal to the lanes bit for bit): curve hits are not in scatter groups.
    let (key, vertex) =
        (SampleKey { pixel: st.pixel, sample: st.sample, seed: ctx.sampling.seed }, st.vertex);
    let wo = -st.dir;
    let footprint = st.cone().width_at(hit.t);
    let mut s = scene.curve_surface(&hit, wo);
    w.stats.clock.lap(Phase::Shading);
    let inputs = scene.shade(&s, filter, touch);
    w.stats.clock.shader_evaluations += 1;
    if w.stats.clock.enabled() {
        w.stats.clock.lap(if w.tables.textured_materials[s.material as usize] {
            Phase::Texturing
        } else {
            Phase::Shading
        });
    }

    // Stochastic transparency: straight on, from beyond the fibre.
    let opacity = inputs.effective_opacity();
    if opacity < 1.0 && sample_1d(key, vertex, dim::OPACITY) >= opacity {
        let origin = s.spawn(st.dir);
        if st.pass_through(hit.t, footprint, origin, max_depth) {
            rays.bounce += 1;
            w.queues.next_rays.push(i);
        }
        return;
    }
    if let Some(n) = inputs.normal {
        s.ns = crate::scene::Scene::mapped_normal(&s, n, wo);
    }
    let bsdf = scene.bsdf(&s, &inputs, wo);
    let first = &mut w.paths.first_hits[i as usize];
    if first.is_none() && st.bounces == 0 {
        *first = Some(FirstHit { albedo: bsdf.albedo(), normal: s.ns, depth: st.travelled + hit.t });
        if ctx.aov.is_some() {
            w.paths.aov.first_hit(scene, i as usize, &s, (blob::NONE, st.time, ctx.settings.shutter));
        }
    }
    // Curves and points are not sampled as lights: BSDF sampling finds their emission unweighted.
    let le = inputs.emissive_color.max(Vec3::ZERO);
    if le != Vec3::ZERO {
        let emitted = st.beta * le * 1.0;
        st.radiance += emitted;
        if let Some(mut k) = ctx.aov.and_then(|plan| w.paths.aov.sink(plan, i as usize)) {
            k.add_object(k.state, emitted);
        }
    }
    if st.bounces >= max_depth {
        return;
    }

    // Every other random number of the vertex, at once (as the scalar integrator draws them).
    let u = vertex_samples(hash_u32(key.seed), key.pixel, key.sample, vertex);
    let d = |x: u32| u[x as usize];
    // The light sample of next-event estimation.
    let light = scene.lights.sample(s.p, d(dim::LIGHT_SELECT), [d(dim::LIGHT_UV), d(dim::LIGHT_UV + 1)]).map(
        |mut ls| {
            if let Some((tri, [b1, b2])) = ls.emitter {
                ls.li = scene.emission_at(tri, b1, b2, filter, touch);
            }
            ls
        },
    );
    let (u_lobe, u_dir) = (d(dim::LOBE), [d(dim::BSDF_UV), d(dim::BSDF_UV + 1)]);
    let lobe = match ctx.aov.is_some_and(|p| p.lpe.is_some()) {
        true => lobe_event(&bsdf, &inputs, wo, s.ng, u_lobe, None),
        false => Scatter::ReflectGlossy,
    };
    let lobes = [lobe; 2];
    let hair = match bsdf {
        SurfaceBsdf::Hair(hair) => hair,
        // (Glass is shaded by `glass_vertex`, never here.)
        preview @ (SurfaceBsdf::Preview(_) | SurfaceBsdf::Glass(_)) => {
            // A point: its UsdPreviewSurface BSDF, one hit at a time.
            let eval = light.map(|ls| preview.eval(wo, ls.wi));
            let sample = preview.sample(wo, u_lobe, u_dir);
            finish(ctx, w, Parked { path: i, surface: s, footprint, light, u, lobes }, eval, sample, rays);
            return;
        }
    };
    let k = group.len;
    group.hair.set(k, &hair);
    if let Some(ls) = &light {
        (group.light_wi[0][k], group.light_wi[1][k], group.light_wi[2][k]) = (ls.wi.x, ls.wi.y, ls.wi.z);
    }
    (group.u.u_lobe[k], group.u.u0[k], group.u.u1[k]) = (u_lobe, u_dir[0], u_dir[1]);
    group.parked[k] = Some(Parked { path: i, surface: s, footprint, light, u, lobes });
    group.len += 1;
    w.stats.clock.lap(Phase::Integration);
    if group.len == LANES {
        flush(ctx, w, group, rays);
    }
}

/// The whole vertex of path `i` at the refracting part of a transmissive triangle surface `s`
/// (hit `hit`, shading inputs `inputs`; stochastic transparency chose it): normal map, first-hit
/// record, emission, the light sample, the dielectric BSDF towards it and its sample, then
/// [`finish`]. One hit at a time with the scalar sampler, in the scalar integrator's order, so the
/// image stays the scalar one bit for bit: glass hits are few, and the dielectric has no lane twin.
pub(super) fn glass_vertex<T: Touch>(
    ctx: &Context<'_, '_, T>,
    w: &mut StageParts<'_>,
    i: u32,
    s: &Surface,
    hit: &crate::accel::Hit,
    inputs: &crate::shading::ShadingInputs,
    rays: &mut RayCounts,
) {
    let scene = ctx.scene;
    let (max_depth, filter, touch) = (ctx.settings.max_depth, ctx.settings.filter, ctx.touch);
    let st = &mut w.paths.states[i as usize];
    let (key, vertex) =
        (SampleKey { pixel: st.pixel, sample: st.sample, seed: ctx.sampling.seed }, st.vertex);
    let wo = -st.dir;
    let footprint = st.cone().width_at(hit.t);
    let mut s = *s;
    if let Some(n) = inputs.normal {
        s.ns = crate::scene::Scene::mapped_normal(&s, n, wo);
    }
    let bsdf = scene.glass_bsdf(hit, &s, inputs);
    // The scalar integrator's Beer–Lambert factor, at the same point of the vertex.
    if let Some(kept) = match &bsdf {
        SurfaceBsdf::Glass(g) => g.interior_transmittance(hit.t),
        _ => None,
    } {
        st.beta *= kept;
    }
    let first = &mut w.paths.first_hits[i as usize];
    if first.is_none() && st.bounces == 0 {
        *first = Some(FirstHit { albedo: bsdf.albedo(), normal: s.ns, depth: st.travelled + hit.t });
        if ctx.aov.is_some() {
            w.paths.aov.first_hit(scene, i as usize, &s, (hit.instance, st.time, ctx.settings.shutter));
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
        return;
    }
    let u = vertex_samples(hash_u32(key.seed), key.pixel, key.sample, vertex);
    let d = |x: u32| u[x as usize];
    let u_select = d(dim::LIGHT_SELECT);
    // Light linking: the scalar integrator's drop of a light that does not light the point.
    let set = scene.lights.links().map_or(UNLINKED, |l| l.set_of(hit.triangle));
    let light = (scene.lights.linked_choice(set, s.p, u_select) != Some(None))
        .then(|| scene.lights.sample(s.p, u_select, [d(dim::LIGHT_UV), d(dim::LIGHT_UV + 1)]))
        .flatten()
        .map(|mut ls| {
            if let Some((tri, [b1, b2])) = ls.emitter {
                ls.li = scene.emission_at(tri, b1, b2, filter, touch);
            }
            ls
        });
    let eval = light.map(|ls| bsdf.eval(wo, ls.wi));
    let sample = bsdf.sample(wo, d(dim::LOBE), [d(dim::BSDF_UV), d(dim::BSDF_UV + 1)]);
    // Glass labels by the side each direction leaves on (the scalar integrator's).
    let lobes = match ctx.aov.is_some_and(|p| p.lpe.is_some()) {
        true => [light.map(|ls| ls.wi), sample.map(|bs| bs.wi)]
            .map(|wi| lobe_event(&bsdf, inputs, wo, s.ng, 0.0, wi)),
        false => [Scatter::ReflectSingular; 2],
    };
    w.stats.clock.lap(Phase::Shading);
    finish(ctx, w, Parked { path: i, surface: s, footprint, light, u, lobes }, eval, sample, rays);
}

/// Runs the hair lane kernels on the parked fibre hits and finishes their vertices; empties the
/// group.
pub(super) fn flush<T: Touch>(
    ctx: &Context<'_, '_, T>,
    w: &mut StageParts<'_>,
    group: &mut CurveGroup,
    rays: &mut RayCounts,
) {
    if group.len == 0 {
        return;
    }
    let (mut eval, mut sample) = (EvalLanes::default(), SampleLanes::default());
    let any_light = group.parked[..group.len].iter().any(|p| p.as_ref().is_some_and(|p| p.light.is_some()));
    if any_light {
        eval_lanes(&group.hair, &group.light_wi, &mut eval);
    }
    sample_lanes(&group.hair, &group.u, &mut sample);
    let lane3 = |c: &Lanes3, k: usize| Vec3::new(c[0][k], c[1][k], c[2][k]);
    for k in 0..group.len {
        let Some(parked) = group.parked[k].take() else { continue };
        let eval = parked.light.map(|_| (lane3(&eval.f, k), eval.pdf[k]));
        let bs = (sample.ok[k] != 0).then(|| BsdfSample {
            wi: lane3(&sample.wi, k),
            f: lane3(&sample.f, k),
            pdf: sample.pdf[k],
            lobe_alpha: sample.lobe_alpha[k],
        });
        finish(ctx, w, parked, eval, bs, rays);
    }
    group.len = 0;
}

/// The rest of a curve or point hit's vertex once its BSDF has answered: the light sample's
/// contribution with `eval` (value and pdf towards it) into the occlusion queue, then the
/// continuation `sample` (`None`: absorbed), its throughput and Russian roulette, into the next ray
/// queue.
fn finish<T: Touch>(
    ctx: &Context<'_, '_, T>,
    w: &mut StageParts<'_>,
    parked: Parked,
    eval: Option<(Vec3, f32)>,
    sample: Option<BsdfSample>,
    rays: &mut RayCounts,
) {
    let Parked { path: i, surface: s, footprint, light, u: samples, lobes } = parked;
    let st = &mut w.paths.states[i as usize];
    let vertex = st.vertex;

    // Next-event estimation.
    if let (Some(ls), Some((f, bsdf_pdf))) = (light, eval) {
        let (beta, cos, li, light_pdf, delta) =
            (st.beta, s.ns.dot(ls.wi).abs(), ls.li, ls.pdf, ls.delta as u32);
        let weighed = mis::weigh(&NeeLane { beta, f, li, cos, light_pdf, bsdf_pdf, delta });
        if weighed.keep {
            let origin = s.spawn(ls.wi);
            let tmax = shadow_tmax(ls.distance, origin, s.p);
            let seed = shadow_seed(hash_u32(ctx.sampling.seed), st.pixel, st.sample, vertex);
            // Shadow linking: the light the sample came from (linked: it lights this point).
            let light = match ctx.scene.lights.links() {
                Some(_) => ctx.scene.lights.selected(s.p, samples[dim::LIGHT_SELECT as usize]) as u32,
                None => blob::NONE,
            };
            w.paths.shadow[i as usize] = ShadowRay {
                origin,
                dir: ls.wi,
                tmax,
                contribution: weighed.contribution,
                seed,
                delta: ls.delta,
                light,
            };
            w.queues.occlusion.push(i);
            if let Some(plan) = ctx.aov {
                let at = (ls.emitter.is_some(), s.p, samples[dim::LIGHT_SELECT as usize]);
                w.paths.aov.light_sample(plan, ctx.scene, i as usize, lobes[0], at);
            }
        }
    }

    // BSDF sampling, throughput and Russian roulette.
    let Some(bs) = sample else { return };
    if let Some(plan) = ctx.aov {
        w.paths.aov.lobe[i as usize] = lobes[1];
        w.paths.aov.scatter(plan, i as usize);
    }
    st.prev_p = s.p;
    st.prev_pdf = bs.pdf;
    if let Some(links) = ctx.scene.lights.links() {
        w.paths.prev_light_set[i as usize] = links.set_of(s.triangle);
    }
    st.bounces += 1;
    let play = st.bounces >= RR_START_BOUNCE;
    let u = if play { samples[dim::RUSSIAN_ROULETTE as usize] } else { 0.0 };
    let (beta, f, cos, pdf) = (st.beta, bs.f, s.ns.dot(bs.wi).abs(), bs.pdf);
    let next = roulette::continue_path(&RouletteLane { beta, f, cos, pdf, u, play });
    st.beta = next.beta;
    if !next.alive {
        return;
    }
    st.vertex += 1;
    st.origin = s.spawn(bs.wi);
    st.dir = bs.wi;
    st.travelled = 0.0;
    st.cone_width = footprint;
    st.cone_spread += CONE_WIDEN_PER_ALPHA * bs.lobe_alpha;
    rays.bounce += 1;
    w.queues.next_rays.push(i);
    w.stats.clock.lap(Phase::Integration);
}

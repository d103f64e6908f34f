//! Shading of curve and point hits inside stage 4 ([`super::shade`]): the scalar integrator's vertex,
//! one hit at a time. A fibre's Chiang hair BSDF ([`crate::hair`]) has no lane kernel, and its rays
//! leave the fibre from beyond its diameter rather than from an offset along the normal, so these
//! hits skip the AoS → AoSoA scatter phase: each computes its light sample, MIS weight, BSDF sample
//! and Russian roulette here, with the scalar sampler's random numbers, and queues its shadow ray
//! and continuation like the lanes do. Points (UsdPreviewSurface with per-point colours) come along
//! for the same ray offsets. The operations are the scalar integrator's, in its order, so the image
//! stays bit for bit the scalar one.

use super::{Context, ShadowRay, Worker};
use crate::integrator::{shadow_tmax, FirstHit, RayCounts, CONE_WIDEN_PER_ALPHA, RR_START_BOUNCE};
use crate::lights::power_heuristic;
use crate::sampler::{dim, hash_combine, hash_u32, sample_1d, SampleKey};
use crate::stats::Phase;
use glam::Vec3;
use texture::Touch;

/// Shades path `i`'s curve or point hit: emission, the light sample (into
/// the occlusion queue) and the continuation (into the next ray queue).
pub(super) fn vertex<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, i: u32, rays: &mut RayCounts) {
    let scene = ctx.scene;
    let (max_depth, filter, touch) = (ctx.settings.max_depth, ctx.settings.filter, ctx.touch);
    let hit = w.curve_hits[i as usize];
    let st = &mut w.states[i as usize];
    // The scalar sampler (equal to the lanes bit for bit): curve hits are not in scatter groups.
    let (key, vertex) = (SampleKey { pixel: st.pixel, sample: st.sample, seed: ctx.options.seed }, st.vertex);
    let r = |d: u32| sample_1d(key, vertex, d);
    let wo = -st.dir;
    let footprint = st.cone().width_at(hit.t);
    let mut s = scene.curve_surface(&hit, wo);
    w.clock.lap(Phase::Shading);
    let inputs = scene.shade(&s, filter, touch);
    w.clock.shader_evaluations += 1;
    if w.clock.enabled() {
        w.clock.lap(if w.textured_materials[s.material as usize] {
            Phase::Texturing
        } else {
            Phase::Shading
        });
    }

    // Stochastic transparency: straight on, from beyond the fibre.
    let opacity = inputs.effective_opacity();
    if opacity < 1.0 && r(dim::OPACITY) >= opacity {
        let origin = s.spawn(st.dir);
        if st.pass_through(hit.t, footprint, origin, max_depth) {
            rays.bounce += 1;
            w.next_rays.push(i);
        }
        return;
    }
    if let Some(n) = inputs.normal {
        s.ns = crate::scene::Scene::mapped_normal(&s, n, wo);
    }
    let bsdf = scene.bsdf(&s, &inputs);
    let first = &mut w.first_hits[i as usize];
    if first.is_none() && st.bounces == 0 {
        *first = Some(FirstHit { albedo: bsdf.albedo(), normal: s.ns, depth: st.travelled + hit.t });
    }
    // Curves and points are not sampled as lights: BSDF sampling finds their emission unweighted.
    let le = inputs.emissive_color.max(Vec3::ZERO);
    if le != Vec3::ZERO {
        st.radiance += st.beta * le * 1.0;
    }
    if st.bounces >= max_depth {
        return;
    }

    // Next-event estimation.
    let vertex = st.vertex;
    if let Some(mut ls) =
        scene.lights.sample(s.p, r(dim::LIGHT_SELECT), [r(dim::LIGHT_UV), r(dim::LIGHT_UV + 1)])
    {
        if let Some((tri, [b1, b2])) = ls.emitter {
            ls.li = scene.emission_at(tri, b1, b2, filter, touch);
        }
        let (f, bsdf_pdf) = bsdf.eval(wo, ls.wi);
        let contribution = st.beta * f * ls.li * (s.ns.dot(ls.wi).abs() / ls.pdf);
        if contribution.max_element() > 0.0 {
            let mis = if ls.delta { 1.0 } else { power_heuristic(ls.pdf, bsdf_pdf) };
            let origin = s.spawn(ls.wi);
            let tmax = shadow_tmax(ls.distance, origin, s.p);
            let seed = hash_combine(hash_combine(hash_u32(ctx.options.seed), st.pixel), st.sample) ^ vertex;
            w.shadow[i as usize] =
                ShadowRay { origin, dir: ls.wi, tmax, contribution: contribution * mis, seed };
            w.occlusion.push(i);
        }
    }

    // BSDF sampling, throughput and Russian roulette.
    let Some(bs) = bsdf.sample(wo, r(dim::LOBE), [r(dim::BSDF_UV), r(dim::BSDF_UV + 1)]) else { return };
    st.beta *= bs.f * (s.ns.dot(bs.wi).abs() / bs.pdf);
    st.prev_p = s.p;
    st.prev_pdf = bs.pdf;
    st.bounces += 1;
    if st.bounces >= RR_START_BOUNCE {
        let survive = st.beta.max_element().min(0.95);
        if r(dim::RUSSIAN_ROULETTE) >= survive {
            return;
        }
        st.beta /= survive;
    }
    st.vertex += 1;
    st.origin = s.spawn(bs.wi);
    st.dir = bs.wi;
    st.travelled = 0.0;
    st.cone_width = footprint;
    st.cone_spread += CONE_WIDEN_PER_ALPHA * bs.lobe_alpha;
    rays.bounce += 1;
    w.next_rays.push(i);
    w.clock.lap(Phase::Integration);
}

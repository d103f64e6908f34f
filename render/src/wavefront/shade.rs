//! Stage 4: shading. Reads the sorted shade queue (one segment per material) and the hit side table;
//! per hit: stochastic transparency, the material program, the BSDF, the first-hit AOVs, emission at the
//! hit, one light sample (a [`NeeCandidate`], weighed eight at a time by [`lanes`] into the occlusion
//! queue) and one BSDF sample (a continuation ray into the next ray queue). Russian roulette and the
//! depth limit end paths here.

use super::lanes::{self, NeeCandidate};
use super::{sort, Context, Worker};
use crate::accel::offset_ray_origin;
use crate::bsdf::Bsdf;
use crate::integrator::{FirstHit, RayCounts, CONE_WIDEN_PER_ALPHA, MAX_NULL_EVENTS, RR_START_BOUNCE};
use crate::lights::power_heuristic;
use crate::sampler::{dim, hash_combine, hash_u32, sample_1d, sample_2d, SampleKey};
use crate::scene::Scene;
use glam::Vec3;
use texture::Touch;

/// Shades every queued hit, material by material.
pub(super) fn shade<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, rays: &mut RayCounts) {
    w.next_rays.clear();
    w.nee.clear();
    w.occlusion.clear();
    let segments = w.material_starts.len() - 1;
    for m in 0..segments {
        let (a, b) = (w.material_starts[m] as usize, w.material_starts[m + 1] as usize);
        for k in a..b {
            shade_one(ctx, w, sort::index(w.shade[k]), rays);
        }
    }
    let Worker { nee, shadow, occlusion, .. } = w;
    lanes::weigh_all(nee, |c, contribution| {
        shadow[c.index as usize] =
            super::ShadowRay { origin: c.origin, dir: c.dir, tmax: c.tmax, contribution, seed: c.seed };
        occlusion.push(c.index);
    });
    rays.shadow += w.occlusion.len() as u64;
}

fn shade_one<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, i: u32, rays: &mut RayCounts) {
    let scene: &Scene = ctx.scene;
    let (max_depth, filter, touch) = (ctx.settings.max_depth, ctx.settings.filter, ctx.touch);
    let hit = w.hits[i as usize];
    let st = &mut w.states[i as usize];
    let key = SampleKey { pixel: st.pixel, sample: st.sample, seed: ctx.options.seed };
    let wo = -st.dir;
    let footprint = st.cone().width_at(hit.t);
    let Some(mut s) = scene.surface(&hit, wo, footprint) else { return };
    let inputs = scene.shade(&s, filter, touch);

    let opacity = inputs.effective_opacity();
    if opacity < 1.0 && sample_1d(key, st.vertex, dim::OPACITY) >= opacity {
        st.vertex += 1;
        if st.vertex > max_depth + MAX_NULL_EVENTS {
            return;
        }
        st.travelled += hit.t;
        st.cone_width = footprint;
        st.origin = offset_ray_origin(s.p, -s.ng);
        rays.bounce += 1;
        w.next_rays.push(i);
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

    // Next-event estimation: the candidate; weighing and the shadow ray follow in batches.
    let vertex = st.vertex;
    let u_select = sample_1d(key, vertex, dim::LIGHT_SELECT);
    let u_light = sample_2d(key, vertex, dim::LIGHT_UV);
    if let Some(mut ls) = scene.lights.sample(s.p, u_select, u_light) {
        if let Some((tri, [b1, b2])) = ls.emitter {
            ls.li = scene.emission_at(tri, b1, b2, filter, touch);
        }
        let (f, bsdf_pdf) = bsdf.eval(wo, ls.wi);
        let origin = offset_ray_origin(s.p, s.ng);
        let tmax = if ls.distance.is_finite() {
            (ls.distance - (origin - s.p).length()) * (1.0 - 1e-4)
        } else {
            f32::INFINITY
        };
        let shadow_seed = hash_combine(hash_combine(hash_u32(key.seed), key.pixel), key.sample);
        w.nee.push(NeeCandidate {
            index: i,
            beta: st.beta,
            f,
            li: ls.li,
            cos: s.ns.dot(ls.wi).abs(),
            light_pdf: ls.pdf,
            bsdf_pdf,
            delta: ls.delta as u32,
            origin,
            dir: ls.wi,
            tmax,
            seed: shadow_seed ^ vertex,
        });
    }

    // BSDF sampling: the continuation ray.
    let u_lobe = sample_1d(key, vertex, dim::LOBE);
    let u_bsdf = sample_2d(key, vertex, dim::BSDF_UV);
    let Some(bs) = bsdf.sample(wo, u_lobe, u_bsdf) else { return };
    st.beta *= bs.f * (s.ns.dot(bs.wi).abs() / bs.pdf);
    st.prev_p = s.p;
    st.prev_pdf = bs.pdf;
    st.bounces += 1;
    if st.bounces >= RR_START_BOUNCE {
        let survive = st.beta.max_element().min(0.95);
        if sample_1d(key, vertex, dim::RUSSIAN_ROULETTE) >= survive {
            return;
        }
        st.beta /= survive;
    }
    st.vertex += 1;
    st.origin = offset_ray_origin(s.p, s.ng);
    st.dir = bs.wi;
    st.travelled = 0.0;
    st.cone_width = footprint;
    st.cone_spread += CONE_WIDEN_PER_ALPHA * bs.lobe_alpha;
    rays.bounce += 1;
    w.next_rays.push(i);
}

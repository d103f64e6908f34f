//! The scalar, depth-first, unidirectional path tracer.
//!
//! Per path vertex: gather emission (area lights crossed by the incoming segment, the emissive triangle
//! hit, or dome/distant lights on escape — all MIS-weighted against light sampling with the power
//! heuristic), resolve stochastic transparency, sample one light (next-event estimation, MIS-weighted
//! against BSDF sampling), sample the BSDF, and after [`RR_START_BOUNCE`] bounces play unbiased Russian
//! roulette on the throughput. Every random number is [`sample_1d`]/[`sample_2d`] of the path's
//! [`SampleKey`] ([`vertex_samples`] for a scattering vertex's), its vertex counter and a fixed dimension (see [`crate::sampler::dim`]), so the result is
//! a pure function of the keys.

use crate::aov::lpe::Scatter;
use crate::aov::{LpeSink, PathAovs};
use crate::camera::Camera;
use crate::camera::RayCone;
use crate::film::{Sampling, TileJob, TileResult};
use crate::lights::links::UNLINKED;
use crate::lights::mis::{self, NeeLane};
use crate::lights::power_heuristic;
use crate::path::roulette::{self, RouletteLane};
use crate::path::{
    shadow_tmax, FirstHit, PathResult, PathSettings, RayCounts, CONE_WIDEN_PER_ALPHA, MAX_NULL_EVENTS,
    RR_START_BOUNCE,
};
use crate::sampler::{dim, hash_u32, sample_1d, sample_2d, shadow_seed, vertex_samples, SampleKey};
use crate::scene::Scene;
use crate::stats::{Phase, PhaseClock};
use crate::surface::SurfaceBsdf;
use glam::Vec3;
use texture::{Filter, NoTouch, Touch};

impl Scene<'_> {
    /// Traces one camera path with keys `key`, without texture footprints (level-0 lookups).
    pub fn trace_path(
        &self,
        origin: Vec3,
        dir: Vec3,
        key: SampleKey,
        max_depth: u32,
        rays: &mut RayCounts,
    ) -> PathResult {
        let settings = PathSettings { max_depth, filter: Filter::default(), ..PathSettings::default() };
        self.trace_path_with(origin, dir, RayCone::default(), key, &settings, rays, &NoTouch)
    }

    /// Traces one camera path with keys `key` whose pixel footprint is `cone`, reporting texel reads to
    /// `touch`.
    #[allow(clippy::too_many_arguments)]
    pub fn trace_path_with<T: Touch>(
        &self,
        origin: Vec3,
        dir: Vec3,
        cone: RayCone,
        key: SampleKey,
        settings: &PathSettings,
        rays: &mut RayCounts,
        touch: &T,
    ) -> PathResult {
        let mut clock = PhaseClock::new(false);
        self.trace_path_timed(origin, dir, cone, key, settings, rays, touch, &mut clock)
    }

    /// [`Scene::trace_path_with`] charging its time to `clock`'s phases (when enabled) and counting
    /// its shader evaluations there.
    #[allow(clippy::too_many_arguments)]
    pub fn trace_path_timed<T: Touch>(
        &self,
        origin: Vec3,
        dir: Vec3,
        cone: RayCone,
        key: SampleKey,
        settings: &PathSettings,
        rays: &mut RayCounts,
        touch: &T,
        clock: &mut PhaseClock,
    ) -> PathResult {
        self.trace_path_recording(origin, dir, cone, key, settings, rays, touch, clock, None)
    }

    /// [`Scene::trace_path_timed`] recording the path's AOVs in `aov` (light-path expressions,
    /// position; see [`crate::aov`]), begun here. The beauty's operations are the same with or
    /// without it.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn trace_path_recording<T: Touch>(
        &self,
        mut origin: Vec3,
        mut dir: Vec3,
        mut cone: RayCone,
        key: SampleKey,
        settings: &PathSettings,
        rays: &mut RayCounts,
        touch: &T,
        clock: &mut PhaseClock,
        mut aov: Option<&mut PathAovs>,
    ) -> PathResult {
        if let Some(a) = aov.as_deref_mut() {
            a.begin();
        }
        clock.lap(Phase::Overhead);
        let max_depth = settings.max_depth;
        let filter = settings.filter;
        let seed_hash = hash_u32(key.seed);
        let mut result = PathResult::default();
        let mut beta = Vec3::ONE;
        let mut radiance = Vec3::ZERO;
        // Previous scattering vertex and BSDF pdf, for MIS of emission found by BSDF sampling.
        let mut prev: Option<(Vec3, f32)> = None;
        // The previous vertex's light set, for light linking of the emission BSDF sampling finds.
        let mut prev_set = UNLINKED;
        let mut bounces = 0u32;
        let mut vertex = 0u32;
        let mut travelled = 0.0f32;
        // Every ray of the path is at the camera ray's time in the shutter.
        let time = settings.shutter.time(key);
        rays.camera += 1;
        loop {
            let hit = self.accel.closest_hit_at(origin, dir, f32::INFINITY, time);
            // Curves and points have their own BVH; only hits closer than the triangle count.
            let curve_hit = self.curves.closest_hit(origin, dir, hit.map_or(f32::INFINITY, |h| h.t));
            let t_hit = curve_hit.map_or(hit.map_or(f32::INFINITY, |h| h.t), |c| c.t);
            clock.lap(Phase::Intersect);
            let area = self.lights.area_emission_linked(origin, dir, t_hit, prev, prev_set);
            radiance += beta * area;
            if let Some(mut k) = aov.as_deref_mut().and_then(PathAovs::sink) {
                self.record_area_emission(&mut k, beta, area, (origin, dir, t_hit), prev, prev_set);
            }
            let wo = -dir;
            let footprint = cone.width_at(t_hit);
            let mut s = match (curve_hit, hit) {
                (Some(c), _) => self.curve_surface(&c, wo),
                (None, Some(h)) => match self.surface(&h, wo, footprint) {
                    Some(s) => s,
                    None => break,
                },
                (None, None) => {
                    let escaped = self.lights.escaped_emission_linked(dir, prev.map(|p| p.1), prev_set);
                    radiance += beta * escaped;
                    if let Some(mut k) = aov.as_deref_mut().and_then(PathAovs::sink) {
                        self.record_escaped_emission(&mut k, beta, escaped, dir, prev.map(|p| p.1), prev_set);
                    }
                    // Shading, as the area emission above (the wavefront charges both there).
                    clock.lap(Phase::Shading);
                    break;
                }
            };
            clock.lap(Phase::Shading);
            let inputs = self.shade(&s, filter, touch);
            clock.shader_evaluations += 1;
            let textured = clock.enabled() && crate::stats::reads_textures(&self.view, s.material);
            clock.lap(if textured { Phase::Texturing } else { Phase::Shading });

            // Stochastic transparency: with probability 1 − opacity the hit is the surface's
            // refracting part (glass) or, where that is not a dielectric, a hole the path goes
            // straight through.
            let opacity = inputs.effective_opacity();
            let see_through = opacity < 1.0 && sample_1d(key, vertex, dim::OPACITY) >= opacity;
            let glass = see_through && inputs.refracts() && s.curve.is_none();
            if see_through && !glass {
                vertex += 1;
                if vertex > max_depth + MAX_NULL_EVENTS {
                    break;
                }
                travelled += t_hit;
                cone.width = footprint;
                origin = s.spawn(dir);
                rays.bounce += 1;
                clock.lap(Phase::Integration);
                continue;
            }
            if let Some(n) = inputs.normal {
                s.ns = Self::mapped_normal(&s, n, wo);
            }

            let bsdf = match hit {
                Some(h) if glass => self.glass_bsdf(&h, &s, &inputs),
                _ => self.bsdf(&s, &inputs, wo),
            };
            // Beer–Lambert through an absorbing interior the ray just crossed (before anything
            // this vertex adds: its emission and light sample reach the camera through it too).
            if let Some(kept) = match &bsdf {
                SurfaceBsdf::Glass(g) => g.interior_transmittance(t_hit),
                _ => None,
            } {
                beta *= kept;
            }
            if result.first_hit.is_none() && bounces == 0 {
                result.first_hit =
                    Some(FirstHit { albedo: bsdf.albedo(), normal: s.ns, depth: travelled + t_hit });
                if let Some(a) = aov.as_deref_mut() {
                    a.position = s.p;
                    if a.motion {
                        let on = if curve_hit.is_some() { None } else { hit };
                        let instance = on.map_or(blob::NONE, |h| h.instance);
                        a.ends = Some(crate::aov::motion_ends(self, s.p, instance, time, settings.shutter));
                    }
                    if let Some(t) = self.view.triangles.get(s.triangle as usize) {
                        a.first = Some([t.mesh, s.material]);
                    }
                }
            }

            let le = inputs.emissive_color.max(Vec3::ZERO);
            if le != Vec3::ZERO {
                let w = match prev {
                    // Curves are not sampled as lights: BSDF sampling is their only strategy.
                    Some((p, bsdf_pdf)) if s.triangle != blob::NONE => {
                        power_heuristic(bsdf_pdf, self.lights.triangle_pdf(s.triangle, p, s.p))
                    }
                    _ => 1.0,
                };
                let emitted = beta * le * w;
                radiance += emitted;
                if let Some(mut k) = aov.as_deref_mut().and_then(PathAovs::sink) {
                    k.add_object(k.state, emitted);
                }
            }
            if bounces >= max_depth {
                break;
            }

            // Every other random number of the vertex, at once (the lanes draw the same).
            let u = vertex_samples(seed_hash, key.pixel, key.sample, vertex);
            let d = |d: u32| u[d as usize];
            // The lobe this vertex chooses, labelling its light sample and its continuation.
            let lobe = aov
                .as_ref()
                .filter(|a| a.lpe.is_some())
                .map(|_| lobe_event(&bsdf, &inputs, wo, s.ng, d(dim::LOBE), None));

            // Next-event estimation. With light linking, a light that does not light this point
            // contributes nothing (its selection pdf unchanged), and its shadow rays ignore the
            // blockers that do not shadow it.
            let u_select = d(dim::LIGHT_SELECT);
            let u_light = [d(dim::LIGHT_UV), d(dim::LIGHT_UV + 1)];
            let set = self.lights.links().map_or(UNLINKED, |l| l.set_of(s.triangle));
            let linked = self.lights.linked_choice(set, s.p, u_select);
            let sample = match linked {
                Some(None) => None,
                _ => self.lights.sample(s.p, u_select, u_light),
            };
            if let Some(mut ls) = sample {
                if let Some((tri, [b1, b2])) = ls.emitter {
                    ls.li = self.emission_at(tri, b1, b2, filter, touch);
                }
                let (f, bsdf_pdf) = bsdf.eval(wo, ls.wi);
                let cos = s.ns.dot(ls.wi).abs();
                let (li, light_pdf, delta) = (ls.li, ls.pdf, ls.delta as u32);
                let weighed = mis::weigh(&NeeLane { beta, f, li, cos, light_pdf, bsdf_pdf, delta });
                if weighed.keep {
                    let shadow_origin = s.spawn(ls.wi);
                    let tmax = shadow_tmax(ls.distance, shadow_origin, s.p);
                    rays.shadow += 1;
                    clock.lap(Phase::Integration);
                    let mut kept = self.shadow_transmittance(
                        shadow_origin,
                        ls.wi,
                        tmax,
                        time,
                        shadow_seed(seed_hash, key.pixel, key.sample, vertex),
                        ls.delta,
                        linked.flatten(),
                        filter,
                        touch,
                    );
                    if kept > 0.0 && self.curves.any_hit(shadow_origin, ls.wi, tmax) {
                        kept = 0.0;
                    }
                    clock.lap(Phase::Intersect);
                    if kept > 0.0 {
                        let c = weighed.contribution * kept;
                        radiance += c;
                        if let (Some(a), Some(lobe)) = (aov.as_deref_mut(), lobe) {
                            let lobe = match bsdf {
                                SurfaceBsdf::Glass(_) => {
                                    lobe_event(&bsdf, &inputs, wo, s.ng, 0.0, Some(ls.wi))
                                }
                                _ => lobe,
                            };
                            let state = a.after(a.state, lobe);
                            if let Some(mut k) = a.sink() {
                                let emitter = ls.emitter.is_some();
                                let mask = self.light_sample_accepts(&k, state, emitter, s.p, u_select);
                                k.add(mask, c);
                            }
                        }
                    }
                }
            }

            // BSDF sampling.
            let u_lobe = d(dim::LOBE);
            let u_bsdf = [d(dim::BSDF_UV), d(dim::BSDF_UV + 1)];
            let Some(bs) = bsdf.sample(wo, u_lobe, u_bsdf) else { break };
            if let (Some(a), Some(lobe)) = (aov.as_deref_mut(), lobe) {
                let lobe = match bsdf {
                    SurfaceBsdf::Glass(_) => lobe_event(&bsdf, &inputs, wo, s.ng, 0.0, Some(bs.wi)),
                    _ => lobe,
                };
                a.state = a.after(a.state, lobe);
            }
            prev = Some((s.p, bs.pdf));
            prev_set = set;
            bounces += 1;
            let play = bounces >= RR_START_BOUNCE;
            let (f, cos, pdf, u) = (bs.f, s.ns.dot(bs.wi).abs(), bs.pdf, d(dim::RUSSIAN_ROULETTE));
            let next = roulette::continue_path(&RouletteLane { beta, f, cos, pdf, u, play });
            if !next.alive {
                break;
            }
            beta = next.beta;
            vertex += 1;
            origin = s.spawn(bs.wi);
            dir = bs.wi;
            travelled = 0.0;
            cone = RayCone { width: footprint, spread: cone.spread + CONE_WIDEN_PER_ALPHA * bs.lobe_alpha };
            rays.bounce += 1;
            // BSDF sampling, the roulette and the continuation ray are integration; without this lap
            // the next closest-hit lap charged them to intersection.
            clock.lap(Phase::Integration);
        }
        clock.lap(Phase::Integration);
        result.radiance = radiance;
        result
    }
}

/// Renders `tile` one path at a time: each pixel's samples in sample order.
pub(crate) fn render_tile<T: Touch>(
    scene: &Scene,
    camera: &Camera,
    sampling: &Sampling,
    settings: PathSettings,
    phase_stats: bool,
    job: TileJob<'_>,
    touch: &T,
) -> TileResult {
    let TileJob { tile, sums: init, plan, aov: aov_init } = job;
    let Sampling { width, height, samples, forward, .. } = *sampling;
    let mut out =
        TileResult { sums: init.to_vec(), aov: aov_init.to_vec(), rays: RayCounts::default(), clock: None };
    let (traces, stride) = (plan.traces(), plan.stride());
    let mut record = plan.path();
    let motion = crate::aov::MotionProjection::new(camera, settings.shutter, width, height);
    let mut aov_sums = out.aov.chunks_exact_mut(stride.max(1));
    let mut clock = PhaseClock::new(phase_stats);
    let mut sums = out.sums.iter_mut();
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let pixel = y * width + x;
            let Some(p) = sums.next() else { break };
            let mut pixel_aov = if traces { aov_sums.next() } else { None };
            for sample in samples[0]..samples[1] {
                let key = SampleKey { pixel, sample, seed: sampling.seed };
                let [jx, jy] = sample_2d(key, 0, dim::PIXEL);
                // A pinhole draws no lens sample (its images keep their numbers).
                let lens_uv = if camera.lens().is_some() { sample_2d(key, 0, dim::LENS) } else { [0.0; 2] };
                // A moving camera is placed at the path's time (drawn only for it here; the path
                // draws the same time again).
                let time = if camera.is_moving() { settings.shutter.time(key) } else { 0.0 };
                let film = [(x as f32 + jx) / width as f32, (y as f32 + jy) / height as f32];
                let (o, d, cone) = camera.sample_ray(film, lens_uv, time, forward, sampling.footprint_scale);
                let r = if let Some(pa) = pixel_aov.as_deref_mut() {
                    let rec = Some(&mut record);
                    let r = scene.trace_path_recording(
                        o,
                        d,
                        cone,
                        key,
                        &settings,
                        &mut out.rays,
                        touch,
                        &mut clock,
                        rec,
                    );
                    plan.add(pa, r.radiance.is_finite(), &record, &motion);
                    r
                } else {
                    scene.trace_path_timed(o, d, cone, key, &settings, &mut out.rays, touch, &mut clock)
                };
                p.add(r.radiance, &r.first_hit);
            }
        }
    }
    clock.lap(Phase::Overhead);
    out.clock = Some(clock);
    out
}

/// The scattering event of a vertex whose BSDF is `bsdf` seen from `wo` (geometric normal `ng`):
/// for a UsdPreviewSurface the lobe its lobe sample `u_lobe` picks (the one [`SurfaceBsdf::sample`]
/// picks with it); for glass, reflection or transmission by the side of `wi` (the light sample's or
/// the sampled direction), glossy or singular by its roughness; hair is glossy reflection (its
/// lobes are not told apart).
pub(crate) fn lobe_event(
    bsdf: &SurfaceBsdf,
    inputs: &crate::shading::ShadingInputs,
    wo: Vec3,
    ng: Vec3,
    u_lobe: f32,
    wi: Option<Vec3>,
) -> Scatter {
    match bsdf {
        SurfaceBsdf::Preview(b) => {
            let start = b.seen_from(wo).sample_start(u_lobe, [0.5, 0.5]);
            let alpha = if u_lobe < start.probs[0] + start.probs[1] { b.alpha } else { b.clearcoat_alpha };
            Scatter::of(start.diffuse, alpha, false)
        }
        SurfaceBsdf::Glass(_) => {
            let r = inputs.roughness.clamp(0.0, 1.0);
            let alpha = (r * r).max(crate::bsdf::MIN_ALPHA);
            let transmit = wi.is_some_and(|wi| (wi.dot(ng) > 0.0) != (wo.dot(ng) > 0.0));
            Scatter::of(false, alpha, transmit)
        }
        SurfaceBsdf::Hair(_) => Scatter::ReflectGlossy,
    }
}

impl Scene<'_> {
    /// The expressions a kept light sample adds to from `state` (the vertex's lobe taken): an
    /// emissive surface's where the light is triangles (`emitter`: the sample is on one), else the
    /// light's, chosen at `p` by `u_select` (light by light only when the expressions need it).
    pub(crate) fn light_sample_accepts(
        &self,
        k: &LpeSink,
        state: u32,
        emitter: bool,
        p: Vec3,
        u_select: f32,
    ) -> u64 {
        if emitter {
            return k.automaton.object_accepts(state);
        }
        let light = self.lights.selected(p, u_select);
        if self.lights.is_triangles(light) {
            k.automaton.object_accepts(state)
        } else {
            k.automaton.light_accepts(state, if k.per_light { light } else { 0 })
        }
    }

    /// Records area-light emission `area` (the sum over the lights a segment crosses) reached with
    /// throughput `beta` (see [`crate::aov`]: light by light only when the expressions need it).
    pub(crate) fn record_area_emission(
        &self,
        a: &mut LpeSink,
        beta: Vec3,
        area: Vec3,
        (origin, dir, t_hit): (Vec3, Vec3, f32),
        prev: Option<(Vec3, f32)>,
        prev_set: u32,
    ) {
        self.record_emission(a, beta, area, |light| {
            self.lights.area_emission_linked_of(origin, dir, t_hit, prev, prev_set, light)
        });
    }

    /// Records the emission `escaped` of the lights at infinity an escaping ray sees (see
    /// [`Scene::record_area_emission`]).
    pub(crate) fn record_escaped_emission(
        &self,
        a: &mut LpeSink,
        beta: Vec3,
        escaped: Vec3,
        dir: Vec3,
        bsdf_pdf: Option<f32>,
        prev_set: u32,
    ) {
        self.record_emission(a, beta, escaped, |light| {
            self.lights.escaped_emission_linked_of(dir, bsdf_pdf, prev_set, light)
        });
    }

    /// Records `total` emission reached with throughput `beta`: as one sum, or, when the
    /// expressions name light groups, light by light as `of_light` gives it.
    fn record_emission(&self, a: &mut LpeSink, beta: Vec3, total: Vec3, of_light: impl Fn(usize) -> Vec3) {
        if total == Vec3::ZERO {
            return;
        }
        if !a.per_light {
            a.add_light(a.state, 0, beta * total);
            return;
        }
        for light in 0..self.view.lights.len() {
            let e = of_light(light);
            if e != Vec3::ZERO {
                a.add_light(a.state, light, beta * e);
            }
        }
    }
}

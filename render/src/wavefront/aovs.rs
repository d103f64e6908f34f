//! The AOV records of the paths in flight ([`crate::aov`]), for a render whose plan traces
//! ([`crate::aov::Plan::traces`]): columns indexed by path like the pool's other side tables, so
//! the stages add to them where they add to the beauty, in the same order as the scalar integrator
//! ([`crate::scalar`]), and the AOVs equal the scalar ones bit for bit.
//!
//! Per path: the light-path automaton's `u32` state, each expression's radiance (`n` `Vec3` per
//! path, row by row), the first hit's position and its mesh and material (Cryptomatte), the lobe
//! the current vertex chose (its light sample and continuation are labelled with it, as in the
//! scalar integrator), and the expressions its pending shadow ray adds to. A render without AOVs
//! leaves the columns empty and never reads them: its stages test one `Option` per batch or hit.
//!
//! Kept out of [`super::RayState`] (96 bytes, `const`-asserted): the records are only touched by
//! AOV renders, and their size grows with the expressions.

use crate::aov::lpe::Scatter;
use crate::aov::{LpeSink, Plan};
use crate::scene::Scene;
use crate::surface::Surface;
use glam::Vec3;

/// The AOV columns of a worker's pool, sized on its first traced chunk and reused.
#[derive(Default)]
pub(crate) struct AovColumns {
    /// Expressions per path: `radiance` holds this many per path.
    n: usize,
    pub(super) state: Vec<u32>,
    pub(super) radiance: Vec<Vec3>,
    pub(super) position: Vec<Vec3>,
    pub(super) first: Vec<Option<[u32; 2]>>,
    /// The first hit's point at shutter open and close ([`crate::aov::motion_ends`]), written
    /// only when the plan shows motion.
    ends: Vec<Option<[Vec3; 2]>>,
    motion: bool,
    /// The lobe of the path's current scattering vertex (written only with expressions).
    pub(super) lobe: Vec<Scatter>,
    /// The expressions the path's pending shadow ray adds to when it arrives.
    pub(super) shadow_mask: Vec<u64>,
    /// The tile's AOV sums, [`Plan::stride`] per pixel.
    film: Vec<f32>,
}

impl AovColumns {
    /// Starts `paths` camera paths for `plan`.
    pub(super) fn begin(&mut self, plan: &Plan, paths: usize) {
        self.n = plan.expressions.len();
        let start = plan.lpe.as_ref().map_or(crate::aov::lpe::DEAD, |a| a.start());
        self.state.clear();
        self.state.resize(paths, start);
        self.radiance.clear();
        self.radiance.resize(paths * self.n, Vec3::ZERO);
        self.position.clear();
        self.position.resize(paths, Vec3::ZERO);
        self.first.clear();
        self.first.resize(paths, None);
        self.motion = plan.motion;
        if plan.motion {
            self.ends.clear();
            self.ends.resize(paths, None);
        }
        self.lobe.resize(paths, Scatter::ReflectDiffuse);
        self.shadow_mask.resize(paths, 0);
    }

    /// Path `i`'s expression sums and state, when `plan` has expressions.
    #[inline]
    pub(super) fn sink<'r>(&'r mut self, plan: &'r Plan, i: usize) -> Option<LpeSink<'r>> {
        let automaton = plan.lpe.as_ref()?;
        Some(LpeSink {
            automaton,
            per_light: plan.per_light,
            state: self.state[i],
            radiance: &mut self.radiance[i * self.n..(i + 1) * self.n],
        })
    }

    /// Path `i`'s state after its current vertex's lobe (its continuation's state).
    #[inline]
    pub(super) fn scatter(&mut self, plan: &Plan, i: usize) {
        if let Some(a) = &plan.lpe {
            self.state[i] = a.scatter(self.state[i], self.lobe[i]);
        }
    }

    /// Notes what path `i`'s light sample from its current vertex adds to, as the scalar
    /// integrator labels it (`lobe`: the vertex's lobe, or glass's by the light's side).
    pub(super) fn light_sample(
        &mut self,
        plan: &Plan,
        scene: &Scene,
        i: usize,
        lobe: Scatter,
        (emitter, p, u_select): (bool, Vec3, f32),
    ) {
        if let Some(k) = self.sink(plan, i) {
            let state = k.automaton.scatter(k.state, lobe);
            let mask = scene.light_sample_accepts(&k, state, emitter, p, u_select);
            self.shadow_mask[i] = mask;
        }
    }

    /// Records path `i`'s first hit, on surface `s` of `instance` (blob::NONE: not instanced, a
    /// curve or a point) at ray time `time` in `shutter`.
    #[inline]
    pub(super) fn first_hit(
        &mut self,
        scene: &Scene,
        i: usize,
        s: &Surface,
        (instance, time, shutter): (u32, f32, crate::camera::Shutter),
    ) {
        self.position[i] = s.p;
        if self.motion {
            self.ends[i] = Some(crate::aov::motion_ends(scene, s.p, instance, time, shutter));
        }
        if let Some(t) = scene.view.triangles.get(s.triangle as usize) {
            self.first[i] = Some([t.mesh, s.material]);
        }
    }

    /// Starts the tile's sums from `init`.
    pub(super) fn begin_tile(&mut self, init: &[f32]) {
        self.film.clear();
        self.film.extend_from_slice(init);
    }

    /// Adds a finished chunk of `samples` samples per pixel (the pool's order: pixel, then
    /// sample), with the scalar film loop's [`Plan::add_parts`].
    pub(super) fn chunk(
        &mut self,
        plan: &Plan,
        motion: &crate::aov::MotionProjection,
        pool_states: &[super::RayState],
        samples: usize,
    ) {
        let stride = plan.stride();
        let n = self.n;
        for (p, states) in pool_states.chunks_exact(samples).enumerate() {
            let sums = &mut self.film[p * stride..(p + 1) * stride];
            for (j, st) in states.iter().enumerate() {
                let i = p * samples + j;
                let radiance = &self.radiance[i * n..(i + 1) * n];
                let ends = if self.motion { self.ends[i] } else { None };
                let parts = (self.position[i], self.first[i], motion.pixels(self.motion, ends));
                plan.add_parts(sums, st.radiance.is_finite(), radiance, parts);
            }
        }
    }

    /// The tile's sums.
    pub(super) fn finish(&self) -> Vec<f32> {
        self.film.clone()
    }
}

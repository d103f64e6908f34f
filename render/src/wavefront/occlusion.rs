//! Stage 5: occlusion. Reads the occlusion queue and the shadow-ray side table; adds the contribution of
//! every unoccluded light sample to its path.
//!
//! Shadow rays run as any-hit packets of [`PACKET`] consecutive queue entries
//! ([`packet::any_packet`]) with the blocker of [`Scene::shadow_transmits`]
//! ([`Scene::blocks_shadow`]: the same per-triangle stochastic pass-through), then each unblocked ray
//! asks the curves and points, which always block. A scene where some opacity is textured needs
//! closest hits and opacity evaluations along the ray, so its shadow rays run one by one through
//! [`Scene::shadow_transmits`] itself.
//!
//! [`Scene::shadow_transmits`]: crate::scene::Scene::shadow_transmits
//! [`Scene::blocks_shadow`]: crate::scene::Scene::blocks_shadow

use super::packet::{self, PACKET};
use super::{Context, Worker};
use crate::integrator::RayCounts;
use glam::Vec3;
use texture::Touch;

/// Traces every queued shadow ray: any hit among the triangles (with stochastic pass-through, as in
/// the scalar path), then among the curves and points, which always block.
pub(super) fn any_hit<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, _rays: &mut RayCounts) {
    let filter = ctx.settings.filter;
    let scene = ctx.scene;
    if scene.shading.any_textured_opacity() {
        for &i in &w.occlusion {
            let r = &w.shadow[i as usize];
            if scene.shadow_transmits(r.origin, r.dir, r.tmax, r.seed, filter, ctx.touch)
                && !scene.curves.any_hit(r.origin, r.dir, r.tmax)
            {
                w.states[i as usize].radiance += r.contribution;
            }
        }
        return;
    }
    let mut origins = [Vec3::ZERO; PACKET];
    let mut dirs = [Vec3::ZERO; PACKET];
    let mut tmax = [0.0f32; PACKET];
    let mut seeds = [0u32; PACKET];
    for group in w.occlusion.chunks(PACKET) {
        for (k, &i) in group.iter().enumerate() {
            let r = &w.shadow[i as usize];
            (origins[k], dirs[k], tmax[k], seeds[k]) = (r.origin, r.dir, r.tmax, r.seed);
        }
        let n = group.len();
        let blocked =
            packet::any_packet(&scene.accel, &origins[..n], &dirs[..n], &tmax[..n], |k, tri, inst| {
                scene.blocks_shadow(seeds[k], tri, inst)
            });
        for (k, &i) in group.iter().enumerate() {
            if blocked & (1 << k) == 0 && !scene.curves.any_hit(origins[k], dirs[k], tmax[k]) {
                w.states[i as usize].radiance += w.shadow[i as usize].contribution;
            }
        }
    }
}

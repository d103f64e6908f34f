//! Stage 2: closest hits for the ray queue. Reads the ray queue; adds the emission each ray finds
//! (area lights it crosses, and on escape the dome and distant lights) to its path; writes the hit side
//! tables and the shade queue (`key << 32 | index`, unsorted; [`sort_keys`] fills the keys). Escaped
//! paths leave the wave here.
//!
//! Curves and points have their own BVH ([`crate::curves`]). As in the scalar integrator, a ray first
//! finds its closest triangle, then asks the curves for a hit nearer than that one; a curve hit wins
//! and is recorded in `curve_hits`, with [`blob::NONE`] as the triangle of its [`Hit`] (whose `t` is
//! the curve's, so the cone footprint is taken at the right distance).

use super::packet::{closest_packet, PACKET};
use super::{sort, Context, Worker};
use crate::accel::Hit;
use crate::curves::CurveHit;
use crate::scene::Scene;
use crate::stats::Phase;
use glam::Vec3;
use texture::Touch;

/// Rays traversed per batch before their hits are recorded: the hits (1.5 KiB) stay in L1, and
/// with `--stats` the traversal and the emission are timed as separate phases.
const BATCH: usize = 64;

/// Intersects every queued ray. `coherent`: the queue holds camera rays (the samples of one pixel
/// side by side, from one origin), traced as packets of [`PACKET`] (see [`super::packet`]); other
/// waves trace ray by ray.
///
/// Phases: the BVH queries count as intersection; the emission found along the rays as shading,
/// where the scalar integrator charges it, so the two integrators' phase tables compare.
pub(super) fn closest<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker, coherent: bool) {
    let scene = ctx.scene;
    w.shade.clear();
    // Taken out so the loop can hand `w` to `record`; put back below (no allocation either way).
    let rays = std::mem::take(&mut w.rays);
    let mut hits: [Option<Hit>; BATCH] = [None; BATCH];
    let mut curves: [Option<CurveHit>; BATCH] = [None; BATCH];
    for batch in rays.chunks(BATCH) {
        if coherent {
            let mut origins = [Vec3::ZERO; PACKET];
            let mut dirs = [Vec3::ZERO; PACKET];
            for (group, out) in batch.chunks(PACKET).zip(hits.chunks_mut(PACKET)) {
                for (k, &i) in group.iter().enumerate() {
                    let st = &w.states[i as usize];
                    (origins[k], dirs[k]) = (st.origin, st.dir);
                }
                let n = group.len();
                closest_packet(&scene.accel, &origins[..n], &dirs[..n], f32::INFINITY, &mut out[..n]);
            }
        } else {
            for (hit, &i) in hits.iter_mut().zip(batch) {
                let st = &w.states[i as usize];
                *hit = scene.accel.closest_hit(st.origin, st.dir, f32::INFINITY);
            }
        }
        for ((curve, hit), &i) in curves.iter_mut().zip(&hits).zip(batch) {
            let st = &w.states[i as usize];
            *curve = scene.curves.closest_hit(st.origin, st.dir, hit.map_or(f32::INFINITY, |h| h.t));
        }
        w.clock.lap(Phase::Intersect);
        for ((&hit, &curve), &i) in hits.iter().zip(&curves).zip(batch) {
            record(scene, w, i, hit, curve);
        }
        w.clock.lap(Phase::Shading);
    }
    w.rays = rays;
}

/// Completes path `i`'s query from its triangle hit and the curve or point hit nearer than that: the
/// emission found along the ray, and the hit tables and shade queue (or the escape).
#[inline(always)]
fn record(scene: &Scene, w: &mut Worker, i: u32, hit: Option<Hit>, curve: Option<CurveHit>) {
    let st = &mut w.states[i as usize];
    let t_hit = curve.map_or(hit.map_or(f32::INFINITY, |h| h.t), |c| c.t);
    let prev = st.prev();
    st.radiance += st.beta * w.area_lights.emission(&scene.lights, st.origin, st.dir, t_hit, prev);
    w.hits[i as usize] = match (curve, hit) {
        (Some(c), _) => {
            w.curve_hits[i as usize] = c;
            Hit { t: c.t, triangle: blob::NONE, b1: 0.0, b2: 0.0, instance: blob::NONE }
        }
        (None, Some(h)) => h,
        (None, None) => {
            st.radiance += st.beta * scene.lights.escaped_emission(st.dir, prev.map(|p| p.1));
            return;
        }
    };
    w.shade.push(sort::entry(0, i));
}

/// Whether `hit` is a curve or point hit (its data is in the worker's `curve_hits`).
#[inline]
pub(super) fn is_curve(hit: &Hit) -> bool {
    hit.triangle == blob::NONE
}

/// The material of a path's hit: its triangle's, or its curve or point prim's.
#[inline]
pub(super) fn hit_material(scene: &Scene, hit: &Hit, curve: &CurveHit) -> u32 {
    if is_curve(hit) {
        scene.curves.group_of(curve.prim).material
    } else {
        scene.view.triangle_materials[hit.triangle as usize]
    }
}

/// Writes the texture part of every shade-queue key (see [`sort`]): the key needs the surface (uv
/// and footprint), which is kept for shading, so each hit is reconstructed once. Hits on untextured
/// materials keep key 0 and sort by material alone, and so do curve and point hits (they have no uv:
/// their textures are read at uv 0, one key per material).
pub(super) fn sort_keys<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker) {
    let scene = ctx.scene;
    w.surfaces.clear();
    if !ctx.textured {
        return;
    }
    for e in w.shade.iter_mut() {
        let i = sort::index(*e) as usize;
        let hit = &w.hits[i];
        w.surface_slot[i] = u32::MAX;
        if is_curve(hit) {
            continue;
        }
        let material = scene.view.triangle_materials[hit.triangle as usize] as usize;
        if !w.textured_materials[material] {
            continue;
        }
        let st = &w.states[i];
        if let Some(s) = scene.surface(hit, -st.dir, st.cone().width_at(hit.t)) {
            let key = scene.shading.sort_key(s.material, &s.uv);
            w.surface_slot[i] = w.surfaces.len() as u32;
            w.surfaces.push(Some(s));
            *e = sort::entry(sort::shade_key(0, key), i as u32);
        }
    }
}

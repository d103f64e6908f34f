//! Stage 2: closest hits for the ray queue. Reads the ray queue; adds the emission each ray finds
//! (area lights it crosses, and on escape the dome and distant lights) to its path; writes the hit side
//! table and the shade queue (`key << 32 | index`, unsorted; [`sort_keys`] fills the keys). Escaped
//! paths leave the wave here.

use super::{sort, Context, Worker};
use texture::Touch;

/// Intersects every queued ray.
pub(super) fn closest<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker) {
    let scene = ctx.scene;
    w.shade.clear();
    for &i in &w.rays {
        let st = &mut w.states[i as usize];
        let hit = scene.accel.closest_hit(st.origin, st.dir, f32::INFINITY);
        let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
        let prev = st.prev();
        st.radiance += st.beta * w.area_lights.emission(&scene.lights, st.origin, st.dir, t_hit, prev);
        let Some(hit) = hit else {
            st.radiance += st.beta * scene.lights.escaped_emission(st.dir, prev.map(|p| p.1));
            continue;
        };
        w.hits[i as usize] = hit;
        w.shade.push(sort::entry(0, i));
    }
}

/// Writes the texture part of every shade-queue key (see [`sort`]): the key needs the surface (uv
/// and footprint), which is kept for shading, so each hit is reconstructed once. Hits on untextured
/// materials keep key 0 and sort by material alone.
pub(super) fn sort_keys<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker) {
    let scene = ctx.scene;
    w.surfaces.clear();
    if !ctx.textured {
        return;
    }
    for e in w.shade.iter_mut() {
        let i = sort::index(*e) as usize;
        let hit = &w.hits[i];
        let material = scene.view.triangle_materials[hit.triangle as usize] as usize;
        w.surface_slot[i] = u32::MAX;
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

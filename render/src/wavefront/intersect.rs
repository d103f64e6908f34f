//! Stage 2: closest hits for the ray queue. Reads the ray queue; adds the emission each ray finds
//! (area lights it crosses, and on escape the dome and distant lights) to its path; writes the hit side
//! table and the shade queue (`key << 32 | index`, unsorted). Escaped paths leave the wave here.

use super::{sort, Context, Worker};
use texture::Touch;

/// Intersects every queued ray.
pub(super) fn closest<T: Touch>(ctx: &Context<'_, '_, T>, w: &mut Worker) {
    let scene = ctx.scene;
    w.shade.clear();
    w.surfaces.clear();
    for &i in &w.rays {
        let st = &mut w.states[i as usize];
        let hit = scene.accel.closest_hit(st.origin, st.dir, f32::INFINITY);
        let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
        let prev = st.prev();
        st.radiance += st.beta * scene.lights.area_emission(st.origin, st.dir, t_hit, prev);
        let Some(hit) = hit else {
            st.radiance += st.beta * scene.lights.escaped_emission(st.dir, prev.map(|p| p.1));
            continue;
        };
        // The texture key needs the surface (uv and footprint); it is kept for shading, so each hit is
        // reconstructed once. Hits on untextured materials sort by material alone.
        let material = scene.view.triangle_materials[hit.triangle as usize] as usize;
        w.surface_slot[i as usize] = u32::MAX;
        let key = if ctx.textured && w.textured_materials[material] {
            match scene.surface(&hit, -st.dir, st.cone().width_at(hit.t)) {
                Some(s) => {
                    let key = scene.shading.sort_key(s.material, &s.uv);
                    w.surface_slot[i as usize] = w.surfaces.len() as u32;
                    w.surfaces.push(Some(s));
                    key
                }
                None => 0,
            }
        } else {
            0
        };
        w.hits[i as usize] = hit;
        w.shade.push(sort::entry(sort::shade_key(0, key), i));
    }
}

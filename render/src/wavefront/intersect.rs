//! Stage 2: closest hits for the ray queue. Reads the ray queue and writes the hit side tables
//! ([`closest`]); then adds the emission each ray finds (area lights it crosses, and on escape the
//! dome and distant lights) to its path and writes the shade queue (`key << 32 | index`, unsorted;
//! [`sort_keys`] fills the keys), batch by batch. Escaped paths leave the wave here.
//!
//! Curves and points have their own BVH ([`crate::accel::curves`]). As in the scalar integrator, a ray first
//! finds its closest triangle, then asks the curves for a hit nearer than that one; a curve hit wins
//! and is recorded in `curve_hits`, with [`blob::NONE`] as the triangle of its [`Hit`] (whose `t` is
//! the curve's, so the cone footprint is taken at the right distance).

use super::{prefetch, sort, Context, KernelScratch, PathPool, WorkerTables};
use crate::accel::curves::CurveHit;
use crate::accel::Hit;
use crate::lights::emission_lanes;
use crate::scene::Scene;
use crate::shading::sort_key::{self as key_lanes, KeyInputs, KeyPlan};
use crate::stats::{Phase, PhaseClock};
use crate::surface::lanes as surface_lanes;
use lanekit::LANES;
use texture::Touch;

/// Rays intersected before their emission is added: few enough that their path states are still
/// in L1 for the emission pass, many enough that the two clock reads per batch (`--stats`) cost
/// nothing measurable; the batch is what the area-light kernel tests eight rays at a time.
const BATCH: usize = emission_lanes::MAX_RAYS;

/// Intersects every queued ray, one ray at a time: packets did not pay here (ARCHITECTURE.md).
/// Then adds the emission each ray found ([`emission`]), batch by batch, so that `--stats` charges
/// that to shading as the scalar integrator does (timing each ray's two parts would put two clock
/// reads per ray into the figures: they inflated the simple scene's shading share from 5 % to 33 %;
/// one pass over the whole queue for each read the path states twice, ~5 % slower on the
/// shading-heavy scene).
///
/// Each ray's state and hit slot are prefetched [`RAY_LOOKAHEAD`] rays ahead ([`super::prefetch`]):
/// the first read of the state was half of this function's own `perf` samples (shading-heavy,
/// 1 thread; its share 3.15 → 1.5 % of the render's; figures in [`super::shade`]'s docs).
///
/// Lost (kept out): ordering the queue before traversal by direction octant, then Morton code of
/// the origin (a sort of `key << 32 | index` in the radix scratch): the same image, the BVH queries
/// 2 % fewer instructions and 8 % fewer D1 misses (closest hits, shading-heavy: 431 k against
/// 469 k), but the key pass and the sort added 16 M instructions and 200 k D1 misses (the path
/// states are then read out of order), so the render ran +2.7 / +4.8 / +6.1 % instructions
/// (shading-heavy / tractor / simple) and +3 / +7 / +13 % D1 misses.
pub(super) fn closest<T: Touch>(
    ctx: &Context<'_, '_, T>,
    pool: &mut PathPool,
    rays: &[u32],
    shade: &mut Vec<u64>,
    area_lights: &mut emission_lanes::AreaLightLanes,
    clock: &mut PhaseClock,
) {
    let scene = ctx.scene;
    shade.clear();
    for (b, batch) in rays.chunks(BATCH).enumerate() {
        for (j, &i) in batch.iter().enumerate() {
            // The state and hit slot of the ray after next: one traversal hides their misses.
            if let Some(&next) = rays.get(b * BATCH + j + RAY_LOOKAHEAD) {
                prefetch::entry(&pool.states, next as usize);
                prefetch::entry(&pool.hits, next as usize);
            }
            let st = &pool.states[i as usize];
            let hit = scene.accel.closest_hit_at(st.origin, st.dir, f32::INFINITY, st.time);
            let curve = scene.curves.closest_hit(st.origin, st.dir, hit.map_or(f32::INFINITY, |h| h.t));
            pool.hits[i as usize] = match (curve, hit) {
                (Some(c), _) => {
                    pool.curve_hits[i as usize] = c;
                    Hit {
                        t: c.t,
                        triangle: blob::NONE,
                        b1: 0.0,
                        b2: 0.0,
                        instance: blob::NONE,
                        time: st.time,
                    }
                }
                (None, Some(h)) => h,
                (None, None) => MISS,
            };
        }
        clock.lap(Phase::Intersect);
        emission(scene, ctx.aov, pool, shade, area_lights, batch);
        clock.lap(Phase::Shading);
    }
}

/// Queue positions ahead of the ray being traversed whose state and hit slot are prefetched.
const RAY_LOOKAHEAD: usize = 2;

/// A ray that met nothing: the only hit with an infinite `t` (a triangle or curve hit lies below
/// the ray's infinite `tmax`).
const MISS: Hit =
    Hit { t: f32::INFINITY, triangle: blob::NONE, b1: 0.0, b2: 0.0, instance: blob::NONE, time: 0.0 };

/// The emission each ray of `batch` found: the area lights it crosses before its hit and, when it
/// escaped, the dome and distant lights. Hits enter the shade queue; escaped paths leave the wave.
fn emission(
    scene: &Scene,
    plan: Option<&crate::aov::Plan>,
    pool: &mut PathPool,
    shade: &mut Vec<u64>,
    area_lights: &mut emission_lanes::AreaLightLanes,
    batch: &[u32],
) {
    // Slices, copied into the closure: their lengths for the bounds checks stay in registers
    // rather than being reloaded through the `Vec`s for every ray.
    let (states, hits) = (&pool.states[..], &pool.hits[..]);
    // The kernel reads each ray straight from its path state and hit (no transposed copy).
    let ray = move |j: usize| {
        let i = batch[j] as usize;
        let st = &states[i];
        emission_lanes::Ray { o: st.origin.to_array(), d: st.dir.to_array(), tmax: hits[i].t }
    };
    let prev_sets = &pool.prev_light_set[..];
    // With light linking each ray sums only the lights that light its previous vertex, and camera
    // rays only the lights they see: the scalar function per ray (such scenes give up the lane
    // kernel for exactness).
    let mut linked = [glam::Vec3::ZERO; BATCH];
    let area: &[glam::Vec3] = if scene.lights.emission_per_ray() {
        for (j, &i) in batch.iter().enumerate() {
            let (st, hit) = (&states[i as usize], &hits[i as usize]);
            let set = prev_sets[i as usize];
            linked[j] = scene.lights.area_emission_linked(st.origin, st.dir, hit.t, st.prev(), set);
        }
        &linked[..batch.len()]
    } else {
        area_lights.emission(&scene.lights, batch.len(), ray, |j| states[batch[j] as usize].prev())
    };
    // One pass over the batch: each path adds its area emission; hits enter the shade queue, and
    // escaped rays are gathered for their dome and distant lights (a second pass that picked them
    // out cost 2.1 M instructions on shading-heavy at 120×80, 8 spp).
    let mut dirs = [glam::Vec3::ZERO; BATCH];
    let mut pdfs = [None; BATCH];
    let mut paths = [0u32; BATCH];
    let mut n = 0;
    for (&i, &area) in batch.iter().zip(area) {
        let st = &mut pool.states[i as usize];
        st.radiance += st.beta * area;
        if let Some(mut k) = plan.and_then(|plan| pool.aov.sink(plan, i as usize)) {
            let (set, t) = (pool.prev_light_set[i as usize], pool.hits[i as usize].t);
            scene.record_area_emission(&mut k, st.beta, area, (st.origin, st.dir, t), st.prev(), set);
        }
        if pool.hits[i as usize].t == f32::INFINITY {
            (dirs[n], pdfs[n], paths[n]) = (st.dir, st.prev().map(|p| p.1), i);
            n += 1;
        } else {
            shade.push(sort::entry(0, i));
        }
    }
    // The escaped rays' dome and distant lights in a pass of their own, each light once for all of
    // the batch's escaped rays ([`crate::lights::Lights::escaped_emission_rays`]: the per-light
    // `match` resolved once per batch, the scalar's arithmetic and summation order per ray). Called
    // per ray between the other rays' work, that `match` mispredicted on most calls (cachegrind,
    // tractor at 120×80, 8 spp: 52 k of 67 k calls, against 15 in the scalar integrator). Each path
    // still adds its area emission first, as the scalar integrator does. Per ray in a pass of its
    // own, escaped emission cost 8.02 M instructions inclusive on the tractor (shading-heavy 7.82 M,
    // simple 6.06 M); per light over the batch 3.33 M (3.24 M, 1.73 M); see `shade`'s module docs.
    if n > 0 {
        let mut sums = [glam::Vec3::ZERO; BATCH];
        if scene.lights.emission_per_ray() {
            for j in 0..n {
                let set = pool.prev_light_set[paths[j] as usize];
                sums[j] = scene.lights.escaped_emission_linked(dirs[j], pdfs[j], set);
            }
        } else {
            scene.lights.escaped_emission_rays(&dirs[..n], &pdfs[..n], &mut sums[..n]);
        }
        for (&i, &sum) in paths[..n].iter().zip(&sums[..n]) {
            let st = &mut pool.states[i as usize];
            st.radiance += st.beta * sum;
            if let Some(mut k) = plan.and_then(|plan| pool.aov.sink(plan, i as usize)) {
                let (set, pdf) = (pool.prev_light_set[i as usize], st.prev().map(|p| p.1));
                scene.record_escaped_emission(&mut k, st.beta, sum, st.dir, pdf, set);
            }
        }
    }
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

/// Records each queued hit's material (see `Worker::materials`) and writes the texture part of its
/// shade-queue key (see [`sort`]): the key needs the surface (uv and footprint), which is kept for
/// shading, so each hit is reconstructed once. Hits on untextured materials keep key 0 and sort by
/// material alone, and so do curve and point hits (they have no uv: their textures are read at uv 0,
/// one key per material).
///
/// The textured hits' surfaces are built eight at a time ([`surface_lanes`]), in queue order, and
/// pushed to the kept-surface table in that order.
pub(super) fn sort_keys<T: Touch>(
    ctx: &Context<'_, '_, T>,
    pool: &mut PathPool,
    shade: &mut [u64],
    kernels: &mut KernelScratch,
    tables: &WorkerTables,
) {
    let scene = ctx.scene;
    let PathPool { states, hits, curve_hits, materials, surface_slot, surfaces, .. } = pool;
    let WorkerTables { textured_materials, key_plans, .. } = tables;
    let group = &mut *kernels.surface_group;
    // The per-path tables cut to the pool's length: one bounds check of a path index covers them
    // all (each was checked on its own: 1.36 M instructions of checks on shading-heavy).
    let paths = states.len();
    let (hits, curve_hits) = (&hits[..paths], &curve_hits[..paths]);
    let (materials, surface_slot) = (&mut materials[..paths], &mut surface_slot[..paths]);
    let mut keep = KeptSurfaces { shade, surfaces, surface_slot, key_plans, group };
    keep.surfaces.clear();
    // Shared with shading's runs, which leave their last group in it.
    keep.group.clear();
    // Queue positions of the group's hits.
    let mut at = [0usize; LANES];
    for pos in 0..keep.shade.len() {
        let i = sort::index(keep.shade[pos]) as usize;
        let (hit, st) = (&hits[i], &states[i]);
        let material = hit_material(scene, hit, &curve_hits[i]);
        materials[i] = material;
        if !ctx.textured {
            continue;
        }
        keep.surface_slot[i] = u32::MAX;
        if is_curve(hit) || !textured_materials[material as usize] {
            continue;
        }
        at[keep.group.len()] = pos;
        keep.group.push(hit, -st.dir, st.cone().width_at(hit.t));
        if keep.group.is_full() {
            keep_surfaces(scene, &mut keep, &at);
        }
    }
    if !keep.group.is_empty() {
        keep_surfaces(scene, &mut keep, &at);
    }
}

/// What [`keep_surfaces`] writes: the worker's fields it needs, borrowed apart from the per-path
/// tables [`sort_keys`] reads alongside.
struct KeptSurfaces<'a> {
    shade: &'a mut [u64],
    surfaces: &'a mut Vec<crate::surface::Surface>,
    surface_slot: &'a mut [u32],
    key_plans: &'a [KeyPlan],
    group: &'a mut surface_lanes::HitGroup,
}

/// The surfaces of the worker's surface group (the hits at queue positions `at`; the group is
/// emptied) into the kept-surface table, and their texture keys into the queue entries (a
/// degenerate triangle keeps key 0 and no surface): in lanes ([`key_lanes`]) where the material's
/// key has a lane plan, once per material where it does not depend on the hit, else by
/// [`crate::shading::Shading::sort_key`].
fn keep_surfaces(scene: &Scene, w: &mut KeptSurfaces<'_>, at: &[usize; LANES]) {
    let KeptSurfaces { shade, surfaces, surface_slot, key_plans, group } = w;
    let key_plans: &[KeyPlan] = key_plans;
    // The closure only stores: with the key work inside it, it was compiled out of line and every
    // surface went through memory to it (+1.1 M `memcpy` instructions on the tractor).
    let first = surfaces.len();
    let mut kept_at = [0usize; LANES];
    let mut kept = 0;
    surface_lanes::surfaces(scene, group, |k, s| {
        if let Some(s) = s {
            surfaces.push(s);
            kept_at[kept] = at[k];
            kept += 1;
        }
    });
    group.clear();
    let (mut inputs, mut lane_at) = (KeyInputs::default(), [0usize; LANES]);
    for (j, &pos) in kept_at[..kept].iter().enumerate() {
        let e = &mut shade[pos];
        let (i, slot) = (sort::index(*e), first + j);
        surface_slot[i as usize] = slot as u32;
        let s = &surfaces[slot];
        match key_plans[s.material as usize] {
            KeyPlan::Constant(key) => *e = sort::entry(sort::shade_key(0, key), i),
            KeyPlan::Scalar => {
                *e = sort::entry(sort::shade_key(0, scene.shading.sort_key(s.material, &s.uv)), i);
            }
            KeyPlan::Uv(_) => {
                lane_at[inputs.len()] = pos;
                inputs.push(s.material, &s.uv);
            }
        }
    }
    if !inputs.is_empty() {
        let mut keys = [0u32; LANES];
        key_lanes::keys(&scene.shading, key_plans, &inputs, &mut keys);
        for (&pos, &key) in lane_at[..inputs.len()].iter().zip(&keys) {
            let e = &mut shade[pos];
            *e = sort::entry(sort::shade_key(0, key), sort::index(*e));
        }
    }
}

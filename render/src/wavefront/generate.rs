//! Stage 1: camera rays for one chunk of a tile's samples. Reads nothing; writes the [`RayState`] pool
//! and the ray queue.
//!
//! Path `i` of a chunk is pixel `i / samples` of the tile (row-major) and sample `s0 + i % samples`, so
//! the pool is already ordered by pixel and then sample: accumulation reads it front to back.
//!
//! Eight paths at a time: their keys are laid out in lanes, the pixel jitter comes from
//! [`crate::sampler::lanes::pair_lanes`] (from seeds hashed once per pixel) and the rays and cones from [`camera::camera_ray_lanes`], both
//! bit-exact against the scalar film loop's `sample_2d`, `generate_ray` and `pixel_cone` (tested in
//! their modules on random inputs; the equivalence tests compare whole images).
//!
//! A camera with a lens or transform keys then replaces the group's rays by
//! [`camera::lens_ray_lanes`]' (the scalar [`crate::camera::Camera::sample_ray`] per lane, at the
//! path's time: equal to the film loop by construction); its lens samples come from
//! `pair_lanes` with seeds hashed per pixel like the jitter's. Pinhole cameras hash no lens seeds
//! and never reach it. Cost (`nativeNormalMap.usda` of the shared assets, f/4.5, 320×240, 16 spp,
//! one thread, a loaded machine): the generate stage 0.106–0.120 s with the lens against the
//! pinhole's 0.017–0.027 s; the first version, `sample_2d` per lane for the lens sample, took
//! 0.136 s against 0.036 s. What is left is the scalar lens ray itself (the concentric map's
//! branch, a sine/cosine, a square root and two divisions per ray): a lane twin is the next step if
//! depth of field shows up in a profile of a real shot.
//!
//! The keys of [`BATCH`] groups are written before the first group runs (a vector load cannot be
//! forwarded from eight pending scalar stores), and the jitter's pair seeds are hashed once per
//! pixel, eight pixels of a tile row at a time ([`crate::sampler::lanes::pair_seed_lanes`]). Left as
//! they are: the 92-byte [`RayState`] writes (bound by the stores into the pool, not by
//! instructions) and `camera_ray_lanes`' three divisions (needed to equal `generate_ray` bit for
//! bit); measurements: `docs/perf.md#camera-stage-wavefrontgeneraters`.

use super::{Context, PathPool, RayState};
use crate::camera::{self, CameraLanes, RayLanes};
use crate::film::Tile;
use crate::path::RayCounts;
use crate::sampler::lanes as sampler_lanes;
use crate::sampler::{dim, hash_u32, PairSeeds, SampleKey};
use glam::Vec3;
use lanekit::LANES;

/// Fills the pool with the camera rays of samples `s0 .. s0 + samples` of every pixel of `tile`, and the
/// ray queue with their indices (the wave driver: one chunk's paths at once).
pub(super) fn camera_rays<T>(
    ctx: &Context<'_, '_, T>,
    tile: &Tile,
    s0: u32,
    samples: u32,
    pool: &mut PathPool,
    queue: &mut Vec<u32>,
    counts: &mut RayCounts,
) {
    pool.states.clear();
    queue.clear();
    let n = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0) * samples) as usize;
    let states = &mut pool.states;
    camera_paths(ctx, tile, s0, samples, 0..n, |_, st| states.push(st));
    queue.extend(0..pool.states.len() as u32);
    pool.first_hits[..pool.states.len()].fill(None);
    counts.camera += pool.states.len() as u64;
}

/// The camera paths at positions `paths` of the chunk of samples `s0 .. s0 + samples` of `tile`,
/// handed to `put` with their position: position `p` is pixel `p / samples` of the tile (row-major)
/// and sample `s0 + p % samples`. The queue driver asks for the next few positions whenever paths
/// are free; the wave driver for the whole chunk.
///
/// Starting anywhere in the chunk (the pixel, sample and jitter seeds are walked from `paths.start`
/// rather than by nested loops over the tile) cost the wave driver's camera stage 7.83 M → 9.52 M
/// instructions (callgrind, tractor, 120×80, 8 spp; +0.46 % of the process), the same image.
pub(super) fn camera_paths<T, F: FnMut(usize, RayState)>(
    ctx: &Context<'_, '_, T>,
    tile: &Tile,
    s0: u32,
    samples: u32,
    paths: std::ops::Range<usize>,
    mut put: F,
) {
    let cam = CameraLanes::new(
        ctx.camera,
        ctx.sampling.forward,
        ctx.sampling.width,
        ctx.sampling.height,
        ctx.sampling.footprint_scale,
    );
    let seed_hash = hash_u32(ctx.sampling.seed);
    let (shutter, seed) = (ctx.settings.shutter, ctx.sampling.seed);
    let has_lens = ctx.camera.lens().is_some();
    let moving = ctx.camera.is_moving();
    let mut jitter = [[0.0f32; LANES]; 2];
    let mut lens_uv = [[0.0f32; LANES]; 2];
    let mut times = [0.0f32; LANES];
    let mut out = RayLanes::default();
    let mut flush = |keys: &PathKeys, len: usize, put: &mut F| {
        for (k, time) in times.iter_mut().enumerate().take(len) {
            *time = shutter.time(SampleKey { pixel: keys.pixel[k], sample: keys.sample[k], seed });
        }
        sampler_lanes::pair_lanes(&keys.jitter_seeds, &keys.sample, &mut jitter);
        camera::camera_ray_lanes(&cam, &keys.x, &keys.y, &jitter[0], &jitter[1], &mut out);
        if has_lens || moving {
            if has_lens {
                sampler_lanes::pair_lanes(&keys.lens_seeds, &keys.sample, &mut lens_uv);
            }
            camera::lens_ray_lanes(
                ctx.camera,
                ctx.sampling.forward,
                [ctx.sampling.width, ctx.sampling.height],
                ctx.sampling.footprint_scale,
                (&keys.x, &keys.y),
                (&jitter[0], &jitter[1]),
                (&lens_uv[0], &lens_uv[1]),
                &times,
                len,
                &mut out,
            );
        }
        let at = |c: &[[f32; LANES]; 3], k: usize| Vec3::new(c[0][k], c[1][k], c[2][k]);
        #[allow(clippy::needless_range_loop)] // k indexes the key columns and the output alike
        for k in 0..len {
            put(
                keys.position[k] as usize,
                RayState {
                    origin: at(&out.origin, k),
                    dir: at(&out.dir, k),
                    beta: Vec3::ONE,
                    radiance: Vec3::ZERO,
                    prev_p: Vec3::ZERO,
                    prev_pdf: -1.0,
                    cone_width: out.cone_width[k],
                    cone_spread: out.cone_spread[k],
                    travelled: 0.0,
                    pixel: keys.pixel[k],
                    sample: keys.sample[k],
                    vertex: 0,
                    bounces: 0,
                    time: times[k],
                },
            );
        }
    };
    // Keys are written lane by lane (scalar stores) and read by the kernels as whole vectors: read
    // right after being written, a vector load cannot take its data from eight pending stores and
    // stalls until they reach the cache (a third of the jitter kernel's perf samples sat on that
    // load). So keys are filled for `BATCH` groups before the first of them runs.
    let mut batch = [PathKeys::default(); BATCH];
    let mut run = |batch: &[PathKeys; BATCH], len: usize, put: &mut F| {
        for (g, keys) in batch.iter().enumerate().take(len.div_ceil(LANES)) {
            // A last partial group's idle lanes keep earlier keys: computed and dropped.
            flush(keys, (len - g * LANES).min(LANES), put);
        }
    };
    let (tile_width, per_pixel) = ((tile.x1 - tile.x0) as usize, samples as usize);
    let local_pixel = paths.start / per_pixel;
    let mut sample = paths.start % per_pixel;
    let (mut x, mut y) =
        (tile.x0 + (local_pixel % tile_width) as u32, tile.y0 + (local_pixel / tile_width) as u32);
    let mut len = 0;
    let mut row_seeds = sampler_lanes::PairSeedLanes::default();
    let mut row_lens_seeds = sampler_lanes::PairSeedLanes::default();
    // The first pixel of the eight whose seeds `row_seeds` holds.
    let mut seeds_of = u32::MAX;
    for position in paths {
        let pixel = y * ctx.sampling.width + x;
        // The jitter seeds of a pixel are shared by all its samples: hashed once per pixel, eight
        // pixels of a row at a time (pixels past the row's end are hashed and never read).
        let j = ((x - tile.x0) as usize) % LANES;
        let first = pixel - j as u32;
        if first != seeds_of {
            let row_pixels = std::array::from_fn(|k| first.wrapping_add(k as u32));
            sampler_lanes::pair_seed_lanes(seed_hash, &row_pixels, 0, dim::PIXEL, &mut row_seeds);
            if has_lens {
                sampler_lanes::pair_seed_lanes(seed_hash, &row_pixels, 0, dim::LENS, &mut row_lens_seeds);
            }
            seeds_of = first;
        }
        let jitter_seeds =
            PairSeeds { index: row_seeds.index[j], first: row_seeds.first[j], second: row_seeds.second[j] };
        let (keys, k) = (&mut batch[len / LANES], len % LANES);
        (keys.pixel[k], keys.sample[k], keys.x[k], keys.y[k]) = (pixel, s0 + sample as u32, x, y);
        keys.position[k] = position as u32;
        keys.jitter_seeds.set(k, &jitter_seeds);
        if has_lens {
            keys.lens_seeds.set(k, &row_lens_seeds.get(j));
        }
        len += 1;
        if len == BATCH * LANES {
            run(&batch, len, &mut put);
            len = 0;
        }
        sample += 1;
        if sample == per_pixel {
            sample = 0;
            x += 1;
            if x == tile.x1 {
                (x, y) = (tile.x0, y + 1);
            }
        }
    }
    if len > 0 {
        run(&batch, len, &mut put);
    }
}

/// Lane groups whose keys are written before the first of them is read (see `camera_rays`).
const BATCH: usize = 8;

/// Eight paths' camera keys and pixel coordinates.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct PathKeys {
    pixel: [u32; LANES],
    /// Position of the path in its chunk (see [`camera_paths`]).
    position: [u32; LANES],
    sample: [u32; LANES],
    x: [u32; LANES],
    y: [u32; LANES],
    jitter_seeds: sampler_lanes::PairSeedLanes,
    /// The lens sample's seeds (written only when the camera has a lens).
    lens_seeds: sampler_lanes::PairSeedLanes,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::RenderOptions;
    use crate::path::PathSettings;
    use crate::sampler::{sample_2d, SampleKey};
    use crate::scene::Scene;
    use crate::testscene::{self, camera_looking_down_z, card};
    use crate::wavefront::POOL_PATHS;

    /// Every path of a chunk holds the camera ray the scalar film loop generates for its pixel and
    /// sample, in pixel-then-sample order: odd tile sizes and sample counts leave a partly filled last
    /// group, and the chunk starts at a sample other than 0; a pinhole, a round and a polygonal lens.
    #[test]
    fn chunks_hold_the_scalar_film_loops_camera_rays() {
        let mut camera = camera_looking_down_z(glam::Vec3::new(0.3, -0.2, 4.0), 18.0);
        camera.world_from_camera *= glam::Mat4::from_rotation_y(0.3) * glam::Mat4::from_rotation_x(-0.2);
        camera.horizontal_aperture_offset = 1.5;
        let mut round = camera.clone();
        round.lens = scene_pack::Lens { f_stop: 1.2, focus_distance: 3.5, ..Default::default() };
        let mut polygon = camera.clone();
        polygon.lens = scene_pack::Lens {
            f_stop: 2.0,
            focus_distance: 6.0,
            aperture_blades: 7,
            aperture_rotation: -40.0,
        };
        let ingest_scene = scene_pack::Scene {
            meshes: vec![card(0.0, 1.0, 0)],
            materials: vec![testscene::lambert(0.5)],
            cameras: vec![camera, round, polygon],
            default_camera: Some(0),
            meters_per_unit: 1.0,
            ..scene_pack::Scene::default()
        };
        let bytes = testscene::bytes(&ingest_scene);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let scene = Scene::new(view);
        let (width, height) = (37, 23);
        let mut cases = 0;
        for (seed, scale, camera) in
            [(0, 1.0, 0), (9, 0.25, 0), (0xdead_beef, 0.0, 0), (3, 1.0, 1), (4, 0.5, 2)]
        {
            let cam = scene.camera(Some(camera), width, height);
            assert_eq!(cam.lens().is_some(), camera > 0);
            let options = RenderOptions { seed, texture_footprint_scale: scale, ..RenderOptions::default() };
            let ctx = Context {
                scene: &scene,
                camera: &cam,
                sampling: &crate::film::Sampling::new(&options, width, height, cam.forward()),
                settings: PathSettings { max_depth: 4, filter: options.texture_filter, ..Default::default() },
                touch: &texture::NoTouch,
                textured: false,
                aov: None,
            };
            let mut w = crate::wavefront::Worker::new(16, &scene, false);
            for (tile, s0, samples) in [
                (Tile { x0: 0, y0: 0, x1: 16, y1: 16 }, 0, POOL_PATHS as u32 / 256),
                (Tile { x0: 32, y0: 16, x1: 37, y1: 23 }, 5, 3),
                (Tile { x0: 16, y0: 16, x1: 32, y1: 23 }, 7, 1),
            ] {
                let mut rays = RayCounts::default();
                camera_rays(&ctx, &tile, s0, samples, &mut w.paths, &mut w.queues.rays, &mut rays);
                let n = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0) * samples) as usize;
                assert_eq!((w.paths.states.len(), rays.camera), (n, n as u64));
                assert!(w.queues.rays.iter().copied().eq(0..n as u32));
                let mut i = 0;
                for y in tile.y0..tile.y1 {
                    for x in tile.x0..tile.x1 {
                        let pixel = y * width + x;
                        for sample in s0..s0 + samples {
                            // The scalar tile loop (`scalar::render_tile`).
                            let key = SampleKey { pixel, sample, seed };
                            let [jx, jy] = sample_2d(key, 0, dim::PIXEL);
                            let lens_uv =
                                if cam.lens().is_some() { sample_2d(key, 0, dim::LENS) } else { [0.0; 2] };
                            let (o, d) = cam.generate_lens_ray(
                                (x as f32 + jx) / width as f32,
                                (y as f32 + jy) / height as f32,
                                lens_uv,
                            );
                            let mut cone = cam.pixel_cone(d.dot(ctx.sampling.forward));
                            cone.width *= scale;
                            cone.spread *= scale;
                            let st = &w.paths.states[i];
                            assert_eq!((st.pixel, st.sample, st.vertex, st.bounces), (pixel, sample, 0, 0));
                            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                            assert_eq!(bits(st.origin), bits(o));
                            assert_eq!(bits(st.dir), bits(d), "pixel {pixel} sample {sample}");
                            assert_eq!(st.cone_width.to_bits(), cone.width.to_bits());
                            assert_eq!(st.cone_spread.to_bits(), cone.spread.to_bits());
                            assert_eq!((st.beta, st.radiance, st.prev_pdf), (Vec3::ONE, Vec3::ZERO, -1.0));
                            assert!(w.paths.first_hits[i].is_none());
                            i += 1;
                            cases += 1;
                        }
                    }
                }
            }
        }
        assert!(cases > 5 * POOL_PATHS, "{cases}");
    }
}

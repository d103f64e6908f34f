//! Stage 1: camera rays for one chunk of a tile's samples. Reads nothing; writes the [`RayState`] pool
//! and the ray queue.
//!
//! Path `i` of a chunk is pixel `i / samples` of the tile (row-major) and sample `s0 + i % samples`, so
//! the pool is already ordered by pixel and then sample: accumulation reads it front to back.
//!
//! Eight paths at a time: their keys are laid out in lanes, the pixel jitter comes from
//! [`sampler_lanes::sample_2d_lanes`] and the rays and cones from [`camera::camera_ray_lanes`], both
//! bit-exact against the scalar film loop's `sample_2d`, `generate_ray` and `pixel_cone` (tested in
//! their modules on random inputs; the equivalence tests compare whole images).
//!
//! Callgrind, whole process, wavefront, 120×80, 8 spp, 1 thread (76 800 camera rays), instructions in
//! `camera_rays` inclusive: tractor 26.87 M (350 per ray) → FILL_GEN_T, shading-heavy the same
//! 26.87 M → FILL_GEN_S. The scalar code hashed the pair seed's (seed, pixel, vertex) prefix, ran the
//! Sobol table lookups and the Owen scrambles one path at a time; the lanes run them 8-wide.

use super::lanes::LANES;
use super::{sampler_lanes, Context, RayState, Worker};
use crate::camera::{self, CameraLanes, RayLanes};
use crate::film::Tile;
use crate::integrator::RayCounts;
use crate::sampler::{dim, hash_u32};
use glam::Vec3;

/// Fills the pool with the camera rays of samples `s0 .. s0 + samples` of every pixel of `tile`, and the
/// ray queue with their indices.
pub(super) fn camera_rays<T>(
    ctx: &Context<'_, '_, T>,
    tile: &Tile,
    s0: u32,
    samples: u32,
    w: &mut Worker,
    rays: &mut RayCounts,
) {
    w.states.clear();
    w.rays.clear();
    let cam =
        CameraLanes::new(ctx.camera, ctx.forward, ctx.width, ctx.height, ctx.options.texture_footprint_scale);
    let seed_hash = hash_u32(ctx.options.seed);
    let mut keys = PathKeys::default();
    let mut jitter = [[0.0f32; LANES]; 2];
    let mut out = RayLanes::default();
    let mut flush = |keys: &PathKeys, len: usize, states: &mut Vec<RayState>| {
        sampler_lanes::sample_2d_lanes(seed_hash, &keys.pixel, &keys.sample, 0, dim::PIXEL, &mut jitter);
        camera::camera_ray_lanes(&cam, &keys.x, &keys.y, &jitter[0], &jitter[1], &mut out);
        let at = |c: &[[f32; LANES]; 3], k: usize| Vec3::new(c[0][k], c[1][k], c[2][k]);
        states.extend((0..len).map(|k| RayState {
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
        }));
    };
    let mut len = 0;
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let pixel = y * ctx.width + x;
            for sample in s0..s0 + samples {
                (keys.pixel[len], keys.sample[len], keys.x[len], keys.y[len]) = (pixel, sample, x, y);
                len += 1;
                if len == LANES {
                    flush(&keys, len, &mut w.states);
                    len = 0;
                }
            }
        }
    }
    if len > 0 {
        // The idle lanes keep the previous group's keys: computed and dropped.
        flush(&keys, len, &mut w.states);
    }
    w.rays.extend(0..w.states.len() as u32);
    w.first_hits[..w.states.len()].fill(None);
    rays.camera += w.states.len() as u64;
}

/// Eight paths' camera keys and pixel coordinates.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct PathKeys {
    pixel: [u32; LANES],
    sample: [u32; LANES],
    x: [u32; LANES],
    y: [u32; LANES],
}

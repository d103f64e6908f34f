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
//! Before, each path ran the scalar film loop's code: `sample_2d` (hashing the pair seed's (seed,
//! pixel, vertex) prefix, the Sobol table lookups and three Owen scrambles), `generate_ray` and
//! `pixel_cone`, one path at a time: ~350 instructions per camera ray. Now (instructions per ray,
//! tractor): jitter lanes 21, ray and cone lanes 18, key walk 20, the 92-byte [`RayState`] writes
//! 40. The camera has no lens and no pixel filter, so there is no trigonometry here: the `sincosf`
//! of the profiles is called by the light and BSDF sampling kernels (callgrind callers, tractor:
//! `light_lanes::sample_lanes` 4.0 M, `bsdf_lanes::sample_lanes` 3.6 M instructions inside it).
//!
//! | measure (wavefront, 1 thread) | tractor | shading-heavy | simple |
//! |---|---|---|---|
//! | `camera_rays` instructions, inclusive (callgrind, 120×80, 8 spp: 76 800 rays) | 26.87 M → 7.65 M | 26.87 M → 7.65 M | 26.87 M → 7.65 M |
//! | whole process instructions, this and the vertex lanes ([`sampler_lanes`]) | 556.5 M → 521.8 M (−6.2 %) | 943.3 M → 908.2 M (−3.7 %) | 213.2 M → 191.1 M (−10.4 %) |
//! | perf share of the camera stage (320×213, 16 spp; contended) | 5.95 % → 2.1 % | 2.83 % → 1.2 % | |
//!
//! The perf share after is the sum of `sample_2d_lanes`, `camera_ray_lanes`, `camera_rays` and its
//! state writes. Left as they are: hoisting the per-pixel pair seed out of the jitter lanes (the
//! lanes of a group mostly share a pixel; ~8 instructions a ray, 0.1 % of the process) and
//! vector stores for the state writes' constant fields (~15 a ray, 0.2 %).

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

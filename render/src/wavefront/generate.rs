//! Stage 1: camera rays for one chunk of a tile's samples. Reads nothing; writes the [`RayState`] pool
//! and the ray queue.
//!
//! Path `i` of a chunk is pixel `i / samples` of the tile (row-major) and sample `s0 + i % samples`, so
//! the pool is already ordered by pixel and then sample: accumulation reads it front to back.

use super::{Context, RayState, Worker};
use crate::film::Tile;
use crate::integrator::RayCounts;
use crate::sampler::{dim, sample_2d, SampleKey};
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
    let (width, height) = (ctx.width, ctx.height);
    let scale = ctx.options.texture_footprint_scale;
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let pixel = y * width + x;
            for sample in s0..s0 + samples {
                let key = SampleKey { pixel, sample, seed: ctx.options.seed };
                let [jx, jy] = sample_2d(key, 0, dim::PIXEL);
                let (o, d) =
                    ctx.camera.generate_ray((x as f32 + jx) / width as f32, (y as f32 + jy) / height as f32);
                let mut cone = ctx.camera.pixel_cone(d.dot(ctx.forward));
                cone.width *= scale;
                cone.spread *= scale;
                w.rays.push(w.states.len() as u32);
                w.states.push(RayState {
                    origin: o,
                    dir: d,
                    beta: Vec3::ONE,
                    radiance: Vec3::ZERO,
                    prev_p: Vec3::ZERO,
                    prev_pdf: -1.0,
                    cone_width: cone.width,
                    cone_spread: cone.spread,
                    travelled: 0.0,
                    pixel,
                    sample,
                    vertex: 0,
                    bounces: 0,
                });
            }
        }
    }
    w.first_hits[..w.states.len()].fill(None);
    rays.camera += w.states.len() as u64;
}

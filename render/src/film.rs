//! The image and its tiles: [`Image`] (beauty and AOVs), the row-major tiling the render loop
//! hands out, and the per-tile results both integrators return.

use crate::path::RayCounts;
use crate::stats::{PhaseClock, RenderStats};
use glam::Vec3;

/// How a frame is sampled, the same for both integrators.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sampling {
    /// Image width.
    pub(crate) width: u32,
    /// Image height.
    pub(crate) height: u32,
    /// Samples per pixel.
    pub(crate) spp: u32,
    /// Sampler seed.
    pub(crate) seed: u32,
    /// Scale of every camera ray's footprint ([`crate::RenderOptions::texture_footprint_scale`]).
    pub(crate) footprint_scale: f32,
    /// The camera's viewing direction.
    pub(crate) forward: Vec3,
}

impl Sampling {
    /// The sampling `options` ask for, of a `width`×`height` image seen along `forward`.
    pub(crate) fn new(
        options: &crate::options::RenderOptions,
        width: u32,
        height: u32,
        forward: Vec3,
    ) -> Self {
        Sampling {
            width,
            height,
            spp: options.spp,
            seed: options.seed,
            footprint_scale: options.texture_footprint_scale,
            forward,
        }
    }
}

/// A rendered image with its AOVs, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB radiance and alpha (fraction of camera samples that hit geometry).
    pub beauty: Vec<[f32; 4]>,
    /// First-hit diffuse albedo, averaged over samples (0 where a sample missed).
    pub albedo: Vec<[f32; 3]>,
    /// First-hit world-space shading normal, averaged over samples and renormalized.
    pub normal: Vec<[f32; 3]>,
    /// First-hit distance averaged over the samples that hit; +∞ where none did.
    pub depth: Vec<f32>,
    /// Counters and timing.
    pub stats: RenderStats,
}

impl Image {
    /// Beauty RGB of pixel (`x`, `y`).
    pub fn rgb(&self, x: u32, y: u32) -> [f32; 3] {
        let p = self.beauty[(y * self.width + x) as usize];
        [p[0], p[1], p[2]]
    }
}

pub(crate) struct Tile {
    pub(crate) x0: u32,
    pub(crate) y0: u32,
    pub(crate) x1: u32,
    pub(crate) y1: u32,
}

/// The image's `tile_size`-square tiles in row-major order, clipped to its edges.
pub(crate) fn tiles(width: u32, height: u32, tile_size: u32) -> Vec<Tile> {
    let ts = tile_size;
    (0..height.div_ceil(ts))
        .flat_map(|ty| {
            (0..width.div_ceil(ts)).map(move |tx| Tile {
                x0: tx * ts,
                y0: ty * ts,
                x1: ((tx + 1) * ts).min(width),
                y1: ((ty + 1) * ts).min(height),
            })
        })
        .collect()
}

pub(crate) struct TileResult {
    pub(crate) beauty: Vec<[f32; 4]>,
    pub(crate) albedo: Vec<[f32; 3]>,
    pub(crate) normal: Vec<[f32; 3]>,
    pub(crate) depth: Vec<f32>,
    pub(crate) rays: RayCounts,
    pub(crate) nonfinite: u64,
    /// Scalar integrator: the tile's phase times and shader count (the wavefront keeps them per worker).
    pub(crate) clock: Option<PhaseClock>,
}

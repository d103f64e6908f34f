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
    /// The samples of each pixel to trace: `samples[0] .. samples[1]` (sample keys of the whole
    /// render, so a render in passes traces the same paths as one in a single pass).
    pub(crate) samples: [u32; 2],
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
            samples: [0, options.spp],
            seed: options.seed,
            footprint_scale: options.texture_footprint_scale,
            forward,
        }
    }
}

/// Bytes of one pixel of [`Image`] or of a tile result: beauty 16, albedo 12, normal 12, depth 4.
pub const PIXEL_BYTES: u64 = 16 + 12 + 12 + 4;

/// Bytes of one pixel's running sums ([`PixelSum`]).
pub const SUM_BYTES: u64 = std::mem::size_of::<PixelSum>() as u64;

/// Bytes per pixel at the render's peak: the frame's sums and the tiles' returned sums are alive
/// together at the end of a pass, then the [`Image`], and writing the EXR copies every channel once
/// more (its compressed blocks, smaller than the copy, are counted in the same share).
pub const PEAK_BYTES_PER_PIXEL: u64 = 2 * SUM_BYTES + 2 * PIXEL_BYTES;

/// Upper estimate of one path slot of a worker's pools (rays, hits, curve hits, shadow rays, surfaces,
/// queue entries): the wavefront's 2048-path pool is sized to fit a 2 MiB L2, so 1 KiB per path, doubled
/// for margin. The scalar integrator needs less.
pub const POOL_BYTES_PER_PATH: u64 = 2048;

/// Largest samples per pixel: per-pixel sums are `f32`, which stop counting at `2²⁴` equal samples.
pub const MAX_SPP: u32 = 1 << 24;

/// Bytes a `width × height` render on `threads` workers with tiles of `tile_size²` pixels allocates
/// for its film, path pools and AOVs (not the mapped blob, whose pages the kernel owns and may evict).
/// `plan` is the render's products: their sums per pixel and per path in flight, and their
/// channels ([`crate::aov::Plan::memory_per_pixel`]).
pub fn memory_estimate(
    width: u32,
    height: u32,
    tile_size: u32,
    threads: usize,
    plan: &crate::aov::Plan,
) -> u64 {
    let pixels = width as u64 * height as u64;
    let paths = (tile_size as u64 * tile_size as u64).max(crate::wavefront::POOL_PATHS as u64);
    let per_path = POOL_BYTES_PER_PATH + PIXEL_BYTES + plan.memory_per_path();
    let pools = threads as u64 * paths * per_path;
    let per_pixel = PEAK_BYTES_PER_PIXEL + plan.memory_per_pixel();
    pixels.saturating_mul(per_pixel).saturating_add(pools)
}

/// The default memory limit: 3/4 of the physical memory (`MemTotal` of `/proc/meminfo`), leaving a
/// quarter to the mapped blob's page cache and the rest of the machine; 16 GiB where `/proc/meminfo`
/// cannot be read.
pub fn default_max_memory() -> u64 {
    physical_memory().map_or(16 << 30, |total| total / 4 * 3)
}

/// Physical memory in bytes from `/proc/meminfo`, if readable.
fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.trim_start_matches("MemTotal:").trim().trim_end_matches("kB").trim().parse().ok()?;
    kib.checked_mul(1024)
}

/// A rendered image with its AOVs, row-major from the top-left pixel: the data window of a frame
/// (the whole frame unless cropped).
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// This image's top-left pixel in the frame (the EXR data window's origin; zero unless cropped).
    pub origin: [u32; 2],
    /// The frame's width and height (the EXR display window; `[width, height]` unless cropped).
    pub frame: [u32; 2],
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

/// The pixels of a frame a render draws: columns `x0..x1`, rows `y0..y1` (rows from the top).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelWindow {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelWindow {
    /// The whole `width × height` frame.
    pub fn full(width: u32, height: u32) -> Self {
        PixelWindow { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// The pixels of a `width × height` frame whose centres lie in the NDC rectangle `ndc` (xmin, ymin,
    /// xmax, ymax; (0, 0) bottom-left, (1, 1) top-right, as RenderSettings `dataWindowNDC`), minimum
    /// edges inclusive and maximum edges exclusive; clipped to the frame. `None` if no pixel is inside.
    pub fn from_ndc(ndc: [f32; 4], width: u32, height: u32) -> Option<Self> {
        let (w, h) = (f64::from(width), f64::from(height));
        // Column x's centre is (x + ½)/w: the first column at or past `min` is ceil(min·w − ½).
        let first = |edge: f64, size: f64, n: u32| (edge * size - 0.5).ceil().clamp(0.0, f64::from(n)) as u32;
        let [xmin, ymin, xmax, ymax] = ndc.map(f64::from);
        // Rows count from the top: NDC y = 1 − (row + ½)/h.
        let window = PixelWindow {
            x0: first(xmin, w, width),
            x1: first(xmax, w, width),
            y0: first(1.0 - ymax, h, height),
            y1: first(1.0 - ymin, h, height),
        };
        (window.x0 < window.x1 && window.y0 < window.y1).then_some(window)
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
}

pub(crate) struct Tile {
    pub(crate) x0: u32,
    pub(crate) y0: u32,
    pub(crate) x1: u32,
    pub(crate) y1: u32,
}

/// The frame's `tile_size`-square tiles that meet `window`, in row-major order, clipped to it. The grid
/// is the whole frame's, so a cropped render traces each of its pixels in the same tile, with the same
/// neighbours, as the full render does.
pub(crate) fn tiles(window: PixelWindow, tile_size: u32) -> Vec<Tile> {
    let ts = tile_size;
    (window.y0 / ts..window.y1.div_ceil(ts))
        .flat_map(|ty| {
            (window.x0 / ts..window.x1.div_ceil(ts)).map(move |tx| Tile {
                x0: (tx * ts).max(window.x0),
                y0: (ty * ts).max(window.y0),
                x1: ((tx + 1) * ts).min(window.x1),
                y1: ((ty + 1) * ts).min(window.y1),
            })
        })
        .collect()
}

/// Running sums of one pixel over the samples traced so far, added in sample order by both
/// integrators ([`PixelSum::add`]), so continuing them with later samples (a resumed checkpoint, the
/// next pass) gives the bits of a render in one go.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSum {
    /// Radiance of the finite samples.
    pub sum: Vec3,
    /// First-hit albedo of the samples that hit.
    pub albedo: Vec3,
    /// First-hit shading normal of the samples that hit.
    pub normal: Vec3,
    /// First-hit distance of the samples that hit.
    pub depth: f64,
    /// Samples that hit geometry.
    pub hits: u32,
    /// Samples whose radiance was not finite (dropped from `sum`).
    pub nonfinite: u32,
}

impl PixelSum {
    /// Adds one sample.
    #[inline]
    pub(crate) fn add(&mut self, radiance: Vec3, first_hit: &Option<crate::path::FirstHit>) {
        if radiance.is_finite() {
            self.sum += radiance;
        } else {
            self.nonfinite += 1;
        }
        if let Some(h) = first_hit {
            self.albedo += h.albedo;
            self.normal += h.normal;
            self.depth += h.depth as f64;
            self.hits += 1;
        }
    }

    /// The pixel's beauty (RGB and alpha), albedo, normal and depth as the mean of `samples` samples.
    pub fn resolve(&self, samples: u32) -> ([f32; 4], [f32; 3], [f32; 3], f32) {
        let inv = 1.0 / samples as f32;
        let c = self.sum * inv;
        let depth = if self.hits > 0 { (self.depth / self.hits as f64) as f32 } else { f32::INFINITY };
        (
            [c.x, c.y, c.z, self.hits as f32 * inv],
            (self.albedo * inv).to_array(),
            self.normal.normalize_or_zero().to_array(),
            depth,
        )
    }
}

/// A tile to render and its pixels' sums so far (row-major), which the render continues.
#[derive(Clone, Copy)]
pub(crate) struct TileJob<'a> {
    pub(crate) tile: &'a Tile,
    pub(crate) sums: &'a [PixelSum],
    /// The render's AOV plan and the tile's AOV sums so far ([`crate::aov::Plan::stride`] per pixel,
    /// row-major; empty when the plan traces nothing).
    pub(crate) plan: &'a crate::aov::Plan,
    pub(crate) aov: &'a [f32],
}

/// What one tile's render hands back: its pixels' sums, continued from the sums it was given.
pub(crate) struct TileResult {
    /// The tile's pixels, row-major.
    pub(crate) sums: Vec<PixelSum>,
    /// The tile's AOV sums, continued from the job's.
    pub(crate) aov: Vec<f32>,
    pub(crate) rays: RayCounts,
    /// Scalar integrator: the tile's phase times and shader count (the wavefront keeps them per worker).
    pub(crate) clock: Option<PhaseClock>,
}

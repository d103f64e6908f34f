//! The image loop: tiles rendered in parallel on a local rayon pool, samples accumulated per pixel in
//! sample order, so the image depends only on the sample keys — never on the thread count or the
//! scheduling order.

use crate::error::RenderError;
use crate::integrator::{PathSettings, RayCounts};
use crate::sampler::{dim, sample_2d, SampleKey};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Options of one render. [`RenderOptions::default`] gives 16 spp, depth 8, automatic resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Samples per pixel (≥ 1).
    pub spp: u32,
    /// `[width, height]`, or `None` for the scene's RenderSettings resolution, else 512 wide with the
    /// camera's aspect.
    pub resolution: Option<[u32; 2]>,
    /// Camera prim path, or `None` for the scene's default camera (or a framing camera if none).
    pub camera: Option<String>,
    /// Worker threads; 0 = one per core.
    pub threads: usize,
    /// Sampler seed.
    pub seed: u32,
    /// Maximum number of bounces (1 = direct lighting only).
    pub max_depth: u32,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// Texture filter (`--texture-filter`).
    pub texture_filter: texture::Filter,
    /// Multiplies every camera ray's footprint: 1 filters textures over one pixel, 0 reads level 0 at
    /// the sample point (a supersampled reference needs no prefiltering).
    pub texture_footprint_scale: f32,
    /// Count the texel pages the render reads (`RenderStats::texture_bytes_touched`); off by default
    /// because every texel fetch then also marks a shared bitmap.
    pub texture_stats: bool,
    /// Draw every curve as this shape (`None`: tubes, or ribbons where normals are authored).
    pub curve_shape: Option<crate::curves::CurveShape>,
    /// Which integrator traces the paths (`--integrator`); both give the same image.
    pub integrator: Integrator,
    /// Time every phase of every path ([`RenderStats::phases`]); costs a few percent, so off by
    /// default (`--stats` turns it on).
    pub phase_stats: bool,
}

/// The path-tracing integrator: depth-first scalar or breadth-first wavefront (same estimator, same
/// sample keys, same image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// One path at a time ([`crate::integrator`]): the reference.
    Scalar,
    /// Stage by stage over batches of paths ([`crate::wavefront`]): the default, faster on every
    /// bench scene (`bench integrators`).
    #[default]
    Wavefront,
    /// The wavefront integrator under its queue driver ([`crate::wavefront::queues`]: bounded queues
    /// flushed into their handlers when full, MoonRay's scheme); the same image, kept selectable so
    /// `bench integrators` measures it beside the default wave driver, which is faster here.
    WavefrontQueues,
}

impl std::str::FromStr for Integrator {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "scalar" => Ok(Integrator::Scalar),
            "wavefront" => Ok(Integrator::Wavefront),
            "wavefront-queues" => Ok(Integrator::WavefrontQueues),
            _ => Err(format!("unknown integrator {s:?} (scalar, wavefront or wavefront-queues)")),
        }
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            spp: 16,
            resolution: None,
            camera: None,
            threads: 0,
            seed: 0,
            max_depth: 8,
            tile_size: 16,
            texture_filter: texture::Filter::default(),
            texture_footprint_scale: 1.0,
            texture_stats: false,
            curve_shape: None,
            integrator: Integrator::Wavefront,
            phase_stats: false,
        }
    }
}

/// Render statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Rays by kind.
    pub rays: RayCounts,
    /// Camera samples taken.
    pub samples: u64,
    /// Samples discarded because their radiance was NaN or infinite.
    pub nonfinite_samples: u64,
    /// Wall-clock seconds of the render loop.
    pub seconds: f64,
    /// Worker threads used.
    pub threads: usize,
    /// Texel bytes in the blob.
    pub texture_bytes_total: u64,
    /// Bytes of the 4 KiB texel pages read at least once (0 unless `RenderOptions::texture_stats`).
    pub texture_bytes_touched: u64,
    /// Wavefront stage timers, summed over workers (zero for the scalar integrator).
    pub stages: crate::wavefront::StageSeconds,
    /// Wavefront work and lane counters (zero for the scalar integrator).
    pub counters: crate::wavefront::Counters,
    /// CPU seconds per phase, both integrators (zero unless `RenderOptions::phase_stats`).
    pub phases: crate::stats::PhaseSeconds,
    /// Material programs evaluated at path vertices.
    pub shader_evaluations: u64,
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
    pub(crate) clock: Option<crate::stats::PhaseClock>,
}

/// Renders a prepared `scene` with `options`.
pub fn render_scene(scene: &Scene, options: &RenderOptions) -> Result<Image, RenderError> {
    render_scene_with_progress(scene, options, &|_, _| {})
}

/// [`render_scene`] calling `progress(tiles_done, tiles_total)` as tiles finish (from worker threads).
pub fn render_scene_with_progress(
    scene: &Scene,
    options: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    let total_bytes = scene.shading.textures().texel_bytes();
    if options.texture_stats {
        // One bitmap for the whole render, allocated before any tile starts.
        let pages = texture::PageTouches::new(total_bytes);
        let mut image = render_with_touch(scene, options, progress, &pages)?;
        image.stats.texture_bytes_touched = pages.touched_bytes();
        image.stats.texture_bytes_total = total_bytes as u64;
        Ok(image)
    } else {
        let mut image = render_with_touch(scene, options, progress, &texture::NoTouch)?;
        image.stats.texture_bytes_total = total_bytes as u64;
        Ok(image)
    }
}

fn render_with_touch<T: texture::Touch + Sync>(
    scene: &Scene,
    options: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
    touch: &T,
) -> Result<Image, RenderError> {
    if options.spp == 0 {
        return Err(RenderError::InvalidOption("spp must be at least 1".into()));
    }
    if options.tile_size == 0 {
        return Err(RenderError::InvalidOption("tile size must be at least 1".into()));
    }
    let camera_index = scene.camera_index(options.camera.as_deref())?;
    let [width, height] = scene.resolution(options.resolution, camera_index);
    if width == 0 || height == 0 || width as u64 * height as u64 > u32::MAX as u64 {
        return Err(RenderError::InvalidOption(format!("resolution {width}x{height} is out of range")));
    }
    let camera = scene.camera(camera_index, width, height);
    let mut scene = scene.clone();
    if options.curve_shape.is_some() {
        scene.curves.shape = options.curve_shape;
    }
    let scene = &scene;
    let total_texel_bytes = scene.shading.textures().texel_bytes();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .build()
        .map_err(|e| RenderError::ThreadPool(e.to_string()))?;

    let ts = options.tile_size;
    let tiles = tiles(width, height, ts);
    let total = tiles.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let start = Instant::now();
    let spp = options.spp;
    let settings = PathSettings { max_depth: options.max_depth, filter: options.texture_filter };
    let forward = camera.forward();

    let render_tile = |tile: &Tile| -> TileResult {
        let n = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize;
        let mut out = TileResult {
            beauty: Vec::with_capacity(n),
            albedo: Vec::with_capacity(n),
            normal: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            rays: RayCounts::default(),
            nonfinite: 0,
            clock: None,
        };
        let mut clock = crate::stats::PhaseClock::new(options.phase_stats);
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let pixel = y * width + x;
                let mut sum = Vec3::ZERO;
                let (mut albedo, mut normal, mut depth, mut hits) = (Vec3::ZERO, Vec3::ZERO, 0.0f64, 0u32);
                for sample in 0..spp {
                    let key = SampleKey { pixel, sample, seed: options.seed };
                    let [jx, jy] = sample_2d(key, 0, dim::PIXEL);
                    let (o, d) =
                        camera.generate_ray((x as f32 + jx) / width as f32, (y as f32 + jy) / height as f32);
                    let mut cone = camera.pixel_cone(d.dot(forward));
                    cone.width *= options.texture_footprint_scale;
                    cone.spread *= options.texture_footprint_scale;
                    let r =
                        scene.trace_path_timed(o, d, cone, key, &settings, &mut out.rays, touch, &mut clock);
                    if r.radiance.is_finite() {
                        sum += r.radiance;
                    } else {
                        out.nonfinite += 1;
                    }
                    if let Some(h) = r.first_hit {
                        albedo += h.albedo;
                        normal += h.normal;
                        depth += h.depth as f64;
                        hits += 1;
                    }
                }
                let inv = 1.0 / spp as f32;
                let c = sum * inv;
                out.beauty.push([c.x, c.y, c.z, hits as f32 * inv]);
                out.albedo.push((albedo * inv).to_array());
                out.normal.push(normal.normalize_or_zero().to_array());
                out.depth.push(if hits > 0 { (depth / hits as f64) as f32 } else { f32::INFINITY });
            }
        }
        clock.lap(crate::stats::Phase::Overhead);
        out.clock = Some(clock);
        let finished = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(finished, total);
        out
    };
    let stages = std::sync::Mutex::new((
        crate::wavefront::StageSeconds::default(),
        crate::wavefront::Counters::default(),
        crate::stats::PhaseClock::new(false),
    ));
    let results: Vec<TileResult> = match options.integrator {
        Integrator::Scalar => pool.install(|| tiles.par_iter().map(render_tile).collect()),
        Integrator::Wavefront | Integrator::WavefrontQueues => {
            let driver = match options.integrator {
                Integrator::WavefrontQueues => {
                    crate::wavefront::queues::Driver::Queues(crate::wavefront::queues::QueueConfig::DEFAULT)
                }
                _ => crate::wavefront::DEFAULT_DRIVER,
            };
            let ctx = crate::wavefront::Context {
                scene,
                camera: &camera,
                options,
                settings,
                width,
                height,
                forward,
                touch,
                textured: total_texel_bytes > 0,
            };
            // One Worker (pools and queues) per rayon job, dropped when the job ends: the timers merge
            // then, under a lock taken once per worker, never on the hot path.
            type Totals =
                (crate::wavefront::StageSeconds, crate::wavefront::Counters, crate::stats::PhaseClock);
            struct Merge<'m>(crate::wavefront::Worker, &'m std::sync::Mutex<Totals>);
            impl Drop for Merge<'_> {
                fn drop(&mut self) {
                    if let Ok(mut s) = self.1.lock() {
                        s.0.add(&self.0.seconds);
                        s.1.add(&self.0.counters);
                        s.2.merge(&self.0.clock);
                    }
                }
            }
            pool.install(|| {
                tiles
                    .par_iter()
                    .map_init(
                        || {
                            let worker =
                                crate::wavefront::Worker::with_driver(ts, scene, options.phase_stats, driver);
                            Merge(worker, &stages)
                        },
                        |m, tile| {
                            let r = crate::wavefront::render(&ctx, &mut m.0, tile);
                            let finished = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                            progress(finished, total);
                            r
                        },
                    )
                    .collect()
            })
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let (stage_seconds, counters, mut clock) =
        stages.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner());

    let n = (width * height) as usize;
    let mut image = Image {
        width,
        height,
        beauty: vec![[0.0; 4]; n],
        albedo: vec![[0.0; 3]; n],
        normal: vec![[0.0; 3]; n],
        depth: vec![0.0; n],
        stats: RenderStats {
            samples: n as u64 * spp as u64,
            seconds,
            threads: pool.current_num_threads(),
            stages: stage_seconds,
            counters,
            ..RenderStats::default()
        },
    };
    for (tile, r) in tiles.iter().zip(&results) {
        let tw = (tile.x1 - tile.x0) as usize;
        for (row, y) in (tile.y0..tile.y1).enumerate() {
            let dst = (y * width + tile.x0) as usize;
            let src = row * tw;
            image.beauty[dst..dst + tw].copy_from_slice(&r.beauty[src..src + tw]);
            image.albedo[dst..dst + tw].copy_from_slice(&r.albedo[src..src + tw]);
            image.normal[dst..dst + tw].copy_from_slice(&r.normal[src..src + tw]);
            image.depth[dst..dst + tw].copy_from_slice(&r.depth[src..src + tw]);
        }
        image.stats.rays.add(&r.rays);
        if let Some(c) = &r.clock {
            clock.merge(c);
        }
        image.stats.nonfinite_samples += r.nonfinite;
    }
    image.stats.phases = clock.seconds();
    image.stats.shader_evaluations = clock.shader_evaluations;
    Ok(image)
}

//! One frame: validates the options, cuts the image into tiles, renders them in parallel on a local
//! rayon pool with the chosen integrator, and assembles the [`Image`]. Samples are accumulated per pixel
//! in sample order, so the image depends only on the sample keys — never on the thread count or the
//! scheduling order.

use crate::error::RenderError;
use crate::film::{tiles, Image, PixelSum, PixelWindow, Sampling, TileJob, TileResult};
use crate::options::{Integrator, RenderOptions};
use crate::path::PathSettings;
use crate::scene::Scene;
use crate::stats::{Counters, PhaseClock, RenderStats, StageSeconds};
use rayon::prelude::*;
use std::time::Instant;

/// How far a render has come, reported as each tile finishes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Tiles finished.
    pub tiles_done: usize,
    /// Tiles of the render.
    pub tiles_total: usize,
    /// Camera samples of the finished tiles.
    pub samples_done: u64,
    /// Camera samples of the render.
    pub samples_total: u64,
}

/// Renders a prepared `scene` with `options`.
pub fn render_scene(scene: &Scene, options: &RenderOptions) -> Result<Image, RenderError> {
    render_scene_with_progress(scene, options, &|_| {})
}

/// [`render_scene`] calling `progress` as tiles finish (from worker threads, in completion order).
pub fn render_scene_with_progress(
    scene: &Scene,
    options: &RenderOptions,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<Image, RenderError> {
    let mut film = Accumulation::new(scene, options)?;
    match options.adaptive {
        Some((threshold, min_spp)) => film.render_adaptive(scene, options, threshold, min_spp, progress)?,
        None => film.render(scene, options, options.spp, progress)?,
    }
    Ok(film.image())
}

/// A frame's running pixel sums and how many samples per pixel they hold: what a render in passes, a
/// checkpoint and a resumed render carry between passes. Continuing it traces the samples after
/// [`Accumulation::samples`] with the keys of the whole render, so any split into passes gives the
/// bits of one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct Accumulation {
    /// The pixels drawn, in the frame.
    pub window: PixelWindow,
    /// The render's whole region (crop, authored data window or frame) that `window` is a tile of
    /// (`window` itself unless [`RenderOptions::band`] cut it): what a merge of the tiles must cover.
    pub region: PixelWindow,
    /// The frame's width and height.
    pub frame: [u32; 2],
    /// The first sample index of every pixel this accumulation holds ([`RenderOptions::first_sample`]:
    /// non-zero for a farm's sample slice).
    pub first_sample: u32,
    /// One past the last sample index traced so far (every pixel has the same): the pixels hold
    /// samples `first_sample .. samples`.
    pub samples: u32,
    /// The window's pixels, row-major.
    pub sums: Vec<PixelSum>,
    /// The render products' layers ([`crate::aov`]); empty for an accumulation read back from a
    /// checkpoint or merged from parts (they keep the beauty's sums alone).
    pub plan: std::sync::Arc<crate::aov::Plan>,
    /// The window's AOV sums, [`crate::aov::Plan::stride`] per pixel, row-major.
    pub aov: Vec<f32>,
    /// Counters and timings of the passes so far.
    pub stats: RenderStats,
    /// An adaptive render's per-pixel state ([`Accumulation::render_adaptive`]); `None` for a
    /// uniform one, whose pixels all hold [`Accumulation::sample_count`] samples.
    pub adaptive: Option<Adaptive>,
}

/// Adaptive sampling's per-pixel state: how many samples each pixel holds and the batch means
/// its error estimate is made of.
///
/// The estimate is the batch-means one: a pixel's samples come in batches of [`ADAPTIVE_BATCH`],
/// each batch's mean luminance `mᵢ` (from the pixel's sums before and after it) is one draw,
/// and with `k` batches the standard error of the pixel's mean is `σ = √(s² / k)`, `s²` the
/// unbiased variance of the `mᵢ`. The error compared with `--adaptive-threshold` is
/// `σ / (10⁻³ + √μ)`, `μ` the mean of the `mᵢ` (Cycles' normalisation: between an absolute error,
/// too strict on highlights, and a relative one, too strict in the dark). A tile stops when every
/// pixel of it is below the threshold (or at `--spp`), after at least the minimum samples: the
/// decision reads only the sums, so it is the same on any thread count and for both
/// integrators, whose sums are equal bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct Adaptive {
    /// Samples each pixel holds (one past its last sample index).
    pub counts: Vec<u32>,
    /// Per pixel: the sum of its batch means, of their squares, and the batches.
    means: Vec<f64>,
    squares: Vec<f64>,
    batches: Vec<u32>,
}

impl Adaptive {
    /// The error estimate of pixel `i` (see the type's docs); infinite below two batches.
    pub fn error(&self, i: usize) -> f64 {
        let k = f64::from(self.batches[i]);
        if k < 2.0 {
            return f64::INFINITY;
        }
        let mean = self.means[i] / k;
        let variance = ((self.squares[i] - k * mean * mean) / (k - 1.0)).max(0.0);
        (variance / k).sqrt() / (1e-3 + mean.max(0.0).sqrt())
    }
}

/// Samples per batch of an adaptive render (see [`Adaptive`]): small enough that a tile stops
/// soon after converging, large enough for the wavefront's chunks (2048 paths over 256 pixels
/// hold 8).
pub const ADAPTIVE_BATCH: u32 = 4;

/// Luminance (Rec. 709) of a radiance sum.
fn luminance(c: glam::Vec3) -> f64 {
    0.2126 * f64::from(c.x) + 0.7152 * f64::from(c.y) + 0.0722 * f64::from(c.z)
}

impl Accumulation {
    /// An empty accumulation for `options` (validated: spp, tile size, camera, resolution, window and
    /// memory; an error before anything is allocated).
    pub fn new(scene: &Scene, options: &RenderOptions) -> Result<Self, RenderError> {
        let products = crate::aov::Plan::new(&scene.view)?;
        let (window, region, frame) = plan(scene, options, &products)?;
        let n = window.width() as usize * window.height() as usize;
        let plan = products;
        let aov = vec![0.0; n * plan.stride()];
        Ok(Accumulation {
            plan: std::sync::Arc::new(plan),
            aov,
            window,
            region,
            frame,
            first_sample: options.first_sample,
            samples: options.first_sample,
            sums: vec![PixelSum::default(); n],
            stats: RenderStats::default(),
            adaptive: None,
        })
    }

    /// Traces samples `self.samples .. until` of every pixel (nothing if `until` is not past them),
    /// calling `progress` as tiles finish.
    pub fn render(
        &mut self,
        scene: &Scene,
        options: &RenderOptions,
        until: u32,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<(), RenderError> {
        if until <= self.samples {
            return Ok(());
        }
        let (window, _, frame) = plan(scene, options, &self.plan)?;
        if options.first_sample != self.first_sample {
            return Err(RenderError::InvalidOption(format!(
                "the accumulation starts at sample {}, the options at {}",
                self.first_sample, options.first_sample
            )));
        }
        if (window, frame) != (self.window, self.frame) {
            return Err(RenderError::InvalidOption(format!(
                "the accumulation is of pixels {:?} of a {}x{} frame, the options ask for {window:?} of {}x{}",
                self.window, self.frame[0], self.frame[1], frame[0], frame[1]
            )));
        }
        let samples = [self.samples, until.min(crate::film::MAX_SPP)];
        let ranges = vec![samples; tiles(self.window, options.tile_size).len()];
        self.pass(scene, options, &ranges, progress)?;
        self.samples = samples[1];
        self.stats.nonfinite_samples = self.sums.iter().map(|p| u64::from(p.nonfinite)).sum();
        Ok(())
    }

    /// One pass over `ranges` (per tile, see [`render_pass`]), its statistics added.
    fn pass(
        &mut self,
        scene: &Scene,
        options: &RenderOptions,
        ranges: &[[u32; 2]],
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<(), RenderError> {
        let total_bytes = scene.shading.textures().texel_bytes();
        let mut stats = if options.texture_stats {
            // One bitmap for the pass, allocated before any tile starts.
            let pages = texture::PageTouches::new(total_bytes);
            let mut stats = render_pass(scene, options, self, ranges, progress, &pages)?;
            stats.texture_bytes_touched = pages.touched_bytes();
            stats
        } else {
            render_pass(scene, options, self, ranges, progress, &texture::NoTouch)?
        };
        stats.texture_bytes_total = total_bytes as u64;
        self.stats.add_pass(&stats);
        Ok(())
    }

    /// Gives an accumulation read back from a checkpoint or merged from parts its render's
    /// products: `plan` is [`crate::aov::Plan::new`] of the blob it was rendered from, `stored` the
    /// stride of the product sums its file held ([`crate::checkpoint::Provenance::product_sums`]).
    /// An error, leaving `self` as it was, if the file held no product sums where the plan needs
    /// some, or a stride other than the plan's.
    pub fn adopt_plan(
        &mut self,
        plan: std::sync::Arc<crate::aov::Plan>,
        stored: Option<usize>,
    ) -> Result<(), String> {
        let stride = plan.stride();
        match stored {
            None if stride > 0 => {
                return Err(format!(
                    "it holds no RenderProduct sums, and the products need {stride} per pixel (written by a render without --checkpoint's product sums)"
                ))
            }
            Some(s) if s != stride => {
                return Err(format!(
                    "it holds {s} RenderProduct sums per pixel, the blob's products need {stride}"
                ))
            }
            _ => {}
        }
        if self.aov.len() != self.sums.len() * stride {
            return Err(format!(
                "it holds {} RenderProduct sums for {} pixels, not {stride} per pixel",
                self.aov.len(),
                self.sums.len()
            ));
        }
        self.plan = plan;
        Ok(())
    }

    /// Samples per pixel held (for an adaptive render the most any pixel may hold: `--spp`).
    pub fn sample_count(&self) -> u32 {
        self.samples - self.first_sample
    }

    /// Samples pixel `i` (row-major in the window) holds.
    pub fn pixel_samples(&self, i: usize) -> u32 {
        match &self.adaptive {
            Some(a) => a.counts[i] - self.first_sample,
            None => self.sample_count(),
        }
    }

    /// An adaptive render (see [`Adaptive`]): batches of [`ADAPTIVE_BATCH`] samples over the
    /// tiles not yet converged, until every tile is below `threshold` or at `options.spp`; every
    /// tile takes at least `min_spp` samples (rounded up to whole batches, and at least two
    /// batches). The accumulation must be new (no samples yet) and start at sample 0.
    pub fn render_adaptive(
        &mut self,
        scene: &Scene,
        options: &RenderOptions,
        threshold: f32,
        min_spp: u32,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<(), RenderError> {
        if !(threshold.is_finite() && threshold > 0.0) {
            return Err(RenderError::InvalidOption(format!(
                "the adaptive threshold {threshold} must be a positive number"
            )));
        }
        if self.samples != 0 || self.first_sample != 0 || self.adaptive.is_some() {
            return Err(RenderError::InvalidOption(
                "adaptive sampling starts from an empty render (no checkpoint, resume or sample range)"
                    .into(),
            ));
        }
        let (window, _, frame) = plan(scene, options, &self.plan)?;
        if (window, frame) != (self.window, self.frame) {
            return Err(RenderError::InvalidOption("the accumulation is of other pixels".into()));
        }
        let n = self.sums.len();
        self.adaptive = Some(Adaptive {
            counts: vec![0; n],
            means: vec![0.0; n],
            squares: vec![0.0; n],
            batches: vec![0; n],
        });
        let spp = options.spp;
        let min = min_spp.max(2 * ADAPTIVE_BATCH).div_ceil(ADAPTIVE_BATCH) * ADAPTIVE_BATCH;
        let tiles = tiles(self.window, options.tile_size);
        let mut counts = vec![0u32; tiles.len()];
        // Each tile's pixels, as indices into the window.
        let window = self.window;
        let pixels: Vec<Vec<usize>> = tiles
            .iter()
            .map(|t| {
                (t.y0..t.y1)
                    .flat_map(|y| {
                        (t.x0..t.x1).map(move |x| ((y - window.y0) * window.width() + x - window.x0) as usize)
                    })
                    .collect()
            })
            .collect();
        loop {
            let adaptive = self.adaptive.as_ref().expect("set above");
            let ranges: Vec<[u32; 2]> = pixels
                .iter()
                .zip(&counts)
                .map(|(tile_pixels, &c)| {
                    let open = c < spp
                        && (c < min || tile_pixels.iter().any(|&i| adaptive.error(i) > f64::from(threshold)));
                    if open {
                        [c, (c + ADAPTIVE_BATCH).min(spp)]
                    } else {
                        [c, c]
                    }
                })
                .collect();
            if ranges.iter().all(|r| r[1] == r[0]) {
                break;
            }
            let before: Vec<f64> = self.sums.iter().map(|p| luminance(p.sum)).collect();
            self.pass(scene, options, &ranges, progress)?;
            let adaptive = self.adaptive.as_mut().expect("set above");
            for ((tile_pixels, r), c) in pixels.iter().zip(&ranges).zip(counts.iter_mut()) {
                if r[1] == r[0] {
                    continue;
                }
                let batch = f64::from(r[1] - r[0]);
                for &i in tile_pixels {
                    let m = (luminance(self.sums[i].sum) - before[i]) / batch;
                    adaptive.means[i] += m;
                    adaptive.squares[i] += m * m;
                    adaptive.batches[i] += 1;
                    adaptive.counts[i] = r[1];
                }
                *c = r[1];
            }
        }
        // Done: every tile converged or reached `spp`; `samples` is the render's target and each
        // pixel's own count is `pixel_samples`.
        self.samples = spp;
        self.stats.nonfinite_samples = self.sums.iter().map(|p| u64::from(p.nonfinite)).sum();
        Ok(())
    }

    /// Each render product's channels (name, values of the window's pixels), in product order;
    /// nothing when the accumulation holds no product sums ([`Accumulation::plan`]).
    pub fn products(&self) -> Vec<(&crate::aov::Product, crate::aov::Channels)> {
        self.plan
            .products
            .iter()
            .map(|p| (p, self.plan.channels(p, &self.sums, &self.aov, &|i| self.pixel_samples(i))))
            .collect()
    }

    /// The pixels: each the mean of its [`Accumulation::sample_count`] samples.
    pub fn image(&self) -> Image {
        let n = self.sums.len();
        let mut image = Image {
            width: self.window.width(),
            height: self.window.height(),
            origin: [self.window.x0, self.window.y0],
            frame: self.frame,
            beauty: Vec::with_capacity(n),
            albedo: Vec::with_capacity(n),
            normal: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            stats: self.stats,
        };
        for (i, p) in self.sums.iter().enumerate() {
            let (beauty, albedo, normal, depth) = p.resolve(self.pixel_samples(i).max(1));
            image.beauty.push(beauty);
            image.albedo.push(albedo);
            image.normal.push(normal);
            image.depth.push(depth);
        }
        image
    }
}

/// A resolution the film can index: both axes 1..=65536 and at most [`blob::tree::MAX_PIXELS`] pixels
/// in total (what the blob accepts for an authored one).
pub fn check_resolution(width: u32, height: u32) -> Result<(), RenderError> {
    let pixels = width as u64 * height as u64;
    let axis = blob::tree::MAX_RESOLUTION_AXIS;
    if width == 0 || height == 0 || width > axis || height > axis || pixels > blob::tree::MAX_PIXELS {
        return Err(RenderError::InvalidOption(format!(
            "resolution {width}x{height} ({pixels} pixels) is out of range (1..={axis} per axis, at most {} pixels)",
            blob::tree::MAX_PIXELS
        )));
    }
    Ok(())
}

/// Tiles and samples finished so far, counted from the worker threads.
struct ProgressCounter {
    tiles_total: usize,
    samples_total: u64,
    /// Finished tiles and their samples, updated together.
    done: std::sync::Mutex<(usize, u64)>,
}

impl ProgressCounter {
    fn new(tiles_total: usize, samples_total: u64) -> Self {
        ProgressCounter { tiles_total, samples_total, done: std::sync::Mutex::new((0, 0)) }
    }

    /// Counts `tile`, traced for samples `range`, as finished and returns the progress so far.
    fn finish(&self, tile: &crate::film::Tile, range: [u32; 2]) -> Progress {
        let spp = u64::from(range[1] - range[0]);
        let samples = u64::from(tile.x1 - tile.x0) * u64::from(tile.y1 - tile.y0) * spp;
        let mut done = self.done.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        done.0 += 1;
        done.1 += samples;
        Progress {
            tiles_done: done.0,
            tiles_total: self.tiles_total,
            samples_done: done.1,
            samples_total: self.samples_total,
        }
    }
}

/// The pixels a render draws: the `crop` it is asked for, else the scene's authored data window, else
/// the whole frame; an error if the window holds no pixel.
fn pixel_window(
    scene: &Scene,
    crop: Option<[f32; 4]>,
    width: u32,
    height: u32,
) -> Result<PixelWindow, RenderError> {
    let (ndc, what) = match (crop, scene.data_window_ndc()) {
        (Some(c), _) => (c, "--crop"),
        (None, Some(authored)) => (authored, "the RenderSettings dataWindowNDC"),
        (None, None) => return Ok(PixelWindow::full(width, height)),
    };
    PixelWindow::from_ndc(ndc, width, height).ok_or_else(|| {
        RenderError::InvalidOption(format!(
            "{what} {ndc:?} (xmin, ymin, xmax, ymax in NDC) holds no pixel centre of the {width}x{height} frame"
        ))
    })
}

/// The window and frame size `options` ask for, validated (see [`Accumulation::new`]).
fn plan(
    scene: &Scene,
    options: &RenderOptions,
    products: &crate::aov::Plan,
) -> Result<(PixelWindow, PixelWindow, [u32; 2]), RenderError> {
    if options.spp == 0 || options.spp > crate::film::MAX_SPP {
        return Err(RenderError::InvalidOption(format!(
            "spp {} out of range (1..={})",
            options.spp,
            crate::film::MAX_SPP
        )));
    }
    if options.tile_size == 0 || options.tile_size > 4096 {
        return Err(RenderError::InvalidOption("tile size must be 1..=4096".into()));
    }
    let camera_index = scene.camera_index(options.camera.as_deref())?;
    let [width, height] = scene.resolution(options.resolution, camera_index);
    check_resolution(width, height)?;
    let region = pixel_window(scene, options.crop, width, height)?;
    let window = match options.band {
        Some(band) => band_of(region, band)?,
        None => region,
    };
    if options.first_sample >= options.spp {
        return Err(RenderError::InvalidOption(format!(
            "the first sample {} is not below the sample count {}",
            options.first_sample, options.spp
        )));
    }
    // Before anything is allocated: the film and pools of a huge resolution (an authored one, or one
    // a camera's aperture aspect implies) must be refused, not aborted on.
    let needed = crate::film::memory_estimate(
        window.width(),
        window.height(),
        options.tile_size,
        thread_count(options),
        products,
    );
    let limit = options.max_memory.unwrap_or_else(crate::film::default_max_memory);
    if needed > limit {
        return Err(RenderError::Memory { width: window.width(), height: window.height(), needed, limit });
    }
    Ok((window, region, [width, height]))
}

/// Band `index` of `count` of `window`: its rows cut into `count` runs as equal as they can be
/// (a farm's `--tile I/N`; pixels equal the whole render's whatever the cut).
fn band_of(window: PixelWindow, [index, count]: [u32; 2]) -> Result<PixelWindow, RenderError> {
    let rows = window.height();
    if count == 0 || index >= count || count > rows {
        return Err(RenderError::InvalidOption(format!(
            "tile {index}/{count} of a {rows}-row image: the count must be 1..={rows} and the index below it"
        )));
    }
    let row = |i: u32| window.y0 + (u64::from(rows) * u64::from(i) / u64::from(count)) as u32;
    Ok(PixelWindow { y0: row(index), y1: row(index + 1), ..window })
}

/// The shutter of a render: closed at the frame without motion blur, else `--shutter`, else the
/// camera's.
fn shutter(
    options: &RenderOptions,
    camera: &crate::camera::Camera,
) -> Result<crate::camera::Shutter, RenderError> {
    if !options.motion_blur {
        return Ok(crate::camera::Shutter::default());
    }
    let Some([open, close]) = options.shutter else { return Ok(camera.shutter()) };
    let limit = blob::MAX_SHUTTER;
    if !(open.is_finite()
        && close.is_finite()
        && open <= close
        && open.abs() <= limit
        && close.abs() <= limit)
    {
        return Err(RenderError::InvalidOption(format!(
            "shutter {open},{close} must be OPEN,CLOSE with OPEN <= CLOSE, finite, within ±{limit} time codes"
        )));
    }
    Ok(crate::camera::Shutter { open, close })
}

/// The worker threads `options` ask for (0: one per core).
fn thread_count(options: &RenderOptions) -> usize {
    match options.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
}

/// One pass: samples `ranges[t][0] .. ranges[t][1]` of every pixel of tile `t` of `film`'s window
/// ([`tiles`] order; an empty range skips the tile), continuing its sums. Returns the pass's
/// statistics.
fn render_pass<T: texture::Touch + Sync>(
    scene: &Scene,
    options: &RenderOptions,
    film: &mut Accumulation,
    ranges: &[[u32; 2]],
    progress: &(dyn Fn(Progress) + Sync),
    touch: &T,
) -> Result<RenderStats, RenderError> {
    let (window, [width, height]) = (film.window, film.frame);
    let camera_index = scene.camera_index(options.camera.as_deref())?;
    let camera = scene.camera(camera_index, width, height);
    let camera = if options.depth_of_field { camera } else { camera.without_lens() };
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
    let all_tiles = tiles(window, ts);
    // The tiles this pass traces, each with its samples.
    let tiles: Vec<(&crate::film::Tile, [u32; 2])> =
        all_tiles.iter().zip(ranges.iter().copied()).filter(|(_, r)| r[1] > r[0]).collect();
    let traced: u64 =
        tiles.iter().map(|(t, r)| u64::from((t.x1 - t.x0) * (t.y1 - t.y0)) * u64::from(r[1] - r[0])).sum();
    let counter = ProgressCounter::new(tiles.len(), traced);
    let start = Instant::now();
    let settings = PathSettings {
        max_depth: options.max_depth,
        filter: options.texture_filter,
        shutter: shutter(options, &camera)?,
    };
    // A closed shutter sees the camera where it is at the shutter's time, standing still.
    let camera = if settings.shutter.is_open() { camera } else { camera.at_time(settings.shutter.open) };
    let sampling = Sampling::new(options, width, height, camera.forward());
    let sampling_of = |samples: [u32; 2]| Sampling { samples, ..sampling };
    // The tile's sums so far, row-major (the window's rows are `film.window.width()` long).
    let sums = &film.sums;
    let stride = window.width();
    let tile_sums = |tile: &crate::film::Tile| -> Vec<PixelSum> {
        (tile.y0..tile.y1)
            .flat_map(|y| {
                let row = ((y - window.y0) * stride + tile.x0 - window.x0) as usize;
                sums[row..row + (tile.x1 - tile.x0) as usize].iter().copied()
            })
            .collect()
    };
    let plan = &*film.plan;
    let (aov, aov_stride) = (&film.aov, plan.stride());
    let tile_aov = |tile: &crate::film::Tile| -> Vec<f32> {
        (tile.y0..tile.y1)
            .flat_map(|y| {
                let row = ((y - window.y0) * stride + tile.x0 - window.x0) as usize * aov_stride;
                aov[row..row + (tile.x1 - tile.x0) as usize * aov_stride].iter().copied()
            })
            .collect()
    };

    let stages =
        std::sync::Mutex::new((StageSeconds::default(), Counters::default(), PhaseClock::new(false)));
    let results: Vec<TileResult> = match options.integrator {
        Integrator::Scalar => pool.install(|| {
            tiles
                .par_iter()
                .map(|&(tile, samples)| {
                    let r = crate::scalar::render_tile(
                        scene,
                        &camera,
                        &sampling_of(samples),
                        settings,
                        options.phase_stats,
                        TileJob { tile, sums: &tile_sums(tile), plan, aov: &tile_aov(tile) },
                        touch,
                    );
                    progress(counter.finish(tile, samples));
                    r
                })
                .collect()
        }),
        Integrator::Wavefront => {
            let ctx = crate::wavefront::Context {
                scene,
                camera: &camera,
                sampling: &sampling,
                settings,
                touch,
                textured: total_texel_bytes > 0,
                aov: None,
            };
            // One Worker (pools and queues) per rayon job, dropped when the job ends: the timers merge
            // then, under a lock taken once per worker, never on the hot path.
            type Totals = (StageSeconds, Counters, PhaseClock);
            struct Merge<'m>(crate::wavefront::Worker, &'m std::sync::Mutex<Totals>);
            impl Drop for Merge<'_> {
                fn drop(&mut self) {
                    if let Ok(mut s) = self.1.lock() {
                        s.0.add(&self.0.stats.seconds);
                        s.1.add(&self.0.stats.counters);
                        s.2.merge(&self.0.stats.clock);
                    }
                }
            }
            pool.install(|| {
                tiles
                    .par_iter()
                    .map_init(
                        || {
                            let worker = crate::wavefront::Worker::new(ts, scene, options.phase_stats);
                            Merge(worker, &stages)
                        },
                        |m, &(tile, samples)| {
                            let sampling = sampling_of(samples);
                            let ctx = crate::wavefront::Context { sampling: &sampling, ..ctx };
                            let r = crate::wavefront::render(
                                &ctx,
                                &mut m.0,
                                TileJob { tile, sums: &tile_sums(tile), plan, aov: &tile_aov(tile) },
                            );
                            progress(counter.finish(tile, samples));
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
    let mut stats = RenderStats {
        samples: traced,
        seconds,
        threads: pool.current_num_threads(),
        stages: stage_seconds,
        counters,
        ..RenderStats::default()
    };
    for ((tile, _), r) in tiles.iter().zip(&results) {
        let tw = (tile.x1 - tile.x0) as usize;
        for (row, y) in (tile.y0..tile.y1).enumerate() {
            let dst = ((y - window.y0) * stride + tile.x0 - window.x0) as usize;
            film.sums[dst..dst + tw].copy_from_slice(&r.sums[row * tw..(row + 1) * tw]);
            let (a, at) = (aov_stride, dst * aov_stride);
            film.aov[at..at + tw * a].copy_from_slice(&r.aov[row * tw * a..(row + 1) * tw * a]);
        }
        stats.rays.add(&r.rays);
        if let Some(c) = &r.clock {
            clock.merge(c);
        }
    }
    stats.phases = clock.seconds();
    stats.shader_evaluations = clock.shader_evaluations;
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A blob with one camera of the given apertures and nothing else.
    fn camera_blob(horizontal_aperture: f32, vertical_aperture: f32) -> blob::AlignedBytes {
        let mut data = blob::SceneData::default();
        let name = data.add_string("/Cam");
        data.cameras.push(blob::Camera {
            name,
            focal_length: 50.0,
            horizontal_aperture,
            vertical_aperture,
            world_from_camera: [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
            ..blob::Camera::default()
        });
        data.info.default_camera = 0;
        data.info.dome_light = blob::NONE;
        blob::AlignedBytes::copy_from(&data.encode())
    }

    #[test]
    fn resolutions_and_memory_beyond_the_limits_are_refused_before_allocating() {
        let bytes = camera_blob(36.0, 24.0);
        let scene = Scene::new(blob::SceneView::parse(&bytes).unwrap());
        let render =
            |options: RenderOptions| render_scene(&scene, &options).map(|_| ()).unwrap_err().to_string();
        // A camera aperture of 192000 implied a 512 × 2.7 M image through the default aspect.
        let tall = camera_blob(36.0, 192_000.0);
        let tall_scene = Scene::new(blob::SceneView::parse(&tall).unwrap());
        let err = render_scene(&tall_scene, &RenderOptions::default()).map(|_| ()).unwrap_err().to_string();
        assert!(err.contains("resolution 512x2730667 (1398101504 pixels) is out of range"), "{err}");
        let err = render(RenderOptions { resolution: Some([1, 2_147_483_647]), ..RenderOptions::default() });
        assert!(err.contains("resolution 1x2147483647"), "{err}");
        let err = render(RenderOptions {
            resolution: Some([8192, 8192]),
            max_memory: Some(1 << 30),
            threads: 2,
            ..RenderOptions::default()
        });
        let needed = crate::film::memory_estimate(8192, 8192, 16, 2, &Default::default());
        assert_eq!(needed, 8192 * 8192 * (2 * 56 + 2 * 44) + 2 * 2048 * (2048 + 44));
        assert_eq!(
            err,
            format!(
                "a 8192x8192 render needs about {needed} bytes of film, path pools and AOVs, more than the \
                 limit of 1073741824 bytes (--max-memory; the default is 3/4 of the physical memory)"
            )
        );
        let err = render(RenderOptions { spp: crate::film::MAX_SPP + 1, ..RenderOptions::default() });
        assert_eq!(err, "invalid option: spp 16777217 out of range (1..=16777216)");
        assert!(crate::film::default_max_memory() > 0);
    }
}

//! One frame: validates the options, cuts the image into tiles, renders them in parallel on a local
//! rayon pool with the chosen integrator, and assembles the [`Image`]. Samples are accumulated per pixel
//! in sample order, so the image depends only on the sample keys — never on the thread count or the
//! scheduling order.

use crate::error::RenderError;
use crate::film::{tiles, Image, Sampling, TileResult};
use crate::options::{Integrator, RenderOptions};
use crate::path::PathSettings;
use crate::scene::Scene;
use crate::stats::{Counters, PhaseClock, RenderStats, StageSeconds};
use rayon::prelude::*;
use std::time::Instant;

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

fn render_with_touch<T: texture::Touch + Sync>(
    scene: &Scene,
    options: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
    touch: &T,
) -> Result<Image, RenderError> {
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
    // Before anything is allocated: the film and pools of a huge resolution (an authored one, or one
    // a camera's aperture aspect implies) must be refused, not aborted on.
    let threads = match options.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    let needed = crate::film::memory_estimate(width, height, options.tile_size, threads);
    let limit = options.max_memory.unwrap_or_else(crate::film::default_max_memory);
    if needed > limit {
        return Err(RenderError::Memory { width, height, needed, limit });
    }
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
    let tiles = tiles(width, height, ts);
    let total = tiles.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let start = Instant::now();
    let spp = options.spp;
    let settings = PathSettings { max_depth: options.max_depth, filter: options.texture_filter };
    let sampling = Sampling::new(options, width, height, camera.forward());

    let stages =
        std::sync::Mutex::new((StageSeconds::default(), Counters::default(), PhaseClock::new(false)));
    let results: Vec<TileResult> = match options.integrator {
        Integrator::Scalar => pool.install(|| {
            tiles
                .par_iter()
                .map(|tile| {
                    let r = crate::scalar::render_tile(
                        scene,
                        &camera,
                        &sampling,
                        settings,
                        options.phase_stats,
                        tile,
                        touch,
                    );
                    let finished = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    progress(finished, total);
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
        let needed = crate::film::memory_estimate(8192, 8192, 16, 2);
        assert_eq!(needed, 8192 * 8192 * 132 + 2 * 2048 * (2048 + 44));
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

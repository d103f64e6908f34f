//! Render: memory-maps a scene blob and path-traces it.
//!
//! Data flow: blob bytes ([`map_blob`] or [`read_blob`]) → [`blob::SceneView::parse`] validates them
//! once → [`Scene`] wraps the typed slices (BVH, lights; no copies) → [`render_image`] traces tiles in
//! parallel and returns an [`Image`] (beauty + albedo/normal/depth AOVs) → [`write_exr`] / [`write_png`].
//!
//! ```
//! use render::{render_image, RenderOptions};
//! // A scene with nothing but a white dome light: every pixel reads 1.
//! let mut data = blob::SceneData::default();
//! data.info.default_camera = blob::NONE;
//! data.info.dome_light = 0;
//! data.lights.push(blob::Light { kind: blob::light_kind::DOME, radiance: [1.0; 3], ..Default::default() });
//! let bytes = blob::AlignedBytes::copy_from(&data.encode());
//! let view = blob::SceneView::parse(&bytes).unwrap();
//! let options = RenderOptions { spp: 2, resolution: Some([8, 4]), ..RenderOptions::default() };
//! let image = render_image(&view, &options).unwrap();
//! assert_eq!((image.width, image.height), (8, 4));
//! assert!((image.rgb(3, 2)[1] - 1.0).abs() < 1e-6);
//! ```
//!
//! For benchmarks, [`trace_rays`] (or [`Accel::closest_hit`] / [`Accel::any_hit`]) queries the BVH
//! directly.
//!
//! Modules: [`cli`] (arguments → validated command), [`mapped`] (memory map, `unsafe fn` with its
//! contract), [`accel`] (8-wide BVH traversal, watertight triangle test, ray offsets;
//! [`accel::instanced`]: the top-level BVH over instances; [`accel::curves`]: curve and point BVH,
//! tube/ribbon/sphere tests), [`hair`] (Chiang et al. hair BSDF for curves), [`camera`],
//! [`sampler`] (stateless Owen-scrambled Sobol), [`bsdf`] (UsdPreviewSurface), [`lights`] (UsdLux +
//! emissive triangles, the light tree, MIS), [`surface`] (a hit rebuilt from the blob), [`path`]
//! (what both integrators share about a path, Russian roulette), [`scalar`] (the path, depth
//! first), [`wavefront`] (the same paths, breadth first), [`frame`] (the tile loop), [`film`]
//! (tiles, image), [`options`], [`output`] (EXR/PNG), [`stats`] (summary), [`info`] (`--info`),
//! [`scene`] (view + derived data), [`shading`] (material programs, sort keys and filtered texture
//! lookups), [`trig`] (the samplers' sine and cosine), [`error`]. Each lane kernel sits beside its
//! scalar reference as `lanes.rs` in the domain's folder (see `ARCHITECTURE.md`).

#![deny(missing_docs)]

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod cli;
#[cfg(test)]
mod dispatch_tests;
#[cfg(test)]
mod dome_tests;
pub mod error;
pub mod film;
pub mod frame;
pub mod hair;
pub mod info;
pub mod lights;
pub mod mapped;
pub mod options;
pub mod output;
pub mod path;
pub mod sampler;
pub mod scalar;
pub mod scene;
pub mod shading;
pub mod stats;
pub mod surface;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod testscene;
#[cfg(test)]
mod texture_tests;
pub mod trig;
pub mod wavefront;

pub use accel::{Accel, Hit, Ray};
pub use error::RenderError;
pub use film::Image;
pub use frame::{render_scene, render_scene_with_progress};
pub use mapped::{map_blob, parse_blob, read_blob, MappedBlob};
pub use options::{Integrator, RenderOptions};
pub use output::{write_exr, write_png};
pub use scene::Scene;
pub use stats::RenderStats;

use anyhow::Context;
use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::Instant;

/// Renders a validated blob view (prepares a [`Scene`] and calls [`render_scene`]).
pub fn render_image(view: &blob::SceneView, options: &RenderOptions) -> Result<Image, RenderError> {
    render_scene(&Scene::new(*view), options)
}

/// Closest hits of `rays` against the blob's BVH, in order (for benchmarks; single-threaded).
pub fn trace_rays(view: &blob::SceneView, rays: &[Ray]) -> Vec<Option<Hit>> {
    Accel::new(view).trace_closest(rays)
}

/// The `render` binary: parses `args`, renders or prints `--info`, reports on stderr.
pub fn run<I, T>(args: I) -> anyhow::Result<ExitCode>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    use clap::Parser;
    let args = match cli::Args::try_parse_from(args) {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return Ok(if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS });
        }
    };
    let command = args.into_command()?;
    let load_start = Instant::now();
    let blob_path = match &command {
        cli::Command::Info { blob } | cli::Command::Render { blob, .. } => blob.clone(),
    };
    // SAFETY: blobs are replaced atomically by ingest (temporary file + rename), never written in place;
    // the map lives until this function returns and nothing here writes to the file.
    let map = unsafe { map_blob(&blob_path) }?;
    let view = parse_blob(&blob_path, &map)?;
    let load_seconds = load_start.elapsed().as_secs_f64();

    match command {
        cli::Command::Info { .. } => {
            println!("{}", serde_json::to_string(&info::summarize(&view))?);
            Ok(ExitCode::SUCCESS)
        }
        cli::Command::Render { output, png, stats, options, .. } => {
            let scene = Scene::new(view);
            let bar = std::io::stderr().is_terminal().then(|| {
                let bar = indicatif::ProgressBar::new(0);
                bar.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{bar:40} {pos}/{len} tiles {elapsed_precise} eta {eta}",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                bar
            });
            let progress = |done: usize, total: usize| {
                if let Some(bar) = &bar {
                    bar.set_length(total as u64);
                    bar.set_position(done as u64);
                }
            };
            let image = render_scene_with_progress(&scene, &options, &progress)
                .with_context(|| format!("rendering {}", blob_path.display()))?;
            if let Some(bar) = &bar {
                bar.finish_and_clear();
            }
            let write_start = Instant::now();
            write_exr(&output, &image)?;
            if let Some(png) = &png {
                write_png(png, &image)?;
            }
            let mut summary =
                stats::Summary::from_render(&image.stats, image.width, image.height, options.spp);
            summary.load_seconds = load_seconds;
            summary.integrator = format!("{:?}", options.integrator).to_lowercase();
            summary.write_seconds = write_start.elapsed().as_secs_f64();
            eprintln!("{}", summary.to_text());
            if let Some(path) = &stats {
                std::fs::write(path, serde_json::to_string_pretty(&summary)?)
                    .with_context(|| format!("writing statistics to {}", path.display()))?;
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

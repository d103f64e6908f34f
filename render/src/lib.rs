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
//! Modules: [`mapped`] (memory map, `unsafe fn` with its
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
#[cfg(test)]
mod adaptive_tests;
pub mod aov;
#[cfg(test)]
mod aov_tests;
pub mod bsdf;
pub mod camera;
pub mod checkpoint;
#[cfg(test)]
mod dispatch_tests;
#[cfg(test)]
mod dof_tests;
#[cfg(test)]
mod dome_tests;
pub mod error;
pub mod film;
#[cfg(test)]
mod film_tests;
pub mod frame;
pub mod hair;
pub mod info;
pub mod lights;
pub mod mapped;
pub mod merge;
#[cfg(test)]
mod motion_tests;
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
pub use frame::{render_scene, render_scene_with_progress, Accumulation, Progress};
pub use mapped::{map_blob, parse_blob, read_blob, MappedBlob};
pub use options::{Integrator, RenderOptions};
pub use output::{write_exr, write_png};
pub use scene::Scene;
pub use stats::RenderStats;

/// Renders a validated blob view (prepares a [`Scene`] and calls [`render_scene`]).
pub fn render_image(view: &blob::SceneView, options: &RenderOptions) -> Result<Image, RenderError> {
    render_scene(&Scene::new(*view), options)
}

/// Closest hits of `rays` against the blob's BVH, in order (for benchmarks; single-threaded).
pub fn trace_rays(view: &blob::SceneView, rays: &[Ray]) -> Vec<Option<Hit>> {
    Accel::new(view).trace_closest(rays)
}

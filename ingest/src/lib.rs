//! Ingest: a USD asset becomes one scene blob.
//!
//! The data flow is USD stage → [`Scene`] → blob:
//!
//! 1. [`usd`] composes the stage through the `openusd` crate and reads it into a [`Scene`], the
//!    validated model: world-space triangulated meshes, subdivision surfaces diced against the
//!    render camera ([`dicing`]), curves, UsdPreviewSurface materials, UsdLux lights, cameras and
//!    warnings. An Alembic archive (`.abc`) is read by [`alembic`], which translates it into a
//!    USD layer for the same reader.
//! 2. [`pack`] turns the scene into a [`blob::SceneData`]: shared vertex and triangle sections,
//!    Pod records, the emissive-triangle distribution, the BVHs and the instance prototypes.
//! 3. [`blob::write_atomic`] writes its bytes, which `render` maps and validates with
//!    [`blob::SceneView::parse`].
//!
//! [`pipeline`] runs the three steps as one call, and every failure on the way is one
//! [`IngestError`] naming the file (and, for USD, the layer, prim and attribute):
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let dir = tempfile::tempdir()?;
//! let stage = dir.path().join("quad.usda");
//! std::fs::write(
//!     &stage,
//!     r#"#usda 1.0
//! def Mesh "Quad" {
//!     point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
//!     int[] faceVertexCounts = [4]
//!     int[] faceVertexIndices = [0, 1, 2, 3]
//!     uniform token subdivisionScheme = "none"
//! }
//! "#,
//! )?;
//! let output = dir.path().join("quad.blob");
//! let (scene, report) = ingest::pipeline::ingest_file(&stage, &output, &Default::default())?;
//! assert_eq!((scene.meshes.len(), report.triangles), (1, 2), "the quad is two triangles");
//!
//! let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&output)?);
//! let view = blob::SceneView::parse(&bytes)?;
//! assert_eq!(view.triangles.len(), 2);
//!
//! // A missing file is an error naming it, not a panic.
//! let missing = dir.path().join("nowhere.usda");
//! let error = ingest::pipeline::ingest_file(&missing, &output, &Default::default()).unwrap_err();
//! assert!(error.to_string().starts_with("cannot ingest "), "{error}");
//! # Ok(())
//! # }
//! ```
//!
//! The model ([`scene`]) and the packer ([`pack`], with [`curves`] and [`instancing`]) live in the
//! `scene-pack` crate, which knows neither USD nor OpenSubdiv, so that render's tests can build and
//! pack scenes without either; they are re-exported here under their old paths.
//!
//! Modules:
//! - [`scene`]: the model between reading and packing (re-exported below; from `scene-pack`).
//! - [`usd`]: the USD reader, its [`usd::UsdError`] and the openusd workarounds.
//! - [`alembic`]: the Alembic reader (Ogawa archives → a USD layer).
//! - [`dicing`]: subdivision levels and edge rates from the render camera; [`dicing::SubdivOptions`]
//!   ([`dicing::DicingCamera`] is `scene-pack`'s, re-exported).
//! - [`curves`]: curve basis conversion, NURBS fitting, adaptive splitting (from `scene-pack`).
//! - [`instancing`]: identical instances → shared prototypes (from `scene-pack`).
//! - [`pack`]: scene → blob records ([`pack::curves`] for curve splitting; private children for
//!   the dome distribution and instances; the BVH build is private), from `scene-pack`.
//! - [`pipeline`]: the whole step as one call, and the `--dump-json` listing.
//!
//! The `ingest` binary (`src/main.rs`) only parses its arguments into [`usd::LoadOptions`] and
//! [`pack::PackOptions`], calls [`pipeline`] and prints the report.

#![deny(missing_docs)]

pub mod alembic;
pub mod dicing;
mod error;
pub mod fuzz_entry;
pub mod outputs;
pub mod pipeline;
pub mod usd;

pub use scene_pack::{curves, instancing, pack, scene};

pub use error::IngestError;
pub use scene::{
    BezierSegment, Camera, CurveKind, Curves, Lens, Light, LightKind, Material, Mesh, PointSphere, Scene,
    Subdivision, UpAxis, Warning,
};

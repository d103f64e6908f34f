//! Ingest: a USD asset becomes one scene blob.
//!
//! Data flow: `usd` composes the stage through the `openusd` crate and reads it into a [`Scene`]
//! (world-space triangulated meshes, UsdPreviewSurface materials, UsdLux lights, cameras, warnings);
//! `pack` turns the scene into a [`blob::SceneData`] with a prebuilt BVH (`bvh`) and the emissive-triangle
//! distribution; [`blob::write_atomic`] writes it.
//!
//! An Alembic archive (`.abc`) is read by [`alembic`], which translates it into a USD layer for
//! the same reader.
//!
//! Modules: [`scene`] (the model), [`usd`] (the USD reader), [`alembic`] (the Alembic reader),
//! [`dicing`] (subdivision levels from the render camera), [`instancing`] (identical instances →
//! shared prototypes), [`curves`] (basis conversion, NURBS fitting, adaptive splitting), [`pack`]
//! (scene → blob records; its children split curves, sample the dome and pack instances), `bvh`,
//! [`pipeline`] (the whole step as one call).

pub mod alembic;
mod bvh;
pub mod curves;
pub mod dicing;
mod error;
pub mod instancing;
pub mod pack;
pub mod pipeline;
pub mod scene;
pub mod usd;

/// The old path of [`pack::curves`], kept while callers outside this crate (render's curve tests)
/// still name it; new code uses [`pack::curves`] or [`pack::Split`].
#[doc(hidden)]
pub use pack::curves as pack_curves;

pub use error::IngestError;
pub use scene::{
    BezierSegment, Camera, CurveKind, Curves, Light, LightKind, Material, Mesh, PointSphere, Scene,
    Subdivision, UpAxis, Warning,
};

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
//! (scene → blob records; `pack_instances` for prototypes and the top-level BVH), `bvh`,
//! [`pipeline`] (the whole step as one call).

pub mod alembic;
mod bvh;
pub mod curves;
pub mod dicing;
pub mod instancing;
pub mod pack;
pub mod pack_curves;
mod pack_dome;
mod pack_instances;
pub mod pipeline;
pub mod scene;
pub mod usd;

pub use scene::{
    BezierSegment, Camera, CurveKind, Curves, Light, LightKind, Material, Mesh, PointSphere, Scene,
    Subdivision, UpAxis, Warning,
};

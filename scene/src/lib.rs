//! The scene model between a scene format and the blob, and the packer that turns it into blob
//! records. Nothing here knows USD or OpenSubdiv.
//!
//! The data flow is [`Scene`] → [`pack`] → [`blob::SceneData`] → bytes:
//!
//! 1. A [`Scene`] is the validated model: world-space (or prototype-space) triangulated meshes,
//!    Bézier curves and point spheres, compiled material programs, lights, cameras, baked
//!    textures. Ingest's USD reader fills it (diced subdivision surfaces arrive as triangles; the
//!    validated cage rides along in [`Subdivision`] for reports), and tests build one in code.
//! 2. [`pack::pack_scene`] validates it and writes the blob records: shared vertex and triangle
//!    sections, Pod materials and lights, the emissive-triangle distribution, the BVH8 (built by
//!    obvhs' PLOC, private module `bvh`), the curve BVH after camera-driven splitting
//!    ([`pack::curves`], against a [`camera::DicingCamera`]), the instance prototypes and their
//!    top-level BVH ([`instancing`]), the dome map's distribution.
//! 3. [`blob::SceneData::encode`] gives the bytes that `render` maps and validates with
//!    [`blob::SceneView::parse`].
//!
//! ```
//! use glam::Vec3;
//! use scene_pack::{Material, Mesh, Scene};
//!
//! let quad = Mesh {
//!     path: "/Quad".into(),
//!     positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
//!     triangles: vec![[0, 1, 2], [0, 2, 3]],
//!     triangle_materials: vec![0, 0],
//!     ..Mesh::default()
//! };
//! let scene = Scene { meshes: vec![quad], materials: vec![Material::default()], ..Scene::default() };
//! let bytes = blob::AlignedBytes::copy_from(&scene_pack::pack::pack(&scene)?.encode());
//! let view = blob::SceneView::parse(&bytes)?;
//! assert_eq!(view.triangles.len(), 2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Why a crate of its own (issue 18): render's unit tests build their scenes as [`Scene`] values
//! and pack them, and they must not compile USD (`openusd`) or OpenSubdiv (`subdiv`). So the model
//! and the packer live here, and `ingest` re-exports them (`ingest::Scene`, `ingest::pack`, …)
//! for its reader, binary and users. The packer never dices: subdivision surfaces are tessellated
//! by ingest's reader before a scene exists, so the only subdivision data in the model is the
//! cage kept for reports, a plain [`cage::Topology`] (the OpenSubdiv-free half of `subdiv`).
//! Rejected: an ingest-only `Scene` wrapping this one with the subdivision list beside it (a
//! `Deref` wrapper, and every `scene.subdivisions` user and struct literal would change), and
//! dicing injected into the packer (it has never diced).
//!
//! Modules:
//! - [`scene`]: the model (re-exported below).
//! - [`pack`]: scene → blob records ([`pack::curves`] for curve splitting; private children for
//!   the dome distribution and instances); `bvh` (private) builds the BVHs.
//! - [`camera`]: the render camera as dicing and splitting see it ([`camera::DicingCamera`]).
//! - [`curves`]: curve basis conversion, NURBS fitting, adaptive splitting.
//! - [`instancing`]: identical instances → shared prototypes.

#![deny(missing_docs)]

mod bvh;
pub mod camera;
pub mod curves;
pub mod instancing;
pub mod pack;
pub mod scene;

pub use scene::{
    BezierSegment, Camera, CurveKind, Curves, DeformKey, Deformation, Lens, Light, LightKind, LightSet,
    Material, Mesh, MotionKey, PointSphere, RenderProduct, RenderVar, Scene, Subdivision, TransformMotion,
    UpAxis, Warning,
};

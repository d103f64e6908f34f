//! Subdivision surfaces for the path tracer, through OpenSubdiv 3.5's Far layer (Debian's
//! `libosd-dev`) and a small C++ shim.
//!
//! Data flow, one mesh at a time:
//!
//! 1. [`Cage`] borrows the mesh as USD authors it (`faceVertexCounts`, `faceVertexIndices`,
//!    crease chains, corners, holes, face-varying index buffers) and [`Topology::new`] validates
//!    it into an owned [`Topology`]. Bad topology stops here with an [`Error`]; OpenSubdiv never
//!    sees an out-of-range index.
//! 2. [`Refiner::new`] builds a `Far::TopologyRefiner` and refines it uniformly to a level, for
//!    instance one chosen by [`level_for_dicing_rate`]. It owns the C++ object and frees it on
//!    drop.
//! 3. [`Refiner::vertex_primvar`] and [`Refiner::face_varying_primvar`] refine any float-n
//!    primvar to that level, either as control points or on the limit surface;
//!    [`Refiner::limit`] gives limit positions and tangents.
//! 4. [`tessellate`] turns the last level into triangles with limit positions, unit limit
//!    normals (`du × dv`), limit UVs split along seams, and the cage face of each triangle (its
//!    doc has the uniform path's example, a cube at level 2).
//!
//! Or, per face instead of per level: [`AdaptiveRefiner::new`] keeps the cage unrefined and
//! lists its edges; [`AdaptiveRefiner::tessellate`] takes a number of segments per edge (for
//! instance from [`rate_for_dicing_rate`]) and evaluates each face's limit surface through
//! OpenSubdiv's Bfr interface at a `Bfr::Tessellation` of those rates, sharing the points of every
//! edge and vertex between its faces, so the mesh is watertight:
//!
//! ```
//! use subdiv::{AdaptiveRefiner, Cage, Topology};
//!
//! # let points = [
//! #     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0],
//! #     [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0],
//! # ];
//! # let indices = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7];
//! # let cage = Cage { face_vertex_counts: &[4; 6], face_vertex_indices: &indices, vertex_count: 8, ..Default::default() };
//! let refiner = AdaptiveRefiner::new(&Topology::new(&cage)?)?;
//! // Four segments on every edge: the triangles of uniform level 2.
//! let rates = vec![4; refiner.edges().len()];
//! let mesh = refiner.tessellate(&points, None, &rates, false)?.mesh;
//! assert_eq!(mesh.triangles.len(), 2 * 6 * 16);
//! # Ok::<(), subdiv::Error>(())
//! ```
//!
//! Listings that need only triangle counts plan them instead ([`UniformPlan`],
//! [`AdaptiveRefiner::planned_face_triangles`]): same counts, per cage face, no limit evaluation.
//!
//! The cage types and the error are the `cage` crate's (OpenSubdiv-free, so the scene model can
//! hold a [`Topology`]), re-exported here.
//!
//! Modules: `refine` (the refiner and primvar refinement),
//! `limit` (limit positions and tangents), `tessellate` (triangles and the dicing-rate level),
//! `adaptive` (per-face Bfr tessellation with per-edge rates), `plan` (triangle counts without
//! evaluation), `ffi` (private declarations of the shim in `shim/osd_shim.cpp`).

#![deny(missing_docs)]

mod adaptive;
mod ffi;
mod limit;
mod plan;
mod refine;
mod tessellate;

pub use adaptive::{
    level_for_rate, rate_for_dicing_rate, AdaptiveRefiner, AdaptiveTessellation, AdaptiveUv, MAX_RATE,
};
pub use cage::{
    BoundaryInterpolation, Cage, FaceVaryingChannel, FaceVaryingInterpolation, Options, Scheme, Topology,
    TriangleSubdivision, UnknownToken,
};
pub use cage::{Error, Result};
pub use limit::{normal_from_tangents, LimitSurface};
pub use plan::{uniform_face_triangles, UniformPlan};
pub use refine::{Evaluation, RefinedFaces, Refiner, MAX_LEVEL};
pub use tessellate::{level_for_dicing_rate, tessellate, Tessellation, UvSource};

#[cfg(test)]
mod adaptive_tests;
#[cfg(test)]
mod plan_tests;
#[cfg(test)]
mod tests;

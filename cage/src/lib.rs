//! A subdivision cage as data: USD's mesh topology validated into an owned [`Topology`], with no
//! OpenSubdiv in sight.
//!
//! Data flow: [`Cage`] borrows the mesh as USD authors it (`faceVertexCounts`,
//! `faceVertexIndices`, crease chains, corners, holes, face-varying index buffers);
//! [`Topology::new`] validates it into an owned [`Topology`] or stops with an [`Error`] naming the
//! attribute at fault. `subdiv` refines a `Topology` through OpenSubdiv and re-exports everything
//! here, so `subdiv::Topology` is this type.
//!
//! Why a crate of its own: the scene model (`scene-pack`) keeps each subdivision surface's
//! validated cage beside its diced triangles (for reports and re-refinement in benchmarks), and
//! render's tests build that model; holding the cage here lets the model carry it without linking
//! libosd or building the C++ shim.
//!
//! ```
//! use cage::{Cage, Topology};
//!
//! let cage = Cage {
//!     face_vertex_counts: &[4],
//!     face_vertex_indices: &[0, 1, 2, 3],
//!     vertex_count: 4,
//!     ..Default::default()
//! };
//! let topology = Topology::new(&cage)?;
//! assert_eq!((topology.face_count(), topology.vertex_count()), (1, 4));
//!
//! // An index past the points is an error naming the attribute, before OpenSubdiv sees it.
//! let bad = Cage { face_vertex_indices: &[0, 1, 2, 7], ..cage };
//! assert!(Topology::new(&bad).unwrap_err().to_string().starts_with("faceVertexIndices[3]"));
//! # Ok::<(), cage::Error>(())
//! ```
//!
//! Modules: `topology` (the cage, its options and validation), `error` ([`Error`]).

#![deny(missing_docs)]

mod error;
mod topology;

pub use error::{Error, Result};
pub use topology::{
    BoundaryInterpolation, Cage, FaceVaryingChannel, FaceVaryingInterpolation, Options, Scheme, Topology,
    TriangleSubdivision, UnknownToken,
};

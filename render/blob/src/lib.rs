//! The scene blob: one relocatable file that ingest writes and render memory-maps.
//!
//! Data flow: ingest fills a [`SceneData`] (owned vectors of `#[repr(C)]` [`bytemuck::Pod`] records whose
//! cross-references are `u32` indices), [`SceneData::encode`] lays it out as a header, a section table and
//! 64-byte-aligned sections with checksums, and [`write_atomic`] puts it on disk (temp file, fsync,
//! rename). Render maps the file and calls [`SceneView::parse`], which validates everything once —
//! magic, version, checksums, bounds, record sizes, every index, every BVH's tree shape and depth, float
//! magnitudes — and hands out typed slices that need no further checks.
//!
//! ```
//! use blob::{SceneData, SceneView, AlignedBytes};
//! let mut scene = SceneData::default();
//! scene.info.default_camera = blob::NONE;
//! scene.info.dome_light = blob::NONE;
//! let bytes = AlignedBytes::copy_from(&scene.encode());
//! let view = SceneView::parse(&bytes).unwrap();
//! assert_eq!(view.triangles.len(), 0);
//! ```
//!
//! Modules: [`records`] (the Pod records; the `MATH` shader op of MaterialX arithmetic, format 7), [`curves`] (curve and point records, format 2), [`instances`] (prototypes, instances and
//! the top-level BVH, format 5), [`dome`] (textured dome lights' maps and distributions, format 6), `container` (header and section table), the light sets of light and shadow linking ([`light_set_words`], format 8), [`outputs`] (render products, vars and light groups, format 14), [`deform`] (deforming meshes' keys and BVH, format 16), [`sequence`] (frame ranges and file-name patterns of frame sequences; no format change), `scene` (encode and
//! parse), [`tree`] (the structural proofs parse runs on every BVH and the float and size limits), `checksum`,
//! `error`, `io` (atomic write, aligned buffers). [`reseal`] recomputes a mutated blob's checksums for
//! tests and fuzzers.

#![deny(missing_docs)]

pub mod bulk;
mod checksum;
mod container;
pub mod curves;
pub mod deform;
pub mod dome;
mod error;
pub mod instances;
mod io;
pub mod outputs;
pub mod records;
mod scene;
pub mod sequence;
pub mod surface_inputs;
pub mod tree;

pub use bulk::PendingChecksums;
pub use checksum::checksum;
pub use container::reseal;
pub use container::{Header, SectionEntry, SectionKind, FORMAT_VERSION, MAGIC, SECTION_ALIGN, TEXEL_ALIGN};
pub use curves::{CurveAttributes, CurveData, CurveGroup, CurveSegment, CurveView, PointSphere};
pub use deform::{DeformData, DeformView, MeshMotion};
pub use dome::{DomeData, DomeMap, DomeView};
pub use error::BlobError;
pub use instances::{
    Instance, InstanceData, InstanceMotion, InstanceView, MotionKey, Prototype, MAX_MOTION_KEYS,
};
pub use io::{write_atomic, AlignedBytes};
pub use outputs::{OutputData, OutputView, RenderProduct, RenderVar};
pub use records::*;
pub use scene::{SceneData, SceneView};

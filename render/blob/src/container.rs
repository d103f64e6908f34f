//! The container: header, section table and 64-byte-aligned sections.
//!
//! ```text
//! offset 0   Header                    64 bytes
//! offset 64  SectionEntry × count      32 bytes each
//! ...        zero padding to 64
//! sections   each starts on a 64-byte boundary, zero padding between
//! ```
//! All integers are little-endian (the writer refuses to run on a big-endian host).

use bytemuck::{Pod, Zeroable};

/// First eight bytes of every blob.
pub const MAGIC: [u8; 8] = *b"PTSCENE\0";

/// Bumped whenever a record layout or a section's meaning changes.
pub const FORMAT_VERSION: u32 = 16;

/// Alignment of every section (a cache line; also enough for any SIMD load of records).
pub const SECTION_ALIGN: usize = 64;

/// Alignment of a non-empty [`SectionKind::TextureTexels`] section: a page, so that each texture (which
/// starts on a 4 KiB boundary of the section) shares pages only with itself once the file is mapped.
pub const TEXEL_ALIGN: usize = 4096;

/// File header. 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Header {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// [`FORMAT_VERSION`].
    pub version: u32,
    /// Number of entries in the section table.
    pub section_count: u32,
    /// Total file size in bytes.
    pub file_size: u64,
    /// Checksum of the section table bytes.
    pub table_checksum: u64,
    /// Checksum of this header's 64 bytes with this field set to zero (see [`Header::seal`]).
    pub header_checksum: u64,
    /// Reserved, zero.
    pub reserved: [u64; 3],
}
const _: () = assert!(std::mem::size_of::<Header>() == 64);

impl Header {
    /// The checksum this header should carry: all 64 bytes with `header_checksum` zeroed.
    pub fn expected_checksum(&self) -> u64 {
        crate::checksum(bytemuck::bytes_of(&Header { header_checksum: 0, ..*self }))
    }

    /// Sets `header_checksum` to match the other fields.
    pub fn seal(&mut self) {
        self.header_checksum = self.expected_checksum();
    }
}

/// One row of the section table. 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct SectionEntry {
    /// A [`SectionKind`] as `u32`.
    pub kind: u32,
    /// Size of one record in bytes (1 for byte sections).
    pub record_size: u32,
    /// Offset from the start of the file; a multiple of [`SECTION_ALIGN`].
    pub offset: u64,
    /// Length in bytes; a multiple of `record_size`.
    pub byte_len: u64,
    /// [`crate::checksum`] of the section's bytes.
    pub checksum: u64,
}
const _: () = assert!(std::mem::size_of::<SectionEntry>() == 32);

macro_rules! section_kinds {
    ($($(#[$doc:meta])* $name:ident = $value:literal,)*) => {
        /// What a section holds. Each kind appears at most once.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[repr(u32)]
        pub enum SectionKind { $($(#[$doc])* $name = $value,)* }

        impl SectionKind {
            /// Every kind, in table order.
            pub const ALL: &'static [SectionKind] = &[$(SectionKind::$name,)*];

            /// Position of the kind in [`SectionKind::ALL`].
            pub fn slot(self) -> usize {
                // Every kind is in ALL, so the fallback is never taken.
                Self::ALL.iter().position(|&k| k == self).unwrap_or(0)
            }

            /// The kind for a raw table value.
            pub fn from_u32(value: u32) -> Option<Self> {
                match value { $($value => Some(SectionKind::$name),)* _ => None }
            }
        }
    };
}

section_kinds! {
    /// One [`crate::SceneInfo`].
    SceneInfo = 1,
    /// UTF-8 bytes referenced by [`crate::StrRef`].
    Strings = 2,
    /// `[f32; 3]` world-space vertex positions.
    Positions = 3,
    /// `[f32; 3]` world-space unit shading normals (per vertex, meshes with `MESH_HAS_NORMALS`).
    Normals = 4,
    /// `[f32; 2]` texture coordinates (per vertex, meshes with `MESH_HAS_UVS`).
    Uvs = 5,
    /// [`crate::Triangle`].
    Triangles = 6,
    /// `u32` material index per triangle.
    TriangleMaterials = 7,
    /// [`crate::Mesh`].
    Meshes = 8,
    /// [`crate::Material`].
    Materials = 9,
    /// [`crate::Light`].
    Lights = 10,
    /// [`crate::Camera`].
    Cameras = 11,
    /// [`crate::EmissiveTriangle`].
    EmissiveTriangles = 12,
    /// [`crate::BvhNode`] over the top-level (world-space) triangles; node 0 is the root. (Kinds 13 and 14 held the compressed CWBVH of format 1.)
    BvhNodes = 20,
    /// [`crate::TriangleBlock`]s of the BVH leaves.
    BvhTriangleBlocks = 21,
    /// [`crate::TextureRecord`]. Texture kinds start at 30 so that other section kinds can be added
    /// below them without renumbering.
    TextureRecords = 30,
    /// [`crate::UdimSet`].
    UdimSets = 31,
    /// `u32` texture index (or [`crate::NONE`]) per UDIM grid cell.
    UdimTiles = 32,
    /// Texel bytes of every texture; starts on a [`TEXEL_ALIGN`] boundary when non-empty.
    TextureTexels = 33,
    /// [`crate::ShaderOp`]: every material's program, concatenated.
    ShaderOps = 34,
    /// [`crate::PrimvarRecord`]: the primvars material programs read, sorted by (mesh, name id).
    Primvars = 35,
    /// `[f32; 4]` primvar values referenced by [`crate::PrimvarRecord`]s.
    PrimvarValues = 36,
    /// [`crate::CurveGroup`] (curve and point prims; format 2).
    CurveGroups = 40,
    /// [`crate::CurveSegment`] (cubic Bézier pieces).
    CurveSegments = 41,
    /// [`crate::CurveAttributes`], one per curve segment.
    CurveAttributes = 42,
    /// [`crate::PointSphere`].
    PointSpheres = 43,
    /// [`crate::CwBvhNode`] of the curve BVH; node 0 is the root.
    CurveBvhNodes = 44,
    /// `u32` segment-or-sphere index per curve BVH primitive slot.
    CurveBvhPrimitives = 45,
    /// [`crate::Prototype`] (two-level instancing; format 5). Kinds 50–55 are instancing.
    Prototypes = 50,
    /// [`crate::Instance`].
    Instances = 51,
    /// [`crate::BvhNode`] of the top-level BVH over instances; node 0 is the root.
    InstanceBvhNodes = 52,
    /// `u32` instance index per top-level BVH leaf slot.
    InstanceBvhItems = 53,
    /// [`crate::BvhNode`] of every prototype's BVH, concatenated (absolute child indices).
    PrototypeBvhNodes = 54,
    /// [`crate::TriangleBlock`] of every prototype's BVH, vertices in prototype space.
    PrototypeBvhBlocks = 55,
    /// [`crate::InstanceMotion`]: the key range of each moving instance (format 13).
    InstanceMotions = 56,
    /// [`crate::MotionKey`]: every moving instance's and moving camera's transform keys, concatenated.
    MotionKeys = 57,
    /// [`crate::DomeMap`] (textured dome lights; format 6).
    DomeMaps = 60,
    /// `f32` CDF values of the dome maps' distributions.
    DomeCdfValues = 61,
    /// `u32` words of the light sets (light and shadow linking; format 8): see
    /// [`crate::light_set_words`] for the layout.
    LightSets = 70,
    /// [`crate::RenderProduct`] (render outputs; format 14).
    RenderProducts = 80,
    /// [`crate::RenderVar`] of every product, concatenated.
    RenderVars = 81,
    /// [`crate::StrRef`] light group per light, or none.
    LightGroups = 82,
    /// [`crate::MeshMotion`] per deforming mesh (deformation motion; format 16). Kinds 90–94 are
    /// deformation (see [`crate::deform`]).
    MeshMotions = 90,
    /// `f32` key times of the deforming meshes.
    MeshMotionTimes = 91,
    /// `[f32; 3]` keyed positions of the deforming meshes.
    MeshMotionPoints = 92,
    /// [`crate::BvhNode`] of the BVH over the deforming triangles; node 0 is the root.
    DeformBvhNodes = 93,
    /// [`crate::TriangleBlock`]s of its leaves.
    DeformBvhBlocks = 94,
}

/// Recomputes, in place, every section checksum whose section lies inside `bytes`, then the table's and
/// the header's checksums, so that only structural validation stands between mutated bytes and render.
/// For tests and fuzzers that craft blobs (an adversary can do the same, which is why
/// [`crate::SceneView::parse`] never relies on checksums for safety). `file_size` becomes the buffer's
/// length, so truncations and extensions reach the section checks too. Does nothing to a buffer too
/// short for its header; only the header is resealed when the table does not fit.
pub fn reseal(bytes: &mut [u8]) {
    let header_len = std::mem::size_of::<Header>();
    let entry_len = std::mem::size_of::<SectionEntry>();
    if bytes.len() < header_len {
        return;
    }
    let mut header: Header = bytemuck::pod_read_unaligned(&bytes[..header_len]);
    header.file_size = bytes.len() as u64;
    let table_end = header_len as u64 + header.section_count as u64 * entry_len as u64;
    if table_end > bytes.len() as u64 {
        header.seal();
        bytes[..header_len].copy_from_slice(bytemuck::bytes_of(&header));
        return;
    }
    for i in 0..header.section_count as usize {
        let at = header_len + i * entry_len;
        let mut entry: SectionEntry = bytemuck::pod_read_unaligned(&bytes[at..at + entry_len]);
        let end = entry.offset.checked_add(entry.byte_len);
        if let Some(end) = end.filter(|&e| e <= bytes.len() as u64) {
            entry.checksum = crate::checksum(&bytes[entry.offset as usize..end as usize]);
            bytes[at..at + entry_len].copy_from_slice(bytemuck::bytes_of(&entry));
        }
    }
    header.table_checksum = crate::checksum(&bytes[header_len..table_end as usize]);
    header.seal();
    bytes[..header_len].copy_from_slice(bytemuck::bytes_of(&header));
}

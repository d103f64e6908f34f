//! Plain-old-data records that ingest copies into blob sections and render reads back in place.
//!
//! [`TextureRecord`] (with [`MAX_MIP_LEVELS`] and [`NONE`]) is defined once, in the blob crate
//! (`blob::records`), and re-exported here; its layout table is documented there.
//!
//! No record holds a pointer: texel locations are byte offsets from the start of the texel array, texture
//! references are indices into the texture table. All are `#[repr(C)]` + [`bytemuck::Pod`] with their size
//! `const`-asserted, so a blob written on one machine reads on another of the same endianness
//! (little-endian; texels are decoded with `from_le_bytes`).

use bytemuck::{Pod, Zeroable};

// The blob's own record: one definition, so the builder's table is the blob's section as it is.
pub use blob::records::{TextureRecord, MAX_MIP_LEVELS, NONE};

/// Largest supported width or height: `2^(MAX_MIP_LEVELS - 1)` (the blob's
/// [`blob::records::MAX_TEXTURE_DIMENSION`]).
pub const MAX_DIMENSION: u32 = blob::records::MAX_TEXTURE_DIMENSION;

/// A UDIM set: a `u_count × v_count` window of the UDIM grid in the tile table. 16 bytes, align 4.
///
/// Tile `(u, v)` (UDIM number `1001 + u + 10 v`) is `udim_tiles[first_tile + v * u_count + u]`, a texture
/// index or [`NONE`]. `u_count <= 10`; `v_count` covers the highest row found on disk.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct UdimSetRecord {
    /// Index of tile 1001 in the shared tile table.
    pub first_tile: u32,
    /// Columns (`u`) present: highest `u` found plus one.
    pub u_count: u32,
    /// Rows (`v`) present: highest `v` found plus one.
    pub v_count: u32,
    /// Zero.
    pub reserved: u32,
}
const _: () = assert!(size_of::<UdimSetRecord>() == 16);

//! Plain-old-data records that ingest copies into blob sections and render reads back in place.
//!
//! [`TextureRecord`] (with [`MAX_MIP_LEVELS`] and [`NONE`]) is defined once, in the blob crate
//! (`blob::records`), and re-exported here; its layout table is documented there.
//!
//! No record holds a pointer: texel locations are byte offsets from the start of the texel array, texture
//! references are indices into the texture table. All are `#[repr(C)]` + [`bytemuck::Pod`] with their size
//! `const`-asserted, so a blob written on one machine reads on another of the same endianness
//! (little-endian; texels are decoded with `from_le_bytes`).

// The blob's own record: one definition, so the builder's table is the blob's section as it is.
pub use blob::records::{TextureRecord, MAX_MIP_LEVELS, NONE};

/// Largest supported width or height: `2^(MAX_MIP_LEVELS - 1)` (the blob's
/// [`blob::records::MAX_TEXTURE_DIMENSION`]).
pub const MAX_DIMENSION: u32 = blob::records::MAX_TEXTURE_DIMENSION;

/// A UDIM set: the blob's record (one definition; see [`blob::UdimSet`]).
pub use blob::UdimSet as UdimSetRecord;

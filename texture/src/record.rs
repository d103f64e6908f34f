//! Plain-old-data records that ingest copies into blob sections and render reads back in place.
//!
//! No record holds a pointer: texel locations are byte offsets from the start of the texel array, texture
//! references are indices into the texture table. All are `#[repr(C)]` + [`bytemuck::Pod`] with their size
//! `const`-asserted, so a blob written on one machine reads on another of the same endianness
//! (little-endian; texels are decoded with `from_le_bytes`).

use bytemuck::{Pod, Zeroable};

/// Most mip levels a texture may have: enough for [`MAX_DIMENSION`] down to 1×1.
pub const MAX_MIP_LEVELS: usize = 16;

/// Largest supported width or height: `2^(MAX_MIP_LEVELS - 1)`.
pub const MAX_DIMENSION: u32 = 1 << (MAX_MIP_LEVELS - 1);

/// Marks a hole in a UDIM tile table.
pub const NONE: u32 = u32::MAX;

/// One baked texture: its size, texel format and where each mip level starts. 168 bytes, align 8.
///
/// | offset | field           | meaning                                                             |
/// |-------:|-----------------|---------------------------------------------------------------------|
/// | 0      | `width`         | level-0 width in texels; level `l` is `max(1, width >> l)`          |
/// | 4      | `height`        | level-0 height, halved the same way                                 |
/// | 8      | `channels`      | stored channels: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA                |
/// | 12     | `format`        | [`crate::TexelFormat`] discriminant                                 |
/// | 16     | `mip_count`     | levels stored, `floor(log2(max(width, height))) + 1` (down to 1×1)  |
/// | 20     | `tile_log2`     | tiles are `2^tile_log2` texels square (clipped to the level)        |
/// | 24     | `reserved`      | zero                                                                |
/// | 32     | `byte_len`      | bytes from `level_offsets[0]` to the end of the last level          |
/// | 40     | `level_offsets` | byte offset of each level in the texel array; unused entries zero   |
///
/// Within a level, tiles are stored row-major and each tile's texels row-major, channels interleaved
/// (see [`crate::layout::LevelLayout`]). Rows run bottom-up: row 0 is the bottom of the image, so the USD
/// texture coordinate `t` maps to rows without a flip.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct TextureRecord {
    /// Level-0 width in texels.
    pub width: u32,
    /// Level-0 height in texels.
    pub height: u32,
    /// Stored channels per texel, 1..=4.
    pub channels: u32,
    /// [`crate::TexelFormat`] as `u32`.
    pub format: u32,
    /// Number of mip levels stored.
    pub mip_count: u32,
    /// log2 of the tile edge in texels.
    pub tile_log2: u32,
    /// Zero; keeps `byte_len` 8-aligned without implicit padding.
    pub reserved: [u32; 2],
    /// Total bytes of all levels, starting at `level_offsets[0]`.
    pub byte_len: u64,
    /// Byte offset of each level from the start of the texel array.
    pub level_offsets: [u64; MAX_MIP_LEVELS],
}
const _: () = assert!(size_of::<TextureRecord>() == 168);
const _: () = assert!(align_of::<TextureRecord>() == 8);

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

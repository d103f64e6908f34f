//! Textures for the path tracer: decode once at ingest, look up in place at render.
//!
//! Textures live in the memory-mapped blob, and the OS page cache is the tile cache. The crate therefore
//! has two halves that meet only at four flat tables of plain data:
//!
//! ```text
//!  ingest (allocates)                                         render (borrows, never allocates)
//!  file ──decode──▶ SourceImage ──bake──▶ BakedTexture ──▶ TextureSetBuilder ──▶ TextureSet
//!  (png jpg tga tif hdr exr;   (linearise, mip chain in      (UDIM expansion,      records, udim_sets,
//!   <UDIM> patterns)             f32, quantise, tile)          dedup, rebasing)     udim_tiles, texels
//!                                                                                       │ blob sections
//!                                             TextureSetView::new(&[..], &[..], &[..], &[u8]) (validate once)
//!                                                     │
//!                         sample(&TextureView, uv, duv_dx, duv_dy, filter, wrap_s, wrap_t) → linear RGBA
//!                         TextureSetView::sample_udim(set, &Lookup, fallback)              → linear RGBA
//! ```
//!
//! Records are `#[repr(C)]` [`bytemuck::Pod`] ([`TextureRecord`], 168 bytes, the blob crate's record
//! re-exported; [`UdimSetRecord`], 16 bytes) whose texel locations are byte offsets into the texel
//! array, so ingest copies them without fix-ups.
//! Texels are stored as sRGB-encoded `u8` (8-bit sources), linear `u8` (8-bit `raw`) or linear `f16`
//! (16-bit and float sources), keeping the source's 1–4 channels; lookups decode to linear RGBA.
//!
//! ```
//! use texture::{sample, BakeOptions, Filter, SourceImage, Samples, TextureSetBuilder, Wrap};
//!
//! // A 2×1 8-bit grey image: black, white (sRGB).
//! let src = SourceImage { width: 2, height: 1, channels: 1, samples: Samples::U8(vec![0, 255]) };
//! let mut builder = TextureSetBuilder::new();
//! let index = builder.add_baked(texture::bake(&src, &BakeOptions::default())?);
//! let set = builder.finish(); // ingest writes set.records, set.texels, ... into the blob
//!
//! // Render side: borrowed slices (from the mapped blob), validated once.
//! let view = texture::TextureSetView::new(&set.records, &set.udim_sets, &set.udim_tiles, &set.texels)?;
//! let tex = view.texture(index).unwrap();
//! let zero = [0.0; 2];
//! // Between the two texel centres, magnified: the bilinear average in linear space.
//! let rgba = sample(&tex, [0.5, 0.5], zero, zero, Filter::Moonray, Wrap::Clamp, Wrap::Clamp);
//! assert_eq!(rgba, [0.5, 0.5, 0.5, 1.0]);
//! // A footprint of the whole image selects the 1×1 level: the linear mean 0.5, re-encoded as sRGB 188
//! // (0.5029). Averaging the sRGB codes instead would have given 0.216.
//! let rgba = sample(&tex, [0.25, 0.5], [1.0, 0.0], zero, Filter::Trilinear, Wrap::Repeat, Wrap::Repeat);
//! assert!((rgba[0] - 0.5029).abs() < 1e-4);
//! # Ok::<(), texture::Error>(())
//! ```
//!
//! Modules:
//! - [`format`](mod@format): colour space, texel format, wrap and filter enums (parsed from USD tokens);
//! - [`srgb`]: the 256-entry decode table and the exact curves;
//! - [`half_float`]: `f16` texels to `f32`, F16C chosen at run time;
//! - [`float`]: `floor` and `round` without libm calls;
//! - [`decode`](mod@decode): files → [`SourceImage`];
//! - [`mip`]: linear mip chain with exact odd-size filtering;
//! - [`layout`]: tiled addressing shared by bake and lookup;
//! - [`bake`](mod@bake): [`SourceImage`] → [`BakedTexture`];
//! - [`udim`]: `<UDIM>` pattern expansion;
//! - [`record`]: the Pod records ([`TextureRecord`] is `blob::TextureRecord`);
//! - [`set`]: the builder and the validated view over the four tables;
//! - [`sample`](mod@sample): filtered lookups;
//! - [`stats`]: texel-byte counting for `--stats`;
//! - [`sort_key`]: the shading sort key for the wavefront integrator.
#![deny(missing_docs)]

pub mod bake;
pub mod decode;
pub mod error;
pub mod float;
pub mod format;
pub mod half_float;
pub mod layout;
pub mod mip;
pub mod record;
pub mod sample;
pub mod set;
pub mod sort_key;
pub mod srgb;
pub mod stats;
pub mod udim;

#[cfg(test)]
mod tests;

pub use bake::{bake, BakeOptions, BakedTexture};
pub use decode::{
    decode, decode_bytes, decode_bytes_with, decode_with, DecodeLimits, Samples, SourceImage,
    DEFAULT_MAX_PIXELS,
};
pub use error::{Error, ErrorKind, Warning};
pub use format::{ColorSpace, Filter, TexelFormat, Wrap};
pub use record::{TextureRecord, UdimSetRecord, MAX_DIMENSION, MAX_MIP_LEVELS, NONE};
pub use sample::{
    mip_level, sample, sample_lanes_with, sample_with, Lookup, LookupLanes, TextureView, EWA_ALPHA,
    EWA_FOOTPRINT_SCALE, MAX_ANISOTROPY,
};
pub use set::{TextureRef, TextureSet, TextureSetBuilder, TextureSetView};
pub use sort_key::{shading_sort_key, shading_sort_key_saturating};
pub use stats::{BytesRead, NoTouch, PageTouches, Touch};

//! [`SourceImage`] → [`BakedTexture`]: linearise, build the mip chain, quantise, tile.
//!
//! Stored format (the crate keeps the source's channel count — a grey roughness map costs one byte per
//! texel, not four — and lookups expand to RGBA):
//! - 8-bit source, `auto` or `sRGB` → [`TexelFormat::Srgb8`] (colour sRGB-encoded, alpha linear);
//! - 8-bit source, `raw` → [`TexelFormat::Unorm8`];
//! - 16-bit or float source → [`TexelFormat::F16`], linear. An explicit `sRGB` on such a source is decoded
//!   at bake time, since half floats have the precision to hold linear values.

use crate::decode::{Samples, SourceImage};
use crate::error::Error;
use crate::format::{ColorSpace, TexelFormat};
use crate::layout::LevelLayout;
use crate::mip::{build_pyramid, LinearImage};
use crate::record::{TextureRecord, MAX_MIP_LEVELS};
use crate::srgb::{encode_srgb8, quantize8, srgb_to_linear, SRGB_TO_LINEAR};

/// Default tile edge: 64 texels, so an RGBA8 tile is 16 KiB (four 4 KiB pages) and an RGBA16F tile 32 KiB.
pub const DEFAULT_TILE_LOG2: u32 = 6;

/// Each level starts on a cache line, so a later SIMD pass can use aligned loads within a tile row.
const LEVEL_ALIGN: usize = 64;

/// How to bake one texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BakeOptions {
    /// UsdUVTexture `sourceColorSpace`.
    pub color_space: ColorSpace,
    /// log2 of the tile edge, 2..=12.
    pub tile_log2: u32,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions { color_space: ColorSpace::Auto, tile_log2: DEFAULT_TILE_LOG2 }
    }
}

/// One baked texture: its record (offsets relative to the start of `texels`) and its texel bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedTexture {
    /// Header; `level_offsets` are relative to `texels[0]` until the texture is added to a set.
    pub record: TextureRecord,
    /// All levels, tiled.
    pub texels: Vec<u8>,
}

/// `true` if stored channel `ch` of a `channels`-channel texel is alpha (never sRGB-encoded).
#[inline]
pub(crate) fn is_alpha(ch: usize, channels: usize) -> bool {
    (channels == 2 && ch == 1) || (channels == 4 && ch == 3)
}

/// The format a source with this bit depth and colour space is stored in.
pub fn stored_format(samples: &Samples, color_space: ColorSpace) -> TexelFormat {
    match (samples, color_space) {
        (Samples::U8(_), ColorSpace::Auto | ColorSpace::Srgb) => TexelFormat::Srgb8,
        (Samples::U8(_), ColorSpace::Raw) => TexelFormat::Unorm8,
        _ => TexelFormat::F16,
    }
}

/// Source → linear `f32`, rows flipped to bottom-up so that `t = 0` is the bottom of the image (USD).
fn linearize(src: &SourceImage, color_space: ColorSpace) -> LinearImage {
    let c = src.channels as usize;
    let row = src.width as usize * c;
    let srgb = match &src.samples {
        Samples::U8(_) => color_space != ColorSpace::Raw,
        _ => color_space == ColorSpace::Srgb,
    };
    let convert = |i: usize, v: f32| if srgb && !is_alpha(i % c, c) { srgb_to_linear(v) } else { v };
    let flat: Vec<f32> = match &src.samples {
        Samples::U8(v) => v
            .iter()
            .enumerate()
            .map(
                |(i, &b)| {
                    if srgb && !is_alpha(i % c, c) {
                        SRGB_TO_LINEAR[b as usize]
                    } else {
                        b as f32 / 255.0
                    }
                },
            )
            .collect(),
        Samples::U16(v) => v.iter().enumerate().map(|(i, &s)| convert(i, s as f32 / 65535.0)).collect(),
        Samples::F32(v) => v.iter().enumerate().map(|(i, &s)| convert(i, s)).collect(),
    };
    let data = flat.chunks_exact(row).rev().flatten().copied().collect();
    LinearImage { width: src.width, height: src.height, channels: src.channels, data }
}

/// Writes one linear level into its tiled slot, quantising to `format`.
fn write_level(level: &LinearImage, format: TexelFormat, layout: &LevelLayout, out: &mut [u8]) {
    let c = level.channels as usize;
    let cb = format.channel_bytes() as usize;
    for y in 0..level.height {
        for x in 0..level.width {
            let src = &level.data[(y as usize * level.width as usize + x as usize) * c..][..c];
            let dst = &mut out[layout.texel_offset(x, y)..][..c * cb];
            for (ch, &v) in src.iter().enumerate() {
                match format {
                    TexelFormat::Srgb8 if !is_alpha(ch, c) => dst[ch] = encode_srgb8(v),
                    TexelFormat::Srgb8 | TexelFormat::Unorm8 => dst[ch] = quantize8(v),
                    TexelFormat::F16 => {
                        dst[2 * ch..2 * ch + 2].copy_from_slice(&half::f16::from_f32(v).to_le_bytes())
                    }
                }
            }
        }
    }
}

/// Bakes a decoded image into a tiled mip chain. Fails only on invalid images (zero or oversized sides,
/// bad channel counts) or an out-of-range `tile_log2`.
pub fn bake(src: &SourceImage, options: &BakeOptions) -> Result<BakedTexture, Error> {
    let nowhere = std::path::Path::new("");
    src.validate(nowhere)?;
    if !(2..=12).contains(&options.tile_log2) {
        return Err(Error::invalid("bake options", 0, "tile_log2 must be in 2..=12"));
    }
    let format = stored_format(&src.samples, options.color_space);
    let levels = build_pyramid(linearize(src, options.color_space));
    debug_assert!(levels.len() <= MAX_MIP_LEVELS);

    let texel_bytes = src.channels * format.channel_bytes();
    let mut record = TextureRecord {
        width: src.width,
        height: src.height,
        channels: src.channels,
        format: format as u32,
        mip_count: levels.len() as u32,
        tile_log2: options.tile_log2,
        reserved: [0; 2],
        byte_len: 0,
        level_offsets: [0; MAX_MIP_LEVELS],
    };
    let mut texels = Vec::new();
    for (l, level) in levels.iter().enumerate() {
        let base = texels.len().next_multiple_of(LEVEL_ALIGN);
        let layout = LevelLayout::new(src.width, src.height, l as u32, options.tile_log2, texel_bytes, base);
        debug_assert_eq!((layout.width, layout.height), (level.width, level.height));
        texels.resize(base + layout.byte_len(), 0);
        write_level(level, format, &layout, &mut texels);
        record.level_offsets[l] = base as u64;
    }
    record.byte_len = texels.len() as u64;
    Ok(BakedTexture { record, texels })
}

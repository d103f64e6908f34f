//! Tap addresses of the lane filter, lane by lane and without branches: each lane's level geometry
//! ([`LayoutLanes`], the lane form of [`crate::layout::LevelLayout`]), its wrapped integer coordinates
//! ([`wrap_lanes`], the wrap mode resolved once per call) and the tiled byte offsets ([`offsets`]).
//!
//! The scalar filter addresses one texel at a time through `LevelLayout::texel_offset` after
//! `super::wrap`; these compute the same integers for eight lanes. Written as straight-line lane loops so
//! that the AVX2 instantiation of the lane filter compiles them to vector shifts, multiplies and
//! selects: the branchy per-lane addressing they replace (a layout cache lookup, a `match` on the wrap
//! mode and a range test per coordinate) was most of `moonray_lanes`' instructions.

// Lane loops index several columns by the same lane number.
#![allow(clippy::needless_range_loop)]

use super::lanes::LANES;
use super::{rem_euclid, NO_TEXEL};
use crate::format::Wrap;
use crate::record::{TextureRecord, MAX_MIP_LEVELS};

/// One level's geometry per lane (each lane may address its own level).
pub(super) struct LayoutLanes {
    pub(super) width: [u32; LANES],
    pub(super) height: [u32; LANES],
    tile_w: [u32; LANES],
    tile_h: [u32; LANES],
    tiles_x: [u32; LANES],
    base: [u64; LANES],
}

impl LayoutLanes {
    /// The geometry of level `level[k]` in lane `k`: `LevelLayout::new`'s shifts, lane by lane.
    #[inline(always)]
    pub(super) fn new(rec: &TextureRecord, level: &[u32; LANES]) -> Self {
        let tile_log2 = rec.tile_log2;
        let tile = 1u32 << tile_log2;
        let mut out = LayoutLanes {
            width: [0; LANES],
            height: [0; LANES],
            tile_w: [0; LANES],
            tile_h: [0; LANES],
            tiles_x: [0; LANES],
            base: [0; LANES],
        };
        for k in 0..LANES {
            let width = (rec.width >> level[k]).max(1);
            let height = (rec.height >> level[k]).max(1);
            out.width[k] = width;
            out.height[k] = height;
            out.tile_w[k] = width.min(tile);
            out.tile_h[k] = height.min(tile);
            out.tiles_x[k] = if width <= tile { 1 } else { (width + tile - 1) >> tile_log2 };
            // Levels are below `mip_count <= MAX_MIP_LEVELS`; the mask only spares a bounds check.
            out.base[k] = rec.level_offsets[level[k] as usize & (MAX_MIP_LEVELS - 1)];
        }
        out
    }
}

/// `super::wrap` of coordinate `i[k]` into `0..n[k]` per lane; a lane whose texel lies on a black
/// border clears `valid[k]` (its coordinate is then 0, a safe address that is never read).
/// `POW2`: every `n[k]` is a power of two, so the Euclidean remainders are masks (the same integers
/// `rem_euclid` computes; they vectorize, the division does not).
#[inline(always)]
pub(super) fn wrap_lanes<const POW2: bool>(
    i: &[i32; LANES],
    n: &[u32; LANES],
    mode: Wrap,
    valid: &mut [bool; LANES],
) -> [u32; LANES] {
    let mut out = [0u32; LANES];
    // `n <= MAX_DIMENSION`, so `n` and `2n` fit in `i32`.
    let remainder = |i: i32, n: i32| if POW2 { i & (n - 1) } else { rem_euclid(i, n) };
    match mode {
        Wrap::Repeat => {
            for k in 0..LANES {
                out[k] = remainder(i[k], n[k] as i32) as u32;
            }
        }
        Wrap::Mirror => {
            for k in 0..LANES {
                let n = n[k] as i32;
                let m = remainder(i[k], 2 * n);
                out[k] = if m < n { m } else { 2 * n - 1 - m } as u32;
            }
        }
        Wrap::Clamp => {
            for k in 0..LANES {
                out[k] = i[k].clamp(0, n[k] as i32 - 1) as u32;
            }
        }
        Wrap::Black => {
            for k in 0..LANES {
                let inside = (i[k] as u32) < n[k];
                valid[k] &= inside;
                out[k] = if inside { i[k] as u32 } else { 0 };
            }
        }
    }
    out
}

/// Byte offsets of texels `(x[k], y[k])` (already wrapped into their lane's level) in the texel array,
/// `NO_TEXEL` where `valid[k]` is false: `LevelLayout::texel_offset` per lane. The texel index within
/// a level stays below `MAX_DIMENSION²` = 2³⁰ (edge tiles pad to at most `MAX_DIMENSION` per axis), so
/// it is computed in `u32`.
#[inline(always)]
pub(super) fn offsets(
    lv: &LayoutLanes,
    tile_log2: u32,
    texel_bytes: u32,
    x: &[u32; LANES],
    y: &[u32; LANES],
    valid: &[bool; LANES],
) -> [usize; LANES] {
    let mask = (1u32 << tile_log2) - 1;
    let mut out = [0usize; LANES];
    for k in 0..LANES {
        let tile = (y[k] >> tile_log2) * lv.tiles_x[k] + (x[k] >> tile_log2);
        let within = (y[k] & mask) * lv.tile_w[k] + (x[k] & mask);
        let texel = tile * (lv.tile_w[k] * lv.tile_h[k]) + within;
        let offset = lv.base[k] as usize + texel as usize * texel_bytes as usize;
        out[k] = if valid[k] { offset } else { NO_TEXEL };
    }
    out
}

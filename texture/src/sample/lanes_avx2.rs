//! The MoonRay lane filter's addressing and 8-bit texel reads in AVX2 intrinsics, bit-identical to
//! the portable lane filter's per-lane addressing (`Sampler::address`, the scalar lookup's) and
//! [`super::Decode::gather`], and so to the scalar lookup.
//!
//! - [`addresses`]: every tap's byte offset for eight lanes in vector registers — level geometry by
//!   variable shifts, `floor` by `vroundps` (the same bits as [`crate::float::floor`]; a NaN comes back
//!   quietened, and only feeds `as i32`, which makes it 0 either way, and the bilinear weight, where
//!   `x - floor(x)` returns `x`'s NaN either way), `as i32` by `vcvttps2dq` plus its saturation fix-ups,
//!   the wrap mode resolved once per call, the level bases by one gather from the record.
//! - [`levels`]: footprint lengths, `log2` (ours, [`log2`]: the scalar lookup's, in `f64` lanes)
//!   and the level pair.
//! - [`gather_blend_u8`]: one `vpgatherdd` reads a tap's eight texels (a 32-bit word at each lane's
//!   offset); sRGB colour channels decode through one `vgatherdps` from [`SRGB_TO_LINEAR`] each,
//!   unorm channels and alpha as `code as f32 * (1/255)` — the scalar decode's table entries and
//!   products — and the blend follows in the same registers.
//!
//! Only reached from the AVX2 instantiation of the lane filter, after `is_x86_feature_detected!`,
//! and only for textures whose level-0 sizes are powers of two (so wraps are masks; other sizes divide)
//! in texel arrays under 2 GiB (offsets in 32-bit lanes); everything else takes the portable loops.

// Tap loops index several tables by the same tap number.
#![allow(clippy::needless_range_loop)]

use super::level_lanes::LevelLanes;
use super::log2::{SERIES, SQRT_HALF_BITS, TWO_POW_23};
use crate::format::Wrap;
use crate::record::TextureRecord;
use crate::srgb::SRGB_TO_LINEAR;
use lanekit::{Lanes, LANES};
use std::arch::x86_64::*;

/// Byte offsets of the four taps of eight lanes, in 32-bit lanes, with the lanes that read.
pub(super) struct TapOffsets {
    /// Byte offset of each tap in the texel array (0 where the tap is absent).
    pub(super) offset: [[i32; LANES]; 4],
    /// `-1` where the lane reads the tap, `0` where not.
    pub(super) present: [[i32; LANES]; 4],
}

/// Loads eight lanes.
#[inline(always)]
fn load_i(v: &[i32; LANES]) -> __m256i {
    // SAFETY: `[i32; 8]` is 32 readable bytes; unaligned load.
    unsafe { _mm256_loadu_si256(v.as_ptr() as *const __m256i) }
}

#[inline(always)]
fn load_f(v: &Lanes) -> __m256 {
    // SAFETY: `[f32; 8]` is 32 readable bytes; unaligned load.
    unsafe { _mm256_loadu_ps(v.as_ptr()) }
}

#[inline(always)]
fn store_i(v: __m256i, out: &mut [i32; LANES]) {
    // SAFETY: `[i32; 8]` is 32 writable bytes; unaligned store.
    unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, v) }
}

#[inline(always)]
fn store_f(v: __m256, out: &mut Lanes) {
    // SAFETY: `[f32; 8]` is 32 writable bytes; unaligned store.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) }
}

/// `levels` of the portable lanes (`mip_level` and `level_pair` per lane) in registers: the
/// footprint lengths, [`log2`], the level pair and its weight. Lanes that magnify get levels 0 and
/// weight 0 (the portable loops leave other values there; no one reads them).
#[target_feature(enable = "avx2")]
pub(super) fn levels(w: f32, h: f32, last: u32, duv_dx: &[Lanes; 2], duv_dy: &[Lanes; 2]) -> LevelLanes {
    let level = log2(footprint_sizes(w, h, duv_dx, duv_dy));
    let magnify = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_NGT_UQ>(level, _mm256_setzero_ps()));
    // `f32::min` and `vminps` agree where the level is a number, as it is in every lane that reads it.
    let clamped = _mm256_min_ps(level, _mm256_set1_ps(last as f32));
    let l0f = _mm256_floor_ps(clamped);
    let l0 = _mm256_cvttps_epi32(l0f);
    let l1 = _mm256_min_epi32(_mm256_add_epi32(l0, _mm256_set1_epi32(1)), _mm256_set1_epi32(last as i32));
    let mut out = LevelLanes::default();
    store_i(magnify, &mut out.magnify);
    store_i(_mm256_andnot_si256(magnify, l0), &mut out.l0);
    store_i(_mm256_andnot_si256(magnify, l1), &mut out.l1);
    let t = _mm256_sub_ps(clamped, l0f);
    store_f(_mm256_andnot_ps(_mm256_castsi256_ps(magnify), t), &mut out.t);
    out
}

/// The portable lanes' `footprint_sizes`: per lane, the larger of the lengths of `duv_dx` and
/// `duv_dy` in level-0 texels, with `f32::max`'s NaN rule (a NaN length yields the other one).
#[inline]
#[target_feature(enable = "avx2")]
fn footprint_sizes(w: f32, h: f32, duv_dx: &[Lanes; 2], duv_dy: &[Lanes; 2]) -> __m256 {
    let (w, h) = (_mm256_set1_ps(w), _mm256_set1_ps(h));
    let length = |d: &[Lanes; 2]| {
        let (x, y) = (_mm256_mul_ps(load_f(&d[0]), w), _mm256_mul_ps(load_f(&d[1]), h));
        _mm256_sqrt_ps(_mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)))
    };
    let (ax, ay) = (length(duv_dx), length(duv_dy));
    // `vmaxps` returns its second operand when either is NaN: that is `ay` for a NaN `ax`; a NaN
    // `ay` must give `ax`. (Lengths are never -0, so the order of equal zeros does not matter.)
    let max = _mm256_max_ps(ax, ay);
    _mm256_blendv_ps(max, ax, _mm256_cmp_ps::<_CMP_UNORD_Q>(ay, ay))
}

/// `super::log2::log2` per lane: the same IEEE operations in the same order (the `f64` series on
/// two halves of four lanes), the special inputs blended in last.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn log2(x: __m256) -> __m256 {
    let zero = _mm256_setzero_ps();
    let subnormal = _mm256_cmp_ps::<_CMP_LT_OQ>(x, _mm256_set1_ps(f32::MIN_POSITIVE));
    let normal = _mm256_blendv_ps(x, _mm256_mul_ps(x, _mm256_set1_ps(TWO_POW_23)), subnormal);
    let scaled = _mm256_and_si256(_mm256_castps_si256(subnormal), _mm256_set1_epi32(23));
    let bits = _mm256_castps_si256(normal);
    let e = _mm256_srai_epi32::<23>(_mm256_sub_epi32(bits, _mm256_set1_epi32(SQRT_HALF_BITS as i32)));
    let m = _mm256_castsi256_ps(_mm256_sub_epi32(bits, _mm256_slli_epi32::<23>(e)));
    let e = _mm256_sub_epi32(e, scaled);
    let series = |m: __m128, e: __m128i| {
        let one = _mm256_set1_pd(1.0);
        let m = _mm256_cvtps_pd(m);
        let s = _mm256_div_pd(_mm256_sub_pd(m, one), _mm256_add_pd(m, one));
        let s2 = _mm256_mul_pd(s, s);
        let mut p = _mm256_set1_pd(SERIES[8]);
        for k in (0..8).rev() {
            p = _mm256_add_pd(_mm256_mul_pd(p, s2), _mm256_set1_pd(SERIES[k]));
        }
        _mm256_cvtpd_ps(_mm256_add_pd(_mm256_cvtepi32_pd(e), _mm256_mul_pd(s, p)))
    };
    let low = series(_mm256_castps256_ps128(m), _mm256_castsi256_si128(e));
    let high = series(_mm256_extractf128_ps::<1>(m), _mm256_extracti128_si256::<1>(e));
    let r = _mm256_set_m128(high, low);
    let r = _mm256_blendv_ps(r, _mm256_set1_ps(f32::NAN), _mm256_cmp_ps::<_CMP_NGT_UQ>(x, zero));
    let r = _mm256_blendv_ps(r, _mm256_set1_ps(f32::NEG_INFINITY), _mm256_cmp_ps::<_CMP_EQ_OQ>(x, zero));
    _mm256_blendv_ps(
        r,
        _mm256_set1_ps(f32::INFINITY),
        _mm256_cmp_ps::<_CMP_EQ_OQ>(x, _mm256_set1_ps(f32::INFINITY)),
    )
}

/// `floor(x) as i32` per lane with Rust's saturating `as`: NaN → 0, too large → `i32::MAX`, too
/// small → `i32::MIN` (what `vcvttps2dq` returns for every out-of-range input).
#[inline]
#[target_feature(enable = "avx2")]
fn floor_to_i32(x: __m256) -> __m256i {
    let f = _mm256_floor_ps(x);
    let t = _mm256_cvttps_epi32(f);
    let too_large = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(f, _mm256_set1_ps(2_147_483_648.0)));
    let t = _mm256_blendv_epi8(t, _mm256_set1_epi32(i32::MAX), too_large);
    let ordered = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_ORD_Q>(f, f));
    _mm256_and_si256(t, ordered)
}

/// `i.saturating_add(1)` per lane.
#[inline]
#[target_feature(enable = "avx2")]
fn saturating_inc(i: __m256i) -> __m256i {
    let max = _mm256_set1_epi32(i32::MAX);
    _mm256_blendv_epi8(_mm256_add_epi32(i, _mm256_set1_epi32(1)), max, _mm256_cmpeq_epi32(i, max))
}

/// One level per lane: its size and tiling (`LevelLayout::new` in lanes) and its byte offset.
struct Level {
    width: __m256i,
    height: __m256i,
    tile_w: __m256i,
    tile_h: __m256i,
    tiles_x: __m256i,
    base: __m256i,
}

impl Level {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(rec: &TextureRecord, level: __m256i) -> Self {
        let one = _mm256_set1_epi32(1);
        let tile = _mm256_set1_epi32(1 << rec.tile_log2);
        let width = _mm256_max_epi32(_mm256_srlv_epi32(_mm256_set1_epi32(rec.width as i32), level), one);
        let height = _mm256_max_epi32(_mm256_srlv_epi32(_mm256_set1_epi32(rec.height as i32), level), one);
        // `LevelLayout::new`'s `if width <= tile { 1 } else { (width + tile - 1) >> tile_log2 }`: the
        // shift gives 1 for every width in `1..=tile` too.
        let tiles_x = _mm256_srl_epi32(
            _mm256_sub_epi32(_mm256_add_epi32(width, tile), one),
            _mm_cvtsi32_si128(rec.tile_log2 as i32),
        );
        // The low halves of the `u64` level offsets, which are below 2^31 (the caller checked the
        // texel array's size). SAFETY: levels are below `mip_count <= 16`, inside `level_offsets`.
        let base = unsafe { _mm256_i32gather_epi32::<8>(rec.level_offsets.as_ptr() as *const i32, level) };
        Level {
            width,
            height,
            tile_w: _mm256_min_epi32(width, tile),
            tile_h: _mm256_min_epi32(height, tile),
            tiles_x,
            base,
        }
    }
}

/// `super::wrap` per lane for a power-of-two `n`; clears `valid` on a black border.
#[inline]
#[target_feature(enable = "avx2")]
fn wrap(i: __m256i, n: __m256i, mode: Wrap, valid: &mut __m256i) -> __m256i {
    let one = _mm256_set1_epi32(1);
    match mode {
        Wrap::Repeat => _mm256_and_si256(i, _mm256_sub_epi32(n, one)),
        Wrap::Mirror => {
            let two_n = _mm256_add_epi32(n, n);
            let m = _mm256_and_si256(i, _mm256_sub_epi32(two_n, one));
            let flipped = _mm256_sub_epi32(_mm256_sub_epi32(two_n, one), m);
            // m < n ? m : 2n - 1 - m
            _mm256_blendv_epi8(flipped, m, _mm256_cmpgt_epi32(n, m))
        }
        Wrap::Clamp => {
            _mm256_min_epi32(_mm256_max_epi32(i, _mm256_setzero_si256()), _mm256_sub_epi32(n, one))
        }
        Wrap::Black => {
            // `(i as u32) < n` with `0 < n < 2^31`: `0 <= i` and `i < n`.
            let inside =
                _mm256_andnot_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), i), _mm256_cmpgt_epi32(n, i));
            *valid = _mm256_and_si256(*valid, inside);
            _mm256_and_si256(i, inside)
        }
    }
}

/// Byte offsets of texels `(x, y)`, already wrapped into `lv`: `LevelLayout::texel_offset` per lane.
#[inline]
#[target_feature(enable = "avx2")]
fn offset(lv: &Level, tile_log2: u32, texel_bytes: u32, x: __m256i, y: __m256i) -> __m256i {
    let shift = _mm_cvtsi32_si128(tile_log2 as i32);
    let mask = _mm256_set1_epi32((1 << tile_log2) - 1);
    let tile = _mm256_add_epi32(
        _mm256_mullo_epi32(_mm256_srl_epi32(y, shift), lv.tiles_x),
        _mm256_srl_epi32(x, shift),
    );
    let within =
        _mm256_add_epi32(_mm256_mullo_epi32(_mm256_and_si256(y, mask), lv.tile_w), _mm256_and_si256(x, mask));
    let texel = _mm256_add_epi32(_mm256_mullo_epi32(tile, _mm256_mullo_epi32(lv.tile_w, lv.tile_h)), within);
    _mm256_add_epi32(lv.base, _mm256_mullo_epi32(texel, _mm256_set1_epi32(texel_bytes as i32)))
}

/// The taps of the MoonRay lane filter (see `moonray_lanes_in`) and the level-0 bilinear weights
/// `fx`, `fy`, for the lanes below `count`. The record's level-0 sizes must be powers of two and its
/// texel array under 2 GiB.
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) fn addresses(
    rec: &TextureRecord,
    texel_bytes: u32,
    wrap_s: Wrap,
    wrap_t: Wrap,
    uv: &[Lanes; 2],
    levels: &LevelLanes,
    count: usize,
    (fx, fy): (&mut Lanes, &mut Lanes),
) -> TapOffsets {
    let lane_index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let active = _mm256_cmpgt_epi32(_mm256_set1_epi32(count as i32), lane_index);
    let magnify = load_i(&levels.magnify);
    let weighted = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_NEQ_UQ>(load_f(&levels.t), _mm256_setzero_ps()));
    let (u, v) = (load_f(&uv[0]), load_f(&uv[1]));

    // Level 0, bilinear (`Sampler::bilinear`).
    let zero_level = _mm256_setzero_si256();
    let base = Level::new(rec, zero_level);
    let bx = _mm256_sub_ps(_mm256_mul_ps(u, _mm256_set1_ps(rec.width as f32)), _mm256_set1_ps(0.5));
    let by = _mm256_sub_ps(_mm256_mul_ps(v, _mm256_set1_ps(rec.height as f32)), _mm256_set1_ps(0.5));
    store_f(_mm256_sub_ps(bx, _mm256_floor_ps(bx)), fx);
    store_f(_mm256_sub_ps(by, _mm256_floor_ps(by)), fy);
    let (bx0, by0) = (floor_to_i32(bx), floor_to_i32(by));
    let (bx1, by1) = (saturating_inc(bx0), saturating_inc(by0));

    // The two levels, nearest texel (`Sampler::nearest`); magnifying lanes address level 0.
    let nearest = |lv: &Level| {
        (
            floor_to_i32(_mm256_mul_ps(u, _mm256_cvtepi32_ps(lv.width))),
            floor_to_i32(_mm256_mul_ps(v, _mm256_cvtepi32_ps(lv.height))),
        )
    };
    let near = Level::new(rec, _mm256_andnot_si256(magnify, load_i(&levels.l0)));
    let far = Level::new(rec, _mm256_andnot_si256(magnify, load_i(&levels.l1)));
    let (nx, ny) = nearest(&near);
    let (fx_, fy_) = nearest(&far);

    let select = |if_magnify: __m256i, otherwise: __m256i| _mm256_blendv_epi8(otherwise, if_magnify, magnify);
    let magnifying = _mm256_and_si256(active, magnify);
    let taps = [
        (&near, select(bx0, nx), select(by0, ny), active),
        (
            &far,
            select(bx1, fx_),
            select(by0, fy_),
            _mm256_and_si256(active, _mm256_or_si256(magnify, weighted)),
        ),
        (&base, bx0, by1, magnifying),
        (&base, bx1, by1, magnifying),
    ];
    let mut out = TapOffsets { offset: [[0; LANES]; 4], present: [[0; LANES]; 4] };
    for (tap, (lv, x, y, mut valid)) in taps.into_iter().enumerate() {
        if _mm256_testz_si256(valid, valid) != 0 {
            continue; // no lane reads this tap
        }
        let x = wrap(x, lv.width, wrap_s, &mut valid);
        let y = wrap(y, lv.height, wrap_t, &mut valid);
        let at = _mm256_and_si256(offset(lv, rec.tile_log2, texel_bytes, x, y), valid);
        store_i(at, &mut out.offset[tap]);
        store_i(valid, &mut out.present[tap]);
    }
    out
}

/// The texels at `taps` decoded as `Decode::gather` of `Srgb8` (`srgb`) or `Unorm8` decodes them
/// (absent taps zero in every channel), blended as the portable lanes' `blend` blends them
/// (bilinear where `levels` magnifies, else the two levels by their weight; lanes at or past
/// `count` zero), into `out`. Returns `false`, writing nothing, when a present tap lies within 4
/// bytes of the array's end (the word read would run past it), for the portable gather to take.
///
/// One pass from the gathered words to the filtered colour: the decoded taps stay in registers
/// instead of going through a `[tap][channel][lane]` array (512 bytes copied out and read back).
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) fn gather_blend_u8(
    texels: &[u8],
    channels: u32,
    srgb: bool,
    taps: &TapOffsets,
    levels: &LevelLanes,
    (fx, fy): (&Lanes, &Lanes),
    count: usize,
    out: &mut [Lanes; 4],
) -> bool {
    let Some(limit) = texels.len().checked_sub(4) else { return false };
    let limit = _mm256_set1_epi32(limit.min(i32::MAX as usize) as i32);
    let bytes = texels.as_ptr() as *const i32;
    let mut words = [_mm256_setzero_si256(); 4];
    let mut masks = [_mm256_setzero_si256(); 4];
    for tap in 0..4 {
        let mask = load_i(&taps.present[tap]);
        if _mm256_testz_si256(mask, mask) != 0 {
            continue; // a tap no lane uses (e.g. taps 2 and 3 when no lane magnifies)
        }
        let offset = load_i(&taps.offset[tap]);
        if _mm256_testz_si256(_mm256_cmpgt_epi32(offset, limit), mask) == 0 {
            return false;
        }
        // SAFETY: the masked gather reads only the lanes whose mask is set, each at an offset that
        // leaves 4 bytes inside `texels` (checked above); masked lanes keep the zero source.
        words[tap] = unsafe { _mm256_mask_i32gather_epi32::<1>(_mm256_setzero_si256(), bytes, offset, mask) };
        masks[tap] = mask;
    }
    let table = SRGB_TO_LINEAR.as_ptr();
    let low_byte = _mm256_set1_epi32(0xff);
    let one = _mm256_set1_ps(1.0);
    let inv_255 = _mm256_set1_ps(1.0 / 255.0);
    let code = |words: __m256i, c: i32| {
        _mm256_and_si256(_mm256_srlv_epi32(words, _mm256_set1_epi32(8 * c)), low_byte)
    };
    let unorm = |words: __m256i, c: i32| _mm256_mul_ps(_mm256_cvtepi32_ps(code(words, c)), inv_255);
    // Channel `c` of RGBA from the stored channels, as `expand` does; a missing tap is zero in every
    // channel, as the scalar fetch returns.
    let decode = |tap: usize, c: usize| {
        let w = words[tap];
        let colour = |i: i32| {
            if srgb {
                // SAFETY: codes are 0..=255, the table's indices.
                unsafe { _mm256_i32gather_ps::<4>(table, code(w, i)) }
            } else {
                unorm(w, i)
            }
        };
        let v = match (channels, c) {
            (1 | 2, 0..=2) => colour(0),
            (_, 0..=2) => colour(c as i32),
            (1 | 3, _) => one,
            (2, _) => unorm(w, 1),
            _ => unorm(w, 3),
        };
        _mm256_and_ps(v, _mm256_castsi256_ps(masks[tap]))
    };
    let lane_index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let active = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(count as i32), lane_index));
    let t = load_f(&levels.t);
    let unweighted = _mm256_cmp_ps::<_CMP_EQ_OQ>(t, _mm256_setzero_ps());
    let magnify = load_i(&levels.magnify);
    let any_magnify = _mm256_testz_si256(magnify, magnify) == 0;
    let magnify = _mm256_castsi256_ps(magnify);
    let (fx, fy) = (load_f(fx), load_f(fy));
    let lerp = |a: __m256, b: __m256, t: __m256| _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), t));
    for c in 0..4 {
        let (t00, t10) = (decode(0, c), decode(1, c));
        let mut value = _mm256_blendv_ps(lerp(t00, t10, t), t00, unweighted);
        if any_magnify {
            let (t01, t11) = (decode(2, c), decode(3, c));
            let bilinear = lerp(lerp(t00, t10, fx), lerp(t01, t11, fx), fy);
            value = _mm256_blendv_ps(value, bilinear, magnify);
        }
        store_f(_mm256_and_ps(value, active), &mut out[c]);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane `log2` equals the scalar one bit for bit: random bit patterns of every exponent and
    /// sign, and the special inputs.
    #[test]
    fn log2_lanes_equal_scalar() {
        if !lanekit::cpu::has_avx2() {
            return; // the portable path calls the scalar `log2` itself
        }
        let specials = [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            1.0,
            -1.0,
            std::f32::consts::FRAC_1_SQRT_2,
            std::f32::consts::SQRT_2,
            5.0,
            f32::from_bits(0x007f_ffff),
        ];
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut random = || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            f32::from_bits((state >> 32) as u32)
        };
        let inputs: Vec<f32> = specials.into_iter().chain((0..400_000).map(|_| random())).collect();
        for chunk in inputs.chunks_exact(LANES) {
            let x: Lanes = chunk.try_into().expect("eight lanes");
            let mut got = [0.0; LANES];
            // SAFETY: the CPU has AVX2 (checked above).
            unsafe { store_f(log2(load_f(&x)), &mut got) };
            for k in 0..LANES {
                let want = super::super::log2::log2(x[k]);
                assert_eq!(got[k].to_bits(), want.to_bits(), "log2({:e}) bits {:#x}", x[k], x[k].to_bits());
            }
        }
    }

    /// A tap whose 32-bit word would run past the texel array is left to the portable gather; one
    /// that fits is read, and decodes as the scalar texel decode does.
    #[test]
    fn gathers_stop_short_of_the_array_end() {
        if !lanekit::cpu::has_avx2() {
            return; // nothing to run; the portable path is tested on its own
        }
        let texels: Vec<u8> = (0..64u8).map(|i| i.wrapping_mul(37)).collect();
        let mut taps = TapOffsets { offset: [[0; LANES]; 4], present: [[0; LANES]; 4] };
        for k in 0..LANES {
            taps.offset[0][k] = (k * 7) as i32;
            taps.present[0][k] = -1;
        }
        taps.offset[0][3] = 60; // the last whole word
                                // Every lane minifying with weight 0: the result is tap 0 as decoded.
        let levels = LevelLanes::default();
        let zero = [0.0; LANES];
        let mut got = [[0.0; LANES]; 4];
        let gather = |taps: &TapOffsets, count: usize, got: &mut [Lanes; 4]| {
            // SAFETY: the CPU has AVX2 (checked above).
            unsafe { gather_blend_u8(&texels, 3, true, taps, &levels, (&zero, &zero), count, got) }
        };
        assert!(gather(&taps, LANES, &mut got), "every word inside the array");
        for k in 0..LANES {
            let at = taps.offset[0][k] as usize;
            let want = [0, 1, 2].map(|c| SRGB_TO_LINEAR[texels[at + c] as usize]);
            assert_eq!([got[0][k], got[1][k], got[2][k], got[3][k]], [want[0], want[1], want[2], 1.0]);
        }
        assert!(gather(&taps, 5, &mut got));
        assert_eq!(
            got.map(|c| c[5..].to_vec()),
            [[0.0; 3]; 4].map(|c| c.to_vec()),
            "lanes past count are zero"
        );
        taps.offset[0][5] = 61; // a 3-byte texel at the end: its word would read one byte past
        assert!(!gather(&taps, LANES, &mut got));
        taps.present[0][5] = 0; // ... unless that lane does not read it
        assert!(gather(&taps, LANES, &mut got));
        assert_eq!([got[0][5], got[3][5]], [0.0, 0.0], "an absent tap is zero, alpha too");
    }
}

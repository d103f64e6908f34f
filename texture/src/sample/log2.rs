//! `log2` of the footprint length for the mip level, ours rather than libm's so that the lane
//! filter can compute it eight at a time in registers and still equal the scalar lookup bit for bit.
//!
//! Why not libm: glibc's `log2f` is not correctly rounded (0.75 ulp) and glibc picks one of two
//! builds of it by CPU, so a vector `log2` could not reproduce it; the level's fraction is the blend
//! weight of the two mip levels, so the lanes called it once per lane (`__log2f_fma`, 2.9 M of the
//! wavefront's 527 M instructions on shading-heavy, 120×80, 8 spp, 1 thread; ≈ 250 a group of
//! eight with the calls). [`log2`] is the scalar definition; `lanes_avx2::log2` computes the same
//! IEEE operations in the same order on eight lanes (tested bit for bit on random and special
//! inputs).
//!
//! Method: `x = 2^e · m` with `m ∈ [√½, √2)` (integer operations on the bits, subnormals scaled by
//! 2^23 first), then in `f64` `log2 m = 2/ln 2 · atanh s` with `s = (m − 1)/(m + 1)`, `|s| ≤ 0.1716`,
//! as the odd series `s · Σ_{k≤8} s^{2k} · 2/((2k+1) ln 2)` (truncation below 1e-15 relative), plus
//! `e`, rounded once to `f32`. Exact at powers of two; `-inf` at ±0, NaN below 0 and for NaN,
//! `+inf` at `+inf`.
//!
//! Accuracy (`tests::matches_the_correctly_rounded_log2`): against `f64::log2` rounded to `f32`, on
//! every 61st positive `f32` bit pattern (35 million inputs, every exponent, subnormals included)
//! and on every float within 4,096 ulps of the powers of two and of 1: no input differs, and
//! so the error is at most 0.5 ulp (correct rounding) on all of them. The `f64` error before the final rounding is
//! ≈ 1e-15 relative, so an `f32` result can only misround where the exact value lies within that of
//! a half-way point between two floats; none of the tested inputs does. glibc's `log2f` (0.75 ulp)
//! returns other bits on 5,128 of those 35 million inputs (0.015 %; 0.11 % of the ones between
//! 1e-4 and 1e4, where footprint sizes lie): the scalar images changed by that much (figures in
//! `sample/lanes.rs`).

/// Bits of `√½` rounded to `f32` (0.70710677): mantissas from here up reduce to `[√½, √2)`.
pub(super) const SQRT_HALF_BITS: u32 = 0x3f35_04f3;

/// `2^23`, which scales a subnormal input into the normal range exactly.
pub(super) const TWO_POW_23: f32 = 8_388_608.0;

/// Series coefficients: `2 / ((2k + 1) ln 2)` for `k = 0..=8`.
pub(super) const SERIES: [f64; 9] = {
    let two_log2_e = 2.0 * std::f64::consts::LOG2_E;
    let mut c = [0.0; 9];
    let mut k = 0;
    while k < 9 {
        c[k] = two_log2_e / (2 * k + 1) as f64;
        k += 1;
    }
    c
};

/// `log2(x)`, correctly rounded on every input tested (see the module docs).
#[inline]
pub fn log2(x: f32) -> f32 {
    if x == 0.0 {
        return f32::NEG_INFINITY;
    }
    if x.is_nan() || x < 0.0 {
        return f32::NAN;
    }
    if x == f32::INFINITY {
        return x;
    }
    let (x, scaled) = if x < f32::MIN_POSITIVE { (x * TWO_POW_23, 23) } else { (x, 0) };
    let bits = x.to_bits();
    let e = (bits.wrapping_sub(SQRT_HALF_BITS) as i32) >> 23;
    let m = f32::from_bits(bits.wrapping_sub((e << 23) as u32)) as f64;
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let mut p = SERIES[8];
    for k in (0..8).rev() {
        p = p * s2 + SERIES[k];
    }
    ((e - scaled) as f64 + s * p) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `log2` against `f64::log2` rounded to `f32`; returns the error in units of the result's ulp.
    fn error_ulps(x: f32) -> f64 {
        let got = log2(x);
        let exact = (x as f64).log2();
        let want = exact as f32;
        if want.is_nan() {
            assert!(got.is_nan(), "log2({x:e}) = {got}, want NaN");
            return 0.0;
        }
        if want.is_infinite() || want == 0.0 {
            assert_eq!(got.to_bits(), want.to_bits(), "log2({x:e})");
            return 0.0;
        }
        let ulp = (f32::from_bits(want.abs().to_bits() + 1) - want.abs()) as f64;
        let err = (got as f64 - exact).abs() / ulp;
        assert_eq!(got.to_bits(), want.to_bits(), "log2({x:e}) = {got:e}, correctly rounded {want:e}");
        err
    }

    /// `2^e` for every exponent of `f32`, subnormals included (`powi` underflows below 2^-126).
    fn power_of_two(e: i32) -> f32 {
        if e >= -126 {
            f32::from_bits(((e + 127) as u32) << 23)
        } else {
            f32::from_bits(1 << (e + 149))
        }
    }

    #[test]
    fn matches_the_correctly_rounded_log2() {
        let mut worst = 0.0f64;
        for bits in (1..0x7f80_0000u32).step_by(61) {
            worst = worst.max(error_ulps(f32::from_bits(bits)));
        }
        for centre in (-149..=127).map(power_of_two) {
            let c = centre.to_bits();
            for bits in c.saturating_sub(4096)..=(c + 4096).min(0x7f7f_ffff) {
                worst = worst.max(error_ulps(f32::from_bits(bits)));
            }
        }
        assert!(worst <= 0.5 + 1e-9, "worst error {worst} ulp");
    }

    #[test]
    fn special_values() {
        assert_eq!(log2(0.0), f32::NEG_INFINITY);
        assert_eq!(log2(-0.0), f32::NEG_INFINITY);
        assert!(log2(-1.0).is_nan() && log2(f32::NAN).is_nan() && log2(f32::NEG_INFINITY).is_nan());
        assert_eq!(log2(f32::INFINITY), f32::INFINITY);
        for e in -149..=127 {
            assert_eq!(log2(power_of_two(e)), e as f32, "2^{e}");
        }
        assert_eq!(log2(f32::MAX), 128.0);
        assert_eq!(log2(5.0), 5f32.log2());
    }
}

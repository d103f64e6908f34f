//! One `f32` sine and cosine for every sampling routine of both integrators.
//!
//! Why not libm: `sincosf` is an opaque call, so a lane loop over it stays one call per lane
//! (~45 instructions each, plus the call); it was the largest single cost left in the wavefront's
//! light and BSDF sampling kernels (callgrind, tractor: 4.0 M of the light kernel's 11.5 M
//! instructions). A vector polynomial cannot stand beside libm either: the wavefront's lanes must
//! equal the scalar integrator bit for bit, and no polynomial rounds like libm's. So both
//! integrators call this function: [`sin_cos`] is branch-free straight-line IEEE arithmetic (no
//! table, no libm call, no fused multiply-add: Rust never contracts `a * b + c`, so the AVX2 clone
//! of a lane kernel and the baseline scalar build round identically), which LLVM inlines and
//! vectorises 8-wide inside the lane kernels' `multiversion` AVX2 clones ([`sin_cos_lanes`]).
//!
//! Method (Cephes `sinf`/`cosf`, Moshier): `k = round(x · 2/π)` by the 1.5·2²³ trick (an add and
//! a subtract; the quadrant `k mod 4` is read from the sum's low mantissa bits), then
//! `r = x − k·π/2` in three parts (Cody–Waite: `k·P1` and `k·P2` are exact for |k| < 2¹³, so the
//! reduction is exact up to the last part's rounding), then degree-7 sine and degree-8 cosine
//! minimax polynomials on |r| ≤ π/4, and the quadrant swaps them and sets their signs with bit
//! operations (no branch, no select on floats).
//!
//! Domain: |x| < 8192 (the callers pass [0, 2π) for φ = 2πu, [−π/4, 3π/4] for the concentric
//! disk's θ, and below 10π for the hair's azimuths). NaN and ±∞ give NaN, as libm does. Measured
//! against `f64` sin/cos over dense sweeps of those ranges (the tests): at most 2 ulp of the exact
//! value's `f32` ulp where |value| ≥ 2⁻¹² (measured 1.52 ulp over 2πu, 1.49 over the disk's θ,
//! 1.51 over [−10π, 10π]), at most 7.8e-8 absolute anywhere; sin² + cos² within 1.5e-7 of 1.
//! (libm's `sinf`/`cosf` are within 1 ulp; the images change in the last bits.)
//!
//! Callgrind, instructions, 120×80, 8 spp, 1 thread, libm → this (both integrators still equal bit
//! for bit): the wavefront's light kernel tractor 11.48 → 6.03 M, shading-heavy 15.59 → 9.92 M,
//! simple 2.10 → 1.07 M; its BSDF sampler 9.35 → 5.26 M, 9.85 → 5.53 M, 1.72 → 0.99 M; the whole
//! wavefront process 409.2 → 400.6 M (−2.1 %), 760.5 → 752.3 M (−1.1 %), 147.6 → 146.2 M (−1.0 %).
//! The scalar integrator gains no instructions: one call at a time, the baseline-SSE2 polynomial
//! (~50 instructions with the quadrant's moves between float and integer registers) counts what
//! glibc's `__sincosf_fma` did (tractor: `Lights::sample` 15.97 → 15.06 M, `Bsdf::sample` 56.13 →
//! 56.94 M; process +0.16 %, +0.26 %, +0.23 % on the three scenes), but no call and no table:
//! perf, 320×213, 16 spp, 1 thread (contended), `Bsdf::sample` + `Lights::sample` + `sincosf` self
//! time, % of each run: tractor scalar 15.4 → 12.0, wavefront (both lane kernels) 9.0 → 5.1;
//! shading-heavy scalar 10.1 → 8.5, wavefront 4.9 → 3.6.

/// π/2 = `P1 + P2 + P3`: `P1` has 8 significant bits and `P2` 11, so `k·P1` and `k·P2` are exact
/// for integers |k| < 2¹³ (Cephes' `DP1..DP3`, doubled).
const P1: f32 = 1.570_312_5;
const P2: f32 = 4.837_513e-4;
const P3: f32 = 7.549_79e-8;

/// Adding 1.5·2²³ rounds a float of magnitude below 2²² to an integer (to nearest, ties to even)
/// and leaves that integer in the low mantissa bits.
const ROUNDER: f32 = 12_582_912.0;

/// Cephes `sinf` on [−π/4, π/4]: sin r ≈ r + r³·(S2 + r²·(S1 + r²·S0)).
const S0: f32 = -1.951_529_6e-4;
const S1: f32 = 8.332_161e-3;
const S2: f32 = -1.666_665_5e-1;

/// Cephes `cosf` on [−π/4, π/4]: cos r ≈ 1 − r²/2 + r⁴·(C2 + r²·(C1 + r²·C0)).
const C0: f32 = 2.443_315_7e-5;
const C1: f32 = -1.388_731_6e-3;
const C2: f32 = 4.166_664_6e-2;

/// `(sin x, cos x)` for |x| < 8192, a few ulp from the exact values (see the module docs).
#[inline(always)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let shifted = x * std::f32::consts::FRAC_2_PI + ROUNDER;
    let k = shifted - ROUNDER;
    let quadrant = shifted.to_bits();
    let r = ((x - k * P1) - k * P2) - k * P3;
    let z = r * r;
    let sin_r = ((S0 * z + S1) * z + S2) * z * r + r;
    let cos_r = ((C0 * z + C1) * z + C2) * z * z - 0.5 * z + 1.0;
    // sin(r + kπ/2) is sin r, cos r, −sin r, −cos r for k mod 4 = 0, 1, 2, 3; cos(r + kπ/2) is
    // cos r, −sin r, −cos r, sin r.
    let swap = 0u32.wrapping_sub(quadrant & 1);
    let (sin_bits, cos_bits) = (sin_r.to_bits(), cos_r.to_bits());
    let sin_sign = (quadrant & 2) << 30;
    let cos_sign = (quadrant.wrapping_add(1) & 2) << 30;
    let sin = f32::from_bits(((sin_bits & !swap) | (cos_bits & swap)) ^ sin_sign);
    let cos = f32::from_bits(((cos_bits & !swap) | (sin_bits & swap)) ^ cos_sign);
    (sin, cos)
}

/// [`sin_cos`] of every element: call it from inside a `multiversion` kernel, where it inlines
/// and vectorises to the kernel's width (8 lanes of AVX2 for `N = 8`).
#[inline(always)]
pub fn sin_cos_lanes<const N: usize>(x: &[f32; N], sin: &mut [f32; N], cos: &mut [f32; N]) {
    for ((&x, sin), cos) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        (*sin, *cos) = sin_cos(x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lanekit::Lanes;
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

    /// Distance of `got` from `exact` in units of the `f32` ulp at `exact`.
    fn ulps(got: f32, exact: f64) -> f64 {
        let ulp = (exact.abs() as f32).max(f32::MIN_POSITIVE);
        let ulp = f32::from_bits(ulp.to_bits() + 1) - ulp;
        (got as f64 - exact).abs() / ulp as f64
    }

    #[derive(Default, Debug)]
    struct Errors {
        ulp: f64,
        abs: f64,
        norm: f64,
    }

    impl Errors {
        fn add(&mut self, x: f32) {
            let (sin, cos) = sin_cos(x);
            let (s, c) = (x as f64).sin_cos();
            for (got, exact) in [(sin, s), (cos, c)] {
                self.abs = self.abs.max((got as f64 - exact).abs());
                // Near a zero the f32 ulp shrinks without bound while the error of the reduced
                // argument does not; there the absolute error is the measure.
                if exact.abs() >= 2f64.powi(-12) {
                    self.ulp = self.ulp.max(ulps(got, exact));
                }
            }
            let norm = sin as f64 * sin as f64 + cos as f64 * cos as f64;
            self.norm = self.norm.max((norm - 1.0).abs());
        }

        fn check(&self, range: &str) {
            println!("{range}: {self:?}");
            assert!(self.ulp <= 2.0, "{range}: {} ulp", self.ulp);
            assert!(self.abs <= 1.0e-7, "{range}: absolute error {}", self.abs);
            assert!(self.norm <= 2.0e-7, "{range}: |sin² + cos² − 1| = {}", self.norm);
        }
    }

    /// φ = 2πu at every `u` the samplers can produce (multiples of 2⁻²⁴ in [0, 1)).
    #[test]
    fn accurate_for_two_pi_u() {
        let mut e = Errors::default();
        for i in 0..1u32 << 24 {
            e.add(TAU * (i as f32 / 16_777_216.0));
        }
        e.check("2πu");
    }

    /// The concentric disk's θ = π/4 · b/a and π/2 − π/4 · a/b: every f32 in [−π/4, 3π/4] at a
    /// stride, and the exact expressions over a grid of (a, b).
    #[test]
    fn accurate_for_concentric_disk_angles() {
        let mut e = Errors::default();
        let (lo, hi) = (FRAC_PI_4.to_bits(), (3.0 * FRAC_PI_4).to_bits());
        for bits in (0..lo).step_by(7) {
            e.add(-f32::from_bits(bits));
        }
        for bits in (0..hi).step_by(7) {
            e.add(f32::from_bits(bits));
        }
        let n = 2048;
        for i in 0..n {
            for j in 0..n {
                let (a, b) = (2.0 * (i as f32 / n as f32) - 1.0, 2.0 * (j as f32 / n as f32) - 1.0);
                if a == 0.0 && b == 0.0 {
                    continue;
                }
                e.add(if a.abs() > b.abs() { FRAC_PI_4 * (b / a) } else { FRAC_PI_2 - FRAC_PI_4 * (a / b) });
            }
        }
        e.check("concentric θ");
    }

    /// The hair's azimuths φ_o + Δφ: a dense sweep of [−10π, 10π].
    #[test]
    fn accurate_for_hair_azimuths() {
        let mut e = Errors::default();
        let n = 1 << 24;
        for i in 0..=n {
            e.add(-10.0 * PI + 20.0 * PI * (i as f32 / n as f32));
        }
        e.check("hair azimuth");
    }

    /// `k·P1` and `k·P2` must be exact for |k| < 2¹³: their significands end in enough zeros.
    #[test]
    fn reduction_constants_split_half_pi() {
        let zeros = |c: f32| (c.to_bits() & 0x7f_ffff).trailing_zeros();
        assert!(zeros(P1) >= 23 - 7 && zeros(P2) >= 23 - 10, "{} {}", zeros(P1), zeros(P2));
        let sum = P1 as f64 + P2 as f64 + P3 as f64;
        assert!((sum - std::f64::consts::FRAC_PI_2).abs() < 4e-15, "{sum}");
    }

    #[test]
    fn exact_at_zero_and_nan_outside_the_domain() {
        // sin(−0) is +0 here (libm keeps the sign); every caller multiplies it by a radius.
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert_eq!(sin_cos(-0.0), (0.0, 1.0));
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "{x}: {s} {c}");
        }
    }

    #[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
    fn eight_lanes(x: &Lanes, sin: &mut Lanes, cos: &mut Lanes) {
        sin_cos_lanes(x, sin, cos);
    }

    /// The vectorised lane loop (AVX2 clone where the CPU has it) equals the scalar function.
    #[test]
    fn lanes_equal_scalar_bit_for_bit() {
        let mut state = 7u32;
        let mut next = || {
            state = crate::sampler::hash_u32(state);
            (state >> 8) as f32 / 16_777_216.0
        };
        for _ in 0..200_000 {
            let x: Lanes = std::array::from_fn(|k| match k {
                0 => TAU * next(),
                1 => FRAC_PI_4 * (2.0 * next() - 1.0) + FRAC_PI_2 * (next() < 0.5) as u32 as f32,
                _ => 20.0 * PI * (next() - 0.5),
            });
            let (mut sin, mut cos) = ([0.0; 8], [0.0; 8]);
            eight_lanes(&x, &mut sin, &mut cos);
            for k in 0..8 {
                let (s, c) = sin_cos(x[k]);
                assert_eq!((sin[k].to_bits(), cos[k].to_bits()), (s.to_bits(), c.to_bits()), "{}", x[k]);
            }
        }
    }
}

//! `floor` and `round` of `f32` without libm calls, bit-identical to [`f32::floor`] and [`f32::round`].
//!
//! The workspace builds for baseline x86-64 (SSE2), which has no rounding instruction (`roundss` is
//! SSE4.1), so `f32::floor` and `f32::round` compile to calls into libm: `floorf` alone was 1.9 % of
//! the wavefront's instructions on the shading-heavy scene, called from every lookup and sort key.
//! Below `2^23` a float truncates exactly through `i32`, and at or above it (and for infinities and
//! NaN) it is already integral, so two compares, two conversions and a select give the same bits,
//! signed zeros included: both results carry the sign of `x`. `tests::match_std` compares them with
//! the standard library on 16.7 million bit patterns spread over every exponent and on every float
//! near the integers and half-integers up to 4096 and near 2^22, 2^23 and 2^24.

/// Smallest magnitude from which every `f32` is an integer.
const INTEGRAL: f32 = 8_388_608.0; // 2^23

/// `x.floor()`, bit for bit.
#[inline(always)]
pub fn floor(x: f32) -> f32 {
    if x.is_nan() || x.abs() >= INTEGRAL {
        return x; // integral already, or NaN (returned as is, as libm does)
    }
    let t = x as i32 as f32; // truncation toward zero, exact below 2^23
    let f = if t > x { t - 1.0 } else { t };
    // floor(-0.0) is -0.0, and a non-negative x floors to +0.0 or more: the result has x's sign.
    f.copysign(x)
}

/// `x.round()` (half away from zero), bit for bit.
#[inline(always)]
pub fn round(x: f32) -> f32 {
    if x.is_nan() {
        // libm's `roundf` quietens a signalling NaN (sets the quiet bit, keeps the payload).
        return f32::from_bits(x.to_bits() | 0x0040_0000);
    }
    if x.abs() >= INTEGRAL {
        return x;
    }
    let t = x as i32 as f32;
    // `x - t` is the exact fractional part (|x| < 2^23).
    let r = if (x - t).abs() >= 0.5 { t + 1.0f32.copysign(x) } else { t };
    r.copysign(x) // round(-0.3) is -0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(x: f32) {
        assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "floor({x:e}) bits {:#x}", x.to_bits());
        assert_eq!(round(x).to_bits(), x.round().to_bits(), "round({x:e}) bits {:#x}", x.to_bits());
    }

    #[test]
    fn match_std() {
        // Every 257th bit pattern: all exponents, both signs, NaNs and infinities.
        for bits in (0..=u32::MAX).step_by(257) {
            check(f32::from_bits(bits));
        }
        // Every float within 64 ulps of each integer and half-integer up to 4096 and around the
        // powers of two where truncation through `i32` stops being needed (2^22 .. 2^24), both signs.
        let centres = (0..8192u32).map(|i| i as f32 * 0.5).chain([4_194_304.0, INTEGRAL, 16_777_216.0]);
        for centre in centres {
            let b = centre.to_bits();
            for d in 0..64 {
                for v in [f32::from_bits(b.wrapping_add(d)), f32::from_bits(b.saturating_sub(d))] {
                    check(v);
                    check(-v);
                }
            }
        }
        for x in [0.0, -0.0, 0.5, -0.5, 0.49999997, -0.49999997, 1.5, -2.5, INTEGRAL, -INTEGRAL] {
            check(x);
            check(f32::from_bits(x.to_bits() - 1));
        }
        check(f32::NAN);
        check(f32::INFINITY);
        check(f32::NEG_INFINITY);
    }
}

//! Half-float (`f16`) texels to `f32`: the conversion is exact, so hardware and software agree.
//!
//! Every `f16` value is representable in `f32`, so there is exactly one right answer per bit pattern,
//! NaNs included once both quieten them the same way (F16C's `vcvtph2ps` sets the quiet bit and keeps
//! the payload; [`to_f32_soft`] does the same). Lookups therefore may convert with whatever is fastest
//! without changing a pixel: the scalar filters convert one value at a time through `half` (F16C picked
//! at run time per call), the lane filter converts all its taps in one call ([`to_f32_array`]: F16C
//! picked once, eight values per instruction). `tests::all_halves_agree` checks every one of the
//! 65,536 bit patterns through all three.
//!
//! Measured (callgrind, a throwaway probe: 20,000 groups of eight MoonRay-filter lookups, minifying,
//! on a 512² RGBA half-float texture): the lane filter took 128.9 M instructions decoding each value
//! through `half::f16::to_f32` (a feature check and a call per channel) and 122.6 M with the batched
//! conversion (−4.9 %). The bench scenes have no half-float textures, so renders do not show it.

/// Converts `bits` (raw `f16` patterns) in one call: F16C when the CPU has it (checked once per call),
/// else `half`'s software conversion.
#[inline]
pub fn to_f32_array<const N: usize>(bits: &[u16; N]) -> [f32; N] {
    use half::slice::{HalfBitsSliceExt, HalfFloatSliceExt};
    let mut out = [0.0f32; N];
    let halves: &[half::f16] = bits[..].reinterpret_cast();
    halves.convert_to_f32_slice(&mut out);
    out
}

/// The exact conversion of one `f16` bit pattern, in integer operations: the specification the
/// hardware path is tested against.
pub fn to_f32_soft(bits: u16) -> f32 {
    let sign = ((bits & 0x8000) as u32) << 16;
    let exponent = ((bits >> 10) & 0x1f) as u32;
    let mantissa = (bits & 0x3ff) as u32;
    let magnitude = match exponent {
        // Zero and subnormals: mantissa · 2⁻²⁴, exact in f32 (a 10-bit integer times a power of two).
        0 => (mantissa as f32 * f32::from_bits(0x3380_0000)).to_bits(),
        // Infinity, or NaN with the quiet bit set and the payload kept.
        0x1f if mantissa == 0 => 0x7f80_0000,
        0x1f => 0x7fc0_0000 | (mantissa << 13),
        // Normal: rebias the exponent (15 → 127), widen the mantissa.
        _ => ((exponent + 112) << 23) | (mantissa << 13),
    };
    f32::from_bits(sign | magnitude)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_halves_agree() {
        let all: Vec<u16> = (0..=u16::MAX).collect();
        let mut converted = Vec::with_capacity(all.len());
        for chunk in all.chunks_exact(32) {
            converted.extend(to_f32_array::<32>(chunk.try_into().expect("32 values")));
        }
        for (&bits, &hardware) in all.iter().zip(&converted) {
            let soft = to_f32_soft(bits);
            let one = half::f16::from_bits(bits).to_f32();
            assert_eq!(hardware.to_bits(), soft.to_bits(), "slice conversion of {bits:#06x}");
            assert_eq!(one.to_bits(), soft.to_bits(), "per-value conversion of {bits:#06x}");
        }
        // Spot checks of the specification itself.
        assert_eq!(to_f32_soft(0x3c00), 1.0);
        assert_eq!(to_f32_soft(0xc000), -2.0);
        assert_eq!(to_f32_soft(0x0001), 2f32.powi(-24));
        assert_eq!(to_f32_soft(0x7bff), 65504.0);
        assert_eq!(to_f32_soft(0x8000).to_bits(), (-0.0f32).to_bits());
        assert_eq!(to_f32_soft(0xfc00), f32::NEG_INFINITY);
        assert!(to_f32_soft(0x7e00).is_nan());
    }

    /// `scripts/test-fallback.sh` runs this crate's tests under qemu on CPU models without F16C and
    /// sets `RENDER_EMULATED_CPU`: there [`all_halves_agree`] must have exercised `half`'s software
    /// conversion, not F16C.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn emulated_cpus_convert_without_f16c() {
        let f16c = is_x86_feature_detected!("f16c");
        eprintln!("half-float decoding uses {}", if f16c { "F16C" } else { "the software conversion" });
        match std::env::var("RENDER_EMULATED_CPU").as_deref() {
            Err(_) => {}
            Ok("no-avx" | "avx-no-avx2") => assert!(!f16c, "the emulated CPU should have no F16C"),
            Ok(other) => panic!("RENDER_EMULATED_CPU={other:?}: expected \"no-avx\" or \"avx-no-avx2\""),
        }
    }
}

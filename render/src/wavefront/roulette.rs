//! The throughput update after a BSDF sample and Russian roulette, eight paths at a time, beside the
//! scalar reference (the integrator's own lines, [`continue_scalar`]).
//!
//! `β ← β · f · (|n·ωᵢ| / pdf)`; from [`crate::integrator::RR_START_BOUNCE`] bounces on, the path
//! survives with probability `q = min(max(β), 0.95)` and then `β ← β / q`. Same IEEE operations in the
//! same order as the scalar code, so lanes equal it bit for bit.

use super::bsdf_lanes::{Lanes, Lanes3};
use super::lanes::LANES;
use glam::Vec3;

/// Eight paths' inputs.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct RouletteLanes {
    /// Throughput before the bounce.
    pub beta: Lanes3,
    /// Sampled BSDF value.
    pub f: Lanes3,
    /// `|n_s · ω_i|`.
    pub cos: Lanes,
    /// Sampled pdf.
    pub pdf: Lanes,
    /// The roulette's random number.
    pub u: Lanes,
    /// 1 where roulette is played (enough bounces).
    pub play: [u32; LANES],
}

/// Eight updated throughputs; `alive == 0` where roulette ended the path.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct RouletteOut {
    /// New throughput.
    pub beta: Lanes3,
    /// 1 where the path continues.
    pub alive: [u32; LANES],
}

/// The scalar reference: the new throughput, or `None` when roulette ends the path.
#[inline]
pub fn continue_scalar(beta: Vec3, f: Vec3, cos: f32, pdf: f32, play: bool, u: f32) -> Option<Vec3> {
    let mut beta = beta;
    beta *= f * (cos / pdf);
    if play {
        let survive = beta.max_element().min(0.95);
        if u >= survive {
            return None;
        }
        beta /= survive;
    }
    Some(beta)
}

/// [`continue_scalar`] on eight lanes.
// `!(a <= b)` on purpose: it is how the scalar code's early return treats NaN (it does not return).
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn continue_lanes(l: &RouletteLanes, out: &mut RouletteOut) {
    for k in 0..LANES {
        let s = l.cos[k] / l.pdf[k];
        let b = [0, 1, 2].map(|c| l.beta[c][k] * (l.f[c][k] * s));
        // glam's `max_element`: `if a > b { a } else { b }`, right to left.
        let gt = |a: f32, b: f32| if a > b { a } else { b };
        let survive = gt(b[0], gt(b[1], b[2])).min(0.95);
        let play = l.play[k] != 0;
        for c in 0..3 {
            out.beta[c][k] = if play { b[c] / survive } else { b[c] };
        }
        out.alive[k] = (!play || !(l.u[k] >= survive)) as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_equal_the_scalar_roulette_bit_for_bit_on_random_inputs() {
        let mut x = 5u32;
        let mut u = || {
            x = crate::sampler::hash_u32(x);
            (x >> 8) as f32 / 16_777_216.0
        };
        let special = [0.0, f32::INFINITY, f32::NAN, 1e-30, 3.0];
        let (mut alive, mut total) = (0, 0);
        for _ in 0..1000 {
            let mut l = RouletteLanes::default();
            for k in 0..LANES {
                for c in 0..3 {
                    l.beta[c][k] = if u() < 0.03 { special[(u() * 5.0) as usize % 5] } else { 2.0 * u() };
                    l.f[c][k] = u();
                }
                l.cos[k] = u();
                l.pdf[k] = if u() < 0.03 { 0.0 } else { 4.0 * u() };
                l.u[k] = u();
                l.play[k] = (u() < 0.7) as u32;
            }
            let mut out = RouletteOut::default();
            continue_lanes(&l, &mut out);
            for k in 0..LANES {
                let at = |c: &Lanes3| Vec3::new(c[0][k], c[1][k], c[2][k]);
                let expected =
                    continue_scalar(at(&l.beta), at(&l.f), l.cos[k], l.pdf[k], l.play[k] != 0, l.u[k]);
                assert_eq!(out.alive[k] != 0, expected.is_some(), "lane {k}");
                if let Some(b) = expected {
                    let bits =
                        |v: Vec3| v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() });
                    assert_eq!(bits(at(&out.beta)), bits(b), "lane {k}");
                    alive += 1;
                }
                total += 1;
            }
        }
        assert!(alive > total / 3 && alive < total, "{alive} of {total} survive");
    }
}

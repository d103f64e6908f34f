//! The throughput update after a BSDF sample and Russian roulette, eight paths at a time, beside the
//! scalar reference (the integrator's own lines, [`continue_scalar`]).
//!
//! `β ← β · f · (|n·ωᵢ| / pdf)`; from [`crate::path::RR_START_BOUNCE`] bounces on, the path
//! survives with probability `q = min(max(β), 0.95)` and then `β ← β / q`. Same IEEE operations in the
//! same order as the scalar code, so lanes equal it bit for bit.
//!
//! Groups where no lane plays roulette skip the three divisions by `q` (the kernel is a chain of
//! two divisions, `cos / pdf` then `β / q`, so it is latency-bound). One-process timing against
//! the frozen old kernel (2048 groups, min of 60 alternating rounds, contended), per group: no lane
//! playing 5.2–8.0 → 4.2–6.1 ns (−21 to −24 %), half the groups playing −9 to −11 %, every group
//! playing −3 to −10 % (the throughput products written out: as `[0, 1, 2].map(..)` they became
//! an out-of-line call in the two-variant kernel).

use glam::Vec3;
use lanekit::LANES;

lanekit::soa! {
    /// Eight paths' inputs.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct RouletteLanes for struct RouletteLane {
        /// Throughput before the bounce.
        pub beta: Vec3 as [f32; 3],
        /// Sampled BSDF value.
        pub f: Vec3 as [f32; 3],
        /// `|n_s · ω_i|`.
        pub cos: f32,
        /// Sampled pdf.
        pub pdf: f32,
        /// The roulette's random number.
        pub u: f32,
        /// 1 where roulette is played (enough bounces).
        pub play: bool,
    }
}

lanekit::soa! {
    /// Eight updated throughputs; `alive == 0` where roulette ended the path.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct RouletteOut for struct RouletteResult {
        /// New throughput.
        pub beta: Vec3 as [f32; 3],
        /// 1 where the path continues.
        pub alive: bool,
    }
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
///
/// Groups where no lane plays roulette (all before [`crate::path::RR_START_BOUNCE`]: the
/// first bounces, the most numerous) take a variant without the three divisions by the survival
/// probability, which the selects would discard.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn continue_lanes(l: &RouletteLanes, out: &mut RouletteOut) {
    if l.play.iter().any(|&p| p != 0) {
        continue_group::<true>(l, out);
    } else {
        continue_group::<false>(l, out);
    }
}

// `!(a <= b)` on purpose: it is how the scalar code's early return treats NaN (it does not return).
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn continue_group<const PLAY: bool>(l: &RouletteLanes, out: &mut RouletteOut) {
    for k in 0..LANES {
        let s = l.cos[k] / l.pdf[k];
        // Written out: `[0, 1, 2].map(..)` stayed an out-of-line call in the two variants.
        let b =
            [l.beta[0][k] * (l.f[0][k] * s), l.beta[1][k] * (l.f[1][k] * s), l.beta[2][k] * (l.f[2][k] * s)];
        if !PLAY {
            for c in 0..3 {
                out.beta[c][k] = b[c];
            }
            out.alive[k] = 1;
            continue;
        }
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
        let (mut alive, mut total, mut no_play_groups) = (0, 0, 0);
        for round in 0..1000 {
            let mut l = RouletteLanes::default();
            // One group in three plays no roulette on any lane (the kernel's variant without it).
            let no_play_group = round % 3 == 0;
            for k in 0..LANES {
                let (mut beta, mut f) = (Vec3::ZERO, Vec3::ZERO);
                for c in 0..3 {
                    beta[c] = if u() < 0.03 { special[(u() * 5.0) as usize % 5] } else { 2.0 * u() };
                    f[c] = u();
                }
                let cos = u();
                let pdf = if u() < 0.03 { 0.0 } else { 4.0 * u() };
                let u_rr = u();
                let play = !no_play_group && u() < 0.7;
                l.set(k, &RouletteLane { beta, f, cos, pdf, u: u_rr, play });
            }
            no_play_groups += l.play.iter().all(|&p| p == 0) as u32;
            let mut out = RouletteOut::default();
            continue_lanes(&l, &mut out);
            for k in 0..LANES {
                let (i, o) = (l.get(k), out.get(k));
                let expected = continue_scalar(i.beta, i.f, i.cos, i.pdf, i.play, i.u);
                assert_eq!(o.alive, expected.is_some(), "lane {k}");
                if let Some(b) = expected {
                    let bits =
                        |v: Vec3| v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() });
                    assert_eq!(bits(o.beta), bits(b), "lane {k}");
                    alive += 1;
                }
                total += 1;
            }
        }
        assert!(alive > total / 3 && alive < total, "{alive} of {total} survive");
        assert!((334..400).contains(&no_play_groups), "{no_play_groups} groups without roulette");
    }
}

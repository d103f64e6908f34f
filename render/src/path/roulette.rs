//! The throughput update after a BSDF sample and Russian roulette: one branch-free body,
//! [`continue_path`], that both integrators call per bounce and [`continue_lanes`] calls per lane.
//!
//! `β ← β · f · (|n·ωᵢ| / pdf)`; from [`crate::path::RR_START_BOUNCE`] bounces on, the path
//! survives with probability `q = min(max(β), 0.95)` and then `β ← β / q`.
//!
//! Groups where no lane plays roulette (the first bounces, the most numerous) run the body with
//! `play` fixed to false, so the three divisions by `q` that the selects would discard are not
//! computed: the kernel is a chain of two divisions, `cos / pdf` then `β / q`, so it is
//! latency-bound (figures: `docs/perf.md#russian-roulette-and-mis-pathroulettersrs-lightsmisrs`).

use glam::{BVec3, Vec3};
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

/// One path's bounce: the new throughput and whether roulette lets the path go on. Branch-free
/// (selects, no early return), so that [`continue_lanes`] runs it eight lanes wide.
///
/// Where `alive` is false the throughput is the one divided by `q`, never read.
// `!(a >= b)` on purpose: a NaN `q` or `u` keeps the path, as the early return it replaced did.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
pub fn continue_path(l: &RouletteLane) -> RouletteResult {
    let beta = l.beta * (l.f * (l.cos / l.pdf));
    let survive = beta.max_element().min(0.95);
    // Per-component selects and `|`: a whole-vector `if` or `||` became a branch per lane, which
    // kept the loop scalar.
    let divided = beta / survive;
    RouletteResult {
        beta: Vec3::select(BVec3::splat(l.play), divided, beta),
        alive: !l.play | !(l.u >= survive),
    }
}

/// [`continue_path`] on eight lanes.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn continue_lanes(l: &RouletteLanes, out: &mut RouletteOut) {
    if l.play.iter().any(|&p| p != 0) {
        continue_group::<true>(l, out);
    } else {
        continue_group::<false>(l, out);
    }
}

#[inline(always)]
fn continue_group<const PLAY: bool>(l: &RouletteLanes, out: &mut RouletteOut) {
    for k in 0..LANES {
        let mut lane = l.get(k);
        lane.play &= PLAY;
        out.set(k, &continue_path(&lane));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The update as the integrator first wrote it, with its early return: the specification.
    fn continue_reference(beta: Vec3, f: Vec3, cos: f32, pdf: f32, play: bool, u: f32) -> Option<Vec3> {
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

    /// Bits, with every NaN one value (IEEE leaves a NaN's sign and payload open).
    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() })
    }

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
                let expected = continue_reference(i.beta, i.f, i.cos, i.pdf, i.play, i.u);
                assert_eq!(o.alive, expected.is_some(), "lane {k}");
                let body = continue_path(&i);
                assert_eq!((body.alive, bits(body.beta)), (o.alive, bits(o.beta)), "body, lane {k}");
                if let Some(b) = expected {
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

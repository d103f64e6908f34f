//! The MIS weight of next-event estimation: one branch-free body, [`weigh`], that both
//! integrators call per light sample and [`weigh_lanes`] calls per lane (AoSoA `[f32; 8]`
//! columns, compiled for x86-64 AVX2+FMA with a generic fallback, [`multiversion`]).
//!
//! Per candidate: `contribution = β · f · Lᵢ · (|cos θ| / p_light)`, kept when its largest channel is
//! positive, weighted by the power heuristic against the BSDF pdf (1 for delta lights).
//! [`power_heuristic`] is written with selects, not a short-circuit chain: as a chain it compiled to
//! a scalar loop with a branch and a `divss` per lane (figures:
//! `docs/perf.md#russian-roulette-and-mis-pathroulettersrs-lightsmisrs`).
//!
//! Candidates arrive AoS from shading (sorted by material and texture, not by lane), are transposed
//! eight at a time into [`NeeLanes`], weighed, and scattered back.

use glam::Vec3;

/// Power heuristic (β = 2) weight of a strategy with pdf `a` against one with pdf `b`: `a²/(a²+b²)`
/// where that sum is a positive number, else 1 for an infinite `a` (a delta strategy) and 0.
// Selects, not `&&` and early returns, so that it runs eight lanes wide in [`weigh_lanes`].
#[inline(always)]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    let sum = a2 + b2;
    let regular = (sum > 0.0) & sum.is_finite();
    let fallback = if a.is_infinite() { 1.0 } else { 0.0 };
    if regular {
        a2 / sum
    } else {
        fallback
    }
}

use lanekit::LANES;

/// A next-event candidate from shading (AoS, indexed by its path).
#[derive(Clone, Copy, Debug, Default)]
pub struct NeeCandidate {
    /// Path (ray-state) index.
    pub index: u32,
    /// Throughput at the vertex.
    pub beta: Vec3,
    /// BSDF value towards the light.
    pub f: Vec3,
    /// Incident radiance from the light sample.
    pub li: Vec3,
    /// `|n_s · ω_i|`.
    pub cos: f32,
    /// Light pdf (solid angle, with selection).
    pub light_pdf: f32,
    /// BSDF pdf of `ω_i`.
    pub bsdf_pdf: f32,
    /// 1 for a delta light.
    pub delta: u32,
    /// Shadow ray origin.
    pub origin: glam::Vec3,
    /// Shadow ray direction.
    pub dir: glam::Vec3,
    /// Shadow ray extent.
    pub tmax: f32,
    /// Pass-through seed.
    pub seed: u32,
}

lanekit::soa! {
    /// Eight candidates' inputs, one column per scalar.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct NeeLanes for struct NeeLane {
        /// Throughput, per channel.
        pub beta: Vec3 as [f32; 3],
        /// BSDF value, per channel.
        pub f: Vec3 as [f32; 3],
        /// Light radiance, per channel.
        pub li: Vec3 as [f32; 3],
        /// Cosines.
        pub cos: f32,
        /// Light pdfs.
        pub light_pdf: f32,
        /// BSDF pdfs.
        pub bsdf_pdf: f32,
        /// Delta-light flags (0/1).
        pub delta: u32,
    }
}

lanekit::soa! {
    /// Eight weighed contributions (`visible == 0`: dropped, no shadow ray).
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct NeeOut for struct NeeWeighed {
        /// MIS-weighted contribution per channel.
        pub contribution: Vec3 as [f32; 3],
        /// 1 where the contribution is positive somewhere.
        pub keep: bool,
    }
}

/// One light sample's MIS-weighted contribution, zero and `keep == false` where it is black.
#[inline(always)]
pub fn weigh(c: &NeeLane) -> NeeWeighed {
    let contribution = c.beta * c.f * c.li * (c.cos / c.light_pdf);
    let keep = contribution.max_element() > 0.0;
    let w = if c.delta != 0 { 1.0 } else { power_heuristic(c.light_pdf, c.bsdf_pdf) };
    NeeWeighed { contribution: if keep { contribution * w } else { Vec3::ZERO }, keep }
}

/// Transposes up to eight candidates into lanes (missing lanes stay zero and come out dropped).
pub fn transpose(cands: &[NeeCandidate]) -> NeeLanes {
    let mut l = NeeLanes::default();
    for (k, c) in cands.iter().take(LANES).enumerate() {
        let NeeCandidate { beta, f, li, cos, light_pdf, bsdf_pdf, delta, .. } = *c;
        l.set(k, &NeeLane { beta, f, li, cos, light_pdf, bsdf_pdf, delta });
    }
    l
}

/// [`weigh`] on eight candidates.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn weigh_lanes(l: &NeeLanes, out: &mut NeeOut) {
    for k in 0..LANES {
        out.set(k, &weigh(&l.get(k)));
    }
}

/// Weighs `cands` eight at a time, calling `emit(candidate, weighted contribution)` for each kept one,
/// in order.
pub fn weigh_all(cands: &[NeeCandidate], mut emit: impl FnMut(&NeeCandidate, Vec3)) {
    let mut out = NeeOut::default();
    for chunk in cands.chunks(LANES) {
        weigh_lanes(&transpose(chunk), &mut out);
        for (k, c) in chunk.iter().enumerate() {
            let NeeWeighed { contribution, keep } = out.get(k);
            if keep {
                emit(c, contribution);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The power heuristic as first written, with its short-circuit chain: the specification.
    fn power_heuristic_reference(a: f32, b: f32) -> f32 {
        let (a2, b2) = (a * a, b * b);
        if a2 + b2 > 0.0 && (a2 + b2).is_finite() {
            a2 / (a2 + b2)
        } else if a.is_infinite() {
            1.0
        } else {
            0.0
        }
    }

    /// The weight as the integrator first wrote it, with its early return: the specification.
    fn weigh_reference(c: &NeeCandidate) -> Option<Vec3> {
        let contribution = c.beta * c.f * c.li * (c.cos / c.light_pdf);
        if contribution.max_element() > 0.0 {
            let w = if c.delta != 0 { 1.0 } else { power_heuristic_reference(c.light_pdf, c.bsdf_pdf) };
            Some(contribution * w)
        } else {
            None
        }
    }

    #[test]
    fn power_heuristic_equals_the_reference_bit_for_bit() {
        let special =
            [0.0, -0.0, 1e-30, 1e30, 3e19, f32::MAX, f32::INFINITY, -f32::INFINITY, f32::NAN, 0.5, 2.0];
        let mut x = 7u32;
        let mut values = special.to_vec();
        for _ in 0..2000 {
            x = crate::sampler::hash_u32(x);
            values.push(f32::from_bits(x));
        }
        let bits = |v: f32| if v.is_nan() { u32::MAX } else { v.to_bits() };
        let mut regular = 0;
        for &a in &values {
            for &b in values.iter().step_by(7).chain(&special) {
                let (got, want) = (power_heuristic(a, b), power_heuristic_reference(a, b));
                assert_eq!(bits(got), bits(want), "power_heuristic({a}, {b})");
                regular += (want > 0.0 && want < 1.0) as u32;
            }
        }
        assert!(regular > 10_000, "{regular} weights strictly between 0 and 1");
    }

    #[test]
    fn lanes_equal_scalar_bit_for_bit_on_random_inputs() {
        let mut x = 99u32;
        let mut u = || {
            x = crate::sampler::hash_u32(x);
            (x >> 8) as f32 / 16_777_216.0
        };
        let special = [0.0, -0.0, f32::INFINITY, 1e-30, 1e30, f32::NAN, -1.0];
        let mut cands = Vec::new();
        for i in 0..4099u32 {
            let mut pick = |scale: f32| {
                let r = u();
                if r < 0.05 {
                    special[(u() * special.len() as f32) as usize % special.len()]
                } else {
                    r * scale
                }
            };
            cands.push(NeeCandidate {
                index: i,
                beta: Vec3::new(pick(2.0), pick(2.0), pick(2.0)),
                f: Vec3::new(pick(1.0), pick(1.0), pick(1.0)),
                li: Vec3::new(pick(10.0), pick(10.0), pick(10.0)),
                cos: pick(1.0),
                light_pdf: pick(5.0),
                bsdf_pdf: pick(5.0),
                delta: (u() < 0.2) as u32,
                ..NeeCandidate::default()
            });
        }
        // Bits, with every NaN one value (its sign and payload are not specified by IEEE arithmetic).
        let bits = |v: Vec3| v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() });
        let mut got = Vec::new();
        weigh_all(&cands, |c, v| got.push((c.index, bits(v))));
        let expected: Vec<_> =
            cands.iter().filter_map(|c| weigh_reference(c).map(|v| (c.index, bits(v)))).collect();
        assert!(expected.len() > 3000);
        for (g, e) in got.iter().zip(&expected) {
            assert_eq!(g, e, "{:?}", cands[e.0 as usize]);
        }
        assert_eq!(got.len(), expected.len());
    }
}

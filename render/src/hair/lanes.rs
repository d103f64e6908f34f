//! The Chiang hair BSDF ([`crate::hair::HairBsdf`]) evaluated, sampled and its pdf found eight fibre
//! hits at a time, in AoSoA form (`[f32; 8]` columns), for the wavefront's curve hits
//! (`shade_curves`).
//!
//! One copy of the lobe mathematics: the kernels find the local directions (the frame dots), the
//! `cos 2πu` of the longitudinal sample ([`crate::trig::sin_cos_lanes`]) and the world direction of
//! a sample eight at a time, loops LLVM vectorises under [`multiversion`]; between those, each lane
//! runs `HairBsdf::eval_local` / `HairBsdf::sample_local`, the very functions the scalar
//! [`HairBsdf::eval`] and [`HairBsdf::sample`] call, on a `HairBsdf` gathered from the columns and
//! the per-lane records (the roughness terms and the view terms, found once per fibre and hit). The
//! lanes therefore equal the scalar BSDF bit for bit by construction, and the tests check it on
//! 16 000 random cases per kernel: fibres, views, directions (some along the fibre), offsets over
//! the whole width, colour-derived, zero and direct absorptions, roughnesses 0.05–1 and tilts
//! ±5° (the scalar code's `None` is the lanes' `ok` mask).
//!
//! Why the lobes stay per lane: they are libm calls LLVM cannot vectorise (per evaluation an
//! `atan2f` and, per lobe, the longitudinal term's `expf` (and `logf` of the Bessel term for the
//! narrow R and TT lobes) and the logistic's `expf`: ten; a sample adds two `logf`), and branches
//! (lobe choice, the Bessel term's two forms, azimuth wrapping). What changed the cost instead was
//! doing less of it, in `hair.rs`, for both integrators, with the same bits: the lobes'
//! normalizations once per roughness (`hair::Lobes`, cached for the default fibre), and
//! the view's terms (transmittance, lobe weights, azimuth of `wo`) once per hit rather than in the
//! light sample's evaluation, the BSDF sample and the sample's own evaluation
//! (`hair::View`). Libm calls per shaded fibre hit with a light sample: ~64 → ~31.
//! Vector `expf`/`logf`/`atan2f` polynomials shared by both integrators (as
//! [`crate::trig::sin_cos`] replaced `sincosf`) and a branch-free lobe loop are the next step; they
//! change the hair image of both integrators, so they were left for a separate change.
//!
//! Measurements: `docs/perf.md#hair-lanes-hairlanesrs`.

use crate::bsdf::lanes::{EvalLanes, SampleInputs, SampleLanes};
use crate::hair::{HairBsdf, Lobes, View};
use glam::Vec3;
use lanekit::LANES;
use lanekit::V;
use lanekit::{Lanes, Lanes3};
use std::f32::consts::TAU;
use std::ops::Add;

/// Eight hair BSDFs and their outgoing directions, transposed.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct HairLanes {
    /// Fibre tangent (frame x).
    pub x: Lanes3,
    /// Frame y (z × x).
    pub y: Lanes3,
    /// Frame z, towards the viewer (the shading normal).
    pub z: Lanes3,
    /// Offset across the fibre.
    pub h: Lanes,
    /// `asin h`.
    pub gamma_o: Lanes,
    /// Absorption coefficient.
    pub sigma_a: Lanes3,
    /// Fibre colour.
    pub color: Lanes3,
    /// Per lane: what the fibre's roughness fixes and what the view does (records, not columns:
    /// only the per-lane lobe code reads them).
    lobes: [Lobes; LANES],
    view: [View; LANES],
}

impl Default for HairLanes {
    fn default() -> Self {
        let zero = [[0.0; LANES]; 3];
        HairLanes {
            x: zero,
            y: zero,
            z: zero,
            h: [0.0; LANES],
            gamma_o: [0.0; LANES],
            sigma_a: zero,
            color: zero,
            lobes: [*Lobes::default_fibre(); LANES],
            view: [View::default(); LANES],
        }
    }
}

impl HairLanes {
    /// Writes `hair` into lane `k`.
    #[inline]
    pub fn set(&mut self, k: usize, hair: &HairBsdf) {
        let put = |dst: &mut Lanes3, v: Vec3| (dst[0][k], dst[1][k], dst[2][k]) = (v.x, v.y, v.z);
        put(&mut self.x, hair.x);
        put(&mut self.y, hair.y);
        put(&mut self.z, hair.z);
        put(&mut self.sigma_a, hair.sigma_a);
        put(&mut self.color, hair.color);
        self.h[k] = hair.h;
        self.gamma_o[k] = hair.gamma_o;
        self.lobes[k] = hair.lobes;
        self.view[k] = hair.view;
    }

    /// Lane `k`'s BSDF (what [`HairLanes::set`] wrote).
    #[inline(always)]
    fn at(&self, k: usize) -> HairBsdf {
        let v3 = |c: &Lanes3| Vec3::new(c[0][k], c[1][k], c[2][k]);
        HairBsdf {
            x: v3(&self.x),
            y: v3(&self.y),
            z: v3(&self.z),
            h: self.h[k],
            gamma_o: self.gamma_o[k],
            sigma_a: v3(&self.sigma_a),
            color: v3(&self.color),
            lobes: self.lobes[k],
            view: self.view[k],
        }
    }
}

/// `HairBsdf::local` of world directions `w` in every lane: `(w·x, w·y, w·z)` with glam's `dot`
/// order.
#[inline(always)]
fn to_local_lanes(l: &HairLanes, w: &Lanes3, out: &mut Lanes3) {
    for k in 0..LANES {
        let v = V::at(w, k);
        V { x: v.dot(V::at(&l.x, k)), y: v.dot(V::at(&l.y, k)), z: v.dot(V::at(&l.z, k)) }.store(out, k);
    }
}

#[inline(always)]
fn lane(c: &Lanes3, k: usize) -> Vec3 {
    Vec3::new(c[0][k], c[1][k], c[2][k])
}

/// [`HairBsdf::eval`] on eight lanes: `wi` towards the light, per lane.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn eval_lanes(l: &HairLanes, wi: &Lanes3, out: &mut EvalLanes) {
    let mut wi_l = [[0.0; LANES]; 3];
    to_local_lanes(l, wi, &mut wi_l);
    for k in 0..LANES {
        let (f, pdf) = l.at(k).eval_local(lane(&wi_l, k));
        (out.f[0][k], out.f[1][k], out.f[2][k]) = (f.x, f.y, f.z);
        out.pdf[k] = pdf;
    }
}

/// [`HairBsdf::pdf`] on eight lanes.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn pdf_lanes(l: &HairLanes, wi: &Lanes3, out: &mut Lanes) {
    let mut wi_l = [[0.0; LANES]; 3];
    to_local_lanes(l, wi, &mut wi_l);
    for (k, pdf) in out.iter_mut().enumerate() {
        *pdf = l.at(k).eval_local(lane(&wi_l, k)).1;
    }
}

/// [`HairBsdf::sample`] on eight lanes; lanes with `ok == 0` were absorbed (the scalar `sample`
/// returned `None`; their other outputs are zero).
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn sample_lanes(l: &HairLanes, u: &SampleInputs, out: &mut SampleLanes) {
    let angle = u.u1.map(|u1| TAU * u1);
    let (mut sin_phi, mut cos_phi) = ([0.0; LANES], [0.0; LANES]);
    crate::trig::sin_cos_lanes(&angle, &mut sin_phi, &mut cos_phi);
    let mut wi_l = [[0.0; LANES]; 3];
    for k in 0..LANES {
        let sampled = l.at(k).sample_local(u.u_lobe[k], u.u0[k], cos_phi[k]);
        let (w, f, pdf) = sampled.unwrap_or((Vec3::ZERO, Vec3::ZERO, 0.0));
        (wi_l[0][k], wi_l[1][k], wi_l[2][k]) = (w.x, w.y, w.z);
        (out.f[0][k], out.f[1][k], out.f[2][k]) = (f.x, f.y, f.z);
        out.pdf[k] = pdf;
        out.ok[k] = sampled.is_some() as u32;
        // Hair lobes are broad in azimuth: cones widen as after a diffuse bounce (the scalar value).
        out.lobe_alpha[k] = 1.0;
    }
    // `HairBsdf::world`: `x·w.x + y·w.y + z·w.z` per component.
    for k in 0..LANES {
        let w = V::at(&wi_l, k);
        let (x, y, z) = (V::at(&l.x, k), V::at(&l.y, k), V::at(&l.z, k));
        x.scale(w.x).add(y.scale(w.y)).add(z.scale(w.z)).store(&mut out.wi, k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::Rng;

    fn direction(rng: &mut Rng) -> Vec3 {
        let z = 1.0 - 2.0 * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = TAU * rng.next_f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// A random fibre: any tangent and view, `h` across the whole width (and the clamped ends),
    /// colour-derived or direct absorption (zero included), roughness 0.05–1, tilt −5°–5°.
    fn fibre(rng: &mut Rng) -> HairBsdf {
        let (tangent, wo) = (direction(rng), direction(rng));
        let h = -1.0 + 2.0 * rng.next_f32();
        let color = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        match rng.next_f32() {
            c if c < 0.4 => HairBsdf::new(tangent, wo, h, color),
            c => {
                let sigma_a = if c < 0.5 { Vec3::ZERO } else { color * 4.0 };
                let (beta_m, beta_n) = (0.05 + 0.95 * rng.next_f32(), 0.05 + 0.95 * rng.next_f32());
                let alpha = -5.0 + 10.0 * rng.next_f32();
                HairBsdf::with_params(tangent, wo, h, sigma_a, beta_m, beta_n, alpha, color)
            }
        }
    }

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    /// Eight random fibres with a direction each for `eval`/`pdf` and random numbers for `sample`.
    fn group(rng: &mut Rng) -> ([HairBsdf; LANES], HairLanes, Lanes3, SampleInputs) {
        let fibres: [HairBsdf; LANES] = std::array::from_fn(|_| fibre(rng));
        let mut lanes = HairLanes::default();
        let (mut wi, mut u) = ([[0.0; LANES]; 3], SampleInputs::default());
        for (k, hair) in fibres.iter().enumerate() {
            lanes.set(k, hair);
            // Half towards the fibre's side of the viewer, some grazing ones along the tangent.
            let w = if rng.next_f32() < 0.1 { hair.x } else { direction(rng) };
            (wi[0][k], wi[1][k], wi[2][k]) = (w.x, w.y, w.z);
            (u.u_lobe[k], u.u0[k], u.u1[k]) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
        }
        (fibres, lanes, wi, u)
    }

    const GROUPS: usize = 2_000;

    #[test]
    fn eval_and_pdf_lanes_equal_the_scalar_bsdf_bit_for_bit() {
        let mut rng = Rng(0x4a1f);
        let (mut nonzero, mut cases) = (0, 0);
        for _ in 0..GROUPS {
            let (fibres, lanes, wi, _) = group(&mut rng);
            let (mut out, mut pdfs) = (EvalLanes::default(), [0.0; LANES]);
            eval_lanes(&lanes, &wi, &mut out);
            pdf_lanes(&lanes, &wi, &mut pdfs);
            for (k, hair) in fibres.iter().enumerate() {
                let w = lane(&wi, k);
                let (f, pdf) = hair.eval(w);
                assert_eq!(bits(lane(&out.f, k)), bits(f), "f, lane {k}: {:?} vs {f}", lane(&out.f, k));
                assert_eq!(out.pdf[k].to_bits(), pdf.to_bits(), "pdf, lane {k}");
                assert_eq!(pdfs[k].to_bits(), hair.pdf(w).to_bits(), "pdf kernel, lane {k}");
                nonzero += (pdf > 0.0 && f.max_element() > 0.0) as usize;
                cases += 1;
            }
        }
        assert_eq!(cases, GROUPS * LANES);
        // The comparison is not all zeros: nearly every random direction has a hair value.
        assert!(nonzero > cases * 9 / 10, "{nonzero} of {cases}");
    }

    #[test]
    fn sample_lanes_equal_the_scalar_bsdf_bit_for_bit() {
        let mut rng = Rng(0x5eed);
        let (mut sampled, mut cases) = (0, 0);
        for _ in 0..GROUPS {
            let (fibres, lanes, _, u) = group(&mut rng);
            let mut out = SampleLanes::default();
            sample_lanes(&lanes, &u, &mut out);
            for (k, hair) in fibres.iter().enumerate() {
                cases += 1;
                match hair.sample(u.u_lobe[k], [u.u0[k], u.u1[k]]) {
                    Some(s) => {
                        sampled += 1;
                        assert_eq!(out.ok[k], 1, "lane {k} absorbed, scalar sampled");
                        assert_eq!(bits(lane(&out.wi, k)), bits(s.wi), "wi, lane {k}");
                        assert_eq!(bits(lane(&out.f, k)), bits(s.f), "f, lane {k}");
                        assert_eq!(out.pdf[k].to_bits(), s.pdf.to_bits(), "pdf, lane {k}");
                        assert_eq!(out.lobe_alpha[k].to_bits(), s.lobe_alpha.to_bits());
                    }
                    None => assert_eq!(out.ok[k], 0, "lane {k} sampled, scalar absorbed"),
                }
            }
        }
        assert_eq!(cases, GROUPS * LANES);
        assert!(sampled > cases * 9 / 10, "{sampled} of {cases} sampled");
    }
}

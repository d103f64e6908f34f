//! The UsdPreviewSurface BSDF as first written, one point at a time with early returns: the
//! specification that the branch-free bodies both integrators now run ([`super::SeenBsdf`],
//! [`super::Bsdf::from_lane`]) must equal bit for bit, NaN and infinities included.
//!
//! Since the clearcoat became OpenPBR's coat layer (albedo scaling and absorption, [`super::coat_view`])
//! the comparison runs on coat-free inputs (a zero weight) with OpenPBR's specular weight and
//! colour at their fallbacks (1): it pins the UsdPreviewSurface base,
//! which is also why images without a coat keep their bytes. The reference's `(1 − cc·F)` coat is
//! kept as it was first written; the coat layer is pinned by the furnace and absorption tests.

use super::{
    albedo, lanes::tests::random_inputs, lanes::tests::Rng, luminance, Bsdf, BsdfSample, Frame, MIN_ALPHA,
};
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// Schlick's Fresnel with the grazing reflectance F90 = saturate(50 · 0.33 · ΣF0) (Filament's
/// "specular occlusion" trick): any real interface (F0 ≥ 0.02) gets F90 = 1, while F0 = 0 (ior = 1, or
/// a black specularColor) means no interface and no specular at all, not a grazing-angle sheen.
#[inline]
fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m5 = (m * m) * (m * m) * m;
    let f90 = (50.0 * 0.33 * (f0.x + f0.y + f0.z)).clamp(0.0, 1.0);
    f0 + (Vec3::splat(f90) - f0) * m5
}

#[inline]
fn schlick_scalar(f0: f32, cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    f0 + (1.0 - f0) * (m * m) * (m * m) * m
}

const CLEARCOAT_F0: f32 = 0.04;

/// GGX normal distribution for a local half vector.
#[inline]
fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let c2 = h.z * h.z;
    let d = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Smith Λ for GGX.
#[inline]
fn ggx_lambda(w: Vec3, alpha: f32) -> f32 {
    let c2 = w.z * w.z;
    if c2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan2 = ((1.0 - c2) / c2).max(0.0);
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// Height-correlated Smith masking-shadowing.
#[inline]
fn ggx_g2(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))
}

/// Solid-angle pdf of `wi` when sampling visible normals from `wo`: G₁(wo)·D(h) / (4 wo.z).
#[inline]
fn ggx_pdf(wo: Vec3, h: Vec3, alpha: f32) -> f32 {
    let g1 = 1.0 / (1.0 + ggx_lambda(wo, alpha));
    g1 * ggx_d(h, alpha) / (4.0 * wo.z)
}

/// Samples a GGX visible normal (spherical caps, Dupuy & Benyoub 2023).
#[inline]
fn sample_ggx_vndf(wo: Vec3, alpha: f32, u: [f32; 2]) -> Vec3 {
    let wi_std = Vec3::new(wo.x * alpha, wo.y * alpha, wo.z).normalize();
    let phi = TAU * u[0];
    let z = (1.0 - u[1]) * (1.0 + wi_std.z) - wi_std.z;
    let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
    let (sin_phi, cos_phi) = crate::trig::sin_cos(phi);
    let c = Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, z);
    let h_std = c + wi_std;
    Vec3::new(h_std.x * alpha, h_std.y * alpha, h_std.z).normalize()
}

/// Cosine-weighted hemisphere sample via the concentric disk mapping.
#[inline]
fn sample_cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let [dx, dy] = sample_concentric_disk(u);
    Vec3::new(dx, dy, (1.0 - dx * dx - dy * dy).max(0.0).sqrt())
}

/// Shirley–Chiu concentric map of the unit square to the unit disk.
#[inline]
fn sample_concentric_disk(u: [f32; 2]) -> [f32; 2] {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, theta) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (b, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b))
    };
    let (sin, cos) = crate::trig::sin_cos(theta);
    [r * cos, r * sin]
}

/// The first version's `Bsdf` (the same fields).
#[derive(Debug)]
struct Old {
    frame: Frame,
    ng: Vec3,
    diffuse: Vec3,
    f0: Vec3,
    alpha: f32,
    clearcoat: f32,
    clearcoat_alpha: f32,
}

impl Old {
    /// Resolves evaluated shading inputs (constants or a material program's output); see [`Bsdf::new`].
    pub fn from_inputs(mat: &crate::shading::ShadingInputs, ns: Vec3, ng: Vec3) -> Self {
        let base = mat.diffuse_color.clamp(Vec3::ZERO, Vec3::ONE);
        let (diffuse, f0) = if mat.use_specular_workflow {
            (base, mat.specular_color.clamp(Vec3::ZERO, Vec3::ONE))
        } else {
            let metallic = mat.metallic.clamp(0.0, 1.0);
            let r = (mat.ior - 1.0) / (mat.ior + 1.0);
            let dielectric = if r.is_finite() { (r * r).min(1.0) } else { 0.04 };
            (base * (1.0 - metallic), Vec3::splat(dielectric).lerp(base, metallic))
        };
        let roughness = mat.roughness.clamp(0.0, 1.0);
        let cc_roughness = mat.clearcoat_roughness.clamp(0.0, 1.0);
        Old {
            frame: Frame::new(ns),
            ng,
            diffuse,
            f0,
            alpha: (roughness * roughness).max(MIN_ALPHA),
            clearcoat: mat.clearcoat.clamp(0.0, 1.0),
            clearcoat_alpha: (cc_roughness * cc_roughness).max(MIN_ALPHA),
        }
    }

    /// Lobe selection probabilities (diffuse, specular, clearcoat) for local `wo`.
    fn lobe_probabilities(&self, wo: Vec3) -> [f32; 3] {
        let coat_f = self.clearcoat * schlick_scalar(CLEARCOAT_F0, wo.z);
        let base = 1.0 - coat_f;
        let spec_f = schlick(self.f0, wo.z);
        let w_d = base * luminance(self.diffuse * (Vec3::ONE - spec_f));
        let w_s = base * luminance(spec_f);
        let total = w_d + w_s + coat_f;
        if total <= 0.0 {
            return [0.0; 3];
        }
        [w_d / total, w_s / total, coat_f / total]
    }

    /// The diffuse and the multiple-scattering lobes' values for local cosines `mu_o`, `mu_i`
    /// ([`albedo`]).
    #[inline]
    fn energy_lobes(&self, mu_o: f32, mu_i: f32) -> (Vec3, Vec3) {
        let t = albedo::tables();
        let (at_o, at_i) =
            (albedo::lobe_albedo(t, mu_o, self.alpha), albedo::lobe_albedo_ab(t, mu_i, self.alpha));
        let (d, f0) = (self.diffuse, self.f0);
        let f90 = albedo::f90(f0.x, f0.y, f0.z);
        let channel = |d: f32, f0: f32| {
            albedo::light_terms(albedo::view_terms(d, f0, f90, 0.0, at_o), f0, f90, 0.0, at_i)
        };
        let ([dx, mx], [dy, my], [dz, mz]) = (channel(d.x, f0.x), channel(d.y, f0.y), channel(d.z, f0.z));
        (Vec3::new(dx, dy, dz) * FRAC_1_PI, Vec3::new(mx, my, mz) * FRAC_1_PI)
    }

    /// BSDF value (no cosine) and combined pdf for world directions `wo` (towards the viewer) and `wi`.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if wi.dot(self.ng) <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let wo_l = self.frame.to_local(wo);
        let wi_l = self.frame.to_local(wi);
        self.eval_local(wo_l, wi_l)
    }

    fn eval_local(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let probs = self.lobe_probabilities(wo);
        let h = (wo + wi).normalize();
        let wo_h = wo.dot(h).max(0.0);
        let denom = 4.0 * wo.z * wi.z;

        let coat_view = self.clearcoat * schlick_scalar(CLEARCOAT_F0, wo.z);
        let (diffuse, multiple) = self.energy_lobes(wo.z, wi.z);
        let specular = schlick(self.f0, wo_h) * (ggx_d(h, self.alpha) * ggx_g2(wo, wi, self.alpha) / denom);
        let mut f = (1.0 - coat_view) * (diffuse + (specular + multiple));
        let mut pdf = probs[0] * wi.z * FRAC_1_PI + probs[1] * ggx_pdf(wo, h, self.alpha);
        if self.clearcoat > 0.0 {
            let a = self.clearcoat_alpha;
            f += Vec3::splat(
                self.clearcoat * schlick_scalar(CLEARCOAT_F0, wo_h) * ggx_d(h, a) * ggx_g2(wo, wi, a) / denom,
            );
            pdf += probs[2] * ggx_pdf(wo, h, a);
        }
        (f, pdf)
    }

    /// Samples an incident direction for world `wo` with a lobe choice `u_lobe` and a 2D sample `u`.
    /// `None` when the sample is absorbed (black material, or a direction below either hemisphere).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<BsdfSample> {
        let wo_l = self.frame.to_local(wo);
        if wo_l.z <= 0.0 {
            return None;
        }
        let [p_d, p_s, p_c] = self.lobe_probabilities(wo_l);
        if p_d + p_s + p_c <= 0.0 {
            return None;
        }
        let (wi_l, lobe_alpha) = if u_lobe < p_d {
            (sample_cosine_hemisphere(u), 1.0)
        } else {
            let alpha = if u_lobe < p_d + p_s { self.alpha } else { self.clearcoat_alpha };
            let h = sample_ggx_vndf(wo_l, alpha, u);
            (2.0 * wo_l.dot(h) * h - wo_l, alpha)
        };
        if wi_l.z <= 0.0 {
            return None;
        }
        let wi = self.frame.to_world(wi_l).normalize();
        if wi.dot(self.ng) <= 0.0 {
            return None;
        }
        let (f, pdf) = self.eval_local(wo_l, wi_l);
        (pdf > 0.0 && f.is_finite()).then_some(BsdfSample { wi, f, pdf, lobe_alpha })
    }
}

/// Bits, with every NaN one value (IEEE leaves a NaN's sign and payload open).
fn bits(v: Vec3) -> [u32; 3] {
    v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() })
}

#[test]
fn branch_free_bsdf_equals_the_early_return_reference_bit_for_bit() {
    let mut rng = Rng(31);
    let (mut cases, mut nonzero, mut sampled) = (0, 0, 0);
    for _ in 0..40_000 {
        let (mut inputs, ns, ng) = random_inputs(&mut rng);
        inputs.clearcoat = if rng.f() < 0.1 { -0.0 } else { 0.0 };
        // The reference predates OpenPBR's specular weight and tint as well.
        (inputs.specular_weight, inputs.specular_tint, inputs.fuzz_weight) = (1.0, Vec3::ONE, 0.0);
        let (new, old) = (Bsdf::from_inputs(&inputs, ns, ng), Old::from_inputs(&inputs, ns, ng));
        let one = |x: f32| bits(Vec3::splat(x));
        assert_eq!(bits(new.frame.t), bits(old.frame.t), "{old:?}");
        assert_eq!(bits(new.frame.b), bits(old.frame.b), "{old:?}");
        assert_eq!((bits(new.diffuse), bits(new.f0)), (bits(old.diffuse), bits(old.f0)), "{old:?}");
        assert_eq!((one(new.alpha), one(new.clearcoat)), (one(old.alpha), one(old.clearcoat)), "{old:?}");
        assert_eq!(one(new.clearcoat_alpha), one(old.clearcoat_alpha), "{old:?}");
        let wo = if rng.f() < 0.05 { -ng } else { (ng * 0.3 + rng.dir()).normalize_or(ng) };
        let wi = if rng.f() < 0.5 { rng.dir() } else { (ng + rng.dir()).normalize_or(ng) };
        let ((f, pdf), (f_old, pdf_old)) = (new.eval(wo, wi), old.eval(wo, wi));
        assert_eq!((bits(f), one(pdf)), (bits(f_old), one(pdf_old)), "eval {old:?} wo {wo} wi {wi}");
        nonzero += (pdf_old > 0.0) as u32;
        let u_lobe = rng.f();
        let u = [if rng.f() < 0.02 { 0.5 } else { rng.f() }, if rng.f() < 0.02 { 0.5 } else { rng.f() }];
        match (new.sample(wo, u_lobe, u), old.sample(wo, u_lobe, u)) {
            (Some(s), Some(r)) => {
                assert_eq!((bits(s.wi), bits(s.f)), (bits(r.wi), bits(r.f)), "sample {old:?} wo {wo}");
                assert_eq!((one(s.pdf), one(s.lobe_alpha)), (one(r.pdf), one(r.lobe_alpha)), "{old:?}");
                sampled += 1;
            }
            (None, None) => {}
            (s, r) => panic!("sample {old:?} wo {wo} u {u_lobe} {u:?}: {s:?} vs reference {r:?}"),
        }
        cases += 1;
    }
    assert!(
        nonzero > cases / 4 && sampled > cases / 3,
        "{nonzero} evaluations, {sampled} samples of {cases}"
    );
}

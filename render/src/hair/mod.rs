//! The hair BSDF for curves: Chiang, Bitterli, Tappan & Burley 2016, "A Practical and Controllable
//! Hair and Fur Model for Production Path Tracing", as in pbrt-v3/v4 `HairBxDF`.
//!
//! Lobes R (p = 0), TT (1), TRT (2) and the residual TRT+ (p = 3): each is a longitudinal term `M_p`
//! (Gaussian-like, variance `v_p` from β_m, tilted by the cuticle scale angle α), an attenuation `A_p`
//! (dielectric Fresnel at the fibre, absorption σ_a along the refracted path) and an azimuthal term
//! `N_p` (trimmed logistic of width s from β_n around the exit azimuth Φ(p, γ_o, γ_t)). Without
//! absorption the lobes' attenuations sum to 1 (Fresnel energy split), so a white fibre reflects all
//! the light it intercepts: the white-furnace test below checks ∫ f |cos θ_i| dω ≈ 1.
//!
//! Which curves use it: UsdPreviewSurface has no hair model, so **every curve (BasisCurves,
//! NurbsCurves) uses this BSDF** with the bound material's `diffuseColor` (or the interpolated
//! `primvars:displayColor`) as the fibre's colour, converted to σ_a with Chiang et al.'s inverse fit
//! for β_n. Roughness is fixed (β_m = β_n = 0.3, α = 2°, η = 1.55). Points use UsdPreviewSurface.
//!
//! Frame: x along the fibre (tangent), z towards the viewer perpendicular to x, y = z × x; `h` is the
//! hit's offset across the fibre along y, in [−1, 1].

pub mod lanes;

use crate::bsdf::BsdfSample;
use glam::Vec3;
use std::f32::consts::{PI, TAU};

/// Number of explicit lobes (R, TT, TRT); index `P_MAX` is the residual.
const P_MAX: usize = 3;
/// Index of refraction of keratin.
pub const ETA: f32 = 1.55;
/// Default longitudinal roughness.
pub const BETA_M: f32 = 0.3;
/// Default azimuthal roughness.
pub const BETA_N: f32 = 0.3;
/// Default cuticle scale tilt, degrees.
pub const ALPHA_DEGREES: f32 = 2.0;

/// A hair BSDF at one hit.
#[derive(Clone, Copy, Debug)]
pub struct HairBsdf {
    /// Tangent (x), y, z (towards the viewer) in world space.
    pub(crate) x: Vec3,
    pub(crate) y: Vec3,
    pub(crate) z: Vec3,
    pub(crate) h: f32,
    pub(crate) gamma_o: f32,
    pub(crate) sigma_a: Vec3,
    pub(crate) color: Vec3,
    pub(crate) lobes: Lobes,
    pub(crate) view: View,
}

/// What depends on the viewing direction only. A hair BSDF is built for one `wo` (its frame
/// already is), so these are found once per hit rather than in the light sample's evaluation, the
/// BSDF sample and the sample's evaluation each (the transmittance's three `expf`, an `asinf` and
/// an `atan2f`, three times per hit before). Same operations on the same local `wo`: same bits.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct View {
    /// Sine and cosine of `wo`'s longitudinal angle (its local x).
    pub(crate) sin_o: f32,
    pub(crate) cos_o: f32,
    /// Azimuth of `wo`.
    pub(crate) phi_o: f32,
    /// Attenuation per lobe.
    pub(crate) ap: [Vec3; P_MAX + 1],
    /// Refracted offset angle.
    pub(crate) gamma_t: f32,
    /// Lobe selection probabilities.
    pub(crate) pdfs: [f32; P_MAX + 1],
}

/// What a fibre's roughness, scale tilt and index of refraction fix, the same at every hit of
/// fibres with the same parameters (every curve today: [`Lobes::default_fibre`] is computed once).
///
/// Besides the model's parameters it holds the lobes' normalizations, which the evaluation used
/// to recompute per call: `ln(1/(2v))` and `2v·sinh(1/v)` of each longitudinal term and the
/// trimmed logistic's `F(π) − F(−π)` and `F(−π)`. Same operations, done once, so the same bits:
/// two `logf`, two `sinhf` and six `expf` fewer per evaluation, one `expf` fewer per sample. With
/// the view's terms found once per hit ([`View`]), an evaluation makes 10 libm calls where it
/// made 25.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lobes {
    pub(crate) eta: f32,
    /// Longitudinal variance per lobe (R, TT, TRT, residual).
    pub(crate) v: [f32; P_MAX + 1],
    /// Azimuthal logistic scale.
    pub(crate) s: f32,
    pub(crate) sin_2k_alpha: [f32; 3],
    pub(crate) cos_2k_alpha: [f32; 3],
    /// `ln(1 / (2v))` per lobe (the normalization of `M_p` for `v ≤ 0.1`).
    pub(crate) log_norm: [f32; P_MAX + 1],
    /// `sinh(1/v) · 2 · v` per lobe (the normalization of `M_p` for `v > 0.1`).
    pub(crate) sinh_norm: [f32; P_MAX + 1],
    /// `F(π) − F(−π)` of the logistic of scale `s`: the trimmed logistic's mass.
    pub(crate) trim: f32,
    /// `F(−π)`.
    pub(crate) cdf_lo: f32,
    /// `exp(−2/v)` per lobe (the longitudinal sample's lower end).
    pub(crate) exp_neg2_over_v: [f32; P_MAX + 1],
}

impl Lobes {
    /// The lobes of a fibre with longitudinal roughness `beta_m`, azimuthal roughness `beta_n` and
    /// scales tilted by `alpha_degrees`.
    pub(crate) fn new(beta_m: f32, beta_n: f32, alpha_degrees: f32) -> Self {
        let v0 = {
            let b = 0.726 * beta_m + 0.812 * beta_m * beta_m + 3.7 * beta_m.powi(20);
            b * b
        };
        let s = (PI / 8.0).sqrt() * (0.265 * beta_n + 1.194 * beta_n * beta_n + 5.372 * beta_n.powi(22));
        let mut sin_2k_alpha = [0.0; 3];
        let mut cos_2k_alpha = [0.0; 3];
        sin_2k_alpha[0] = alpha_degrees.to_radians().sin();
        cos_2k_alpha[0] = safe_sqrt(1.0 - sin_2k_alpha[0] * sin_2k_alpha[0]);
        for i in 1..3 {
            sin_2k_alpha[i] = 2.0 * cos_2k_alpha[i - 1] * sin_2k_alpha[i - 1];
            cos_2k_alpha[i] = cos_2k_alpha[i - 1].powi(2) - sin_2k_alpha[i - 1].powi(2);
        }
        let v = [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0];
        Lobes {
            eta: ETA,
            v,
            s,
            sin_2k_alpha,
            cos_2k_alpha,
            log_norm: v.map(|v| (1.0 / (2.0 * v)).ln()),
            sinh_norm: v.map(|v| (1.0 / v).sinh() * 2.0 * v),
            trim: logistic_cdf(PI, s) - logistic_cdf(-PI, s),
            cdf_lo: logistic_cdf(-PI, s),
            exp_neg2_over_v: v.map(|v| (-2.0 / v).exp()),
        }
    }

    /// The lobes of every curve's fibre ([`BETA_M`], [`BETA_N`], [`ALPHA_DEGREES`]), computed once.
    pub(crate) fn default_fibre() -> &'static Lobes {
        static DEFAULT: std::sync::OnceLock<Lobes> = std::sync::OnceLock::new();
        DEFAULT.get_or_init(|| Lobes::new(BETA_M, BETA_N, ALPHA_DEGREES))
    }
}

/// The frame's z axis for a fibre along unit `tangent` seen from `wo`: `wo` without its component
/// along the fibre, normalized (any perpendicular when `wo` runs along the fibre). It is also the
/// hit's shading normal, so [`crate::surface::Surface`] keeps it and the BSDF is built from it
/// where the hit is shaded ([`HairBsdf::from_view_axis`]).
pub fn view_axis(tangent: Vec3, wo: Vec3) -> Vec3 {
    let x = tangent;
    (wo - x * wo.dot(x)).try_normalize().unwrap_or_else(|| crate::bsdf::Frame::new(x).t)
}

#[inline]
fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

#[inline]
fn safe_asin(x: f32) -> f32 {
    x.clamp(-1.0, 1.0).asin()
}

/// Absorption coefficient giving roughly the colour `c` for azimuthal roughness `beta_n` (Chiang et
/// al. 2016, eq. 9).
pub fn sigma_a_from_color(c: Vec3, beta_n: f32) -> Vec3 {
    let b = beta_n;
    let d = 5.969 - 0.215 * b + 2.532 * b * b - 10.73 * b.powi(3) + 5.574 * b.powi(4) + 0.245 * b.powi(5);
    c.clamp(Vec3::splat(1e-4), Vec3::splat(0.9999)).to_array().map(|ci| (ci.ln() / d).powi(2)).into()
}

fn i0(x: f32) -> f32 {
    let mut val = 0.0f32;
    let mut x2i = 1.0f32;
    let mut ifact = 1.0f32;
    let mut i4 = 1.0f32;
    for i in 0..10 {
        if i > 1 {
            ifact *= i as f32;
        }
        val += x2i / (i4 * ifact * ifact);
        x2i *= x * x;
        i4 *= 4.0;
    }
    val
}

fn log_i0(x: f32) -> f32 {
    if x > 12.0 {
        x + 0.5 * (-(TAU.ln()) + (1.0 / x).ln() + 1.0 / (8.0 * x))
    } else {
        i0(x).ln()
    }
}

/// `M_p` for lobe `p` of `lobes`.
#[inline(always)]
fn mp(cos_i: f32, cos_o: f32, sin_i: f32, sin_o: f32, lobes: &Lobes, p: usize) -> f32 {
    let v = lobes.v[p];
    let a = cos_i * cos_o / v;
    let b = sin_i * sin_o / v;
    if v <= 0.1 {
        (log_i0(a) - b - 1.0 / v + std::f32::consts::LN_2 + lobes.log_norm[p]).exp()
    } else {
        (-b).exp() * i0(a) / lobes.sinh_norm[p]
    }
}

fn fr_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(-1.0, 1.0);
    let (cos_i, eta) = if cos_i < 0.0 { (-cos_i, 1.0 / eta) } else { (cos_i, eta) };
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = safe_sqrt(1.0 - sin2_t);
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

fn ap(cos_theta_o: f32, eta: f32, h: f32, t: Vec3) -> [Vec3; P_MAX + 1] {
    let cos_gamma_o = safe_sqrt(1.0 - h * h);
    let f = fr_dielectric(cos_theta_o * cos_gamma_o, eta);
    let a0 = Vec3::splat(f);
    let a1 = (1.0 - f) * (1.0 - f) * t;
    let a2 = a1 * t * f;
    let denom = Vec3::ONE - t * f;
    let a3 = a2 * f * t / denom.max(Vec3::splat(1e-6));
    [a0, a1, a2, a3]
}

#[inline]
fn phi(p: usize, gamma_o: f32, gamma_t: f32) -> f32 {
    2.0 * p as f32 * gamma_t - 2.0 * gamma_o + p as f32 * PI
}

#[inline]
fn logistic(x: f32, s: f32) -> f32 {
    let x = x.abs();
    let e = (-x / s).exp();
    e / (s * (1.0 + e) * (1.0 + e))
}

#[inline]
fn logistic_cdf(x: f32, s: f32) -> f32 {
    1.0 / (1.0 + (-x / s).exp())
}

/// The logistic of scale `lobes.s` trimmed to [−π, π].
#[inline(always)]
fn trimmed_logistic(x: f32, lobes: &Lobes) -> f32 {
    logistic(x, lobes.s) / lobes.trim
}

#[inline(always)]
fn sample_trimmed_logistic(u: f32, lobes: &Lobes) -> f32 {
    let (s, k) = (lobes.s, lobes.trim);
    let x = -s * (1.0 / (u * k + lobes.cdf_lo) - 1.0).ln();
    x.clamp(-PI, PI)
}

#[inline(always)]
fn np(phi_: f32, p: usize, lobes: &Lobes, gamma_o: f32, gamma_t: f32) -> f32 {
    let mut dphi = phi_ - phi(p, gamma_o, gamma_t);
    while dphi > PI {
        dphi -= TAU;
    }
    while dphi < -PI {
        dphi += TAU;
    }
    trimmed_logistic(dphi, lobes)
}

impl HairBsdf {
    /// A fibre with tangent `tangent`, viewed from `wo`, hit at offset `h`, of colour `color`.
    pub fn new(tangent: Vec3, wo: Vec3, h: f32, color: Vec3) -> Self {
        Self::from_view_axis(tangent, wo, view_axis(tangent, wo), h, color)
    }

    /// [`HairBsdf::new`] with the frame's z axis `z` already found ([`view_axis`] of `tangent`
    /// and `wo`).
    pub fn from_view_axis(tangent: Vec3, wo: Vec3, z: Vec3, h: f32, color: Vec3) -> Self {
        let sigma_a = sigma_a_from_color(color, BETA_N);
        Self::with_axes(tangent, wo, z, h, sigma_a, *Lobes::default_fibre(), color)
    }

    /// Full parameter set (σ_a directly).
    #[allow(clippy::too_many_arguments)]
    pub fn with_params(
        tangent: Vec3,
        wo: Vec3,
        h: f32,
        sigma_a: Vec3,
        beta_m: f32,
        beta_n: f32,
        alpha_degrees: f32,
        color: Vec3,
    ) -> Self {
        let lobes = Lobes::new(beta_m, beta_n, alpha_degrees);
        Self::with_axes(tangent, wo, view_axis(tangent, wo), h, sigma_a, lobes, color)
    }

    fn with_axes(tangent: Vec3, wo: Vec3, z: Vec3, h: f32, sigma_a: Vec3, lobes: Lobes, color: Vec3) -> Self {
        let x = tangent;
        let y = z.cross(x);
        let h = h.clamp(-0.999, 0.999);
        let mut hair =
            HairBsdf { x, y, z, h, gamma_o: safe_asin(h), sigma_a, color, lobes, view: View::default() };
        let wo = hair.local(wo);
        let sin_o = wo.x;
        let (ap, gamma_t) = hair.attenuation(wo);
        hair.view = View {
            sin_o,
            cos_o: safe_sqrt(1.0 - sin_o * sin_o),
            phi_o: wo.z.atan2(wo.y),
            ap,
            gamma_t,
            pdfs: hair.lobe_pdfs(&ap),
        };
        hair
    }

    /// The direction the integrator multiplies `f` by the cosine to (`f` already divides by it).
    pub fn normal(&self) -> Vec3 {
        self.z
    }

    /// Fibre colour (for the albedo AOV).
    pub fn color(&self) -> Vec3 {
        self.color
    }

    fn local(&self, w: Vec3) -> Vec3 {
        Vec3::new(w.dot(self.x), w.dot(self.y), w.dot(self.z))
    }

    fn world(&self, w: Vec3) -> Vec3 {
        self.x * w.x + self.y * w.y + self.z * w.z
    }

    /// Longitudinal angles of `wo` tilted by the scales for lobe `p`.
    fn tilted(&self, p: usize, sin_o: f32, cos_o: f32) -> (f32, f32) {
        let (s, c) = (self.lobes.sin_2k_alpha, self.lobes.cos_2k_alpha);
        let (sin_op, cos_op) = match p {
            0 => (sin_o * c[1] - cos_o * s[1], cos_o * c[1] + sin_o * s[1]),
            1 => (sin_o * c[0] + cos_o * s[0], cos_o * c[0] - sin_o * s[0]),
            2 => (sin_o * c[2] + cos_o * s[2], cos_o * c[2] - sin_o * s[2]),
            _ => (sin_o, cos_o),
        };
        (sin_op, cos_op.abs())
    }

    /// Attenuations and the refracted azimuth for local `wo`.
    fn attenuation(&self, wo: Vec3) -> ([Vec3; P_MAX + 1], f32) {
        let sin_o = wo.x;
        let cos_o = safe_sqrt(1.0 - sin_o * sin_o);
        let eta = self.lobes.eta;
        let sin_t = sin_o / eta;
        let cos_t = safe_sqrt(1.0 - sin_t * sin_t);
        let etap = (eta * eta - sin_o * sin_o).sqrt() / cos_o.max(1e-6);
        let sin_gamma_t = self.h / etap;
        let cos_gamma_t = safe_sqrt(1.0 - sin_gamma_t * sin_gamma_t);
        let gamma_t = safe_asin(sin_gamma_t);
        let t = (-self.sigma_a * (2.0 * cos_gamma_t / cos_t.max(1e-6))).exp();
        (ap(cos_o, eta, self.h, t), gamma_t)
    }

    fn lobe_pdfs(&self, ap: &[Vec3; P_MAX + 1]) -> [f32; P_MAX + 1] {
        let lum = ap.map(crate::bsdf::luminance);
        let sum: f32 = lum.iter().sum();
        if sum <= 0.0 {
            return [0.25; P_MAX + 1];
        }
        lum.map(|l| l / sum)
    }

    /// Value (divided by |cos| to [`HairBsdf::normal`], as the integrator multiplies it back) and
    /// pdf for local `wi`. Shared with the lane kernels ([`crate::hair::lanes`]),
    /// which call it per lane after finding the local directions eight at a time.
    #[inline(always)]
    pub(crate) fn eval_local(&self, wi: Vec3) -> (Vec3, f32) {
        let View { sin_o, cos_o, phi_o, ap, gamma_t, pdfs, .. } = self.view;
        let sin_i = wi.x;
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        let phi_i = wi.z.atan2(wi.y);
        let dphi = phi_i - phi_o;
        let mut f = Vec3::ZERO;
        let mut pdf = 0.0;
        for p in 0..P_MAX {
            let (sin_op, cos_op) = self.tilted(p, sin_o, cos_o);
            let m = mp(cos_i, cos_op, sin_i, sin_op, &self.lobes, p);
            let n = np(dphi, p, &self.lobes, self.gamma_o, gamma_t);
            f += ap[p] * (m * n);
            pdf += pdfs[p] * m * n;
        }
        let m = mp(cos_i, cos_o, sin_i, sin_o, &self.lobes, P_MAX);
        f += ap[P_MAX] * (m / TAU);
        pdf += pdfs[P_MAX] * m / TAU;
        let cos = wi.z.abs();
        if cos > 0.0 {
            f /= cos;
        }
        (f, pdf)
    }

    /// Value and pdf towards world direction `wi`, for the `wo` the BSDF was built for.
    pub fn eval(&self, wi: Vec3) -> (Vec3, f32) {
        self.eval_local(self.local(wi))
    }

    /// The pdf of sampling world direction `wi`: [`HairBsdf::eval`]'s second half.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        self.eval_local(self.local(wi)).1
    }

    /// Samples an incident direction for the `wo` the BSDF was built for: `u_lobe` picks the lobe
    /// and (rescaled) the azimuth, `u` the longitudinal angle.
    pub fn sample(&self, u_lobe: f32, u: [f32; 2]) -> Option<BsdfSample> {
        let (_, cos_phi) = crate::trig::sin_cos(TAU * u[1]);
        let (wi_l, f, pdf) = self.sample_local(u_lobe, u[0], cos_phi)?;
        // Hair lobes are broad in azimuth: widen ray cones as a diffuse bounce does.
        Some(BsdfSample { wi: self.world(wi_l), f, pdf, lobe_alpha: 1.0 })
    }

    /// [`HairBsdf::sample`] in the local frame, given `cos(2π u[1])`: the local incident direction,
    /// value and pdf, `None` when absorbed. Shared with the lane kernels, which find the cosine and
    /// the world direction eight at a time.
    #[inline(always)]
    pub(crate) fn sample_local(&self, u_lobe: f32, u0: f32, cos_phi: f32) -> Option<(Vec3, Vec3, f32)> {
        let View { sin_o, cos_o, phi_o, gamma_t, pdfs, .. } = self.view;
        let mut p = 0;
        let mut ul = u_lobe;
        while p < P_MAX && ul >= pdfs[p] {
            ul -= pdfs[p];
            p += 1;
        }
        let ul = (ul / pdfs[p].max(1e-12)).clamp(0.0, 0.999_999);
        let (sin_op, cos_op) = self.tilted(p, sin_o, cos_o);
        let v = self.lobes.v[p];
        let u0 = u0.max(1e-5);
        let cos_theta = 1.0 + v * (u0 + (1.0 - u0) * self.lobes.exp_neg2_over_v[p]).ln();
        let sin_theta = safe_sqrt(1.0 - cos_theta * cos_theta);
        let sin_i = -cos_theta * sin_op + sin_theta * cos_phi * cos_op;
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        let dphi = if p < P_MAX {
            phi(p, self.gamma_o, gamma_t) + sample_trimmed_logistic(ul, &self.lobes)
        } else {
            TAU * ul
        };
        // |φ_o| ≤ π and |Δφ| < 8π: inside `sin_cos`'s domain.
        let (sin_phi_i, cos_phi_i) = crate::trig::sin_cos(phi_o + dphi);
        let wi_l = Vec3::new(sin_i, cos_i * cos_phi_i, cos_i * sin_phi_i);
        let (f, pdf) = self.eval_local(wi_l);
        if pdf.is_nan() || pdf <= 0.0 || f == Vec3::ZERO {
            return None;
        }
        Some((wi_l, f, pdf))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::Rng;

    fn uniform_sphere(rng: &mut Rng) -> Vec3 {
        let z = 1.0 - 2.0 * rng.next_f32();
        let r = safe_sqrt(1.0 - z * z);
        let phi = TAU * rng.next_f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// ∫ f |cos| dω over the sphere for the BSDF's view, estimated by uniform sampling.
    fn albedo(bsdf: &HairBsdf, rng: &mut Rng, n: usize) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            let wi = uniform_sphere(rng);
            let (f, _) = bsdf.eval(wi);
            sum += f * wi.dot(bsdf.normal()).abs();
        }
        sum * (4.0 * PI / n as f32)
    }

    #[test]
    fn white_furnace_without_absorption_is_close_to_one() {
        let mut rng = Rng(7);
        let mut worst: f32 = 0.0;
        let mut lowest: f32 = 1.0;
        for &beta in &[0.2f32, 0.3, 0.5, 0.8] {
            for _ in 0..4 {
                let wo = uniform_sphere(&mut rng);
                let h = -1.0 + 2.0 * rng.next_f32();
                let hair = HairBsdf::with_params(Vec3::X, wo, h, Vec3::ZERO, beta, beta, 2.0, Vec3::ONE);
                let a = albedo(&hair, &mut rng, 200_000).y;
                worst = worst.max(a);
                lowest = lowest.min(a);
            }
        }
        assert!(worst <= 1.05, "energy gain: {worst}");
        assert!(lowest >= 0.93, "energy loss without absorption: {lowest}");
    }

    #[test]
    fn absorbing_hair_reflects_less_and_sampling_matches_eval() {
        let mut rng = Rng(11);
        let wo = Vec3::new(0.3, 0.2, 0.9).normalize();
        let hair = HairBsdf::new(Vec3::X, wo, 0.3, Vec3::new(0.6, 0.3, 0.1));
        let a = albedo(&hair, &mut rng, 200_000);
        assert!(a.x < 1.0 && a.x > a.y && a.y > a.z, "{a}");
        // Importance-sampled estimate of the same integral.
        let n = 200_000;
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            if let Some(s) = hair.sample(rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                sum += s.f * s.wi.dot(hair.normal()).abs() / s.pdf;
            }
        }
        let b = sum / n as f32;
        assert!((a - b).abs().max_element() < 0.03, "uniform {a} vs sampled {b}");
    }
}

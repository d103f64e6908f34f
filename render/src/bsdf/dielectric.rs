//! A rough dielectric interface: GGX reflection and refraction (Walter et al. 2007, "Microfacet
//! Models for Refraction through Rough Surfaces"), with the exact unpolarised Fresnel term. What the
//! `1 − opacity` part of a UsdPreviewSurface with `opacityThreshold = 0` and `ior ≠ 1` is: clear
//! glass that keeps its specular response and refracts by `ior`, as the UsdPreviewSurface
//! specification describes.
//!
//! ```text
//! reflection:    f = D(h) G₂ F(o·h) / (4 |n·o| |n·i|)                  h = normalize(o + i)
//! transmission:  f = D(h) G₂ (1 − F(o·h)) |i·h| |o·h| / (|n·o| |n·i| (i·h + o·h/η)²) / η²
//!                                                                       h = normalize(o + η i)
//! ```
//! `η` is the ratio of the index behind the surface to the index in front of it (the side of `o`):
//! `ior` where the ray enters the object (it hits the front of the triangle: USD's right-handed winding
//! faces out), `1 / ior` where it leaves. The `1/η²` factor is radiance's change of solid angle
//! across the interface (pbrt-v4's `TransportMode::Radiance`), so a path that enters and leaves an
//! object gets it back. Sampling draws a GGX visible normal, then reflects with probability `F` and
//! refracts otherwise, so `f·|cos|/pdf` is `G₂/G₁` (times `1/η²` through): a smooth interface
//! (α at [`super::MIN_ALPHA`]) is a near-delta lobe that MIS still handles, with no special case.
//! Both integrators call this code per hit (the wavefront shades such hits one at a time, as it does
//! curve hits), so there is no lane twin to keep equal.
//!
//! OpenPBR's transmission parameters (format 15):
//! - `transmission_color` with `transmission_depth = 0` tints the refracted lobe: each refraction
//!   multiplies by the colour (a solid sphere, entered and left, shows it squared).
//! - With `transmission_depth = d > 0` the colour is instead the transmittance of the interior
//!   after distance `d` (OpenPBR 1.1: extinction `σ = −ln(colour)/d`, no scattering), Beer–Lambert
//!   along the refracted path: a segment of length `t` inside keeps `colour^(t/d)`. The path has
//!   no medium stack: a ray that meets a transmissive surface from behind (leaving, or reflected
//!   inside) has travelled `t` through that surface's interior, so [`Dielectric::interior_transmittance`]
//!   is charged there. That is exact for closed, non-nested objects.
//! - `geometry_thin_walled` makes the surface an infinitesimally thin slab of index `ior`: light
//!   reflects or passes straight through, unbent. Per microfacet the slab's incoherent series of
//!   internal reflections, with `F = F(o·h)` the single-interface Fresnel and `c` the colour
//!   (absorbed once per pass through the slab), sums to
//!
//! ```text
//! T = c (1 − F)² Σ (c F)²ᵏ = c (1 − F)² / (1 − c² F²)
//! R = F + F c² (1 − F)² / (1 − c² F²)           (c = 1: R = 2F/(1 + F), T = (1 − F)/(1 + F), R + T = 1)
//! ```
//!
//!   The transmitted lobe is the reflected lobe mirrored through the tangent plane (a rough thin
//!   wall blurs what is behind it as much as its reflection; a smooth one is a straight delta-like
//!   lobe), with no `1/η²` (the light leaves into the medium it came from). Sampling reflects with
//!   probability `mean(R) / (mean(R) + mean(T))`. The depth is ignored (a thin wall has no interior).
//!
//! Multiple scattering between microfacets (energy compensation, Turquin 2019, "Practical
//! multiple scattering compensation for microfacet models", its dielectric case): single-scattering
//! GGX loses the light that would bounce more than once on the microsurface, up to 20–40 % at
//! roughness 0.9 (a rough glass sphere read 0.8–0.9 in the white furnace). The interface's whole
//! single-scattering BSDF, reflection and transmission alike, is scaled by `1 / E_ss(μo)`:
//!
//! ```text
//! f = f_ss(o, i) / E_ss(μo, r, η),     E_ss(μ, r, η) = ∫ f_ss |cos θi| dωi    (transmission as energy)
//! ```
//!
//! so every direction reflects and transmits exactly what arrives, in the single-scattering
//! lobes' proportions and shapes (Turquin's assumption: the multiply scattered light leaves
//! distributed like the singly scattered). `E_ss` is tabulated once per process
//! ([`albedo::dielectric_albedo`]: 32 cosines × 16 roughnesses × 16 indices in [1, 3], one table
//! for each side of the interface, the inner one with total internal reflection), deterministically
//! (a stratified 24 × 24 grid of visible normals per entry taking both lobes, f64 sums of this
//! module's f32 Fresnel and refraction), and read trilinearly; indices past 3 read the row of 3. A
//! thin wall's `R + T` is 1 per microfacet at colour 1, so its `E_ss` is the GGX reflection lobe's
//! unit-Fresnel albedo ([`albedo::thin_wall_albedo`], on a 48 × 48 grid of visible normals). The scaling is by the view direction
//! only, so the BSDF is not reciprocal (the path tracer's MIS does not need it to be); the sampled
//! weight stays `G₂/G₁`, times the factor. A smooth interface (`roughness = 0`) is not scaled at
//! all: its images keep their bits. Both integrators call this code, so their images stay
//! bit-equal.

use super::{albedo, ggx_d, ggx_g2, ggx_lambda, ggx_pdf, sample_ggx_vndf, BsdfSample, Frame, MIN_ALPHA};
use glam::Vec3;

/// The unpolarised Fresnel reflectance of a dielectric interface for a direction at `cos_i` to the
/// normal on the incident side (`cos_i > 0`), with `eta` the transmitted over the incident index.
/// 1 under total internal reflection.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)
}

/// The transmittance `1 − F` of a dielectric interface of index `ior` at normal incidence,
/// `1 − ((ior − 1)/(ior + 1))²`: what a shadow ray towards a delta light keeps per glass surface it
/// crosses ([`crate::scene::Scene::shadow_transmittance`]).
#[inline]
pub fn normal_transmittance(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    (1.0 - r * r).clamp(0.0, 1.0)
}

/// `o` refracted through a microfacet of normal `h` (same side as `o`) into a medium `eta` times
/// denser; `None` under total internal reflection.
#[inline]
pub(super) fn refract(o: Vec3, h: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = o.dot(h);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-o / eta + h * (cos_i / eta - cos_t))
}

/// A dielectric interface at one shading point.
#[derive(Clone, Copy, Debug)]
pub struct Dielectric {
    frame: Frame,
    /// Geometric normal on the side of `wo`.
    ng: Vec3,
    alpha: f32,
    /// The roughness `α` was made from (`√α` but at [`MIN_ALPHA`]): the compensation table's axis,
    /// 0 for a smooth interface, which is not compensated.
    roughness: f32,
    /// Index behind the surface over the index on the side of `wo` (a thin wall: its `ior`).
    eta: f32,
    /// What each refraction multiplies by: `transmission_color` at depth 0, else white.
    tint: Vec3,
    /// `geometry_thin_walled`: a slab, see the module docs.
    thin: bool,
    /// `(transmission_color, transmission_depth)` of the interior the ray to this point crossed:
    /// set only when it arrived from behind a solid surface with an absorbing interior.
    interior: Option<(Vec3, f32)>,
}

/// OpenPBR's transmission parameters of one material (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transmission {
    /// `transmission_color`.
    pub color: Vec3,
    /// `transmission_depth`.
    pub depth: f32,
    /// `geometry_thin_walled`.
    pub thin_walled: bool,
}

impl Transmission {
    /// Untinted, solid glass: the fallbacks.
    pub const CLEAR: Transmission = Transmission { color: Vec3::ONE, depth: 0.0, thin_walled: false };
}

/// The thin slab's `(R, T)` per channel for single-interface Fresnel `f` and per-pass colour `c`.
#[inline]
fn slab(f: f32, c: Vec3) -> (Vec3, Vec3) {
    let cf = c * f;
    let denom = Vec3::ONE - cf * cf;
    let t1 = (1.0 - f) * (1.0 - f);
    let t = c * t1 / denom;
    let r = Vec3::splat(f) + cf * c * t1 / denom;
    (r, t)
}

/// The probability of sampling the slab's reflection.
#[inline]
fn slab_reflect_probability(r: Vec3, t: Vec3) -> f32 {
    let (r, t) = (r.x + r.y + r.z, t.x + t.y + t.z);
    if r + t > 0.0 {
        r / (r + t)
    } else {
        1.0
    }
}

impl Dielectric {
    /// The interface of index `ior` and UsdPreviewSurface `roughness` (α = roughness²) at a point
    /// with unit shading normal `ns` and geometric normal `ng`, both flipped to the side of the
    /// outgoing direction; `entering`: that side is the outside (the triangle's front).
    pub fn new(ior: f32, roughness: f32, ns: Vec3, ng: Vec3, entering: bool) -> Self {
        Self::with_transmission(ior, roughness, ns, ng, entering, Transmission::CLEAR)
    }

    /// [`Dielectric::new`] with OpenPBR's transmission colour, depth and thin-walled flag.
    pub fn with_transmission(
        ior: f32,
        roughness: f32,
        ns: Vec3,
        ng: Vec3,
        entering: bool,
        t: Transmission,
    ) -> Self {
        let roughness = roughness.clamp(0.0, 1.0);
        let color = t.color.clamp(Vec3::ZERO, Vec3::ONE);
        let solid_absorbs = !t.thin_walled && t.depth > 0.0;
        Dielectric {
            frame: Frame::new(ns),
            ng,
            alpha: (roughness * roughness).max(MIN_ALPHA),
            roughness,
            eta: if entering || t.thin_walled { ior } else { 1.0 / ior },
            tint: if solid_absorbs { Vec3::ONE } else { color },
            thin: t.thin_walled,
            interior: (solid_absorbs && !entering).then_some((color, t.depth)),
        }
    }

    /// What the segment of length `t` that reached this point keeps of its throughput, when it
    /// ran through an absorbing interior (`colour^(t/depth)`, Beer–Lambert); `None` otherwise.
    pub fn interior_transmittance(&self, t: f32) -> Option<Vec3> {
        self.interior.map(|(c, depth)| {
            let x = t / depth;
            Vec3::new(c.x.powf(x), c.y.powf(x), c.z.powf(x))
        })
    }

    /// Index behind the surface over the index on the side of `wo`.
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// BSDF value (no cosine) and pdf for world directions `wo` (towards the viewer) and `wi`.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let reflect = wi.dot(self.ng) > 0.0;
        self.eval_local(self.frame.to_local(wo), self.frame.to_local(wi), reflect)
    }

    /// The multiple-scattering compensation `1 / E_ss(μo)` the single-scattering lobes are scaled
    /// by (see the module docs); exactly 1 for a smooth interface.
    #[inline]
    fn compensation(&self, mu_o: f32) -> f32 {
        if self.roughness <= 0.0 {
            return 1.0;
        }
        let table = albedo::dielectric_table();
        let e = if self.thin {
            // With `c = 1` the slab's R + T is 1 at every microfacet: what is lost is the GGX
            // reflection lobe's own shortfall, `1 − E1` with `E1` its unit-Fresnel albedo.
            albedo::thin_wall_albedo(table, mu_o, self.roughness)
        } else {
            albedo::dielectric_albedo(table, mu_o, self.roughness, self.eta)
        };
        1.0 / e.max(1e-3)
    }

    /// `reflect`: `wi` is on the geometric side of `wo`; it must be on the same side of the shading
    /// frame too, or the pair is rejected (no light leaks through a shading normal).
    fn eval_local(&self, wo: Vec3, wi: Vec3, reflect: bool) -> (Vec3, f32) {
        let alpha = self.alpha;
        if wo.z <= 0.0 || wi.z == 0.0 || (wi.z > 0.0) != reflect {
            return (Vec3::ZERO, 0.0);
        }
        if self.thin {
            // The transmitted lobe is the reflected one mirrored through the tangent plane.
            let wm = Vec3::new(wi.x, wi.y, wi.z.abs());
            let h = (wo + wm).normalize();
            let (r, t) = slab(fresnel_dielectric(wo.dot(h), self.eta), self.tint);
            let p_r = slab_reflect_probability(r, t);
            let lobe = ggx_d(h, alpha) * ggx_g2(wo, wm, alpha) / (4.0 * wo.z * wm.z);
            let (weight, p) = if reflect { (r, p_r) } else { (t, 1.0 - p_r) };
            return (weight * (lobe * self.compensation(wo.z)), ggx_pdf(wo, h, alpha) * p);
        }
        if reflect {
            let h = (wo + wi).normalize();
            let f = fresnel_dielectric(wo.dot(h), self.eta);
            let value = ggx_d(h, alpha) * ggx_g2(wo, wi, alpha) * f / (4.0 * wo.z * wi.z);
            return (Vec3::splat(value * self.compensation(wo.z)), ggx_pdf(wo, h, alpha) * f);
        }
        let eta = self.eta;
        let mut h = (wo + wi * eta).normalize();
        if h.z < 0.0 {
            h = -h;
        }
        let (o_h, i_h) = (wo.dot(h), wi.dot(h));
        // The microfacet must face `wo` and have `wi` behind it.
        if !(o_h > 0.0 && i_h < 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let t = 1.0 - fresnel_dielectric(o_h, eta);
        let denom = i_h + o_h / eta;
        let denom2 = denom * denom;
        let d = ggx_d(h, alpha);
        let value = t * d * ggx_g2(wo, wi, alpha) * (i_h * o_h / (wi.z * wo.z * denom2)).abs() / (eta * eta);
        let g1 = 1.0 / (1.0 + ggx_lambda(wo, alpha));
        let pdf = g1 * d * o_h / wo.z * (i_h.abs() / denom2) * t;
        (Vec3::splat(value * self.compensation(wo.z)) * self.tint, pdf)
    }

    /// Samples an incident direction for world `wo`: `u_lobe` chooses reflection (below the Fresnel
    /// reflectance) or refraction, `u` the visible normal. `None` when the sample is rejected.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<BsdfSample> {
        let wo_l = self.frame.to_local(wo);
        if wo_l.z <= 0.0 {
            return None;
        }
        let h = sample_ggx_vndf(wo_l, self.alpha, u);
        let f = fresnel_dielectric(wo_l.dot(h), self.eta);
        let (wi_l, reflect) = if self.thin {
            let (r, t) = slab(f, self.tint);
            let mirrored = 2.0 * wo_l.dot(h) * h - wo_l;
            if u_lobe < slab_reflect_probability(r, t) {
                (mirrored, true)
            } else {
                (Vec3::new(mirrored.x, mirrored.y, -mirrored.z), false)
            }
        } else if u_lobe < f {
            (2.0 * wo_l.dot(h) * h - wo_l, true)
        } else {
            (refract(wo_l, h, self.eta)?, false)
        };
        let wi = self.frame.to_world(wi_l).normalize();
        if (wi.dot(self.ng) > 0.0) != reflect {
            return None;
        }
        let (f, pdf) = self.eval_local(wo_l, wi_l, reflect);
        (pdf > 0.0 && f.is_finite()).then_some(BsdfSample { wi, f, pdf, lobe_alpha: self.alpha })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::Rng;

    fn dir(theta_deg: f32) -> Vec3 {
        let t = theta_deg.to_radians();
        Vec3::new(t.sin(), 0.0, t.cos())
    }

    /// (reflected, transmitted) parts of ∫ f |cos| dω estimated by the BSDF's own sampling, the
    /// transmitted part without the 1/η² radiance factor (so each is an energy fraction).
    fn albedo(b: &Dielectric, wo: Vec3, n: usize) -> (f64, f64) {
        let (r, t, _) = albedo_and_acceptance(b, wo, n);
        (r, t)
    }

    /// [`albedo`] and the fraction of samples `sample` accepts (what its pdf integrates to).
    fn albedo_and_acceptance(b: &Dielectric, wo: Vec3, n: usize) -> (f64, f64, f64) {
        let mut rng = Rng(11);
        let (mut r, mut t, mut accepted) = (0.0f64, 0.0f64, 0usize);
        for _ in 0..n {
            if let Some(s) = b.sample(wo, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                accepted += 1;
                let w = (s.f.x * s.wi.z.abs() / s.pdf) as f64;
                if s.wi.z > 0.0 {
                    r += w;
                } else {
                    t += w * (b.eta * b.eta) as f64;
                }
            }
        }
        (r / n as f64, t / n as f64, accepted as f64 / n as f64)
    }

    #[test]
    fn fresnel_matches_known_values() {
        // Normal incidence: ((η − 1)/(η + 1))², 0.04 for glass.
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        // Brewster's angle: the parallel part vanishes, R = r_s²/2.
        let brewster = 1.5f32.atan();
        let r = fresnel_dielectric(brewster.cos(), 1.5);
        let (ci, ct) = (brewster.cos(), (1.0 - brewster.sin().powi(2) / 2.25).sqrt());
        let rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
        assert!((r - 0.5 * rs * rs).abs() < 1e-6, "{r}");
        // Total internal reflection past the critical angle (41.8° from glass).
        assert_eq!(fresnel_dielectric(45f32.to_radians().cos(), 1.0 / 1.5), 1.0);
        assert!(fresnel_dielectric(40f32.to_radians().cos(), 1.0 / 1.5) < 1.0);
        assert!((normal_transmittance(1.5) - 0.96).abs() < 1e-6);
        assert_eq!(normal_transmittance(1.0), 1.0);
    }

    /// A smooth interface reflects the Fresnel fraction and transmits the rest, along Snell's
    /// direction, from either side; all the energy stays.
    #[test]
    fn smooth_interface_splits_energy_by_fresnel() {
        for entering in [true, false] {
            let b = Dielectric::new(1.5, 0.0, Vec3::Z, Vec3::Z, entering);
            let eta = if entering { 1.5 } else { 1.0 / 1.5 };
            for theta in [0.0f32, 30.0, 40.0, 60.0, 85.0] {
                let wo = dir(theta);
                let (r, t) = albedo(&b, wo, 100_000);
                let expect = fresnel_dielectric(wo.z, eta) as f64;
                eprintln!("smooth entering={entering} θ={theta}: R {r:.4} T {t:.4} (Fresnel {expect:.4})");
                assert!((r - expect).abs() < 0.01, "entering={entering} θ={theta}: R {r} vs {expect}");
                assert!((r + t - 1.0).abs() < 0.01, "entering={entering} θ={theta}: R + T = {}", r + t);
            }
            // Snell: η sin θt = sin θi, but for GGX's long tail (even at the smallest α about
            // α²/(α² + tan²θ) of the normals tilt more than θ).
            let wo = dir(30.0);
            let mut rng = Rng(5);
            let (mut refracted, mut on_snell) = (0, 0);
            for _ in 0..1000 {
                if let Some(s) = b.sample(wo, 0.999, [rng.next_f32(), rng.next_f32()]) {
                    assert!(s.wi.z < 0.0, "u_lobe above F refracts");
                    refracted += 1;
                    let sin_t = (1.0 - s.wi.z * s.wi.z).sqrt();
                    on_snell += ((eta * sin_t - 0.5).abs() < 0.01 && s.wi.x < 0.0) as u32;
                }
            }
            assert!(
                refracted > 990 && on_snell as f32 > 0.98 * refracted as f32,
                "{on_snell} of {refracted}"
            );
        }
    }

    /// Rough interfaces, compensated for multiple scattering, keep all the energy from either
    /// side, at every roughness and angle (uncompensated they kept 0.97 at roughness 0.2 down to
    /// 0.75 at 0.8); eval's pdf integrates to what sample accepts and its value to the albedo.
    #[test]
    fn rough_interface_conserves_energy_and_eval_agrees_with_sample() {
        for roughness in [0.2, 0.5, 0.8, 1.0] {
            for (theta, entering) in [(0.0, true), (45.0, true), (75.0, true), (20.0, false), (60.0, false)] {
                let b = Dielectric::new(1.5, roughness, Vec3::Z, Vec3::Z, entering);
                let wo = dir(theta);
                let (r, t, accepted) = albedo_and_acceptance(&b, wo, 200_000);
                eprintln!(
                    "rough {roughness} θ={theta} entering={entering}: R {r:.4} T {t:.4}, \
                     {accepted:.4} of samples accepted"
                );
                assert!((r + t - 1.0).abs() < 0.01, "r={roughness} θ={theta} entering={entering}: {}", r + t);
                if !entering {
                    continue;
                }
                if roughness < 0.5 {
                    // Uniform sampling of a sharp lobe is too noisy to compare.
                    continue;
                }
                // ∫ pdf dω over the sphere is the fraction of samples `sample` accepts (it rejects
                // reflections below the surface), by uniform sphere sampling, independent of it.
                let mut rng = Rng(3);
                let n = 400_000;
                let mut mass = 0.0f64;
                let mut energy = 0.0f64;
                for _ in 0..n {
                    let z = 2.0 * rng.next_f32() - 1.0;
                    let s = (1.0 - z * z).max(0.0).sqrt();
                    let phi = std::f32::consts::TAU * rng.next_f32();
                    let wi = Vec3::new(s * phi.cos(), s * phi.sin(), z);
                    let (f, pdf) = b.eval(wo, wi);
                    let scale = if z < 0.0 { (b.eta * b.eta) as f64 } else { 1.0 };
                    mass += pdf as f64 * 4.0 * std::f64::consts::PI;
                    energy += f.x as f64 * z.abs() as f64 * scale * 4.0 * std::f64::consts::PI;
                }
                let (mass, energy) = (mass / n as f64, energy / n as f64);
                assert!(
                    (mass - accepted).abs() < 0.02,
                    "r={roughness} θ={theta}: pdf mass {mass} vs {accepted}"
                );
                assert!((energy - (r + t)).abs() < 0.03, "r={roughness} θ={theta}: {energy} vs {}", r + t);
            }
        }
    }

    /// The radiance BTDF is `η_o² · S` with `S` symmetric in the two directions and their indices
    /// (Veach's generalised reciprocity), so entering (η_o = 1) and leaving (η_o = 1.5) along the
    /// same pair of directions differ by exactly 1.5² in the single-scattering lobes. The
    /// multiple-scattering compensation scales each side by its own `1 / E_ss(μo)`, so the
    /// compensated pair differs by 1.5² times the ratio of the two factors, and nothing else.
    #[test]
    fn transmission_obeys_generalised_reciprocity() {
        let mut enter = Dielectric::new(1.5, 0.4, Vec3::Z, Vec3::Z, true);
        let mut leave = Dielectric::new(1.5, 0.4, Vec3::Z, Vec3::Z, false);
        let wo = dir(20.0);
        let wi = Vec3::new(-0.3, 0.1, -0.9).normalize();
        // Seen from inside, the frame is flipped to the side of the new `wo`.
        let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
        let (c1, c2) = (enter.compensation(wo.z), leave.compensation(flip(wi).z));
        assert!(c1 > 1.0 && c2 > 1.0 && c1 != c2, "{c1} {c2}");
        let (f1, _) = enter.eval(wo, wi);
        let (f2, _) = leave.eval(flip(wi), flip(wo));
        let ratio = f2.x / f1.x;
        assert!((ratio - 2.25 * c2 / c1).abs() < 1e-3, "compensated ratio {ratio}");
        (enter.roughness, leave.roughness) = (0.0, 0.0); // the single-scattering lobes alone
        let (f1, _) = enter.eval(wo, wi);
        let (f2, _) = leave.eval(flip(wi), flip(wo));
        assert!(f1.x > 0.0 && f2.x > 0.0);
        let ratio = f2.x / f1.x;
        assert!((ratio - 2.25).abs() < 1e-3, "ratio {ratio}");
    }

    /// The compensated thin wall keeps all the energy too (reflected plus transmitted), and a
    /// table entry between grid points matches a direct estimate of `E_ss` by the sampler.
    #[test]
    fn thin_wall_is_compensated_and_the_table_matches_the_uncompensated_lobes() {
        let thin = Transmission { thin_walled: true, ..Transmission::CLEAR };
        for roughness in [0.3, 0.7, 0.95] {
            let b = Dielectric::with_transmission(1.5, roughness, Vec3::Z, Vec3::Z, true, thin);
            for theta in [0.0, 50.0, 80.0] {
                let (r, t, _) = albedo_and_acceptance(&b, dir(theta), 200_000);
                // The thin wall's transmission has no 1/η²; undo the helper's scaling.
                let t = t / (b.eta * b.eta) as f64;
                eprintln!("thin rough {roughness} θ={theta}: R {r:.4} T {t:.4}");
                assert!((r + t - 1.0).abs() < 0.01, "thin r={roughness} θ={theta}: {}", r + t);
            }
        }
        for (roughness, ior, theta, entering) in
            [(0.45, 1.45, 33.0, true), (0.83, 1.7, 70.0, true), (0.6, 1.33, 25.0, false)]
        {
            let mut b = Dielectric::new(ior, roughness, Vec3::Z, Vec3::Z, entering);
            let wo = dir(theta);
            let table = albedo::dielectric_albedo(albedo::dielectric_table(), wo.z, roughness, b.eta);
            b.roughness = 0.0; // the single-scattering lobes alone
            let (r, t) = albedo(&b, wo, 400_000);
            eprintln!(
                "E_ss r={roughness} ior={ior} θ={theta} entering={entering}: table {table:.4}, sampled {:.4}",
                r + t
            );
            assert!((table as f64 - (r + t)).abs() < 0.006, "table {table} vs {}", r + t);
            assert!(table < 0.995, "rough interfaces lose energy to single scattering: {table}");
        }
    }
}

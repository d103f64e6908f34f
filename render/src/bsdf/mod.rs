//! The surface BSDF: OpenPBR Surface's reflection lobes (ASWF OpenPBR v1.1) over a
//! UsdPreviewSurface-style base: Lambert diffuse + GGX specular, under an OpenPBR coat layer.
//!
//! ```text
//! f = base · [(1 − w) + w · T(μo) T(μi) (1 − E_c(μo))] + w · D_c·G₂_c·F_c(v·h) / (4 |n·l| |n·v|)
//! base = diffuse/π · s(n·v, n·l) + D·G₂·F(v·h) / (4 |n·l| |n·v|) + f_ms
//! ```
//! `diffuse = diffuseColor·(1 − metallic)` (metallic workflow) or `diffuseColor` (specular workflow);
//! `F` is Schlick with F0 = mix(((ior−1)/(ior+1))², diffuseColor, metallic) or F0 = specularColor.
//! `D` is GGX with α = roughness² (α ≥ 1e-3), `G₂` the height-correlated
//! Smith term. `s = (1 − E(n·v))(1 − E(n·l)) / (1 − E_avg)` scales the diffuse lobe by what the
//! specular lobe does not reflect ([`albedo`]: its tabulated directional albedo `E`), so a white
//! base reflects exactly 1 at every angle; it replaced `(1 − F(n·v))`, which took up to 45 % off a
//! rough matte floor towards the horizon. `f_ms` is the specular lobe's multiple scattering.
//!
//! The coat (weight `w` = `clearcoat`/`coat_weight`, α_c = `clearcoatRoughness`², index
//! `coat_ior`, F0_c = ((η−1)/(η+1))², Schlick with F90 = 1) is layered by albedo scaling, as the
//! OpenPBR specification prescribes: the base is seen through the coat with weight
//! `1 − E_c(μo)`, `E_c` the coat lobe's directional albedo from the same Kulla–Conty tables
//! ([`coat_view`]), so a white base under any coat reflects exactly `w·E_c + (1 − w·E_c) = 1`. The
//! old `1 − cc·F_c(n·v)` factor (Schlick at the normal, not the lobe's albedo) read 0.956 at 80°.
//! `T(μ) = coat_color^(1/μt)`, `μt` the cosine refracted into the coat, is its absorption along each
//! pass (`coat_color²` at normal incidence). Decisions: the scaling is by the view direction only
//! (the spec's; not reciprocal, which MIS does not need); the base's roughening by a rough coat,
//! its Fresnel against the coat's index instead of air and `coat_darkening` (internal reflections)
//! are not modelled. UsdPreviewSurface's clearcoat is this coat with index 1.5 (F0 0.04) and
//! colour 1: clearcoat scenes changed when it became a layer.
//!
//! Metals take OpenPBR's F82-tint Fresnel (Kutz et al. 2021): `F = Schlick(μ) − b·μ(1 − μ)⁶`
//! with `b` ([`f82_b`]) set so that `F(1/7) = specular_color · Schlick(1/7)`; `specular_weight`
//! scales F0 of the dielectric and the metal (a simplification: the spec modulates the dielectric's
//! index and scales the metal's whole Fresnel, grazing included), and `specular_color` tints the
//! dielectric's F0 (the mapping ingest used before format 12, through the specular workflow).
//!
//! The fuzz (`fuzz_weight` `w_f`, `fuzz_color`, `fuzz_roughness`) is layered over everything by
//! albedo scaling: `f = w_f · fuzz_color · f_sheen + (1 − w_f·E_f(μo)) · f_coated`. OpenPBR
//! recommends Zeltner et al. 2022's LTC sheen; this is Estevez & Kulla's "Charlie" sheen
//! ([`sheen`], α = fuzz_roughness², at least 0.01) with Neubelt & Pettineo's visibility, its
//! untinted albedo `E_f` tabulated once ([`albedo::sheen_albedo`]), sampled cosine-weighted. As in
//! the spec the fuzz is grey in transmission: only its reflection is tinted.
//!
//! Lobes are sampled in proportion to their estimated albedos at `v` (diffuse: cosine-weighted;
//! specular and clearcoat: GGX visible normals, Dupuy & Benyoub 2023); [`Bsdf::eval`] returns the
//! one-sample-MIS pdf of all lobes combined, which is what the integrator's MIS weights need.
//!
//! Directions live in world space at the interface; the BSDF works in the shading frame. A direction is
//! accepted only if it is above both the shading and the geometric hemispheres of the side facing `v`, so
//! a shading normal can never let light leak through the surface.
//!
//! One copy of the mathematics for both integrators: [`Bsdf::eval`] and [`Bsdf::sample`] see the
//! BSDF from `wo` ([`SeenBsdf`]) and run its branch-free methods (selects where the first version
//! returned early), which the lane kernels ([`lanes`]) run once per lane of the same struct
//! transposed. The per-lane bodies are split where a lane loop must be: around the sample's sine and
//! cosine ([`crate::trig::sin_cos_lanes`]) and around the albedo tables' lookups
//! ([`SeenBsdf::light_albedo`]), whose scalar reads would keep a loop from vectorising. A `COAT`
//! parameter leaves the coat layer's terms out where the weight is zero
//! ([`SeenBsdf::has_coat_terms`]); both variants give the same bits there. The coat's view half
//! (a lookup and three `powf`s) is made only for BSDFs (lane groups) with a coat; a zero weight gives
//! zeros either way. The lobes' building
//! blocks (`ggx_lambda`, `schlick`, …) are `#[inline(always)]`: simplified on their own first, as
//! `#[inline]` functions, their selects became branches in the lane loops and kept them scalar.

pub mod albedo;
pub mod dielectric;
pub mod lanes;
#[cfg(test)]
mod reference_tests;

use glam::{BVec3, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// Smallest GGX α (keeps the lobe a finite density so every BSDF is MIS-able).
pub const MIN_ALPHA: f32 = 1e-3;

/// An orthonormal basis around a unit normal.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Tangent.
    pub t: Vec3,
    /// Bitangent.
    pub b: Vec3,
    /// Normal.
    pub n: Vec3,
}

impl Frame {
    /// A basis around `n` (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    #[inline(always)]
    pub fn new(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            t: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }
    /// World → local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// World-space incident direction (towards the light).
    pub wi: Vec3,
    /// BSDF value (without the cosine).
    pub f: Vec3,
    /// Solid-angle pdf of all lobes combined.
    pub pdf: f32,
    /// GGX α of the lobe that was sampled (1 for the diffuse lobe): how much the bounce widens a
    /// ray cone.
    pub lobe_alpha: f32,
}

/// Material parameters resolved for one shading point.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    // Crate-visible so the wavefront's 8-lane kernels (`bsdf::lanes`) can transpose them.
    pub(crate) frame: Frame,
    /// Geometric normal on the side of `wo`.
    pub(crate) ng: Vec3,
    pub(crate) diffuse: Vec3,
    pub(crate) f0: Vec3,
    /// The F82-tint coefficient of the metal part ([`f82_b`] times `metallic`; 0 without a tint).
    pub(crate) f82_b: Vec3,
    pub(crate) alpha: f32,
    pub(crate) clearcoat: f32,
    pub(crate) clearcoat_alpha: f32,
    /// Coat colour (transmittance of one pass at normal incidence).
    pub(crate) coat_color: Vec3,
    /// The coat's Schlick F0, `((η − 1)/(η + 1))²`.
    pub(crate) coat_f0: f32,
    /// `1/η²` of the coat's index.
    pub(crate) coat_inv_eta2: f32,
    /// Fuzz weight.
    pub(crate) fuzz: f32,
    /// Fuzz colour.
    pub(crate) fuzz_color: Vec3,
    /// Fuzz roughness (the table's axis; α = [`sheen_alpha`] of it).
    pub(crate) fuzz_roughness: f32,
}

/// Rec. 709 luminance.
#[inline(always)]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Schlick's Fresnel with the grazing reflectance F90 = saturate(50 · 0.33 · ΣF0) (Filament's
/// "specular occlusion" trick): any real interface (F0 ≥ 0.02) gets F90 = 1, while F0 = 0 (ior = 1, or
/// a black specularColor) means no interface and no specular at all, not a grazing-angle sheen.
#[inline(always)]
fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m5 = (m * m) * (m * m) * m;
    let f90 = (50.0 * 0.33 * (f0.x + f0.y + f0.z)).clamp(0.0, 1.0);
    f0 + (Vec3::splat(f90) - f0) * m5
}

/// [`schlick`] with the F82-tint correction `− b·μ(1 − μ)⁶` (Kutz et al. 2021, as OpenPBR's metal
/// uses it; `b` from [`f82_b`]); `b = 0` is exactly Schlick.
#[inline(always)]
fn fresnel(f0: Vec3, b82: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let g = (1.0 - m) * ((m * m) * (m * m) * (m * m));
    schlick(f0, cos) - b82 * g
}

/// `x` clamped to [0, 1], NaN to 0.
#[inline(always)]
fn unit(x: f32) -> f32 {
    if x >= 0.0 {
        x.min(1.0)
    } else {
        0.0
    }
}

/// Smallest sheen α: below it `sin^(1/α)` is a spike no table resolves.
const SHEEN_MIN_ALPHA: f32 = 0.01;

/// The sheen α of fuzz roughness `r` (clamped to [0, 1]): `r²`, at least [`SHEEN_MIN_ALPHA`].
#[inline(always)]
pub(crate) fn sheen_alpha(r: f32) -> f32 {
    let r = r.clamp(0.0, 1.0);
    (r * r).max(SHEEN_MIN_ALPHA)
}

/// The fuzz lobe, untinted, for local directions above the surface and their half vector `h`:
/// Estevez & Kulla's "Charlie" sheen distribution `D = (2 + 1/α) sin^(1/α)θh / 2π` with Neubelt &
/// Pettineo's visibility `1 / (4 (μi + μo − μi μo))`.
#[inline(always)]
pub(crate) fn sheen(wo: Vec3, wi: Vec3, h: Vec3, alpha: f32) -> f32 {
    let inv = 1.0 / alpha;
    let sin2 = (1.0 - h.z * h.z).max(0.0);
    let d = (2.0 + inv) * sin2.powf(0.5 * inv) * (0.5 * FRAC_1_PI);
    d / (4.0 * (wi.z + wo.z - wi.z * wo.z))
}

/// The cosine of the F82 model's "grazing edge", 1/7 (about 82°).
const F82_MU: f32 = 1.0 / 7.0;

/// The F82-tint coefficient `b = F_Schlick(μ̄) (1 − tint) / (μ̄ (1 − μ̄)⁶)` of a metal with F0 `f0`
/// and edge tint `tint` (OpenPBR's `specular_color`), so that the corrected Fresnel at μ̄ = 1/7 is
/// `tint · F_Schlick(μ̄)`. A tint of 1 gives exactly 0.
#[inline(always)]
pub(crate) fn f82_b(f0: Vec3, tint: Vec3) -> Vec3 {
    let m = 1.0 - F82_MU;
    let m6 = (m * m) * (m * m) * (m * m);
    let schlick_bar = f0 + (Vec3::ONE - f0) * (m6 / m);
    schlick_bar * (Vec3::ONE - tint) * (1.0 / (F82_MU * m6))
}

#[inline(always)]
fn schlick_scalar(f0: f32, cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    f0 + (1.0 - f0) * (m * m) * (m * m) * m
}

/// The coat's transmittance `c^(1/μt)` for colour `c` along a direction at cosine `mu` outside a
/// coat of index `η` (`inv_eta2` = 1/η²): one pass through a coat of unit optical depth at normal
/// incidence, the path length `1/μt` of the refracted direction (OpenPBR's coat absorption; a round
/// trip at normal incidence is `c²`). Colour 1 gives exactly 1 (`powf(1, x)`), and an index of 1
/// at grazing gives `c^∞`: 0, or 1 for `c = 1`.
#[inline(always)]
fn coat_transmittance(c: Vec3, inv_eta2: f32, mu: f32) -> Vec3 {
    let mu_t = (1.0 - (1.0 - mu * mu) * inv_eta2).max(0.0).sqrt();
    let k = 1.0 / mu_t;
    Vec3::new(c.x.powf(k), c.y.powf(k), c.z.powf(k))
}

/// The view half of the coat layer at local view cosine `mu_o` for a BSDF with coat weight `w`:
/// the base's weight `w · T(μo) · (1 − E_c(μo))` beside its `1 − w` uncoated part (the light
/// half, `T(μi)`, is applied per evaluation), and the coat's own albedo `w · E_c(μo)`, the
/// lobe-selection weight. `E_c = F0_c·A + B` is the coat's GGX albedo with Schlick's Fresnel from
/// the same tables as the base's specular lobe ([`albedo::lobe_albedo_ab`]).
#[inline(always)]
pub(crate) fn coat_view(t: &albedo::Tables, coat: CoatParams, mu_o: f32) -> (Vec3, f32) {
    let CoatParams { weight, alpha, f0, color, inv_eta2 } = coat;
    let [a, b, _] = albedo::lobe_albedo_ab(t, mu_o, alpha);
    let e = f0 * a + b;
    let t_o = coat_transmittance(color, inv_eta2, mu_o);
    (t_o * (weight * (1.0 - e)), weight * e)
}

/// The fuzz layer's view half at `mu_o`: its albedo times its weight, `w_f · E_f(μo)` (the sheen
/// table, [`albedo::sheen_albedo`]); what is under it is scaled by one minus that, and a zero weight
/// gives exactly 0.
#[inline(always)]
pub(crate) fn fuzz_view(t: &albedo::SheenTable, weight: f32, roughness: f32, mu_o: f32) -> f32 {
    weight * albedo::sheen_albedo(t, mu_o, roughness)
}

/// The coat's parameters, as [`Bsdf`] and [`SeenBsdf`] both hold them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CoatParams {
    pub(crate) weight: f32,
    pub(crate) alpha: f32,
    pub(crate) f0: f32,
    pub(crate) color: Vec3,
    pub(crate) inv_eta2: f32,
}

/// GGX normal distribution for a local half vector.
#[inline(always)]
pub(crate) fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let c2 = h.z * h.z;
    let d = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Smith Λ for GGX.
#[inline(always)]
pub(crate) fn ggx_lambda(w: Vec3, alpha: f32) -> f32 {
    let c2 = w.z * w.z;
    let tan2 = ((1.0 - c2) / c2).max(0.0);
    let lambda = 0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0);
    if c2 <= 0.0 {
        f32::INFINITY
    } else {
        lambda
    }
}

/// Height-correlated Smith masking-shadowing.
#[inline(always)]
pub(crate) fn ggx_g2(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))
}

/// Solid-angle pdf of `wi` when sampling visible normals from `wo`: G₁(wo)·D(h) / (4 wo.z).
#[inline(always)]
pub(crate) fn ggx_pdf(wo: Vec3, h: Vec3, alpha: f32) -> f32 {
    let g1 = 1.0 / (1.0 + ggx_lambda(wo, alpha));
    g1 * ggx_d(h, alpha) / (4.0 * wo.z)
}

/// Samples a GGX visible normal (spherical caps, Dupuy & Benyoub 2023).
#[inline]
pub(crate) fn sample_ggx_vndf(wo: Vec3, alpha: f32, u: [f32; 2]) -> Vec3 {
    let (sin_phi, cos_phi) = crate::trig::sin_cos(TAU * u[0]);
    ggx_vndf(wo, alpha, u[1], sin_phi, cos_phi)
}

/// [`sample_ggx_vndf`] given the sine and cosine of its azimuth `2π·u[0]`.
#[inline(always)]
fn ggx_vndf(wo: Vec3, alpha: f32, u1: f32, sin_phi: f32, cos_phi: f32) -> Vec3 {
    let wi_std = Vec3::new(wo.x * alpha, wo.y * alpha, wo.z).normalize();
    let z = (1.0 - u1) * (1.0 + wi_std.z) - wi_std.z;
    let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
    let c = Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, z);
    let h_std = c + wi_std;
    Vec3::new(h_std.x * alpha, h_std.y * alpha, h_std.z).normalize()
}

/// Cosine-weighted hemisphere sample via the concentric disk mapping.
#[inline]
pub fn sample_cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let [dx, dy] = sample_concentric_disk(u);
    Vec3::new(dx, dy, (1.0 - dx * dx - dy * dy).max(0.0).sqrt())
}

/// Shirley–Chiu concentric map of the unit square to the unit disk.
#[inline]
pub fn sample_concentric_disk(u: [f32; 2]) -> [f32; 2] {
    let (sin, cos) = crate::trig::sin_cos(concentric_angle(u));
    concentric_disk(u, sin, cos)
}

/// The angle of [`sample_concentric_disk`]'s point (NaN at the centre, which
/// [`concentric_disk`] maps to the origin whatever the angle).
#[inline(always)]
fn concentric_angle(u: [f32; 2]) -> f32 {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if a.abs() > b.abs() {
        FRAC_PI_4 * (b / a)
    } else {
        FRAC_PI_2 - FRAC_PI_4 * (a / b)
    }
}

/// [`sample_concentric_disk`] given the sine and cosine of [`concentric_angle`].
#[inline(always)]
fn concentric_disk(u: [f32; 2], sin: f32, cos: f32) -> [f32; 2] {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    let r = if a.abs() > b.abs() { a } else { b };
    let centre = (a == 0.0) & (b == 0.0);
    [if centre { 0.0 } else { r * cos }, if centre { 0.0 } else { r * sin }]
}

/// `if keep { x } else { 0.0 }` as a mask: written as an `if`, LLVM sank the computation of `x`
/// into a branch and the lane loops stayed scalar.
#[inline(always)]
fn or_zero(keep: bool, x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0u32.wrapping_sub(keep as u32))
}

/// Component-wise `if c { a } else { b }`: an `if` on whole vectors can become a branch, which
/// keeps a lane loop scalar.
#[inline(always)]
pub(crate) fn select(c: bool, a: Vec3, b: Vec3) -> Vec3 {
    Vec3::select(BVec3::splat(c), a, b)
}

/// The view halves of the energy-conserving lobes ([`albedo::view_terms`]) of a BSDF with diffuse
/// colour `d`, F0 `f0` and α `alpha` at local view cosine `mu_o`: diffuse, multiple scattering,
/// multiple-scattering Fresnel.
#[inline(always)]
pub(crate) fn view_halves(
    t: &albedo::Tables,
    d: Vec3,
    f0: Vec3,
    b82: Vec3,
    alpha: f32,
    mu_o: f32,
) -> [Vec3; 3] {
    let at_o = albedo::lobe_albedo(t, mu_o, alpha);
    let f90 = albedo::f90(f0.x, f0.y, f0.z);
    let [dx, mx, fx] = albedo::view_terms(d.x, f0.x, f90, b82.x, at_o);
    let [dy, my, fy] = albedo::view_terms(d.y, f0.y, f90, b82.y, at_o);
    let [dz, mz, fz] = albedo::view_terms(d.z, f0.z, f90, b82.z, at_o);
    [Vec3::new(dx, dy, dz), Vec3::new(mx, my, mz), Vec3::new(fx, fy, fz)]
}

/// A [`Bsdf`] seen from one outgoing direction `wo` (declared with its lanes, [`lanes::BsdfLanes`]):
/// the frame as its three axes, the parameters, `wo` and the view halves of the energy-conserving
/// lobes (they depend on `wo` only). Its methods are the BSDF's mathematics, branch-free.
pub use lanes::SeenBsdf;
/// The steps of a sample (declared with their lanes).
pub use lanes::{SampleStart, SampledDirection};

impl SeenBsdf {
    /// World → local (the shading frame).
    #[inline(always)]
    fn local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Whether the clearcoat lobe's terms are needed: not where the weight is ±0.
    ///
    /// `!= 0` rather than `eval_local`'s `> 0` so that a BSDF without the lobe has a zero weight,
    /// not a NaN or a negative one: then its probability `coat_f / total` is ±0 whenever the other
    /// two are numbers (NaN only when `total` is, and then the diffuse one is NaN too), so the
    /// sampler's `p_d + p_s + p_c <= 0` equals `p_d + p_s <= 0` and `COAT = false` gives the same
    /// bits. NaN weights take the variant with the lobe, which masks it off.
    #[inline(always)]
    pub fn has_coat_terms(&self) -> bool {
        (self.clearcoat != 0.0) | (self.fuzz != 0.0)
    }

    /// The specular lobe's [`albedo::lobe_albedo_ab`] in `tables` ([`albedo::tables`]) at local
    /// light cosine `mu_i`: a table lookup, which the lane kernels make in a loop of their own.
    #[inline(always)]
    pub(crate) fn light_albedo(&self, tables: &albedo::Tables, mu_i: f32) -> [f32; 3] {
        albedo::lobe_albedo_ab(tables, mu_i, self.alpha)
    }

    /// Lobe selection probabilities (diffuse, specular, clearcoat) at local view cosine `wo_z`:
    /// the base's lobes by their Fresnel-weighted colours times the base's coat-layer weight at
    /// `wo` (without the light half of the coat's absorption), the coat by its albedo.
    #[inline(always)]
    fn lobe_probabilities(&self, wo_z: f32) -> [f32; 4] {
        // Under the fuzz, `1 − w_f·E_f(μo)` of everything ([`fuzz_view`]); exactly 1 without it.
        let under = 1.0 - self.fuzz_p;
        let coat_f = self.coat_p * under;
        let base = ((1.0 - self.clearcoat) + luminance(self.coat_base)) * under;
        let spec_f = schlick(self.f0, wo_z);
        let w_d = base * luminance(self.diffuse * (Vec3::ONE - spec_f));
        let w_s = base * luminance(spec_f);
        let fuzz_f = self.fuzz_p * luminance(self.fuzz_color);
        let total = w_d + w_s + coat_f + fuzz_f;
        let probs = [w_d / total, w_s / total, coat_f / total, fuzz_f / total];
        if total <= 0.0 {
            [0.0; 4]
        } else {
            probs
        }
    }

    /// Value and pdf for local directions above both hemispheres, with the lobe probabilities
    /// `probs` known and `at_i` = [`SeenBsdf::light_albedo`] at `wi.z` (the callers mask the
    /// directions below).
    #[inline(always)]
    fn eval_local<const COAT: bool>(
        &self,
        probs: [f32; 4],
        wo: Vec3,
        wi: Vec3,
        at_i: [f32; 3],
    ) -> (Vec3, f32) {
        let h = (wo + wi).normalize();
        let wo_h = wo.dot(h).max(0.0);
        let denom = 4.0 * wo.z * wi.z;
        // The diffuse and multiple-scattering lobes from their view halves ([`albedo`]).
        let (dv, mv, fm, f0, b82) = (self.diffuse_view, self.ms_view, self.ms_fresnel, self.f0, self.f82_b);
        let f90 = albedo::f90(f0.x, f0.y, f0.z);
        let [dx, mx] = albedo::light_terms([dv.x, mv.x, fm.x], f0.x, f90, b82.x, at_i);
        let [dy, my] = albedo::light_terms([dv.y, mv.y, fm.y], f0.y, f90, b82.y, at_i);
        let [dz, mz] = albedo::light_terms([dv.z, mv.z, fm.z], f0.z, f90, b82.z, at_i);
        let (diffuse, multiple) = (Vec3::new(dx, dy, dz) * FRAC_1_PI, Vec3::new(mx, my, mz) * FRAC_1_PI);
        let specular = fresnel(f0, b82, wo_h) * (ggx_d(h, self.alpha) * ggx_g2(wo, wi, self.alpha) / denom);
        let base = diffuse + (specular + multiple);
        let mut f = base;
        let mut pdf = probs[0] * wi.z * FRAC_1_PI + probs[1] * ggx_pdf(wo, h, self.alpha);
        if COAT {
            let a = self.clearcoat_alpha;
            let coat =
                self.clearcoat * schlick_scalar(self.coat_f0, wo_h) * ggx_d(h, a) * ggx_g2(wo, wi, a) / denom;
            // The base under the coat: `1 − w` of it bare, `w` of it through the coat, which
            // reflects `E_c(μo)` and absorbs along both passes ([`coat_view`]).
            let t_i = coat_transmittance(self.coat_color, self.coat_inv_eta2, wi.z);
            let layered = base * (Vec3::splat(1.0 - self.clearcoat) + self.coat_base * t_i);
            let with_coat = pdf + probs[2] * ggx_pdf(wo, h, a);
            let has_coat = self.clearcoat > 0.0;
            f = select(has_coat, layered + Vec3::splat(coat), f);
            pdf = if has_coat { with_coat } else { pdf };
            // The fuzz over everything, by albedo scaling ([`fuzz_view`]).
            let fuzz = self.fuzz_color * (self.fuzz * sheen(wo, wi, h, sheen_alpha(self.fuzz_roughness)));
            let with_fuzz = pdf + probs[3] * wi.z * FRAC_1_PI;
            let has_fuzz = self.fuzz > 0.0;
            f = select(has_fuzz, f * (1.0 - self.fuzz_p) + fuzz, f);
            pdf = if has_fuzz { with_fuzz } else { pdf };
        }
        (f, pdf)
    }

    /// Value (no cosine) and combined pdf towards world `wi`, `at_i` = [`SeenBsdf::light_albedo`]
    /// at `wi · n`; zero below the geometric or either local hemisphere.
    #[inline(always)]
    pub fn eval<const COAT: bool>(&self, wi: Vec3, at_i: [f32; 3]) -> (Vec3, f32) {
        let (wo_l, wi_l) = (self.local(self.wo), self.local(wi));
        let (f, pdf) = self.eval_local::<COAT>(self.lobe_probabilities(wo_l.z), wo_l, wi_l, at_i);
        let above = !((wo_l.z <= 0.0) | (wi_l.z <= 0.0) | (wi.dot(self.ng) <= 0.0));
        (Vec3::new(or_zero(above, f.x), or_zero(above, f.y), or_zero(above, f.z)), or_zero(above, pdf))
    }
}

impl Bsdf {
    /// Resolves `mat` at a point with unit shading normal `ns` and unit geometric normal `ng`, both
    /// already flipped to the side of the outgoing direction.
    pub fn new(mat: &blob::Material, ns: Vec3, ng: Vec3) -> Self {
        Self::from_inputs(&crate::shading::ShadingInputs::constant(mat), ns, ng)
    }

    /// Resolves evaluated shading inputs (constants or a material program's output); see [`Bsdf::new`].
    pub fn from_inputs(mat: &crate::shading::ShadingInputs, ns: Vec3, ng: Vec3) -> Self {
        Self::from_lane(&lanes::InputLane::new(mat, ns, ng))
    }

    /// [`Bsdf::from_inputs`] of one lane's inputs ([`lanes::from_inputs_lanes`] runs it per lane):
    /// both workflows computed, one selected.
    #[inline(always)]
    pub(crate) fn from_lane(mat: &lanes::InputLane) -> Self {
        let base = mat.diffuse_color.clamp(Vec3::ZERO, Vec3::ONE);
        let specular = mat.specular_color.clamp(Vec3::ZERO, Vec3::ONE);
        let metallic = mat.metallic.clamp(0.0, 1.0);
        let r = (mat.ior - 1.0) / (mat.ior + 1.0);
        let dielectric = if r.is_finite() { (r * r).min(1.0) } else { 0.04 };
        let workflow = mat.use_specular_workflow;
        let diffuse = select(workflow, base, base * (1.0 - metallic));
        // OpenPBR's specular_weight scales F0 of both the dielectric and the metal, its
        // specular_color (`specular_tint`) tints the dielectric's F0 and is the metal's F82 edge
        // tint; at their fallbacks (1) every product is by 1 and `f82_b` is 0, exactly
        // UsdPreviewSurface. The specular workflow's F0 is specularColor as authored.
        let weight = mat.specular_weight.clamp(0.0, 1.0);
        let tint = mat.specular_tint.max(Vec3::ZERO).min(Vec3::ONE);
        let metal_f0 = base * weight;
        let dielectric_f0 = Vec3::splat(dielectric) * (tint * weight);
        let f0 = select(workflow, specular, dielectric_f0.lerp(metal_f0, metallic));
        let f82 = select(workflow, Vec3::ZERO, f82_b(metal_f0, tint) * metallic);
        let roughness = mat.roughness.clamp(0.0, 1.0);
        let cc_roughness = mat.clearcoat_roughness.clamp(0.0, 1.0);
        // The blob validates the coat's index into [1, 10]; a program-free check keeps any other
        // input (NaN included) a 1.5 coat rather than a NaN one.
        let coat_ior = if (mat.coat_ior >= 1.0) & (mat.coat_ior <= 10.0) { mat.coat_ior } else { 1.5 };
        let rc = (coat_ior - 1.0) / (coat_ior + 1.0);
        Bsdf {
            frame: Frame::new(mat.ns),
            ng: mat.ng,
            diffuse,
            f0,
            f82_b: f82,
            alpha: (roughness * roughness).max(MIN_ALPHA),
            clearcoat: mat.clearcoat.clamp(0.0, 1.0),
            clearcoat_alpha: (cc_roughness * cc_roughness).max(MIN_ALPHA),
            // `max` first: NaN → 0 (a black coat), never a NaN transmittance.
            coat_color: mat.coat_color.max(Vec3::ZERO).min(Vec3::ONE),
            coat_f0: rc * rc,
            coat_inv_eta2: 1.0 / (coat_ior * coat_ior),
            // NaN → 0, so that a zero weight's view half is exactly 0 whatever the other inputs.
            fuzz: unit(mat.fuzz_weight),
            fuzz_color: mat.fuzz_color.max(Vec3::ZERO).min(Vec3::ONE),
            fuzz_roughness: unit(mat.fuzz_roughness),
        }
    }

    /// The coat's parameters.
    #[inline(always)]
    pub(crate) fn coat(&self) -> CoatParams {
        let (weight, alpha, f0) = (self.clearcoat, self.clearcoat_alpha, self.coat_f0);
        CoatParams { weight, alpha, f0, color: self.coat_color, inv_eta2: self.coat_inv_eta2 }
    }

    /// The diffuse albedo (for the albedo AOV).
    pub fn diffuse_albedo(&self) -> Vec3 {
        self.diffuse
    }

    /// This BSDF seen from world direction `wo` (towards the viewer).
    #[inline(always)]
    pub fn seen_from(&self, wo: Vec3) -> SeenBsdf {
        let mu_o = wo.dot(self.frame.n);
        let view = view_halves(albedo::tables(), self.diffuse, self.f0, self.f82_b, self.alpha, mu_o);
        // Without a coat its view half is zero (what `coat_view` gives for a zero weight too,
        // without the lookup and the powers).
        let layers = (self.clearcoat != 0.0) | (self.fuzz != 0.0);
        let (coat, fuzz_p) = if layers {
            let fuzz = fuzz_view(albedo::sheen_table(), self.fuzz, self.fuzz_roughness, mu_o);
            (coat_view(albedo::tables(), self.coat(), mu_o), fuzz)
        } else {
            ((Vec3::ZERO, 0.0), 0.0)
        };
        self.seen_with(wo, view, coat, fuzz_p)
    }

    /// [`Bsdf::seen_from`] with the view halves known ([`view_halves`], [`coat_view`]).
    #[inline(always)]
    pub(crate) fn seen_with(&self, wo: Vec3, view: [Vec3; 3], coat: (Vec3, f32), fuzz_p: f32) -> SeenBsdf {
        #[rustfmt::skip]
        let Bsdf {
            frame, ng, diffuse, f0, f82_b, alpha, clearcoat, clearcoat_alpha, coat_color, coat_f0, coat_inv_eta2,
            fuzz, fuzz_color, fuzz_roughness,
        } = *self;
        let [diffuse_view, ms_view, ms_fresnel] = view;
        let (coat_base, coat_p) = coat;
        #[rustfmt::skip]
        let seen = SeenBsdf {
            t: frame.t, b: frame.b, n: frame.n, ng, diffuse, f0, f82_b, alpha, clearcoat, clearcoat_alpha, wo,
            diffuse_view, ms_view, ms_fresnel, coat_color, coat_f0, coat_inv_eta2, coat_base, coat_p,
            fuzz, fuzz_color, fuzz_roughness, fuzz_p,
        };
        seen
    }

    /// BSDF value (no cosine) and combined pdf for world directions `wo` (towards the viewer) and `wi`.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        // A shortcut, not a second rule: `SeenBsdf::eval` returns these zeros for these directions
        // too (its local `z` are these dot products), but skipping the lobes for light samples
        // behind the surface saves the scalar integrator 2.2 M of 87.1 M instructions on the
        // tractor (`docs/perf.md#bsdf-lanes-bsdflanesrs`).
        let n = self.frame.n;
        if (wi.dot(self.ng) <= 0.0) | (wo.dot(n) <= 0.0) | (wi.dot(n) <= 0.0) {
            return (Vec3::ZERO, 0.0);
        }
        let seen = self.seen_from(wo);
        let at_i = seen.light_albedo(albedo::tables(), wi.dot(seen.n));
        if seen.has_coat_terms() {
            seen.eval::<true>(wi, at_i)
        } else {
            seen.eval::<false>(wi, at_i)
        }
    }

    /// Samples an incident direction for world `wo` with a lobe choice `u_lobe` and a 2D sample `u`.
    /// `None` when the sample is absorbed (black material, or a direction below either hemisphere).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<BsdfSample> {
        let seen = self.seen_from(wo);
        let start = seen.sample_start(u_lobe, u);
        let (sin, cos) = crate::trig::sin_cos(start.angle);
        let dir = seen.sample_direction(&start, u_lobe, u, sin, cos);
        let at_i = seen.light_albedo(albedo::tables(), dir.local.z);
        let (sample, ok) = if seen.has_coat_terms() {
            seen.sample_finish::<true>(&start, &dir, at_i)
        } else {
            seen.sample_finish::<false>(&start, &dir, at_i)
        };
        ok.then_some(sample)
    }
}

/// A sample in three steps, so that the lane kernels find the sines and cosines and make the table
/// lookups between them, eight lanes at a time.
impl SeenBsdf {
    /// The local `wo`, the lobe probabilities, the lobe `u_lobe` picks and the angle whose sine and
    /// cosine it needs (the concentric disk's for the diffuse lobe, the spherical cap's azimuth for
    /// GGX).
    #[inline(always)]
    pub fn sample_start(&self, u_lobe: f32, u: [f32; 2]) -> SampleStart {
        let wo = self.local(self.wo);
        let probs = self.lobe_probabilities(wo.z);
        // The fuzz lobe is sampled like the diffuse one (cosine-weighted); without it (`probs[3]`
        // 0) the choice is exactly the three-lobe one.
        let fuzz = (probs[3] > 0.0) & (u_lobe >= probs[0] + probs[1] + probs[2]);
        let diffuse = (u_lobe < probs[0]) | fuzz;
        let angle = if diffuse { concentric_angle(u) } else { TAU * u[0] };
        SampleStart { wo, probs, diffuse, angle }
    }

    /// The direction of the chosen lobe, from the sine and cosine of `start.angle`.
    #[inline(always)]
    pub fn sample_direction(
        &self,
        start: &SampleStart,
        u_lobe: f32,
        u: [f32; 2],
        sin: f32,
        cos: f32,
    ) -> SampledDirection {
        let wo = start.wo;
        let [dx, dy] = concentric_disk(u, sin, cos);
        let diffuse = Vec3::new(dx, dy, (1.0 - dx * dx - dy * dy).max(0.0).sqrt());
        let alpha = if u_lobe < start.probs[0] + start.probs[1] { self.alpha } else { self.clearcoat_alpha };
        let h = ggx_vndf(wo, alpha, u[1], sin, cos);
        let local = select(start.diffuse, diffuse, 2.0 * wo.dot(h) * h - wo);
        let wi = (self.t * local.x + self.b * local.y + self.n * local.z).normalize();
        SampledDirection { wi, local, lobe_alpha: if start.diffuse { 1.0 } else { alpha } }
    }

    /// The sample's value and pdf (`at_i` = [`SeenBsdf::light_albedo`] at `dir.local.z`), and whether
    /// it exists: not where `wo` or the direction is below a hemisphere, the BSDF is black, or the
    /// value is not finite.
    // `!(a <= b)` on purpose: it is how the early returns it replaced treated NaN (they did not return).
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    #[inline(always)]
    pub fn sample_finish<const COAT: bool>(
        &self,
        start: &SampleStart,
        dir: &SampledDirection,
        at_i: [f32; 3],
    ) -> (BsdfSample, bool) {
        // Without the lobe's terms `p_c` is ±0, or beside a NaN `p_d` ([`SeenBsdf::has_coat_terms`]).
        let probs = [
            start.probs[0],
            start.probs[1],
            if COAT { start.probs[2] } else { 0.0 },
            if COAT { start.probs[3] } else { 0.0 },
        ];
        let (f, pdf) = self.eval_local::<COAT>(probs, start.wo, dir.local, at_i);
        let ok = !(start.wo.z <= 0.0)
            & !(probs[0] + probs[1] + probs[2] + probs[3] <= 0.0)
            & !(dir.local.z <= 0.0)
            & !(dir.wi.dot(self.ng) <= 0.0)
            & (pdf > 0.0)
            & f.is_finite();
        (BsdfSample { wi: dir.wi, f, pdf, lobe_alpha: dir.lobe_alpha }, ok)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::Rng;

    fn material(diffuse: f32, metallic: f32, roughness: f32, ior: f32) -> blob::Material {
        blob::Material {
            diffuse_color: [diffuse; 3],
            metallic,
            roughness,
            ior,
            opacity: 1.0,
            clearcoat_roughness: 0.01,
            ..Default::default()
        }
    }

    fn dir_from_angle(theta_deg: f32) -> Vec3 {
        let t = theta_deg.to_radians();
        Vec3::new(t.sin(), 0.0, t.cos())
    }

    /// ∫ f cos dω estimated by the BSDF's own sampling.
    fn albedo_by_sampling(bsdf: &Bsdf, wo: Vec3, n: usize) -> f32 {
        let mut rng = Rng(99);
        let mut sum = 0.0f64;
        for _ in 0..n {
            if let Some(s) = bsdf.sample(wo, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                sum += (s.f.x * s.wi.z / s.pdf) as f64;
            }
        }
        (sum / n as f64) as f32
    }

    /// ∫ f cos dω and ∫ pdf dω estimated by uniform hemisphere sampling (independent of `sample`).
    fn albedo_and_pdf_mass_uniform(bsdf: &Bsdf, wo: Vec3, n: usize) -> (f32, f32) {
        let mut rng = Rng(7);
        let (mut a, mut p) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let z = rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = TAU * rng.next_f32();
            let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let (f, pdf) = bsdf.eval(wo, wi);
            a += (f.x * wi.z * TAU) as f64;
            p += (pdf * TAU) as f64;
        }
        ((a / n as f64) as f32, (p / n as f64) as f32)
    }

    #[test]
    fn white_lambert_integrates_to_one() {
        let bsdf = Bsdf::new(&material(1.0, 0.0, 0.5, 1.0), Vec3::Z, Vec3::Z);
        for theta in [0.0, 30.0, 60.0, 85.0] {
            let wo = dir_from_angle(theta);
            let sampled = albedo_by_sampling(&bsdf, wo, 20_000);
            eprintln!("white Lambert θ={theta}: sampled albedo {sampled:.5}");
            assert!((sampled - 1.0).abs() < 1e-3, "θ={theta}: sampled albedo {sampled}");
            let (uniform, mass) = albedo_and_pdf_mass_uniform(&bsdf, wo, 200_000);
            assert!((uniform - 1.0).abs() < 0.01, "θ={theta}: uniform albedo {uniform}");
            assert!((mass - 1.0).abs() < 0.01, "θ={theta}: pdf mass {mass}");
        }
    }

    /// A perfect-Fresnel conductor (metallic 1, diffuseColor 1: F0 = 1) keeps all the energy at
    /// every roughness and angle: single-scattering GGX loses up to 69 % (at α = 1 head-on it keeps
    /// exactly 1 − ln 2, pinned in [`albedo`]'s tests), and the multiple-scattering lobe returns it.
    #[test]
    fn white_metal_is_a_furnace_at_every_roughness() {
        for roughness in [0.1, 0.3, 0.6, 1.0] {
            let bsdf = Bsdf::new(&material(1.0, 1.0, roughness, 1.5), Vec3::Z, Vec3::Z);
            for theta in [0.0, 45.0, 75.0] {
                let wo = dir_from_angle(theta);
                let sampled = albedo_by_sampling(&bsdf, wo, 200_000);
                eprintln!("white metal roughness {roughness} θ={theta}: albedo {sampled:.4}");
                assert!((sampled - 1.0).abs() < 0.01, "r={roughness} θ={theta}: {sampled}");
                if roughness >= 0.3 {
                    // Uniform sampling of a sharp lobe is too noisy to compare at r = 0.1.
                    let (uniform, _) = albedo_and_pdf_mass_uniform(&bsdf, wo, 400_000);
                    assert!(
                        (sampled - uniform).abs() < 0.02,
                        "r={roughness} θ={theta}: {sampled} vs {uniform}"
                    );
                }
            }
        }
    }

    /// OpenPBR's coat layer over a white plastic base conserves energy: the base keeps what the
    /// coat does not reflect (`1 − w·E_c(μo)`), so the furnace reads 1 at every view angle, coat
    /// roughness, weight and index, grazing 80° included (the old `1 − cc·F_c(n·v)` factor read
    /// 0.956 there).
    #[test]
    fn coated_plastic_is_a_furnace_at_every_angle() {
        for (weight, coat_roughness, coat_ior, roughness) in
            [(1.0, 0.0, 1.5, 0.4), (1.0, 0.2, 1.5, 0.4), (1.0, 0.5, 1.6, 0.1), (0.5, 0.3, 2.0, 0.8)]
        {
            let mut m = material(1.0, 0.0, roughness, 1.5);
            (m.clearcoat, m.clearcoat_roughness, m.coat_ior) = (weight, coat_roughness, coat_ior);
            let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
            for theta in [0.0, 45.0, 80.0] {
                let a = albedo_by_sampling(&bsdf, dir_from_angle(theta), 200_000);
                eprintln!(
                    "coat {weight} r_c {coat_roughness} ior {coat_ior} over plastic r {roughness} θ={theta}: albedo {a:.4}"
                );
                assert!((a - 1.0).abs() < 0.01, "coat {weight}/{coat_roughness}/{coat_ior} θ={theta}: {a}");
            }
        }
        // A coated white metal too.
        let mut m = material(1.0, 1.0, 0.5, 1.5);
        (m.clearcoat, m.clearcoat_roughness) = (1.0, 0.1);
        let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
        for theta in [0.0, 45.0, 80.0] {
            let a = albedo_by_sampling(&bsdf, dir_from_angle(theta), 200_000);
            eprintln!("coated white metal θ={theta}: albedo {a:.4}");
            assert!((a - 1.0).abs() < 0.01, "coated metal θ={theta}: {a}");
        }
    }

    /// The coat absorbs along both passes: over a smooth white mirror, a smooth coat of colour `c`
    /// reflects `F0_c + (1 − F0_c) c²` head-on (0.04 + 0.96 · 0.25 = 0.28 for c = 0.5 and index
    /// 1.5), per channel; off normal the path through the coat is longer (`c^(2/μt)`).
    #[test]
    fn coat_colour_attenuates_a_mirror_by_its_square_head_on() {
        let mut m = material(1.0, 1.0, 0.0, 1.5);
        (m.clearcoat, m.clearcoat_roughness, m.coat_color) = (1.0, 0.0, [0.5, 0.8, 1.0]);
        let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
        let mut rng = Rng(5);
        let n = 100_000;
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            if let Some(s) = bsdf.sample(Vec3::Z, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                sum += s.f * (s.wi.z / s.pdf);
            }
        }
        let a = sum / n as f32;
        let expect = |c: f32| 0.04 + 0.96 * c * c;
        eprintln!("mirror under a (0.5, 0.8, 1) coat, head-on: {a}");
        for (got, c) in [(a.x, 0.5), (a.y, 0.8), (a.z, 1.0)] {
            assert!((got - expect(c)).abs() < 2e-3, "coat colour {c}: {got} vs {}", expect(c));
        }
        // At 60° the refracted cosine in a 1.5 coat is √(1 − 0.75/2.25) = 0.8165: T = c^(2/0.8165).
        let wo = dir_from_angle(60.0);
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            if let Some(s) = bsdf.sample(wo, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                sum += s.f * (s.wi.z / s.pdf);
            }
        }
        let (white, tinted) = (sum.z / n as f32, sum.x / n as f32);
        let e_c = schlick_scalar(0.04, 0.5); // a smooth coat reflects Schlick's F at 60°
        let expect = e_c + (1.0 - e_c) * 0.5f32.powf(2.0 / (1.0f32 - 0.75 / 2.25).sqrt());
        eprintln!("60°: white {white:.4}, tinted {tinted:.4} (expected {expect:.4})");
        assert!((white - 1.0).abs() < 0.01 && (tinted - expect).abs() < 3e-3, "{tinted} vs {expect}");
    }

    /// ∫ f cos dω per channel, by the BSDF's own sampling.
    fn rgb_albedo(bsdf: &Bsdf, wo: Vec3, n: usize) -> Vec3 {
        let mut rng = Rng(17);
        let mut sum = glam::DVec3::ZERO;
        for _ in 0..n {
            if let Some(s) = bsdf.sample(wo, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                sum += (s.f * (s.wi.z / s.pdf)).as_dvec3();
            }
        }
        (sum / n as f64).as_vec3()
    }

    /// OpenPBR's F82 tint: a metal's Fresnel at the model's edge cosine μ̄ = 1/7 (81.8°) is the
    /// authored `specular_color` times Schlick's there, and it is Schlick's at normal incidence;
    /// through the BSDF, a smooth tinted metal seen at μ̄ reflects that (within 1e-3), and a
    /// rough one keeps `eval` and `sample` consistent (the tables' `C` column in its energy).
    #[test]
    fn f82_tint_sets_the_metal_edge_reflectance() {
        let (f0, tint) = (Vec3::new(0.95, 0.64, 0.54), Vec3::new(0.9, 0.5, 0.2));
        let b = f82_b(f0, tint);
        let schlick_bar = schlick(f0, F82_MU);
        let at_bar = fresnel(f0, b, F82_MU);
        eprintln!("F82 at μ̄: {at_bar} vs tint × Schlick {}", tint * schlick_bar);
        assert!((at_bar - tint * schlick_bar).abs().max_element() < 1e-5, "{at_bar}");
        assert_eq!(fresnel(f0, b, 1.0), f0, "head-on: F0");
        assert_eq!(f82_b(f0, Vec3::ONE), Vec3::ZERO, "an untinted metal is Schlick's");
        let mut m = material(1.0, 1.0, 0.0, 1.5);
        (m.diffuse_color, m.specular_tint) = (f0.to_array(), tint.to_array());
        let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
        let wo = Vec3::new((1.0 - F82_MU * F82_MU).sqrt(), 0.0, F82_MU);
        let a = rgb_albedo(&bsdf, wo, 50_000);
        eprintln!("smooth tinted metal at μ̄: reflectance {a} (tint × Schlick {})", tint * schlick_bar);
        assert!((a - tint * schlick_bar).abs().max_element() < 1e-3, "{a}");
        // Rough: sampled and uniformly integrated albedo agree per channel.
        m.roughness = 0.6;
        let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
        for theta in [0.0, 60.0, 80.0] {
            let wo = dir_from_angle(theta);
            let sampled = rgb_albedo(&bsdf, wo, 200_000);
            let mut rng = Rng(8);
            let mut uniform = glam::DVec3::ZERO;
            let n = 400_000;
            for _ in 0..n {
                let z = rng.next_f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = TAU * rng.next_f32();
                let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                uniform += (bsdf.eval(wo, wi).0 * (wi.z * TAU)).as_dvec3();
            }
            let uniform = (uniform / n as f64).as_vec3();
            eprintln!("rough tinted metal θ={theta}: sampled {sampled}, uniform {uniform}");
            assert!((sampled - uniform).abs().max_element() < 0.01, "θ={theta}: {sampled} vs {uniform}");
        }
    }

    /// `specular_weight` scales the specular lobe's F0 (0 removes it: a white base is then exactly
    /// Lambert) and `specular_color` tints a dielectric's F0; the diffuse keeps what the tinted
    /// lobe leaves, so a white base still reads 1 per channel at every angle.
    #[test]
    fn specular_weight_and_tint_keep_the_dielectric_base_a_furnace() {
        let mut m = material(1.0, 0.0, 0.3, 1.5);
        m.specular_weight = 0.0;
        let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
        let (f, _) = bsdf.eval(dir_from_angle(30.0), dir_from_angle(-50.0));
        assert!((f - Vec3::splat(FRAC_1_PI)).abs().max_element() < 1e-6, "no specular: Lambert, {f}");
        (m.specular_weight, m.specular_tint) = (0.5, [1.0, 0.5, 0.25]);
        let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
        let r = (0.5f32 / 2.5).powi(2);
        assert!((bsdf.f0 - Vec3::new(1.0, 0.5, 0.25) * (0.5 * r)).abs().max_element() < 1e-7, "{}", bsdf.f0);
        for theta in [0.0, 45.0, 80.0] {
            let a = rgb_albedo(&bsdf, dir_from_angle(theta), 200_000);
            eprintln!("white plastic, specular weight 0.5, tint (1, 0.5, 0.25), θ={theta}: {a}");
            assert!((a - Vec3::ONE).abs().max_element() < 0.01, "θ={theta}: {a}");
        }
    }

    /// The fuzz layer (OpenPBR's fuzz, here a Charlie sheen) over everything conserves energy by
    /// albedo scaling: white plastic, coated or not, under a white fuzz reads 1 at 0°, 45° and 80°
    /// for smooth and rough fuzz; over a black base a fuzz of colour `c` reflects `c · E_f(μo)`,
    /// the tabulated sheen albedo (which the sampled lobe matches within 1 %).
    #[test]
    fn fuzz_is_a_furnace_over_every_base_and_its_albedo_is_the_table() {
        for (fuzz_roughness, coat) in [(0.2, 0.0), (0.5, 0.0), (0.9, 0.0), (0.5, 1.0)] {
            let mut m = material(1.0, 0.0, 0.4, 1.5);
            (m.fuzz_weight, m.fuzz_roughness, m.clearcoat, m.clearcoat_roughness) =
                (1.0, fuzz_roughness, coat, 0.1);
            let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
            for theta in [0.0, 45.0, 80.0] {
                let a = rgb_albedo(&bsdf, dir_from_angle(theta), 200_000);
                eprintln!("white fuzz r {fuzz_roughness} over plastic (coat {coat}) θ={theta}: {a}");
                assert!((a - Vec3::ONE).abs().max_element() < 0.01, "r {fuzz_roughness} θ={theta}: {a}");
            }
        }
        let mut m = material(0.0, 0.0, 0.4, 1.0);
        (m.fuzz_weight, m.fuzz_roughness, m.fuzz_color) = (1.0, 0.5, [1.0, 0.5, 0.25]);
        let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
        for theta in [0.0, 45.0, 80.0] {
            let wo = dir_from_angle(theta);
            let a = rgb_albedo(&bsdf, wo, 400_000);
            let e = albedo::sheen_albedo(albedo::sheen_table(), wo.z, 0.5);
            eprintln!("fuzz (1, 0.5, 0.25) over black θ={theta}: {a}, table E_f {e:.4}");
            assert!(e > 0.02, "θ={theta}: E_f {e}");
            let expect = Vec3::new(1.0, 0.5, 0.25) * e;
            assert!((a - expect).abs().max_element() < 0.01 * e.max(0.1), "θ={theta}: {a} vs {expect}");
        }
    }

    /// Diffuse under a dielectric specular layer conserves energy ([`albedo`]): a white base reads
    /// 1 at every angle and roughness, and a grey one keeps its brightness towards the horizon
    /// (the old `1 − F(n·v)` factor took 25 % off this rough floor at 80°).
    #[test]
    fn white_plastic_is_a_furnace_and_grazing_views_keep_their_diffuse() {
        for roughness in [0.05, 0.3, 0.6, 1.0] {
            let bsdf = Bsdf::new(&material(1.0, 0.0, roughness, 1.5), Vec3::Z, Vec3::Z);
            for theta in [0.0, 45.0, 70.0, 85.0] {
                let a = albedo_by_sampling(&bsdf, dir_from_angle(theta), 200_000);
                eprintln!("white plastic roughness {roughness} θ={theta}: albedo {a:.4}");
                assert!((a - 1.0).abs() < 0.01, "roughness {roughness} θ={theta}: {a}");
            }
        }
        let floor = Bsdf::new(&material(0.8, 0.0, 1.0, 1.5), Vec3::Z, Vec3::Z);
        let head_on = albedo_by_sampling(&floor, dir_from_angle(0.0), 200_000);
        let grazing = albedo_by_sampling(&floor, dir_from_angle(80.0), 200_000);
        eprintln!("rough grey floor: albedo {head_on:.4} head-on, {grazing:.4} at 80°");
        assert!(grazing > 0.97 * head_on, "{grazing} vs {head_on}");
    }

    /// Chi-square test: histogram of sampled directions over (cos θ, φ) bins vs the integral of `pdf`.
    fn chi_square(bsdf: &Bsdf, wo: Vec3) -> (f64, usize) {
        const NT: usize = 10;
        const NP: usize = 20;
        const N: usize = 200_000;
        let mut observed = [[0f64; NP]; NT];
        let mut rng = Rng(2024);
        for _ in 0..N {
            if let Some(s) = bsdf.sample(wo, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                let ct = s.wi.z.clamp(0.0, 0.999_999);
                let phi = s.wi.y.atan2(s.wi.x).rem_euclid(TAU);
                observed[(ct * NT as f32) as usize]
                    [((phi / TAU) * NP as f32).min(NP as f32 - 1.0) as usize] += 1.0;
            }
        }
        let mut stat = 0.0;
        let mut dof = 0;
        let sub = 12;
        let mut pooled_e = 0.0;
        let mut pooled_o = 0.0;
        for (i, row) in observed.iter().enumerate() {
            for (j, &count) in row.iter().enumerate() {
                // Integrate the pdf over the bin (area element in (cos θ, φ) is dcosθ dφ).
                let mut e = 0.0f64;
                for a in 0..sub {
                    for b in 0..sub {
                        let ct = (i as f32 + (a as f32 + 0.5) / sub as f32) / NT as f32;
                        let phi = (j as f32 + (b as f32 + 0.5) / sub as f32) / NP as f32 * TAU;
                        let st = (1.0 - ct * ct).sqrt();
                        let wi = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                        e += bsdf.eval(wo, wi).1 as f64;
                    }
                }
                e *= (1.0 / NT as f64) * (TAU as f64 / NP as f64) / (sub * sub) as f64 * N as f64;
                if e < 5.0 {
                    pooled_e += e;
                    pooled_o += count;
                } else {
                    stat += (count - e).powi(2) / e;
                    dof += 1;
                }
            }
        }
        if pooled_e > 5.0 {
            stat += (pooled_o - pooled_e).powi(2) / pooled_e;
            dof += 1;
        }
        (stat, dof)
    }

    #[test]
    fn sampled_directions_follow_the_pdf() {
        let mut coated = material(0.8, 0.0, 0.5, 1.5);
        coated.clearcoat = 0.7;
        coated.clearcoat_roughness = 0.3;
        let mut fuzzed = coated;
        (fuzzed.fuzz_weight, fuzzed.fuzz_roughness) = (0.7, 0.4);
        let cases = [
            ("lambert", material(0.7, 0.0, 0.5, 1.0)),
            ("rough metal", material(0.9, 1.0, 0.6, 1.5)),
            ("plastic", material(0.5, 0.0, 0.4, 1.5)),
            ("coated", coated),
            ("fuzzed", fuzzed),
        ];
        for (name, m) in cases {
            let bsdf = Bsdf::new(&m, Vec3::Z, Vec3::Z);
            for theta in [10.0, 60.0] {
                let (stat, dof) = chi_square(&bsdf, dir_from_angle(theta));
                // Mean = dof, sd = sqrt(2 dof); allow ~5 sd (bin integration is itself approximate).
                let limit = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
                eprintln!("χ² {name} θ={theta}: {stat:.1} with {dof} dof");
                assert!(stat < limit, "{name} θ={theta}: χ² = {stat:.1} with {dof} dof (limit {limit:.1})");
            }
        }
    }

    #[test]
    fn shading_normal_never_leaks_below_the_geometric_surface() {
        // Shading normal tilted 40° from the geometric normal.
        let ns = dir_from_angle(40.0);
        let bsdf = Bsdf::new(&material(1.0, 0.0, 0.5, 1.0), ns, Vec3::Z);
        let below = Vec3::new(0.9, 0.0, -0.1).normalize();
        assert_eq!(bsdf.eval(Vec3::Z, below).0, Vec3::ZERO);
        let mut rng = Rng(3);
        for _ in 0..10_000 {
            if let Some(s) = bsdf.sample(Vec3::Z, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                assert!(s.wi.z > 0.0);
            }
        }
    }
}

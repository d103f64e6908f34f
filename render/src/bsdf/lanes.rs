//! The UsdPreviewSurface BSDF ([`crate::bsdf::Bsdf`]) evaluated and sampled eight shading points at a
//! time, in AoSoA form (`[f32; 8]` columns). The scalar reference is [`Bsdf::eval`] and
//! [`Bsdf::sample`] themselves: the lanes perform the same IEEE operations in the same order (glam's
//! `dot` is `(x·x' + y·y') + z·z'`, `normalize` multiplies by `1 / length`, no FMA contraction happens
//! without fast-math), and every early return of the scalar code becomes a lane mask, so each lane
//! equals the scalar result bit for bit (the tests check it on random inputs, NaN and infinities
//! included).
//!
//! The kernels are straight-line per lane (selects, no branches) in three loops over the lanes: before
//! the trigonometry, the sines and cosines ([`crate::trig::sin_cos_lanes`], the polynomial the
//! scalar [`Bsdf::sample`] calls too), and after. LLVM vectorises all three loops to 8-wide AVX2
//! under [`multiversion`] (chosen at run time, generic fallback elsewhere).
//!
//! Groups where no lane has a clearcoat lobe (`clearcoat > 0`; most groups of the bench scenes) run
//! a variant without its terms, and the sampler keeps the lobe probabilities and the local `wo` of
//! its first loop for its last. The kernels are bound by the divider, not by the instruction count:
//! every `vdivps` and `vsqrtps` is needed for the scalar code's bits (a product by a reciprocal rounds
//! differently); [`any_coat`] defines coatless groups by a zero weight on every lane. Tried and
//! dropped: `wo` and the lobe probabilities as [`BsdfLanes`] columns, an AVX-512VL clone, a variant
//! for all-diffuse groups; measurements: `docs/perf.md#bsdf-lanes-bsdflanesrs`.

use crate::bsdf::{albedo, Bsdf};
use crate::shading::ShadingInputs;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};
use std::ops::{Add, Mul, Sub};

use lanekit::{Lanes3, LANES, V};

const CLEARCOAT_F0: f32 = 0.04;

lanekit::soa! {
    /// Eight BSDFs and their outgoing directions, transposed.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct BsdfLanes for struct BsdfLane {
        /// Shading frame tangent.
        pub t: Vec3 as [f32; 3],
        /// Shading frame bitangent.
        pub b: Vec3 as [f32; 3],
        /// Shading normal.
        pub n: Vec3 as [f32; 3],
        /// Geometric normal on the side of `wo`.
        pub ng: Vec3 as [f32; 3],
        /// Diffuse colour.
        pub diffuse: Vec3 as [f32; 3],
        /// Specular F0.
        pub f0: Vec3 as [f32; 3],
        /// GGX α of the specular lobe.
        pub alpha: f32,
        /// Clearcoat weight.
        pub clearcoat: f32,
        /// GGX α of the clearcoat.
        pub clearcoat_alpha: f32,
        /// World-space direction towards the viewer.
        pub wo: Vec3 as [f32; 3],
        /// The diffuse lobe's view half at `wo` ([`albedo::view_terms`] per channel).
        pub diffuse_view: Vec3 as [f32; 3],
        /// The multiple-scattering lobe's view half at `wo`.
        pub ms_view: Vec3 as [f32; 3],
        /// The multiple-scattering Fresnel ([`albedo::ms_fresnel`]).
        pub ms_fresnel: Vec3 as [f32; 3],
    }
}

impl BsdfLanes {
    /// Writes `bsdf` seen from `wo` into lane `k` (the frame flattened into its three axes).
    #[inline]
    pub fn set_bsdf(&mut self, k: usize, bsdf: &Bsdf, wo: Vec3) {
        let Bsdf { frame, ng, diffuse, f0, alpha, clearcoat, clearcoat_alpha } = *bsdf;
        let (t, b, n) = (frame.t, frame.b, frame.n);
        let (diffuse_view, ms_view, ms_fresnel) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        #[rustfmt::skip]
        self.set(k, &BsdfLane {
            t, b, n, ng, diffuse, f0, alpha, clearcoat, clearcoat_alpha, wo, diffuse_view, ms_view, ms_fresnel,
        });
        self.set_view_terms(albedo::tables(), k, wo.dot(n));
    }

    /// Lane `k`'s view halves ([`albedo::view_terms`]) from its diffuse colour, F0 and α at local
    /// cosine `wo_z`.
    #[inline(always)]
    fn set_view_terms(&mut self, tables: &albedo::Tables, k: usize, wo_z: f32) {
        let (d, f0) = (V::at(&self.diffuse, k), V::at(&self.f0, k));
        let at_o = albedo::lobe_albedo(tables, wo_z, self.alpha[k]);
        let f90 = albedo::f90(f0.x, f0.y, f0.z);
        let [dx, mx, fx] = albedo::view_terms(d.x, f0.x, f90, at_o);
        let [dy, my, fy] = albedo::view_terms(d.y, f0.y, f90, at_o);
        let [dz, mz, fz] = albedo::view_terms(d.z, f0.z, f90, at_o);
        V { x: dx, y: dy, z: dz }.store(&mut self.diffuse_view, k);
        V { x: mx, y: my, z: mz }.store(&mut self.ms_view, k);
        V { x: fx, y: fy, z: fz }.store(&mut self.ms_fresnel, k);
    }
}

lanekit::soa! {
    /// Eight shading points' resolved UsdPreviewSurface inputs and normals: what
    /// [`Bsdf::from_inputs`] reads, transposed.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct InputLanes for struct InputLane {
        /// `diffuseColor`.
        pub diffuse_color: Vec3 as [f32; 3],
        /// `specularColor`.
        pub specular_color: Vec3 as [f32; 3],
        /// 1 for `useSpecularWorkflow`.
        pub use_specular_workflow: bool,
        /// `roughness`.
        pub roughness: f32,
        /// `metallic`.
        pub metallic: f32,
        /// `ior`.
        pub ior: f32,
        /// `clearcoat`.
        pub clearcoat: f32,
        /// `clearcoatRoughness`.
        pub clearcoat_roughness: f32,
        /// Unit shading normal on the side of the viewer.
        pub ns: Vec3 as [f32; 3],
        /// Unit geometric normal on the side of the viewer.
        pub ng: Vec3 as [f32; 3],
    }
}

impl InputLanes {
    /// Writes `inputs` at a point with normals `ns` and `ng` into lane `k` (the inputs the BSDF
    /// reads: not emission, opacity or the normal map, which phase 1 has applied).
    #[inline]
    pub fn set_inputs(&mut self, k: usize, inputs: &ShadingInputs, ns: Vec3, ng: Vec3) {
        self.set(
            k,
            &InputLane {
                diffuse_color: inputs.diffuse_color,
                specular_color: inputs.specular_color,
                use_specular_workflow: inputs.use_specular_workflow,
                roughness: inputs.roughness,
                metallic: inputs.metallic,
                ior: inputs.ior,
                clearcoat: inputs.clearcoat,
                clearcoat_roughness: inputs.clearcoat_roughness,
                ns,
                ng,
            },
        );
    }
}

/// [`Bsdf::from_inputs`] on eight lanes: writes every field of `out` but `wo`. Both workflows are
/// computed and selected per lane; glam's `Vec3::clamp` (`max` then `min` by comparison, NaN → the
/// bound) and `f32::clamp` (NaN passes) are kept apart as the scalar code uses them.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn from_inputs_lanes(inp: &InputLanes, out: &mut BsdfLanes) {
    // glam's `Vec3::clamp(ZERO, ONE)` on one component.
    let unit = |x: f32| {
        let m = if x > 0.0 { x } else { 0.0 };
        if m < 1.0 {
            m
        } else {
            1.0
        }
    };
    let tables = albedo::tables();
    for k in 0..LANES {
        // `Frame::new(ns)` (Duff et al. 2017), in its operation order.
        let n = V::at(&inp.ns, k);
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        V { x: 1.0 + sign * n.x * n.x * a, y: sign * b, z: -sign * n.x }.store(&mut out.t, k);
        V { x: b, y: sign + n.y * n.y * a, z: -n.y }.store(&mut out.b, k);
        n.store(&mut out.n, k);
        V::at(&inp.ng, k).store(&mut out.ng, k);

        let dc = V::at(&inp.diffuse_color, k);
        let base = V { x: unit(dc.x), y: unit(dc.y), z: unit(dc.z) };
        let sc = V::at(&inp.specular_color, k);
        let specular = V { x: unit(sc.x), y: unit(sc.y), z: unit(sc.z) };
        let metallic = inp.metallic[k].clamp(0.0, 1.0);
        let ior = inp.ior[k];
        let r = (ior - 1.0) / (ior + 1.0);
        let dielectric = if r.is_finite() { (r * r).min(1.0) } else { 0.04 };
        let keep = 1.0 - metallic;
        // `Vec3::splat(dielectric).lerp(base, metallic)`: `self * (1 − s) + rhs * s`.
        let f0_metal = V {
            x: dielectric * keep + base.x * metallic,
            y: dielectric * keep + base.y * metallic,
            z: dielectric * keep + base.z * metallic,
        };
        let specular_workflow = inp.use_specular_workflow[k] != 0;
        V::select(specular_workflow, base, base.scale(keep)).store(&mut out.diffuse, k);
        V::select(specular_workflow, specular, f0_metal).store(&mut out.f0, k);
        let roughness = inp.roughness[k].clamp(0.0, 1.0);
        let cc_roughness = inp.clearcoat_roughness[k].clamp(0.0, 1.0);
        out.alpha[k] = (roughness * roughness).max(crate::bsdf::MIN_ALPHA);
        out.clearcoat[k] = inp.clearcoat[k].clamp(0.0, 1.0);
        out.clearcoat_alpha[k] = (cc_roughness * cc_roughness).max(crate::bsdf::MIN_ALPHA);
        // The local `wo.z` as `to_local` computes it.
        let wo_z = V::at(&out.wo, k).dot(n);
        out.set_view_terms(tables, k, wo_z);
    }
}

lanekit::soa! {
    /// Values and pdfs of eight evaluations.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct EvalLanes for struct EvalLane {
        /// BSDF value (no cosine).
        pub f: Vec3 as [f32; 3],
        /// Combined pdf.
        pub pdf: f32,
    }
}

lanekit::soa! {
    /// Eight BSDF samples; lanes with `ok == 0` were absorbed (the scalar `sample` returned `None`).
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct SampleLanes for struct SampleLane {
        /// World-space incident direction.
        pub wi: Vec3 as [f32; 3],
        /// BSDF value.
        pub f: Vec3 as [f32; 3],
        /// Combined pdf.
        pub pdf: f32,
        /// α of the sampled lobe.
        pub lobe_alpha: f32,
        /// 1 where the sample exists.
        pub ok: bool,
    }
}

lanekit::soa! {
    /// The random numbers of eight samples.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct SampleInputs for struct SampleInput {
        /// Lobe choice.
        pub u_lobe: f32,
        /// First direction coordinate.
        pub u0: f32,
        /// Second direction coordinate.
        pub u1: f32,
    }
}

#[inline(always)]
fn schlick(f0: V, cos: f32) -> V {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m5 = (m * m) * (m * m) * m;
    let f90 = (50.0 * 0.33 * (f0.x + f0.y + f0.z)).clamp(0.0, 1.0);
    f0.add((V { x: f90, y: f90, z: f90 }.sub(f0)).scale(m5))
}

#[inline(always)]
fn schlick_scalar(f0: f32, cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    f0 + (1.0 - f0) * (m * m) * (m * m) * m
}

#[inline(always)]
fn luminance(c: V) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[inline(always)]
fn ggx_d(hz: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let c2 = hz * hz;
    let d = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

#[inline(always)]
fn ggx_lambda(wz: f32, alpha: f32) -> f32 {
    let c2 = wz * wz;
    let tan2 = ((1.0 - c2) / c2).max(0.0);
    let l = 0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0);
    if c2 <= 0.0 {
        f32::INFINITY
    } else {
        l
    }
}

#[inline(always)]
fn ggx_g2(woz: f32, wiz: f32, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(woz, alpha) + ggx_lambda(wiz, alpha))
}

#[inline(always)]
fn ggx_pdf(woz: f32, hz: f32, alpha: f32) -> f32 {
    let g1 = 1.0 / (1.0 + ggx_lambda(woz, alpha));
    g1 * ggx_d(hz, alpha) / (4.0 * woz)
}

/// One lane's BSDF parameters.
#[derive(Clone, Copy)]
struct P {
    diffuse: V,
    diffuse_view: V,
    ms_view: V,
    ms_fresnel: V,
    f0: V,
    alpha: f32,
    clearcoat: f32,
    clearcoat_alpha: f32,
}

impl P {
    #[inline(always)]
    fn at(l: &BsdfLanes, k: usize) -> P {
        P {
            diffuse: V::at(&l.diffuse, k),
            diffuse_view: V::at(&l.diffuse_view, k),
            ms_view: V::at(&l.ms_view, k),
            ms_fresnel: V::at(&l.ms_fresnel, k),
            f0: V::at(&l.f0, k),
            alpha: l.alpha[k],
            clearcoat: l.clearcoat[k],
            clearcoat_alpha: l.clearcoat_alpha[k],
        }
    }

    /// `Bsdf::lobe_probabilities`.
    #[inline(always)]
    fn lobe_probabilities(&self, woz: f32) -> [f32; 3] {
        let coat_f = self.clearcoat * schlick_scalar(CLEARCOAT_F0, woz);
        let base = 1.0 - coat_f;
        let spec_f = schlick(self.f0, woz);
        let one = V { x: 1.0, y: 1.0, z: 1.0 };
        let w_d = base * luminance(self.diffuse.mul(one.sub(spec_f)));
        let w_s = base * luminance(spec_f);
        let total = w_d + w_s + coat_f;
        let probs = [w_d / total, w_s / total, coat_f / total];
        if total <= 0.0 {
            [0.0; 3]
        } else {
            probs
        }
    }

    /// `Bsdf::eval_local` with the lobe probabilities already known; without `COAT` (no lane of
    /// the group has `clearcoat > 0`) the clearcoat lobe's terms are not computed.
    #[inline(always)]
    /// `at_i`: [`albedo::lobe_albedo_ab`] at `wi.z`, looked up in a loop of its own (table reads in
    /// this loop kept LLVM from vectorising it: +12–18 % instructions on the bench scenes).
    fn eval_local<const COAT: bool>(&self, probs: [f32; 3], wo: V, wi: V, at_i: [f32; 2]) -> (V, f32) {
        let h = wo.add(wi).normalize();
        let wo_h = wo.dot(h).max(0.0);
        let denom = 4.0 * wo.z * wi.z;
        let coat_view = self.clearcoat * schlick_scalar(CLEARCOAT_F0, wo.z);
        // `Bsdf::energy_lobes`, through the same per-channel functions, with their view halves kept.
        let (dv, mv, fm, f0) = (self.diffuse_view, self.ms_view, self.ms_fresnel, self.f0);
        let f90 = albedo::f90(f0.x, f0.y, f0.z);
        let [dx, mx] = albedo::light_terms([dv.x, mv.x, fm.x], f0.x, f90, at_i);
        let [dy, my] = albedo::light_terms([dv.y, mv.y, fm.y], f0.y, f90, at_i);
        let [dz, mz] = albedo::light_terms([dv.z, mv.z, fm.z], f0.z, f90, at_i);
        let diffuse = V { x: dx, y: dy, z: dz }.scale(FRAC_1_PI);
        let multiple = V { x: mx, y: my, z: mz }.scale(FRAC_1_PI);
        let specular =
            schlick(self.f0, wo_h).scale(ggx_d(h.z, self.alpha) * ggx_g2(wo.z, wi.z, self.alpha) / denom);
        let f = diffuse.add(specular.add(multiple)).scale(1.0 - coat_view);
        let pdf = probs[0] * wi.z * FRAC_1_PI + probs[1] * ggx_pdf(wo.z, h.z, self.alpha);
        let (f, pdf) = if COAT {
            let a = self.clearcoat_alpha;
            let coat =
                self.clearcoat * schlick_scalar(CLEARCOAT_F0, wo_h) * ggx_d(h.z, a) * ggx_g2(wo.z, wi.z, a)
                    / denom;
            let coat_pdf = pdf + probs[2] * ggx_pdf(wo.z, h.z, a);
            let has_coat = self.clearcoat > 0.0;
            (
                V::select(has_coat, f.add(V { x: coat, y: coat, z: coat }), f),
                if has_coat { coat_pdf } else { pdf },
            )
        } else {
            (f, pdf)
        };
        let below = wo.z <= 0.0 || wi.z <= 0.0;
        let zero = V { x: 0.0, y: 0.0, z: 0.0 };
        (V::select(below, zero, f), if below { 0.0 } else { pdf })
    }
}

#[inline(always)]
fn to_local(l: &BsdfLanes, k: usize, v: V) -> V {
    V { x: v.dot(V::at(&l.t, k)), y: v.dot(V::at(&l.b, k)), z: v.dot(V::at(&l.n, k)) }
}

/// Whether any lane's clearcoat weight is not zero: groups where every lane's is ±0 skip the
/// clearcoat lobe's terms (a second GGX D, G₂ and pdf: two square roots and four divisions per
/// lane) and, in [`sample_lanes`], its probability.
///
/// The test is `clearcoat != 0` rather than `Bsdf::eval_local`'s `clearcoat > 0` so that a lane
/// without the lobe has a zero weight, not a NaN or a negative one: then its probability
/// `coat_f / total` is ±0 whenever the other two are numbers (NaN only when `total` is, and then
/// the diffuse one is NaN too), so the sampler's `p_d + p_s + p_c <= 0` equals `p_d + p_s <= 0`
/// and needs no third division. NaN weights take the variant with the lobe, which masks it off as
/// the scalar code does.
#[inline(always)]
fn any_coat(l: &BsdfLanes) -> bool {
    l.clearcoat.iter().fold(false, |any, &c| any | (c != 0.0))
}

/// [`Bsdf::eval`] on eight lanes: `wi` towards the light, per lane.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn eval_lanes(l: &BsdfLanes, wi: &Lanes3, out: &mut EvalLanes) {
    if any_coat(l) {
        eval_group::<true>(l, wi, out);
    } else {
        eval_group::<false>(l, wi, out);
    }
}

#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn eval_group<const COAT: bool>(l: &BsdfLanes, wi: &Lanes3, out: &mut EvalLanes) {
    let at_i = light_albedo(l, wi);
    for k in 0..LANES {
        let p = P::at(l, k);
        let (wo_w, wi_w) = (V::at(&l.wo, k), V::at(wi, k));
        let wo = to_local(l, k, wo_w);
        let wi_l = to_local(l, k, wi_w);
        let probs = p.lobe_probabilities(wo.z);
        let (f, pdf) = p.eval_local::<COAT>(probs, wo, wi_l, at_i[k]);
        let below_ng = wi_w.dot(V::at(&l.ng, k)) <= 0.0;
        V::select(below_ng, V { x: 0.0, y: 0.0, z: 0.0 }, f).store(&mut out.f, k);
        out.pdf[k] = if below_ng { 0.0 } else { pdf };
    }
}

/// [`albedo::lobe_albedo_ab`] of each lane's lobe at the local cosine of world direction `wi` (the
/// `z` of `to_local`, in its operations).
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn light_albedo(l: &BsdfLanes, wi: &Lanes3) -> [[f32; 2]; LANES] {
    let tables = albedo::tables();
    let mut at = [[0.0; 2]; LANES];
    for k in 0..LANES {
        at[k] = albedo::lobe_albedo_ab(tables, V::at(wi, k).dot(V::at(&l.n, k)), l.alpha[k]);
    }
    at
}

/// [`Bsdf::sample`] on eight lanes.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn sample_lanes(l: &BsdfLanes, u: &SampleInputs, out: &mut SampleLanes) {
    if any_coat(l) {
        sample_group::<true>(l, u, out);
    } else {
        sample_group::<false>(l, u, out);
    }
}

// `!(a <= b)` on purpose: it is how the scalar code's early return treats NaN (it does not return).
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn sample_group<const COAT: bool>(l: &BsdfLanes, u: &SampleInputs, out: &mut SampleLanes) {
    // Before the trigonometry: the local `wo`, the lobe probabilities (kept for the last loop:
    // LLVM does not reuse them across the loops), the lobe, and the angle whose
    // cosine and sine the lobe needs (the concentric disk's θ for the diffuse lobe, the spherical
    // cap's φ for GGX).
    let (mut wo_local, mut probs) = ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3]);
    let mut angle = [0.0f32; LANES];
    let mut diffuse = [false; LANES];
    for k in 0..LANES {
        let p = P::at(l, k);
        let wo = to_local(l, k, V::at(&l.wo, k));
        let lobes = p.lobe_probabilities(wo.z);
        wo.store(&mut wo_local, k);
        (probs[0][k], probs[1][k]) = (lobes[0], lobes[1]);
        if COAT {
            probs[2][k] = lobes[2];
        }
        let (a, b) = (2.0 * u.u0[k] - 1.0, 2.0 * u.u1[k] - 1.0);
        let theta = if a.abs() > b.abs() { FRAC_PI_4 * (b / a) } else { FRAC_PI_2 - FRAC_PI_4 * (a / b) };
        diffuse[k] = u.u_lobe[k] < lobes[0];
        angle[k] = if diffuse[k] { theta } else { TAU * u.u0[k] };
    }
    let (mut cos, mut sin) = ([0.0f32; LANES], [0.0f32; LANES]);
    crate::trig::sin_cos_lanes(&angle, &mut sin, &mut cos);
    // The sampled directions (world, then local, with the lobe's α), then their table lookups, then
    // the evaluation: three loops, so that the lookups' scalar reads leave the other two vectorised.
    let (mut wi_world, mut wi_local, mut lobe_alphas) =
        ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3], [0.0f32; LANES]);
    for k in 0..LANES {
        let p = P::at(l, k);
        let wo = V::at(&wo_local, k);
        let (p_d, p_s) = (probs[0][k], probs[1][k]);
        // Diffuse: the concentric disk lifted to the hemisphere.
        let (a, b) = (2.0 * u.u0[k] - 1.0, 2.0 * u.u1[k] - 1.0);
        let r = if a.abs() > b.abs() { a } else { b };
        let centre = a == 0.0 && b == 0.0;
        let dx = if centre { 0.0 } else { r * cos[k] };
        let dy = if centre { 0.0 } else { r * sin[k] };
        let wi_d = V { x: dx, y: dy, z: (1.0 - dx * dx - dy * dy).max(0.0).sqrt() };
        // GGX visible normals (spherical caps).
        let alpha = if u.u_lobe[k] < p_d + p_s { p.alpha } else { p.clearcoat_alpha };
        let wi_std = V { x: wo.x * alpha, y: wo.y * alpha, z: wo.z }.normalize();
        let z = (1.0 - u.u1[k]) * (1.0 + wi_std.z) - wi_std.z;
        let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let c = V { x: sin_theta * cos[k], y: sin_theta * sin[k], z };
        let h_std = c.add(wi_std);
        let h = V { x: h_std.x * alpha, y: h_std.y * alpha, z: h_std.z }.normalize();
        let wi_g = h.scale(2.0 * wo.dot(h)).sub(wo);
        let wi_l = V::select(diffuse[k], wi_d, wi_g);
        let lobe_alpha = if diffuse[k] { 1.0 } else { alpha };
        let (t, bt, n) = (V::at(&l.t, k), V::at(&l.b, k), V::at(&l.n, k));
        let wi = t.scale(wi_l.x).add(bt.scale(wi_l.y)).add(n.scale(wi_l.z)).normalize();
        wi.store(&mut wi_world, k);
        wi_l.store(&mut wi_local, k);
        lobe_alphas[k] = lobe_alpha;
    }
    let tables = albedo::tables();
    let mut at_i = [[0.0f32; 2]; LANES];
    for k in 0..LANES {
        at_i[k] = albedo::lobe_albedo_ab(tables, wi_local[2][k], l.alpha[k]);
    }
    for k in 0..LANES {
        let p = P::at(l, k);
        let wo = V::at(&wo_local, k);
        // Without the lobe in the group, `p_c` is ±0 or beside a NaN `p_d` ([`any_coat`]).
        let lobes = [probs[0][k], probs[1][k], if COAT { probs[2][k] } else { 0.0 }];
        let [p_d, p_s, p_c] = lobes;
        let (wi, wi_l, lobe_alpha) = (V::at(&wi_world, k), V::at(&wi_local, k), lobe_alphas[k]);
        let (f, pdf) = p.eval_local::<COAT>(lobes, wo, wi_l, at_i[k]);
        let finite = f.x.is_finite() && f.y.is_finite() && f.z.is_finite();
        let ok = !(wo.z <= 0.0)
            && !(p_d + p_s + p_c <= 0.0)
            && !(wi_l.z <= 0.0)
            && !(wi.dot(V::at(&l.ng, k)) <= 0.0)
            && pdf > 0.0
            && finite;
        wi.store(&mut out.wi, k);
        f.store(&mut out.f, k);
        out.pdf[k] = pdf;
        out.lobe_alpha[k] = lobe_alpha;
        out.ok[k] = ok as u32;
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lane-indexed comparisons read clearest as index loops
mod tests {
    use super::*;

    struct Rng(u32);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 = crate::sampler::hash_u32(self.0);
            (self.0 >> 8) as f32 / 16_777_216.0
        }
        fn dir(&mut self) -> Vec3 {
            let z = 2.0 * self.f() - 1.0;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = TAU * self.f();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        }
    }

    fn random_bsdf(rng: &mut Rng) -> (Bsdf, Vec3) {
        let (inputs, ns, ng) = random_inputs(rng);
        let wo = if rng.f() < 0.05 { -ng } else { (ng * 0.3 + rng.dir()).normalize_or(ng) };
        (Bsdf::from_inputs(&inputs, ns, ng), wo)
    }

    /// Shading inputs with NaN, zero, one and out-of-range values among them, and a shading normal
    /// tilted off the geometric one (sometimes past it).
    fn random_inputs(rng: &mut Rng) -> (ShadingInputs, Vec3, Vec3) {
        let pick = |rng: &mut Rng, special: bool| {
            if special && rng.f() < 0.1 {
                [0.0, 1.0, 0.0, 1.0, f32::NAN, 2.0][(rng.f() * 6.0) as usize % 6]
            } else {
                rng.f()
            }
        };
        let inputs = ShadingInputs {
            diffuse_color: Vec3::new(pick(rng, true), pick(rng, true), pick(rng, true)),
            emissive_color: Vec3::ZERO,
            specular_color: Vec3::new(pick(rng, true), pick(rng, false), pick(rng, false)),
            use_specular_workflow: rng.f() < 0.3,
            roughness: pick(rng, true),
            metallic: pick(rng, true),
            ior: if rng.f() < 0.03 { -1.0 } else { 1.0 + 2.0 * pick(rng, true) },
            opacity: 1.0,
            opacity_threshold: 0.0,
            clearcoat: if rng.f() < 0.5 { 0.0 } else { pick(rng, true) },
            clearcoat_roughness: pick(rng, true),
            normal: None,
        };
        let ng = rng.dir();
        let ns = (ng + rng.dir() * (rng.f() * 1.2)).normalize_or(ng);
        (inputs, ns, ng)
    }

    #[test]
    fn construction_lanes_equal_the_scalar_bsdf_bit_for_bit() {
        let mut rng = Rng(13);
        let (mut metallic, mut specular) = (0, 0);
        for _ in 0..2000 {
            let mut inp = InputLanes::default();
            let mut expected = Vec::new();
            for k in 0..LANES {
                let (inputs, ns, ng) = random_inputs(&mut rng);
                inp.set_inputs(k, &inputs, ns, ng);
                expected.push(Bsdf::from_inputs(&inputs, ns, ng));
                specular += inputs.use_specular_workflow as u32;
                metallic += !inputs.use_specular_workflow as u32;
            }
            let mut out = BsdfLanes::default();
            from_inputs_lanes(&inp, &mut out);
            for (k, b) in expected.iter().enumerate() {
                let at = |c: &Lanes3| Vec3::new(c[0][k], c[1][k], c[2][k]);
                let one = |x: f32| bits(Vec3::splat(x));
                assert_eq!(bits(at(&out.t)), bits(b.frame.t), "tangent, lane {k}: {b:?}");
                assert_eq!(bits(at(&out.b)), bits(b.frame.b), "bitangent, lane {k}: {b:?}");
                assert_eq!(bits(at(&out.n)), bits(b.frame.n), "normal, lane {k}");
                assert_eq!(bits(at(&out.ng)), bits(b.ng), "geometric normal, lane {k}");
                assert_eq!(bits(at(&out.diffuse)), bits(b.diffuse), "diffuse, lane {k}: {b:?}");
                assert_eq!(bits(at(&out.f0)), bits(b.f0), "f0, lane {k}: {b:?}");
                assert_eq!(one(out.alpha[k]), one(b.alpha), "alpha, lane {k}");
                assert_eq!(one(out.clearcoat[k]), one(b.clearcoat), "clearcoat, lane {k}");
                assert_eq!(one(out.clearcoat_alpha[k]), one(b.clearcoat_alpha), "coat alpha, lane {k}");
            }
        }
        assert!(
            metallic > 4000 && specular > 2000,
            "both workflows: {metallic} metallic, {specular} specular"
        );
    }

    /// Bits, with every NaN one value (IEEE leaves a NaN's sign and payload open).
    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() })
    }

    #[test]
    fn lanes_equal_the_scalar_bsdf_bit_for_bit_on_random_inputs() {
        let mut rng = Rng(7);
        let (mut evals, mut samples, mut ok, mut coatless_groups) = (0, 0, 0, 0);
        for round in 0..2000 {
            let mut l = BsdfLanes::default();
            let mut bsdfs = Vec::new();
            let mut wi = Lanes3::default();
            let mut u = SampleInputs::default();
            // One group in four has a zero clearcoat weight on every lane (the kernels skip the
            // lobe's terms); NaN weights (from `random_inputs`) take the variant with the lobe.
            let coatless = round % 4 == 0;
            for k in 0..LANES {
                let (mut bsdf, wo) = random_bsdf(&mut rng);
                if coatless {
                    bsdf.clearcoat = if rng.f() < 0.1 { -0.0 } else { 0.0 };
                }
                l.set_bsdf(k, &bsdf, wo);
                let w = if rng.f() < 0.5 { rng.dir() } else { (bsdf.ng + rng.dir()).normalize_or(bsdf.ng) };
                (wi[0][k], wi[1][k], wi[2][k]) = (w.x, w.y, w.z);
                u.u_lobe[k] = rng.f();
                u.u0[k] = if rng.f() < 0.02 { 0.5 } else { rng.f() };
                u.u1[k] = if rng.f() < 0.02 { 0.5 } else { rng.f() };
                bsdfs.push((bsdf, wo, w));
            }
            coatless_groups += !any_coat(&l) as u32;
            let mut e = EvalLanes::default();
            eval_lanes(&l, &wi, &mut e);
            let mut s = SampleLanes::default();
            sample_lanes(&l, &u, &mut s);
            for (k, (bsdf, wo, w)) in bsdfs.iter().enumerate() {
                let (f, pdf) = bsdf.eval(*wo, *w);
                let lane = Vec3::new(e.f[0][k], e.f[1][k], e.f[2][k]);
                assert_eq!(bits(lane), bits(f), "eval f, lane {k}: {bsdf:?} wo {wo} wi {w}");
                assert_eq!(bits(Vec3::splat(e.pdf[k])), bits(Vec3::splat(pdf)), "eval pdf, lane {k}");
                evals += 1;
                let scalar = bsdf.sample(*wo, u.u_lobe[k], [u.u0[k], u.u1[k]]);
                assert_eq!(s.ok[k] != 0, scalar.is_some(), "sample exists, lane {k}: {bsdf:?} wo {wo}");
                if let Some(bs) = scalar {
                    let at = |c: &Lanes3| Vec3::new(c[0][k], c[1][k], c[2][k]);
                    assert_eq!(bits(at(&s.wi)), bits(bs.wi), "sample wi, lane {k}");
                    assert_eq!(bits(at(&s.f)), bits(bs.f), "sample f, lane {k}");
                    assert_eq!(s.pdf[k].to_bits(), bs.pdf.to_bits(), "sample pdf, lane {k}");
                    assert_eq!(s.lobe_alpha[k].to_bits(), bs.lobe_alpha.to_bits(), "lobe α, lane {k}");
                    ok += 1;
                }
                samples += 1;
            }
        }
        eprintln!("{evals} evaluations, {samples} samples ({ok} not absorbed) equal the scalar BSDF");
        assert!(ok > samples / 3, "too few live samples to be a test: {ok} of {samples}");
        assert!((500..1000).contains(&coatless_groups), "{coatless_groups} groups without a clearcoat");
    }
}

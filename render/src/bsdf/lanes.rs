//! The UsdPreviewSurface BSDF ([`crate::bsdf::Bsdf`]) constructed, evaluated and sampled eight
//! shading points at a time, in AoSoA form (`[f32; 8]` columns). Each kernel is loops over the lanes
//! around the branch-free code the scalar BSDF runs ([`Bsdf::from_lane`], [`SeenBsdf`]'s methods)
//! on [`InputLanes`] and [`BsdfLanes`] (a `SeenBsdf` transposed), so each lane equals the scalar
//! result by construction (the tests check it on random inputs, NaN and infinities included).
//! LLVM vectorises the loops to 8-wide AVX2 under [`multiversion`] (chosen at run time, generic
//! fallback elsewhere); the albedo tables' lookups and the sample's sines and cosines
//! ([`crate::trig::sin_cos_lanes`]) run in loops of their own between them.
//!
//! Groups where no lane has a clearcoat weight ([`SeenBsdf::has_coat_terms`]; most groups of the
//! bench scenes) run the `COAT = false` variant, without the lobe's terms. The kernels are bound by
//! the divider, not by the instruction count: every `vdivps` and `vsqrtps` is needed for the scalar
//! code's bits (a product by a reciprocal rounds differently). Tried and dropped: `wo` and the lobe
//! probabilities as [`BsdfLanes`] columns, an AVX-512VL clone, a variant for all-diffuse groups;
//! measurements: `docs/perf.md#bsdf-lanes-bsdflanesrs`.

use crate::bsdf::{albedo, coat_view, fuzz_view, view_halves, Bsdf, BsdfSample, CoatParams};
use crate::shading::ShadingInputs;
use glam::Vec3;

use lanekit::{Lanes, Lanes3, LANES};

lanekit::soa! {
    /// Eight BSDFs seen from their outgoing directions ([`SeenBsdf`]: one lane, whose methods are
    /// the BSDF's mathematics), transposed.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct BsdfLanes for struct SeenBsdf {
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
        /// F82-tint coefficient ([`crate::bsdf::f82_b`]).
        pub f82_b: Vec3 as [f32; 3],
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
        /// Coat colour.
        pub coat_color: Vec3 as [f32; 3],
        /// The coat's Schlick F0.
        pub coat_f0: f32,
        /// `1/η²` of the coat's index.
        pub coat_inv_eta2: f32,
        /// The base's coat-layer weight at `wo` ([`crate::bsdf::coat_view`]).
        pub coat_base: Vec3 as [f32; 3],
        /// The coat's albedo times its weight at `wo`.
        pub coat_p: f32,
        /// Fuzz weight.
        pub fuzz: f32,
        /// Fuzz colour.
        pub fuzz_color: Vec3 as [f32; 3],
        /// Fuzz roughness.
        pub fuzz_roughness: f32,
        /// The fuzz's albedo times its weight at `wo` ([`crate::bsdf::fuzz_view`]).
        pub fuzz_p: f32,
    }
}

impl BsdfLanes {
    /// Writes `bsdf` seen from `wo` into lane `k`.
    #[inline]
    pub fn set_bsdf(&mut self, k: usize, bsdf: &Bsdf, wo: Vec3) {
        self.set(k, &bsdf.seen_from(wo));
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
        /// OpenPBR `specular_weight`.
        pub specular_weight: f32,
        /// OpenPBR `specular_color` (`specular_tint`).
        pub specular_tint: Vec3 as [f32; 3],
        /// `clearcoatRoughness`.
        pub clearcoat_roughness: f32,
        /// OpenPBR `coat_color`.
        pub coat_color: Vec3 as [f32; 3],
        /// OpenPBR `coat_ior`.
        pub coat_ior: f32,
        /// OpenPBR `fuzz_weight`.
        pub fuzz_weight: f32,
        /// OpenPBR `fuzz_color`.
        pub fuzz_color: Vec3 as [f32; 3],
        /// OpenPBR `fuzz_roughness`.
        pub fuzz_roughness: f32,
        /// Unit shading normal on the side of the viewer.
        pub ns: Vec3 as [f32; 3],
        /// Unit geometric normal on the side of the viewer.
        pub ng: Vec3 as [f32; 3],
    }
}

impl InputLane {
    /// The inputs the BSDF reads of `inputs` at a point with normals `ns` and `ng` (not emission,
    /// opacity or the normal map, which phase 1 has applied).
    #[inline(always)]
    pub fn new(inputs: &ShadingInputs, ns: Vec3, ng: Vec3) -> Self {
        InputLane {
            diffuse_color: inputs.diffuse_color,
            specular_color: inputs.specular_color,
            use_specular_workflow: inputs.use_specular_workflow,
            roughness: inputs.roughness,
            metallic: inputs.metallic,
            ior: inputs.ior,
            clearcoat: inputs.clearcoat,
            specular_weight: inputs.specular_weight,
            specular_tint: inputs.specular_tint,
            clearcoat_roughness: inputs.clearcoat_roughness,
            coat_color: inputs.coat_color,
            coat_ior: inputs.coat_ior,
            fuzz_weight: inputs.fuzz_weight,
            fuzz_color: inputs.fuzz_color,
            fuzz_roughness: inputs.fuzz_roughness,
            ns,
            ng,
        }
    }
}

impl InputLanes {
    /// Writes `inputs` at a point with normals `ns` and `ng` into lane `k` ([`InputLane::new`]).
    #[inline]
    pub fn set_inputs(&mut self, k: usize, inputs: &ShadingInputs, ns: Vec3, ng: Vec3) {
        self.set(k, &InputLane::new(inputs, ns, ng));
    }
}

/// [`Bsdf::from_inputs`] on eight lanes, seen from the directions `out.wo` already holds: the
/// BSDFs ([`Bsdf::from_lane`]) in one loop, their view halves (table lookups) in another.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn from_inputs_lanes(inp: &InputLanes, out: &mut BsdfLanes) {
    for k in 0..LANES {
        let wo = at(&out.wo, k);
        out.set(k, &Bsdf::from_lane(&inp.get(k)).seen_with(wo, [Vec3::ZERO; 3], (Vec3::ZERO, 0.0), 0.0));
    }
    let tables = albedo::tables();
    for k in 0..LANES {
        let (d, f0, n, wo) = (at(&out.diffuse, k), at(&out.f0, k), at(&out.n, k), at(&out.wo, k));
        let [dv, mv, fm] = view_halves(tables, d, f0, at(&out.f82_b, k), out.alpha[k], wo.dot(n));
        for c in 0..3 {
            (out.diffuse_view[c][k], out.ms_view[c][k], out.ms_fresnel[c][k]) = (dv[c], mv[c], fm[c]);
        }
    }
    // The coat's view halves (a lookup and three powers per lane) only in groups with a coat; a
    // lane without one gets zeros either way (`coat_view` of a zero weight), as the scalar BSDF.
    if any_coat(out) {
        let sheen = albedo::sheen_table();
        for k in 0..LANES {
            let s = out.get(k);
            let (weight, alpha, f0, color, inv_eta2) =
                (s.clearcoat, s.clearcoat_alpha, s.coat_f0, s.coat_color, s.coat_inv_eta2);
            let coat = CoatParams { weight, alpha, f0, color, inv_eta2 };
            let mu_o = s.wo.dot(s.n);
            let (base, p) = coat_view(tables, coat, mu_o);
            for c in 0..3 {
                out.coat_base[c][k] = base[c];
            }
            out.coat_p[k] = p;
            out.fuzz_p[k] = fuzz_view(sheen, s.fuzz, s.fuzz_roughness, mu_o);
        }
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

/// Whether any lane needs the clearcoat lobe's terms ([`SeenBsdf::has_coat_terms`]).
#[inline(always)]
fn any_coat(l: &BsdfLanes) -> bool {
    l.clearcoat.iter().zip(&l.fuzz).fold(false, |any, (&c, &f)| any | (c != 0.0) | (f != 0.0))
}

#[inline(always)]
fn at(c: &Lanes3, k: usize) -> Vec3 {
    Vec3::new(c[0][k], c[1][k], c[2][k])
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

#[inline(always)]
fn eval_group<const COAT: bool>(l: &BsdfLanes, wi: &Lanes3, out: &mut EvalLanes) {
    let (tables, mut at_i) = (albedo::tables(), [[0.0; 3]; LANES]);
    for (k, at_i) in at_i.iter_mut().enumerate() {
        *at_i = l.get(k).light_albedo(tables, at(wi, k).dot(at(&l.n, k)));
    }
    for (k, &at_i) in at_i.iter().enumerate() {
        let (f, pdf) = l.get(k).eval::<COAT>(at(wi, k), at_i);
        out.set(k, &EvalLane { f, pdf });
    }
}

lanekit::soa! {
    /// Eight samples' first steps ([`SeenBsdf::sample_start`]).
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct StartLanes for struct SampleStart {
        /// Local `wo`.
        pub wo: Vec3 as [f32; 3],
        /// Lobe probabilities (diffuse, specular, coat, fuzz).
        pub probs: [f32; 4],
        /// Whether the diffuse lobe was chosen.
        pub diffuse: bool,
        /// The angle whose sine and cosine the chosen lobe needs.
        pub angle: f32,
    }
}

lanekit::soa! {
    /// Eight sampled directions before their evaluation ([`SeenBsdf::sample_direction`]).
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct DirectionLanes for struct SampledDirection {
        /// World space, unit.
        pub wi: Vec3 as [f32; 3],
        /// Local (shading frame).
        pub local: Vec3 as [f32; 3],
        /// GGX α of the chosen lobe (1 for the diffuse lobe).
        pub lobe_alpha: f32,
    }
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

/// The three steps of [`Bsdf::sample`] in loops of their own, with the sines and cosines and the
/// table lookups between them.
#[allow(clippy::needless_range_loop)] // each loop indexes several columns by the lane
#[inline(always)]
fn sample_group<const COAT: bool>(l: &BsdfLanes, u: &SampleInputs, out: &mut SampleLanes) {
    let (mut starts, mut angle) = (StartLanes::default(), [0.0f32; LANES]);
    for k in 0..LANES {
        let start = l.get(k).sample_start(u.u_lobe[k], [u.u0[k], u.u1[k]]);
        angle[k] = start.angle;
        starts.set(k, &start);
    }
    let (mut sin, mut cos): (Lanes, Lanes) = ([0.0; LANES], [0.0; LANES]);
    crate::trig::sin_cos_lanes(&angle, &mut sin, &mut cos);
    let mut dirs = DirectionLanes::default();
    for k in 0..LANES {
        let start = starts.get(k);
        dirs.set(k, &l.get(k).sample_direction(&start, u.u_lobe[k], [u.u0[k], u.u1[k]], sin[k], cos[k]));
    }
    let (tables, mut at_i) = (albedo::tables(), [[0.0f32; 3]; LANES]);
    for (k, at_i) in at_i.iter_mut().enumerate() {
        *at_i = l.get(k).light_albedo(tables, dirs.local[2][k]);
    }
    for (k, &at_i) in at_i.iter().enumerate() {
        let (BsdfSample { wi, f, pdf, lobe_alpha }, ok) =
            l.get(k).sample_finish::<COAT>(&starts.get(k), &dirs.get(k), at_i);
        out.set(k, &SampleLane { wi, f, pdf, lobe_alpha, ok });
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lane-indexed comparisons read clearest as index loops
pub(super) mod tests {
    use super::*;
    use std::f32::consts::TAU;

    pub(in crate::bsdf) struct Rng(pub(in crate::bsdf) u32);
    impl Rng {
        pub(in crate::bsdf) fn f(&mut self) -> f32 {
            self.0 = crate::sampler::hash_u32(self.0);
            (self.0 >> 8) as f32 / 16_777_216.0
        }
        pub(in crate::bsdf) fn dir(&mut self) -> Vec3 {
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
    pub(in crate::bsdf) fn random_inputs(rng: &mut Rng) -> (ShadingInputs, Vec3, Vec3) {
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
            coat_color: Vec3::new(pick(rng, true), pick(rng, false), pick(rng, false)),
            coat_ior: 1.0 + 2.0 * pick(rng, true),
            specular_weight: pick(rng, true),
            specular_tint: Vec3::new(pick(rng, true), pick(rng, false), pick(rng, false)),
            fuzz_weight: if rng.f() < 0.6 { 0.0 } else { pick(rng, true) },
            fuzz_color: Vec3::new(pick(rng, true), pick(rng, false), pick(rng, false)),
            fuzz_roughness: pick(rng, true),
            transmission_color: Vec3::ONE,
            transmission_depth: 0.0,
            thin_walled: false,
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
            let mut out = BsdfLanes::default();
            for k in 0..LANES {
                let (inputs, ns, ng) = random_inputs(&mut rng);
                inp.set_inputs(k, &inputs, ns, ng);
                let wo = (ng * 0.3 + rng.dir()).normalize_or(ng);
                (out.wo[0][k], out.wo[1][k], out.wo[2][k]) = (wo.x, wo.y, wo.z);
                expected.push(Bsdf::from_inputs(&inputs, ns, ng));
                specular += inputs.use_specular_workflow as u32;
                metallic += !inputs.use_specular_workflow as u32;
            }
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
                assert_eq!(bits(at(&out.f82_b)), bits(b.f82_b), "F82 b, lane {k}: {b:?}");
                assert_eq!(one(out.alpha[k]), one(b.alpha), "alpha, lane {k}");
                assert_eq!(one(out.clearcoat[k]), one(b.clearcoat), "clearcoat, lane {k}");
                assert_eq!(one(out.clearcoat_alpha[k]), one(b.clearcoat_alpha), "coat alpha, lane {k}");
                assert_eq!(bits(at(&out.coat_color)), bits(b.coat_color), "coat colour, lane {k}: {b:?}");
                assert_eq!(one(out.coat_f0[k]), one(b.coat_f0), "coat F0, lane {k}");
                assert_eq!(one(out.coat_inv_eta2[k]), one(b.coat_inv_eta2), "coat 1/η², lane {k}");
                let seen = b.seen_from(at(&out.wo));
                assert_eq!(bits(at(&out.coat_base)), bits(seen.coat_base), "coat view, lane {k}: {b:?}");
                assert_eq!(one(out.coat_p[k]), one(seen.coat_p), "coat albedo, lane {k}: {b:?}");
                assert_eq!(one(out.fuzz_p[k]), one(seen.fuzz_p), "fuzz albedo, lane {k}: {b:?}");
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
                    bsdf.fuzz = if rng.f() < 0.1 { -0.0 } else { 0.0 };
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

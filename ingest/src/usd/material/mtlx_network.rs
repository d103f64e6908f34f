//! MaterialX shading networks: UsdShade networks whose shaders carry `info:id = "ND_…"`, inline in
//! a USD layer or translated from a `.mtlx` document ([`crate::usd::mtlx_document`]), read through
//! the Material's `outputs:mtlx:surface`.
//!
//! The renderer's surface is UsdPreviewSurface's inputs ([`blob::preview_surface_constants!`]), so
//! each MaterialX surface model is mapped onto them. Rules (MaterialX and OpenPBR names, their
//! specifications' defaults when unauthored):
//!
//! | UsdPreviewSurface | standard_surface | open_pbr_surface | ND_UsdPreviewSurface |
//! |---|---|---|---|
//! | diffuseColor | `base` · `base_color` (1 · 0.8) | `base_weight` · `base_color` (1 · 0.8) | `diffuseColor` |
//! | metallic | `metalness` (0) | `base_metalness` (0) | `metallic` |
//! | roughness | `specular_roughness` (0.2) | `specular_roughness` (0.3) | `roughness` |
//! | ior | `specular_IOR` (1.5) | `specular_ior` (1.5) | `ior` |
//! | specularColor, useSpecularWorkflow | see below | see below | the same names |
//! | emissiveColor | `emission` · `emission_color` (0 · 1) | `emission_luminance` · `emission_color` (0 · 1) | `emissiveColor` |
//! | clearcoat | `coat` (0) | `coat_weight` (0) | `clearcoat` |
//! | clearcoatRoughness | `coat_roughness` (0.1) | `coat_roughness` (0) | `clearcoatRoughness` |
//! | opacity, opacityThreshold | `transmission` t > 0: 1 − t, threshold 0; else `opacity` (x), threshold 0.5 | `transmission_weight`; else `geometry_opacity` | `opacity`, `opacityThreshold` |
//! | normal (tangent space) | `normal` | `geometry_normal` | `normal` |
//! | coat_color | `coat_color` (1) | `coat_color` (1) | — (1) |
//! | coat_ior | `coat_IOR` (1.5) | `coat_ior` (1.6) | — (1.5) |
//! | specular_weight | `specular` (1) | `specular_weight` (1) | — (1) |
//! | specular_tint (OpenPBR `specular_color`) | `specular_color` (1) | `specular_color` (1) | — (1) |
//! | fuzz_weight | `sheen` (0) | `fuzz_weight` (0) | — (0) |
//! | fuzz_color | `sheen_color` (1) | `fuzz_color` (1) | — (1) |
//! | fuzz_roughness | `sheen_roughness` (0.3) | `fuzz_roughness` (0.5) | — (0.5) |
//! | transmission_color | `transmission_color` (1) | `transmission_color` (1) | — (1) |
//! | transmission_depth | `transmission_depth` (0) | `transmission_depth` (0) | — (0) |
//! | thin_walled | `thin_walled` (false) | `geometry_thin_walled` (false) | — (false) |
//!
//! The last ten rows are OpenPBR parameters the blob keeps beside UsdPreviewSurface's
//! ([`blob::surface_inputs`]); standard_surface's follow the OpenPBR/MaterialX mapping notes
//! (`coat` → `coat_weight`, `coat_IOR` → `coat_ior`, `specular` → `specular_weight`, `sheen*` →
//! `fuzz*`). They are
//! constants: a connected one is one warning and its default, and a value outside the blob's range
//! ([`blob::surface_inputs::OPENPBR_RANGES`]) is clamped with a warning.
//!
//! - **Transmission** is the agreed mapping: opacity `1 − t` with `opacityThreshold` 0 is what the
//!   renderer treats as a transmissive dielectric of `ior` (the spec's clear glass), so
//!   `transmission = 1` is clear glass. Its colour and depth are carried (a tint at depth 0,
//!   else Beer–Lambert absorption inside; `render::bsdf::dielectric`), as is the thin-walled flag;
//!   `transmission_scatter` is not (the interior absorbs, it does not scatter).
//! - **Opacity** (MaterialX presence) is a cut-out: authored or connected, it gets
//!   `opacityThreshold = 0.5`, so that a fractional value is never read as glass.
//! - **Specular weight and colour** are OpenPBR's `specular_weight` and `specular_color`
//!   (standard_surface's `specular`, `specular_color`), carried as they are: the renderer scales
//!   F0 by the weight, tints a dielectric's F0 by the colour and uses it as a metal's F82 edge tint
//!   (`render::bsdf`). Until format 12 a dielectric with either authored became the specular
//!   workflow with `specularColor = weight · colour · F0(ior)`, the same F0.
//! - **Normal**: MaterialX normals are world-space vectors; the renderer's is UsdPreviewSurface's
//!   tangent-space one, so `normal` is read only from a `normalmap` node (its tangent-space result);
//!   any other source is one warning and the interpolated normal.
//! - **Emission**: OpenPBR's `emission_luminance` (nits) is read as radiance 1 per nit unit, like
//!   standard_surface's unitless `emission`.
//! - Lobes the model lacks (subsurface, thin film, anisotropy, coat darkening, ...) are
//!   named in one warning per material when their weight is authored non-zero or connected.
//!
//! Nodes compile to the material program ([`crate::scene::ShaderNode`]); arithmetic is the
//! program's `MATH` op ([`blob::math_op`]), folded at ingest when every operand is constant.
//! Supported categories: `image`, `tiledimage` (`uvtiling`, `uvoffset`), `texcoord`,
//! `geompropvalue`, `UsdPrimvarReader`, `UsdUVTexture`, `UsdTransform2d`, `constant`, `dot`,
//! `normalmap`, `add`, `subtract`, `multiply`, `divide`, `mix`, `clamp`, `power`, `min`, `max`,
//! `invert`, `absval`, `place2d` (constant parameters, SRT order), `extract`, `convert`,
//! `swizzle`, `separate2/3/4`, `combine2/3/4`. An unsupported node (or an unsupported use of one)
//! is one warning naming the node, its category and its file; the inputs it feeds keep their
//! authored value, else the surface model's default.
//!
//! An `image` without a file is its `default` (MaterialX's meaning of an empty `file`), a constant.
//!
//! Value conventions: a float-typed value lives in channel `x` of its register (a float constant
//! in every channel); where a float feeds a vector or colour operation it is broadcast first.
//! Texture colour spaces: `colorSpace` metadata on `inputs:file` (`srgb_texture` → sRGB, any other
//! name → linear); colour images without one are decoded `auto`; float and vector images are
//! always read as stored.

use std::collections::HashMap;

use glam::Vec3;

use super::{vec4, Input, Program, MAX_NODE_DEPTH};
use crate::scene::{Look, Material, MathOp, ShaderNode, ShadingInput};
use crate::usd::stage::Value;
use crate::usd::{Reader, UsdError};

/// A value in a MaterialX network: a constant, or a register of the program.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Val {
    Const([f32; 4]),
    Reg(u32),
}

/// A value and whether it is float-typed (only `x` meaningful in a register).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Typed {
    val: Val,
    float: bool,
}

impl Typed {
    fn constant(v: [f32; 4], float: bool) -> Self {
        Typed { val: Val::Const(v), float }
    }
}

/// The surface models a MaterialX surface shader maps onto UsdPreviewSurface from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Model {
    Standard,
    OpenPbr,
    Preview,
}

impl Model {
    /// The model of a surface shader's `info:id`, if it is one this module maps.
    pub(super) fn of(id: &str) -> Option<Model> {
        match id {
            "ND_standard_surface_surfaceshader" | "ND_standard_surface_surfaceshader_100" => {
                Some(Model::Standard)
            }
            "ND_open_pbr_surface_surfaceshader" => Some(Model::OpenPbr),
            "ND_UsdPreviewSurface_surfaceshader" => Some(Model::Preview),
            _ => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Model::Standard => "standard_surface",
            Model::OpenPbr => "open_pbr_surface",
            Model::Preview => "UsdPreviewSurface",
        }
    }
}

/// Per material: node values compiled so far (a node feeding several inputs is compiled once,
/// and an unsupported one warned about once) and the categories read.
#[derive(Default)]
struct Mx {
    values: HashMap<String, Option<Typed>>,
    /// Constant registers by value bits (shared by every op that needs the constant).
    constants: HashMap<[u32; 4], u32>,
    temporaries: u32,
}

/// The node categories this module knows, longest first where one prefixes another.
const CATEGORIES: &[&str] = &[
    "UsdPrimvarReader",
    "UsdUVTexture",
    "UsdTransform2d",
    "geompropvalueuniform",
    "geompropvalue",
    "tiledimage",
    "image",
    "texcoord",
    "normalmap",
    "constant",
    "multiply",
    "subtract",
    "divide",
    "add",
    "mix",
    "clamp",
    "power",
    "min",
    "max",
    "invert",
    "absval",
    "place2d",
    "extract",
    "convert",
    "swizzle",
    "separate2",
    "separate3",
    "separate4",
    "combine2",
    "combine3",
    "combine4",
    "dot",
];

/// `(category, signature)` of a nodedef name: `ND_multiply_color3FA` → `("multiply", "color3FA")`.
/// Unknown categories split at the last `_` (`ND_hsvtorgb_color3` → `hsvtorgb`).
fn split_nodedef(id: &str) -> (String, String) {
    let rest = id.strip_prefix("ND_").unwrap_or(id);
    for c in CATEGORIES {
        if let Some(sig) = rest.strip_prefix(c) {
            if sig.is_empty() || sig.starts_with('_') {
                return (c.to_string(), sig.trim_start_matches('_').to_string());
            }
        }
    }
    match rest.rsplit_once('_') {
        Some((c, sig)) => (c.to_string(), sig.to_string()),
        None => (rest.to_string(), String::new()),
    }
}

/// The result type of a node from its category and signature.
fn result_type<'s>(category: &str, sig: &'s str) -> &'s str {
    let mut parts = sig.split('_');
    let first = parts.next().unwrap_or("");
    match category {
        "convert" | "swizzle" => sig.rsplit('_').next().unwrap_or(""),
        "extract" => "float",
        "normalmap" => "vector3",
        "texcoord" | "place2d" => "vector2",
        _ => first.strip_suffix("FA").unwrap_or(first),
    }
}

fn is_float_type(ty: &str) -> bool {
    matches!(ty, "float" | "integer" | "boolean")
}

/// The channel a connection reads, for outputs naming one (`outr`, `outx`, `r`, ...).
fn port_channel(output: &str) -> Option<u8> {
    let c = output.strip_prefix("out").filter(|c| c.len() == 1).unwrap_or(output);
    match c {
        "r" | "x" => Some(0),
        "g" | "y" => Some(1),
        "b" | "z" => Some(2),
        "a" | "w" => Some(3),
        _ => None,
    }
}

/// A constant as a `vec4`: scalars in every channel, tuples padded with alpha 1.
fn constant(value: &Value) -> Option<([f32; 4], bool)> {
    match value {
        Value::Scalar(s) => Some(([*s as f32; 4], true)),
        Value::Tuple(t) if !t.is_empty() => Some((vec4(value, [0.0, 0.0, 0.0, 1.0]), false)),
        _ => None,
    }
}

impl Reader<'_> {
    /// Reads a Material whose `outputs:mtlx:surface` is the MaterialX surface `shader` of `model`.
    pub(super) fn mtlx_surface(
        &mut self,
        path: &str,
        shader: &str,
        model: Model,
    ) -> Result<Material, UsdError> {
        let mut m = Material::default();
        let mut program = Program::default();
        let mut mx = Mx::default();
        let p = &mut program;
        let names = |s: &'static str, o: &'static str, u: &'static str| match model {
            Model::Standard => s,
            Model::OpenPbr => o,
            Model::Preview => u,
        };
        // (name, default, float) read on the shader.
        let read =
            |r: &mut Self, mx: &mut Mx, p: &mut Program, name: &str, default: [f32; 4], float: bool| {
                r.mtlx_input(path, shader, name, default, float, p, mx, 0)
            };
        let c3 = |v: f32| [v, v, v, 1.0];
        let f = |v: f32| [v; 4];
        if model == Model::Preview {
            for (name, slot, default) in [
                ("diffuseColor", ShadingInput::DiffuseColor, c3(0.18)),
                ("emissiveColor", ShadingInput::EmissiveColor, c3(0.0)),
                ("specularColor", ShadingInput::SpecularColor, c3(0.0)),
            ] {
                let v = read(self, &mut mx, p, name, default, false)?;
                self.bind(&mut m, p, slot, v);
            }
            for (name, slot, default) in [
                ("roughness", ShadingInput::Roughness, 0.5),
                ("metallic", ShadingInput::Metallic, 0.0),
                ("ior", ShadingInput::Ior, 1.5),
                ("opacity", ShadingInput::Opacity, 1.0),
                ("clearcoat", ShadingInput::Clearcoat, 0.0),
                ("clearcoatRoughness", ShadingInput::ClearcoatRoughness, 0.01),
            ] {
                let v = read(self, &mut mx, p, name, f(default), true)?;
                self.bind(&mut m, p, slot, v);
            }
            if let Val::Const(v) = read(self, &mut mx, p, "opacityThreshold", f(0.0), true)?.val {
                m.opacity_threshold = v[0];
            }
            if let Val::Const(v) = read(self, &mut mx, p, "useSpecularWorkflow", f(0.0), true)?.val {
                m.use_specular_workflow = v[0] != 0.0;
            }
            self.mtlx_normal(path, shader, "normal", p, &mut mx)?;
        } else {
            let open = model == Model::OpenPbr;
            let base = read(self, &mut mx, p, names("base", "base_weight", ""), f(1.0), true)?;
            let base_color = read(self, &mut mx, p, "base_color", c3(0.8), false)?;
            let diffuse = self.combine(p, &mut mx, MathOp::Multiply, [base_color, base, base_color], false);
            self.bind(&mut m, p, ShadingInput::DiffuseColor, diffuse);
            let metal = read(self, &mut mx, p, names("metalness", "base_metalness", ""), f(0.0), true)?;
            self.bind(&mut m, p, ShadingInput::Metallic, metal);
            let roughness = if open { 0.3 } else { 0.2 };
            let rough = read(self, &mut mx, p, "specular_roughness", f(roughness), true)?;
            self.bind(&mut m, p, ShadingInput::Roughness, rough);
            let ior = read(self, &mut mx, p, names("specular_IOR", "specular_ior", ""), f(1.5), true)?;
            self.bind(&mut m, p, ShadingInput::Ior, ior);
            let amount = read(self, &mut mx, p, names("emission", "emission_luminance", ""), f(0.0), true)?;
            let emission_color = read(self, &mut mx, p, "emission_color", c3(1.0), false)?;
            let emission =
                self.combine(p, &mut mx, MathOp::Multiply, [emission_color, amount, emission_color], false);
            self.bind(&mut m, p, ShadingInput::EmissiveColor, emission);
            let coat = read(self, &mut mx, p, names("coat", "coat_weight", ""), f(0.0), true)?;
            self.bind(&mut m, p, ShadingInput::Clearcoat, coat);
            let coat_roughness = if open { 0.0 } else { 0.1 };
            let coat_rough = read(self, &mut mx, p, "coat_roughness", f(coat_roughness), true)?;
            self.bind(&mut m, p, ShadingInput::ClearcoatRoughness, coat_rough);
            let [cc, ci, sw, st, fw, fc, fr, tc, td] = blob::surface_inputs::OPENPBR_RANGES;
            let coat_color =
                self.openpbr_constant(path, shader, names("coat_color", "coat_color", ""), 1.0, cc)?;
            m.coat_color = Vec3::from_slice(&coat_color[..3]);
            let coat_ior = if open { 1.6 } else { 1.5 };
            m.coat_ior =
                self.openpbr_constant(path, shader, names("coat_IOR", "coat_ior", ""), coat_ior, ci)?[0];
            let weight_name = names("specular", "specular_weight", "");
            m.specular_weight = self.openpbr_constant(path, shader, weight_name, 1.0, sw)?[0];
            let tint = self.openpbr_constant(path, shader, "specular_color", 1.0, st)?;
            m.specular_tint = Vec3::from_slice(&tint[..3]);
            let fuzz_weight = names("sheen", "fuzz_weight", "");
            m.fuzz_weight = self.openpbr_constant(path, shader, fuzz_weight, 0.0, fw)?[0];
            let fuzz =
                self.openpbr_constant(path, shader, names("sheen_color", "fuzz_color", ""), 1.0, fc)?;
            m.fuzz_color = Vec3::from_slice(&fuzz[..3]);
            let (name, default) = if open { ("fuzz_roughness", 0.5) } else { ("sheen_roughness", 0.3) };
            m.fuzz_roughness = self.openpbr_constant(path, shader, name, default, fr)?[0];
            let color = self.openpbr_constant(path, shader, "transmission_color", 1.0, tc)?;
            m.transmission_color = Vec3::from_slice(&color[..3]);
            m.transmission_depth = self.openpbr_constant(path, shader, "transmission_depth", 0.0, td)?[0];
            let thin = names("thin_walled", "geometry_thin_walled", "");
            m.thin_walled = self.openpbr_constant(path, shader, thin, 0.0, ("", 0.0, 1.0))?[0] != 0.0;
            let transmission =
                read(self, &mut mx, p, names("transmission", "transmission_weight", ""), f(0.0), true)?;
            if transmission.val != Val::Const(f(0.0)) {
                let one = Typed::constant(f(1.0), true);
                let opacity = self.combine(p, &mut mx, MathOp::Subtract, [one, transmission, one], true);
                self.bind(&mut m, p, ShadingInput::Opacity, opacity);
                m.opacity_threshold = 0.0;
            } else {
                // standard_surface's opacity is a colour; OpenPBR's geometry_opacity a float.
                let name = names("opacity", "geometry_opacity", "");
                let opacity = read(self, &mut mx, p, name, f(1.0), true)?;
                if opacity.val != Val::Const(f(1.0)) {
                    self.bind(&mut m, p, ShadingInput::Opacity, opacity);
                    m.opacity_threshold = 0.5;
                }
            }
            self.mtlx_normal(path, shader, names("normal", "geometry_normal", ""), p, &mut mx)?;
            self.unmapped_lobes(path, shader, model)?;
        }
        self.warn_displacement(path);
        m.look = Look {
            surface_model: model.name().into(),
            node_categories: std::mem::take(&mut program.categories).into_iter().collect(),
        };
        m.program = program.nodes;
        Ok(m)
    }

    /// The constant value of OpenPBR parameter `name` of `shader` (`default` when unauthored, in
    /// every channel), clamped into its blob range `(_, lo, hi)` ([`blob::surface_inputs::OPENPBR_RANGES`])
    /// with a warning when outside it or not finite. These parameters are constants in the blob
    /// (no program op writes them): a connected one is one warning and the default.
    fn openpbr_constant(
        &mut self,
        path: &str,
        shader: &str,
        name: &str,
        default: f32,
        (_, lo, hi): (&str, f32, f32),
    ) -> Result<[f32; 4], UsdError> {
        match self.trace_input(shader, &format!("inputs:{name}"))? {
            Input::Unauthored => Ok([default; 4]),
            Input::Network { node, .. } => {
                self.warn(
                    path,
                    format!("{name} reads {node}: only a constant {name} is carried; using {default}"),
                );
                Ok([default; 4])
            }
            Input::Constant { value, .. } => {
                let v = vec4(&value, [default; 4]);
                let clamped = v.map(|x| if x.is_nan() { default } else { x.clamp(lo, hi) });
                if clamped[..3] != v[..3] {
                    let shown = |c: &[f32]| match c {
                        [x, y, z, ..] if x == y && y == z => format!("{x}"),
                        c => format!("{:?}", &c[..3]),
                    };
                    let (v, c) = (shown(&v), shown(&clamped));
                    self.warn(
                        path,
                        format!("{name} = {v} outside [{lo}, {hi}] (or not finite); clamped to {c}"),
                    );
                }
                Ok(clamped)
            }
        }
    }

    /// `outputs:mtlx:displacement` is not rendered: one warning.
    fn warn_displacement(&mut self, path: &str) {
        if !self.stage.connections(path, "outputs:mtlx:displacement").is_empty() {
            self.warn(path, "MaterialX displacement ignored");
        }
    }

    /// One warning naming the lobes of `model` the renderer's surface lacks that `shader` uses.
    fn unmapped_lobes(&mut self, path: &str, shader: &str, model: Model) -> Result<(), UsdError> {
        let lobes: &[&str] = match model {
            Model::Standard => &[
                "subsurface",
                "thin_film_thickness",
                "specular_anisotropy",
                "coat_anisotropy",
                "transmission_scatter_anisotropy",
                "transmission_dispersion",
            ],
            Model::OpenPbr => &[
                "subsurface_weight",
                "thin_film_weight",
                "specular_anisotropy",
                "coat_darkening",
                "transmission_dispersion_scale",
            ],
            Model::Preview => &[],
        };
        let mut used = Vec::new();
        for lobe in lobes {
            let used_here = match self.trace_input(shader, &format!("inputs:{lobe}"))? {
                Input::Unauthored => false,
                Input::Constant { value, .. } => value.as_f64().is_none_or(|v| v != 0.0),
                Input::Network { .. } => true,
            };
            if used_here {
                used.push(*lobe);
            }
        }
        if !used.is_empty() {
            self.warn(
                path,
                format!(
                    "{} {} not in the renderer's surface model (UsdPreviewSurface); ignored",
                    model.name(),
                    used.join(", ")
                ),
            );
        }
        Ok(())
    }

    /// Reads the surface's `normal` input: from a `normalmap` node only (see the module docs).
    fn mtlx_normal(
        &mut self,
        path: &str,
        shader: &str,
        name: &str,
        p: &mut Program,
        mx: &mut Mx,
    ) -> Result<(), UsdError> {
        let attr = format!("inputs:{name}");
        let Input::Network { node, .. } = self.trace_input(shader, &attr)? else { return Ok(()) };
        let id = self.token(&node, "info:id")?.unwrap_or_default();
        let (category, _) = split_nodedef(&id);
        let tangent = category == "normalmap" || (id == "UsdUVTexture" && name == "normal");
        if !tangent {
            self.warn(
                path,
                format!(
                    "{name} reads {node} ({category}), not a normalmap: a world-space normal the renderer cannot take; using the interpolated normal"
                ),
            );
            return Ok(());
        }
        let v = self.mtlx_input(path, shader, name, [0.0, 0.0, 1.0, 1.0], false, p, mx, 0)?;
        if let Val::Reg(src) = v.val {
            p.nodes.push(ShaderNode::Output { input: ShadingInput::Normal, src, swizzle: [0, 1, 2, 3] });
        }
        Ok(())
    }

    /// Binds a value to a surface input: a constant into the material, a register by an output.
    fn bind(&mut self, m: &mut Material, p: &mut Program, slot: ShadingInput, v: Typed) {
        match v.val {
            Val::Const(c) => {
                let rgb = Vec3::new(c[0], c[1], c[2]);
                match slot {
                    ShadingInput::DiffuseColor => m.diffuse_color = rgb,
                    ShadingInput::EmissiveColor => m.emissive_color = rgb,
                    ShadingInput::SpecularColor => m.specular_color = rgb,
                    ShadingInput::Roughness => m.roughness = c[0],
                    ShadingInput::Metallic => m.metallic = c[0],
                    ShadingInput::Opacity => m.opacity = c[0],
                    ShadingInput::Clearcoat => m.clearcoat = c[0],
                    ShadingInput::ClearcoatRoughness => m.clearcoat_roughness = c[0],
                    ShadingInput::Ior => m.ior = c[0],
                    ShadingInput::Normal => {}
                }
            }
            Val::Reg(src) => {
                let swizzle = if v.float { [0; 4] } else { [0, 1, 2, 3] };
                p.nodes.push(ShaderNode::Output { input: slot, src, swizzle });
            }
        }
    }

    /// The value of input `name` of MaterialX node `node`: its constant, the compiled node it
    /// connects to, else `default`. An input connected to a node that cannot be compiled keeps
    /// its own authored value if it has one, else `default`.
    #[allow(clippy::too_many_arguments)]
    fn mtlx_input(
        &mut self,
        material: &str,
        node: &str,
        name: &str,
        default: [f32; 4],
        float: bool,
        p: &mut Program,
        mx: &mut Mx,
        depth: u32,
    ) -> Result<Typed, UsdError> {
        let attr = format!("inputs:{name}");
        let fallback = |r: &mut Self| -> Result<Typed, UsdError> {
            Ok(match r.stage.attr(node, &attr)?.as_ref().and_then(constant) {
                Some((v, f)) => Typed::constant(v, f),
                None => Typed::constant(default, float),
            })
        };
        match self.trace_input(node, &attr)? {
            Input::Unauthored => Ok(Typed::constant(default, float)),
            Input::Constant { value, .. } => Ok(match constant(&value) {
                Some((v, f)) => Typed::constant(v, f),
                None => Typed::constant(default, float),
            }),
            Input::Network { node: source, output } => {
                let Some(value) = self.mtlx_node(material, &source, p, mx, depth + 1)? else {
                    return fallback(self);
                };
                match (port_channel(&output), value.val) {
                    (Some(c), Val::Const(v)) => Ok(Typed::constant([v[c as usize]; 4], true)),
                    (Some(0), Val::Reg(_)) => Ok(Typed { float: true, ..value }),
                    (Some(c), Val::Reg(_)) => {
                        Ok(self.math(p, mx, MathOp::Swizzle([c; 4]), [value; 3], true).unwrap_or(value))
                    }
                    (None, _) => Ok(value),
                }
            }
        }
    }

    /// A register holding `v` (constants share one register per value), or `None` when the file is full.
    fn register_of(&mut self, p: &mut Program, mx: &mut Mx, v: Val) -> Option<u32> {
        match v {
            Val::Reg(r) => Some(r),
            Val::Const(c) => {
                let bits = c.map(f32::to_bits);
                if let Some(&r) = mx.constants.get(&bits) {
                    return Some(r);
                }
                let dst = p.register()?;
                mx.temporaries += 1;
                p.registers.insert(format!("#const{}", mx.temporaries), dst);
                p.nodes.push(ShaderNode::Const { dst, value: c });
                mx.constants.insert(bits, dst);
                Some(dst)
            }
        }
    }

    /// `op` of three operands, folded when all are constant; float operands of a non-float
    /// operation are broadcast first. `None` when the register file is full.
    fn math(
        &mut self,
        p: &mut Program,
        mx: &mut Mx,
        op: MathOp,
        operands: [Typed; 3],
        float: bool,
    ) -> Option<Typed> {
        if let [Val::Const(a), Val::Const(b), Val::Const(c)] = operands.map(|o| o.val) {
            return Some(Typed::constant(blob::math(op.flags(), a, b, c), float));
        }
        // Identities (a texture times the default weight 1) cost neither an op nor a register.
        let is = |o: Typed, v: f32| o.val == Val::Const([v; 4]);
        let [a, b, _] = operands;
        let kept = match op {
            MathOp::Multiply if is(b, 1.0) => Some(a),
            MathOp::Multiply if is(a, 1.0) => Some(b),
            MathOp::Add if is(b, 0.0) => Some(a),
            MathOp::Add if is(a, 0.0) => Some(b),
            MathOp::Subtract if is(b, 0.0) => Some(a),
            _ => None,
        };
        if let Some(kept) = kept.filter(|k| k.float == float || !k.float) {
            return Some(Typed { float, ..kept });
        }
        let mut srcs = [0u32; 3];
        for (i, o) in operands.iter().enumerate() {
            let mut r = self.register_of(p, mx, o.val)?;
            if o.float && !float && matches!(o.val, Val::Reg(_)) {
                r = self.emit(p, mx, |dst| ShaderNode::Math {
                    dst,
                    op: MathOp::Swizzle([0; 4]),
                    srcs: [r; 3],
                })?;
            }
            srcs[i] = r;
        }
        let dst = self.emit(p, mx, |dst| ShaderNode::Math { dst, op, srcs })?;
        Some(Typed { val: Val::Reg(dst), float })
    }

    /// [`Self::math`] for a surface mapping, keeping the first operand when the file is full.
    fn combine(
        &mut self,
        p: &mut Program,
        mx: &mut Mx,
        op: MathOp,
        operands: [Typed; 3],
        float: bool,
    ) -> Typed {
        self.math(p, mx, op, operands, float).unwrap_or(operands[0])
    }

    /// Appends a temporary node writing a fresh register.
    fn emit(&mut self, p: &mut Program, mx: &mut Mx, node: impl FnOnce(u32) -> ShaderNode) -> Option<u32> {
        let dst = p.register()?;
        mx.temporaries += 1;
        p.registers.insert(format!("#tmp{}", mx.temporaries), dst);
        p.nodes.push(node(dst));
        Some(dst)
    }

    /// One warning on an unsupported MaterialX node, naming its category and file.
    fn unsupported(&mut self, node: &str, id: &str, category: &str, why: &str) {
        let file = self.stage.authoring_layer(node, "info:id");
        self.warn(
            node,
            format!(
                "MaterialX node {category:?} ({id}) in {file}: {why}; the inputs it feeds keep their authored value or default"
            ),
        );
    }

    /// Compiles MaterialX node `node` (and what it reads); `None` when it cannot be (warned once).
    fn mtlx_node(
        &mut self,
        material: &str,
        node: &str,
        p: &mut Program,
        mx: &mut Mx,
        depth: u32,
    ) -> Result<Option<Typed>, UsdError> {
        if let Some(v) = mx.values.get(node) {
            return Ok(*v);
        }
        let id = self.token(node, "info:id")?.unwrap_or_default();
        let (category, sig) = split_nodedef(&id);
        p.categories.insert(category.clone());
        if depth > MAX_NODE_DEPTH {
            self.unsupported(node, &id, &category, "network nested too deeply (a cycle?)");
            mx.values.insert(node.to_string(), None);
            return Ok(None);
        }
        let result = self.mtlx_compile(material, node, &category, &sig, p, mx, depth)?;
        let value = match result {
            Ok(v) => Some(v),
            Err(why) => {
                self.unsupported(node, &id, &category, &why);
                None
            }
        };
        mx.values.insert(node.to_string(), value);
        Ok(value)
    }

    #[allow(clippy::too_many_arguments)]
    fn mtlx_compile(
        &mut self,
        material: &str,
        node: &str,
        category: &str,
        sig: &str,
        p: &mut Program,
        mx: &mut Mx,
        depth: u32,
    ) -> Result<Result<Typed, String>, UsdError> {
        let ty = result_type(category, sig);
        let float = is_float_type(ty);
        let full = || Err("material network has more registers than the program holds".to_string());
        let zero = [0.0; 4];
        let one = [1.0; 4];
        macro_rules! input {
            ($name:expr, $default:expr) => {
                self.mtlx_input(material, node, $name, $default, float, p, mx, depth)?
            };
        }
        macro_rules! math {
            ($op:expr, $a:expr, $b:expr, $c:expr) => {{
                let operands = [$a, $b, $c];
                match self.math(p, mx, $op, operands, float) {
                    Some(v) => Ok(v),
                    None => full(),
                }
            }};
        }
        let value = match category {
            // Nodes the UsdPreviewSurface compiler reads (same inputs under an ND_ name).
            "UsdUVTexture" | "UsdTransform2d" | "UsdPrimvarReader" => {
                let usd_id = match category {
                    "UsdPrimvarReader" if sig == "vector2" => "UsdPrimvarReader_float2".to_string(),
                    "UsdPrimvarReader" => {
                        format!("UsdPrimvarReader_{}", if sig.is_empty() { "float" } else { sig })
                    }
                    other => other.to_string(),
                };
                match self.compile_usd_node(material, node, &usd_id, p, depth)? {
                    Some(r) => Ok(Typed { val: Val::Reg(r), float }),
                    None => full(),
                }
            }
            "constant" => Ok(input!("value", zero)),
            "dot" => Ok(input!("in", zero)),
            "texcoord" => {
                let index = self.f64(node, "inputs:index")?.unwrap_or(0.0);
                if index != 0.0 {
                    return Ok(Err(format!(
                        "texture coordinate set {index} (only set 0, the mesh's uvs, is carried)"
                    )));
                }
                match self.uv_register(p) {
                    Some(r) => Ok(Typed { val: Val::Reg(r), float: false }),
                    None => full(),
                }
            }
            "geompropvalue" | "geompropvalueuniform" => {
                let name = self.token(node, "inputs:geomprop")?.unwrap_or_default();
                let default = input!("default", zero);
                let Val::Const(fallback) = default.val else {
                    return Ok(Err("a connected default is not supported".into()));
                };
                let name = name.strip_prefix("primvars:").unwrap_or(&name).to_string();
                if name.is_empty() {
                    Ok(default)
                } else if ty == "vector2" && matches!(name.as_str(), "st" | "uv" | "UVMap" | "st0" | "map1") {
                    match self.uv_register(p) {
                        Some(r) => Ok(Typed { val: Val::Reg(r), float: false }),
                        None => full(),
                    }
                } else {
                    match self.emit(p, mx, |dst| ShaderNode::Primvar { dst, name, fallback }) {
                        Some(r) => Ok(Typed { val: Val::Reg(r), float }),
                        None => full(),
                    }
                }
            }
            "image" | "tiledimage" => self.mtlx_image(material, node, category, ty, p, mx, depth)?,
            "normalmap" => {
                let n = self.mtlx_input(material, node, "in", [0.5, 0.5, 1.0, 1.0], false, p, mx, depth)?;
                let scale = self.mtlx_input(material, node, "scale", one, true, p, mx, depth)?;
                let space = self.token(node, "inputs:space")?;
                if space.as_deref().is_some_and(|s| s != "tangent") {
                    return Ok(Err(format!("normalmap space {space:?} (only tangent space is supported)")));
                }
                // The scale multiplies x and y only: keep it a float (not broadcast).
                match self.math(p, mx, MathOp::NormalMap, [n, Typed { float: false, ..scale }, n], false) {
                    Some(v) => Ok(v),
                    None => full(),
                }
            }
            "add" => math!(MathOp::Add, input!("in1", zero), input!("in2", zero), input!("in1", zero)),
            "subtract" => {
                math!(MathOp::Subtract, input!("in1", zero), input!("in2", zero), input!("in1", zero))
            }
            "multiply" => {
                math!(MathOp::Multiply, input!("in1", zero), input!("in2", one), input!("in1", zero))
            }
            "divide" => math!(MathOp::Divide, input!("in1", zero), input!("in2", one), input!("in1", zero)),
            "power" => math!(MathOp::Power, input!("in1", zero), input!("in2", one), input!("in1", zero)),
            "min" => math!(MathOp::Min, input!("in1", zero), input!("in2", zero), input!("in1", zero)),
            "max" => math!(MathOp::Max, input!("in1", zero), input!("in2", zero), input!("in1", zero)),
            "mix" => math!(MathOp::Mix, input!("fg", zero), input!("bg", zero), input!("mix", zero)),
            "clamp" => math!(MathOp::Clamp, input!("in", zero), input!("low", zero), input!("high", one)),
            "invert" => {
                math!(MathOp::Subtract, input!("amount", one), input!("in", zero), input!("in", zero))
            }
            "absval" => math!(MathOp::Absolute, input!("in", zero), input!("in", zero), input!("in", zero)),
            "extract" => {
                let index = self.f64(node, "inputs:index")?.unwrap_or(0.0);
                if !(0.0..4.0).contains(&index) {
                    return Ok(Err(format!("extract index {index} out of range")));
                }
                let v = self.mtlx_input(material, node, "in", zero, false, p, mx, depth)?;
                math!(MathOp::Swizzle([index as u8; 4]), v, v, v)
            }
            "convert" => {
                let from = sig.split('_').next().unwrap_or("");
                let v = self.mtlx_input(material, node, "in", zero, is_float_type(from), p, mx, depth)?;
                if v.float && !float {
                    math!(MathOp::Swizzle([0; 4]), v, v, v)
                } else {
                    Ok(Typed { float, ..v })
                }
            }
            "swizzle" => {
                let channels = self.token(node, "inputs:channels")?.unwrap_or_default();
                let picks: Option<Vec<u8>> = channels.chars().map(|c| port_channel(&c.to_string())).collect();
                match picks.filter(|p| (1..=4).contains(&p.len())) {
                    None => Err(format!(
                        "swizzle channels {channels:?} (only r/g/b/a and x/y/z/w picks are supported)"
                    )),
                    Some(picks) => {
                        let from = sig.split('_').next().unwrap_or("");
                        let v =
                            self.mtlx_input(material, node, "in", zero, is_float_type(from), p, mx, depth)?;
                        let s = std::array::from_fn(|i| picks[i.min(picks.len() - 1)]);
                        match (v.float, float) {
                            (true, true) => Ok(v),
                            (true, false) => math!(MathOp::Swizzle([0; 4]), v, v, v),
                            (false, _) => math!(MathOp::Swizzle(s), v, v, v),
                        }
                    }
                }
            }
            "separate2" | "separate3" | "separate4" => Ok(Typed { float: false, ..input!("in", zero) }),
            "combine2" | "combine3" | "combine4" => {
                let n = (category.as_bytes()[7] - b'0') as usize;
                let mut sum = Typed::constant([0.0, 0.0, 0.0, if n < 4 { 1.0 } else { 0.0 }], false);
                for i in 0..n {
                    let part =
                        self.mtlx_input(material, node, &format!("in{}", i + 1), zero, true, p, mx, depth)?;
                    let mut unit = [0.0; 4];
                    unit[i] = 1.0;
                    // A float register is broadcast by `math` before the product.
                    let part = Typed { float: true, ..part };
                    let unit = Typed::constant(unit, false);
                    let Some(spread) = self.math(p, mx, MathOp::Multiply, [part, unit, part], false) else {
                        return Ok(full());
                    };
                    let Some(next) = self.math(p, mx, MathOp::Add, [sum, spread, sum], false) else {
                        return Ok(full());
                    };
                    sum = next;
                }
                Ok(sum)
            }
            "place2d" => {
                let uv = self.mtlx_input(material, node, "texcoord", zero, false, p, mx, depth)?;
                let pair = |r: &mut Self, name: &str, d: [f32; 2]| -> Result<Option<[f32; 2]>, UsdError> {
                    Ok(match r.trace_input(node, &format!("inputs:{name}"))? {
                        Input::Unauthored => Some(d),
                        Input::Constant { value, .. } => Some(match constant(&value) {
                            Some((v, _)) => [v[0], v[1]],
                            None => d,
                        }),
                        Input::Network { .. } => None,
                    })
                };
                let (Some(pivot), Some(scale), Some(offset), Some(rotate)) = (
                    pair(self, "pivot", [0.0; 2])?,
                    pair(self, "scale", [1.0; 2])?,
                    pair(self, "offset", [0.0; 2])?,
                    pair(self, "rotate", [0.0; 2])?,
                ) else {
                    return Ok(Err("connected place2d parameters are not supported".into()));
                };
                if self.f64(node, "inputs:operationorder")?.unwrap_or(0.0) != 0.0 {
                    return Ok(Err("place2d operationorder other than 0 (SRT)".into()));
                }
                // out = R(rotate) · ((uv − pivot) / scale) − offset + pivot, as one UsdTransform2d.
                let s = [1.0 / scale[0], 1.0 / scale[1]];
                let (sin, cos) = rotate[0].to_radians().sin_cos();
                let rp = [s[0] * pivot[0], s[1] * pivot[1]];
                let translation = [
                    pivot[0] - offset[0] - (cos * rp[0] - sin * rp[1]),
                    pivot[1] - offset[1] - (sin * rp[0] + cos * rp[1]),
                ];
                self.transform_uv(p, mx, uv, rotate[0], s, translation)
            }
            _ => Err("not supported".to_string()),
        };
        Ok(value)
    }

    /// A UsdTransform2d of texture coordinates `uv` (kept as the transform op, so the footprint
    /// derivatives follow the coordinates to the texture lookup).
    fn transform_uv(
        &mut self,
        p: &mut Program,
        mx: &mut Mx,
        uv: Typed,
        rotation_degrees: f32,
        scale: [f32; 2],
        translation: [f32; 2],
    ) -> Result<Typed, String> {
        if let Val::Const(c) = uv.val {
            let (sin, cos) = rotation_degrees.to_radians().sin_cos();
            let (x, y) = (c[0] * scale[0], c[1] * scale[1]);
            return Ok(Typed::constant(
                [cos * x - sin * y + translation[0], sin * x + cos * y + translation[1], c[2], c[3]],
                false,
            ));
        }
        let Some(src) = self.register_of(p, mx, uv.val) else {
            return Err("material network has more registers than the program holds".into());
        };
        match self.emit(p, mx, |dst| ShaderNode::Transform2d {
            dst,
            src,
            rotation_degrees,
            scale,
            translation,
        }) {
            Some(r) => Ok(Typed { val: Val::Reg(r), float: false }),
            None => Err("material network has more registers than the program holds".into()),
        }
    }

    /// The register of the mesh's texture coordinates (one per program).
    fn uv_register(&mut self, p: &mut Program) -> Option<u32> {
        if let Some(&r) = p.registers.get("#uv0") {
            return Some(r);
        }
        let dst = p.register()?;
        p.registers.insert("#uv0".into(), dst);
        p.nodes.push(ShaderNode::PrimvarUv { dst, fallback: [0.0; 4] });
        Some(dst)
    }

    /// `image` / `tiledimage`: a texture lookup at `texcoord` (the mesh's uvs when unconnected).
    #[allow(clippy::too_many_arguments)]
    fn mtlx_image(
        &mut self,
        material: &str,
        node: &str,
        category: &str,
        ty: &str,
        p: &mut Program,
        mx: &mut Mx,
        depth: u32,
    ) -> Result<Result<Typed, String>, UsdError> {
        let float = is_float_type(ty);
        let full = || Err("material network has more registers than the program holds".to_string());
        let default = self.mtlx_input(material, node, "default", [0.0; 4], float, p, mx, depth)?;
        let Val::Const(fallback) = default.val else {
            return Ok(Err("a connected default is not supported".into()));
        };
        // An image without a file is MaterialX's way to author its `default` (not a missing file).
        let has_file = matches!(
            self.trace_input(node, "inputs:file")?,
            Input::Constant { value: Value::Str(f), .. } if !f.is_empty()
        );
        if !has_file {
            return Ok(Ok(default));
        }
        let mut uv = match self.trace_input(node, "inputs:texcoord")? {
            Input::Unauthored => match self.uv_register(p) {
                Some(r) => Typed { val: Val::Reg(r), float: false },
                None => return Ok(full()),
            },
            _ => self.mtlx_input(material, node, "texcoord", [0.0; 4], false, p, mx, depth)?,
        };
        if category == "tiledimage" {
            let pair = |r: &mut Self, name: &str, d: [f32; 2]| -> Result<[f32; 2], UsdError> {
                Ok(r.stage
                    .attr(node, &format!("inputs:{name}"))?
                    .as_ref()
                    .and_then(constant)
                    .map_or(d, |(v, _)| [v[0], v[1]]))
            };
            let tiling = pair(self, "uvtiling", [1.0; 2])?;
            let offset = pair(self, "uvoffset", [0.0; 2])?;
            if tiling != [1.0; 2] || offset != [0.0; 2] {
                uv = match self.transform_uv(p, mx, uv, 0.0, tiling, [-offset[0], -offset[1]]) {
                    Ok(v) => v,
                    Err(e) => return Ok(Err(e)),
                };
            }
        }
        let Some(st) = self.register_of(p, mx, uv.val) else { return Ok(full()) };
        let wrap = |r: &mut Self, name: &str| -> Result<texture::Wrap, UsdError> {
            Ok(match r.token(node, &format!("inputs:{name}"))?.as_deref() {
                Some("clamp") => texture::Wrap::Clamp,
                Some("mirror") => texture::Wrap::Mirror,
                Some("constant") => texture::Wrap::Black,
                _ => texture::Wrap::Repeat,
            })
        };
        let (wrap_s, wrap_t) = (wrap(self, "uaddressmode")?, wrap(self, "vaddressmode")?);
        let color_space = if !matches!(ty, "color3" | "color4") {
            texture::ColorSpace::Raw
        } else {
            match self.stage.attr_metadata(node, "inputs:file", "colorSpace").as_ref().and_then(Value::as_str)
            {
                None | Some("") => texture::ColorSpace::Auto,
                Some("srgb_texture") | Some("sRGB") | Some("srgb") => texture::ColorSpace::Srgb,
                Some(_) => texture::ColorSpace::Raw,
            }
        };
        let texture = self
            .texture_file(material, node)?
            .and_then(|path| self.bake_texture(node, &path, color_space, fallback));
        let Some(dst) = p.register() else { return Ok(full()) };
        p.registers.insert(node.to_string(), dst);
        p.nodes.push(ShaderNode::Texture {
            dst,
            src: st,
            texture,
            wrap_s,
            wrap_t,
            scale: [1.0; 4],
            bias: [0.0; 4],
            fallback,
        });
        Ok(Ok(Typed { val: Val::Reg(dst), float }))
    }

    /// The register of a MaterialX value for a UsdPreviewSurface network that reads one.
    pub(super) fn mtlx_register(
        &mut self,
        material: &str,
        node: &str,
        p: &mut Program,
        depth: u32,
    ) -> Result<Option<u32>, UsdError> {
        if let Some(&r) = p.registers.get(node) {
            return Ok(Some(r));
        }
        let mut mx = Mx::default();
        let Some(v) = self.mtlx_node(material, node, p, &mut mx, depth)? else { return Ok(None) };
        let broadcast = v.float && matches!(v.val, Val::Reg(_));
        let v =
            if broadcast { self.math(p, &mut mx, MathOp::Swizzle([0; 4]), [v; 3], false) } else { Some(v) };
        Ok(v.and_then(|v| self.register_of(p, &mut mx, v.val)))
    }
}

#[cfg(test)]
mod tests {
    use super::{result_type, split_nodedef};

    #[test]
    fn nodedef_names_split_into_category_and_signature() {
        let split = |id: &str| {
            let (c, s) = split_nodedef(id);
            (c, s)
        };
        assert_eq!(split("ND_multiply_color3FA"), ("multiply".into(), "color3FA".into()));
        assert_eq!(split("ND_image_color3"), ("image".into(), "color3".into()));
        assert_eq!(split("ND_tiledimage_float"), ("tiledimage".into(), "float".into()));
        assert_eq!(split("ND_normalmap"), ("normalmap".into(), "".into()));
        assert_eq!(split("ND_convert_vector3_color3"), ("convert".into(), "vector3_color3".into()));
        assert_eq!(split("ND_geompropvalue_vector2"), ("geompropvalue".into(), "vector2".into()));
        assert_eq!(split("ND_UsdPrimvarReader_vector3"), ("UsdPrimvarReader".into(), "vector3".into()));
        assert_eq!(split("ND_hsvtorgb_color3"), ("hsvtorgb".into(), "color3".into()));
        assert_eq!(result_type("convert", "vector3_color3"), "color3");
        assert_eq!(result_type("multiply", "color3FA"), "color3");
        assert_eq!(result_type("extract", "color3"), "float");
        assert_eq!(result_type("mix", "color3_color3"), "color3");
    }
}

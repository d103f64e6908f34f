//! Material binding and UsdPreviewSurface constant inputs.
//!
//! Binding resolution (a simplified `UsdShadeMaterialBindingAPI::ComputeBoundMaterial` for the
//! "full" render purpose): at each prim from the gprim up to the root, the direct binding is
//! `material:binding:full` if authored, else `material:binding`. The nearest prim with a binding
//! wins, unless an ancestor's binding is `bindMaterialAs = "strongerThanDescendants"` (then the
//! topmost such ancestor wins). Only if no full/all-purpose binding exists anywhere up the chain is
//! `material:binding:preview` used, with a warning. Collection-based bindings are not resolved
//! (warned when of the full or all purposes; `preview:` ones never apply to a final render). GeomSubsets of a mesh carrying a direct binding give per-face materials.
//!
//! Inputs connected to shading networks are compiled into the material's program
//! ([`crate::scene::ShaderNode`]): each reachable node (UsdUVTexture, UsdPrimvarReader_float2 (the
//! texture coordinates), UsdPrimvarReader_float/float3/float4/int/normal/point/vector (a primvar
//! the gprim carries into the blob, see [`Reader::program_primvars`]), UsdTransform2d; string readers
//! and unknown nodes become their fallback constant) gets one register, in dependency order, and each
//! connected PreviewSurface input an `Output` reading the connected channel(s). An unbound gprim
//! whose displayColor varies gets a program that reads it per hit.
//! A Material's `outputs:mtlx:surface` wins over `outputs:surface` when its shader is a MaterialX
//! surface model [`mtlx_network`] maps (standard_surface, open_pbr_surface, UsdPreviewSurface): it
//! is the production look a MaterialX renderer picks, and the universal surface is the preview of
//! it. `ND_*` nodes inside a UsdPreviewSurface network compile through [`mtlx_network`] too.
//! Texture files resolve against the layer that authored `inputs:file` and are decoded and baked here,
//! once per (file, colour space), so a missing or unreadable file is a warning on the shader naming the
//! file and the fallback the lookup will return instead.

mod mtlx_network;

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use glam::Vec3;
use rayon::prelude::*;

use super::stage::Value;
use super::texture_files::{decode_texture, packaged, resolve_asset, texture_location};
use super::{Reader, UsdError};
use crate::scene::{Look, Material, SceneTexture, ShaderNode, ShadingInput, TextureData};
use mtlx_network::Model;

/// Where a shader input's value comes from.
enum Input {
    /// Not authored: the PreviewSurface fallback applies.
    Unauthored,
    /// An authored (or interface-forwarded) constant, and the attribute that holds it.
    Constant { value: Value, prim: String, attr: String },
    /// Connected to a shader node: its prim and the output the connection reads (`rgb`, `r`, ...).
    Network { node: String, output: String },
}

/// Most shader nodes a network may nest (a cycle guard).
const MAX_NODE_DEPTH: u32 = 16;

/// A material program being built: the nodes so far, one register per compiled node.
#[derive(Default)]
struct Program {
    nodes: Vec<ShaderNode>,
    /// Register per compiled node prim (a node feeding several inputs is evaluated once).
    registers: HashMap<String, u32>,
    /// Program index of each UsdUVTexture node whose `scale` and `bias` are both unauthored, by
    /// register (a normal map without them is remapped from `[0, 1]` to `[-1, 1]`).
    unscaled_textures: HashMap<u32, usize>,
    /// Categories of the nodes read (`UsdUVTexture`, MaterialX `image`, ...), for the report.
    categories: BTreeSet<String>,
}

impl Program {
    fn register(&self) -> Option<u32> {
        let next = self.registers.len() as u32;
        (next < blob::MAX_REGISTERS).then_some(next)
    }
}

/// The channels a connection to `output` reads: `[0; 4]` for `r`, the identity for `rgb`/`result`.
fn swizzle(output: &str) -> [u8; 4] {
    match output {
        "r" | "x" => [0; 4],
        "g" | "y" => [1; 4],
        "b" | "z" => [2; 4],
        "a" | "w" => [3; 4],
        _ => [0, 1, 2, 3],
    }
}

/// A value as a `vec4`: scalars broadcast to rgb (alpha 1), tuples padded with `default`.
fn vec4(value: &Value, default: [f32; 4]) -> [f32; 4] {
    match value {
        Value::Scalar(s) => [*s as f32, *s as f32, *s as f32, 1.0],
        Value::Tuple(t) => std::array::from_fn(|i| t.get(i).map_or(default[i], |&c| c as f32)),
        _ => default,
    }
}

fn channel(output: &str) -> usize {
    match output {
        "g" | "y" => 1,
        "b" | "z" => 2,
        "a" | "w" => 3,
        _ => 0,
    }
}

fn as_color(value: &Value, output: &str) -> Option<Vec3> {
    match value {
        Value::Scalar(s) => Some(Vec3::splat(*s as f32)),
        Value::Tuple(t)
            if t.len() >= 3 && !matches!(output, "r" | "g" | "b" | "a" | "x" | "y" | "z" | "w") =>
        {
            Some(Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32))
        }
        Value::Tuple(t) => t.get(channel(output)).map(|&c| Vec3::splat(c as f32)),
        _ => None,
    }
}

fn as_float(value: &Value, output: &str) -> Option<f32> {
    match value {
        Value::Scalar(s) => Some(*s as f32),
        Value::Tuple(t) => t.get(channel(output)).map(|&c| c as f32),
        _ => None,
    }
}

/// Whether `property` is a collection-based binding a final-frame render would use:
/// `material:binding:collection:NAME` (all purposes) or `material:binding:collection:full:NAME`.
/// A `preview:` one never applies to the full purpose (as in usd-core's `ComputeBoundMaterial`).
fn renders_collection_binding(property: &str) -> bool {
    let Some(rest) = property.strip_prefix("material:binding:collection:") else { return false };
    match rest.split_once(':') {
        None => true,
        Some((purpose, _)) => purpose == "full",
    }
}

/// A binding relationship opinion at one prim: target material and `strongerThanDescendants`.
type DirectBinding = Option<(String, bool)>;

impl Reader<'_> {
    /// The material index for a whole gprim: its bound material, else its displayColor material.
    pub(super) fn gprim_material(&mut self, gprim: &str) -> Result<u32, UsdError> {
        match self.bound_material_path(gprim) {
            Some(material) => self.material(&material, gprim),
            None => self.display_color_material(gprim),
        }
    }

    /// Per-face material indices of a mesh with `faces` faces, honouring bound GeomSubsets of the
    /// `materialBind` family (UsdShade's `GetMaterialBindSubsets`: a binding on a subset of another
    /// family is ignored, with a warning).
    pub(super) fn mesh_face_materials(&mut self, mesh: &str, faces: usize) -> Result<Vec<u32>, UsdError> {
        let whole = self.gprim_material(mesh)?;
        let mut per_face = vec![whole; faces];
        let children = self.children_of(mesh);
        for subset in children {
            if self.stage.type_name(&subset) != "GeomSubset" {
                continue;
            }
            let element = self.token(&subset, "elementType")?;
            if element.as_deref().is_some_and(|e| e != "face") {
                continue;
            }
            let Some((material, _)) =
                self.direct_binding(&subset, &["material:binding:full", "material:binding"])
            else {
                continue;
            };
            let family = self.token(&subset, "familyName")?;
            if family.as_deref() != Some("materialBind") {
                let family = family.map_or("no familyName".to_string(), |f| format!("familyName \"{f}\""));
                self.warn(
                    &subset,
                    format!("material binding on a GeomSubset with {family}, not \"materialBind\"; ignored (as UsdShade ignores it)"),
                );
                continue;
            }
            let index = self.material(&material, &subset)?;
            let indices = self.ints(&subset, "indices")?.unwrap_or_default();
            let mut out_of_range = 0;
            for i in indices {
                match usize::try_from(i).ok().filter(|&i| i < faces) {
                    Some(i) => per_face[i] = index,
                    None => out_of_range += 1,
                }
            }
            if out_of_range > 0 {
                self.warn(
                    &subset,
                    format!("{out_of_range} subset indices out of range ({faces} faces); ignored"),
                );
            }
        }
        Ok(per_face)
    }

    /// The direct binding authored on `prim` through the first of `relationships` that has targets.
    fn direct_binding(&mut self, prim: &str, relationships: &[&str]) -> DirectBinding {
        for rel in relationships {
            if let Some(target) = self.stage.targets(prim, rel).into_iter().next() {
                let stronger =
                    self.stage.rel_metadata(prim, rel, "bindMaterialAs").as_ref().and_then(Value::as_str)
                        == Some("strongerThanDescendants");
                return Some((target, stronger));
            }
        }
        None
    }

    fn resolve_binding(&mut self, gprim: &str, relationships: &[&'static str]) -> Option<String> {
        let mut winner: Option<String> = None;
        let mut prim = gprim.to_string();
        loop {
            let binding = match self.binding_cache.get(&(prim.clone(), relationships[0])) {
                Some(b) => b.clone(),
                None => {
                    if self.stage.property_names(&prim).iter().any(|p| renders_collection_binding(p)) {
                        self.warn(&prim, "collection-based material bindings not supported yet; ignored");
                    }
                    let b = self.direct_binding(&prim, relationships);
                    self.binding_cache.insert((prim.clone(), relationships[0]), b.clone());
                    b
                }
            };
            if let Some((material, stronger)) = binding {
                if winner.is_none() || stronger {
                    winner = Some(material);
                }
            }
            let parent = super::parent_of(&prim);
            if prim == "/" || parent == "/" {
                break;
            }
            prim = parent.to_string();
        }
        winner
    }

    /// The material bound to `gprim` for rendering, if any.
    fn bound_material_path(&mut self, gprim: &str) -> Option<String> {
        if let Some(m) = self.resolve_binding(gprim, &["material:binding:full", "material:binding"]) {
            return Some(m);
        }
        let preview = self.resolve_binding(gprim, &["material:binding:preview"])?;
        self.warn(gprim, "only a preview-purpose material binding is authored; using it");
        Some(preview)
    }

    /// The scene index of the material at `path` (read once), falling back to the displayColor
    /// material of `gprim` when the material has no UsdPreviewSurface.
    fn material(&mut self, path: &str, gprim: &str) -> Result<u32, UsdError> {
        if let Some(&index) = self.material_index.get(path) {
            return Ok(index);
        }
        match self.preview_surface(path)? {
            Some(mut material) => {
                material.path = path.to_string();
                Ok(self.add_material(material))
            }
            // The binding is a fact of the stage whatever the look (usd-core's ComputeBoundMaterial
            // names it): a Material whose surface we cannot read keeps its path, for listings and
            // per-material outputs, and draws with the gprim's displayColor.
            None if self.stage.type_name(path) == "Material" => {
                let key = format!("{path} with {gprim}.displayColor");
                if let Some(&index) = self.material_index.get(&key) {
                    return Ok(index);
                }
                let material = Material { path: path.to_string(), ..self.display_color_look(gprim)? };
                let index = self.scene.materials.len() as u32;
                self.material_index.insert(key, index);
                self.scene.materials.push(material);
                Ok(index)
            }
            None => self.display_color_material(gprim),
        }
    }

    fn add_material(&mut self, material: Material) -> u32 {
        let index = self.scene.materials.len() as u32;
        self.material_index.insert(material.path.clone(), index);
        self.scene.materials.push(material);
        index
    }

    /// Follows the material's `output` through NodeGraph/Material outputs to the shader it reads.
    fn surface_shader(&mut self, material: &str, output: &str) -> Option<String> {
        let mut source = self.stage.connections(material, output).into_iter().next()?;
        for _ in 0..16 {
            let (prim, prop) = source.split_once('.')?;
            let ty = self.stage.type_name(prim);
            if ty != "NodeGraph" && ty != "Material" {
                return Some(prim.to_string());
            }
            source = self.stage.connections(prim, prop).into_iter().next()?;
        }
        None
    }

    /// Reads the UsdPreviewSurface of a Material, or `None` (with a warning) when it has none.
    fn preview_surface(&mut self, path: &str) -> Result<Option<Material>, UsdError> {
        let ty = self.stage.type_name(path);
        if ty != "Material" {
            let message = if self.stage.is_defined(path) {
                format!("bound material is a {ty:?} prim, not a Material; using displayColor")
            } else {
                // Typically a material defined only in a layer that did not load (a `.mtlx` reference).
                "bound material is not defined on the stage (no composed layer defines it: see the composition warnings for an arc that failed); using displayColor".to_string()
            };
            self.warn(path, message);
            return Ok(None);
        }
        // The MaterialX surface first (the production look, what a MaterialX renderer picks), when
        // it is a model `mtlx_network` maps; else the universal surface; else RenderMan's (a
        // PxrDisney is read, see `renderman`).
        let mut unmapped_mtlx = None;
        if let Some(shader) = self.surface_shader(path, "outputs:mtlx:surface") {
            let id = self.token(&shader, "info:id")?.unwrap_or_default();
            match Model::of(&id) {
                Some(model) => return self.mtlx_surface(path, &shader, model).map(Some),
                None => unmapped_mtlx = Some((shader, id)),
            }
        }
        let shader = self
            .surface_shader(path, "outputs:surface")
            .or_else(|| self.surface_shader(path, "outputs:ri:surface"));
        if let Some((mtlx_shader, id)) = unmapped_mtlx {
            let then = if shader.is_some() { "using outputs:surface" } else { "using displayColor" };
            self.warn(
                path,
                format!("MaterialX surface {mtlx_shader} is {id:?}, not a surface model the renderer maps (standard_surface, open_pbr_surface, UsdPreviewSurface); {then}"),
            );
            if shader.is_none() {
                return Ok(None);
            }
        }
        let Some(shader) = shader else {
            let other = self
                .stage
                .property_names(path)
                .into_iter()
                .find(|p| p.starts_with("outputs:") && p.ends_with(":surface") && p != "outputs:surface");
            let message = match other {
                Some(output) => format!(
                    "surface is only authored as {output} (not UsdPreviewSurface); using displayColor"
                ),
                None => "material has no outputs:surface connection; using displayColor".to_string(),
            };
            self.warn(path, message);
            return Ok(None);
        };
        let id = self.token(&shader, "info:id")?;
        if id.as_deref() == Some("PxrDisney") {
            let mut m = self.disney_surface(path, &shader)?;
            m.look.surface_model = "PxrDisney".into();
            return Ok(Some(m));
        }
        if id.as_deref() != Some("UsdPreviewSurface") {
            self.warn(
                path,
                format!(
                    "surface shader {shader} is {:?}, not UsdPreviewSurface; using displayColor",
                    id.unwrap_or_default()
                ),
            );
            return Ok(None);
        }
        let mut m = Material::default();
        let mut program = Program::default();
        let p = &mut program;
        let mut color =
            |r: &mut Self, name: &str, input: ShadingInput, slot: &mut Vec3| -> Result<(), UsdError> {
                if let Some((v, out)) = r.input(path, &shader, name, p, Some(input))? {
                    if let Some(c) = as_color(&v, &out) {
                        *slot = c;
                    }
                }
                Ok(())
            };
        color(self, "diffuseColor", ShadingInput::DiffuseColor, &mut m.diffuse_color)?;
        color(self, "emissiveColor", ShadingInput::EmissiveColor, &mut m.emissive_color)?;
        color(self, "specularColor", ShadingInput::SpecularColor, &mut m.specular_color)?;
        let mut normal = Vec3::Z;
        color(self, "normal", ShadingInput::Normal, &mut normal)?;
        let mut float =
            |r: &mut Self, name: &str, input: Option<ShadingInput>, slot: &mut f32| -> Result<(), UsdError> {
                if let Some((v, out)) = r.input(path, &shader, name, p, input)? {
                    if let Some(f) = as_float(&v, &out) {
                        *slot = f;
                    }
                }
                Ok(())
            };
        float(self, "roughness", Some(ShadingInput::Roughness), &mut m.roughness)?;
        float(self, "metallic", Some(ShadingInput::Metallic), &mut m.metallic)?;
        float(self, "ior", Some(ShadingInput::Ior), &mut m.ior)?;
        float(self, "opacity", Some(ShadingInput::Opacity), &mut m.opacity)?;
        float(self, "opacityThreshold", None, &mut m.opacity_threshold)?;
        float(self, "clearcoat", Some(ShadingInput::Clearcoat), &mut m.clearcoat)?;
        float(
            self,
            "clearcoatRoughness",
            Some(ShadingInput::ClearcoatRoughness),
            &mut m.clearcoat_roughness,
        )?;
        let mut workflow = 0.0;
        float(self, "useSpecularWorkflow", None, &mut workflow)?;
        m.use_specular_workflow = workflow != 0.0;
        let displaced = match self.trace_input(&shader, "inputs:displacement")? {
            Input::Unauthored => false,
            Input::Constant { value, .. } => value.as_f64().is_none_or(|d| d != 0.0),
            Input::Network { .. } => true,
        };
        if displaced {
            self.warn(path, "displacement ignored");
        }
        m.program = program.nodes;
        m.look = Look {
            surface_model: "UsdPreviewSurface".into(),
            node_categories: program.categories.into_iter().collect(),
        };
        Ok(Some(m))
    }

    /// A RenderMan PxrDisney surface from its constant inputs ([`super::renderman`]); connected
    /// inputs and lobes PreviewSurface lacks are named in warnings.
    fn disney_surface(&mut self, path: &str, shader: &str) -> Result<Material, UsdError> {
        let constant = |r: &mut Self, name: &str| -> Result<Option<Value>, UsdError> {
            Ok(match r.trace_input(shader, &format!("inputs:{name}"))? {
                Input::Constant { value, .. } => Some(value),
                Input::Unauthored => None,
                Input::Network { node, .. } => {
                    r.warn(path, format!("PxrDisney input {name} is connected to {node}; using its default"));
                    None
                }
            })
        };
        let color = |r: &mut Self, name: &str| -> Result<Option<Vec3>, UsdError> {
            Ok(constant(r, name)?.and_then(|v| as_color(&v, "")))
        };
        let base_color = color(self, "baseColor")?;
        let emit_color = color(self, "emitColor")?;
        let float = |r: &mut Self, name: &str| -> Result<Option<f32>, UsdError> {
            Ok(constant(r, name)?.and_then(|v| as_float(&v, "")))
        };
        let inputs = super::renderman::DisneyInputs {
            base_color,
            emit_color,
            metallic: float(self, "metallic")?,
            specular: float(self, "specular")?,
            roughness: float(self, "roughness")?,
            clearcoat: float(self, "clearcoat")?,
            clearcoat_gloss: float(self, "clearcoatGloss")?,
            presence: float(self, "presence")?,
        };
        let mut ignored = Vec::new();
        for lobe in super::renderman::UNSUPPORTED_LOBES {
            if float(self, lobe)?.is_some_and(|v| v != 0.0) {
                ignored.push(lobe);
            }
        }
        if !ignored.is_empty() {
            self.warn(path, format!("PxrDisney {} not supported; ignored", ignored.join(", ")));
        }
        Ok(super::renderman::disney_material(&inputs))
    }

    /// The constant value of a shader input and the output channel it reads (`""` for a direct
    /// value), or `None` to keep the PreviewSurface fallback. An input connected to a network is
    /// compiled into `program` with an output binding for `slot`; its value here is `None`.
    fn input(
        &mut self,
        material: &str,
        shader: &str,
        name: &str,
        program: &mut Program,
        slot: Option<ShadingInput>,
    ) -> Result<Option<(Value, String)>, UsdError> {
        match self.trace_input(shader, &format!("inputs:{name}"))? {
            Input::Unauthored => Ok(None),
            Input::Constant { value, .. } => Ok(Some((value, String::new()))),
            Input::Network { node, output } => {
                let Some(slot) = slot else {
                    self.warn(material, format!("input {name} is connected to a shading network; only its constant is supported, using the PreviewSurface fallback"));
                    return Ok(None);
                };
                match self.compile_node(material, &node, program, 0)? {
                    Some(src) => {
                        if slot == ShadingInput::Normal {
                            // A normal map stores [-1, 1] as [0, 1]; assets that do not author the
                            // texture's scale (2) and bias (-1) themselves get that remap here.
                            if let Some(&i) = program.unscaled_textures.get(&src) {
                                if let ShaderNode::Texture { scale, bias, .. } = &mut program.nodes[i] {
                                    *scale = [2.0, 2.0, 2.0, 1.0];
                                    *bias = [-1.0, -1.0, -1.0, 0.0];
                                }
                            }
                        }
                        program.nodes.push(ShaderNode::Output {
                            input: slot,
                            src,
                            swizzle: swizzle(&output),
                        });
                        Ok(None)
                    }
                    None => Ok(None),
                }
            }
        }
    }

    /// Compiles shader `node` (and what it reads) into `program`; returns the register holding its
    /// output, or `None` when the network is too large.
    fn compile_node(
        &mut self,
        material: &str,
        node: &str,
        program: &mut Program,
        depth: u32,
    ) -> Result<Option<u32>, UsdError> {
        if let Some(&r) = program.registers.get(node) {
            return Ok(Some(r));
        }
        if depth > MAX_NODE_DEPTH {
            self.warn(
                node,
                "shading network nested too deeply (a cycle?); using the PreviewSurface fallback",
            );
            return Ok(None);
        }
        let id = self.token(node, "info:id")?.unwrap_or_default();
        if id.starts_with("ND_") {
            return self.mtlx_register(material, node, program, depth);
        }
        program.categories.insert(id.clone());
        self.compile_usd_node(material, node, &id, program, depth)
    }

    /// [`Self::compile_node`] for the UsdShade node `node` whose `info:id` is `id`.
    fn compile_usd_node(
        &mut self,
        material: &str,
        node: &str,
        id: &str,
        program: &mut Program,
        depth: u32,
    ) -> Result<Option<u32>, UsdError> {
        let value = |r: &mut Self, name: &str| -> Result<Option<Value>, UsdError> {
            Ok(match r.trace_input(node, &format!("inputs:{name}"))? {
                Input::Constant { value, .. } => Some(value),
                _ => None,
            })
        };
        let fallback = value(self, "fallback")?;
        let node_out: ShaderNode = match id {
            "UsdUVTexture" => {
                let st = self.coordinate_register(material, node, "st", program, depth)?;
                let file = self.texture_file(material, node)?;
                let wrap = |r: &mut Self, name: &str| -> Result<texture::Wrap, UsdError> {
                    let token = value(r, name)?.and_then(|v| v.as_str().map(str::to_string));
                    Ok(match token.as_deref().map(str::parse::<texture::Wrap>) {
                        None => texture::Wrap::Repeat,
                        Some(Ok(w)) => w,
                        Some(Err(e)) => {
                            r.warn(node, format!("{e}; using repeat"));
                            texture::Wrap::Repeat
                        }
                    })
                };
                let (wrap_s, wrap_t) = (wrap(self, "wrapS")?, wrap(self, "wrapT")?);
                let scale_v = value(self, "scale")?;
                let bias_v = value(self, "bias")?;
                let fallback =
                    fallback.as_ref().map_or([0.0, 0.0, 0.0, 1.0], |v| vec4(v, [0.0, 0.0, 0.0, 1.0]));
                let color_space = match value(self, "sourceColorSpace")?.as_ref().and_then(Value::as_str) {
                    None => texture::ColorSpace::Auto,
                    Some(t) => t.parse().unwrap_or_else(|e: String| {
                        self.warn(node, format!("{e}; using auto"));
                        texture::ColorSpace::Auto
                    }),
                };
                let texture = file.and_then(|path| self.bake_texture(node, &path, color_space, fallback));
                let Some(dst) = program.register() else { return self.too_many(node) };
                if scale_v.is_none() && bias_v.is_none() {
                    program.unscaled_textures.insert(dst, program.nodes.len());
                }
                ShaderNode::Texture {
                    dst,
                    src: st,
                    texture,
                    wrap_s,
                    wrap_t,
                    scale: scale_v.as_ref().map_or([1.0; 4], |v| vec4(v, [1.0; 4])),
                    bias: bias_v.as_ref().map_or([0.0; 4], |v| vec4(v, [0.0; 4])),
                    fallback,
                }
            }
            "UsdPrimvarReader_float2" => {
                let Some(dst) = program.register() else { return self.too_many(node) };
                ShaderNode::PrimvarUv {
                    dst,
                    fallback: fallback.as_ref().map_or([0.0; 4], |v| vec4(v, [0.0; 4])),
                }
            }
            "UsdTransform2d" => {
                let src = self.coordinate_register(material, node, "in", program, depth)?;
                let pair = |v: Option<Value>, d: [f32; 2]| match v {
                    Some(Value::Tuple(t)) if t.len() >= 2 => [t[0] as f32, t[1] as f32],
                    Some(Value::Scalar(s)) => [s as f32; 2],
                    _ => d,
                };
                let rotation_degrees =
                    value(self, "rotation")?.and_then(|v| v.as_f64()).unwrap_or(0.0) as f32;
                let scale = pair(value(self, "scale")?, [1.0; 2]);
                let translation = pair(value(self, "translation")?, [0.0; 2]);
                let Some(dst) = program.register() else { return self.too_many(node) };
                ShaderNode::Transform2d { dst, src, rotation_degrees, scale, translation }
            }
            "UsdPrimvarReader_float"
            | "UsdPrimvarReader_float3"
            | "UsdPrimvarReader_float4"
            | "UsdPrimvarReader_int"
            | "UsdPrimvarReader_normal"
            | "UsdPrimvarReader_point"
            | "UsdPrimvarReader_vector" => {
                let fallback =
                    fallback.as_ref().map_or([0.0, 0.0, 0.0, 1.0], |v| vec4(v, [0.0, 0.0, 0.0, 1.0]));
                let varname = value(self, "varname")?.and_then(|v| v.as_str().map(str::to_string));
                let name = varname.as_deref().map(|n| n.strip_prefix("primvars:").unwrap_or(n).to_string());
                let Some(dst) = program.register() else { return self.too_many(node) };
                match name.filter(|n| !n.is_empty()) {
                    Some(name) => ShaderNode::Primvar { dst, name, fallback },
                    None => {
                        self.warn(
                            node,
                            format!("{id} has no inputs:varname; using its fallback {fallback:?}"),
                        );
                        ShaderNode::Const { dst, value: fallback }
                    }
                }
            }
            other => {
                let what = if other.starts_with("UsdPrimvarReader_") {
                    format!("{other} reads a primvar type the renderer does not carry (strings, matrices)")
                } else {
                    format!("shader {other:?} is not supported")
                };
                let value = fallback.as_ref().map_or([0.0, 0.0, 0.0, 1.0], |v| vec4(v, [0.0, 0.0, 0.0, 1.0]));
                self.warn(node, format!("{what}; using its fallback {value:?}"));
                let Some(dst) = program.register() else { return self.too_many(node) };
                ShaderNode::Const { dst, value }
            }
        };
        let dst = program.registers.len() as u32;
        program.registers.insert(node.to_string(), dst);
        program.nodes.push(node_out);
        Ok(Some(dst))
    }

    fn too_many(&mut self, node: &str) -> Result<Option<u32>, UsdError> {
        self.warn(
            node,
            format!(
                "material network has more than {} nodes; the rest use the PreviewSurface fallback",
                blob::MAX_REGISTERS
            ),
        );
        Ok(None)
    }

    /// The register holding a node's coordinate input (`st` of a texture, `in` of a transform):
    /// the connected node's output, else a constant (USD's fallback is `(0, 0)`).
    fn coordinate_register(
        &mut self,
        material: &str,
        node: &str,
        name: &str,
        program: &mut Program,
        depth: u32,
    ) -> Result<u32, UsdError> {
        let constant = match self.trace_input(node, &format!("inputs:{name}"))? {
            Input::Network { node: source, .. } => {
                if let Some(r) = self.compile_node(material, &source, program, depth + 1)? {
                    return Ok(r);
                }
                [0.0; 4]
            }
            Input::Constant { value, .. } => vec4(&value, [0.0; 4]),
            Input::Unauthored => [0.0; 4],
        };
        // Constant coordinates share one register per value; a full file reuses the last one.
        let key = format!("{node}.inputs:{name}");
        let dst = program.register().unwrap_or(blob::MAX_REGISTERS - 1);
        program.registers.insert(key, dst);
        program.nodes.push(ShaderNode::Const { dst, value: constant });
        Ok(dst)
    }

    /// The resolved `inputs:file` of a texture node, or `None` with a warning.
    fn texture_file(&mut self, material: &str, node: &str) -> Result<Option<PathBuf>, UsdError> {
        let (asset, prim, attr) = match self.trace_input(node, "inputs:file")? {
            Input::Constant { value: Value::Str(s), prim, attr } if !s.is_empty() => (s, prim, attr),
            _ => {
                self.warn(node, "texture has no inputs:file; using its fallback");
                return Ok(None);
            }
        };
        let layer = self.stage.authoring_layer(&prim, &attr);
        match resolve_asset(&layer, &asset) {
            Ok(path) => Ok(Some(path)),
            Err(why) => {
                self.warn(
                    node,
                    format!("texture file {asset:?} (material {material}): {why}; using its fallback"),
                );
                Ok(None)
            }
        }
    }

    /// The scene texture for `path` baked in `color_space` (decoded once per pair), or `None` with a
    /// warning naming the file and the fallback the lookups return instead; the time it takes is
    /// charged to the load timings' texture seconds.
    fn bake_texture(
        &mut self,
        node: &str,
        path: &Path,
        color_space: texture::ColorSpace,
        fallback: [f32; 4],
    ) -> Option<u32> {
        let start = std::time::Instant::now();
        let texture = self.bake_texture_untimed(node, path, color_space, fallback);
        self.scene.load_timings.texture_seconds += start.elapsed().as_secs_f64();
        texture
    }

    /// [`Self::bake_texture`] without the timing.
    fn bake_texture_untimed(
        &mut self,
        node: &str,
        path: &Path,
        color_space: texture::ColorSpace,
        fallback: [f32; 4],
    ) -> Option<u32> {
        if !self.bake_textures {
            return None;
        }
        let requested = path;
        let located = texture_location(path);
        let path = located.as_path();
        if let Some(i) =
            self.scene.textures.iter().position(|t| t.path == path && t.color_space == color_space)
        {
            return Some(i as u32);
        }
        let options = texture::BakeOptions { color_space, ..texture::BakeOptions::default() };
        let limits = self.texture_limits;
        let bake_file = |p: &Path| {
            decode_texture(p, &limits)
                .and_then(|src| texture::bake(&src, &options))
                .map_err(|e| e.to_string())
        };
        // A sequence's later frames take the first frame's bake of the file (see `bake_cache`).
        let cache = self.bake_cache;
        let bake_one = |p: &Path| match cache {
            Some(cache) => (*cache.image(p, options, || bake_file(p))).clone(),
            None => bake_file(p),
        };
        let data = if texture::udim::is_udim(path) {
            let tiles = match texture::udim::expand(path) {
                Ok(tiles) => tiles,
                Err(e) => {
                    self.warn(
                        node,
                        format!("texture {}: {e}; using its fallback {fallback:?}", path.display()),
                    );
                    return None;
                }
            };
            // Tiles decode independently: one task each.
            let baked: Vec<_> = tiles.par_iter().map(|t| (t, bake_one(&t.path))).collect();
            let mut found = Vec::new();
            for (tile, result) in baked {
                match result {
                    Ok(b) => found.push((tile.u, tile.v, b)),
                    Err(e) => self.warn(
                        node,
                        format!(
                            "UDIM tile {} cannot be read ({e}); lookups there use the fallback {fallback:?}",
                            tile.number
                        ),
                    ),
                }
            }
            if found.is_empty() {
                return None;
            }
            let u_count = found.iter().map(|t| t.0).max().unwrap_or(0) + 1;
            let v_count = found.iter().map(|t| t.1).max().unwrap_or(0) + 1;
            for v in 0..v_count {
                for u in 0..u_count {
                    if !found.iter().any(|t| (t.0, t.1) == (u, v)) {
                        let number = 1001 + u + 10 * v;
                        let tile = texture::udim::tile_path(path, number);
                        self.warn(
                            node,
                            format!(
                                "UDIM tile {number} of {} is missing ({} not found); lookups there use the fallback {fallback:?}",
                                path.display(),
                                tile.display()
                            ),
                        );
                    }
                }
            }
            TextureData::Udim(found)
        } else {
            match bake_one(path) {
                Ok(b) => TextureData::Image(b),
                Err(e) => {
                    let exists = path.exists() || packaged(path).is_some();
                    let why = match () {
                        _ if exists => format!("{} cannot be read ({e})", path.display()),
                        _ if requested != path => format!(
                            "{} not found in the package nor beside it ({})",
                            requested.display(),
                            path.display()
                        ),
                        _ => format!("{} not found", path.display()),
                    };
                    self.warn(node, format!("texture file {why}; using its fallback {fallback:?}"));
                    return None;
                }
            }
        };
        self.scene.textures.push(SceneTexture { path: path.to_path_buf(), color_space, data });
        Some(self.scene.textures.len() as u32 - 1)
    }

    /// Follows an input's connections through interface inputs to a constant or a network node.
    fn trace_input(&mut self, prim: &str, attr: &str) -> Result<Input, UsdError> {
        let (mut prim, mut attr) = (prim.to_string(), attr.to_string());
        for _ in 0..16 {
            let Some(source) = self.stage.connections(&prim, &attr).into_iter().next() else {
                return Ok(match self.stage.attr(&prim, &attr)? {
                    Some(value) => Input::Constant { value, prim, attr },
                    None => Input::Unauthored,
                });
            };
            let Some((src_prim, src_prop)) = source.split_once('.') else { return Ok(Input::Unauthored) };
            if self.stage.type_name(src_prim) == "Shader" {
                let output = src_prop.strip_prefix("outputs:").unwrap_or(src_prop).to_string();
                return Ok(Input::Network { node: src_prim.to_string(), output });
            }
            (prim, attr) = (src_prim.to_string(), src_prop.to_string());
        }
        Ok(Input::Unauthored)
    }

    /// The material of an unbound gprim: `primvars:displayColor` / `primvars:displayOpacity`,
    /// named `<gprim>.displayColor`. A display primvar that varies over the gprim is read per hit by
    /// a program (as Hydra's fallback material does), its average kept as the constant for curves
    /// and for whatever reads constants only.
    fn display_color_material(&mut self, gprim: &str) -> Result<u32, UsdError> {
        let name = format!("{gprim}.displayColor");
        if let Some(&index) = self.material_index.get(&name) {
            return Ok(index);
        }
        let look = self.display_color_look(gprim)?;
        Ok(self.add_material(Material { path: name, ..look }))
    }

    /// The look of `gprim`'s displayColor/displayOpacity (constant, or read per point by a
    /// program), not yet registered.
    fn display_color_look(&mut self, gprim: &str) -> Result<Material, UsdError> {
        let mut m = Material::default();
        if let Some((values, varies)) = self.display_primvar::<3>(gprim, "primvars:displayColor")? {
            m.diffuse_color = Vec3::new(values[0] as f32, values[1] as f32, values[2] as f32);
            if varies {
                let fallback = [m.diffuse_color.x, m.diffuse_color.y, m.diffuse_color.z, 1.0];
                let dst = m.program.len() as u32;
                m.program.push(ShaderNode::Primvar { dst, name: "displayColor".into(), fallback });
                m.program.push(ShaderNode::Output {
                    input: ShadingInput::DiffuseColor,
                    src: dst,
                    swizzle: [0, 1, 2, 3],
                });
            }
        }
        if let Some((values, varies)) = self.display_primvar::<1>(gprim, "primvars:displayOpacity")? {
            m.opacity = values[0] as f32;
            if varies {
                let dst = m.program.len() as u32;
                let fallback = [m.opacity, m.opacity, m.opacity, 1.0];
                m.program.push(ShaderNode::Primvar { dst, name: "displayOpacity".into(), fallback });
                m.program.push(ShaderNode::Output {
                    input: ShadingInput::Opacity,
                    src: dst,
                    swizzle: [0; 4],
                });
            }
        }
        Ok(m)
    }

    /// The primvars the programs of `materials` read (sorted by name), as authored on `gprim` or
    /// inherited; names the gprim does not carry are left out (their readers return the fallback).
    pub(super) fn program_primvars(
        &mut self,
        gprim: &str,
        materials: &[u32],
        topology: Option<&super::mesh::Topology>,
    ) -> Result<Vec<super::mesh::CagePrimvar>, UsdError> {
        let mut names: Vec<String> = Vec::new();
        let mut seen_materials: Vec<u32> = Vec::new();
        for &m in materials {
            if seen_materials.contains(&m) {
                continue;
            }
            seen_materials.push(m);
            for node in &self.scene.materials[m as usize].program {
                if let ShaderNode::Primvar { name, .. } = node {
                    if !names.contains(name) {
                        names.push(name.clone());
                    }
                }
            }
        }
        names.sort();
        let mut out = Vec::with_capacity(names.len());
        for name in names {
            if let Some(p) = self.program_primvar(gprim, &name, topology)? {
                out.push(p);
            }
        }
        Ok(out)
    }

    /// A display primvar reduced to one value (its only element, or the average) and whether its
    /// elements differ.
    fn display_primvar<const N: usize>(
        &mut self,
        gprim: &str,
        name: &str,
    ) -> Result<Option<([f64; N], bool)>, UsdError> {
        let values = match self.stage.attr(gprim, name)? {
            None => return Ok(None),
            Some(Value::Scalar(s)) if N == 1 => vec![[s; N]],
            Some(v) => match (v.as_tuple::<N>(), v.as_array::<N>()) {
                (Some(t), _) => vec![t],
                (None, Some(a)) => a,
                _ => {
                    self.warn(gprim, format!("{name} has an unexpected type; ignored"));
                    return Ok(None);
                }
            },
        };
        let values = match self.ints(gprim, &format!("{name}:indices")).ok().flatten() {
            Some(indices) => indices
                .into_iter()
                .filter_map(|i| usize::try_from(i).ok().and_then(|i| values.get(i)))
                .copied()
                .collect(),
            None => values,
        };
        if values.is_empty() {
            return Ok(None);
        }
        let varies = !values.windows(2).all(|w| w[0] == w[1]);
        let mut sum = [0.0; N];
        for v in &values {
            for (s, c) in sum.iter_mut().zip(v) {
                *s += c;
            }
        }
        Ok(Some((sum.map(|s| s / values.len() as f64), varies)))
    }
}

#[cfg(test)]
mod tests {
    use super::renders_collection_binding;

    #[test]
    fn only_full_and_all_purpose_collection_bindings_matter_to_a_final_render() {
        assert!(renders_collection_binding("material:binding:collection:Shiny"));
        assert!(renders_collection_binding("material:binding:collection:full:Shiny"));
        assert!(!renders_collection_binding("material:binding:collection:preview:MainMaterial"));
        assert!(!renders_collection_binding("material:binding:full"));
        assert!(!renders_collection_binding("material:binding"));
    }
}

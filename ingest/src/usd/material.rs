//! Material binding and UsdPreviewSurface constant inputs.
//!
//! Binding resolution (a simplified `UsdShadeMaterialBindingAPI::ComputeBoundMaterial` for the
//! "full" render purpose): at each prim from the gprim up to the root, the direct binding is
//! `material:binding:full` if authored, else `material:binding`. The nearest prim with a binding
//! wins, unless an ancestor's binding is `bindMaterialAs = "strongerThanDescendants"` (then the
//! topmost such ancestor wins). Only if no full/all-purpose binding exists anywhere up the chain is
//! `material:binding:preview` used, with a warning. Collection-based bindings are not resolved
//! (warned). GeomSubsets of a mesh carrying a direct binding give per-face materials.

use glam::Vec3;

use super::stage::Value;
use super::{Reader, UsdError};
use crate::scene::Material;

/// Where a shader input's value comes from.
enum Input {
    /// Not authored: the PreviewSurface fallback applies.
    Unauthored,
    /// An authored (or interface-forwarded) constant.
    Constant(Value),
    /// Connected to a texture / primvar-reader node: its `inputs:fallback` (if authored) and the
    /// output the connection reads (`rgb`, `r`, ...).
    Network { fallback: Option<Value>, output: String },
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

    /// Per-face material indices of a mesh with `faces` faces, honouring bound GeomSubsets.
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
                    if self
                        .stage
                        .property_names(&prim)
                        .iter()
                        .any(|p| p.starts_with("material:binding:collection"))
                    {
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
            None => self.display_color_material(gprim),
        }
    }

    fn add_material(&mut self, material: Material) -> u32 {
        let index = self.scene.materials.len() as u32;
        self.material_index.insert(material.path.clone(), index);
        self.scene.materials.push(material);
        index
    }

    /// Follows `prim.attr` through NodeGraph/Material outputs to the shader output it reads.
    fn surface_shader(&mut self, material: &str) -> Option<String> {
        let mut source = self.stage.connections(material, "outputs:surface").into_iter().next()?;
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
            self.warn(path, format!("bound material is a {ty:?} prim, not a Material; using displayColor"));
            return Ok(None);
        }
        let Some(shader) = self.surface_shader(path) else {
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
        let color = |r: &mut Self, name: &str, slot: &mut Vec3| -> Result<(), UsdError> {
            if let Some((v, out)) = r.input(path, &shader, name)? {
                if let Some(c) = as_color(&v, &out) {
                    *slot = c;
                }
            }
            Ok(())
        };
        color(self, "diffuseColor", &mut m.diffuse_color)?;
        color(self, "emissiveColor", &mut m.emissive_color)?;
        color(self, "specularColor", &mut m.specular_color)?;
        let float = |r: &mut Self, name: &str, slot: &mut f32| -> Result<(), UsdError> {
            if let Some((v, out)) = r.input(path, &shader, name)? {
                if let Some(f) = as_float(&v, &out) {
                    *slot = f;
                }
            }
            Ok(())
        };
        float(self, "roughness", &mut m.roughness)?;
        float(self, "metallic", &mut m.metallic)?;
        float(self, "ior", &mut m.ior)?;
        float(self, "opacity", &mut m.opacity)?;
        float(self, "opacityThreshold", &mut m.opacity_threshold)?;
        float(self, "clearcoat", &mut m.clearcoat)?;
        float(self, "clearcoatRoughness", &mut m.clearcoat_roughness)?;
        let mut workflow = 0.0;
        float(self, "useSpecularWorkflow", &mut workflow)?;
        m.use_specular_workflow = workflow != 0.0;
        Ok(Some(m))
    }

    /// The constant value of a shader input and the output channel it reads (`""` for a direct
    /// value), or `None` to keep the PreviewSurface fallback.
    fn input(
        &mut self,
        material: &str,
        shader: &str,
        name: &str,
    ) -> Result<Option<(Value, String)>, UsdError> {
        match self.trace_input(shader, &format!("inputs:{name}"))? {
            Input::Unauthored => Ok(None),
            Input::Constant(v) => Ok(Some((v, String::new()))),
            Input::Network { fallback, output } => {
                self.warn(
                    material,
                    format!("input {name} is connected to a texture network; textures not supported yet"),
                );
                Ok(fallback.map(|f| (f, output)))
            }
        }
    }

    /// Follows an input's connections through interface inputs to a constant or a network node.
    fn trace_input(&mut self, prim: &str, attr: &str) -> Result<Input, UsdError> {
        let (mut prim, mut attr) = (prim.to_string(), attr.to_string());
        for _ in 0..16 {
            let Some(source) = self.stage.connections(&prim, &attr).into_iter().next() else {
                return Ok(match self.stage.attr(&prim, &attr)? {
                    Some(v) => Input::Constant(v),
                    None => Input::Unauthored,
                });
            };
            let Some((src_prim, src_prop)) = source.split_once('.') else { return Ok(Input::Unauthored) };
            if self.stage.type_name(src_prim) == "Shader" {
                let output = src_prop.strip_prefix("outputs:").unwrap_or(src_prop).to_string();
                let fallback = self.stage.attr(src_prim, "inputs:fallback")?;
                return Ok(Input::Network { fallback, output });
            }
            (prim, attr) = (src_prim.to_string(), src_prop.to_string());
        }
        Ok(Input::Unauthored)
    }

    /// The material of an unbound gprim: `primvars:displayColor` / `primvars:displayOpacity`,
    /// named `<gprim>.displayColor`.
    fn display_color_material(&mut self, gprim: &str) -> Result<u32, UsdError> {
        let name = format!("{gprim}.displayColor");
        if let Some(&index) = self.material_index.get(&name) {
            return Ok(index);
        }
        let mut m = Material { path: name, ..Material::default() };
        if let Some(values) = self.display_primvar::<3>(gprim, "primvars:displayColor")? {
            m.diffuse_color = Vec3::new(values[0] as f32, values[1] as f32, values[2] as f32);
        }
        if let Some(values) = self.display_primvar::<1>(gprim, "primvars:displayOpacity")? {
            m.opacity = values[0] as f32;
        }
        Ok(self.add_material(m))
    }

    /// A display primvar reduced to one value: its only element, or the average with a warning.
    fn display_primvar<const N: usize>(
        &mut self,
        gprim: &str,
        name: &str,
    ) -> Result<Option<[f64; N]>, UsdError> {
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
        let constant = values.windows(2).all(|w| w[0] == w[1]);
        if !constant {
            self.warn(gprim, format!("{name} is not constant; using its average"));
        }
        let mut sum = [0.0; N];
        for v in &values {
            for (s, c) in sum.iter_mut().zip(v) {
                *s += c;
            }
        }
        Ok(Some(sum.map(|s| s / values.len() as f64)))
    }
}

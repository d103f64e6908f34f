//! UsdRender products: the RenderSettings' `products` → RenderProduct (`productName`, `orderedVars`)
//! → RenderVar (`sourceName`, `sourceType`, `dataType`), and the light groups light-path expressions
//! name.
//!
//! A var render cannot compute (an unknown raw `sourceName`, a `sourceType` other than `raw` and
//! `lpe`, a `dataType` that is not a float, colour or vector) is one warning naming its prim and is
//! left out of its product; a product with no `productName` or no var left is one warning and not
//! written. LPE syntax is render's to check (its grammar lives with the automaton it compiles to).

use blob::outputs::{data_type, source_type, RawSource};

use super::{Reader, UsdError};
use crate::scene::{RenderProduct, RenderVar};

/// Light attributes naming a light's group, first found wins (RenderMan, Karma, Arnold spellings);
/// unauthored, an LPE label matches the light's prim name.
pub(super) const LIGHT_GROUP_SPELLINGS: [&str; 5] = [
    "lightGroup",
    "inputs:lightGroup",
    "inputs:ri:light:lightGroup",
    "karma:light:lightgroup",
    "primvars:arnold:aov",
];

impl Reader<'_> {
    /// The RenderProducts of `settings`, in `products` order.
    pub(super) fn read_render_products(&mut self, settings: &str) -> Result<(), UsdError> {
        for product in self.stage.targets(settings, "products") {
            if let Some(p) = self.read_render_product(&product)? {
                self.scene.render_products.push(p);
            }
        }
        Ok(())
    }

    fn read_render_product(&mut self, path: &str) -> Result<Option<RenderProduct>, UsdError> {
        let name = self.token(path, "productName")?.unwrap_or_default();
        if name.is_empty() {
            self.warn(path, "RenderProduct has no productName; not written");
            return Ok(None);
        }
        let mut vars = Vec::new();
        for var in self.stage.targets(path, "orderedVars") {
            if let Some(v) = self.read_render_var(&var)? {
                vars.push(v);
            }
        }
        if vars.is_empty() {
            self.warn(path, format!("RenderProduct {name:?} has no var render can compute; not written"));
            return Ok(None);
        }
        Ok(Some(RenderProduct { path: path.to_string(), name, vars }))
    }

    fn read_render_var(&mut self, path: &str) -> Result<Option<RenderVar>, UsdError> {
        let source = self.token(path, "sourceName")?.unwrap_or_default();
        let kind = self.token(path, "sourceType")?.unwrap_or_else(|| "raw".into());
        let ty = self.token(path, "dataType")?.unwrap_or_else(|| "color3f".into());
        let source_type = match kind.as_str() {
            "raw" if RawSource::from_name(&source).is_some() => source_type::RAW,
            "raw" => {
                let known: Vec<&str> = RawSource::NAMES.iter().flat_map(|(_, n)| n.iter().copied()).collect();
                self.warn(
                    path,
                    format!("RenderVar sourceName {source:?} is not a raw value render computes ({}); not written", known.join(", ")),
                );
                return Ok(None);
            }
            "lpe" if !source.is_empty() => source_type::LPE,
            _ => {
                self.warn(
                    path,
                    format!("RenderVar sourceType {kind:?} (sourceName {source:?}) is not supported (raw, lpe); not written"),
                );
                return Ok(None);
            }
        };
        let data_type = match ty.as_str() {
            "float" | "half" | "double" | "int" | "uint" => data_type::FLOAT,
            "color3f" | "color3h" | "color3d" => data_type::COLOR3,
            "color4f" | "color4h" | "color4d" | "float4" | "half4" => data_type::COLOR4,
            "float3" | "half3" | "double3" | "vector3f" | "normal3f" | "point3f" => data_type::VECTOR3,
            _ => {
                self.warn(
                    path,
                    format!("RenderVar dataType {ty:?} is not a float, colour or vector type; not written"),
                );
                return Ok(None);
            }
        };
        Ok(Some(RenderVar { path: path.to_string(), source, source_type, data_type }))
    }

    /// The light group light `path` authors, if any.
    pub(super) fn light_group(&self, path: &str) -> Result<Option<String>, UsdError> {
        for name in LIGHT_GROUP_SPELLINGS {
            if let Some(group) = self.token(path, name)?.filter(|g| !g.is_empty()) {
                return Ok(Some(group));
            }
        }
        Ok(None)
    }
}

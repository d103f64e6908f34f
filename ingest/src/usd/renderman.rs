//! RenderMan's PxrDisney surface (a studio's `outputs:ri:surface`) as our UsdPreviewSurface-style
//! material: assets published from RenderMan pipelines (the USD tutorial's Table) bind materials
//! whose only surface is a PxrDisney shader, and a renderer that drew them with displayColor would
//! lose their look. Only constant inputs are read; the mapping follows Burley's Disney BRDF:
//! * `baseColor` → diffuse colour (and the metal's specular colour through `metallic`),
//! * `specular` s → the dielectric's normal reflectance F0 = 0.08·s, i.e. ior = (1+√F0)/(1−√F0),
//! * `roughness`, `metallic`, `clearcoat` as they are; `clearcoatGloss` g → the clear coat's GGX
//!   α = 0.1·(1−g) + 0.001·g, whose PreviewSurface roughness is √α,
//! * `emitColor` → emission, `presence` → opacity.
//!
//! Lobes PreviewSurface has no counterpart for (sheen, subsurface, anisotropy, specular tint) are
//! reported by name when they are not zero.

use crate::scene::Material;
use glam::Vec3;

/// PxrDisney's defaults (RenderMan's PxrDisney.args) for the inputs read here.
const BASE_COLOR: Vec3 = Vec3::new(0.2, 0.5, 0.8);
const SPECULAR: f32 = 0.5;
const ROUGHNESS: f32 = 0.25;
const CLEARCOAT_GLOSS: f32 = 1.0;

/// The PxrDisney inputs without a PreviewSurface counterpart, reported when authored non-zero.
pub const UNSUPPORTED_LOBES: [&str; 5] = ["sheen", "subsurface", "anisotropic", "specularTint", "sheenTint"];

/// The constant inputs of a PxrDisney shader, `None` where not authored (the default applies).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DisneyInputs {
    pub base_color: Option<Vec3>,
    pub emit_color: Option<Vec3>,
    pub metallic: Option<f32>,
    pub specular: Option<f32>,
    pub roughness: Option<f32>,
    pub clearcoat: Option<f32>,
    pub clearcoat_gloss: Option<f32>,
    pub presence: Option<f32>,
}

/// The material PxrDisney `inputs` describe (its `path` left empty for the caller).
pub fn disney_material(inputs: &DisneyInputs) -> Material {
    let f0 = (0.08 * inputs.specular.unwrap_or(SPECULAR)).clamp(0.0, 0.999);
    let gloss = inputs.clearcoat_gloss.unwrap_or(CLEARCOAT_GLOSS).clamp(0.0, 1.0);
    let coat_alpha = 0.1 * (1.0 - gloss) + 0.001 * gloss;
    Material {
        diffuse_color: inputs.base_color.unwrap_or(BASE_COLOR),
        emissive_color: inputs.emit_color.unwrap_or(Vec3::ZERO),
        metallic: inputs.metallic.unwrap_or(0.0),
        roughness: inputs.roughness.unwrap_or(ROUGHNESS),
        ior: (1.0 + f0.sqrt()) / (1.0 - f0.sqrt()),
        clearcoat: inputs.clearcoat.unwrap_or(0.0),
        clearcoat_roughness: coat_alpha.sqrt(),
        opacity: inputs.presence.unwrap_or(1.0),
        ..Material::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_and_the_disney_to_preview_surface_mapping() {
        let m = disney_material(&DisneyInputs::default());
        assert_eq!(m.diffuse_color, BASE_COLOR);
        assert_eq!(m.roughness, 0.25);
        // specular 0.5 is F0 = 0.04, the reflectance of ior 1.5.
        assert!((m.ior - 1.5).abs() < 1e-5, "{}", m.ior);
        assert!((m.clearcoat_roughness - 0.001f32.sqrt()).abs() < 1e-6);
        assert_eq!((m.opacity, m.metallic, m.clearcoat), (1.0, 0.0, 0.0));

        let m = disney_material(&DisneyInputs {
            base_color: Some(Vec3::new(0.0, 0.227, 0.004)),
            specular: Some(0.0),
            clearcoat_gloss: Some(0.0),
            presence: Some(0.5),
            metallic: Some(1.0),
            ..Default::default()
        });
        assert_eq!(m.diffuse_color, Vec3::new(0.0, 0.227, 0.004));
        // No specular: F0 = 0, ior 1 (no dielectric reflection).
        assert_eq!(m.ior, 1.0);
        assert!((m.clearcoat_roughness - 0.1f32.sqrt()).abs() < 1e-6);
        assert_eq!((m.opacity, m.metallic), (0.5, 1.0));
        // F0 = 0.08 for specular 1: ior = (1 + √0.08) / (1 − √0.08).
        let m = disney_material(&DisneyInputs { specular: Some(1.0), ..Default::default() });
        let f0 = ((m.ior - 1.0) / (m.ior + 1.0)).powi(2);
        assert!((f0 - 0.08).abs() < 1e-6, "{f0}");
    }
}

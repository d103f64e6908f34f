//! The UsdPreviewSurface inputs a material keeps as constants, listed once for every crate.
//!
//! [`crate::preview_surface_constants!`] hands the list to a macro of the caller's, which turns it into
//! that crate's form: the blob record ([`crate::Material`]), the scene model's material and its
//! fallbacks (scene-pack), the packer's conversion between the two, and render's shading inputs.
//! Adding an input here adds it everywhere at once (and the blob's format version goes up, since
//! the record grows).
//!
//! Each entry is `field: kind = fallback, "usdName";`, in the blob record's field order. Kinds:
//! `color` (`[f32; 3]` in the blob, `Vec3` elsewhere), `float` (`f32`), `flag` (`u32` 0 or 1 in the
//! blob, `bool` elsewhere). Fallbacks are the UsdPreviewSurface specification's.
//!
//! The last ten are OpenPBR Surface parameters (seven since format 12, the transmission three
//! since format 15; their names are the ASWF OpenPBR v1.1 specification's) that UsdPreviewSurface
//! lacks: with their fallbacks the surface is exactly UsdPreviewSurface (a clear coat of index 1.5,
//! its F0 0.04; an untinted, unweighted specular lobe; no fuzz; untinted, solid glass). OpenPBR's
//! `transmission_weight` is not among them: it is the refracting part UsdPreviewSurface already
//! has, `opacity = 1 − transmission_weight` with `opacityThreshold = 0`. `clearcoat` and `clearcoatRoughness` are OpenPBR's `coat_weight` and `coat_roughness`.
//! `specular_tint` is OpenPBR's `specular_color`, renamed because `specularColor` is
//! UsdPreviewSurface's specular-workflow F0. They are constants only (no program op writes them),
//! and validation at load keeps them finite and in [`OPENPBR_RANGES`].

/// Calls `$callback! { field: kind = fallback, "usdName"; … }` with the UsdPreviewSurface inputs a
/// material keeps as constants (see the [module docs](crate::surface_inputs)).
#[macro_export]
macro_rules! preview_surface_constants {
    ($callback:ident) => {
        $callback! {
            diffuse_color: color = [0.18, 0.18, 0.18], "diffuseColor";
            emissive_color: color = [0.0, 0.0, 0.0], "emissiveColor";
            specular_color: color = [0.0, 0.0, 0.0], "specularColor";
            roughness: float = 0.5, "roughness";
            metallic: float = 0.0, "metallic";
            ior: float = 1.5, "ior";
            opacity: float = 1.0, "opacity";
            opacity_threshold: float = 0.0, "opacityThreshold";
            clearcoat: float = 0.0, "clearcoat";
            clearcoat_roughness: float = 0.01, "clearcoatRoughness";
            use_specular_workflow: flag = false, "useSpecularWorkflow";
            coat_color: color = [1.0, 1.0, 1.0], "coat_color";
            coat_ior: float = 1.5, "coat_ior";
            specular_weight: float = 1.0, "specular_weight";
            specular_tint: color = [1.0, 1.0, 1.0], "specular_color";
            fuzz_weight: float = 0.0, "fuzz_weight";
            fuzz_color: color = [1.0, 1.0, 1.0], "fuzz_color";
            fuzz_roughness: float = 0.5, "fuzz_roughness";
            transmission_color: color = [1.0, 1.0, 1.0], "transmission_color";
            transmission_depth: float = 0.0, "transmission_depth";
            thin_walled: flag = false, "geometry_thin_walled";
        }
    };
}

/// The accepted range of each OpenPBR constant of the [`crate::Material`] record, `(name, low,
/// high)` (colour inputs: each channel): [`crate::SceneView::parse`] rejects a record with a value
/// outside it or not finite, and ingest clamps authored values into it with a warning. A coat of
/// index below 1 would turn the layering's Fresnel inside out; a specular weight above 1 could make
/// F0 exceed 1 (OpenPBR's soft range is [0, 1]).
/// A `transmission_depth` above [`MAX_TRANSMISSION_DEPTH`] is a unit mistake (and keeps the
/// absorption exponent `t / depth` well away from underflow).
pub const OPENPBR_RANGES: [(&str, f32, f32); 9] = [
    ("coat_color", 0.0, 1.0),
    ("coat_ior", 1.0, 10.0),
    ("specular_weight", 0.0, 1.0),
    ("specular_color", 0.0, 1.0),
    ("fuzz_weight", 0.0, 1.0),
    ("fuzz_color", 0.0, 1.0),
    ("fuzz_roughness", 0.0, 1.0),
    ("transmission_color", 0.0, 1.0),
    ("transmission_depth", 0.0, MAX_TRANSMISSION_DEPTH),
];

/// The largest `transmission_depth` validation accepts, in scene units.
pub const MAX_TRANSMISSION_DEPTH: f32 = 1.0e9;

/// The type of an input kind outside the blob, given the caller's 3-vector type: `color` → `$vec3`,
/// `float` → `f32`, `flag` → `bool`.
#[macro_export]
#[doc(hidden)]
macro_rules! model_input_type {
    (color, $vec3:ty) => {
        $vec3
    };
    (float, $vec3:ty) => {
        f32
    };
    (flag, $vec3:ty) => {
        bool
    };
}

/// An input kind's fallback in the blob's type.
#[macro_export]
#[doc(hidden)]
macro_rules! blob_fallback {
    (color, $v:expr) => {
        $v
    };
    (float, $v:expr) => {
        $v
    };
    (flag, $v:expr) => {
        $v as u32
    };
}

/// The blob type of an input kind (`color`, `float`, `flag`).
#[macro_export]
#[doc(hidden)]
macro_rules! blob_input_type {
    (color) => {
        [f32; 3]
    };
    (float) => {
        f32
    };
    (flag) => {
        u32
    };
}

//! Render outputs (format 14): the stage's RenderProduct and RenderVar prims, and the light groups
//! light-path expressions name.
//!
//! Sections (kinds 80–82): one [`RenderProduct`] per product of the stage's RenderSettings, in
//! `products` order; the [`RenderVar`]s of every product, concatenated in each product's
//! `orderedVars` order; and one [`crate::StrRef`] per light holding its light group (empty: the
//! light has none; an LPE label `'name'` then matches the light's prim name alone), or no record at all
//! when no light authors one. Ingest stores only vars whose source it recognised (the others are a
//! warning naming the prim), so every stored `source_type` and `data_type` is one of the constants
//! below (checked at parse).

use crate::StrRef;
use bytemuck::{Pod, Zeroable};

/// `sourceType` of a [`RenderVar`].
pub mod source_type {
    /// A value the renderer computes: `color`, `albedo`, `N`, `depth`, `P`, … (render's `aov` module
    /// lists them).
    pub const RAW: u32 = 0;
    /// A light-path expression.
    pub const LPE: u32 = 1;
    /// A primvar of the gprim the camera ray hits.
    pub const PRIMVAR: u32 = 2;
}

/// `dataType` of a [`RenderVar`]: how many channels it has and how they are named.
pub mod data_type {
    /// `float` (also `int`, `half`): one channel.
    pub const FLOAT: u32 = 0;
    /// `color3f` (also `color3h`): `R G B`.
    pub const COLOR3: u32 = 1;
    /// `color4f`: `R G B A`.
    pub const COLOR4: u32 = 2;
    /// `float3`, `vector3f`, `normal3f`, `point3f`: `X Y Z`.
    pub const VECTOR3: u32 = 3;
    /// Largest value.
    pub const LAST: u32 = VECTOR3;

    /// Channels of a data type (0 for an unknown one).
    pub fn channels(ty: u32) -> usize {
        match ty {
            FLOAT => 1,
            COLOR3 | VECTOR3 => 3,
            COLOR4 => 4,
            _ => 0,
        }
    }
}

/// One RenderProduct. 24 bytes.
///
/// | offset | field       | meaning                                                  |
/// |-------:|-------------|----------------------------------------------------------|
/// | 0      | `path`      | the product's prim path                                  |
/// | 8      | `name`      | `productName`: the file to write                         |
/// | 16     | `first_var` | index of its first [`RenderVar`]                         |
/// | 20     | `var_count` | its vars (`orderedVars` that were understood)            |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct RenderProduct {
    /// Prim path.
    pub path: StrRef,
    /// `productName`.
    pub name: StrRef,
    /// First var in the vars section.
    pub first_var: u32,
    /// Number of vars.
    pub var_count: u32,
}
const _: () = assert!(std::mem::size_of::<RenderProduct>() == 24);

/// One RenderVar. 32 bytes.
///
/// | offset | field         | meaning                                               |
/// |-------:|---------------|-------------------------------------------------------|
/// | 0      | `path`        | the var's prim path (its last element names the layer)|
/// | 8      | `source`      | `sourceName`                                          |
/// | 16     | `source_type` | a [`source_type`] constant                            |
/// | 20     | `data_type`   | a [`data_type`] constant                              |
/// | 24     | `reserved`    | zero                                                  |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct RenderVar {
    /// Prim path.
    pub path: StrRef,
    /// `sourceName`.
    pub source: StrRef,
    /// [`source_type`].
    pub source_type: u32,
    /// [`data_type`].
    pub data_type: u32,
    /// Reserved, zero.
    pub reserved: [u32; 2],
}
const _: () = assert!(std::mem::size_of::<RenderVar>() == 32);

/// The render outputs as ingest writes them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OutputData {
    /// Products.
    pub products: Vec<RenderProduct>,
    /// Their vars.
    pub vars: Vec<RenderVar>,
    /// One light group per light, or none.
    pub light_groups: Vec<StrRef>,
}

/// The validated render outputs of a blob.
#[derive(Clone, Copy, Debug, Default)]
pub struct OutputView<'a> {
    /// Products (var ranges, names and paths checked).
    pub products: &'a [RenderProduct],
    /// Vars (strings, source and data types checked).
    pub vars: &'a [RenderVar],
    /// Empty, or one per light (strings checked).
    pub light_groups: &'a [StrRef],
}

impl OutputView<'_> {
    /// Checks every record against `lights` lights and the strings check `strings_ok`; the error is
    /// (section, record, what).
    pub(crate) fn validate(
        &self,
        lights: usize,
        strings_ok: impl Fn(StrRef) -> bool,
    ) -> Result<(), (crate::SectionKind, usize, &'static str)> {
        use crate::SectionKind as K;
        for (i, p) in self.products.iter().enumerate() {
            if !strings_ok(p.path) || !strings_ok(p.name) || p.name.len == 0 {
                return Err((
                    K::RenderProducts,
                    i,
                    "path or productName outside the strings section, or empty",
                ));
            }
            if p.first_var as u64 + p.var_count as u64 > self.vars.len() as u64 {
                return Err((K::RenderProducts, i, "var range outside the render vars section"));
            }
        }
        for (i, v) in self.vars.iter().enumerate() {
            if !strings_ok(v.path) || !strings_ok(v.source) {
                return Err((K::RenderVars, i, "path or sourceName outside the strings section"));
            }
            if v.source_type > source_type::PRIMVAR || v.data_type > data_type::LAST || v.reserved != [0; 2] {
                return Err((K::RenderVars, i, "unknown source type or data type, or reserved bits set"));
            }
        }
        if !self.light_groups.is_empty() && self.light_groups.len() != lights {
            return Err((K::LightGroups, 0, "not one light group per light"));
        }
        if let Some(i) = self.light_groups.iter().position(|&g| !strings_ok(g)) {
            return Err((K::LightGroups, i, "light group outside the strings section"));
        }
        Ok(())
    }
}

/// A value render computes for a `raw` [`RenderVar`], named by its `sourceName`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawSource {
    /// The beauty (`color`, `Ci`, `C`, `beauty`, `rgba`); with a fourth channel its alpha.
    Color,
    /// Camera-sample coverage (`a`, `alpha`, `A`).
    Alpha,
    /// First-hit diffuse albedo (`albedo`).
    Albedo,
    /// First-hit world shading normal (`N`, `normal`, `Nn`).
    Normal,
    /// First-hit distance from the camera (`depth`, `z`, `Z`, `Pz`).
    Depth,
    /// First-hit world position (`P`, `position`).
    Position,
    /// Samples per pixel (`sampleCount`, `samples`).
    SampleCount,
    /// Screen-space motion of the first hit over the shutter, in pixels (`motionvector`, Arnold's
    /// and Karma's name; `motion`, `motionvectors`).
    Motion,
    /// Cryptomatte ids and coverage of the gprims' prim paths (`CryptoObject`, `crypto_object`).
    CryptoObject,
    /// Cryptomatte ids and coverage of the bound materials' paths (`CryptoMaterial`,
    /// `crypto_material`).
    CryptoMaterial,
}

impl RawSource {
    /// Every source and the `sourceName` spellings (RenderMan, Karma, Arnold, the UsdRender schema)
    /// that ask for it.
    pub const NAMES: &'static [(RawSource, &'static [&'static str])] = &[
        (RawSource::Color, &["color", "Ci", "C", "beauty", "rgba"]),
        (RawSource::Alpha, &["a", "alpha", "A"]),
        (RawSource::Albedo, &["albedo"]),
        (RawSource::Normal, &["N", "normal", "Nn"]),
        (RawSource::Depth, &["depth", "z", "Z", "Pz"]),
        (RawSource::Position, &["P", "position"]),
        (RawSource::SampleCount, &["sampleCount", "samples"]),
        (RawSource::Motion, &["motionvector", "motion", "motionvectors"]),
        (RawSource::CryptoObject, &["CryptoObject", "crypto_object"]),
        (RawSource::CryptoMaterial, &["CryptoMaterial", "crypto_material"]),
    ];

    /// The source a `sourceName` asks for, if render computes it.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::NAMES.iter().find(|(_, names)| names.contains(&name)).map(|(s, _)| *s)
    }
}

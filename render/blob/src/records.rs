//! The `#[repr(C)]`, `Pod` records stored in blob sections.
//!
//! Every record's size is stated in its doc comment and pinned by a `const` assertion, so a change of
//! layout is a compile error until [`crate::FORMAT_VERSION`] and the assertion are bumped together.
//! Cross-references are `u32` indices into other sections, never pointers, so the file is relocatable.

use bytemuck::{Pod, Zeroable};

/// "No index": the value of an optional `u32` index that is absent.
pub const NONE: u32 = u32::MAX;

/// A UTF-8 string stored in the [`crate::SectionKind::Strings`] section. 8 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct StrRef {
    /// Byte offset into the strings section.
    pub offset: u32,
    /// Length in bytes.
    pub len: u32,
}
const _: () = assert!(std::mem::size_of::<StrRef>() == 8);

/// Up axis of the source stage.
pub const UP_AXIS_Y: u32 = 1;
/// Up axis of the source stage.
pub const UP_AXIS_Z: u32 = 2;

/// Scene-wide facts; the [`crate::SectionKind::SceneInfo`] section holds exactly one. 104 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SceneInfo {
    /// World-space bounds of all renderable geometry (min; max). Empty scenes store min > max.
    pub bounds_min: [f32; 3],
    /// See `bounds_min`.
    pub bounds_max: [f32; 3],
    /// `metersPerUnit` of the stage.
    pub meters_per_unit: f32,
    /// [`UP_AXIS_Y`] or [`UP_AXIS_Z`].
    pub up_axis: u32,
    /// Index of the camera named by the stage's render settings (or the first camera), or [`NONE`].
    pub default_camera: u32,
    /// Resolution authored by a RenderSettings prim, or 0×0 when unauthored.
    pub resolution: [u32; 2],
    /// Number of gprims (composed Mesh prims) the triangles came from.
    pub gprim_count: u32,
    /// Number of instances (instanceable prims and point-instancer instances) the scene expanded.
    pub instance_count: u32,
    /// Index of the dome light in the lights section, or [`NONE`].
    pub dome_light: u32,
    /// Reserved, zero.
    pub reserved: [u32; 2],
    /// RenderSettings `dataWindowNDC` (xmin, ymin, xmax, ymax; (0, 0) the bottom-left corner of the
    /// frame, (1, 1) the top-right): the region render draws. A window of zero area means unauthored
    /// (the whole frame), so a zeroed record keeps today's meaning.
    pub data_window_ndc: [f32; 4],
    /// Where the blob's origin lies in the stage's world space: every position in the blob is
    /// `stage world − world_origin` (ingest renders camera-relative so that f32 positions keep
    /// their precision far from the stage origin). Finite; zero for scenes near the origin.
    pub world_origin: [f64; 3],
}
const _: () = assert!(std::mem::size_of::<SceneInfo>() == 104);

/// One triangle: three indices into the vertex sections and the mesh it belongs to. 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Triangle {
    /// Indices into positions/normals/uvs.
    pub vertices: [u32; 3],
    /// Index into the meshes section.
    pub mesh: u32,
}
const _: () = assert!(std::mem::size_of::<Triangle>() == 16);

/// The mesh has per-vertex shading normals in the normals section; otherwise shade with the face normal.
pub const MESH_HAS_NORMALS: u32 = 1;
/// The mesh has per-vertex texture coordinates in the uvs section.
pub const MESH_HAS_UVS: u32 = 2;
/// Both faces of the mesh are rendered (`doubleSided = true`). Single-sided meshes are still hit from
/// behind (USD leaves culling to the renderer; we never cull for path tracing) but are flagged for AOVs.
pub const MESH_DOUBLE_SIDED: u32 = 4;

/// One gprim after composition, triangulated and in world space. 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Mesh {
    /// Prim path.
    pub name: StrRef,
    /// First triangle in the triangles section.
    pub first_triangle: u32,
    /// Number of triangles.
    pub triangle_count: u32,
    /// First vertex in the vertex sections.
    pub first_vertex: u32,
    /// Number of vertices.
    pub vertex_count: u32,
    /// `MESH_*` bits.
    pub flags: u32,
    /// Index of the gprim's light set in the [`crate::SectionKind::LightSets`] section (format 8);
    /// 0 when the blob has no light sets (every light lights and is shadowed by every gprim).
    pub light_set: u32,
}
const _: () = assert!(std::mem::size_of::<Mesh>() == 32);

/// Words of one half of a light set for a blob with `light_count` lights: one bit per light.
///
/// A light set (UsdLux light and shadow linking, format 8) is `2 × light_set_words` `u32` words in
/// the [`crate::SectionKind::LightSets`] section: first the *lit-by* mask (bit `l % 32` of word
/// `l / 32` set: light `l` lights the gprim), then the *shadows* mask (set: the gprim blocks light
/// `l`'s shadow rays). Bits past the last light are zero. The section is empty when nothing is
/// linked, and then every [`Mesh::light_set`] is 0.
pub const fn light_set_words(light_count: usize) -> usize {
    light_count.div_ceil(32)
}

macro_rules! material_record {
    ($($field:ident: $kind:ident = $fallback:expr, $usd:literal;)*) => {
        /// UsdPreviewSurface inputs and the OpenPBR parameters beyond them as constants, plus the
        /// material's shading program. 168 bytes (148 before format 15, 96 before format 12).
        ///
        /// The constants are the values of inputs that no program op writes; a textured input's
        /// constant is the value the scene authored on the input itself (or the spec fallback) and is
        /// never read. The inputs are those of [`crate::preview_surface_constants!`], in its order.
        ///
        /// `Material::default()` is the specification's fallbacks (a zeroed record is not a valid
        /// material: its coat would have index 0).
        #[repr(C)]
        #[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
        pub struct Material {
            /// Material prim path (or the gprim path for a displayColor material).
            pub name: StrRef,
            $(
                #[doc = concat!("`", $usd, "`.")]
                pub $field: $crate::blob_input_type!($kind),
            )*
            /// First op of the material's program in the [`crate::SectionKind::ShaderOps`] section.
            pub program_start: u32,
            /// Ops in the program; 0 for a material whose inputs are all constants.
            pub program_len: u32,
            /// Reserved, zero.
            pub reserved: [u32; 3],
        }

        impl Default for Material {
            fn default() -> Self {
                Material {
                    name: StrRef::default(),
                    $($field: $crate::blob_fallback!($kind, $fallback),)*
                    program_start: 0,
                    program_len: 0,
                    reserved: [0; 3],
                }
            }
        }

        impl Material {
            /// The first OpenPBR constant not finite or outside its range
            /// ([`crate::surface_inputs::OPENPBR_RANGES`]), as validation's error text.
            pub fn openpbr_out_of_range(&self) -> Option<&'static str> {
                const WHAT: [&str; 10] = [
                    "coat_color not finite or outside [0, 1]",
                    "coat_ior not finite or outside [1, 10]",
                    "specular_weight not finite or outside [0, 1]",
                    "specular_color (specular_tint) not finite or outside [0, 1]",
                    "fuzz_weight not finite or outside [0, 1]",
                    "fuzz_color not finite or outside [0, 1]",
                    "fuzz_roughness not finite or outside [0, 1]",
                    "transmission_color not finite or outside [0, 1]",
                    "transmission_depth not finite or outside [0, 1e9]",
                    "geometry_thin_walled not 0 or 1",
                ];
                if self.thin_walled > 1 {
                    return Some(WHAT[9]);
                }
                let values: [&[f32]; 9] = [
                    &self.coat_color,
                    std::slice::from_ref(&self.coat_ior),
                    std::slice::from_ref(&self.specular_weight),
                    &self.specular_tint,
                    std::slice::from_ref(&self.fuzz_weight),
                    &self.fuzz_color,
                    std::slice::from_ref(&self.fuzz_roughness),
                    &self.transmission_color,
                    std::slice::from_ref(&self.transmission_depth),
                ];
                crate::surface_inputs::OPENPBR_RANGES
                    .iter()
                    .zip(values)
                    .zip(WHAT)
                    .find(|(((_, lo, hi), v), _)| !v.iter().all(|x| (*lo..=*hi).contains(x)))
                    .map(|(_, what)| what)
            }
        }
    };
}
crate::preview_surface_constants!(material_record);
const _: () = assert!(std::mem::size_of::<Material>() == 168);

/// Light kinds stored in [`Light::kind`].
pub mod light_kind {
    /// UsdLuxDomeLight (untextured: uniform radiance from every direction).
    pub const DOME: u32 = 0;
    /// UsdLuxDistantLight, shining along the light's −Z.
    pub const DISTANT: u32 = 1;
    /// UsdLuxSphereLight.
    pub const SPHERE: u32 = 2;
    /// UsdLuxRectLight in the light's XY plane, emitting along −Z.
    pub const RECT: u32 = 3;
    /// UsdLuxDiskLight in the light's XY plane, emitting along −Z.
    pub const DISK: u32 = 4;
    /// UsdLuxDomeLight with a lat-long texture: [`crate::Light::dome_map`] names its
    /// [`crate::DomeMap`] (format 6).
    pub const TEXTURED_DOME: u32 = 5;
}

/// `inputs:normalize`: power does not depend on size.
pub const LIGHT_NORMALIZE: u32 = 1;
/// `treatAsPoint` on a sphere light.
pub const LIGHT_TREAT_AS_POINT: u32 = 2;
/// Camera rays do not see the light (it still lights the scene, and shows in reflections);
/// format 8.
pub const LIGHT_CAMERA_HIDDEN: u32 = 4;

/// One UsdLux light. 96 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Light {
    /// Light prim path.
    pub name: StrRef,
    /// One of [`light_kind`].
    pub kind: u32,
    /// `LIGHT_*` bits.
    pub flags: u32,
    /// color × intensity × 2^exposure, before any normalization by area.
    pub radiance: [f32; 3],
    /// Sphere and disk radius, in light space.
    pub radius: f32,
    /// Rect width, in light space.
    pub width: f32,
    /// Rect height, in light space.
    pub height: f32,
    /// Distant light angular diameter, degrees.
    pub angle_degrees: f32,
    /// [`crate::DomeMap`] index of a [`light_kind::TEXTURED_DOME`]; zero for other kinds.
    pub dome_map: u32,
    /// Row-major 3×4 affine `world_from_light` (rows 0..3 of the 4×4, column vectors convention).
    pub world_from_light: [[f32; 4]; 3],
}
const _: () = assert!(std::mem::size_of::<Light>() == 96);

/// Camera projections stored in [`Camera::projection`].
pub const PROJECTION_PERSPECTIVE: u32 = 0;
/// See [`PROJECTION_PERSPECTIVE`].
pub const PROJECTION_ORTHOGRAPHIC: u32 = 1;

/// Most aperture blades [`Camera::aperture_blades`] may name; a polygon of more sides is a disc to
/// any pixel, and the bound keeps the lens sampler's sector index small.
pub const MAX_APERTURE_BLADES: u32 = 64;

/// Largest [`Camera::f_stop`] validation accepts. Real lenses stop at f/64–f/128; a larger number is
/// a pinhole in all but name and most likely a unit mistake.
pub const MAX_F_STOP: f32 = 1.0e6;

/// Largest shutter offset, in time codes from the frame, validation accepts on
/// [`Camera::shutter_open`], [`Camera::shutter_close`] and the motion keys' times: a shutter
/// longer than this is a unit mistake, and the bound keeps interpolation weights well conditioned.
pub const MAX_SHUTTER: f32 = 1.0e4;

/// One UsdGeomCamera. 128 bytes (112 before format 16).
///
/// Lens units follow UsdGeomCamera: `focalLength` and the apertures are in tenths of a scene unit,
/// `focusDistance` and `clippingRange` in scene units (see `render::camera` for how the thin lens
/// is built from them).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Camera {
    /// Camera prim path.
    pub name: StrRef,
    /// [`PROJECTION_PERSPECTIVE`] or [`PROJECTION_ORTHOGRAPHIC`].
    pub projection: u32,
    /// `focalLength`, tenths of a scene unit (the apertures' unit).
    pub focal_length: f32,
    /// `horizontalAperture`.
    pub horizontal_aperture: f32,
    /// `verticalAperture`.
    pub vertical_aperture: f32,
    /// `horizontalApertureOffset`.
    pub horizontal_aperture_offset: f32,
    /// `verticalApertureOffset`.
    pub vertical_aperture_offset: f32,
    /// `clippingRange` (near, far) in scene units.
    pub clipping_range: [f32; 2],
    /// `fStop`: 0 is a pinhole (no depth of field, USD's fallback); otherwise in (0, [`MAX_F_STOP`]].
    pub f_stop: f32,
    /// `focusDistance` in scene units; positive whenever `f_stop` is.
    pub focus_distance: f32,
    /// Blades of a polygonal aperture (`ri:apertureNSides`): 0 for a round aperture, else
    /// 3..=[`MAX_APERTURE_BLADES`].
    pub aperture_blades: u32,
    /// Rotation of the polygonal aperture (`ri:apertureAngle`), degrees counter-clockwise from the
    /// camera's +X to the first corner; finite, within ±360.
    pub aperture_rotation: f32,
    /// Row-major 3×4 affine `world_from_camera`; the camera looks down its −Z with +Y up.
    pub world_from_camera: [[f32; 4]; 3],
    /// `shutter:open`, time codes relative to the frame (format 13); finite, within
    /// ±[`MAX_SHUTTER`], at most `shutter_close`. Equal to it: an instantaneous shutter (no blur).
    pub shutter_open: f32,
    /// `shutter:close`, time codes relative to the frame.
    pub shutter_close: f32,
    /// First of the camera's transform keys in the [`crate::SectionKind::MotionKeys`] section
    /// (format 16; `world_from_object` there is `world_from_camera` at the key's time); 0 for a
    /// still camera.
    pub first_motion_key: u32,
    /// Number of keys: 0 for a camera that stands still, else 2..=[`crate::MAX_MOTION_KEYS`].
    pub motion_key_count: u32,
    /// Reserved, zero.
    pub reserved: [u32; 2],
}
const _: () = assert!(std::mem::size_of::<Camera>() == 128);

/// A triangle with nonzero emission, for next-event estimation. 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EmissiveTriangle {
    /// Index into the triangles section.
    pub triangle: u32,
    /// World-space area.
    pub area: f32,
    /// Cumulative distribution up to and including this entry (last entry = 1), proportional to
    /// emitted power (area × luminance of emission).
    pub cdf: f32,
    /// Probability of choosing this entry.
    pub pmf: f32,
}
const _: () = assert!(std::mem::size_of::<EmissiveTriangle>() == 16);

/// Children per [`BvhNode`].
pub const BVH_WIDTH: usize = 8;
/// Triangles per [`TriangleBlock`].
pub const BLOCK_WIDTH: usize = 4;

/// Child references stored in [`BvhNode::children`].
///
/// ```text
/// bit 31      1 = leaf, 0 = internal node
/// internal    bits 0..31: index of the child node (always greater than the parent's index)
/// leaf        bits 27..31: number of triangle blocks, bits 0..27: first block
/// empty slot  exactly EMPTY (a leaf of 0 blocks at block 0); any other 0-block leaf is rejected
/// ```
pub mod child_ref {
    /// Tag bit of a leaf reference.
    pub const LEAF: u32 = 1 << 31;
    /// Shift of a leaf's block count.
    pub const COUNT_SHIFT: u32 = 27;
    /// Largest block count of one leaf.
    pub const MAX_BLOCKS: u32 = 0xf;
    /// Mask of a leaf's first block index.
    pub const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;
    /// An unused child slot: a leaf with no blocks (its bounds are empty, min = +inf, max = −inf).
    pub const EMPTY: u32 = LEAF;

    /// A leaf of `count` blocks starting at `first`, or `None` if either does not fit.
    pub const fn leaf(first: u32, count: u32) -> Option<u32> {
        if first > FIRST_MASK || count > MAX_BLOCKS {
            None
        } else {
            Some(LEAF | count << COUNT_SHIFT | first)
        }
    }

    /// Whether a child reference is a leaf (else an internal node index). The one rule for "internal
    /// child": the validator and every BVH8 traversal in render decide with this function.
    #[inline(always)]
    pub const fn is_leaf(r: u32) -> bool {
        r & LEAF != 0
    }

    /// `(first block, block count)` of a leaf reference.
    #[inline(always)]
    pub const fn leaf_range(r: u32) -> (u32, u32) {
        (r & FIRST_MASK, (r >> COUNT_SHIFT) & MAX_BLOCKS)
    }
}

/// One node of the 8-wide BVH: the uncompressed bounds of up to eight children, stored SoA so one
/// SIMD lane tests one child, and their [`child_ref`]s. 256 bytes (four cache lines, 64-byte aligned
/// in the file).
///
/// `bounds[axis]` holds the children's minima on `axis` (x, y, z) and `bounds[3 + axis]` their maxima,
/// so a traversal picks the near and far plane arrays once per ray from the direction's signs.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    /// `[min_x, min_y, min_z, max_x, max_y, max_z]`, each one lane per child.
    pub bounds: [[f32; BVH_WIDTH]; 6],
    /// One [`child_ref`] per child.
    pub children: [u32; BVH_WIDTH],
    /// Reserved, zero (pads the node to four cache lines).
    pub reserved: [u32; BVH_WIDTH],
}
const _: () = assert!(std::mem::size_of::<BvhNode>() == 256);

/// Four triangles of a BVH leaf, vertices copied SoA so one SIMD lane tests one triangle, with the
/// blob triangle each lane came from. Unused lanes repeat a triangle of the same leaf. 160 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TriangleBlock {
    /// `vertices[corner][axis][lane]`: corner 0, 1, 2 of the blob triangle, world space.
    pub vertices: [[[f32; BLOCK_WIDTH]; 3]; 3],
    /// Index into the triangles section, per lane.
    pub triangles: [u32; BLOCK_WIDTH],
}
const _: () = assert!(std::mem::size_of::<TriangleBlock>() == 160);

/// One baked texture: size, texel format and where each mip level starts in the
/// [`crate::SectionKind::TextureTexels`] section. 168 bytes, align 8.
///
/// The one definition of the record: the `texture` crate re-exports it as `texture::TextureRecord`,
/// bakes it and samples through it in place, so ingest and render use the same type and no copy or
/// cast stands between them.
///
/// | offset | field           | meaning                                                             |
/// |-------:|-----------------|---------------------------------------------------------------------|
/// | 0      | `width`         | level-0 width in texels; level `l` is `max(1, width >> l)`          |
/// | 4      | `height`        | level-0 height, halved the same way                                 |
/// | 8      | `channels`      | stored channels: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA                |
/// | 12     | `format`        | `texture::TexelFormat` discriminant: 0 sRGB8, 1 unorm8, 2 f16       |
/// | 16     | `mip_count`     | levels stored, `floor(log2(max(width, height))) + 1` (down to 1×1)  |
/// | 20     | `tile_log2`     | tiles are `2^tile_log2` texels square (clipped to the level)        |
/// | 24     | `reserved`      | zero                                                                |
/// | 32     | `byte_len`      | bytes from `level_offsets[0]` to the end of the last level          |
/// | 40     | `level_offsets` | byte offset of each level in the texel section; unused entries zero |
///
/// Within a level, tiles are stored row-major and each tile's texels row-major, channels interleaved
/// (`texture::layout::LevelLayout`). Rows run bottom-up: row 0 is the bottom of the image, so the USD
/// texture coordinate `t` maps to rows without a flip.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct TextureRecord {
    /// Level-0 width in texels.
    pub width: u32,
    /// Level-0 height in texels.
    pub height: u32,
    /// Stored channels per texel, 1..=4.
    pub channels: u32,
    /// Texel format discriminant (0 sRGB8, 1 unorm8, 2 f16; `texture::TexelFormat` as `u32`).
    pub format: u32,
    /// Number of mip levels stored.
    pub mip_count: u32,
    /// log2 of the tile edge in texels.
    pub tile_log2: u32,
    /// Zero; keeps `byte_len` 8-aligned without implicit padding.
    pub reserved: [u32; 2],
    /// Total bytes of all levels, starting at `level_offsets[0]`.
    pub byte_len: u64,
    /// Byte offset of each level from the start of the texel section.
    pub level_offsets: [u64; MAX_MIP_LEVELS],
}
const _: () = assert!(std::mem::size_of::<TextureRecord>() == 168);
const _: () = assert!(std::mem::align_of::<TextureRecord>() == 8);

/// Most mip levels a texture may store: enough for [`MAX_TEXTURE_DIMENSION`] down to 1×1.
pub const MAX_MIP_LEVELS: usize = 16;
/// Largest texture width or height: `2^(MAX_MIP_LEVELS - 1)`.
pub const MAX_TEXTURE_DIMENSION: u32 = 1 << (MAX_MIP_LEVELS - 1);

/// A UDIM set: a `u_count × v_count` window of the UDIM grid in the [`crate::SectionKind::UdimTiles`]
/// section, whose cells are texture indices or [`NONE`] (a missing tile). 16 bytes; `texture` uses this
/// record as its `UdimSetRecord`. Tile `(u, v)` (UDIM number `1001 + u + 10 v`) is
/// `udim_tiles[first_tile + v * u_count + u]`; `u_count <= 10`; `v_count` covers the highest row found.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct UdimSet {
    /// Index of tile 1001 in the tile table.
    pub first_tile: u32,
    /// Columns, 1..=10.
    pub u_count: u32,
    /// Rows.
    pub v_count: u32,
    /// Zero.
    pub reserved: u32,
}
const _: () = assert!(std::mem::size_of::<UdimSet>() == 16);

/// Registers of a shading program: each a `vec4` of `f32`.
pub const MAX_REGISTERS: u32 = 16;

/// [`ShaderOp::kind`] values: the closed set of shader nodes a material program is made of.
pub mod op_kind {
    /// `r[dst] = params[0]`.
    pub const CONST: u32 = 0;
    /// `r[dst] = (u, v, 0, 1)` from the mesh's texture coordinates, or `params[0]` on a mesh without
    /// them (UsdPrimvarReader_float2 with its fallback).
    pub const PRIMVAR_UV: u32 = 1;
    /// `r[dst].xy = M · r[src].xy + t` with `M = params[0]` (row-major 2×2: scale, then rotation) and
    /// `t = params[1].xy` (UsdTransform2d); `zw` copied.
    pub const TRANSFORM_2D: u32 = 2;
    /// `r[dst] = lookup(texture, r[src].xy) · params[0] + params[1]`, or `params[2]` (the fallback)
    /// where the texture has no data (missing file, missing UDIM tile). `flags`: [`super::OP_UDIM`]
    /// and the wrap modes (see [`super::op_wrap_s`]).
    pub const TEXTURE: u32 = 3;
    /// Shading input `dst` (a [`super::shading_input`]) = `swizzle(r[src])`, the swizzle in `flags`
    /// as four 2-bit channel selectors, lowest first.
    pub const OUTPUT: u32 = 4;
    /// `r[dst] =` the hit mesh's primvar whose [`super::PrimvarRecord::name_id`] is `src`, interpolated
    /// with the triangle's barycentrics, or `params[0]` (the reader's fallback) where the mesh has no
    /// such primvar (UsdPrimvarReader_float/float3/float4/int). `src` is a key, not a register.
    pub const PRIMVAR: u32 = 5;
    /// `r[dst] = f(a, b, c)` per channel with `a = r[src]`, `b = r[src2]`, `c = r[src3]` and `f` the
    /// [`super::math_op`] in the low byte of `flags` (MaterialX arithmetic nodes). The result carries
    /// no footprint derivatives (a texture read through it filters at the finest level).
    pub const MATH: u32 = 6;
    /// One past the largest kind.
    pub const COUNT: u32 = 7;
}

/// [`op_kind::MATH`] functions, in the low byte of the op's `flags`; per channel `i` of `a`, `b`, `c`
/// (unused operands ignored). Each is one IEEE expression, evaluated the same way by the scalar and
/// the lane programs.
pub mod math_op {
    /// `a + b`.
    pub const ADD: u32 = 0;
    /// `a - b`.
    pub const SUBTRACT: u32 = 1;
    /// `a * b`.
    pub const MULTIPLY: u32 = 2;
    /// `a / b`.
    pub const DIVIDE: u32 = 3;
    /// `b + (a - b) * c`: MaterialX `mix(fg = a, bg = b, mix = c)`.
    pub const MIX: u32 = 4;
    /// `min(max(a, b), c)`: MaterialX `clamp(in, low, high)`.
    pub const CLAMP: u32 = 5;
    /// `powf(a, b)`.
    pub const POWER: u32 = 6;
    /// `min(a, b)`.
    pub const MIN: u32 = 7;
    /// `max(a, b)`.
    pub const MAX: u32 = 8;
    /// `a[s[i]]`, the four 2-bit channel selectors `s` in bits 8..16 of `flags`, lowest first
    /// (MaterialX `extract`, `convert`, `swizzle`, `separate`).
    pub const SWIZZLE: u32 = 9;
    /// A tangent-space normal from a `[0, 1]`-encoded one: `2a - 1`, then `x` and `y` times `b.x`
    /// (MaterialX `normalmap` with `scale`).
    pub const NORMAL_MAP: u32 = 10;
    /// `1 - a`.
    pub const ONE_MINUS: u32 = 11;
    /// `|a|`.
    pub const ABSOLUTE: u32 = 12;
    /// One past the largest function.
    pub const COUNT: u32 = 13;
}

/// An [`op_kind::MATH`] op's function (its `flags`) of its operand values: the one definition of
/// each [`math_op`], run by render's scalar and lane programs and by ingest when it folds
/// constant operands.
#[inline]
pub fn math(flags: u32, a: [f32; 4], b: [f32; 4], c: [f32; 4]) -> [f32; 4] {
    let each = |f: &dyn Fn(f32, f32, f32) -> f32| std::array::from_fn(|i| f(a[i], b[i], c[i]));
    match op_math(flags) {
        math_op::ADD => each(&|a, b, _| a + b),
        math_op::SUBTRACT => each(&|a, b, _| a - b),
        math_op::MULTIPLY => each(&|a, b, _| a * b),
        math_op::DIVIDE => each(&|a, b, _| a / b),
        math_op::MIX => each(&|a, b, c| b + (a - b) * c),
        math_op::CLAMP => each(&|a, b, c| a.max(b).min(c)),
        math_op::POWER => each(&|a, b, _| a.powf(b)),
        math_op::MIN => each(&|a, b, _| a.min(b)),
        math_op::MAX => each(&|a, b, _| a.max(b)),
        math_op::SWIZZLE => {
            let s = op_math_swizzle(flags);
            std::array::from_fn(|i| a[((s >> (2 * i)) & 3) as usize])
        }
        math_op::NORMAL_MAP => {
            let n: [f32; 4] = each(&|a, _, _| 2.0 * a - 1.0);
            [n[0] * b[0], n[1] * b[0], n[2], n[3]]
        }
        math_op::ONE_MINUS => each(&|a, _, _| 1.0 - a),
        math_op::ABSOLUTE => each(&|a, _, _| a.abs()),
        // Validated at parse: no other code reaches a renderer.
        _ => a,
    }
}

/// The [`math_op`] of an [`op_kind::MATH`] op's flags.
pub const fn op_math(flags: u32) -> u32 {
    flags & 0xff
}

/// The swizzle selectors of a [`math_op::SWIZZLE`] op's flags (see [`op_kind::OUTPUT`] for the layout).
pub const fn op_math_swizzle(flags: u32) -> u32 {
    (flags >> 8) & 0xff
}

/// [`op_kind::TEXTURE`] flag: `texture` indexes the UDIM sets, not the textures.
pub const OP_UDIM: u32 = 1;
/// Wrap modes in [`op_kind::TEXTURE`] flags: 0 repeat, 1 mirror, 2 clamp, 3 black.
pub const fn op_wrap_s(flags: u32) -> u32 {
    (flags >> 8) & 3
}
/// See [`op_wrap_s`].
pub const fn op_wrap_t(flags: u32) -> u32 {
    (flags >> 10) & 3
}
/// Packs wrap modes into [`op_kind::TEXTURE`] flags.
pub const fn op_wrap_flags(s: u32, t: u32) -> u32 {
    ((s & 3) << 8) | ((t & 3) << 10)
}

/// The UsdPreviewSurface inputs a program can drive ([`op_kind::OUTPUT`]'s `dst`).
pub mod shading_input {
    /// `diffuseColor` (rgb).
    pub const DIFFUSE_COLOR: u32 = 0;
    /// `emissiveColor` (rgb).
    pub const EMISSIVE_COLOR: u32 = 1;
    /// `specularColor` (rgb).
    pub const SPECULAR_COLOR: u32 = 2;
    /// `roughness` (x).
    pub const ROUGHNESS: u32 = 3;
    /// `metallic` (x).
    pub const METALLIC: u32 = 4;
    /// `opacity` (x).
    pub const OPACITY: u32 = 5;
    /// `normal`, tangent space (xyz).
    pub const NORMAL: u32 = 6;
    /// `clearcoat` (x).
    pub const CLEARCOAT: u32 = 7;
    /// `clearcoatRoughness` (x).
    pub const CLEARCOAT_ROUGHNESS: u32 = 8;
    /// `ior` (x).
    pub const IOR: u32 = 9;
    /// One past the largest input.
    pub const COUNT: u32 = 10;
}

/// One op of a material's shading program: a node of the UsdShade network, flattened. 80 bytes.
///
/// Programs are straight-line code over [`MAX_REGISTERS`] `vec4` registers, in dependency order, ending
/// in [`op_kind::OUTPUT`] ops that bind registers to shading inputs. See [`op_kind`] for each kind's
/// meaning of the fields.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShaderOp {
    /// One of [`op_kind`].
    pub kind: u32,
    /// Destination register, or the shading input for [`op_kind::OUTPUT`].
    pub dst: u32,
    /// Source register (ignored by `CONST` and `PRIMVAR_UV`).
    pub src: u32,
    /// Texture or UDIM-set index for [`op_kind::TEXTURE`] ([`NONE`]: missing, use the fallback).
    pub texture: u32,
    /// Kind-specific bits.
    pub flags: u32,
    /// Second source register of [`op_kind::MATH`] (zero for the other kinds).
    pub src2: u32,
    /// Third source register of [`op_kind::MATH`] (zero for the other kinds).
    pub src3: u32,
    /// Reserved, zero.
    pub reserved: u32,
    /// Kind-specific constants.
    pub params: [[f32; 4]; 3],
}
const _: () = assert!(std::mem::size_of::<ShaderOp>() == 80);

/// How a [`PrimvarRecord`]'s values map onto its mesh, after triangulation (USD's `varying` is stored
/// as [`primvar_interpolation::VERTEX`], `uniform` per triangle, `faceVarying` per triangle corner).
pub mod primvar_interpolation {
    /// One value for the whole mesh.
    pub const CONSTANT: u32 = 0;
    /// One value per triangle of the mesh, in triangle order.
    pub const UNIFORM: u32 = 1;
    /// One value per vertex of the mesh (`vertex - first_vertex`), interpolated across triangles.
    pub const VERTEX: u32 = 2;
    /// Three values per triangle, in the order of its vertices, interpolated within the triangle.
    pub const FACE_VARYING: u32 = 3;
    /// One past the largest code.
    pub const COUNT: u32 = 4;
}

/// One primvar of one mesh that some material program reads ([`op_kind::PRIMVAR`]). 32 bytes.
///
/// Records are sorted by `(mesh, name_id)` without repeats (checked at parse), so the primvar a
/// program reads at a hit is a binary search. Values live in the
/// [`crate::SectionKind::PrimvarValues`] section as `[f32; 4]`, already widened the way the readers
/// widen them: a scalar `s` as `(s, s, s, 1)`, a 2-vector as `(x, y, 0, 1)`, a 3-vector as `(x, y, z, 1)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PrimvarRecord {
    /// Primvar name without the `primvars:` prefix (`displayColor`).
    pub name: StrRef,
    /// The name's key, shared by every mesh and by the ops that read it.
    pub name_id: u32,
    /// Index into the meshes section.
    pub mesh: u32,
    /// One of [`primvar_interpolation`].
    pub interpolation: u32,
    /// Components authored per element, 1..=4.
    pub components: u32,
    /// First value in the primvar-values section.
    pub first_value: u32,
    /// Values: 1, the mesh's triangle count, its vertex count or three per triangle.
    pub value_count: u32,
}
const _: () = assert!(std::mem::size_of::<PrimvarRecord>() == 32);

/// One node of a compressed wide BVH (CWBVH, Ylitie et al. 2017), used for the curve BVH; bit-identical to
/// `obvhs::cwbvh::CwBvhNode` 0.4 so render can traverse the mapped slice directly. 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CwBvhNode {
    /// Min point of the node's bounds.
    pub p: [f32; 3],
    /// Exponents of the child-bounds quantization.
    pub e: [u8; 3],
    /// Bit per child: 1 = internal node.
    pub imask: u8,
    /// First child node index.
    pub child_base_idx: u32,
    /// First primitive index into the BVH primitive section.
    pub primitive_base_idx: u32,
    /// Per-child meta byte (see obvhs docs).
    pub child_meta: [u8; 8],
    /// Quantized child bounds.
    pub child_min_x: [u8; 8],
    /// Quantized child bounds.
    pub child_max_x: [u8; 8],
    /// Quantized child bounds.
    pub child_min_y: [u8; 8],
    /// Quantized child bounds.
    pub child_max_y: [u8; 8],
    /// Quantized child bounds.
    pub child_min_z: [u8; 8],
    /// Quantized child bounds.
    pub child_max_z: [u8; 8],
}
const _: () = assert!(std::mem::size_of::<CwBvhNode>() == 80);

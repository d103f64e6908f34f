//! The validated scene model between USD and the blob.
//!
//! Everything here is already composed, flattened to world space and triangulated: the USD reader
//! (ingest's `usd` module) produces it, `crate::pack` turns it into blob records. Gprims inside instances are
//! kept as a reference to local-space geometry shared by every identical instance plus their
//! transforms ([`PlacedMesh`]): 1,000 instances of a mesh hold one mesh through ingest, and world
//! copies are made only where one is packed in world space (`--flatten-instances`, singletons).
//! Hand-built scenes may instead give a world-space mesh with an explicit instance-space copy
//! ([`InstancedMesh`]). Nothing in this module knows about USD or about the blob layout.

use glam::{DMat3, DMat4, DVec3, Mat4, Vec2, Vec3, Vec4};
use std::borrow::Cow;
use std::sync::Arc;

/// A composed, world-space, renderable scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Renderable gprims (Mesh prims), one entry per instance once instancing is flattened.
    pub meshes: Vec<Mesh>,
    /// Wall seconds of the load's heavy phases, so composition can be timed apart from them.
    pub load_timings: LoadTimings,
    /// Curve and point prims (BasisCurves, NurbsCurves, Points), one entry per instance.
    pub curves: Vec<Curves>,
    /// Materials; `Mesh::triangle_materials` index into this.
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Cameras.
    pub cameras: Vec<Camera>,
    /// Index into `cameras` of the camera named by RenderSettings (or the first camera).
    pub default_camera: Option<usize>,
    /// Resolution authored by RenderSettings, if any.
    pub resolution: Option<[u32; 2]>,
    /// RenderSettings `dataWindowNDC` (xmin, ymin, xmax, ymax; y up), if authored and not the whole frame.
    pub data_window_ndc: Option<[f32; 4]>,
    /// `metersPerUnit` of the stage (fallback 0.01).
    pub meters_per_unit: f64,
    /// Up axis of the stage.
    pub up_axis: UpAxis,
    /// Number of instances (instanceable prims / point-instancer entries) expanded.
    pub instance_count: u32,
    /// The outermost instances (instanceable prims and point-instancer entries not inside another
    /// instance): what [`Mesh::instance`] refers to. `crate::instancing` turns them into shared
    /// prototypes when packing.
    pub instances: Vec<SceneInstance>,
    /// Unsupported features and other non-fatal findings, each naming the prim and the feature.
    pub warnings: Vec<Warning>,
    /// The subdivision surfaces among `meshes`: their cages and the level each was diced at.
    pub subdivisions: Vec<Subdivision>,
    /// Baked textures read by the materials' programs ([`ShaderNode::Texture`] indexes this).
    pub textures: Vec<SceneTexture>,
    /// The distinct light sets of the gprims ([`Mesh::light_set`]); empty when no light links or
    /// shadow-links anything short of every gprim.
    pub light_sets: Vec<LightSet>,
    /// Indices into `lights` of the lights camera rays do not see (ascending).
    pub camera_hidden_lights: Vec<usize>,
    /// Where this scene's origin lies in the stage's world space: every position here is
    /// `stage world − world_origin` (see `blob::SceneInfo::world_origin`).
    pub world_origin: DVec3,
    /// The RenderSettings' products, in `products` order (empty: render writes its beauty EXR alone).
    pub render_products: Vec<RenderProduct>,
    /// The light group of each light, indexed like `lights` (empty: no light authors one).
    pub light_groups: Vec<Option<String>>,
}

/// A RenderProduct: one multi-layer EXR of its vars.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderProduct {
    /// Prim path.
    pub path: String,
    /// `productName`: the file render writes.
    pub name: String,
    /// Its `orderedVars` that ingest understood, in order.
    pub vars: Vec<RenderVar>,
}

/// A RenderVar: one layer of a product.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderVar {
    /// Prim path (its last element names the EXR layer).
    pub path: String,
    /// `sourceName`.
    pub source: String,
    /// `sourceType`: a `blob::outputs::source_type` constant.
    pub source_type: u32,
    /// `dataType`: a `blob::outputs::data_type` constant.
    pub data_type: u32,
}

/// A texture a bound material reads, already decoded and baked (mip chain, tiles) at read time, so
/// that a file that cannot be read is a warning on the shader that names it, not a pack error.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneTexture {
    /// The resolved file, or the `<UDIM>` pattern.
    pub path: std::path::PathBuf,
    /// `sourceColorSpace` it was baked with (a file read in two colour spaces is two textures).
    pub color_space: texture::ColorSpace,
    /// The baked data.
    pub data: TextureData,
}

/// One image, or the tiles of a UDIM set found on disk.
#[derive(Clone, Debug, PartialEq)]
pub enum TextureData {
    /// A single image.
    Image(texture::BakedTexture),
    /// UDIM tiles as `(u, v, baked)`, tile number `1001 + u + 10 v`; absent tiles are holes whose
    /// lookups return the texture node's fallback.
    Udim(Vec<(u32, u32, texture::BakedTexture)>),
}

/// A UsdPreviewSurface input a material program can drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShadingInput {
    /// `diffuseColor`.
    DiffuseColor,
    /// `emissiveColor`.
    EmissiveColor,
    /// `specularColor`.
    SpecularColor,
    /// `roughness`.
    Roughness,
    /// `metallic`.
    Metallic,
    /// `opacity`.
    Opacity,
    /// `normal` (tangent space, `[-1, 1]³`).
    Normal,
    /// `clearcoat`.
    Clearcoat,
    /// `clearcoatRoughness`.
    ClearcoatRoughness,
    /// `ior`.
    Ior,
}

/// One node of a material's shading network, flattened to straight-line code over `vec4` registers
/// (at most `blob::MAX_REGISTERS`). Programs list nodes in dependency order and end with
/// [`ShaderNode::Output`]s.
#[derive(Clone, Debug, PartialEq)]
pub enum ShaderNode {
    /// `r[dst] = value`.
    Const {
        /// Destination register.
        dst: u32,
        /// The value.
        value: [f32; 4],
    },
    /// `r[dst] = (u, v, 0, 1)` of the mesh's texture coordinates, `fallback` on a mesh without them.
    PrimvarUv {
        /// Destination register.
        dst: u32,
        /// `inputs:fallback` of the primvar reader.
        fallback: [f32; 4],
    },
    /// UsdPrimvarReader_float/float3/float4/int: `r[dst]` = the hit mesh's primvar `name` (see
    /// [`MeshPrimvar`]), interpolated, or `fallback` where the mesh does not carry it.
    Primvar {
        /// Destination register.
        dst: u32,
        /// `inputs:varname` (without the `primvars:` prefix).
        name: String,
        /// `inputs:fallback` of the reader, widened to a `vec4`.
        fallback: [f32; 4],
    },
    /// UsdTransform2d: `r[dst].xy = translation + rotate(rotation_degrees, scale * r[src].xy)`.
    Transform2d {
        /// Destination register.
        dst: u32,
        /// Source register.
        src: u32,
        /// `inputs:rotation`, degrees counter-clockwise.
        rotation_degrees: f32,
        /// `inputs:scale`.
        scale: [f32; 2],
        /// `inputs:translation`.
        translation: [f32; 2],
    },
    /// UsdUVTexture: `r[dst] = lookup(r[src].xy) * scale + bias`, or `fallback` without data.
    Texture {
        /// Destination register.
        dst: u32,
        /// Register holding `st`.
        src: u32,
        /// Index into [`Scene::textures`]; `None` when the file is missing (lookups use `fallback`).
        texture: Option<u32>,
        /// `inputs:wrapS`.
        wrap_s: texture::Wrap,
        /// `inputs:wrapT`.
        wrap_t: texture::Wrap,
        /// `inputs:scale`.
        scale: [f32; 4],
        /// `inputs:bias`.
        bias: [f32; 4],
        /// `inputs:fallback`.
        fallback: [f32; 4],
    },
    /// MaterialX arithmetic: `r[dst] = op(r[a], r[b], r[c])` per channel (see [`blob::math_op`] for
    /// each function; operands a function does not use are ignored).
    Math {
        /// Destination register.
        dst: u32,
        /// The function.
        op: MathOp,
        /// Operand registers `a`, `b`, `c`.
        srcs: [u32; 3],
    },
    /// Binds `swizzle(r[src])` to a shading input.
    Output {
        /// The input.
        input: ShadingInput,
        /// Source register.
        src: u32,
        /// Channel of `r[src]` per component (the connected output: `rgb` → `[0, 1, 2, 3]`, `r` →
        /// `[0; 4]`, `a` → `[3; 4]`).
        swizzle: [u8; 4],
    },
}

/// The functions of [`ShaderNode::Math`], one per [`blob::math_op`] code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MathOp {
    /// `a + b`.
    Add,
    /// `a - b`.
    Subtract,
    /// `a * b`.
    Multiply,
    /// `a / b`.
    Divide,
    /// `b + (a - b) * c` (MaterialX `mix(fg, bg, mix)`).
    Mix,
    /// `min(max(a, b), c)`.
    Clamp,
    /// `a ^ b`.
    Power,
    /// `min(a, b)`.
    Min,
    /// `max(a, b)`.
    Max,
    /// `a` with channel `i` taken from channel `selectors[i]`.
    Swizzle([u8; 4]),
    /// `2a - 1`, `x` and `y` then times `b.x`.
    NormalMap,
    /// `1 - a`.
    OneMinus,
    /// `|a|`.
    Absolute,
}

impl MathOp {
    /// The op's [`blob::ShaderOp::flags`]: the [`blob::math_op`] code, and a swizzle's selectors.
    pub fn flags(self) -> u32 {
        use blob::math_op as m;
        match self {
            MathOp::Add => m::ADD,
            MathOp::Subtract => m::SUBTRACT,
            MathOp::Multiply => m::MULTIPLY,
            MathOp::Divide => m::DIVIDE,
            MathOp::Mix => m::MIX,
            MathOp::Clamp => m::CLAMP,
            MathOp::Power => m::POWER,
            MathOp::Min => m::MIN,
            MathOp::Max => m::MAX,
            MathOp::Swizzle(s) => {
                m::SWIZZLE | s.iter().enumerate().fold(0, |f, (i, &c)| f | ((c as u32 & 3) << (8 + 2 * i)))
            }
            MathOp::NormalMap => m::NORMAL_MAP,
            MathOp::OneMinus => m::ONE_MINUS,
            MathOp::Absolute => m::ABSOLUTE,
        }
    }
}

impl ShaderNode {
    /// The mesh's uvs through a UsdTransform2d into register 1 (register 0 holds them untransformed):
    /// the head of a program whose texture lookups read `st` from register 1.
    pub fn transformed_uvs(rotation_degrees: f32, scale: [f32; 2], translation: [f32; 2]) -> Vec<ShaderNode> {
        vec![
            ShaderNode::PrimvarUv { dst: 0, fallback: [0.0; 4] },
            ShaderNode::Transform2d { dst: 1, src: 0, rotation_degrees, scale, translation },
        ]
    }

    /// The program of a material whose diffuse colour is texture `texture` read at the mesh's uvs
    /// (repeat wrap, `fallback` where there is no texel); register 1 holds the texel, so callers may
    /// route more of its channels (e.g. alpha to roughness) with further [`ShaderNode::Output`]s.
    pub fn diffuse_texture_program(texture: u32, fallback: [f32; 4]) -> Vec<ShaderNode> {
        vec![
            ShaderNode::PrimvarUv { dst: 0, fallback: [0.0; 4] },
            ShaderNode::Texture {
                dst: 1,
                src: 0,
                texture: Some(texture),
                wrap_s: texture::Wrap::Repeat,
                wrap_t: texture::Wrap::Repeat,
                scale: [1.0; 4],
                bias: [0.0; 4],
                fallback,
            },
            ShaderNode::Output { input: ShadingInput::DiffuseColor, src: 1, swizzle: [0, 1, 2, 3] },
        ]
    }
}

/// Stage up axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UpAxis {
    /// `upAxis = "Y"` (USD's fallback).
    #[default]
    Y,
    /// `upAxis = "Z"`.
    Z,
}

/// A non-fatal finding, printed by the `ingest` binary.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// Prim path the finding is about.
    pub prim: String,
    /// What was unsupported or odd.
    pub message: String,
}

/// One triangulated gprim in world space.
///
/// Vertices are per *shading* vertex: where normals or uvs are faceVarying, the reader splits vertices
/// per face corner so every attribute is per vertex here.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Prim path (for instances: the instance proxy path).
    pub path: String,
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// World-space unit shading normals, one per position, or empty (flat shading).
    pub normals: Vec<Vec3>,
    /// Texture coordinates (`primvars:st` or the first texCoord2f primvar), one per position, or empty.
    pub uvs: Vec<Vec2>,
    /// Counter-clockwise (right-handed, after applying `orientation`) triangles indexing `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Index into `Scene::materials` per triangle.
    pub triangle_materials: Vec<u32>,
    /// `doubleSided`.
    pub double_sided: bool,
    /// For a gprim inside an instance: the same gprim in the instance's space, so that identical
    /// instances can share one prototype. `None` for gprims drawn once.
    pub instance: Option<InstancedMesh>,
    /// The primvars the mesh's materials read ([`ShaderNode::Primvar`]), sorted by name.
    pub primvars: Vec<MeshPrimvar>,
    /// Index into [`Scene::light_sets`] (light and shadow linking); 0 when the scene has none.
    pub light_set: u32,
    /// For a gprim inside an instance as the USD reader keeps it: its geometry by reference, in
    /// local space, with its transforms. `positions`, `normals`, `uvs`, `triangles` and `primvars`
    /// are then empty (see [`Mesh::in_world`]); `triangle_materials` is the instance's own.
    pub placed: Option<PlacedMesh>,
    /// Transform motion over the shutter, or `None` for a gprim that stands still. The mesh's
    /// world-space geometry is where it is at the frame; the keys move that geometry.
    pub motion: Option<TransformMotion>,
    /// Deformation motion over the shutter (time-sampled points, velocities), or `None`. Only a
    /// world-space mesh (not inside an instance, without `motion`: ingest bakes a moving
    /// transform into the keys) deforms; `positions` stay the frame's.
    pub deformation: Option<Deformation>,
}

/// Where a deforming mesh's vertices are over the shutter: world-space positions (relative to the
/// world origin, as `Mesh::positions`) at each key time, one per vertex of the mesh, in its
/// order. Between keys the renderer interpolates each vertex linearly (see `blob::deform`), so
/// the keys are the shutter's open and close, the frame and the times USD authors inside it.
#[derive(Clone, Debug, PartialEq)]
pub struct Deformation {
    /// At least two keys, times strictly increasing; the key at time 0, when there is one, holds
    /// the mesh's own positions.
    pub keys: Vec<DeformKey>,
}

/// One key of a [`Deformation`].
#[derive(Clone, Debug, PartialEq)]
pub struct DeformKey {
    /// Time codes from the frame.
    pub time: f32,
    /// The mesh's vertices at `time`, as many as `Mesh::positions`.
    pub positions: Vec<Vec3>,
}

/// Where a moving gprim is over the shutter: keys of `world_from_stored`, the transform taking its
/// stored world-space geometry (the frame's) to where it is at the key's time. Between keys the
/// renderer interpolates the matrices linearly (see `blob::instances`), so the keys are the times
/// USD authors inside the shutter plus its open and close, each evaluated as USD evaluates the
/// xformOps there.
#[derive(Clone, Debug, PartialEq)]
pub struct TransformMotion {
    /// At least two keys, times strictly increasing.
    pub keys: Vec<MotionKey>,
}

/// One key of a [`TransformMotion`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionKey {
    /// Time codes from the frame.
    pub time: f32,
    /// Stored (frame) world space to world space at `time`.
    pub world_from_stored: DMat4,
}

impl TransformMotion {
    /// The placement at time `t` (time codes from the frame): the keys' matrices interpolated
    /// linearly, the end keys held outside them.
    pub fn at(&self, t: f32) -> DMat4 {
        let keys = &self.keys;
        let (Some(first), Some(last)) = (keys.first(), keys.last()) else { return DMat4::IDENTITY };
        if t <= first.time {
            return first.world_from_stored;
        }
        if t >= last.time {
            return last.world_from_stored;
        }
        let i = keys.partition_point(|k| k.time <= t).clamp(1, keys.len() - 1);
        let (a, b) = (&keys[i - 1], &keys[i]);
        let w = f64::from((t - a.time) / (b.time - a.time));
        a.world_from_stored * (1.0 - w) + b.world_from_stored * w
    }
}

/// Triangulated geometry in a gprim's local space, shared by every instance whose copy of the gprim
/// is identical (same points, normals, uvs, triangles and primvars).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LocalGeometry {
    /// Local-space positions, in `f64` so that world and instance copies round as a direct
    /// transform of the authored points would.
    pub positions: Vec<DVec3>,
    /// Local-space normals (empty: flat shading).
    pub normals: Vec<DVec3>,
    /// Texture coordinates, one per position, or empty.
    pub uvs: Vec<Vec2>,
    /// Triangles wound for the local space.
    pub triangles: Vec<[u32; 3]>,
    /// Primvars, per-corner values in the local winding.
    pub primvars: Vec<MeshPrimvar>,
}

/// Positions, normals, triangles and primvars of [`LocalGeometry`] moved to another space.
pub struct Transformed {
    /// Positions in the target space.
    pub positions: Vec<Vec3>,
    /// Unit normals (inverse transpose), or empty.
    pub normals: Vec<Vec3>,
    /// Triangles, flipped where the transform mirrors.
    pub triangles: Vec<[u32; 3]>,
    /// Primvars, corner values following their triangle's vertex order.
    pub primvars: Vec<MeshPrimvar>,
}

impl LocalGeometry {
    /// The geometry under `target_from_local`.
    ///
    /// A transform with negative determinant mirrors the surface; the winding is flipped so the
    /// triangles stay counter-clockwise about the (inverse-transpose transformed) normals, as Hydra
    /// does (`orientation` XOR mirrored).
    pub fn transformed(&self, target_from_local: DMat4) -> Transformed {
        let normal_from_local = DMat3::from_mat4(target_from_local).inverse().transpose();
        let mut triangles = self.triangles.clone();
        let mut primvars = self.primvars.clone();
        if target_from_local.determinant() < 0.0 {
            triangles.iter_mut().for_each(|t| t.swap(1, 2));
            for p in primvars.iter_mut().filter(|p| p.layout == PrimvarLayout::PerCorner) {
                p.values.chunks_exact_mut(3).for_each(|c| c.swap(1, 2));
            }
        }
        Transformed {
            positions: self
                .positions
                .iter()
                .map(|&p| target_from_local.project_point3(p).as_vec3())
                .collect(),
            normals: self
                .normals
                .iter()
                .map(|&n| (normal_from_local * n).normalize_or_zero().as_vec3())
                .collect(),
            triangles,
            primvars,
        }
    }

    /// Bounds of the positions under `target_from_local`, exactly as those of
    /// [`LocalGeometry::transformed`] (without making the copy).
    pub fn bounds(&self, target_from_local: DMat4) -> [Vec3; 2] {
        self.positions.iter().fold(
            [Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)],
            |[lo, hi], &p| {
                let p = target_from_local.project_point3(p).as_vec3();
                [lo.min(p), hi.max(p)]
            },
        )
    }
}

/// A gprim inside an instance: shared local geometry and where this instance puts it.
#[derive(Clone, Debug)]
pub struct PlacedMesh {
    /// Index into [`Scene::instances`].
    pub instance: u32,
    /// The geometry (one allocation for every identical instance).
    pub geometry: Arc<LocalGeometry>,
    /// Local-to-world transform.
    pub world_from_local: DMat4,
    /// Local-to-instance transform (the same for every instance of a prototype).
    pub instance_from_local: DMat4,
    /// World bounds of the positions (computed once, for the listing and the scene bounds).
    pub world_bounds: [Vec3; 2],
}

impl PlacedMesh {
    /// Places `geometry` inside instance `instance`.
    pub fn new(
        instance: u32,
        geometry: Arc<LocalGeometry>,
        world_from_local: DMat4,
        instance_from_local: DMat4,
    ) -> Self {
        let world_bounds = geometry.bounds(world_from_local);
        PlacedMesh { instance, geometry, world_from_local, instance_from_local, world_bounds }
    }
}

impl Mesh {
    /// Triangles drawn.
    pub fn triangle_count(&self) -> usize {
        self.placed.as_ref().map_or(self.triangles.len(), |p| p.geometry.triangles.len())
    }

    /// Vertices.
    pub fn vertex_count(&self) -> usize {
        self.placed.as_ref().map_or(self.positions.len(), |p| p.geometry.positions.len())
    }

    /// World bounds of the vertices (`+∞..−∞` when there are none).
    pub fn world_bounds(&self) -> [Vec3; 2] {
        match &self.placed {
            Some(p) => p.world_bounds,
            None => self
                .positions
                .iter()
                .fold([Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)], |[lo, hi], p| {
                    [lo.min(*p), hi.max(*p)]
                }),
        }
    }

    /// Whether the mesh has shading normals / texture coordinates.
    pub fn has_normals(&self) -> bool {
        self.placed.as_ref().map_or(!self.normals.is_empty(), |p| !p.geometry.normals.is_empty())
    }

    /// See [`Mesh::has_normals`].
    pub fn has_uvs(&self) -> bool {
        self.placed.as_ref().map_or(!self.uvs.is_empty(), |p| !p.geometry.uvs.is_empty())
    }

    /// The primvars, wherever they are kept.
    pub fn primvar_list(&self) -> &[MeshPrimvar] {
        self.placed.as_ref().map_or(&self.primvars, |p| &p.geometry.primvars)
    }

    /// The index into [`Scene::instances`] of the instance the gprim is inside.
    pub fn instance_index(&self) -> Option<u32> {
        match (&self.placed, &self.instance) {
            (Some(p), _) => Some(p.instance),
            (None, Some(i)) => Some(i.instance),
            (None, None) => None,
        }
    }

    /// The mesh in world space: itself, or a copy made from its placed geometry.
    pub fn in_world(&self) -> Cow<'_, Mesh> {
        match &self.placed {
            None => Cow::Borrowed(self),
            Some(p) => Cow::Owned(self.copy_in(&p.geometry, p.world_from_local)),
        }
    }

    /// The mesh in its instance's space (`None` outside instances).
    pub fn in_instance(&self) -> Option<Mesh> {
        if let Some(p) = &self.placed {
            return Some(self.copy_in(&p.geometry, p.instance_from_local));
        }
        let local = self.instance.as_ref()?;
        // Corner values follow their triangle's vertex order; the instance-space triangles may be
        // wound against the world's (a mirroring instance transform).
        let primvars = self
            .primvars
            .iter()
            .map(|p| {
                let mut p = p.clone();
                if p.layout == PrimvarLayout::PerCorner {
                    for (c, (stored, world)) in
                        p.values.chunks_exact_mut(3).zip(local.triangles.iter().zip(&self.triangles))
                    {
                        if stored != world {
                            c.swap(1, 2);
                        }
                    }
                }
                p
            })
            .collect();
        Some(Mesh {
            positions: local.positions.clone(),
            normals: local.normals.clone(),
            triangles: local.triangles.clone(),
            primvars,
            instance: None,
            placed: None,
            ..self.clone()
        })
    }

    fn copy_in(&self, geometry: &LocalGeometry, target_from_local: DMat4) -> Mesh {
        let t = geometry.transformed(target_from_local);
        Mesh {
            path: self.path.clone(),
            positions: t.positions,
            normals: t.normals,
            uvs: geometry.uvs.clone(),
            triangles: t.triangles,
            triangle_materials: self.triangle_materials.clone(),
            double_sided: self.double_sided,
            instance: None,
            primvars: t.primvars,
            light_set: self.light_set,
            placed: None,
            motion: self.motion.clone(),
            // The packer reads a deformation from the scene mesh itself.
            deformation: None,
        }
    }
}

/// Wall seconds spent in the parts of a load that are not composition (`bench ingest` subtracts them
/// to compare composing and listing a stage with usd-core, which neither bakes nor refines).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadTimings {
    /// Decoding textures and baking their mip pyramids.
    pub texture_seconds: f64,
    /// Dicing and tessellating subdivision surfaces.
    pub subdivision_seconds: f64,
}

/// One outermost instance: an instanceable prim, or one entry of a PointInstancer.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneInstance {
    /// The instance prim path, or `<instancer>[i]` for a point-instancer entry.
    pub path: String,
    /// Instance-to-world transform: the instanceable prim's own world transform, or the instancer's
    /// world transform times the entry's (position, orientation, scale).
    pub world_from_instance: glam::DMat4,
}

/// A [`Mesh`] of an instance, in the instance's space (`world = world_from_instance · this`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InstancedMesh {
    /// Index into [`Scene::instances`].
    pub instance: u32,
    /// Instance-space positions.
    pub positions: Vec<Vec3>,
    /// Instance-space unit normals (empty when the mesh has none).
    pub normals: Vec<Vec3>,
    /// Triangles wound for the instance-space transform (mirroring may differ from world space).
    pub triangles: Vec<[u32; 3]>,
}

/// Where the values of a [`MeshPrimvar`] sit on the triangulated mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimvarLayout {
    /// One value.
    Constant,
    /// One value per triangle (`uniform`).
    PerTriangle,
    /// One value per vertex (`vertex`, `varying`), interpolated.
    PerVertex,
    /// Three values per triangle, in its vertex order (`faceVarying`), interpolated.
    PerCorner,
}

/// A primvar a material program reads, laid out on the triangulated mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshPrimvar {
    /// Name without the `primvars:` prefix.
    pub name: String,
    /// How `values` map onto the mesh.
    pub layout: PrimvarLayout,
    /// Components authored per element, 1..=4.
    pub components: u32,
    /// Values widened to `vec4` (scalar `s` → `(s, s, s, 1)`, missing components 0, alpha 1).
    pub values: Vec<[f32; 4]>,
}

impl MeshPrimvar {
    /// The number of values `layout` needs on a mesh of `vertices` vertices and `triangles` triangles.
    pub fn expected_len(&self, vertices: usize, triangles: usize) -> usize {
        match self.layout {
            PrimvarLayout::Constant => 1,
            PrimvarLayout::PerTriangle => triangles,
            PrimvarLayout::PerVertex => vertices,
            PrimvarLayout::PerCorner => 3 * triangles,
        }
    }
}

/// A subdivision surface as diced: `Scene::meshes[mesh]` holds its triangles (none when the
/// scene was read for a listing, ingest's `SubdivOptions::tessellate` off).
///
/// The cage is kept (validated, wound counter-clockwise) so that reports and benchmarks can
/// re-refine it, e.g. to measure the tessellation error against the limit surface. What a
/// listing reports is planned from the topology and the chosen level or rates
/// (`subdiv::UniformPlan`, `subdiv::AdaptiveRefiner::planned_face_triangles`) and equals what
/// dicing makes: [`Subdivision::triangles`], [`Subdivision::materials`], and the cage's world
/// bounds ([`Subdivision::cage_world_bounds`], USD's extent of the mesh).
#[derive(Clone, Debug)]
pub struct Subdivision {
    /// Index into `Scene::meshes`.
    pub mesh: usize,
    /// The validated cage (left-handed faces already reversed).
    pub topology: cage::Topology,
    /// Cage points in the gprim's local space.
    pub points: Vec<[f32; 3]>,
    /// Local-to-world transform of the gprim.
    pub world_from_local: glam::DMat4,
    /// Uniform level refined to (what OpenSubdiv used: Catmull–Clark cages with non-quads are
    /// refined at least once); for an adaptive tessellation, the level as fine as its finest
    /// edge (`ceil(log2(max edge rate))`).
    pub level: u32,
    /// Adaptive tessellation: segments per cage edge, in `subdiv::AdaptiveRefiner::edges` order
    /// (empty for uniform refinement).
    pub edge_rates: Vec<u32>,
    /// Triangles the same surface would have at the level cap (`--max-subdiv-level`), from the
    /// face-count formula.
    pub triangles_at_max_level: u64,
    /// Triangles diced (planned from the topology; the tessellation makes exactly these).
    pub triangles: u64,
    /// Indices into `Scene::materials` of the cage faces that make triangles, sorted, distinct.
    pub materials: Vec<u32>,
}

impl Subdivision {
    /// World bounds of the cage points (`+∞..−∞` without points): USD's extent of the mesh,
    /// which the limit surface lies inside.
    pub fn cage_world_bounds(&self) -> [Vec3; 2] {
        let m = self.world_from_local;
        let (lo, hi) =
            self.points.iter().fold((glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY), |(lo, hi), p| {
                let w = m.transform_point3(Vec3::from_array(*p).as_dvec3());
                (lo.min(w), hi.max(w))
            });
        [lo.as_vec3(), hi.as_vec3()]
    }
}

/// How a curve prim is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CurveKind {
    /// Round tubes (curves without authored normals).
    #[default]
    Tube,
    /// Flat ribbons oriented by the authored normals.
    Ribbon,
    /// A Points prim: one sphere per point.
    Points,
}

/// One cubic Bézier piece of a curve in world space, with its shading attributes at both ends.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BezierSegment {
    /// Control points: `xyz` position, `w` radius (half the USD width).
    pub p: [Vec4; 4],
    /// Parameter range along the authored curve, in [0, 1].
    pub u: [f32; 2],
    /// Ribbon normals at t = 0 and 1 (zero without authored normals).
    pub normal: [Vec3; 2],
    /// Colour at t = 0 and 1.
    pub color: [Vec3; 2],
    /// Texture coordinates at t = 0 and 1.
    pub uv: [Vec2; 2],
}

/// A sphere of a Points prim.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointSphere {
    /// World-space centre.
    pub center: Vec3,
    /// World-space radius (half the USD width).
    pub radius: f32,
    /// Colour.
    pub color: Vec3,
}

/// A BasisCurves, NurbsCurves or Points prim in world space, every basis already converted to exact
/// cubic Bézier segments (before the camera-dependent splitting done by `pack`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curves {
    /// Prim path.
    pub path: String,
    /// Tube, ribbon or points.
    pub kind: CurveKind,
    /// Bézier segments (curves).
    pub segments: Vec<BezierSegment>,
    /// Spheres (points).
    pub spheres: Vec<PointSphere>,
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Authored curves (entries of `curveVertexCounts`) or points.
    pub curve_count: usize,
    /// Segments carry authored normals.
    pub has_normals: bool,
    /// Segments/spheres carry a per-vertex colour that replaces the material's diffuse colour.
    pub has_colors: bool,
    /// Segments carry texture coordinates.
    pub has_uvs: bool,
}

/// An input's fallback in the scene model's type.
macro_rules! model_fallback {
    (color, $v:expr) => {
        Vec3::from_array($v)
    };
    (float, $v:expr) => {
        $v
    };
    (flag, $v:expr) => {
        $v
    };
}

macro_rules! scene_material {
    ($($field:ident: $kind:ident = $fallback:expr, $usd:literal;)*) => {
        /// UsdPreviewSurface with constant inputs (fallbacks from the UsdPreviewSurface spec when
        /// unauthored); the inputs are [`blob::preview_surface_constants!`]'s.
        #[derive(Clone, Debug, PartialEq)]
        pub struct Material {
            /// Material prim path, or `<gprim path>.displayColor` for a gprim without a bound material.
            pub path: String,
            $(
                #[doc = concat!("`", $usd, "` (fallback ", stringify!($fallback), ").")]
                pub $field: blob::model_input_type!($kind, Vec3),
            )*
            /// Inputs connected to shading networks, compiled; empty when every input is a constant.
            pub program: Vec<ShaderNode>,
            /// What the material was read from, for reports; the packer ignores it.
            pub look: Look,
        }

        impl Default for Material {
            fn default() -> Self {
                Material {
                    path: String::new(),
                    $($field: model_fallback!($kind, $fallback),)*
                    program: Vec::new(),
                    look: Look::default(),
                }
            }
        }
    };
}
blob::preview_surface_constants!(scene_material);

/// The surface model a material was authored with and the shading nodes read for it (what
/// `ingest --dump-json` lists per material).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Look {
    /// `UsdPreviewSurface`, `standard_surface`, `open_pbr_surface`, `PxrDisney`, or empty for a
    /// displayColor material.
    pub surface_model: String,
    /// Categories of the network nodes read (`image`, `UsdUVTexture`, ...), sorted, each once.
    pub node_categories: Vec<String>,
}

/// A UsdLux light.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Light prim path.
    pub path: String,
    /// Kind and shape parameters.
    pub kind: LightKind,
    /// `color` × `intensity` × 2^`exposure` (before normalization).
    pub radiance: Vec3,
    /// `normalize`.
    pub normalize: bool,
    /// Light-to-world transform (the light's local frame: emission along −Z for distant/rect/disk).
    pub world_from_light: Mat4,
}

/// Which lights light a gprim and which lights' shadow rays it blocks (UsdLux light linking and
/// shadow linking), indexed like [`Scene::lights`]. [`Scene::light_sets`] is empty when nothing is
/// linked; otherwise set 0 is every light in both.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct LightSet {
    /// `lit_by[l]`: light `l`'s `lightLink` collection includes the gprim.
    pub lit_by: Vec<bool>,
    /// `shadows[l]`: light `l`'s `shadowLink` collection includes the gprim.
    pub shadows: Vec<bool>,
}

impl LightSet {
    /// Every one of `lights` lights and is shadowed by the gprim.
    pub fn everything(lights: usize) -> Self {
        LightSet { lit_by: vec![true; lights], shadows: vec![true; lights] }
    }
}

/// Light kinds with their shape parameters, in the light's local space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// DomeLight (untextured).
    Dome,
    /// DomeLight with a lat-long `texture:file`.
    TexturedDome {
        /// [`Scene::textures`] index of the baked map.
        texture: u32,
    },
    /// DistantLight.
    Distant {
        /// `angle`: the angular diameter in degrees (fallback 0.53).
        angle_degrees: f32,
    },
    /// SphereLight.
    Sphere {
        /// `radius` (fallback 0.5).
        radius: f32,
        /// `treatAsPoint`: rendered as a zero-radius point light.
        treat_as_point: bool,
    },
    /// RectLight, in its local XY plane.
    Rect {
        /// `width` along X (fallback 1).
        width: f32,
        /// `height` along Y (fallback 1).
        height: f32,
    },
    /// DiskLight, in its local XY plane.
    Disk {
        /// `radius` (fallback 0.5).
        radius: f32,
    },
}

/// A UsdGeomCamera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Camera prim path.
    pub path: String,
    /// Camera-to-world transform; the camera looks down −Z with +Y up.
    pub world_from_camera: Mat4,
    /// `projection` is orthographic.
    pub orthographic: bool,
    /// `focalLength` (fallback 50).
    pub focal_length: f32,
    /// `horizontalAperture` (fallback 20.955).
    pub horizontal_aperture: f32,
    /// `verticalAperture` (fallback 15.2908).
    pub vertical_aperture: f32,
    /// `horizontalApertureOffset` (fallback 0).
    pub horizontal_aperture_offset: f32,
    /// `verticalApertureOffset` (fallback 0).
    pub vertical_aperture_offset: f32,
    /// `clippingRange` (fallback (1, 1000000)).
    pub clipping_range: [f32; 2],
    /// Depth of field; the default is a pinhole.
    pub lens: Lens,
    /// `shutter:open`, `shutter:close`: time codes relative to the frame (fallback 0, 0: an
    /// instantaneous shutter, no motion blur).
    pub shutter: [f32; 2],
    /// Camera motion over the shutter: keys of `world_from_stored` taking `world_from_camera` (the
    /// frame's) to the camera's transform at the key's time, or `None` for a camera that stands
    /// still.
    pub motion: Option<TransformMotion>,
}

/// A camera's thin lens, in UsdGeomCamera's units (see `blob::Camera`). The default (`f_stop` 0)
/// is a pinhole, USD's fallback.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lens {
    /// `fStop`; 0 turns depth of field off.
    pub f_stop: f32,
    /// `focusDistance`, scene units.
    pub focus_distance: f32,
    /// `ri:apertureNSides`: 0 for a round aperture, else 3..=64 blades.
    pub aperture_blades: u32,
    /// `ri:apertureAngle`, degrees.
    pub aperture_rotation: f32,
}

impl Scene {
    /// Total triangle count.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(Mesh::triangle_count).sum()
    }

    /// Records a warning once per (prim, message) pair.
    pub fn warn(&mut self, prim: impl Into<String>, message: impl Into<String>) {
        let warning = Warning { prim: prim.into(), message: message.into() };
        if !self.warnings.contains(&warning) {
            self.warnings.push(warning);
        }
    }
}

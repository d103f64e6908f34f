//! Scene → blob records: concatenate meshes into shared vertex and triangle sections, convert materials,
//! lights and cameras to their Pod records, build the emissive-triangle distribution and the BVH.
//!
//! The output depends only on the scene (no hash-map iteration order, no thread timing), so the same scene
//! always encodes to the same bytes.
//!
//! The steps with their own module: `curves` (curve splitting and the curve BVH), `dome` (the
//! textured dome's sampling distribution), `instances` (prototypes and the top-level BVH); what
//! they share with this module (the error, the mesh layout, matrix rows) is in `common`, a leaf
//! module, so that this module only calls its children and none of them imports from it (their
//! tests excepted).

mod common;
pub mod curves;
mod dome;
mod instances;
mod reuse;

use crate::scene::{LightKind, Scene, ShaderNode, ShadingInput, TextureData, UpAxis};
use blob::records as rec;
use common::{affine_rows, MeshLayout};
use glam::Vec3;

pub use common::PackError;
pub use curves::Split;
pub use reuse::BvhCache;

/// How a scene is packed.
#[derive(Clone, Copy, Debug, Default)]
pub struct PackOptions {
    /// Curve splitting policy.
    pub split: Split,
    /// Copy every instance into world space instead of sharing prototypes (format 4 behaviour;
    /// `ingest --flatten-instances`).
    pub flatten_instances: bool,
}

/// Packs a scene into blob records.
pub fn pack(scene: &Scene) -> Result<blob::SceneData, PackError> {
    pack_scene(scene, &PackOptions::default())
}

/// [`pack`] with an explicit curve-splitting policy.
pub fn pack_with(scene: &Scene, split: Split) -> Result<blob::SceneData, PackError> {
    pack_scene(scene, &PackOptions { split, ..PackOptions::default() })
}

/// [`pack`] with explicit options.
pub fn pack_scene(scene: &Scene, options: &PackOptions) -> Result<blob::SceneData, PackError> {
    pack_scene_reusing(scene, options, None)
}

/// [`pack_scene`] for one frame of a sequence: BVHs over the same triangles as one of the
/// previous frame's are taken from `cache` instead of being built again (see [`BvhCache`]; the
/// bytes are the same). Call [`BvhCache::end_frame`] after each frame.
pub fn pack_scene_reusing(
    scene: &Scene,
    options: &PackOptions,
    mut cache: Option<&mut BvhCache>,
) -> Result<blob::SceneData, PackError> {
    validate(scene)?;
    let mut data = blob::SceneData::default();
    let mut bounds_min = Vec3::splat(f32::INFINITY);
    let mut bounds_max = Vec3::splat(f32::NEG_INFINITY);
    for [lo, hi] in scene.meshes.iter().map(crate::scene::Mesh::world_bounds) {
        bounds_min = bounds_min.min(lo);
        bounds_max = bounds_max.max(hi);
    }
    let primvar_ids = primvar_name_ids(scene);
    let texture_refs = pack_textures(scene, &mut data);
    let material_slot = pack_materials(scene, &texture_refs, &primvar_ids, &mut data);
    // Emission per blob material, from the first scene material stored in it (equal in value).
    let mut emission = vec![Vec3::ZERO; data.materials.len()];
    for (m, &slot) in scene.materials.iter().zip(&material_slot).rev() {
        emission[slot as usize] = emission_estimate(m);
    }
    let plan = if options.flatten_instances {
        crate::instancing::Instancing::flattened(scene)
    } else {
        let emissive: Vec<bool> =
            material_slot.iter().map(|&slot| luminance(emission[slot as usize]) > 0.0).collect();
        crate::instancing::plan(scene, &emissive, &material_slot)
    };
    let layout = MeshLayout {
        any_normals: scene.meshes.iter().any(crate::scene::Mesh::has_normals),
        any_uvs: scene.meshes.iter().any(crate::scene::Mesh::has_uvs),
        primvar_ids,
        material_slot,
    };
    // Deforming meshes keep their keys; emissive ones are drawn at the frame (light sampling is
    // world-space; ingest warns), as are meshes inside instances or with transform motion.
    let deforms = |mesh: &crate::scene::Mesh| {
        mesh.deformation.is_some()
            && mesh.motion.is_none()
            && mesh.instance_index().is_none()
            && !mesh
                .triangle_materials
                .iter()
                .any(|&t| luminance(emission[layout.material_slot[t as usize] as usize]) > 0.0)
    };
    for &m in &plan.top_level {
        let mesh = &scene.meshes[m];
        if let (true, Some(deformation)) = (deforms(mesh), &mesh.deformation) {
            pack_deformation(&mut data, deformation, &mut bounds_min, &mut bounds_max);
        }
        layout.push(&mut data, &mesh.in_world());
    }
    let top_level_triangles = data.triangles.len();

    let mut dome_light = rec::NONE;
    for (i, light) in scene.lights.iter().enumerate() {
        let name = data.add_string(&light.path);
        let mut record = rec::Light {
            name,
            radiance: light.radiance.to_array(),
            world_from_light: affine_rows(&light.world_from_light),
            flags: if light.normalize { rec::LIGHT_NORMALIZE } else { 0 }
                | if scene.camera_hidden_lights.contains(&i) { rec::LIGHT_CAMERA_HIDDEN } else { 0 },
            ..rec::Light::default()
        };
        match light.kind {
            LightKind::Dome => {
                record.kind = rec::light_kind::DOME;
                if dome_light == rec::NONE {
                    dome_light = i as u32;
                }
            }
            LightKind::TexturedDome { texture } => {
                record.kind = rec::light_kind::TEXTURED_DOME;
                record.dome_map = dome::pack_dome_map(scene, &light.path, texture, &texture_refs, &mut data)?;
                if dome_light == rec::NONE {
                    dome_light = i as u32;
                }
            }
            LightKind::Distant { angle_degrees } => {
                record.kind = rec::light_kind::DISTANT;
                record.angle_degrees = angle_degrees;
            }
            LightKind::Sphere { radius, treat_as_point } => {
                record.kind = rec::light_kind::SPHERE;
                record.radius = radius;
                if treat_as_point {
                    record.flags |= rec::LIGHT_TREAT_AS_POINT;
                }
            }
            LightKind::Rect { width, height } => {
                record.kind = rec::light_kind::RECT;
                record.width = width;
                record.height = height;
            }
            LightKind::Disk { radius } => {
                record.kind = rec::light_kind::DISK;
                record.radius = radius;
            }
        }
        data.lights.push(record);
    }

    for c in &scene.cameras {
        let name = data.add_string(&c.path);
        data.cameras.push(rec::Camera {
            name,
            projection: if c.orthographic {
                rec::PROJECTION_ORTHOGRAPHIC
            } else {
                rec::PROJECTION_PERSPECTIVE
            },
            focal_length: c.focal_length,
            horizontal_aperture: c.horizontal_aperture,
            vertical_aperture: c.vertical_aperture,
            horizontal_aperture_offset: c.horizontal_aperture_offset,
            vertical_aperture_offset: c.vertical_aperture_offset,
            clipping_range: c.clipping_range,
            f_stop: c.lens.f_stop,
            focus_distance: c.lens.focus_distance,
            aperture_blades: c.lens.aperture_blades,
            aperture_rotation: c.lens.aperture_rotation,
            world_from_camera: affine_rows(&c.world_from_camera),
            shutter_open: c.shutter[0],
            shutter_close: c.shutter[1],
            ..rec::Camera::default()
        });
    }

    data.emissive_triangles = emissive_distribution(&data, &emission);

    let corner = |t: &rec::Triangle| t.vertices.map(|v| Vec3::from_array(data.positions[v as usize]));
    if data.deform.motions.is_empty() {
        let corners: Vec<[Vec3; 3]> = data.triangles[..top_level_triangles].iter().map(corner).collect();
        let bvh = match cache.as_deref_mut() {
            Some(cache) => cache.build(corners),
            None => crate::bvh::build(&corners),
        };
        data.bvh_nodes = bvh.nodes;
        data.bvh_blocks = bvh.blocks;
    } else {
        // Deforming triangles go to their own BVH over the union of their key boxes; the world
        // BVH holds the others (block lanes renumbered to blob triangles). Neither is cached
        // across frames: a deforming mesh changes every frame.
        let deforming = |t: &rec::Triangle| data.deform.motion_of(t.mesh).is_some();
        let (moving, still): (Vec<u32>, Vec<u32>) =
            (0..top_level_triangles as u32).partition(|&t| deforming(&data.triangles[t as usize]));
        let corners: Vec<[Vec3; 3]> = still.iter().map(|&t| corner(&data.triangles[t as usize])).collect();
        let mut bvh = crate::bvh::build(&corners);
        bvh.blocks.iter_mut().for_each(|b| b.triangles = b.triangles.map(|i| still[i as usize]));
        let frame: Vec<[Vec3; 3]> = moving.iter().map(|&t| corner(&data.triangles[t as usize])).collect();
        let boxes: Vec<(Vec3, Vec3)> =
            moving.iter().map(|&t| deforming_box(&data, &data.triangles[t as usize])).collect();
        let mut moving_bvh = crate::bvh::build_bounded(&frame, &boxes);
        moving_bvh.blocks.iter_mut().for_each(|b| b.triangles = b.triangles.map(|i| moving[i as usize]));
        data.bvh_nodes = bvh.nodes;
        data.bvh_blocks = bvh.blocks;
        data.deform.bvh_nodes = moving_bvh.nodes;
        data.deform.bvh_blocks = moving_bvh.blocks;
    }
    instances::pack_instances(scene, &plan, &layout, &mut data, cache);
    pack_camera_motion(scene, &mut data);
    let first_group = data.curves.groups.len();
    let (curves_min, curves_max) =
        curves::pack_curves(scene, &mut data, options.split, (bounds_min, bounds_max))?;
    for group in &mut data.curves.groups[first_group..] {
        group.material = layout.material_slot[group.material as usize];
    }
    bounds_min = bounds_min.min(curves_min);
    bounds_max = bounds_max.max(curves_max);

    data.light_sets = light_set_words(scene);
    pack_outputs(scene, &mut data);
    data.info = rec::SceneInfo {
        bounds_min: bounds_min.to_array(),
        bounds_max: bounds_max.to_array(),
        meters_per_unit: scene.meters_per_unit as f32,
        up_axis: match scene.up_axis {
            UpAxis::Y => rec::UP_AXIS_Y,
            UpAxis::Z => rec::UP_AXIS_Z,
        },
        default_camera: scene.default_camera.map_or(rec::NONE, |c| c as u32),
        resolution: scene.resolution.unwrap_or([0, 0]),
        gprim_count: scene.meshes.len() as u32,
        instance_count: scene.instance_count,
        dome_light,
        reserved: [0; 2],
        data_window_ndc: scene.data_window_ndc.unwrap_or([0.0; 4]),
        world_origin: scene.world_origin.to_array(),
    };
    Ok(data)
}

/// The keys of the deforming mesh about to be pushed as the next blob mesh (see `blob::deform`),
/// its keyed positions added to the scene bounds.
fn pack_deformation(
    data: &mut blob::SceneData,
    deformation: &crate::scene::Deformation,
    bounds_min: &mut Vec3,
    bounds_max: &mut Vec3,
) {
    let d = &mut data.deform;
    d.motions.push(blob::MeshMotion {
        mesh: data.meshes.len() as u32,
        key_count: deformation.keys.len() as u32,
        first_time: d.times.len() as u32,
        first_position: d.positions.len() as u32,
    });
    for key in &deformation.keys {
        d.times.push(key.time);
        d.positions.extend(key.positions.iter().map(|p| p.to_array()));
        for p in &key.positions {
            (*bounds_min, *bounds_max) = (bounds_min.min(*p), bounds_max.max(*p));
        }
    }
}

/// The union of a deforming triangle's boxes at every key of its mesh (and at the frame).
fn deforming_box(data: &blob::SceneData, tri: &rec::Triangle) -> (Vec3, Vec3) {
    let (d, mesh) = (&data.deform, &data.meshes[tri.mesh as usize]);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    if let Some(m) = d.motion_of(tri.mesh) {
        for k in 0..m.key_count {
            for &v in &tri.vertices {
                let at = m.first_position + k * mesh.vertex_count + (v - mesh.first_vertex);
                let p = Vec3::from_array(d.positions[at as usize]);
                (lo, hi) = (lo.min(p), hi.max(p));
            }
        }
    }
    for &v in &tri.vertices {
        let p = Vec3::from_array(data.positions[v as usize]);
        (lo, hi) = (lo.min(p), hi.max(p));
    }
    (lo, hi)
}

/// Moving cameras' keys, appended to the motion keys section after the instances' (each key the
/// camera's `world_from_camera` at its time).
fn pack_camera_motion(scene: &Scene, data: &mut blob::SceneData) {
    for (c, record) in scene.cameras.iter().zip(&mut data.cameras) {
        let Some(motion) = &c.motion else { continue };
        let keys = &mut data.instancing.motion_keys;
        record.first_motion_key = keys.len() as u32;
        record.motion_key_count = motion.keys.len() as u32;
        let frame = c.world_from_camera.as_dmat4();
        keys.extend(motion.keys.iter().map(|k| blob::MotionKey {
            time: k.time,
            world_from_object: affine_rows(&(k.world_from_stored * frame).as_mat4()),
            ..blob::MotionKey::default()
        }));
    }
}

/// The render products, their vars and the light groups as blob records (see `blob::outputs`).
fn pack_outputs(scene: &Scene, data: &mut blob::SceneData) {
    for product in &scene.render_products {
        let record = blob::RenderProduct {
            path: data.add_string(&product.path),
            name: data.add_string(&product.name),
            first_var: data.outputs.vars.len() as u32,
            var_count: product.vars.len() as u32,
        };
        for var in &product.vars {
            let var = blob::RenderVar {
                path: data.add_string(&var.path),
                source: data.add_string(&var.source),
                source_type: var.source_type,
                data_type: var.data_type,
                reserved: [0; 2],
            };
            data.outputs.vars.push(var);
        }
        data.outputs.products.push(record);
    }
    if scene.light_groups.iter().any(Option::is_some) {
        for i in 0..scene.lights.len() {
            let group = scene.light_groups.get(i).cloned().flatten().unwrap_or_default();
            let group = data.add_string(&group);
            data.outputs.light_groups.push(group);
        }
    }
}

/// Converts the materials to blob records, storing each class of materials with the same
/// compiled program and constants once (gprims without a bound material get a
/// `<gprim>.displayColor` material each: 1,000 instances would otherwise store 1,000 equal
/// records). Returns the blob material of each scene material; a record keeps the name of the
/// first material of its class.
fn pack_materials(
    scene: &Scene,
    texture_refs: &[(u32, bool)],
    primvar_ids: &std::collections::BTreeMap<String, u32>,
    data: &mut blob::SceneData,
) -> Vec<u32> {
    let mut slot_of: std::collections::HashMap<(Vec<u8>, Vec<u8>), u32> = std::collections::HashMap::new();
    let mut slots = Vec::with_capacity(scene.materials.len());
    for m in &scene.materials {
        let ops: Vec<rec::ShaderOp> =
            m.program.iter().map(|node| shader_op(node, texture_refs, primvar_ids)).collect();
        let record = rec::Material { program_len: ops.len() as u32, ..material_constants(m) };
        // Equal bytes: the same constants and the same program (floats compared bit for bit).
        let key = (bytemuck::bytes_of(&record).to_vec(), bytemuck::cast_slice::<_, u8>(&ops).to_vec());
        let next = data.materials.len() as u32;
        let slot = *slot_of.entry(key).or_insert(next);
        if slot == next {
            let name = data.add_string(&m.path);
            let program_start = data.shader_ops.len() as u32;
            data.shader_ops.extend(ops);
            data.materials.push(rec::Material { name, program_start, ..record });
        }
        slots.push(slot);
    }
    slots
}

/// An input of the scene model in the blob's type.
macro_rules! blob_input {
    (color, $v:expr) => {
        $v.to_array()
    };
    (float, $v:expr) => {
        $v
    };
    (flag, $v:expr) => {
        $v as u32
    };
}

macro_rules! material_constants {
    ($($field:ident: $kind:ident = $fallback:expr, $usd:literal;)*) => {
        /// The blob record of `m`'s constants ([`blob::preview_surface_constants!`]), with no name and
        /// no program yet.
        fn material_constants(m: &crate::scene::Material) -> rec::Material {
            rec::Material { $($field: blob_input!($kind, m.$field),)* ..rec::Material::default() }
        }
    };
}
blob::preview_surface_constants!(material_constants);

/// Rec. 709 luminance, the weight of emission in the light distribution.
fn luminance(e: Vec3) -> f32 {
    e.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Copies the baked textures into the blob's texture tables; returns, per scene texture, the blob
/// reference (`(index, is_udim)`).
fn pack_textures(scene: &Scene, data: &mut blob::SceneData) -> Vec<(u32, bool)> {
    let mut builder = texture::TextureSetBuilder::new();
    let mut refs = Vec::with_capacity(scene.textures.len());
    // (first tile, u count, v count, cells) per UDIM set, filled once the builder is finished.
    let mut udim_sets: Vec<rec::UdimSet> = Vec::new();
    let mut udim_tiles: Vec<u32> = Vec::new();
    for t in &scene.textures {
        match &t.data {
            TextureData::Image(baked) => refs.push((builder.add_baked(baked.clone()), false)),
            TextureData::Udim(tiles) => {
                let u_count = tiles.iter().map(|t| t.0).max().unwrap_or(0) + 1;
                let v_count = tiles.iter().map(|t| t.1).max().unwrap_or(0) + 1;
                let mut grid = vec![rec::NONE; (u_count * v_count) as usize];
                for (u, v, baked) in tiles {
                    grid[(v * u_count + u) as usize] = builder.add_baked(baked.clone());
                }
                let first_tile = udim_tiles.len() as u32;
                udim_tiles.extend_from_slice(&grid);
                udim_sets.push(rec::UdimSet { first_tile, u_count, v_count, reserved: 0 });
                refs.push((udim_sets.len() as u32 - 1, true));
            }
        }
    }
    let set = builder.finish();
    data.texture_records = set.records;
    data.texels = set.texels;
    data.udim_sets = udim_sets;
    data.udim_tiles = udim_tiles;
    refs
}

fn wrap_code(w: texture::Wrap) -> u32 {
    match w {
        texture::Wrap::Repeat => 0,
        texture::Wrap::Mirror => 1,
        texture::Wrap::Clamp => 2,
        texture::Wrap::Black => 3,
    }
}

fn input_code(input: ShadingInput) -> u32 {
    use rec::shading_input as si;
    match input {
        ShadingInput::DiffuseColor => si::DIFFUSE_COLOR,
        ShadingInput::EmissiveColor => si::EMISSIVE_COLOR,
        ShadingInput::SpecularColor => si::SPECULAR_COLOR,
        ShadingInput::Roughness => si::ROUGHNESS,
        ShadingInput::Metallic => si::METALLIC,
        ShadingInput::Opacity => si::OPACITY,
        ShadingInput::Normal => si::NORMAL,
        ShadingInput::Clearcoat => si::CLEARCOAT,
        ShadingInput::ClearcoatRoughness => si::CLEARCOAT_ROUGHNESS,
        ShadingInput::Ior => si::IOR,
    }
}

/// A key per primvar name that any mesh carries or any program reads, in name order (so records
/// sorted by name within a mesh are sorted by key).
fn primvar_name_ids(scene: &Scene) -> std::collections::BTreeMap<String, u32> {
    let mut names = std::collections::BTreeSet::new();
    for mesh in &scene.meshes {
        names.extend(mesh.primvar_list().iter().map(|p| p.name.clone()));
    }
    for m in &scene.materials {
        names.extend(m.program.iter().filter_map(|n| match n {
            ShaderNode::Primvar { name, .. } => Some(name.clone()),
            _ => None,
        }));
    }
    names.into_iter().enumerate().map(|(i, n)| (n, i as u32)).collect()
}

/// One program node as a blob op (see [`rec::op_kind`] for the field meanings).
fn shader_op(
    node: &ShaderNode,
    textures: &[(u32, bool)],
    primvar_ids: &std::collections::BTreeMap<String, u32>,
) -> rec::ShaderOp {
    use rec::op_kind;
    let op = rec::ShaderOp::default();
    match *node {
        ShaderNode::Primvar { dst, ref name, fallback } => rec::ShaderOp {
            kind: op_kind::PRIMVAR,
            dst,
            src: primvar_ids.get(name).copied().unwrap_or(rec::NONE),
            params: [fallback, [0.0; 4], [0.0; 4]],
            ..op
        },
        ShaderNode::Const { dst, value } => {
            rec::ShaderOp { kind: op_kind::CONST, dst, params: [value, [0.0; 4], [0.0; 4]], ..op }
        }
        ShaderNode::PrimvarUv { dst, fallback } => {
            rec::ShaderOp { kind: op_kind::PRIMVAR_UV, dst, params: [fallback, [0.0; 4], [0.0; 4]], ..op }
        }
        ShaderNode::Transform2d { dst, src, rotation_degrees, scale, translation } => {
            // UsdTransform2d: result = in * scale, rotated, then translated; as one 2×2 matrix.
            let (sin, cos) = rotation_degrees.to_radians().sin_cos();
            let m = [cos * scale[0], -sin * scale[1], sin * scale[0], cos * scale[1]];
            rec::ShaderOp {
                kind: op_kind::TRANSFORM_2D,
                dst,
                src,
                params: [m, [translation[0], translation[1], 0.0, 0.0], [0.0; 4]],
                ..op
            }
        }
        ShaderNode::Texture { dst, src, texture, wrap_s, wrap_t, scale, bias, fallback } => {
            let (index, udim) =
                texture.and_then(|t| textures.get(t as usize).copied()).unwrap_or((rec::NONE, false));
            rec::ShaderOp {
                kind: op_kind::TEXTURE,
                dst,
                src,
                texture: index,
                flags: rec::op_wrap_flags(wrap_code(wrap_s), wrap_code(wrap_t))
                    | if udim { rec::OP_UDIM } else { 0 },
                params: [scale, bias, fallback],
                ..op
            }
        }
        ShaderNode::Output { input, src, swizzle } => {
            let flags = swizzle.iter().enumerate().fold(0u32, |f, (i, &c)| f | ((c as u32 & 3) << (2 * i)));
            rec::ShaderOp { kind: op_kind::OUTPUT, dst: input_code(input), src, flags, ..op }
        }
        ShaderNode::Math { dst, op: math, srcs: [a, b, c] } => {
            rec::ShaderOp { kind: op_kind::MATH, dst, src: a, src2: b, src3: c, flags: math.flags(), ..op }
        }
    }
}

/// Emitted radiance used to weight a material's triangles in the light distribution: the constant,
/// or for a textured `emissiveColor` the bound of `scale + bias` over texel values in `[0, 1]` (the
/// estimate only steers sampling; the radiance itself is evaluated per point).
/// Whether `m` emits (an upper bound on its emission is nonzero): such gprims stay in world space,
/// where light sampling draws from them (see `crate::instancing`).
pub fn emits(m: &crate::scene::Material) -> bool {
    luminance(emission_estimate(m)) > 0.0
}

fn emission_estimate(m: &crate::scene::Material) -> Vec3 {
    let textured = m.program.iter().find_map(|n| match n {
        ShaderNode::Output { input: ShadingInput::EmissiveColor, src, .. } => Some(*src),
        _ => None,
    });
    let Some(register) = textured else { return m.emissive_color };
    // The last writer of the register decides the bound.
    let bound = m.program.iter().rev().find_map(|n| match *n {
        ShaderNode::Texture { dst, scale, bias, texture, fallback, .. } if dst == register => {
            Some(if texture.is_some() {
                Vec3::new(scale[0].abs() + bias[0], scale[1].abs() + bias[1], scale[2].abs() + bias[2])
                    .max(Vec3::from_slice(&fallback[..3]))
            } else {
                Vec3::from_slice(&fallback[..3])
            })
        }
        ShaderNode::Const { dst, value } if dst == register => Some(Vec3::from_slice(&value[..3])),
        _ => None,
    });
    bound.unwrap_or(Vec3::ONE).max(Vec3::ZERO)
}

/// Triangles with emission, with a distribution proportional to emitted power (area × luminance of
/// `emission[material]`).
fn emissive_distribution(data: &blob::SceneData, emission: &[Vec3]) -> Vec<rec::EmissiveTriangle> {
    let mut entries: Vec<rec::EmissiveTriangle> = Vec::new();
    let mut total = 0.0f64;
    for (i, (tri, &material)) in data.triangles.iter().zip(&data.triangle_materials).enumerate() {
        let luminance = luminance(emission[material as usize]);
        if luminance <= 0.0 {
            continue;
        }
        let [a, b, c] = tri.vertices.map(|v| Vec3::from_array(data.positions[v as usize]));
        let area = 0.5 * (b - a).cross(c - a).length();
        if area <= 0.0 {
            continue;
        }
        total += (area * luminance) as f64;
        entries.push(rec::EmissiveTriangle {
            triangle: i as u32,
            area,
            cdf: total as f32,
            pmf: (area * luminance),
        });
    }
    let mut running = 0.0f64;
    for e in &mut entries {
        running += e.pmf as f64;
        e.pmf = (e.pmf as f64 / total) as f32;
        e.cdf = (running / total).min(1.0) as f32;
    }
    if let Some(last) = entries.last_mut() {
        last.cdf = 1.0;
    }
    entries
}

/// Largest coordinate (and width) packed. The BVH builders multiply box extents into surface
/// areas, which overflow `f32` (and then panic on the infinite cost) past about 1e19; a scene that
/// large is not renderable in `f32` anyway. Found by the layer fuzzer (a mutated width of 3e38).
const MAX_COORDINATE: f32 = 1e18;

/// `v` is finite and within ±[`MAX_COORDINATE`] (`false` for NaN; per component, because
/// `max_element` skips NaN).
fn within_range(v: f32) -> bool {
    v.abs() <= MAX_COORDINATE
}

fn validate(scene: &Scene) -> Result<(), PackError> {
    let fail = |prim: &str, problem: String| Err(PackError { prim: prim.to_string(), problem });
    let keys_ok = |times: &[f32]| {
        (2..=blob::MAX_MOTION_KEYS as usize).contains(&times.len())
            && times.iter().all(|t| t.is_finite() && t.abs() <= blob::MAX_SHUTTER)
            && times.windows(2).all(|w| w[0] < w[1])
    };
    for c in &scene.cameras {
        if let Some(m) = &c.motion {
            let invertible = m.keys.iter().all(|k| {
                let w = k.world_from_stored * c.world_from_camera.as_dmat4();
                w.is_finite() && glam::DMat3::from_mat4(w).determinant().abs() > 1e-12
            });
            let times: Vec<f32> = m.keys.iter().map(|k| k.time).collect();
            if !keys_ok(&times) || !invertible {
                return fail(
                    &c.path,
                    "camera motion keys must be 2..=256 with finite increasing times within ±1e4 and invertible transforms".into(),
                );
            }
        }
    }
    for mesh in &scene.meshes {
        if let Some(d) = &mesh.deformation {
            let times: Vec<f32> = d.keys.iter().map(|k| k.time).collect();
            if !keys_ok(&times) {
                return fail(
                    &mesh.path,
                    "deformation keys must be 2..=256 with finite increasing times within ±1e4".into(),
                );
            }
            if let Some(k) = d.keys.iter().find(|k| k.positions.len() != mesh.positions.len()) {
                return fail(
                    &mesh.path,
                    format!(
                        "deformation key at time {} has {} points for the mesh's {}",
                        k.time,
                        k.positions.len(),
                        mesh.positions.len()
                    ),
                );
            }
            if d.keys.iter().flat_map(|k| &k.positions).any(|p| !p.to_array().into_iter().all(within_range)) {
                return fail(
                    &mesh.path,
                    "deformation point not finite or beyond the coordinate limit".into(),
                );
            }
        }
    }
    // Shared geometry is checked once, under the path of its first gprim.
    let mut checked = std::collections::HashSet::new();
    for mesh in &scene.meshes {
        if let Some(placed) = &mesh.placed {
            let g = &placed.geometry;
            if checked.insert(std::sync::Arc::as_ptr(g)) {
                let local = crate::scene::Mesh {
                    path: mesh.path.clone(),
                    positions: g.positions.iter().map(|p| p.as_vec3()).collect(),
                    normals: g.normals.iter().map(|n| n.as_vec3()).collect(),
                    uvs: g.uvs.clone(),
                    triangles: g.triangles.clone(),
                    triangle_materials: vec![0; g.triangles.len()],
                    primvars: g.primvars.clone(),
                    ..crate::scene::Mesh::default()
                };
                if g.positions.iter().any(|p| !p.is_finite()) {
                    return fail(&mesh.path, "point not finite".into());
                }
                validate_mesh(scene, &local, true)?;
            }
            if mesh.triangle_materials.len() != g.triangles.len() {
                return fail(&mesh.path, "one material per triangle is required".into());
            }
            if (placed.instance as usize) >= scene.instances.len() {
                return fail(&mesh.path, format!("instance {} out of range", placed.instance));
            }
            if !placed.world_bounds.iter().all(|b| b.to_array().into_iter().all(within_range))
                && !g.positions.is_empty()
            {
                return fail(&mesh.path, format!("point beyond ±{MAX_COORDINATE:e} or not finite"));
            }
            if let Some(&m) = mesh.triangle_materials.iter().find(|&&m| m as usize >= scene.materials.len()) {
                return fail(&mesh.path, format!("material index {m} out of range"));
            }
        } else {
            validate_mesh(scene, mesh, false)?;
        }
    }
    for m in &scene.materials {
        if let Some(problem) = program_problem(&m.program, scene.textures.len()) {
            return fail(&m.path, problem);
        }
    }
    if scene.positions_total() > u32::MAX as usize || scene.triangle_count() > u32::MAX as usize {
        return fail("/", "more than 2^32 vertices or triangles".into());
    }
    for c in &scene.curves {
        if c.material as usize >= scene.materials.len() {
            return fail(&c.path, format!("material index {} out of range", c.material));
        }
        let in_range =
            c.segments.iter().all(|s| s.p.iter().all(|p| p.to_array().into_iter().all(within_range)))
                && c.spheres
                    .iter()
                    .all(|s| s.center.to_array().into_iter().all(within_range) && within_range(s.radius));
        if !in_range {
            return fail(
                &c.path,
                format!("curve control point, point or width beyond ±{MAX_COORDINATE:e} or not finite"),
            );
        }
        if let Some(s) = c.spheres.iter().find(|s| s.radius < 0.0) {
            return fail(&c.path, format!("point radius {} is negative", s.radius));
        }
    }
    if let Some(c) = scene.default_camera.filter(|&c| c >= scene.cameras.len()) {
        return fail("/", format!("default camera {c} out of range"));
    }
    let lights = scene.lights.len();
    if lights == 0 && !scene.light_sets.is_empty() {
        return fail("/", "light sets in a scene without lights".into());
    }
    if let Some((i, _)) = scene
        .light_sets
        .iter()
        .enumerate()
        .find(|(_, s)| s.lit_by.len() != lights || s.shadows.len() != lights)
    {
        return fail("/", format!("light set {i} does not have one entry per light ({lights})"));
    }
    if let Some(&l) = scene.camera_hidden_lights.iter().find(|&&l| l >= lights) {
        return fail("/", format!("camera-hidden light {l} out of range ({lights} lights)"));
    }
    let sets = scene.light_sets.len().max(1);
    if let Some(m) = scene.meshes.iter().find(|m| m.light_set as usize >= sets) {
        return fail(&m.path, format!("light set {} out of range", m.light_set));
    }
    Ok(())
}

/// The scene's light sets as the blob's bit masks ([`blob::light_set_words`]).
fn light_set_words(scene: &Scene) -> Vec<u32> {
    let words = blob::light_set_words(scene.lights.len());
    if words == 0 {
        // No lights: `validate` refused any light set.
        return Vec::new();
    }
    let mut out = vec![0u32; 2 * words * scene.light_sets.len()];
    for (set, masks) in scene.light_sets.iter().zip(out.chunks_mut(2 * words)) {
        let (lit, shadows) = masks.split_at_mut(words);
        for (l, (&a, &b)) in set.lit_by.iter().zip(&set.shadows).enumerate() {
            lit[l / 32] |= (a as u32) << (l % 32);
            shadows[l / 32] |= (b as u32) << (l % 32);
        }
    }
    out
}

/// Checks one mesh's arrays against each other (`local`: shared geometry, whose points are
/// checked in world space per placement instead).
fn validate_mesh(scene: &Scene, mesh: &crate::scene::Mesh, local: bool) -> Result<(), PackError> {
    let fail = |prim: &str, problem: String| Err(PackError { prim: prim.to_string(), problem });
    let n = mesh.positions.len();
    if !mesh.normals.is_empty() && mesh.normals.len() != n {
        return fail(&mesh.path, format!("{} normals for {n} points", mesh.normals.len()));
    }
    if !mesh.uvs.is_empty() && mesh.uvs.len() != n {
        return fail(&mesh.path, format!("{} uvs for {n} points", mesh.uvs.len()));
    }
    if mesh.triangle_materials.len() != mesh.triangles.len() {
        return fail(&mesh.path, "one material per triangle is required".into());
    }
    if let Some(t) = mesh.triangles.iter().find(|t| t.iter().any(|&v| v as usize >= n)) {
        return fail(&mesh.path, format!("triangle {t:?} indexes past {n} points"));
    }
    if let Some(&m) = mesh.triangle_materials.iter().find(|&&m| m as usize >= scene.materials.len()) {
        return fail(&mesh.path, format!("material index {m} out of range"));
    }
    if !local && mesh.positions.iter().any(|p| !p.to_array().into_iter().all(within_range)) {
        return fail(&mesh.path, format!("point beyond ±{MAX_COORDINATE:e} or not finite"));
    }
    if let Some(copy) = &mesh.instance {
        let consistent = (copy.instance as usize) < scene.instances.len()
            && copy.positions.len() == n
            && (copy.normals.len() == mesh.normals.len())
            && copy.triangles.len() == mesh.triangles.len()
            && copy.triangles.iter().all(|t| t.iter().all(|&v| (v as usize) < n))
            && copy.positions.iter().all(|p| p.is_finite());
        if !consistent {
            return fail(&mesh.path, "instance-space copy does not match the mesh".into());
        }
    }
    for p in &mesh.primvars {
        let expected = p.expected_len(n, mesh.triangles.len());
        if p.values.len() != expected || !(1..=4).contains(&p.components) {
            let (got, components) = (p.values.len(), p.components);
            return fail(
                &mesh.path,
                format!(
                    "primvar {}: {got} values of {components} components, {:?} needs {expected} of 1..=4",
                    p.name, p.layout
                ),
            );
        }
    }
    let mut names: Vec<&str> = mesh.primvars.iter().map(|p| p.name.as_str()).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return fail(&mesh.path, format!("primvar {} appears twice", w[0]));
    }
    Ok(())
}

/// Why a material program cannot be encoded (registers past the file, unknown textures), if it cannot.
fn program_problem(program: &[ShaderNode], textures: usize) -> Option<String> {
    let max = rec::MAX_REGISTERS;
    for node in program {
        let (regs, texture) = match *node {
            ShaderNode::Const { dst, .. }
            | ShaderNode::PrimvarUv { dst, .. }
            | ShaderNode::Primvar { dst, .. } => ([dst, 0], None),
            ShaderNode::Transform2d { dst, src, .. } => ([dst, src], None),
            ShaderNode::Texture { dst, src, texture, .. } => ([dst, src], texture),
            ShaderNode::Output { src, .. } => ([src, 0], None),
            ShaderNode::Math { dst, srcs, .. } => {
                if srcs.iter().any(|&r| r >= max) {
                    return Some(format!("shading program uses a register past {max}"));
                }
                ([dst, 0], None)
            }
        };
        if regs.iter().any(|&r| r >= max) {
            return Some(format!("shading program uses a register past {max}"));
        }
        if texture.is_some_and(|t| t as usize >= textures) {
            return Some("shading program names a texture that was not baked".into());
        }
    }
    None
}

impl Scene {
    fn positions_total(&self) -> usize {
        self.meshes.iter().map(crate::scene::Mesh::vertex_count).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, Mesh};
    use glam::Vec2;

    fn quad_scene() -> Scene {
        let mesh = Mesh {
            path: "/World/Quad".into(),
            positions: vec![
                Vec3::new(0., 0., 0.),
                Vec3::new(1., 0., 0.),
                Vec3::new(1., 1., 0.),
                Vec3::new(0., 1., 0.),
            ],
            uvs: vec![Vec2::ZERO; 4],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            triangle_materials: vec![0, 1],
            ..Mesh::default()
        };
        let emissive = Material { path: "/Looks/E".into(), emissive_color: Vec3::ONE, ..Material::default() };
        Scene {
            meshes: vec![mesh],
            materials: vec![Material { path: "/Looks/M".into(), ..Material::default() }, emissive],
            meters_per_unit: 1.0,
            ..Scene::default()
        }
    }

    #[test]
    fn packs_bounds_emitters_and_a_parseable_blob() {
        let data = pack(&quad_scene()).unwrap();
        assert_eq!(data.info.bounds_min, [0.0, 0.0, 0.0]);
        assert_eq!(data.info.bounds_max, [1.0, 1.0, 0.0]);
        assert_eq!(data.emissive_triangles.len(), 1);
        assert_eq!(data.emissive_triangles[0].triangle, 1);
        assert!((data.emissive_triangles[0].area - 0.5).abs() < 1e-6);
        assert_eq!(data.emissive_triangles[0].cdf, 1.0);
        let bytes = blob::AlignedBytes::copy_from(&data.encode());
        let view = blob::SceneView::parse(&bytes).unwrap();
        assert_eq!(view.triangles.len(), 2);
        assert_eq!(view.string(view.meshes[0].name), "/World/Quad");
        assert_eq!(view.meshes[0].flags & blob::MESH_HAS_UVS, blob::MESH_HAS_UVS);
        let mut slots: Vec<u32> = view.bvh_blocks.iter().flat_map(|b| b.triangles).collect();
        slots.sort();
        slots.dedup();
        assert_eq!(slots, vec![0, 1], "every triangle is reachable from the BVH");
    }

    #[test]
    fn materials_equal_in_value_are_stored_once() {
        let mut scene = quad_scene();
        // Three displayColor-style materials: two equal in value under different paths.
        let grey = |path: &str| Material { path: path.into(), ..Material::default() };
        scene.materials = vec![
            grey("/A.displayColor"),
            Material { path: "/B.displayColor".into(), diffuse_color: Vec3::X, ..Material::default() },
            grey("/C.displayColor"),
        ];
        scene.meshes[0].triangle_materials = vec![2, 1];
        let data = pack(&scene).unwrap();
        assert_eq!(data.materials.len(), 2, "/C is stored as /A");
        assert_eq!(data.triangle_materials, vec![0, 1]);
        let bytes = blob::AlignedBytes::copy_from(&data.encode());
        let view = blob::SceneView::parse(&bytes).unwrap();
        assert_eq!(view.string(view.materials[0].name), "/A.displayColor");
        assert_eq!(view.materials[1].diffuse_color, [1.0, 0.0, 0.0]);
        // A program (even one computing the same colour) makes a material distinct.
        scene.materials[2].program = vec![
            ShaderNode::Const { dst: 0, value: [0.18, 0.18, 0.18, 1.0] },
            ShaderNode::Output { input: ShadingInput::DiffuseColor, src: 0, swizzle: [0, 1, 2, 3] },
        ];
        assert_eq!(pack(&scene).unwrap().materials.len(), 3);
    }

    #[test]
    fn same_scene_same_bytes() {
        assert_eq!(pack(&quad_scene()).unwrap().encode(), pack(&quad_scene()).unwrap().encode());
    }

    #[test]
    fn out_of_range_triangle_names_the_mesh() {
        let mut scene = quad_scene();
        scene.meshes[0].triangles[1] = [0, 2, 9];
        let err = pack(&scene).unwrap_err().to_string();
        assert!(err.contains("/World/Quad") && err.contains("indexes past 4 points"), "{err}");
    }
}

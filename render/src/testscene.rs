//! Test scenes built in code as `ingest::Scene` values and packed into blob bytes.
//!
//! `pack` is a stand-in for `ingest::pack::pack` while that lands: it writes the same records (world
//! space vertices, materials, lights, cameras, the emissive distribution and an obvhs CWBVH).

use blob::{AlignedBytes, SceneData};
use glam::{Mat4, Vec2, Vec3};
use ingest::{Camera, Light, LightKind, Material, Mesh, Scene};

/// A small deterministic generator for test inputs (SplitMix64).
pub struct Rng(pub u64);

impl Rng {
    /// Next value in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 * (1.0 / 16_777_216.0)
    }

    /// Next value in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }
}

/// Validated-ready blob bytes for `data`.
pub fn encode(data: &SceneData) -> AlignedBytes {
    AlignedBytes::copy_from(&data.encode())
}

/// Packs and encodes a scene.
pub fn bytes(scene: &Scene) -> AlignedBytes {
    encode(&pack(scene))
}

/// A Lambertian material (ior 1, so no specular lobe).
pub fn lambert(albedo: f32) -> Material {
    Material { diffuse_color: Vec3::splat(albedo), ior: 1.0, ..Material::default() }
}

/// A UV sphere with smooth normals; `inward` flips the winding and normals.
pub fn sphere(center: Vec3, radius: f32, rings: u32, segments: u32, material: u32, inward: bool) -> Mesh {
    let mut mesh = Mesh { path: "/sphere".into(), double_sided: false, ..Mesh::default() };
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            mesh.positions.push(center + radius * n);
            mesh.normals.push(if inward { -n } else { n });
            mesh.uvs.push(Vec2::new(j as f32 / segments as f32, i as f32 / rings as f32));
        }
    }
    let row = segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let a = i * row + j;
            let b = a + row;
            let mut quads = [[a, a + 1, b + 1], [a, b + 1, b]];
            if !inward {
                for t in &mut quads {
                    t.swap(1, 2);
                }
            }
            for t in quads {
                mesh.triangles.push(t);
                mesh.triangle_materials.push(material);
            }
        }
    }
    mesh
}

/// An axis-aligned square in the XY plane at `z`, facing +Z, of half-size `half`.
pub fn card(z: f32, half: f32, material: u32) -> Mesh {
    Mesh {
        path: "/card".into(),
        positions: vec![
            Vec3::new(-half, -half, z),
            Vec3::new(half, -half, z),
            Vec3::new(half, half, z),
            Vec3::new(-half, half, z),
        ],
        normals: vec![Vec3::Z; 4],
        uvs: vec![],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![material; 2],
        double_sided: false,
    }
}

/// A perspective camera at `eye` looking down −Z with a square aperture.
pub fn camera_looking_down_z(eye: Vec3, focal: f32) -> Camera {
    Camera {
        path: "/cam".into(),
        world_from_camera: Mat4::from_translation(eye),
        orthographic: false,
        focal_length: focal,
        horizontal_aperture: 20.0,
        vertical_aperture: 20.0,
        horizontal_aperture_offset: 0.0,
        vertical_aperture_offset: 0.0,
        clipping_range: [0.01, 1.0e6],
    }
}

/// A dome light of uniform radiance.
pub fn dome(radiance: f32) -> Light {
    Light {
        path: "/dome".into(),
        kind: LightKind::Dome,
        radiance: Vec3::splat(radiance),
        normalize: false,
        world_from_light: Mat4::IDENTITY,
    }
}

/// `count` random triangles inside [−1, 1]³ with one material and no lights.
pub fn random_triangles(count: usize, seed: u64) -> SceneData {
    let mut rng = Rng(seed);
    let mut mesh = Mesh { path: "/random".into(), ..Mesh::default() };
    for i in 0..count {
        let c = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        for _ in 0..3 {
            mesh.positions.push(c + 0.3 * Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)));
        }
        let b = 3 * i as u32;
        mesh.triangles.push([b, b + 1, b + 2]);
        mesh.triangle_materials.push(0);
    }
    let scene = Scene { meshes: vec![mesh], materials: vec![lambert(0.5)], ..Scene::default() };
    pack(&scene)
}

fn rows(m: Mat4) -> [[f32; 4]; 3] {
    let r = m.transpose();
    [r.x_axis.to_array(), r.y_axis.to_array(), r.z_axis.to_array()]
}

/// Scene → blob records (stand-in for `ingest::pack::pack`).
pub fn pack(scene: &Scene) -> SceneData {
    let mut data = SceneData::default();
    let any_normals = scene.meshes.iter().any(|m| !m.normals.is_empty());
    let any_uvs = scene.meshes.iter().any(|m| !m.uvs.is_empty());
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for mesh in &scene.meshes {
        let first_vertex = data.positions.len() as u32;
        let first_triangle = data.triangles.len() as u32;
        let mesh_index = data.meshes.len() as u32;
        for (i, p) in mesh.positions.iter().enumerate() {
            data.positions.push(p.to_array());
            lo = lo.min(*p);
            hi = hi.max(*p);
            if any_normals {
                data.normals.push(mesh.normals.get(i).map_or([0.0; 3], |n| n.to_array()));
            }
            if any_uvs {
                data.uvs.push(mesh.uvs.get(i).map_or([0.0; 2], |u| u.to_array()));
            }
        }
        for (t, m) in mesh.triangles.iter().zip(&mesh.triangle_materials) {
            data.triangles.push(blob::Triangle { vertices: t.map(|v| v + first_vertex), mesh: mesh_index });
            data.triangle_materials.push(*m);
        }
        let mut flags = 0;
        if !mesh.normals.is_empty() {
            flags |= blob::MESH_HAS_NORMALS;
        }
        if !mesh.uvs.is_empty() {
            flags |= blob::MESH_HAS_UVS;
        }
        if mesh.double_sided {
            flags |= blob::MESH_DOUBLE_SIDED;
        }
        let name = data.add_string(&mesh.path);
        data.meshes.push(blob::Mesh {
            name,
            first_triangle,
            triangle_count: mesh.triangles.len() as u32,
            first_vertex,
            vertex_count: mesh.positions.len() as u32,
            flags,
            reserved: 0,
        });
    }
    for m in &scene.materials {
        let name = data.add_string(&m.path);
        data.materials.push(blob::Material {
            name,
            diffuse_color: m.diffuse_color.to_array(),
            emissive_color: m.emissive_color.to_array(),
            specular_color: m.specular_color.to_array(),
            roughness: m.roughness,
            metallic: m.metallic,
            ior: m.ior,
            opacity: m.opacity,
            opacity_threshold: m.opacity_threshold,
            clearcoat: m.clearcoat,
            clearcoat_roughness: m.clearcoat_roughness,
            use_specular_workflow: m.use_specular_workflow as u32,
            reserved: [0; 5],
        });
    }
    data.info.dome_light = blob::NONE;
    for l in &scene.lights {
        let name = data.add_string(&l.path);
        let mut rec = blob::Light {
            name,
            radiance: l.radiance.to_array(),
            flags: if l.normalize { blob::LIGHT_NORMALIZE } else { 0 },
            world_from_light: rows(l.world_from_light),
            ..blob::Light::default()
        };
        match l.kind {
            LightKind::Dome => {
                rec.kind = blob::light_kind::DOME;
                if data.info.dome_light == blob::NONE {
                    data.info.dome_light = data.lights.len() as u32;
                }
            }
            LightKind::Distant { angle_degrees } => {
                rec.kind = blob::light_kind::DISTANT;
                rec.angle_degrees = angle_degrees;
            }
            LightKind::Sphere { radius, treat_as_point } => {
                rec.kind = blob::light_kind::SPHERE;
                rec.radius = radius;
                if treat_as_point {
                    rec.flags |= blob::LIGHT_TREAT_AS_POINT;
                }
            }
            LightKind::Rect { width, height } => {
                rec.kind = blob::light_kind::RECT;
                rec.width = width;
                rec.height = height;
            }
            LightKind::Disk { radius } => {
                rec.kind = blob::light_kind::DISK;
                rec.radius = radius;
            }
        }
        data.lights.push(rec);
    }
    for c in &scene.cameras {
        let name = data.add_string(&c.path);
        data.cameras.push(blob::Camera {
            name,
            projection: if c.orthographic { blob::PROJECTION_ORTHOGRAPHIC } else { blob::PROJECTION_PERSPECTIVE },
            focal_length: c.focal_length,
            horizontal_aperture: c.horizontal_aperture,
            vertical_aperture: c.vertical_aperture,
            horizontal_aperture_offset: c.horizontal_aperture_offset,
            vertical_aperture_offset: c.vertical_aperture_offset,
            clipping_range: c.clipping_range,
            reserved: [0.0; 2],
            world_from_camera: rows(c.world_from_camera),
        });
    }
    data.info.default_camera = scene.default_camera.map_or(blob::NONE, |c| c as u32);
    data.info.resolution = scene.resolution.unwrap_or([0, 0]);
    data.info.bounds_min = lo.to_array();
    data.info.bounds_max = hi.to_array();
    data.info.gprim_count = scene.meshes.len() as u32;
    data.info.up_axis = blob::UP_AXIS_Y;
    data.info.meters_per_unit = 0.01;

    // Emissive distribution proportional to area × luminance.
    let mut weights = Vec::new();
    for (i, t) in data.triangles.iter().enumerate() {
        let e = Vec3::from(data.materials[data.triangle_materials[i] as usize].emissive_color);
        let lum = 0.2126 * e.x + 0.7152 * e.y + 0.0722 * e.z;
        if lum > 0.0 {
            let [a, b, c] = t.vertices.map(|v| Vec3::from(data.positions[v as usize]));
            let area = 0.5 * (b - a).cross(c - a).length();
            weights.push((i as u32, area, area * lum));
        }
    }
    let total: f32 = weights.iter().map(|w| w.2).sum();
    let mut acc = 0.0;
    for (n, (triangle, area, w)) in weights.iter().enumerate() {
        acc += w / total;
        let cdf = if n + 1 == weights.len() { 1.0 } else { acc.min(1.0) };
        data.emissive_triangles.push(blob::EmissiveTriangle { triangle: *triangle, area: *area, cdf, pmf: w / total });
    }

    if !data.triangles.is_empty() {
        let tris: Vec<obvhs::triangle::Triangle> = data
            .triangles
            .iter()
            .map(|t| {
                let [v0, v1, v2] = t.vertices.map(|v| glam::Vec3A::from(data.positions[v as usize]));
                obvhs::triangle::Triangle { v0, v1, v2 }
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        data.bvh_nodes = bytemuck::cast_slice(&bvh.nodes).to_vec();
        data.bvh_primitives = bvh.primitive_indices.clone();
    }
    data
}

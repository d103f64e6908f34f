//! Test scenes built in code as `scene_pack::Scene` values (what ingest calls `scene_pack::Scene`) and
//! packed into blob bytes.
//!
//! Packing goes through `scene_pack::pack::pack`, ingest's packer, so these tests also cover the
//! blob ingest writes (without compiling USD or OpenSubdiv).

use crate::Image;
use blob::{AlignedBytes, SceneData};
use glam::{Mat4, Vec2, Vec3};
use scene_pack::{Camera, Light, LightKind, Material, Mesh, Scene};

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
            // Counter-clockwise seen from outside (USD's right-handed front) unless `inward`.
            let mut quads = [[a, a + 1, b + 1], [a, b + 1, b]];
            if inward {
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
        instance: None,
        placed: None,
        motion: None,
        deformation: None,
        primvars: Vec::new(),
        light_set: 0,
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
        lens: Default::default(),
        shutter: [0.0; 2],
        motion: None,
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
    let scene = Scene {
        meshes: vec![random_triangles_mesh(count, seed)],
        materials: vec![lambert(0.5)],
        ..Scene::default()
    };
    pack(&scene)
}

/// The mesh of [`random_triangles`] (material 0).
pub fn random_triangles_mesh(count: usize, seed: u64) -> Mesh {
    let mut rng = Rng(seed);
    let mut mesh = Mesh { path: "/random".into(), ..Mesh::default() };
    for i in 0..count {
        let c = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        for _ in 0..3 {
            mesh.positions
                .push(c + 0.3 * Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)));
        }
        let b = 3 * i as u32;
        mesh.triangles.push([b, b + 1, b + 2]);
        mesh.triangle_materials.push(0);
    }
    mesh
}

/// Exact ties: `copies` copies of one large triangle in the z = 0 plane (identical vertices, so every
/// ray meets them all at the same `t` with the same barycentrics), interleaved in index order with
/// `clutter` random triangles around z = 1; more copies than a leaf holds spread them over leaves.
pub fn stacked_copies(copies: usize, clutter: usize, seed: u64) -> SceneData {
    let random = random_triangles_mesh(clutter, seed);
    let mut mesh = Mesh { path: "/ties".into(), ..Mesh::default() };
    let big = [Vec3::new(-2.0, -2.0, 0.0), Vec3::new(2.0, -2.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
    let every = (clutter / copies.max(1)).max(1);
    let mut copies_left = copies;
    let push = |mesh: &mut Mesh, corners: [Vec3; 3]| {
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(corners);
        mesh.triangles.push([base, base + 1, base + 2]);
        mesh.triangle_materials.push(0);
    };
    for (j, [a, b, c]) in random.triangles.iter().enumerate() {
        if j % every == 0 && copies_left > 0 {
            push(&mut mesh, big);
            copies_left -= 1;
        }
        push(&mut mesh, [a, b, c].map(|v| random.positions[*v as usize] + Vec3::Z));
    }
    for _ in 0..copies_left {
        push(&mut mesh, big);
    }
    pack(&Scene { meshes: vec![mesh], materials: vec![lambert(0.5)], ..Scene::default() })
}

/// `count` instances of a smooth sphere plus one random-triangle cloud in world space, under
/// random rotations, non-uniform scales (some mirrored) and translations inside [−3, 3]³: every
/// gprim carries its instance-space copy, as the USD reader writes it.
pub fn instanced_spheres(count: usize, seed: u64) -> Scene {
    let mut rng = Rng(seed);
    let local = sphere(Vec3::ZERO, 0.4, 6, 10, 0, false);
    let mut scene = Scene { materials: vec![lambert(0.5)], ..Scene::default() };
    for i in 0..count {
        let axis = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(0.1, 1.0)).normalize();
        let mut scale = Vec3::new(rng.range(0.5, 1.5), rng.range(0.5, 1.5), rng.range(0.5, 1.5));
        if i % 5 == 0 {
            scale.x = -scale.x;
        }
        let translation = Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
        let m = glam::DMat4::from_scale_rotation_translation(
            scale.as_dvec3(),
            glam::DQuat::from_axis_angle(axis.as_dvec3(), rng.range(0.0, 6.0) as f64),
            translation.as_dvec3(),
        );
        let normal_from_local = glam::DMat3::from_mat4(m).inverse().transpose();
        let mut triangles = local.triangles.clone();
        if m.determinant() < 0.0 {
            triangles.iter_mut().for_each(|t| t.swap(1, 2));
        }
        scene
            .instances
            .push(scene_pack::scene::SceneInstance { path: format!("/S{i}"), world_from_instance: m });
        scene.meshes.push(Mesh {
            path: format!("/S{i}/Mesh"),
            positions: local.positions.iter().map(|p| m.transform_point3(p.as_dvec3()).as_vec3()).collect(),
            normals: local
                .normals
                .iter()
                .map(|n| (normal_from_local * n.as_dvec3()).normalize().as_vec3())
                .collect(),
            triangles,
            primvars: Vec::new(),
            instance: Some(scene_pack::scene::InstancedMesh {
                instance: i as u32,
                positions: local.positions.clone(),
                normals: local.normals.clone(),
                triangles: local.triangles.clone(),
            }),
            ..local.clone()
        });
    }
    let cloud = random_triangles_mesh(60, seed ^ 0x77);
    scene.meshes.push(cloud);
    scene
}

/// Scene → blob records through ingest's packer (the same path as the `ingest` binary).
pub fn pack(scene: &Scene) -> SceneData {
    scene_pack::pack::pack(scene).expect("test scenes are valid")
}

/// Randomly placed and turned area lights (sphere, rect, disk in turn) for the emission tests:
/// centres within `spread` of the origin, sphere radii `radius.0 + radius.1·u`, rect/disk sides
/// `side.0 + side.1·u`; `u` draws uniform numbers in [0, 1).
pub fn area_light_records(
    count: usize,
    spread: f32,
    radius: (f32, f32),
    side: (f32, f32),
    u: &mut impl FnMut() -> f32,
) -> Vec<blob::Light> {
    (0..count)
        .map(|i| {
            let kind = [blob::light_kind::SPHERE, blob::light_kind::RECT, blob::light_kind::DISK][i % 3];
            let mut at = || spread * (2.0 * u() - 1.0);
            let (tx, ty, tz) = (at(), at(), at());
            let (a, b) = (u() * 3.0, u() * 3.0);
            let (ca, sa, cb, sb) = (a.cos(), a.sin(), b.cos(), b.sin());
            blob::Light {
                kind,
                radiance: [1.0 + u(), 2.0 * u(), u()],
                radius: radius.0 + radius.1 * u(),
                width: side.0 + side.1 * u(),
                height: side.0 + side.1 * u(),
                world_from_light: [
                    [cb, 0.0, sb, tx],
                    [sa * sb, ca, -sa * cb, ty],
                    [-ca * sb, sa, ca * cb, tz],
                ],
                ..Default::default()
            }
        })
        .collect()
}

/// A blob holding only `lights` (no camera, no geometry).
pub fn lights_only(lights: Vec<blob::Light>) -> AlignedBytes {
    let mut data = SceneData::default();
    data.info.default_camera = blob::NONE;
    data.info.dome_light = blob::NONE;
    data.lights = lights;
    encode(&data)
}

/// Mean of channel-averaged beauty over pixels selected by `keep(x, y)`.
pub fn mean_where(image: &Image, keep: impl Fn(f32, f32) -> bool) -> (f32, usize) {
    let mut sum = 0.0f64;
    let mut n = 0;
    for y in 0..image.height {
        for x in 0..image.width {
            // Pixel centre in [−1, 1]², y up.
            let fx = (x as f32 + 0.5) / image.width as f32 * 2.0 - 1.0;
            let fy = 1.0 - (y as f32 + 0.5) / image.height as f32 * 2.0;
            if keep(fx, fy) {
                let [r, g, b] = image.rgb(x, y);
                sum += ((r + g + b) / 3.0) as f64;
                n += 1;
            }
        }
    }
    ((sum / n as f64) as f32, n)
}

/// Asserts `value` is within `rel` (relative) of `expected`, printing both.
pub fn assert_close(name: &str, value: f32, expected: f32, rel: f32) {
    eprintln!("{name}: {value:.5} (expected {expected:.5}, {:+.3}%)", (value / expected - 1.0) * 100.0);
    assert!((value / expected - 1.0).abs() < rel, "{name}: {value} vs expected {expected}");
}

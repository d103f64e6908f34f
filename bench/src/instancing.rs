//! `bench instancing`: a generated scene of 1,000 instanced spheres packed twice — as one prototype
//! plus 1,000 instance records (two-level BVH), and flattened into 1,000 world-space copies — with
//! the blob bytes of each and closest-hit throughput on the same primary and incoherent rays.

use crate::rays;
use glam::{DMat4, DQuat, DVec3, Mat4, Vec2, Vec3};
use ingest::scene::{InstancedMesh, SceneInstance};
use ingest::{Camera, Material, Mesh, Scene};
use std::path::Path;

/// A UV sphere in its own space: (positions, normals, uvs, triangles).
fn sphere(radius: f32, rings: u32, segments: u32) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<[u32; 3]>) {
    let (mut p, mut n, mut uv, mut tris) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            p.push(radius * d);
            n.push(d);
            uv.push(Vec2::new(j as f32 / segments as f32, i as f32 / rings as f32));
        }
    }
    let row = segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let a = i * row + j;
            tris.push([a, a + row, a + 1]);
            tris.push([a + 1, a + row, a + row + 1]);
        }
    }
    (p, n, uv, tris)
}

/// `count` instances of a `rings × segments` sphere on a 10-wide grid, randomly rotated, seen by a
/// camera from +Z.
pub fn scene(count: usize, rings: u32, segments: u32) -> Scene {
    let (positions, normals, uvs, triangles) = sphere(0.8, rings, segments);
    let mut scene = Scene {
        materials: vec![Material { path: "/Looks/Grey".into(), ..Material::default() }],
        meters_per_unit: 1.0,
        ..Scene::default()
    };
    for i in 0..count {
        let cell = DVec3::new((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64);
        let m = DMat4::from_rotation_translation(
            DQuat::from_rotation_y(i as f64 * 0.37),
            DVec3::new(2.0 * cell.x - 9.0, 2.0 * cell.y - 9.0, -2.0 * cell.z),
        );
        scene.instances.push(SceneInstance { path: format!("/World/I{i}"), world_from_instance: m });
        scene.meshes.push(Mesh {
            path: format!("/World/I{i}/Ball"),
            positions: positions.iter().map(|p| m.transform_point3(p.as_dvec3()).as_vec3()).collect(),
            normals: normals.iter().map(|n| m.transform_vector3(n.as_dvec3()).as_vec3()).collect(),
            uvs: uvs.clone(),
            triangles: triangles.clone(),
            triangle_materials: vec![0; triangles.len()],
            double_sided: false,
            primvars: Vec::new(),
            instance: Some(InstancedMesh {
                instance: i as u32,
                positions: positions.clone(),
                normals: normals.clone(),
                triangles: triangles.clone(),
            }),
            placed: None,
            motion: None,
            deformation: None,
            light_set: 0,
        });
    }
    scene.instance_count = count as u32;
    scene.cameras.push(Camera {
        path: "/Cam".into(),
        world_from_camera: Mat4::from_translation(Vec3::new(0.0, 0.0, 30.0)),
        orthographic: false,
        focal_length: 35.0,
        horizontal_aperture: 36.0,
        vertical_aperture: 36.0,
        horizontal_aperture_offset: 0.0,
        vertical_aperture_offset: 0.0,
        clipping_range: [0.1, 1000.0],
        lens: Default::default(),
        shutter: [0.0; 2],
        motion: None,
    });
    scene.default_camera = Some(0);
    scene
}

/// Packs the scene both ways, measures, prints and writes `instancing.json` (with the `ingest`
/// figures of [`crate::instancing_ingest::measure`]).
#[allow(clippy::too_many_arguments)]
pub fn run(
    count: usize,
    rings: u32,
    segments: u32,
    res: u32,
    rays_count: usize,
    repeat: usize,
    ingest: Option<serde_json::Value>,
    out: &Path,
) -> anyhow::Result<()> {
    let scene = scene(count, rings, segments);
    let pack = |flatten| {
        let options = ingest::pack::PackOptions { flatten_instances: flatten, ..Default::default() };
        ingest::pack::pack_scene(&scene, &options).map(|d| blob::AlignedBytes::copy_from(&d.encode()))
    };
    let (instanced, flattened) = (pack(false)?, pack(true)?);
    let vi = blob::SceneView::parse(&instanced)?;
    let vf = blob::SceneView::parse(&flattened)?;
    let (ai, af) = (render::Accel::new(&vi), render::Accel::new(&vf));
    // The same world-space rays for both (incoherent rays start on the flattened triangles).
    let sets = [rays::primary_rays(&vf, res), rays::incoherent_rays(&vf, rays_count, 1)];
    let mut figures = serde_json::Map::new();
    println!(
        "{:<11} {:>9} {:>16} {:>16} {:>7} {:>9}",
        "rays", "count", "instanced Mray/s", "flattened Mray/s", "ratio", "agree"
    );
    for set in &sets {
        let (pi, ti) = rays::trace(&ai, set);
        let (pf, tf) = rays::trace(&af, set);
        // Hit or miss agree, and hits at the same distance (triangle ids differ between the blobs).
        let agree = pi
            .iter()
            .zip(&pf)
            .zip(ti.iter().zip(&tf))
            .filter(|((a, b), (s, t))| {
                (**a < 0) == (**b < 0) && (**a < 0 || (*s - *t).abs() <= 1e-4 * t.abs().max(1.0))
            })
            .count() as f64
            / pi.len().max(1) as f64;
        let one_i = rays::measure(&ai, set, 1, repeat)?;
        let one_f = rays::measure(&af, set, 1, repeat)?;
        println!(
            "{:<11} {:>9} {:>16.3} {:>16.3} {:>7.3} {:>9.5}",
            set.name,
            set.origins.len(),
            one_i,
            one_f,
            one_i / one_f,
            agree
        );
        figures.insert(
            set.name.into(),
            serde_json::json!({"rays": set.origins.len(), "instanced_mrays_1thr": one_i, "flattened_mrays_1thr": one_f, "agree": agree}),
        );
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "blob bytes: instanced {} ({} triangles stored), flattened {} ({} triangles); {:.1}x smaller; load average {}",
        instanced.len(),
        vi.triangles.len(),
        flattened.len(),
        vf.triangles.len(),
        flattened.len() as f64 / instanced.len() as f64,
        load.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
    );
    let result = serde_json::json!({
        "instances": count,
        "sphere_triangles": 2 * rings * segments,
        "instanced": {"blob_bytes": instanced.len(), "triangles_stored": vi.triangles.len()},
        "flattened": {"blob_bytes": flattened.len(), "triangles_stored": vf.triangles.len()},
        "rays": figures,
        "load_average": load.trim(),
        "ingest": ingest,
    });
    let file = out.join("instancing.json");
    std::fs::write(&file, serde_json::to_string_pretty(&result)?)?;
    println!("figures written to {}", file.display());
    Ok(())
}

//! Texture footprints: the mip level a hit's ray cone selects, and the shading sort key built from it.

use crate::camera::Camera;
use crate::testscene::{self, camera_looking_down_z, lambert};
use crate::Scene;
use glam::{Vec2, Vec3};
use scene_pack::scene::{SceneTexture, ShaderNode, TextureData};
use scene_pack::Mesh;

/// A 1024² checker (8-texel squares) baked in memory.
fn checker() -> SceneTexture {
    let n = 1024u32;
    let texels: Vec<u8> =
        (0..n * n).map(|i| if ((i % n) / 8 + (i / n) / 8).is_multiple_of(2) { 230 } else { 20 }).collect();
    let src =
        texture::SourceImage { width: n, height: n, channels: 1, samples: texture::Samples::U8(texels) };
    let baked = texture::bake(&src, &texture::BakeOptions::default()).unwrap();
    SceneTexture {
        path: "checker.png".into(),
        color_space: texture::ColorSpace::Auto,
        data: TextureData::Image(baked),
    }
}

/// A material whose diffuse colour is the checker read through the mesh's uvs.
fn textured_material() -> scene_pack::Material {
    let mut m = lambert(0.5);
    m.program = ShaderNode::diffuse_texture_program(0, [0.0, 0.0, 0.0, 1.0]);
    m
}

/// The plane y = −1 from z = 0 to z = −`far`, `far` wide each side of the view, uv repeating every unit:
/// a ground receding to the horizon from a camera at the origin looking down −z.
fn ground_plane(far: f32) -> Mesh {
    quad(
        [
            Vec3::new(-far, -1.0, 0.0),
            Vec3::new(far, -1.0, 0.0),
            Vec3::new(far, -1.0, -far),
            Vec3::new(-far, -1.0, -far),
        ],
        far,
    )
}

/// A quad with corners `corners` (counter-clockwise seen from the camera) and uvs spanning `[0, uv_max]²`.
fn quad(corners: [Vec3; 4], uv_max: f32) -> Mesh {
    Mesh {
        path: "/quad".into(),
        positions: corners.to_vec(),
        normals: vec![],
        uvs: vec![Vec2::ZERO, Vec2::new(uv_max, 0.0), Vec2::new(uv_max, uv_max), Vec2::new(0.0, uv_max)],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![0, 0],
        double_sided: true,
        instance: None,
        placed: None,
        motion: None,
        deformation: None,
        primvars: Vec::new(),
        light_set: 0,
    }
}

/// The mip level (fractional, before clamping) and the sort key of the hit along camera ray `(fx, fy)`.
fn level_at(scene: &Scene, camera: &Camera, fx: f32, fy: f32) -> (f32, f32, u32) {
    let (o, d) = camera.generate_ray(fx, fy);
    let hit = scene.accel.closest_hit(o, d, f32::INFINITY).expect("ray hits the plane");
    let cone = camera.pixel_cone(d.dot(camera.forward()));
    let footprint = cone.width_at(hit.t);
    let s = scene.surface(&hit, -d, footprint).unwrap();
    let tex = scene.shading.textures().texture(0).unwrap();
    let level = texture::mip_level(tex.record(), s.uv.duv_dx, s.uv.duv_dy);
    (level, hit.t, scene.shading_sort_key(&hit, -d, footprint))
}

#[test]
fn mip_level_rises_by_one_per_doubling_of_distance() {
    // Fronto-parallel 2 × 2 cards at z = −d, one texel per 1/512 unit.
    let camera_scene = |d: f32| scene_pack::Scene {
        meshes: vec![quad(
            [
                Vec3::new(-1.0, -1.0, -d),
                Vec3::new(1.0, -1.0, -d),
                Vec3::new(1.0, 1.0, -d),
                Vec3::new(-1.0, 1.0, -d),
            ],
            1.0,
        )],
        materials: vec![textured_material()],
        cameras: vec![camera_looking_down_z(Vec3::ZERO, 20.0)],
        default_camera: Some(0),
        textures: vec![checker()],
        ..scene_pack::Scene::default()
    };
    let mut previous: Option<f32> = None;
    for d in [1.0f32, 2.0, 4.0, 8.0, 16.0] {
        let bytes = testscene::bytes(&camera_scene(d));
        let view = blob::SceneView::parse(&bytes).unwrap();
        let scene = Scene::new(view);
        let camera = scene.camera(Some(0), 256, 256);
        let (level, _, key) = level_at(&scene, &camera, 0.5, 0.5);
        // One pixel spans 20/256/20 = 1/256 rad: at d = 1 that is 1/256 unit = 2 texels → level 1.
        eprintln!("card at distance {d}: mip level {level:.4}, sort-key level {}", (key >> 14) & 15);
        if let Some(p) = previous {
            assert!((level - p - 1.0f32).abs() < 0.01, "d = {d}: level {level} after {p}");
        }
        assert_eq!((key >> 14) & 15, level.round().max(0.0) as u32, "sort key carries the level");
        previous = Some(level);
    }
    assert!((previous.unwrap() - 5.0).abs() < 0.01);
}

#[test]
fn receding_plane_minor_axis_level_rises_by_one_per_doubling() {
    // A ground plane y = −1 to the horizon, checker repeated every unit; camera at the origin looking
    // down −z. Rows nearer the horizon see farther points; the footprint's minor axis (across the view,
    // what EWA picks its level from) grows linearly with distance, the major axis with distance².
    let far = 400.0;
    let scene_data = scene_pack::Scene {
        meshes: vec![ground_plane(far)],
        materials: vec![textured_material()],
        cameras: vec![camera_looking_down_z(Vec3::ZERO, 20.0)],
        default_camera: Some(0),
        textures: vec![checker()],
        ..scene_pack::Scene::default()
    };
    let bytes = testscene::bytes(&scene_data);
    let scene = Scene::new(blob::SceneView::parse(&bytes).unwrap());
    let camera = scene.camera(Some(0), 512, 512);
    let mut samples = Vec::new();
    for row in [0.75f32, 0.625, 0.5625, 0.53125, 0.515625] {
        let (o, d) = camera.generate_ray(0.5, row);
        let hit = scene.accel.closest_hit(o, d, f32::INFINITY).unwrap();
        let footprint = camera.pixel_cone(d.dot(camera.forward())).width_at(hit.t);
        let s = scene.surface(&hit, -d, footprint).unwrap();
        let size = 1024.0 * 400.0 / 400.0;
        let axis = |v: [f32; 2]| (v[0] * v[0] + v[1] * v[1]).sqrt() * size;
        let (a, b) = (axis(s.uv.duv_dx), axis(s.uv.duv_dy));
        let (minor, major) = (a.min(b).log2(), a.max(b).log2());
        let (level, _, _) = level_at(&scene, &camera, 0.5, row);
        eprintln!(
            "row {row}: distance {:.3}, minor-axis level {minor:.3}, major {major:.3}, mip_level {level:.3}",
            hit.t
        );
        samples.push((hit.t.log2(), minor, major));
    }
    // Rows were picked so that each distance is double the previous one.
    for w in samples.windows(2) {
        let doublings = w[1].0 - w[0].0;
        assert!((doublings - 1.0).abs() < 0.05, "distances double: {doublings}");
        assert!(((w[1].1 - w[0].1) / doublings - 1.0).abs() < 0.05, "minor axis: {:?}", w);
        assert!(((w[1].2 - w[0].2) / doublings - 2.0).abs() < 0.15, "major axis: {:?}", w);
    }
}

/// `bench textures` in small: a receding plane under a white dome whose diffuse texture is a 1-texel
/// checker with thin stripes (aliases without prefiltering). Against a 256-spp render reading level 0
/// at every sample point, at 4 spp: EWA's RMSE is at most the multi-tap anisotropic filter's, and both
/// beat trilinear (isotropic: blurs along the footprint's minor axis) and no prefiltering at all.
#[test]
fn ewa_error_on_a_receding_plane_is_at_most_the_anisotropic_filters() {
    use texture::Filter;
    let n = 256u32;
    let texels: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            let (x, y) = (i % n, i / n);
            if x % 37 < 2 || y % 53 < 3 {
                [250, 240, 40]
            } else if (x + y) % 2 == 0 {
                [230, 230, 230]
            } else {
                [20, 30, 120]
            }
        })
        .collect();
    let src =
        texture::SourceImage { width: n, height: n, channels: 3, samples: texture::Samples::U8(texels) };
    let baked = texture::bake(&src, &texture::BakeOptions::default()).unwrap();
    let far = 200.0;
    let mut material = textured_material();
    material.ior = 1.0;
    let scene_data = scene_pack::Scene {
        meshes: vec![ground_plane(far)],
        materials: vec![material],
        lights: vec![testscene::dome(1.0)],
        cameras: vec![camera_looking_down_z(Vec3::ZERO, 20.0)],
        default_camera: Some(0),
        textures: vec![SceneTexture {
            path: "stripes.png".into(),
            color_space: texture::ColorSpace::Auto,
            data: TextureData::Image(baked),
        }],
        ..scene_pack::Scene::default()
    };
    let bytes = testscene::bytes(&scene_data);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let base =
        crate::RenderOptions { resolution: Some([96, 64]), max_depth: 1, threads: 2, ..Default::default() };
    let reference = crate::render_image(
        &view,
        &crate::RenderOptions {
            spp: 256,
            seed: 0x5EED,
            texture_filter: Filter::Bilinear,
            texture_footprint_scale: 0.0,
            ..base.clone()
        },
    )
    .unwrap();
    let rmse = |filter: Filter, scale: f32| {
        let options = crate::RenderOptions {
            spp: 4,
            seed: 1,
            texture_filter: filter,
            texture_footprint_scale: scale,
            ..base.clone()
        };
        let image = crate::render_image(&view, &options).unwrap();
        let sum: f64 = image
            .beauty
            .iter()
            .zip(&reference.beauty)
            .map(|(p, q)| (0..3).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>())
            .sum();
        (sum / (3 * image.beauty.len()) as f64).sqrt()
    };
    let none = rmse(Filter::Bilinear, 0.0);
    let trilinear = rmse(Filter::Trilinear, 1.0);
    let anisotropic = rmse(Filter::Anisotropic, 1.0);
    let ewa = rmse(Filter::Ewa, 1.0);
    eprintln!("RMSE vs 256 spp: none {none:.5}, trilinear {trilinear:.5}, anisotropic {anisotropic:.5}, ewa {ewa:.5}");
    assert!(ewa <= anisotropic, "ewa {ewa} > anisotropic {anisotropic}");
    assert!(anisotropic < trilinear && ewa < none, "{none} {trilinear} {anisotropic} {ewa}");
}

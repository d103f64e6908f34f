//! Whole-image equivalence of the wavefront and scalar integrators on a scene that exercises every
//! lane kernel: textured UsdPreviewSurface materials (diffuse, metal, clearcoat; texture-driven colour
//! and roughness), sphere, rect and disk lights (the area-emission lanes, more than eight of them), an
//! emissive triangle, a dome and a sun, and paths deep enough for Russian roulette.

use crate::testscene::{self, camera_looking_down_z, card, sphere};
use crate::{render_image, Integrator, RenderOptions};
use glam::{Mat4, Vec3};
use ingest::scene::{SceneTexture, ShaderNode, ShadingInput, TextureData};
use ingest::{Light, LightKind, Material, Scene};

fn textured(metallic: f32, clearcoat: f32) -> Material {
    let mut m = Material { ior: 1.5, metallic, clearcoat, clearcoat_roughness: 0.2, ..Material::default() };
    m.program = {
        let mut program = ShaderNode::diffuse_texture_program(0, [0.5; 4]);
        program.push(ShaderNode::Output { input: ShadingInput::Roughness, src: 1, swizzle: [3; 4] });
        program
    };
    m
}

fn scene() -> Scene {
    let n = 64u32;
    let texels: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            let h = crate::sampler::hash_u32(i);
            [(h >> 24) as u8, (h >> 16) as u8, 40 + (h >> 9) as u8 % 200, 10 + (h >> 1) as u8 % 240]
        })
        .collect();
    let src =
        texture::SourceImage { width: n, height: n, channels: 4, samples: texture::Samples::U8(texels) };
    let baked = texture::bake(&src, &texture::BakeOptions::default()).expect("valid image");
    let emitter = Material { emissive_color: Vec3::new(4.0, 3.0, 2.0), ..testscene::lambert(0.2) };
    let mut meshes = vec![card(-1.5, 3.0, 0)];
    for (i, x) in [-1.2f32, 0.0, 1.2].into_iter().enumerate() {
        meshes.push(sphere(Vec3::new(x, 0.0, -0.5), 0.55, 12, 24, i as u32, false));
    }
    let mut lamp = card(-0.2, 0.3, 3);
    lamp.positions.iter_mut().for_each(|p| *p += Vec3::new(0.0, 1.6, 0.0));
    meshes.push(lamp);
    let at = |x: f32, y: f32, z: f32| Mat4::from_translation(Vec3::new(x, y, z));
    let mut lights = vec![
        Light {
            path: "/dome".into(),
            kind: LightKind::Dome,
            radiance: Vec3::splat(0.3),
            normalize: false,
            world_from_light: Mat4::IDENTITY,
        },
        Light {
            path: "/sun".into(),
            kind: LightKind::Distant { angle_degrees: 3.0 },
            radiance: Vec3::splat(1.5),
            normalize: true,
            world_from_light: Mat4::from_rotation_x(-0.6),
        },
    ];
    for k in 0..12 {
        let a = k as f32 * 0.52;
        let (x, y) = (2.0 * a.cos(), 1.0 + 0.8 * a.sin());
        let kind = match k % 3 {
            0 => LightKind::Sphere { radius: 0.12, treat_as_point: false },
            1 => LightKind::Rect { width: 0.4, height: 0.3 },
            _ => LightKind::Disk { radius: 0.2 },
        };
        // Rect and disk lights emit along their −Z: towards the scene from z = 1.5.
        lights.push(Light {
            path: format!("/light{k}"),
            kind,
            radiance: Vec3::new(3.0, 2.5 + 0.1 * k as f32, 2.0),
            normalize: false,
            world_from_light: at(x, y, 1.5),
        });
    }
    Scene {
        meshes,
        materials: vec![textured(0.0, 0.0), textured(1.0, 0.0), textured(0.0, 1.0), emitter],
        lights,
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.3, 4.0), 18.0)],
        default_camera: Some(0),
        meters_per_unit: 1.0,
        textures: vec![SceneTexture {
            path: "generated".into(),
            color_space: texture::ColorSpace::Auto,
            data: TextureData::Image(baked),
        }],
        ..Scene::default()
    }
}

#[test]
fn wavefront_equals_scalar_with_textures_and_many_area_lights() {
    let bytes = testscene::bytes(&scene());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let options = RenderOptions {
        spp: 16,
        resolution: Some([48, 48]),
        tile_size: 16,
        max_depth: 6,
        ..RenderOptions::default()
    };
    let scalar =
        render_image(&view, &RenderOptions { integrator: Integrator::Scalar, ..options.clone() }).unwrap();
    let wave = render_image(&view, &RenderOptions { integrator: Integrator::Wavefront, ..options }).unwrap();
    let (mut max, mut sum, mut n) = (0.0f32, 0.0f64, 0usize);
    for (a, b) in scalar.beauty.iter().flatten().zip(wave.beauty.iter().flatten()) {
        max = max.max((a - b).abs());
        sum += (a - b).abs() as f64;
        n += 1;
    }
    eprintln!(
        "textures + 12 area lights: wavefront vs scalar: max abs diff {max:e}, mean {:e}",
        sum / n as f64
    );
    assert_eq!(max, 0.0, "the lane kernels are bit-exact, so the images must be equal");
    assert_eq!(scalar.albedo, wave.albedo);
    assert_eq!(scalar.stats.rays, wave.stats.rays);
    assert_eq!(scalar.stats.shader_evaluations, wave.stats.shader_evaluations);
    // The scene must actually be lit by its area lights and show texture variation.
    let lum: Vec<f32> = scalar.beauty.iter().map(|p| p[0] + p[1] + p[2]).collect();
    let mean = lum.iter().sum::<f32>() / lum.len() as f32;
    assert!(mean > 0.05, "mean luminance {mean}");
    assert!(wave.stats.counters.bsdf_lane_groups > 0);
}

/// `phase_stats` times every phase for both integrators, and the timers cover the render: their sum
/// is positive and no more than the render's wall time over all threads.
#[test]
fn phase_timers_cover_both_integrators() {
    let bytes = testscene::bytes(&scene());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    for integrator in [Integrator::Scalar, Integrator::Wavefront] {
        let options = RenderOptions {
            spp: 8,
            resolution: Some([48, 48]),
            threads: 1,
            integrator,
            phase_stats: true,
            ..RenderOptions::default()
        };
        let image = render_image(&view, &options).unwrap();
        let p = image.stats.phases;
        eprintln!("{integrator:?}: {p:?} of {:.4} s", image.stats.seconds);
        assert!(p.intersect > 0.0 && p.shading > 0.0 && p.texturing > 0.0 && p.integration > 0.0, "{p:?}");
        assert!(p.total() <= image.stats.seconds * 1.05 + 1e-3, "{} > {}", p.total(), image.stats.seconds);
        // The rest is thread-pool start-up and tile bookkeeping outside the laps.
        assert!(p.total() >= image.stats.seconds * 0.25, "{} ≪ {}", p.total(), image.stats.seconds);
        assert!(image.stats.shader_evaluations > 48 * 48 * 8 / 2, "{}", image.stats.shader_evaluations);
        let c = image.stats.counters;
        if integrator == Integrator::Wavefront {
            // Chunks of 256 hits leave at most one partial group each: lanes are mostly full.
            assert!(c.bsdf_lanes_active * 10 >= c.bsdf_lane_groups * 8 * 9, "{c:?}");
            assert!(c.light_lanes_active <= c.bsdf_lanes_active && c.light_lanes_active > 0, "{c:?}");
        } else {
            assert_eq!(c, crate::wavefront::Counters::default());
        }
    }
    // Without `phase_stats` nothing is timed.
    let image =
        render_image(&view, &RenderOptions { spp: 1, resolution: Some([8, 8]), ..RenderOptions::default() })
            .unwrap();
    assert_eq!(image.stats.phases.total(), 0.0);
}

/// The material-program and texture lanes equal the scalar lookups for every texture filter (the
/// MoonRay filter runs in lane loops, the others per lane): whole images equal, per filter.
#[test]
fn wavefront_equals_scalar_for_every_texture_filter() {
    let bytes = testscene::bytes(&scene());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let mut images = Vec::new();
    for texture_filter in texture::Filter::ALL {
        let options = RenderOptions {
            spp: 4,
            resolution: Some([40, 40]),
            tile_size: 16,
            max_depth: 4,
            texture_filter,
            ..RenderOptions::default()
        };
        let scalar =
            render_image(&view, &RenderOptions { integrator: Integrator::Scalar, ..options.clone() })
                .unwrap();
        let wave =
            render_image(&view, &RenderOptions { integrator: Integrator::Wavefront, ..options }).unwrap();
        let max = scalar
            .beauty
            .iter()
            .flatten()
            .zip(wave.beauty.iter().flatten())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        eprintln!("{texture_filter:?}: wavefront vs scalar: max abs diff {max:e}");
        assert_eq!(max, 0.0, "{texture_filter:?}");
        assert_eq!(scalar.beauty, wave.beauty, "{texture_filter:?}");
        assert_eq!(scalar.albedo, wave.albedo, "{texture_filter:?}");
        images.push(scalar.beauty);
    }
    // The filters differ, so each comparison exercised its own lookups.
    assert!(images.windows(2).all(|w| w[0] != w[1]));
}

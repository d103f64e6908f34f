//! Whole-image equivalence of the wavefront and scalar integrators on a scene that exercises every
//! lane kernel: textured UsdPreviewSurface materials (diffuse, metal, clearcoat; texture-driven colour
//! and roughness), sphere, rect and disk lights (the area-emission lanes, more than eight of them), an
//! emissive triangle, a dome and a sun, and paths deep enough for Russian roulette; and the same scene
//! with curves (hair-coloured tubes, ribbons, a textured and a translucent UsdPreviewSurface material
//! on fibres) and points among the triangles.

use crate::testscene::{self, camera_looking_down_z, card, sphere};
use crate::{render_image, Image, Integrator, RenderOptions};
use glam::{Mat4, Vec3};
use scene_pack::scene::{SceneTexture, ShaderNode, ShadingInput, TextureData};
use scene_pack::{
    BezierSegment, CurveKind, Curves, Light, LightKind, LightSet, Material, PointSphere, Scene,
};

fn textured(metallic: f32, clearcoat: f32) -> Material {
    let mut m = Material { ior: 1.5, metallic, clearcoat, clearcoat_roughness: 0.2, ..Material::default() };
    m.program = {
        let mut program = ShaderNode::diffuse_texture_program(0, [0.5; 4]);
        program.push(ShaderNode::Output { input: ShadingInput::Roughness, src: 1, swizzle: [3; 4] });
        program
    };
    m
}

pub(crate) fn scene() -> Scene {
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

/// 48 × 48 at 16 spp in 16-pixel tiles, paths up to 6 bounces (Russian roulette from the third).
pub(crate) fn options() -> RenderOptions {
    RenderOptions {
        spp: 16,
        resolution: Some([48, 48]),
        tile_size: 16,
        max_depth: 6,
        ..RenderOptions::default()
    }
}

/// The largest absolute difference between two beauty images, over every channel.
fn max_abs_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max)
}

/// Renders `view` with both integrators and asserts the images are equal bit for bit (beauty and
/// every AOV), with the same ray and shader-evaluation counts.
pub(crate) fn both_integrators(
    view: &blob::SceneView,
    options: &RenderOptions,
    what: &str,
) -> (Image, Image) {
    let scalar =
        render_image(view, &RenderOptions { integrator: Integrator::Scalar, ..options.clone() }).unwrap();
    let wave =
        render_image(view, &RenderOptions { integrator: Integrator::Wavefront, ..options.clone() }).unwrap();
    let (mut max, mut sum, mut n) = (0.0f32, 0.0f64, 0usize);
    for (a, b) in scalar.beauty.iter().flatten().zip(wave.beauty.iter().flatten()) {
        max = max.max((a - b).abs());
        sum += (a - b).abs() as f64;
        n += 1;
    }
    let mean = sum / n as f64;
    eprintln!("{what}: wavefront vs scalar: max abs diff {max:e}, mean {mean:e}");
    assert_eq!(max, 0.0, "the lane kernels are bit-exact, so the images must be equal");
    assert_eq!(mean, 0.0);
    assert_eq!(scalar.beauty, wave.beauty);
    assert_eq!(scalar.albedo, wave.albedo);
    assert_eq!(scalar.normal, wave.normal);
    assert_eq!(scalar.depth, wave.depth);
    assert_eq!(scalar.stats.rays, wave.stats.rays);
    assert_eq!(scalar.stats.shader_evaluations, wave.stats.shader_evaluations);
    crate::dispatch_tests::record_image(what, &scalar);
    (scalar, wave)
}

#[test]
fn wavefront_equals_scalar_with_textures_and_many_area_lights() {
    let bytes = testscene::bytes(&scene());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let options = options();
    let (scalar, wave) = both_integrators(&view, &options, "textures + 12 area lights");
    // The scene must actually be lit by its area lights and show texture variation.
    let lum: Vec<f32> = scalar.beauty.iter().map(|p| p[0] + p[1] + p[2]).collect();
    let mean = lum.iter().sum::<f32>() / lum.len() as f32;
    assert!(mean > 0.05, "mean luminance {mean}");
    assert!(wave.stats.counters.bsdf_lane_groups > 0);
}

/// [`scene`] with production-style UsdPreviewSurface networks on the spheres and the card: st through
/// a UsdTransform2d, then base colour, roughness and metallic from the colour texture's channels and a
/// tangent-space normal map (a second, raw texture, `2·t − 1`), as a published asset's looks read
/// them; each material rotates and scales its uvs differently.
fn pbr_scene() -> Scene {
    let mut scene = scene();
    let n = 32u32;
    let texels: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            let h = crate::sampler::hash_u32(i ^ 0x5bd1_e995);
            // Normals tilted up to ~40° off the tangent plane's normal.
            [64 + (h >> 25) as u8, 64 + (h >> 17) as u8 % 128, 200 + (h >> 3) as u8 % 55]
        })
        .collect();
    let src =
        texture::SourceImage { width: n, height: n, channels: 3, samples: texture::Samples::U8(texels) };
    let options = texture::BakeOptions { color_space: texture::ColorSpace::Raw, ..Default::default() };
    scene.textures.push(SceneTexture {
        path: "generated-normals".into(),
        color_space: texture::ColorSpace::Raw,
        data: TextureData::Image(texture::bake(&src, &options).expect("valid image")),
    });
    let lookup = |dst, texture, scale, bias| ShaderNode::Texture {
        dst,
        src: 1,
        texture: Some(texture),
        wrap_s: texture::Wrap::Repeat,
        wrap_t: texture::Wrap::Mirror,
        scale,
        bias,
        fallback: [0.5; 4],
    };
    for (k, m) in scene.materials.iter_mut().take(3).enumerate() {
        m.program = ShaderNode::transformed_uvs(30.0 * k as f32, [1.5, 2.0], [0.25, -0.1 * k as f32]);
        m.program.extend([
            lookup(2, 0, [1.0; 4], [0.0; 4]),
            lookup(3, 1, [2.0, 2.0, 2.0, 1.0], [-1.0, -1.0, -1.0, 0.0]),
            ShaderNode::Output { input: ShadingInput::DiffuseColor, src: 2, swizzle: [0, 1, 2, 3] },
            ShaderNode::Output { input: ShadingInput::Roughness, src: 2, swizzle: [3; 4] },
            ShaderNode::Output { input: ShadingInput::Metallic, src: 2, swizzle: [1; 4] },
            ShaderNode::Output { input: ShadingInput::Normal, src: 3, swizzle: [0, 1, 2, 3] },
        ]);
    }
    scene
}

#[test]
fn wavefront_equals_scalar_with_production_material_networks() {
    let bytes = testscene::bytes(&pbr_scene());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let (scalar, _) = both_integrators(&view, &options(), "transform2d + 2 maps + normal map");
    // The normal map must bend the shading normals: the normal AOV differs from the plain scene's.
    let plain_bytes = testscene::bytes(&scene());
    let plain_view = blob::SceneView::parse(&plain_bytes).expect("valid blob");
    let plain = render_image(&plain_view, &RenderOptions { integrator: Integrator::Scalar, ..options() })
        .expect("renders");
    // Only the spheres carry uvs (tangents): the cards' normals stay (0, 0, 1).
    let on_spheres = |k: usize| plain.normal[k][2] < 0.99;
    let spheres = (0..plain.normal.len()).filter(|&k| on_spheres(k)).count();
    let bent =
        (0..plain.normal.len()).filter(|&k| on_spheres(k) && scalar.normal[k] != plain.normal[k]).count();
    assert!(spheres > 150 && bent * 3 > spheres * 2, "{bent} of {spheres} sphere pixels' normals bent");
}

/// [`scene`] with OpenPBR's layers on its materials: a tinted coat of index 1.6 on the plastic, a
/// half coat, a fuzz and an F82 edge tint on the metal, a specular weight and tint under the clear
/// coat, a coloured fuzz on the emitter card; lane groups mix layered and bare lanes.
#[test]
fn wavefront_equals_scalar_with_openpbr_coat_fuzz_and_f82_tint() {
    let mut scene = scene();
    let m = &mut scene.materials;
    (m[0].clearcoat, m[0].coat_color, m[0].coat_ior) = (0.8, Vec3::new(0.9, 0.6, 0.3), 1.6);
    (m[1].clearcoat, m[1].coat_color, m[1].specular_tint) = (0.5, Vec3::ONE, Vec3::new(0.9, 0.7, 0.4));
    (m[1].specular_weight, m[1].fuzz_weight, m[1].fuzz_roughness) = (0.9, 0.6, 0.4);
    (m[3].fuzz_weight, m[3].fuzz_color) = (1.0, Vec3::new(0.8, 0.2, 0.6));
    (m[2].specular_weight, m[2].specular_tint, m[2].coat_color) =
        (0.5, Vec3::new(1.0, 0.5, 0.5), Vec3::splat(0.7));
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let (scalar, _) = both_integrators(&view, &options(), "OpenPBR coat colour, coat ior, fuzz, F82 tint");
    let plain_bytes = testscene::bytes(&self::scene());
    let plain_view = blob::SceneView::parse(&plain_bytes).expect("valid blob");
    let plain = render_image(&plain_view, &RenderOptions { integrator: Integrator::Scalar, ..options() })
        .expect("renders");
    let changed = scalar.beauty.iter().zip(&plain.beauty).filter(|(a, b)| a != b).count();
    assert!(changed * 4 > plain.beauty.len(), "the layers change the spheres: {changed} pixels");
}

/// Material indices [`curve_scene`] adds after [`scene`]'s four.
const TRANSLUCENT: u32 = 4;
const GLOWING: u32 = 5;

/// A cubic Bézier fibre from `root` along `dir`, bent sideways by `bend`, radius `r0` → `r1`.
fn fibre(root: Vec3, dir: Vec3, bend: Vec3, r0: f32, r1: f32) -> BezierSegment {
    let p = [
        root.extend(r0),
        (root + dir / 3.0).extend(r0 + (r1 - r0) / 3.0),
        (root + dir * (2.0 / 3.0) + bend * 0.5).extend(r0 + (r1 - r0) * (2.0 / 3.0)),
        (root + dir + bend).extend(r1),
    ];
    BezierSegment { p, u: [0.0, 1.0], ..BezierSegment::default() }
}

/// [`scene`] with curves and points in front of and between its spheres: a hair-coloured groom of
/// tubes (per-vertex colours: the hair BSDF's absorption), ribbons with authored normals under the
/// textured UsdPreviewSurface material, translucent fibres (opacity 0.5: stochastic pass-through,
/// also of shadow rays' occluders), coloured points and glowing points (emission found by BSDF
/// sampling).
pub(crate) fn curve_scene() -> Scene {
    let mut scene = scene();
    scene.materials.push(Material { opacity: 0.5, ..testscene::lambert(0.7) });
    scene.materials.push(Material { emissive_color: Vec3::new(2.0, 1.0, 0.5), ..testscene::lambert(0.3) });
    let mut rng = testscene::Rng(17);
    let mut groom =
        Curves { path: "/Groom".into(), kind: CurveKind::Tube, has_colors: true, ..Curves::default() };
    for k in 0..80 {
        let root = Vec3::new(rng.range(-1.6, 1.6), rng.range(-0.9, -0.3), rng.range(-0.2, 0.6));
        let bend = Vec3::new(rng.range(-0.3, 0.3), 0.0, rng.range(-0.2, 0.2));
        let mut seg = fibre(root, Vec3::new(0.0, rng.range(0.6, 1.2), 0.0), bend, 0.012, 0.004);
        let tint = k as f32 / 80.0;
        seg.color = [Vec3::new(0.3 + 0.5 * tint, 0.2, 0.1), Vec3::new(0.9, 0.7 - 0.4 * tint, 0.4)];
        groom.segments.push(seg);
    }
    groom.curve_count = groom.segments.len();
    let mut ribbons =
        Curves { path: "/Ribbons".into(), kind: CurveKind::Ribbon, has_normals: true, ..Curves::default() };
    for k in 0..12 {
        let x = -1.5 + 0.27 * k as f32;
        let mut seg =
            fibre(Vec3::new(x, 0.6, 0.4), Vec3::new(0.1, -0.9, 0.2), Vec3::new(0.15, 0.0, 0.0), 0.05, 0.03);
        seg.normal = [Vec3::new(0.3, 0.0, 1.0).normalize(), Vec3::new(-0.4, 0.2, 1.0).normalize()];
        ribbons.segments.push(seg);
    }
    ribbons.curve_count = ribbons.segments.len();
    let mut translucent = Curves { path: "/Veil".into(), material: TRANSLUCENT, ..Curves::default() };
    for k in 0..20 {
        let y = -0.8 + 0.09 * k as f32;
        translucent.segments.push(fibre(
            Vec3::new(-1.8, y, 0.9),
            Vec3::new(3.6, 0.1, -0.2),
            Vec3::new(0.0, 0.05, 0.1),
            0.02,
            0.02,
        ));
    }
    translucent.curve_count = translucent.segments.len();
    let points = |path: &str, material: u32, has_colors: bool, rng: &mut testscene::Rng| {
        let spheres: Vec<PointSphere> = (0..30)
            .map(|_| PointSphere {
                center: Vec3::new(rng.range(-1.8, 1.8), rng.range(-0.9, 1.2), rng.range(-0.4, 0.8)),
                radius: rng.range(0.03, 0.12),
                color: Vec3::new(rng.range(0.1, 0.9), rng.range(0.1, 0.9), rng.range(0.1, 0.9)),
            })
            .collect();
        Curves {
            path: path.into(),
            kind: CurveKind::Points,
            curve_count: spheres.len(),
            spheres,
            material,
            has_colors,
            ..Curves::default()
        }
    };
    let coloured = points("/Points", 0, true, &mut rng);
    let glowing = points("/Glow", GLOWING, false, &mut rng);
    scene.curves = vec![groom, ribbons, translucent, coloured, glowing];
    scene
}

#[test]
fn wavefront_equals_scalar_with_curves_and_points() {
    let with_curves = curve_scene();
    let bytes = testscene::bytes(&with_curves);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    assert!(view.curves.segments.len() >= 112 && view.curves.spheres.len() == 60);
    let options = options();
    let (scalar, wave) = both_integrators(&view, &options, "curves, points, textures + 12 area lights");
    // The wavefront really ran (no scalar fallback for scenes with curves): its stages took time
    // and its lanes ran; the scalar render has neither.
    let stages = wave.stats.stages;
    assert!(stages.intersect > 0.0 && stages.shade > 0.0 && stages.occlusion > 0.0, "{stages:?}");
    assert!(wave.stats.counters.bsdf_lane_groups > 0);
    assert_eq!(scalar.stats.stages, crate::stats::StageSeconds::default());
    assert_eq!(scalar.stats.counters, crate::stats::Counters::default());

    // The curves and points are in the picture: without them, many pixels change.
    let plain = testscene::bytes(&scene());
    let plain = blob::SceneView::parse(&plain).expect("valid blob");
    let without =
        render_image(&plain, &RenderOptions { integrator: Integrator::Wavefront, ..options }).unwrap();
    let changed = wave.beauty.iter().zip(&without.beauty).filter(|(a, b)| a != b).count();
    let changed_first_hits = wave.depth.iter().zip(&without.depth).filter(|(a, b)| a != b).count();
    eprintln!("curves change {changed} pixels, {changed_first_hits} first-hit depths of {}", 48 * 48);
    assert!(changed_first_hits > 48 * 48 / 10, "{changed_first_hits} pixels see a curve or point first");
}

/// `scene` with light and shadow linking on its gprims (the card, three spheres, the emissive
/// lamp), every set different: lights left out of lighting (the dome, the sun, area lights, so
/// that both NEE and the emission BSDF-sampled rays find are dropped) and out of shadowing (the
/// spheres' shadows from some lights), with glass on one sphere so the per-hit glass vertex and
/// the closest-hit shadow walk see linking too.
pub(crate) fn linked(mut scene: Scene, glass: bool) -> Scene {
    let n = scene.lights.len();
    let set = |lit: &dyn Fn(usize) -> bool, shadows: &dyn Fn(usize) -> bool| LightSet {
        lit_by: (0..n).map(lit).collect(),
        shadows: (0..n).map(shadows).collect(),
    };
    scene.light_sets = vec![
        LightSet::everything(n),
        set(&|l| l != 0, &|l| l % 3 != 1),
        set(&|l| l != 1 && l % 4 != 2, &|_| true),
        set(&|l| l % 2 == 0, &|l| l == 1 || l > 6),
        set(&|l| l < 5, &|l| l % 2 == 1),
    ];
    for (m, mesh) in scene.meshes.iter_mut().enumerate() {
        mesh.light_set = ((m + 1) % 5) as u32;
    }
    if glass {
        let mut rough = textured(0.0, 0.0);
        (rough.ior, rough.opacity) = (1.33, 0.4);
        rough.program.push(ShaderNode::Output { input: ShadingInput::Opacity, src: 1, swizzle: [2; 4] });
        scene.materials[2] = rough;
    }
    scene
}

#[test]
fn wavefront_equals_scalar_with_light_and_shadow_linking() {
    let options = RenderOptions { max_depth: 8, ..options() };
    let plain = testscene::bytes(&scene());
    let plain = blob::SceneView::parse(&plain).expect("valid blob");
    let unlinked = render_image(&plain, &RenderOptions { integrator: Integrator::Scalar, ..options.clone() })
        .expect("renders");
    for (what, scene) in [
        ("light + shadow linking", linked(scene(), false)),
        ("linking through glass", linked(scene(), true)),
        ("linking with curves and points", linked(curve_scene(), false)),
    ] {
        let bytes = testscene::bytes(&scene);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        assert_eq!(view.light_set_count(), 5);
        let (scalar, _) = both_integrators(&view, &options, what);
        let changed = scalar.beauty.iter().zip(&unlinked.beauty).filter(|(a, b)| a != b).count();
        assert!(changed > 48 * 48 / 2, "{what}: linking changes most pixels ({changed})");
    }
}

/// Light sets that link every light to everything take the linked code paths (the wavefront's
/// per-ray emission, the light choice per lane, the shadow rays' light) and must give the unlinked
/// image byte for byte, in both integrators.
#[test]
fn light_sets_linking_everything_give_the_unlinked_image() {
    let options = options();
    let plain = testscene::bytes(&curve_scene());
    let plain = blob::SceneView::parse(&plain).expect("valid blob");
    let (unlinked, _) = both_integrators(&plain, &options, "curves, unlinked");
    let mut everything = curve_scene();
    let n = everything.lights.len();
    everything.light_sets = vec![LightSet::everything(n), LightSet::everything(n)];
    everything.meshes.iter_mut().step_by(2).for_each(|m| m.light_set = 1);
    let bytes = testscene::bytes(&everything);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    assert_eq!(view.light_set_count(), 2);
    let (scalar, _) = both_integrators(&view, &options, "curves, every light linked");
    assert_eq!(scalar.beauty, unlinked.beauty);
}

/// [`scene`] with glass: a smooth clear sphere, a rough half-opaque one of ior 1.33 whose opacity
/// comes from the texture (the shadow rays walk closest hits), and the metal one kept; the sun (a
/// delta light) and the area lights shine through them. Refraction, total internal reflection,
/// glass-aware shadow rays and the per-hit glass vertex of the wavefront give the scalar image.
#[test]
fn wavefront_equals_scalar_through_glass() {
    let mut scene = scene();
    scene.materials[0] = Material { opacity: 0.0, ior: 1.5, roughness: 0.0, ..Material::default() };
    let mut rough = textured(0.0, 0.0);
    (rough.ior, rough.opacity) = (1.33, 0.4);
    rough.program.push(ShaderNode::Output { input: ShadingInput::Opacity, src: 1, swizzle: [2; 4] });
    scene.materials[2] = rough;
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let options = RenderOptions { max_depth: 10, ..options() };
    let (scalar, _) = both_integrators(&view, &options, "glass");
    let mean = scalar.beauty.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / scalar.beauty.len() as f32;
    assert!(mean > 0.05, "mean luminance {mean}");
}

/// OpenPBR transmission in both integrators: a tinted thin-walled rough sphere and an absorbing
/// solid one (Beer–Lambert charged where paths leave it) give the scalar image.
#[test]
fn wavefront_equals_scalar_through_tinted_thin_and_absorbing_glass() {
    let mut scene = scene();
    scene.materials[0] = Material {
        opacity: 0.0,
        ior: 1.5,
        roughness: 0.3,
        thin_walled: true,
        transmission_color: Vec3::new(0.9, 0.5, 0.2),
        ..Material::default()
    };
    scene.materials[2] = Material {
        opacity: 0.0,
        ior: 1.4,
        roughness: 0.1,
        transmission_color: Vec3::new(0.3, 0.8, 0.6),
        transmission_depth: 0.5,
        ..Material::default()
    };
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let options = RenderOptions { max_depth: 10, ..options() };
    let (scalar, _) = both_integrators(&view, &options, "thin and absorbing glass");
    let mean = scalar.beauty.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / scalar.beauty.len() as f32;
    assert!(mean > 0.05, "mean luminance {mean}");
}

/// Every light kind the light-sampling lanes handle (dome, delta and cone distant lights, point,
/// sphere, rect and disk lights, emissive triangles of three powers, one of them with a textured
/// `emissiveColor` evaluated per light sample): the wavefront image equals the scalar one.
#[test]
fn wavefront_equals_scalar_with_every_light_kind() {
    let mut lit = crate::lights::lanes::every_light_kind();
    lit.textures = scene().textures;
    lit.materials[2].program = vec![
        ShaderNode::PrimvarUv { dst: 0, fallback: [0.0; 4] },
        ShaderNode::Texture {
            dst: 1,
            src: 0,
            texture: Some(0),
            wrap_s: texture::Wrap::Repeat,
            wrap_t: texture::Wrap::Repeat,
            scale: [2.0; 4],
            bias: [0.0; 4],
            fallback: [1.0; 4],
        },
        ShaderNode::Output { input: ShadingInput::EmissiveColor, src: 1, swizzle: [0, 1, 2, 3] },
    ];
    let bytes = testscene::bytes(&lit);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    assert_eq!(view.lights.len(), 7);
    assert_eq!(
        view.emissive_triangles.len(),
        6,
        "three emissive cards of two triangles: {:?}",
        view.emissive_triangles
    );
    let options = RenderOptions {
        spp: 16,
        resolution: Some([40, 40]),
        tile_size: 16,
        max_depth: 5,
        ..RenderOptions::default()
    };
    let (scalar, wave) = both_integrators(&view, &options, "every light kind");
    assert!(wave.stats.counters.light_lanes_active > 0);
    let mean = scalar.beauty.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / scalar.beauty.len() as f32;
    assert!(mean > 0.05, "mean luminance {mean}");
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
            assert_eq!(c, crate::stats::Counters::default());
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
        let max = max_abs_diff(&scalar.beauty, &wave.beauty);
        eprintln!("{texture_filter:?}: wavefront vs scalar: max abs diff {max:e}");
        assert_eq!(max, 0.0, "{texture_filter:?}");
        assert_eq!(scalar.beauty, wave.beauty, "{texture_filter:?}");
        assert_eq!(scalar.albedo, wave.albedo, "{texture_filter:?}");
        crate::dispatch_tests::record_image(&format!("texture filter {texture_filter:?}"), &scalar);
        images.push(scalar.beauty);
    }
    // The filters differ, so each comparison exercised its own lookups.
    assert!(images.windows(2).all(|w| w[0] != w[1]));
}

/// A whole image rendered by the wavefront outside `frame` (so tests can choose which tiles share a
/// worker).
struct DriverImage {
    beauty: Vec<[f32; 4]>,
    albedo: Vec<[f32; 3]>,
    normal: Vec<[f32; 3]>,
    depth: Vec<f32>,
    rays: crate::path::RayCounts,
    shader_evaluations: u64,
}

/// Renders `view` on `threads` threads, worker `k` taking every `threads`-th tile
/// from the `k`-th (so the thread count changes which tiles share a worker's queues); asserts that
/// no worker's queues or pools grew.
/// Pixels of `tile`.
fn npix(tile: &crate::film::Tile) -> usize {
    ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize
}

fn render_with_workers(view: &blob::SceneView, options: &RenderOptions, threads: usize) -> DriverImage {
    let scene = crate::scene::Scene::new(*view);
    let camera_index = scene.camera_index(None).unwrap();
    let [width, height] = scene.resolution(options.resolution, camera_index);
    let camera = scene.camera(camera_index, width, height);
    let ctx = super::Context {
        scene: &scene,
        camera: &camera,
        sampling: &crate::film::Sampling::new(options, width, height, camera.forward()),
        settings: crate::path::PathSettings {
            max_depth: options.max_depth,
            filter: options.texture_filter,
            ..Default::default()
        },
        touch: &texture::NoTouch,
        textured: scene.shading.textures().texel_bytes() > 0,
        aov: None,
    };
    let tiles = crate::film::tiles(crate::film::PixelWindow::full(width, height), options.tile_size);
    let n = (width * height) as usize;
    let mut image = DriverImage {
        beauty: vec![[0.0; 4]; n],
        albedo: vec![[0.0; 3]; n],
        normal: vec![[0.0; 3]; n],
        depth: vec![0.0; n],
        rays: Default::default(),
        shader_evaluations: 0,
    };
    let results: Vec<_> = std::thread::scope(|s| {
        let jobs: Vec<_> = (0..threads)
            .map(|k| {
                let (ctx, tiles) = (&ctx, &tiles);
                s.spawn(move || {
                    let mut w = super::Worker::new(options.tile_size, ctx.scene, false);
                    let storage = w.storage();
                    let done: Vec<_> = tiles
                        .iter()
                        .enumerate()
                        .skip(k)
                        .step_by(threads)
                        .map(|(t, tile)| {
                            let fresh = vec![crate::film::PixelSum::default(); npix(tile)];
                            let r = super::render(
                                ctx,
                                &mut w,
                                crate::film::TileJob {
                                    tile,
                                    sums: &fresh,
                                    plan: &Default::default(),
                                    aov: &[],
                                },
                            );
                            assert!(w.queues.occlusion.is_empty(), "a tile left shadow rays queued");
                            (t, r)
                        })
                        .collect();
                    assert_eq!(w.storage(), storage, "rendering grew a queue or pool");
                    (done, w.stats.clock.shader_evaluations)
                })
            })
            .collect();
        jobs.into_iter().map(|j| j.join().unwrap()).collect()
    });
    for (done, evaluations) in results {
        image.shader_evaluations += evaluations;
        for (t, r) in done {
            let tile = &tiles[t];
            image.rays.camera += r.rays.camera;
            image.rays.bounce += r.rays.bounce;
            image.rays.shadow += r.rays.shadow;
            let mut k = 0;
            for y in tile.y0..tile.y1 {
                for x in tile.x0..tile.x1 {
                    let p = (y * width + x) as usize;
                    let (beauty, albedo, normal, depth) = r.sums[k].resolve(options.spp);
                    (image.beauty[p], image.albedo[p], image.normal[p], image.depth[p]) =
                        (beauty, albedo, normal, depth);
                    k += 1;
                }
            }
        }
    }
    image
}

/// Workers that render a changing set of tiles give the scalar integrator's image bit for bit (beauty
/// and every AOV, ray and shader counts) on 1 and 3 threads, and never grow a pool or queue.
fn workers_equal_scalar(view: &blob::SceneView, options: &RenderOptions, what: &str) {
    let scalar =
        render_image(view, &RenderOptions { integrator: Integrator::Scalar, ..options.clone() }).unwrap();
    for threads in [1, 3] {
        let q = render_with_workers(view, options, threads);
        let max = max_abs_diff(&scalar.beauty, &q.beauty);
        assert_eq!(max, 0.0, "{what}, {threads} threads");
        assert_eq!(scalar.beauty, q.beauty, "{what}, {threads} threads");
        assert_eq!(scalar.albedo, q.albedo);
        assert_eq!(scalar.normal, q.normal);
        assert_eq!(scalar.depth, q.depth);
        assert_eq!(scalar.stats.rays, q.rays, "{what}");
        assert_eq!(scalar.stats.shader_evaluations, q.shader_evaluations, "{what}");
    }
}

#[test]
fn workers_equal_scalar_with_textures_and_many_area_lights() {
    let bytes = testscene::bytes(&scene());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    workers_equal_scalar(&view, &options(), "textures + 12 area lights");
}

#[test]
fn workers_equal_scalar_with_curves_and_points() {
    let bytes = testscene::bytes(&curve_scene());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    // Odd tile sizes and sample counts: partial tiles, chunks that split a pixel's samples unevenly.
    let options = RenderOptions { spp: 7, resolution: Some([45, 37]), tile_size: 13, ..options() };
    workers_equal_scalar(&view, &options, "curves, points, textures + 12 area lights");
}

#[test]
fn workers_equal_scalar_with_every_light_kind() {
    let mut lit = crate::lights::lanes::every_light_kind();
    lit.textures = scene().textures;
    let bytes = testscene::bytes(&lit);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let options = RenderOptions {
        spp: 16,
        resolution: Some([40, 40]),
        tile_size: 16,
        max_depth: 5,
        ..RenderOptions::default()
    };
    workers_equal_scalar(&view, &options, "every light kind");
}

//! End-to-end analytic tests of the integrator: scenes built in code, rendered at small resolutions,
//! compared against closed-form readings.

use crate::testscene::{self, assert_close, camera_looking_down_z, card, dome, lambert, mean_where, sphere};
use crate::{render_image, Image, RenderOptions};
use glam::{Mat4, Vec3};
use scene_pack::{Light, LightKind, Scene};
use std::f32::consts::PI;

fn render(scene: &Scene, options: &RenderOptions) -> Image {
    let bytes = testscene::bytes(scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    render_image(&view, options).unwrap()
}

fn options(res: u32, spp: u32) -> RenderOptions {
    RenderOptions { spp, resolution: Some([res, res]), threads: 2, ..RenderOptions::default() }
}

/// A grey (albedo 0.5) sphere of radius 1 at the origin seen from z = 4 with a 2×-wide field of view.
fn sphere_under_dome(albedo: f32) -> Scene {
    Scene {
        meshes: vec![sphere(Vec3::ZERO, 1.0, 48, 96, 0, false)],
        materials: vec![lambert(albedo)],
        lights: vec![dome(1.0)],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 4.0), 20.0)],
        default_camera: Some(0),
        ..Scene::default()
    }
}

// The sphere's silhouette is at tan = 1/√15 ≈ 0.258 of the 0.5 half-width: |f| < 0.4 is sphere,
// |f| > 0.62 dome.
fn on_sphere(fx: f32, fy: f32) -> bool {
    fx * fx + fy * fy < 0.4 * 0.4
}
fn on_dome(fx: f32, fy: f32) -> bool {
    fx * fx + fy * fy > 0.65 * 0.65
}

#[test]
fn lambert_sphere_under_uniform_dome_reads_its_albedo() {
    let image = render(&sphere_under_dome(0.5), &options(32, 256));
    let (sphere_mean, n) = mean_where(&image, on_sphere);
    assert!(n > 100);
    assert_close("sphere under dome", sphere_mean, 0.5, 0.02);
    let (dome_mean, _) = mean_where(&image, on_dome);
    assert_close("dome pixels", dome_mean, 1.0, 1e-5);
    // Every sphere pixel individually, too (noise at 256 spp is well under 10%).
    for y in 0..32 {
        for x in 0..32 {
            let fx = (x as f32 + 0.5) / 16.0 - 1.0;
            let fy = 1.0 - (y as f32 + 0.5) / 16.0;
            if on_sphere(fx, fy) {
                let v = image.rgb(x, y)[0];
                assert!((v - 0.5).abs() < 0.05, "pixel {x},{y}: {v}");
            }
        }
    }
    // AOVs: albedo 0.5 on the sphere, the centre normal faces the camera, depth 3.
    let centre = (16 * 32 + 16) as usize;
    assert!((image.albedo[centre][0] - 0.5).abs() < 1e-6);
    assert!(image.normal[centre][2] > 0.99);
    assert!((image.depth[centre] - 3.0).abs() < 0.01, "depth {}", image.depth[centre]);
    assert!(image.depth[0].is_infinite() && image.beauty[0][3] == 0.0 && image.beauty[centre][3] == 1.0);
}

#[test]
fn white_sphere_under_white_dome_is_a_furnace() {
    let mut o = options(32, 256);
    o.max_depth = 64;
    let image = render(&sphere_under_dome(1.0), &o);
    let (mean, _) = mean_where(&image, on_sphere);
    assert_close("white furnace (sphere under dome)", mean, 1.0, 0.02);
}

#[test]
fn closed_emissive_sphere_seen_from_inside_converges_to_le_over_one_minus_albedo() {
    // Inside a closed sphere of albedo a and emission Le every point reads Le / (1 − a): this exercises
    // every bounce, Russian roulette, emissive-triangle NEE and its MIS with BSDF hits.
    let mut material = lambert(0.5);
    material.emissive_color = Vec3::splat(0.5);
    let scene = Scene {
        meshes: vec![sphere(Vec3::ZERO, 1.0, 24, 48, 0, true)],
        materials: vec![material],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 0.2), 20.0)],
        default_camera: Some(0),
        ..Scene::default()
    };
    let mut o = options(16, 256);
    o.max_depth = 64;
    let image = render(&scene, &o);
    let (mean, _) = mean_where(&image, |_, _| true);
    assert_close("closed furnace Le/(1-a)", mean, 1.0, 0.02);
}

fn card_scene(light: Light, camera_height: f32, focal: f32) -> Scene {
    Scene {
        meshes: vec![card(0.0, 3.0, 0)],
        materials: vec![lambert(0.5)],
        lights: vec![light],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, camera_height), focal)],
        default_camera: Some(0),
        ..Scene::default()
    }
}

fn distant(intensity: f32, angle_degrees: f32, normalize: bool) -> Light {
    Light {
        path: "/sun".into(),
        kind: LightKind::Distant { angle_degrees },
        radiance: Vec3::splat(intensity),
        normalize,
        world_from_light: Mat4::IDENTITY,
    }
}

#[test]
fn lambert_card_under_normalized_distant_light_reads_albedo_e_over_pi() {
    let expected = 0.5 * 3.0 / PI; // 0.477
    let image = render(&card_scene(distant(3.0, 0.53, true), 3.0, 50.0), &options(16, 256));
    assert_close("card under normalized distant (0.53°)", mean_where(&image, |_, _| true).0, expected, 0.02);
    // A delta sun (angle 0, not normalized) of intensity 3 gives the same reading.
    let image = render(&card_scene(distant(3.0, 0.0, false), 3.0, 50.0), &options(16, 64));
    assert_close("card under delta distant", mean_where(&image, |_, _| true).0, expected, 1e-4);
    // A wide normalized sun (30°) tilted 0° still gives E = 3.
    let image = render(&card_scene(distant(3.0, 30.0, true), 3.0, 50.0), &options(16, 256));
    assert_close("card under normalized 30° distant", mean_where(&image, |_, _| true).0, expected, 0.02);
}

fn light_at(kind: LightKind, height: f32, radiance: f32) -> Light {
    Light {
        path: "/area".into(),
        kind,
        radiance: Vec3::splat(radiance),
        normalize: false,
        world_from_light: Mat4::from_translation(Vec3::new(0.0, 0.0, height)),
    }
}

#[test]
fn lambert_card_under_area_lights_matches_analytic_irradiance() {
    // A narrow camera (focal 1000 → ±0.01 at the card) sees the point right below each light.
    let h = 2.0;
    let reading = |light: Light| {
        let image = render(&card_scene(light, 1.0, 1000.0), &options(8, 256));
        mean_where(&image, |_, _| true).0
    };
    // Disk radius r facing the point: E = L π r² / (h² + r²).
    let r = 0.5f32;
    let e_disk = 10.0 * PI * r * r / (h * h + r * r);
    assert_close(
        "disk light",
        reading(light_at(LightKind::Disk { radius: r }, h, 10.0)),
        0.5 * e_disk / PI,
        0.02,
    );
    // Sphere radius r at distance h: E = L π (r/h)².
    let e_sphere = 10.0 * PI * (r / h).powi(2);
    assert_close(
        "sphere light",
        reading(light_at(LightKind::Sphere { radius: r, treat_as_point: false }, h, 10.0)),
        0.5 * e_sphere / PI,
        0.02,
    );
    // Rect w×h: numerical integral of cos·cos/d².
    let (w, hh) = (2.0f64, 1.0f64);
    let n = 400;
    let mut ff = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let x = -w / 2.0 + w * (i as f64 + 0.5) / n as f64;
            let y = -hh / 2.0 + hh * (j as f64 + 0.5) / n as f64;
            let d2 = x * x + y * y + (h as f64).powi(2);
            ff += (h as f64).powi(2) / (d2 * d2) * (w / n as f64) * (hh / n as f64);
        }
    }
    let e_rect = 10.0 * ff as f32;
    assert_close(
        "rect light",
        reading(light_at(LightKind::Rect { width: 2.0, height: 1.0 }, h, 10.0)),
        0.5 * e_rect / PI,
        0.02,
    );
    // Normalized rect: radiance divided by its area (2).
    let mut normalized = light_at(LightKind::Rect { width: 2.0, height: 1.0 }, h, 10.0);
    normalized.normalize = true;
    assert_close("normalized rect light", reading(normalized), 0.5 * e_rect / 2.0 / PI, 0.02);
}

#[test]
fn emissive_quad_lights_a_card() {
    // An emissive 0.2×0.2 card (emission 50, facing down) 2 units above: E ≈ L·A·cos²/d² at the centre.
    let mut emitter = card(2.0, 0.1, 1);
    emitter.triangles = vec![[0, 2, 1], [0, 3, 2]]; // facing −Z
    let mut m = lambert(0.0);
    m.emissive_color = Vec3::splat(50.0);
    let scene = Scene {
        meshes: vec![card(0.0, 3.0, 0), emitter],
        materials: vec![lambert(0.5), m],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 1.0), 1000.0)],
        default_camera: Some(0),
        ..Scene::default()
    };
    let image = render(&scene, &options(8, 256));
    // Exact: the disk-like integral over the square, numerically.
    let n = 200;
    let mut e = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let x = -0.1 + 0.2 * (i as f64 + 0.5) / n as f64;
            let y = -0.1 + 0.2 * (j as f64 + 0.5) / n as f64;
            let d2 = x * x + y * y + 4.0;
            e += 4.0 / (d2 * d2) * (0.2 / n as f64).powi(2);
        }
    }
    let expected = 0.5 * 50.0 * e as f32 / PI;
    assert_close("emissive quad", mean_where(&image, |_, _| true).0, expected, 0.02);
}

#[test]
fn one_and_two_threads_give_bit_identical_images() {
    let mut scene = sphere_under_dome(0.5);
    scene.materials[0].roughness = 0.3;
    scene.materials[0].ior = 1.5;
    scene.lights.push(distant(2.0, 5.0, true));
    let mut o = options(24, 8);
    o.threads = 1;
    let one = render(&scene, &o);
    o.threads = 2;
    let two = render(&scene, &o);
    o.tile_size = 7;
    let odd_tiles = render(&scene, &o);
    let bits = |i: &Image| i.beauty.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<u32>>();
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(bits(&one), bits(&odd_tiles));
    o.seed = 1;
    assert_ne!(bits(&one), bits(&render(&scene, &o)), "the seed changes the noise");
}

#[test]
fn stochastic_opacity_lets_the_dome_through() {
    // A card of opacity 0.25 (albedo 0) in front of a white dome: reads 1 − 0.25 = 0.75.
    let mut m = lambert(0.0);
    m.opacity = 0.25;
    let scene = Scene {
        meshes: vec![card(0.0, 3.0, 0)],
        materials: vec![m],
        lights: vec![dome(1.0)],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 50.0)],
        default_camera: Some(0),
        ..Scene::default()
    };
    let image = render(&scene, &options(16, 256));
    assert_close("opacity 0.25 card", mean_where(&image, |_, _| true).0, 0.75, 0.02);
}

#[test]
fn no_camera_frames_the_bounds_and_bad_camera_paths_are_errors() {
    let mut scene = sphere_under_dome(0.5);
    scene.cameras.clear();
    scene.default_camera = None;
    let image = render(&scene, &options(16, 4));
    // The framing camera looks at the sphere: the centre pixel hits it.
    assert_eq!(image.beauty[(8 * 16 + 8) as usize][3], 1.0);
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let o = RenderOptions { camera: Some("/nope".into()), ..options(4, 1) };
    assert!(matches!(render_image(&view, &o), Err(crate::RenderError::UnknownCamera { .. })));
}

/// Clear glass (UsdPreviewSurface opacity 0, ior 1.5, roughness 0).
fn glass(roughness: f32) -> scene_pack::Material {
    scene_pack::Material { opacity: 0.0, ior: 1.5, roughness, ..lambert(0.0) }
}

#[test]
fn glass_is_entered_from_the_front_of_the_winding() {
    let scene = Scene { materials: vec![glass(0.0)], ..sphere_under_dome(1.0) };
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let s = crate::scene::Scene::new(view);
    let inputs = crate::shading::ShadingInputs::constant(&view.materials[0]);
    for (origin, dir, entering) in
        [(Vec3::new(0.1, 0.2, 4.0), -Vec3::Z, true), (Vec3::new(0.1, 0.2, 0.0), Vec3::Z, false)]
    {
        let hit = s.accel.closest_hit(origin, dir, f32::INFINITY).expect("the ray meets the sphere");
        let surface = s.surface(&hit, -dir, 0.0).unwrap();
        let crate::surface::SurfaceBsdf::Glass(g) = s.glass_bsdf(&hit, &surface, &inputs) else {
            unreachable!()
        };
        let eta = if entering { 1.5 } else { 1.0 / 1.5 };
        assert_eq!(g.eta(), eta, "entering = {entering}");
    }
}

/// A non-absorbing dielectric sphere in a uniform dome reads the dome's radiance: every path
/// leaves it again, and the 1/η² of entering and leaving cancel. Rough spheres too, by the
/// interface's multiple-scattering compensation (uncompensated, roughness 0.3 read about 0.96).
#[test]
fn glass_sphere_under_uniform_dome_is_a_furnace() {
    let mut o = options(32, 1024);
    o.max_depth = 64;
    for (roughness, tolerance) in [(0.0, 0.01), (0.2, 0.01), (0.5, 0.01), (0.9, 0.01)] {
        let scene = Scene { materials: vec![glass(roughness)], ..sphere_under_dome(1.0) };
        let image = render(&scene, &o);
        let (mean, _) = mean_where(&image, on_sphere);
        assert_close(&format!("glass furnace, roughness {roughness}"), mean, 1.0, tolerance);
        // The albedo AOV of clear glass is white.
        assert_eq!(image.albedo[16 * 32 + 16], [1.0; 3]);
    }
}

/// A smooth glass slab (ior 1.5) in front of an emitter of radiance 1, seen head-on: two
/// interfaces with every internal reflection transmit (1 − R)² Σ R²ᵏ = (1 − R)/(1 + R), R = 0.04.
#[test]
fn glass_slab_transmits_the_fresnel_series() {
    let mut bottom = card(-0.3, 4.0, 0);
    bottom.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    bottom.normals.iter_mut().for_each(|n| *n = -*n);
    let emitter = scene_pack::Material { emissive_color: Vec3::ONE, ..lambert(0.0) };
    let scene = Scene {
        meshes: vec![card(0.0, 4.0, 0), bottom, card(-1.0, 6.0, 1)],
        materials: vec![glass(0.0), emitter],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 200.0)],
        default_camera: Some(0),
        ..Scene::default()
    };
    let mut o = options(16, 64);
    o.max_depth = 32;
    let image = render(&scene, &o);
    let r = 0.04f32;
    assert_close("glass slab transmittance", mean_where(&image, |_, _| true).0, (1.0 - r) / (1.0 + r), 0.005);
}

/// A smooth slab of `material` (cards at z = 0 and z = −0.3, the lower one facing down) in
/// front of an emitter of radiance 1, seen head-on: the mean pixel.
fn slab_in_front_of_an_emitter(material: scene_pack::Material, two_faces: bool) -> [f32; 3] {
    let mut bottom = card(-0.3, 4.0, 0);
    bottom.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    bottom.normals.iter_mut().for_each(|n| *n = -*n);
    let emitter = scene_pack::Material { emissive_color: Vec3::ONE, ..lambert(0.0) };
    let mut meshes = vec![card(0.0, 4.0, 0), card(-1.0, 6.0, 1)];
    if two_faces {
        meshes.push(bottom);
    }
    let scene = Scene {
        meshes,
        materials: vec![material, emitter],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 200.0)],
        default_camera: Some(0),
        ..Scene::default()
    };
    let mut o = options(16, 64);
    o.max_depth = 32;
    let image = render(&scene, &o);
    let n = image.beauty.len() as f32;
    let mut sum = [0.0f32; 3];
    for p in &image.beauty {
        (0..3).for_each(|c| sum[c] += p[c] / n);
    }
    sum
}

/// One thin-walled card (OpenPBR `geometry_thin_walled`, ior 1.5, colour c) in front of an
/// emitter, head-on: the slab's incoherent series, T = c (1 − F)² / (1 − c² F²) with F = 0.04
/// (c = 1: (1 − F)/(1 + F) = 0.923), straight through, with no second surface to cross.
#[test]
fn thin_walled_card_transmits_the_slab_series() {
    let f = 0.04f32;
    for c in [1.0f32, 0.5] {
        let thin = scene_pack::Material {
            thin_walled: true,
            transmission_color: Vec3::new(c, 1.0, 0.0),
            ..glass(0.0)
        };
        let got = slab_in_front_of_an_emitter(thin, false);
        let slab = |c: f32| c * (1.0 - f) * (1.0 - f) / (1.0 - c * c * f * f);
        eprintln!("thin wall, colour ({c}, 1, 0): {got:?}, expected ({}, {}, 0)", slab(c), slab(1.0));
        assert_close("thin wall, red", got[0], slab(c), 0.005);
        assert_close("thin wall, green", got[1], slab(1.0), 0.005);
        assert!(got[2].abs() < 1e-3, "a black wall reflects only: {}", got[2]);
    }
}

/// An absorbing glass slab (colour c at `transmission_depth` d, thickness 0.3) in front of an
/// emitter: Beer–Lambert a = c^(0.3/d) = exp(−σ·0.3), σ = −ln c / d, per pass through the slab,
/// with the two interfaces' Fresnel series, T = (1 − F)² a / (1 − F² a²).
#[test]
fn absorbing_glass_slab_keeps_beer_lambert_transmittance() {
    let f = 0.04f32;
    let (color, depth) = (Vec3::new(0.5, 0.9, 1.0), 0.3f32);
    let absorbing =
        scene_pack::Material { transmission_color: color, transmission_depth: depth, ..glass(0.0) };
    let got = slab_in_front_of_an_emitter(absorbing, true);
    for (c, got) in color.to_array().into_iter().zip(got) {
        let sigma = -c.ln() / depth;
        let a = (-sigma * 0.3).exp();
        let expected = (1.0 - f) * (1.0 - f) * a / (1.0 - f * f * a * a);
        eprintln!("absorbing slab, colour {c}: {got}, expected {expected}");
        assert_close("absorbing slab", got, expected, 0.005);
    }
}

/// OpenPBR `transmission_weight = 1` (opacity 0) with a white colour conserves energy in the
/// white furnace: solid glass with a white absorbing interior, and thin walls smooth and rough.
/// The rough walls read 1 by the multiple-scattering compensation (roughness 0.3 read 0.973
/// before it: GGX's single-scattering loss compounded over a path's bounces on the sphere).
#[test]
fn white_transmission_is_a_furnace() {
    let mut o = options(32, 1024);
    o.max_depth = 64;
    let white_interior = scene_pack::Material { transmission_depth: 0.7, ..glass(0.0) };
    let rough_interior = scene_pack::Material { transmission_depth: 0.7, ..glass(0.5) };
    let thin = |roughness: f32| scene_pack::Material { thin_walled: true, ..glass(roughness) };
    for (what, material) in [
        ("solid, white interior", white_interior),
        ("solid, white interior, roughness 0.5", rough_interior),
        ("thin wall, smooth", thin(0.0)),
        ("thin wall, roughness 0.2", thin(0.2)),
        ("thin wall, roughness 0.5", thin(0.5)),
        ("thin wall, roughness 0.9", thin(0.9)),
    ] {
        let scene = Scene { materials: vec![material], ..sphere_under_dome(1.0) };
        let (mean, _) = mean_where(&render(&scene, &o), on_sphere);
        eprintln!("transmission furnace, {what}: {mean:.4}");
        assert!((0.99..=1.01).contains(&mean), "{what}: {mean}");
    }
}

/// A glass ball is a lens of focal length nR / (2(n − 1)) = 1.5 R: a background beyond it shows
/// upside down and mirrored, so the ball's left half sees the right half of the background.
#[test]
fn glass_sphere_inverts_the_background() {
    let red = scene_pack::Material { emissive_color: Vec3::new(1.0, 0.0, 0.0), ..lambert(0.0) };
    let green = scene_pack::Material { emissive_color: Vec3::new(0.0, 1.0, 0.0), ..lambert(0.0) };
    let half = |x0: f32, x1: f32, material: u32| {
        let mut m = card(-6.0, 1.0, material);
        for (p, [x, y]) in m.positions.iter_mut().zip([[x0, -20.0], [x1, -20.0], [x1, 20.0], [x0, 20.0]]) {
            (p.x, p.y) = (x, y);
        }
        m
    };
    let scene = Scene {
        meshes: vec![sphere(Vec3::ZERO, 1.0, 48, 96, 0, false), half(-20.0, 0.0, 1), half(0.0, 20.0, 2)],
        materials: vec![glass(0.0), red, green],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 4.0), 20.0)],
        default_camera: Some(0),
        ..Scene::default()
    };
    let mut o = options(32, 16);
    o.max_depth = 16;
    let image = render(&scene, &o);
    let channel = |c: usize, left: bool| {
        let (mut sum, mut n) = (0.0f32, 0);
        for y in 0..32 {
            for x in 0..32 {
                let fx = (x as f32 + 0.5) / 16.0 - 1.0;
                let fy = 1.0 - (y as f32 + 0.5) / 16.0;
                if on_sphere(fx, fy) && fx.abs() > 0.05 && (fx < 0.0) == left {
                    sum += image.rgb(x, y)[c];
                    n += 1;
                }
            }
        }
        sum / n as f32
    };
    let (left_red, left_green) = (channel(0, true), channel(1, true));
    let (right_red, right_green) = (channel(0, false), channel(1, false));
    eprintln!(
        "through the ball: left r {left_red:.3} g {left_green:.3}, right r {right_red:.3} g {right_green:.3}"
    );
    // Outside the ball the camera sees red on the left, green on the right; through it, the reverse.
    assert!(left_green > 4.0 * left_red && right_red > 4.0 * right_green);
    let (outside, _) = mean_where(&image, |fx, fy| fx < -0.7 && fy.abs() < 0.2);
    assert!(outside > 0.3, "the left edge sees the red half directly: {outside}");
}

/// Shadows under clear glass: a delta (distant) light reaches a card under a glass pane with the
/// pane's two normal-incidence transmittances, 0.96², not black.
#[test]
fn distant_light_through_a_glass_pane_keeps_its_transmittance() {
    let mut pane_bottom = card(0.5, 5.0, 1);
    pane_bottom.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    pane_bottom.normals.iter_mut().for_each(|n| *n = -*n);
    // A dark card, so that light the pane reflects back down adds under 1 %; the sun 30° off the
    // camera's axis, so that its glint on the smooth pane stays out of the frame.
    let sun = Light { world_from_light: Mat4::from_rotation_x(0.5), ..distant(1.0, 0.0, true) };
    let mut bare = card_scene(sun, 3.0, 50.0);
    bare.materials[0] = lambert(0.1);
    let mut scene = bare.clone();
    scene.meshes.push(card(0.6, 5.0, 1));
    scene.meshes.push(pane_bottom);
    scene.materials.push(glass(0.0));
    let o = options(16, 16);
    let (under, _) = mean_where(&render(&scene, &o), |_, _| true);
    let (open, _) = mean_where(&render(&bare, &o), |_, _| true);
    // The camera looks through the pane too (another 0.96² on the way up, by refraction).
    let expected = open * 0.96f32.powi(2) * (1.0 - 0.04) / (1.0 + 0.04);
    assert_close("card under a glass pane, distant light", under, expected, 0.02);
}

#[test]
fn scenes_without_any_light_are_recognised() {
    let dark = Scene { meshes: vec![card(0.0, 1.0, 0)], materials: vec![lambert(0.5)], ..Scene::default() };
    let has_light = |scene: &Scene| {
        crate::Scene::new(blob::SceneView::parse(&testscene::bytes(scene)).unwrap()).has_light()
    };
    assert!(!has_light(&dark));
    assert!(has_light(&Scene { lights: vec![dome(1.0)], ..dark.clone() }));
    let lamp = scene_pack::Material { emissive_color: Vec3::ONE, ..lambert(0.5) };
    assert!(has_light(&Scene { materials: vec![lamp], ..dark.clone() }), "an emissive surface lights it");
}

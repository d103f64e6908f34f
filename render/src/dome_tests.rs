//! Textured dome lights end to end: maps generated here, baked and packed as ingest does, checked
//! against quadratures of the same texels (a bilinear reconstruction written independently of
//! [`crate::lights::dome_map`]) and against the UsdLux orientation.

use crate::lights::dome_map::DomeMap;
use crate::lights::Lights;
use crate::testscene::{self, camera_looking_down_z, card, lambert, sphere, Rng};
use crate::{render_image, Image, Integrator, RenderOptions};
use glam::{Mat3, Mat4, Quat, Vec3};
use scene_pack::scene::{SceneTexture, TextureData};
use scene_pack::{Light, LightKind, Scene};
use std::f64::consts::PI;

/// A lat-long map, top row first, RGB.
struct Map {
    width: usize,
    height: usize,
    rgb: Vec<[f32; 3]>,
}

impl Map {
    fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> [f32; 3]) -> Self {
        let rgb = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Map { width, height, rgb }
    }

    fn texture(&self) -> SceneTexture {
        let samples = self.rgb.iter().flatten().copied().collect();
        let src = texture::SourceImage {
            width: self.width as u32,
            height: self.height as u32,
            channels: 3,
            samples: texture::Samples::F32(samples),
        };
        let baked = texture::bake(&src, &texture::BakeOptions::default()).expect("bakes");
        SceneTexture {
            path: "/generated/map.exr".into(),
            color_space: texture::ColorSpace::Auto,
            data: TextureData::Image(baked),
        }
    }

    /// The map's radiance along dome-frame direction `d` as the UsdLux spec places it: top row +Y,
    /// longitude +π at the left edge, 0 (+Z) at the centre, +π/2 (+X) a quarter in; bilinear between
    /// texel centres, wrapping in longitude, clamped at the poles.
    fn radiance(&self, d: [f64; 3]) -> [f64; 3] {
        let theta = d[1].clamp(-1.0, 1.0).acos();
        let phi = d[0].atan2(d[2]);
        let s = 0.5 - phi / (2.0 * PI);
        let v = theta / PI;
        let x = s * self.width as f64 - 0.5;
        let y = (v * self.height as f64 - 0.5).clamp(0.0, self.height as f64 - 1.0);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |xi: f64, yi: f64| {
            let xi = (xi as i64).rem_euclid(self.width as i64) as usize;
            let yi = (yi as usize).min(self.height - 1);
            self.rgb[yi * self.width + xi].map(|c| c as f64)
        };
        let mut out = [0.0; 3];
        for (dx, dy, w) in [
            (0.0, 0.0, (1.0 - fx) * (1.0 - fy)),
            (1.0, 0.0, fx * (1.0 - fy)),
            (0.0, 1.0, (1.0 - fx) * fy),
            (1.0, 1.0, fx * fy),
        ] {
            let t = texel(x0 + dx, y0 + dy);
            for c in 0..3 {
                out[c] += w * t[c];
            }
        }
        out
    }

    /// `∫ L(ω) max(0, ω·n) dω` over the sphere (midpoint rule in θ and φ), `n` in the dome frame.
    fn irradiance(&self, n: [f64; 3]) -> [f64; 3] {
        let (nt, np) = (1024, 2048);
        let mut e = [0.0; 3];
        for i in 0..nt {
            let theta = PI * (i as f64 + 0.5) / nt as f64;
            let (st, ct) = theta.sin_cos();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64 - PI;
                let d = [st * phi.sin(), ct, st * phi.cos()];
                let cos = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                if cos <= 0.0 {
                    continue;
                }
                let l = self.radiance(d);
                let w = cos * st * (PI / nt as f64) * (2.0 * PI / np as f64);
                for c in 0..3 {
                    e[c] += l[c] * w;
                }
            }
        }
        e
    }
}

fn dome_light(radiance: Vec3, world_from_light: Mat4) -> Light {
    Light {
        path: "/env".into(),
        kind: LightKind::TexturedDome { texture: 0 },
        radiance,
        normalize: false,
        world_from_light,
    }
}

fn scene_with(map: &Map, light: Light, meshes: Vec<scene_pack::Mesh>, albedo: f32) -> Scene {
    Scene {
        meshes,
        materials: vec![lambert(albedo)],
        lights: vec![light],
        textures: vec![map.texture()],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 4.0), 20.0)],
        default_camera: Some(0),
        ..Scene::default()
    }
}

fn render(scene: &Scene, options: &RenderOptions) -> Image {
    let bytes = testscene::bytes(scene);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    render_image(&view, options).expect("renders")
}

fn options(res: u32, spp: u32) -> RenderOptions {
    RenderOptions { spp, resolution: Some([res, res]), threads: 2, ..RenderOptions::default() }
}

/// Mean beauty RGB over the pixels `keep(fx, fy)` selects (`f` in [−1, 1]², y up).
fn mean_rgb(image: &Image, keep: impl Fn(f32, f32) -> bool) -> Vec3 {
    let (mut sum, mut n) = (Vec3::ZERO, 0);
    for y in 0..image.height {
        for x in 0..image.width {
            let fx = (x as f32 + 0.5) / image.width as f32 * 2.0 - 1.0;
            let fy = 1.0 - (y as f32 + 0.5) / image.height as f32 * 2.0;
            if keep(fx, fy) {
                sum += Vec3::from(image.rgb(x, y));
                n += 1;
            }
        }
    }
    sum / n as f32
}

/// A map with structure everywhere: a smooth gradient, a dark band, a bright patch, a black cap.
fn busy_map() -> Map {
    Map::from_fn(48, 24, |x, y| {
        let g = 0.2 + 0.8 * (x as f32 / 48.0);
        if y < 2 {
            [0.0; 3]
        } else if (5..8).contains(&y) && (33..39).contains(&x) {
            [40.0, 30.0, 10.0]
        } else if y == 15 {
            [0.01, 0.0, 0.02]
        } else {
            [g, 0.5 * g, 1.0 - 0.5 * g]
        }
    })
}

fn a_rotation() -> Mat4 {
    Mat4::from_quat(Quat::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 0.9))
}

#[test]
fn sampled_directions_carry_the_pdf_the_map_reports_and_the_pdf_integrates_to_one() {
    let map = busy_map();
    let rotation = a_rotation();
    let scene = scene_with(&map, dome_light(Vec3::ONE, rotation), vec![], 0.5);
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let dome = DomeMap::new(&view, 0, Mat3::from_mat4(rotation)).expect("a map");
    let mut rng = Rng(3);
    let (mut n, mut agree, mut worst) = (0, 0, 0.0f32);
    for _ in 0..200_000 {
        let Some(s) = dome.sample([rng.next_f32(), rng.next_f32()]) else { continue };
        n += 1;
        let rel = (dome.pdf(s.wi) / s.pdf - 1.0).abs();
        // A direction within rounding of a cell edge may land in the neighbouring cell.
        if rel < 1e-3 {
            agree += 1;
        } else {
            worst = worst.max(rel);
        }
    }
    eprintln!("{agree} of {n} sampled pdfs agree with pdf(dir) to 1e-3 (worst other {worst})");
    assert!(n > 199_000 && agree as f64 >= 0.9999 * n as f64, "{agree} of {n}");

    // ∫ pdf dω: a quadrature in the dome's world frame, and a Monte Carlo estimate.
    let (nt, np) = (1024, 2048);
    let mut quadrature = 0.0f64;
    for i in 0..nt {
        let theta = PI * (i as f64 + 0.5) / nt as f64;
        for j in 0..np {
            let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            let d = Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
            );
            quadrature += dome.pdf(d) as f64 * theta.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
        }
    }
    let mut mc = 0.0f64;
    let count = 400_000;
    for _ in 0..count {
        let z = 1.0 - 2.0 * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * rng.next_f32();
        mc += dome.pdf(Vec3::new(r * phi.cos(), r * phi.sin(), z)) as f64 * 4.0 * PI;
    }
    mc /= count as f64;
    eprintln!("∫ pdf dω: quadrature {quadrature:.5}, Monte Carlo {mc:.4}");
    assert!((quadrature - 1.0).abs() < 2e-3, "quadrature {quadrature}");
    assert!((mc - 1.0).abs() < 0.03, "Monte Carlo {mc}");

    // Through the light list: NEE's pdf (with selection) is what an escaping ray in that direction
    // reports, and the radiance is the map's there.
    let lights = Lights::new(&view);
    for _ in 0..1000 {
        let u = [rng.next_f32(), rng.next_f32()];
        let Some(s) = lights.sample(Vec3::ZERO, 0.5, u) else { continue };
        let escaped = lights.escaped_emission(s.wi, None);
        assert!(
            (escaped - s.li).abs().max_element() <= 1e-3 * s.li.max_element().max(1e-3),
            "{escaped} vs {}",
            s.li
        );
    }
}

#[test]
fn sampled_cells_follow_the_distribution() {
    // Chi-square of the cells NEE picks against luminance × solid angle (the bilinear weights of
    // ingest spread each texel over its neighbours, so compare against 6 × 3 blocks of 8 × 8 texels).
    let map = busy_map();
    let scene = scene_with(&map, dome_light(Vec3::ONE, Mat4::IDENTITY), vec![], 0.5);
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let dome = DomeMap::new(&view, 0, Mat3::IDENTITY).expect("a map");
    let (bx, by) = (6usize, 3usize);
    let mut counts = vec![0f64; bx * by];
    let mut rng = Rng(9);
    let n = 200_000;
    for _ in 0..n {
        let Some(s) = dome.sample([rng.next_f32(), rng.next_f32()]) else { continue };
        let d = s.wi.as_dvec3();
        let sx = 0.5 - d.x.atan2(d.z) / (2.0 * PI);
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        let (i, j) = (((sx * bx as f64) as usize).min(bx - 1), ((v * by as f64) as usize).min(by - 1));
        counts[j * bx + i] += 1.0;
    }
    // Expected: ∫ pdf over each block, by quadrature of the reported pdf (the test above shows it
    // integrates to 1 and matches the sampled one).
    let mut expected = vec![0f64; bx * by];
    let (nt, np) = (384, 768);
    for a in 0..nt {
        let v = (a as f64 + 0.5) / nt as f64;
        let theta = PI * v;
        for b in 0..np {
            let sx = (b as f64 + 0.5) / np as f64;
            let phi = PI * (1.0 - 2.0 * sx);
            let d = Vec3::new(
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
                (theta.sin() * phi.cos()) as f32,
            );
            let w = dome.pdf(d) as f64 * theta.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
            expected[((v * by as f64) as usize) * bx + (sx * bx as f64) as usize] += w * n as f64;
        }
    }
    let chi2: f64 =
        counts.iter().zip(&expected).filter(|(_, &e)| e > 5.0).map(|(&o, &e)| (o - e).powi(2) / e).sum();
    eprintln!("chi² over {} blocks: {chi2:.1}", bx * by);
    // 17 degrees of freedom: the 0.999 quantile is 40.8.
    assert!(chi2 < 40.8, "chi² {chi2}; counts {counts:?} expected {expected:?}");
    // And the blocks follow luminance: the one holding the bright patch gets the most samples.
    let brightest = counts.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map(|(i, _)| i);
    assert_eq!(brightest, Some(4), "block (4, 0) holds the 40× patch: {counts:?}");
}

#[test]
fn constant_map_renders_as_the_uniform_dome_of_that_colour() {
    // Texture 0.5 × radiance 2 = the uniform dome of radiance 1: a Lambertian sphere of albedo 0.5
    // reads 0.5 (furnace), the background reads exactly 1, and both match the untextured render.
    let map = Map::from_fn(16, 8, |_, _| [0.5; 3]);
    let ball = || vec![sphere(Vec3::ZERO, 1.0, 48, 96, 0, false)];
    let textured = scene_with(&map, dome_light(Vec3::splat(2.0), a_rotation()), ball(), 0.5);
    let uniform = Scene {
        lights: vec![testscene::dome(1.0)],
        textures: vec![],
        ..scene_with(&map, dome_light(Vec3::ONE, Mat4::IDENTITY), ball(), 0.5)
    };
    let on_sphere = |fx: f32, fy: f32| fx * fx + fy * fy < 0.4 * 0.4;
    let on_dome = |fx: f32, fy: f32| fx * fx + fy * fy > 0.65 * 0.65;
    let a = render(&textured, &options(32, 256));
    let b = render(&uniform, &options(32, 256));
    let (sa, sb) = (mean_rgb(&a, on_sphere), mean_rgb(&b, on_sphere));
    eprintln!("sphere: textured {sa}, uniform {sb}; background {}", mean_rgb(&a, on_dome));
    assert!((sa - Vec3::splat(0.5)).abs().max_element() < 0.01, "textured furnace {sa}");
    assert!((sa - sb).abs().max_element() < 0.01, "textured {sa} vs uniform {sb}");
    assert!((mean_rgb(&a, on_dome) - Vec3::ONE).abs().max_element() < 1e-5);
}

/// A card facing `normal` (world) at the origin, seen head-on by a narrow camera, under the map.
fn card_reading(map: &Map, world_from_light: Mat4, normal: Vec3, spp: u32) -> Vec3 {
    let albedo = 0.5;
    let to_world = Mat4::from_quat(Quat::from_rotation_arc(Vec3::Z, normal));
    let mut face = card(0.0, 3.0, 0);
    face.positions.iter_mut().for_each(|p| *p = to_world.transform_point3(*p));
    face.normals.iter_mut().for_each(|n| *n = to_world.transform_vector3(*n));
    let mut scene = scene_with(map, dome_light(Vec3::ONE, world_from_light), vec![face], albedo);
    scene.cameras[0] = camera_looking_down_z(Vec3::new(0.0, 0.0, 1.0), 1000.0);
    scene.cameras[0].world_from_camera = to_world * scene.cameras[0].world_from_camera;
    mean_rgb(&render(&scene, &options(8, spp)), |_, _| true) / albedo * std::f32::consts::PI
}

#[test]
fn one_bright_patch_lights_a_card_with_the_irradiance_of_its_texels() {
    // 64 × 32, black but for a patch of 20 at columns 12..28 (longitude 0.125π..0.625π, partly behind
    // the card) and rows 8..14 (45°..79° from +Y).
    let map = Map::from_fn(64, 32, |x, y| {
        if (12..28).contains(&x) && (8..14).contains(&y) {
            [20.0, 10.0, 5.0]
        } else {
            [0.0; 3]
        }
    });
    let expected = map.irradiance([0.0, 0.0, 1.0]);
    let e = card_reading(&map, Mat4::IDENTITY, Vec3::Z, 1024);
    eprintln!("card under the patch: E = {e}, quadrature {expected:?}");
    for c in 0..3 {
        let rel = e[c] as f64 / expected[c] - 1.0;
        assert!(rel.abs() < 0.01, "channel {c}: {} vs {} ({rel:+.4})", e[c], expected[c]);
    }
    assert!(expected[0] > 1.0, "the patch faces the card: E = {expected:?}");
}

#[test]
fn map_halves_light_the_cards_the_spec_says() {
    // Red on the left half of the image, green on the right, blue on the top half. UsdLux / OpenEXR:
    // the left half is longitude (0, π], the +X side; the right half −X; the top half +Y.
    let map =
        Map::from_fn(64, 32, |x, y| [(x < 32) as u8 as f32, (x >= 32) as u8 as f32, (y < 16) as u8 as f32]);
    let full = std::f32::consts::PI; // a whole hemisphere of radiance 1
    let check = |name: &str, e: Vec3, expected: [f64; 3]| {
        eprintln!("{name}: E = {e}, quadrature {expected:?}");
        for c in 0..3 {
            assert!(
                (e[c] as f64 - expected[c]).abs() < 0.02 * full as f64,
                "{name} channel {c}: {e} vs {expected:?}"
            );
        }
    };
    let px = card_reading(&map, Mat4::IDENTITY, Vec3::X, 256);
    check("card facing +X", px, map.irradiance([1.0, 0.0, 0.0]));
    assert!(px.x > 0.95 * full && px.y < 0.05 * full, "+X sees the left half: {px}");
    let nx = card_reading(&map, Mat4::IDENTITY, -Vec3::X, 256);
    check("card facing −X", nx, map.irradiance([-1.0, 0.0, 0.0]));
    assert!(nx.y > 0.95 * full && nx.x < 0.05 * full, "−X sees the right half: {nx}");
    let py = card_reading(&map, Mat4::IDENTITY, Vec3::Y, 256);
    check("card facing +Y", py, map.irradiance([0.0, 1.0, 0.0]));
    assert!(py.z > 0.95 * full && (py.x / py.y - 1.0).abs() < 0.05, "+Y sees the top half: {py}");
    // The light's transform rotates the map: rotateX 90° (a Z-up stage) puts the top half on +Z.
    let pz = card_reading(&map, Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2), Vec3::Z, 256);
    check("card facing +Z, dome rotated X 90°", pz, map.irradiance([0.0, 1.0, 0.0]));
}

#[test]
fn wavefront_image_equals_the_scalar_one_under_a_textured_dome() {
    let map = busy_map();
    let mut scene = scene_with(
        &map,
        dome_light(Vec3::new(1.0, 0.9, 0.8), a_rotation()),
        vec![card(-1.5, 3.0, 0), sphere(Vec3::ZERO, 1.0, 16, 32, 0, false)],
        0.6,
    );
    // Other lights in the same selection list, so lanes of one group mix kinds.
    scene.lights.push(Light {
        path: "/sun".into(),
        kind: LightKind::Distant { angle_degrees: 2.0 },
        radiance: Vec3::splat(2.0),
        normalize: true,
        world_from_light: Mat4::from_rotation_x(-0.7),
    });
    scene.lights.push(Light {
        path: "/ball".into(),
        kind: LightKind::Sphere { radius: 0.3, treat_as_point: false },
        radiance: Vec3::splat(5.0),
        normalize: false,
        world_from_light: Mat4::from_translation(Vec3::new(1.0, 1.5, 1.0)),
    });
    let o = options(24, 16);
    let scalar = render(&scene, &RenderOptions { integrator: Integrator::Scalar, ..o.clone() });
    let wavefront = render(&scene, &RenderOptions { integrator: Integrator::Wavefront, ..o });
    crate::dispatch_tests::record_image("textured dome", &scalar);
    let max_diff = scalar
        .beauty
        .iter()
        .zip(&wavefront.beauty)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0f32, f32::max);
    eprintln!("wavefront vs scalar under a textured dome: max |Δ| = {max_diff}");
    assert!(scalar.beauty.iter().flatten().any(|&v| v > 0.0));
    assert_eq!(
        scalar.beauty.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>(),
        wavefront.beauty.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>(),
        "max |Δ| {max_diff}"
    );
}

#[test]
fn importance_sampling_the_map_beats_uniform_directions_on_a_bright_patch() {
    // Irradiance on a +Z card under the one-patch map, estimated per sample as L cos / pdf: by the
    // map's distribution and by uniform directions. Both must agree with the quadrature; the map's
    // estimator must have a far smaller variance.
    let map = Map::from_fn(64, 32, |x, y| {
        if (20..24).contains(&x) && (10..12).contains(&y) {
            [100.0; 3]
        } else {
            [0.01; 3]
        }
    });
    let expected = map.irradiance([0.0, 0.0, 1.0])[0];
    let scene = scene_with(&map, dome_light(Vec3::ONE, Mat4::IDENTITY), vec![], 0.5);
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let dome = DomeMap::new(&view, 0, Mat3::IDENTITY).expect("a map");
    let mut rng = Rng(21);
    let n = 100_000;
    let moments = |sample: &mut dyn FnMut() -> f64| {
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let x = sample();
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        (mean, sum2 / n as f64 - mean * mean)
    };
    let (by_map, var_map) = moments(&mut || {
        let Some(s) = dome.sample([rng.next_f32(), rng.next_f32()]) else { return 0.0 };
        (s.texel.x * s.wi.z.max(0.0) / s.pdf) as f64
    });
    let mut rng = Rng(22);
    let (uniform, var_uniform) = moments(&mut || {
        let z = 1.0 - 2.0 * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * rng.next_f32();
        let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        (dome.texel_and_pdf(d).0.x * z.max(0.0)) as f64 * 4.0 * PI
    });
    eprintln!(
        "E: quadrature {expected:.4}, by the map {by_map:.4} (variance {var_map:.3}), uniform {uniform:.4} (variance {var_uniform:.1}); ratio {:.0}",
        var_uniform / var_map
    );
    assert!((by_map / expected - 1.0).abs() < 0.01, "by the map {by_map} vs {expected}");
    assert!((uniform / expected - 1.0).abs() < 0.1, "uniform {uniform} vs {expected}");
    assert!(var_uniform > 20.0 * var_map, "variance: map {var_map}, uniform {var_uniform}");
}

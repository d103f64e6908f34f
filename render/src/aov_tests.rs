//! Render products end to end: scenes built in code with RenderProducts, rendered by both
//! integrators, the LPE AOVs checked against the beauty and against closed forms.

use crate::testscene::{self, assert_close, camera_looking_down_z, card, dome, lambert, sphere};
use crate::{Accumulation, Integrator, RenderOptions, Scene as RenderScene};
use blob::outputs::{data_type as dt, source_type as st};
use glam::{Mat4, Vec3};
use scene_pack::{Light, LightKind, Material, RenderProduct, RenderVar, Scene};
use std::f32::consts::PI;

fn var(name: &str, source: &str, source_type: u32, data_type: u32) -> RenderVar {
    RenderVar { path: format!("/Render/Vars/{name}"), source: source.into(), source_type, data_type }
}

fn lpe(name: &str, expression: &str) -> RenderVar {
    var(name, expression, st::LPE, dt::COLOR3)
}

/// The comp split: every path ends in exactly one of these (camera-seen lights in `CL`).
const SPLIT: [(&str, &str); 7] = [
    ("diffuse_direct", "C<RD>L"),
    ("diffuse_indirect", "C<RD>.+L"),
    ("specular_direct", "C<RS>L"),
    ("specular_indirect", "C<RS>.+L"),
    ("transmission", "C<T.*>.*L"),
    ("emission", "C.*O"),
    ("lights", "CL"),
];

fn product(vars: Vec<RenderVar>) -> RenderProduct {
    RenderProduct { path: "/Render/Comp".into(), name: "comp.exr".into(), vars }
}

/// Renders `scene` with `integrator` and returns the accumulation (sums and products).
fn render(scene: &Scene, integrator: Integrator, res: u32, spp: u32) -> Accumulation {
    let bytes = testscene::bytes(scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let scene = RenderScene::new(view);
    let options = RenderOptions {
        spp,
        resolution: Some([res, res]),
        threads: 2,
        integrator,
        ..RenderOptions::default()
    };
    let mut film = Accumulation::new(&scene, &options).unwrap();
    film.render(&scene, &options, spp, &|_| {}).unwrap();
    film
}

/// Channel `name` of the first product.
fn channel<'a>(products: &'a [(String, Vec<f32>)], name: &str) -> &'a [f32] {
    let names: Vec<&str> = products.iter().map(|(n, _)| n.as_str()).collect();
    &products.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no {name} in {names:?}")).1
}

fn sun(intensity: f32) -> Light {
    Light {
        path: "/sun".into(),
        kind: LightKind::Distant { angle_degrees: 0.0 },
        radiance: Vec3::splat(intensity),
        normalize: false,
        world_from_light: Mat4::IDENTITY,
    }
}

/// Grey card, a glossy ball, a glass ball and an emissive quad under a sun, a keyed sphere light
/// and a dome: every kind of event.
fn busy_scene() -> Scene {
    let glossy = Material { diffuse_color: Vec3::splat(0.2), roughness: 0.3, ior: 1.5, ..lambert(0.2) };
    let mirror = Material { roughness: 0.0, metallic: 1.0, ..lambert(0.9) };
    let glass = Material { opacity: 0.0, ior: 1.5, roughness: 0.0, opacity_threshold: 0.0, ..lambert(1.0) };
    let mut emitter = card(1.5, 0.3, 4);
    emitter.path = "/emitter".into();
    let mut m_emit = lambert(0.0);
    m_emit.emissive_color = Vec3::splat(4.0);
    let mut key = Light {
        path: "/World/key".into(),
        kind: LightKind::Sphere { radius: 0.3, treat_as_point: false },
        radiance: Vec3::splat(20.0),
        normalize: false,
        world_from_light: Mat4::from_translation(Vec3::new(1.5, 1.5, 2.0)),
    };
    key.normalize = false;
    let mut ball = sphere(Vec3::new(-1.0, 0.0, 0.6), 0.6, 12, 24, 1, false);
    ball.path = "/ball".into();
    let mut ball2 = sphere(Vec3::new(1.0, -0.5, 0.5), 0.5, 12, 24, 2, false);
    ball2.path = "/glass".into();
    let mut ball3 = sphere(Vec3::new(0.5, 1.0, 0.4), 0.4, 12, 24, 3, false);
    ball3.path = "/mirror".into();
    Scene {
        meshes: vec![card(0.0, 3.0, 0), ball, ball2, ball3, emitter],
        materials: vec![lambert(0.5), glossy, glass, mirror, m_emit],
        lights: vec![sun(2.0), key, dome(0.3)],
        light_groups: vec![None, Some("keys".into()), None],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 6.0), 25.0)],
        default_camera: Some(0),
        ..Scene::default()
    }
}

#[test]
fn lpe_aovs_sum_to_the_beauty_and_both_integrators_agree() {
    let mut scene = busy_scene();
    let mut vars: Vec<RenderVar> = SPLIT.iter().map(|(n, e)| lpe(n, e)).collect();
    vars.push(lpe("keys", "C.*<L.'keys'>"));
    vars.push(var("color", "Ci", st::RAW, dt::COLOR4));
    scene.render_products = vec![product(vars)];
    let film = render(&scene, Integrator::Wavefront, 24, 8);
    let products = film.products();
    let (_, channels) = &products[0];
    let image = film.image();
    let mut worst = 0.0f32;
    let mut totals = [0.0f64; 8];
    for (i, beauty) in image.beauty.iter().enumerate() {
        for c in 0..3 {
            let comp = ["R", "G", "B"][c];
            let sum: f32 = SPLIT.iter().map(|(n, _)| channel(channels, &format!("{n}.{comp}"))[i]).sum();
            worst = worst.max((sum - beauty[c]).abs() / beauty[c].abs().max(1e-3));
            assert_eq!(channel(channels, comp)[i], beauty[c], "the raw colour is the beauty");
        }
        for (k, (n, _)) in SPLIT.iter().enumerate() {
            totals[k] += f64::from(channel(channels, &format!("{n}.R"))[i]);
        }
        totals[7] += f64::from(channel(channels, "keys.R")[i]);
        assert_eq!(channel(channels, "A")[i], beauty[3]);
    }
    assert!(worst < 1e-4, "the split differs from the beauty by {worst} (relative)");
    // Every part of the split is there: the scene has each kind of path.
    for (k, t) in totals.iter().enumerate() {
        assert!(*t > 0.01, "AOV {k} is empty: {totals:?}");
    }
    // The key group is a part of the lights' light, less than the beauty.
    let beauty_total: f64 = image.beauty.iter().map(|b| f64::from(b[0])).sum();
    assert!(totals[7] < beauty_total * 0.9, "{} of {beauty_total}", totals[7]);
    // The wavefront's own lanes traced the AOVs (the scalar code runs no BSDF lane groups).
    assert!(film.stats.counters.bsdf_lane_groups > 0, "the AOV render ran the wavefront stages");
    let scalar = render(&scene, Integrator::Scalar, 24, 8);
    assert_eq!(scalar.stats.counters.bsdf_lane_groups, 0);
    assert_eq!(scalar.aov, film.aov, "both integrators give the AOV sums bit for bit");
    assert_eq!(scalar.sums, film.sums);
}

#[test]
fn recording_aovs_keeps_the_beauty_bits() {
    let plain = busy_scene();
    let mut with = busy_scene();
    with.render_products = vec![product(vec![lpe("d", "C<RD>L"), var("P", "P", st::RAW, dt::VECTOR3)])];
    for integrator in [Integrator::Scalar, Integrator::Wavefront] {
        let a = render(&plain, integrator, 16, 4);
        let b = render(&with, integrator, 16, 4);
        assert_eq!(a.sums, b.sums, "{integrator:?}");
        assert!(a.aov.is_empty() && b.aov.len() == 16 * 16 * 6);
    }
}

#[test]
fn direct_diffuse_of_a_lambert_card_under_a_sun_is_albedo_e_over_pi() {
    let scene = Scene {
        meshes: vec![card(0.0, 3.0, 0)],
        materials: vec![lambert(0.5)],
        lights: vec![sun(3.0)],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 50.0)],
        default_camera: Some(0),
        render_products: vec![product(vec![
            lpe("direct", "C<RD>L"),
            lpe("indirect", "C<RD>.+L"),
            lpe("specular", "C<RS>.*L"),
            var("albedo", "albedo", st::RAW, dt::COLOR3),
            var("N", "N", st::RAW, dt::VECTOR3),
            var("P", "P", st::RAW, dt::VECTOR3),
            var("depth", "depth", st::RAW, dt::FLOAT),
            var("spp", "sampleCount", st::RAW, dt::FLOAT),
        ])],
        ..Scene::default()
    };
    let film = render(&scene, Integrator::Wavefront, 8, 16);
    let products = film.products();
    let (product, channels) = &products[0];
    assert_eq!(product.name, "comp.exr");
    let image = film.image();
    for i in 0..64 {
        assert_close("direct diffuse", channel(channels, "direct.G")[i], 0.5 * 3.0 / PI, 1e-4);
        assert_eq!(channel(channels, "indirect.G")[i], 0.0, "a lone card has no indirect light");
        assert_eq!(channel(channels, "specular.G")[i], 0.0, "ior 1: no specular lobe");
        assert_eq!(channel(channels, "albedo.R")[i], image.albedo[i][0]);
        assert_eq!(channel(channels, "N.Z")[i], 1.0);
        assert_eq!(channel(channels, "depth")[i], image.depth[i]);
        assert_eq!(channel(channels, "P.Z")[i], 0.0, "the card lies in z = 0");
        // Left columns see the card at negative x, right ones at positive x.
        let x = channel(channels, "P.X")[i];
        assert!(x.abs() < 1.2 && (x < 0.0) == (i % 8 < 4), "pixel {i}: P.X {x}");
        assert_eq!(channel(channels, "spp")[i], 16.0);
    }
}

#[test]
fn a_bad_expression_is_an_error_naming_its_var() {
    let mut scene = busy_scene();
    scene.render_products = vec![product(vec![lpe("broken", "C<RD")])];
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let err = Accumulation::new(&RenderScene::new(view), &RenderOptions::default()).unwrap_err().to_string();
    assert_eq!(
        err,
        "invalid option: RenderVar /Render/Vars/broken: light-path expression \"C<RD\": expected `>` at byte 4"
    );
}

#[test]
fn a_product_is_one_multi_layer_exr() {
    let mut scene = busy_scene();
    scene.render_products = vec![product(vec![
        var("beauty", "color", st::RAW, dt::COLOR4),
        lpe("diffuse", "C<RD>.*L"),
        var("depth", "z", st::RAW, dt::FLOAT),
    ])];
    let film = render(&scene, Integrator::Scalar, 8, 2);
    let dir = tempfile::tempdir().unwrap();
    let path = crate::output::product_path(&dir.path().join("beauty.exr"), "comp.exr");
    assert_eq!(path, dir.path().join("comp.exr"));
    let products = film.products();
    let (product, channels) = products.into_iter().next().unwrap();
    crate::output::write_product(&path, &film, product, channels.clone(), &[]).unwrap();
    let read = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let layer = &read.layer_data[0];
    let mut names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    names.sort();
    assert_eq!(names, ["A", "B", "G", "R", "depth", "diffuse.B", "diffuse.G", "diffuse.R"]);
    let diffuse = layer.channel_data.list.iter().find(|c| c.name.to_string() == "diffuse.G").unwrap();
    let expected = channel(&channels, "diffuse.G");
    for (i, v) in expected.iter().enumerate() {
        assert_eq!(diffuse.sample_data.value_by_flat_index(i).to_f32(), *v);
    }
}

/// A card spanning `x0..x1` × −3..3 in z = 0, named `path`.
fn strip(x0: f32, x1: f32, material: u32, path: &str) -> scene_pack::Mesh {
    let mut m = card(0.0, 3.0, material);
    m.positions = vec![
        Vec3::new(x0, -3.0, 0.0),
        Vec3::new(x1, -3.0, 0.0),
        Vec3::new(x1, 3.0, 0.0),
        Vec3::new(x0, 3.0, 0.0),
    ];
    m.path = path.into();
    m
}

/// Two strips meeting at x = 0 under a sun, filling a 9×9 frame whose middle column is centred on
/// the seam, with CryptoObject and CryptoMaterial layers.
fn crypto_film(
    integrator: Integrator,
    spp: u32,
) -> (Accumulation, crate::aov::Channels, Vec<(String, String)>) {
    let scene = Scene {
        meshes: vec![strip(-3.0, 0.0, 0, "/World/left"), strip(0.0, 3.0, 1, "/World/right")],
        materials: vec![
            Material { path: "/Looks/grey".into(), ..lambert(0.5) },
            Material { path: "/Looks/white".into(), ..lambert(0.9) },
        ],
        lights: vec![sun(1.0)],
        cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 50.0)],
        default_camera: Some(0),
        render_products: vec![product(vec![
            var("CryptoObject", "CryptoObject", st::RAW, dt::COLOR4),
            var("CryptoMaterial", "crypto_material", st::RAW, dt::COLOR4),
        ])],
        ..Scene::default()
    };
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let scene = RenderScene::new(view);
    let options =
        RenderOptions { spp, resolution: Some([9, 9]), threads: 2, integrator, ..RenderOptions::default() };
    let mut film = Accumulation::new(&scene, &options).unwrap();
    film.render(&scene, &options, spp, &|_| {}).unwrap();
    let products = film.products();
    let (product, channels) = products.into_iter().next().unwrap();
    let attributes = film.plan.attributes(product, &view);
    (film.clone(), channels, attributes)
}

#[test]
fn cryptomatte_coverage_splits_at_an_edge_and_the_manifest_names_the_ids() {
    use crate::aov::cryptomatte::{id_of, key_of};
    let (film, channels, attributes) = crypto_film(Integrator::Wavefront, 64);
    let mut names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    names.sort();
    assert_eq!(names.len(), 24, "{names:?}");
    assert!(names.contains(&"CryptoObject02.A") && names.contains(&"CryptoMaterial00.R"), "{names:?}");
    let key = key_of("CryptoObject");
    let find = |k: &str| attributes.iter().find(|(n, _)| n == k).map(|(_, v)| v.as_str());
    assert_eq!(find(&format!("cryptomatte/{key}/name")), Some("CryptoObject"));
    assert_eq!(find(&format!("cryptomatte/{key}/hash")), Some("MurmurHash3_32"));
    assert_eq!(find(&format!("cryptomatte/{key}/conversion")), Some("uint32_to_float32"));
    let manifest: serde_json::Value =
        serde_json::from_str(find(&format!("cryptomatte/{key}/manifest")).unwrap()).unwrap();
    let by_hex = |id: f32| {
        let hex = format!("{:08x}", id.to_bits());
        manifest.as_object().unwrap().iter().find(|(_, v)| v.as_str() == Some(&hex)).map(|(k, _)| k.clone())
    };
    let material_key = key_of("CryptoMaterial");
    let materials: serde_json::Value =
        serde_json::from_str(find(&format!("cryptomatte/{material_key}/manifest")).unwrap()).unwrap();
    assert_eq!(materials["/Looks/white"], format!("{:08x}", id_of("/Looks/white")));
    let c = |name: &str, i: usize| channel(&channels, name)[i];
    for y in 0..9 {
        for x in 0..9 {
            let i = y * 9 + x;
            let coverage: f32 = ["00.G", "00.A", "01.G", "01.A", "02.G", "02.A"]
                .iter()
                .map(|s| c(&format!("CryptoObject{s}"), i))
                .sum();
            assert_eq!(coverage, 1.0, "pixel ({x}, {y}) is covered");
            let first = by_hex(c("CryptoObject00.R", i));
            match x {
                4 => {
                    // The seam: about half the samples on each strip.
                    let (a, b) = (c("CryptoObject00.G", i), c("CryptoObject00.A", i));
                    assert!((a - 0.5).abs() < 0.15 && (b - 0.5).abs() < 0.15, "seam pixel {x},{y}: {a} {b}");
                    let second = by_hex(c("CryptoObject00.B", i));
                    let mut both = [first.unwrap(), second.unwrap()];
                    both.sort();
                    assert_eq!(both, ["/World/left", "/World/right"]);
                }
                _ => {
                    let expected = if x < 4 { "/World/left" } else { "/World/right" };
                    assert_eq!(first.as_deref(), Some(expected), "pixel {x},{y}");
                    assert_eq!(c("CryptoObject00.G", i), 1.0);
                    let material = if x < 4 { "/Looks/grey" } else { "/Looks/white" };
                    assert_eq!(c("CryptoMaterial00.R", i).to_bits(), id_of(material));
                }
            }
        }
    }
    let (scalar, ..) = crypto_film(Integrator::Scalar, 64);
    assert_eq!(scalar.aov, film.aov, "both integrators give the Cryptomatte sums bit for bit");
}

#[test]
fn a_cryptomatte_product_has_the_same_bytes_on_every_write() {
    let (film, channels, attributes) = crypto_film(Integrator::Scalar, 4);
    assert_eq!(attributes.len(), 8);
    let dir = tempfile::tempdir().unwrap();
    let product = &film.plan.products[0];
    let mut files = Vec::new();
    for i in 0..4 {
        let path = dir.path().join(format!("crypto{i}.exr"));
        // A fresh map per write, as a fresh process would have: the crate's order differs between them.
        crate::output::write_product(&path, &film, product, channels.clone(), &attributes).unwrap();
        files.push(std::fs::read(&path).unwrap());
    }
    assert!(files.windows(2).all(|w| w[0] == w[1]), "the product's bytes differ between writes");
    let read = exr::prelude::read_all_flat_layers_from_file(dir.path().join("crypto0.exr")).unwrap();
    let other = &read.layer_data[0].attributes.other;
    let key = crate::aov::cryptomatte::key_of("CryptoMaterial");
    let name = exr::prelude::Text::from(format!("cryptomatte/{key}/name").as_str());
    assert_eq!(other.get(&name), Some(&exr::meta::attribute::AttributeValue::Text("CryptoMaterial".into())));
}

#[test]
fn lpe_aovs_of_curves_points_and_linked_glass_equal_the_scalar_ones() {
    use crate::wavefront::equivalence_tests as eq;
    // Fibre, point and glass hits take the wavefront's per-hit vertex (`shade_curves.rs`), and
    // light linking its per-ray emission: each records the AOVs on its own path.
    for (what, mut scene) in [("curves", eq::curve_scene()), ("linked glass", eq::linked(eq::scene(), true))]
    {
        let mut vars: Vec<RenderVar> = SPLIT.iter().map(|(n, e)| lpe(n, e)).collect();
        vars.push(var("P", "P", st::RAW, dt::VECTOR3));
        scene.render_products = vec![product(vars)];
        let wave = render(&scene, Integrator::Wavefront, 24, 4);
        let scalar = render(&scene, Integrator::Scalar, 24, 4);
        assert!(wave.stats.counters.bsdf_lane_groups > 0, "{what}: the wavefront ran");
        assert!(wave.aov.iter().filter(|&&v| v != 0.0).count() > wave.aov.len() / 4, "{what}");
        assert_eq!(scalar.aov, wave.aov, "{what}: AOV sums bit for bit");
        assert_eq!(scalar.sums, wave.sums, "{what}");
    }
}

#[test]
fn max_memory_counts_the_products_sums_and_channels() {
    let mut scene = busy_scene();
    let mut vars: Vec<RenderVar> = SPLIT.iter().map(|(n, e)| lpe(n, e)).collect();
    vars.push(var("CryptoObject", "CryptoObject", st::RAW, dt::COLOR3));
    scene.render_products = vec![product(vars)];
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let plan = crate::aov::Plan::new(&view).unwrap();
    // 7 expressions × 3 sums + 8 Cryptomatte (id, count) slots; 7 × 3 + 12 channels.
    assert_eq!(plan.stride(), 7 * 3 + 16);
    assert_eq!(plan.memory_per_pixel(), 8 * 37 + 8 * 33);
    let (res, threads) = (256, 2);
    let without = crate::film::memory_estimate(res, res, 16, threads, &Default::default());
    let with = crate::film::memory_estimate(res, res, 16, threads, &plan);
    let pixels = u64::from(res * res);
    assert!(with - without >= pixels * plan.memory_per_pixel(), "{with} vs {without}");
    let scene = RenderScene::new(view);
    let options = |limit: u64| RenderOptions {
        resolution: Some([res, res]),
        threads,
        max_memory: Some(limit),
        ..RenderOptions::default()
    };
    let err = Accumulation::new(&scene, &options(with - 1)).unwrap_err().to_string();
    assert!(err.contains(&format!("needs about {with} bytes")), "{err}");
    Accumulation::new(&scene, &options(with)).unwrap();
}

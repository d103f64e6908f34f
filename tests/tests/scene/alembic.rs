//! Alembic archives against the USD they were exported from (tests/assets/alembic, made by
//! make_abc.py with Blender): the tractor's geometry, camera and image.
//!
//! Alembic has no materials or lights, so the image comparison gives both scenes one grey
//! material and the USD scene's lights; what is compared is geometry and camera.

use std::path::{Path, PathBuf};

use glam::Vec3;
use ingest::usd::LoadOptions;
use render::{render_image, Image, RenderOptions};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

fn dump(input: &Path) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let (scene, _) =
        ingest::pipeline::ingest_file(input, &dir.path().join("out.blob"), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("ingest {}: {e:#}", input.display()));
    ingest::pipeline::dump_json(&scene)
}

fn vec3(v: &serde_json::Value) -> Vec3 {
    Vec3::new(v[0].as_f64().unwrap() as f32, v[1].as_f64().unwrap() as f32, v[2].as_f64().unwrap() as f32)
}

/// Per gprim (triangles, bounds min, bounds max), sorted, from a `--dump-json` listing.
fn gprims(dump: &serde_json::Value) -> Vec<(u64, Vec3, Vec3)> {
    let mut out: Vec<_> = dump["gprims"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| (g["triangles"].as_u64().unwrap(), vec3(&g["bounds_min"]), vec3(&g["bounds_max"])))
        .collect();
    out.sort_by(|a, b| (a.0, a.1.x, a.1.z).partial_cmp(&(b.0, b.1.x, b.1.z)).unwrap());
    out
}

#[test]
fn tractor_abc_has_the_usda_triangles_and_bounds() {
    let usd = dump(&repo("examples/tractor.usda"));
    let abc = dump(&repo("tests/assets/alembic/tractor.abc"));
    assert_eq!(usd["triangles"], abc["triangles"]);
    assert_eq!(abc["triangles"], 1990);
    let (usd, abc) = (gprims(&usd), gprims(&abc));
    assert_eq!(usd.len(), abc.len());
    // Blender's Y-up → Z-up import and Z-up → Y-up export cancel: the same world coordinates.
    let extent = usd.iter().fold(0.0f32, |e, g| e.max(g.1.abs().max_element()).max(g.2.abs().max_element()));
    for (u, a) in usd.iter().zip(&abc) {
        assert_eq!(u.0, a.0);
        let err = (u.1 - a.1).abs().max((u.2 - a.2).abs()).max_element();
        assert!(err <= 1e-4 * extent, "bounds {u:?} vs {a:?}: {err} over extent {extent}");
    }
}

/// The scene of `input` with every triangle and curve on one grey Lambertian, and `lights`.
fn grey_blob(input: &Path, lights: Option<Vec<ingest::Light>>) -> (blob::AlignedBytes, Vec<ingest::Light>) {
    let mut scene = if input.extension().is_some_and(|e| e == "abc") {
        ingest::alembic::load(input, &LoadOptions::default()).unwrap()
    } else {
        ingest::usd::load(input, &LoadOptions::default()).unwrap()
    };
    scene.materials = vec![ingest::Material { path: "/grey".into(), ..Default::default() }];
    for m in &mut scene.meshes {
        m.triangle_materials.iter_mut().for_each(|t| *t = 0);
    }
    if let Some(lights) = lights {
        scene.lights = lights;
    }
    let bytes = ingest::pack::pack(&scene).unwrap().encode();
    (blob::AlignedBytes::copy_from(&bytes), scene.lights)
}

fn render(bytes: &[u8], camera: Option<&str>) -> Image {
    let view = blob::SceneView::parse(bytes).unwrap();
    let options = RenderOptions {
        spp: 16,
        resolution: Some([96, 64]),
        camera: camera.map(str::to_string),
        threads: 2,
        seed: 7,
        ..RenderOptions::default()
    };
    render_image(&view, &options).unwrap()
}

fn mean(image: &Image) -> (f64, f64, f64) {
    let n = image.beauty.len() as f64;
    let luminance = image.beauty.iter().map(|p| f64::from(p[0] + p[1] + p[2]) / 3.0).sum::<f64>() / n;
    let coverage = image.beauty.iter().map(|p| f64::from(p[3])).sum::<f64>() / n;
    let hits: Vec<f64> = image.depth.iter().filter(|d| d.is_finite()).map(|&d| f64::from(d)).collect();
    (luminance, coverage, hits.iter().sum::<f64>() / hits.len() as f64)
}

#[test]
fn tractor_abc_renders_like_the_usda_through_its_own_camera() {
    let (usd, lights) = grey_blob(&repo("examples/tractor.usda"), None);
    let (abc, _) = grey_blob(&repo("tests/assets/alembic/tractor.abc"), Some(lights));
    // The USD renders through its RenderSettings camera, the Alembic through the camera Blender
    // exported from it, named explicitly as `render --camera` does.
    let (u, a) = (mean(&render(&usd, None)), mean(&render(&abc, Some("/World/Camera/Camera"))));
    eprintln!(
        "usda: mean {:.4}, coverage {:.4}, depth {:.2}; abc: {:.4}, {:.4}, {:.2}",
        u.0, u.1, u.2, a.0, a.1, a.2
    );
    assert!(u.0 > 0.05, "the tractor is lit");
    assert!((a.0 - u.0).abs() <= 0.03 * u.0, "mean {} vs {}", a.0, u.0);
    assert!((a.1 - u.1).abs() <= 0.01, "coverage {} vs {}", a.1, u.1);
    assert!((a.2 - u.2).abs() <= 0.01 * u.2, "depth {} vs {}", a.2, u.2);
    // A camera path the archive does not have is refused, not silently replaced.
    let view = blob::SceneView::parse(&abc).unwrap();
    let options = RenderOptions { camera: Some("/World/Camera".into()), ..RenderOptions::default() };
    assert!(render_image(&view, &options).is_err());
}

//! Textured dome lights end to end: `.hdr` maps written by the test → DomeLight `texture:file` →
//! ingest (bake, distribution) → blob → render, read back from background pixels (camera rays that
//! escape read the dome's radiance exactly: no noise).

use render::{render_image, RenderOptions};
use std::path::{Path, PathBuf};

/// The map: left half (longitude 0..π, the light's +X side) `LEFT`, right half `RIGHT`.
const LEFT: [f32; 3] = [0.25, 0.5, 0.75];
const RIGHT: [f32; 3] = [2.0, 1.0, 0.5];

/// The bytes of a 32 × 16 Radiance `.hdr` with `LEFT` and `RIGHT` halves.
fn hdr_bytes() -> Vec<u8> {
    hdr_halves(LEFT, RIGHT)
}

/// The bytes of a 32 × 16 Radiance `.hdr` with halves `left` and `right`.
fn hdr_halves(left: [f32; 3], right: [f32; 3]) -> Vec<u8> {
    let img = image::Rgb32FImage::from_fn(32, 16, |x, _| image::Rgb(if x < 16 { left } else { right }));
    let mut bytes = std::io::Cursor::new(Vec::new());
    image::DynamicImage::ImageRgb32F(img).write_to(&mut bytes, image::ImageFormat::Hdr).expect("encode hdr");
    bytes.into_inner()
}

/// A stage with a narrow camera at the origin looking down −Z and a DomeLight `/World/Sky` rotated
/// +90° about Y (its +X, the map's left half, turns to −Z: straight ahead), with `inputs`.
fn stage(inputs: &str) -> String {
    format!(
        r#"#usda 1.0
(
    defaultPrim = "World"
    upAxis = "Y"
)
def Xform "World"
{{
    def Camera "Cam"
    {{
        float focalLength = 500
    }}
    def DomeLight "Sky"
    {{
        color3f inputs:color = (0.5, 1, 1)
        float inputs:intensity = 2
        float inputs:exposure = 1
{inputs}
        float xformOp:rotateY = 90
        uniform token[] xformOpOrder = ["xformOp:rotateY"]
    }}
}}
"#
    )
}

/// Ingests `root`, renders 4 × 4 pixels; the mean background RGB and the ingest warnings.
fn render_root(root: &Path) -> ([f32; 3], Vec<String>, blob::AlignedBytes) {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("scene.blob");
    let (_, report) =
        ingest::pipeline::ingest_file(root, &output, &ingest::usd::LoadOptions::default()).expect("ingest");
    let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&output).unwrap());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let options = RenderOptions { spp: 1, resolution: Some([4, 4]), threads: 1, ..RenderOptions::default() };
    let image = render_image(&view, &options).expect("render");
    let mut mean = [0.0f32; 3];
    for p in &image.beauty {
        for c in 0..3 {
            mean[c] += p[c] / image.beauty.len() as f32;
        }
    }
    (mean, report.warnings, bytes)
}

/// Writes `name`: the dome stage reading `map`, its light turned `degrees` about Y instead of 90.
fn write_turned(dir: &Path, name: &str, map: &str, degrees: i32) -> PathBuf {
    let layer = stage(&format!("        asset inputs:texture:file = @{map}@"))
        .replace("float xformOp:rotateY = 90", &format!("float xformOp:rotateY = {degrees}"));
    write(dir, name, layer.as_bytes())
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn assert_rgb(v: [f32; 3], expected: [f32; 3], rel: f32, what: &str) {
    for c in 0..3 {
        assert!(
            (v[c] / expected[c] - 1.0).abs() <= rel,
            "{what}: reads {v:?}, expected {expected:?} ± {rel}"
        );
    }
}

/// color × intensity × 2^exposure.
fn scale(texel: [f32; 3]) -> [f32; 3] {
    let color = [0.5, 1.0, 1.0];
    [0, 1, 2].map(|c| texel[c] * color[c] * 2.0 * 2.0)
}

#[test]
fn textured_dome_from_an_hdr_file_shows_its_map_turned_by_the_light_transform() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "sky.hdr", &hdr_bytes());
    let root =
        write(dir.path(), "scene.usda", stage("        asset inputs:texture:file = @./sky.hdr@").as_bytes());
    let (rgb, warnings, bytes) = render_root(&root);
    eprintln!("background {rgb:?} (expected {:?}), warnings {warnings:?}", scale(LEFT));
    assert!(warnings.is_empty(), "{warnings:?}");
    // RGBE keeps 8 bits of mantissa; the half-float bake keeps 11.
    assert_rgb(rgb, scale(LEFT), 0.01, "left half of the map, straight ahead");
    let view = blob::SceneView::parse(&bytes).unwrap();
    assert_eq!(view.lights[0].kind, blob::light_kind::TEXTURED_DOME);
    assert_eq!(view.info.dome_light, 0);
    let map = view.dome.maps[view.lights[0].dome_map as usize];
    assert_eq!((map.width, map.height), (32, 16), "one cell per texel");
    // Unrotated, the camera looks at −Z: the seam between the halves (their bilinear average).
    let root = write_turned(dir.path(), "unrotated.usda", "sky.hdr", 0);
    let (rgb, _, _) = render_root(&root);
    let seam = scale([0, 1, 2].map(|c| 0.5 * (LEFT[c] + RIGHT[c])));
    assert_rgb(rgb, seam, 0.05, "the seam at −Z");
    // Turned the other way (−90°), −Z sees the light's −X: the right half.
    let root = write_turned(dir.path(), "turned.usda", "sky.hdr", -90);
    let (rgb, _, _) = render_root(&root);
    assert_rgb(rgb, scale(RIGHT), 0.01, "right half of the map, rotated −90°");
}

#[test]
fn a_sun_brighter_than_half_floats_hold_keeps_its_radiance() {
    // 2¹⁷ is past the half-float maximum (65504) the bake stores float maps in: the map is scaled
    // down by a power of two at ingest and the light's radiance carries the factor back. (Values
    // RGBE holds exactly: mantissas 128, 96, 64 under one exponent.)
    let sun = [131_072.0, 98_304.0, 65_536.0];
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "sun.hdr", &hdr_halves(sun, RIGHT));
    let root =
        write(dir.path(), "scene.usda", stage("        asset inputs:texture:file = @sun.hdr@").as_bytes());
    let (rgb, warnings, bytes) = render_root(&root);
    eprintln!("sun background {rgb:?} (expected {:?})", scale(sun));
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_rgb(rgb, scale(sun), 1e-6, "sun half");
    let view = blob::SceneView::parse(&bytes).unwrap();
    assert_eq!(view.lights[0].radiance, [4.0 * 0.5 * 4.0, 4.0 * 4.0, 4.0 * 4.0], "× 2² to fit 65504");
    // The other half, now stored four times smaller, still reads its value.
    let root = write_turned(dir.path(), "turned.usda", "sun.hdr", -90);
    let (rgb, _, _) = render_root(&root);
    assert_rgb(rgb, scale(RIGHT), 0.01, "dim half beside the sun");
}

#[test]
fn dome_texture_inside_a_usdz_is_read_from_the_package() {
    let dir = tempfile::tempdir().unwrap();
    let package = dir.path().join("sky.usdz");
    let mut archive = openusd::usdz::ArchiveWriter::create(&package).expect("create usdz");
    let layer = stage("        asset inputs:texture:file = @textures/sky.hdr@");
    archive.add_layer("scene.usda", layer.as_bytes()).expect("add layer");
    archive.add_layer("textures/sky.hdr", &hdr_bytes()).expect("add map");
    archive.finish().expect("finish usdz");
    let (rgb, warnings, _) = render_root(&package);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_rgb(rgb, scale(LEFT), 0.01, "map inside the package");
}

#[test]
fn unsupported_formats_and_missing_maps_fall_back_to_the_uniform_colour_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "sky.hdr", &hdr_bytes());
    let uniform = scale([1.0; 3]);
    for (name, inputs, needle) in [
        (
            "ball.usda",
            "        asset inputs:texture:file = @sky.hdr@\n        token inputs:texture:format = \"mirroredBall\"",
            "texture:format \"mirroredBall\" not supported",
        ),
        (
            "cross.usda",
            "        asset inputs:texture:file = @sky.hdr@\n        token inputs:texture:format = \"cubeMapVerticalCross\"",
            "texture:format \"cubeMapVerticalCross\" not supported",
        ),
        ("missing.usda", "        asset inputs:texture:file = @nowhere.exr@", "nowhere.exr not found"),
        ("garbage.usda", "        asset inputs:texture:file = @garbage.hdr@", "garbage.hdr cannot be read"),
    ] {
        write(dir.path(), "garbage.hdr", b"#?RADIANCE\nnot an image");
        let root = write(dir.path(), name, stage(inputs).as_bytes());
        let (rgb, warnings, bytes) = render_root(&root);
        eprintln!("{name}: {warnings:?}");
        assert!(
            warnings.iter().any(|w| w.contains("/World/Sky") && w.contains(needle) && w.contains("uniform color")),
            "{name}: {warnings:?}"
        );
        assert_rgb(rgb, uniform, 1e-6, name);
        let view = blob::SceneView::parse(&bytes).unwrap();
        assert_eq!(view.lights[0].kind, blob::light_kind::DOME, "{name}");
    }
    // `latlong` and `automatic` are read.
    let root = write(
        dir.path(),
        "latlong.usda",
        stage("        asset inputs:texture:file = @sky.hdr@\n        token inputs:texture:format = \"latlong\"")
            .as_bytes(),
    );
    let (rgb, warnings, _) = render_root(&root);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_rgb(rgb, scale(LEFT), 0.01, "latlong");
}

#[test]
fn a_corrupted_dome_distribution_is_refused_on_load() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "sky.hdr", &hdr_bytes());
    let root =
        write(dir.path(), "scene.usda", stage("        asset inputs:texture:file = @sky.hdr@").as_bytes());
    let scene = ingest::usd::load(&root, &ingest::usd::LoadOptions::default()).expect("load");
    let data = ingest::pack::pack(&scene).expect("pack");
    assert_eq!(data.dome.cdf_values.len(), 17 + 16 * 33);
    blob::SceneView::parse(&blob::AlignedBytes::copy_from(&data.encode())).expect("valid as packed");
    for (what, edit) in [
        (
            "a CDF that falls",
            Box::new(|d: &mut blob::SceneData| d.dome.cdf_values[20] = -0.5) as Box<dyn Fn(&mut _)>,
        ),
        ("a CDF past 1", Box::new(|d: &mut blob::SceneData| d.dome.cdf_values[16] = 2.0)),
        ("a NaN", Box::new(|d: &mut blob::SceneData| d.dome.cdf_values[40] = f32::NAN)),
        ("values cut short", Box::new(|d: &mut blob::SceneData| d.dome.cdf_values.truncate(100))),
        ("a map index out of range", Box::new(|d: &mut blob::SceneData| d.lights[0].dome_map = 1)),
        ("a texture index out of range", Box::new(|d: &mut blob::SceneData| d.dome.maps[0].texture = 7)),
    ] {
        let mut bad = data.clone();
        edit(&mut bad);
        let err = blob::SceneView::parse(&blob::AlignedBytes::copy_from(&bad.encode()))
            .expect_err(what)
            .to_string();
        eprintln!("{what}: {err}");
        assert!(err.contains("Dome") || err.contains("Light"), "{what}: {err}");
    }
}

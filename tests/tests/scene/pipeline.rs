//! End to end: USD text → ingest → blob → render, checked against physics.
//!
//! Each analytic test states its stage in full; the expected radiance follows from the setup:
//! - a convex Lambertian under a uniform dome of radiance 1 reflects exactly its albedo (it sees the
//!   whole dome over its hemisphere and never itself);
//! - a Lambertian card facing a normalized distant light of illuminance E reads albedo·E/π;
//! - in a white furnace (albedo 1 everywhere, dome radiance 1) every path carries radiance 1, however many
//!   bounces the concave geometry forces.

use render::{render_image, RenderOptions};
use scene_tests::*;

fn render_rgb(bytes: &[u8], options: &RenderOptions) -> (Vec<[f32; 3]>, usize) {
    let view = blob::SceneView::parse(bytes).expect("valid blob");
    let image = render_image(&view, options).expect("render");
    let rgb = image.beauty.iter().map(|p| [p[0], p[1], p[2]]).collect();
    (rgb, image.width as usize)
}

fn assert_close(value: [f32; 3], expected: f32, tolerance: f32, what: &str) {
    eprintln!("{what}: reads {value:?}, expected {expected}");
    for (c, v) in value.iter().enumerate() {
        assert!(
            (v - expected).abs() <= tolerance * expected,
            "{what}: channel {c} reads {v}, expected {expected} ± {:.1}%",
            tolerance * 100.0
        );
    }
}

const DOME: &str = "def DomeLight \"Dome\"\n{\n    float inputs:intensity = 1\n}\n";

mod analytic {
    use super::*;

    #[test]
    fn lambertian_sphere_under_white_dome_reads_its_albedo() {
        let dir = tempfile::tempdir().unwrap();
        let body = [
            lambert_material("/World/Grey", 0.5),
            sphere_mesh("Ball", [0.0, 0.0, 0.0], 1.0, 48, 96, "/World/Grey"),
            camera_prim("Cam", [0.0, 0.0, 5.0], 50.0, 30.0),
            DOME.to_string(),
        ]
        .join("\n");
        let bytes = ingest_text(dir.path(), &stage(&body));
        let options = RenderOptions { spp: 256, resolution: Some([32, 32]), ..RenderOptions::default() };
        let (rgb, width) = render_rgb(&bytes, &options);
        // The sphere projects to a disc of radius ~10.9 px around the centre (16, 16).
        let r =
            |x: usize, y: usize| ((x as f32 + 0.5 - 16.0).powi(2) + (y as f32 + 0.5 - 16.0).powi(2)).sqrt();
        let sphere = mean_where(&rgb, width, |x, y| r(x, y) < 8.0);
        let dome = mean_where(&rgb, width, |x, y| r(x, y) > 13.5);
        assert_close(sphere, 0.5, 0.02, "sphere");
        assert_close(dome, 1.0, 0.02, "dome seen directly");
    }

    #[test]
    fn lambertian_card_under_normalized_distant_light_reads_albedo_e_over_pi() {
        let dir = tempfile::tempdir().unwrap();
        let card = mesh_prim(
            "Card",
            &[[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]],
            &[4],
            &[0, 1, 2, 3],
            None,
            "/World/Grey",
        );
        // A DistantLight shines along its −Z: straight onto the card's +Z face.
        let sun = "def DistantLight \"Sun\"\n{\n    float inputs:intensity = 3\n    bool inputs:normalize = true\n}\n";
        let body = [
            lambert_material("/World/Grey", 0.5),
            card,
            camera_prim("Cam", [0.0, 0.0, 5.0], 50.0, 10.0),
            sun.into(),
        ]
        .join("\n");
        let bytes = ingest_text(dir.path(), &stage(&body));
        let options = RenderOptions { spp: 256, resolution: Some([16, 16]), ..RenderOptions::default() };
        let (rgb, width) = render_rgb(&bytes, &options);
        let card = mean_where(&rgb, width, |_, _| true);
        assert_close(card, 0.5 * 3.0 / std::f32::consts::PI, 0.02, "card");
    }

    #[test]
    fn white_furnace_with_interreflections_reads_one() {
        let dir = tempfile::tempdir().unwrap();
        // An open box (a cup) seen from above: its inside reflects light many times before escaping.
        let cup = open_box_mesh("Cup", "/World/White");
        let body = [
            lambert_material("/World/White", 1.0),
            cup,
            camera_prim("Cam", [0.0, 0.0, 4.0], 50.0, 24.0),
            DOME.into(),
        ]
        .join("\n");
        let bytes = ingest_text(dir.path(), &stage(&body));
        let options = RenderOptions {
            spp: 256,
            resolution: Some([16, 16]),
            max_depth: 256,
            ..RenderOptions::default()
        };
        let (rgb, width) = render_rgb(&bytes, &options);
        let inside = mean_where(&rgb, width, |x, y| (4..12).contains(&x) && (4..12).contains(&y));
        assert_close(inside, 1.0, 0.02, "inside the cup");
        let all = mean_where(&rgb, width, |_, _| true);
        assert_close(all, 1.0, 0.02, "whole image");
    }
}

mod determinism {
    use super::*;

    #[test]
    fn one_and_two_threads_give_bit_identical_images() {
        let dir = tempfile::tempdir().unwrap();
        let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
        let out = dir.path().join("tractor.blob");
        ingest::pipeline::ingest_file(&example, &out, &Default::default())
            .expect("ingest the bundled example");
        let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&out).unwrap());
        let options = |threads| RenderOptions {
            spp: 4,
            resolution: Some([48, 32]),
            threads,
            seed: 7,
            ..RenderOptions::default()
        };
        let (one, _) = render_rgb(&bytes, &options(1));
        let (two, _) = render_rgb(&bytes, &options(2));
        assert!(one.iter().zip(&two).all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)));
        // And the image is not trivially constant.
        let lum: Vec<f32> = one.iter().map(|p| p[0] + p[1] + p[2]).collect();
        let (lo, hi) = lum.iter().fold((f32::MAX, f32::MIN), |(l, h), v| (l.min(*v), h.max(*v)));
        assert!(hi > lo * 1.5, "example image should have contrast: {lo}..{hi}");
        let (other_seed, _) = render_rgb(&bytes, &RenderOptions { seed: 8, ..options(2) });
        assert!(one != other_seed, "a different seed gives a different image");
    }

    #[test]
    fn ingest_is_deterministic_to_the_byte() {
        let dir = tempfile::tempdir().unwrap();
        let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
        let (a, b) = (dir.path().join("a.blob"), dir.path().join("b.blob"));
        ingest::pipeline::ingest_file(&example, &a, &Default::default()).unwrap();
        ingest::pipeline::ingest_file(&example, &b, &Default::default()).unwrap();
        assert_eq!(std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    }
}

mod bad_input {
    use super::*;

    #[test]
    fn missing_reference_names_the_referencing_layer_and_leaves_no_blob() {
        let dir = tempfile::tempdir().unwrap();
        let text = "#usda 1.0\n\ndef Xform \"World\" (\n    prepend references = @./nowhere.usda@\n)\n{\n}\n";
        let input = write(dir.path(), "asks.usda", text);
        let output = dir.path().join("out.blob");
        let err = ingest::pipeline::ingest_file(&input, &output, &Default::default()).unwrap_err();
        let message = format!("{err:#}");
        assert!(message.contains("asks.usda") && message.contains("nowhere.usda"), "{message}");
        assert!(!output.exists(), "no blob is written on error");
    }

    #[test]
    fn corrupted_blob_is_an_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let bytes = ingest_text(dir.path(), &stage(&lambert_material("/World/M", 0.5)));
        let mut corrupted = bytes.to_vec();
        let middle = corrupted.len() / 2;
        corrupted[middle] ^= 0x10;
        assert!(blob::SceneView::parse(&blob::AlignedBytes::copy_from(&corrupted)).is_err());
        assert!(blob::SceneView::parse(&blob::AlignedBytes::copy_from(&bytes[..bytes.len() - 1])).is_err());
    }
}

/// The wavefront integrator against the scalar one: same sample keys, same paths, same image.
mod wavefront {
    use super::*;
    use render::Integrator;

    /// Renders `bytes` with both integrators and returns (max, mean) absolute difference over the beauty
    /// and the albedo/normal AOVs.
    pub fn scalar_vs_wavefront(bytes: &[u8], options: &RenderOptions, what: &str) -> (f32, f64) {
        let view = blob::SceneView::parse(bytes).expect("valid blob");
        let scalar =
            render_image(&view, &RenderOptions { integrator: Integrator::Scalar, ..options.clone() })
                .expect("scalar render");
        let wave =
            render_image(&view, &RenderOptions { integrator: Integrator::Wavefront, ..options.clone() })
                .expect("wavefront render");
        let a = scalar
            .beauty
            .iter()
            .flatten()
            .chain(scalar.albedo.iter().flatten())
            .chain(scalar.normal.iter().flatten());
        let b = wave
            .beauty
            .iter()
            .flatten()
            .chain(wave.albedo.iter().flatten())
            .chain(wave.normal.iter().flatten());
        let (mut max, mut sum, mut n) = (0.0f32, 0.0f64, 0usize);
        for (x, y) in a.zip(b) {
            let d = (x - y).abs();
            max = max.max(d);
            sum += d as f64;
            n += 1;
        }
        let mean = sum / n as f64;
        eprintln!("{what}: wavefront vs scalar: max abs diff {max:e}, mean {mean:e} over {n} values");
        assert_eq!(scalar.stats.rays, wave.stats.rays, "{what}: same rays traced");
        assert!(max <= 1e-5, "{what}: max abs diff {max}");
        assert_eq!(scalar.depth, wave.depth, "{what}: depth AOV");
        (max, mean)
    }

    #[test]
    fn equals_scalar_on_the_analytic_scenes() {
        let dir = tempfile::tempdir().unwrap();
        let sphere = [
            lambert_material("/World/Grey", 0.5),
            sphere_mesh("Ball", [0.0, 0.0, 0.0], 1.0, 24, 48, "/World/Grey"),
            camera_prim("Cam", [0.0, 0.0, 5.0], 50.0, 30.0),
            DOME.to_string(),
        ]
        .join("\n");
        let bytes = ingest_text(dir.path(), &stage(&sphere));
        let options =
            RenderOptions { spp: 16, resolution: Some([32, 32]), tile_size: 8, ..RenderOptions::default() };
        scalar_vs_wavefront(&bytes, &options, "sphere under dome");

        let cup = [
            lambert_material("/World/White", 0.8),
            open_box_mesh("Cup", "/World/White"),
            camera_prim("Cam", [0.0, 0.0, 4.0], 50.0, 24.0),
            DOME.into(),
            "def DistantLight \"Sun\"\n{\n    float inputs:intensity = 3\n    bool inputs:normalize = true\n}\n"
                .into(),
        ]
        .join("\n");
        let bytes = ingest_text(dir.path(), &stage(&cup));
        let options =
            RenderOptions { spp: 64, resolution: Some([16, 16]), max_depth: 64, ..RenderOptions::default() };
        scalar_vs_wavefront(&bytes, &options, "cup (furnace-like, deep paths, RR)");
    }

    #[test]
    fn equals_scalar_on_the_tractor() {
        let dir = tempfile::tempdir().unwrap();
        let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
        let out = dir.path().join("tractor.blob");
        ingest::pipeline::ingest_file(&example, &out, &Default::default()).expect("ingest the example");
        let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&out).unwrap());
        let options = RenderOptions {
            spp: 8,
            resolution: Some([64, 48]),
            threads: 2,
            seed: 3,
            ..RenderOptions::default()
        };
        scalar_vs_wavefront(&bytes, &options, "tractor");
        // A tile wider than the path pool splits samples into chunks of one sample per pixel.
        let big = RenderOptions { tile_size: 80, spp: 3, ..options };
        scalar_vs_wavefront(&bytes, &big, "tractor, one 80-pixel tile");
    }
}

mod precision {
    use super::*;

    /// A grey ball resting on a grey ground under a sun, the whole shot (camera included) placed
    /// `offset` units from the stage origin along every axis by one double-precision translate.
    fn far_shot(offset: f64) -> String {
        let ground = mesh_prim(
            "Ground",
            &[[-10.0, 0.0, 10.0], [10.0, 0.0, 10.0], [10.0, 0.0, -10.0], [-10.0, 0.0, -10.0]],
            &[4],
            &[0, 1, 2, 3],
            None,
            "/World/Grey",
        );
        let sun = "def DistantLight \"Sun\"\n{\n    float inputs:intensity = 2\n    bool inputs:normalize = true\n    float3 xformOp:rotateXYZ = (-50, 30, 0)\n    uniform token[] xformOpOrder = [\"xformOp:rotateXYZ\"]\n}\n";
        let shot = [
            sphere_mesh("Ball", [0.0, 1.0, 0.0], 1.0, 32, 64, "/World/Grey"),
            ground,
            camera_prim("Cam", [0.0, 1.0, 6.0], 35.0, 24.0),
        ]
        .join("\n");
        let indented: String = shot.lines().map(|l| format!("    {l}\n")).collect();
        let body = format!(
            "{}\n{sun}\ndef Xform \"Shot\"\n{{\n    double3 xformOp:translate = ({offset}, {offset}, {offset})\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n{indented}}}\n",
            lambert_material("/World/Grey", 0.5)
        );
        stage(&body)
    }

    fn render_far(offset: f64) -> (Vec<[f32; 3]>, [f64; 3]) {
        let dir = tempfile::tempdir().unwrap();
        let bytes = ingest_text(dir.path(), &far_shot(offset));
        let origin = blob::SceneView::parse(&bytes).unwrap().info.world_origin;
        let options = RenderOptions { spp: 16, resolution: Some([96, 64]), ..RenderOptions::default() };
        (render_rgb(&bytes, &options).0, origin)
    }

    /// Mean |a − b| over the image, relative to the mean of `a`.
    fn relative_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
        let diff: f64 =
            a.iter().zip(b).map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).abs() as f64).sum::<f64>()).sum();
        let mean: f64 = a.iter().map(|p| p.iter().map(|&v| v as f64).sum::<f64>()).sum();
        diff / mean
    }

    /// Before ingest stored positions relative to the camera, the shot at 1e5 lost the ball's
    /// contact shadow and blackened its lower half (mean |Δ| 3.9 / 255 of the PNG, 1,791 pixels
    /// off by more than 40 / 255 at 240×160), and at 1e7 the ball rendered as a cube.
    #[test]
    fn a_shot_far_from_the_stage_origin_renders_as_it_does_at_the_origin() {
        let (near, origin) = render_far(0.0);
        assert_eq!(origin, [0.0; 3], "a camera within 32 units of the origin keeps the stage's origin");
        for (offset, expected_origin) in [(100_010.0, 100_032.0), (1e7 + 3.25, 1e7)] {
            let (far, origin) = render_far(offset);
            assert_eq!(origin, [expected_origin; 3], "the origin is the camera snapped to 64 units");
            let d = relative_difference(&near, &far);
            eprintln!("offset {offset}: mean |Δ| / mean = {d:.2e}");
            assert!(d < 2e-3, "offset {offset}: the image differs from the origin's by {d:.2e} of its mean");
        }
    }
}

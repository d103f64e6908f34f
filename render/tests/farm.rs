//! The render binary's checkpoints, time limits, resumes, tiles, sample slices and merges as a farm
//! runs them: separate processes, one killed mid-render.

use glam::{Mat4, Vec3};
use scene_pack::{Light, LightKind, Material, Mesh, Scene};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A floor and a card above it under a dome: soft shadows, so every sample differs.
fn blob(dir: &Path) -> PathBuf {
    blob_named(dir, "scene.blob", 0.6)
}

/// The scene with its card at `card_height`, written to `dir/name`.
fn blob_named(dir: &Path, name: &str, card_height: f32) -> PathBuf {
    write_scene(dir, name, scene(card_height))
}

/// The scene with a RenderProduct `comp.exr` of every kind of layer: the beauty, LPEs
/// (direct and indirect diffuse), raw albedo, position and sample count, Cryptomatte objects and
/// materials.
fn products_blob(dir: &Path) -> PathBuf {
    use blob::outputs::{data_type as dt, source_type as st};
    let var = |name: &str, source: &str, source_type, data_type| scene_pack::RenderVar {
        path: format!("/Render/Vars/{name}"),
        source: source.into(),
        source_type,
        data_type,
    };
    let mut scene = scene(0.6);
    scene.materials.push(Material { diffuse_color: Vec3::new(0.2, 0.7, 0.3), ..Material::default() });
    scene.meshes[1].triangle_materials = vec![1, 1];
    scene.render_products = vec![scene_pack::RenderProduct {
        path: "/Render/Comp".into(),
        name: "comp.exr".into(),
        vars: vec![
            var("color", "Ci", st::RAW, dt::COLOR4),
            var("direct", "C<RD>L", st::LPE, dt::COLOR3),
            var("indirect", "C<RD>.+L", st::LPE, dt::COLOR3),
            var("albedo", "albedo", st::RAW, dt::COLOR3),
            var("P", "P", st::RAW, dt::VECTOR3),
            var("spp", "sampleCount", st::RAW, dt::FLOAT),
            var("CryptoObject", "CryptoObject", st::RAW, dt::COLOR3),
            var("CryptoMaterial", "CryptoMaterial", st::RAW, dt::COLOR3),
        ],
    }];
    write_scene(dir, "products.blob", scene)
}

fn write_scene(dir: &Path, name: &str, scene: Scene) -> PathBuf {
    let path = dir.join(name);
    blob::write_atomic(&path, &scene_pack::pack::pack(&scene).unwrap().encode()).unwrap();
    path
}

/// A floor and a card at `card_height` above it under a dome.
fn scene(card_height: f32) -> Scene {
    let quad = |path: &str, z: f32, half: f32| Mesh {
        path: path.into(),
        positions: vec![
            Vec3::new(-half, -half, z),
            Vec3::new(half, -half, z),
            Vec3::new(half, half, z),
            Vec3::new(-half, half, z),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![0, 0],
        ..Mesh::default()
    };
    Scene {
        meshes: vec![quad("/Floor", 0.0, 3.0), quad("/Card", card_height, 0.5)],
        materials: vec![Material::default()],
        lights: vec![Light {
            path: "/Dome".into(),
            kind: LightKind::Dome,
            radiance: Vec3::ONE,
            normalize: false,
            world_from_light: Mat4::IDENTITY,
        }],
        cameras: vec![scene_pack::camera::test_camera(Vec3::new(0.0, 0.0, 4.0), false)],
        default_camera: Some(0),
        ..Scene::default()
    }
}

fn render(blob: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args =
        vec![blob.to_str().unwrap(), "-o", out.to_str().unwrap(), "--res", "40x30", "--threads", "2"];
    args.extend(extra);
    Command::new(env!("CARGO_BIN_EXE_render")).args(&args).output().unwrap()
}

fn stderr(output: &std::process::Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn a_resumed_render_equals_an_uninterrupted_one_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    let (whole, part) = (dir.path().join("whole.exr"), dir.path().join("part.exr"));
    for integrator in ["scalar", "wavefront"] {
        let run = render(&blob, &whole, &["--spp", "20", "--checkpoint", "1000", "--integrator", integrator]);
        assert!(run.status.success(), "{}", stderr(&run));
        // 8 of 20 samples, a checkpoint; then continued to 20.
        let first = render(&blob, &part, &["--spp", "8", "--checkpoint", "1000", "--integrator", integrator]);
        assert!(first.status.success(), "{}", stderr(&first));
        assert!(std::fs::read(&part).unwrap() != std::fs::read(&whole).unwrap());
        let resumed = render(
            &blob,
            &part,
            &["--spp", "20", "--checkpoint", "1000", "--resume", "--integrator", integrator],
        );
        assert!(resumed.status.success(), "{}", stderr(&resumed));
        let (x, y) = (std::fs::read(&part).unwrap(), std::fs::read(&whole).unwrap());
        assert!(x == y, "{integrator}: the resumed EXR differs from the uninterrupted one");
    }
    // Without --checkpoint the resumed render's EXR is the plain one, as an uninterrupted plain render.
    let plain = dir.path().join("plain.exr");
    assert!(render(&blob, &plain, &["--spp", "20"]).status.success());
    assert!(render(&blob, &part, &["--spp", "8", "--checkpoint", "1000"]).status.success());
    assert!(render(&blob, &part, &["--spp", "20", "--resume"]).status.success());
    assert!(std::fs::read(&part).unwrap() == std::fs::read(&plain).unwrap());
}

#[test]
fn resumes_refuse_other_blobs_settings_and_plain_images() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    let out = dir.path().join("out.exr");
    assert!(render(&blob, &out, &["--spp", "4", "--checkpoint", "1000"]).status.success());
    let other_seed = render(&blob, &out, &["--spp", "8", "--resume", "--seed", "3"]);
    assert!(!other_seed.status.success());
    assert!(stderr(&other_seed).contains("it was rendered with seed 0"), "{}", stderr(&other_seed));
    let fewer = render(&blob, &out, &["--spp", "2", "--resume"]);
    assert!(stderr(&fewer).contains("it holds 4 samples per pixel, more than --spp 2"), "{}", stderr(&fewer));
    let other_res = render(&blob, &out, &["--spp", "8", "--resume", "--res", "20x30"]);
    assert!(!other_res.status.success(), "{}", stderr(&other_res));
    let plain = dir.path().join("plain.exr");
    assert!(render(&blob, &plain, &["--spp", "2"]).status.success());
    let not_a_checkpoint = render(&blob, &plain, &["--spp", "4", "--resume"]);
    assert!(
        stderr(&not_a_checkpoint)
            .contains("no render.checkpoint attribute: not a checkpoint (render --checkpoint writes them)"),
        "{}",
        stderr(&not_a_checkpoint)
    );
}

#[test]
fn a_time_limit_stops_after_a_pass_and_the_rest_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    let (whole, part) = (dir.path().join("whole.exr"), dir.path().join("part.exr"));
    assert!(render(&blob, &whole, &["--spp", "24", "--checkpoint", "1000"]).status.success());
    let limited = render(&blob, &part, &["--spp", "24", "--time-limit", "0"]);
    assert!(limited.status.success(), "{}", stderr(&limited));
    assert!(
        stderr(&limited).contains("time limit of 0 s reached after 8 of 24 samples per pixel"),
        "{}",
        stderr(&limited)
    );
    assert!(render(&blob, &part, &["--spp", "24", "--checkpoint", "1000", "--resume"]).status.success());
    assert!(std::fs::read(&part).unwrap() == std::fs::read(&whole).unwrap());
}

#[test]
fn a_killed_render_leaves_its_last_checkpoint_whole() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    let out = dir.path().join("out.exr");
    // A checkpoint after every pass of 8 samples, far more samples than the test waits for.
    let mut child = Command::new(env!("CARGO_BIN_EXE_render"))
        .args([blob.to_str().unwrap(), "-o", out.to_str().unwrap(), "--res", "200x150", "--spp", "1000000"])
        .args(["--threads", "1", "--checkpoint", "0"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while !out.exists() && start.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(out.exists(), "a checkpoint within two minutes");
    // Kill it while it writes the next ones.
    std::thread::sleep(std::time::Duration::from_millis(300));
    child.kill().unwrap();
    child.wait().unwrap();
    let (film, _) = render::checkpoint::read_checkpoint(&out).expect("the last checkpoint reads whole");
    assert!(film.samples >= 8 && film.samples % 8 == 0, "{} samples", film.samples);
    assert_eq!(film.sums.len(), 200 * 150);
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| n == "scene.blob" || n == "out.exr" || n.starts_with(".out.exr.render-tmp-")),
        "{names:?}"
    );
}

fn merge(parts: &[&Path], out: &Path) -> std::process::Output {
    merge_with(parts, out, &[])
}

fn merge_with(parts: &[&Path], out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["merge".to_string()];
    args.extend(extra.iter().map(|s| s.to_string()));
    args.extend(parts.iter().map(|p| p.to_str().unwrap().to_string()));
    args.extend(["-o".to_string(), out.to_str().unwrap().to_string()]);
    Command::new(env!("CARGO_BIN_EXE_render")).args(&args).output().unwrap()
}

/// Beauty R of every pixel of an EXR.
fn red(path: &Path) -> Vec<f32> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let r = image.layer_data[0].channel_data.list.iter().find(|c| c.name.to_string() == "R").unwrap();
    (0..r.sample_data.len()).map(|i| r.sample_data.value_by_flat_index(i).to_f32()).collect()
}

#[test]
fn four_tiles_merge_to_the_single_process_render_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    for integrator in ["scalar", "wavefront"] {
        let whole = dir.path().join("whole.exr");
        assert!(render(&blob, &whole, &["--spp", "6", "--integrator", integrator]).status.success());
        let parts: Vec<PathBuf> = (0..4).map(|i| dir.path().join(format!("tile{i}.exr"))).collect();
        for (i, part) in parts.iter().enumerate() {
            let tile = format!("{i}/4");
            let run = render(&blob, part, &["--spp", "6", "--tile", &tile, "--integrator", integrator]);
            assert!(run.status.success(), "{}", stderr(&run));
        }
        let merged = dir.path().join("merged.exr");
        let refs: Vec<&Path> = parts.iter().map(PathBuf::as_path).collect();
        let run = merge(&refs, &merged);
        assert!(run.status.success(), "{}", stderr(&run));
        assert!(
            stderr(&run).contains("4 parts, samples 0..6, pixels 40x30 of the 40x30 frame"),
            "{}",
            stderr(&run)
        );
        assert!(
            std::fs::read(&merged).unwrap() == std::fs::read(&whole).unwrap(),
            "{integrator}: merged differs"
        );
    }
}

#[test]
fn a_sample_split_merges_to_the_single_process_render_within_rounding() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    let whole = dir.path().join("whole.exr");
    assert!(render(&blob, &whole, &["--spp", "16"]).status.success());
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    assert!(render(&blob, &a, &["--sample-range", "0..8"]).status.success());
    assert!(render(&blob, &b, &["--sample-range", "8..16"]).status.success());
    let merged = dir.path().join("merged.exr");
    let run = merge(&[&b, &a], &merged);
    assert!(run.status.success(), "{}", stderr(&run));
    let (m, w) = (red(&merged), red(&whole));
    assert_eq!(m.len(), 40 * 30);
    let worst = m.iter().zip(&w).map(|(m, w)| ((m - w) / w.max(1e-3)).abs()).fold(0.0f32, f32::max);
    assert!(worst <= 1e-5, "largest relative difference {worst}");
    let half = red(&a);
    assert!(half.iter().zip(&w).any(|(h, w)| h != w), "a slice alone is a noisier image");
}

#[test]
fn merges_refuse_gaps_overlaps_other_blobs_and_broken_parts() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    let part = |name: &str, extra: &[&str]| {
        let path = dir.path().join(name);
        let run = render(&blob, &path, extra);
        assert!(run.status.success(), "{}", stderr(&run));
        path
    };
    let t0 = part("t0.exr", &["--spp", "4", "--tile", "0/3"]);
    let t1 = part("t1.exr", &["--spp", "4", "--tile", "1/3"]);
    let out = dir.path().join("out.exr");
    let missing = merge(&[&t0, &t1], &out);
    assert!(!missing.status.success());
    assert!(stderr(&missing).contains("no part holds pixel (0, 20) of samples 0..4"), "{}", stderr(&missing));
    let overlap = merge(&[&t0, &t1, &t0], &out);
    assert!(stderr(&overlap).contains("overlaps"), "{}", stderr(&overlap));
    let s0 = part("s0.exr", &["--sample-range", "0..4"]);
    let s2 = part("s2.exr", &["--sample-range", "8..12"]);
    let gap = merge(&[&s0, &s2], &out);
    assert!(stderr(&gap).contains("sample ranges 0..4 and 8..12 leave a gap"), "{}", stderr(&gap));
    let other_blob = blob_named(dir.path(), "other.blob", 0.8);
    let foreign = dir.path().join("foreign.exr");
    assert!(render(&other_blob, &foreign, &["--spp", "4", "--tile", "2/3"]).status.success());
    let t2 = part("t2.exr", &["--spp", "4", "--tile", "2/3"]);
    let wrong = merge(&[&t0, &t1, &foreign], &out);
    assert!(stderr(&wrong).contains("foreign.exr: rendered from blob"), "{}", stderr(&wrong));
    let bytes = std::fs::read(&t2).unwrap();
    let truncated = dir.path().join("truncated.exr");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let broken = merge(&[&t0, &t1, &truncated], &out);
    assert!(!broken.status.success());
    assert!(stderr(&broken).contains("truncated.exr"), "{}", stderr(&broken));
    assert!(!out.exists(), "no output from a failed merge");
    assert!(merge(&[&t0, &t1, &t2], &out).status.success(), "the three tiles merge");
}

#[test]
fn farm_dry_runs_print_the_jobs_and_resubmit_only_missing_units() {
    let dir = tempfile::tempdir().unwrap();
    let blob = blob(dir.path());
    let out = dir.path().join("beauty.exr");
    let dry = || {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/farm.sh");
        let run = Command::new("bash")
            .arg(script)
            .args(["--render", env!("CARGO_BIN_EXE_render"), "--dry-run", "--tiles", "3", "--cpus", "2"])
            .args([blob.to_str().unwrap(), "-o", out.to_str().unwrap(), "--spp", "8"])
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", stderr(&run));
        String::from_utf8(run.stdout).unwrap()
    };
    let all = dry();
    assert!(all.contains("--array=0,1,2 --cpus-per-task=2"), "{all}");
    assert!(all.contains("1) unit=\"--tile 1/3\""), "{all}");
    assert!(all.contains("--dependency=afterok:ARRAY --kill-on-invalid-dep=yes"), "{all}");
    assert!(all.contains("--dependency=afternotok:ARRAY"), "{all}");
    // Part 1 already rendered: only 0 and 2 are submitted again.
    let parts = dir.path().join("beauty.exr.parts");
    let run = render(&blob, &parts.join("part-1.exr"), &["--spp", "8", "--tile", "1/3"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let again = dry();
    assert!(again.contains("--array=0,2 "), "{again}");
}

/// Every channel of an EXR's first layer: name and values.
fn channels(path: &Path) -> Vec<(String, Vec<f32>)> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let list = &image.layer_data[0].channel_data.list;
    list.iter()
        .map(|c| {
            let values = (0..c.sample_data.len()).map(|i| c.sample_data.value_by_flat_index(i).to_f32());
            (c.name.to_string(), values.collect())
        })
        .collect()
}

#[test]
fn render_products_resume_to_the_uninterrupted_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let blob = products_blob(dir.path());
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    for integrator in ["scalar", "wavefront"] {
        let whole = a.join("whole.exr");
        let run = render(&blob, &whole, &["--spp", "20", "--integrator", integrator]);
        assert!(run.status.success(), "{}", stderr(&run));
        let part = b.join("part.exr");
        let first = render(&blob, &part, &["--spp", "8", "--checkpoint", "1000", "--integrator", integrator]);
        assert!(first.status.success(), "{}", stderr(&first));
        let resumed = render(&blob, &part, &["--spp", "20", "--resume", "--integrator", integrator]);
        assert!(resumed.status.success(), "{}", stderr(&resumed));
        assert!(!stderr(&resumed).contains("warning"), "{}", stderr(&resumed));
        assert!(std::fs::read(&part).unwrap() == std::fs::read(&whole).unwrap(), "{integrator}: beauty");
        let (x, y) = (std::fs::read(b.join("comp.exr")).unwrap(), std::fs::read(a.join("comp.exr")).unwrap());
        assert!(x == y, "{integrator}: the resumed product differs from the uninterrupted one");
        let names: Vec<String> = channels(&a.join("comp.exr")).into_iter().map(|c| c.0).collect();
        for layer in ["direct.R", "indirect.G", "P.X", "CryptoObject00.R", "CryptoMaterial02.A", "spp"] {
            assert!(names.iter().any(|n| n == layer), "{layer} in {names:?}");
        }
    }
}

#[test]
fn render_products_merge_from_tiles_exactly_and_from_slices_within_rounding() {
    let dir = tempfile::tempdir().unwrap();
    let blob = products_blob(dir.path());
    let b = blob.to_str().unwrap();
    let sub = |name: &str| {
        let d = dir.path().join(name);
        std::fs::create_dir_all(&d).unwrap();
        d
    };
    let (single, tiled, sliced, parts) = (sub("single"), sub("tiled"), sub("sliced"), sub("parts"));
    assert!(render(&blob, &single.join("beauty.exr"), &["--spp", "16"]).status.success());
    let tiles: Vec<PathBuf> = (0..3).map(|i| parts.join(format!("tile{i}.exr"))).collect();
    for (i, t) in tiles.iter().enumerate() {
        let run = render(&blob, t, &["--spp", "16", "--tile", &format!("{i}/3")]);
        assert!(run.status.success(), "{}", stderr(&run));
    }
    assert!(!parts.join("comp.exr").exists(), "a part writes no product of its own");
    let refs: Vec<&Path> = tiles.iter().map(PathBuf::as_path).collect();
    // Without the blob, parts holding product sums are refused, not merged into a beauty alone.
    let refused = merge(&refs, &tiled.join("beauty.exr"));
    assert!(!refused.status.success());
    assert!(stderr(&refused).contains("render merge --blob SCENE.blob"), "{}", stderr(&refused));
    let run = merge_with(&refs, &tiled.join("beauty.exr"), &["--blob", b]);
    assert!(run.status.success(), "{}", stderr(&run));
    for file in ["beauty.exr", "comp.exr"] {
        let (x, y) = (std::fs::read(tiled.join(file)).unwrap(), std::fs::read(single.join(file)).unwrap());
        assert!(x == y, "tiles: {file} differs from the single render");
    }

    let slices = [parts.join("s0.exr"), parts.join("s1.exr"), parts.join("s2.exr")];
    for (s, range) in slices.iter().zip(["0..5", "5..11", "11..16"]) {
        let run = render(&blob, s, &["--sample-range", range]);
        assert!(run.status.success(), "{}", stderr(&run));
    }
    let refs: Vec<&Path> = slices.iter().map(PathBuf::as_path).collect();
    let run = merge_with(&refs, &sliced.join("beauty.exr"), &["--blob", b]);
    assert!(run.status.success(), "{}", stderr(&run));
    let (merged, whole) = (channels(&sliced.join("comp.exr")), channels(&single.join("comp.exr")));
    assert_eq!(
        merged.iter().map(|c| &c.0).collect::<Vec<_>>(),
        whole.iter().map(|c| &c.0).collect::<Vec<_>>()
    );
    for ((name, m), (_, w)) in merged.iter().zip(&whole) {
        if name.starts_with("Crypto") || name == "spp" {
            // Ids and sample counts merge exactly (no pixel here sees more than eight objects).
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(m), bits(w), "{name}");
        } else {
            let worst =
                m.iter().zip(w).map(|(m, w)| ((m - w) / w.abs().max(1e-3)).abs()).fold(0.0f32, f32::max);
            assert!(worst <= 1e-5, "{name}: largest relative difference {worst}");
        }
    }
    // A sliced and a tiled part of a render with products do not mix with a blob of none.
    let other = blob_named(dir.path(), "other.blob", 0.6);
    let wrong = merge_with(&refs, &sliced.join("x.exr"), &["--blob", other.to_str().unwrap()]);
    assert!(stderr(&wrong).contains("was rendered from blob"), "{}", stderr(&wrong));
}

/// Three blobs of a shot, the card higher at each frame: `shot.0001.blob` ... `shot.0003.blob`.
fn shot(dir: &Path) -> Vec<PathBuf> {
    (1..=3).map(|f| blob_named(dir, &format!("shot.{f:04}.blob"), 0.4 + 0.2 * f as f32)).collect()
}

#[test]
fn a_sequence_renders_each_frame_to_its_own_output_as_single_renders_do() {
    let dir = tempfile::tempdir().unwrap();
    let blobs = shot(dir.path());
    let pattern = dir.path().join("shot.####.blob");
    let out = dir.path().join("beauty.#.exr");
    let run = render(
        &pattern,
        &out,
        &["--frames", "1-3", "--spp", "4", "--png", &format!("{}/p.%02d.png", dir.path().display())],
    );
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(stderr(&run).contains("render: frame 2 (2 of 3): "), "{}", stderr(&run));
    let mut images = Vec::new();
    for (i, blob) in blobs.iter().enumerate() {
        let single = dir.path().join(format!("single{i}.exr"));
        assert!(render(blob, &single, &["--spp", "4"]).status.success());
        let framed = std::fs::read(dir.path().join(format!("beauty.{}.exr", i + 1))).unwrap();
        assert!(framed == std::fs::read(&single).unwrap(), "frame {} differs from its single render", i + 1);
        assert!(dir.path().join(format!("p.{:02}.png", i + 1)).exists());
        images.push(framed);
    }
    assert!(images[0] != images[2], "the frames differ");
    // A list of blobs, numbered by their names; a step skips frame 2.
    let listed = Command::new(env!("CARGO_BIN_EXE_render"))
        .args([blobs[2].to_str().unwrap(), blobs[0].to_str().unwrap()])
        .args(["-o", dir.path().join("listed.%04d.exr").to_str().unwrap()])
        .args(["--res", "40x30", "--threads", "2", "--spp", "4"])
        .output()
        .unwrap();
    assert!(listed.status.success(), "{}", stderr(&listed));
    assert!(std::fs::read(dir.path().join("listed.0003.exr")).unwrap() == images[2]);
    assert!(std::fs::read(dir.path().join("listed.0001.exr")).unwrap() == images[0]);
    let stepped = render(&pattern, &dir.path().join("step.#.exr"), &["--frames", "1-3x2", "--spp", "4"]);
    assert!(stepped.status.success(), "{}", stderr(&stepped));
    assert!(!dir.path().join("step.2.exr").exists() && dir.path().join("step.3.exr").exists());
}

#[test]
fn sequences_name_missing_frames_and_refuse_outputs_without_a_frame_field() {
    let dir = tempfile::tempdir().unwrap();
    let blobs = shot(dir.path());
    std::fs::remove_file(&blobs[1]).unwrap();
    let pattern = dir.path().join("shot.####.blob");
    let out = dir.path().join("beauty.#.exr");
    let run = render(&pattern, &out, &["--frames", "1-3", "--spp", "1"]);
    assert!(!run.status.success());
    let missing = format!("1 of 3 frames have no blob: frame 2: {}", blobs[1].display());
    assert!(stderr(&run).contains(&missing), "{}", stderr(&run));
    assert!(!dir.path().join("beauty.1.exr").exists(), "nothing rendered before the check");
    let cases: &[(&[&str], &str)] = &[
        (&["--frames", "3-1"], "frame range \"3-1\": the last frame is before the first"),
        (&["--frames", "1-3x0"], "the step must be at least 1"),
    ];
    for (extra, expected) in cases {
        let run = render(&pattern, &out, extra);
        assert!(!run.status.success() && stderr(&run).contains(expected), "{extra:?}: {}", stderr(&run));
    }
    let plain = render(&pattern, &dir.path().join("beauty.exr"), &["--frames", "1-3"]);
    assert!(stderr(&plain).contains("has no frame field"), "{}", stderr(&plain));
    let unnumbered = blob_named(dir.path(), "plain.blob", 0.5);
    let run = Command::new(env!("CARGO_BIN_EXE_render"))
        .args([blobs[0].to_str().unwrap(), unnumbered.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(stderr(&run).contains("plain.blob: no frame number in the file name"), "{}", stderr(&run));
    let frames = Command::new(env!("CARGO_BIN_EXE_render"))
        .args(["frames", "--frames", "8-12x2", "s.####.blob", "b.%d.exr"])
        .output()
        .unwrap();
    assert!(frames.status.success(), "{}", stderr(&frames));
    assert_eq!(
        String::from_utf8(frames.stdout).unwrap(),
        "8\ts.0008.blob\tb.8.exr\n10\ts.0010.blob\tb.10.exr\n12\ts.0012.blob\tb.12.exr\n"
    );
}

#[test]
fn farm_dry_runs_of_a_sequence_make_frames_units_and_resubmit_only_missing_frames() {
    let dir = tempfile::tempdir().unwrap();
    let blobs = shot(dir.path());
    let pattern = dir.path().join("shot.####.blob");
    let out = dir.path().join("beauty.####.exr");
    let farm = |extra: &[&str]| {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/farm.sh");
        Command::new("bash")
            .arg(script)
            .args(["--render", env!("CARGO_BIN_EXE_render"), "--dry-run"])
            .args(extra)
            .args([pattern.to_str().unwrap(), "-o", out.to_str().unwrap(), "--spp", "4"])
            .output()
            .unwrap()
    };
    let stdout = |o: &std::process::Output| String::from_utf8_lossy(&o.stdout).into_owned();
    // Two tiles per frame: six units, and a merge per frame.
    let run = farm(&["--frames", "1-3", "--tiles", "2"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let all = stdout(&run);
    assert!(all.contains("farm: 3 frames (1-3) x 2 units per frame"), "{all}");
    assert!(all.contains("farm: units 0,1,2,3,4,5 of 6"), "{all}");
    let frame2 = dir.path().join("beauty.0002.exr");
    let part = format!(
        "3) unit=\"--tile 1/2\" blob={} out={}.parts/part-1.exr",
        blobs[1].display(),
        frame2.display()
    );
    assert!(all.contains(&part), "{all}");
    assert!(all.contains("sbatch --array=0,1,2 --dependency=afterok:ARRAY"), "{all}");
    // Frame 2 is done: only frames 1 and 3 are submitted and merged.
    assert!(render(&blobs[1], &frame2, &["--spp", "4"]).status.success());
    let again = stdout(&farm(&["--frames", "1-3", "--tiles", "2"]));
    assert!(again.contains("farm: frame 2 (done)") && again.contains("farm: units 0,1,4,5 of 6"), "{again}");
    assert!(again.contains("sbatch --array=0,2 --dependency=afterok:ARRAY"), "{again}");
    // Unsplit frames render straight to their outputs: one unit each, no merge.
    let whole = stdout(&farm(&["--frames", "1-3"]));
    assert!(whole.contains("farm: units 0,2 of 3") && !whole.contains("merge.sh\n"), "{whole}");
    let unit = format!(
        "2) unit=\"\" blob={} out={}",
        blobs[2].display(),
        dir.path().join("beauty.0003.exr").display()
    );
    assert!(whole.contains(&unit), "{whole}");
    // A missing blob is named; a bad range is refused.
    std::fs::remove_file(&blobs[0]).unwrap();
    let run = farm(&["--frames", "1-3"]);
    assert!(!run.status.success());
    assert!(
        stderr(&run).contains(&format!("1 of 3 frames have no blob: frame 1: {}", blobs[0].display())),
        "{}",
        stderr(&run)
    );
    let run = farm(&["--frames", "3-1"]);
    assert!(
        !run.status.success() && stderr(&run).contains("the last frame is before the first"),
        "{}",
        stderr(&run)
    );
}

/// The farm on a real Slurm cluster (`scripts/slurm-local.sh start`, which the README's test command
/// runs): only with `FARM_SLURM=1`, since it submits jobs.
mod slurm {
    use super::*;
    use std::time::{Duration, Instant};

    fn enabled() -> bool {
        let on = std::env::var_os("FARM_SLURM").is_some();
        if !on {
            eprintln!("skipped: FARM_SLURM is unset (scripts/test.sh sets it once Slurm is up)");
        }
        on
    }

    /// `scripts/farm.sh ARGS` with this build's render; its stdout.
    fn farm(args: &[&str]) -> String {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/farm.sh");
        let out = Command::new("bash")
            .arg(script)
            .args(["--render", env!("CARGO_BIN_EXE_render")])
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "farm.sh: {}", stderr(&out));
        String::from_utf8(out.stdout).unwrap()
    }

    /// Waits until `path` exists and no job of ours is queued or running (two minutes at most).
    fn wait_for(path: &Path) {
        let start = Instant::now();
        loop {
            let queue = Command::new("squeue").args(["-h", "-o", "%i"]).output().unwrap();
            if path.exists() && queue.stdout.is_empty() {
                return;
            }
            assert!(start.elapsed() < Duration::from_secs(120), "no {} after two minutes", path.display());
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    fn array_id(farm_output: &str) -> String {
        let at = farm_output.find("render array ").expect("an array id") + "render array ".len();
        farm_output[at..].split_whitespace().next().unwrap().to_string()
    }

    #[test]
    fn tiles_slices_and_a_cancelled_task_merge_to_the_single_render() {
        if !enabled() {
            return;
        }
        let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
        let blob = blob(dir.path());
        let b = blob.to_str().unwrap();
        let whole = dir.path().join("whole.exr");
        assert!(render(&blob, &whole, &["--spp", "32"]).status.success());

        // Four tiles, one task each: the merge is the single render byte for byte.
        let tiled = dir.path().join("tiled.exr");
        let out = farm(&["--tiles", "4", b, "-o", tiled.to_str().unwrap(), "--res", "40x30", "--spp", "32"]);
        assert!(out.contains("units 0,1,2,3 of 4"), "{out}");
        wait_for(&tiled);
        assert!(std::fs::read(&tiled).unwrap() == std::fs::read(&whole).unwrap(), "tiled merge differs");

        // Two sample slices: equal within the merge's rounding bound.
        let split = dir.path().join("split.exr");
        farm(&["--samples", "2", b, "-o", split.to_str().unwrap(), "--res", "40x30", "--spp", "32"]);
        wait_for(&split);
        let (m, w) = (red(&split), red(&whole));
        let worst = m.iter().zip(&w).map(|(m, w)| ((m - w) / w.max(1e-3)).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-5, "sample split: largest relative difference {worst}");

        // A task cancelled while it runs is resubmitted once; the result is still the single render.
        let big = ["--res", "200x150", "--spp", "256"];
        let reference = dir.path().join("big.exr");
        let run = Command::new(env!("CARGO_BIN_EXE_render"))
            .args([b, "-o", reference.to_str().unwrap(), "--threads", "2"])
            .args(big)
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", stderr(&run));
        let cancelled = dir.path().join("cancelled.exr");
        let out = farm(&[&["--tiles", "2", b, "-o", cancelled.to_str().unwrap()][..], &big].concat());
        let array = array_id(&out);
        let start = Instant::now();
        let running = loop {
            let q =
                Command::new("squeue").args(["-h", "-t", "R", "-j", &array, "-o", "%i"]).output().unwrap();
            let ids = String::from_utf8(q.stdout).unwrap();
            if let Some(id) = ids.split_whitespace().next() {
                break id.to_string();
            }
            assert!(start.elapsed() < Duration::from_secs(60), "no task of array {array} started");
            std::thread::sleep(Duration::from_millis(50));
        };
        assert!(Command::new("scancel").arg(&running).status().unwrap().success());
        wait_for(&cancelled);
        let jobs = dir.path().join("cancelled.exr.parts/jobs");
        let retried = std::fs::read_dir(&jobs)
            .unwrap()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with("retry-"));
        assert!(retried, "the retry job ran after {running} was cancelled");
        assert!(
            std::fs::read(&cancelled).unwrap() == std::fs::read(&reference).unwrap(),
            "retried merge differs"
        );
    }

    #[test]
    fn a_sequence_of_tiled_frames_merges_each_frame_to_its_single_render() {
        if !enabled() {
            return;
        }
        let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
        let blobs = shot(dir.path());
        let pattern = dir.path().join("shot.####.blob");
        let out = dir.path().join("beauty.####.exr");
        let (p, o) = (pattern.to_str().unwrap(), out.to_str().unwrap());
        let run = farm(&["--frames", "1-3", "--tiles", "2", p, "-o", o, "--res", "40x30", "--spp", "8"]);
        assert!(run.contains("units 0,1,2,3,4,5 of 6"), "{run}");
        let last = dir.path().join("beauty.0003.exr");
        wait_for(&last);
        for (i, blob) in blobs.iter().enumerate() {
            let single = dir.path().join(format!("single{i}.exr"));
            assert!(render(blob, &single, &["--spp", "8"]).status.success());
            let framed = dir.path().join(format!("beauty.{:04}.exr", i + 1));
            assert!(
                std::fs::read(&framed).unwrap() == std::fs::read(&single).unwrap(),
                "frame {}: the merged tiles differ from the single render",
                i + 1
            );
        }
        // Everything is there: a rerun submits nothing.
        let again = farm(&["--frames", "1-3", "--tiles", "2", p, "-o", o, "--res", "40x30", "--spp", "8"]);
        assert!(again.contains("farm: all 3 frames are done"), "{again}");
    }
}

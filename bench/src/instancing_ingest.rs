//! `bench instancing`, ingest side: peak resident memory and wall time of the `ingest` binary on a
//! generated stage of many instanceable references and on shared layout assets, instanced against
//! `--flatten-instances` (and against an older `ingest` binary when one is given), each run a fresh
//! process under `/usr/bin/time -v`. The `--dump-json` listings of every run must be identical:
//! instancing changes what is stored, never what is drawn.
//!
//! The default layout assets come from the shared asset library: `$SHARED_ASSETS` if set, else
//! `../shared/assets` beside the workspace (the folder the other benches name from the workspace root).

use anyhow::{bail, Context};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The layout assets measured by default (1,000 subdivided teapots; 1,000 displayColor assets), relative
/// to [`shared_assets`].
pub const LAYOUT_ASSETS: [&str; 2] = [
    "intent_vfx_layout/intent-vfx/scenes/teapotScene_layout.usd",
    "intent_vfx_layout/intent-vfx/scenes/simpleAssetScene.usd",
];

/// The shared asset library: `$SHARED_ASSETS` if set, else `../shared/assets` from the workspace root.
pub fn shared_assets() -> PathBuf {
    match std::env::var_os("SHARED_ASSETS") {
        Some(dir) => PathBuf::from(dir),
        // CARGO_MANIFEST_DIR is `<workspace>/bench`; its grandparent holds `shared/`.
        None => Path::new(env!("CARGO_MANIFEST_DIR"))
            .ancestors()
            .nth(2)
            .unwrap_or(Path::new(".."))
            .join("shared/assets"),
    }
}

/// [`LAYOUT_ASSETS`] in [`shared_assets`]; the error names the first one missing.
pub fn layout_assets() -> anyhow::Result<Vec<PathBuf>> {
    layout_assets_in(&shared_assets())
}

fn layout_assets_in(root: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let found = |name: &&str| {
        let path = root.join(name);
        anyhow::ensure!(
            path.exists(),
            "layout asset {} not found (shared assets are read from $SHARED_ASSETS, else \
             ../shared/assets beside the workspace; --ingest-assets names other stages)",
            path.display()
        );
        Ok(path)
    };
    LAYOUT_ASSETS.iter().map(found).collect()
}

/// A stage of `count` instanceable references to one polygon sphere (`rings × segments` quads) on
/// a 10 × 10 grid of layers, each rotated and scaled differently, without a camera.
pub fn instanced_stage(count: usize, rings: usize, segments: usize) -> String {
    let mut s = String::from(
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n\n",
    );
    s.push_str("class Xform \"Proto\"\n{\n    def Mesh \"Ball\"\n    {\n        uniform token subdivisionScheme = \"none\"\n");
    let (mut points, mut normals) = (Vec::new(), Vec::new());
    for r in 0..=rings {
        let theta = std::f64::consts::PI * r as f64 / rings as f64;
        for k in 0..segments {
            let phi = std::f64::consts::TAU * k as f64 / segments as f64;
            let n = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
            points.push(format!("({:.6}, {:.6}, {:.6})", 0.8 * n[0], 0.8 * n[1], 0.8 * n[2]));
            normals.push(format!("({:.6}, {:.6}, {:.6})", n[0], n[1], n[2]));
        }
    }
    let (mut counts, mut indices) = (Vec::new(), Vec::new());
    for r in 0..rings {
        for k in 0..segments {
            let (a, b) = (r * segments + k, r * segments + (k + 1) % segments);
            let (c, d) = ((r + 1) * segments + (k + 1) % segments, (r + 1) * segments + k);
            counts.push("4".to_string());
            indices.extend([a, b, c, d].map(|i| i.to_string()));
        }
    }
    let _ = writeln!(s, "        int[] faceVertexCounts = [{}]", counts.join(", "));
    let _ = writeln!(s, "        int[] faceVertexIndices = [{}]", indices.join(", "));
    let _ = writeln!(s, "        point3f[] points = [{}]", points.join(", "));
    let _ = writeln!(
        s,
        "        normal3f[] normals = [{}] (\n            interpolation = \"vertex\"\n        )",
        normals.join(", ")
    );
    s.push_str("    }\n}\n\ndef Xform \"World\"\n{\n");
    for i in 0..count {
        let (x, y, z) = ((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64);
        let _ = write!(
            s,
            "    def \"I{i}\" (\n        instanceable = true\n        references = </Proto>\n    )\n    {{\n        \
             double3 xformOp:translate = ({}, {}, {})\n        float xformOp:rotateY = {}\n        \
             float3 xformOp:scale = (1, {}, 1)\n        \
             uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateY\", \"xformOp:scale\"]\n    }}\n",
            2.0 * x - 9.0,
            2.0 * y - 9.0,
            -2.0 * z,
            i * 37 % 360,
            0.7 + 0.05 * (i % 7) as f64,
        );
    }
    s.push_str("}\n");
    s
}

/// One ingest process: peak RSS and wall seconds.
struct Run {
    label: String,
    max_rss_kib: u64,
    wall_seconds: f64,
    blob_bytes: u64,
    dump: Vec<u8>,
}

fn run(label: &str, binary: &Path, input: &Path, extra: &[&str], scratch: &Path) -> anyhow::Result<Run> {
    let blob = scratch.join("run.blob");
    let dump = scratch.join("run.json");
    let output = Command::new("/usr/bin/time")
        .arg("-v")
        .arg(binary)
        .arg(input)
        .arg("-o")
        .arg(&blob)
        .arg("--dump-json")
        .arg(&dump)
        .arg("-q")
        .args(extra)
        .output()
        .context("cannot run /usr/bin/time (GNU time is needed for peak RSS)")?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() {
        bail!("{} {} failed: {stderr}", binary.display(), input.display());
    }
    let field = |name: &str| {
        stderr
            .lines()
            .find_map(|l| l.trim().strip_prefix(name).map(|v| v.trim().to_string()))
            .unwrap_or_default()
    };
    let max_rss_kib = field("Maximum resident set size (kbytes):").parse().unwrap_or(0);
    // "h:mm:ss" or "m:ss.ss".
    let wall = field("Elapsed (wall clock) time (h:mm:ss or m:ss):");
    let wall_seconds = wall.split(':').fold(0.0, |t, part| t * 60.0 + part.parse::<f64>().unwrap_or(0.0));
    Ok(Run {
        label: label.to_string(),
        max_rss_kib,
        wall_seconds,
        blob_bytes: std::fs::metadata(&blob)?.len(),
        dump: std::fs::read(&dump)?,
    })
}

/// Measures every input with the current binary (instanced and flattened) and `baseline` if given;
/// returns the figures as JSON.
pub fn measure(
    count: usize,
    assets: &[PathBuf],
    baseline: Option<&Path>,
    out: &Path,
) -> anyhow::Result<serde_json::Value> {
    let binary = std::env::current_exe()?.with_file_name("ingest");
    if !binary.exists() {
        bail!("{} not found: build it with `cargo build --release -p ingest`", binary.display());
    }
    let scratch = out.join("instancing-ingest");
    std::fs::create_dir_all(&scratch)?;
    let generated = scratch.join(format!("instanced_{count}.usda"));
    std::fs::write(&generated, instanced_stage(count, 12, 24))?;
    let mut inputs = vec![generated];
    for asset in assets {
        anyhow::ensure!(asset.exists(), "ingest asset {} not found", asset.display());
        inputs.push(asset.clone());
    }
    println!(
        "\n{:<28} {:<22} {:>12} {:>9} {:>12}",
        "ingest input", "run", "peak RSS MiB", "wall s", "blob bytes"
    );
    let mut figures = Vec::new();
    for input in &inputs {
        let mut runs = vec![
            run("instanced", &binary, input, &[], &scratch)?,
            run("flattened", &binary, input, &["--flatten-instances"], &scratch)?,
        ];
        if let Some(b) = baseline {
            runs.push(run("baseline", b, input, &[], &scratch)?);
        }
        let name = input.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        for r in &runs {
            println!(
                "{:<28} {:<22} {:>12.1} {:>9.2} {:>12}",
                name,
                r.label,
                r.max_rss_kib as f64 / 1024.0,
                r.wall_seconds,
                r.blob_bytes
            );
        }
        let same_dump = runs.iter().all(|r| r.dump == runs[0].dump);
        if !same_dump {
            bail!(
                "{name}: --dump-json differs between {:?}",
                runs.iter().map(|r| &r.label).collect::<Vec<_>>()
            );
        }
        figures.push(serde_json::json!({
            "input": input.display().to_string(),
            "dump_json_identical": same_dump,
            "runs": runs.iter().map(|r| serde_json::json!({
                "run": r.label,
                "max_rss_kib": r.max_rss_kib,
                "wall_seconds": r.wall_seconds,
                "blob_bytes": r.blob_bytes,
            })).collect::<Vec<_>>(),
        }));
    }
    Ok(serde_json::json!({ "generated_instances": count, "inputs": figures }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_assets_sit_beside_the_workspace() {
        if std::env::var_os("SHARED_ASSETS").is_none() {
            let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
            assert_eq!(shared_assets(), workspace.parent().unwrap().join("shared/assets"));
        }
    }

    #[test]
    fn a_missing_layout_asset_is_an_error_naming_its_path() {
        let root = Path::new("/nonexistent/shared/assets");
        let message = layout_assets_in(root).unwrap_err().to_string();
        assert!(message.contains(&root.join(LAYOUT_ASSETS[0]).display().to_string()), "{message}");
        assert!(message.contains("SHARED_ASSETS"), "{message}");
    }
}

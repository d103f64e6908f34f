//! `bench sequence`: ingest seconds per frame of a 24-frame sequence (`ingest --frames`, the stage
//! composed once, texture bakes and unchanged BVHs shared) against 24 separate `ingest --frame N`
//! runs, side by side in one run, on the bundled tractor with its vehicle sliding along x
//! (time-sampled translate over frames 1–24) under a still camera.
//!
//! Both sides run as fresh processes of the same `ingest` binary, timed around the processes
//! (wall seconds). Every frame's blob of the sequence is checked to equal the single ingest's
//! byte for byte before any figure is written. Figures land in `OUT/sequence.json` and
//! `OUT/sequence.md`.

use anyhow::Context;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The tractor with `/World/Vehicle` translated along x from frame 1 to `frames`.
fn stage(frames: u32) -> String {
    let tractor = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
    format!(
        r#"#usda 1.0
(
    subLayers = [@{}@]
    startTimeCode = 1
    endTimeCode = {frames}
)
over "World"
{{
    over "Vehicle"
    {{
        double3 xformOp:translate:slide.timeSamples = {{ 1: (0, 0, 0), {frames}: (200, 0, 0) }}
        uniform token[] xformOpOrder = ["xformOp:translate:slide"]
    }}
}}
"#,
        tractor.display()
    )
}

fn ingest(binary: &Path, args: &[&str]) -> anyhow::Result<f64> {
    let start = Instant::now();
    let run =
        Command::new(binary).args(args).output().with_context(|| format!("running {}", binary.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    anyhow::ensure!(run.status.success(), "ingest {args:?}: {}", String::from_utf8_lossy(&run.stderr));
    Ok(seconds)
}

/// Runs the comparison over `frames` frames in `out`.
pub fn run(frames: u32, out: &Path) -> anyhow::Result<()> {
    let binary = std::env::current_exe()?.with_file_name("ingest");
    anyhow::ensure!(binary.exists(), "no {} (cargo build --release -p ingest)", binary.display());
    let work = out.join("sequence");
    std::fs::create_dir_all(&work)?;
    let shot = work.join("shot.usda");
    std::fs::write(&shot, stage(frames))?;
    let s = shot.to_str().context("a UTF-8 path")?;
    let pattern = work.join("seq.####.blob");
    let range = format!("1-{frames}");
    let sequence = ingest(&binary, &[s, "--frames", &range, "-o", pattern.to_str().unwrap(), "-q"])?;
    let mut separate = 0.0;
    for frame in 1..=frames {
        let single = work.join(format!("single.{frame}.blob"));
        separate +=
            ingest(&binary, &[s, "--frame", &frame.to_string(), "-o", single.to_str().unwrap(), "-q"])?;
        let (a, b) = (std::fs::read(work.join(format!("seq.{frame:04}.blob")))?, std::fs::read(&single)?);
        anyhow::ensure!(a == b, "frame {frame}: the sequence's blob differs from the single ingest's");
        std::fs::remove_file(&single)?;
    }
    let per = |total: f64| total / frames as f64;
    let ratio = separate / sequence;
    let json = serde_json::json!({
        "scene": "examples/tractor.usda, vehicle translated over the frames",
        "frames": frames,
        "sequence_seconds": sequence,
        "separate_seconds": separate,
        "sequence_seconds_per_frame": per(sequence),
        "separate_seconds_per_frame": per(separate),
        "speedup": ratio,
        "blobs_equal": true,
    });
    std::fs::write(out.join("sequence.json"), serde_json::to_string_pretty(&json)?)?;
    let md = format!(
        "| {frames} frames of the tractor | seconds | seconds per frame |\n|---|---|---|\n| `ingest --frames 1-{frames}` | {sequence:.2} | {:.3} |\n| {frames} × `ingest --frame N` | {separate:.2} | {:.3} |\n\nThe sequence is {ratio:.2}× faster per frame; every blob equal byte for byte.\n",
        per(sequence),
        per(separate)
    );
    std::fs::write(out.join("sequence.md"), &md)?;
    print!("{md}");
    Ok(())
}

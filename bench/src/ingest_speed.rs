//! `bench ingest`: seconds to compose a stage and list what it renders, ours against usd-core, on the
//! same files in one run.
//!
//! Ours: `ingest::usd::load` (compose through openusd, read every gprim, tessellate at
//! `--subdiv-level 0` so no refinement is timed that usd-core does not do) plus the `--dump-json`
//! listing; separately the whole ingest (pack, BVH, textures, blob written). Theirs
//! (bench/usd_compose.py): `Usd.Stage.Open` alone, and open plus the traversal computing the same
//! listing (tests/python/usd_reference.py), each timing in a fresh Python process so usd-core's layer
//! registry cannot serve a second run from memory. Best of `repeat` runs each; the OS file cache is warm
//! for both because each side runs `repeat` times. Wall and CPU seconds are both reported: CPU seconds
//! (all threads of the process) stay meaningful when the machine is busy.

use anyhow::Context;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The shared assets with the largest layer stacks (INVENTORY.md sizes), the default set.
pub const LARGEST_ASSETS: [&str; 3] = [
    "../shared/assets/open_chess_set/full_assets/OpenChessSet/chess_set.usda",
    "../shared/assets/standard_shader_ball/full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
    "../shared/assets/teapot/full_assets/Teapot/DrawModes.usd",
];

/// Wall and CPU seconds of one timed step.
#[derive(Clone, Copy, Debug)]
struct Seconds {
    wall: f64,
    cpu: f64,
}

impl Seconds {
    const WORST: Seconds = Seconds { wall: f64::INFINITY, cpu: f64::INFINITY };

    fn best(self, other: Seconds) -> Seconds {
        Seconds { wall: self.wall.min(other.wall), cpu: self.cpu.min(other.cpu) }
    }

    fn json(self) -> serde_json::Value {
        serde_json::json!({"wall": self.wall, "cpu": self.cpu})
    }
}

/// CPU seconds used by this process so far, all threads.
pub(crate) fn process_cpu_seconds() -> f64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `t` is a valid, writable timespec and the clock id is a constant Linux supports.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) };
    if status != 0 {
        return f64::NAN;
    }
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, Seconds) {
    let (wall, cpu) = (Instant::now(), process_cpu_seconds());
    let value = f();
    (value, Seconds { wall: wall.elapsed().as_secs_f64(), cpu: process_cpu_seconds() - cpu })
}

/// Our timings for one asset, best of the runs.
struct Ours {
    compose: Seconds,
    /// Wall seconds of `compose` minus texture baking and subdivision (which usd-core's listing
    /// does not do): composing, reading and triangulating alone.
    compose_only_wall: f64,
    ingest: Seconds,
    gprims: usize,
}

fn options() -> ingest::usd::LoadOptions {
    let mut options = ingest::usd::LoadOptions { lenient: true, ..Default::default() };
    options.subdiv.forced_level = Some(0);
    options
}

fn time_ours(asset: &Path, repeat: usize, work: &Path) -> anyhow::Result<Ours> {
    let options = options();
    let mut best =
        Ours { compose: Seconds::WORST, compose_only_wall: f64::INFINITY, ingest: Seconds::WORST, gprims: 0 };
    for _ in 0..repeat.max(1) {
        let (loaded, seconds) = timed(|| {
            ingest::usd::load(asset, &options)
                .map(|scene| (ingest::pipeline::dump_json(&scene), scene.load_timings))
        });
        let (listing, phases) = loaded.with_context(|| format!("{}", asset.display()))?;
        best.compose = best.compose.best(seconds);
        let heavy = phases.texture_seconds + phases.subdivision_seconds;
        best.compose_only_wall = best.compose_only_wall.min(seconds.wall - heavy);
        best.gprims = listing["gprims"].as_array().map_or(0, |g| g.len());
        let (done, seconds) =
            timed(|| ingest::pipeline::ingest_file(asset, &work.join("ingest_speed.blob"), &options));
        done?;
        best.ingest = best.ingest.best(seconds);
    }
    Ok(best)
}

/// usd-core's best timing of `mode` on `asset`, one fresh process per run; with its gprim count.
fn time_theirs(python: &Path, asset: &Path, mode: &str, repeat: usize) -> anyhow::Result<(Seconds, u64)> {
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("usd_compose.py");
    let mut best = Seconds::WORST;
    let mut gprims = 0;
    for _ in 0..repeat.max(1) {
        let run = Command::new(python)
            .arg(&script)
            .arg(asset)
            .args(["--mode", mode])
            .output()
            .with_context(|| format!("cannot run {} (scripts/setup.sh makes .venv)", python.display()))?;
        anyhow::ensure!(
            run.status.success(),
            "usd-core side failed: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&run.stdout)?;
        let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
        best = best.best(Seconds { wall: f("wall_seconds"), cpu: f("cpu_seconds") });
        gprims = v["gprims"].as_u64().unwrap_or(gprims);
    }
    Ok((best, gprims))
}

/// Runs both sides on `assets` and writes `out/ingest_speed.json`.
pub fn run(assets: &[PathBuf], python: &Path, repeat: usize, out: &Path) -> anyhow::Result<()> {
    println!(
        "{:<34} {:>6} {:>6} {:>13} {:>9} {:>13} {:>13} {:>13} {:>9} {:>9} {:>9}",
        "asset (wall/CPU s)",
        "ours",
        "usd",
        "ours list",
        "compose",
        "ours ingest",
        "usd open",
        "usd list",
        "list/us",
        "open/us",
        "comp/us"
    );
    let mut rows = Vec::new();
    for asset in assets {
        let ours = time_ours(asset, repeat, out)?;
        let (open, _) = time_theirs(python, asset, "open", repeat)?;
        let (listing, usd_gprims) = time_theirs(python, asset, "listing", repeat)?;
        let name = asset.file_name().map_or(String::new(), |n| n.to_string_lossy().to_string());
        let pair = |s: Seconds| format!("{:.3}/{:.3}", s.wall, s.cpu);
        // Ratios from CPU seconds: robust to other load on the machine.
        let list_ratio = listing.cpu / ours.compose.cpu;
        let open_ratio = open.cpu / ours.compose.cpu;
        // Composition alone, wall clock (the phases it excludes are timed in wall seconds).
        let compose_ratio = listing.wall / ours.compose_only_wall;
        println!(
            "{:<34} {:>6} {:>6} {:>13} {:>9.3} {:>13} {:>13} {:>13} {:>9.2} {:>9.2} {:>9.2}",
            name,
            ours.gprims,
            usd_gprims,
            pair(ours.compose),
            ours.compose_only_wall,
            pair(ours.ingest),
            pair(open),
            pair(listing),
            list_ratio,
            open_ratio,
            compose_ratio,
        );
        rows.push(serde_json::json!({
            "asset": asset,
            "ours_gprims": ours.gprims,
            "usd_gprims": usd_gprims,
            "ours_compose_and_list": ours.compose.json(),
            "ours_compose_and_list_without_textures_and_subdivision_wall": ours.compose_only_wall,
            "wall_ratio_usd_list_over_ours_compose_only": compose_ratio,
            "ours_full_ingest": ours.ingest.json(),
            "usd_open": open.json(),
            "usd_open_and_list": listing.json(),
            "cpu_ratio_usd_list_over_ours": list_ratio,
            "cpu_ratio_usd_open_over_ours": open_ratio,
        }));
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let result = serde_json::json!({"repeat": repeat, "loadavg": load.trim(), "assets": rows});
    let file = out.join("ingest_speed.json");
    std::fs::write(&file, serde_json::to_string_pretty(&result)?)?;
    println!(
        "list/us, open/us: usd-core CPU seconds over ours (> 1: ours faster); comp/us: usd-core listing wall \
         seconds over ours without texture baking and subdivision; figures in {}",
        file.display()
    );
    Ok(())
}

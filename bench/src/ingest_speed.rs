//! `bench ingest`: seconds to compose a stage and list what it renders, ours against usd-core, on the
//! same files in one run.
//!
//! Both sides are timed the same way: one fresh process per run, best of `repeat`, wall and CPU
//! seconds (CPU: user + system of the process, all threads; it stays meaningful when the machine
//! is busy). Theirs (bench/usd_compose.py): `Usd.Stage.Open` alone, and open plus the traversal
//! computing the `--dump-json` listing (tests/python/usd_reference.py: instance proxies, world
//! bounds of the points, triangle counts, bound materials), timed inside the Python process (its
//! interpreter start and `import pxr` are not counted). Ours: `ingest ASSET --dump-json F` (no
//! `-o`: compose, read every gprim, list; no texture baked, no blob), timed around the whole
//! process (start-up and writing the listing counted), with `--subdiv-level 0`; usd-core's
//! listing counts the subdivision cages' faces and evaluates no limit surface, so ours is also
//! reported without the subdivision phase (in-process, wall seconds). Beside them, ours as a
//! whole: `ingest ASSET -o BLOB` (textures baked, BVH built, blob written). Each side runs
//! `repeat` times, so the OS file cache is warm for both.

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

/// User plus system CPU seconds of every child process waited for so far.
fn children_cpu_seconds() -> f64 {
    // SAFETY: an all-zero rusage is a valid value of this plain C struct.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `usage` is a valid, writable rusage and RUSAGE_CHILDREN a constant Linux supports.
    if unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) } != 0 {
        return f64::NAN;
    }
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    seconds(usage.ru_utime) + seconds(usage.ru_stime)
}

/// Runs `command` to completion; its wall and CPU seconds.
fn timed_process(command: &mut Command) -> anyhow::Result<Seconds> {
    let (wall, cpu) = (Instant::now(), children_cpu_seconds());
    let run = command.output().with_context(|| format!("cannot run {command:?}"))?;
    let seconds = Seconds { wall: wall.elapsed().as_secs_f64(), cpu: children_cpu_seconds() - cpu };
    anyhow::ensure!(run.status.success(), "{command:?} failed: {}", String::from_utf8_lossy(&run.stderr));
    Ok(seconds)
}

/// Our timings for one asset, best of the runs.
struct Ours {
    /// `ingest --dump-json` without `-o`, a fresh process.
    listing: Seconds,
    /// Wall seconds of composing, reading and listing in this process, without subdivision.
    compose_only_wall: f64,
    /// `ingest -o`, a fresh process.
    ingest: Seconds,
    gprims: usize,
}

/// The `ingest` binary built beside this one.
fn ingest_binary() -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe()?.with_file_name("ingest");
    anyhow::ensure!(exe.exists(), "{} not found: cargo build --release -p ingest", exe.display());
    Ok(exe)
}

fn time_ours(asset: &Path, repeat: usize, work: &Path) -> anyhow::Result<Ours> {
    let ingest = ingest_binary()?;
    let listing_file = work.join("ingest_speed_listing.json");
    let common = ["--subdiv-level", "0", "--lenient", "-q"];
    let mut options = ingest::usd::LoadOptions { lenient: true, bake_textures: false, ..Default::default() };
    options.subdiv.forced_level = Some(0);
    let mut best =
        Ours { listing: Seconds::WORST, compose_only_wall: f64::INFINITY, ingest: Seconds::WORST, gprims: 0 };
    for _ in 0..repeat.max(1) {
        let listing = timed_process(
            Command::new(&ingest).arg(asset).arg("--dump-json").arg(&listing_file).args(common),
        )?;
        best.listing = best.listing.best(listing);
        let listed: serde_json::Value = serde_json::from_slice(&std::fs::read(&listing_file)?)?;
        best.gprims = listed["gprims"].as_array().map_or(0, |g| g.len());
        let wall = Instant::now();
        let scene = ingest::usd::load(asset, &options).with_context(|| format!("{}", asset.display()))?;
        let _ = ingest::pipeline::dump_json(&scene);
        let compose_only = wall.elapsed().as_secs_f64() - scene.load_timings.subdivision_seconds;
        best.compose_only_wall = best.compose_only_wall.min(compose_only);
        let full = timed_process(
            Command::new(&ingest).arg(asset).arg("-o").arg(work.join("ingest_speed.blob")).args(common),
        )?;
        best.ingest = best.ingest.best(full);
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

/// Runs both sides on `assets` and writes `OUT/ingest_speed.json`.
pub fn run(assets: &[PathBuf], python: &Path, repeat: usize, out: &Path) -> anyhow::Result<()> {
    println!(
        "{:<32} {:>5} {:>5} {:>13} {:>13} {:>13} {:>9} {:>13} {:>8} {:>8} {:>8}",
        "asset (wall/CPU s)",
        "ours",
        "usd",
        "ours list",
        "usd list",
        "usd open",
        "ours cmp",
        "ours ingest",
        "wall x",
        "CPU x",
        "cmp x"
    );
    let mut rows = Vec::new();
    for asset in assets {
        let ours = time_ours(asset, repeat, out)?;
        let (open, _) = time_theirs(python, asset, "open", repeat)?;
        let (listing, usd_gprims) = time_theirs(python, asset, "listing", repeat)?;
        let name = asset.file_name().map_or(String::new(), |n| n.to_string_lossy().to_string());
        let pair = |s: Seconds| format!("{:.3}/{:.3}", s.wall, s.cpu);
        let wall_ratio = listing.wall / ours.listing.wall;
        let cpu_ratio = listing.cpu / ours.listing.cpu;
        let compose_ratio = listing.wall / ours.compose_only_wall;
        println!(
            "{:<32} {:>5} {:>5} {:>13} {:>13} {:>13} {:>9.3} {:>13} {:>8.2} {:>8.2} {:>8.2}",
            name,
            ours.gprims,
            usd_gprims,
            pair(ours.listing),
            pair(listing),
            pair(open),
            ours.compose_only_wall,
            pair(ours.ingest),
            wall_ratio,
            cpu_ratio,
            compose_ratio,
        );
        rows.push(serde_json::json!({
            "asset": asset,
            "ours_gprims": ours.gprims,
            "usd_gprims": usd_gprims,
            "ours_list": ours.listing.json(),
            "usd_open_and_list": listing.json(),
            "usd_open": open.json(),
            "wall_ratio_usd_list_over_ours_list": wall_ratio,
            "cpu_ratio_usd_list_over_ours_list": cpu_ratio,
            "ours_compose_and_list_without_subdivision_wall": ours.compose_only_wall,
            "wall_ratio_usd_list_over_ours_without_subdivision": compose_ratio,
            "ours_full_ingest": ours.ingest.json(),
        }));
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let result = serde_json::json!({"repeat": repeat, "loadavg": load.trim(), "assets": rows});
    let file = out.join("ingest_speed.json");
    std::fs::write(&file, serde_json::to_string_pretty(&result)?)?;
    println!(
        "ours list: `ingest --dump-json` (no -o), a fresh process; usd list: Stage.Open + the same listing; \
         wall x, CPU x: usd list over ours list (> 1: ours faster); ours cmp: ours without subdivision \
         (wall, in-process), cmp x: usd list wall over it; ours ingest: the whole `ingest -o`; figures in {}",
        file.display()
    );
    Ok(())
}

//! The bench harness. Speed is measured here, side by side in one run, never asserted in a test.
//!
//! - `bench rays BLOB`: primary and incoherent closest-hit rays through our BVH and through Embree
//!   (embreex) on the same triangles, 1 and 2 threads, with the ratio and how often the two agree.
//! - `bench convergence BLOB`: RMSE against a high-spp reference versus render seconds for spp = 1…256,
//!   charted as SVG.
//! - `bench subdiv`: subdivision tessellation error (pixels at the render camera) against ingest
//!   seconds and blob bytes, for uniform levels and dicing rates, charted as SVG.
//! - `bench integrators [BLOB…]`: the scalar and wavefront integrators side by side (default scenes: the
//!   tractor, a generated shading-heavy scene, its material-heavy variant, a simple one): speed, phase
//!   breakdown, SIMD lane use, image difference; table, JSON and stacked-bar SVG.
//!
//! - `bench instancing`: 1,000 instanced spheres as one prototype plus instance records versus
//!   flattened: blob bytes and closest-hit Mrays/s on the same rays; then peak RSS and wall time of
//!   the `ingest` binary on a generated 10,000-instance stage and the layout assets, instanced
//!   versus `--flatten-instances` (and versus `--baseline BIN`).
//!
//! - `bench curves`: a generated groom; curve-intersection throughput and image error against segments per
//!   curve, fixed versus camera-adaptive splitting, charted as SVG.
//!
//! - `bench sequence [--frames N]`: ingest seconds per frame of an N-frame sequence against N
//!   separate ingests, side by side in one run (`sequence.json`, `sequence.md`).
//! - `bench ingest [ASSETS]`: seconds to compose a stage and list its gprims, ours against usd-core
//!   (`Usd.Stage.Open` + the same listing) on the same files, default the three largest shared assets.
//!
//! - `bench peers-table PEERS.json`: from `scripts/bench-peers.sh`'s sweeps of ours, Cycles and Mitsuba 3,
//!   the time each renderer needs to reach one RMSE (markdown) and RMSE against seconds (SVG).
//!
//! - `bench perf-record`: the generated part of `docs/perf.md` from the figures above in `out/bench/`.
//!
//! Figures go to stdout and to a JSON file.

mod adaptive;
mod convergence;
mod curves;
mod ingest_speed;
mod instancing;
mod instancing_ingest;
mod integrators;
mod peers_table;
mod perf_record;
mod rays;
mod sequence;
mod subdiv;
mod textures;

use anyhow::Context;
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::Command;

#[derive(Parser)]
#[command(about)]
struct Args {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Texture filters: RMSE against a supersampled reference versus render time, and lookups/s.
    Textures {
        /// Reference samples per pixel.
        #[arg(long, default_value_t = 1024)]
        reference_spp: u32,
        /// Samples per pixel of each filter's render.
        #[arg(long, default_value_t = 4)]
        spp: u32,
        /// Image width (height is two thirds).
        #[arg(long, default_value_t = 240)]
        width: u32,
        /// Work folder for the chart and results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Scalar against wavefront integrator side by side: speed, phase breakdown, lane use, chart.
    Integrators {
        /// Scene blobs (default: the tractor, a generated shading-heavy scene, its material-heavy variant
        /// and a simple one).
        blobs: Vec<PathBuf>,
        /// Samples per pixel.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Image width (height from the camera).
        #[arg(long, default_value_t = 320)]
        width: u32,
        /// Worker threads (0: one per core).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Best of this many timings.
        #[arg(long, default_value_t = 2)]
        repeat: usize,
        /// Work folder for the results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Ray throughput: ours against Embree on the same rays.
    Rays {
        /// Scene blob.
        blob: PathBuf,
        /// Primary rays: res × res.
        #[arg(long, default_value_t = 512)]
        res: u32,
        /// Incoherent (cosine-bounce) rays.
        #[arg(long, default_value_t = 1_000_000)]
        rays: usize,
        /// Best of this many timings.
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Python with embreex and numpy (skip Embree when absent).
        #[arg(long, default_value = ".venv/bin/python")]
        python: PathBuf,
        /// Work folder for the ray files and results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Adaptive against uniform sampling: time to equal RMSE against a reference, chart.
    Adaptive {
        /// Scene blob.
        blob: PathBuf,
        /// Reference samples per pixel (the sweeps go to a quarter of it).
        #[arg(long, default_value_t = 1024)]
        reference_spp: u32,
        /// Image width (height from the camera).
        #[arg(long, default_value_t = 192)]
        width: u32,
        /// Work folder for the chart and results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Error against time: RMSE versus render seconds for spp = 1…256.
    Convergence {
        /// Scene blob.
        blob: PathBuf,
        /// Reference samples per pixel.
        #[arg(long, default_value_t = 1024)]
        reference_spp: u32,
        /// Largest spp of the sweep (powers of two from 1).
        #[arg(long, default_value_t = 256)]
        max_spp: u32,
        /// Image width (height from the camera).
        #[arg(long, default_value_t = 192)]
        width: u32,
        /// Work folder for the chart and results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Ingest seconds per frame: a frame sequence (`ingest --frames`) against one ingest per frame.
    Sequence {
        /// Frames of the sequence.
        #[arg(long, default_value_t = 24)]
        frames: u32,
        /// Work folder for the blobs and results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Subdivision: chordal error in pixels against ingest seconds and blob bytes.
    Subdiv {
        /// NAME=ROOT_LAYER[@MAX_LEVEL[/FORCED_MAX]]: the level cap of dicing and the highest forced
        /// uniform level run (repeatable; default: the teapot to level 5 and the chess set capped
        /// at 2, forced levels to 1, from ../shared/assets).
        #[arg(long = "asset", value_name = "NAME=PATH[@MAX[/FORCED]]")]
        assets: Vec<String>,
        /// Work folder for the chart and results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Instancing: blob bytes and Mrays/s of 1,000 instanced spheres, two-level versus flattened.
    Instancing {
        /// Instances.
        #[arg(long, default_value_t = 1000)]
        count: usize,
        /// Sphere rings (triangles per sphere: 2 × rings × segments).
        #[arg(long, default_value_t = 16)]
        rings: u32,
        /// Sphere segments.
        #[arg(long, default_value_t = 32)]
        segments: u32,
        /// Primary rays: res × res.
        #[arg(long, default_value_t = 512)]
        res: u32,
        /// Incoherent (cosine-bounce) rays.
        #[arg(long, default_value_t = 300_000)]
        rays: usize,
        /// Best of this many timings.
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Instances of the generated stage whose ingest is measured (0: skip the ingest runs).
        #[arg(long, default_value_t = 10_000)]
        ingest_instances: usize,
        /// Stages whose ingest is measured as well (default: teapotScene_layout, simpleAssetScene from
        /// $SHARED_ASSETS, else ../shared/assets beside the workspace).
        #[arg(long)]
        ingest_assets: Vec<PathBuf>,
        /// An older `ingest` binary to measure against.
        #[arg(long)]
        baseline: Option<PathBuf>,
        /// Work folder for the results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Curves: throughput and image error against segments per curve, adaptive versus fixed splitting.
    Curves {
        /// Strands of the generated groom.
        #[arg(long, default_value_t = 100_000)]
        strands: usize,
        /// Image size (square).
        #[arg(long, default_value_t = 256)]
        res: u32,
        /// Work folder for the chart and results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
    /// Peers: time to reach an RMSE (markdown) and RMSE vs seconds (SVG) from bench-peers.sh's peers.json.
    PeersTable {
        /// The JSON written by scripts/bench-peers.sh.
        json: PathBuf,
        /// Renderer whose RMSE at --target-spp is the target.
        #[arg(long, default_value = "mitsuba_llvm_ad_rgb")]
        target_renderer: String,
        /// Samples per pixel of the target renderer's point.
        #[arg(long, default_value_t = 16)]
        target_spp: u32,
        /// Folder for peers.md and peers.svg.
        #[arg(long, default_value = "out/bench/peers")]
        out: PathBuf,
    },
    /// Perf record: rewrite the generated part of docs/perf.md from the figures in out/bench/.
    PerfRecord {
        /// Folder the other subcommands wrote their figures to.
        #[arg(long, default_value = "out/bench")]
        bench: PathBuf,
        /// The record whose generated part (between its markers) is replaced.
        #[arg(long, default_value = "docs/perf.md")]
        doc: PathBuf,
    },
    /// Ingest speed: compose and list a stage, ours against usd-core on the same files.
    Ingest {
        /// Root layers (default: the three largest shared assets).
        assets: Vec<PathBuf>,
        /// Python with usd-core.
        #[arg(long, default_value = ".venv/bin/python")]
        python: PathBuf,
        /// Best of this many timings.
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Work folder for the results.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
    },
}

/// Parses `NAME=PATH[@MAX_LEVEL[/FORCED_MAX]]`.
fn subdiv_asset(spec: &str) -> anyhow::Result<subdiv::Asset> {
    let (name, rest) = spec.split_once('=').context("expected NAME=PATH[@MAX_LEVEL[/FORCED_MAX]]")?;
    let (path, max_level, forced_max) = match rest.rsplit_once('@') {
        Some((path, max)) => match max.split_once('/') {
            Some((max, forced)) => {
                (path, max.parse().context("MAX_LEVEL")?, forced.parse().context("FORCED_MAX")?)
            }
            None => (path, max.parse().context("MAX_LEVEL")?, max.parse().context("MAX_LEVEL")?),
        },
        None => (rest, 5, 5),
    };
    Ok(subdiv::Asset { name: name.into(), path: path.into(), max_level, forced_max })
}

fn load(path: &PathBuf) -> anyhow::Result<blob::AlignedBytes> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(blob::AlignedBytes::copy_from(&bytes))
}

fn main() -> anyhow::Result<()> {
    match Args::parse().command {
        Cmd::Textures { reference_spp, spp, width, out } => {
            std::fs::create_dir_all(&out)?;
            textures::run(reference_spp, spp, width, &out)?;
        }
        Cmd::Integrators { blobs, spp, width, threads, repeat, out } => {
            std::fs::create_dir_all(&out)?;
            integrators::run(&blobs, spp, width, threads, repeat, &out)?;
        }
        Cmd::Rays { blob: path, res, rays: count, repeat, python, out } => {
            let bytes = load(&path)?;
            let view = blob::SceneView::parse(&bytes).with_context(|| format!("{}", path.display()))?;
            if !view.instancing.instances.is_empty() {
                // Embree gets the stored triangles, and incoherent rays start on them: both need
                // world space.
                anyhow::bail!(
                    "{} has instances: ingest it with --flatten-instances for bench rays (bench instancing compares the two)",
                    path.display()
                );
            }
            let accel = render::accel::Accel::new(&view);
            std::fs::create_dir_all(&out)?;
            rays::write_triangles(&view, &out)?;
            let sets = [rays::primary_rays(&view, res), rays::incoherent_rays(&view, count, 1)];
            let mut ours = serde_json::Map::new();
            for set in &sets {
                let (prims, dists) = rays::trace(&accel, set);
                rays::write_set(&out, set, &prims, &dists)?;
                let one = rays::measure(&accel, set, 1, repeat)?;
                let two = rays::measure(&accel, set, 2, repeat)?;
                let hit_fraction =
                    prims.iter().filter(|&&p| p >= 0).count() as f64 / prims.len().max(1) as f64;
                ours.insert(
                    set.name.into(),
                    serde_json::json!({"rays": set.origins.len(), "ours_mrays_1thr": one, "ours_mrays_2thr": two, "hit_fraction": hit_fraction}),
                );
            }
            let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("embree_rays.py");
            let embree =
                Command::new(&python).arg(&script).arg(&out).arg("--repeat").arg(repeat.to_string()).output();
            let embree: serde_json::Value = match embree {
                Ok(o) if o.status.success() => serde_json::from_slice(&o.stdout)?,
                Ok(o) => {
                    eprintln!("embree run failed: {}", String::from_utf8_lossy(&o.stderr));
                    serde_json::Value::Null
                }
                Err(e) => {
                    eprintln!(
                        "cannot run {}: {e} (run scripts/bench.sh to install embreex)",
                        python.display()
                    );
                    serde_json::Value::Null
                }
            };
            println!("triangles: {}", view.triangles.len());
            println!(
                "{:<11} {:>8} {:>12} {:>12} {:>12} {:>12} {:>8} {:>8} {:>9}",
                "rays",
                "count",
                "ours 1thr",
                "embree 1thr",
                "ours 2thr",
                "embree 2thr",
                "ratio1",
                "ratio2",
                "agree"
            );
            for (name, o) in &ours {
                let e = &embree["sets"][name];
                let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
                println!(
                    "{:<11} {:>8} {:>12.3} {:>12.3} {:>12.3} {:>12.3} {:>8.3} {:>8.3} {:>9.5}",
                    name,
                    o["rays"],
                    f(&o["ours_mrays_1thr"]),
                    f(&e["embree_mrays_1thr"]),
                    f(&o["ours_mrays_2thr"]),
                    f(&e["embree_mrays_2thr"]),
                    f(&o["ours_mrays_1thr"]) / f(&e["embree_mrays_1thr"]),
                    f(&o["ours_mrays_2thr"]) / f(&e["embree_mrays_2thr"]),
                    f(&e["agree_hit_or_miss"]),
                );
            }
            let result = serde_json::json!({"blob": path, "triangles": view.triangles.len(), "ours": ours, "embree": embree});
            let file = out.join("rays.json");
            std::fs::write(&file, serde_json::to_string_pretty(&result)?)?;
            println!("figures written to {}", file.display());
        }
        Cmd::Adaptive { blob: path, reference_spp, width, out } => {
            let bytes = load(&path)?;
            let view = blob::SceneView::parse(&bytes).with_context(|| format!("{}", path.display()))?;
            std::fs::create_dir_all(&out)?;
            adaptive::run(&view, reference_spp, width, &out)?;
        }
        Cmd::Convergence { blob: path, reference_spp, max_spp, width, out } => {
            let bytes = load(&path)?;
            let view = blob::SceneView::parse(&bytes).with_context(|| format!("{}", path.display()))?;
            std::fs::create_dir_all(&out)?;
            convergence::run(&view, reference_spp, max_spp, width, &out)?;
        }
        Cmd::Subdiv { assets, out } => {
            let assets = if assets.is_empty() {
                vec![
                    "teapot=../shared/assets/teapot/full_assets/Teapot/Teapot.usd@5".to_string(),
                    "chess=../shared/assets/open_chess_set/full_assets/OpenChessSet/chess_set.usda@2/1"
                        .to_string(),
                ]
            } else {
                assets
            };
            let assets = assets.iter().map(|a| subdiv_asset(a)).collect::<anyhow::Result<Vec<_>>>()?;
            std::fs::create_dir_all(&out)?;
            subdiv::run(&assets, &out)?;
        }
        Cmd::Instancing {
            count,
            rings,
            segments,
            res,
            rays,
            repeat,
            ingest_instances,
            ingest_assets,
            baseline,
            out,
        } => {
            std::fs::create_dir_all(&out)?;
            let ingest = if ingest_instances == 0 {
                None
            } else {
                let assets = if ingest_assets.is_empty() {
                    instancing_ingest::layout_assets()?
                } else {
                    ingest_assets
                };
                Some(instancing_ingest::measure(ingest_instances, &assets, baseline.as_deref(), &out)?)
            };
            instancing::run(count, rings, segments, res, rays, repeat, ingest, &out)?;
        }
        Cmd::Curves { strands, res, out } => {
            std::fs::create_dir_all(&out)?;
            curves::run(strands, res, &out)?;
        }
        Cmd::PeersTable { json, target_renderer, target_spp, out } => {
            peers_table::run(&json, &target_renderer, target_spp, &out)?;
        }
        Cmd::PerfRecord { bench, doc } => perf_record::run(&bench, &doc)?,
        Cmd::Sequence { frames, out } => sequence::run(frames, &out)?,
        Cmd::Ingest { assets, python, repeat, out } => {
            let assets = if assets.is_empty() {
                ingest_speed::LARGEST_ASSETS.iter().map(PathBuf::from).collect()
            } else {
                assets
            };
            std::fs::create_dir_all(&out)?;
            ingest_speed::run(&assets, &python, repeat, &out)?;
        }
    }
    Ok(())
}

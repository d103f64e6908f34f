//! `ingest ASSET -o scene.blob`: compose a USD asset and write one scene blob.

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;

/// Compose a USD asset, triangulate it, build its BVH and write one relocatable scene blob.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Root layer (.usda, .usdc, .usdz or .usd).
    asset: PathBuf,
    /// Output blob path (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Leave payload arcs unloaded.
    #[arg(long)]
    no_payloads: bool,
    /// A missing sublayer/reference/payload is a warning instead of an error.
    #[arg(long)]
    lenient: bool,
    /// Also write a JSON list of every rendered gprim (path, bounds, triangles, materials).
    #[arg(long, value_name = "FILE")]
    dump_json: Option<PathBuf>,
    /// Print no summary (warnings are still printed).
    #[arg(short, long)]
    quiet: bool,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    let options = ingest::usd::LoadOptions { load_payloads: !args.no_payloads, lenient: args.lenient };
    let (scene, report) = ingest::pipeline::ingest_file(&args.asset, &args.output, &options)?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(path) = &args.dump_json {
        let text = serde_json::to_string_pretty(&ingest::pipeline::dump_json(&scene))?;
        std::fs::write(path, text).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    }
    if !args.quiet {
        eprintln!(
            "ingest: {} meshes, {} triangles, {} materials, {} lights, {} cameras -> {} ({:.1} MiB); load {:.2}s, pack {:.2}s",
            report.meshes,
            report.triangles,
            report.materials,
            report.lights,
            report.cameras,
            args.output.display(),
            report.blob_bytes as f64 / (1 << 20) as f64,
            report.load_seconds,
            report.pack_seconds
        );
    }
    Ok(())
}

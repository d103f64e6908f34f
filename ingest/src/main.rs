//! `ingest ASSET -o scene.blob`: compose a USD asset and write one scene blob.
//! `ingest ASSET --dump-json list.json` (no `-o`): compose and list the gprims only; no texture is
//! baked and no blob is packed (the composition benchmark's side against usd-core).

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;

/// Compose a USD asset, triangulate it, build its BVH and write one relocatable scene blob.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Root layer (.usda, .usdc, .usdz or .usd), or an Alembic archive (.abc).
    asset: PathBuf,
    /// Output blob path (written atomically). Without it, `--dump-json` is required and only the
    /// listing is made: textures are not baked and no blob is packed.
    #[arg(short, long, required_unless_present = "dump_json")]
    output: Option<PathBuf>,
    /// Leave payload arcs unloaded.
    #[arg(long)]
    no_payloads: bool,
    /// A missing sublayer/reference/payload, or a composition cycle, is a warning instead of an error.
    #[arg(long)]
    lenient: bool,
    /// Also write a JSON list of every rendered gprim (path, bounds, triangles, materials) and of every material (surface model, node categories read).
    #[arg(long, value_name = "FILE")]
    dump_json: Option<PathBuf>,
    /// Search directory for asset paths not found next to the layer naming them (repeatable;
    /// searched in order).
    #[arg(long = "asset-path", value_name = "DIR")]
    asset_paths: Vec<PathBuf>,
    /// Evaluate time samples at this time code (default: the stage's startTimeCode); for .abc,
    /// at F / fps seconds (default: each property's first sample).
    #[arg(long, value_name = "F", allow_negative_numbers = true, conflicts_with = "frames")]
    frame: Option<f64>,
    /// Ingest a frame sequence: `A-B` or `A-BxSTEP` (integer frames; `N` is one frame), one blob
    /// per frame at `-o`'s pattern (`shot.####.blob` or `shot.%04d.blob`: `#` runs pad to their
    /// length). The stage is composed once and texture bakes and unchanged BVHs are shared; each
    /// blob equals `--frame N`'s byte for byte.
    #[arg(long, value_name = "A-B[xSTEP]", allow_hyphen_values = true)]
    frames: Option<String>,
    /// Refine every subdivision surface to this uniform level, ignoring the camera.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=subdiv::MAX_LEVEL as i64))]
    subdiv_level: Option<u32>,
    /// Target on-screen length of a refined subdivision edge, in pixels at the render camera and
    /// resolution.
    #[arg(long, value_name = "PX", default_value_t = 1.0)]
    dicing_rate: f32,
    /// How subdivision surfaces are diced from the camera: `adaptive` (segments per cage edge
    /// from its on-screen length) or `uniform` (one level per mesh). `--subdiv-level` is uniform.
    #[arg(long, value_name = "MODE", default_value = "adaptive", value_parser = ["adaptive", "uniform"])]
    subdiv_mode: String,
    /// Highest subdivision level dicing may choose (adaptive: at most 2^N segments per cage edge).
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(u32).range(0..=subdiv::MAX_LEVEL as i64))]
    max_subdiv_level: u32,
    /// Copy every instance into world space instead of storing shared prototypes once.
    #[arg(long)]
    flatten_instances: bool,
    /// Most pixels (width × height) a texture file may declare; larger ones are refused from their
    /// header, before decoding (a warning; the texture's fallback is used). Default 268435456
    /// (2^28, a 16k × 16k image).
    #[arg(long, value_name = "N", default_value_t = texture::DEFAULT_MAX_PIXELS)]
    max_texture_pixels: u64,
    /// Print no summary (warnings are still printed).
    #[arg(short, long)]
    quiet: bool,
}

// glibc's `mallopt` (std links glibc on Linux; the `libc` crate is not a dependency of this crate
// for one function).
extern "C" {
    fn mallopt(param: std::ffi::c_int, value: std::ffi::c_int) -> std::ffi::c_int;
}

/// Keeps freed memory in the process for reuse instead of returning it to the kernel.
///
/// Ingest allocates and frees many large buffers in turn (decoded images, mip levels, meshes,
/// blob sections). By default glibc serves each above a dynamic threshold with a fresh `mmap`
/// and gives it back on free, and trims the heap top past 128 KiB, so every buffer's pages
/// fault in zeroed again: on the shader ball about half the page faults of a full ingest and a
/// quarter of its CPU time (measured: 530k faults and 2.9 s CPU → 320k and 2.1 s). The
/// process is short-lived, so keeping its peak footprint mapped costs nothing.
fn keep_freed_memory() {
    const M_TRIM_THRESHOLD: std::ffi::c_int = -1;
    const M_TOP_PAD: std::ffi::c_int = -2;
    const M_MMAP_THRESHOLD: std::ffi::c_int = -3;
    // SAFETY: mallopt takes plain integers and is called before any other thread exists. A
    // refused setting (returns 0) leaves glibc's default, which is only slower.
    unsafe {
        mallopt(M_MMAP_THRESHOLD, 32 << 20); // the largest glibc accepts on 64-bit
        mallopt(M_TRIM_THRESHOLD, 1 << 30);
        mallopt(M_TOP_PAD, 64 << 20);
    }
}

fn main() -> ExitCode {
    keep_freed_memory();
    // A panic in the USD reader is reported as one error line (exit 1), not a panic banner.
    ingest::usd::quiet_reader_panics();
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    if !(args.dicing_rate.is_finite() && args.dicing_rate > 0.0) {
        anyhow::bail!("--dicing-rate must be a positive number of pixels, not {}", args.dicing_rate);
    }
    let options = ingest::usd::LoadOptions {
        load_payloads: !args.no_payloads,
        lenient: args.lenient,
        asset_paths: args.asset_paths.clone(),
        frame: args.frame,
        bake_textures: args.output.is_some(),
        max_texture_pixels: args.max_texture_pixels,
        // Every file this run writes: none may be an input (checked before each is written).
        outputs: args.output.iter().chain(&args.dump_json).cloned().collect(),
        subdiv: ingest::dicing::SubdivOptions {
            forced_level: args.subdiv_level,
            dicing_rate: args.dicing_rate,
            max_level: args.max_subdiv_level,
            mode: if args.subdiv_mode == "uniform" {
                ingest::dicing::SubdivMode::Uniform
            } else {
                ingest::dicing::SubdivMode::Adaptive
            },
            // A listing reports planned counts and cage bounds: no limit surface is evaluated.
            tessellate: args.output.is_some(),
        },
    };
    if let Some(frames) = &args.frames {
        return sequence(&args, frames, options);
    }
    let Some(output) = &args.output else { return list_only(&args, &options) };
    let pack = ingest::pack::PackOptions { flatten_instances: args.flatten_instances, ..Default::default() };
    let (scene, report) = ingest::pipeline::ingest_file_with(&args.asset, output, &options, &pack)?;
    Ok(finish_frame(&args, &scene, &report, output, args.dump_json.as_deref())?)
}

/// Prints a written blob's warnings and summary and writes its listing (when asked for).
fn finish_frame(
    args: &Args,
    scene: &ingest::Scene,
    report: &ingest::pipeline::IngestReport,
    output: &std::path::Path,
    dump_json: Option<&std::path::Path>,
) -> Result<(), ingest::IngestError> {
    for w in &report.warnings {
        // The file, then the prim and the feature (`warning: a.usda: /World/Cyl: Cylinder prims ...`).
        eprintln!("warning: {}: {w}", args.asset.display());
    }
    if let Some(w) = ingest::pipeline::unlit_warning(scene) {
        eprintln!("warning: {}: /: {w}", args.asset.display());
    }
    if let Some(path) = dump_json {
        ingest::pipeline::write_dump(scene, path)?;
    }
    if !args.quiet {
        eprintln!(
            "ingest: {} meshes, {} triangles, {} materials, {} lights, {} cameras -> {} ({:.1} MiB); load {:.2}s, pack {:.2}s",
            report.meshes,
            report.triangles,
            report.materials,
            report.lights,
            report.cameras,
            output.display(),
            report.blob_bytes as f64 / (1 << 20) as f64,
            report.load_seconds,
            report.pack_seconds
        );
        if report.instances > 0 {
            eprintln!(
                "ingest: {} instances of {} prototypes; {} triangles stored for {} rendered",
                report.instances, report.prototypes, report.stored_triangles, report.triangles
            );
        }
        if report.subdivision_meshes > 0 {
            let saved = report.triangles_at_fixed_level as i64 - report.triangles as i64;
            eprintln!(
                "ingest: {} subdivision meshes; {} triangles at level {} everywhere, {} saved by dicing ({:.1}%)",
                report.subdivision_meshes,
                report.triangles_at_fixed_level,
                args.max_subdiv_level,
                saved,
                100.0 * saved as f64 / report.triangles_at_fixed_level.max(1) as f64
            );
        }
    }
    Ok(())
}

/// `--frames A-B[xSTEP]`: one blob per frame at `-o`'s pattern (and one listing per frame at
/// `--dump-json`'s), composed once (see [`ingest::pipeline::ingest_sequence`]).
fn sequence(args: &Args, frames: &str, options: ingest::usd::LoadOptions) -> anyhow::Result<()> {
    use blob::sequence::{frame_paths, FramePattern, FrameRange};
    let range: FrameRange = frames.parse()?;
    let output = args.output.as_ref().ok_or_else(|| {
        anyhow::anyhow!("--frames needs -o with a frame field (out.####.blob or out.%04d.blob)")
    })?;
    let pattern = FramePattern::new(output.to_string_lossy());
    let paths = frame_paths(&pattern, &range).map_err(|e| anyhow::anyhow!("-o {e}"))?;
    let dumps = match &args.dump_json {
        Some(dump) => {
            let listing = FramePattern::new(dump.to_string_lossy());
            Some(frame_paths(&listing, &range).map_err(|e| anyhow::anyhow!("--dump-json {e}"))?)
        }
        None => None,
    };
    let mut options = options;
    if let Some(dumps) = &dumps {
        options.outputs.extend(dumps.iter().map(|(_, p)| p.clone()));
    }
    let pack = ingest::pack::PackOptions { flatten_instances: args.flatten_instances, ..Default::default() };
    let times: Vec<(f64, std::path::PathBuf)> = paths.iter().map(|(f, p)| (*f as f64, p.clone())).collect();
    let start = std::time::Instant::now();
    let done = ingest::pipeline::ingest_sequence(
        &args.asset,
        &times,
        &options,
        &pack,
        |time, output, scene, report| {
            if !args.quiet {
                eprintln!("ingest: frame {time}");
            }
            let dump = dumps
                .as_ref()
                .and_then(|d| d.iter().find(|(f, _)| *f as f64 == time))
                .map(|(_, p)| p.as_path());
            finish_frame(args, scene, report, output, dump)
        },
    )?;
    if !args.quiet {
        eprintln!(
            "ingest: {} frames ({range}) -> {} in {:.2}s; shared: the composed stage, {} texture bakes reused, {} of {} BVHs reused",
            done.frames,
            pattern.as_str(),
            start.elapsed().as_secs_f64(),
            done.texture_bakes_reused,
            done.bvhs_reused,
            done.bvhs_reused + done.bvhs_built
        );
    }
    Ok(())
}

/// `--dump-json` without `-o`: compose and list; nothing is baked, packed or written but the list.
fn list_only(args: &Args, options: &ingest::usd::LoadOptions) -> anyhow::Result<()> {
    let path = args.dump_json.as_ref().expect("clap requires --dump-json without -o");
    let start = std::time::Instant::now();
    let scene = ingest::pipeline::load_until_exit(&args.asset, options)?;
    let load_seconds = start.elapsed().as_secs_f64();
    for w in &scene.warnings {
        eprintln!("warning: {}: {}", w.prim, w.message);
    }
    if let Some(w) = ingest::pipeline::unlit_warning(&scene) {
        eprintln!("warning: /: {w}");
    }
    ingest::pipeline::write_dump(&scene, path)?;
    // The process ends here: its memory goes back at exit, not one allocation at a time.
    let scene = std::mem::ManuallyDrop::new(scene);
    if !args.quiet {
        eprintln!(
            "ingest: {} meshes, {} triangles, {} materials, {} lights, {} cameras listed in {}; load {:.2}s (no blob)",
            scene.meshes.len(),
            ingest::pipeline::listed_triangles(&scene),
            scene.materials.len(),
            scene.lights.len(),
            scene.cameras.len(),
            path.display(),
            load_seconds
        );
    }
    Ok(())
}

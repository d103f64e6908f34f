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
    #[arg(long, value_name = "F", allow_negative_numbers = true)]
    frame: Option<f64>,
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
    let Some(output) = &args.output else { return list_only(&args, &options) };
    let pack = ingest::pack::PackOptions { flatten_instances: args.flatten_instances, ..Default::default() };
    let (scene, report) = ingest::pipeline::ingest_file_with(&args.asset, output, &options, &pack)?;
    for w in &report.warnings {
        // The file, then the prim and the feature (`warning: a.usda: /World/Cyl: Cylinder prims ...`).
        eprintln!("warning: {}: {w}", args.asset.display());
    }
    if let Some(w) = ingest::pipeline::unlit_warning(&scene) {
        eprintln!("warning: {}: /: {w}", args.asset.display());
    }
    if let Some(path) = &args.dump_json {
        ingest::pipeline::write_dump(&scene, path)?;
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

//! The `render` binary: arguments → a validated [`cli::Command`] → the render library; the CLI's
//! crates (clap, indicatif, anyhow) stay out of the library.

mod cli;
mod progress;

use anyhow::Context;
use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    match run(std::env::args_os()) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("render: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

/// Parses `args`, renders or prints `--info`, reports on stderr.
fn run<I, T>(args: I) -> anyhow::Result<ExitCode>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    use clap::Parser;
    let args: Vec<std::ffi::OsString> = args.into_iter().map(Into::into).collect();
    if args.get(1).is_some_and(|a| a == "merge") {
        return run_merge(&args[1..]);
    }
    if args.get(1).is_some_and(|a| a == "frames") {
        return run_frames(&args[1..]);
    }
    let args = match cli::Args::try_parse_from(args) {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return Ok(if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS });
        }
    };
    let frames = args.into_frames()?;
    if let [(None, _)] = frames.as_slice() {
        let (_, command) = frames.into_iter().next().expect("one command");
        return run_command(command);
    }
    // A sequence: every frame's blob must be there before the first frame renders.
    let blob_of = |c: &cli::Command| match c {
        cli::Command::Info { blob } | cli::Command::Render { blob, .. } => blob.clone(),
    };
    let missing: Vec<String> = frames
        .iter()
        .filter(|(_, c)| !blob_of(c).is_file())
        .map(|(f, c)| format!("frame {}: {}", f.unwrap_or_default(), blob_of(c).display()))
        .collect();
    if !missing.is_empty() {
        anyhow::bail!("{} of {} frames have no blob: {}", missing.len(), frames.len(), missing.join(", "));
    }
    let count = frames.len();
    for (i, (frame, command)) in frames.into_iter().enumerate() {
        let frame = frame.unwrap_or_default();
        if let cli::Command::Render { blob, output, .. } = &command {
            eprintln!(
                "render: frame {frame} ({} of {count}): {} -> {}",
                i + 1,
                blob.display(),
                output.display()
            );
        }
        let code = run_command(command).with_context(|| format!("frame {frame}"))?;
        if code != ExitCode::SUCCESS {
            return Ok(code);
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `render frames --frames A-B PATTERN...`: prints each frame and its files, tab-separated (the
/// farm script's one source of frame numbers and names, `blob::sequence`).
fn run_frames(args: &[std::ffi::OsString]) -> anyhow::Result<ExitCode> {
    use blob::sequence::{frame_paths, FramePattern, FrameRange};
    use clap::Parser;
    let args = match cli::FramesArgs::try_parse_from(args) {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return Ok(if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS });
        }
    };
    let range: FrameRange = args.frames.parse()?;
    let mut columns = Vec::new();
    for pattern in &args.patterns {
        columns.push(frame_paths(&FramePattern::new(pattern.as_str()), &range)?);
    }
    for (row, frame) in range.frames().into_iter().enumerate() {
        let files: Vec<String> = columns.iter().map(|c| c[row].1.display().to_string()).collect();
        println!("{frame}\t{}", files.join("\t"));
    }
    Ok(ExitCode::SUCCESS)
}

/// Renders (or prints `--info` of) one blob.
fn run_command(command: cli::Command) -> anyhow::Result<ExitCode> {
    if let cli::Command::Render { blob, output, png, stats, .. } = &command {
        // Before any work: no output may destroy the input or another output, and every output
        // directory must take a file (a full render used to end in "cannot write").
        let mut outputs = vec![("-o", output.as_path())];
        outputs.extend(png.as_deref().map(|p| ("--png", p)));
        outputs.extend(stats.as_deref().map(|p| ("--stats", p)));
        render::output::check_outputs(blob, &outputs)?;
    }
    let load_start = Instant::now();
    let blob_path = match &command {
        cli::Command::Info { blob } | cli::Command::Render { blob, .. } => blob.clone(),
    };
    // SAFETY: blobs are immutable by contract and replaced atomically (temporary file + rename), never
    // written in place (README, "The blob"); the map lives until this function returns, nothing here
    // writes to the file, and `check_unchanged` below refuses the image if someone did.
    let map = unsafe { render::map_blob(&blob_path) }?;
    let view = map.parse(&blob_path)?;
    let load_seconds = load_start.elapsed().as_secs_f64();

    match command {
        cli::Command::Info { .. } => {
            map.check_unchanged(&blob_path)?;
            println!("{}", serde_json::to_string(&render::info::summarize(&view))?);
            Ok(ExitCode::SUCCESS)
        }
        cli::Command::Render {
            output,
            png,
            stats,
            options,
            progress_interval,
            checkpoint,
            resume,
            time_limit,
            part,
            ..
        } => {
            let scene = render::Scene::new(view);
            // The products' files, checked like the other outputs before any work.
            let products: Vec<std::path::PathBuf> = scene
                .view
                .outputs
                .products
                .iter()
                .map(|p| render::output::product_path(&output, scene.view.string(p.name)))
                .collect();
            if !products.is_empty() {
                let mut outputs = vec![("-o", output.as_path())];
                outputs.extend(products.iter().map(|p| ("a RenderProduct", p.as_path())));
                render::output::check_outputs(&blob_path, &outputs)?;
            }
            if !scene.has_light() {
                eprintln!(
                    "render: warning: {} has no light (no UsdLux light, no emissive surface): the image is black",
                    blob_path.display()
                );
            }
            let provenance = render::checkpoint::Provenance::of(&map, &options);
            let mut film = if resume {
                let (mut film, stored) = resumed(&output, &provenance, &options)?;
                let plan = std::sync::Arc::new(render::aov::Plan::new(&scene.view)?);
                if let Err(why) = film.adopt_plan(plan, stored) {
                    eprintln!(
                        "render: warning: {}: {why}; the RenderProducts are not written",
                        output.display()
                    );
                }
                film
            } else {
                render::Accumulation::new(&scene, &options)?
            };
            let spp = options.spp;
            // Passes only where something happens between them (a checkpoint, a deadline check): one
            // pass of all samples keeps the wavefront's chunks as full as they can be.
            let pass = if checkpoint.is_some() || time_limit.is_some() { PASS_SAMPLES } else { spp };
            let reporter = progress::Reporter::for_stderr(
                std::io::stderr().is_terminal(),
                std::time::Duration::from_secs_f64(progress_interval),
            );
            let (start, mut last_checkpoint) = (Instant::now(), Instant::now());
            let pixels = film.sums.len() as u64;
            if let Some((threshold, min_spp)) = options.adaptive {
                // The CLI refused it with checkpoints, resumes, time limits and farm parts.
                let report = |p: render::Progress| reporter.report(p);
                film.render_adaptive(&scene, &options, threshold, min_spp, &report)
                    .with_context(|| format!("rendering {}", blob_path.display()))?;
            }
            while film.samples < spp {
                let before = u64::from(film.samples) * pixels;
                let until = film.samples.saturating_add(pass).min(spp);
                let report = |p: render::Progress| {
                    reporter.report(render::Progress {
                        samples_done: before + p.samples_done,
                        samples_total: u64::from(spp) * pixels,
                        ..p
                    })
                };
                film.render(&scene, &options, until, &report)
                    .with_context(|| format!("rendering {}", blob_path.display()))?;
                if let Some(limit) = time_limit.filter(|&t| start.elapsed().as_secs_f64() >= t) {
                    if film.samples < spp {
                        eprintln!(
                            "render: time limit of {limit} s reached after {} of {spp} samples per pixel; {} holds them and --resume continues it",
                            film.samples,
                            output.display()
                        );
                        break;
                    }
                }
                if let Some(every) = checkpoint {
                    if film.samples < spp && last_checkpoint.elapsed().as_secs_f64() >= every {
                        map.check_unchanged(&blob_path)?;
                        render::checkpoint::write_checkpoint(&output, &film, &provenance)?;
                        last_checkpoint = Instant::now();
                    }
                }
            }
            reporter.finish();
            map.check_unchanged(&blob_path)?;
            let image = film.image();
            let write_start = Instant::now();
            if checkpoint.is_some() || part || film.samples < spp {
                render::checkpoint::write_checkpoint(&output, &film, &provenance)?;
            } else {
                render::write_exr(&output, &image)?;
            }
            if let Some(png) = &png {
                render::write_png(png, &image)?;
            }
            if !products.is_empty() && film.samples >= spp && !part {
                for ((product, channels), path) in film.products().into_iter().zip(&products) {
                    let text = film.plan.attributes(product, &scene.view);
                    render::output::write_product(path, &film, product, channels, &text)?;
                }
            }
            let mut summary = render::stats::Summary::from_render(
                &image.stats,
                image.width,
                image.height,
                film.sample_count(),
            );
            summary.load_seconds = load_seconds;
            summary.integrator = format!("{:?}", options.integrator).to_lowercase();
            summary.write_seconds = write_start.elapsed().as_secs_f64();
            eprintln!("{}", summary.to_text());
            if let Some(path) = &stats {
                render::output::write_text(path, &serde_json::to_string_pretty(&summary)?)
                    .with_context(|| format!("writing statistics to {}", path.display()))?;
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `render merge PARTS... -o OUT.exr`: reads, merges and writes (see [`render::merge`]).
fn run_merge(args: &[std::ffi::OsString]) -> anyhow::Result<ExitCode> {
    use clap::Parser;
    let args = match cli::MergeArgs::try_parse_from(args) {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return Ok(if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS });
        }
    };
    let outputs = [("-o", args.output.as_path())];
    for part in &args.parts {
        render::output::check_outputs(part, &outputs)?;
    }
    let parts = render::merge::read_parts(&args.parts)?;
    // With --blob: the products' plan, from the blob the parts name (checked by its identity).
    let map = match &args.blob {
        // SAFETY: as for a render (see `run`): blobs are replaced atomically, never written in
        // place; the map lives until this function returns and `check_unchanged` guards it.
        Some(path) => Some((path, unsafe { render::map_blob(path) }?)),
        None => None,
    };
    let view = match &map {
        Some((path, map)) => Some((path, map.parse(path)?, render::checkpoint::blob_id(map))),
        None => None,
    };
    let mut plan = None;
    if let Some((path, view, id)) = &view {
        if let Some(part) = parts.iter().find(|p| p.provenance.blob != *id) {
            anyhow::bail!(
                "{} was rendered from blob {:016x}, --blob {} is {id:016x}",
                part.path.display(),
                part.provenance.blob,
                path.display()
            );
        }
        plan = Some(std::sync::Arc::new(render::aov::Plan::new(view)?));
    }
    let (film, provenance) = render::merge::merge(&parts, plan)?;
    let products: Vec<std::path::PathBuf> =
        film.plan.products.iter().map(|p| render::output::product_path(&args.output, &p.name)).collect();
    if let Some((path, ..)) = &view {
        let mut outputs = vec![("-o", args.output.as_path())];
        outputs.extend(products.iter().map(|p| ("a RenderProduct", p.as_path())));
        render::output::check_outputs(path, &outputs)?;
    }
    if args.keep_sums {
        render::checkpoint::write_checkpoint(&args.output, &film, &provenance)?;
    } else {
        render::write_exr(&args.output, &film.image())?;
    }
    if let (Some((_, view, _)), false) = (&view, args.keep_sums) {
        for ((product, channels), path) in film.products().into_iter().zip(&products) {
            let text = film.plan.attributes(product, view);
            render::output::write_product(path, &film, product, channels, &text)?;
        }
    }
    if let Some((path, map)) = &map {
        map.check_unchanged(path)?;
    }
    eprintln!(
        "render merge: {} parts, samples {}..{}, pixels {}x{} of the {}x{} frame -> {}",
        parts.len(),
        film.first_sample,
        film.samples,
        film.window.width(),
        film.window.height(),
        film.frame[0],
        film.frame[1],
        args.output.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Samples per pixel of one pass when passes are needed (`--checkpoint`, `--time-limit`): the
/// wavefront's chunk of a 16-pixel tile (2048 paths / 256 pixels), so a pass costs no efficiency.
const PASS_SAMPLES: u32 = 8;

/// The checkpoint at `output`, checked to continue this render: the same blob and pixel settings,
/// and no more samples than `--spp`; with the stride of the product sums it holds.
fn resumed(
    output: &std::path::Path,
    provenance: &render::checkpoint::Provenance,
    options: &render::RenderOptions,
) -> anyhow::Result<(render::Accumulation, Option<usize>)> {
    let (film, from) = render::checkpoint::read_checkpoint(output)?;
    if from.blob != provenance.blob {
        anyhow::bail!(
            "cannot resume from {}: it was rendered from another blob (id {:016x}, this one is {:016x})",
            output.display(),
            from.blob,
            provenance.blob
        );
    }
    if from.settings != provenance.settings {
        anyhow::bail!(
            "cannot resume from {}: it was rendered with {}, this render asks for {}",
            output.display(),
            from.settings,
            provenance.settings
        );
    }
    if film.samples > options.spp {
        anyhow::bail!(
            "cannot resume from {}: it holds {} samples per pixel, more than --spp {}",
            output.display(),
            film.samples,
            options.spp
        );
    }
    Ok((film, from.product_sums))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_entry_point_renders_writes_and_reports() {
        let dir = tempfile::tempdir().unwrap();
        // A white dome and nothing else: every camera ray escapes and reads 1.
        let blob_path = dome_blob(dir.path());
        let exr = dir.path().join("out.exr");
        let png = dir.path().join("out.png");
        let stats = dir.path().join("stats.json");
        let arg = |p: &std::path::Path| p.to_str().unwrap().to_string();
        let code = run([
            "render".to_string(),
            arg(&blob_path),
            "-o".into(),
            arg(&exr),
            "--spp".into(),
            "2".into(),
            "--res".into(),
            "16x8".into(),
            "--png".into(),
            arg(&png),
            "--stats".into(),
            arg(&stats),
            "--threads".into(),
            "1".into(),
        ])
        .unwrap();
        assert_eq!(code, std::process::ExitCode::SUCCESS);
        assert_eq!(image::open(&png).unwrap().width(), 16);
        assert!(std::fs::metadata(&exr).unwrap().len() > 0);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
        assert_eq!(json["camera_rays"], 16 * 8 * 2);
        assert_eq!(json["rays"], json["camera_rays"], "a dome alone casts no bounce or shadow ray");
        let pixel = image::open(&png).unwrap().to_rgb8().get_pixel(3, 2).0;
        assert_eq!(pixel, [255, 255, 255], "radiance 1 is white in the sRGB preview");

        // A truncated blob is an error naming the file, not a panic.
        let bad = dir.path().join("bad.blob");
        let bytes = std::fs::read(&blob_path).unwrap();
        std::fs::write(&bad, &bytes[..bytes.len() / 2]).unwrap();
        let err = run(["render".to_string(), arg(&bad), "--info".into()]).unwrap_err();
        assert!(format!("{err:#}").contains("bad.blob"), "{err:#}");
    }

    /// `render BLOB ARGS...` as a list of strings.
    fn args(blob: &std::path::Path, rest: &[&str]) -> Vec<String> {
        let mut v = vec!["render".to_string(), blob.to_str().unwrap().to_string()];
        v.extend(rest.iter().map(|s| s.to_string()));
        v
    }

    fn dome_blob(dir: &std::path::Path) -> std::path::PathBuf {
        let path = dir.join("scene.blob");
        let mut data = blob::SceneData::default();
        data.info.default_camera = blob::NONE;
        data.info.dome_light = 0;
        data.lights.push(blob::Light {
            kind: blob::light_kind::DOME,
            radiance: [1.0; 3],
            ..Default::default()
        });
        blob::write_atomic(&path, &data.encode()).unwrap();
        path
    }

    #[test]
    fn outputs_that_would_destroy_the_input_or_each_other_are_refused_before_rendering() {
        let dir = tempfile::tempdir().unwrap();
        let blob = dome_blob(dir.path());
        let bytes = std::fs::read(&blob).unwrap();
        let b = blob.to_str().unwrap();
        let link = dir.path().join("link.blob");
        std::fs::hard_link(&blob, &link).unwrap();
        let l = link.to_str().unwrap();
        let out = dir.path().join("out.exr");
        let o = out.to_str().unwrap();
        let same_dir = format!("{}/./scene.blob", dir.path().display());
        let cases: Vec<(Vec<&str>, String)> = vec![
            (vec!["-o", b], format!("refusing to write -o {b}: it is the input blob")),
            (vec!["-o", o, "--png", b], format!("refusing to write --png {b}: it is the input blob")),
            (vec!["-o", o, "--stats", l], format!("refusing to write --stats {l}: it is the input blob")),
            (vec!["-o", &same_dir], "it is the input blob".to_string()),
            (vec!["-o", o, "--png", o], "--png and -o name the same file".to_string()),
            (
                vec!["-o", "/nonexistent-blobsafe-dir/x.exr"],
                "cannot create a file in /nonexistent-blobsafe-dir".into(),
            ),
            (vec!["-o", dir.path().to_str().unwrap()], "-o names a directory".into()),
        ];
        for (rest, expected) in cases {
            let mut rest = rest.clone();
            rest.extend(["--res", "4x4", "--spp", "1", "--threads", "1"]);
            let err = format!("{:#}", run(args(&blob, &rest)).unwrap_err());
            assert!(err.contains(&expected), "{rest:?}: {err}");
            assert_eq!(std::fs::read(&blob).unwrap(), bytes, "{rest:?} left the blob intact");
            assert!(!out.exists(), "{rest:?}: refused before rendering");
        }
    }

    #[test]
    fn a_render_beyond_max_memory_is_refused_with_its_size() {
        let dir = tempfile::tempdir().unwrap();
        let blob = dome_blob(dir.path());
        let out = dir.path().join("out.exr");
        let rest =
            ["-o", out.to_str().unwrap(), "--res", "4096x4096", "--max-memory", "64M", "--threads", "1"];
        let err = format!("{:#}", run(args(&blob, &rest)).unwrap_err());
        let needed = render::film::memory_estimate(4096, 4096, 16, 1, &Default::default());
        assert!(err.contains(&format!("a 4096x4096 render needs about {needed} bytes")), "{err}");
        assert!(err.contains(&format!("the limit of {} bytes", 64u64 << 20)), "{err}");
        assert!(!out.exists());
    }

    #[test]
    fn stale_temporaries_of_dead_runs_are_removed_and_a_rerun_replaces_the_output() {
        let dir = tempfile::tempdir().unwrap();
        let blob = dome_blob(dir.path());
        let out = dir.path().join("out.exr");
        // A pid above the kernel's maximum (2^22) cannot be alive.
        let stale = dir.path().join(".out.exr.render-tmp-4194305");
        std::fs::write(&stale, b"half an image").unwrap();
        std::fs::write(&out, b"previous").unwrap();
        let rest = ["-o", out.to_str().unwrap(), "--res", "4x4", "--spp", "1", "--threads", "1"];
        assert_eq!(run(args(&blob, &rest)).unwrap(), ExitCode::SUCCESS);
        assert!(!stale.exists(), "the dead run's temporary is gone");
        assert_ne!(std::fs::read(&out).unwrap(), b"previous", "replaced by the new image");
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().contains(".render-tmp-"))
            .collect();
        assert!(left.is_empty(), "no temporary left: {left:?}");
    }
}

//! The `render` binary: arguments → a validated [`cli::Command`] → the render library; the CLI's
//! crates (clap, indicatif, anyhow) stay out of the library.

mod cli;

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
    let args = match cli::Args::try_parse_from(args) {
        Ok(a) => a,
        Err(e) => {
            let _ = e.print();
            return Ok(if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS });
        }
    };
    let command = args.into_command()?;
    let load_start = Instant::now();
    let blob_path = match &command {
        cli::Command::Info { blob } | cli::Command::Render { blob, .. } => blob.clone(),
    };
    // SAFETY: blobs are replaced atomically by ingest (temporary file + rename), never written in place;
    // the map lives until this function returns and nothing here writes to the file.
    let map = unsafe { render::map_blob(&blob_path) }?;
    let view = render::parse_blob(&blob_path, &map)?;
    let load_seconds = load_start.elapsed().as_secs_f64();

    match command {
        cli::Command::Info { .. } => {
            println!("{}", serde_json::to_string(&render::info::summarize(&view))?);
            Ok(ExitCode::SUCCESS)
        }
        cli::Command::Render { output, png, stats, options, .. } => {
            let scene = render::Scene::new(view);
            let bar = std::io::stderr().is_terminal().then(|| {
                let bar = indicatif::ProgressBar::new(0);
                bar.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{bar:40} {pos}/{len} tiles {elapsed_precise} eta {eta}",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                bar
            });
            let progress = |done: usize, total: usize| {
                if let Some(bar) = &bar {
                    bar.set_length(total as u64);
                    bar.set_position(done as u64);
                }
            };
            let image = render::render_scene_with_progress(&scene, &options, &progress)
                .with_context(|| format!("rendering {}", blob_path.display()))?;
            if let Some(bar) = &bar {
                bar.finish_and_clear();
            }
            let write_start = Instant::now();
            render::write_exr(&output, &image)?;
            if let Some(png) = &png {
                render::write_png(png, &image)?;
            }
            let mut summary =
                render::stats::Summary::from_render(&image.stats, image.width, image.height, options.spp);
            summary.load_seconds = load_seconds;
            summary.integrator = format!("{:?}", options.integrator).to_lowercase();
            summary.write_seconds = write_start.elapsed().as_secs_f64();
            eprintln!("{}", summary.to_text());
            if let Some(path) = &stats {
                std::fs::write(path, serde_json::to_string_pretty(&summary)?)
                    .with_context(|| format!("writing statistics to {}", path.display()))?;
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_entry_point_renders_writes_and_reports() {
        let dir = tempfile::tempdir().unwrap();
        let blob_path = dir.path().join("scene.blob");
        // A white dome and nothing else: every camera ray escapes and reads 1.
        let mut data = blob::SceneData::default();
        data.info.default_camera = blob::NONE;
        data.info.dome_light = 0;
        data.lights.push(blob::Light {
            kind: blob::light_kind::DOME,
            radiance: [1.0; 3],
            ..Default::default()
        });
        blob::write_atomic(&blob_path, &data.encode()).unwrap();
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
}

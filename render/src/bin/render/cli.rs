//! Command-line arguments (clap) and their validation into [`Command`].

use clap::Parser;
use render::{RenderError, RenderOptions};
use std::path::PathBuf;

/// Raw arguments of the `render` binary.
#[derive(Debug, Clone, Parser)]
#[command(name = "render", version, about = "Path-traces a scene blob written by ingest.")]
pub struct Args {
    /// The scene blob; or a sequence: one blob pattern (`shot.####.blob`, `shot.%04d.blob`) with
    /// `--frames`, or several blobs, each numbered by the last run of digits in its file name.
    #[arg(required = true, num_args = 1..)]
    pub blob: Vec<PathBuf>,
    /// Render the frames A-B[xSTEP] of the blob pattern, each to its own -o (and --png, --stats)
    /// with the frame number in the pattern's frame field (`beauty.####.exr`).
    #[arg(long, value_name = "A-B[xSTEP]", allow_hyphen_values = true)]
    pub frames: Option<String>,
    /// Output OpenEXR file (beauty RGBA + albedo, normal, depth layers).
    #[arg(short = 'o', long = "output", required_unless_present = "info")]
    pub output: Option<PathBuf>,
    /// Print scene counts and bounds as one JSON object and exit.
    #[arg(long)]
    pub info: bool,
    /// Samples per pixel (1..=16777216).
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Resolution as WIDTHxHEIGHT, at most 65536 per axis and 2^28 pixels (default: RenderSettings,
    /// else 512 wide with the camera aspect).
    #[arg(long, value_parser = parse_resolution)]
    pub res: Option<[u32; 2]>,
    /// Refuse to start a render whose film, path pools and AOVs need more than SIZE bytes (suffixes K,
    /// M, G, T: powers of 1024). Default: 3/4 of the physical memory.
    #[arg(long, value_parser = parse_size)]
    pub max_memory: Option<u64>,
    /// Camera prim path (default: the scene's default camera).
    #[arg(long)]
    pub camera: Option<String>,
    /// Worker threads (default: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Sampler seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Maximum bounces.
    #[arg(long, default_value_t = 8)]
    pub max_depth: u32,
    /// Also write an 8-bit sRGB PNG preview of the beauty.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Write the run's statistics as JSON (also counts the texture bytes the render reads).
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Texture filter: moonray (two point-sampled levels blended; bilinear when magnifying),
    /// bilinear, trilinear, anisotropic (trilinear taps along the footprint) or ewa (elliptical
    /// Gaussian over the footprint).
    #[arg(long, default_value = "moonray", value_parser = parse_filter)]
    pub texture_filter: texture::Filter,
    /// Draw all curves as `tube` or `ribbon` (default: tubes, oriented ribbons where normals are authored).
    #[arg(long, value_parser = parse_curve_shape)]
    pub curve_shape: Option<render::accel::curves::CurveShape>,
    /// Integrator: wavefront (breadth first, batched, 8-lane kernels; the default: it is faster on
    /// every bench scene) or scalar (depth first, the reference); same image bit for bit.
    #[arg(long, default_value = "wavefront")]
    pub integrator: render::Integrator,
    /// Render only this region of the frame: XMIN,YMIN,XMAX,YMAX in NDC ((0,0) bottom-left, (1,1)
    /// top-right, as RenderSettings dataWindowNDC, which it overrides). The EXR keeps the frame as its
    /// display window; the pixels equal the full render's.
    #[arg(long, value_parser = parse_crop)]
    pub crop: Option<[f32; 4]>,
    /// Seconds between progress lines when stderr is not a terminal (a farm log); a terminal gets a bar.
    #[arg(long, default_value_t = 10.0)]
    pub progress_interval: f64,
    /// Write the image so far to -o at most every SECONDS (atomically; with its exact pixel sums, sample
    /// count and provenance as EXR channels and attributes), so a killed render loses at most that much
    /// and `--resume` continues it. The final EXR keeps the sums too.
    #[arg(long, value_name = "SECONDS")]
    pub checkpoint: Option<f64>,
    /// Continue the checkpoint at -o (same blob and pixel settings) up to --spp; the image equals an
    /// uninterrupted render's bit for bit.
    #[arg(long)]
    pub resume: bool,
    /// Stop after the pass (8 samples per pixel) during which SECONDS have passed, and write what is
    /// done as a checkpoint at -o (resumable).
    #[arg(long, value_name = "SECONDS")]
    pub time_limit: Option<f64>,
    /// A farm tile: render only band I (0-based) of N bands of rows of the frame (or of the crop), and
    /// write it as a part for `render merge`.
    #[arg(long, value_name = "I/N", value_parser = parse_tile)]
    pub tile: Option<[u32; 2]>,
    /// A farm sample slice: trace only samples A..B of each pixel (the keys the whole render uses; B
    /// at most --spp's range) and write a part for `render merge`. Overrides --spp.
    #[arg(long, value_name = "A..B", value_parser = parse_sample_range)]
    pub sample_range: Option<[u32; 2]>,
    /// Render the camera as a pinhole, ignoring its depth of field (`fStop`).
    #[arg(long)]
    pub no_dof: bool,
    /// Render without motion blur: every ray at the frame's time (overrides --shutter).
    #[arg(long)]
    pub no_motion_blur: bool,
    /// The shutter OPEN,CLOSE in time codes from the frame, overriding the camera's
    /// `shutter:open` / `shutter:close` (motion outside the ingested keys holds the end keys).
    #[arg(long, value_name = "OPEN,CLOSE", value_parser = parse_shutter)]
    pub shutter: Option<[f32; 2]>,
    /// Adaptive sampling: tiles stop taking samples once every pixel's error estimate is below T
    /// (standard error of its mean luminance over 10^-3 + its square root), at most --spp.
    #[arg(long, value_name = "T")]
    pub adaptive_threshold: Option<f32>,
    /// Samples every pixel takes before adaptive sampling may stop it.
    #[arg(long, value_name = "N", default_value_t = 16)]
    pub adaptive_min_spp: u32,
}

/// `render frames --frames A-B[xSTEP] PATTERN...`: the frames and their files, one line each.
#[derive(Debug, Parser)]
#[command(
    name = "render frames",
    about = "Lists the frames of a range with each pattern's file (frame, then the files; tab-separated)."
)]
pub struct FramesArgs {
    /// The range: A-B or A-BxSTEP.
    #[arg(long, value_name = "A-B[xSTEP]", allow_hyphen_values = true)]
    pub frames: String,
    /// File-name patterns (`#` runs, `%04d`); each must have a frame field for several frames.
    #[arg(required = true)]
    pub patterns: Vec<String>,
}

/// `render merge PARTS... -o OUT.exr`.
#[derive(Debug, Parser)]
#[command(
    name = "render merge",
    about = "Assembles the parts of a farm render (tiles, sample slices) into one EXR."
)]
pub struct MergeArgs {
    /// The parts: EXRs written by render --tile / --sample-range (or checkpoints).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The merged EXR.
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Keep the exact pixel sums in the output (a part of a larger merge, or resumable).
    #[arg(long)]
    pub keep_sums: bool,
    /// The blob the parts were rendered from: its RenderProducts are merged and written beside
    /// the output (needed when the parts hold product sums).
    #[arg(long, value_name = "SCENE.blob")]
    pub blob: Option<PathBuf>,
}

fn parse_tile(s: &str) -> Result<[u32; 2], String> {
    let (i, n) = s.split_once('/').ok_or_else(|| format!("expected I/N, got {s:?}"))?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("bad tile {s:?}: {e}"));
    let (i, n) = (parse(i)?, parse(n)?);
    if n == 0 || i >= n {
        return Err(format!("tile {s:?}: I must be below N (0-based), N at least 1"));
    }
    Ok([i, n])
}

fn parse_sample_range(s: &str) -> Result<[u32; 2], String> {
    let (a, b) = s.split_once("..").ok_or_else(|| format!("expected A..B, got {s:?}"))?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("bad sample range {s:?}: {e}"));
    let (a, b) = (parse(a)?, parse(b)?);
    if a >= b || b > render::film::MAX_SPP {
        return Err(format!("sample range {s:?}: A must be below B, B at most {}", render::film::MAX_SPP));
    }
    Ok([a, b])
}

fn parse_crop(s: &str) -> Result<[f32; 4], String> {
    let values: Vec<f32> = s
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|e| format!("bad crop {s:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let [x0, y0, x1, y1] = values[..] else {
        return Err(format!("expected XMIN,YMIN,XMAX,YMAX, got {s:?}"));
    };
    let limit = blob::tree::MAX_NDC;
    if !values.iter().all(|v| v.is_finite() && v.abs() <= limit) || x0 >= x1 || y0 >= y1 {
        return Err(format!(
            "crop {s:?} must be XMIN,YMIN,XMAX,YMAX with XMIN < XMAX, YMIN < YMAX, within ±{limit}"
        ));
    }
    Ok([x0, y0, x1, y1])
}

fn parse_shutter(s: &str) -> Result<[f32; 2], String> {
    let values: Vec<f32> = s
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|e| format!("bad shutter {s:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let [open, close] = values[..] else { return Err(format!("expected OPEN,CLOSE, got {s:?}")) };
    let limit = blob::MAX_SHUTTER;
    if !values.iter().all(|v| v.is_finite() && v.abs() <= limit) || open > close {
        return Err(format!(
            "shutter {s:?} must be OPEN,CLOSE with OPEN <= CLOSE, within ±{limit} time codes"
        ));
    }
    Ok([open, close])
}

fn parse_filter(s: &str) -> Result<texture::Filter, String> {
    s.parse()
}

fn parse_curve_shape(s: &str) -> Result<render::accel::curves::CurveShape, String> {
    match s {
        "tube" => Ok(render::accel::curves::CurveShape::Tube),
        "ribbon" => Ok(render::accel::curves::CurveShape::Ribbon),
        _ => Err(format!("expected tube or ribbon, got {s:?}")),
    }
}

fn parse_resolution(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("bad resolution {s:?}: {e}"));
    let res = [parse(w)?, parse(h)?];
    // The total, not only each axis: 65535x65535 is 4.3 G pixels.
    render::frame::check_resolution(res[0], res[1]).map_err(|e| e.to_string())?;
    Ok(res)
}

/// Bytes with an optional binary suffix: `512M`, `8G`, `1073741824`.
fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let (digits, shift) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let shift = match c.to_ascii_uppercase() {
                'K' => 10,
                'M' => 20,
                'G' => 30,
                'T' => 40,
                _ => return Err(format!("bad size {s:?}: suffix must be K, M, G or T")),
            };
            (&t[..i], shift)
        }
        _ => (t, 0),
    };
    let n: u64 = digits.trim().parse().map_err(|e| format!("bad size {s:?}: {e}"))?;
    n.checked_mul(1u64 << shift).ok_or_else(|| format!("size {s:?} does not fit in 64 bits"))
}

/// What to do, validated.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Print the scene summary.
    Info {
        /// The blob.
        blob: PathBuf,
    },
    /// Render.
    Render {
        /// The blob.
        blob: PathBuf,
        /// EXR output.
        output: PathBuf,
        /// PNG preview.
        png: Option<PathBuf>,
        /// Statistics JSON.
        stats: Option<PathBuf>,
        /// Render options (boxed: the largest variant by far).
        options: Box<RenderOptions>,
        /// Seconds between plain progress lines (stderr not a terminal).
        progress_interval: f64,
        /// Seconds between checkpoints.
        checkpoint: Option<f64>,
        /// Continue the checkpoint at `output`.
        resume: bool,
        /// Seconds after which no new pass starts.
        time_limit: Option<f64>,
        /// Write a farm part (sums and provenance kept): a tile or a sample slice.
        part: bool,
    },
}

/// The frame number of a listed blob: the last run of digits in its file name.
fn frame_of(blob: &std::path::Path) -> Option<i64> {
    let name = blob.file_name()?.to_str()?;
    let end = name.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = name[..end].rfind(|c: char| !c.is_ascii_digit()).map_or(0, |i| i + 1);
    name[start..end].parse().ok()
}

impl Args {
    /// Validates the arguments into one command per frame: `(None, command)` for a single blob
    /// without `--frames`, else each frame's number and its command, with the blob and the
    /// outputs taken from their patterns.
    pub fn into_frames(self) -> Result<Vec<(Option<i64>, Command)>, RenderError> {
        use blob::sequence::{FramePattern, FrameRange};
        let invalid = |m: String| RenderError::InvalidOption(m);
        let blobs: Vec<(i64, PathBuf)> = match (&self.frames, self.blob.as_slice()) {
            (None, [_]) => return Ok(vec![(None, self.into_command()?)]),
            (Some(range), [pattern]) => {
                let range: FrameRange = range.parse().map_err(|e| invalid(format!("--frames: {e}")))?;
                let pattern = FramePattern::new(pattern.to_string_lossy());
                blob::sequence::frame_paths(&pattern, &range).map_err(|e| invalid(format!("the blob {e}")))?
            }
            (Some(_), _) => {
                return Err(invalid("--frames takes one blob pattern (shot.####.blob), not a list".into()))
            }
            (None, list) => {
                let mut frames: Vec<(i64, PathBuf)> = Vec::new();
                for blob in list {
                    let frame = frame_of(blob).ok_or_else(|| {
                        invalid(format!(
                            "{}: no frame number in the file name (a list of blobs is numbered by the last digits of each name)",
                            blob.display()
                        ))
                    })?;
                    if let Some((_, other)) = frames.iter().find(|(f, _)| *f == frame) {
                        return Err(invalid(format!(
                            "{} and {} are both frame {frame}",
                            other.display(),
                            blob.display()
                        )));
                    }
                    frames.push((frame, blob.clone()));
                }
                frames
            }
        };
        let count = blobs.len();
        let pattern = |option: &str, path: &Option<PathBuf>| -> Result<Option<FramePattern>, RenderError> {
            let Some(path) = path else { return Ok(None) };
            let pattern = FramePattern::new(path.to_string_lossy());
            pattern.check(count).map_err(|e| invalid(format!("{option} {e}")))?;
            Ok(Some(pattern))
        };
        let (output, png, stats) =
            (pattern("-o", &self.output)?, pattern("--png", &self.png)?, pattern("--stats", &self.stats)?);
        let mut frames = Vec::with_capacity(count);
        for (frame, blob) in blobs {
            let mut args = self.clone();
            args.blob = vec![blob];
            args.output = output.as_ref().map(|p| p.path(frame));
            args.png = png.as_ref().map(|p| p.path(frame));
            args.stats = stats.as_ref().map(|p| p.path(frame));
            frames.push((Some(frame), args.into_command()?));
        }
        Ok(frames)
    }

    /// Validates the arguments of one blob.
    pub fn into_command(self) -> Result<Command, RenderError> {
        let blob = self.blob.into_iter().next().expect("clap requires a blob");
        if self.info {
            return Ok(Command::Info { blob });
        }
        if self.spp == 0 || self.spp > render::film::MAX_SPP {
            return Err(RenderError::InvalidOption(format!(
                "--spp {} out of range (1..={})",
                self.spp,
                render::film::MAX_SPP
            )));
        }
        let output =
            self.output.ok_or_else(|| RenderError::InvalidOption("-o OUT.exr is required".into()))?;
        let seconds = [
            ("--progress-interval", Some(self.progress_interval)),
            ("--checkpoint", self.checkpoint),
            ("--time-limit", self.time_limit),
        ];
        for (option, value) in seconds {
            if let Some(v) = value.filter(|v| !(v.is_finite() && (0.0..=1e9).contains(v))) {
                return Err(RenderError::InvalidOption(format!(
                    "{option} {v} out of range (0..=1000000000 seconds)"
                )));
            }
        }
        if let Some(t) = self.adaptive_threshold {
            if !(t.is_finite() && t > 0.0) {
                return Err(RenderError::InvalidOption(format!(
                    "--adaptive-threshold {t} must be a positive number"
                )));
            }
            let with = [
                ("--checkpoint", self.checkpoint.is_some()),
                ("--resume", self.resume),
                ("--time-limit", self.time_limit.is_some()),
                ("--tile", self.tile.is_some()),
                ("--sample-range", self.sample_range.is_some()),
            ];
            if let Some((option, _)) = with.iter().find(|(_, on)| *on) {
                return Err(RenderError::InvalidOption(format!(
                    "--adaptive-threshold does not combine with {option} yet (its per-pixel sample counts are not kept in checkpoints)"
                )));
            }
        }
        Ok(Command::Render {
            stats: self.stats.clone(),
            blob,
            output,
            png: self.png,
            progress_interval: self.progress_interval,
            checkpoint: self.checkpoint,
            resume: self.resume,
            time_limit: self.time_limit,
            part: self.tile.is_some() || self.sample_range.is_some(),
            options: Box::new(RenderOptions {
                spp: self.sample_range.map_or(self.spp, |[_, end]| end),
                first_sample: self.sample_range.map_or(0, |[first, _]| first),
                band: self.tile,
                resolution: self.res,
                camera: self.camera,
                threads: self.threads,
                seed: self.seed,
                max_depth: self.max_depth,
                texture_filter: self.texture_filter,
                texture_stats: self.stats.is_some(),
                phase_stats: self.stats.is_some(),
                curve_shape: self.curve_shape,
                integrator: self.integrator,
                max_memory: self.max_memory,
                crop: self.crop,
                depth_of_field: !self.no_dof,
                motion_blur: !self.no_motion_blur,
                shutter: self.shutter,
                adaptive: self.adaptive_threshold.map(|t| (t, self.adaptive_min_spp)),
                ..RenderOptions::default()
            }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_become_a_validated_command() {
        let args = Args::try_parse_from([
            "render",
            "s.blob",
            "-o",
            "o.exr",
            "--spp",
            "4",
            "--res",
            "64x32",
            "--threads",
            "2",
        ])
        .unwrap();
        let Command::Render { options, output, .. } = args.into_command().unwrap() else { panic!() };
        assert_eq!(output, PathBuf::from("o.exr"));
        assert_eq!((options.spp, options.resolution, options.threads), (4, Some([64, 32]), 2));
        assert_eq!(options.integrator, render::Integrator::Wavefront);
        assert!(options.depth_of_field, "depth of field is on unless --no-dof");
        let still = Args::try_parse_from(["render", "s.blob", "-o", "o.exr", "--no-motion-blur"]).unwrap();
        let Command::Render { options: still, .. } = still.into_command().unwrap() else { panic!() };
        assert!(!still.motion_blur && still.shutter.is_none());
        let shutter =
            Args::try_parse_from(["render", "s.blob", "-o", "o.exr", "--shutter=-0.25,0.5"]).unwrap();
        let Command::Render { options: shutter, .. } = shutter.into_command().unwrap() else { panic!() };
        assert_eq!((shutter.motion_blur, shutter.shutter), (true, Some([-0.25, 0.5])));
        for bad in ["0.5,0.25", "nan,1", "1", "0,2e4"] {
            let arg = format!("--shutter={bad}");
            let err = Args::try_parse_from(["render", "s.blob", "-o", "o.exr", &arg]).unwrap_err();
            assert!(
                err.to_string().contains("shutter") || err.to_string().contains("OPEN,CLOSE"),
                "{bad}: {err}"
            );
        }
        let pinhole = Args::try_parse_from(["render", "s.blob", "-o", "o.exr", "--no-dof"]).unwrap();
        let Command::Render { options, .. } = pinhole.into_command().unwrap() else { panic!() };
        assert!(!options.depth_of_field);
        let scalar =
            Args::try_parse_from(["render", "s.blob", "-o", "o.exr", "--integrator", "scalar"]).unwrap();
        let Command::Render { options, .. } = scalar.into_command().unwrap() else { panic!() };
        assert_eq!(options.integrator, render::Integrator::Scalar);
        assert!(Args::try_parse_from(["render", "s.blob", "-o", "o.exr", "--integrator", "gpu"]).is_err());
        assert!(Args::try_parse_from(["render", "s.blob"]).is_err(), "-o is required without --info");
        assert!(matches!(
            Args::try_parse_from(["render", "s.blob", "--info"]).unwrap().into_command().unwrap(),
            Command::Info { .. }
        ));
        assert!(Args::try_parse_from(["render", "s.blob", "-o", "x", "--res", "0x5"]).is_err());
        // Each axis fits, the total does not (4.3 G pixels aborted on the allocation).
        let err = parse_resolution("65535x65535").unwrap_err();
        assert!(err.contains("resolution 65535x65535 (4294836225 pixels) is out of range"), "{err}");
        assert_eq!(parse_resolution("16384x16384"), Ok([16384, 16384]));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("3g"), Ok(3 << 30));
        assert_eq!(parse_size("1000"), Ok(1000));
        assert!(parse_size("5Q").unwrap_err().contains("suffix"));
        let err = Args::try_parse_from(["render", "s.blob", "-o", "x", "--spp", "16777217"])
            .unwrap()
            .into_command()
            .unwrap_err();
        assert!(err.to_string().contains("--spp 16777217 out of range"), "{err}");
        assert_eq!(parse_crop("0.25, 0, 0.75,0.5"), Ok([0.25, 0.0, 0.75, 0.5]));
        assert!(parse_crop("0.5,0,0.25,1").unwrap_err().contains("XMIN < XMAX"));
        assert!(parse_crop("0,0,1").unwrap_err().contains("expected XMIN,YMIN,XMAX,YMAX"));
        assert!(parse_crop("0,0,nan,1").unwrap_err().contains("within ±16"));
        let err = Args::try_parse_from(["render", "s.blob", "-o", "x", "--progress-interval=-1"])
            .unwrap()
            .into_command()
            .unwrap_err();
        assert!(err.to_string().contains("--progress-interval -1 out of range"), "{err}");
        let err = Args::try_parse_from(["render", "s.blob", "-o", "x", "--checkpoint", "nan"])
            .unwrap()
            .into_command()
            .unwrap_err();
        assert!(err.to_string().contains("--checkpoint NaN out of range"), "{err}");
        assert_eq!(parse_tile("3/4"), Ok([3, 4]));
        assert!(parse_tile("4/4").unwrap_err().contains("I must be below N"));
        assert_eq!(parse_sample_range("8..16"), Ok([8, 16]));
        assert!(parse_sample_range("8..8").unwrap_err().contains("A must be below B"));
        let args =
            Args::try_parse_from(["render", "s.blob", "-o", "x", "--sample-range", "4..12", "--tile", "1/2"]);
        let Command::Render { options, part, .. } = args.unwrap().into_command().unwrap() else { panic!() };
        assert_eq!((options.first_sample, options.spp, options.band, part), (4, 12, Some([1, 2]), true));
        assert!(Args::try_parse_from(["render", "s.blob", "-o", "x", "--spp", "0"])
            .unwrap()
            .into_command()
            .is_err());
    }
}

//! Command-line arguments (clap) and their validation into [`Command`].

use clap::Parser;
use render::{RenderError, RenderOptions};
use std::path::PathBuf;

/// Raw arguments of the `render` binary.
#[derive(Debug, Parser)]
#[command(name = "render", version, about = "Path-traces a scene blob written by ingest.")]
pub struct Args {
    /// The scene blob.
    pub blob: PathBuf,
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
    /// Render the camera as a pinhole, ignoring its depth of field (`fStop`).
    #[arg(long)]
    pub no_dof: bool,
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
        /// Render options.
        options: RenderOptions,
    },
}

impl Args {
    /// Validates the arguments.
    pub fn into_command(self) -> Result<Command, RenderError> {
        if self.info {
            return Ok(Command::Info { blob: self.blob });
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
        Ok(Command::Render {
            stats: self.stats.clone(),
            blob: self.blob,
            output,
            png: self.png,
            options: RenderOptions {
                spp: self.spp,
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
                depth_of_field: !self.no_dof,
                ..RenderOptions::default()
            },
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
        assert!(Args::try_parse_from(["render", "s.blob", "-o", "x", "--spp", "0"])
            .unwrap()
            .into_command()
            .is_err());
    }
}

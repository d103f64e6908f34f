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
    /// Samples per pixel.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Resolution as WIDTHxHEIGHT (default: RenderSettings, else 512 wide with the camera aspect).
    #[arg(long, value_parser = parse_resolution)]
    pub res: Option<[u32; 2]>,
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
    if res[0] == 0 || res[1] == 0 || res[0] > 65536 || res[1] > 65536 {
        return Err(format!("resolution {s:?} out of range (1..=65536 per axis)"));
    }
    Ok(res)
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
        if self.spp == 0 {
            return Err(RenderError::InvalidOption("--spp must be at least 1".into()));
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
        assert!(Args::try_parse_from(["render", "s.blob", "-o", "x", "--spp", "0"])
            .unwrap()
            .into_command()
            .is_err());
    }
}

//! What a render is asked for: [`RenderOptions`] and the [`Integrator`] that traces its paths.

/// Options of one render. [`RenderOptions::default`] gives 16 spp, depth 8, automatic resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Samples per pixel (≥ 1).
    pub spp: u32,
    /// `[width, height]`, or `None` for the scene's RenderSettings resolution, else 512 wide with the
    /// camera's aspect.
    pub resolution: Option<[u32; 2]>,
    /// Camera prim path, or `None` for the scene's default camera (or a framing camera if none).
    pub camera: Option<String>,
    /// Worker threads; 0 = one per core.
    pub threads: usize,
    /// Sampler seed.
    pub seed: u32,
    /// Maximum number of bounces (1 = direct lighting only).
    pub max_depth: u32,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// Texture filter (`--texture-filter`).
    pub texture_filter: texture::Filter,
    /// Multiplies every camera ray's footprint: 1 filters textures over one pixel, 0 reads level 0 at
    /// the sample point (a supersampled reference needs no prefiltering).
    pub texture_footprint_scale: f32,
    /// Count the texel pages the render reads (`RenderStats::texture_bytes_touched`); off by default
    /// because every texel fetch then also marks a shared bitmap.
    pub texture_stats: bool,
    /// Draw every curve as this shape (`None`: tubes, or ribbons where normals are authored).
    pub curve_shape: Option<crate::accel::curves::CurveShape>,
    /// Which integrator traces the paths (`--integrator`); both give the same image.
    pub integrator: Integrator,
    /// Time every phase of every path ([`crate::RenderStats::phases`]); costs a few percent, so off by
    /// default (`--stats` turns it on).
    pub phase_stats: bool,
    /// Refuse a render whose film, pools and AOVs would need more than this many bytes
    /// ([`crate::film::memory_estimate`]); `None` for [`crate::film::default_max_memory`] (3/4 of the
    /// physical memory).
    pub max_memory: Option<u64>,
    /// Draw only this NDC rectangle of the frame (xmin, ymin, xmax, ymax; (0, 0) bottom-left), as
    /// RenderSettings `dataWindowNDC` does and overriding it; `None` for the authored window or the
    /// whole frame. Pixels are the full render's, bit for bit ([`crate::film::PixelWindow::from_ndc`]).
    pub crop: Option<[f32; 4]>,
    /// Draw only band `[index, count]` of the window: its rows cut into `count` runs (a farm's tile;
    /// `render --tile I/N`).
    pub band: Option<[u32; 2]>,
    /// Trace samples `first_sample .. spp` of each pixel (a farm's sample slice; 0 for a whole render).
    pub first_sample: u32,
    /// Render the camera's depth of field (its `fStop`); `false` renders it as a pinhole
    /// (`--no-dof`).
    pub depth_of_field: bool,
    /// Render motion blur over the shutter; `false` renders every ray at time 0, the frame
    /// (`--no-motion-blur`).
    pub motion_blur: bool,
    /// The shutter `[open, close]` in time codes from the frame, overriding the camera's
    /// (`--shutter A,B`); `None` for the camera's.
    pub shutter: Option<[f32; 2]>,
    /// Adaptive sampling `(threshold, min_spp)` ([`crate::frame::Adaptive`],
    /// `--adaptive-threshold`, `--adaptive-min-spp`); `None` for uniform sampling.
    pub adaptive: Option<(f32, u32)>,
}

/// The path-tracing integrator: depth-first scalar or breadth-first wavefront (same estimator, same
/// sample keys, same image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// One path at a time ([`crate::scalar`]): the reference.
    Scalar,
    /// Stage by stage over batches of paths ([`crate::wavefront`]): the default, faster on every
    /// bench scene (`bench integrators`).
    #[default]
    Wavefront,
}

impl std::str::FromStr for Integrator {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "scalar" => Ok(Integrator::Scalar),
            "wavefront" => Ok(Integrator::Wavefront),
            _ => Err(format!("unknown integrator {s:?} (scalar or wavefront)")),
        }
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            spp: 16,
            resolution: None,
            camera: None,
            threads: 0,
            seed: 0,
            max_depth: 8,
            tile_size: 16,
            texture_filter: texture::Filter::default(),
            texture_footprint_scale: 1.0,
            texture_stats: false,
            curve_shape: None,
            integrator: Integrator::Wavefront,
            max_memory: None,
            phase_stats: false,
            crop: None,
            band: None,
            first_sample: 0,
            depth_of_field: true,
            motion_blur: true,
            shutter: None,
            adaptive: None,
        }
    }
}

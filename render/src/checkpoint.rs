//! Checkpoints: an EXR of the image so far that also carries the frame's exact pixel sums
//! ([`PixelSum`], as `sums.*` channels: f32 sums, the f64 depth sum as two u32 halves, u32 counts)
//! and what they were rendered from (the `render.checkpoint` attribute: the sample range, the blob's
//! identity, the settings that change pixels); the EXR data window is the pixels it holds. A farm's
//! part (a tile, a sample slice) is a checkpoint too, which [`crate::merge`] assembles. `render --resume` reads one back as an [`Accumulation`] and
//! continues it, so the result has the bits of an uninterrupted render; the mean of a sum stored as
//! an image would not (`mean × n` does not round back to the sum).
//!
//! The image channels are [`crate::output::write_exr`]'s, so any EXR reader shows a checkpoint as the
//! image so far.

use crate::error::RenderError;
use crate::film::{PixelSum, PixelWindow};
use crate::frame::Accumulation;
use crate::options::RenderOptions;
use exr::prelude::{read_all_flat_layers_from_file, AnyChannel, AttributeValue, FlatSamples, Text, Vec2};
use glam::Vec3;
use std::path::Path;

/// What a checkpoint's sums were rendered from; a resume must match it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Provenance {
    /// The blob's identity ([`blob_id`]).
    pub blob: u64,
    /// The options that change pixels, as text (seed, depth, camera, filters, curve shape, depth of
    /// field).
    pub settings: String,
    /// Read from a checkpoint: the [`crate::aov::Plan::stride`] of the RenderProduct sums it holds
    /// (`sums.aov.*` channels), or `None` if its render had no RenderProducts (or predates them).
    /// [`write_checkpoint`] writes the film's own plan and ignores it.
    pub product_sums: Option<usize>,
}

impl Provenance {
    /// The provenance of a render of the blob `bytes` with `options`.
    pub fn of(bytes: &[u8], options: &RenderOptions) -> Self {
        let settings = format!(
            "seed {} max_depth {} camera {:?} texture_filter {:?} footprint {} curve_shape {:?} dof {}",
            options.seed,
            options.max_depth,
            options.camera,
            options.texture_filter,
            options.texture_footprint_scale,
            options.curve_shape,
            options.depth_of_field
        );
        // Only a render that overrides the camera's shutter says so, so the provenance of every
        // other render (and of checkpoints written before motion blur) keeps its text.
        let settings = if options.motion_blur && options.shutter.is_none() {
            settings
        } else {
            format!("{settings} motion_blur {} shutter {:?}", options.motion_blur, options.shutter)
        };
        Provenance { blob: blob_id(bytes), settings, product_sums: None }
    }
}

/// A blob's identity: its header checksum, which seals the section table and through it every
/// section's checksum (a blob that validates cannot change without changing it).
pub fn blob_id(bytes: &[u8]) -> u64 {
    let header =
        bytes.get(..std::mem::size_of::<blob::Header>()).map(bytemuck::pod_read_unaligned::<blob::Header>);
    header.map_or(0, |h| h.header_checksum)
}

/// The one attribute holding the provenance and sample count, as `samples N`, `blob HEX` and
/// `settings …` lines. One attribute, because exr keeps custom attributes in a `HashMap` and writes
/// them in its per-process random order: several would give different file bytes run to run.
const ATTRIBUTE: &str = "render.checkpoint";

/// A sums channel: its name and how to read one pixel's value.
type SumChannel<T> = (&'static str, fn(&PixelSum) -> T);

const F32_SUMS: [SumChannel<f32>; 9] = [
    ("sums.R", |p| p.sum.x),
    ("sums.G", |p| p.sum.y),
    ("sums.B", |p| p.sum.z),
    ("sums.albedo.R", |p| p.albedo.x),
    ("sums.albedo.G", |p| p.albedo.y),
    ("sums.albedo.B", |p| p.albedo.z),
    ("sums.normal.X", |p| p.normal.x),
    ("sums.normal.Y", |p| p.normal.y),
    ("sums.normal.Z", |p| p.normal.z),
];
const U32_SUMS: [SumChannel<u32>; 4] = [
    ("sums.depth.hi", |p| (p.depth.to_bits() >> 32) as u32),
    ("sums.depth.lo", |p| p.depth.to_bits() as u32),
    ("sums.hits", |p| p.hits),
    ("sums.nonfinite", |p| p.nonfinite),
];

/// Most RenderProduct sums per pixel a checkpoint may claim (far above any plan: 64 expressions
/// and both Cryptomatte kinds are under 250), so a corrupt count cannot ask for a huge film.
const MAX_PRODUCT_SUMS: usize = 4096;

/// The channel of RenderProduct sum `k` of each pixel.
fn aov_channel(k: usize) -> String {
    format!("sums.aov.{k:04}")
}

/// Writes `film` to `path` atomically: the image so far plus its sums and `provenance`.
pub fn write_checkpoint(
    path: &Path,
    film: &Accumulation,
    provenance: &Provenance,
) -> Result<(), RenderError> {
    let image = film.image();
    let mut channels = crate::output::image_channels(&image);
    for (name, read) in F32_SUMS {
        channels.push(AnyChannel::new(name, FlatSamples::F32(film.sums.iter().map(read).collect())));
    }
    for (name, read) in U32_SUMS {
        channels.push(AnyChannel::new(name, FlatSamples::U32(film.sums.iter().map(read).collect())));
    }
    // The RenderProducts' sums, only when the render has products (so the checkpoints of every
    // other render keep their bytes): each as its bits, exact whatever the value (a Cryptomatte
    // id is a float's bit pattern).
    let stride = film.plan.stride();
    let products = !film.plan.products.is_empty();
    if products {
        for k in 0..stride {
            let bits = film.aov.iter().skip(k).step_by(stride).map(|v| v.to_bits()).collect();
            channels.push(AnyChannel::new(aov_channel(k).as_str(), FlatSamples::U32(bits)));
        }
    }
    let mut attributes = crate::output::layer_attributes(&image);
    let products_line = if products { format!("\nproducts {stride}") } else { String::new() };
    let text = format!(
        "first {}\nsamples {}\nregion {} {} {} {}\nblob {:016x}\nsettings {}{products_line}",
        film.first_sample,
        film.samples,
        film.region.x0,
        film.region.y0,
        film.region.x1,
        film.region.y1,
        provenance.blob,
        provenance.settings
    );
    attributes.other.insert(Text::from(ATTRIBUTE), AttributeValue::Text(Text::from(text.as_str())));
    crate::output::write_channels(path, &image, attributes, channels)
}

/// Reads a checkpoint written by [`write_checkpoint`]: the accumulation (statistics empty) and its
/// provenance. Any other file is an error naming what is missing.
pub fn read_checkpoint(path: &Path) -> Result<(Accumulation, Provenance), RenderError> {
    let fail = |message: String| RenderError::Checkpoint { path: path.to_path_buf(), message };
    let image = read_all_flat_layers_from_file(path).map_err(|e| fail(e.to_string()))?;
    let layer = image.layer_data.first().ok_or_else(|| fail("no layer".into()))?;
    let text = match layer.attributes.other.get(&Text::from(ATTRIBUTE)) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        _ => {
            return Err(fail(format!(
                "no {ATTRIBUTE} attribute: not a checkpoint (render --checkpoint writes them)"
            )))
        }
    };
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key).and_then(|v| v.strip_prefix(' ')))
            .ok_or_else(|| fail(format!("{ATTRIBUTE} has no {key} line")))
    };
    let samples = field("samples")?
        .parse::<u32>()
        .ok()
        .filter(|n| (1..=crate::film::MAX_SPP).contains(n))
        .ok_or_else(|| fail(format!("{ATTRIBUTE} has no valid sample count")))?;
    let first_sample = field("first")?
        .parse::<u32>()
        .ok()
        .filter(|&f| f < samples)
        .ok_or_else(|| fail(format!("{ATTRIBUTE} has no valid first sample")))?;
    let region: Vec<u32> = field("region")?.split(' ').filter_map(|v| v.parse().ok()).collect();
    let region = match region[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => PixelWindow { x0, y0, x1, y1 },
        _ => return Err(fail(format!("{ATTRIBUTE} has no valid region"))),
    };
    let blob = u64::from_str_radix(field("blob")?, 16).map_err(|e| fail(format!("bad blob id: {e}")))?;
    let settings = field("settings")?.to_string();
    let product_sums = match field("products") {
        Err(_) => None,
        Ok(v) => Some(
            v.parse::<usize>()
                .ok()
                .filter(|&s| s <= MAX_PRODUCT_SUMS)
                .ok_or_else(|| fail(format!("{ATTRIBUTE} has no valid products line")))?,
        ),
    };
    let display = image.attributes.display_window;
    let position = layer.attributes.layer_position;
    let (width, height) = (layer.size.width() as u32, layer.size.height() as u32);
    let frame = [display.size.width() as u32, display.size.height() as u32];
    let (x0, y0) = (position.x(), position.y());
    if x0 < 0
        || y0 < 0
        || x0 as u32 + width > frame[0]
        || y0 as u32 + height > frame[1]
        || display.position != Vec2(0, 0)
    {
        return Err(fail("its data window is not inside its display window".into()));
    }
    let window = PixelWindow { x0: x0 as u32, y0: y0 as u32, x1: x0 as u32 + width, y1: y0 as u32 + height };
    let n = width as usize * height as usize;
    let channel = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .ok_or_else(|| fail(format!("no {name} channel: not a checkpoint")))
    };
    let f32s = |name: &str| match &channel(name)?.sample_data {
        FlatSamples::F32(v) if v.len() == n => Ok(v.clone()),
        _ => Err(fail(format!("channel {name} is not {n} f32 samples"))),
    };
    let u32s = |name: &str| match &channel(name)?.sample_data {
        FlatSamples::U32(v) if v.len() == n => Ok(v.clone()),
        _ => Err(fail(format!("channel {name} is not {n} u32 samples"))),
    };
    let f: Vec<Vec<f32>> = F32_SUMS.iter().map(|(name, _)| f32s(name)).collect::<Result<_, _>>()?;
    let u: Vec<Vec<u32>> = U32_SUMS.iter().map(|(name, _)| u32s(name)).collect::<Result<_, _>>()?;
    let sums = (0..n)
        .map(|i| PixelSum {
            sum: Vec3::new(f[0][i], f[1][i], f[2][i]),
            albedo: Vec3::new(f[3][i], f[4][i], f[5][i]),
            normal: Vec3::new(f[6][i], f[7][i], f[8][i]),
            depth: f64::from_bits((u64::from(u[0][i]) << 32) | u64::from(u[1][i])),
            hits: u[2][i],
            nonfinite: u[3][i],
        })
        .collect();
    let stride = product_sums.unwrap_or(0);
    let mut aov = vec![0.0f32; n * stride];
    for k in 0..stride {
        let bits = u32s(&aov_channel(k))?;
        for (i, b) in bits.into_iter().enumerate() {
            aov[i * stride + k] = f32::from_bits(b);
        }
    }
    let inside = |w: &PixelWindow| w.x1 <= frame[0] && w.y1 <= frame[1];
    if !inside(&region)
        || window.x0 < region.x0
        || window.y0 < region.y0
        || window.x1 > region.x1
        || window.y1 > region.y1
    {
        return Err(fail("its pixels are not inside its region, or its region not inside its frame".into()));
    }
    let film = Accumulation {
        window,
        region,
        frame,
        first_sample,
        samples,
        sums,
        plan: Default::default(),
        aov,
        stats: Default::default(),
        adaptive: None,
    };
    Ok((film, Provenance { blob, settings, product_sums }))
}

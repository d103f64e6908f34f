//! Texture files → [`SourceImage`]: png, jpg, tga, tif, hdr via `image`; exr via `exr`.
//!
//! The decoded image keeps its bit depth (8-bit, 16-bit or float) because the colour-space rule and the
//! stored format both depend on it, and its channel count (1..=4) because the bake keeps it.
//!
//! Memory is budgeted before it is spent: the size a file declares is read from its header and checked
//! against [`DecodeLimits::max_pixels`] before any pixel buffer is allocated (a 95-byte PNG can declare
//! 100000×100000, which the decoders would otherwise try to allocate whole; a small PNG of a flat colour
//! can decode to gigabytes). The `image` decoders also get an allocation cap sized from that budget, so
//! their own buffers are bounded too.

use std::path::Path;

use crate::error::{Error, ErrorKind};
use crate::record::MAX_DIMENSION;

/// Decoded samples, in the source's bit depth.
#[derive(Clone, Debug, PartialEq)]
pub enum Samples {
    /// 8-bit sources (png, jpg, tga, 8-bit tif).
    U8(Vec<u8>),
    /// 16-bit sources (png, tif).
    U16(Vec<u16>),
    /// Float sources (hdr, exr, float tif). EXR half samples are widened to `f32`.
    F32(Vec<f32>),
}

/// A decoded image: rows top-down as in the file, channels interleaved.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA.
    pub channels: u32,
    /// `width * height * channels` samples.
    pub samples: Samples,
}

impl SourceImage {
    /// Checks the invariants the bake relies on.
    pub(crate) fn validate(&self, path: &Path) -> Result<(), Error> {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 || w > MAX_DIMENSION || h > MAX_DIMENSION {
            return Err(Error::new(path, ErrorKind::Size { width: w, height: h }));
        }
        if !(1..=4).contains(&self.channels) {
            return Err(Error::new(path, ErrorKind::Channels(format!("{} channels", self.channels))));
        }
        let len = match &self.samples {
            Samples::U8(v) => v.len(),
            Samples::U16(v) => v.len(),
            Samples::F32(v) => v.len(),
        };
        if len != w as usize * h as usize * self.channels as usize {
            return Err(Error::new(path, ErrorKind::Channels(format!("{len} samples for {w}x{h}"))));
        }
        Ok(())
    }
}

/// Most pixels a texture may declare by default: 2^28, a 16k × 16k image (4 GiB as RGBA float, the
/// largest production textures; a decoded 16-bit RGBA one is 2 GiB).
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 28;

/// Bytes per pixel of the widest decoded layout (RGBA `f32`), to size the decoders' allocation cap.
const MAX_BYTES_PER_PIXEL: u64 = 16;

/// What a decode may spend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodeLimits {
    /// Most pixels (width × height) a file may declare; larger ones are refused from their header.
    pub max_pixels: u64,
}

impl Default for DecodeLimits {
    fn default() -> Self {
        DecodeLimits { max_pixels: DEFAULT_MAX_PIXELS }
    }
}

impl DecodeLimits {
    /// Refuses a declared size above the budget, or above [`MAX_DIMENSION`] per side, before anything is
    /// allocated for it.
    fn check(&self, path: &Path, width: u64, height: u64) -> Result<(), Error> {
        if width.saturating_mul(height) > self.max_pixels {
            return Err(Error::new(
                path,
                ErrorKind::TooManyPixels { width, height, max_pixels: self.max_pixels },
            ));
        }
        let side = |v: u64| u32::try_from(v).unwrap_or(u32::MAX);
        if width > u64::from(MAX_DIMENSION) || height > u64::from(MAX_DIMENSION) {
            return Err(Error::new(path, ErrorKind::Size { width: side(width), height: side(height) }));
        }
        Ok(())
    }

    /// The `image` crate's limits for this budget: allocations up to the budget's widest decoded image
    /// (plus room for a decoder's working buffers). Sizes are left to [`DecodeLimits::check`], whose
    /// error names them.
    fn image_limits(&self) -> image::Limits {
        let mut limits = image::Limits::no_limits();
        limits.max_alloc = Some(self.max_pixels.saturating_mul(MAX_BYTES_PER_PIXEL).saturating_add(64 << 20));
        limits
    }
}

/// Decodes a texture file, choosing the decoder by extension (`.exr`) or by content, within the default
/// [`DecodeLimits`].
pub fn decode(path: &Path) -> Result<SourceImage, Error> {
    decode_with(path, &DecodeLimits::default())
}

/// [`decode`] within `limits`.
pub fn decode_with(path: &Path, limits: &DecodeLimits) -> Result<SourceImage, Error> {
    let is_exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let img = if is_exr {
        let meta = exr::meta::MetaData::read_from_file(path, false)
            .map_err(|e| Error::new(path, ErrorKind::Exr(e)))?;
        check_exr(path, &meta, limits)?;
        let image = exr::prelude::read_first_flat_layer_from_file(path)
            .map_err(|e| Error::new(path, ErrorKind::Exr(e)))?;
        decode_exr(path, image)?
    } else {
        let reader = image::ImageReader::open(path).map_err(|e| Error::new(path, ErrorKind::Io(e)))?;
        decode_image(path, reader, limits)?
    };
    img.validate(path)?;
    Ok(img)
}

/// Decodes a texture already in memory (an entry of a `.usdz` package, read without extracting it);
/// `name` (the entry's path) picks the decoder by extension like [`decode`] and names errors. Within the
/// default [`DecodeLimits`].
pub fn decode_bytes(bytes: &[u8], name: &Path) -> Result<SourceImage, Error> {
    decode_bytes_with(bytes, name, &DecodeLimits::default())
}

/// [`decode_bytes`] within `limits`.
pub fn decode_bytes_with(bytes: &[u8], name: &Path, limits: &DecodeLimits) -> Result<SourceImage, Error> {
    let is_exr = name.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let img = if is_exr {
        let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
            .map_err(|e| Error::new(name, ErrorKind::Exr(e)))?;
        check_exr(name, &meta, limits)?;
        // What `read_first_flat_layer_from_file` reads, from a buffer.
        use exr::prelude::{ReadChannels, ReadLayers};
        let image = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(bytes))
            .map_err(|e| Error::new(name, ErrorKind::Exr(e)))?;
        decode_exr(name, image)?
    } else {
        let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
        // TGA has no signature to guess from: start from the extension, as `ImageReader::open` does.
        if let Ok(format) = image::ImageFormat::from_path(name) {
            reader.set_format(format);
        }
        decode_image(name, reader, limits)?
    };
    img.validate(name)?;
    Ok(img)
}

/// Every part of the file is checked against `limits`: the largest layer's declared size (the one the
/// reader decodes).
fn check_exr(path: &Path, meta: &exr::meta::MetaData, limits: &DecodeLimits) -> Result<(), Error> {
    for header in meta.headers.iter() {
        limits.check(path, header.layer_size.0 as u64, header.layer_size.1 as u64)?;
    }
    Ok(())
}

fn decode_image<R: std::io::BufRead + std::io::Seek>(
    path: &Path,
    reader: image::ImageReader<R>,
    limits: &DecodeLimits,
) -> Result<SourceImage, Error> {
    use image::{DynamicImage as D, ImageDecoder};
    let err = |e| Error::new(path, ErrorKind::Image(e));
    let mut reader = reader.with_guessed_format().map_err(|e| Error::new(path, ErrorKind::Io(e)))?;
    // Production textures (16k 16-bit) exceed the crate's default 512 MiB allocation limit, so the cap is
    // sized from the pixel budget instead.
    reader.limits(limits.image_limits());
    // The decoder reads the header only; its declared size is checked before the pixels are allocated.
    let decoder = reader.into_decoder().map_err(err)?;
    let (width, height) = decoder.dimensions();
    limits.check(path, width.into(), height.into())?;
    let dynamic = D::from_decoder(decoder).map_err(err)?;
    let (width, height) = (dynamic.width(), dynamic.height());
    let (channels, samples) = match dynamic {
        D::ImageLuma8(b) => (1, Samples::U8(b.into_raw())),
        D::ImageLumaA8(b) => (2, Samples::U8(b.into_raw())),
        D::ImageRgb8(b) => (3, Samples::U8(b.into_raw())),
        D::ImageRgba8(b) => (4, Samples::U8(b.into_raw())),
        D::ImageLuma16(b) => (1, Samples::U16(b.into_raw())),
        D::ImageLumaA16(b) => (2, Samples::U16(b.into_raw())),
        D::ImageRgb16(b) => (3, Samples::U16(b.into_raw())),
        D::ImageRgba16(b) => (4, Samples::U16(b.into_raw())),
        D::ImageRgb32F(b) => (3, Samples::F32(b.into_raw())),
        D::ImageRgba32F(b) => (4, Samples::F32(b.into_raw())),
        // `DynamicImage` is non-exhaustive; anything newer goes through RGBA float.
        other => (4, Samples::F32(other.into_rgba32f().into_raw())),
    };
    Ok(SourceImage { width, height, channels, samples })
}

type ExrImage =
    exr::prelude::Image<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>>;

/// Reads the first valid layer's largest level with all its channels, then picks R, G, B, A or Y by name
/// (the part after the last `.`, so `diffuse.R` counts as `R`). A layer with a single channel of another
/// name (`Z`, `mask`) is read as grey.
fn decode_exr(path: &Path, image: ExrImage) -> Result<SourceImage, Error> {
    let layer = &image.layer_data;
    let (w, h) = (layer.size.0, layer.size.1);
    let list = &layer.channel_data.list;
    let find = |want: &str| {
        list.iter().position(|c| {
            let name = c.name.to_string();
            name.rsplit('.').next().is_some_and(|n| n.eq_ignore_ascii_case(want))
        })
    };
    let picks: Vec<usize> = match (find("R"), find("G"), find("B"), find("Y"), find("A")) {
        (Some(r), Some(g), Some(b), _, a) => [Some(r), Some(g), Some(b), a].into_iter().flatten().collect(),
        (_, _, _, Some(y), a) => [Some(y), a].into_iter().flatten().collect(),
        _ if list.len() == 1 => vec![0],
        _ => {
            let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
            return Err(Error::new(path, ErrorKind::Channels(format!("EXR channels {names:?}"))));
        }
    };
    let c = picks.len();
    let mut data = vec![0.0f32; w * h * c];
    for (k, &ch) in picks.iter().enumerate() {
        for (i, v) in list[ch].sample_data.values_as_f32().enumerate().take(w * h) {
            data[i * c + k] = v;
        }
    }
    Ok(SourceImage { width: w as u32, height: h as u32, channels: c as u32, samples: Samples::F32(data) })
}

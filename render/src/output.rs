//! Writing images: a multi-channel OpenEXR (beauty RGBA plus `albedo.*`, `normal.*` and `depth.Z`
//! layers, 32-bit float, linear; a cropped render's data window inside the frame's display window)
//! and an 8-bit sRGB PNG preview of the beauty (the data window only); and the rules every output
//! of render follows.
//!
//! * **Atomic**: each output is written to a temporary file in its own directory, fsynced and renamed
//!   over the target ([`write_atomic_with`]). A full disk or a kill leaves the previous file intact and
//!   never a truncated one under the target name. An existing device or pipe (`-o /dev/null`) is written
//!   directly: a rename would replace the node itself.
//! * **Stale temporaries**: the temporary is `.NAME.render-tmp-PID`; [`check_outputs`] removes those
//!   whose process no longer runs (Linux `/proc`), so an interrupted run's leftovers go with the next run.
//! * **Checked before work** ([`check_outputs`]): an output that is the input blob (same path after
//!   canonicalisation, or the same device and inode: a hard link or symlink), two outputs naming the same
//!   file, an output that is a directory, and an output directory where no file can be created are all
//!   refused before the blob is rendered.

use crate::error::RenderError;
use crate::film::Image;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Prefix-free suffix of render's temporary files (see the module docs).
const TEMP_TAG: &str = ".render-tmp-";

/// The temporary beside `path` of the process `pid`: `.NAME.render-tmp-PID`.
fn temp_path(path: &Path, pid: u32) -> Result<PathBuf, RenderError> {
    let name = path.file_name().ok_or_else(|| RenderError::Output {
        path: path.to_path_buf(),
        message: "the output path has no file name".into(),
    })?;
    Ok(output_dir(path).join(format!(".{}{TEMP_TAG}{pid}", name.to_string_lossy())))
}

/// The directory an output goes to (`.` for a bare file name).
fn output_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Writes `path` atomically: `write` fills a temporary file in the target's directory, which is flushed,
/// fsynced and renamed over `path`. On any error the temporary is removed and `path` is untouched (a
/// previous file of that name stays as it was).
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), String>,
) -> Result<(), RenderError> {
    let fail = |message: String| RenderError::Output { path: path.to_path_buf(), message };
    if is_special(path) {
        // A device or pipe (`-o /dev/null`): renaming over it would replace the node with a file.
        let file = std::fs::OpenOptions::new().write(true).open(path).map_err(|e| fail(e.to_string()))?;
        let mut out = BufWriter::new(file);
        write(&mut out).map_err(fail)?;
        return out.flush().map_err(|e| fail(e.to_string()));
    }
    let temp = temp_path(path, std::process::id())?;
    let result = (|| {
        let file = File::create(&temp).map_err(|e| format!("cannot create {}: {e}", temp.display()))?;
        let mut out = BufWriter::new(file);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| e.error().to_string())?;
        file.sync_all().map_err(|e| e.to_string())?;
        drop(file);
        std::fs::rename(&temp, path).map_err(|e| e.to_string())?;
        if let Ok(dir) = File::open(output_dir(path)) {
            // Persist the rename; some filesystems cannot fsync a directory, which is harmless.
            let _ = dir.sync_all();
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result.map_err(fail)
}

/// Whether `path` exists and is neither a regular file nor a directory (a device, a pipe, a socket).
fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Writes `text` to `path` atomically (the statistics JSON).
pub fn write_text(path: &Path, text: &str) -> Result<(), RenderError> {
    write_atomic_with(path, |out| out.write_all(text.as_bytes()).map_err(|e| e.to_string()))
}

/// Device and inode: the identity of a file whatever path names it.
type FileId = (u64, u64);

/// The [`FileId`] of `meta` (none off Unix: canonical paths alone are compared there).
#[cfg(unix)]
fn file_id(meta: &std::fs::Metadata) -> Option<FileId> {
    use std::os::unix::fs::MetadataExt;
    Some((meta.dev(), meta.ino()))
}

#[cfg(not(unix))]
fn file_id(_: &std::fs::Metadata) -> Option<FileId> {
    None
}

/// Where `path` points: its directory canonicalised, joined with its file name (the file itself may not
/// exist yet).
fn canonical_target(path: &Path) -> Option<PathBuf> {
    Some(std::fs::canonicalize(output_dir(path)).ok()?.join(path.file_name()?))
}

/// Removes the temporaries of `path` left by runs that are no longer alive (see the module docs).
/// Returns how many were removed. Without `/proc` nothing is removed (liveness is unknown).
pub fn remove_stale_temporaries(path: &Path) -> usize {
    let (Some(name), true) = (path.file_name(), Path::new("/proc/self").exists()) else { return 0 };
    let prefix = format!(".{}{TEMP_TAG}", name.to_string_lossy());
    let Ok(entries) = std::fs::read_dir(output_dir(path)) else { return 0 };
    let mut removed = 0;
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(pid) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else { continue };
        let Ok(pid) = pid.parse::<u32>() else { continue };
        if pid != std::process::id()
            && !Path::new(&format!("/proc/{pid}")).exists()
            && std::fs::remove_file(entry.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// Refuses, before any work, outputs that would destroy the input `blob` or each other, or that cannot
/// be written (see the module docs); removes stale temporaries of each output. `outputs` are
/// `(option, path)` pairs such as `("-o", out.exr)`, named in the errors.
pub fn check_outputs(blob: &Path, outputs: &[(&str, &Path)]) -> Result<(), RenderError> {
    let blob_meta = std::fs::metadata(blob).ok();
    let blob_id = blob_meta.as_ref().and_then(file_id);
    let blob_canonical = std::fs::canonicalize(blob).ok();
    // (option, canonical target, file identity) of the outputs checked so far.
    let mut seen: Vec<(&str, Option<PathBuf>, Option<FileId>)> = Vec::new();
    for &(option, path) in outputs {
        let refuse = |message: String| RenderError::Output { path: path.to_path_buf(), message };
        let meta = std::fs::metadata(path).ok();
        if meta.as_ref().is_some_and(|m| m.is_dir()) {
            return Err(refuse(format!("{option} names a directory")));
        }
        let id = meta.as_ref().and_then(file_id);
        let target = canonical_target(path);
        if (id.is_some() && id == blob_id) || (target.is_some() && target == blob_canonical) {
            return Err(RenderError::OutputIsInput { option: option.into(), path: path.to_path_buf() });
        }
        if let Some((other, ..)) =
            seen.iter().find(|(_, t, i)| (target.is_some() && *t == target) || (id.is_some() && *i == id))
        {
            return Err(refuse(format!("{option} and {other} name the same file")));
        }
        seen.push((option, target, id));
        if is_special(path) {
            continue;
        }
        remove_stale_temporaries(path);
        // Probe the directory with the temporary the write will use, so that an unwritable directory
        // fails now rather than after the render.
        let probe = temp_path(path, std::process::id())?;
        File::create(&probe)
            .map_err(|e| refuse(format!("cannot create a file in {}: {e}", output_dir(path).display())))?;
        let _ = std::fs::remove_file(&probe);
    }
    Ok(())
}

/// Writes `image` as an OpenEXR file with the layers `R G B A`, `albedo.{R,G,B}`, `normal.{X,Y,Z}`
/// and `depth.Z`.
pub fn write_exr(path: &Path, image: &Image) -> Result<(), RenderError> {
    write_channels(path, image, layer_attributes(image), image_channels(image))
}

/// The image's channels as [`write_exr`] writes them.
pub(crate) fn image_channels(image: &Image) -> Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>> {
    use exr::prelude::*;
    let channel = |name: &str, values: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(values));
    let beauty = |c: usize| image.beauty.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let albedo = |c: usize| image.albedo.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let normal = |c: usize| image.normal.iter().map(|p| p[c]).collect::<Vec<f32>>();
    vec![
        channel("R", beauty(0)),
        channel("G", beauty(1)),
        channel("B", beauty(2)),
        channel("A", beauty(3)),
        channel("albedo.R", albedo(0)),
        channel("albedo.G", albedo(1)),
        channel("albedo.B", albedo(2)),
        channel("normal.X", normal(0)),
        channel("normal.Y", normal(1)),
        channel("normal.Z", normal(2)),
        channel("depth.Z", image.depth.clone()),
    ]
}

/// The layer's attributes: named `beauty`, placed at the image's origin in the frame (a cropped image
/// is the data window of its frame, as compositors expect of a region render).
pub(crate) fn layer_attributes(image: &Image) -> exr::prelude::LayerAttributes {
    use exr::prelude::*;
    LayerAttributes {
        layer_position: Vec2(image.origin[0] as i32, image.origin[1] as i32),
        ..LayerAttributes::named("beauty")
    }
}

/// Writes one layer of `channels` with `attributes`, the image's frame as the display window.
pub(crate) fn write_channels(
    path: &Path,
    image: &Image,
    attributes: exr::prelude::LayerAttributes,
    channels: Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>>,
) -> Result<(), RenderError> {
    write_layer(path, [image.width, image.height], image.frame, attributes, channels)
}

/// Writes one layer of `channels` of `size` pixels with `attributes` in a `frame` display window.
fn write_layer(
    path: &Path,
    size: [u32; 2],
    frame: [u32; 2],
    attributes: exr::prelude::LayerAttributes,
    channels: Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>>,
) -> Result<(), RenderError> {
    use exr::prelude::*;
    let size = (size[0] as usize, size[1] as usize);
    let layer = Layer::new(
        size,
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let frame = (frame[0] as usize, frame[1] as usize);
    // Sequential compression: exr's parallel writer emits blocks in completion order, so the same pixels
    // would give different file bytes from run to run.
    let image = exr::prelude::Image::new(ImageAttributes::new(IntegerBounds::from_dimensions(frame)), layer);
    write_atomic_with(path, |out| image.write().non_parallel().to_buffered(out).map_err(|e| e.to_string()))
}

/// Where a render product named `product_name` is written: as named when absolute, else beside
/// `output` (the `-o` beauty), so a stage's relative `productName`s follow the render's output
/// directory rather than the working directory.
pub fn product_path(output: &Path, product_name: &str) -> PathBuf {
    let name = Path::new(product_name);
    if name.is_absolute() {
        name.to_path_buf()
    } else {
        output_dir(output).join(name)
    }
}

/// Writes one render product of `film` ([`crate::Accumulation::products`]): its `channels` as one
/// layer named after the product's prim, with the film's data window in its frame, and the string
/// header attributes `text` ([`crate::aov::Plan::attributes`]).
///
/// The exr crate keeps custom attributes in a `HashMap` and writes them in its iteration order,
/// which changes from run to run; they are written as one contiguous run at the end of the header,
/// so this reorders that run by name in the encoded bytes (the header keeps its length, so the
/// offset table stays valid) and a product's bytes are the same on every run.
pub fn write_product(
    path: &Path,
    film: &crate::Accumulation,
    product: &crate::aov::Product,
    channels: Vec<(String, Vec<f32>)>,
    text: &[(String, String)],
) -> Result<(), RenderError> {
    use exr::prelude::*;
    let fail = |message: String| RenderError::Output { path: path.to_path_buf(), message };
    let name = product.path.rsplit('/').next().unwrap_or(&product.path);
    let mut attributes = LayerAttributes {
        layer_position: Vec2(film.window.x0 as i32, film.window.y0 as i32),
        ..LayerAttributes::named(name)
    };
    for (key, value) in text {
        let text = |s: &str| Text::from_slice_unchecked(s.as_bytes());
        attributes.other.insert(text(key), AttributeValue::Text(text(value)));
    }
    let channels = channels
        .into_iter()
        .map(|(n, values)| AnyChannel::new(n.as_str(), FlatSamples::F32(values)))
        .collect();
    let layer = Layer::new(
        (film.window.width() as usize, film.window.height() as usize),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let frame = IntegerBounds::from_dimensions((film.frame[0] as usize, film.frame[1] as usize));
    let image = exr::prelude::Image::new(ImageAttributes::new(frame), layer);
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write().non_parallel().to_buffered(&mut bytes).map_err(|e| fail(e.to_string()))?;
    let mut bytes = bytes.into_inner();
    let names: Vec<&str> = text.iter().map(|(k, _)| k.as_str()).collect();
    sort_text_attributes(&mut bytes, &names).map_err(fail)?;
    write_atomic_with(path, |out| out.write_all(&bytes).map_err(|e| e.to_string()))
}

/// Sorts the string attributes `names` of an encoded single-part EXR by name, in place (see
/// [`write_product`]). Each is found by its `name\0string\0` prefix; they must form one
/// contiguous run.
fn sort_text_attributes(bytes: &mut [u8], names: &[&str]) -> Result<(), String> {
    if names.is_empty() {
        return Ok(());
    }
    let mut records: Vec<(usize, usize, &str)> = Vec::new();
    for &name in names {
        let prefix = [name.as_bytes(), b"\0string\0"].concat();
        let start = bytes
            .windows(prefix.len())
            .position(|w| w == prefix.as_slice())
            .ok_or_else(|| format!("the EXR header lacks its attribute {name}"))?;
        let size_at = start + prefix.len();
        let size = bytes.get(size_at..size_at + 4).ok_or("a truncated EXR header")?;
        let size = u32::from_le_bytes([size[0], size[1], size[2], size[3]]) as usize;
        records.push((start, prefix.len() + 4 + size, name));
    }
    let begin = records.iter().map(|r| r.0).min().unwrap_or(0);
    let end = records.iter().map(|r| r.0 + r.1).max().unwrap_or(0);
    if records.iter().map(|r| r.1).sum::<usize>() != end - begin {
        return Err("the EXR header's string attributes are not one run".into());
    }
    records.sort_by_key(|r| r.2);
    let sorted: Vec<u8> = records.iter().flat_map(|&(at, len, _)| bytes[at..at + len].to_vec()).collect();
    bytes[begin..end].copy_from_slice(&sorted);
    Ok(())
}

/// The sRGB opto-electronic transfer function of a linear value in [0, 1].
pub fn srgb_oetf(linear: f32) -> f32 {
    let x = linear.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes the beauty as an 8-bit sRGB PNG (clamped, alpha dropped).
pub fn write_png(path: &Path, image: &Image) -> Result<(), RenderError> {
    let mut pixels = Vec::with_capacity(image.beauty.len() * 3);
    for p in &image.beauty {
        for &c in &p[..3] {
            let c = if c.is_finite() { c } else { 0.0 };
            pixels.push((srgb_oetf(c) * 255.0 + 0.5) as u8);
        }
    }
    write_atomic_with(path, |out| {
        image::write_buffer_with_format(
            out,
            &pixels,
            image.width,
            image.height,
            image::ColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| e.to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::RenderStats;

    #[test]
    fn exr_and_png_round_trip() {
        let image = Image {
            width: 3,
            height: 2,
            origin: [0, 0],
            frame: [3, 2],
            beauty: (0..6).map(|i| [i as f32 * 0.25, 0.5, 1.5, 1.0]).collect(),
            albedo: vec![[0.5; 3]; 6],
            normal: vec![[0.0, 0.0, 1.0]; 6],
            depth: vec![2.0; 6],
            stats: RenderStats::default(),
        };
        let dir = tempfile::tempdir().unwrap();
        let exr_path = dir.path().join("out.exr");
        write_exr(&exr_path, &image).unwrap();
        let read = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
        let layer = &read.layer_data[0];
        let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
        for expected in ["R", "G", "B", "A", "albedo.R", "normal.Z", "depth.Z"] {
            assert!(names.iter().any(|n| n == expected), "{names:?}");
        }
        let r = layer.channel_data.list.iter().find(|c| c.name.to_string() == "R").unwrap();
        assert_eq!(r.sample_data.value_by_flat_index(5).to_f32(), 1.25);

        let png_path = dir.path().join("out.png");
        write_png(&png_path, &image).unwrap();
        let png = image::open(&png_path).unwrap().to_rgb8();
        assert_eq!(png.get_pixel(2, 0).0, [188, 188, 255]); // 0.5 → 188 in sRGB, 1.5 clamps
        assert_eq!(png.get_pixel(0, 0).0[0], 0);
    }

    #[test]
    fn a_failed_write_keeps_the_previous_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        std::fs::write(&path, b"the previous good image").unwrap();
        // What a full disk does mid-write: some bytes out, then an error.
        let err = write_atomic_with(&path, |out| {
            out.write_all(&[0u8; 10_000]).map_err(|e| e.to_string())?;
            Err("No space left on device (os error 28)".into())
        })
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            format!("cannot write {}: No space left on device (os error 28)", path.display())
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"the previous good image");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary left behind");
        write_text(&path, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // A device is written through, not replaced.
        write_text(Path::new("/dev/null"), "discarded").unwrap();
        assert!(!std::fs::metadata("/dev/null").unwrap().is_file());
    }

    #[test]
    fn outputs_aliasing_the_blob_or_each_other_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let blob = dir.path().join("scene.blob");
        std::fs::write(&blob, b"blob").unwrap();
        let link = dir.path().join("alias.blob");
        std::os::unix::fs::symlink(&blob, &link).unwrap();
        let out = dir.path().join("out.exr");
        let err = check_outputs(&blob, &[("-o", &out), ("--png", &link)]).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!("refusing to write --png {}: it is the input blob", link.display())
        );
        let err = check_outputs(&blob, &[("-o", &out), ("--stats", &out)]).unwrap_err();
        assert!(err.to_string().ends_with("--stats and -o name the same file"), "{err}");
        check_outputs(&blob, &[("-o", &out), ("--png", &dir.path().join("out.png"))]).unwrap();
        assert!(!out.exists(), "the writability probe leaves nothing behind");
        assert_eq!(std::fs::read(&blob).unwrap(), b"blob");
    }
}

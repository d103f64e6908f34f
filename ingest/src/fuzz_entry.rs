//! The functions the coverage-guided fuzz targets (`ingest/fuzz`, run by `scripts/fuzz.sh`) call,
//! public so that the normal test suite replays the committed corpora and regression inputs
//! through exactly the same code without libFuzzer (`tests/fuzz_corpus.rs`).
//!
//! Each takes arbitrary bytes and returns `Ok` or the error the reader gave: any error is an
//! acceptable outcome, a panic is a finding. A panic inside the composition engine is caught by
//! [`usd::load`] and returned as [`UsdErrorKind::Internal`]; these functions turn that back into
//! a panic (it is a bug, just one the binary survives) so libFuzzer reports it.
//!
//! The layer targets go through [`usd::load`] on a file, not a layer parser alone: the reader
//! opens layers through its resolver (normalization, crate-file checks, MaterialX translation)
//! and then composes and converts the stage, and the bytes-to-scene path is what a hostile file
//! reaches. Each input is written to a directory private to the thread, named with the extension that picks the reader.
//!
//! Budgets are tighter than the defaults so that an input that honestly asks for a lot is refused
//! before it nears libFuzzer's RSS limit (2 GiB in `scripts/fuzz.sh`), while a too-large request
//! that slipped past a budget still shows up as an out-of-memory finding.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::usd::{self, LoadOptions, UsdErrorKind};

/// Most pixels a fuzzed texture may declare: 4 M (64 MiB as float RGBA).
pub const FUZZ_MAX_PIXELS: u64 = 1 << 22;

/// The extensions [`texture_decode`] picks from with the input's first byte: one per decoder.
pub const TEXTURE_EXTENSIONS: [&str; 6] = ["png", "jpg", "tga", "tif", "hdr", "exr"];

/// A `.usda` layer: text normalization, the USDA parser, composition, conversion.
pub fn usda(bytes: &[u8]) -> Result<(), String> {
    layer(bytes, "usda")
}

/// A `.usdc` crate file: the crate check and repair, the crate reader, composition, conversion.
pub fn usdc(bytes: &[u8]) -> Result<(), String> {
    layer(bytes, "usdc")
}

/// A `.usdz` package: the zip reader and the layers and textures inside it.
pub fn usdz(bytes: &[u8]) -> Result<(), String> {
    layer(bytes, "usdz")
}

/// An Alembic archive: the Ogawa reader, the translation to a USD layer, composition and
/// conversion ([`crate::alembic::load`]). A panic in the archive reader is a finding.
pub fn abc(bytes: &[u8]) -> Result<(), String> {
    let path = scratch().join("archive.abc");
    std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    let options = LoadOptions { max_texture_pixels: FUZZ_MAX_PIXELS, ..LoadOptions::default() };
    crate::alembic::load(&path, &options).map(drop).map_err(|e| e.to_string())
}

/// A MaterialX document: its translation to USDA and, when that succeeds, a root layer that
/// references it, composed as a `.mtlx` reference is in a real stage.
pub fn mtlx(bytes: &[u8]) -> Result<(), String> {
    let text = std::str::from_utf8(bytes).map_err(|e| format!("doc.mtlx: not UTF-8 text: {e}"))?;
    crate::usd::translate_mtlx(text, "doc.mtlx")?;
    let dir = scratch();
    let document = dir.join("doc.mtlx");
    std::fs::write(&document, bytes).map_err(|e| format!("{}: {e}", document.display()))?;
    let root =
        "#usda 1.0\n\ndef Xform \"World\" (\n    references = @./doc.mtlx@</MaterialX/Materials>\n)\n{\n}\n";
    load(&dir, root.as_bytes(), "usda")
}

/// A texture file: the input's first byte picks the decoder's name
/// ([`TEXTURE_EXTENSIONS`], modulo their count), the rest is the file, decoded within
/// [`FUZZ_MAX_PIXELS`].
pub fn texture_decode(bytes: &[u8]) -> Result<(), String> {
    let Some((&selector, file)) = bytes.split_first() else { return Ok(()) };
    let extension = TEXTURE_EXTENSIONS[usize::from(selector) % TEXTURE_EXTENSIONS.len()];
    let name = PathBuf::from(format!("fuzz.{extension}"));
    let limits = texture::DecodeLimits { max_pixels: FUZZ_MAX_PIXELS };
    texture::decode_bytes_with(file, &name, &limits).map(drop).map_err(|e| e.to_string())
}

/// Writes `bytes` as `layer.<extension>` in the scratch directory and loads it.
fn layer(bytes: &[u8], extension: &str) -> Result<(), String> {
    load(&scratch(), bytes, extension)
}

fn load(dir: &Path, bytes: &[u8], extension: &str) -> Result<(), String> {
    let path = dir.join(format!("layer.{extension}"));
    std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    // Lenient: a seed whose references are missing from the scratch directory still composes the
    // rest, so mutations reach past the first missing file.
    let options =
        LoadOptions { lenient: true, max_texture_pixels: FUZZ_MAX_PIXELS, ..LoadOptions::default() };
    match usd::load(&path, &options) {
        Ok(_) => Ok(()),
        Err(e) if matches!(e.kind(), UsdErrorKind::Internal(_)) => panic!("reader panic: {e}"),
        Err(e) => Err(e.to_string()),
    }
}

/// A directory private to this thread (the replay tests run targets on parallel threads, each
/// writing `layer.<extension>`), created once per thread.
fn scratch() -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    thread_local! {
        static DIR: PathBuf = {
            let n = NEXT.fetch_add(1, Ordering::Relaxed);
            let dir = std::env::temp_dir().join(format!("ingest-fuzz-{}-{n}", std::process::id()));
            std::fs::create_dir_all(&dir).expect("cannot create the fuzz scratch directory");
            dir
        };
    }
    DIR.with(PathBuf::clone)
}

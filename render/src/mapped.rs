//! Getting blob bytes into memory: a read-only memory map (the renderer's path) or an aligned copy
//! (for tests and for files that cannot be mapped).

use crate::error::RenderError;
use blob::{AlignedBytes, SceneView};
use std::path::Path;

/// A read-only memory map of a blob file (or nothing, for an empty file, which mmap rejects).
pub struct MappedBlob {
    map: Option<memmap2::Mmap>,
}

impl std::ops::Deref for MappedBlob {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.map.as_deref().unwrap_or(&[])
    }
}

/// Memory-maps the blob at `path` read-only. The map starts on a page boundary, so every 64-byte
/// aligned section can be cast in place.
///
/// # Safety
/// The file must not be modified or truncated by anyone (this or another process) while the returned
/// map or anything borrowed from it is alive: the map aliases the file's pages, so a concurrent write
/// changes memory behind validated `&[T]` slices, and a truncation turns reads into `SIGBUS`. Blobs are
/// written atomically (temporary file + rename, see [`blob::write_atomic`]), which replaces the file
/// instead of modifying it, so re-running ingest on the same path is safe.
pub unsafe fn map_blob(path: &Path) -> Result<MappedBlob, RenderError> {
    let io_err = |source| RenderError::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::open(path).map_err(io_err)?;
    let len = file.metadata().map_err(io_err)?.len();
    if len == 0 {
        return Ok(MappedBlob { map: None });
    }
    // SAFETY: the caller guarantees the file is not modified or truncated while the map lives (see the
    // `# Safety` section); the map is read-only.
    let map = unsafe { memmap2::Mmap::map(&file) }.map_err(io_err)?;
    Ok(MappedBlob { map: Some(map) })
}

/// Reads the blob at `path` into a 64-byte aligned buffer (no mapping; safe but copies).
pub fn read_blob(path: &Path) -> Result<AlignedBytes, RenderError> {
    let bytes = std::fs::read(path).map_err(|source| RenderError::Io { path: path.to_path_buf(), source })?;
    Ok(AlignedBytes::copy_from(&bytes))
}

/// Validates blob `bytes` read from `path` (named in the error).
pub fn parse_blob<'a>(path: &Path, bytes: &'a [u8]) -> Result<SceneView<'a>, RenderError> {
    SceneView::parse(bytes).map_err(|source| RenderError::Blob { path: path.to_path_buf(), source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene;

    fn write_temp(bytes: &[u8]) -> tempfile::NamedTempFile {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        std::io::Write::write_all(&mut f, bytes).unwrap();
        f
    }

    #[test]
    fn corrupted_and_truncated_blobs_are_errors_not_panics() {
        let good = testscene::random_triangles(20, 1).encode();
        let mut cases: Vec<(&str, Vec<u8>)> = vec![
            ("empty", vec![]),
            ("truncated header", good[..40].to_vec()),
            ("truncated body", good[..good.len() - 100].to_vec()),
        ];
        let mut flipped = good.clone();
        let last = flipped.len() - 70;
        flipped[last] ^= 0x5a;
        cases.push(("flipped byte", flipped));
        let mut version = good.clone();
        version[8] = 99;
        cases.push(("wrong version", version));
        for (name, bytes) in &cases {
            let file = write_temp(bytes);
            // SAFETY: the temporary file is owned by this test and not modified while mapped.
            let map = unsafe { map_blob(file.path()) }.unwrap();
            let err = parse_blob(file.path(), &map).expect_err(name);
            let message = format!("{err} ({})", std::error::Error::source(&err).unwrap());
            assert!(message.contains(&file.path().display().to_string()), "{name}: {message}");
            let copy = read_blob(file.path()).unwrap();
            assert!(parse_blob(file.path(), &copy).is_err(), "{name}");
        }
        let file = write_temp(&good);
        // SAFETY: as above.
        let map = unsafe { map_blob(file.path()) }.unwrap();
        assert_eq!(parse_blob(file.path(), &map).unwrap().triangles.len(), 20);
        assert!(matches!(read_blob(Path::new("/nonexistent/blob")), Err(RenderError::Io { .. })));
    }
}

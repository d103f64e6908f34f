//! Getting blob bytes into memory: a read-only memory map (the renderer's path) or an aligned copy
//! (for tests and for files that cannot be mapped).
//!
//! # The mapped-blob contract
//! A blob is immutable once written: it is replaced by writing a new file and renaming it over the old
//! one (what [`blob::write_atomic`] and ingest do), never truncated or overwritten in place. A rename
//! leaves the mapped inode untouched, so a render in progress finishes on the old scene. Writing into
//! the mapped file instead changes memory behind slices that were validated once, and truncating it
//! turns reads of the lost pages into `SIGBUS`; neither can be made safe without copying the blob.
//! What is cheap to detect is detected: [`MappedBlob::check_unchanged`] compares the open file's size
//! and modification time with those seen when it was mapped, and render calls it after the frame and
//! refuses to write an image from a blob that changed under it.

use crate::error::RenderError;
use blob::{AlignedBytes, SceneView};
use std::path::Path;

/// A read-only memory map of a blob file (or nothing, for an empty file, which mmap rejects), with the
/// open file and its size and modification time at mapping.
pub struct MappedBlob {
    map: Option<memmap2::Mmap>,
    file: std::fs::File,
    stamp: (u64, Option<std::time::SystemTime>),
}

impl MappedBlob {
    /// Errors if the mapped file's size or modification time differs from when it was mapped: it was
    /// written or truncated in place, against the contract (see the module docs), and what was read
    /// from it may be wrong. A blob replaced by rename passes (the map still holds the old file).
    pub fn check_unchanged(&self, path: &Path) -> Result<(), RenderError> {
        let meta =
            self.file.metadata().map_err(|source| RenderError::Io { path: path.to_path_buf(), source })?;
        let now = (meta.len(), meta.modified().ok());
        if now.0 != self.stamp.0 {
            let what = format!("size {} → {} bytes", self.stamp.0, now.0);
            return Err(RenderError::BlobModified { path: path.to_path_buf(), what });
        }
        if now.1 != self.stamp.1 {
            return Err(RenderError::BlobModified {
                path: path.to_path_buf(),
                what: "modification time changed".into(),
            });
        }
        Ok(())
    }
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
/// immutable by contract (see the module docs): they are written atomically (temporary file + rename,
/// see [`blob::write_atomic`]), which replaces the file instead of modifying it, so re-running ingest on
/// the same path is safe. [`MappedBlob::check_unchanged`] detects, after the fact, a size or mtime
/// change of the mapped file; it cannot undo reads made before it.
pub unsafe fn map_blob(path: &Path) -> Result<MappedBlob, RenderError> {
    let io_err = |source| RenderError::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::open(path).map_err(io_err)?;
    let meta = file.metadata().map_err(io_err)?;
    let stamp = (meta.len(), meta.modified().ok());
    if stamp.0 == 0 {
        return Ok(MappedBlob { map: None, file, stamp });
    }
    // SAFETY: the caller guarantees the file is not modified or truncated while the map lives (see the
    // `# Safety` section); the map is read-only.
    let map = unsafe { memmap2::Mmap::map(&file) }.map_err(io_err)?;
    Ok(MappedBlob { map: Some(map), file, stamp })
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

    #[test]
    fn a_blob_written_in_place_while_mapped_is_detected_and_one_replaced_by_rename_is_not() {
        let good = testscene::random_triangles(20, 1).encode();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.blob");
        std::fs::write(&path, &good).unwrap();
        // SAFETY: the test appends to the file while mapped, past the mapped length, and reads nothing
        // of the map afterwards: the point is that the change is detected.
        let map = unsafe { map_blob(&path) }.unwrap();
        map.check_unchanged(&path).unwrap();
        // Replaced by rename: the map keeps the old inode, which is unchanged.
        blob::write_atomic(&path, &good).unwrap();
        map.check_unchanged(&path).unwrap();
        // SAFETY: as above.
        let map = unsafe { map_blob(&path) }.unwrap();
        let mut f = std::fs::OpenOptions::new().append(true).open(&path).unwrap();
        std::io::Write::write_all(&mut f, &[0u8; 64]).unwrap();
        let err = map.check_unchanged(&path).unwrap_err();
        let n = good.len();
        assert_eq!(
            err.to_string(),
            format!(
                "{} was modified in place while render had it mapped (size {n} → {} bytes); blobs are \
                 immutable and must be replaced by rename (as ingest does), so the image is not written",
                path.display(),
                n + 64
            )
        );
    }
}

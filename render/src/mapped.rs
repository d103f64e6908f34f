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
//!
//! # Checksums in the background
//! [`MappedBlob::parse`] waits only for the structural proofs (everything the typed slices' safety rests
//! on) and verifies the section checksums on a thread of its own while render works: on a 925 MiB blob
//! that takes start-up from 131 ms to 59 ms (`cargo run --release -p blob --example parse_time`). The
//! thread reads a second map of the same open file (so it needs no borrow of this one and sees the same
//! inode), and [`MappedBlob::check_unchanged`], which render calls before writing any checkpoint or
//! image, waits for it: a corrupted blob still writes nothing and exits with the checksum error.

use crate::error::RenderError;
use blob::{AlignedBytes, BlobError, SceneView};
use std::path::Path;
use std::sync::Mutex;
use std::thread::JoinHandle;

/// A read-only memory map of a blob file (or nothing, for an empty file, which mmap rejects), with the
/// open file and its size and modification time at mapping.
pub struct MappedBlob {
    map: Option<memmap2::Mmap>,
    file: std::fs::File,
    stamp: (u64, Option<std::time::SystemTime>),
    checksums: Mutex<Checksums>,
}

/// Where the section checksums of a [`MappedBlob::parse`] stand.
enum Checksums {
    /// Not parsed by [`MappedBlob::parse`] (nothing to wait for).
    NotStarted,
    /// Being verified on this thread.
    Running(JoinHandle<Result<(), BlobError>>),
    /// Verified (or found corrupt).
    Done(Result<(), BlobError>),
}

impl MappedBlob {
    /// Proves the blob's structure and returns its view, leaving the section checksums to a background
    /// thread that [`MappedBlob::check_unchanged`] waits for (see the module docs). `path` names the file
    /// in errors.
    pub fn parse(&self, path: &Path) -> Result<SceneView<'_>, RenderError> {
        let blob_error = |source| RenderError::Blob { path: path.to_path_buf(), source };
        let (view, pending) = SceneView::parse_deferring_checksums(self).map_err(blob_error)?;
        let io_err = |source| RenderError::Io { path: path.to_path_buf(), source };
        let file = self.file.try_clone().map_err(io_err)?;
        // SAFETY: the same file as `self.map`, under the same contract (see `map_blob`); read-only.
        let second = unsafe { memmap2::Mmap::map(&file) }.map_err(io_err)?;
        let handle = std::thread::Builder::new()
            .name("blob checksums".into())
            .spawn(move || pending.verify(&second))
            .map_err(io_err)?;
        *self.lock_checksums() = Checksums::Running(handle);
        Ok(view)
    }

    fn lock_checksums(&self) -> std::sync::MutexGuard<'_, Checksums> {
        // The state stays meaningful if a holder panicked: take it as it is.
        self.checksums.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Waits for the background checksums of [`MappedBlob::parse`], if it started them.
    fn checksums_verified(&self, path: &Path) -> Result<(), RenderError> {
        let state = &mut *self.lock_checksums();
        if matches!(state, Checksums::Running(_)) {
            if let Checksums::Running(handle) = std::mem::replace(state, Checksums::NotStarted) {
                *state = Checksums::Done(handle.join().unwrap_or_else(|p| std::panic::resume_unwind(p)));
            }
        }
        match state {
            Checksums::Done(Err(source)) => {
                Err(RenderError::Blob { path: path.to_path_buf(), source: source.clone() })
            }
            _ => Ok(()),
        }
    }

    /// Errors if the blob's section checksums (verified in the background since [`MappedBlob::parse`];
    /// this waits for them) do not match, or if the mapped file's size or modification time differs from
    /// when it was mapped: it was written or truncated in place, against the contract (see the module
    /// docs), and what was read from it may be wrong. A blob replaced by rename passes (the map still
    /// holds the old file).
    pub fn check_unchanged(&self, path: &Path) -> Result<(), RenderError> {
        self.checksums_verified(path)?;
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
        return Ok(MappedBlob { map: None, file, stamp, checksums: Mutex::new(Checksums::NotStarted) });
    }
    // SAFETY: the caller guarantees the file is not modified or truncated while the map lives (see the
    // `# Safety` section); the map is read-only.
    // Populated: the kernel reads the pages in at the map instead of one fault per touch during
    // validation, which halves start-up on a 925 MiB blob (see the module docs).
    let map = unsafe { memmap2::MmapOptions::new().populate().map(&file) }.map_err(io_err)?;
    Ok(MappedBlob { map: Some(map), file, stamp, checksums: Mutex::new(Checksums::NotStarted) })
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

    #[test]
    fn a_corrupted_section_starts_the_render_and_fails_at_the_first_write_check() {
        let good = testscene::random_triangles(20, 1).encode();
        let view_bytes = AlignedBytes::copy_from(&good);
        let view = SceneView::parse(&view_bytes).unwrap();
        // A position's byte: the structure stays valid (a small value change), only its checksum fails.
        let at = view.positions.as_ptr() as usize - view_bytes.as_ptr() as usize + 4;
        let mut bad = good.clone();
        bad[at] ^= 0x01;
        let file = write_temp(&bad);
        // SAFETY: the temporary file is owned by this test and not modified while mapped.
        let map = unsafe { map_blob(file.path()) }.unwrap();
        let view = map.parse(file.path()).expect("the structure is valid");
        assert_eq!(view.positions.len(), 60);
        let err = map.check_unchanged(file.path()).unwrap_err();
        assert_eq!(err.to_string(), format!("{} is not a valid scene blob", file.path().display()),);
        assert!(matches!(
            err,
            RenderError::Blob { source: blob::BlobError::SectionChecksum(blob::SectionKind::Positions), .. }
        ));
        // Asked again (a later checkpoint), the same answer.
        assert!(map.check_unchanged(file.path()).is_err());
        // The intact blob passes.
        let file = write_temp(&good);
        // SAFETY: as above.
        let map = unsafe { map_blob(file.path()) }.unwrap();
        map.parse(file.path()).unwrap();
        map.check_unchanged(file.path()).unwrap();
    }
}

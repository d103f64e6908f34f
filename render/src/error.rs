//! The render library's error type. Underlying causes are exposed through `Error::source` (print the
//! chain, e.g. anyhow's `{:#}`), not repeated in the message.

use std::path::PathBuf;

/// Why loading, rendering or writing failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// The blob file could not be opened, mapped or read.
    #[error("cannot read scene blob {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The bytes are not a valid blob (truncated, corrupted, wrong version, ...).
    #[error("{path} is not a valid scene blob")]
    Blob {
        /// The file.
        path: PathBuf,
        /// What the validator rejected.
        source: blob::BlobError,
    },
    /// `--camera` names no camera of the scene.
    #[error("no camera {path:?} in the scene; cameras: {available:?}")]
    UnknownCamera {
        /// The requested prim path.
        path: String,
        /// The scene's camera paths.
        available: Vec<String>,
    },
    /// An option value outside its valid range.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// A checkpoint or farm part that cannot be read, resumed or merged.
    #[error("{path}: {message}")]
    Checkpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// The render would need more memory than its limit (`--max-memory`).
    #[error(
        "a {width}x{height} render needs about {needed} bytes of film, path pools and AOVs, more than \
         the limit of {limit} bytes (--max-memory; the default is 3/4 of the physical memory)"
    )]
    Memory {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Bytes the render would allocate ([`crate::film::memory_estimate`]).
        needed: u64,
        /// The limit.
        limit: u64,
    },
    /// The worker thread pool could not be created.
    #[error("cannot create the thread pool: {0}")]
    ThreadPool(String),
    /// An output path names the input blob (refused before rendering).
    #[error("refusing to write {option} {path}: it is the input blob")]
    OutputIsInput {
        /// The option (`-o`, `--png`, `--stats`).
        option: String,
        /// The output path as given.
        path: PathBuf,
    },
    /// The blob's file changed while it was mapped (see [`crate::mapped::map_blob`]).
    #[error("{path} was modified in place while render had it mapped ({what}); blobs are immutable and must be replaced by rename (as ingest does), so the image is not written")]
    BlobModified {
        /// The blob.
        path: PathBuf,
        /// What changed.
        what: String,
    },
    /// An output image could not be written.
    #[error("cannot write {path}: {message}")]
    Output {
        /// The file.
        path: PathBuf,
        /// The encoder's or the OS's message.
        message: String,
    },
}

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
    /// The worker thread pool could not be created.
    #[error("cannot create the thread pool: {0}")]
    ThreadPool(String),
    /// An output image could not be written.
    #[error("cannot write {path}: {message}")]
    Output {
        /// The file.
        path: PathBuf,
        /// The encoder's or the OS's message.
        message: String,
    },
}

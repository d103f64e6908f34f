//! [`IngestError`]: what the whole ingest step (read, check, pack, write) can fail with.

use std::path::{Path, PathBuf};

use crate::alembic::AlembicError;
use crate::dicing::SubdivOptionsError;
use crate::pack::PackError;
use crate::usd::UsdError;

/// An ingest step that failed, with the file it was working on and the reader's own error.
///
/// Displays as one line, the cause included: `cannot ingest scene.usda: layer.usda: /World/Mesh.points:
/// message`. The cause is a field of its variant rather than [`std::error::Error::source`], so an
/// error chain (`anyhow`'s `{:#}`) prints it once; match on the variant to reach it (a
/// [`UsdError`] carries its layer, prim and attribute).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IngestError {
    /// The USD stage could not be composed or read.
    #[error("cannot ingest {}: {error}", path.display())]
    Usd {
        /// The root layer.
        path: PathBuf,
        /// Where in which layer, and what.
        error: UsdError,
    },
    /// The Alembic archive could not be read or translated.
    #[error("cannot ingest {}: {error}", path.display())]
    Alembic {
        /// The archive.
        path: PathBuf,
        /// Which object, and what.
        error: AlembicError,
    },
    /// The scene read from `path` cannot be packed into a blob.
    #[error("cannot pack {}: {error}", path.display())]
    Pack {
        /// The asset the scene was read from.
        path: PathBuf,
        /// Which prim, and what.
        error: PackError,
    },
    /// An output file (the blob, the `--dump-json` listing) could not be written.
    #[error("cannot write {}: {error}", path.display())]
    Write {
        /// The file being written.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// An output path names the input (checked before anything is read; the stage's other layers
    /// and its textures are checked once it is read, as [`crate::usd::UsdErrorKind::OutputIsInput`]).
    #[error("refusing to write {}: it is the input {}", output.display(), input.display())]
    OutputIsInput {
        /// The output path as given.
        output: PathBuf,
        /// The input it names.
        input: PathBuf,
    },
    /// Two outputs of one run name the same file (the blob and the `--dump-json` listing).
    #[error("refusing to write {} and {}: they are the same file", first.display(), second.display())]
    OutputsCollide {
        /// The first output.
        first: PathBuf,
        /// The second.
        second: PathBuf,
    },
    /// The subdivision options are out of range (checked before any file is read).
    #[error("invalid subdivision options: {0}")]
    SubdivOptions(SubdivOptionsError),
    /// A frame of a sequence failed (`ingest --frames`); the frames before it are written.
    #[error("frame {frame}: {error}")]
    Frame {
        /// The frame's time code.
        frame: f64,
        /// What went wrong there.
        error: Box<IngestError>,
    },
}

impl IngestError {
    /// The USD error, if reading the stage failed.
    pub fn usd(&self) -> Option<&UsdError> {
        match self {
            IngestError::Usd { error, .. } => Some(error),
            IngestError::Frame { error, .. } => error.usd(),
            _ => None,
        }
    }

    pub(crate) fn write(path: &Path, error: std::io::Error) -> Self {
        IngestError::Write { path: path.to_path_buf(), error }
    }
}

impl From<SubdivOptionsError> for IngestError {
    fn from(error: SubdivOptionsError) -> Self {
        IngestError::SubdivOptions(error)
    }
}

//! The crate's error type: every bake error names the file it came from.

use std::fmt;
use std::path::{Path, PathBuf};

/// A bake or validation failure, with the texture file it concerns (empty for in-memory data).
#[derive(Debug)]
pub struct Error {
    /// The file being decoded, or the `<UDIM>` pattern; empty when the error is about in-memory records.
    pub path: PathBuf,
    /// What went wrong.
    pub kind: ErrorKind,
}

/// What went wrong; new kinds may be added.
#[derive(Debug)]
#[non_exhaustive]
pub enum ErrorKind {
    /// Listing a UDIM directory or opening a file failed.
    Io(std::io::Error),
    /// The `image` crate could not decode the file.
    Image(image::ImageError),
    /// The `exr` crate could not decode the file.
    Exr(exr::error::Error),
    /// The image has a channel layout the crate cannot map to grey / grey+alpha / RGB / RGBA.
    Channels(String),
    /// Width or height is zero or above [`crate::MAX_DIMENSION`].
    Size {
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
    },
    /// The file declares more pixels than the decode's budget ([`crate::DecodeLimits`]); refused from
    /// its header, before allocating.
    TooManyPixels {
        /// Declared width in pixels.
        width: u64,
        /// Declared height in pixels.
        height: u64,
        /// The budget it exceeds.
        max_pixels: u64,
    },
    /// A `<UDIM>` pattern is malformed or matched no tile on disk.
    Udim(String),
    /// A record failed validation against the texel array (render side).
    InvalidRecord {
        /// Which table the record lives in (`"texture"`, `"udim set"`, `"udim tile"`).
        table: &'static str,
        /// Index of the record in that table.
        index: usize,
        /// The check that failed.
        reason: &'static str,
    },
}

impl Error {
    pub(crate) fn new(path: &Path, kind: ErrorKind) -> Self {
        Error { path: path.to_path_buf(), kind }
    }

    pub(crate) fn invalid(table: &'static str, index: usize, reason: &'static str) -> Self {
        Error { path: PathBuf::new(), kind: ErrorKind::InvalidRecord { table, index, reason } }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.path.as_os_str().is_empty() {
            write!(f, "{}: ", self.path.display())?;
        }
        match &self.kind {
            ErrorKind::Io(e) => write!(f, "{e}"),
            ErrorKind::Image(e) => write!(f, "decoding failed: {e}"),
            ErrorKind::Exr(e) => write!(f, "decoding EXR failed: {e}"),
            ErrorKind::Channels(what) => write!(f, "unsupported channel layout: {what}"),
            ErrorKind::Size { width, height } => {
                write!(f, "image size {width}x{height} is outside 1..={} per side", crate::MAX_DIMENSION)
            }
            ErrorKind::TooManyPixels { width, height, max_pixels } => write!(
                f,
                "image declares {width}x{height} = {} pixels, above the limit of {max_pixels} pixels",
                width.saturating_mul(*height)
            ),
            ErrorKind::Udim(what) => write!(f, "UDIM: {what}"),
            ErrorKind::InvalidRecord { table, index, reason } => {
                write!(f, "{table} record {index} is invalid: {reason}")
            }
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            ErrorKind::Io(e) => Some(e),
            ErrorKind::Image(e) => Some(e),
            ErrorKind::Exr(e) => Some(e),
            _ => None,
        }
    }
}

/// A problem the bake survived; ingest prints these once each.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Warning {
    /// A UDIM set has a hole: lookups in this tile return the caller's fallback.
    MissingUdimTile {
        /// The `<UDIM>` pattern as written in the scene.
        pattern: PathBuf,
        /// The UDIM number, `1001 + u + 10 v`.
        tile: u32,
        /// The file that would have held the tile.
        path: PathBuf,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::MissingUdimTile { pattern, tile, path } => write!(
                f,
                "UDIM tile {tile} of {} is missing ({} not found); lookups there use the fallback",
                pattern.display(),
                path.display()
            ),
        }
    }
}

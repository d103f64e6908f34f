//! Why a byte buffer is not a valid blob.
#![allow(missing_docs)] // Variant fields are self-describing; each variant is documented.

use crate::SectionKind;
use std::fmt;

/// A reason the blob was rejected. Every check in [`crate::SceneView::parse`] has its own variant so
/// the message says exactly what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum BlobError {
    /// Fewer bytes than the header and section table need.
    Truncated { needed: u64, actual: u64 },
    /// The first eight bytes are not [`crate::MAGIC`].
    BadMagic,
    /// A format this build cannot read.
    UnsupportedVersion { found: u32, supported: u32 },
    /// The header's own checksum does not match.
    HeaderChecksum,
    /// The header's `file_size` differs from the buffer length.
    FileSize { header: u64, actual: u64 },
    /// Too many sections for any blob this build writes.
    SectionCount(u32),
    /// The section table's checksum does not match.
    TableChecksum,
    /// A section kind this build does not know.
    UnknownSection(u32),
    /// The same kind appears twice.
    DuplicateSection(SectionKind),
    /// A section this build requires is absent.
    MissingSection(SectionKind),
    /// Section bounds outside the file, overlapping the table, or misaligned.
    SectionBounds { kind: SectionKind, offset: u64, byte_len: u64 },
    /// The record size in the table differs from this build's record.
    RecordSize { kind: SectionKind, found: u32, expected: u32 },
    /// The section's checksum does not match its bytes.
    SectionChecksum(SectionKind),
    /// The section's memory is not aligned for its record type.
    Misaligned(SectionKind),
    /// Nonzero bytes in the padding between or after sections.
    Padding { offset: u64 },
    /// A record refers outside its target section, or a count is inconsistent.
    BadIndex { kind: SectionKind, record: u64, what: &'static str },
}

impl fmt::Display for BlobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BlobError::Truncated { needed, actual } => {
                write!(f, "truncated: needs at least {needed} bytes, has {actual}")
            }
            BlobError::BadMagic => write!(f, "not a scene blob (bad magic)"),
            BlobError::UnsupportedVersion { found, supported } => {
                write!(f, "format version {found} is not supported (this build reads version {supported}); re-run ingest")
            }
            BlobError::HeaderChecksum => write!(f, "header checksum mismatch (corrupted header)"),
            BlobError::FileSize { header, actual } => {
                write!(f, "header says {header} bytes but the file has {actual} (truncated or appended to)")
            }
            BlobError::SectionCount(n) => write!(f, "implausible section count {n}"),
            BlobError::TableChecksum => write!(f, "section table checksum mismatch (corrupted table)"),
            BlobError::UnknownSection(k) => write!(f, "unknown section kind {k}"),
            BlobError::DuplicateSection(k) => write!(f, "section {k:?} appears twice"),
            BlobError::MissingSection(k) => write!(f, "required section {k:?} is missing"),
            BlobError::SectionBounds { kind, offset, byte_len } => {
                write!(f, "section {kind:?} at offset {offset} with {byte_len} bytes is out of bounds or misaligned")
            }
            BlobError::RecordSize { kind, found, expected } => {
                write!(f, "section {kind:?} has {found}-byte records, expected {expected}")
            }
            BlobError::SectionChecksum(k) => write!(f, "section {k:?} checksum mismatch (corrupted data)"),
            BlobError::Misaligned(k) => write!(f, "section {k:?} is not aligned in memory"),
            BlobError::Padding { offset } => {
                write!(f, "nonzero padding byte at offset {offset} (corrupted file)")
            }
            BlobError::BadIndex { kind, record, what } => {
                write!(f, "section {kind:?} record {record}: {what}")
            }
        }
    }
}

impl std::error::Error for BlobError {}

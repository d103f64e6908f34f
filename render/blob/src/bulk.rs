//! The two costs of parse that grow with the scene — per-record checks over the big sections and the
//! section checksums — and how they are kept off the start-up path.
//!
//! Per-record checks run on every core: a slice of at least [`PARALLEL_MIN`] records is cut into one
//! contiguous chunk per thread (`std::thread::scope`; this crate depends on bytemuck only, so no
//! rayon). Each chunk first folds its predicate without early exit (the loop vectorises for the float
//! checks) and looks for the offending record only when the fold fails; the lowest failing index over
//! all chunks is the answer, so the error is the one a sequential scan would report.
//!
//! Checksums are [`PendingChecksums`]: parse proves the structure (everything safety rests on) and
//! leaves the checksums, which only tell a corrupted file from the written one, to be verified by the
//! caller — eagerly in [`crate::SceneView::parse`], or in the background while render works and before
//! it writes anything (render's mapped blob). When the structure is refused, the checksums are verified
//! first anyway and a mismatch is the error reported, so a corrupted blob gets the same diagnosis
//! whichever entry point read it.

use crate::checksum::checksum;
use crate::container::{SectionEntry, SectionKind};
use crate::error::BlobError;

/// Slices shorter than this are checked on the calling thread: below it, starting threads costs more
/// than the scan.
pub const PARALLEL_MIN: usize = 1 << 16;

/// Index of the first record of `items` for which `ok` is false, if any.
pub fn first_failing<T: Sync>(items: &[T], ok: impl Fn(&T) -> bool + Sync) -> Option<usize> {
    let scan = |chunk: &[T]| {
        if chunk.iter().fold(true, |all, item| all & ok(item)) {
            None
        } else {
            chunk.iter().position(|item| !ok(item))
        }
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(8);
    if items.len() < PARALLEL_MIN || threads == 1 {
        return scan(items);
    }
    let chunk_len = items.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let scan = &scan;
        let handles: Vec<_> = items
            .chunks(chunk_len)
            .enumerate()
            .map(|(c, chunk)| scope.spawn(move || scan(chunk).map(|i| c * chunk_len + i)))
            .collect();
        // A panic inside a predicate is re-raised as it would be on one thread.
        let found: Vec<Option<usize>> =
            handles.into_iter().map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect();
        found.into_iter().flatten().next()
    })
}

/// The section checksums of a blob whose structure parse has proven, still to be compared with the
/// bytes (see the module docs). Entries are in section-table order, which is the order of the report.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PendingChecksums {
    entries: Vec<SectionEntry>,
}

impl PendingChecksums {
    pub(crate) fn push(&mut self, entry: SectionEntry) {
        self.entries.push(entry);
    }

    /// Bytes the verification reads.
    pub fn byte_len(&self) -> u64 {
        self.entries.iter().map(|e| e.byte_len).sum()
    }

    /// Compares every section's checksum with `bytes` (the blob parse read, or another mapping of the
    /// same file); the first mismatch in table order is the error. A section that no longer fits in
    /// `bytes` (the file shrank) is reported as truncated.
    pub fn verify(&self, bytes: &[u8]) -> Result<(), BlobError> {
        for entry in &self.entries {
            let kind = SectionKind::from_u32(entry.kind).ok_or(BlobError::UnknownSection(entry.kind))?;
            let end = entry.offset.saturating_add(entry.byte_len);
            let data = usize::try_from(end)
                .ok()
                .and_then(|end| bytes.get(entry.offset as usize..end))
                .ok_or(BlobError::Truncated { needed: end, actual: bytes.len() as u64 })?;
            if checksum(data) != entry.checksum {
                return Err(BlobError::SectionChecksum(kind));
            }
        }
        Ok(())
    }

    /// `error`, unless a section checksum fails first: a structural error in a corrupted file is
    /// reported as the corruption it is.
    pub(crate) fn prefer_mismatch(&self, bytes: &[u8], error: BlobError) -> BlobError {
        self.verify(bytes).err().unwrap_or(error)
    }
}

#[cfg(test)]
mod tests {
    use super::first_failing;

    #[test]
    fn first_failing_reports_the_lowest_index_whichever_chunk_holds_it() {
        let n = super::PARALLEL_MIN * 5 + 17;
        let values: Vec<u32> = (0..n as u32).collect();
        assert_eq!(first_failing(&values, |_| true), None);
        for bad in [0, 1, super::PARALLEL_MIN * 3 + 5, n - 1] {
            assert_eq!(first_failing(&values, |&v| v as usize != bad), Some(bad));
            // Several failures: the first wins even when a later chunk finishes first.
            assert_eq!(first_failing(&values, |&v| (v as usize) < bad), Some(bad));
        }
        assert_eq!(first_failing(&values[..10], |&v| v != 7), Some(7));
        assert_eq!(first_failing::<u32>(&[], |_| false), None);
    }
}

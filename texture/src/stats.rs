//! Counting the texel bytes a render touches, for `--stats` (bytes touched vs texel bytes in the blob).
//!
//! Lookups are generic over a [`Touch`] sink that sees the byte offset and length of every texel fetched.
//! [`NoTouch`] compiles away; [`PageTouches`] marks 4 KiB pages in a bitmap the caller allocates once
//! (pages are what the OS page cache, our tile cache, actually loads); [`BytesRead`] sums fetched bytes
//! on one thread. None allocates during a lookup.

use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

/// Receives the location of every texel a lookup reads.
pub trait Touch {
    /// Texel bytes `byte_offset .. byte_offset + len` of the texel array were read.
    fn touch(&self, byte_offset: usize, len: usize);
}

/// Discards touches; the default for plain lookups.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoTouch;

impl Touch for NoTouch {
    #[inline(always)]
    fn touch(&self, _: usize, _: usize) {}
}

/// Which 4 KiB pages of the texel array were read; shareable between render threads.
#[derive(Debug)]
pub struct PageTouches {
    pages: Vec<AtomicU64>,
    total_bytes: usize,
}

impl PageTouches {
    /// Page granularity: the usual OS page size.
    pub const PAGE_BYTES: usize = 4096;

    /// A bitmap for a texel array of `total_bytes` (allocates once, up front).
    pub fn new(total_bytes: usize) -> Self {
        let pages = total_bytes.div_ceil(Self::PAGE_BYTES);
        PageTouches { pages: (0..pages.div_ceil(64)).map(|_| AtomicU64::new(0)).collect(), total_bytes }
    }

    /// Size of the texel array this bitmap covers.
    pub fn total_bytes(&self) -> usize {
        self.total_bytes
    }

    /// Pages read at least once.
    pub fn touched_pages(&self) -> u64 {
        self.pages.iter().map(|w| w.load(Ordering::Relaxed).count_ones() as u64).sum()
    }

    /// Bytes in the pages read, capped at the array size (the last page may be partial).
    pub fn touched_bytes(&self) -> u64 {
        (self.touched_pages() * Self::PAGE_BYTES as u64).min(self.total_bytes as u64)
    }

    #[inline]
    fn mark(&self, page: usize) {
        if let Some(word) = self.pages.get(page / 64) {
            let bit = 1u64 << (page % 64);
            // Read before writing: after warm-up almost every page is already marked, and a plain load
            // keeps the cache line shared between threads instead of bouncing it on every fetch.
            if word.load(Ordering::Relaxed) & bit == 0 {
                word.fetch_or(bit, Ordering::Relaxed);
            }
        }
    }
}

impl Touch for PageTouches {
    #[inline]
    fn touch(&self, byte_offset: usize, len: usize) {
        let first = byte_offset / Self::PAGE_BYTES;
        let last = (byte_offset + len.max(1) - 1) / Self::PAGE_BYTES;
        for page in first..=last {
            self.mark(page);
        }
    }
}

/// Sums texel bytes fetched (with repeats) on one thread.
#[derive(Debug, Default)]
pub struct BytesRead(pub Cell<u64>);

impl Touch for BytesRead {
    #[inline]
    fn touch(&self, _: usize, len: usize) {
        self.0.set(self.0.get() + len as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pages() {
        let t = PageTouches::new(10_000);
        t.touch(0, 4);
        t.touch(4094, 4); // straddles pages 0 and 1
        t.touch(9_999, 1);
        assert_eq!(t.touched_pages(), 3);
        assert_eq!(t.touched_bytes(), 10_000);
        t.touch(1_000_000, 4); // outside: ignored, not a panic
        assert_eq!(t.touched_pages(), 3);
    }
}

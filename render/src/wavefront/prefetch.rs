//! Software prefetch of side-table entries read by queue order: the stages walk their queue in
//! sorted (shade) or shading (intersect, occlusion) order, so each path's state, hit and shadow ray
//! is a random access into a [`super::POOL_PATHS`]-entry table (2048: `RayState` alone is 184 KiB), a miss the hardware
//! prefetchers cannot predict. The queue tells us which entries come next, so a stage asks for them
//! a few queue positions ahead and the loads of the entry it works on find them in cache.
//!
//! Written by hand: `core::intrinsics::prefetch_read_data` is unstable and the prefetch crates on
//! crates.io wrap the same one x86 instruction; on other targets this is a no-op.

/// Asks for the cache lines of `table[index]` (all of them: a 92-byte `RayState` spans two or
/// three). Not bounds-checked: an index past the table asks for lines past it, which a prefetch
/// may do (it never faults and reads nothing); the check and its branch per entry were ~1 M
/// instructions in shading's look-ahead on shading-heavy (120×80, 8 spp).
#[inline(always)]
pub(super) fn entry<T>(table: &[T], index: usize) {
    // `wrapping_add`: the address is only computed, never dereferenced.
    let item = table.as_ptr().wrapping_add(index).cast::<u8>();
    if size_of::<T>() <= align_of::<T>() {
        // An entry no larger than its alignment (a `u32`, a `u64`) never straddles two lines.
        line(item);
    } else {
        bytes(item, size_of::<T>());
    }
}

/// Asks for the cache line holding `field` (one field of an entry the loop will read or update).
#[inline(always)]
pub(super) fn field<T>(field: &T) {
    line(std::ptr::from_ref(field).cast());
}

/// Every cache line of the `len` bytes at `start`.
#[inline(always)]
fn bytes(start: *const u8, len: usize) {
    let mut offset = 0;
    while offset < len {
        line(start.wrapping_add(offset));
        offset += 64;
    }
    // The last byte's line, which the 64-byte steps miss when `start` is not line-aligned.
    line(start.wrapping_add(len.saturating_sub(1)));
}

#[inline(always)]
fn line(at: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `prefetcht0` is a hint: it reads no architectural state and never faults, even for
    // an address that is not mapped; SSE is part of the x86_64 baseline.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(at.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = at;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefetching_any_index_leaves_the_table_alone_and_never_faults() {
        // A hint has no observable effect: the table is unchanged, and an index past its end (the
        // look-ahead at a queue's end) or far past it neither faults nor reads.
        let table: Vec<super::super::RayState> =
            (0..5).map(|i| super::super::RayState { pixel: i, ..Default::default() }).collect();
        for i in (0..10).chain([1 << 40, usize::MAX]) {
            entry(&table, i);
        }
        field(&table[4].radiance);
        let empty: [u64; 0] = [];
        entry(&empty, 0);
        assert_eq!(table.iter().map(|s| s.pixel).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
    }
}

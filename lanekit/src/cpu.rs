//! The CPU features the hand-written intrinsics paths test at run time: one spelling for every
//! `#[target_feature]` kernel that is not under `multiversion` (those dispatch themselves).
//!
//! std caches the answer (`is_x86_feature_detected!` reads one static after the first `cpuid`), so
//! these are one load and a test per call, and a second cache (a `OnceLock`) would add nothing.
//! Off x86-64 they are `false`. Under `scripts/test-fallback.sh`'s qemu models they report what
//! the emulated CPU has, so the portable paths run there.

/// Whether this CPU runs AVX (`#[target_feature(enable = "avx")]` code).
#[inline]
pub fn has_avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx");
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

/// Whether this CPU runs AVX2 (`#[target_feature(enable = "avx2")]` code; AVX2 implies AVX).
#[inline]
pub fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    #[test]
    fn answers_equal_std() {
        assert_eq!(super::has_avx(), std::arch::is_x86_feature_detected!("avx"));
        assert_eq!(super::has_avx2(), std::arch::is_x86_feature_detected!("avx2"));
        assert!(!super::has_avx2() || super::has_avx());
    }
}

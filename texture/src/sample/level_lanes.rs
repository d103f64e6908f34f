//! The per-lane mip levels the portable and the AVX2 lane lookups share.

use lanekit::{Lanes, LANES};

/// The per-lane levels of [`super::Sampler::moonray_lanes`]: `mip_level` and `level_pair`, in lanes. Masks
/// and levels are `i32` so that the AVX2 path loads them as vectors as they are. Where a lane
/// magnifies, its `l0`, `l1` and `t` are not read.
#[derive(Default)]
pub(super) struct LevelLanes {
    /// `-1` where the lane magnifies (level ≤ 0 or NaN: bilinear on level 0), else `0`.
    pub(super) magnify: [i32; LANES],
    /// Nearer level.
    pub(super) l0: [i32; LANES],
    /// Coarser level.
    pub(super) l1: [i32; LANES],
    /// Weight of the coarser level.
    pub(super) t: Lanes,
}

//! The shading sort key: groups shading points that will read the same texture pages.
//!
//! Layout (MoonRay's `Intersection::computeShadingSortKey`), most significant first:
//!
//! | bits   | width | field                                                        |
//! |--------|------:|--------------------------------------------------------------|
//! | 25..32 | 7     | light set (zero here; the integrator ORs it in)               |
//! | 18..25 | 7     | UDIM tile index `u + 10 v` (UDIM number − 1001), `0..128`      |
//! | 14..18 | 4     | mip level, `0..16`                                            |
//! | 0..14  | 14    | Morton code of `uv`'s fractional part, 7 bits each, u in even bits |
//!
//! Sorting by this key orders points by tile, then level, then along a Z-curve inside the tile, so
//! neighbouring queue entries touch neighbouring texel tiles.

use crate::float::floor;

/// Bits of each field, and where it starts.
pub const LIGHT_SET_SHIFT: u32 = 25;
/// Start of the UDIM field.
pub const UDIM_SHIFT: u32 = 18;
/// Start of the mip-level field.
pub const MIP_SHIFT: u32 = 14;
/// Largest UDIM tile index the key can hold.
pub const MAX_UDIM_TILE: u32 = (1 << (LIGHT_SET_SHIFT - UDIM_SHIFT)) - 1;
/// Largest mip level the key can hold.
pub const MAX_SORT_MIP: u32 = (1 << (UDIM_SHIFT - MIP_SHIFT)) - 1;

/// Spreads the low 7 bits of `x` to the even bits 0, 2, .., 12.
#[inline]
fn spread7(x: u32) -> u32 {
    let mut x = x & 0x7f;
    x = (x | (x << 4)) & 0x0f0f;
    x = (x | (x << 2)) & 0x3333;
    (x | (x << 1)) & 0x5555
}

/// The key for a shading point on UDIM tile index `udim_tile` (`u + 10 v`, not the UDIM number), mip
/// level `mip_level`, at `uv` (only its fractional part counts). `None` if `udim_tile > 127` or
/// `mip_level > 15`; callers that prefer a coarse key can saturate with [`shading_sort_key_saturating`].
#[inline]
pub fn shading_sort_key(udim_tile: u32, mip_level: u32, uv: [f32; 2]) -> Option<u32> {
    if udim_tile > MAX_UDIM_TILE || mip_level > MAX_SORT_MIP {
        return None;
    }
    // `x - floor(x)` can round to 1.0 for tiny negative x; clamp the quantised value to 127.
    let q = |x: f32| (((x - floor(x)) * 128.0) as u32).min(127);
    let morton = spread7(q(uv[0])) | (spread7(q(uv[1])) << 1);
    Some((udim_tile << UDIM_SHIFT) | (mip_level << MIP_SHIFT) | morton)
}

/// [`shading_sort_key`] with out-of-range fields clamped to their largest value (a sort key only needs
/// to be a good ordering, not exact).
#[inline]
pub fn shading_sort_key_saturating(udim_tile: u32, mip_level: u32, uv: [f32; 2]) -> u32 {
    shading_sort_key(udim_tile.min(MAX_UDIM_TILE), mip_level.min(MAX_SORT_MIP), uv).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout() {
        assert_eq!(shading_sort_key(0, 0, [0.0, 0.0]), Some(0));
        assert_eq!(shading_sort_key(1, 0, [0.0, 0.0]), Some(1 << 18));
        assert_eq!(shading_sort_key(0, 1, [0.0, 0.0]), Some(1 << 14));
        assert_eq!(shading_sort_key(0, 0, [1.0 / 128.0, 0.0]), Some(0b01));
        assert_eq!(shading_sort_key(0, 0, [0.0, 1.0 / 128.0]), Some(0b10));
        assert_eq!(shading_sort_key(127, 15, [0.999, 0.999]), Some((1 << 25) - 1));
        // uv 2.5 is tile-fractional 0.5 → quantised 64 → bit 6 of u → key bit 12.
        assert_eq!(shading_sort_key(0, 0, [2.5, 0.0]), Some(1 << 12));
        assert_eq!(shading_sort_key(0, 0, [-1e-9, 0.0]), Some(0x1555));
    }

    #[test]
    fn range_checks() {
        assert_eq!(shading_sort_key(128, 0, [0.0; 2]), None);
        assert_eq!(shading_sort_key(0, 16, [0.0; 2]), None);
        assert_eq!(shading_sort_key_saturating(500, 20, [0.0; 2]), (127 << 18) | (15 << 14));
    }
}

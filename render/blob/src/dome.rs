//! Textured dome lights (format 6): the lat-long environment map a [`crate::Light`] of kind
//! [`crate::light_kind::TEXTURED_DOME`] shows, and the distribution next-event estimation samples it by.
//!
//! Sections (kinds 60–61): one [`DomeMap`] per textured dome, and the `f32` CDF values they index.
//! A map's distribution is a 2D piecewise-constant density over `width × height` lat-long cells (row 0
//! at the +Y pole, the top of the image; column 0 at the image's left edge): the marginal CDF over
//! rows, then one conditional CDF over the columns of each row. Each CDF starts at 0, never decreases
//! and ends at exactly 1, so a cell's probability is the difference of two neighbouring values and
//! sampling and pdf evaluation read the same numbers.

use bytemuck::{Pod, Zeroable};

/// Most cells along either side of a distribution (ingest builds at most 1024 × 512).
pub const MAX_DOME_CELLS_PER_SIDE: u32 = 1 << 15;

/// One textured dome's map and distribution. 16 bytes.
///
/// | offset | field         | meaning                                                             |
/// |-------:|---------------|---------------------------------------------------------------------|
/// | 0      | `texture`     | index into the texture records (the baked lat-long image)           |
/// | 4      | `width`       | distribution columns (longitude)                                    |
/// | 8      | `height`      | distribution rows (latitude), row 0 at the +Y pole                  |
/// | 12     | `first_value` | index of the marginal CDF in the dome CDF values                    |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct DomeMap {
    /// Texture record index.
    pub texture: u32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// First CDF value: `height + 1` marginal values, then `height` conditional CDFs of `width + 1`.
    pub first_value: u32,
}
const _: () = assert!(std::mem::size_of::<DomeMap>() == 16);

impl DomeMap {
    /// Index range of the marginal CDF over rows (`height + 1` values).
    pub fn marginal(&self) -> std::ops::Range<usize> {
        let start = self.first_value as usize;
        start..start + self.height as usize + 1
    }

    /// Index range of row `row`'s conditional CDF over columns (`width + 1` values).
    pub fn conditional(&self, row: u32) -> std::ops::Range<usize> {
        let start = self.marginal().end + row as usize * (self.width as usize + 1);
        start..start + self.width as usize + 1
    }

    /// Number of CDF values the map owns.
    pub fn value_count(&self) -> u64 {
        (self.height as u64 + 1) + self.height as u64 * (self.width as u64 + 1)
    }
}

/// The dome maps and their CDF values, as ingest writes them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DomeData {
    /// One per textured dome light.
    pub maps: Vec<DomeMap>,
    /// Every map's CDFs, concatenated.
    pub cdf_values: Vec<f32>,
}

/// Validated dome maps (texture index, sizes, CDF ranges and every CDF's shape checked).
#[derive(Clone, Copy, Debug, Default)]
pub struct DomeView<'a> {
    /// Maps.
    pub maps: &'a [DomeMap],
    /// CDF values.
    pub cdf_values: &'a [f32],
}

/// `0 = c[0] ≤ c[1] ≤ … ≤ c[n] = 1`, all finite.
fn is_cdf(c: &[f32]) -> bool {
    c.first() == Some(&0.0) && c.last() == Some(&1.0) && c.windows(2).all(|w| w[0] <= w[1])
}

impl DomeView<'_> {
    /// Checks every map against `textures` texture records and the CDF values; the failing map and
    /// why.
    pub(crate) fn validate(&self, textures: usize) -> Result<(), (usize, &'static str)> {
        for (i, m) in self.maps.iter().enumerate() {
            if m.texture as usize >= textures {
                return Err((i, "texture index out of range"));
            }
            let sides = 1..=MAX_DOME_CELLS_PER_SIDE;
            if !sides.contains(&m.width) || !sides.contains(&m.height) {
                return Err((i, "distribution size out of range"));
            }
            if m.first_value as u64 + m.value_count() > self.cdf_values.len() as u64 {
                return Err((i, "CDF values outside their section"));
            }
            let rows_ok = (0..m.height).all(|row| is_cdf(&self.cdf_values[m.conditional(row)]));
            if !is_cdf(&self.cdf_values[m.marginal()]) || !rows_ok {
                return Err((i, "a CDF does not rise from 0 to 1"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_tile_the_values_and_bad_cdfs_are_refused() {
        let m = DomeMap { texture: 0, width: 2, height: 2, first_value: 1 };
        assert_eq!(m.marginal(), 1..4);
        assert_eq!(m.conditional(0), 4..7);
        assert_eq!(m.conditional(1), 7..10);
        assert_eq!(m.value_count(), 9);
        let mut values = vec![9.0, 0.0, 0.5, 1.0, 0.0, 0.25, 1.0, 0.0, 1.0, 1.0];
        let view = |v: &[f32]| DomeView { maps: std::slice::from_ref(&m), cdf_values: v }.validate(1);
        assert_eq!(view(&values), Ok(()));
        assert_eq!(
            DomeView { maps: &[m], cdf_values: &values }.validate(0),
            Err((0, "texture index out of range"))
        );
        assert_eq!(view(&values[..9]), Err((0, "CDF values outside their section")));
        values[5] = 1.5; // not monotonic
        assert_eq!(view(&values), Err((0, "a CDF does not rise from 0 to 1")));
        values[5] = f32::NAN;
        assert_eq!(view(&values), Err((0, "a CDF does not rise from 0 to 1")));
    }
}

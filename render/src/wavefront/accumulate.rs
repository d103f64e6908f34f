//! Stage 6: accumulation. Reads the finished pool of a chunk (ordered by pixel, then sample: the
//! radiance queue, already sorted by pixel) and adds each path to its pixel's running sums in sample
//! order with [`PixelSum::add`], the scalar film loop's own code; [`finish`] hands the sums back and
//! the frame turns them into pixels once every pass is in. Walking the pool in pixel runs rather than
//! looking each path's pixel up: `docs/perf.md#accumulation-wavefrontaccumulaters`.

use super::PathPool;
use crate::film::{PixelSum, TileResult};
use crate::path::RayCounts;

/// Starts the tile's sums from `init` (its pixels' sums of the samples before this render's).
pub(super) fn begin(film: &mut Vec<PixelSum>, init: &[PixelSum]) {
    film.clear();
    film.extend_from_slice(init);
}

/// Adds a finished chunk of `samples` samples per pixel.
///
/// Pixel by pixel over the chunk's runs of `samples` paths (the pool's order), where it first
/// looked up each path's pixel by a division and two bounds checks (49 instructions a path on the
/// simple scene).
pub(super) fn chunk(film: &mut [PixelSum], pool: &PathPool, samples: usize) {
    let paths = pool.states.len();
    let runs = pool.states.chunks_exact(samples).zip(pool.first_hits[..paths].chunks_exact(samples));
    for (p, (states, first_hits)) in film.iter_mut().zip(runs) {
        for (st, first_hit) in states.iter().zip(first_hits) {
            p.add(st.radiance, first_hit);
        }
    }
}

/// The tile's sums.
pub(super) fn finish(pixels: &[PixelSum], rays: RayCounts) -> TileResult {
    TileResult { sums: pixels.to_vec(), aov: Vec::new(), rays, clock: None }
}

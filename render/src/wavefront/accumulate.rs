//! Stage 6: accumulation. Reads the finished pool of a chunk (ordered by pixel, then sample: the
//! radiance queue, already sorted by pixel) and adds each path to its pixel's running sums in sample
//! order, exactly as the scalar film loop does; [`finish`] turns the sums into the tile.

use super::Worker;
use crate::film::TileResult;
use crate::integrator::RayCounts;
use glam::Vec3;

/// Running sums of one pixel.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelSum {
    sum: Vec3,
    albedo: Vec3,
    normal: Vec3,
    depth: f64,
    hits: u32,
    nonfinite: u32,
}

/// Resets the sums for a tile of `npix` pixels.
pub(super) fn begin(w: &mut Worker, npix: usize) {
    w.pixels.clear();
    w.pixels.resize(npix, PixelSum::default());
}

/// Adds a finished chunk of `samples` samples per pixel.
pub(super) fn chunk(w: &mut Worker, samples: usize) {
    for (i, st) in w.states.iter().enumerate() {
        let p = &mut w.pixels[i / samples];
        if st.radiance.is_finite() {
            p.sum += st.radiance;
        } else {
            p.nonfinite += 1;
        }
        if let Some(h) = w.first_hits[i] {
            p.albedo += h.albedo;
            p.normal += h.normal;
            p.depth += h.depth as f64;
            p.hits += 1;
        }
    }
}

/// The tile's pixels.
pub(super) fn finish(w: &mut Worker, spp: u32, rays: RayCounts) -> TileResult {
    let n = w.pixels.len();
    let mut out = TileResult {
        beauty: Vec::with_capacity(n),
        albedo: Vec::with_capacity(n),
        normal: Vec::with_capacity(n),
        depth: Vec::with_capacity(n),
        rays,
        nonfinite: 0,
        clock: None,
    };
    let inv = 1.0 / spp as f32;
    for p in &w.pixels {
        let c = p.sum * inv;
        out.beauty.push([c.x, c.y, c.z, p.hits as f32 * inv]);
        out.albedo.push((p.albedo * inv).to_array());
        out.normal.push(p.normal.normalize_or_zero().to_array());
        out.depth.push(if p.hits > 0 { (p.depth / p.hits as f64) as f32 } else { f32::INFINITY });
        out.nonfinite += p.nonfinite as u64;
    }
    out
}

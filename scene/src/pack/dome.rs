//! Textured dome lights: the importance-sampling distribution over a lat-long map, built once at
//! ingest and stored beside the baked map (blob sections `DomeMaps` and `DomeCdfValues`).
//!
//! The density is piecewise constant over lat-long cells (row 0 at the +Y pole, the image's top row):
//! a cell's weight is the integral of the map's bilinear reconstruction over it (the separable
//! `[1, 6, 1] / 8` kernel over the texel and its neighbours, wrapping in longitude and clamping in
//! latitude) times `sin θ` at the cell's centre (the solid angle a lat-long cell covers). The kernel
//! rather than the texel alone, because render looks the map up bilinearly: a lone bright texel lights
//! half of each neighbouring cell too, and a cell the distribution gave no weight could then only be
//! reached by BSDF sampling. Maps wider than [`MAX_COLUMNS`] are sampled on the first mip level that
//! fits: the coarser cells cost a little variance on a small sun but keep the CDFs at 2 MiB or less.

use super::common::PackError;
use crate::scene::{Scene, TextureData};
use glam::Vec3;
use std::f64::consts::PI;

/// Widest distribution (columns); its height is at most the same.
pub const MAX_COLUMNS: u32 = 1024;

/// Adds the distribution of scene texture `texture` (once per texture) and returns its dome map
/// index; `texture_refs` maps scene textures to blob texture records.
pub(super) fn pack_dome_map(
    scene: &Scene,
    light: &str,
    texture: u32,
    texture_refs: &[(u32, bool)],
    data: &mut blob::SceneData,
) -> Result<u32, PackError> {
    let fail = |problem: &str| PackError { prim: light.to_string(), problem: problem.to_string() };
    let (Some(scene_texture), Some(&(blob_texture, udim))) =
        (scene.textures.get(texture as usize), texture_refs.get(texture as usize))
    else {
        return Err(fail("dome texture index out of range"));
    };
    let TextureData::Image(baked) = &scene_texture.data else {
        return Err(fail("a dome texture must be one image, not a UDIM set"));
    };
    debug_assert!(!udim);
    if let Some(i) = data.dome.maps.iter().position(|m| m.texture == blob_texture) {
        return Ok(i as u32);
    }
    let view = texture::TextureView::new(&baked.record, &baked.texels)
        .map_err(|e| fail(&format!("dome texture cannot be read back: {e}")))?;
    let (width, height, luminance) = cell_luminance(&view);
    let weights = cell_weights(&luminance, width, height);
    let first_value = data.dome.cdf_values.len() as u32;
    data.dome.cdf_values.extend(distribution(&weights, width, height));
    data.dome.maps.push(blob::DomeMap { texture: blob_texture, width, height, first_value });
    Ok(data.dome.maps.len() as u32 - 1)
}

/// The texel luminance of the first mip level at most [`MAX_COLUMNS`] wide and high, top row first.
fn cell_luminance(view: &texture::TextureView) -> (u32, u32, Vec<f64>) {
    let record = view.record();
    let level = (0..record.mip_count)
        .find(|&l| (record.width >> l).max(1) <= MAX_COLUMNS && (record.height >> l).max(1) <= MAX_COLUMNS)
        .unwrap_or(record.mip_count - 1);
    let (w, h) = ((record.width >> level).max(1), (record.height >> level).max(1));
    // A footprint of 2^level level-0 texels selects `level` exactly; at a texel centre the bilinear
    // weights are (1, 0, 0, 0), so each lookup returns one stored texel.
    let footprint = [(1u32 << level) as f32 / record.width as f32, 0.0];
    let mut luminance = Vec::with_capacity(w as usize * h as usize);
    for row in 0..h {
        let t = (h - 1 - row) as f32 + 0.5; // texture rows run bottom-up
        for x in 0..w {
            let uv = [(x as f32 + 0.5) / w as f32, t / h as f32];
            let [r, g, b, _] = texture::sample(
                view,
                uv,
                footprint,
                [0.0; 2],
                texture::Filter::Bilinear,
                texture::Wrap::Repeat,
                texture::Wrap::Clamp,
            );
            // Half floats above 65504 are stored as infinity; weigh them as the largest finite value.
            let y = Vec3::new(r, g, b).max(Vec3::ZERO).min(Vec3::splat(65504.0));
            let y = y.dot(Vec3::new(0.2126, 0.7152, 0.0722));
            luminance.push(if y.is_finite() { y as f64 } else { 0.0 });
        }
    }
    (w, h, luminance)
}

/// Each cell's weight: the bilinear reconstruction's integral over the cell times `sin θ`.
fn cell_weights(luminance: &[f64], w: u32, h: u32) -> Vec<f64> {
    const K: [f64; 3] = [0.125, 0.75, 0.125];
    let (w, h) = (w as i64, h as i64);
    let at = |x: i64, y: i64| luminance[(y.clamp(0, h - 1) * w + x.rem_euclid(w)) as usize];
    let mut weights = Vec::with_capacity(luminance.len());
    for y in 0..h {
        let sin = (PI * (y as f64 + 0.5) / h as f64).sin();
        for x in 0..w {
            let mut sum = 0.0;
            for (dy, ky) in (-1..=1).zip(K) {
                for (dx, kx) in (-1..=1).zip(K) {
                    sum += ky * kx * at(x + dx, y + dy);
                }
            }
            weights.push(sum * sin);
        }
    }
    weights
}

/// The marginal CDF over rows, then each row's conditional CDF (see [`blob::DomeMap`]). A row of zero
/// weight gets a uniform conditional (it is never chosen), an all-zero map a uniform marginal.
fn distribution(weights: &[f64], w: u32, h: u32) -> Vec<f32> {
    debug_assert_eq!(weights.len(), w as usize * h as usize);
    let rows: Vec<&[f64]> = weights.chunks_exact(w as usize).collect();
    let row_sums: Vec<f64> = rows.iter().map(|r| r.iter().sum()).collect();
    let mut values = cdf(&row_sums);
    for row in rows {
        values.extend(cdf(row));
    }
    values
}

/// `0, f₀/Σ, (f₀+f₁)/Σ, …, 1` in `f32` (accumulated in `f64`); uniform when `Σ = 0`.
fn cdf(f: &[f64]) -> Vec<f32> {
    let total: f64 = f.iter().sum();
    let n = f.len();
    let mut out = Vec::with_capacity(n + 1);
    let mut running = 0.0f64;
    out.push(0.0);
    for (i, &v) in f.iter().enumerate() {
        running += v;
        let c = if total > 0.0 { running / total } else { (i + 1) as f64 / n as f64 };
        out.push(c.min(1.0) as f32);
    }
    // The last value is exactly 1 whatever the rounding of the sum.
    out[n] = 1.0;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdfs_rise_from_zero_to_one_and_match_the_weights() {
        let c = cdf(&[1.0, 0.0, 3.0]);
        assert_eq!(c, vec![0.0, 0.25, 0.25, 1.0]);
        assert_eq!(cdf(&[0.0, 0.0]), vec![0.0, 0.5, 1.0]);
        // 2 × 2: rows of weight 1 + 1 and 0 + 2.
        let v = distribution(&[1.0, 1.0, 0.0, 2.0], 2, 2);
        assert_eq!(v, vec![0.0, 0.5, 1.0, 0.0, 0.5, 1.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn a_lone_texel_weighs_its_neighbours_by_the_bilinear_integral() {
        // One bright texel in the middle of a 4 × 3 map: its own cell holds (6/8)² of its integral,
        // edge neighbours 6/64, corners 1/64, across the longitude seam too.
        let mut lum = vec![0.0; 12];
        lum[4] = 64.0; // row 1, column 0
        let w = cell_weights(&lum, 4, 3);
        let sin_mid = (PI * 1.5 / 3.0).sin();
        let sin_pole = (PI * 0.5 / 3.0).sin();
        assert!((w[4] - 36.0 * sin_mid).abs() < 1e-12);
        assert!((w[7] - 6.0 * sin_mid).abs() < 1e-12, "wraps to the last column");
        assert!((w[0] - 6.0 * sin_pole).abs() < 1e-12);
        assert!((w[3] - 1.0 * sin_pole).abs() < 1e-12);
        assert_eq!(w[2], 0.0);
    }
}

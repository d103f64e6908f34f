//! A textured dome light's lat-long map: radiance by direction and importance sampling by the
//! distribution ingest stored beside it ([`blob::DomeMap`]).
//!
//! Orientation (UsdLux DomeLight, after the OpenEXR lat-long convention), in the light's frame: the
//! image's top row is +Y (latitude +π/2), its bottom row −Y; longitude runs from +π at the image's left
//! edge to −π at its right edge, longitude 0 (the image's centre column) is +Z and longitude +π/2 (a
//! quarter in from the left) is +X, so the left and right edges meet at −Z. With θ the angle from +Y
//! and φ the longitude, a direction is `(sin θ sin φ, cos θ, sin θ cos φ)`; texture coordinates are
//! `s = ½ − φ/2π` and `t = 1 − θ/π` (`t = 1` at the top, as USD addresses images). The light's
//! transform rotates the map (its rotation part only: scale and shear would not change where a
//! direction at infinity points).
//!
//! Density: a cell `(column i, row j)` of a `W × H` distribution is chosen with probability
//! `pₘ(j) p꜀(i | j)` (differences of the stored CDFs) and a point in it uniformly in `(s, θ)`, so the
//! solid-angle pdf is `W H pₘ p꜀ / (2π² sin θ)`.

use glam::{Mat3, Vec3};
use std::f32::consts::{PI, TAU};
use texture::{Filter, TextureView, Wrap};

/// One textured dome: map, distribution and frame.
#[derive(Clone, Copy, Debug)]
pub struct DomeMap<'a> {
    texture: TextureView<'a>,
    width: u32,
    height: u32,
    marginal: &'a [f32],
    /// `height` conditional CDFs of `width + 1` values each.
    conditionals: &'a [f32],
    /// The light's rotation, orthonormalised.
    world_from_dome: Mat3,
}

/// A direction sampled from the map.
#[derive(Clone, Copy, Debug)]
pub struct DomeSample {
    /// Unit world-space direction towards the dome.
    pub wi: Vec3,
    /// Solid-angle pdf (without light selection).
    pub pdf: f32,
    /// Texture value there (linear RGB).
    pub texel: Vec3,
}

/// The orthonormal frame nearest the columns of `m` (Gram–Schmidt, keeping a mirror's handedness).
fn rotation_part(m: Mat3) -> Mat3 {
    let x = m.x_axis.normalize_or(Vec3::X);
    let y = (m.y_axis - x * x.dot(m.y_axis)).normalize_or(x.any_orthonormal_vector());
    let z = x.cross(y);
    Mat3::from_cols(x, y, if m.determinant() < 0.0 { -z } else { z })
}

impl<'a> DomeMap<'a> {
    /// The map `index` of a validated view, seen through `world_from_light` (its 3×3 part).
    pub fn new(view: &blob::SceneView<'a>, index: u32, world_from_light: Mat3) -> Option<Self> {
        let rec = view.dome.maps.get(index as usize)?;
        let record = view.texture_records.get(rec.texture as usize)?;
        // The blob validated the record as `TextureView::new` does; this cannot fail.
        let texture = TextureView::new(record, view.texels).ok()?;
        let marginal = &view.dome.cdf_values[rec.marginal()];
        let first = rec.conditional(0).start;
        let conditionals = &view.dome.cdf_values[first..first + (rec.height * (rec.width + 1)) as usize];
        Some(DomeMap {
            texture,
            width: rec.width,
            height: rec.height,
            marginal,
            conditionals,
            world_from_dome: rotation_part(world_from_light),
        })
    }

    fn conditional(&self, row: usize) -> &'a [f32] {
        let n = self.width as usize + 1;
        &self.conditionals[row * n..(row + 1) * n]
    }

    /// Linear RGB of the map at texture coordinate `(s, t)`: bilinear on level 0.
    fn texel(&self, s: f32, t: f32) -> Vec3 {
        let [r, g, b, _] = texture::sample(
            &self.texture,
            [s, t],
            [0.0; 2],
            [0.0; 2],
            Filter::Bilinear,
            Wrap::Repeat,
            Wrap::Clamp,
        );
        Vec3::new(r, g, b)
    }

    /// `(s, v = θ/π, sin θ)` of a world direction.
    fn coordinates(&self, d: Vec3) -> (f32, f32, f32) {
        let local = self.world_from_dome.transpose() * d;
        let theta = local.y.clamp(-1.0, 1.0).acos();
        let phi = local.x.atan2(local.z);
        let s = 0.5 - phi / TAU;
        let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
        (s - s.floor(), theta / PI, sin_theta)
    }

    /// The map's value seen along world direction `d` (unit), and the solid-angle pdf that
    /// [`DomeMap::sample`] picks `d` (one coordinate transform for both: escaping rays need both).
    pub fn texel_and_pdf(&self, d: Vec3) -> (Vec3, f32) {
        let (s, v, sin_theta) = self.coordinates(d);
        (self.texel(s, 1.0 - v), self.pdf_at(s, v, sin_theta))
    }

    /// Probability of cell `(i, j)` per unit `(s, v)` area.
    fn cell_density(&self, i: usize, j: usize) -> f32 {
        let c = self.conditional(j);
        let pm = self.marginal[j + 1] - self.marginal[j];
        let pc = c[i + 1] - c[i];
        (self.width * self.height) as f32 * pm * pc
    }

    /// Solid-angle pdf that [`DomeMap::sample`] picks world direction `d` (unit).
    pub fn pdf(&self, d: Vec3) -> f32 {
        let (s, v, sin_theta) = self.coordinates(d);
        self.pdf_at(s, v, sin_theta)
    }

    fn pdf_at(&self, s: f32, v: f32, sin_theta: f32) -> f32 {
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let i = ((s * self.width as f32) as usize).min(self.width as usize - 1);
        let j = ((v * self.height as f32) as usize).min(self.height as usize - 1);
        self.cell_density(i, j) / (2.0 * PI * PI * sin_theta)
    }

    /// A direction by the map's distribution; `None` at a pole (zero solid angle).
    pub fn sample(&self, u: [f32; 2]) -> Option<DomeSample> {
        let (j, v_offset) = pick(self.marginal, u[0]);
        let (i, s_offset) = pick(self.conditional(j), u[1]);
        let s = (i as f32 + s_offset) / self.width as f32;
        let v = (j as f32 + v_offset) / self.height as f32;
        let (sin_theta, cos_theta) = (PI * v).sin_cos();
        let (sin_phi, cos_phi) = (PI * (1.0 - 2.0 * s)).sin_cos();
        if sin_theta <= 0.0 {
            return None;
        }
        let local = Vec3::new(sin_theta * sin_phi, cos_theta, sin_theta * cos_phi);
        let wi = (self.world_from_dome * local).normalize();
        let pdf = self.cell_density(i, j) / (2.0 * PI * PI * sin_theta);
        (pdf > 0.0).then(|| DomeSample { wi, pdf, texel: self.texel(s, 1.0 - v) })
    }
}

/// The bucket `k` of a CDF with `cdf[k] ≤ u < cdf[k + 1]`, and where `u` falls inside it in `[0, 1)`.
fn pick(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let k = cdf[1..].partition_point(|&c| c <= u).min(n - 1);
    let width = cdf[k + 1] - cdf[k];
    let offset = if width > 0.0 { ((u - cdf[k]) / width).clamp(0.0, 0.999_999_94) } else { 0.5 };
    (k, offset)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pick_finds_the_bucket_and_skips_empty_ones() {
        let cdf = [0.0, 0.25, 0.25, 1.0];
        assert_eq!(pick(&cdf, 0.0), (0, 0.0));
        assert_eq!(pick(&cdf, 0.125), (0, 0.5));
        assert_eq!(pick(&cdf, 0.25), (2, 0.0), "the empty bucket 1 is never chosen");
        let (k, o) = pick(&cdf, 0.999_999_9);
        assert_eq!(k, 2);
        assert!(o < 1.0);
    }

    #[test]
    fn rotation_part_is_orthonormal_and_keeps_handedness() {
        let m =
            Mat3::from_cols(Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.3, 3.0, 0.0), Vec3::new(0.0, 0.0, -1.0));
        let r = rotation_part(m);
        assert!((r.transpose() * r - Mat3::IDENTITY).abs_diff_eq(Mat3::ZERO, 1e-6));
        assert!(r.determinant() < 0.0);
    }
}

//! The lookups as they were before the texture-lookup speed-ups (libm `floor`/`round`, `half`'s
//! per-value conversion, a `LevelLayout` with a division per lookup, `rem_euclid` wraps): kept
//! verbatim as the reference the optimised lookups must equal bit for bit.

#![allow(dead_code)]

use crate::format::{Filter, TexelFormat, Wrap};
use crate::record::TextureRecord;
use crate::sample::{Lookup, TextureView, EWA_ALPHA, EWA_FOOTPRINT_SCALE, MAX_ANISOTROPY};
use crate::srgb::SRGB_TO_LINEAR;

/// The reference lookup of `lookup` on `tex`.
pub(crate) fn sample(tex: &TextureView, lookup: &Lookup) -> [f32; 4] {
    let (rec, texels) = (tex.record(), tex.texels());
    match tex.format() {
        TexelFormat::Srgb8 => Sampler::<Srgb8>::new(rec, texels, lookup).filter(lookup),
        TexelFormat::Unorm8 => Sampler::<Unorm8>::new(rec, texels, lookup).filter(lookup),
        TexelFormat::F16 => Sampler::<F16>::new(rec, texels, lookup).filter(lookup),
    }
}

/// Geometry of one mip level, derived from a [`TextureRecord`] with shifts only.
struct LevelLayout {
    /// Byte offset of the level in the texel array.
    base: usize,
    /// Level width in texels.
    width: u32,
    /// Level height in texels.
    height: u32,
    /// Bytes per texel.
    texel_bytes: u32,
    tile_log2: u32,
    tile_w: u32,
    tile_h: u32,
    tiles_x: u32,
}

impl LevelLayout {
    /// Layout of level `level` of a texture with the given level-0 size.
    fn new(width: u32, height: u32, level: u32, tile_log2: u32, texel_bytes: u32, base: usize) -> Self {
        let width = (width >> level).max(1);
        let height = (height >> level).max(1);
        let tile = 1u32 << tile_log2;
        let tile_w = width.min(tile);
        let tile_h = height.min(tile);
        LevelLayout {
            base,
            width,
            height,
            texel_bytes,
            tile_log2,
            tile_w,
            tile_h,
            tiles_x: width.div_ceil(tile_w),
        }
    }

    /// Layout of level `level` of a baked texture.
    #[inline]
    fn of(rec: &TextureRecord, level: u32) -> Self {
        let format = crate::TexelFormat::from_u32(rec.format).unwrap_or(crate::TexelFormat::Srgb8);
        Self::new(
            rec.width,
            rec.height,
            level,
            rec.tile_log2,
            rec.channels * format.channel_bytes(),
            rec.level_offsets[level as usize] as usize,
        )
    }

    /// Byte offset in the texel array of texel `(x, y)`; `x < width`, `y < height`.
    #[inline(always)]
    fn texel_offset(&self, x: u32, y: u32) -> usize {
        let mask = (1u32 << self.tile_log2) - 1;
        let tile = (y >> self.tile_log2) * self.tiles_x + (x >> self.tile_log2);
        // When the level is narrower than a tile, `x >> tile_log2 == 0` and `x & mask == x`, so the same
        // formula addresses the clipped single tile.
        let within = (y & mask) * self.tile_w + (x & mask);
        let texel = tile as usize * (self.tile_w * self.tile_h) as usize + within as usize;
        self.base + texel * self.texel_bytes as usize
    }
}

/// Level of detail for a footprint: `log2` of the larger of `|duv_dx|`, `|duv_dy|` measured in level-0
/// texels. `≤ 0` means magnification; `-inf` for a zero footprint.
#[inline]
fn mip_level(rec: &TextureRecord, duv_dx: [f32; 2], duv_dy: [f32; 2]) -> f32 {
    let (w, h) = (rec.width as f32, rec.height as f32);
    let ax = length(duv_dx[0] * w, duv_dx[1] * h);
    let ay = length(duv_dy[0] * w, duv_dy[1] * h);
    // The one change since: the level's `log2` is the crate's, which the lane filter computes too.
    crate::sample::log2(ax.max(ay))
}

/// Footprint axis length in texels. Not `f32::hypot`: that is a libm call (2% of a lookup in a profile)
/// guarding against overflow that texel-space derivatives never reach.
#[inline(always)]
fn length(x: f32, y: f32) -> f32 {
    (x * x + y * y).sqrt()
}

/// Maps integer texel coordinate `i` into `0..n`, or `None` for a black border.
#[inline(always)]
fn wrap(i: i32, n: u32, mode: Wrap) -> Option<u32> {
    let n = n as i32; // n <= MAX_DIMENSION, so 2n fits too
    match mode {
        Wrap::Repeat => Some(i.rem_euclid(n) as u32),
        Wrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            Some(if m < n { m } else { 2 * n - 1 - m } as u32)
        }
        Wrap::Clamp => Some(i.clamp(0, n - 1) as u32),
        Wrap::Black => (0..n).contains(&i).then_some(i as u32),
    }
}

/// Decodes one stored texel to linear RGBA.
trait Decode {
    fn texel(bytes: &[u8], channels: u32) -> [f32; 4];
}

struct Srgb8;
struct Unorm8;
struct F16;

/// Grey / grey+alpha / RGB / RGBA → RGBA, with colour and alpha decoded by separate functions.
#[inline(always)]
fn expand(channels: u32, colour: impl Fn(usize) -> f32, alpha: impl Fn(usize) -> f32) -> [f32; 4] {
    match channels {
        1 => {
            let g = colour(0);
            [g, g, g, 1.0]
        }
        2 => {
            let g = colour(0);
            [g, g, g, alpha(1)]
        }
        3 => [colour(0), colour(1), colour(2), 1.0],
        _ => [colour(0), colour(1), colour(2), alpha(3)],
    }
}

impl Decode for Srgb8 {
    #[inline(always)]
    fn texel(b: &[u8], channels: u32) -> [f32; 4] {
        expand(channels, |i| SRGB_TO_LINEAR[b[i] as usize], |i| b[i] as f32 * (1.0 / 255.0))
    }
}

impl Decode for Unorm8 {
    #[inline(always)]
    fn texel(b: &[u8], channels: u32) -> [f32; 4] {
        let unorm = |i: usize| b[i] as f32 * (1.0 / 255.0);
        expand(channels, unorm, unorm)
    }
}

impl Decode for F16 {
    #[inline(always)]
    fn texel(b: &[u8], channels: u32) -> [f32; 4] {
        let half = |i: usize| half::f16::from_le_bytes([b[2 * i], b[2 * i + 1]]).to_f32();
        expand(channels, half, half)
    }
}

#[inline(always)]
fn lerp4(a: [f32; 4], b: [f32; 4], t: f32) -> [f32; 4] {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
}

/// One lookup's state, specialised on texel format.
struct Sampler<'a, D> {
    rec: &'a TextureRecord,
    texels: &'a [u8],
    wrap_s: Wrap,
    wrap_t: Wrap,
    _decode: std::marker::PhantomData<D>,
}

impl<D: Decode> Sampler<'_, D> {
    fn new<'b>(rec: &'b TextureRecord, texels: &'b [u8], lookup: &Lookup) -> Sampler<'b, D> {
        Sampler {
            rec,
            texels,
            wrap_s: lookup.wrap_s,
            wrap_t: lookup.wrap_t,
            _decode: std::marker::PhantomData,
        }
    }

    #[inline(always)]
    fn last_level(&self) -> u32 {
        self.rec.mip_count - 1
    }

    #[inline(always)]
    fn fetch(&self, lv: &LevelLayout, x: i32, y: i32) -> [f32; 4] {
        match (wrap(x, lv.width, self.wrap_s), wrap(y, lv.height, self.wrap_t)) {
            (Some(x), Some(y)) => {
                let off = lv.texel_offset(x, y);
                let n = lv.texel_bytes as usize;
                D::texel(&self.texels[off..off + n], self.rec.channels)
            }
            _ => [0.0; 4],
        }
    }

    /// Texel containing `uv` on `level`.
    fn nearest(&self, level: u32, uv: [f32; 2]) -> [f32; 4] {
        let lv = LevelLayout::of(self.rec, level);
        // `as i32` saturates huge or NaN coordinates (NaN → 0) instead of failing; wrap keeps them in range.
        let x = (uv[0] * lv.width as f32).floor() as i32;
        let y = (uv[1] * lv.height as f32).floor() as i32;
        self.fetch(&lv, x, y)
    }

    /// Bilinear blend of the four texels whose centres surround `uv` on `level`.
    fn bilinear(&self, level: u32, uv: [f32; 2]) -> [f32; 4] {
        let lv = LevelLayout::of(self.rec, level);
        let x = uv[0] * lv.width as f32 - 0.5;
        let y = uv[1] * lv.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i32, y0 as i32);
        let (x1, y1) = (x0.saturating_add(1), y0.saturating_add(1));
        let bottom = lerp4(self.fetch(&lv, x0, y0), self.fetch(&lv, x1, y0), fx);
        let top = lerp4(self.fetch(&lv, x0, y1), self.fetch(&lv, x1, y1), fx);
        lerp4(bottom, top, fy)
    }

    /// Splits a fractional level into the two levels to blend and the weight of the upper one; `None`
    /// when magnifying (level ≤ 0, or NaN).
    #[inline(always)]
    fn level_pair(&self, level: f32) -> Option<(u32, u32, f32)> {
        if level.is_nan() || level <= 0.0 {
            return None;
        }
        let last = self.last_level();
        let level = level.min(last as f32);
        let l0 = level.floor();
        let l0i = l0 as u32;
        Some((l0i, (l0i + 1).min(last), level - l0))
    }

    fn trilinear(&self, level: f32, uv: [f32; 2]) -> [f32; 4] {
        match self.level_pair(level) {
            None => self.bilinear(0, uv),
            Some((l0, _, 0.0)) => self.bilinear(l0, uv),
            Some((l0, l1, t)) => lerp4(self.bilinear(l0, uv), self.bilinear(l1, uv), t),
        }
    }

    fn filter(&self, q: &Lookup) -> [f32; 4] {
        match q.filter {
            Filter::Moonray => match self.level_pair(mip_level(self.rec, q.duv_dx, q.duv_dy)) {
                None => self.bilinear(0, q.uv),
                Some((l0, _, 0.0)) => self.nearest(l0, q.uv),
                Some((l0, l1, t)) => lerp4(self.nearest(l0, q.uv), self.nearest(l1, q.uv), t),
            },
            Filter::Bilinear => {
                let level = mip_level(self.rec, q.duv_dx, q.duv_dy);
                // NaN and -inf round to NaN/-inf; `as u32` saturates both to 0.
                self.bilinear((level.round() as u32).min(self.last_level()), q.uv)
            }
            Filter::Trilinear => self.trilinear(mip_level(self.rec, q.duv_dx, q.duv_dy), q.uv),
            Filter::Anisotropic => self.anisotropic(q),
            Filter::Ewa => self.ewa(q),
        }
    }

    /// EWA (pbrt-v3 `MIPMap::Lookup` with an ellipse): the axes are `duv_dx`, `duv_dy` scaled by
    /// [`EWA_FOOTPRINT_SCALE`]; the shorter is
    /// lengthened to `1 / MAX_ANISOTROPY` of the longer, the level pair comes from its length, and each
    /// level sums a Gaussian over the texels inside the ellipse. Magnification (the longer axis under a
    /// texel) is bilinear, as for the other filters; a footprint beyond the coarsest level reads it
    /// bilinearly, since the coarsest level already averages the whole image.
    fn ewa(&self, q: &Lookup) -> [f32; 4] {
        let (w, h) = (self.rec.width as f32, self.rec.height as f32);
        let k = EWA_FOOTPRINT_SCALE;
        let (mut d0, mut d1) = ([q.duv_dx[0] * k, q.duv_dx[1] * k], [q.duv_dy[0] * k, q.duv_dy[1] * k]);
        let mut major = length(d0[0] * w, d0[1] * h);
        let mut minor = length(d1[0] * w, d1[1] * h);
        if minor > major {
            std::mem::swap(&mut d0, &mut d1);
            std::mem::swap(&mut major, &mut minor);
        }
        if major.is_nan() || major <= 1.0 {
            return self.bilinear(0, q.uv);
        }
        let limit = major / MAX_ANISOTROPY as f32;
        if minor < limit {
            // Lengthen the minor axis (or, when it is zero, make one perpendicular to the major).
            let scale = limit / minor;
            d1 = if minor > 0.0 && scale.is_finite() {
                [d1[0] * scale, d1[1] * scale]
            } else {
                let dir = [-d0[1] * w / major, d0[0] * h / major]; // ⟂ in texel space, unit length
                [dir[0] * limit / w, dir[1] * limit / h]
            };
            minor = limit;
        }
        let lod = minor.log2().max(0.0);
        let last = self.last_level();
        if lod >= last as f32 {
            return self.bilinear(last, q.uv);
        }
        let l0 = lod.floor();
        let t = lod - l0;
        let near = self.ewa_level(l0 as u32, q.uv, d0, d1);
        if t == 0.0 {
            return near;
        }
        lerp4(near, self.ewa_level(l0 as u32 + 1, q.uv, d0, d1), t)
    }

    /// One level of EWA: the Gaussian `exp(−α r²)` (α = [`EWA_ALPHA`]) over the texels whose centres lie
    /// inside the ellipse `r² < 1` spanned by `d0`, `d1` (uv per pixel) at this level, widened by one
    /// texel in every direction (the `+ 1` terms: a reconstruction filter, so a footprint under a texel
    /// still covers one), normalised by the sum of the weights.
    fn ewa_level(&self, level: u32, uv: [f32; 2], d0: [f32; 2], d1: [f32; 2]) -> [f32; 4] {
        let lv = LevelLayout::of(self.rec, level);
        let (w, h) = (lv.width as f32, lv.height as f32);
        let (s, t) = (uv[0] * w - 0.5, uv[1] * h - 0.5);
        let (a0, a1) = ([d0[0] * w, d0[1] * h], [d1[0] * w, d1[1] * h]);
        // Implicit ellipse A s² + B s t + C t² = F for the axes a0, a1, scaled so that F = 1.
        let mut a = a0[1] * a0[1] + a1[1] * a1[1] + 1.0;
        let mut b = -2.0 * (a0[0] * a0[1] + a1[0] * a1[1]);
        let mut c = a0[0] * a0[0] + a1[0] * a1[0] + 1.0;
        let inv_f = 1.0 / (a * c - b * b * 0.25);
        a *= inv_f;
        b *= inv_f;
        c *= inv_f;
        // Bounding box of the ellipse.
        let det = 4.0 * a * c - b * b;
        let inv_det = 1.0 / det;
        let (u_half, v_half) = (2.0 * inv_det * (det * c).sqrt(), 2.0 * inv_det * (det * a).sqrt());
        if !(u_half.is_finite() && v_half.is_finite()) {
            return self.bilinear(level, uv);
        }
        let (x0, x1) = ((s - u_half).ceil() as i32, (s + u_half).floor() as i32);
        let (y0, y1) = ((t - v_half).ceil() as i32, (t + v_half).floor() as i32);
        let mut sum = [0.0f32; 4];
        let mut weights = 0.0f32;
        for y in y0..=y1 {
            let tt = y as f32 - t;
            for x in x0..=x1 {
                let ss = x as f32 - s;
                let r2 = a * ss * ss + b * ss * tt + c * tt * tt;
                if r2 < 1.0 {
                    let weight = (-EWA_ALPHA * r2).exp();
                    let texel = self.fetch(&lv, x, y);
                    sum = std::array::from_fn(|k| sum[k] + texel[k] * weight);
                    weights += weight;
                }
            }
        }
        if weights > 0.0 {
            sum.map(|v| v / weights)
        } else {
            self.bilinear(level, uv)
        }
    }

    /// Trilinear taps spread along the footprint's major axis, level chosen from the minor axis.
    fn anisotropic(&self, q: &Lookup) -> [f32; 4] {
        let (w, h) = (self.rec.width as f32, self.rec.height as f32);
        let ax = length(q.duv_dx[0] * w, q.duv_dx[1] * h);
        let ay = length(q.duv_dy[0] * w, q.duv_dy[1] * h);
        let (axis, major, minor) = if ax >= ay { (q.duv_dx, ax, ay) } else { (q.duv_dy, ay, ax) };
        if major.is_nan() || major <= 0.0 {
            return self.bilinear(0, q.uv);
        }
        let minor = minor.max(major / MAX_ANISOTROPY as f32);
        let taps = ((major / minor).ceil() as u32).clamp(1, MAX_ANISOTROPY);
        let level = minor.log2();
        let mut sum = [0.0f32; 4];
        for i in 0..taps {
            // Tap centres at the middles of `taps` equal segments of the major axis, which spans
            // one pixel step: -0.5 .. 0.5 times `axis`.
            let o = (i as f32 + 0.5) / taps as f32 - 0.5;
            let c = self.trilinear(level, [q.uv[0] + axis[0] * o, q.uv[1] + axis[1] * o]);
            sum = std::array::from_fn(|k| sum[k] + c[k]);
        }
        sum.map(|v| v / taps as f32)
    }
}

/// The optimised scalar and lane lookups equal the reference bit for bit (every NaN alike) on random
/// coordinates and footprints, for every filter, wrap and texel format.
#[test]
#[allow(clippy::needless_range_loop)] // lanes and lookups indexed by the same lane number
fn lookups_equal_the_reference() {
    use super::lanes::{bits, images, Rng};
    use crate::{sample_lanes_with, sample_with, LookupLanes, NoTouch};
    let mut rng = Rng(23);
    let set = super::set_of(&images(&mut rng));
    let view = set.view().unwrap();
    let wraps = [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp, Wrap::Black];
    let mut compared = 0;
    for index in 0..view.texture_count() as u32 {
        let tex = view.texture(index).unwrap();
        for filter in Filter::ALL {
            for round in 0..16 {
                let mut q = LookupLanes {
                    filter,
                    wrap_s: wraps[round % 4],
                    wrap_t: wraps[(round / 4 + index as usize) % 4],
                    ..Default::default()
                };
                for k in 0..8 {
                    for c in 0..2 {
                        q.uv[c][k] = rng.coordinate(1.5, 3.0);
                        q.duv_dx[c][k] = rng.derivative();
                        q.duv_dy[c][k] = rng.derivative();
                    }
                }
                let lanes = sample_lanes_with(&tex, &q, 8, &NoTouch);
                for k in 0..8 {
                    let want = sample(&tex, &q.lane(k)).map(bits);
                    let got = sample_with(&tex, &q.lane(k), &NoTouch).map(bits);
                    assert_eq!(got, want, "texture {index}, {filter:?}: {:?}", q.lane(k));
                    let lane: [f32; 4] = std::array::from_fn(|c| lanes[c][k]);
                    assert_eq!(
                        lane.map(bits),
                        want,
                        "lane {k}, texture {index}, {filter:?}: {:?}",
                        q.lane(k)
                    );
                    compared += 1;
                }
            }
        }
    }
    assert!(compared > 7000, "{compared}");
}

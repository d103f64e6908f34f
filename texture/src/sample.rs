//! Filtered lookups on borrowed texel bytes: no allocation, no locks, no I/O beyond page faults.
//!
//! The texel format is resolved once per lookup (a `match` that picks a monomorphised filter), so the
//! per-texel path is a table load (sRGB8), a multiply (unorm8) or a half→float conversion (f16). Texels
//! with fewer than four channels expand as UsdUVTexture does: grey → `(g, g, g, 1)`, grey+alpha →
//! `(g, g, g, a)`, RGB → `(r, g, b, 1)`.
//!
//! Coordinates follow USD: `(0, 0)` is the bottom-left corner of the image and `(1, 1)` the top-right; texel
//! `(x, y)` of a `w × h` level covers `[x/w, (x+1)/w) × [y/h, (y+1)/h)` with its centre at `+0.5`.
//!
//! All filters are written as scalar code over one lookup; [`sample_lanes_with`] runs eight lookups
//! on one texture at once with the same results (the MoonRay filter in lane loops: footprint → level →
//! coordinates → gathers → weights).
//!
//! # Cost, and what made it cheaper
//! Lookups must not change a bit when they get faster (the wavefront image equals the scalar one, and
//! both equal what they were): `tests::reference` keeps the lookups as they were before these changes
//! and compares every filter, wrap and format against them on random coordinates and footprints. What
//! was cut, per lookup:
//! - `floor`/`round` were libm calls on baseline x86-64 (no SSE4.1); [`crate::float`] does them inline
//!   with the same bits;
//! - a level's [`LevelLayout`] decoded the texel format and divided (`div_ceil`) per level addressed; the
//!   view now holds the texel size and the tile count is a shift;
//! - `Repeat`/`Mirror` wraps divided (`rem_euclid`) per texel; coordinates already in range and
//!   power-of-two levels skip the division;
//! - the lane filter computes every tap's address first, then reads and decodes only the taps in use,
//!   half floats in one F16C conversion ([`crate::half_float`]), and skips the level-0 bilinear
//!   coordinates when no lane magnifies.
//!
//! Measurements: `docs/perf.md#texture-lookups-texturesrcsamplers`.

use crate::error::Error;
use crate::float::{floor, round};
use crate::format::{Filter, TexelFormat, Wrap};
use crate::layout::LevelLayout;
use crate::mip::mip_count;
use crate::record::{TextureRecord, MAX_DIMENSION};
use crate::srgb::SRGB_TO_LINEAR;
use crate::stats::{NoTouch, Touch};

mod lanes;
#[cfg(target_arch = "x86_64")]
mod lanes_avx2;
mod level_lanes;
mod log2;
#[cfg(test)]
pub(crate) use lanes::{sample_lanes_on, LanePath};
pub use lanes::{sample_lanes_with, Lanes, LookupLanes, LANES};
pub use log2::log2;

/// Most taps the anisotropic filter takes along the footprint's major axis; footprints more elongated
/// than this are blurred along the minor axis instead (their level is raised).
pub const MAX_ANISOTROPY: u32 = 8;

/// Falloff of the EWA Gaussian `exp(−α r²)` over the ellipse `r² < 1` (pbrt-v3's value: the weight at
/// the ellipse's edge is `e⁻²`, so the Gaussian's σ is half the ellipse's axis).
pub const EWA_ALPHA: f32 = 2.0;

/// The EWA ellipse's axes are the uv derivatives (one pixel step) times this, `1/√3`, so that the
/// Gaussian's σ (half the axis) is `1/√12` pixel: the standard deviation of the one-pixel box the
/// renderer integrates each pixel over. pbrt-v3 uses the derivatives as they are (σ = ½ pixel), which
/// over-blurs against a box-filtered reference: on `bench textures` (receding checker plane, 4 spp vs
/// 1024 spp) the RMSE was 0.0342 with scale 1, 0.0323 with 0.75, 0.0311 with `1/√3` and 0.0307 with 0.5
/// (the multi-tap anisotropic filter: 0.0325). Narrower still trades blur for aliasing with the
/// sample count; `1/√3` is the choice that does not depend on the benchmark.
pub const EWA_FOOTPRINT_SCALE: f32 = 0.577_350_3;

/// A validated texture: its record and the whole texel array its offsets point into.
#[derive(Clone, Copy, Debug)]
pub struct TextureView<'a> {
    record: &'a TextureRecord,
    format: TexelFormat,
    /// Bytes per texel, derived once from `record` and `format` rather than per level addressed.
    texel_bytes: u32,
    texels: &'a [u8],
}

impl<'a> TextureView<'a> {
    /// Checks `record` against `texels` (the whole texel array) so lookups cannot index out of bounds.
    pub fn new(record: &'a TextureRecord, texels: &'a [u8]) -> Result<Self, Error> {
        validate(record, texels.len(), 0)
            .map(|format| Self::trusted(record, format, texels))
            .map_err(|reason| Error::invalid("texture", 0, reason))
    }

    /// A view of a record already validated by [`validate`].
    #[inline]
    pub(crate) fn trusted(record: &'a TextureRecord, format: TexelFormat, texels: &'a [u8]) -> Self {
        let texel_bytes = record.channels * format.channel_bytes();
        TextureView { record, format, texel_bytes, texels }
    }

    /// The whole texel array the record's offsets point into.
    #[cfg(test)]
    pub(crate) fn texels(&self) -> &'a [u8] {
        self.texels
    }

    /// The texture's record.
    pub fn record(&self) -> &'a TextureRecord {
        self.record
    }

    /// The stored texel format.
    pub fn format(&self) -> TexelFormat {
        self.format
    }
}

/// Checks one record against a texel array of `len` bytes; returns its format or the failed check.
pub(crate) fn validate(rec: &TextureRecord, len: usize, _index: usize) -> Result<TexelFormat, &'static str> {
    let format = TexelFormat::from_u32(rec.format).ok_or("unknown texel format")?;
    if !(1..=MAX_DIMENSION).contains(&rec.width) || !(1..=MAX_DIMENSION).contains(&rec.height) {
        return Err("width or height out of range");
    }
    if !(1..=4).contains(&rec.channels) {
        return Err("channels must be 1..=4");
    }
    if !(2..=12).contains(&rec.tile_log2) {
        return Err("tile_log2 must be 2..=12");
    }
    if rec.mip_count == 0 || rec.mip_count > mip_count(rec.width, rec.height) {
        return Err("mip_count must be 1..=full chain");
    }
    for level in 0..rec.mip_count {
        let layout = LevelLayout::of(rec, level);
        let end = (rec.level_offsets[level as usize] as usize).checked_add(layout.byte_len());
        if end.is_none_or(|end| end > len) {
            return Err("mip level runs past the texel array");
        }
    }
    Ok(format)
}

/// Everything a lookup needs besides the texture; `Copy`, built on the stack per lookup.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lookup {
    /// Texture coordinate `(s, t)`.
    pub uv: [f32; 2],
    /// Change of `uv` per pixel step in x (the footprint's first axis).
    pub duv_dx: [f32; 2],
    /// Change of `uv` per pixel step in y.
    pub duv_dy: [f32; 2],
    /// Filter.
    pub filter: Filter,
    /// Wrap along `s`.
    pub wrap_s: Wrap,
    /// Wrap along `t`.
    pub wrap_t: Wrap,
}

/// Filtered RGBA at `uv`, linear. See the module docs for coordinates and [`Filter`] for the filters.
#[inline]
pub fn sample(
    tex: &TextureView,
    uv: [f32; 2],
    duv_dx: [f32; 2],
    duv_dy: [f32; 2],
    filter: Filter,
    wrap_s: Wrap,
    wrap_t: Wrap,
) -> [f32; 4] {
    sample_with(tex, &Lookup { uv, duv_dx, duv_dy, filter, wrap_s, wrap_t }, &NoTouch)
}

/// [`sample`], reporting every texel read to `touch`.
#[inline]
pub fn sample_with<T: Touch>(tex: &TextureView, lookup: &Lookup, touch: &T) -> [f32; 4] {
    // Resolve the format once; each arm is a separately optimised copy of the filters.
    match tex.format {
        TexelFormat::Srgb8 => Sampler::<Srgb8, T>::new(tex, lookup, touch).filter(lookup),
        TexelFormat::Unorm8 => Sampler::<Unorm8, T>::new(tex, lookup, touch).filter(lookup),
        TexelFormat::F16 => Sampler::<F16, T>::new(tex, lookup, touch).filter(lookup),
    }
}

/// Level of detail for a footprint: `log2` of the larger of `|duv_dx|`, `|duv_dy|` measured in level-0
/// texels. `≤ 0` means magnification; `-inf` for a zero footprint. The `log2` is [`log2`] (correctly
/// rounded, computed the same way by the lane filter), not libm's.
#[inline]
pub fn mip_level(rec: &TextureRecord, duv_dx: [f32; 2], duv_dy: [f32; 2]) -> f32 {
    let (w, h) = (rec.width as f32, rec.height as f32);
    let ax = length(duv_dx[0] * w, duv_dx[1] * h);
    let ay = length(duv_dy[0] * w, duv_dy[1] * h);
    log2(ax.max(ay))
}

/// Footprint axis length in texels. Not `f32::hypot`: that is a libm call (2% of a lookup in a profile)
/// guarding against overflow that texel-space derivatives never reach.
#[inline(always)]
fn length(x: f32, y: f32) -> f32 {
    (x * x + y * y).sqrt()
}

/// Maps integer texel coordinate `i` into `0..n`, or `None` for a black border.
#[inline(always)]
pub fn wrap(i: i32, n: u32, mode: Wrap) -> Option<u32> {
    let n = n as i32; // n <= MAX_DIMENSION, so 2n fits too
    match mode {
        Wrap::Repeat => Some(rem_euclid(i, n) as u32),
        Wrap::Mirror => {
            let m = rem_euclid(i, 2 * n);
            Some(if m < n { m } else { 2 * n - 1 - m } as u32)
        }
        Wrap::Clamp => Some(i.clamp(0, n - 1) as u32),
        Wrap::Black => (0..n).contains(&i).then_some(i as u32),
    }
}

/// `i.rem_euclid(n)` for `n > 0`, without the integer division where it is not needed: a coordinate
/// already inside `0..n` (every lookup on uvs in `[0, 1)`), and power-of-two sizes, where the
/// Euclidean remainder of a two's-complement integer is its low bits. `idiv` was a third of
/// `nearest`'s instructions on the tiled ground of the shading-heavy scene.
#[inline(always)]
fn rem_euclid(i: i32, n: i32) -> i32 {
    if (i as u32) < n as u32 {
        i
    } else if n & (n - 1) == 0 {
        i & (n - 1)
    } else {
        i.rem_euclid(n)
    }
}

/// Marks a tap without a texel: a black border, or a tap the lane's filter does not use.
pub(crate) const NO_TEXEL: usize = usize::MAX;

/// Decodes stored texels to linear RGBA.
trait Decode {
    /// `Some(srgb)` for the one-byte-per-channel formats (sRGB or unorm), which the AVX2 lane filter
    /// gathers in hardware; `None` for the others.
    const U8_SRGB: Option<bool> = None;

    /// One texel: `bytes` holds its `channels` stored channels.
    fn texel(bytes: &[u8], channels: u32) -> [f32; 4];

    /// The texels at byte offsets `at[tap][lane]` (`NO_TEXEL`: zero, nothing read) of the first
    /// `count` lanes, `[tap][channel][lane]`, reported to `touch` lane by lane; `texel_bytes` bytes each.
    #[inline(always)]
    fn gather<T: Touch>(
        texels: &[u8],
        channels: u32,
        texel_bytes: usize,
        at: &[[usize; LANES]; 4],
        count: usize,
        touch: &T,
    ) -> [[Lanes; 4]; 4] {
        let mut taps = [[[0.0f32; LANES]; 4]; 4];
        for k in 0..count {
            for tap in 0..4 {
                let off = at[tap][k];
                if off != NO_TEXEL {
                    touch.touch(off, texel_bytes);
                    let v = Self::texel(&texels[off..off + texel_bytes], channels);
                    for c in 0..4 {
                        taps[tap][c][k] = v[c];
                    }
                }
            }
        }
        taps
    }
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
    const U8_SRGB: Option<bool> = Some(true);

    #[inline(always)]
    fn texel(b: &[u8], channels: u32) -> [f32; 4] {
        expand(channels, |i| SRGB_TO_LINEAR[b[i] as usize], |i| b[i] as f32 * (1.0 / 255.0))
    }
}

impl Decode for Unorm8 {
    const U8_SRGB: Option<bool> = Some(false);

    #[inline(always)]
    fn texel(b: &[u8], channels: u32) -> [f32; 4] {
        let unorm = |i: usize| b[i] as f32 * (1.0 / 255.0);
        expand(channels, unorm, unorm)
    }
}

impl Decode for F16 {
    /// One value at a time through `half`, which picks F16C at run time per call.
    #[inline(always)]
    fn texel(b: &[u8], channels: u32) -> [f32; 4] {
        let half = |i: usize| half::f16::from_le_bytes([b[2 * i], b[2 * i + 1]]).to_f32();
        expand(channels, half, half)
    }

    /// Copies the raw halves of every tap first, then converts them in one call: `half`'s slice
    /// conversion checks for F16C once and converts eight values per instruction (`vcvtph2ps`).
    /// The conversion is exact either way (see [`crate::half_float`]), so the result is the same.
    #[inline(always)]
    fn gather<T: Touch>(
        texels: &[u8],
        channels: u32,
        texel_bytes: usize,
        at: &[[usize; LANES]; 4],
        count: usize,
        touch: &T,
    ) -> [[Lanes; 4]; 4] {
        // Slot `(tap * LANES + lane) * 4 + channel`; a missing tap stays +0.0 (bits 0), as the scalar
        // fetch returns.
        let mut raw = [0u16; 4 * LANES * 4];
        let mut present = [[false; LANES]; 4];
        for k in 0..count {
            for tap in 0..4 {
                let off = at[tap][k];
                if off != NO_TEXEL {
                    touch.touch(off, texel_bytes);
                    let slot = &mut raw[(tap * LANES + k) * 4..][..4];
                    for (c, pair) in texels[off..off + texel_bytes].chunks_exact(2).enumerate() {
                        slot[c] = u16::from_le_bytes([pair[0], pair[1]]);
                    }
                    present[tap][k] = true;
                }
            }
        }
        let values = crate::half_float::to_f32_array(&raw);
        let mut taps = [[[0.0f32; LANES]; 4]; 4];
        for tap in 0..4 {
            for k in 0..count {
                if present[tap][k] {
                    let v = &values[(tap * LANES + k) * 4..][..4];
                    let v = expand(channels, |i| v[i], |i| v[i]);
                    for c in 0..4 {
                        taps[tap][c][k] = v[c];
                    }
                }
            }
        }
        taps
    }
}

#[inline(always)]
fn lerp4(a: [f32; 4], b: [f32; 4], t: f32) -> [f32; 4] {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
}

/// One lookup's state, specialised on texel format and touch sink.
struct Sampler<'a, D, T> {
    tex: &'a TextureView<'a>,
    wrap_s: Wrap,
    wrap_t: Wrap,
    touch: &'a T,
    _decode: std::marker::PhantomData<D>,
}

impl<'a, D: Decode, T: Touch> Sampler<'a, D, T> {
    #[inline(always)]
    fn new(tex: &'a TextureView<'a>, lookup: &Lookup, touch: &'a T) -> Self {
        Sampler {
            tex,
            wrap_s: lookup.wrap_s,
            wrap_t: lookup.wrap_t,
            touch,
            _decode: std::marker::PhantomData,
        }
    }

    #[inline(always)]
    fn last_level(&self) -> u32 {
        self.tex.record.mip_count - 1
    }

    /// Where `level` lives, from shifts of the record (no texel-format decoding, no division).
    #[inline(always)]
    fn layout(&self, level: u32) -> LevelLayout {
        let rec = self.tex.record;
        LevelLayout::new(
            rec.width,
            rec.height,
            level,
            rec.tile_log2,
            self.tex.texel_bytes,
            rec.level_offsets[level as usize] as usize,
        )
    }

    /// Byte offset of texel `(x, y)` after wrapping, or `NO_TEXEL` on a black border.
    #[inline(always)]
    fn address(&self, lv: &LevelLayout, x: i32, y: i32) -> usize {
        match (wrap(x, lv.width, self.wrap_s), wrap(y, lv.height, self.wrap_t)) {
            (Some(x), Some(y)) => lv.texel_offset(x, y),
            _ => NO_TEXEL,
        }
    }

    #[inline(always)]
    fn fetch(&self, lv: &LevelLayout, x: i32, y: i32) -> [f32; 4] {
        let off = self.address(lv, x, y);
        if off == NO_TEXEL {
            return [0.0; 4];
        }
        let n = lv.texel_bytes as usize;
        self.touch.touch(off, n);
        D::texel(&self.tex.texels[off..off + n], self.tex.record.channels)
    }

    /// Byte offset of the texel containing `uv` on `lv` (`NO_TEXEL` on a black border).
    #[inline(always)]
    fn nearest_address(&self, lv: &LevelLayout, uv: [f32; 2]) -> usize {
        // `as i32` saturates huge or NaN coordinates (NaN → 0) instead of failing; wrap keeps them in range.
        let x = floor(uv[0] * lv.width as f32) as i32;
        let y = floor(uv[1] * lv.height as f32) as i32;
        self.address(lv, x, y)
    }

    /// Texel containing `uv` on `level`.
    fn nearest(&self, level: u32, uv: [f32; 2]) -> [f32; 4] {
        let lv = self.layout(level);
        let x = floor(uv[0] * lv.width as f32) as i32;
        let y = floor(uv[1] * lv.height as f32) as i32;
        self.fetch(&lv, x, y)
    }

    /// Bilinear blend of the four texels whose centres surround `uv` on `level`.
    fn bilinear(&self, level: u32, uv: [f32; 2]) -> [f32; 4] {
        let lv = self.layout(level);
        let x = uv[0] * lv.width as f32 - 0.5;
        let y = uv[1] * lv.height as f32 - 0.5;
        let (x0, y0) = (floor(x), floor(y));
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
        let l0 = floor(level);
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
            Filter::Moonray => match self.level_pair(mip_level(self.tex.record, q.duv_dx, q.duv_dy)) {
                None => self.bilinear(0, q.uv),
                Some((l0, _, 0.0)) => self.nearest(l0, q.uv),
                Some((l0, l1, t)) => lerp4(self.nearest(l0, q.uv), self.nearest(l1, q.uv), t),
            },
            Filter::Bilinear => {
                let level = mip_level(self.tex.record, q.duv_dx, q.duv_dy);
                // NaN and -inf round to NaN/-inf; `as u32` saturates both to 0.
                self.bilinear((round(level) as u32).min(self.last_level()), q.uv)
            }
            Filter::Trilinear => self.trilinear(mip_level(self.tex.record, q.duv_dx, q.duv_dy), q.uv),
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
        let (w, h) = (self.tex.record.width as f32, self.tex.record.height as f32);
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
        let l0 = floor(lod);
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
        let lv = self.layout(level);
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
        let (x0, x1) = ((s - u_half).ceil() as i32, floor(s + u_half) as i32);
        let (y0, y1) = ((t - v_half).ceil() as i32, floor(t + v_half) as i32);
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
        let (w, h) = (self.tex.record.width as f32, self.tex.record.height as f32);
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

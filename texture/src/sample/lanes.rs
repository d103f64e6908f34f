//! Eight lookups on one texture at once, for the wavefront integrator's material programs: the
//! lane entry point next to the scalar filters of [`super`].
//!
//! Each lane equals [`super::sample_with`] bit for bit: the same IEEE operations in the same order,
//! every branch of the scalar code turned into a per-lane select. The MoonRay filter (the default) runs
//! as lane loops — footprint and mip level, the level-0 bilinear coordinates and weights, the tap
//! addresses (wrapped integer coordinates), the blend — around one gather that reads and decodes the
//! texels in use (addresses differ per lane, so the reads are scalar). The other filters loop the scalar lookup over the lanes: their
//! tap counts vary per lane (anisotropic, EWA) or they are not the default.
//!
//! Lanes at or past `count` are not read (no texel touched) and come back zero.

// Lane loops index several columns by the same lane number.
#![allow(clippy::needless_range_loop)]

use super::{sample_with, Decode, Lookup, Sampler, Srgb8, TextureView, Unorm8, F16, NO_TEXEL};
use crate::float::floor;
use crate::format::{Filter, TexelFormat, Wrap};
use crate::layout::LevelLayout;
use crate::stats::Touch;

/// Lookups per call.
pub const LANES: usize = 8;

/// One scalar per lane.
pub type Lanes = [f32; LANES];

/// Eight lookups' coordinates and footprints (one column per component), sharing filter and wraps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LookupLanes {
    /// Texture coordinate `(s, t)`.
    pub uv: [Lanes; 2],
    /// Change of `uv` per pixel step in x.
    pub duv_dx: [Lanes; 2],
    /// Change of `uv` per pixel step in y.
    pub duv_dy: [Lanes; 2],
    /// Filter.
    pub filter: Filter,
    /// Wrap along `s`.
    pub wrap_s: Wrap,
    /// Wrap along `t`.
    pub wrap_t: Wrap,
}

impl LookupLanes {
    /// The scalar lookup of lane `k`.
    pub fn lane(&self, k: usize) -> Lookup {
        Lookup {
            uv: [self.uv[0][k], self.uv[1][k]],
            duv_dx: [self.duv_dx[0][k], self.duv_dx[1][k]],
            duv_dy: [self.duv_dy[0][k], self.duv_dy[1][k]],
            filter: self.filter,
            wrap_s: self.wrap_s,
            wrap_t: self.wrap_t,
        }
    }
}

/// Filtered linear RGBA (`[channel][lane]`) of the first `count` lanes of `q`, reporting texel reads
/// to `touch`; lane `k` equals `sample_with(tex, &q.lane(k), touch)` exactly.
pub fn sample_lanes_with<T: Touch>(
    tex: &TextureView,
    q: &LookupLanes,
    count: usize,
    touch: &T,
) -> [Lanes; 4] {
    let count = count.min(LANES);
    if q.filter != Filter::Moonray {
        let mut out = [[0.0; LANES]; 4];
        for k in 0..count {
            let v = sample_with(tex, &q.lane(k), touch);
            for c in 0..4 {
                out[c][k] = v[c];
            }
        }
        return out;
    }
    match tex.format {
        TexelFormat::Srgb8 => Sampler::<Srgb8, T>::new(tex, &q.lane(0), touch).moonray_lanes(q, count),
        TexelFormat::Unorm8 => Sampler::<Unorm8, T>::new(tex, &q.lane(0), touch).moonray_lanes(q, count),
        TexelFormat::F16 => Sampler::<F16, T>::new(tex, &q.lane(0), touch).moonray_lanes(q, count),
    }
}

/// The per-lane levels of [`Sampler::moonray_lanes`]: `mip_level` and `level_pair`, in lanes.
#[derive(Default)]
struct LevelLanes {
    /// Magnifying (level ≤ 0 or NaN): bilinear on level 0.
    magnify: [bool; LANES],
    /// Nearer level.
    l0: [u32; LANES],
    /// Coarser level.
    l1: [u32; LANES],
    /// Weight of the coarser level.
    t: Lanes,
}

/// `mip_level` for eight footprints; the `log2` calls are libm, one lane at a time.
#[inline]
fn levels(width: u32, height: u32, last: u32, q: &LookupLanes) -> LevelLanes {
    let (w, h) = (width as f32, height as f32);
    let mut size = [0.0f32; LANES];
    for k in 0..LANES {
        let (x, y) = (q.duv_dx[0][k] * w, q.duv_dx[1][k] * h);
        let ax = (x * x + y * y).sqrt();
        let (x, y) = (q.duv_dy[0][k] * w, q.duv_dy[1][k] * h);
        let ay = (x * x + y * y).sqrt();
        size[k] = ax.max(ay);
    }
    let level = size.map(f32::log2);
    let mut out = LevelLanes::default();
    for k in 0..LANES {
        let level = level[k];
        out.magnify[k] = level.is_nan() || level <= 0.0;
        let clamped = level.min(last as f32);
        let l0 = floor(clamped);
        out.l0[k] = l0 as u32;
        out.l1[k] = (out.l0[k] + 1).min(last);
        out.t[k] = clamped - l0;
    }
    out
}

impl<D: Decode, T: Touch> Sampler<'_, D, T> {
    /// [`Filter::Moonray`] for the first `count` lanes of `q` (the lookups' own wraps, not the
    /// sampler's first lane's, are the same for all lanes by construction of [`LookupLanes`]).
    ///
    /// Addresses first, texels second: the lane loop finds each tap's byte offset (level layouts built
    /// once per level, not per lane), then [`Decode::gather`] reads and decodes exactly the taps in use,
    /// all at once (one F16C conversion for half-float textures).
    fn moonray_lanes(&self, q: &LookupLanes, count: usize) -> [Lanes; 4] {
        let rec = self.tex.record;
        let lv = levels(rec.width, rec.height, self.last_level(), q);
        // Level-0 bilinear coordinates and weights, used by magnifying lanes only: a group of
        // minifying lanes (most groups past the first bounce) skips them, and its blend then selects
        // the level blend over a bilinear made of zeros.
        let base = self.layout(0);
        let (w0, h0) = (base.width as f32, base.height as f32);
        let (mut x0, mut y0) = ([0.0f32; LANES], [0.0f32; LANES]);
        let (mut fx, mut fy) = ([0.0f32; LANES], [0.0f32; LANES]);
        if lv.magnify[..count].contains(&true) {
            for k in 0..LANES {
                let x = q.uv[0][k] * w0 - 0.5;
                let y = q.uv[1][k] * h0 - 0.5;
                x0[k] = floor(x);
                y0[k] = floor(y);
                fx[k] = x - x0[k];
                fy[k] = y - y0[k];
            }
        }
        // Addresses: four taps per magnifying lane, one or two per minifying lane.
        let mut at = [[NO_TEXEL; LANES]; 4];
        let mut layouts = LayoutCache::default();
        for k in 0..count {
            if lv.magnify[k] {
                let (x0, y0) = (x0[k] as i32, y0[k] as i32);
                let (x1, y1) = (x0.saturating_add(1), y0.saturating_add(1));
                at[0][k] = self.address(&base, x0, y0);
                at[1][k] = self.address(&base, x1, y0);
                at[2][k] = self.address(&base, x0, y1);
                at[3][k] = self.address(&base, x1, y1);
            } else {
                let uv = [q.uv[0][k], q.uv[1][k]];
                at[0][k] = self.nearest_address(&layouts.get(self, lv.l0[k]), uv);
                if lv.t[k] != 0.0 {
                    at[1][k] = self.nearest_address(&layouts.get(self, lv.l1[k]), uv);
                }
            }
        }
        let texel_bytes = self.tex.texel_bytes as usize;
        let taps = D::gather(self.tex.texels, rec.channels, texel_bytes, &at, count, self.touch);
        // Blend: bilinear (magnifying) or the two levels (minifying), selected per lane.
        let mut out = [[0.0f32; LANES]; 4];
        for c in 0..4 {
            let [t00, t10, t01, t11] = [taps[0][c], taps[1][c], taps[2][c], taps[3][c]];
            for k in 0..LANES {
                let bottom = t00[k] + (t10[k] - t00[k]) * fx[k];
                let top = t01[k] + (t11[k] - t01[k]) * fx[k];
                let bilinear = bottom + (top - bottom) * fy[k];
                let t = lv.t[k];
                let levels = if t == 0.0 { t00[k] } else { t00[k] + (t10[k] - t00[k]) * t };
                out[c][k] = if lv.magnify[k] { bilinear } else { levels };
            }
        }
        // Lanes past `count` read nothing; keep them zero whatever the blend made of the zero taps.
        for channel in &mut out {
            channel[count..].fill(0.0);
        }
        out
    }
}

/// The layouts of the two levels most recently addressed: the lanes of a group mostly share one
/// level pair, so each is built once per call rather than once per lane.
#[derive(Default)]
struct LayoutCache {
    entries: [Option<(u32, LevelLayout)>; 2],
}

impl LayoutCache {
    #[inline(always)]
    fn get<D: Decode, T: Touch>(&mut self, sampler: &Sampler<'_, D, T>, level: u32) -> LevelLayout {
        for (cached, layout) in self.entries.iter().flatten() {
            if *cached == level {
                return *layout;
            }
        }
        let layout = sampler.layout(level);
        self.entries[1] = self.entries[0];
        self.entries[0] = Some((level, layout));
        layout
    }
}

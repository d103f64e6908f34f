//! Eight lookups on one texture at once, for the wavefront integrator's material programs: the
//! lane entry point next to the scalar filters of [`super`].
//!
//! Each lane equals [`super::sample_with`] bit for bit: the same IEEE operations in the same order,
//! every branch of the scalar code turned into a per-lane select. The MoonRay filter (the default) runs
//! as lane loops — footprint and mip level, the level-0 bilinear coordinates and weights, the tap
//! addresses (wrapped integer coordinates), the blend — around one gather that reads and decodes the
//! texels in use. The other filters loop the scalar lookup over the lanes: their tap counts vary per
//! lane (anisotropic, EWA) or they are not the default.
//!
//! Lanes at or past `count` are not read (no texel touched) and come back zero.
//!
//! # Two code paths, chosen at run time
//! [`LanePath::detect`] picks, per call, from [`lanekit::cpu::has_avx2`] (std's cached flag):
//! - **AVX2**: the lane filter compiled for AVX2; for power-of-two textures in a texel array under
//!   2 GiB (the bench scenes' and most assets') the tap addresses are AVX2 intrinsics and 8-bit texels
//!   are read by hardware gathers (`super::lanes_avx2`); other textures run the portable lane loops
//!   in this AVX2 build.
//! - **Portable**: the same lane filter for the baseline target (SSE2): taps addressed lane by lane
//!   through the scalar lookup's addressing, texels read lane by lane.
//!
//! `tests::lanes` compares both paths with the scalar lookup on every filter, wrap, format, channel
//! count, power-of-two and other size and tile size; `scripts/test-fallback.sh` runs the crate's
//! tests under `qemu-x86_64 -cpu Nehalem`/`SandyBridge`, where the dispatch test asserts the portable
//! path was picked.
//!
//! The mip level's `log2` is ours ([`super::log2`], used by the scalar `mip_level` too), so the AVX2
//! `levels` computes it in registers; on the AVX2 path the gather, the decode and the blend are one
//! function (`lanes_avx2::gather_blend_u8`). The sort key's mip level cannot stand in for `levels`
//! (it is the rounded level, not the fraction the blend needs); measurements: `docs/perf.md#texture-lane-lookups-texturesrcsamplelanesrs`.

// Lane loops index several columns by the same lane number.
#![allow(clippy::needless_range_loop)]

#[cfg(target_arch = "x86_64")]
use super::lanes_avx2;
use super::level_lanes::LevelLanes;
use super::log2::log2;
use super::{sample_with, Decode, Lookup, Sampler, Srgb8, TextureView, Unorm8, F16, NO_TEXEL};
use crate::float::floor;
use crate::format::{Filter, TexelFormat, Wrap};
use crate::layout::LevelLayout;
use crate::stats::Touch;

/// Lookups per call and one scalar per lane: the workspace's one lane width and column.
pub use lanekit::{Lanes, LANES};

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

/// Which code the lane filter runs: chosen at run time from the CPU, so one binary serves every x86-64.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LanePath {
    /// Lane loops as the baseline target compiles them (SSE2), texels read one lane at a time.
    Portable,
    /// The same lane loops compiled for AVX2; for power-of-two textures the addresses and the 8-bit
    /// texel reads in intrinsics (hardware gathers).
    Avx2,
}

impl LanePath {
    /// The best path this CPU supports.
    #[inline(always)]
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if lanekit::cpu::has_avx2() {
            return LanePath::Avx2;
        }
        LanePath::Portable
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
    sample_lanes_on(tex, q, count, touch, LanePath::detect())
}

/// [`sample_lanes_with`] on the code `path` names (tests run both; a CPU without AVX2 runs the
/// portable path whatever `path` says).
pub(crate) fn sample_lanes_on<T: Touch>(
    tex: &TextureView,
    q: &LookupLanes,
    count: usize,
    touch: &T,
    path: LanePath,
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
        TexelFormat::Srgb8 => Sampler::<Srgb8, T>::new(tex, &q.lane(0), touch).moonray_lanes(q, count, path),
        TexelFormat::Unorm8 => {
            Sampler::<Unorm8, T>::new(tex, &q.lane(0), touch).moonray_lanes(q, count, path)
        }
        TexelFormat::F16 => Sampler::<F16, T>::new(tex, &q.lane(0), touch).moonray_lanes(q, count, path),
    }
}

/// `mip_level` and `level_pair` for eight footprints. `AVX2`: all of it in intrinsics, the `log2`
/// included ([`lanes_avx2::levels`]); otherwise lane loops around the scalar [`log2`].
#[inline(always)]
fn levels<const AVX2: bool>(width: u32, height: u32, last: u32, q: &LookupLanes) -> LevelLanes {
    let (w, h) = (width as f32, height as f32);
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: `AVX2` is true only in `moonray_lanes_avx2`, which runs on CPUs with AVX2.
        return unsafe { lanes_avx2::levels(w, h, last, &q.duv_dx, &q.duv_dy) };
    }
    let level = footprint_sizes(w, h, q).map(log2);
    let mut out = LevelLanes::default();
    for k in 0..LANES {
        let level = level[k];
        out.magnify[k] = -((level.is_nan() || level <= 0.0) as i32);
        let clamped = level.min(last as f32);
        let l0 = floor(clamped);
        out.l0[k] = l0 as u32 as i32;
        out.l1[k] = (l0 as u32 + 1).min(last) as i32;
        out.t[k] = clamped - l0;
    }
    out
}

/// The longer footprint axis per lane in level-0 texels, as `mip_level` measures it.
#[inline(always)]
fn footprint_sizes(w: f32, h: f32, q: &LookupLanes) -> Lanes {
    let mut size = [0.0f32; LANES];
    for k in 0..LANES {
        let (x, y) = (q.duv_dx[0][k] * w, q.duv_dx[1][k] * h);
        let ax = (x * x + y * y).sqrt();
        let (x, y) = (q.duv_dy[0][k] * w, q.duv_dy[1][k] * h);
        let ay = (x * x + y * y).sqrt();
        size[k] = ax.max(ay);
    }
    size
}

impl<D: Decode, T: Touch> Sampler<'_, D, T> {
    /// [`Filter::Moonray`] for the first `count` lanes of `q` (the lookups' own wraps, not the
    /// sampler's first lane's, are the same for all lanes by construction of [`LookupLanes`]), on
    /// the code `path` names (the portable path when the CPU lacks what `path` needs).
    fn moonray_lanes(&self, q: &LookupLanes, count: usize, path: LanePath) -> [Lanes; 4] {
        #[cfg(target_arch = "x86_64")]
        if path == LanePath::Avx2 && LanePath::detect() == LanePath::Avx2 {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { self.moonray_lanes_avx2(q, count) };
        }
        let _ = path;
        self.moonray_lanes_in::<false>(q, count)
    }

    /// [`Self::moonray_lanes_in`] compiled for AVX2: the lane loops become 8-wide vector code and the
    /// 8-bit texel reads become hardware gathers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn moonray_lanes_avx2(&self, q: &LookupLanes, count: usize) -> [Lanes; 4] {
        self.moonray_lanes_in::<true>(q, count)
    }

    /// The MoonRay filter in lanes. Levels first (our `log2`, as the scalar lookup), then
    /// every tap's address for all lanes at once — tap 0 the level-0 bilinear corner (magnifying) or
    /// the nearer level's texel, tap 1 its right neighbour or the coarser level's texel (only where
    /// that level's weight is not 0), taps 2 and 3 the upper bilinear row (magnifying only) — then
    /// one gather that reads and decodes the taps in use, then the blend. Under `AVX2` the addresses
    /// and the 8-bit texel reads are intrinsics ([`lanes_avx2`]) where they apply; elsewhere
    /// the per-lane addressing of [`Self::addresses`] and [`Decode::gather`] (per lane; half floats in
    /// one F16C conversion).
    #[inline(always)]
    fn moonray_lanes_in<const AVX2: bool>(&self, q: &LookupLanes, count: usize) -> [Lanes; 4] {
        let rec = self.tex.record;
        let lv = levels::<AVX2>(rec.width, rec.height, self.last_level(), q);
        let (mut fx, mut fy) = ([0.0f32; LANES], [0.0f32; LANES]);
        #[cfg(target_arch = "x86_64")]
        if AVX2 && self.avx2_addressing() {
            let (s, t) = (self.wrap_s, self.wrap_t);
            let texel_bytes = self.tex.texel_bytes;
            // SAFETY (both calls): `AVX2` is true only in `moonray_lanes_avx2`, which runs on CPUs with
            // AVX2; `avx2_addressing` checked the sizes `addresses` requires.
            let taps = unsafe {
                lanes_avx2::addresses(rec, texel_bytes, s, t, &q.uv, &lv, count, (&mut fx, &mut fy))
            };
            if let Some(srgb) = D::U8_SRGB {
                let mut out = [[0.0f32; LANES]; 4];
                let weights = (&fx, &fy);
                let (texels, channels) = (self.tex.texels, rec.channels);
                if unsafe {
                    lanes_avx2::gather_blend_u8(texels, channels, srgb, &taps, &lv, weights, count, &mut out)
                } {
                    self.touch_all(&taps);
                    return out;
                }
            }
            let at: [[usize; LANES]; 4] = std::array::from_fn(|tap| {
                let (offset, present) = (&taps.offset[tap], &taps.present[tap]);
                std::array::from_fn(|k| if present[k] != 0 { offset[k] as usize } else { NO_TEXEL })
            });
            let decoded =
                D::gather(self.tex.texels, rec.channels, texel_bytes as usize, &at, count, self.touch);
            return blend(&lv, &decoded, &fx, &fy, count);
        }
        let at = self.addresses(&lv, q, count, (&mut fx, &mut fy));
        let texel_bytes = self.tex.texel_bytes as usize;
        let decoded = D::gather(self.tex.texels, rec.channels, texel_bytes, &at, count, self.touch);
        blend(&lv, &decoded, &fx, &fy, count)
    }

    /// Whether [`lanes_avx2::addresses`] applies: power-of-two level-0 sizes (so every level's wraps
    /// are masks) and a texel array under 2 GiB (32-bit offsets).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn avx2_addressing(&self) -> bool {
        let rec = self.tex.record;
        rec.width.is_power_of_two()
            && rec.height.is_power_of_two()
            && self.tex.texels.len() <= i32::MAX as usize
    }

    /// Reports every tap the lanes read to the touch sink (nothing to do for [`crate::NoTouch`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn touch_all(&self, taps: &lanes_avx2::TapOffsets) {
        for (offset, present) in taps.offset.iter().zip(&taps.present) {
            for k in 0..LANES {
                if present[k] != 0 {
                    self.touch.touch(offset[k] as usize, self.tex.texel_bytes as usize);
                }
            }
        }
    }

    /// The taps' byte offsets (`NO_TEXEL` where a lane does not read the tap, or reads a black border)
    /// and the level-0 bilinear weights, lane by lane: four taps per magnifying lane, one or two per
    /// minifying lane, each through the scalar lookup's addressing. Lane loops that computed every
    /// tap in every lane without branches (wrap mode matched once per call, each lane's level
    /// geometry, remainders as masks) took 8 % more instructions here on the baseline target and
    /// 12 % fewer compiled for AVX2 (LLVM vectorized little of them); the AVX2 path has intrinsics
    /// for the common case instead, so they were dropped.
    #[inline(always)]
    fn addresses(
        &self,
        lv: &LevelLanes,
        q: &LookupLanes,
        count: usize,
        (fx, fy): (&mut Lanes, &mut Lanes),
    ) -> [[usize; LANES]; 4] {
        // Level-0 bilinear coordinates and weights, used by magnifying lanes only: a group of
        // minifying lanes (most groups past the first bounce) skips them, and its blend then selects
        // the level blend over a bilinear made of zeros.
        let base = self.layout(0);
        let (w0, h0) = (base.width as f32, base.height as f32);
        let (mut x0, mut y0) = ([0.0f32; LANES], [0.0f32; LANES]);
        if lv.magnify[..count].iter().any(|&m| m != 0) {
            for k in 0..LANES {
                let x = q.uv[0][k] * w0 - 0.5;
                let y = q.uv[1][k] * h0 - 0.5;
                x0[k] = floor(x);
                y0[k] = floor(y);
                fx[k] = x - x0[k];
                fy[k] = y - y0[k];
            }
        }
        let mut at = [[NO_TEXEL; LANES]; 4];
        let mut layouts = LayoutCache::default();
        for k in 0..count {
            if lv.magnify[k] != 0 {
                let (x0, y0) = (x0[k] as i32, y0[k] as i32);
                let (x1, y1) = (x0.saturating_add(1), y0.saturating_add(1));
                at[0][k] = self.address(&base, x0, y0);
                at[1][k] = self.address(&base, x1, y0);
                at[2][k] = self.address(&base, x0, y1);
                at[3][k] = self.address(&base, x1, y1);
            } else {
                let uv = [q.uv[0][k], q.uv[1][k]];
                at[0][k] = self.nearest_address(&layouts.get(self, lv.l0[k] as u32), uv);
                if lv.t[k] != 0.0 {
                    at[1][k] = self.nearest_address(&layouts.get(self, lv.l1[k] as u32), uv);
                }
            }
        }
        at
    }
}

/// The MoonRay blend of the decoded taps `[tap][channel][lane]`: bilinear (magnifying) or the two
/// levels (minifying), selected per lane; lanes at or past `count` are zero.
#[inline(always)]
fn blend(lv: &LevelLanes, taps: &[[Lanes; 4]; 4], fx: &Lanes, fy: &Lanes, count: usize) -> [Lanes; 4] {
    let mut out = [[0.0f32; LANES]; 4];
    for c in 0..4 {
        let [t00, t10, t01, t11] = [taps[0][c], taps[1][c], taps[2][c], taps[3][c]];
        for k in 0..LANES {
            let bottom = t00[k] + (t10[k] - t00[k]) * fx[k];
            let top = t01[k] + (t11[k] - t01[k]) * fx[k];
            let bilinear = bottom + (top - bottom) * fy[k];
            let t = lv.t[k];
            let levels = if t == 0.0 { t00[k] } else { t00[k] + (t10[k] - t00[k]) * t };
            let value = if lv.magnify[k] != 0 { bilinear } else { levels };
            // Lanes past `count` read nothing; keep them zero whatever the blend made of the zero taps.
            out[c][k] = if k < count { value } else { 0.0 };
        }
    }
    out
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

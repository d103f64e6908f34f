//! The lane entry point equals the scalar lookup bit for bit, lane by lane, for every filter, wrap and
//! texel format, on random coordinates and footprints (magnifying, minifying, beyond the coarsest
//! level, zero, NaN and infinite), and reads the same texels — on both code paths of the lane filter
//! (portable and AVX2; the AVX2 one where the CPU has it), on power-of-two and other sizes.

use super::set_of;
use crate::sample::{sample_lanes_on, LanePath};
use crate::{sample_with, ColorSpace, Filter, LookupLanes, Samples, SourceImage, Touch, Wrap};
use std::cell::RefCell;

/// Every texel read, in order.
#[derive(Default)]
struct Reads(RefCell<Vec<(usize, usize)>>);

impl Touch for Reads {
    fn touch(&self, byte_offset: usize, len: usize) {
        self.0.borrow_mut().push((byte_offset, len));
    }
}

/// SplitMix64: a tiny deterministic generator (the crate has no random-number dependency).
pub(super) struct Rng(pub(super) u64);

impl Rng {
    pub(super) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    pub(super) fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Mostly ordinary values in `[-lo, hi)`, now and then a special one.
    pub(super) fn coordinate(&mut self, lo: f32, hi: f32) -> f32 {
        match self.next() % 40 {
            0 => f32::NAN,
            1 => f32::INFINITY,
            2 => -1e30,
            3 => 0.0,
            _ => -lo + (lo + hi) * self.unit(),
        }
    }
    /// A footprint component spanning magnification to beyond the whole texture.
    pub(super) fn derivative(&mut self) -> f32 {
        match self.next() % 30 {
            0 => 0.0,
            1 => f32::NAN,
            2 => f32::INFINITY,
            _ => (self.unit() - 0.5) * 10f32.powf(-4.0 + 5.0 * self.unit()),
        }
    }
}

pub(super) fn images(rng: &mut Rng) -> Vec<(SourceImage, ColorSpace)> {
    let mut out = Vec::new();
    for (w, h) in [(37, 21), (64, 64), (1, 5), (130, 9), (32, 8)] {
        for channels in 1..=4u32 {
            let n = (w * h * channels) as usize;
            let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            out.push((
                SourceImage { width: w, height: h, channels, samples: Samples::U8(bytes.clone()) },
                ColorSpace::Auto,
            ));
            out.push((
                SourceImage { width: w, height: h, channels, samples: Samples::U8(bytes) },
                ColorSpace::Raw,
            ));
            let floats = (0..n).map(|_| rng.unit() * 4.0 - 1.0).collect();
            out.push((
                SourceImage { width: w, height: h, channels, samples: Samples::F32(floats) },
                ColorSpace::Raw,
            ));
        }
    }
    out
}

/// The bits of `v`, every NaN alike: Rust does not specify which NaN an operation on NaNs returns
/// (LLVM may swap the operands of a commutative one), so only NaN-ness is comparable.
pub(super) fn bits(v: f32) -> u32 {
    if v.is_nan() {
        f32::NAN.to_bits()
    } else {
        v.to_bits()
    }
}

/// The paths this CPU can run: the portable one always, AVX2 where the CPU has it.
fn paths() -> Vec<LanePath> {
    let mut paths = vec![LanePath::Portable];
    if LanePath::detect() == LanePath::Avx2 {
        paths.push(LanePath::Avx2);
    }
    paths
}

#[test]
fn lanes_equal_scalar_lookups() {
    for path in paths() {
        // The default 64-texel tiles (most levels one tile), and 4-texel tiles (many tiles per level).
        for tile_log2 in [None, Some(2)] {
            lanes_equal_scalar_lookups_on(path, tile_log2);
        }
    }
}

fn lanes_equal_scalar_lookups_on(path: LanePath, tile_log2: Option<u32>) {
    let mut rng = Rng(7);
    let images = images(&mut rng);
    let set = match tile_log2 {
        None => set_of(&images),
        Some(tile_log2) => {
            let mut b = crate::TextureSetBuilder::new();
            for (img, color_space) in &images {
                let options = crate::BakeOptions { color_space: *color_space, tile_log2 };
                b.add_baked(crate::bake(img, &options).unwrap());
            }
            b.finish()
        }
    };
    let view = set.view().unwrap();
    let wraps = [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp, Wrap::Black];
    let mut lanes_compared = 0;
    for index in 0..view.texture_count() as u32 {
        let tex = view.texture(index).unwrap();
        for filter in Filter::ALL {
            for round in 0..12 {
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
                let count = if round == 5 { 3 } else { 8 };
                let (lane_touch, scalar_touch) = (Reads::default(), Reads::default());
                let got = sample_lanes_on(&tex, &q, count, &lane_touch, path);
                for k in 0..8 {
                    let got: [f32; 4] = std::array::from_fn(|c| got[c][k]);
                    if k >= count {
                        assert_eq!(got, [0.0; 4], "idle lane {k}");
                        continue;
                    }
                    let want = sample_with(&tex, &q.lane(k), &scalar_touch);
                    assert_eq!(
                        got.map(bits),
                        want.map(bits),
                        "{path:?}: texture {index}, {filter:?}, lane {k}: {:?}",
                        q.lane(k)
                    );
                    lanes_compared += 1;
                }
                // Lanes read lane by lane, in the scalar lookups' order within each lane.
                let (mut a, mut b) = (lane_touch.0.into_inner(), scalar_touch.0.into_inner());
                a.sort_unstable();
                b.sort_unstable();
                assert_eq!(a, b, "{path:?}: texture {index}, {filter:?}: texels read");
            }
        }
    }
    assert!(lanes_compared > 5000, "{lanes_compared}");
}

/// The coarsest level of an 8-bit texture is the last texel of the texel array: the AVX2 path's
/// 32-bit word reads would run past it for textures of fewer than four channels, so it hands such
/// lookups to the portable gather, with the same results.
#[test]
fn lookups_at_the_end_of_the_texel_array_equal_scalar_lookups() {
    let mut rng = Rng(5);
    for channels in 1..=4u32 {
        let bytes: Vec<u8> = (0..16 * 8 * channels).map(|_| rng.next() as u8).collect();
        let image = SourceImage { width: 16, height: 8, channels, samples: Samples::U8(bytes) };
        let set = set_of(&[(image, ColorSpace::Auto)]);
        let view = set.view().unwrap();
        let tex = view.texture(0).unwrap();
        for path in paths() {
            for round in 0..16 {
                let mut q = LookupLanes { filter: Filter::Moonray, ..Default::default() };
                for k in 0..8 {
                    q.uv[0][k] = rng.unit();
                    q.uv[1][k] = rng.unit();
                    // Footprints of 4 to 64 texels: the coarsest levels, the 1×1 one among them.
                    q.duv_dx[0][k] = (2.0 + 2.0 * rng.unit()).exp2() / 16.0 * (round % 4) as f32;
                }
                let got = sample_lanes_on(&tex, &q, 8, &crate::NoTouch, path);
                for k in 0..8 {
                    let want = sample_with(&tex, &q.lane(k), &crate::NoTouch);
                    let got: [f32; 4] = std::array::from_fn(|c| got[c][k]);
                    assert_eq!(got.map(bits), want.map(bits), "{path:?}, {channels} channels, lane {k}");
                }
            }
        }
    }
}

/// `scripts/test-fallback.sh` runs these tests under qemu on CPU models without AVX2 and sets
/// `RENDER_EMULATED_CPU`: there the lane filter must pick the portable path (and the tests above
/// then ran it alone); natively it picks AVX2 exactly when the CPU has it.
#[cfg(target_arch = "x86_64")]
#[test]
fn dispatch_picks_the_path_the_cpu_supports() {
    let avx2 = is_x86_feature_detected!("avx2");
    let path = LanePath::detect();
    eprintln!("texture lane filter: avx2 {avx2}, path {path:?}");
    assert_eq!(path == LanePath::Avx2, avx2);
    match std::env::var("RENDER_EMULATED_CPU").as_deref() {
        Err(_) => {}
        Ok("no-avx" | "avx-no-avx2") => assert_eq!(path, LanePath::Portable),
        Ok(other) => panic!("RENDER_EMULATED_CPU={other:?}: expected \"no-avx\" or \"avx-no-avx2\""),
    }
}

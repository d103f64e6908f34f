//! Baked mip chains: the 1×1 level of a checker holds its linear mean, for POT and NPOT sizes.

use super::set_of;
use crate::layout::LevelLayout;
use crate::{sample, ColorSpace, Filter, Samples, SourceImage, TexelFormat, Wrap};

fn checker(w: u32, h: u32, lo: u16, hi: u16, sixteen: bool) -> SourceImage {
    let v: Vec<u16> =
        (0..h).flat_map(|y| (0..w).map(move |x| if (x + y) % 2 == 0 { lo } else { hi })).collect();
    let samples = if sixteen { Samples::U16(v) } else { Samples::U8(v.iter().map(|&s| s as u8).collect()) };
    SourceImage { width: w, height: h, channels: 1, samples }
}

/// The top level through a lookup: a huge footprint clamps to the last level.
fn top_value(img: SourceImage, cs: ColorSpace) -> (f32, u32, TexelFormat) {
    let set = set_of(&[(img, cs)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    let rec = tex.record();
    let last = LevelLayout::of(rec, rec.mip_count - 1);
    assert_eq!((last.width, last.height), (1, 1));
    let big = [1e3, 0.0];
    let v = sample(&tex, [0.3, 0.3], big, big, Filter::Moonray, Wrap::Repeat, Wrap::Repeat)[0];
    (v, rec.mip_count, tex.format())
}

#[test]
fn checker_mean_at_1x1() {
    // (size, number of "hi" texels / total): (x + y) odd is "hi".
    for (w, h, levels) in [(256, 256, 9), (100, 60, 7), (37, 1, 6)] {
        let hi_fraction = {
            let hi = (0..h).flat_map(|y| (0..w).map(move |x| (x + y) % 2)).sum::<u32>();
            hi as f32 / (w * h) as f32
        };
        // 8-bit sRGB black/white: linear 0/1, filtered in linear, re-encoded each level. The mean is the
        // linear fraction (0.5, not the 0.21 that averaging sRGB codes would give), within one 8-bit
        // sRGB step near 0.5 (≈ 0.003).
        let (v, n, fmt) = top_value(checker(w, h, 0, 255, false), ColorSpace::Auto);
        assert_eq!((n, fmt), (levels, TexelFormat::Srgb8));
        assert!((v - hi_fraction).abs() < 0.004, "{w}x{h} sRGB8: {v} vs {hi_fraction}");

        // 16-bit raw: f16 storage, error within half precision.
        let (v, _, fmt) = top_value(checker(w, h, 0, 65535, true), ColorSpace::Auto);
        assert_eq!(fmt, TexelFormat::F16);
        assert!((v - hi_fraction).abs() < 5e-4, "{w}x{h} f16: {v} vs {hi_fraction}");
    }
}

/// 8-bit `raw` stays 8-bit and averages the stored values directly.
#[test]
fn raw_8bit_averages_codes() {
    let (v, _, fmt) = top_value(checker(256, 256, 0, 255, false), ColorSpace::Raw);
    assert_eq!(fmt, TexelFormat::Unorm8);
    assert!((v - 128.0 / 255.0).abs() < 1e-6, "{v}");
}

/// Every level of the 100×60 chain keeps the mean, not only the last.
#[test]
fn every_npot_level_keeps_the_mean() {
    let set = set_of(&[(checker(100, 60, 0, 65535, true), ColorSpace::Raw)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    let rec = tex.record();
    for level in 0..rec.mip_count {
        let lv = LevelLayout::of(rec, level);
        let mut sum = 0.0f64;
        for y in 0..lv.height {
            for x in 0..lv.width {
                let o = lv.texel_offset(x, y);
                sum += half::f16::from_le_bytes([set.texels[o], set.texels[o + 1]]).to_f64();
            }
        }
        let mean = sum / (lv.width * lv.height) as f64;
        assert!((mean - 0.5).abs() < 5e-4, "level {level} ({}x{}): mean {mean}", lv.width, lv.height);
    }
}

//! Wrap modes, level selection, magnification, orientation and the filters' agreement on flat regions.

use super::{assert_close, float_image, set_of};
use crate::{
    mip_level, sample, sample_with, BytesRead, ColorSpace, Filter, Lookup, Samples, SourceImage, Wrap,
};

/// Texels 0..6 of a 6×1 ramp. `u = -0.25` is the centre of texel -2, `u = 1.25` the centre of texel 7.
#[test]
fn wrap_modes_at_minus_quarter_and_one_and_a_quarter() {
    let set = set_of(&[(float_image(6, 1, 1, (0..6).map(|i| i as f32).collect()), ColorSpace::Raw)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    let cases = [
        (Wrap::Repeat, 4.0, 1.0),
        (Wrap::Mirror, 1.0, 4.0),
        (Wrap::Clamp, 0.0, 5.0),
        (Wrap::Black, 0.0, 0.0),
    ];
    for filter in Filter::ALL {
        for (wrap, left, right) in cases {
            let alpha = if wrap == Wrap::Black { 0.0 } else { 1.0 };
            let z = [0.0; 2];
            let got = sample(&tex, [-0.25, 0.5], z, z, filter, wrap, Wrap::Clamp);
            assert_close(got, [left, left, left, alpha], 0.0);
            let got = sample(&tex, [1.25, 0.5], z, z, filter, wrap, Wrap::Clamp);
            assert_close(got, [right, right, right, alpha], 0.0);
        }
    }
}

/// A 256² checker of single texels: level 0 alternates 0/1, every coarser level is 0.5.
fn checker_set() -> crate::TextureSet {
    let data = (0..256 * 256).map(|i| ((i % 256 + i / 256) % 2) as f32).collect();
    set_of(&[(float_image(256, 256, 1, data), ColorSpace::Raw)])
}

#[test]
fn level_from_footprint() {
    let set = checker_set();
    let rec = &set.records[0];
    let t = 1.0 / 256.0;
    assert_eq!(mip_level(rec, [t, 0.0], [0.0, t]), 0.0);
    assert_eq!(mip_level(rec, [4.0 * t, 0.0], [0.0, t]), 2.0);
    assert_eq!(mip_level(rec, [0.0, t], [0.0, 4.0 * t]), 2.0, "the larger axis wins");
    assert_eq!(mip_level(rec, [0.5 * t, 0.0], [0.0, 0.5 * t]), -1.0);
    assert_eq!(mip_level(rec, [3.0 * t, 4.0 * t], [0.0, 0.0]), 5f32.log2(), "length, not max component");

    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    // Texel (3, 5) centre; rows are stored bottom-up, so it is file row 250: (3 + 250) % 2 = 1.
    let uv = [3.5 * t, 5.5 * t];
    let one = sample(&tex, uv, [t, 0.0], [0.0, t], Filter::Moonray, Wrap::Repeat, Wrap::Repeat);
    assert_close(one, [1.0, 1.0, 1.0, 1.0], 1e-6);
    let four = sample(&tex, uv, [4.0 * t, 0.0], [0.0, 4.0 * t], Filter::Moonray, Wrap::Repeat, Wrap::Repeat);
    assert_close(four, [0.5, 0.5, 0.5, 1.0], 1e-3);
    // Level 0.5: halfway between level 0 (1) and level 1 (0.5).
    let s2 = 2f32.sqrt() * t;
    let half = sample(&tex, uv, [s2, 0.0], [0.0, s2], Filter::Moonray, Wrap::Repeat, Wrap::Repeat);
    assert_close(half, [0.75, 0.75, 0.75, 1.0], 1e-3);
}

/// Magnification (footprint 0.5 texel → level -1) is bilinear: halfway between two texel centres is
/// their average, a quarter of the way is the 3:1 blend.
#[test]
fn magnification_is_bilinear() {
    let set = set_of(&[(float_image(4, 1, 1, vec![0.0, 1.0, 0.25, 0.75]), ColorSpace::Raw)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    let d = [0.5 / 4.0, 0.0];
    for filter in Filter::ALL {
        let mid = sample(&tex, [0.25, 0.5], d, [0.0, 0.0], filter, Wrap::Clamp, Wrap::Clamp);
        assert_close(mid, [0.5, 0.5, 0.5, 1.0], 1e-6);
        let quarter = sample(&tex, [0.6875, 0.5], d, [0.0, 0.0], filter, Wrap::Clamp, Wrap::Clamp);
        assert_close(quarter, [0.375, 0.375, 0.375, 1.0], 1e-6);
    }
}

/// USD's `t = 0` is the bottom of the image, which is the last row of the file.
#[test]
fn t_runs_bottom_up() {
    // File rows top-down: white over black.
    let img = SourceImage { width: 1, height: 2, channels: 1, samples: Samples::U8(vec![255, 0]) };
    let set = set_of(&[(img, ColorSpace::Auto)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    let z = [0.0; 2];
    assert_eq!(sample(&tex, [0.5, 0.25], z, z, Filter::Moonray, Wrap::Clamp, Wrap::Clamp)[0], 0.0);
    assert_eq!(sample(&tex, [0.5, 0.75], z, z, Filter::Moonray, Wrap::Clamp, Wrap::Clamp)[0], 1.0);
}

/// On a constant texture every filter returns the constant at any footprint, and the anisotropic filter
/// takes more taps (reads more bytes) than trilinear for an elongated footprint.
#[test]
fn filters_agree_on_flat_texture() {
    let img = float_image(64, 32, 3, [0.25f32, 0.5, 2.0].repeat(64 * 32));
    let set = set_of(&[(img, ColorSpace::Raw)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    for filter in Filter::ALL {
        for d in [0.0, 0.001, 0.01, 0.1, 1.0, 10.0] {
            let q = Lookup {
                uv: [0.3, 0.7],
                duv_dx: [d, 0.0],
                duv_dy: [0.0, d / 5.0],
                filter,
                ..Default::default()
            };
            assert_close(sample_with(&tex, &q, &crate::NoTouch), [0.25, 0.5, 2.0, 1.0], 1e-6);
        }
    }
    let bytes = |filter| {
        let read = BytesRead::default();
        let q =
            Lookup { uv: [0.3, 0.7], duv_dx: [0.1, 0.0], duv_dy: [0.0, 0.02], filter, ..Default::default() };
        sample_with(&tex, &q, &read);
        read.0.get()
    };
    assert_eq!(bytes(Filter::Moonray), 2 * 6, "two nearest texels, 3 × f16 each");
    assert_eq!(bytes(Filter::Trilinear), 8 * 6);
    assert!(bytes(Filter::Anisotropic) >= 4 * bytes(Filter::Trilinear));
}

/// The anisotropic filter averages along the major axis: a footprint spanning 8 columns of a
/// column-stripe texture, 1 row tall, sees the stripes' mean where trilinear at the same minor width
/// would alias.
#[test]
fn anisotropic_integrates_along_major_axis() {
    let data = (0..64 * 64).map(|i| (i % 64 % 2) as f32).collect();
    let set = set_of(&[(float_image(64, 64, 1, data), ColorSpace::Raw)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    let t = 1.0 / 64.0;
    let q = Lookup {
        uv: [10.0 * t, 10.5 * t],
        duv_dx: [8.0 * t, 0.0],
        duv_dy: [0.0, t],
        filter: Filter::Anisotropic,
        ..Default::default()
    };
    assert_close(sample_with(&tex, &q, &crate::NoTouch), [0.5, 0.5, 0.5, 1.0], 1e-3);
}

/// A 64² pseudo-random grey texture (raw, so texels are stored as they are, up to f16 rounding).
fn noise_set() -> crate::TextureSet {
    let data =
        (0..64u32 * 64).map(|i| (i.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32).collect();
    set_of(&[(float_image(64, 64, 1, data), ColorSpace::Raw)])
}

/// EWA with an isotropic footprint of `r` level-0 texels, `r` times [`crate::EWA_FOOTPRINT_SCALE`] a
/// power of two so the level is exactly `log2(r · scale)` with no blend: at that level the ellipse is a
/// circle of radius `√(1 + 1)` texels (one texel of footprint, widened by the one-texel
/// reconstruction term), and the result is the
/// Gaussian-weighted average `Σ exp(−α d²/R²) texel / Σ exp(−α d²/R²)` over the texel centres with
/// `d < R` — computed here from the level's texels read one by one with the nearest filter.
#[test]
fn ewa_isotropic_footprint_is_a_gaussian_weighted_box() {
    let set = noise_set();
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    for (scaled, uv) in [(2.0f32, [0.31f32, 0.47f32]), (4.0, [0.5, 0.5]), (8.0, [0.02, 0.93])] {
        let r = scaled / crate::EWA_FOOTPRINT_SCALE;
        let level = scaled.log2() as u32;
        let n = 64 >> level;
        let texel = |x: i32, y: i32| {
            let (x, y) = (x.rem_euclid(n), y.rem_euclid(n));
            let centre = [(x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32];
            // A footprint of exactly 2^level texels selects `level` with no blend.
            let d = [scaled / 64.0, 0.0];
            sample(&tex, centre, d, [0.0, scaled / 64.0], Filter::Moonray, Wrap::Repeat, Wrap::Repeat)[0]
        };
        let (s, t) = (uv[0] * n as f32 - 0.5, uv[1] * n as f32 - 0.5);
        let radius2 = 1.0f32 + 1.0;
        let (mut sum, mut weights) = (0.0f64, 0.0f64);
        for y in (t - 3.0).floor() as i32..=(t + 3.0).ceil() as i32 {
            for x in (s - 3.0).floor() as i32..=(s + 3.0).ceil() as i32 {
                let d2 = (x as f32 - s).powi(2) + (y as f32 - t).powi(2);
                if d2 < radius2 {
                    let w = (-crate::EWA_ALPHA * d2 / radius2).exp() as f64;
                    sum += w * texel(x, y) as f64;
                    weights += w;
                }
            }
        }
        let expected = (sum / weights) as f32;
        let got = sample(&tex, uv, [r / 64.0, 0.0], [0.0, r / 64.0], Filter::Ewa, Wrap::Repeat, Wrap::Repeat);
        eprintln!("EWA r = {r} texels at {uv:?}: {} (Gaussian box {expected})", got[0]);
        assert_close(got, [expected, expected, expected, 1.0], 1e-5);
        // The footprint is rotation invariant: the same circle from rotated axes.
        let (sin, cos) = 0.7f32.sin_cos();
        let rot = |v: [f32; 2]| [cos * v[0] - sin * v[1], sin * v[0] + cos * v[1]];
        let rotated = sample(
            &tex,
            uv,
            rot([r / 64.0, 0.0]),
            rot([0.0, r / 64.0]),
            Filter::Ewa,
            Wrap::Repeat,
            Wrap::Repeat,
        );
        assert_close(rotated, got, 1e-4);
    }
}

/// EWA integrates along the major axis like the multi-tap filter: 8 columns of a 1-texel column-stripe
/// texture under an 8 × 1 footprint average to 0.5; across the stripes' direction (1 × 8) too, and an
/// axis-aligned footprint along the stripes keeps them apart.
#[test]
fn ewa_integrates_an_elongated_footprint() {
    let data = (0..64 * 64).map(|i| (i % 64 % 2) as f32).collect();
    let set = set_of(&[(float_image(64, 64, 1, data), ColorSpace::Raw)]);
    let view = set.view().unwrap();
    let tex = view.texture(0).unwrap();
    let t = 1.0 / 64.0;
    let across = Lookup {
        uv: [10.0 * t, 10.5 * t],
        duv_dx: [8.0 * t, 0.0],
        duv_dy: [0.0, t],
        filter: Filter::Ewa,
        ..Default::default()
    };
    assert_close(sample_with(&tex, &across, &crate::NoTouch), [0.5, 0.5, 0.5, 1.0], 0.02);
    // Along the stripes (8 texels tall, 1 wide, centred on a 1-column): level 0, and the Gaussian
    // weights the centre column most.
    let along =
        Lookup { uv: [11.5 * t, 10.5 * t], duv_dx: [0.0, 8.0 * t], duv_dy: [1.01 * t, 0.0], ..across };
    let v = sample_with(&tex, &along, &crate::NoTouch)[0];
    assert!(v > 0.6, "along the stripes: {v}");
}

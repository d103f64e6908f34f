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
    for filter in [Filter::Moonray, Filter::Bilinear, Filter::Trilinear, Filter::Anisotropic] {
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
    for filter in [Filter::Moonray, Filter::Bilinear, Filter::Trilinear, Filter::Anisotropic] {
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

//! Tests across modules: bake → set → lookup, with files written by the tests themselves.

mod alloc;
mod decoding;
mod lanes;
mod lookup;
mod pyramid;
mod reference;
mod udim;

use crate::{
    bake, BakeOptions, ColorSpace, Filter, Lookup, Samples, SourceImage, TextureSet, TextureSetBuilder,
};

/// Bakes in-memory images into a set (one texture each).
pub(crate) fn set_of(images: &[(SourceImage, ColorSpace)]) -> TextureSet {
    let mut b = TextureSetBuilder::new();
    for (img, cs) in images {
        b.add_baked(bake(img, &BakeOptions { color_space: *cs, ..Default::default() }).unwrap());
    }
    b.finish()
}

/// A float image with `c` channels.
pub(crate) fn float_image(w: u32, h: u32, c: u32, data: Vec<f32>) -> SourceImage {
    SourceImage { width: w, height: h, channels: c, samples: Samples::F32(data) }
}

/// A point lookup (zero footprint) at `uv`.
pub(crate) fn at(uv: [f32; 2], filter: Filter) -> Lookup {
    Lookup { uv, filter, ..Default::default() }
}

pub(crate) fn assert_close(got: [f32; 4], want: [f32; 4], tol: f32) {
    for k in 0..4 {
        assert!((got[k] - want[k]).abs() <= tol, "got {got:?}, want {want:?} (±{tol})");
    }
}

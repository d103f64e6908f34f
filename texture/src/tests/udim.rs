//! UDIM sets from PNG tiles written to a temporary directory.

use std::path::Path;

use super::{assert_close, at};
use crate::{BakeOptions, Filter, Lookup, TextureRef, TextureSetBuilder, Warning};

const RED: [u8; 3] = [255, 0, 0];
const GREEN: [u8; 3] = [0, 255, 0];
const BLUE: [u8; 3] = [0, 0, 255];
const WHITE: [u8; 3] = [255, 255, 255];

fn write_tile(dir: &Path, number: u32, rgb: [u8; 3]) {
    let img = image::RgbImage::from_pixel(16, 8, image::Rgb(rgb));
    img.save(dir.join(format!("albedo.{number}.png"))).unwrap();
}

fn linear(rgb: [u8; 3]) -> [f32; 4] {
    [rgb[0] as f32 / 255.0, rgb[1] as f32 / 255.0, rgb[2] as f32 / 255.0, 1.0]
}

#[test]
fn tiles_land_where_their_numbers_say() {
    let dir = tempfile::tempdir().unwrap();
    for (n, c) in [(1001, RED), (1002, GREEN), (1011, BLUE), (1012, WHITE)] {
        write_tile(dir.path(), n, c);
    }
    std::fs::write(dir.path().join("albedo.100.png"), b"not a tile").unwrap(); // three digits: ignored
    let pattern = dir.path().join("albedo.<UDIM>.png");
    let mut b = TextureSetBuilder::new();
    let TextureRef::Udim(set) = b.add_file(&pattern, &BakeOptions::default()).unwrap() else {
        panic!("pattern should make a UDIM set")
    };
    assert!(b.warnings().is_empty(), "{:?}", b.warnings());
    let built = b.finish();
    assert_eq!(built.records.len(), 4);
    let view = built.view().unwrap();
    let fallback = [0.5, 0.25, 0.125, 1.0];
    for filter in Filter::ALL {
        for (uv, c) in [([0.5, 0.5], RED), ([1.5, 0.5], GREEN), ([0.5, 1.5], BLUE), ([1.5, 1.5], WHITE)] {
            assert_close(view.sample_udim(set, &at(uv, filter), fallback), linear(c), 0.0);
        }
        // Outside the grid.
        for uv in [[2.5, 0.5], [-0.5, 0.5], [0.5, 2.5], [f32::NAN, 0.5]] {
            assert_eq!(view.sample_udim(set, &at(uv, filter), fallback), fallback);
        }
    }
    assert_eq!(view.udim_tile(set, [1.5, 1.5]), Some((11, Some(3))));
}

/// 0.999 and 1.001 fall in different tiles, and even a footprint several texels wide never pulls in the
/// neighbour tile's colour (tiles clamp at their edges).
#[test]
fn seams_never_blend_across_tiles() {
    let dir = tempfile::tempdir().unwrap();
    write_tile(dir.path(), 1001, RED);
    write_tile(dir.path(), 1002, GREEN);
    let mut b = TextureSetBuilder::new();
    let TextureRef::Udim(set) =
        b.add_file(&dir.path().join("albedo.<UDIM>.png"), &Default::default()).unwrap()
    else {
        panic!()
    };
    let built = b.finish();
    let view = built.view().unwrap();
    for filter in Filter::ALL {
        for d in [0.0, 0.01, 0.2] {
            let q =
                |u| Lookup { uv: [u, 0.5], duv_dx: [d, 0.0], duv_dy: [0.0, d], filter, ..Default::default() };
            assert_close(view.sample_udim(set, &q(0.999), [0.0; 4]), linear(RED), 0.0);
            assert_close(view.sample_udim(set, &q(1.001), [0.0; 4]), linear(GREEN), 0.0);
        }
    }
}

#[test]
fn missing_tile_gives_fallback_and_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    for (n, c) in [(1001, RED), (1002, GREEN), (1012, WHITE)] {
        write_tile(dir.path(), n, c);
    }
    let pattern = dir.path().join("albedo.<UDIM>.png");
    let mut b = TextureSetBuilder::new();
    let first = b.add_file(&pattern, &BakeOptions::default()).unwrap();
    let again = b.add_file(&pattern, &BakeOptions::default()).unwrap();
    assert_eq!(first, again, "second reference reuses the bake");
    assert_eq!(
        b.warnings(),
        [Warning::MissingUdimTile {
            pattern: pattern.clone(),
            tile: 1011,
            path: dir.path().join("albedo.1011.png")
        }]
    );
    let message = b.warnings()[0].to_string();
    assert!(message.contains("albedo.1011.png"), "{message}");
    let TextureRef::Udim(set) = first else { panic!() };
    let built = b.finish();
    let view = built.view().unwrap();
    let fallback = [0.1, 0.2, 0.3, 0.4];
    assert_eq!(view.sample_udim(set, &at([0.5, 1.5], Filter::Moonray), fallback), fallback);
    assert_close(view.sample_udim(set, &at([1.5, 1.5], Filter::Moonray), fallback), linear(WHITE), 0.0);
}

#[test]
fn pattern_without_tiles_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let err =
        TextureSetBuilder::new().add_file(&dir.path().join("x.<UDIM>.exr"), &Default::default()).unwrap_err();
    assert!(matches!(err.kind, crate::ErrorKind::Udim(_)), "{err}");
    let err = TextureSetBuilder::new().add_file(Path::new("<UDIM>/x.png"), &Default::default()).unwrap_err();
    assert!(err.to_string().contains("file name"), "{err}");
}

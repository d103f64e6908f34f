//! Every supported file type and layout, written by the test and read back through decode → bake → sample.

use std::path::Path;

use super::{assert_close, at};
use crate::{decode, BakeOptions, ColorSpace, Filter, Samples, TexelFormat, TextureRef, TextureSetBuilder};

/// Decodes, bakes and point-samples the centre of `path`; returns (channels, format, rgba).
fn read_back(path: &Path, cs: ColorSpace) -> (u32, TexelFormat, [f32; 4]) {
    let channels = decode(path).unwrap().channels;
    let mut b = TextureSetBuilder::new();
    let TextureRef::Texture(t) =
        b.add_file(path, &BakeOptions { color_space: cs, ..Default::default() }).unwrap()
    else {
        panic!()
    };
    let set = b.finish();
    let view = set.view().unwrap();
    let tex = view.texture(t).unwrap();
    (channels, tex.format(), view_sample(&tex))
}

fn view_sample(tex: &crate::TextureView) -> [f32; 4] {
    crate::sample_with(tex, &at([0.5, 0.5], Filter::Moonray), &crate::NoTouch)
}

const S128: f32 = 0.215_860_5; // sRGB 128 → linear
const S10: f32 = 0.003_035_3; // sRGB 10 → linear

#[test]
fn png_8bit_layouts() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    image::GrayImage::from_pixel(4, 4, image::Luma([128])).save(p("l.png")).unwrap();
    image::GrayAlphaImage::from_pixel(4, 4, image::LumaA([128, 51])).save(p("la.png")).unwrap();
    image::RgbImage::from_pixel(4, 4, image::Rgb([10, 128, 255])).save(p("rgb.png")).unwrap();
    image::RgbaImage::from_pixel(4, 4, image::Rgba([10, 128, 255, 51])).save(p("rgba.png")).unwrap();

    let (c, f, v) = read_back(&p("l.png"), ColorSpace::Auto);
    assert_eq!((c, f), (1, TexelFormat::Srgb8));
    assert_close(v, [S128, S128, S128, 1.0], 1e-7);

    let (c, _, v) = read_back(&p("la.png"), ColorSpace::Auto);
    assert_eq!(c, 2);
    assert_close(v, [S128, S128, S128, 0.2], 1e-7); // alpha stays linear: 51/255

    let (c, _, v) = read_back(&p("rgb.png"), ColorSpace::Srgb);
    assert_eq!(c, 3);
    assert_close(v, [S10, S128, 1.0, 1.0], 1e-7);

    let (c, _, v) = read_back(&p("rgba.png"), ColorSpace::Auto);
    assert_eq!(c, 4);
    assert_close(v, [S10, S128, 1.0, 0.2], 1e-7);

    // `raw` keeps the codes linear.
    let (_, f, v) = read_back(&p("rgba.png"), ColorSpace::Raw);
    assert_eq!(f, TexelFormat::Unorm8);
    assert_close(v, [10.0 / 255.0, 128.0 / 255.0, 1.0, 0.2], 1e-7);
}

#[test]
fn png_16bit() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rgb16.png");
    image::ImageBuffer::<image::Rgb<u16>, _>::from_pixel(4, 4, image::Rgb([0u16, 32768, 65535]))
        .save(&path)
        .unwrap();
    assert!(matches!(decode(&path).unwrap().samples, Samples::U16(_)));
    // `auto` on 16-bit is raw: 32768 / 65535 = 0.500008, stored as f16.
    let (c, f, v) = read_back(&path, ColorSpace::Auto);
    assert_eq!((c, f), (3, TexelFormat::F16));
    assert_close(v, [0.0, 0.500_008, 1.0, 1.0], 3e-4);
    // Explicit sRGB decodes at bake: sRGB(0.5) = 0.214041.
    let (_, _, v) = read_back(&path, ColorSpace::Srgb);
    assert_close(v, [0.0, 0.214_05, 1.0, 1.0], 3e-4);

    let grey = dir.path().join("l16.png");
    image::ImageBuffer::<image::Luma<u16>, _>::from_pixel(2, 2, image::Luma([16384u16])).save(&grey).unwrap();
    let (c, _, v) = read_back(&grey, ColorSpace::Auto);
    assert_eq!(c, 1);
    assert_close(v, [0.25, 0.25, 0.25, 1.0], 3e-4);
}

#[test]
fn hdr_and_exr_floats() {
    let dir = tempfile::tempdir().unwrap();
    let hdr = dir.path().join("sky.hdr");
    let img = image::Rgb32FImage::from_pixel(4, 4, image::Rgb([2.5, 0.25, 16.0]));
    image::DynamicImage::ImageRgb32F(img).save(&hdr).unwrap();
    let (c, f, v) = read_back(&hdr, ColorSpace::Auto);
    assert_eq!((c, f), (3, TexelFormat::F16));
    assert_close(v, [2.5, 0.25, 16.0, 1.0], 0.01 * 16.0); // RGBE: 8-bit mantissa, shared exponent
    assert!((v[0] - 2.5).abs() < 0.02 && (v[1] - 0.25).abs() < 0.002, "{v:?}");

    let exr_path = dir.path().join("light.exr");
    exr::prelude::write_rgba_file(&exr_path, 4, 4, |_, _| (0.25f32, 1.5f32, 8.0f32, 0.5f32)).unwrap();
    let (c, f, v) = read_back(&exr_path, ColorSpace::Auto);
    assert_eq!((c, f), (4, TexelFormat::F16));
    assert_close(v, [0.25, 1.5, 8.0, 0.5], 0.0);

    // A luminance-only EXR is grey.
    use exr::prelude::*;
    let y_path = dir.path().join("height.exr");
    let pixels = SpecificChannels::build().with_channel("Y").with_pixel_fn(|_| (0.75f32,));
    Image::from_channels((3, 5), pixels).write().to_file(&y_path).unwrap();
    let (c, _, v) = read_back(&y_path, ColorSpace::Auto);
    assert_eq!(c, 1);
    assert_close(v, [0.75, 0.75, 0.75, 1.0], 0.0);
}

#[test]
fn jpg_tga_tif() {
    let dir = tempfile::tempdir().unwrap();
    let rgb = image::RgbImage::from_pixel(8, 8, image::Rgb([10, 128, 255]));
    for name in ["a.jpg", "a.tga", "a.tif"] {
        let path = dir.path().join(name);
        rgb.save(&path).unwrap();
        let (c, f, v) = read_back(&path, ColorSpace::Auto);
        assert_eq!((c, f), (3, TexelFormat::Srgb8), "{name}");
        // JPEG is lossy (chroma subsampling of a flat colour still shifts codes by a few).
        let tol = if name.ends_with("jpg") { 0.02 } else { 1e-7 };
        assert_close(v, [S10, S128, 1.0, 1.0], tol);
    }
    let tif16 = dir.path().join("b.tif");
    image::ImageBuffer::<image::Rgba<u16>, _>::from_pixel(4, 4, image::Rgba([65535u16, 0, 32768, 65535]))
        .save(&tif16)
        .unwrap();
    let (c, f, v) = read_back(&tif16, ColorSpace::Auto);
    assert_eq!((c, f), (4, TexelFormat::F16));
    assert_close(v, [1.0, 0.0, 0.5, 1.0], 3e-4);
}

#[test]
fn unreadable_file_names_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.png");
    std::fs::write(&path, b"definitely not a png").unwrap();
    let err = decode(&path).unwrap_err();
    assert!(err.to_string().contains("broken.png"), "{err}");
}

/// In-memory decoding (package entries) gives what the file decoder gives, for a format detected
/// from content (PNG), one only the extension names (TGA has no signature) and EXR.
#[test]
fn decode_bytes_matches_decode() {
    let dir = tempfile::tempdir().unwrap();
    let rgb = image::RgbImage::from_pixel(8, 4, image::Rgb([10, 128, 255]));
    for name in ["a.png", "a.tga"] {
        let path = dir.path().join(name);
        rgb.save(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let from_memory = crate::decode_bytes(&bytes, Path::new(name)).unwrap();
        assert_eq!(from_memory, decode(&path).unwrap(), "{name}");
        assert_eq!(from_memory.samples, Samples::U8([10, 128, 255].repeat(32)));
    }
    let exr_path = dir.path().join("light.exr");
    exr::prelude::write_rgba_file(&exr_path, 4, 4, |_, _| (0.25f32, 1.5f32, 8.0f32, 0.5f32)).unwrap();
    let bytes = std::fs::read(&exr_path).unwrap();
    assert_eq!(
        crate::decode_bytes(&bytes, Path::new("textures/light.exr")).unwrap(),
        decode(&exr_path).unwrap()
    );
    let err = crate::decode_bytes(b"not an image", Path::new("pkg.usdz[t/x.png]")).unwrap_err();
    assert!(err.to_string().contains("pkg.usdz[t/x.png]"), "{err}");
}

/// CRC-32 (PNG's polynomial), for chunks written by hand.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// A well-formed PNG header declaring `width`×`height` RGBA8, with one tiny IDAT: under 100 bytes.
fn png_declaring(width: u32, height: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    // An empty zlib stream: the decoder would fail only after allocating the image.
    chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(b"IEND", &[]);
    out
}

#[test]
fn declared_sizes_above_the_pixel_budget_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("huge.png");
    std::fs::write(&png, png_declaring(100_000, 100_000)).unwrap();
    assert!(std::fs::metadata(&png).unwrap().len() < 100);
    let hdr = dir.path().join("huge.hdr");
    std::fs::write(&hdr, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n\x02\x02\x00\x10")
        .unwrap();
    for path in [&png, &hdr] {
        let text = decode(path).unwrap_err().to_string();
        assert_eq!(
            text,
            format!(
                "{}: image declares 100000x100000 = 10000000000 pixels, above the limit of 268435456 pixels",
                path.display()
            )
        );
    }
    // The same bytes from memory (a `.usdz` entry).
    let text = crate::decode_bytes(&png_declaring(30_000, 30_000), Path::new("pkg/huge.png"))
        .unwrap_err()
        .to_string();
    assert_eq!(
        text,
        "pkg/huge.png: image declares 30000x30000 = 900000000 pixels, above the limit of 268435456 pixels"
    );

    // A real image over a caller's budget; within it, it decodes.
    let small = dir.path().join("small.png");
    image::RgbImage::from_pixel(40, 30, image::Rgb([1, 2, 3])).save(&small).unwrap();
    let tight = crate::DecodeLimits { max_pixels: 1199 };
    let text = crate::decode_with(&small, &tight).unwrap_err().to_string();
    assert!(
        text.ends_with("small.png: image declares 40x30 = 1200 pixels, above the limit of 1199 pixels"),
        "{text}"
    );
    let enough = crate::DecodeLimits { max_pixels: 1200 };
    assert_eq!(crate::decode_with(&small, &enough).unwrap().width, 40);
}

#[test]
fn exr_declared_sizes_above_the_pixel_budget_are_refused() {
    use exr::prelude::WritableImage;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("small.exr");
    let pixels = exr::prelude::SpecificChannels::rgb(|_: exr::prelude::Vec2<usize>| (0.5f32, 0.5f32, 0.5f32));
    exr::prelude::Image::from_channels((40, 30), pixels).write().to_file(&path).unwrap();
    let tight = crate::DecodeLimits { max_pixels: 1000 };
    let text = crate::decode_with(&path, &tight).unwrap_err().to_string();
    assert!(
        text.ends_with("small.exr: image declares 40x30 = 1200 pixels, above the limit of 1000 pixels"),
        "{text}"
    );
    let bytes = std::fs::read(&path).unwrap();
    let text = crate::decode_bytes_with(&bytes, Path::new("a.exr"), &tight).unwrap_err().to_string();
    assert_eq!(text, "a.exr: image declares 40x30 = 1200 pixels, above the limit of 1000 pixels");
    assert_eq!(crate::decode_with(&path, &crate::DecodeLimits { max_pixels: 1200 }).unwrap().height, 30);
}

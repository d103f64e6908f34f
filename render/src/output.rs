//! Writing images: a multi-channel OpenEXR (beauty RGBA plus `albedo.*`, `normal.*` and `depth.Z`
//! layers, 32-bit float, linear) and an 8-bit sRGB PNG preview of the beauty.

use crate::error::RenderError;
use crate::film::Image;
use std::path::Path;

/// Writes `image` as an OpenEXR file with the layers `R G B A`, `albedo.{R,G,B}`, `normal.{X,Y,Z}`
/// and `depth.Z`.
pub fn write_exr(path: &Path, image: &Image) -> Result<(), RenderError> {
    use exr::prelude::*;
    let size = (image.width as usize, image.height as usize);
    let channel = |name: &str, values: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(values));
    let beauty = |c: usize| image.beauty.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let albedo = |c: usize| image.albedo.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let normal = |c: usize| image.normal.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let channels = vec![
        channel("R", beauty(0)),
        channel("G", beauty(1)),
        channel("B", beauty(2)),
        channel("A", beauty(3)),
        channel("albedo.R", albedo(0)),
        channel("albedo.G", albedo(1)),
        channel("albedo.B", albedo(2)),
        channel("normal.X", normal(0)),
        channel("normal.Y", normal(1)),
        channel("normal.Z", normal(2)),
        channel("depth.Z", image.depth.clone()),
    ];
    let layer = Layer::new(
        size,
        LayerAttributes::named("beauty"),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    // Sequential compression: exr's parallel writer emits blocks in completion order, so the same pixels
    // would give different file bytes from run to run.
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_file(path)
        .map_err(|e| RenderError::Output { path: path.to_path_buf(), message: e.to_string() })
}

/// The sRGB opto-electronic transfer function of a linear value in [0, 1].
pub fn srgb_oetf(linear: f32) -> f32 {
    let x = linear.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes the beauty as an 8-bit sRGB PNG (clamped, alpha dropped).
pub fn write_png(path: &Path, image: &Image) -> Result<(), RenderError> {
    let mut pixels = Vec::with_capacity(image.beauty.len() * 3);
    for p in &image.beauty {
        for &c in &p[..3] {
            let c = if c.is_finite() { c } else { 0.0 };
            pixels.push((srgb_oetf(c) * 255.0 + 0.5) as u8);
        }
    }
    image::save_buffer_with_format(
        path,
        &pixels,
        image.width,
        image.height,
        image::ColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| RenderError::Output { path: path.to_path_buf(), message: e.to_string() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::RenderStats;

    #[test]
    fn exr_and_png_round_trip() {
        let image = Image {
            width: 3,
            height: 2,
            beauty: (0..6).map(|i| [i as f32 * 0.25, 0.5, 1.5, 1.0]).collect(),
            albedo: vec![[0.5; 3]; 6],
            normal: vec![[0.0, 0.0, 1.0]; 6],
            depth: vec![2.0; 6],
            stats: RenderStats::default(),
        };
        let dir = tempfile::tempdir().unwrap();
        let exr_path = dir.path().join("out.exr");
        write_exr(&exr_path, &image).unwrap();
        let read = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
        let layer = &read.layer_data[0];
        let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
        for expected in ["R", "G", "B", "A", "albedo.R", "normal.Z", "depth.Z"] {
            assert!(names.iter().any(|n| n == expected), "{names:?}");
        }
        let r = layer.channel_data.list.iter().find(|c| c.name.to_string() == "R").unwrap();
        assert_eq!(r.sample_data.value_by_flat_index(5).to_f32(), 1.25);

        let png_path = dir.path().join("out.png");
        write_png(&png_path, &image).unwrap();
        let png = image::open(&png_path).unwrap().to_rgb8();
        assert_eq!(png.get_pixel(2, 0).0, [188, 188, 255]); // 0.5 → 188 in sRGB, 1.5 clamps
        assert_eq!(png.get_pixel(0, 0).0[0], 0);
    }
}

//! Crops, authored data windows and passes: a region render draws exactly the full render's pixels
//! (both integrators, windows cutting through tiles) and writes them as the EXR data window of the
//! frame; a render in passes (checkpoints, resumes) equals one in a single pass bit for bit.

use crate::film::PixelWindow;
use crate::testscene::{self, camera_looking_down_z, card, dome, lambert, sphere};
use crate::{render_image, Image, Integrator, RenderOptions};
use glam::Vec3;
use scene_pack::Scene;

/// A sphere in front of a card under a dome: edges, shadows and bounces in every tile.
fn scene(data_window_ndc: Option<[f32; 4]>) -> Scene {
    Scene {
        meshes: vec![sphere(Vec3::ZERO, 1.0, 24, 48, 0, false), card(-1.5, 3.0, 1)],
        materials: vec![lambert(0.7), lambert(0.3)],
        lights: vec![dome(1.0)],
        cameras: vec![camera_looking_down_z(Vec3::new(0.3, 0.2, 4.0), 18.0)],
        default_camera: Some(0),
        data_window_ndc,
        ..Scene::default()
    }
}

fn render(scene: &Scene, options: &RenderOptions) -> Image {
    let bytes = testscene::bytes(scene);
    render_image(&blob::SceneView::parse(&bytes).unwrap(), options).unwrap()
}

fn options(integrator: Integrator, crop: Option<[f32; 4]>) -> RenderOptions {
    RenderOptions {
        spp: 3,
        resolution: Some([37, 29]),
        threads: 2,
        integrator,
        crop,
        ..RenderOptions::default()
    }
}

/// Every AOV of `crop` equals the same pixel of `full`, bit for bit.
fn assert_same_pixels(crop: &Image, full: &Image) {
    let [ox, oy] = crop.origin;
    for y in 0..crop.height {
        for x in 0..crop.width {
            let (c, f) = ((y * crop.width + x) as usize, ((y + oy) * full.width + x + ox) as usize);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&crop.beauty[c]), bits(&full.beauty[f]), "beauty at ({}, {})", x + ox, y + oy);
            assert_eq!(bits(&crop.albedo[c]), bits(&full.albedo[f]));
            assert_eq!(bits(&crop.normal[c]), bits(&full.normal[f]));
            assert_eq!(crop.depth[c].to_bits(), full.depth[f].to_bits());
        }
    }
}

const CROP: [f32; 4] = [0.13, 0.21, 0.71, 0.93];

#[test]
fn ndc_windows_take_the_pixels_whose_centres_they_hold() {
    // Columns: ceil(0.13·37 − ½) = 5 to ceil(0.71·37 − ½) = 26; rows from the top: ceil(0.07·29 − ½) = 2
    // to ceil(0.79·29 − ½) = 23.
    assert_eq!(PixelWindow::from_ndc(CROP, 37, 29), Some(PixelWindow { x0: 5, y0: 2, x1: 26, y1: 23 }));
    assert_eq!(PixelWindow::from_ndc([0.0, 0.0, 1.0, 1.0], 37, 29), Some(PixelWindow::full(37, 29)));
    // Overscan clips to the frame; the bottom-left quarter is the lower rows.
    assert_eq!(
        PixelWindow::from_ndc([-1.0, -1.0, 0.5, 0.5], 4, 4),
        Some(PixelWindow { x0: 0, y0: 2, x1: 2, y1: 4 })
    );
    assert_eq!(PixelWindow::from_ndc([0.0, 0.0, 0.01, 1.0], 37, 29), None, "no column centre inside");
}

#[test]
fn a_cropped_render_is_the_full_render_s_pixels_in_both_integrators() {
    let scene = scene(None);
    for integrator in [Integrator::Scalar, Integrator::Wavefront] {
        let full = render(&scene, &options(integrator, None));
        let crop = render(&scene, &options(integrator, Some(CROP)));
        assert_eq!((crop.width, crop.height, crop.origin, crop.frame), (21, 21, [5, 2], [37, 29]));
        assert_eq!(crop.stats.samples, 21 * 21 * 3);
        assert!(crop.stats.rays.camera < full.stats.rays.camera / 2, "only the window is traced");
        assert_same_pixels(&crop, &full);
    }
}

#[test]
fn the_authored_data_window_crops_and_crop_overrides_it() {
    let authored = render(&scene(Some(CROP)), &options(Integrator::Wavefront, None));
    assert_eq!((authored.origin, authored.width, authored.height), ([5, 2], 21, 21));
    let full = render(&scene(None), &options(Integrator::Wavefront, None));
    assert_same_pixels(&authored, &full);
    let overridden = render(&scene(Some(CROP)), &options(Integrator::Wavefront, Some([0.5, 0.0, 1.0, 0.5])));
    // The right half from column ceil(18.5 − ½) = 18, the lower half from row ceil(14.5 − ½) = 14.
    assert_eq!((overridden.origin, overridden.width, overridden.height), ([18, 14], 19, 15));
    assert_same_pixels(&overridden, &full);

    let bytes = testscene::bytes(&scene(None));
    let view = blob::SceneView::parse(&bytes).unwrap();
    let err = render_image(&view, &options(Integrator::Scalar, Some([0.0, 0.0, 0.01, 1.0]))).unwrap_err();
    assert_eq!(
        err.to_string(),
        "invalid option: --crop [0.0, 0.0, 0.01, 1.0] (xmin, ymin, xmax, ymax in NDC) holds no pixel centre of the 37x29 frame"
    );
}

#[test]
fn a_cropped_exr_is_the_data_window_of_the_whole_frame() {
    let crop = render(&scene(None), &options(Integrator::Wavefront, Some(CROP)));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("crop.exr");
    crate::write_exr(&path, &crop).unwrap();
    let read = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    let display = read.attributes.display_window;
    assert_eq!(
        (display.position.x(), display.position.y(), display.size.width(), display.size.height()),
        (0, 0, 37, 29)
    );
    let layer = &read.layer_data[0];
    assert_eq!((layer.attributes.layer_position.x(), layer.attributes.layer_position.y()), (5, 2));
    assert_eq!((layer.size.width(), layer.size.height()), (21, 21));
    let r = layer.channel_data.list.iter().find(|c| c.name.to_string() == "R").unwrap();
    assert_eq!(r.sample_data.value_by_flat_index(21 * 3 + 4).to_f32(), crop.beauty[21 * 3 + 4][0]);
}

#[test]
fn a_render_in_passes_equals_one_pass_bit_for_bit() {
    let bytes = testscene::bytes(&scene(None));
    let scene = crate::Scene::new(blob::SceneView::parse(&bytes).unwrap());
    for integrator in [Integrator::Scalar, Integrator::Wavefront] {
        let options = RenderOptions { spp: 7, ..options(integrator, Some(CROP)) };
        let whole = crate::render_scene(&scene, &options).unwrap();
        let mut film = crate::Accumulation::new(&scene, &options).unwrap();
        for until in [1, 3, 3, 7] {
            film.render(&scene, &options, until, &|_| {}).unwrap();
        }
        assert_eq!(film.samples, 7);
        let passes = film.image();
        assert_eq!((passes.origin, passes.width, passes.height), (whole.origin, whole.width, whole.height));
        // Both are the window: compare them as the full frame of themselves.
        let at_origin = |image: &Image| Image { origin: [0, 0], ..image.clone() };
        assert_same_pixels(&at_origin(&passes), &at_origin(&whole));
        assert_eq!(passes.stats.rays, whole.stats.rays, "the same paths were traced");
        assert_eq!(passes.stats.samples, whole.stats.samples);
    }
}

//! Adaptive sampling end to end ([`crate::frame::Adaptive`]): a frame half flat (the dome seen
//! directly: every sample reads exactly 1) and half noisy (a grey card lit by the dome, whose
//! value is its albedo: a white-furnace card).

use crate::testscene::{self, camera_looking_down_z, dome, lambert};
use crate::{Accumulation, Integrator, RenderOptions, Scene as RenderScene};
use blob::outputs::{data_type as dt, source_type as st};
use glam::Vec3;
use scene_pack::{Mesh, RenderProduct, RenderVar, Scene};

const ALBEDO: f32 = 0.5;

/// The card fills the right half of the frame (x > 0 at z = −10, seen from the origin).
fn half_and_half() -> Scene {
    let mut card = testscene::card(-10.0, 1.0, 0);
    card.positions =
        [[0.0, -1e3], [1e3, -1e3], [1e3, 1e3], [0.0, 1e3]].map(|[x, y]| Vec3::new(x, y, -10.0)).to_vec();
    Scene {
        meshes: vec![Mesh { path: "/card".into(), ..card }],
        materials: vec![lambert(ALBEDO)],
        lights: vec![dome(1.0)],
        cameras: vec![camera_looking_down_z(Vec3::ZERO, 35.0)],
        default_camera: Some(0),
        render_products: vec![RenderProduct {
            path: "/Render/Counts".into(),
            name: "counts.exr".into(),
            vars: vec![RenderVar {
                path: "/Render/Vars/spp".into(),
                source: "sampleCount".into(),
                source_type: st::RAW,
                data_type: dt::FLOAT,
            }],
        }],
        meters_per_unit: 1.0,
        ..Scene::default()
    }
}

const W: u32 = 64;
const H: u32 = 32;

fn render(scene: &Scene, options: &RenderOptions) -> Accumulation {
    let bytes = testscene::bytes(scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let scene = RenderScene::new(view);
    let mut film = Accumulation::new(&scene, options).unwrap();
    match options.adaptive {
        Some((t, min)) => film.render_adaptive(&scene, options, t, min, &|_| {}).unwrap(),
        None => film.render(&scene, options, options.spp, &|_| {}).unwrap(),
    }
    film
}

fn options(threshold: Option<f32>, spp: u32) -> RenderOptions {
    RenderOptions {
        spp,
        resolution: Some([W, H]),
        threads: 2,
        max_depth: 2,
        adaptive: threshold.map(|t| (t, 16)),
        ..RenderOptions::default()
    }
}

/// The normalised error of a pixel of luminance `l` against the card's or the dome's exact value.
fn error(x: u32, l: f32) -> f64 {
    let truth = if x >= W / 2 { f64::from(ALBEDO) } else { 1.0 };
    (f64::from(l) - truth).abs() / (1e-3 + truth.sqrt())
}

#[test]
fn the_flat_half_stops_at_the_minimum_and_the_noisy_half_below_the_threshold() {
    let threshold = 0.01;
    let film = render(&half_and_half(), &options(Some(threshold), 4096));
    let adaptive = film.adaptive.as_ref().unwrap();
    let image = film.image();
    let (mut flat, mut noisy, mut sq, mut stopped) = (0u64, 0u64, 0.0f64, 0usize);
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let count = adaptive.counts[i];
            if x < W / 2 {
                assert_eq!(count, 16, "pixel ({x}, {y}) of the flat half: the minimum");
                assert_eq!(image.rgb(x, y), [1.0; 3]);
                flat += u64::from(count);
            } else {
                noisy += u64::from(count);
                if count < 4096 {
                    let [r, g, b] = image.rgb(x, y);
                    sq += error(x, 0.2126 * r + 0.7152 * g + 0.0722 * b).powi(2);
                    stopped += 1;
                }
            }
        }
    }
    let rms = (sq / stopped.max(1) as f64).sqrt();
    eprintln!(
        "flat half {flat} samples, noisy half {noisy}; {stopped} noisy pixels stopped, RMS error {rms:.4}"
    );
    assert!(noisy > 4 * flat, "the noisy half took the samples: {noisy} against {flat}");
    assert!(stopped > 0);
    assert!(
        rms <= f64::from(threshold),
        "RMS error {rms} of the stopped noisy pixels, threshold {threshold}"
    );
    // The sampleCount layer shows where the samples went.
    let products = film.products();
    let spp = &products[0].1.iter().find(|(n, _)| n == "spp").unwrap().1;
    assert!(spp.iter().zip(&adaptive.counts).all(|(&s, &c)| s == c as f32));
    assert_eq!(film.stats.samples, flat + noisy, "the statistics count the samples traced");
}

#[test]
fn adaptive_renders_are_equal_on_any_thread_count_and_for_both_integrators() {
    let scene = half_and_half();
    let reference = render(&scene, &options(Some(0.02), 512));
    let bits = |f: &Accumulation| {
        let image = f.image();
        (image.beauty.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>(), f.adaptive.clone())
    };
    for (threads, integrator) in
        [(1, Integrator::Wavefront), (3, Integrator::Wavefront), (2, Integrator::Scalar)]
    {
        let other = render(&scene, &RenderOptions { threads, integrator, ..options(Some(0.02), 512) });
        assert!(bits(&other) == bits(&reference), "{threads} threads, {integrator:?}");
    }
    // A uniform render is unchanged by the machinery: every pixel holds spp samples.
    let uniform = render(&scene, &options(None, 16));
    assert!(uniform.adaptive.is_none());
    assert_eq!(uniform.stats.samples, u64::from(W * H * 16));
}

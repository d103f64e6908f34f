//! Motion blur end to end: scenes built in code with moving meshes (`scene_pack::Mesh::motion`),
//! rendered by both integrators and measured on the image.
//!
//! The camera of [`ramp_scene`] looks down −Z from the origin with `focalLength` 50 on a 20-wide
//! aperture, so at distance `d` one pixel of a `W`-wide image spans `(20 / W) · d / 50` scene
//! units. A black half-plane in front of an emissive wall, whose edge sweeps `v` pixels during the
//! shutter, hides each pixel it crosses for a fraction of the shutter that grows linearly across
//! the sweep: the image is a ramp `v` pixels wide from the wall's plateau to black. (The moving
//! card is the black one: an emissive gprim is not moved, light sampling being world-space.)

use crate::testscene::{self, camera_looking_down_z, card};
use crate::{render_image, Image, Integrator, RenderOptions};
use glam::{DMat4, DVec3, Vec3};
use scene_pack::{Material, Mesh, MotionKey, Scene, TransformMotion};

const FOCAL: f32 = 50.0;
const APERTURE: f32 = 20.0;
const DISTANCE: f32 = 100.0;

/// A black half-plane from `x = 0` to far right at `z = −DISTANCE`.
fn half_plane() -> Mesh {
    let mut mesh = card(-DISTANCE, 1.0, 0);
    let (x0, x1, y) = (0.0, 1000.0, 1000.0);
    mesh.positions = [[x0, -y], [x1, -y], [x1, y], [x0, y]].map(|[x, y]| Vec3::new(x, y, -DISTANCE)).to_vec();
    mesh
}

/// Translation keys along x: `(time, x)`.
fn sliding(keys: &[(f32, f64)]) -> TransformMotion {
    TransformMotion {
        keys: keys
            .iter()
            .map(|&(time, x)| MotionKey {
                time,
                world_from_stored: DMat4::from_translation(DVec3::new(x, 0.0, 0.0)),
            })
            .collect(),
    }
}

/// The half-plane moving by `motion`, seen through a camera with shutter `shutter`.
fn ramp_scene(motion: Option<TransformMotion>, shutter: [f32; 2]) -> Scene {
    let mut camera = camera_looking_down_z(Vec3::ZERO, FOCAL);
    camera.shutter = shutter;
    Scene {
        meshes: vec![Mesh { motion, ..half_plane() }, card(-2.0 * DISTANCE, 1000.0, 1)],
        materials: vec![
            testscene::lambert(0.0),
            Material { emissive_color: Vec3::splat(10.0), ..testscene::lambert(0.0) },
        ],
        cameras: vec![camera],
        default_camera: Some(0),
        meters_per_unit: 1.0,
        ..Scene::default()
    }
}

fn render(scene: &Scene, options: &RenderOptions) -> Image {
    let bytes = testscene::bytes(scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    render_image(&view, options).unwrap()
}

fn options(width: u32, spp: u32) -> RenderOptions {
    RenderOptions { spp, resolution: Some([width, 8]), threads: 2, max_depth: 1, ..RenderOptions::default() }
}

fn luminance(image: &Image, x: u32, y: u32) -> f64 {
    let [r, g, b] = image.rgb(x, y);
    f64::from(r + g + b) / 3.0
}

/// Pixels whose beauty bits differ.
fn differing(a: &Image, b: &Image) -> usize {
    a.beauty.iter().zip(&b.beauty).filter(|(x, y)| x.map(f32::to_bits) != y.map(f32::to_bits)).count()
}

/// Per row, the pixels strictly between 2 % and 98 % of the plateau (the wall, left of the sweep),
/// averaged over the rows; and the largest deviation of the pixels `start..start + v` from the
/// straight ramp `1 − (k + ½) / v`.
fn ramp(image: &Image, start: u32, v: u32) -> (f64, f64) {
    let plateau = luminance(image, 0, image.height / 2);
    let (mut transitional, mut worst) = (0usize, 0.0f64);
    for y in 0..image.height {
        for x in 0..image.width {
            let value = luminance(image, x, y) / plateau;
            transitional += usize::from(value > 0.02 && value < 0.98);
            if (start..start + v).contains(&x) {
                let expected = 1.0 - (f64::from(x - start) + 0.5) / f64::from(v);
                worst = worst.max((value - expected).abs());
            }
        }
    }
    (transitional as f64 / f64::from(image.height), worst)
}

#[test]
fn a_card_moving_v_pixels_over_the_shutter_makes_a_linear_ramp_v_pixels_wide() {
    let width = 128;
    let pixel = f64::from(APERTURE) / f64::from(width) * f64::from(DISTANCE / FOCAL);
    for v in [4u32, 9, 16] {
        // The edge starts on the boundary of pixel column 64 (the image centre) at the shutter's
        // open and ends `v` pixels to the right at its close; the frame (time 0) is half-way.
        let d = f64::from(v) * pixel;
        let motion = sliding(&[(-0.5, -0.5 * d), (0.5, 0.5 * d)]);
        // The keys are relative to the frame: the stored edge sits at the sweep's middle.
        let mut scene = ramp_scene(Some(motion), [-0.5, 0.5]);
        scene.meshes[0].positions.iter_mut().for_each(|p| p.x += (0.5 * d) as f32);
        for integrator in [Integrator::Wavefront, Integrator::Scalar] {
            let image = render(&scene, &RenderOptions { integrator, ..options(width, 256) });
            let (measured, worst) = ramp(&image, 64, v);
            eprintln!("v {v} px, {integrator:?}: ramp {measured:.3} px wide, worst deviation from linear {worst:.4}");
            assert!((measured - f64::from(v)).abs() <= 1.0, "v {v}: ramp {measured} px wide");
            assert!(worst < 0.04, "v {v}: the ramp is linear within 4 % (sampling noise), worst {worst}");
        }
    }
}

#[test]
fn a_closed_shutter_or_no_motion_blur_gives_the_still_image() {
    let width = 64;
    let o = options(width, 16);
    let still = render(&ramp_scene(None, [0.0, 0.0]), &o);
    let motion = || Some(sliding(&[(-0.5, -3.0), (0.5, 3.0)]));
    // Symmetric keys interpolate to exactly the identity at time 0.
    for (scene, options, what) in [
        (ramp_scene(None, [-0.5, 0.5]), o.clone(), "no motion, open shutter"),
        (ramp_scene(motion(), [0.0, 0.0]), o.clone(), "motion, closed shutter"),
        (
            ramp_scene(motion(), [-0.5, 0.5]),
            RenderOptions { motion_blur: false, ..o.clone() },
            "--no-motion-blur",
        ),
        (
            ramp_scene(motion(), [-0.5, 0.5]),
            RenderOptions { shutter: Some([0.0, 0.0]), ..o.clone() },
            "--shutter 0,0",
        ),
    ] {
        for integrator in [Integrator::Wavefront, Integrator::Scalar] {
            let image = render(&scene, &RenderOptions { integrator, ..options.clone() });
            assert_eq!(differing(&image, &still), 0, "{what}, {integrator:?}: pixels unlike the still image");
        }
    }
    let blurred = render(&ramp_scene(motion(), [-0.5, 0.5]), &o);
    assert!(differing(&blurred, &still) >= 8 * 8, "the open shutter blurs a ramp on each row");
    // `--shutter` beyond the keys holds the end keys: the edge stands at +3 for the whole shutter.
    let held =
        render(&ramp_scene(motion(), [0.0, 0.0]), &RenderOptions { shutter: Some([2.0, 3.0]), ..o.clone() });
    let mut moved = ramp_scene(None, [0.0, 0.0]);
    moved.meshes[0].positions.iter_mut().for_each(|p| p.x += 3.0);
    let moved = render(&moved, &o);
    assert_eq!(differing(&held, &moved), 0, "held end key against the card moved there");
}

#[test]
fn an_invalid_shutter_option_is_refused() {
    let scene = ramp_scene(None, [0.0, 0.0]);
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let err =
        render_image(&view, &RenderOptions { shutter: Some([0.5, 0.25]), ..options(16, 1) }).unwrap_err();
    assert_eq!(
        err.to_string(),
        "invalid option: shutter 0.5,0.25 must be OPEN,CLOSE with OPEN <= CLOSE, finite, within ±10000 time codes"
    );
}

#[test]
fn wavefront_equals_scalar_with_motion_blur_and_depth_of_field() {
    let mut scene = crate::wavefront::equivalence_tests::scene();
    // Sphere 1 slides, sphere 2 spins about its centre over three keys, sphere 3 stands still; the
    // lamp is emissive (light sampling is world-space) and stays in world space.
    scene.meshes[1].motion = Some(sliding(&[(-0.5, -0.3), (0.0, 0.0), (0.5, 0.4)]));
    let centre = DVec3::new(0.0, 0.0, -0.5);
    let spin = |time: f32, degrees: f64| MotionKey {
        time,
        world_from_stored: DMat4::from_translation(centre)
            * DMat4::from_rotation_y(degrees.to_radians())
            * DMat4::from_translation(-centre),
    };
    scene.meshes[2].motion =
        Some(TransformMotion { keys: vec![spin(-0.5, -40.0), spin(0.1, 5.0), spin(0.5, 60.0)] });
    let lamp = scene.meshes.len() - 1;
    scene.meshes[lamp].motion = Some(sliding(&[(-0.5, -1.0), (0.5, 1.0)]));
    let still = render(
        &crate::wavefront::equivalence_tests::scene(),
        &crate::wavefront::equivalence_tests::options(),
    );
    for (lens, what) in [
        (scene_pack::Lens::default(), "motion blur"),
        (
            scene_pack::Lens { f_stop: 1.8, focus_distance: 4.0, ..Default::default() },
            "motion blur and depth of field",
        ),
    ] {
        let mut scene = scene.clone();
        for camera in &mut scene.cameras {
            camera.lens = lens;
            camera.shutter = [-0.5, 0.5];
        }
        let data = testscene::pack(&scene);
        assert_eq!(data.instancing.motions.len(), 2, "the two spheres move; the emissive lamp does not");
        let bytes = testscene::encode(&data);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let options = crate::wavefront::equivalence_tests::options();
        let (scalar, _) = crate::wavefront::equivalence_tests::both_integrators(&view, &options, what);
        let changed = scalar.beauty.iter().zip(&still.beauty).filter(|(a, b)| a != b).count();
        assert!(changed > scalar.beauty.len() / 10, "{what}: motion changed only {changed} pixels");
    }
}

/// The `motionvector` layer (X, Y) of a render of `scene` with `integrator`.
fn motion_layer(scene: &Scene, width: u32, integrator: Integrator) -> (Vec<f32>, Vec<f32>) {
    use blob::outputs::{data_type, source_type};
    let mut scene = scene.clone();
    scene.render_products = vec![scene_pack::RenderProduct {
        path: "/Render/Vectors".into(),
        name: "vectors.exr".into(),
        vars: vec![scene_pack::RenderVar {
            path: "/Render/Vars/mv".into(),
            source: "motionvector".into(),
            source_type: source_type::RAW,
            data_type: data_type::VECTOR3,
        }],
    }];
    let bytes = testscene::bytes(&scene);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let scene = crate::Scene::new(view);
    let options = RenderOptions { integrator, ..options(width, 16) };
    let mut film = crate::Accumulation::new(&scene, &options).unwrap();
    film.render(&scene, &options, options.spp, &|_| {}).unwrap();
    let products = film.products();
    let channel = |name: &str| products[0].1.iter().find(|(n, _)| n == name).unwrap().1.clone();
    assert!(channel("mv.Z").iter().all(|&z| z == 0.0));
    (channel("mv.X"), channel("mv.Y"))
}

#[test]
fn the_motion_vector_of_a_card_moving_v_pixels_reads_v_and_a_still_card_zero() {
    let width = 32;
    let pixel = f64::from(APERTURE) / f64::from(width) * f64::from(DISTANCE / FOCAL);
    for (v, shutter) in [(3.0f64, [0.0, 1.0]), (7.5, [-0.5, 0.5]), (-2.25, [0.25, 0.75])] {
        let d = v * pixel;
        let [open, close] = shutter;
        let motion = sliding(&[(open, 0.0), (close, d)]);
        let mut scene = ramp_scene(Some(motion), shutter);
        // The card covers the whole frame at every time in the shutter.
        scene.meshes[0].positions = [[-1e3, -1e3], [1e3, -1e3], [1e3, 1e3], [-1e3, 1e3]]
            .map(|[x, y]| Vec3::new(x, y, -DISTANCE))
            .to_vec();
        let (x, y) = motion_layer(&scene, width, Integrator::Wavefront);
        let worst = x.iter().map(|&m| (f64::from(m) - v).abs()).fold(0.0, f64::max);
        assert!(worst <= 0.01, "v {v} px over {shutter:?}: worst |x − v| {worst}");
        assert!(y.iter().all(|m| m.abs() <= 0.01), "no vertical motion: {:?}", &y[..4]);
        let scalar = motion_layer(&scene, width, Integrator::Scalar);
        let bits = |c: &[f32]| c.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!((bits(&scalar.0), bits(&scalar.1)), (bits(&x), bits(&y)), "integrators equal");
        // The same card without motion keys, and with motion blur off, reads 0.
        let still = ramp_scene(None, shutter);
        let (x, y) = motion_layer(&still, width, Integrator::Wavefront);
        assert!(x.iter().chain(&y).all(|&m| m == 0.0));
    }
}

#[test]
fn a_camera_moving_right_moves_a_still_point_left_on_the_film() {
    // The hook camera motion plugs into: the camera at open and at close.
    let mut record = blob::Camera {
        focal_length: FOCAL,
        horizontal_aperture: APERTURE,
        vertical_aperture: APERTURE,
        world_from_camera: [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
        ..blob::Camera::default()
    };
    let open = crate::camera::Camera::from_blob(&record, 32, 32);
    let pixel = APERTURE / 32.0 * DISTANCE / FOCAL;
    record.world_from_camera[0][3] = 2.0 * pixel;
    record.world_from_camera[1][3] = -pixel;
    let close = crate::camera::Camera::from_blob(&record, 32, 32);
    let projection = crate::aov::MotionProjection::between(&open, &close, 32, 32);
    let p = Vec3::new(3.0, -4.0, -DISTANCE);
    let [mx, my] = projection.pixels(true, Some([p, p]));
    assert!((mx + 2.0).abs() < 1e-3 && (my - 1.0).abs() < 1e-3, "({mx}, {my})");
    assert_eq!(projection.pixels(false, Some([p, p])), [0.0; 2]);
    assert_eq!(projection.pixels(true, None), [0.0; 2]);
}

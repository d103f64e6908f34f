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
    // Sphere 3 breathes: its points scale about their centroid over three keys (deformation).
    let breathing = |time: f32, scale: f32| {
        let points = &scene.meshes[3].positions;
        let centre = points.iter().copied().sum::<Vec3>() / points.len() as f32;
        scene_pack::DeformKey {
            time,
            positions: points.iter().map(|&p| centre + (p - centre) * scale).collect(),
        }
    };
    let keys = vec![breathing(-0.5, 0.8), breathing(0.0, 1.0), breathing(0.2, 1.1), breathing(0.5, 1.3)];
    scene.meshes[3].deformation = Some(scene_pack::Deformation { keys });
    let lamp = scene.meshes.len() - 1;
    scene.meshes[lamp].motion = Some(sliding(&[(-0.5, -1.0), (0.5, 1.0)]));
    let still = render(
        &crate::wavefront::equivalence_tests::scene(),
        &crate::wavefront::equivalence_tests::options(),
    );
    // The camera pans and turns about its own axis over three keys.
    let pan = |time: f32, x: f64, degrees: f64| MotionKey {
        time,
        world_from_stored: DMat4::from_translation(DVec3::new(x, 0.1 * x, 0.0))
            * DMat4::from_rotation_y(degrees.to_radians()),
    };
    let camera_motion =
        TransformMotion { keys: vec![pan(-0.5, -0.2, -3.0), pan(0.0, 0.0, 0.0), pan(0.5, 0.3, 4.0)] };
    for (lens, camera_moves, what) in [
        (scene_pack::Lens::default(), false, "motion blur"),
        (
            scene_pack::Lens { f_stop: 1.8, focus_distance: 4.0, ..Default::default() },
            false,
            "motion blur and depth of field",
        ),
        (scene_pack::Lens::default(), true, "motion blur and camera motion"),
        (
            scene_pack::Lens { f_stop: 1.8, focus_distance: 4.0, ..Default::default() },
            true,
            "camera motion and depth of field",
        ),
    ] {
        let mut scene = scene.clone();
        for camera in &mut scene.cameras {
            camera.lens = lens;
            camera.shutter = [-0.5, 0.5];
            if camera_moves {
                let frame = camera.world_from_camera.as_dmat4();
                // Turning about the camera's own position: conjugated by its frame transform.
                let keys = camera_motion
                    .keys
                    .iter()
                    .map(|k| MotionKey {
                        world_from_stored: frame * k.world_from_stored * frame.inverse(),
                        ..*k
                    })
                    .collect();
                camera.motion = Some(TransformMotion { keys });
            }
        }
        let data = testscene::pack(&scene);
        assert_eq!(data.instancing.motions.len(), 2, "the two spheres move; the emissive lamp does not");
        assert_eq!(data.deform.motions.len(), 1, "the third sphere breathes");
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

/// Camera keys translating the camera along x: `(time, x)`.
fn camera_sliding(keys: &[(f32, f64)]) -> Option<TransformMotion> {
    Some(sliding(keys))
}

/// A still card seen by a camera sliding the other way gives the moving card's ramp: the edge
/// crosses the same `v` pixels of the film over the shutter (the wall behind is uniform).
#[test]
fn a_camera_moving_v_pixels_over_the_shutter_makes_the_ramp_of_the_card_moving_v_pixels() {
    let width = 128;
    let pixel = f64::from(APERTURE) / f64::from(width) * f64::from(DISTANCE / FOCAL);
    for v in [4u32, 9, 16] {
        let d = f64::from(v) * pixel;
        let mut card = ramp_scene(Some(sliding(&[(-0.5, -0.5 * d), (0.5, 0.5 * d)])), [-0.5, 0.5]);
        card.meshes[0].positions.iter_mut().for_each(|p| p.x += (0.5 * d) as f32);
        // The card stands where the moving one is at the frame; the camera starts `d/2` to its
        // right (the edge at the image centre) and ends `d/2` to the left.
        let mut camera = ramp_scene(None, [-0.5, 0.5]);
        camera.meshes[0].positions.iter_mut().for_each(|p| p.x += (0.5 * d) as f32);
        camera.cameras[0].motion = camera_sliding(&[(-0.5, 0.5 * d), (0.0, 0.0), (0.5, -0.5 * d)]);
        for integrator in [Integrator::Wavefront, Integrator::Scalar] {
            let o = RenderOptions { integrator, ..options(width, 256) };
            let (moved, still) = (render(&card, &o), render(&camera, &o));
            let (card_ramp, _) = ramp(&moved, 64, v);
            let (measured, worst) = ramp(&still, 64, v);
            eprintln!("v {v} px, {integrator:?}: camera ramp {measured:.3} px, card ramp {card_ramp:.3} px, worst deviation {worst:.4}");
            assert!((measured - f64::from(v)).abs() <= 1.0, "v {v}: ramp {measured} px wide");
            assert!((measured - card_ramp).abs() <= 1.0, "v {v}: {measured} against the card's {card_ramp}");
            assert!(worst < 0.04, "v {v}: the ramp is linear within 4 % (sampling noise), worst {worst}");
        }
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

#[test]
fn a_moving_camera_with_a_closed_shutter_or_no_motion_blur_gives_the_still_image() {
    let o = options(64, 16);
    let still = render(&ramp_scene(None, [0.0, 0.0]), &o);
    let moving = |shutter| {
        let mut scene = ramp_scene(None, shutter);
        // Keys that do not pass through the identity at 0 except the frame key itself.
        scene.cameras[0].motion = camera_sliding(&[(-0.5, 2.0), (0.0, 0.0), (0.25, 0.7), (0.5, -3.0)]);
        scene
    };
    for (scene, options, what) in [
        (moving([0.0, 0.0]), o.clone(), "closed shutter"),
        (moving([-0.5, 0.5]), RenderOptions { motion_blur: false, ..o.clone() }, "--no-motion-blur"),
        (moving([-0.5, 0.5]), RenderOptions { shutter: Some([0.0, 0.0]), ..o.clone() }, "--shutter 0,0"),
    ] {
        for integrator in [Integrator::Wavefront, Integrator::Scalar] {
            let image = render(&scene, &RenderOptions { integrator, ..options.clone() });
            assert_eq!(differing(&image, &still), 0, "{what}, {integrator:?}: pixels unlike the still image");
        }
    }
    // Closed at a key's time: the camera stands exactly there (the card moved the other way).
    let held = render(&moving([0.5, 0.5]), &o);
    let mut shifted = ramp_scene(None, [0.0, 0.0]);
    shifted.meshes[0].positions.iter_mut().for_each(|p| p.x += 3.0);
    shifted.cameras[0].world_from_camera = glam::Mat4::IDENTITY;
    let shifted = render(&shifted, &o);
    let blurred = render(&moving([-0.5, 0.5]), &o);
    assert!(
        differing(&blurred, &still) >= 8 * 4,
        "the open shutter blurs (a ramp of about 8 px on each of the 8 rows)"
    );
    assert!(differing(&held, &still) >= 8, "the camera closed at 0.5 stands 3 units to the left");
    let mean_diff = held.beauty.iter().zip(&shifted.beauty).map(|(a, b)| (a[0] - b[0]).abs()).sum::<f32>()
        / held.beauty.len() as f32;
    assert!(mean_diff < 0.05, "camera at -3 against the card at +3: mean difference {mean_diff}");
}

/// The half-plane's points at the keys `(time, x shift)`: a deformation, not a transform.
fn deforming(mesh: &Mesh, keys: &[(f32, f32)]) -> Option<scene_pack::Deformation> {
    let keys = keys
        .iter()
        .map(|&(time, dx)| scene_pack::DeformKey {
            time,
            positions: mesh.positions.iter().map(|p| *p + Vec3::X * dx).collect(),
        })
        .collect();
    Some(scene_pack::Deformation { keys })
}

/// A deforming card (its points, not its transform, move `v` pixels over the shutter) makes the
/// moving card's ramp; at the frame it is the still card.
#[test]
fn a_deforming_card_moving_v_pixels_over_the_shutter_makes_a_linear_ramp_v_pixels_wide() {
    let width = 128;
    let pixel = f64::from(APERTURE) / f64::from(width) * f64::from(DISTANCE / FOCAL);
    for v in [4u32, 9, 16] {
        let d = f64::from(v) * pixel;
        let mut moved = ramp_scene(Some(sliding(&[(-0.5, -0.5 * d), (0.5, 0.5 * d)])), [-0.5, 0.5]);
        moved.meshes[0].positions.iter_mut().for_each(|p| p.x += (0.5 * d) as f32);
        let mut deformed = ramp_scene(None, [-0.5, 0.5]);
        deformed.meshes[0].positions.iter_mut().for_each(|p| p.x += (0.5 * d) as f32);
        let h = (0.5 * d) as f32;
        deformed.meshes[0].deformation = deforming(&deformed.meshes[0], &[(-0.5, -h), (0.0, 0.0), (0.5, h)]);
        let data = testscene::pack(&deformed);
        assert_eq!((data.deform.motions.len(), data.deform.times.len()), (1, 3));
        assert!(
            data.bvh_blocks.iter().all(|b| b.triangles.iter().all(|&t| t >= 2)),
            "the card is not in the world BVH"
        );
        for integrator in [Integrator::Wavefront, Integrator::Scalar] {
            let o = RenderOptions { integrator, ..options(width, 256) };
            let (card, image) = (render(&moved, &o), render(&deformed, &o));
            let (card_ramp, _) = ramp(&card, 64, v);
            let (measured, worst) = ramp(&image, 64, v);
            eprintln!("v {v} px, {integrator:?}: deformation ramp {measured:.3} px, transform ramp {card_ramp:.3} px, worst deviation {worst:.4}");
            assert!((measured - f64::from(v)).abs() <= 1.0, "v {v}: ramp {measured} px wide");
            assert!((measured - card_ramp).abs() <= 1.0, "v {v}: {measured} against {card_ramp}");
            assert!(worst < 0.04, "v {v}: the ramp is linear within 4 % (sampling noise), worst {worst}");
        }
    }
    // Closed shutter, `--no-motion-blur`: the stored (frame) points, the still image's bytes.
    let o = options(64, 16);
    let still = render(&ramp_scene(None, [0.0, 0.0]), &o);
    for (shutter, options, what) in [
        ([0.0, 0.0], o.clone(), "closed shutter"),
        ([-0.5, 0.5], RenderOptions { motion_blur: false, ..o.clone() }, "--no-motion-blur"),
    ] {
        let mut scene = ramp_scene(None, shutter);
        scene.meshes[0].deformation =
            deforming(&scene.meshes[0], &[(-0.5, -3.0), (0.0, 0.0), (0.3, 1.0), (0.5, 3.0)]);
        for integrator in [Integrator::Wavefront, Integrator::Scalar] {
            let image = render(&scene, &RenderOptions { integrator, ..options.clone() });
            assert_eq!(differing(&image, &still), 0, "{what}, {integrator:?}: pixels unlike the still image");
        }
    }
}

#[test]
fn deformation_keys_that_do_not_match_the_mesh_are_refused_by_the_packer() {
    let mut scene = ramp_scene(None, [-0.5, 0.5]);
    let mut deformation = deforming(&scene.meshes[0], &[(-0.5, -1.0), (0.5, 1.0)]).unwrap();
    deformation.keys[1].positions.pop();
    scene.meshes[0].deformation = Some(deformation);
    let err = scene_pack::pack::pack(&scene).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!("{}: deformation key at time 0.5 has 3 points for the mesh's 4", scene.meshes[0].path)
    );
}

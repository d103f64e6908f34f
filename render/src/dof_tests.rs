//! Depth of field end to end: scenes built in code with a thin-lens camera, rendered by both
//! integrators, measured against the thin-lens geometry.
//!
//! The camera looks down −Z from the origin with `focalLength` 50 (tenths of a unit: 5 units) on a
//! 20-wide square aperture, so one pixel of a `W`-wide image spans `20 / W` aperture units. A point at
//! distance `d` seen through an aperture of diameter `A = 0.1 · focalLength / fStop`, focused at
//! `d_f`, spreads into a disc of diameter `A · focalLength · |1/d_f − 1/d|` aperture units on the film
//! (the field of view fixed by `focalLength`, see [`crate::camera`]); that is the expected circle of
//! confusion in pixels, times `W / 20`.

use crate::testscene::{self, camera_looking_down_z, card, lambert};
use crate::{render_image, Image, Integrator, RenderOptions};
use glam::Vec3;
use scene_pack::{Lens, Material, Mesh, Scene};

const FOCAL: f32 = 50.0;
const APERTURE: f32 = 20.0;

fn emitter() -> Material {
    Material { emissive_color: Vec3::splat(10.0), ..lambert(0.0) }
}

/// A camera at the origin looking down −Z through `lens`.
fn scene_with(meshes: Vec<Mesh>, lens: Lens) -> Scene {
    let mut camera = camera_looking_down_z(Vec3::ZERO, FOCAL);
    camera.lens = lens;
    Scene {
        meshes,
        materials: vec![emitter()],
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

fn options(res: u32, spp: u32) -> RenderOptions {
    RenderOptions { spp, resolution: Some([res, res]), threads: 2, max_depth: 1, ..RenderOptions::default() }
}

fn luminance(image: &Image, x: u32, y: u32) -> f64 {
    let [r, g, b] = image.rgb(x, y);
    f64::from(r + g + b) / 3.0
}

/// The expected circle of confusion, in pixels of a `width`-wide image, of a point at `distance`.
fn circle_of_confusion(f_stop: f32, focus: f32, distance: f32, width: u32) -> f64 {
    let diameter = 0.1 * f64::from(FOCAL) / f64::from(f_stop);
    let on_film = diameter * f64::from(FOCAL) * (1.0 / f64::from(focus) - 1.0 / f64::from(distance)).abs();
    on_film * f64::from(width) / f64::from(APERTURE)
}

/// A small emissive square (half-size `half`) at `distance`, facing the camera.
fn point_like(distance: f32, half: f32) -> Mesh {
    card(-distance, half, 0)
}

/// The diameter of the disc an out-of-focus emitter makes, from the image's second moment: a uniform
/// disc of radius `R` has `⟨r²⟩ = R²/2` (a regular `n`-gon of circumradius `R`:
/// `R²(2 + cos(2π/n))/6`, `shape` is that factor over `R²`); the emitter's own square image (side
/// `s` pixels) adds `s²/6`, and reading each sample at its pixel's centre removes the `1/6` px² a
/// uniform position inside a pixel has (total variance). Also returns the number of lit pixels.
fn disc_diameter(image: &Image, emitter_side: f64, shape: f64) -> (f64, usize) {
    let (mut sum, mut sx, mut sy, mut lit) = (0.0, 0.0, 0.0, 0);
    for y in 0..image.height {
        for x in 0..image.width {
            let l = luminance(image, x, y);
            sum += l;
            sx += l * (f64::from(x) + 0.5);
            sy += l * (f64::from(y) + 0.5);
            lit += usize::from(l > 0.0);
        }
    }
    let (cx, cy) = (sx / sum, sy / sum);
    let mut moment = 0.0;
    for y in 0..image.height {
        for x in 0..image.width {
            let (dx, dy) = (f64::from(x) + 0.5 - cx, f64::from(y) + 0.5 - cy);
            moment += luminance(image, x, y) * (dx * dx + dy * dy);
        }
    }
    let r2 = moment / sum - emitter_side * emitter_side / 6.0 + 1.0 / 6.0;
    (2.0 * (r2 / shape).sqrt(), lit)
}

const DISC: f64 = 0.5;

/// The side in pixels of the pinhole image of a square of half-size `half` at `distance`.
fn image_side(half: f32, distance: f32, width: u32) -> f64 {
    f64::from(2.0 * half * FOCAL / distance) * f64::from(width) / f64::from(APERTURE)
}

#[test]
fn an_out_of_focus_point_makes_the_thin_lens_circle_of_confusion() {
    let (width, f_stop, focus, distance, half) = (128, 1.4, 100.0, 30.0, 0.2);
    let lens = Lens { f_stop, focus_distance: focus, ..Lens::default() };
    let image = render(&scene_with(vec![point_like(distance, half)], lens), &options(width, 256));
    let side = image_side(half, distance, width);
    let expected = circle_of_confusion(f_stop, focus, distance, width);
    let (measured, lit) = disc_diameter(&image, side, DISC);
    eprintln!(
        "circle of confusion: measured {measured:.3} px, expected {expected:.3} px ({:+.2} %), {lit} lit pixels, emitter {side:.2} px",
        (measured / expected - 1.0) * 100.0
    );
    assert!((measured / expected - 1.0).abs() < 0.02, "measured {measured} px vs expected {expected} px");
    // The disc is filled: the lit pixels cover about the area of the disc grown by the emitter.
    let area = std::f64::consts::PI / 4.0 * (expected + side).powi(2);
    assert!(
        (lit as f64) > 0.85 * area && (lit as f64) < 1.15 * area,
        "{lit} lit pixels for a disc of {area:.0}"
    );

    // Behind the focus plane the disc follows the same |1/d_f − 1/d| law.
    let (f_stop, distance, half) = (0.7, 500.0, 2.0);
    let far = Lens { f_stop, ..lens };
    let image = render(&scene_with(vec![point_like(distance, half)], far), &options(width, 256));
    let side = image_side(half, distance, width);
    let expected = circle_of_confusion(f_stop, focus, distance, width);
    let (measured, _) = disc_diameter(&image, side, DISC);
    eprintln!(
        "behind focus: measured {measured:.3} px, expected {expected:.3} px ({:+.2} %)",
        (measured / expected - 1.0) * 100.0
    );
    assert!((measured / expected - 1.0).abs() < 0.02, "measured {measured} px vs expected {expected} px");

    // A hexagonal aperture: a hexagon whose corners lie on the circle of confusion.
    let (distance, half) = (30.0, 0.2);
    let hexagon = Lens { aperture_blades: 6, aperture_rotation: 30.0, ..lens };
    let image = render(&scene_with(vec![point_like(distance, half)], hexagon), &options(width, 256));
    let side = image_side(half, distance, width);
    let expected = circle_of_confusion(lens.f_stop, focus, distance, width);
    let shape = (2.0 + (std::f64::consts::TAU / 6.0).cos()) / 6.0;
    let (measured, lit) = disc_diameter(&image, side, shape);
    eprintln!(
        "hexagon: measured corner-to-corner {measured:.3} px, expected {expected:.3} px ({:+.2} %), {lit} lit pixels",
        (measured / expected - 1.0) * 100.0
    );
    assert!((measured / expected - 1.0).abs() < 0.02, "measured {measured} px vs expected {expected} px");
    // A hexagon covers 3√3/(2π) = 83 % of its circle.
    let area = 1.5 * 3f64.sqrt() * (expected / 2.0).powi(2);
    assert!(
        (lit as f64) < 0.97 * std::f64::consts::PI / 4.0 * (expected + side).powi(2),
        "{lit} vs hexagon {area:.0}"
    );

    // The pinhole renders the emitter at its own size.
    let pinhole = render(&scene_with(vec![point_like(distance, half)], Lens::default()), &options(width, 64));
    let (_, lit) = disc_diameter(&pinhole, 0.0, DISC);
    assert!(
        lit as f64 <= (side + 2.0).powi(2),
        "{lit} pixels lit by a {side:.1} px emitter through a pinhole"
    );
}

/// An emissive half-plane whose vertical edge is at `edge_x` on the plane `z = −distance`.
fn half_plane(distance: f32, edge_x: f32) -> Mesh {
    let mut mesh = card(-distance, 1.0, 0);
    let (x0, x1, y) = (edge_x, edge_x + 1000.0, 1000.0);
    mesh.positions = [[x0, -y], [x1, -y], [x1, y], [x0, y]].map(|[x, y]| Vec3::new(x, y, -distance)).to_vec();
    mesh
}

/// The mean number of pixels per row whose value lies strictly between 2 % and 98 % of the lit
/// side's: the edge's width in pixels.
fn edge_width(image: &Image) -> f64 {
    let plateau = luminance(image, image.width - 1, image.height / 2);
    let mut transitional = 0usize;
    for y in 0..image.height {
        for x in 0..image.width {
            let v = luminance(image, x, y) / plateau;
            transitional += usize::from(v > 0.02 && v < 0.98);
        }
    }
    transitional as f64 / f64::from(image.height)
}

#[test]
fn an_edge_at_the_focus_distance_stays_sharp() {
    let (width, focus) = (128, 100.0);
    let lens = Lens { f_stop: 1.4, focus_distance: focus, ..Lens::default() };
    // The edge through the middle of pixel column 64: 0.5 px past the image centre.
    let edge = 0.5 * APERTURE / width as f32 * focus / FOCAL;
    let image = render(&scene_with(vec![half_plane(focus, edge)], lens), &options(width, 64));
    let sharp = edge_width(&image);
    let mid = luminance(&image, 64, 64) / luminance(&image, 127, 64);
    eprintln!("edge at the focus distance: {sharp:.3} px wide, the edge pixel at {mid:.3} of the plateau");
    assert!(sharp <= 1.0, "edge {sharp} px wide");
    assert!((mid - 0.5).abs() < 0.05, "the edge pixel is half covered: {mid}");
    // The same edge nearer than the focus plane blurs over its circle of confusion.
    let near = 60.0;
    let edge = 0.5 * APERTURE / width as f32 * near / FOCAL;
    let blurred = edge_width(&render(&scene_with(vec![half_plane(near, edge)], lens), &options(width, 64)));
    let coc = circle_of_confusion(1.4, focus, near, width);
    eprintln!("edge at {near}: {blurred:.2} px wide, circle of confusion {coc:.2} px");
    assert!(blurred > 0.8 * coc && blurred < coc + 1.0, "edge {blurred} px vs circle of confusion {coc} px");
}

#[test]
fn a_pinhole_and_no_dof_give_the_images_without_a_lens() {
    let meshes = vec![point_like(30.0, 0.2), half_plane(100.0, 0.3)];
    let o = options(48, 8);
    let pinhole = render(&scene_with(meshes.clone(), Lens::default()), &o);
    let lens = Lens { f_stop: 2.0, focus_distance: 100.0, aperture_blades: 5, aperture_rotation: 10.0 };
    let with_lens = scene_with(meshes.clone(), lens);
    let bits = |i: &Image| i.beauty.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<u32>>();
    for integrator in [Integrator::Wavefront, Integrator::Scalar] {
        let o = RenderOptions { integrator, ..o.clone() };
        assert_eq!(bits(&render(&scene_with(meshes.clone(), Lens::default()), &o)), bits(&pinhole));
        let no_dof = render(&with_lens, &RenderOptions { depth_of_field: false, ..o.clone() });
        assert_eq!(bits(&no_dof), bits(&pinhole), "--no-dof is the pinhole, {integrator:?}");
        assert_eq!(no_dof.depth, pinhole.depth);
        assert_ne!(bits(&render(&with_lens, &o)), bits(&pinhole), "the lens changes the image");
    }
    // An orthographic camera with an f-stop (a hand-made blob: ingest stores it as a pinhole) stays sharp.
    let mut ortho = scene_with(meshes.clone(), lens);
    ortho.cameras[0].orthographic = true;
    let mut ortho_pinhole = ortho.clone();
    ortho_pinhole.cameras[0].lens = Lens::default();
    assert_eq!(bits(&render(&ortho, &o)), bits(&render(&ortho_pinhole, &o)));
}

#[test]
fn wavefront_equals_scalar_with_depth_of_field() {
    for (lens, what) in [
        (Lens { f_stop: 1.8, focus_distance: 4.0, ..Lens::default() }, "depth of field, round aperture"),
        (
            Lens { f_stop: 2.8, focus_distance: 3.2, aperture_blades: 6, aperture_rotation: 20.0 },
            "depth of field, hexagonal aperture",
        ),
    ] {
        let mut scene = crate::wavefront::equivalence_tests::scene();
        for camera in &mut scene.cameras {
            camera.lens = lens;
        }
        let bytes = testscene::bytes(&scene);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let options = crate::wavefront::equivalence_tests::options();
        let (scalar, _) = crate::wavefront::equivalence_tests::both_integrators(&view, &options, what);
        let pinhole = render(&crate::wavefront::equivalence_tests::scene(), &options);
        let changed = scalar.beauty.iter().zip(&pinhole.beauty).filter(|(a, b)| a != b).count();
        assert!(changed > scalar.beauty.len() / 2, "{what}: the lens changed only {changed} pixels");
    }
}

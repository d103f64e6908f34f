//! The render camera reduced to what dicing and curve splitting need ([`DicingCamera`]): world
//! lengths to pixels at the render resolution, and the view frustum as world-space planes.
//!
//! Ingest dices subdivision surfaces against it (ingest's `dicing` module, which re-exports it);
//! [`crate::pack::curves`] splits curves against it. It lives here, beside the packer, because
//! curve splitting is part of packing and must not pull in OpenSubdiv.

use glam::{DMat4, DVec3, DVec4};

use crate::scene::Camera;

/// Image width `render` uses when RenderSettings authors no resolution.
pub const DEFAULT_WIDTH: u32 = 512;

/// How world lengths become pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Projection {
    /// Pixels per world unit at unit distance: `focal_length / horizontal_aperture × width`.
    Perspective { focal_px: f64 },
    /// Pixels per world unit anywhere: `width / (horizontal_aperture / 10)` (apertures are in
    /// tenths of a scene unit).
    Orthographic { px_per_unit: f64 },
}

/// The render camera, reduced to what dicing needs.
#[derive(Clone, Debug, PartialEq)]
pub struct DicingCamera {
    /// Image size in pixels.
    resolution: [u32; 2],
    camera_from_world: DMat4,
    eye: DVec3,
    near: f64,
    projection: Projection,
    /// The image window `[x_min, x_max, y_min, y_max]`: at unit distance in front of the camera
    /// (perspective) or in camera-space units (orthographic).
    window: [f64; 4],
    /// The view frustum's sides (behind the camera, then left, right, bottom, top of the image)
    /// as world-space planes `n·x + d` (`xyz` = n, `w` = d), negative outside.
    world_planes: [DVec4; 5],
}

impl DicingCamera {
    /// The camera rendered at `resolution` (`None`: [`DEFAULT_WIDTH`] wide at the aperture's
    /// aspect, as `render` does).
    pub fn new(camera: &Camera, resolution: Option<[u32; 2]>) -> Self {
        let world_from_camera = camera.world_from_camera.as_dmat4();
        let h_ap = f64::from(camera.horizontal_aperture).max(1e-6);
        let v_ap = f64::from(camera.vertical_aperture).max(1e-6);
        let [width, height] = resolution.unwrap_or_else(|| {
            [DEFAULT_WIDTH, ((f64::from(DEFAULT_WIDTH) * v_ap / h_ap).round() as u32).max(1)]
        });
        let resolution = [width.max(1), height.max(1)];
        let (width, height) = (f64::from(resolution[0]), f64::from(resolution[1]));
        // The horizontal aperture spans the image width; the vertical extent follows the image
        // aspect, as in `render`.
        let half_w = h_ap / 2.0;
        let half_h = half_w * height / width;
        let (off_x, off_y) =
            (f64::from(camera.horizontal_aperture_offset), f64::from(camera.vertical_aperture_offset));
        let film = [off_x - half_w, off_x + half_w, off_y - half_h, off_y + half_h];
        let (projection, window) = if camera.orthographic {
            (Projection::Orthographic { px_per_unit: width / (h_ap / 10.0) }, film.map(|v| v / 10.0))
        } else {
            let focal = f64::from(camera.focal_length).max(1e-6);
            (Projection::Perspective { focal_px: focal / h_ap * width }, film.map(|v| v / focal))
        };
        let camera_from_world = world_from_camera.inverse();
        DicingCamera {
            resolution,
            camera_from_world,
            eye: world_from_camera.transform_point3(DVec3::ZERO),
            near: f64::from(camera.clipping_range[0]).max(1e-6),
            projection,
            window,
            world_planes: frustum_planes(camera.orthographic, window, camera_from_world),
        }
    }

    /// The camera `render` uses for a blob without one: 45° horizontal field of view, the world
    /// box `lo..hi`'s bounding sphere fit in view from +Z (from −Y for a Z-up stage), at
    /// [`DEFAULT_WIDTH`] × [`DEFAULT_WIDTH`] (`render::camera::Camera::framing`).
    pub fn framing(lo: DVec3, hi: DVec3, z_up: bool) -> Self {
        let (centre, radius) = ((lo + hi) / 2.0, ((hi - lo).length() / 2.0).max(1e-3));
        let half_fov = 22.5f64.to_radians();
        let distance = radius / half_fov.sin() * 1.05;
        let (eye, x, y, z) = if z_up {
            (centre - DVec3::Y * distance, DVec3::X, DVec3::Z, -DVec3::Y)
        } else {
            (centre + DVec3::Z * distance, DVec3::X, DVec3::Y, DVec3::Z)
        };
        let world_from_camera =
            DMat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), eye.extend(1.0));
        let camera = Camera {
            path: String::new(),
            world_from_camera: world_from_camera.as_mat4(),
            orthographic: false,
            focal_length: (18.0 / half_fov.tan()) as f32,
            horizontal_aperture: 36.0,
            vertical_aperture: 36.0,
            horizontal_aperture_offset: 0.0,
            vertical_aperture_offset: 0.0,
            // No clipping in `render`; the near distance only bounds the projection.
            clipping_range: [(distance * 1e-3) as f32, f32::MAX],
            lens: Default::default(),
            shutter: [0.0; 2],
            motion: None,
        };
        DicingCamera::new(&camera, Some([DEFAULT_WIDTH, DEFAULT_WIDTH]))
    }

    /// Image size in pixels.
    pub fn resolution(&self) -> [u32; 2] {
        self.resolution
    }

    /// The most triangles worth dicing one mesh into at `rate_px`: `2·W·H / rate²`.
    pub fn triangle_budget(&self, rate_px: f32) -> u64 {
        let pixels = f64::from(self.resolution[0]) * f64::from(self.resolution[1]);
        (2.0 * pixels / f64::from(rate_px).powi(2).max(1e-6)).min(u64::MAX as f64) as u64
    }

    /// Whether the world box `lo..hi` lies wholly outside the view frustum (behind the camera or
    /// beyond one side of the image). Conservative: a box straddling the frustum's corner
    /// planes counts as visible.
    pub fn outside(&self, lo: DVec3, hi: DVec3) -> bool {
        // A box is wholly outside a plane when its corner furthest along the normal is: per axis,
        // `hi` where the normal is positive, `lo` elsewhere. (Run per cage face by adaptive
        // dicing: transforming the eight corners to camera space instead was 4 % of a listing.)
        self.world_planes.iter().any(|plane| {
            let n = plane.truncate();
            let furthest = DVec3::select(n.cmpge(DVec3::ZERO), hi, lo);
            n.dot(furthest) + plane.w < 0.0
        })
    }

    /// Whether the world box `lo..hi` lies wholly inside the view frustum: its corner nearest
    /// each side is on the inner side.
    pub fn inside(&self, lo: DVec3, hi: DVec3) -> bool {
        self.world_planes.iter().all(|plane| {
            let n = plane.truncate();
            let nearest = DVec3::select(n.cmpge(DVec3::ZERO), lo, hi);
            n.dot(nearest) + plane.w >= 0.0
        })
    }

    /// [`DicingCamera::segment_pixels`] of every edge (vertex pairs into `points`), with each
    /// point's depth computed once rather than once per edge; the same values.
    pub fn edge_pixels(&self, points: &[DVec3], edges: &[[u32; 2]]) -> Vec<f64> {
        let length = |[a, b]: [u32; 2]| points[a as usize].distance(points[b as usize]);
        match self.projection {
            Projection::Orthographic { px_per_unit } => {
                edges.iter().map(|&e| length(e) * px_per_unit).collect()
            }
            Projection::Perspective { focal_px } => {
                let depth: Vec<f64> =
                    points.iter().map(|&p| -self.camera_from_world.transform_point3(p).z).collect();
                edges
                    .iter()
                    .map(|&e| {
                        let [a, b] = e.map(|v| depth[v as usize]);
                        length(e) * focal_px / a.min(b).max(self.near)
                    })
                    .collect()
            }
        }
    }

    /// Conservative on-screen length, in pixels, of a world length `length` anywhere in the world
    /// box `lo..hi`.
    pub fn pixels(&self, length: f64, lo: DVec3, hi: DVec3) -> f64 {
        match self.projection {
            Projection::Orthographic { px_per_unit } => length * px_per_unit,
            Projection::Perspective { focal_px } => {
                let nearest = self.eye.clamp(lo, hi);
                length * focal_px / self.eye.distance(nearest).max(self.near)
            }
        }
    }

    /// On-screen length, in pixels, of the world segment `a`–`b` if it lay parallel to the
    /// image at its nearest depth: `|a − b| · focal_px / min depth` (at least the near
    /// distance). The perspective scale of a point is set by its depth, not its distance: at the
    /// corner of a 53° view the distance overstates the depth by 22 %, and the segments of a
    /// rate chosen from the distance came out 2.2 px long for a 2 px rate.
    pub fn segment_pixels(&self, a: DVec3, b: DVec3) -> f64 {
        let length = a.distance(b);
        match self.projection {
            Projection::Orthographic { px_per_unit } => length * px_per_unit,
            Projection::Perspective { focal_px } => {
                let depth = |p: DVec3| -self.camera_from_world.transform_point3(p).z;
                length * focal_px / depth(a).min(depth(b)).max(self.near)
            }
        }
    }

    /// Pixels per world unit at world point `p` (for error measurements): perspective scale at
    /// its depth (at least the near distance).
    pub fn pixels_per_unit_at(&self, p: DVec3) -> f64 {
        match self.projection {
            Projection::Orthographic { px_per_unit } => px_per_unit,
            Projection::Perspective { focal_px } => {
                let depth = -self.camera_from_world.transform_point3(p).z;
                focal_px / depth.max(self.near)
            }
        }
    }
}

/// The sides of the view frustum as world-space planes, negative outside (see
/// [`DicingCamera::outside`]). In camera space (looking down −Z) each side is `a·p + b`:
/// perspective sides pass through the eye (`window` is at unit depth), orthographic ones are
/// offset by the window; `p = L·x + t` makes it `(Lᵀa)·x + (a·t + b)` in world space.
fn frustum_planes(orthographic: bool, window: [f64; 4], camera_from_world: DMat4) -> [DVec4; 5] {
    let [x_min, x_max, y_min, y_max] = window;
    let camera_space: [(DVec3, f64); 5] = if orthographic {
        [
            (DVec3::NEG_Z, 0.0),
            (DVec3::X, -x_min),
            (DVec3::NEG_X, x_max),
            (DVec3::Y, -y_min),
            (DVec3::NEG_Y, y_max),
        ]
    } else {
        [
            (DVec3::NEG_Z, 0.0),
            (DVec3::new(1.0, 0.0, x_min), 0.0),
            (DVec3::new(-1.0, 0.0, -x_max), 0.0),
            (DVec3::new(0.0, 1.0, y_min), 0.0),
            (DVec3::new(0.0, -1.0, -y_max), 0.0),
        ]
    };
    let linear = glam::DMat3::from_mat4(camera_from_world);
    let offset = camera_from_world.w_axis.truncate();
    camera_space.map(|(a, b)| (linear.transpose() * a).extend(a.dot(offset) + b))
}

/// Test support, shared by these tests and ingest's dicing tests (ingest depends on this crate;
/// a `cfg(test)` item would not be visible there): a 36 mm lens on 36 mm square film (half-angle
/// atan 0.5 ≈ 26.6°) at `eye`, looking down −Z, clipping 0.1 to 1000.
#[doc(hidden)]
pub fn test_camera(eye: glam::Vec3, orthographic: bool) -> Camera {
    Camera {
        path: "/Cam".into(),
        world_from_camera: glam::Mat4::from_translation(eye),
        orthographic,
        focal_length: 36.0,
        horizontal_aperture: 36.0,
        vertical_aperture: 36.0,
        horizontal_aperture_offset: 0.0,
        vertical_aperture_offset: 0.0,
        clipping_range: [0.1, 1000.0],
        lens: Default::default(),
        shutter: [0.0; 2],
        motion: None,
    }
}

#[cfg(test)]
mod tests {
    use super::test_camera as camera;
    use super::*;
    use glam::{Mat4, Vec3};

    #[test]
    fn segment_pixels_use_depth() {
        let cam = DicingCamera::new(&camera(Vec3::ZERO, false), Some([1000, 1000]));
        // A unit segment 10 deep is 100 px on the axis and at the edge of the view alike.
        let px = |a: [f64; 3], b: [f64; 3]| cam.segment_pixels(DVec3::from(a), DVec3::from(b));
        assert!((px([0.0, 0.0, -10.0], [1.0, 0.0, -10.0]) - 100.0).abs() < 1e-9);
        assert!((px([4.0, 4.0, -10.0], [4.0, 5.0, -10.0]) - 100.0).abs() < 1e-9);
        // Receding: the nearer end's depth; behind the camera: the near distance (0.1).
        assert!((px([0.0, 0.0, -10.0], [0.0, 0.0, -20.0]) - 1000.0).abs() < 1e-9);
        assert!((px([0.0, 0.0, 5.0], [1.0, 0.0, 5.0]) / 10_000.0 - 1.0).abs() < 1e-6);
        let ortho = DicingCamera::new(&camera(Vec3::ZERO, true), Some([1000, 1000]));
        assert!((ortho.segment_pixels(DVec3::ZERO, DVec3::X) - 1000.0 / 3.6).abs() < 1e-9);
    }

    /// The definition [`DicingCamera::outside`] computes with world planes: some side of the
    /// frustum has all eight corners, in camera space, outside.
    fn outside_by_corners(cam: &DicingCamera, lo: DVec3, hi: DVec3) -> bool {
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            let p = DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
            cam.camera_from_world.transform_point3(p)
        });
        let [x_min, x_max, y_min, y_max] = cam.window;
        let planes: [&dyn Fn(DVec3) -> f64; 5] = match cam.projection {
            Projection::Perspective { .. } => {
                [&|p| -p.z, &|p| p.x + x_min * p.z, &|p| -x_max * p.z - p.x, &|p| p.y + y_min * p.z, &|p| {
                    -y_max * p.z - p.y
                }]
            }
            Projection::Orthographic { .. } => {
                [&|p| -p.z, &|p| p.x - x_min, &|p| x_max - p.x, &|p| p.y - y_min, &|p| y_max - p.y]
            }
        };
        planes.iter().any(|plane| corners.iter().all(|&c| plane(c) < 0.0))
    }

    #[test]
    fn world_frustum_planes_agree_with_the_camera_space_corners() {
        // A rotated, scaled, offset camera with an off-centre window, and random boxes around it.
        let mut c = camera(Vec3::new(1.0, -2.0, 3.0), false);
        c.world_from_camera = Mat4::from_scale_rotation_translation(
            Vec3::splat(1.5),
            glam::Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.2),
            Vec3::new(1.0, -2.0, 3.0),
        );
        c.horizontal_aperture_offset = 4.0;
        c.vertical_aperture = 24.0;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut random = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for orthographic in [false, true] {
            c.orthographic = orthographic;
            let cam = DicingCamera::new(&c, Some([640, 480]));
            let (mut inside, mut outside) = (0, 0);
            for _ in 0..4000 {
                let centre = DVec3::new(random(), random(), random()) * 40.0 - 20.0;
                let half = DVec3::new(random(), random(), random()) * 3.0;
                let (lo, hi) = (centre - half, centre + half);
                let expected = outside_by_corners(&cam, lo, hi);
                assert_eq!(cam.outside(lo, hi), expected, "{lo}..{hi}, orthographic {orthographic}");
                if expected {
                    outside += 1;
                } else {
                    inside += 1;
                }
            }
            assert!(inside > 100 && outside > 100, "{inside} in view, {outside} outside");
        }
    }

    #[test]
    fn edge_pixels_equal_segment_pixels_and_inside_means_no_corner_outside() {
        let mut c = camera(Vec3::new(0.5, 0.2, 1.0), false);
        c.world_from_camera *= Mat4::from_rotation_y(0.4);
        let points: Vec<DVec3> = (0..50)
            .map(|i| DVec3::new((i % 7) as f64 - 3.0, (i % 5) as f64 - 2.0, -(i as f64) * 0.7))
            .collect();
        let edges: Vec<[u32; 2]> = (0..49).map(|i| [i, (i * 17 + 3) % 50]).collect();
        for orthographic in [false, true] {
            c.orthographic = orthographic;
            let cam = DicingCamera::new(&c, Some([300, 200]));
            let expected: Vec<f64> = edges
                .iter()
                .map(|&[a, b]| cam.segment_pixels(points[a as usize], points[b as usize]))
                .collect();
            assert_eq!(cam.edge_pixels(&points, &edges), expected);
            // Inside: every corner in view; a box reaching past a side is not inside.
            for w in points.windows(2) {
                let (lo, hi) = (w[0].min(w[1]), w[0].max(w[1]));
                if cam.inside(lo, hi) {
                    for i in 0..8 {
                        let p = DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
                        assert!(!outside_by_corners(&cam, p, p), "{p} of {lo}..{hi}");
                    }
                }
            }
        }
        let cam = DicingCamera::new(&camera(Vec3::ZERO, false), Some([100, 100]));
        assert!(cam.inside(DVec3::new(-0.5, -0.5, -5.0), DVec3::new(0.5, 0.5, -4.0)));
        assert!(!cam.inside(DVec3::new(-0.5, -0.5, -5.0), DVec3::new(4.0, 0.5, -4.0)));
        assert!(!cam.inside(DVec3::new(-0.5, -0.5, -5.0), DVec3::new(0.5, 0.5, 1.0)));
    }

    #[test]
    fn orthographic_pixels_do_not_depend_on_distance() {
        // A 3.6-unit-wide window over 1000 px.
        let cam = DicingCamera::new(&camera(Vec3::ZERO, true), Some([1000, 1000]));
        let near = cam.pixels(1.0, DVec3::new(0.0, 0.0, -2.0), DVec3::new(0.1, 0.1, -1.0));
        let far = cam.pixels(1.0, DVec3::new(0.0, 0.0, -200.0), DVec3::new(0.1, 0.1, -100.0));
        assert!((near - 1000.0 / 3.6).abs() < 1e-9 && near == far);
        assert!(cam.outside(DVec3::new(2.0, 0.0, -2.0), DVec3::new(3.0, 1.0, -1.0)));
    }

    #[test]
    fn default_resolution_is_512_wide_at_the_aperture_aspect() {
        let mut c = camera(Vec3::ZERO, false);
        c.vertical_aperture = 18.0;
        let cam = DicingCamera::new(&c, None);
        assert_eq!(cam.projection, Projection::Perspective { focal_px: 512.0 });
        assert!((cam.window[3] - 0.25).abs() < 1e-3, "{:?}", cam.window);
    }

    #[test]
    fn framing_camera_sees_the_box() {
        let (lo, hi) = (DVec3::splat(-1.0), DVec3::splat(1.0));
        for z_up in [false, true] {
            let cam = DicingCamera::framing(lo, hi, z_up);
            assert!(!cam.outside(lo, hi));
            assert!(cam.outside(lo + DVec3::X * 10.0, hi + DVec3::X * 10.0));
            let eye = if z_up { -DVec3::Y } else { DVec3::Z };
            assert!((cam.eye.normalize() - eye).length() < 1e-9, "{}", cam.eye);
        }
    }
}

//! Camera rays from UsdGeomCamera parameters.
//!
//! USD cameras look down their local −Z with +Y up; `focalLength` and the apertures share a unit, so only
//! their ratios matter for a perspective camera's framing. An orthographic camera's apertures are in
//! tenths of a scene unit (USD's lens-unit convention). When the image aspect differs from the aperture
//! aspect the horizontal aperture is kept and the vertical one follows the image ("fit horizontal").
//! `clippingRange` is not applied (a path tracer has no near/far plane to honour).
//!
//! Depth of field is a thin lens ([`ThinLens`]) in the camera's XY plane: the ray through film point
//! `x` starts at a point `l` of the aperture and passes through the point the pinhole ray through `x`
//! reaches on the focus plane `z = −focusDistance`, so everything on that plane stays sharp. The
//! aperture radius is `focalLength / (2 · fStop)` with `focalLength` turned into scene units (it is in
//! tenths of one, UsdGeomCamera's lens unit; `metersPerUnit` does not enter, see
//! `ingest::usd::lens`). The field of view stays the one `focalLength` and the apertures define (no
//! focus breathing, as pbrt and Cycles do), so a point at distance `d` spreads into a disc of
//! diameter `2r · focal · |1/focus − 1/d|` on the film, in aperture units. The lens point comes from
//! the sampler's [`crate::sampler::dim::LENS`] pair through a concentric disc map (Shirley and Chiu
//! 1997: strata stay compact) or, for a `ri:apertureNSides` polygon, a sector then a uniform point of
//! its triangle. Orthographic cameras have no lens (ingest stores them as pinholes, and
//! [`Camera::from_blob`] ignores an f-stop on one).
//!
//! Motion blur: each camera ray has a time in the [`Shutter`], drawn from the sampler's
//! [`crate::sampler::dim::TIME`] dimension at vertex 0 and kept by every ray of its path (shadow
//! and continuation rays alike), in both integrators. A closed shutter draws no time sample, so its
//! images keep their numbers.
//!
//! Camera motion: a camera with transform keys (`blob::Camera::motion_key_count`, keys at the
//! shutter's open and close, the frame and the authored samples inside it) is placed, for the ray
//! of time `τ`, by its keys' `world_from_camera` matrices interpolated linearly around `τ` as a
//! moving instance's are ([`crate::accel::instanced::interpolate_rows`]; exactly a key at its
//! time), and the ray, its cone and the cone's axis come from that placement
//! ([`Camera::sample_ray`], the one function both integrators call). With the shutter closed the
//! render uses the camera at the shutter's time as a still camera ([`Camera::at_time`]), so a
//! closed shutter gives a still camera's bytes.
//!
//! [`camera_ray_lanes`] generates eight pinhole rays at once (the wavefront integrator's camera stage)
//! with the scalar film loop's IEEE operations in the same order: [`Camera::generate_ray`],
//! [`Camera::pixel_cone`] of the ray's cosine to the axis, times the footprint scale. There is no pixel
//! filter (the pixel position is a uniform jitter), so no trigonometry is involved; the parts that do
//! not depend on the pixel (a pinhole's origin, an orthographic camera's direction and cone) are
//! computed once by the scalar code. [`lens_ray_lanes`] replaces those rays when the camera has a lens:
//! it calls [`Camera::generate_lens_ray`] per lane, so it equals the scalar loop by construction (its
//! square root and sine per ray are not worth a rewritten twin).

use glam::{Affine3A, Vec3, Vec3A};

/// A camera ready to generate rays for a `width × height` image.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    world_from_camera: Affine3A,
    orthographic: bool,
    /// Film-plane window in camera space at z = −focal: x range and y range.
    window_min: [f32; 2],
    window_size: [f32; 2],
    focal: f32,
    /// Image width in pixels (the window is split into this many pixel steps).
    width: u32,
    /// Depth of field, or `None` for a pinhole.
    lens: Option<ThinLens>,
    /// The blob camera's shutter.
    shutter: Shutter,
    /// Transform keys of a moving camera (`world_from_camera` at each key time), or `None`.
    motion: Option<std::sync::Arc<[blob::MotionKey]>>,
}

/// A shutter interval in time codes from the frame: camera rays get times in `[open, close)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Shutter {
    /// Opening time.
    pub open: f32,
    /// Closing time (equal to `open`: an instantaneous shutter).
    pub close: f32,
}

impl Shutter {
    /// True when the shutter is open for a while (`close > open`): the render has motion blur.
    pub fn is_open(&self) -> bool {
        self.close > self.open
    }

    /// The time of the camera ray of sample `key`: `open + u · (close − open)` with `u` the
    /// sampler's [`crate::sampler::dim::TIME`] at vertex 0; `open` for a closed shutter, which draws
    /// no sample.
    #[inline]
    pub fn time(&self, key: crate::sampler::SampleKey) -> f32 {
        if self.close > self.open {
            let u = crate::sampler::sample_1d(key, 0, crate::sampler::dim::TIME);
            self.open + (self.close - self.open) * u
        } else {
            self.open
        }
    }
}

/// A thin lens in camera space: an aperture of `radius` (round or a regular polygon) at the origin of
/// the camera's XY plane, focused on the plane `z = −focus_distance`. Lengths in scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    /// Aperture radius (a polygon's corners lie on this circle).
    pub radius: f32,
    /// Distance of the plane in focus.
    pub focus_distance: f32,
    /// Blades of a polygonal aperture, or 0 for a round one.
    pub blades: u32,
    /// Angle of the polygon's first corner from the camera's +X, radians.
    pub rotation: f32,
}

impl ThinLens {
    /// The lens of a blob camera, or `None` for a pinhole (`f_stop` 0) or an orthographic camera.
    /// `focal` is the focal length the film loop uses (tenths of a scene unit).
    fn from_blob(cam: &blob::Camera, focal: f32) -> Option<Self> {
        if cam.f_stop <= 0.0 || cam.projection == blob::PROJECTION_ORTHOGRAPHIC {
            return None;
        }
        // `focalLength` is in tenths of a scene unit (UsdGeomCamera); the f-number is focal length
        // over aperture diameter.
        let focal_scene = 0.1 * focal;
        Some(ThinLens {
            radius: focal_scene / (2.0 * cam.f_stop),
            focus_distance: cam.focus_distance,
            blades: cam.aperture_blades,
            rotation: cam.aperture_rotation.to_radians(),
        })
    }

    /// The point of the aperture for the lens sample `u` ∈ [0, 1)², in camera space (z = 0).
    pub fn point(&self, u: [f32; 2]) -> [f32; 2] {
        let [x, y] =
            if self.blades == 0 { concentric_disc(u) } else { polygon(self.blades, self.rotation, u) };
        [x * self.radius, y * self.radius]
    }
}

/// Shirley and Chiu's concentric map of [0, 1)² onto the unit disc: squares of the sample space go
/// to annular sectors, so the sampler's 2D stratification carries over to the lens.
pub fn concentric_disc(u: [f32; 2]) -> [f32; 2] {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (b, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b))
    };
    let (sin, cos) = crate::trig::sin_cos(phi);
    [r * cos, r * sin]
}

/// A uniform point of the regular `blades`-gon inscribed in the unit circle, first corner at angle
/// `rotation`: `u[0]` picks one of its `blades` equal triangles (fan from the centre) and is reused,
/// rescaled, with `u[1]` for a uniform point of that triangle (`√s` along the radius).
fn polygon(blades: u32, rotation: f32, u: [f32; 2]) -> [f32; 2] {
    let n = blades as f32;
    let scaled = u[0] * n;
    let sector = scaled.floor().min(n - 1.0);
    let s = (scaled - sector).clamp(0.0, 1.0).sqrt();
    let step = std::f32::consts::TAU / n;
    let (s0, c0) = crate::trig::sin_cos(rotation + sector * step);
    let (s1, c1) = crate::trig::sin_cos(rotation + (sector + 1.0) * step);
    let t = u[1];
    [s * ((1.0 - t) * c0 + t * c1), s * ((1.0 - t) * s0 + t * s1)]
}

/// A ray cone (Akenine-Möller et al., "Texture Level of Detail Strategies for Real-Time Ray Tracing",
/// Ray Tracing Gems 2019): the width of one pixel's footprint along a ray, `width + spread · t`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayCone {
    /// Footprint width at the ray origin, scene units.
    pub width: f32,
    /// Growth of the width per unit distance (the cone's angle, radians, small-angle).
    pub spread: f32,
}

impl RayCone {
    /// The footprint width at distance `t`.
    #[inline]
    pub fn width_at(&self, t: f32) -> f32 {
        self.width + self.spread * t
    }
}

/// Reads a row-major 3×4 `[[f32; 4]; 3]` affine matrix.
pub fn affine_from_rows(m: &[[f32; 4]; 3]) -> Affine3A {
    Affine3A::from_cols(
        Vec3A::new(m[0][0], m[1][0], m[2][0]),
        Vec3A::new(m[0][1], m[1][1], m[2][1]),
        Vec3A::new(m[0][2], m[1][2], m[2][2]),
        Vec3A::new(m[0][3], m[1][3], m[2][3]),
    )
}

impl Camera {
    /// A camera from a blob record for an image of `width × height` pixels, standing still at
    /// the record's transform (see [`Camera::with_motion`]).
    pub fn from_blob(cam: &blob::Camera, width: u32, height: u32) -> Self {
        let h_ap = if cam.horizontal_aperture > 0.0 { cam.horizontal_aperture } else { 20.955 };
        let v_ap = h_ap * height as f32 / width as f32;
        let orthographic = cam.projection == blob::PROJECTION_ORTHOGRAPHIC;
        // Orthographic apertures are in tenths of a scene unit.
        let scale = if orthographic { 0.1 } else { 1.0 };
        let centre = [cam.horizontal_aperture_offset * scale, cam.vertical_aperture_offset * scale];
        let size = [h_ap * scale, v_ap * scale];
        let focal = if cam.focal_length > 0.0 { cam.focal_length } else { 50.0 };
        Camera {
            world_from_camera: affine_from_rows(&cam.world_from_camera),
            orthographic,
            window_min: [centre[0] - 0.5 * size[0], centre[1] - 0.5 * size[1]],
            window_size: size,
            focal,
            width: width.max(1),
            lens: ThinLens::from_blob(cam, focal),
            shutter: Shutter { open: cam.shutter_open, close: cam.shutter_close },
            motion: None,
        }
    }

    /// Where the world point `p` lands on a `width × height` film, in pixels (x right, y down from
    /// the top-left corner: the raster [`Camera::generate_ray`] reads), seen through the lens
    /// centre; `camera_from_world` is the inverse of this camera's `world_from_camera`
    /// ([`Camera::camera_from_world`], computed once by the caller).
    pub fn raster_from_world(
        &self,
        camera_from_world: &Affine3A,
        p: Vec3,
        width: u32,
        height: u32,
    ) -> [f32; 2] {
        let q = camera_from_world.transform_point3(p);
        let (x, y) =
            if self.orthographic { (q.x, q.y) } else { (-self.focal * q.x / q.z, -self.focal * q.y / q.z) };
        let fx = (x - self.window_min[0]) / self.window_size[0];
        let fy = 1.0 - (y - self.window_min[1]) / self.window_size[1];
        [fx * width as f32, fy * height as f32]
    }

    /// The inverse of `world_from_camera`.
    pub fn camera_from_world(&self) -> Affine3A {
        self.world_from_camera.inverse()
    }

    /// This camera moving through `keys` (validated: 2 or more, times increasing, matrices
    /// invertible); no keys leave it still.
    pub fn with_motion(self, keys: &[blob::MotionKey]) -> Self {
        Camera { motion: (keys.len() >= 2).then(|| keys.into()), ..self }
    }

    /// True when the camera has transform keys.
    pub fn is_moving(&self) -> bool {
        self.motion.is_some()
    }

    /// The camera where it is at time `time`, standing still: its keys interpolated (exactly a
    /// key at that key's time; the end keys held outside them). A still camera is itself.
    pub fn at_time(&self, time: f32) -> Camera {
        let Some(keys) = &self.motion else { return self.clone() };
        let rows = match keys.iter().find(|k| k.time == time) {
            Some(key) => key.world_from_object,
            None => crate::accel::instanced::interpolate_rows(keys, time),
        };
        Camera { world_from_camera: affine_from_rows(&rows), motion: None, ..self.clone() }
    }

    /// The camera ray through film point `film` ∈ [0, 1]² and lens sample `lens_uv` at time `time`
    /// with its pixel cone scaled by `footprint_scale`: for a still camera exactly the film loop's
    /// [`Camera::generate_lens_ray`] and [`Camera::pixel_cone`] of its cosine to `forward` (the
    /// camera's [`Camera::forward`]); a moving camera does the same at [`Camera::at_time`], its
    /// own forward axis then. Both integrators call this for every ray a lens or motion needs.
    pub fn sample_ray(
        &self,
        film: [f32; 2],
        lens_uv: [f32; 2],
        time: f32,
        forward: Vec3,
        footprint_scale: f32,
    ) -> (Vec3, Vec3, RayCone) {
        let ray = |camera: &Camera, forward: Vec3| {
            let (o, d) = camera.generate_lens_ray(film[0], film[1], lens_uv);
            let mut cone = camera.pixel_cone(d.dot(forward));
            cone.width *= footprint_scale;
            cone.spread *= footprint_scale;
            (o, d, cone)
        };
        if self.motion.is_none() {
            return ray(self, forward);
        }
        let placed = self.at_time(time);
        let forward = placed.forward();
        ray(&placed, forward)
    }

    /// The camera's shutter (`shutter:open`, `shutter:close`).
    pub fn shutter(&self) -> Shutter {
        self.shutter
    }

    /// The thin lens, or `None` for a pinhole.
    pub fn lens(&self) -> Option<&ThinLens> {
        self.lens.as_ref()
    }

    /// This camera as a pinhole (`render --no-dof`).
    pub fn without_lens(self) -> Self {
        Camera { lens: None, ..self }
    }

    /// A perspective camera (45° horizontal field of view) framing `bounds` from the +Z side, or from −Y
    /// for a Z-up stage. Used when the blob has no camera.
    pub fn framing(bounds_min: Vec3, bounds_max: Vec3, z_up: bool, width: u32, height: u32) -> Self {
        let (centre, radius) = if bounds_min.cmple(bounds_max).all() {
            (0.5 * (bounds_min + bounds_max), (0.5 * (bounds_max - bounds_min).length()).max(1e-3))
        } else {
            (Vec3::ZERO, 1.0)
        };
        let half_fov = 22.5f32.to_radians();
        let aspect = width as f32 / height as f32;
        // Fit the bounding sphere into the narrower of the two half-angles.
        let half_v = (half_fov.tan() / aspect).atan();
        let distance = radius / half_fov.min(half_v).sin() * 1.05;
        let (eye, x, y, z) = if z_up {
            (centre - Vec3::Y * distance, Vec3::X, Vec3::Z, -Vec3::Y)
        } else {
            (centre + Vec3::Z * distance, Vec3::X, Vec3::Y, Vec3::Z)
        };
        let world_from_camera = Affine3A::from_cols(x.into(), y.into(), z.into(), eye.into());
        let h_ap = 36.0;
        let focal = 0.5 * h_ap / half_fov.tan();
        let v_ap = h_ap / aspect;
        Camera {
            world_from_camera,
            orthographic: false,
            window_min: [-0.5 * h_ap, -0.5 * v_ap],
            window_size: [h_ap, v_ap],
            focal,
            width: width.max(1),
            lens: None,
            shutter: Shutter::default(),
            motion: None,
        }
    }

    /// The cone of one pixel around a camera ray with unit camera-space direction `dir_z` (its −z
    /// component, the cosine to the optical axis): a perspective pixel subtends `pitch · cos / focal`
    /// radians at that angle (`cos²` from the oblique film distance, `1/cos` from the oblique pixel
    /// pitch seen along the ray), an orthographic pixel is a constant width.
    pub fn pixel_cone(&self, cos_to_axis: f32) -> RayCone {
        let pitch = self.window_size[0] / self.width as f32;
        if self.orthographic {
            RayCone { width: pitch, spread: 0.0 }
        } else {
            RayCone { width: 0.0, spread: pitch * cos_to_axis.clamp(0.0, 1.0) / self.focal }
        }
    }

    /// The camera's viewing direction (its −Z) in world space.
    pub fn forward(&self) -> Vec3 {
        Vec3::from(self.world_from_camera.transform_vector3a(Vec3A::NEG_Z)).normalize_or_zero()
    }

    /// The world-space ray through film position (`fx`, `fy`) in [0, 1]², x to the right and y down
    /// (raster order). Returns (origin, unit direction).
    pub fn generate_ray(&self, fx: f32, fy: f32) -> (Vec3, Vec3) {
        let x = self.window_min[0] + fx * self.window_size[0];
        let y = self.window_min[1] + (1.0 - fy) * self.window_size[1];
        let (origin, dir) = if self.orthographic {
            (Vec3A::new(x, y, 0.0), Vec3A::NEG_Z)
        } else {
            (Vec3A::ZERO, Vec3A::new(x, y, -self.focal))
        };
        let o = self.world_from_camera.transform_point3a(origin);
        let d = self.world_from_camera.transform_vector3a(dir).normalize();
        (o.into(), d.into())
    }

    /// [`Camera::generate_ray`] through the lens point of sample `lens_uv` ∈ [0, 1)²: the ray from
    /// that point of the aperture towards where the pinhole ray meets the focus plane. Without a lens,
    /// exactly `generate_ray(fx, fy)` (`lens_uv` unused).
    pub fn generate_lens_ray(&self, fx: f32, fy: f32, lens_uv: [f32; 2]) -> (Vec3, Vec3) {
        let Some(lens) = &self.lens else { return self.generate_ray(fx, fy) };
        let x = self.window_min[0] + fx * self.window_size[0];
        let y = self.window_min[1] + (1.0 - fy) * self.window_size[1];
        // The pinhole direction scaled to reach z = −focus_distance.
        let focus = Vec3A::new(x, y, -self.focal) * (lens.focus_distance / self.focal);
        let [lx, ly] = lens.point(lens_uv);
        let on_lens = Vec3A::new(lx, ly, 0.0);
        let o = self.world_from_camera.transform_point3a(on_lens);
        let d = self.world_from_camera.transform_vector3a(focus - on_lens).normalize();
        (o.into(), d.into())
    }
}

use lanekit::{Lanes, U32Lanes, LANES};

/// What [`camera_ray_lanes`] needs of a camera and an image, constant over a render.
#[derive(Clone, Copy, Debug)]
pub struct CameraLanes {
    orthographic: bool,
    /// Columns of `world_from_camera`'s linear part, then its translation.
    axes: [[f32; 3]; 3],
    translation: [f32; 3],
    /// `axes[2] · (−focal)` (perspective) or `axes[2] · 0` (orthographic): the film plane's z term.
    z_term: [f32; 3],
    window_min: [f32; 2],
    window_size: [f32; 2],
    focal: f32,
    /// Image size in pixels, as the film loop divides by it.
    image: [f32; 2],
    forward: [f32; 3],
    /// Pixel pitch on the film (the cone's numerator).
    pitch: f32,
    footprint_scale: f32,
    /// A pinhole's origin; an orthographic camera's direction and scaled cone.
    fixed_origin: Vec3,
    fixed_dir: Vec3,
    fixed_cone: RayCone,
}

impl CameraLanes {
    /// The constants of `camera` for a `width × height` image, cones scaled by `footprint_scale`
    /// (the render's texture footprint scale); `forward` is [`Camera::forward`].
    pub fn new(camera: &Camera, forward: Vec3, width: u32, height: u32, footprint_scale: f32) -> Self {
        let m = &camera.world_from_camera.matrix3;
        let axes = [m.x_axis.to_array(), m.y_axis.to_array(), m.z_axis.to_array()];
        let z = if camera.orthographic { 0.0 } else { -camera.focal };
        // The same products `transform_vector3a` forms (IEEE multiplication is exact per call).
        let z_term = axes[2].map(|a| a * z);
        let (fixed_origin, fixed_dir) = camera.generate_ray(0.5, 0.5);
        let mut fixed_cone = camera.pixel_cone(fixed_dir.dot(forward));
        fixed_cone.width *= footprint_scale;
        fixed_cone.spread *= footprint_scale;
        CameraLanes {
            orthographic: camera.orthographic,
            axes,
            translation: camera.world_from_camera.translation.to_array(),
            z_term,
            window_min: camera.window_min,
            window_size: camera.window_size,
            focal: camera.focal,
            image: [width as f32, height as f32],
            forward: forward.to_array(),
            pitch: camera.window_size[0] / camera.width as f32,
            footprint_scale,
            fixed_origin,
            fixed_dir,
            fixed_cone,
        }
    }
}

lanekit::soa! {
    /// Eight camera rays, one column per scalar.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct RayLanes for struct CameraRay {
        /// World-space origins.
        pub origin: Vec3 as [f32; 3],
        /// Unit world-space directions.
        pub dir: Vec3 as [f32; 3],
        /// Scaled cone widths at the origin.
        pub cone_width: f32,
        /// Scaled cone spreads.
        pub cone_spread: f32,
    }
}

/// The camera rays through pixels (`x[k]`, `y[k]`) jittered by (`jx[k]`, `jy[k]`) ∈ [0, 1)²: lane
/// `k` equals the film loop's `camera.generate_ray((x + jx) / width, (y + jy) / height)` and its
/// `pixel_cone(d · forward)` scaled by the footprint scale, bit for bit.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn camera_ray_lanes(
    c: &CameraLanes,
    x: &U32Lanes,
    y: &U32Lanes,
    jx: &Lanes,
    jy: &Lanes,
    out: &mut RayLanes,
) {
    // Film-plane position, as `generate_ray` computes it from the film loop's fractions.
    let (mut wx, mut wy) = ([0.0f32; LANES], [0.0f32; LANES]);
    for k in 0..LANES {
        let fx = (x[k] as f32 + jx[k]) / c.image[0];
        let fy = (y[k] as f32 + jy[k]) / c.image[1];
        wx[k] = c.window_min[0] + fx * c.window_size[0];
        wy[k] = c.window_min[1] + (1.0 - fy) * c.window_size[1];
    }
    // `matrix3 · (wx, wy, z)`: glam's `mul_vec3a` sums x, y then z terms.
    let mut v = [[0.0f32; LANES]; 3];
    for i in 0..3 {
        for k in 0..LANES {
            v[i][k] = c.axes[0][i] * wx[k] + c.axes[1][i] * wy[k] + c.z_term[i];
        }
    }
    if c.orthographic {
        for i in 0..3 {
            for k in 0..LANES {
                out.origin[i][k] = v[i][k] + c.translation[i];
                out.dir[i][k] = c.fixed_dir[i];
            }
        }
        out.cone_width = [c.fixed_cone.width; LANES];
        out.cone_spread = [c.fixed_cone.spread; LANES];
        return;
    }
    for k in 0..LANES {
        // glam's `normalize`: divide by the root of ((x² + y²) + z²).
        let length = (v[0][k] * v[0][k] + v[1][k] * v[1][k] + v[2][k] * v[2][k]).sqrt();
        let d = [v[0][k] / length, v[1][k] / length, v[2][k] / length];
        let cos = d[0] * c.forward[0] + d[1] * c.forward[1] + d[2] * c.forward[2];
        let spread = c.pitch * cos.clamp(0.0, 1.0) / c.focal;
        for i in 0..3 {
            out.dir[i][k] = d[i];
            out.origin[i][k] = c.fixed_origin[i];
        }
        out.cone_width[k] = c.fixed_cone.width;
        out.cone_spread[k] = spread * c.footprint_scale;
    }
}

/// Replaces lanes `0..len` of `out` (rays [`camera_ray_lanes`] made for pixels (`x[k]`, `y[k]`) of a
/// `width × height` image with jitter (`jx[k]`, `jy[k]`)) by the rays through the camera's lens at
/// lens samples (`lens_u[k]`, `lens_v[k]`) and times `time[k]`, each exactly the film loop's
/// [`Camera::sample_ray`]: the scalar code runs per lane (a lens or a moving camera).
#[allow(clippy::too_many_arguments)]
pub fn lens_ray_lanes(
    camera: &Camera,
    forward: Vec3,
    size: [u32; 2],
    footprint_scale: f32,
    (x, y): (&U32Lanes, &U32Lanes),
    (jx, jy): (&Lanes, &Lanes),
    (lens_u, lens_v): (&Lanes, &Lanes),
    time: &Lanes,
    len: usize,
    out: &mut RayLanes,
) {
    for k in 0..len {
        let film = [(x[k] as f32 + jx[k]) / size[0] as f32, (y[k] as f32 + jy[k]) / size[1] as f32];
        let (o, d, cone) = camera.sample_ray(film, [lens_u[k], lens_v[k]], time[k], forward, footprint_scale);
        out.set(k, &CameraRay { origin: o, dir: d, cone_width: cone.width, cone_spread: cone.spread });
    }
}

/// Default image height for `width` pixels from the aperture aspect of `cam`.
pub fn default_height(cam: Option<&blob::Camera>, width: u32) -> u32 {
    let aspect = cam
        .filter(|c| c.horizontal_aperture > 0.0 && c.vertical_aperture > 0.0)
        .map_or(1.0, |c| c.vertical_aperture / c.horizontal_aperture);
    ((width as f32 * aspect).round() as u32).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blob_camera(projection: u32) -> blob::Camera {
        blob::Camera {
            projection,
            focal_length: 50.0,
            horizontal_aperture: 20.0,
            vertical_aperture: 10.0,
            world_from_camera: [[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 2.0], [0.0, 0.0, 1.0, 3.0]],
            ..Default::default()
        }
    }

    #[test]
    fn perspective_centre_and_corner_rays() {
        let cam = Camera::from_blob(&blob_camera(blob::PROJECTION_PERSPECTIVE), 200, 100);
        let (o, d) = cam.generate_ray(0.5, 0.5);
        assert!((o - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6);
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        // Right edge: x = 10 at z = −50.
        let (_, d) = cam.generate_ray(1.0, 0.5);
        assert!((d.x / -d.z - 0.2).abs() < 1e-6);
        // Top edge (fy = 0) is +Y: y = 5 at z = −50.
        let (_, d) = cam.generate_ray(0.5, 0.0);
        assert!((d.y / -d.z - 0.1).abs() < 1e-6);
        assert_eq!(default_height(Some(&blob_camera(0)), 512), 256);
    }

    #[test]
    fn orthographic_rays_are_parallel() {
        let cam = Camera::from_blob(&blob_camera(blob::PROJECTION_ORTHOGRAPHIC), 200, 100);
        let (o, d) = cam.generate_ray(1.0, 1.0);
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        assert!((o - Vec3::new(1.0 + 1.0, 2.0 - 0.5, 3.0)).length() < 1e-5, "{o}");
    }

    #[test]
    fn framing_camera_sees_the_bounds() {
        let cam = Camera::framing(Vec3::splat(-1.0), Vec3::splat(1.0), false, 64, 64);
        let (o, d) = cam.generate_ray(0.5, 0.5);
        assert!(o.z > 3.0 && (d - Vec3::NEG_Z).length() < 1e-6);
        let cam = Camera::framing(Vec3::splat(-1.0), Vec3::splat(1.0), true, 64, 64);
        let (o, d) = cam.generate_ray(0.5, 0.0);
        assert!(o.y < -3.0 && d.y > 0.9 && d.z > 0.0);
    }

    /// Moments and support of the aperture samplers over a stratified grid: a disc of radius `R` has
    /// `⟨r²⟩ = R²/2`; a regular `n`-gon of circumradius `R` (fan of triangles `0, A, B` with
    /// `⟨r²⟩ = (|A|² + |B|² + A·B) / 6`) has `R²(2 + cos(2π/n)) / 6`; every point lies inside.
    #[test]
    fn apertures_are_uniform_over_their_shapes() {
        // 504 rows divide evenly among 3, 6 and 9 sectors.
        let n = 504;
        for (blades, rotation) in [(0, 0.0), (3, 0.0), (6, 0.4), (9, -1.0)] {
            let lens = ThinLens { radius: 2.0, focus_distance: 1.0, blades, rotation };
            let (mut r2, mut cx, mut cy) = (0.0f64, 0.0f64, 0.0f64);
            for i in 0..n {
                for j in 0..n {
                    let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                    let [x, y] = lens.point(u);
                    let r = (x * x + y * y).sqrt();
                    assert!(r <= 2.0 * (1.0 + 1e-6), "{blades} blades: {x}, {y} outside the aperture");
                    if blades > 0 {
                        // Inside every edge: the apothem along each edge normal.
                        let step = std::f32::consts::TAU / blades as f32;
                        let apothem = 2.0 * (step / 2.0).cos();
                        for k in 0..blades {
                            let normal_angle = rotation + (k as f32 + 0.5) * step;
                            let along = x * normal_angle.cos() + y * normal_angle.sin();
                            assert!(
                                along <= apothem * (1.0 + 1e-5),
                                "{blades} blades: {x}, {y} past edge {k}"
                            );
                        }
                    }
                    r2 += f64::from(r * r);
                    (cx, cy) = (cx + f64::from(x), cy + f64::from(y));
                }
            }
            let count = f64::from(n * n);
            let expected = if blades == 0 {
                4.0 / 2.0
            } else {
                4.0 * (2.0 + (std::f64::consts::TAU / f64::from(blades)).cos()) / 6.0
            };
            let mean = r2 / count;
            assert!((mean / expected - 1.0).abs() < 1e-3, "{blades} blades: <r²> {mean} vs {expected}");
            let (cx, cy) = (cx / count, cy / count);
            assert!(cx.abs() < 1e-4 && cy.abs() < 1e-4, "{blades} blades centred: {cx}, {cy}");
        }
        assert_eq!(concentric_disc([0.5, 0.5]), [0.0, 0.0]);
        // The corners of the sample square go to the circle.
        let [x, y] = concentric_disc([1.0, 1.0]);
        assert!(((x * x + y * y).sqrt() - 1.0).abs() < 1e-6);
    }

    /// Every lens ray through one film point meets the pinhole ray through it on the focus plane; the
    /// lens ray starts on the aperture; a pinhole and an orthographic camera ignore the lens sample.
    #[test]
    fn lens_rays_converge_on_the_focus_plane() {
        let mut cam = blob_camera(blob::PROJECTION_PERSPECTIVE);
        (cam.f_stop, cam.focus_distance) = (2.0, 7.0);
        let camera = Camera::from_blob(&cam, 200, 100);
        let lens = *camera.lens().expect("a lens");
        // 50 tenths of a unit at f/2: a 2.5-unit aperture.
        assert_eq!((lens.radius, lens.focus_distance), (1.25, 7.0));
        let eye = Vec3::new(1.0, 2.0, 3.0);
        for (fx, fy) in [(0.5, 0.5), (0.1, 0.9), (0.97, 0.2)] {
            let (o, d) = camera.generate_ray(fx, fy);
            let focus = o + d * (7.0 / -d.z);
            for uv in [[0.1, 0.2], [0.9, 0.5], [0.5, 0.99], [0.0, 0.0]] {
                let (lo, ld) = camera.generate_lens_ray(fx, fy, uv);
                assert!((lo.z - eye.z).abs() < 1e-6 && (lo - eye).length() <= 1.25 * (1.0 + 1e-6));
                assert!((ld.length() - 1.0).abs() < 1e-6);
                let hit = lo + ld * ((lo.z - focus.z) / -ld.z);
                assert!((hit - focus).length() < 1e-5 * 7.0, "{hit} vs {focus}");
            }
        }
        assert_eq!(
            camera.clone().without_lens().generate_lens_ray(0.3, 0.4, [0.9, 0.1]),
            camera.generate_ray(0.3, 0.4)
        );
        let mut ortho = cam;
        ortho.projection = blob::PROJECTION_ORTHOGRAPHIC;
        let ortho = Camera::from_blob(&ortho, 200, 100);
        assert!(ortho.lens().is_none());
        assert_eq!(ortho.generate_lens_ray(0.3, 0.4, [0.9, 0.1]), ortho.generate_ray(0.3, 0.4));
    }

    /// A random camera: either projection, a rotated, scaled and moved frame, random apertures,
    /// offsets and focal length.
    fn random_camera(u: &mut impl FnMut() -> f32, projection: u32, width: u32, height: u32) -> Camera {
        let angle = 6.0 * u();
        let axis = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize_or(Vec3::Y);
        let m = Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.5 + 2.0 * u()),
            glam::Quat::from_axis_angle(axis, angle),
            Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 100.0,
        );
        let cols = m.to_cols_array_2d();
        let rows = [0, 1, 2].map(|r| [cols[0][r], cols[1][r], cols[2][r], cols[3][r]]);
        let cam = blob::Camera {
            projection,
            focal_length: 10.0 + 90.0 * u(),
            horizontal_aperture: 5.0 + 40.0 * u(),
            vertical_aperture: 5.0 + 40.0 * u(),
            horizontal_aperture_offset: u() - 0.5,
            vertical_aperture_offset: u() - 0.5,
            world_from_camera: rows,
            ..Default::default()
        };
        Camera::from_blob(&cam, width, height)
    }

    #[test]
    fn ray_lanes_equal_the_scalar_film_loop_bit_for_bit() {
        let mut state = 77u32;
        let mut u = || {
            state = crate::sampler::hash_u32(state);
            (state >> 8) as f32 / 16_777_216.0
        };
        for (projection, framing) in
            [(blob::PROJECTION_PERSPECTIVE, false), (blob::PROJECTION_ORTHOGRAPHIC, false), (0, true)]
        {
            let mut cases = 0;
            for round in 0..160 {
                let (width, height) = (1 + (u() * 2000.0) as u32, 1 + (u() * 2000.0) as u32);
                let cam = if framing {
                    Camera::framing(Vec3::splat(-u()), Vec3::splat(u() * 5.0), round % 2 == 0, width, height)
                } else {
                    random_camera(&mut u, projection, width, height)
                };
                let forward = cam.forward();
                let scale = [1.0, 0.0, 0.5 + 3.0 * u()][round % 3];
                let lanes = CameraLanes::new(&cam, forward, width, height, scale);
                for _ in 0..8 {
                    let (mut x, mut y, mut jx, mut jy) = ([0; LANES], [0; LANES], [0.0; LANES], [0.0; LANES]);
                    for k in 0..LANES {
                        x[k] = ((u() * width as f32) as u32).min(width - 1);
                        y[k] = ((u() * height as f32) as u32).min(height - 1);
                        // Jitter in [0, 1), its ends included.
                        (jx[k], jy[k]) = match k {
                            0 => (0.0, 0.0),
                            1 => (1.0 - f32::EPSILON / 2.0, 1.0 - f32::EPSILON / 2.0),
                            _ => (u(), u()),
                        };
                    }
                    let mut out = RayLanes::default();
                    camera_ray_lanes(&lanes, &x, &y, &jx, &jy, &mut out);
                    for k in 0..LANES {
                        let (o, d) = cam.generate_ray(
                            (x[k] as f32 + jx[k]) / width as f32,
                            (y[k] as f32 + jy[k]) / height as f32,
                        );
                        let mut cone = cam.pixel_cone(d.dot(forward));
                        cone.width *= scale;
                        cone.spread *= scale;
                        let ray = out.get(k);
                        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                        assert_eq!(bits(ray.origin), bits(o), "origin, lane {k}");
                        assert_eq!(bits(ray.dir), bits(d), "direction, lane {k}");
                        assert_eq!(ray.cone_width.to_bits(), cone.width.to_bits());
                        assert_eq!(ray.cone_spread.to_bits(), cone.spread.to_bits());
                        cases += 1;
                    }
                }
            }
            assert!(cases >= 10_000, "{cases}");
        }
    }
}

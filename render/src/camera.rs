//! Camera rays from UsdGeomCamera parameters.
//!
//! USD cameras look down their local −Z with +Y up; `focalLength` and the apertures share a unit, so only
//! their ratios matter for a perspective camera. An orthographic camera's apertures are in tenths of a
//! scene unit (USD's lens-unit convention). When the image aspect differs from the aperture aspect the
//! horizontal aperture is kept and the vertical one follows the image ("fit horizontal").
//! `clippingRange` is not applied (a path tracer has no near/far plane to honour).

use glam::{Affine3A, Vec3, Vec3A};

/// A camera ready to generate rays for a `width × height` image.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    world_from_camera: Affine3A,
    orthographic: bool,
    /// Film-plane window in camera space at z = −focal: x range and y range.
    window_min: [f32; 2],
    window_size: [f32; 2],
    focal: f32,
    /// Image width in pixels (the window is split into this many pixel steps).
    width: u32,
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
    /// A camera from a blob record for an image of `width × height` pixels.
    pub fn from_blob(cam: &blob::Camera, width: u32, height: u32) -> Self {
        let h_ap = if cam.horizontal_aperture > 0.0 { cam.horizontal_aperture } else { 20.955 };
        let v_ap = h_ap * height as f32 / width as f32;
        let orthographic = cam.projection == blob::PROJECTION_ORTHOGRAPHIC;
        // Orthographic apertures are in tenths of a scene unit.
        let scale = if orthographic { 0.1 } else { 1.0 };
        let centre = [cam.horizontal_aperture_offset * scale, cam.vertical_aperture_offset * scale];
        let size = [h_ap * scale, v_ap * scale];
        Camera {
            world_from_camera: affine_from_rows(&cam.world_from_camera),
            orthographic,
            window_min: [centre[0] - 0.5 * size[0], centre[1] - 0.5 * size[1]],
            window_size: size,
            focal: if cam.focal_length > 0.0 { cam.focal_length } else { 50.0 },
            width: width.max(1),
        }
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
}

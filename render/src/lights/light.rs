//! One UsdLux light as the blob stores it: its [`Shape`], emitted radiance, and how it is sampled and hit.

use crate::bsdf::Frame;
use crate::camera::affine_from_rows;
use glam::Vec3;
use std::f32::consts::{PI, TAU};

/// Shape and placement of one light, in world space.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// Uniform radiance from every direction.
    Dome,
    /// A lat-long map ([`crate::lights::dome_map`]): `radiance` times the map's value in each direction.
    TexturedDome {
        /// Index into the scene's dome maps (in [`crate::lights::Lights`]).
        map: u32,
    },
    /// A cone of directions around `to_light`; `one_minus_cos_max == 0` is a delta direction.
    Distant {
        /// Unit direction towards the light.
        to_light: Vec3,
        /// 1 − cos(θ/2), computed without cancellation.
        one_minus_cos_max: f32,
    },
    /// A point (sphere with `treatAsPoint`); `radiance` holds the intensity.
    Point {
        /// Position.
        position: Vec3,
    },
    /// A sphere.
    Sphere {
        /// Centre.
        center: Vec3,
        /// World-space radius.
        radius: f32,
    },
    /// A parallelogram `center ± ex ± ey` emitting along `normal`.
    Rect {
        /// Centre.
        center: Vec3,
        /// Half-width vector.
        ex: Vec3,
        /// Half-height vector.
        ey: Vec3,
        /// Unit emission direction (light-space −Z).
        normal: Vec3,
        /// World-space area.
        area: f32,
    },
    /// An ellipse `center + a·ex + b·ey`, a² + b² ≤ 1, emitting along `normal`.
    Disk {
        /// Centre.
        center: Vec3,
        /// Radius vector along light-space X.
        ex: Vec3,
        /// Radius vector along light-space Y.
        ey: Vec3,
        /// Unit emission direction (light-space −Z).
        normal: Vec3,
        /// World-space area.
        area: f32,
    },
    /// All emissive triangles, chosen by the blob's distribution.
    Triangles,
}

/// One light of the selection list.
#[derive(Clone, Copy, Debug)]
pub struct Light {
    /// Where and what.
    pub shape: Shape,
    /// Radiance after normalization (irradiance for a delta distant light, intensity for a point).
    pub radiance: Vec3,
}

/// A light sample seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (infinite for dome and distant lights).
    pub distance: f32,
    /// Incident radiance (or irradiance for delta lights).
    pub li: Vec3,
    /// Solid-angle pdf including the selection probability (selection probability alone for deltas).
    pub pdf: f32,
    /// A delta light (no MIS: BSDF sampling cannot hit it).
    pub delta: bool,
    /// For a point on an emissive triangle: the triangle and the barycentric weights of its vertices 1
    /// and 2, so that a textured `emissiveColor` can be evaluated there (`li` holds the constant).
    pub emitter: Option<(u32, [f32; 2])>,
}

#[inline]
pub(crate) fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = crate::trig::sin_cos(TAU * u[1]);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// Direction inside the cone around `axis` with 1 − cos θ = `u0 · one_minus_cos_max`.
#[inline]
pub(crate) fn sample_cone(axis: Vec3, one_minus_cos_max: f32, u: [f32; 2]) -> Vec3 {
    let one_minus_cos = u[0] * one_minus_cos_max;
    let cos = 1.0 - one_minus_cos;
    let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let (sin_phi, cos_phi) = crate::trig::sin_cos(TAU * u[1]);
    Frame::new(axis).to_world(Vec3::new(sin * cos_phi, sin * sin_phi, cos)).normalize()
}

/// Nearest positive hit of a ray (unit `d`) with a sphere.
#[inline]
pub(crate) fn ray_sphere(o: Vec3, d: Vec3, center: Vec3, radius: f32) -> Option<f32> {
    let oc = o - center;
    let b = oc.dot(d);
    let c = oc.length_squared() - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    sphere_roots(b, c, disc)
}

/// The rest of [`ray_sphere`] once the discriminant is known not to be negative: the nearest
/// positive root of the numerically stable pair. The wavefront's emission kernel computes `b`, `c`
/// and `disc` for eight rays at once and calls this for the rays that pass.
#[inline(always)]
pub(crate) fn sphere_roots(b: f32, c: f32, disc: f32) -> Option<f32> {
    let sq = disc.sqrt();
    let q = if b > 0.0 { -b - sq } else { -b + sq };
    let (mut t0, mut t1) = (q, if q != 0.0 { c / q } else { 0.0 });
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 {
        Some(t1)
    } else {
        None
    }
}

impl Light {
    /// Builds a light from its blob record.
    pub fn from_blob(rec: &blob::Light) -> Self {
        let m = affine_from_rows(&rec.world_from_light);
        let normalize = rec.flags & blob::LIGHT_NORMALIZE != 0;
        let radiance = Vec3::from(rec.radiance);
        let center: Vec3 = m.translation.into();
        let x: Vec3 = m.matrix3.x_axis.into();
        let y: Vec3 = m.matrix3.y_axis.into();
        let z: Vec3 = m.matrix3.z_axis.into();
        let emission_normal = |ex: Vec3, ey: Vec3| {
            let n = ex.cross(ey).normalize_or(Vec3::Z);
            if n.dot(z) > 0.0 {
                -n
            } else {
                n
            }
        };
        let scale_by = |area: f32| if normalize && area > 0.0 { radiance / area } else { radiance };
        match rec.kind {
            blob::light_kind::DISTANT => {
                let to_light = z.normalize_or(Vec3::Z);
                let half = 0.5 * rec.angle_degrees.max(0.0).to_radians().min(PI);
                let s = (0.5 * half).sin();
                let one_minus_cos_max = 2.0 * s * s;
                if one_minus_cos_max < 1e-9 {
                    Light { shape: Shape::Distant { to_light, one_minus_cos_max: 0.0 }, radiance }
                } else {
                    let sin_half = half.sin();
                    let cone = PI * sin_half * sin_half;
                    let radiance = if normalize { radiance / cone } else { radiance };
                    Light { shape: Shape::Distant { to_light, one_minus_cos_max }, radiance }
                }
            }
            blob::light_kind::SPHERE => {
                let radius = rec.radius.max(0.0) * (x.length() + y.length() + z.length()) / 3.0;
                let radiance = scale_by(4.0 * PI * radius * radius);
                if rec.flags & blob::LIGHT_TREAT_AS_POINT != 0 || radius <= 0.0 {
                    Light {
                        shape: Shape::Point { position: center },
                        radiance: radiance * (PI * radius * radius),
                    }
                } else {
                    Light { shape: Shape::Sphere { center, radius }, radiance }
                }
            }
            blob::light_kind::RECT => {
                let ex = x * (0.5 * rec.width);
                let ey = y * (0.5 * rec.height);
                let area = 4.0 * ex.cross(ey).length();
                let normal = emission_normal(ex, ey);
                Light { shape: Shape::Rect { center, ex, ey, normal, area }, radiance: scale_by(area) }
            }
            blob::light_kind::DISK => {
                let ex = x * rec.radius;
                let ey = y * rec.radius;
                let area = PI * ex.cross(ey).length();
                let normal = emission_normal(ex, ey);
                Light { shape: Shape::Disk { center, ex, ey, normal, area }, radiance: scale_by(area) }
            }
            // The map index is set by `Lights::new`, which builds the maps.
            blob::light_kind::TEXTURED_DOME => Light { shape: Shape::TexturedDome { map: 0 }, radiance },
            _ => Light { shape: Shape::Dome, radiance },
        }
    }

    /// Ray parameter and emitted radiance where a ray from `o` along unit `d` meets this area light
    /// before `tmax`.
    /// World bounds of a light rays can hit (rect, disk, sphere); `None` for the others.
    pub(crate) fn bounds(&self) -> Option<(Vec3, Vec3)> {
        match self.shape {
            Shape::Sphere { center, radius } => Some((center - radius, center + radius)),
            Shape::Rect { center, ex, ey, .. } | Shape::Disk { center, ex, ey, .. } => {
                let half = ex.abs() + ey.abs();
                Some((center - half, center + half))
            }
            _ => None,
        }
    }

    #[inline]
    pub(crate) fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, Vec3)> {
        match self.shape {
            Shape::Sphere { center, radius } => {
                ray_sphere(o, d, center, radius).filter(|&t| t < tmax).map(|t| (t, self.radiance))
            }
            Shape::Rect { center, ex, ey, normal, .. } | Shape::Disk { center, ex, ey, normal, .. } => {
                let cos = d.dot(normal);
                if cos >= 0.0 {
                    return None; // behind the emitting side, or parallel
                }
                let t = (center - o).dot(normal) / cos;
                if !(t > 0.0 && t < tmax) {
                    return None;
                }
                let r = o + d * t - center;
                let a = r.dot(ex) / ex.length_squared();
                let b = r.dot(ey) / ey.length_squared();
                let inside = match self.shape {
                    Shape::Rect { .. } => a.abs() <= 1.0 && b.abs() <= 1.0,
                    _ => a * a + b * b <= 1.0,
                };
                inside.then_some((t, self.radiance))
            }
            _ => None,
        }
    }

    /// Solid-angle pdf (without selection) of sampling point `x` on this area light from `p`.
    #[inline]
    pub(crate) fn pdf_area_light(&self, p: Vec3, x: Vec3) -> f32 {
        let to = x - p;
        let d2 = to.length_squared();
        match self.shape {
            Shape::Sphere { center, radius } => {
                let dc2 = (center - p).length_squared();
                if dc2 <= radius * radius * (1.0 + 1e-4) {
                    let n = (x - center).normalize();
                    let cos = n.dot(to).abs() / d2.sqrt();
                    d2 / (cos * 4.0 * PI * radius * radius)
                } else {
                    let sin2 = radius * radius / dc2;
                    let cos_max = (1.0 - sin2).max(0.0).sqrt();
                    1.0 / (TAU * (sin2 / (1.0 + cos_max)))
                }
            }
            Shape::Rect { normal, area, .. } | Shape::Disk { normal, area, .. } => {
                let cos = -normal.dot(to) / d2.sqrt();
                if cos > 0.0 {
                    d2 / (cos * area)
                } else {
                    0.0
                }
            }
            _ => 0.0,
        }
    }
}

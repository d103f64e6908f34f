//! Curves and points → blob records: camera-driven splitting of the Bézier segments, tight per-piece
//! bounds and the curve BVH (its own sections; the triangle BVH is untouched).
//!
//! Splitting, like subdivision dicing, asks how far the centreline of each piece may stray from its
//! chord: [`Split::Adaptive`] allows `pixels` pixel footprints of the default camera (at the RenderSettings
//! resolution, or 512 wide) at the piece's depth; pieces are halved by de Casteljau until
//! [`curves::flatness`] is within that, at most `2^max_depth` pieces per segment. Without a camera the
//! footprint is that of a 512-pixel view of the curves' bounds. [`Split::Fixed`] cuts every segment
//! into equal pieces (for the benchmark).

use crate::curves::{self, Tolerance};
use crate::scene::{Camera, CurveKind, Scene};
use blob::curves as bc;
use glam::{Mat4, Vec2, Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use std::time::Duration;

/// How curve segments are split before the BVH is built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Split {
    /// Split until each piece's chord deviation is below `pixels` pixel footprints, at most
    /// `2^max_depth` pieces per segment.
    Adaptive {
        /// Allowed chord deviation in pixels.
        pixels: f32,
        /// Largest halving depth.
        max_depth: u32,
    },
    /// Every segment into this many equal pieces.
    Fixed(u32),
}

impl Default for Split {
    fn default() -> Self {
        Split::Adaptive { pixels: 0.25, max_depth: 6 }
    }
}

/// Pixel footprint of a camera as a function of the world position.
struct Footprint {
    camera_from_world: Mat4,
    /// World units per pixel at unit depth (perspective) or everywhere (orthographic).
    per_pixel: f32,
    orthographic: bool,
    near: f32,
    pixels: f32,
}

impl Tolerance for Footprint {
    fn at(&self, p: Vec3) -> f32 {
        let scale = if self.orthographic {
            1.0
        } else {
            let q = self.camera_from_world.transform_point3(p);
            // Behind the camera only reflections see the curve: use the distance.
            if q.z < 0.0 {
                (-q.z).max(self.near)
            } else {
                q.length().max(self.near)
            }
        };
        self.pixels * self.per_pixel * scale
    }
}

fn footprint(scene: &Scene, split_pixels: f32, bounds: (Vec3, Vec3)) -> Footprint {
    let width = scene.resolution.map_or(512, |r| r[0]).max(1) as f32;
    match scene.default_camera.and_then(|c| scene.cameras.get(c)) {
        Some(Camera {
            world_from_camera,
            orthographic,
            focal_length,
            horizontal_aperture,
            clipping_range,
            ..
        }) => {
            let per_pixel = if *orthographic {
                // Orthographic apertures are in tenths of a scene unit.
                0.1 * horizontal_aperture / width
            } else {
                horizontal_aperture / focal_length.max(1e-6) / width
            };
            Footprint {
                camera_from_world: world_from_camera.inverse(),
                per_pixel,
                orthographic: *orthographic,
                near: clipping_range[0].max(1e-6),
                pixels: split_pixels,
            }
        }
        None => Footprint {
            camera_from_world: Mat4::IDENTITY,
            per_pixel: (bounds.1 - bounds.0).length().max(1e-6) / width,
            orthographic: true,
            near: 1.0,
            pixels: split_pixels,
        },
    }
}

/// Exact bounds of a cubic Bézier's centreline (per-axis extrema from the derivative's roots), grown
/// by the largest radius control value.
pub fn segment_bounds(p: &[Vec4; 4]) -> (Vec3, Vec3) {
    let mut lo = p[0].truncate().min(p[3].truncate());
    let mut hi = p[0].truncate().max(p[3].truncate());
    for axis in 0..3 {
        let [a, b, c, d] = p.map(|q| q[axis]);
        // B'(t)/3 = e(1−t)² + 2f(1−t)t + g t² = (e − 2f + g)t² + 2(f − e)t + e.
        let (e, f, g) = (b - a, c - b, d - c);
        let (qa, qb, qc) = (e - 2.0 * f + g, 2.0 * (f - e), e);
        let mut roots = [f32::NAN; 2];
        if qa.abs() < 1e-12 {
            if qb.abs() > 1e-12 {
                roots[0] = -qc / qb;
            }
        } else {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                let s = disc.sqrt();
                roots = [(-qb - s) / (2.0 * qa), (-qb + s) / (2.0 * qa)];
            }
        }
        for t in roots {
            if t > 0.0 && t < 1.0 {
                let v = curves::eval(p, t)[axis];
                lo[axis] = lo[axis].min(v);
                hi[axis] = hi[axis].max(v);
            }
        }
    }
    let r = p.iter().map(|q| q.w).fold(0.0f32, f32::max);
    (lo - Vec3::splat(r), hi + Vec3::splat(r))
}

/// Appends the scene's curves and points to `data` (strings, groups, segments, spheres, BVH) and
/// returns their world bounds.
pub(crate) fn pack_curves(scene: &Scene, data: &mut blob::SceneData, split: Split) -> (Vec3, Vec3) {
    let mut bounds = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for c in &scene.curves {
        for s in &c.segments {
            let (lo, hi) = segment_bounds(&s.p);
            bounds = (bounds.0.min(lo), bounds.1.max(hi));
        }
        for s in &c.spheres {
            bounds = (bounds.0.min(s.center - s.radius), bounds.1.max(s.center + s.radius));
        }
    }
    let (pixels, max_depth) = match split {
        Split::Adaptive { pixels, max_depth } => (pixels, max_depth),
        Split::Fixed(_) => (0.25, 0),
    };
    let tolerance = footprint(scene, pixels, bounds);
    for (gi, c) in scene.curves.iter().enumerate() {
        let name = data.add_string(&c.path);
        let out = &mut data.curves;
        let mut flags = 0;
        if c.has_normals {
            flags |= bc::CURVE_HAS_NORMALS;
        }
        if c.has_colors {
            flags |= bc::CURVE_HAS_COLORS;
        }
        if c.has_uvs {
            flags |= bc::CURVE_HAS_UVS;
        }
        let kind = match c.kind {
            CurveKind::Tube => bc::CURVE_TUBE,
            CurveKind::Ribbon => bc::CURVE_RIBBON,
            CurveKind::Points => bc::CURVE_POINTS,
        };
        let first = if kind == bc::CURVE_POINTS { out.spheres.len() } else { out.segments.len() } as u32;
        let group = gi as u32;
        for s in &c.spheres {
            out.spheres.push(bc::PointSphere {
                center: s.center.to_array(),
                radius: s.radius,
                color: s.color.to_array(),
                group,
            });
        }
        for s in &c.segments {
            let pieces = match split {
                Split::Adaptive { .. } => curves::split_adaptive(&s.p, &tolerance, max_depth),
                Split::Fixed(n) => curves::split_uniform(&s.p, n.max(1)),
            };
            for (p, [t0, t1]) in pieces {
                let lerp3 = |v: [Vec3; 2], t: f32| v[0].lerp(v[1], t).to_array();
                let lerp2 = |v: [Vec2; 2], t: f32| v[0].lerp(v[1], t).to_array();
                let normal = if c.has_normals {
                    [0, 1].map(|i| {
                        let t = [t0, t1][i];
                        Vec3::from(lerp3(s.normal, t)).normalize_or_zero().to_array()
                    })
                } else {
                    [[0.0; 3]; 2]
                };
                out.segments.push(bc::CurveSegment {
                    p: p.map(|q| q.to_array()),
                    group,
                    u: [s.u[0] + (s.u[1] - s.u[0]) * t0, s.u[0] + (s.u[1] - s.u[0]) * t1],
                    reserved: 0,
                });
                out.attributes.push(bc::CurveAttributes {
                    normal,
                    color: [lerp3(s.color, t0), lerp3(s.color, t1)],
                    uv: [lerp2(s.uv, t0), lerp2(s.uv, t1)],
                });
            }
        }
        let end = if kind == bc::CURVE_POINTS { out.spheres.len() } else { out.segments.len() } as u32;
        out.groups.push(bc::CurveGroup {
            name,
            kind,
            flags,
            first,
            count: end - first,
            material: c.material,
            curve_count: c.curve_count as u32,
        });
    }
    let out = &mut data.curves;
    let mut boxes: Vec<Aabb> = out
        .segments
        .iter()
        .map(|s| {
            let (lo, hi) = segment_bounds(&s.p.map(Vec4::from_array));
            Aabb::new(Vec3A::from(lo), Vec3A::from(hi))
        })
        .collect();
    boxes.extend(out.spheres.iter().map(|s| {
        let c = Vec3A::from(s.center);
        Aabb::new(c - s.radius, c + s.radius)
    }));
    if !boxes.is_empty() {
        let bvh = obvhs::cwbvh::builder::build_cwbvh(
            &boxes,
            obvhs::BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        out.bvh_nodes = bvh.nodes.iter().map(|n| bytemuck::cast::<_, blob::CwBvhNode>(*n)).collect();
        out.bvh_primitives = bvh.primitive_indices;
    }
    bounds
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_tight_and_contain_the_curve() {
        let p = [
            Vec4::new(0.0, 0.0, 0.0, 0.1),
            Vec4::new(1.0, 3.0, 0.0, 0.1),
            Vec4::new(2.0, -3.0, 1.0, 0.1),
            Vec4::new(3.0, 0.0, 0.0, 0.1),
        ];
        let (lo, hi) = segment_bounds(&p);
        let mut tlo = Vec3::INFINITY;
        let mut thi = Vec3::NEG_INFINITY;
        for i in 0..=1000 {
            let q = curves::eval(&p, i as f32 / 1000.0).truncate();
            tlo = tlo.min(q);
            thi = thi.max(q);
        }
        assert!((lo + 0.1 - tlo).abs().max_element() < 1e-3, "{lo} {tlo}");
        assert!((hi - 0.1 - thi).abs().max_element() < 1e-3, "{hi} {thi}");
    }
}

//! Curves and points → blob records: camera-driven splitting of the Bézier segments, tight per-piece
//! bounds and the curve BVH (its own sections; the triangle BVH is untouched).
//!
//! Splitting, like subdivision dicing, asks the render camera ([`DicingCamera`]: the default camera at
//! the RenderSettings resolution, else the framing camera `render` would use) how much of each piece
//! it will see. A piece is halved (de Casteljau) until the deviation of its centreline from its chord
//! ([`curves::flatness`]) is below `pixels` pixels on screen *or* below `width_fraction` of its own
//! width (a deviation that small is invisible next to the fibre's width at any distance), at most
//! `2^max_depth` pieces per segment. Pieces wholly outside the view frustum are not split: only
//! shadows and reflections see them, and the render-time test refines every piece against its
//! radius anyway. Distance needs no special case: the pixel tolerance grows with it.
//! [`Split::Fixed`] cuts every segment into equal pieces (for the benchmark).
//!
//! The curve BVH then bounds each stored segment by one to eight boxes (BVH slots naming halves,
//! quarters or eighths, `blob::curves::slot`) where smaller boxes pay ([`PIECE_SPLIT_AREA`]), and
//! the records are stored in the order its leaves name them.

use super::common::PackError;
use crate::camera::DicingCamera;
use crate::curves::{self, Tolerance};
use crate::scene::{CurveKind, Scene, UpAxis};
use blob::curves as bc;
use glam::{Vec2, Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use std::time::Duration;

/// How curve segments are split before the BVH is built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Split {
    /// Split until each piece's chord deviation is below `pixels` pixels on screen or below
    /// `width_fraction` of its width; at most `2^max_depth` pieces per segment.
    Adaptive {
        /// Allowed chord deviation in pixels.
        pixels: f32,
        /// Allowed chord deviation as a fraction of the piece's smallest width.
        width_fraction: f32,
        /// Largest halving depth.
        max_depth: u32,
    },
    /// Every segment into this many equal pieces.
    Fixed(u32),
}

impl Default for Split {
    fn default() -> Self {
        Split::Adaptive { pixels: 0.25, width_fraction: 0.1, max_depth: 6 }
    }
}

/// [`Split::Adaptive`]'s tolerance for one camera.
pub struct CameraTolerance<'a> {
    camera: &'a DicingCamera,
    pixels: f32,
    width_fraction: f32,
}

impl<'a> CameraTolerance<'a> {
    /// The tolerance of `pixels` on screen or `width_fraction` of the width, for `camera`.
    pub fn new(camera: &'a DicingCamera, pixels: f32, width_fraction: f32) -> Self {
        CameraTolerance { camera, pixels, width_fraction }
    }
}

impl Tolerance for CameraTolerance<'_> {
    fn of(&self, p: &[Vec4; 4]) -> f32 {
        // The control points' box holds the piece (convex hull); conservative and cheap.
        let (lo, hi) = p[1..].iter().fold((p[0].truncate(), p[0].truncate()), |(lo, hi), q| {
            (lo.min(q.truncate()), hi.max(q.truncate()))
        });
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        if self.camera.outside(lo, hi) {
            return f32::INFINITY;
        }
        // World length of one pixel at the piece's point nearest the eye.
        let pixel = (1.0 / self.camera.pixels(1.0, lo, hi)) as f32;
        let width = 2.0 * p.iter().map(|q| q.w).fold(f32::INFINITY, f32::min).max(0.0);
        (self.pixels * pixel).max(self.width_fraction * width)
    }
}

/// The camera curves are split for: the scene's default camera, else the one `render` frames the
/// world box `lo..hi` with.
pub fn split_camera(scene: &Scene, lo: Vec3, hi: Vec3) -> DicingCamera {
    match scene.default_camera.and_then(|c| scene.cameras.get(c)) {
        Some(camera) => DicingCamera::new(camera, scene.resolution),
        None => DicingCamera::framing(lo.as_dvec3(), hi.as_dvec3(), scene.up_axis == UpAxis::Z),
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
/// returns their world bounds. `others` are the world bounds of everything else (meshes), which the
/// framing camera of a camera-less scene also looks at.
pub(super) fn pack_curves(
    scene: &Scene,
    data: &mut blob::SceneData,
    split: Split,
    others: (Vec3, Vec3),
) -> Result<(Vec3, Vec3), PackError> {
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
    // Made on first use: a scene of points alone may have no finite box to frame.
    let mut camera = None;
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
                Split::Adaptive { pixels, width_fraction, max_depth } => {
                    let camera = camera.get_or_insert_with(|| {
                        split_camera(scene, bounds.0.min(others.0), bounds.1.max(others.1))
                    });
                    let tolerance = CameraTolerance::new(camera, pixels, width_fraction);
                    curves::split_adaptive(&s.p, &tolerance, max_depth)
                }
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
                    // Exact at t = 0 and 1: render tells curve ends (sphere caps) by u = 0 and 1.
                    u: [t0, t1].map(|t| s.u[0] * (1.0 - t) + s.u[1] * t),
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
    if out.segments.len() + out.spheres.len() > bc::SLOT_PRIMITIVE_MASK as usize + 1 {
        let prim = scene.curves.last().map_or(String::new(), |c| c.path.clone());
        let problem = format!(
            "{} curve pieces and points; the curve BVH addresses at most {}",
            out.segments.len() + out.spheres.len(),
            bc::SLOT_PRIMITIVE_MASK as usize + 1
        );
        return Err(PackError { prim, problem });
    }
    let mut boxes = Vec::with_capacity(out.segments.len() + out.spheres.len());
    let mut slots = Vec::with_capacity(boxes.capacity());
    for (i, s) in out.segments.iter().enumerate() {
        let p = s.p.map(Vec4::from_array);
        add_pieces(&p, segment_bounds(&p), i as u32, 1, &mut boxes, &mut slots);
    }
    let segments = out.segments.len() as u32;
    for (i, s) in out.spheres.iter().enumerate() {
        let c = Vec3A::from(s.center);
        boxes.push(Aabb::new(c - s.radius, c + s.radius));
        slots.push(segments + i as u32);
    }
    if !boxes.is_empty() {
        let bvh = obvhs::cwbvh::builder::build_cwbvh(
            &boxes,
            obvhs::BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        out.bvh_nodes = bvh.nodes.iter().map(|n| bytemuck::cast::<_, blob::CwBvhNode>(*n)).collect();
        out.bvh_primitives = bvh.primitive_indices.iter().map(|&i| slots[i as usize]).collect();
        store_in_leaf_order(out);
    }
    Ok(bounds)
}

/// A piece's box is replaced by its two halves' boxes when their surface areas add up to less than
/// this fraction of its own: a ray then meets fewer piece boxes on average. Long diagonal or bent
/// strands split; short straight ones, whose halves' boxes add up to about the whole box, do not.
const PIECE_SPLIT_AREA: f32 = 0.8;

/// Adds BVH boxes for heap node `node` (1 = whole segment) of segment `prim`, whose control points
/// are `p` and box `bounds`, halving down to eighths while [`PIECE_SPLIT_AREA`] says it pays.
fn add_pieces(
    p: &[Vec4; 4],
    bounds: (Vec3, Vec3),
    prim: u32,
    node: u32,
    boxes: &mut Vec<Aabb>,
    slots: &mut Vec<u32>,
) {
    let area = |(lo, hi): (Vec3, Vec3)| {
        let d = hi - lo;
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    if node < 8 {
        let (a, b) = curves::split(p, 0.5);
        let (box_a, box_b) = (segment_bounds(&a), segment_bounds(&b));
        if area(box_a) + area(box_b) < PIECE_SPLIT_AREA * area(bounds) {
            add_pieces(&a, box_a, prim, 2 * node, boxes, slots);
            add_pieces(&b, box_b, prim, 2 * node + 1, boxes, slots);
            return;
        }
    }
    boxes.push(Aabb::new(Vec3A::from(bounds.0), Vec3A::from(bounds.1)));
    // `prim` fits (checked by the caller) and `node − 1` ≤ 14.
    slots.push(bc::slot(prim, node - 1).unwrap_or(prim));
}

/// Reorders segments (with their attributes) and spheres within each group into the order the BVH
/// leaves name them, and renumbers the BVH's primitive slots to match.
///
/// Why: a leaf's primitives are neighbours in space, but in authoring order they are scattered over
/// the whole section (a groom's strands are listed root by root). Profiling the 100k-strand groom
/// showed two thirds of the segment test's time on the first load of each segment record; in leaf
/// order consecutive tests share cache lines. Groups own contiguous ranges, so records move only
/// within their group.
fn store_in_leaf_order(out: &mut bc::CurveData) {
    let segments = out.segments.len();
    let prims = segments + out.spheres.len();
    // The first slot naming each primitive (pieces give a segment several).
    let mut rank = vec![u32::MAX; prims];
    for (slot, &p) in out.bvh_primitives.iter().enumerate() {
        let r = &mut rank[bc::slot_primitive(p) as usize];
        *r = (*r).min(slot as u32);
    }
    // new_of[old] = new index (spheres numbered after the segments, as in the slots).
    let mut new_of: Vec<u32> = (0..prims as u32).collect();
    let mut order: Vec<u32> = Vec::new();
    for g in &out.groups {
        let base = if g.kind == bc::CURVE_POINTS { segments } else { 0 } + g.first as usize;
        order.clear();
        order.extend(base as u32..(base + g.count as usize) as u32);
        order.sort_by_key(|&p| rank[p as usize]);
        for (k, &old) in order.iter().enumerate() {
            new_of[old as usize] = (base + k) as u32;
        }
    }
    let permute = |len: usize, offset: usize| {
        let mut old_at = vec![0usize; len];
        for (old, &new) in new_of[offset..offset + len].iter().enumerate() {
            old_at[new as usize - offset] = old;
        }
        old_at
    };
    let old_at = permute(segments, 0);
    out.segments = old_at.iter().map(|&i| out.segments[i]).collect();
    out.attributes = old_at.iter().map(|&i| out.attributes[i]).collect();
    let old_at = permute(out.spheres.len(), segments);
    out.spheres = old_at.iter().map(|&i| out.spheres[i]).collect();
    for p in &mut out.bvh_primitives {
        *p = new_of[bc::slot_primitive(*p) as usize] | (*p & !bc::SLOT_PRIMITIVE_MASK);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{BezierSegment, Camera, Curves};
    use glam::Mat4;

    /// `n` bent strands (0.35 long, radius 0.004 → 0.001) on the unit sphere around `centre`, seen by
    /// a 50 mm camera at the origin looking down −Z on a 256-pixel image.
    fn groom(centre: Vec3, n: usize) -> Scene {
        let segments = (0..n)
            .map(|i| {
                // Fibonacci sphere directions.
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                let phi = i as f32 * 2.399_963;
                let r = (1.0 - z * z).sqrt();
                let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                let bend = dir.any_orthonormal_vector() * 0.15;
                let root = centre + dir;
                let p = [
                    root.extend(0.004),
                    (root + dir * 0.12 + bend * 0.1).extend(0.003),
                    (root + dir * 0.23 + bend * 0.3).extend(0.002),
                    (root + dir * 0.3 + bend * 0.55).extend(0.001),
                ];
                BezierSegment { p, u: [0.0, 1.0], ..BezierSegment::default() }
            })
            .collect();
        Scene {
            curves: vec![Curves { path: "/Groom".into(), segments, curve_count: n, ..Curves::default() }],
            materials: vec![crate::scene::Material::default()],
            cameras: vec![Camera {
                path: "/Cam".into(),
                world_from_camera: Mat4::IDENTITY,
                orthographic: false,
                focal_length: 50.0,
                horizontal_aperture: 36.0,
                vertical_aperture: 36.0,
                horizontal_aperture_offset: 0.0,
                vertical_aperture_offset: 0.0,
                clipping_range: [0.1, 1000.0],
                lens: Default::default(),
                shutter: [0.0; 2],
                motion: None,
            }],
            default_camera: Some(0),
            resolution: Some([256, 256]),
            meters_per_unit: 1.0,
            ..Scene::default()
        }
    }

    fn pieces(scene: &Scene, split: Split) -> usize {
        crate::pack::pack_with(scene, split).unwrap().curves.segments.len()
    }

    #[test]
    fn distant_and_off_screen_grooms_get_fewer_pieces() {
        let split = Split::default();
        let near = pieces(&groom(Vec3::new(0.0, 0.0, -4.0), 500), split);
        let far = pieces(&groom(Vec3::new(0.0, 0.0, -40.0), 500), split);
        let behind = pieces(&groom(Vec3::new(0.0, 0.0, 4.0), 500), split);
        // Near: 256 px over 2.88 units, so 0.25 px is 2.8e-3 units, and the strands bend by ~0.1:
        // several halvings each. Ten times farther, each halving quarters the deviation: about one
        // halving fewer per strand. Behind the camera: one piece per strand.
        let farther = pieces(&groom(Vec3::new(0.0, 0.0, -200.0), 500), split);
        // Near: 256 px over 2.88 units, so 0.25 px is ~2.5e-3 units there, and each strand's chord
        // deviation is 0.03: two halvings (each quarters the deviation; a few strands nearest the eye
        // need three). Ten times farther, one; fifty times farther or behind the camera, none.
        assert!((2000..2050).contains(&near), "{near}");
        assert_eq!((far, farther, behind), (1000, 500, 500));
        // No camera: split for the view `render` frames the groom with (512 px over 45°, 6.2 units
        // from its centre): a pixel there is about as wide as at the near camera, so as many pieces.
        let mut framed = groom(Vec3::new(0.0, 0.0, -4.0), 500);
        framed.default_camera = None;
        let framed = pieces(&framed, split);
        assert!(framed * 2 > near && framed < 2 * near, "framed {framed}, near {near}");
        // The width criterion alone stops at a tenth of the thinnest width (2e-4 here) at any distance.
        let wide = Split::Adaptive { pixels: 0.0, width_fraction: 0.1, max_depth: 6 };
        assert_eq!(
            pieces(&groom(Vec3::new(0.0, 0.0, -4.0), 50), wide),
            pieces(&groom(Vec3::new(0.0, 0.0, -40.0), 50), wide)
        );
    }

    #[test]
    fn camera_tolerance_is_a_fraction_of_a_pixel_or_of_the_width() {
        let scene = groom(Vec3::ZERO, 1);
        let camera = split_camera(&scene, Vec3::ZERO, Vec3::ONE);
        // focal_px = 50 / 36 × 256; at distance 10 a pixel is 10 / focal_px units.
        let pixel = 10.0 / (50.0 / 36.0 * 256.0);
        let piece = |z: f32, r: f32| [0.0, 0.01, 0.02, 0.03].map(|x| Vec4::new(x, 0.0, z, r));
        let thin = CameraTolerance::new(&camera, 0.25, 0.1).of(&piece(-10.0, 1e-4));
        assert!((thin / (0.25 * pixel) - 1.0).abs() < 1e-4, "{thin}");
        let thick = CameraTolerance::new(&camera, 0.25, 0.1).of(&piece(-10.0, 0.5));
        assert!((thick - 0.1).abs() < 1e-6, "{thick}");
        assert_eq!(CameraTolerance::new(&camera, 0.25, 0.1).of(&piece(10.0, 1e-4)), f32::INFINITY);
    }

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

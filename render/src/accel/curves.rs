//! Ray queries against curves and points: their own CWBVH (blob sections 44–45), cubic Bézier
//! segments intersected as round tubes or flat ribbons, and spheres.
//!
//! The triangle BVH (`accel`) is not touched; the integrator asks both and keeps the closer hit.
//!
//! # BVH
//! A BVH slot names a segment or a *piece* of one (a half, quarter or eighth: see
//! `blob::curves::slot`); ingest gives long or bent segments several pieces with their own tight
//! boxes, and stores segments in the order the BVH leaves name them. On the 100k-strand groom of
//! `bench curves` (one Bézier per strand) pieces cut the candidate segments per primary ray from 95
//! to 15 and leaf order removed most cache misses on segment records (the first load of a record
//! was two thirds of the segment test's time).
//!
//! # Segment test
//! The piece is moved into ray space (ray along +z through the origin) and culled on its control
//! points' box grown by the largest radius, then recursively halved (Nakamaru & Ohno 2002; pbrt-v4
//! `Curve::RecursiveIntersect`) with the same culling; at the leaf depth the piece is replaced by its
//! chord and tested exactly:
//! - **tube**: the chord's round cone (radius linear between the ends) united with spheres at both ends
//!   (Embree's "round linear curve"): the spheres close the wedge between pieces on the outside of a
//!   bend, so there are no cracks at joints, at any width and any angle. Only entries into the fibre
//!   count (see `round_cone`): a ray that starts inside a fibre, as rays leaving a fibre at grazing
//!   angles do, does not meet its inner joint spheres or the far wall, so a straight fibre is hit once
//!   however many pieces it has.
//! - **ribbon**: the closest point of the chord to the ray in the image plane, accepted between the
//!   end perpendiculars (half-open, so neighbouring pieces neither overlap nor leave a gap), width
//!   scaled by |n·d| for ribbons oriented by authored normals (camera-facing otherwise).
//!
//! The leaf depth is chosen per piece from its flatness in ray space against 5 % of its radius,
//! capped by [`CurveAccel::max_refine`] (pbrt's rule; ingest already split segments for the camera, so
//! most pieces need depth 0–3). `max_refine = 0` trusts ingest's splitting and the BVH pieces.
//!
//! Throughput on that groom (4 pieces per strand, primary rays, one thread, contended machine):
//! 0.47 Mrays/s; Embree 4's round Bézier curves on the same segments and rays, 1.3 Mrays/s
//! (`bench/embree_curves.c`). Traversal and the segment test take about equal shares.
//!
//! Tried and kept out: obvhs's `slow_build` for the curve BVH (fewer candidates on one-piece strands,
//! more on split ones; no clear gain at twice the build time).

use crate::bsdf::Frame;
use blob::curves::{CURVE_POINTS, CURVE_RIBBON, CURVE_TUBE};
use glam::{UVec2, Vec3, Vec3A, Vec4};
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::Traversal;
use obvhs::ray::Ray as BvhRay;
use obvhs::traverse;

/// How curves are drawn, overriding the per-prim choice (`render --curve-shape`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveShape {
    /// Round tubes.
    Tube,
    /// Flat ribbons (oriented by authored normals where present, else facing the ray).
    Ribbon,
}

/// A ray's hit on a curve segment or a point sphere.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurveHit {
    /// Ray parameter (in multiples of the ray direction).
    pub t: f32,
    /// Segment index, or `segments.len() + sphere` for a point.
    pub prim: u32,
    /// Curve parameter within the segment.
    pub u: f32,
    /// World-space hit point.
    pub p: Vec3,
    /// Geometric normal facing the ray origin.
    pub n: Vec3,
    /// Unit tangent along the fibre (zero for points).
    pub tangent: Vec3,
    /// Offset across the fibre in [−1, 1] (the hair BSDF's `h`).
    pub h: f32,
    /// Radius at the hit.
    pub radius: f32,
}

/// Read-only curve acceleration structure over the mapped blob sections.
#[derive(Clone, Copy, Debug)]
pub struct CurveAccel<'a> {
    /// CWBVH nodes (the field name is what `obvhs::traverse!` expects).
    nodes: &'a [CwBvhNode],
    view: blob::CurveView<'a>,
    /// Forced shape, or `None` for each prim's own.
    pub shape: Option<CurveShape>,
    /// Largest recursive-halving depth of the segment test.
    pub max_refine: u32,
}

/// Default [`CurveAccel::max_refine`]: at most 16 chords per stored segment.
pub const DEFAULT_MAX_REFINE: u32 = 4;

impl<'a> CurveAccel<'a> {
    /// Wraps the validated view's curve sections.
    pub fn new(view: &blob::SceneView<'a>) -> Self {
        CurveAccel {
            nodes: bytemuck::cast_slice::<blob::CwBvhNode, CwBvhNode>(view.curves.bvh_nodes),
            view: view.curves,
            shape: None,
            max_refine: DEFAULT_MAX_REFINE,
        }
    }

    /// Whether there is anything to intersect.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The blob's curve sections.
    pub fn view(&self) -> &blob::CurveView<'a> {
        &self.view
    }

    /// The group (prim) a primitive belongs to.
    pub fn group_of(&self, prim: u32) -> &'a blob::CurveGroup {
        let segments = self.view.segments.len() as u32;
        let group = if prim < segments {
            self.view.segments[prim as usize].group
        } else {
            self.view.spheres[(prim - segments) as usize].group
        };
        &self.view.groups[group as usize]
    }

    /// Closest hit with `t` in (0, `tmax`).
    pub fn closest_hit(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<CurveHit> {
        if self.nodes.is_empty() {
            return None;
        }
        let query = Query::new(origin, direction);
        let mut ray = BvhRay::new(Vec3A::from(origin), Vec3A::from(direction), 0.0, tmax);
        let mut state = Traversal::default();
        state.reinit(ray.direction);
        let mut best = None;
        let mut node: &CwBvhNode;
        traverse!(self, node, state, node.intersect_ray(&ray, state.oct_inv4), {
            let slot = self.view.bvh_primitives[state.primitive_id as usize];
            if let Some(hit) = self.intersect(&query, slot, ray.tmax) {
                ray.tmax = hit.t;
                best = Some(hit);
            }
        });
        best
    }

    /// True if any curve or point is hit with `t` in (0, `tmax`).
    pub fn any_hit(&self, origin: Vec3, direction: Vec3, tmax: f32) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let query = Query::new(origin, direction);
        let ray = BvhRay::new(Vec3A::from(origin), Vec3A::from(direction), 0.0, tmax);
        let mut state = Traversal::default();
        state.reinit(ray.direction);
        let mut node: &CwBvhNode;
        let mut hit = false;
        'walk: {
            traverse!(self, node, state, node.intersect_ray(&ray, state.oct_inv4), {
                let slot = self.view.bvh_primitives[state.primitive_id as usize];
                if self.intersect(&query, slot, tmax).is_some() {
                    hit = true;
                    break 'walk;
                }
            });
        }
        hit
    }

    /// Reference closest hit testing every primitive (for tests).
    pub fn closest_hit_brute_force(&self, origin: Vec3, direction: Vec3, tmax: f32) -> Option<CurveHit> {
        let query = Query::new(origin, direction);
        let mut best: Option<CurveHit> = None;
        for prim in 0..(self.view.segments.len() + self.view.spheres.len()) as u32 {
            if let Some(h) = self.intersect(&query, prim, best.map_or(tmax, |b| b.t)) {
                best = Some(h);
            }
        }
        best
    }

    /// Intersects the primitive (segment piece or sphere) of BVH slot value `slot` with `t` in
    /// (0, `tmax`).
    fn intersect(&self, q: &Query, slot: u32, tmax: f32) -> Option<CurveHit> {
        let prim = blob::curves::slot_primitive(slot);
        let segments = self.view.segments.len() as u32;
        if prim >= segments {
            let s = &self.view.spheres[(prim - segments) as usize];
            let (t, n) = sphere(q, Vec3::from(s.center), s.radius, tmax)?;
            return Some(CurveHit {
                t,
                prim,
                u: 0.0,
                p: q.origin + q.direction * t,
                n,
                tangent: Vec3::ZERO,
                h: 0.0,
                radius: s.radius,
            });
        }
        let seg = &self.view.segments[prim as usize];
        let group = &self.view.groups[seg.group as usize];
        let shape = match (self.shape, group.kind) {
            (Some(CurveShape::Tube), _) => CURVE_TUBE,
            (Some(CurveShape::Ribbon), _) => CURVE_RIBBON,
            (None, k) => k,
        };
        debug_assert!(group.kind != CURVE_POINTS);
        let normals = (shape == CURVE_RIBBON && group.flags & blob::curves::CURVE_HAS_NORMALS != 0)
            .then(|| self.view.attributes[prim as usize].normal.map(Vec3::from));
        // Ray space: origin at 0, direction +z (unit); t along the unit direction.
        let mut cp = seg.p.map(|p| {
            let v = Vec4::from(p);
            q.frame.to_local(v.truncate() - q.origin).extend(v.w)
        });
        // The slot's piece: follow the heap path from the root (each bit picks a half).
        let piece = blob::curves::slot_piece(slot);
        if piece != 0 {
            let node = piece + 1;
            for bit in (0..31 - node.leading_zeros()).rev() {
                let (a, b) = split(&cp);
                cp = if node >> bit & 1 == 0 { a } else { b };
            }
        }
        let tmax_len = tmax * q.length;
        // Most candidates from the BVH miss their piece's hull: skip the refinement set-up for them.
        if misses_hull(&cp, tmax_len) {
            return None;
        }
        let [u0, u1] = blob::curves::slot_piece_range(piece);
        let depth = refine_depth(&cp, self.max_refine);
        let mut best: Option<(f32, f32)> = None; // (t_len, u)
                                                 // Sphere caps only where the authored curve ends; elsewhere pieces meet neighbours.
        let caps = [u0 == 0.0 && seg.u[0] == 0.0, u1 == 1.0 && seg.u[1] == 1.0];
        recurse(&cp, u0, u1, caps, depth, shape, normals.as_ref(), q, tmax_len, &mut best);
        let (t_len, u) = best?;
        self.finish(q, prim, &seg.p, t_len, u, shape, normals.as_ref())
    }

    /// Hit point, normal, tangent and `h` for a segment hit at unit-length parameter `t_len`, curve
    /// parameter `u`.
    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        q: &Query,
        prim: u32,
        p: &[[f32; 4]; 4],
        t_len: f32,
        u: f32,
        shape: u32,
        normals: Option<&[Vec3; 2]>,
    ) -> Option<CurveHit> {
        let p = p.map(Vec4::from);
        let c = eval(&p, u);
        let tangent = derivative(&p, u).truncate().try_normalize().unwrap_or(Vec3::X);
        let hit = q.origin + q.dir * t_len;
        let radius = c.w.max(0.0);
        let axis = c.truncate();
        // Frame of the hair BSDF: x along the fibre, z towards the viewer (perpendicular to x).
        let wo = -q.dir;
        let z = (wo - tangent * wo.dot(tangent)).try_normalize().unwrap_or(wo);
        let y = z.cross(tangent);
        let n = match (shape, normals) {
            (CURVE_RIBBON, Some(n)) => {
                let n = n[0].lerp(n[1], u).try_normalize().unwrap_or(z);
                if n.dot(wo) < 0.0 {
                    -n
                } else {
                    n
                }
            }
            (CURVE_RIBBON, None) => z,
            _ => {
                // Round cone normal: radial direction tilted by the taper.
                let radial = (hit - axis) - tangent * (hit - axis).dot(tangent);
                let dr = derivative(&p, u).w / derivative(&p, u).truncate().length().max(1e-12);
                let n = (radial.try_normalize().unwrap_or(z) - tangent * dr).try_normalize().unwrap_or(z);
                if n.dot(wo) < 0.0 {
                    -n
                } else {
                    n
                }
            }
        };
        let h = if radius > 0.0 { ((hit - axis).dot(y) / radius).clamp(-1.0, 1.0) } else { 0.0 };
        Some(CurveHit { t: t_len / q.length, prim, u, p: hit, n, tangent, h, radius })
    }
}

/// Per-ray precomputation.
struct Query {
    origin: Vec3,
    /// The ray direction as given.
    direction: Vec3,
    /// Unit direction.
    dir: Vec3,
    /// |direction|.
    length: f32,
    /// Ray space: z along `dir`.
    frame: Frame,
}

impl Query {
    fn new(origin: Vec3, direction: Vec3) -> Self {
        let length = direction.length();
        let dir = direction / length;
        Query { origin, direction, dir, length, frame: Frame::new(dir) }
    }
}

fn eval(p: &[Vec4; 4], t: f32) -> Vec4 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

fn derivative(p: &[Vec4; 4], t: f32) -> Vec4 {
    let s = 1.0 - t;
    3.0 * ((p[1] - p[0]) * (s * s) + (p[2] - p[1]) * (2.0 * s * t) + (p[3] - p[2]) * (t * t))
}

fn split(p: &[Vec4; 4]) -> ([Vec4; 4], [Vec4; 4]) {
    let ab = (p[0] + p[1]) * 0.5;
    let bc = (p[1] + p[2]) * 0.5;
    let cd = (p[2] + p[3]) * 0.5;
    let abc = (ab + bc) * 0.5;
    let bcd = (bc + cd) * 0.5;
    let m = (abc + bcd) * 0.5;
    ([p[0], ab, abc, m], [m, bcd, cd, p[3]])
}

/// pbrt-v4's leaf depth: halvings needed for the chord to be within 5 % of the radius.
fn refine_depth(cp: &[Vec4; 4], max: u32) -> u32 {
    if max == 0 {
        return 0;
    }
    let l0 = (0..2)
        .map(|i| (cp[i] - 2.0 * cp[i + 1] + cp[i + 2]).truncate().abs().max_element())
        .fold(0.0f32, f32::max);
    let radius = cp.iter().map(|c| c.w).fold(0.0f32, f32::max);
    let eps = (0.05 * radius).max(1e-7);
    let r0 = (std::f32::consts::SQRT_2 * 6.0 * l0 / (8.0 * eps)).log2() * 0.5;
    if r0.is_finite() {
        (r0.ceil().max(0.0) as u32).min(max)
    } else {
        0
    }
}

/// Whether the ray (origin 0, direction +z, up to `limit`) misses the box of the control points
/// of `cp` grown by their largest radius (which holds the piece's tube or ribbon).
fn misses_hull(cp: &[Vec4; 4], limit: f32) -> bool {
    let r = cp.iter().map(|c| c.w).fold(0.0f32, f32::max);
    let (mut lo, mut hi) = (cp[0].truncate(), cp[0].truncate());
    for c in &cp[1..] {
        lo = lo.min(c.truncate());
        hi = hi.max(c.truncate());
    }
    lo.x - r > 0.0 || hi.x + r < 0.0 || lo.y - r > 0.0 || hi.y + r < 0.0 || hi.z + r < 0.0 || lo.z - r > limit
}

#[allow(clippy::too_many_arguments)]
fn recurse(
    cp: &[Vec4; 4],
    u0: f32,
    u1: f32,
    caps: [bool; 2],
    depth: u32,
    shape: u32,
    normals: Option<&[Vec3; 2]>,
    q: &Query,
    tmax: f32,
    best: &mut Option<(f32, f32)>,
) {
    let limit = best.map_or(tmax, |b| b.0);
    if misses_hull(cp, limit) {
        return;
    }
    if depth > 0 {
        let (a, b) = split(cp);
        let m = 0.5 * (u0 + u1);
        recurse(&a, u0, m, [caps[0], false], depth - 1, shape, normals, q, tmax, best);
        recurse(&b, m, u1, [false, caps[1]], depth - 1, shape, normals, q, tmax, best);
        return;
    }
    let hit =
        if shape == CURVE_TUBE { round_cone(cp, caps, limit) } else { ribbon(cp, u0, u1, normals, q, limit) };
    if let Some((t, w)) = hit {
        *best = Some((t, u0 + (u1 - u0) * w));
    }
}

/// Whether `x` lies inside the cone that starts at `p`, runs `len` along the unit `dir` and has radius
/// `r + k·m` at distance `m` along it.
fn inside_cone(x: Vec3, p: Vec3, dir: Vec3, len: f32, r: f32, k: f32) -> bool {
    let m = (x - p).dot(dir);
    (0.0..=len).contains(&m) && (x - p - dir * m).length_squared() < (r + k * m).powi(2)
}

/// `v` mirrored about the unit axis `axis`.
fn reflect_about(v: Vec3, axis: Vec3) -> Vec3 {
    2.0 * v.dot(axis) * axis - v
}

/// Ray (origin 0, direction +z) against the chord of the piece `cp` as a round cone (radius linear
/// between the ends) united with spheres at both ends: nearest entry in (0, `tmax`) and the axial
/// parameter of the hit.
///
/// Only *entries* into the fibre count, so a ray meets a straight fibre once however many pieces it
/// is cut into, from any origin:
/// - a piece whose cone contains the ray origin is skipped (the ray is leaving its own fibre);
/// - cone roots where the ray leaves the surface (outward normal along the ray) are skipped;
/// - sphere points inside the piece's own cone are inner surface and skipped; so are, at a joint
///   with a neighbouring piece (`caps[i]` false), sphere points inside the neighbour's cone, which is
///   estimated as this cone mirrored about the curve tangent at the joint (exact for a straight
///   fibre; for a bent one the neighbour's chord is this chord reflected about the shared tangent up
///   to the curve's third derivative). At a bend the sphere then only fills the wedge outside both
///   cones; at the ends of an authored curve (`caps[i]` true) it is the cap.
fn round_cone(cp: &[Vec4; 4], caps: [bool; 2], tmax: f32) -> Option<(f32, f32)> {
    let (pa, pb) = (cp[0].truncate(), cp[3].truncate());
    let (ra, rb) = (cp[0].w, cp[3].w);
    let axis = pb - pa;
    let len = axis.length();
    let u = if len > 1e-12 { axis / len } else { Vec3::ZERO };
    let k = if len > 1e-12 { (rb - ra) / len } else { 0.0 };
    if len > 1e-12 && inside_cone(Vec3::ZERO, pa, u, len, ra, k) {
        return None;
    }
    let mut best: Option<(f32, f32)> = None;
    let mut consider = |t: f32, w: f32| {
        if t > 0.0 && t < tmax && best.is_none_or(|b| t < b.0) {
            best = Some((t, w.clamp(0.0, 1.0)));
        }
    };
    // End spheres: |t z − c|² = r² → t = c.z ± √(r² − c.x² − c.y²) (no cancellation for far spheres).
    let tangent = |d: Vec3, fallback: Vec3| d.try_normalize().unwrap_or(fallback);
    let ends = [
        (pa, ra, 0.0, caps[0], tangent(cp[1].truncate() - pa, u), -1.0f32),
        (pb, rb, 1.0, caps[1], tangent(pb - cp[2].truncate(), u), 1.0),
    ];
    for (c, r, w, cap, joint_tangent, side) in ends {
        let disc = r * r - (c.x * c.x + c.y * c.y);
        if disc < 0.0 || c.length_squared() <= r * r {
            continue;
        }
        let t = c.z - disc.sqrt();
        let x = Vec3::new(0.0, 0.0, t);
        if len > 1e-12 && inside_cone(x, pa, u, len, ra, k) {
            continue;
        }
        // The neighbour continues away from this piece: backwards from `a`, forwards from `b`.
        let neighbour = side * reflect_about(u, joint_tangent);
        if !cap && len > 1e-12 && inside_cone(x, c, neighbour, len, r, side * k) {
            continue;
        }
        consider(t, w);
    }
    if len > 1e-12 {
        // Solve about the point of the ray level with the piece (shift the origin to z = a.z), so the
        // quadratic's terms are of the piece's size and thin far tubes keep their precision.
        let shift = pa.z;
        // X − a = t' z + w0 with w0 = (−a.x, −a.y, 0); split into parts along and across the axis.
        let w0 = Vec3::new(-pa.x, -pa.y, 0.0);
        let (uz, wu) = (u.z, w0.dot(u));
        let z_perp = Vec3::Z - u * uz;
        let w_perp = w0 - u * wu;
        let r0 = ra + k * wu;
        // |t' z⊥ + w⊥|² = (r0 + k uz t')².
        let qa = z_perp.length_squared() - k * k * uz * uz;
        let qb = 2.0 * (z_perp.dot(w_perp) - k * uz * r0);
        let qc = w_perp.length_squared() - r0 * r0;
        if qa.abs() > 1e-12 {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                let s = disc.sqrt();
                // Numerically stable roots.
                let qq = -0.5 * (qb + qb.signum() * s);
                let mut roots = [qq / qa, if qq != 0.0 { qc / qq } else { f32::INFINITY }];
                roots.sort_by(|x, y| x.total_cmp(y));
                for t in roots {
                    let m = t * uz + wu;
                    let radial = z_perp * t + w_perp;
                    // Outward normal ∝ radial/|radial| − k u; an entry has it against +z.
                    let entering = radial.z - k * uz * radial.length() < 0.0;
                    if (0.0..=len).contains(&m) && r0 + k * uz * t > 0.0 && entering {
                        consider(t + shift, m / len);
                        break;
                    }
                }
            }
        }
    }
    best
}

/// Flat ribbon test of the chord of `cp` (ray space), pbrt-v4 style.
fn ribbon(
    cp: &[Vec4; 4],
    u0: f32,
    u1: f32,
    normals: Option<&[Vec3; 2]>,
    q: &Query,
    tmax: f32,
) -> Option<(f32, f32)> {
    // Half-open between the perpendiculars at the ends (through the end tangents, shared with
    // neighbouring pieces of a C¹ curve).
    let edge0 = (cp[1].y - cp[0].y) * -cp[0].y + cp[0].x * (cp[0].x - cp[1].x);
    if edge0 < 0.0 {
        return None;
    }
    let edge1 = (cp[2].y - cp[3].y) * -cp[3].y + cp[3].x * (cp[3].x - cp[2].x);
    if edge1 <= 0.0 {
        return None;
    }
    let seg = (cp[3] - cp[0]).truncate();
    let denom = seg.x * seg.x + seg.y * seg.y;
    if denom == 0.0 {
        return None;
    }
    let w = ((-cp[0].x * seg.x - cp[0].y * seg.y) / denom).clamp(0.0, 1.0);
    let c = eval(cp, w);
    let mut half = c.w;
    if let Some(n) = normals {
        let u = u0 + (u1 - u0) * w;
        let n = n[0].lerp(n[1], u).try_normalize()?;
        half *= n.dot(q.dir).abs();
    }
    if c.x * c.x + c.y * c.y > half * half {
        return None;
    }
    (c.z > 0.0 && c.z < tmax).then_some((c.z, w))
}

/// Ray–sphere: nearest entry in (0, `tmax`) and the outward normal (flipped towards the origin).
fn sphere(q: &Query, center: Vec3, radius: f32, tmax: f32) -> Option<(f32, Vec3)> {
    let oc = q.origin - center;
    let b = oc.dot(q.dir);
    // Distance² from the centre to the ray's line, computed without cancellation.
    let perp = oc - q.dir * b;
    let disc = radius * radius - perp.length_squared();
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let c = oc.length_squared() - radius * radius;
    // Stable roots; an origin outside the sphere (c > 0) only hits its near side, one inside the far.
    let (near, far) = if b > 0.0 {
        let near = -b - s;
        (near, if near != 0.0 { c / near } else { 0.0 })
    } else {
        let far = -b + s;
        (if far != 0.0 { c / far } else { 0.0 }, far)
    };
    let t_len = if c > 0.0 { near } else { far };
    let t = t_len / q.length;
    if !(t > 0.0 && t < tmax) {
        return None;
    }
    let p = q.origin + q.dir * t_len;
    let mut n = ((p - center) / radius.max(1e-30)).normalize_or_zero();
    if n.dot(q.dir) > 0.0 {
        n = -n;
    }
    Some((t, n))
}

// `traverse!` names `UVec2`.
const _: UVec2 = UVec2::ZERO;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::{self, Rng};
    use crate::{render_image, RenderOptions};
    use glam::Vec4;
    use scene_pack::{BezierSegment, CurveKind, Curves, Scene};

    /// A straight tube from `a` to `b` of constant `radius` as one Bézier segment.
    fn straight(a: Vec3, b: Vec3, radius: f32, kind: CurveKind) -> Curves {
        let p = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0].map(|t| a.lerp(b, t).extend(radius));
        Curves {
            path: "/curve".into(),
            kind,
            segments: vec![BezierSegment { p, u: [0.0, 1.0], ..BezierSegment::default() }],
            material: 0,
            curve_count: 1,
            ..Curves::default()
        }
    }

    fn scene_with(curves: Vec<Curves>) -> Scene {
        Scene {
            curves,
            materials: vec![testscene::lambert(0.8)],
            cameras: vec![testscene::camera_looking_down_z(Vec3::new(0.0, 0.0, 10.0), 20.0)],
            default_camera: Some(0),
            lights: vec![testscene::dome(1.0)],
            meters_per_unit: 1.0,
            ..Scene::default()
        }
    }

    fn coverage(image: &crate::Image) -> f64 {
        image.beauty.iter().map(|p| p[3] as f64).sum()
    }

    #[test]
    fn blob_and_obvhs_agree_on_which_children_are_internal() {
        // Parse proves the curve BVH a tree with `blob::tree::cw_child_is_internal`; the traversal is
        // obvhs' macro, which decides from the meta byte itself. With every octant bit set, obvhs
        // flips the low three bits of exactly the children it treats as internal.
        for meta in 0..=255u8 {
            let node = CwBvhNode { child_meta: [meta; 8], ..CwBvhNode::default() };
            let (_, bit_index) = node.get_child_and_index_bits(0x0707_0707);
            let obvhs_internal = (bit_index & 0xff) as u8 != meta & 0b1_1111;
            assert_eq!(obvhs_internal, blob::tree::cw_child_is_internal(meta), "meta {meta:#010b}");
        }
    }

    #[test]
    fn straight_curve_covers_the_expected_pixels() {
        // Camera: focal 20, aperture 20 → a 10-unit-wide view at distance 10 on 200 px (0.05 units/px).
        // A curve 6 units long and w units wide at distance 10 covers (6/0.05)·(w/0.05) px; end caps of
        // the tube add π(w/2)² − nothing for ribbons.
        for (kind, shape) in [(CurveKind::Tube, CurveShape::Tube), (CurveKind::Tube, CurveShape::Ribbon)] {
            for w in [0.5f32, 0.1, 0.02, 0.005] {
                let scene = scene_with(vec![straight(
                    Vec3::new(-3.0, 0.2, 0.0),
                    Vec3::new(3.0, -0.3, 0.0),
                    0.5 * w,
                    kind,
                )]);
                let bytes = testscene::bytes(&scene);
                let view = blob::SceneView::parse(&bytes).unwrap();
                let spp = if w < 0.05 { 64 } else { 16 };
                let options = RenderOptions {
                    spp,
                    resolution: Some([200, 200]),
                    max_depth: 0,
                    curve_shape: Some(shape),
                    ..RenderOptions::default()
                };
                let image = render_image(&view, &options).unwrap();
                let length = (Vec3::new(6.0, -0.5, 0.0)).length();
                let px = 0.05f64;
                let caps = if shape == CurveShape::Tube {
                    std::f64::consts::PI * (w as f64 / 2.0).powi(2)
                } else {
                    0.0
                };
                let expected = (length as f64 * w as f64 + caps) / (px * px);
                let got = coverage(&image);
                let error = (got - expected).abs() / expected;
                assert!(
                    error < 0.05,
                    "{shape:?} w {w}: {got:.1} px covered, expected {expected:.1} ({:.1} %)",
                    error * 100.0
                );
            }
        }
    }

    #[test]
    fn thin_tubes_cover_their_analytic_fraction_at_grazing_angles_without_double_hits() {
        // A straight tube of radius r = 1e-3 along a diagonal axis, authored as 8 segments and split
        // in two each at ingest (pieces of slots on top): 15 joints. A ray meets an infinite straight
        // tube iff its closest approach to the axis is under r, at any angle to the axis; offsets
        // across a strip of 8r, stratified, give exactly 100 of 400 rays per position along the axis.
        let r = 1e-3f32;
        let axis = Vec3::new(1.0, 0.7, 0.4).normalize();
        let segments = (0..8)
            .map(|k| {
                let (a, b) = (axis * (-1.0 + 0.25 * k as f32), axis * (-0.75 + 0.25 * k as f32));
                let p = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0].map(|t| a.lerp(b, t).extend(r));
                BezierSegment { p, u: [k as f32 / 8.0, (k + 1) as f32 / 8.0], ..BezierSegment::default() }
            })
            .collect();
        let curves = vec![Curves { path: "/c".into(), segments, curve_count: 1, ..Curves::default() }];
        let data =
            scene_pack::pack::pack_with(&scene_with(curves), scene_pack::pack::Split::Fixed(2)).unwrap();
        let bytes = blob::AlignedBytes::copy_from(&data.encode());
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = CurveAccel::new(&view);
        assert_eq!(view.curves.segments.len(), 16);
        let e1 = axis.any_orthonormal_vector();
        let e2 = axis.cross(e1);
        // Positions along the axis include joints (multiples of 0.125).
        let positions: Vec<f32> = (0..=96).map(|i| -0.6 + 1.2 * i as f32 / 96.0).collect();
        for degrees in [90.0f32, 30.0, 5.0, 1.0] {
            let (sin, cos) = degrees.to_radians().sin_cos();
            let d = axis * cos + e1 * sin;
            let (mut hits, mut double) = (0usize, 0u32);
            for &s in &positions {
                for i in 0..400 {
                    let o = r * (-4.0 + (i as f32 + 0.5) / 50.0);
                    let origin = axis * s + e2 * o - d * 3.0;
                    let Some(h) = accel.closest_hit(origin, d, f32::INFINITY) else { continue };
                    hits += 1;
                    // Continue from just inside (1 % of r across the surface): nothing more.
                    let inside = h.p + d * (0.01 * r / sin);
                    double += accel.closest_hit(inside, d, f32::INFINITY).is_some() as u32;
                }
            }
            let expected = 100 * positions.len();
            assert!(
                hits.abs_diff(expected) <= positions.len(),
                "{degrees}°: {hits} hits, expected {expected}"
            );
            assert_eq!(double, 0, "{degrees}°: rays continuing inside the tube hit it again");
        }
    }

    /// A shaded coverage image (4 × 4 rays per pixel, coverage × (0.2 + 0.8 |n·l|)) of `accel` seen
    /// from `eye` down −Z with a 0.5 half-tangent, `res` pixels square.
    fn shaded_coverage(accel: &CurveAccel, eye: Vec3, res: u32) -> Vec<f32> {
        let light = Vec3::new(0.5, 0.7, 0.5).normalize();
        let mut image = Vec::new();
        for y in 0..res {
            for x in 0..res {
                let mut sum = 0.0;
                for j in 0..4 {
                    for i in 0..4 {
                        let fx = (x as f32 + (i as f32 + 0.5) / 4.0) / res as f32;
                        let fy = (y as f32 + (j as f32 + 0.5) / 4.0) / res as f32;
                        let d = Vec3::new(fx - 0.5, 0.5 - fy, -1.0);
                        sum += accel
                            .closest_hit(eye, d, f32::INFINITY)
                            .map_or(0.0, |h| 0.2 + 0.8 * h.n.dot(light).abs());
                    }
                }
                image.push(sum / 16.0);
            }
        }
        image
    }

    #[test]
    fn camera_split_groom_matches_a_finely_split_reference() {
        // 1500 bent strands (0.35 long, radius 0.004 → 0.001, a tenth of a pixel wide) on the unit
        // sphere, seen from distance 4 on 128 px. Split for the camera (the default: 0.25 px or a
        // tenth of the width) and traced as `render` does, against 16 pieces per strand refined to
        // 5 % of the radius. Measured: 3414 pieces (2.3 per strand), RMSE 0.00074; one piece per
        // strand with no render-time refinement (each BVH slot's piece one chord) is 0.0114.
        let mut rng = Rng(3);
        let segments = (0..1500)
            .map(|_| {
                let n = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0))
                    .normalize_or(Vec3::Z);
                let t = n.any_orthonormal_vector();
                let bend = (t * rng.range(-0.5, 0.5) + n.cross(t) * rng.range(-0.5, 0.5)) * 0.5;
                let p = [
                    n.extend(0.004),
                    (n * 1.1225 + bend * 0.105).extend(0.003),
                    (n * 1.2275 + bend * 0.315).extend(0.002),
                    (n * 1.2975 + bend * 0.56).extend(0.001),
                ];
                BezierSegment { p, u: [0.0, 1.0], ..BezierSegment::default() }
            })
            .collect();
        let mut scene = scene_with(vec![Curves {
            path: "/Groom".into(),
            segments,
            curve_count: 1500,
            ..Curves::default()
        }]);
        let eye = Vec3::new(0.0, 0.0, 4.0);
        scene.cameras = vec![testscene::camera_looking_down_z(eye, 20.0)];
        scene.resolution = Some([128, 128]);
        let image = |split: scene_pack::pack::Split, refine: u32| {
            let data = scene_pack::pack::pack_with(&scene, split).unwrap();
            let bytes = blob::AlignedBytes::copy_from(&data.encode());
            let view = blob::SceneView::parse(&bytes).unwrap();
            let mut accel = CurveAccel::new(&view);
            accel.max_refine = refine;
            (shaded_coverage(&accel, eye, 128), view.curves.segments.len())
        };
        let rmse = |a: &[f32], b: &[f32]| {
            (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f32>() / a.len() as f32).sqrt()
        };
        use scene_pack::pack::Split;
        let (reference, _) = image(Split::Fixed(16), DEFAULT_MAX_REFINE);
        let (split, pieces) = image(Split::default(), DEFAULT_MAX_REFINE);
        let (coarse, _) = image(Split::Fixed(1), 0);
        let (e_split, e_coarse) = (rmse(&split, &reference), rmse(&coarse, &reference));
        assert!((3000..4000).contains(&pieces), "{pieces} pieces");
        assert!(e_split < 0.002 && e_coarse > 5.0 * e_split, "split {e_split}, coarse {e_coarse}");
    }

    #[test]
    fn bvh_agrees_with_brute_force_on_random_curves() {
        let mut rng = Rng(99);
        let mut curves = Vec::new();
        for i in 0..60 {
            let p: [Vec4; 4] = std::array::from_fn(|_| {
                Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0))
                    .extend(rng.range(0.01, 0.2))
            });
            let kind = if i % 2 == 0 { CurveKind::Tube } else { CurveKind::Ribbon };
            curves.push(Curves {
                path: format!("/c{i}"),
                kind,
                segments: vec![BezierSegment { p, u: [0.0, 1.0], ..BezierSegment::default() }],
                material: 0,
                curve_count: 1,
                ..Curves::default()
            });
        }
        curves.push(Curves {
            path: "/points".into(),
            kind: CurveKind::Points,
            spheres: (0..40)
                .map(|_| scene_pack::PointSphere {
                    center: Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)),
                    radius: rng.range(0.02, 0.3),
                    color: Vec3::ONE,
                })
                .collect(),
            material: 0,
            curve_count: 40,
            ..Curves::default()
        });
        let bytes = testscene::bytes(&scene_with(curves));
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = CurveAccel::new(&view);
        let mut hits = 0;
        for _ in 0..5000 {
            let origin = Vec3::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0), rng.range(-5.0, 5.0));
            let target = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0));
            let dir = (target - origin).normalize();
            let fast = accel.closest_hit(origin, dir, f32::INFINITY);
            let slow = accel.closest_hit_brute_force(origin, dir, f32::INFINITY);
            match (fast, slow) {
                (None, None) => {}
                (Some(f), Some(s)) => {
                    hits += 1;
                    assert!((f.t - s.t).abs() <= 1e-4 * s.t.max(1.0), "{f:?} vs {s:?}");
                }
                other => panic!("BVH and brute force disagree: {other:?}"),
            }
            assert_eq!(accel.any_hit(origin, dir, f32::INFINITY), slow.is_some());
        }
        assert!(hits > 500, "{hits}");
    }

    #[test]
    fn tube_hits_from_every_angle_are_on_the_surface() {
        // A bent tube: every hit lies at the radius from the centreline, normals point outwards.
        let p = [
            Vec4::new(-1.0, 0.0, 0.0, 0.1),
            Vec4::new(-0.3, 1.0, 0.0, 0.1),
            Vec4::new(0.3, -1.0, 0.5, 0.1),
            Vec4::new(1.0, 0.0, 0.0, 0.1),
        ];
        let curves = vec![Curves {
            path: "/c".into(),
            segments: vec![BezierSegment { p, u: [0.0, 1.0], ..BezierSegment::default() }],
            curve_count: 1,
            ..Curves::default()
        }];
        let bytes = testscene::bytes(&scene_with(curves));
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = CurveAccel::new(&view);
        let mut rng = Rng(5);
        let mut hits = 0;
        for _ in 0..4000 {
            let origin = Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
            let target = Vec3::new(rng.range(-1.0, 1.0), rng.range(-0.6, 0.6), rng.range(-0.2, 0.4));
            let from_axis = |x: Vec3| {
                (0..=4000)
                    .map(|i| (eval(&p, i as f32 / 4000.0).truncate() - x).length())
                    .fold(f32::INFINITY, f32::min)
            };
            if from_axis(origin) < 0.15 {
                continue; // inside the fibre: rays leaving a fibre ignore it by design
            }
            let Some(h) = accel.closest_hit(origin, (target - origin).normalize(), f32::INFINITY) else {
                continue;
            };
            hits += 1;
            // Distance from the hit to the centreline (dense sampling).
            let d = from_axis(h.p);
            // The chord pieces deviate from the curve by < 5 % of the radius (plus sampling).
            assert!(
                (d - 0.1).abs() < 0.012,
                "hit {:.4} from the axis: {h:?} origin {origin} segs {}",
                d,
                view.curves.segments.len()
            );
            assert!(h.n.dot(origin - h.p) > 0.0, "normal faces the ray origin");
        }
        assert!(hits > 300, "{hits}");
    }

    #[test]
    fn curves_are_lit_by_a_distant_light() {
        let mut scene = scene_with(vec![straight(
            Vec3::new(-3.0, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
            0.3,
            CurveKind::Tube,
        )]);
        scene.lights = vec![scene_pack::Light {
            path: "/sun".into(),
            kind: scene_pack::LightKind::Distant { angle_degrees: 0.53 },
            radiance: Vec3::splat(3.0),
            normalize: true,
            world_from_light: glam::Mat4::from_rotation_x(-0.5),
        }];
        let bytes = testscene::bytes(&scene);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let options =
            RenderOptions { spp: 16, resolution: Some([40, 40]), max_depth: 1, ..RenderOptions::default() };
        let image = render_image(&view, &options).unwrap();
        let lit = image.beauty.iter().filter(|p| p[3] == 1.0 && p[1] > 0.01).count();
        let covered = image.beauty.iter().filter(|p| p[3] == 1.0).count();
        assert!(covered > 20 && lit * 2 > covered, "{lit} of {covered} covered pixels are lit");
    }

    #[test]
    fn sphere_point_under_a_white_dome_reads_its_albedo() {
        // A Lambertian sphere of albedo 0.8 under a uniform dome of radiance 1, direct + indirect: it
        // reads exactly its albedo (no other geometry, so nothing is occluded) at max_depth 1.
        let curves = vec![Curves {
            path: "/points".into(),
            kind: CurveKind::Points,
            spheres: vec![scene_pack::PointSphere {
                center: Vec3::ZERO,
                radius: 1.5,
                color: Vec3::splat(0.8),
            }],
            material: 0,
            curve_count: 1,
            ..Curves::default()
        }];
        let bytes = testscene::bytes(&scene_with(curves));
        let view = blob::SceneView::parse(&bytes).unwrap();
        let options =
            RenderOptions { spp: 64, resolution: Some([32, 32]), max_depth: 1, ..RenderOptions::default() };
        let image = render_image(&view, &options).unwrap();
        let (mut sum, mut n) = (0.0f64, 0);
        for (i, p) in image.beauty.iter().enumerate() {
            let (x, y) = (i % 32, i / 32);
            let r = ((x as f32 - 15.5).powi(2) + (y as f32 - 15.5).powi(2)).sqrt();
            if r < 6.0 && p[3] == 1.0 {
                sum += p[1] as f64;
                n += 1;
            }
        }
        let mean = sum / n as f64;
        assert!(n > 50 && (mean - 0.8).abs() < 0.02, "sphere reads {mean} over {n} px");
    }

    #[test]
    fn white_hair_under_a_white_dome_stays_below_one() {
        // A furnace for the hair BSDF in the renderer: white fibres (no absorption) under a dome of
        // radiance 1 at depth 1 reflect at most what they receive, and close to all of it.
        let mut c = straight(Vec3::new(-3.0, 0.0, 0.0), Vec3::new(3.0, 0.0, 0.0), 0.5, CurveKind::Tube);
        c.has_colors = true;
        c.segments[0].color = [Vec3::ONE; 2];
        let bytes = testscene::bytes(&scene_with(vec![c]));
        let view = blob::SceneView::parse(&bytes).unwrap();
        let options =
            RenderOptions { spp: 256, resolution: Some([40, 40]), max_depth: 1, ..RenderOptions::default() };
        let image = render_image(&view, &options).unwrap();
        let covered: Vec<f32> = image.beauty.iter().filter(|p| p[3] == 1.0).map(|p| p[1]).collect();
        let mean = covered.iter().sum::<f32>() / covered.len() as f32;
        assert!(
            covered.len() > 40 && mean <= 1.02 && mean > 0.85,
            "white hair reads {mean} over {} px",
            covered.len()
        );
    }
}

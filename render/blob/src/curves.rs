//! Curve and point records: cubic Bézier segments with per-control-point radii, their shading
//! attributes, point spheres, the prims they came from, and their own CWBVH.
//!
//! Ingest converts every USD basis (bezier, bspline, catmullRom, linear; nonperiodic, periodic,
//! pinned) and NurbsCurves to cubic Bézier segments, splits them adaptively for the default camera and
//! builds a BVH over the pieces; render intersects them as tubes or ribbons. Points are spheres.
//!
//! Sections (kinds 40–45): [`CurveGroup`] per prim, [`CurveSegment`] and [`CurveAttributes`] in
//! parallel, [`PointSphere`], then the curve BVH ([`crate::CwBvhNode`]) and its primitive slots: a slot
//! value `v < segments.len()` names segment `v`, otherwise sphere `v − segments.len()`.

use crate::records::StrRef;
use bytemuck::{Pod, Zeroable};

/// [`CurveGroup::kind`]: round tubes (USD curves without authored normals).
pub const CURVE_TUBE: u32 = 0;
/// [`CurveGroup::kind`]: flat ribbons, oriented by the authored normals when [`CURVE_HAS_NORMALS`] is
/// set, else facing the ray.
pub const CURVE_RIBBON: u32 = 1;
/// [`CurveGroup::kind`]: a Points prim; `first`/`count` index the spheres section.
pub const CURVE_POINTS: u32 = 2;

/// The group's attributes carry authored normals (oriented ribbons).
pub const CURVE_HAS_NORMALS: u32 = 1;
/// The group's attributes carry a per-vertex colour (`primvars:displayColor`) replacing the material's.
pub const CURVE_HAS_COLORS: u32 = 2;
/// The group's attributes carry texture coordinates (`primvars:st`).
pub const CURVE_HAS_UVS: u32 = 4;

/// One BasisCurves, NurbsCurves or Points prim after composition. 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct CurveGroup {
    /// Prim path.
    pub name: StrRef,
    /// [`CURVE_TUBE`], [`CURVE_RIBBON`] or [`CURVE_POINTS`].
    pub kind: u32,
    /// `CURVE_HAS_*` bits.
    pub flags: u32,
    /// First segment (curves) or sphere (points).
    pub first: u32,
    /// Number of segments or spheres.
    pub count: u32,
    /// Index into the materials section.
    pub material: u32,
    /// Authored curves (entries of `curveVertexCounts`), or points.
    pub curve_count: u32,
}
const _: () = assert!(std::mem::size_of::<CurveGroup>() == 32);

/// One cubic Bézier piece in world space. 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CurveSegment {
    /// Control points: `xyz` world position, `w` radius (half the USD width) — the radius is a cubic
    /// Bézier function of the curve parameter like the position.
    pub p: [[f32; 4]; 4],
    /// Index into the curve groups section.
    pub group: u32,
    /// Curve parameter range `[u0, u1]` this piece covers along its authored curve (for `v` shading).
    pub u: [f32; 2],
    /// Reserved, zero.
    pub reserved: u32,
}
const _: () = assert!(std::mem::size_of::<CurveSegment>() == 80);

/// Shading attributes at both ends of a segment (index 0 at t = 0, 1 at t = 1), interpolated linearly
/// in between. Zero where the group lacks the attribute. 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CurveAttributes {
    /// Ribbon normals (world space, unit).
    pub normal: [[f32; 3]; 2],
    /// Linear RGB colour.
    pub color: [[f32; 3]; 2],
    /// Texture coordinates.
    pub uv: [[f32; 2]; 2],
}
const _: () = assert!(std::mem::size_of::<CurveAttributes>() == 64);

/// One point of a Points prim: a sphere. 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PointSphere {
    /// World-space centre.
    pub center: [f32; 3],
    /// World-space radius.
    pub radius: f32,
    /// Linear RGB colour (the material's diffuse colour unless the group has `CURVE_HAS_COLORS`).
    pub color: [f32; 3],
    /// Index into the curve groups section.
    pub group: u32,
}
const _: () = assert!(std::mem::size_of::<PointSphere>() == 32);

/// Owned curve sections, filled by ingest (part of [`crate::SceneData`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CurveData {
    /// One per prim.
    pub groups: Vec<CurveGroup>,
    /// Bézier pieces.
    pub segments: Vec<CurveSegment>,
    /// One per segment.
    pub attributes: Vec<CurveAttributes>,
    /// Spheres of Points prims.
    pub spheres: Vec<PointSphere>,
    /// CWBVH over segments and spheres, root first.
    pub bvh_nodes: Vec<crate::CwBvhNode>,
    /// Segment or sphere per BVH primitive slot (see the module docs).
    pub bvh_primitives: Vec<u32>,
}

/// The validated curve sections of a [`crate::SceneView`].
#[derive(Clone, Copy, Debug, Default)]
pub struct CurveView<'a> {
    /// One per prim.
    pub groups: &'a [CurveGroup],
    /// Bézier pieces.
    pub segments: &'a [CurveSegment],
    /// One per segment.
    pub attributes: &'a [CurveAttributes],
    /// Spheres.
    pub spheres: &'a [PointSphere],
    /// CWBVH nodes, root first.
    pub bvh_nodes: &'a [crate::CwBvhNode],
    /// Segment or sphere per slot.
    pub bvh_primitives: &'a [u32],
}

impl CurveView<'_> {
    /// Checks every index and the shape of every record; `what` names the first problem.
    pub(crate) fn validate(
        &self,
        materials: usize,
        strings_ok: impl Fn(StrRef) -> bool,
    ) -> Result<(), (crate::SectionKind, usize, &'static str)> {
        use crate::SectionKind as K;
        if self.attributes.len() != self.segments.len() {
            return Err((K::CurveAttributes, 0, "attribute count differs from segment count"));
        }
        for (i, g) in self.groups.iter().enumerate() {
            let len = if g.kind == CURVE_POINTS { self.spheres.len() } else { self.segments.len() };
            if !strings_ok(g.name) || g.kind > CURVE_POINTS || g.material as usize >= materials {
                return Err((K::CurveGroups, i, "bad name, kind or material"));
            }
            if g.first as u64 + g.count as u64 > len as u64 {
                return Err((K::CurveGroups, i, "segment or sphere range outside its section"));
            }
        }
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        for (i, s) in self.segments.iter().enumerate() {
            let g = self.groups.get(s.group as usize);
            if g.is_none_or(|g| {
                g.kind == CURVE_POINTS || i < g.first as usize || i >= (g.first + g.count) as usize
            }) {
                return Err((K::CurveSegments, i, "group index out of range or not owning the segment"));
            }
            if !finite(bytemuck::cast_slice(&s.p)) || s.p.iter().any(|p| p[3] < 0.0) {
                return Err((K::CurveSegments, i, "non-finite control point or negative radius"));
            }
        }
        for (i, s) in self.spheres.iter().enumerate() {
            let g = self.groups.get(s.group as usize);
            if g.is_none_or(|g| {
                g.kind != CURVE_POINTS || i < g.first as usize || i >= (g.first + g.count) as usize
            }) {
                return Err((K::PointSpheres, i, "group index out of range or not owning the sphere"));
            }
            if !(finite(&s.center) && s.radius >= 0.0 && s.radius.is_finite()) {
                return Err((K::PointSpheres, i, "non-finite centre or bad radius"));
            }
        }
        let prims = self.segments.len() + self.spheres.len();
        if let Some(i) = self.bvh_primitives.iter().position(|&p| p as usize >= prims) {
            return Err((K::CurveBvhPrimitives, i, "primitive index out of range"));
        }
        if self.bvh_nodes.is_empty() != (prims == 0) {
            return Err((
                K::CurveBvhNodes,
                0,
                "a curve BVH is required exactly when there are curves or points",
            ));
        }
        crate::scene::validate_cwbvh(self.bvh_nodes, self.bvh_primitives.len())
            .map_err(|(i, what)| (K::CurveBvhNodes, i, what))
    }
}

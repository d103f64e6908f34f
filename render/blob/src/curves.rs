//! Curve and point records: cubic Bézier segments with per-control-point radii, their shading
//! attributes, point spheres, the prims they came from, and their own CWBVH.
//!
//! Ingest converts every USD basis (bezier, bspline, catmullRom, linear; nonperiodic, periodic,
//! pinned) and NurbsCurves to cubic Bézier segments, splits them adaptively for the default camera and
//! builds a BVH over the pieces; render intersects them as tubes or ribbons. Points are spheres.
//!
//! Sections (kinds 40–45): [`CurveGroup`] per prim, [`CurveSegment`] and [`CurveAttributes`] in
//! parallel, [`PointSphere`], then the curve BVH ([`crate::CwBvhNode`]) and its primitive slots.
//!
//! # Primitive slots
//! A slot is a `u32`: the low 28 bits ([`SLOT_PRIMITIVE_MASK`]) hold a primitive `v` —
//! `v < segments.len()` names segment `v`, otherwise sphere `v − segments.len()` — and the top 4
//! bits a *piece* of that segment ([`slot_piece_range`]): 0 is the whole segment, `c` in 1..=14 the
//! node `c + 1` of a binary heap over the parameter range (2–3 halves, 4–7 quarters, 8–15 eighths).
//! Long or bent segments have several slots, one per piece, each with its own tight box: the BVH
//! then bounds a strand as closely as if it had been split into more segments, at 4 bytes per piece
//! instead of 144. Blobs with only whole-segment slots read the same as before pieces existed.

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

/// Bits of a primitive slot that hold the primitive (see the module docs).
pub const SLOT_PRIMITIVE_MASK: u32 = (1 << SLOT_PIECE_SHIFT) - 1;
/// Shift of the piece code in a primitive slot.
pub const SLOT_PIECE_SHIFT: u32 = 28;
/// Largest piece code (`c + 1 = 15`: the last eighth).
pub const SLOT_MAX_PIECE: u32 = 14;

/// A slot naming piece `piece` (0 = whole, else heap node `piece + 1`) of primitive `primitive`
/// (`None` if either does not fit).
pub fn slot(primitive: u32, piece: u32) -> Option<u32> {
    (primitive <= SLOT_PRIMITIVE_MASK && piece <= SLOT_MAX_PIECE)
        .then_some(primitive | piece << SLOT_PIECE_SHIFT)
}

/// The primitive a slot names.
pub fn slot_primitive(slot: u32) -> u32 {
    slot & SLOT_PRIMITIVE_MASK
}

/// The piece code of a slot (0 = the whole primitive).
pub fn slot_piece(slot: u32) -> u32 {
    slot >> SLOT_PIECE_SHIFT
}

/// The parameter range `[t0, t1]` of piece code `piece` (heap node `piece + 1`; 0 is `[0, 1]`).
pub fn slot_piece_range(piece: u32) -> [f32; 2] {
    if piece == 0 {
        return [0.0, 1.0];
    }
    let node = piece + 1;
    let level = 31 - node.leading_zeros();
    let width = 1.0 / (1u32 << level) as f32;
    let i = (node - (1 << level)) as f32;
    [i * width, (i + 1.0) * width]
}

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
    /// Segment piece or sphere per BVH primitive slot (see the module docs).
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
    /// Segment piece or sphere per slot (see the module docs).
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
        for (i, s) in self.segments.iter().enumerate() {
            let g = self.groups.get(s.group as usize);
            if g.is_none_or(|g| {
                g.kind == CURVE_POINTS || i < g.first as usize || i >= (g.first + g.count) as usize
            }) {
                return Err((K::CurveSegments, i, "group index out of range or not owning the segment"));
            }
            if !crate::tree::all_sane(bytemuck::cast_slice(&s.p)) || s.p.iter().any(|p| p[3] < 0.0) {
                return Err((K::CurveSegments, i, "non-finite or huge control point, or negative radius"));
            }
        }
        for (i, s) in self.spheres.iter().enumerate() {
            let g = self.groups.get(s.group as usize);
            if g.is_none_or(|g| {
                g.kind != CURVE_POINTS || i < g.first as usize || i >= (g.first + g.count) as usize
            }) {
                return Err((K::PointSpheres, i, "group index out of range or not owning the sphere"));
            }
            if !(crate::tree::all_sane(&s.center) && s.radius >= 0.0 && crate::tree::sane(s.radius)) {
                return Err((K::PointSpheres, i, "non-finite centre or bad radius"));
            }
        }
        let prims = self.segments.len() + self.spheres.len();
        if let Some(i) = self.bvh_primitives.iter().position(|&s| {
            let (p, piece) = (slot_primitive(s) as usize, slot_piece(s));
            p >= prims || piece > SLOT_MAX_PIECE || (piece != 0 && p >= self.segments.len())
        }) {
            return Err((K::CurveBvhPrimitives, i, "primitive index out of range, or a piece of a sphere"));
        }
        if self.bvh_nodes.is_empty() != (prims == 0) {
            return Err((
                K::CurveBvhNodes,
                0,
                "a curve BVH is required exactly when there are curves or points",
            ));
        }
        let primitives = self.bvh_primitives.len();
        crate::tree::check_tree(0, self.bvh_nodes.len(), crate::tree::MAX_CURVE_BVH_DEPTH, |n| {
            crate::tree::cwbvh_children(&self.bvh_nodes[n], primitives)
        })
        .map_err(|(i, what)| (K::CurveBvhNodes, i, what))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slot_pieces_tile_the_segment_at_each_level() {
        assert_eq!(slot_piece_range(0), [0.0, 1.0]);
        assert_eq!(slot_piece_range(1), [0.0, 0.5]);
        assert_eq!(slot_piece_range(2), [0.5, 1.0]);
        assert_eq!(slot_piece_range(5), [0.5, 0.75]);
        assert_eq!(slot_piece_range(6), [0.75, 1.0]);
        assert_eq!(slot_piece_range(7), [0.0, 0.125]);
        assert_eq!(slot_piece_range(14), [0.875, 1.0]);
        let s = slot(123_456, 9).unwrap();
        assert_eq!((slot_primitive(s), slot_piece(s)), (123_456, 9));
        assert_eq!(slot(SLOT_PRIMITIVE_MASK + 1, 0), None);
        assert_eq!(slot(0, 15), None);
    }

    #[test]
    fn slots_name_existing_primitives_and_only_segments_have_pieces() {
        let segments = [CurveSegment::default()];
        let spheres = [PointSphere { group: 1, ..PointSphere::default() }];
        let groups = [
            CurveGroup { kind: CURVE_TUBE, count: 1, ..CurveGroup::default() },
            CurveGroup { kind: CURVE_POINTS, count: 1, ..CurveGroup::default() },
        ];
        let check = |slots: &[u32]| {
            let view = CurveView {
                groups: &groups,
                segments: &segments,
                attributes: &[CurveAttributes::default()],
                spheres: &spheres,
                bvh_nodes: &[],
                bvh_primitives: slots,
            };
            view.validate(1, |_| true).map_err(|(kind, i, _)| (kind, i))
        };
        let bad = |i| Err((crate::SectionKind::CurveBvhPrimitives, i));
        // Index checks come before the BVH shape check (an empty BVH is then the error).
        assert_eq!(check(&[slot(0, 3).unwrap(), 1]).unwrap_err().0, crate::SectionKind::CurveBvhNodes);
        assert_eq!(check(&[0, slot(1, 1).unwrap()]), bad(1));
        assert_eq!(check(&[2]), bad(0));
        assert_eq!(check(&[15 << SLOT_PIECE_SHIFT]), bad(0));
    }
}

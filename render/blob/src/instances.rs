//! Two-level instancing (format 5): prototypes stored once in prototype space, instances that place
//! them in the world, and a top-level BVH over the instances' world bounds.
//!
//! Sections (kinds 50–55):
//!
//! ```text
//! 50 Prototypes          Prototype per shared mesh set: ranges into Triangles, 54 and 55
//! 51 Instances           Instance: prototype index + world_from_object / object_from_world (3×4)
//! 52 InstanceBvhNodes    BvhNode, root first; a leaf (first, count) indexes 53
//! 53 InstanceBvhItems    u32 instance index per top-level leaf slot
//! 54 PrototypeBvhNodes   BvhNode of every prototype's BVH, concatenated; child and leaf references
//!                        are absolute indices into 54 / 55
//! 55 PrototypeBvhBlocks  TriangleBlock of every prototype's BVH (vertices in prototype space)
//! 56 InstanceMotions     InstanceMotion per moving instance: a range of 57 (format 13)
//! 57 MotionKeys          MotionKey: a time and a world_from_object
//! ```
//!
//! Transform motion (format 13): an instance whose `motion` is not [`crate::NONE`] moves. Its
//! placement at ray time `τ` (time codes from the frame) is the linear interpolation of the
//! `world_from_object` matrices of the two keys around `τ` (the first or last key outside them),
//! inverted for the ray; the record's own transforms are its placement at `τ = 0`. Interpolating
//! the matrices, not a decomposition, is what makes the top-level BVH's box for the instance the
//! union of the prototype box under each key: every point of the prototype moves on straight
//! segments between its keyed positions, which stay inside that union. Validation bounds the key
//! count ([`MAX_MOTION_KEYS`]), requires finite times increasing strictly within
//! ±[`crate::MAX_SHUTTER`] and finite, invertible key matrices.
//!
//! Prototype triangles live in the ordinary triangle, vertex and material sections, after the
//! world-space ("top-level") triangles: prototypes cover `[first prototype triangle, triangles.len())`
//! contiguously and in order, so every triangle is either top level (traversed by the world BVH,
//! possibly emissive) or in exactly one prototype (traversed through its instances).

use crate::records::{BvhNode, StrRef, TriangleBlock};
use crate::tree::{all_sane, MAX_BVH_DEPTH};
use bytemuck::{Pod, Zeroable};

/// One prototype: a set of meshes in prototype space with its own 8-wide BVH. 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Prototype {
    /// First triangle in the triangles section.
    pub first_triangle: u32,
    /// Number of triangles (at least one).
    pub triangle_count: u32,
    /// Root (first node) of its BVH in the prototype BVH nodes section.
    pub first_node: u32,
    /// Nodes of its BVH.
    pub node_count: u32,
    /// First leaf block in the prototype BVH blocks section.
    pub first_block: u32,
    /// Blocks of its BVH.
    pub block_count: u32,
    /// First mesh record of the prototype (meshes named after the first instance's gprims).
    pub first_mesh: u32,
    /// Mesh records of the prototype.
    pub mesh_count: u32,
    /// Prototype-space bounds (min).
    pub bounds_min: [f32; 3],
    /// Prototype-space bounds (max).
    pub bounds_max: [f32; 3],
    /// Reserved, zero.
    pub reserved: [u32; 2],
}
const _: () = assert!(std::mem::size_of::<Prototype>() == 64);

/// One placement of a prototype. Both transforms are stored so a ray is moved into prototype space
/// with one affine product and a hit's normal back out with the transpose of `object_from_world`
/// (the inverse transpose of `world_from_object`). 112 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Instance {
    /// Row-major 3×4 affine `world_from_object` (rows 0..3 of the 4×4, column-vector convention).
    pub world_from_object: [[f32; 4]; 3],
    /// Row-major 3×4 affine `object_from_world`, the inverse of `world_from_object`.
    pub object_from_world: [[f32; 4]; 3],
    /// Index into the prototypes section.
    pub prototype: u32,
    /// The instance prim path (or `<PointInstancer>[i]`).
    pub name: StrRef,
    /// Index into the instance motions section, or [`crate::NONE`] for an instance that stands
    /// still (format 13; the field was reserved, zero, before).
    pub motion: u32,
}
const _: () = assert!(std::mem::size_of::<Instance>() == 112);

/// Most keys one moving instance may have: USD authors a handful of samples per shutter; more than
/// this is a broken file, and the bound keeps the key search short.
pub const MAX_MOTION_KEYS: u32 = 256;

/// The keys of one moving instance: `key_count` ≥ 2 consecutive records of the motion keys section,
/// times strictly increasing. 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct InstanceMotion {
    /// First key in the motion keys section.
    pub first_key: u32,
    /// Number of keys, 2..=[`MAX_MOTION_KEYS`].
    pub key_count: u32,
    /// Reserved, zero.
    pub reserved: [u32; 2],
}
const _: () = assert!(std::mem::size_of::<InstanceMotion>() == 16);

/// One transform key of a moving instance. 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MotionKey {
    /// Time codes from the frame the blob was ingested at.
    pub time: f32,
    /// Reserved, zero.
    pub reserved: [u32; 3],
    /// Row-major 3×4 affine `world_from_object` at `time`.
    pub world_from_object: [[f32; 4]; 3],
}
const _: () = assert!(std::mem::size_of::<MotionKey>() == 64);

/// Owned instancing sections, filled by ingest (part of [`crate::SceneData`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InstanceData {
    /// Prototypes.
    pub prototypes: Vec<Prototype>,
    /// Instances.
    pub instances: Vec<Instance>,
    /// Top-level BVH over instance world bounds, root first.
    pub bvh_nodes: Vec<BvhNode>,
    /// Instance index per top-level leaf slot.
    pub bvh_items: Vec<u32>,
    /// Every prototype's BVH nodes.
    pub prototype_nodes: Vec<BvhNode>,
    /// Every prototype's leaf blocks.
    pub prototype_blocks: Vec<TriangleBlock>,
    /// Key ranges of the moving instances.
    pub motions: Vec<InstanceMotion>,
    /// Their keys.
    pub motion_keys: Vec<MotionKey>,
}

/// The validated instancing sections of a [`crate::SceneView`].
#[derive(Clone, Copy, Debug, Default)]
pub struct InstanceView<'a> {
    /// Prototypes (ranges checked, contiguous after the top-level triangles).
    pub prototypes: &'a [Prototype],
    /// Instances (prototype index in range, transforms finite and mutually inverse).
    pub instances: &'a [Instance],
    /// Top-level BVH nodes (children after parents, leaf item ranges in range).
    pub bvh_nodes: &'a [BvhNode],
    /// Instance index per top-level leaf slot (in range).
    pub bvh_items: &'a [u32],
    /// Prototype BVH nodes (each prototype's references stay inside its own node and block ranges).
    pub prototype_nodes: &'a [BvhNode],
    /// Prototype leaf blocks (each lane's triangle inside its prototype's triangle range).
    pub prototype_blocks: &'a [TriangleBlock],
    /// Key ranges of the moving instances (in range, 2..=[`MAX_MOTION_KEYS`] keys each).
    pub motions: &'a [InstanceMotion],
    /// Transform keys (times finite and increasing per instance, matrices finite and invertible).
    pub motion_keys: &'a [MotionKey],
}

/// `rows · [p, 1]` for a row-major 3×4 affine matrix.
#[inline]
pub fn transform_point(rows: &[[f32; 4]; 3], p: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| rows[r][0] * p[0] + rows[r][1] * p[1] + rows[r][2] * p[2] + rows[r][3])
}

/// Largest deviation of `a · b` from the identity, for two row-major 3×4 affine matrices.
fn inverse_error(a: &[[f32; 4]; 3], b: &[[f32; 4]; 3]) -> f32 {
    let mut worst = 0.0f32;
    for r in 0..3 {
        for c in 0..4 {
            let mut v = (0..3).map(|k| a[r][k] as f64 * b[k][c] as f64).sum::<f64>();
            if c == 3 {
                v += a[r][3] as f64;
            }
            let expected = if r == c { 1.0 } else { 0.0 };
            // Translations are compared relative to the matrix's reach so large worlds pass.
            let scale = if c == 3 { 1.0 + a[r][3].abs().max(b[r][3].abs()) as f64 } else { 1.0 };
            worst = worst.max(((v - expected).abs() / scale) as f32);
        }
    }
    worst
}

/// Determinant of the linear part of a row-major 3×4 affine matrix, in `f64`.
fn determinant3(m: &[[f32; 4]; 3]) -> f64 {
    let a = |r: usize, c: usize| m[r][c] as f64;
    a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0))
}

/// A motion key's matrix: finite, within the float limits and invertible.
pub(crate) fn key_matrix_ok(rows: &[[f32; 4]; 3]) -> bool {
    all_sane(bytemuck::cast_slice(rows)) && determinant3(rows).abs() >= 1e-12
}

impl InstanceView<'_> {
    /// The number of triangles before the first prototype (the top-level, world-space ones).
    pub fn top_level_triangles(&self, triangles: usize) -> usize {
        self.prototypes.first().map_or(triangles, |p| p.first_triangle as usize)
    }

    /// Checks every index, range and transform; `what` names the first problem.
    pub(crate) fn validate(
        &self,
        triangles: usize,
        meshes: usize,
        strings_ok: impl Fn(StrRef) -> bool,
    ) -> Result<(), (crate::SectionKind, usize, &'static str)> {
        use crate::SectionKind as K;
        let mut next_triangle = self.top_level_triangles(triangles) as u64;
        for (i, p) in self.prototypes.iter().enumerate() {
            if p.triangle_count == 0 || p.first_triangle as u64 != next_triangle {
                return Err((K::Prototypes, i, "triangle range empty or not contiguous after the previous"));
            }
            next_triangle += p.triangle_count as u64;
            if next_triangle > triangles as u64 {
                return Err((K::Prototypes, i, "triangle range outside the triangles section"));
            }
            let node_end = p.first_node as u64 + p.node_count as u64;
            let block_end = p.first_block as u64 + p.block_count as u64;
            if p.node_count == 0 || node_end > self.prototype_nodes.len() as u64 {
                return Err((K::Prototypes, i, "BVH node range empty or outside its section"));
            }
            if block_end > self.prototype_blocks.len() as u64 {
                return Err((K::Prototypes, i, "BVH block range outside its section"));
            }
            if p.first_mesh as u64 + p.mesh_count as u64 > meshes as u64 {
                return Err((K::Prototypes, i, "mesh range outside the meshes section"));
            }
            if !all_sane(&p.bounds_min) || !all_sane(&p.bounds_max) {
                return Err((K::Prototypes, i, "non-finite or huge bounds"));
            }
            // The prototype's BVH is a tree inside its own node range whose leaves stay inside its own
            // block range, so a traversal started at `first_node` visits each of its nodes once and
            // only ever sees this prototype's triangles.
            let (nodes, end) = (self.prototype_nodes, node_end as usize);
            crate::tree::check_tree(p.first_node as usize, p.node_count as usize, MAX_BVH_DEPTH, |n| {
                let leaves = (p.first_block as u64, block_end);
                crate::tree::bvh8_children(nodes, n, end, leaves, "leaf blocks outside the prototype")
            })
            .map_err(|(n, what)| (K::PrototypeBvhNodes, n, what))?;
            let tri_range = p.first_triangle..p.first_triangle + p.triangle_count;
            for b in p.first_block..block_end as u32 {
                let block = &self.prototype_blocks[b as usize];
                if !block.triangles.iter().all(|t| tri_range.contains(t)) {
                    return Err((K::PrototypeBvhBlocks, b as usize, "triangle outside its prototype"));
                }
                if !all_sane(bytemuck::cast_slice(&block.vertices)) {
                    return Err((K::PrototypeBvhBlocks, b as usize, "non-finite or huge vertex"));
                }
            }
        }
        if !self.prototypes.is_empty() && next_triangle != triangles as u64 {
            return Err((
                K::Prototypes,
                self.prototypes.len() - 1,
                "prototypes do not end at the last triangle",
            ));
        }
        for (i, inst) in self.instances.iter().enumerate() {
            if inst.prototype as usize >= self.prototypes.len() {
                return Err((K::Instances, i, "prototype index out of range"));
            }
            if !strings_ok(inst.name) {
                return Err((K::Instances, i, "name outside the strings section"));
            }
            let (a, b) = (&inst.world_from_object, &inst.object_from_world);
            if !all_sane(bytemuck::cast_slice(a)) || !all_sane(bytemuck::cast_slice(b)) {
                return Err((K::Instances, i, "non-finite transform or an entry beyond ±1e12"));
            }
            if inverse_error(a, b) > 1e-3 {
                return Err((K::Instances, i, "object_from_world is not the inverse of world_from_object"));
            }
            if inst.motion != crate::NONE && inst.motion as usize >= self.motions.len() {
                return Err((K::Instances, i, "motion index out of range"));
            }
        }
        for (i, m) in self.motions.iter().enumerate() {
            if !(2..=MAX_MOTION_KEYS).contains(&m.key_count) {
                return Err((K::InstanceMotions, i, "key count not within 2..=256"));
            }
            let first = m.first_key as usize;
            let Some(keys) = self.motion_keys.get(first..first + m.key_count as usize) else {
                return Err((K::InstanceMotions, i, "key range outside the motion keys section"));
            };
            let mut previous = f32::NEG_INFINITY;
            for (j, key) in keys.iter().enumerate() {
                if !(key.time.is_finite() && key.time.abs() <= crate::MAX_SHUTTER && key.time > previous) {
                    return Err((
                        K::MotionKeys,
                        first + j,
                        "key time NaN, infinite, beyond ±1e4 time codes or not after the previous key",
                    ));
                }
                previous = key.time;
                if !key_matrix_ok(&key.world_from_object) {
                    return Err((
                        K::MotionKeys,
                        first + j,
                        "key transform NaN, beyond ±1e12 or not invertible",
                    ));
                }
            }
        }
        if let Some(i) = self.bvh_items.iter().position(|&t| t as usize >= self.instances.len()) {
            return Err((K::InstanceBvhItems, i, "instance index out of range"));
        }
        if self.bvh_nodes.is_empty() != self.instances.is_empty() {
            return Err((
                K::InstanceBvhNodes,
                0,
                "a top-level BVH is required exactly when there are instances",
            ));
        }
        let items = self.bvh_items.len() as u64;
        let nodes = self.bvh_nodes;
        crate::tree::check_tree(0, nodes.len(), MAX_BVH_DEPTH, |n| {
            crate::tree::bvh8_children(nodes, n, nodes.len(), (0, items), "leaf item range out of bounds")
        })
        .map_err(|(n, what)| (K::InstanceBvhNodes, n, what))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_error_is_small_for_inverses_and_large_otherwise() {
        let a = [[2.0, 0.0, 0.0, 10.0], [0.0, 1.0, 0.0, -5.0], [0.0, 0.0, 0.5, 1.0]];
        let b = [[0.5, 0.0, 0.0, -5.0], [0.0, 1.0, 0.0, 5.0], [0.0, 0.0, 2.0, -2.0]];
        assert!(inverse_error(&a, &b) < 1e-6);
        let mut wrong = b;
        wrong[1][3] = 4.0;
        assert!(inverse_error(&a, &wrong) > 0.1);
        assert_eq!(transform_point(&a, [1.0, 1.0, 2.0]), [12.0, -4.0, 2.0]);
    }
}

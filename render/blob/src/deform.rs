//! Deformation motion (format 16): meshes whose vertices move over the shutter, with their own BVH.
//!
//! Sections (kinds 90–94):
//!
//! ```text
//! 90 MeshMotions        MeshMotion per deforming mesh, sorted by mesh: a range of 91 and of 92
//! 91 MeshMotionTimes    f32 key times, time codes from the frame, increasing per mesh
//! 92 MeshMotionPoints   [f32; 3] world-space vertex positions, key after key: vertex v of key k
//!                       of a mesh at first_position + k · vertex_count + (v − first_vertex)
//! 93 DeformBvhNodes     BvhNode of the BVH over every deforming triangle, root first
//! 94 DeformBvhBlocks    TriangleBlock of its leaves (vertices: the frame's, as in Positions)
//! ```
//!
//! A deforming mesh is a top-level (world-space) mesh; its triangles are in the ordinary
//! triangle, position and material sections (the positions are the frame's, so a render at the
//! frame draws exactly them) but in the deformation BVH rather than the world BVH. A vertex at ray
//! time `τ` is the linear interpolation of its positions at the two keys around `τ` (the end
//! keys held outside them; exactly a key's position at its time). The BVH's boxes bound, per
//! triangle, the union of its boxes at every key: a triangle's vertices move on straight
//! segments between keys, which stay inside that union, so one BVH serves every time (no segment
//! bounds; a fast mover's box is loose, which costs traversal steps, never a missed hit).
//!
//! Validation: motions sorted by mesh without repeats, each mesh top level, 2..=[`MAX_MOTION_KEYS`]
//! keys with finite times increasing strictly within ±[`crate::MAX_SHUTTER`], ranges inside their
//! sections, every point finite and within the float limits, the BVH a tree whose blocks name
//! only triangles of deforming meshes.

use crate::records::{BvhNode, Mesh, Triangle, TriangleBlock};
use crate::tree::{all_sane, MAX_BVH_DEPTH};
use crate::MAX_MOTION_KEYS;
use bytemuck::{Pod, Zeroable};

/// The keys of one deforming mesh. 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MeshMotion {
    /// Index into the meshes section (a top-level mesh).
    pub mesh: u32,
    /// Number of keys, 2..=[`MAX_MOTION_KEYS`].
    pub key_count: u32,
    /// First key time in the mesh motion times section.
    pub first_time: u32,
    /// First point in the mesh motion points section (`key_count · vertex_count` points).
    pub first_position: u32,
}
const _: () = assert!(std::mem::size_of::<MeshMotion>() == 16);

/// Owned deformation sections, filled by ingest (part of [`crate::SceneData`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeformData {
    /// Deforming meshes, sorted by mesh.
    pub motions: Vec<MeshMotion>,
    /// Their key times.
    pub times: Vec<f32>,
    /// Their keyed positions.
    pub positions: Vec<[f32; 3]>,
    /// The BVH over every deforming triangle (union of key boxes), root first.
    pub bvh_nodes: Vec<BvhNode>,
    /// Its leaf blocks.
    pub bvh_blocks: Vec<TriangleBlock>,
}

/// The validated deformation sections of a [`crate::SceneView`].
#[derive(Clone, Copy, Debug, Default)]
pub struct DeformView<'a> {
    /// Deforming meshes (sorted by mesh, ranges checked).
    pub motions: &'a [MeshMotion],
    /// Key times (finite, increasing per mesh).
    pub times: &'a [f32],
    /// Keyed positions (finite, within the float limits).
    pub positions: &'a [[f32; 3]],
    /// Deformation BVH nodes (a tree, leaves inside the blocks).
    pub bvh_nodes: &'a [BvhNode],
    /// Deformation BVH blocks (every lane a triangle of a deforming mesh).
    pub bvh_blocks: &'a [TriangleBlock],
}

impl DeformData {
    /// The motion of `mesh`, if it deforms (motions are sorted by mesh).
    pub fn motion_of(&self, mesh: u32) -> Option<&MeshMotion> {
        self.motions.binary_search_by_key(&mesh, |m| m.mesh).ok().map(|i| &self.motions[i])
    }
}

/// Checks one motion's key times: finite, strictly increasing, within ±[`crate::MAX_SHUTTER`].
pub(crate) fn key_times_ok(times: impl IntoIterator<Item = f32>) -> Option<usize> {
    let mut previous = f32::NEG_INFINITY;
    for (j, t) in times.into_iter().enumerate() {
        if !(t.is_finite() && t.abs() <= crate::MAX_SHUTTER && t > previous) {
            return Some(j);
        }
        previous = t;
    }
    None
}

impl DeformView<'_> {
    /// The motion of `mesh`, if it deforms.
    #[inline]
    pub fn motion_of(&self, mesh: u32) -> Option<&MeshMotion> {
        self.motions.binary_search_by_key(&mesh, |m| m.mesh).ok().map(|i| &self.motions[i])
    }

    /// Checks every index, range and value; `what` names the first problem.
    pub(crate) fn validate(
        &self,
        meshes: &[Mesh],
        triangles: &[Triangle],
        top_level_triangles: usize,
    ) -> Result<(), (crate::SectionKind, usize, &'static str)> {
        use crate::SectionKind as K;
        let mut previous_mesh = None;
        for (i, m) in self.motions.iter().enumerate() {
            if previous_mesh.is_some_and(|p| m.mesh <= p) {
                return Err((K::MeshMotions, i, "not sorted by mesh or a mesh repeated"));
            }
            previous_mesh = Some(m.mesh);
            let Some(mesh) = meshes.get(m.mesh as usize) else {
                return Err((K::MeshMotions, i, "mesh index out of range"));
            };
            if mesh.first_triangle as u64 + mesh.triangle_count as u64 > top_level_triangles as u64 {
                return Err((K::MeshMotions, i, "mesh is inside a prototype (only top-level meshes deform)"));
            }
            if !(2..=MAX_MOTION_KEYS).contains(&m.key_count) {
                return Err((K::MeshMotions, i, "key count not within 2..=256"));
            }
            let first = m.first_time as usize;
            let Some(times) = self.times.get(first..first + m.key_count as usize) else {
                return Err((K::MeshMotions, i, "key time range outside the mesh motion times section"));
            };
            if let Some(j) = key_times_ok(times.iter().copied()) {
                return Err((
                    K::MeshMotionTimes,
                    first + j,
                    "key time NaN, infinite, beyond ±1e4 time codes or not after the previous key",
                ));
            }
            let points = m.key_count as u64 * mesh.vertex_count as u64;
            if m.first_position as u64 + points > self.positions.len() as u64 {
                return Err((K::MeshMotions, i, "point range outside the mesh motion points section"));
            }
        }
        if let Some(i) = crate::bulk::first_failing(self.positions, |p| all_sane(p)) {
            return Err((K::MeshMotionPoints, i, "non-finite or huge position"));
        }
        let deforms = |t: u32| {
            (t as usize) < top_level_triangles
                && triangles.get(t as usize).is_some_and(|tri| self.motion_of(tri.mesh).is_some())
        };
        for (b, block) in self.bvh_blocks.iter().enumerate() {
            if !block.triangles.iter().all(|&t| deforms(t)) {
                return Err((K::DeformBvhBlocks, b, "triangle out of range or not of a deforming mesh"));
            }
            if !all_sane(bytemuck::cast_slice(&block.vertices)) {
                return Err((K::DeformBvhBlocks, b, "non-finite or huge vertex"));
            }
        }
        if self.bvh_nodes.is_empty() != self.bvh_blocks.is_empty() {
            return Err((K::DeformBvhNodes, 0, "a deformation BVH is required exactly when it has blocks"));
        }
        let (nodes, blocks) = (self.bvh_nodes, self.bvh_blocks.len() as u64);
        crate::tree::check_tree(0, nodes.len(), MAX_BVH_DEPTH, |n| {
            crate::tree::bvh8_children(nodes, n, nodes.len(), (0, blocks), "leaf block range out of bounds")
        })
        .map_err(|(n, what)| (K::DeformBvhNodes, n, what))?;
        Ok(())
    }
}

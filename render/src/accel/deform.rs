//! Deformation motion: triangles whose vertices move over the shutter (`blob::deform`).
//!
//! The deforming triangles have their own BVH, whose boxes bound each triangle's boxes at every
//! key, and whose leaf blocks hold the frame's vertices. A query walks it after the world BVH with
//! the ordinary node kernel and the ordinary block kernel, handed each block with its vertices
//! replaced by the lanes' triangles at the ray's time ([`Deformation::block_at`]): the lane and
//! scalar kernels stay the ones every other triangle meets, and the moving vertices come from one
//! function ([`Deformation::vertex_at`]) that the hit's surface ([`Deformation::triangle_at`],
//! through [`crate::Accel::hit_vertices`] and the surface lanes) calls too, so both integrators
//! and every kernel see the same bits.
//!
//! A vertex at time `τ` is its keys' positions interpolated linearly around `τ`, exactly a key's
//! position at that key's time, the end keys held outside them (as an instance's matrices, see
//! [`crate::accel::instanced`]). Shading normals stay the frame's (a deforming mesh with authored
//! normals shades with them unrotated), uvs and primvars are per vertex and do not move.

use blob::{BvhNode, MeshMotion, TriangleBlock, BLOCK_WIDTH};
use glam::Vec3;

/// The validated deformation sections of a blob, ready for queries.
#[derive(Clone, Copy, Debug, Default)]
pub struct Deformation<'a> {
    view: blob::DeformView<'a>,
    triangles: &'a [blob::Triangle],
    meshes: &'a [blob::Mesh],
}

impl<'a> Deformation<'a> {
    /// Wraps the validated view's deformation sections.
    pub fn new(view: &blob::SceneView<'a>) -> Self {
        Deformation { view: view.deform, triangles: view.triangles, meshes: view.meshes }
    }

    /// True when no mesh deforms (queries skip the deformation BVH).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.view.bvh_nodes.is_empty()
    }

    /// The deformation BVH's nodes and blocks.
    #[inline(always)]
    pub(crate) fn bvh(&self) -> (&'a [BvhNode], &'a [TriangleBlock]) {
        (self.view.bvh_nodes, self.view.bvh_blocks)
    }

    /// Vertex `vertex` (a blob vertex index) of mesh `mesh` moving by `motion`, at time `time`.
    #[inline]
    fn vertex_at(&self, motion: &MeshMotion, mesh: &blob::Mesh, vertex: u32, time: f32) -> Vec3 {
        // Validated: the key times and the key-major points are inside their sections.
        let first = motion.first_time as usize;
        let times = &self.view.times[first..first + motion.key_count as usize];
        let local = (vertex - mesh.first_vertex) as usize;
        let at = |k: usize| {
            let i = motion.first_position as usize + k * mesh.vertex_count as usize + local;
            Vec3::from(self.view.positions[i])
        };
        let last = times.len() - 1;
        if time <= times[0] {
            return at(0);
        }
        if time >= times[last] {
            return at(last);
        }
        let i = times.partition_point(|&t| t <= time).clamp(1, last);
        if times[i - 1] == time {
            return at(i - 1);
        }
        let w = (time - times[i - 1]) / (times[i] - times[i - 1]);
        let (a, b) = (at(i - 1), at(i));
        Vec3::new(a.x * (1.0 - w) + b.x * w, a.y * (1.0 - w) + b.y * w, a.z * (1.0 - w) + b.z * w)
    }

    /// The world-space vertices of top-level triangle `triangle` at time `time`, or `None` when
    /// its mesh does not deform (its stored vertices are then its vertices at every time).
    #[inline]
    pub fn triangle_at(&self, triangle: u32, time: f32) -> Option<[Vec3; 3]> {
        if self.view.motions.is_empty() {
            return None;
        }
        let tri = self.triangles.get(triangle as usize)?;
        let motion = self.view.motion_of(tri.mesh)?;
        let mesh = &self.meshes[tri.mesh as usize];
        Some(tri.vertices.map(|v| self.vertex_at(motion, mesh, v, time)))
    }

    /// `block` (of the deformation BVH) with every lane's vertices at time `time`.
    #[inline]
    pub(crate) fn block_at(&self, block: &TriangleBlock, time: f32) -> TriangleBlock {
        let mut out = *block;
        for (lane, &triangle) in block.triangles.iter().enumerate().take(BLOCK_WIDTH) {
            // Validated: every lane is a triangle of a deforming mesh.
            if let Some(corners) = self.triangle_at(triangle, time) {
                for (columns, p) in out.vertices.iter_mut().zip(corners) {
                    for (column, v) in columns.iter_mut().zip(p.to_array()) {
                        column[lane] = v;
                    }
                }
            }
        }
        out
    }
}

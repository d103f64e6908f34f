//! BVH construction at ingest time, so render starts without building anything.
//!
//! obvhs builds a PLOC BVH2 with reinsertion and collapses it into a compressed 8-wide BVH (CWBVH, 80-byte
//! nodes). The nodes are stored verbatim in the blob as [`blob::BvhNode`], which is bit-identical to
//! `obvhs::cwbvh::node::CwBvhNode`; a const assertion and a test below pin that.

use glam::Vec3A;
use obvhs::{cwbvh::builder::build_cwbvh_from_tris, triangle::Triangle, BvhBuildParams};
use std::time::Duration;

/// A built BVH in blob records.
pub struct BuiltBvh {
    /// Nodes, root first.
    pub nodes: Vec<blob::BvhNode>,
    /// Triangle index per primitive slot (a triangle may occupy several slots when pre-split).
    pub primitives: Vec<u32>,
}

const _: () =
    assert!(std::mem::size_of::<blob::BvhNode>() == std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>());

/// Builds a BVH over world-space triangles given as vertex triples.
pub fn build(triangles: &[[glam::Vec3; 3]]) -> BuiltBvh {
    if triangles.is_empty() {
        return BuiltBvh { nodes: Vec::new(), primitives: Vec::new() };
    }
    let tris: Vec<Triangle> = triangles
        .iter()
        .map(|[a, b, c]| Triangle { v0: Vec3A::from(*a), v1: Vec3A::from(*b), v2: Vec3A::from(*c) })
        .collect();
    // slow_build: spatial pre-splits and more reinsertion; build time is paid once at ingest, traversal
    // speed on every ray.
    let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::slow_build(), &mut Duration::default());
    let nodes = bvh.nodes.iter().map(|n| bytemuck::cast::<_, blob::BvhNode>(*n)).collect();
    BuiltBvh { nodes, primitives: bvh.primitive_indices }
}

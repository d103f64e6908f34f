//! BVHs reused between the frames of a sequence: a BVH whose triangles are bit-for-bit those of
//! one built for the previous frame is that BVH (the build is a pure function of its input
//! triangles, so the blob's bytes are the same either way).
//!
//! What it saves: every instance prototype of a sequence (their geometry is in prototype space, so
//! it does not move with the instances), and the world BVH whenever the world-space triangles
//! stay put (a static set under a still camera; the world origin follows the camera in 64-unit
//! steps). A moved or deformed mesh changes the triangles and rebuilds. Only the previous frame's
//! BVHs are kept, so memory stays at one frame's worth of BVHs and their triangles.

use crate::bvh::BuiltBvh;
use glam::Vec3;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};

/// One frame's BVHs by the hash of their triangles, kept for the next frame.
#[derive(Default)]
pub struct BvhCache {
    previous: HashMap<u64, Vec<Entry>>,
    current: HashMap<u64, Vec<Entry>>,
    /// BVHs taken from the previous frame so far.
    pub reused: usize,
    /// BVHs built so far.
    pub built: usize,
}

struct Entry {
    corners: Vec<[Vec3; 3]>,
    nodes: Vec<blob::BvhNode>,
    blocks: Vec<blob::TriangleBlock>,
}

/// The triangles' coordinates as bits: `-0.0` and `0.0` differ in the blob's leaf blocks.
fn bits(corners: &[[Vec3; 3]]) -> impl Iterator<Item = u32> + '_ {
    corners.iter().flatten().flat_map(|v| v.to_array().map(f32::to_bits))
}

fn hash(corners: &[[Vec3; 3]]) -> u64 {
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    corners.len().hash(&mut hasher);
    for b in bits(corners) {
        hasher.write_u32(b);
    }
    hasher.finish()
}

impl BvhCache {
    /// The BVH over `corners`: the previous (or this) frame's when its triangles are the same bits,
    /// else built.
    pub(super) fn build(&mut self, corners: Vec<[Vec3; 3]>) -> BuiltBvh {
        let key = hash(&corners);
        let same = |e: &Entry| e.corners.len() == corners.len() && bits(&e.corners).eq(bits(&corners));
        let found = self.current.get(&key).and_then(|list| list.iter().position(same)).map(|i| (true, i));
        let found = found
            .or_else(|| self.previous.get(&key).and_then(|l| l.iter().position(same)).map(|i| (false, i)));
        let entry = match found {
            Some((true, i)) => {
                self.reused += 1;
                let e = &self.current[&key][i];
                return BuiltBvh { nodes: e.nodes.clone(), blocks: e.blocks.clone() };
            }
            Some((false, i)) => {
                self.reused += 1;
                self.previous.get_mut(&key).expect("found above").swap_remove(i)
            }
            None => {
                self.built += 1;
                let bvh = crate::bvh::build(&corners);
                Entry { corners, nodes: bvh.nodes, blocks: bvh.blocks }
            }
        };
        let bvh = BuiltBvh { nodes: entry.nodes.clone(), blocks: entry.blocks.clone() };
        self.current.entry(key).or_default().push(entry);
        bvh
    }

    /// Ends a frame: its BVHs become the ones the next frame may reuse; older ones are dropped.
    pub fn end_frame(&mut self) {
        self.previous = std::mem::take(&mut self.current);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangles(offset: f32) -> Vec<[Vec3; 3]> {
        (0..40)
            .map(|i| [Vec3::new(i as f32 + offset, 0.0, 0.0), Vec3::new(i as f32, 1.0, 0.0), Vec3::Z])
            .collect()
    }

    #[test]
    fn the_same_triangles_reuse_the_previous_frames_bvh_and_moved_ones_rebuild() {
        let mut cache = BvhCache::default();
        let first = cache.build(triangles(0.0));
        cache.end_frame();
        let again = cache.build(triangles(0.0));
        assert_eq!((cache.reused, cache.built), (1, 1));
        let fresh = crate::bvh::build(&triangles(0.0));
        assert_eq!(bytemuck::cast_slice::<_, u8>(&again.nodes), bytemuck::cast_slice::<_, u8>(&fresh.nodes));
        assert_eq!(
            bytemuck::cast_slice::<_, u8>(&again.blocks),
            bytemuck::cast_slice::<_, u8>(&first.blocks)
        );
        let moved = cache.build(triangles(0.5));
        assert_eq!((cache.reused, cache.built), (1, 2));
        assert_ne!(
            bytemuck::cast_slice::<_, u8>(&moved.blocks),
            bytemuck::cast_slice::<_, u8>(&first.blocks)
        );
        // -0.0 is not 0.0: the leaf blocks store the bits.
        let mut negative = triangles(0.0);
        negative[0][2] = Vec3::new(-0.0, 0.0, 1.0);
        cache.build(negative);
        assert_eq!(cache.built, 3);
        // Two frames later the first frame's BVH is gone.
        cache.end_frame();
        cache.end_frame();
        cache.build(triangles(0.0));
        assert_eq!(cache.built, 4);
    }
}

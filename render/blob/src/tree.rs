//! Structural proofs over the blob's BVHs and the limits on its floats and sizes.
//!
//! Checksums only prove that the bytes are the ones the writer wrote; a blob crafted by hand (or by a
//! fuzzer that recomputes the checksums) must still be unable to hang, crash or exhaust render. So
//! every BVH — the world BVH8, each prototype's BVH8, the top-level BVH8 over instances and the curve
//! CWBVH — is proven a *tree* at parse, in one forward pass over its nodes (`check_tree`):
//!
//! * every child index is strictly greater than its parent's and inside the BVH's node range, so the
//!   graph is acyclic and every traversal terminates;
//! * every node but the root has exactly one parent and the root none, so each node is reached exactly
//!   once from the root (together with the first rule: node `n`'s parent precedes it, so by induction
//!   it is reachable) and a traversal does at most one visit per node. A DAG (one node shared by many
//!   parents) is rejected: its traversal is exponential in its depth;
//! * the depth (root = 1) is at most the bound of the traversal's stack ([`MAX_BVH_DEPTH`],
//!   [`MAX_CURVE_BVH_DEPTH`]).
//!
//! Whether a child is internal or a leaf is decided by one function per node kind, shared by this
//! validator and render's traversal: [`crate::child_ref::is_leaf`] for the BVH8s and
//! [`cw_child_is_internal`] for the CWBVH (the rule obvhs' traversal macro applies to the meta byte;
//! render's tests pin that the two agree on all 256 values, and parse requires `imask` to agree with it
//! slot by slot, so no field can say otherwise).
//!
//! Leaves are in bounds and non-empty, or the explicit empty encoding ([`crate::child_ref::EMPTY`] for
//! the BVH8s, a zero meta byte for the CWBVH).
//!
//! Floats that set a ray's reach — scene and prototype bounds, node bounds, vertex positions, instance,
//! camera and light transforms, curve control points — are finite and at most [`MAX_COORDINATE`] in
//! magnitude. The check is `O(table size)` and runs once, at parse.

use crate::records::{child_ref, BvhNode, CwBvhNode, BVH_WIDTH};

/// Deepest path (root = 1) of an 8-wide BVH. Render's BVH8 stack keeps 32 entries inline and spills to
/// the heap beyond them, so depth never makes a query unsafe; the bound keeps that spill small (at most
/// `7 × 128` entries, 7 KiB) and is far above what ingest builds (a balanced BVH8 over 2³² triangles
/// in four-triangle blocks is 11 levels deep; the deepest world BVH among the 1,245 blobs the test
/// suites leave behind, the chess set's included, is 18: `examples/parse_time.rs` prints it).
pub const MAX_BVH_DEPTH: u32 = 128;

/// Deepest path (root = 1) of the curve CWBVH: obvhs' traversal stack is a fixed array of 32 node groups
/// that silently overwrites its last entry when full, and a walk at depth `d` holds at most `d − 1`
/// groups, so 32 levels are the most it traverses exactly (obvhs' own `validate` asserts the same).
pub const MAX_CURVE_BVH_DEPTH: u32 = 32;

/// Largest magnitude of a coordinate, bound or transform entry: `1e12` (a billion kilometres at one unit
/// per metre). Its cube, `1e36`, is still a finite `f32`, so the products of three coordinates in the
/// watertight triangle test, box slabs and camera framing cannot overflow; scene bounds of `±1e38` or
/// `±inf` (each ray then took ~47 ms) are rejected.
pub const MAX_COORDINATE: f32 = 1e12;

/// Largest authored resolution on one axis.
pub const MAX_RESOLUTION_AXIS: u32 = 65_536;

/// Largest authored resolution in pixels: `2²⁸` (16384 × 16384; about 12 GB of film). Render checks the
/// film's actual memory against its `--max-memory` on top of this.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Largest data-window coordinate in NDC: a window may reach past the frame (overscan), render clips
/// it to the frame; ±16 frames is far beyond any authored overscan.
pub const MAX_NDC: f32 = 16.0;

/// A value inside `±MAX_COORDINATE` (false for NaN and infinities).
#[inline]
pub fn sane(x: f32) -> bool {
    x.abs() <= MAX_COORDINATE
}

/// Every value sane (see [`sane`]). No early exit, so the loop vectorises: on the 156 MB chess-set
/// blob (1.9 M positions) the short-circuiting `all` cost 8 ms of a 33 ms parse.
pub fn all_sane(values: &[f32]) -> bool {
    values.iter().fold(true, |ok, &x| ok & (x.abs() <= MAX_COORDINATE))
}

/// Meta byte of an internal CWBVH child in slot `slot`, the only internal encoding parse accepts
/// (obvhs writes exactly this).
pub const fn cw_internal_meta(slot: usize) -> u8 {
    (24 + slot as u8) | 0b0010_0000
}

/// Whether a CWBVH child's meta byte marks an internal node: its low five bits are 24..=31. This is the
/// rule of obvhs' `get_child_and_index_bits` (`meta & (meta << 1) & 0x10`), which render's curve
/// traversal runs; parse requires `imask` bit `slot` to equal it.
#[inline]
pub const fn cw_child_is_internal(meta: u8) -> bool {
    meta & 0b1_1000 == 0b1_1000
}

/// Up to eight child node indices of one node.
pub(crate) struct Children {
    items: [u64; BVH_WIDTH],
    len: usize,
}

impl Children {
    fn new() -> Self {
        Children { items: [0; BVH_WIDTH], len: 0 }
    }
    fn push(&mut self, c: u64) {
        // At most BVH_WIDTH pushes per node (one per slot), so this never overflows.
        if let Some(slot) = self.items.get_mut(self.len) {
            *slot = c;
            self.len += 1;
        }
    }
    fn as_slice(&self) -> &[u64] {
        &self.items[..self.len]
    }
}

/// Proves that nodes `first..first + count` form one tree rooted at `first` of depth at most
/// `max_depth` (see the module docs). `node(n)` checks node `n`'s own leaves and returns its internal
/// children as absolute node indices. Errors name the absolute node index.
pub(crate) fn check_tree(
    first: usize,
    count: usize,
    max_depth: u32,
    mut node: impl FnMut(usize) -> Result<Children, &'static str>,
) -> Result<(), (usize, &'static str)> {
    // Depth per node, 0 = not (yet) reached. Children come after their parent, so one forward pass sees
    // every parent before its children.
    let mut depth = vec![0u8; count];
    let end = first as u64 + count as u64;
    for i in 0..count {
        let n = first + i;
        let d = depth[i];
        if d == 0 && i > 0 {
            return Err((n, "node not reachable from the root (each node must be reached exactly once)"));
        }
        let d = d.max(1);
        let children = node(n).map_err(|what| (n, what))?;
        for &c in children.as_slice() {
            if c <= n as u64 || c >= end {
                return Err((n, "child node index not after the parent or out of range"));
            }
            if d as u32 >= max_depth {
                return Err((n, "BVH deeper than the traversal stack allows"));
            }
            let slot = &mut depth[(c - first as u64) as usize];
            if *slot != 0 {
                return Err((n, "child node shared with another parent (the BVH must be a tree)"));
            }
            *slot = d + 1;
        }
    }
    Ok(())
}

/// The internal children of BVH8 node `n` of the range ending at node `end`, whose leaves index `lo..hi`
/// (blocks or instance items), after checking each leaf: non-empty and inside `lo..hi`, or exactly
/// [`child_ref::EMPTY`]; and each used child's bounds sane (after its reference, so that a bad
/// reference is reported as such).
pub(crate) fn bvh8_children(
    nodes: &[BvhNode],
    n: usize,
    end: usize,
    (lo, hi): (u64, u64),
    leaf_what: &'static str,
) -> Result<Children, &'static str> {
    let node = &nodes[n];
    let mut out = Children::new();
    for (slot, &r) in node.children.iter().enumerate() {
        if r == child_ref::EMPTY {
            continue;
        }
        if !child_ref::is_leaf(r) && (r as usize <= n || r as usize >= end) {
            return Err("child node index not after the parent or out of range");
        }
        if child_ref::is_leaf(r) {
            let (first, count) = child_ref::leaf_range(r);
            if count == 0 {
                return Err("leaf with no blocks that is not the empty-slot encoding");
            }
            if (first as u64) < lo || first as u64 + count as u64 > hi {
                return Err(leaf_what);
            }
        } else {
            out.push(r as u64);
        }
        if (0..6).any(|k| !sane(node.bounds[k][slot])) {
            return Err("non-finite or huge child bounds");
        }
    }
    Ok(out)
}

/// The internal children of a CWBVH node over `primitives` slots, after checking that `imask` agrees
/// with [`cw_child_is_internal`] on every slot, that internal meta bytes are the canonical
/// [`cw_internal_meta`], and that every leaf has a unary count of 1..=3 primitives inside the node's 24
/// primitive bits and inside the slot table.
pub(crate) fn cwbvh_children(node: &CwBvhNode, primitives: usize) -> Result<Children, &'static str> {
    if !all_sane(&node.p) {
        return Err("non-finite or huge node origin");
    }
    let mut out = Children::new();
    let mut rank = 0u64;
    for (slot, &meta) in node.child_meta.iter().enumerate() {
        let internal = cw_child_is_internal(meta);
        if internal != (node.imask & (1 << slot) != 0) {
            return Err("imask and meta byte disagree on whether a child is internal");
        }
        if internal {
            if meta != cw_internal_meta(slot) {
                return Err("internal child's meta byte does not name its own slot");
            }
            out.push(node.child_base_idx as u64 + rank);
            rank += 1;
        } else if meta != 0 {
            let offset = (meta & 0b1_1111) as u64;
            let count = match meta >> 5 {
                0b001 => 1,
                0b011 => 2,
                0b111 => 3,
                _ => return Err("leaf primitive count is not unary 1..=3"),
            };
            if offset + count > 24 {
                return Err("leaf primitives spill past the node's 24 primitive bits");
            }
            if node.primitive_base_idx as u64 + offset + count > primitives as u64 {
                return Err("leaf primitive range out of bounds");
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(links: &[(usize, &[u64])], count: usize, max_depth: u32) -> Result<(), (usize, &'static str)> {
        check_tree(0, count, max_depth, |n| {
            let mut c = Children::new();
            for &(parent, kids) in links {
                if parent == n {
                    kids.iter().for_each(|&k| c.push(k));
                }
            }
            Ok(c)
        })
    }

    #[test]
    fn trees_pass_and_cycles_dags_orphans_and_depth_fail() {
        assert_eq!(chain(&[(0, &[1, 2]), (1, &[3])], 4, 3), Ok(()));
        assert_eq!(
            chain(&[(0, &[0])], 1, 8).unwrap_err().1,
            "child node index not after the parent or out of range"
        );
        assert!(chain(&[(0, &[1, 2]), (1, &[2])], 3, 8)
            .unwrap_err()
            .1
            .contains("shared with another parent"));
        assert!(chain(&[(0, &[1])], 3, 8).unwrap_err().1.contains("not reachable"));
        assert!(chain(&[(0, &[1]), (1, &[2])], 3, 2).unwrap_err().1.contains("deeper"));
        assert_eq!(chain(&[(0, &[1]), (1, &[2])], 3, 3), Ok(()));
    }

    #[test]
    fn cwbvh_meta_rule_is_the_obvhs_rule() {
        for meta in 0..=255u8 {
            assert_eq!(cw_child_is_internal(meta), meta & (meta << 1) & 0x10 != 0, "{meta:#010b}");
        }
        for slot in 0..8 {
            assert!(cw_child_is_internal(cw_internal_meta(slot)));
        }
    }
}

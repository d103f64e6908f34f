//! [`LightSelector::select`] for eight shading points at once, for the wavefront's light-sampling
//! lane kernel: the first choice of all eight lanes without a branch, then the descents of the
//! lanes that chose the tree interleaved level by level.
//!
//! One descent is latency-bound: at each node a chain of square roots and divisions (the 8-lane
//! importance pass, the sum, the choice, `u` rescaled), and the next node's address depends on the
//! choice. The descents of different lanes are independent, so here each level is one loop over
//! the lanes still descending, its body one node step of one lane: nothing in an iteration waits
//! for the one before, and the out-of-order core overlaps the lanes' chains. The loop has no
//! data-dependent branch either: the first choice (dome, sun or tree: a coin flip per lane) and a
//! lane's end of descent (a leaf or not) only set a mask bit and advance a count. The lanes that go
//! on descending are compacted in place, the light index and probability are written at every
//! step, so each lane's last write is its leaf's.
//!
//! Every lane makes the scalar descent's operations in the same order ([`child_weights`],
//! [`choose`], `pmf *= w / sum`, `u` rescaled and clamped): the result equals `select` bit for bit
//! (the tests check it for 1 to 300 lights).
//!
//! Not done: evaluating the root, which every descending lane visits, for all eight points in one
//! pass per child (points in lanes, so the sum and the choice would be vertical too). Only about a
//! third of a group's lanes descend on the bench scene (dome, sun and tree hold one slot each), so
//! eight child passes would replace about three point passes.

use super::node::{child_weights, choose, Node, LEAF};
use super::{LightSelector, ONE_MINUS_EPSILON};

/// Shading points per call: the wavefront's lane count.
pub const LANES: usize = 8;

impl LightSelector {
    /// [`LightSelector::select`] at the eight points `p` (x, y, z columns) with `u_select`: each
    /// lane's light index (selection-list) into `light` and its probability into `pmf`, bit for
    /// bit the scalar results. Must not be empty.
    #[allow(clippy::needless_range_loop)]
    pub fn select_lanes(
        &self,
        p: &[[f32; LANES]; 3],
        u_select: &[f32; LANES],
        light: &mut [u32; LANES],
        pmf: &mut [f32; LANES],
    ) {
        let infinite = self.infinite.len();
        let (mut descending, mut count) = ([0u8; LANES], 0usize);
        let mut u = [0.0f32; LANES];
        for k in 0..LANES {
            let slot = self.slot(u_select[k]);
            // Lanes in the tree's slot get a light at infinity here and their own from the descent.
            light[k] = self.infinite.get(slot.min(infinite.saturating_sub(1))).copied().unwrap_or(0);
            pmf[k] = self.slot_pmf;
            // The tree's slot is the last: stretch `u_select` over it (as `select`).
            u[k] = (u_select[k] * self.slots as f32 - infinite as f32).clamp(0.0, ONE_MINUS_EPSILON);
            descending[count] = k as u8;
            count += (slot >= infinite) as usize;
        }
        if count == 0 {
            return;
        }
        let tree = descending;
        let mut path_pmf = [1.0f32; LANES];
        descend_interleaved(&self.tree.nodes, p, &mut u, &mut descending, count, light, &mut path_pmf);
        for &k in &tree[..count] {
            pmf[k as usize] = self.slot_pmf * path_pmf[k as usize];
        }
    }
}

/// The tree's descents of the lanes `descending[..count]` from the root, level by level: at the
/// end `light[k]` is lane `k`'s light and `pmf[k]` the product of its choices' probabilities (from
/// 1), as [`super::descend`] returns them. `descending` is used as scratch.
#[allow(clippy::too_many_arguments)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
fn descend_interleaved(
    nodes: &[Node],
    p: &[[f32; LANES]; 3],
    u: &mut [f32; LANES],
    descending: &mut [u8; LANES],
    mut count: usize,
    light: &mut [u32; LANES],
    pmf: &mut [f32; LANES],
) {
    // Each lane's current node (all start at the root).
    let mut at = [0u32; LANES];
    while count > 0 {
        let mut next = 0;
        for j in 0..count {
            let k = descending[j] as usize;
            let node = &nodes[at[k] as usize];
            let (w, sum) = child_weights(node, [p[0][k], p[1][k], p[2][k]]);
            let target = u[k] * sum;
            let (chosen, below) = choose(&w, node.len, target);
            pmf[k] *= w[chosen] / sum;
            u[k] = ((target - below) / w[chosen]).clamp(0.0, ONE_MINUS_EPSILON);
            // A node index until the lane reaches a leaf, then its light.
            at[k] = node.child[chosen];
            light[k] = node.child[chosen];
            // `next <= j`: the slot written was read already.
            descending[next] = k as u8;
            next += (node.flags[chosen] & LEAF == 0) as usize;
        }
        count = next;
    }
}

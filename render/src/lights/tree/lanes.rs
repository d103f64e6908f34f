//! [`LightSelector::select`] for eight shading points at once, for the wavefront's light-sampling
//! lane kernel: the first choice of all eight lanes without a branch, then the descents of the
//! lanes that chose the tree interleaved level by level.
//!
//! One descent is latency-bound: at each node a chain of square roots and divisions (the 8-lane
//! importance pass, the sum, the choice, `u` rescaled), and the next node's address depends on the
//! choice. The descents of different lanes are independent, so each level is two loops over the
//! lanes still descending: first every lane's importance pass (into a small array), then every
//! lane's choice and step to its child. Nothing in an iteration waits for the one before, and each
//! body is short enough (about 60 instructions for the pass) that the out-of-order window holds
//! several lanes' chains at once. The loops have no data-dependent branch either: the first choice
//! (dome, sun or tree: a coin flip per lane) and a lane's end of descent (a leaf or not) only set a
//! count; the lanes that go on descending are compacted in place, and the light index and
//! probability are written at every step, so each lane's last write is its leaf's.
//!
//! Every lane makes the scalar descent's operations in the same order ([`child_weights`],
//! [`choose`], `pmf *= w / sum`, `u` rescaled and clamped): the result equals `select` bit for bit
//! (the tests check it for 1 to 300 lights; the bench renders are byte-identical).
//!
//! Measured on the shading-heavy bench scene (48 sphere lights, dome, sun; AMD EPYC, contended),
//! against eight scalar `select` calls per group:
//! - timed in one process, interleaved, 10⁵ groups of random points over the scene, 7 rounds:
//!   eight `select` calls 292–311 ns a group; one loop per level (each body a whole node step)
//!   243–312 ns; the two loops per level 202–250 ns (about −25 %);
//! - perf, wavefront, one thread, 320×213, 16 spp, share of samples, 3 runs each, alternated:
//!   `descend` + `select` 4.85 / 5.19 / 5.35 % → `descend_interleaved` + `select_lanes` 2.79 /
//!   3.42 / 3.36 %; with the kernel around them (`light_lanes::sample_lanes`) 7.9–8.3 → 5.3–6.1 %;
//! - task-clock of that render, 5 runs each, alternated (load average 5–6 on 2 cores, so noisy):
//!   1214–1389 ms (median 1307) → 986–1334 ms (median 1216);
//! - callgrind (120×80, 8 spp, one thread): the selection (inclusive) 14.92 → 18.67 M
//!   instructions (the weights' round trip through memory and the compaction), the render 542.67 →
//!   544.92 M (+0.4 %): more instructions, less time.
//!
//! Not done: evaluating the root, which every descending lane visits, for all eight points in one
//! pass per child (points in lanes, so the sum and the choice would be vertical too). Only about a
//! third of a group's lanes descend on the bench scene (dome, sun and tree hold one slot each), so
//! eight child passes would replace about three point passes, and the square roots and divisions
//! (the divider's throughput) would triple at the root.

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
    let mut weights = [([0.0f32; LANES], 0.0f32); LANES];
    while count > 0 {
        // The importance passes of all lanes first: independent, so the core overlaps them.
        for j in 0..count {
            let k = descending[j] as usize;
            weights[j] = child_weights(&nodes[at[k] as usize], [p[0][k], p[1][k], p[2][k]]);
        }
        let mut next = 0;
        for j in 0..count {
            let k = descending[j] as usize;
            let node = &nodes[at[k] as usize];
            let (w, sum) = &weights[j];
            let target = u[k] * sum;
            let (chosen, below) = choose(w, node.len, target);
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

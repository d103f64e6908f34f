//! [`LightSelector::select`] for eight shading points at once, for the wavefront's light-sampling
//! lane kernel: the first choice of all eight lanes without a branch, then the descents of the
//! lanes that chose the tree interleaved level by level.
//!
//! One descent is latency-bound: at each node a chain (the 8-lane importance pass, the running
//! sums, the choice, `u` rescaled), and the next node's address depends on the choice. The
//! descents of different lanes are independent, so each level is one loop over the lanes still
//! descending, each body one node step of one lane ([`node::step`], or `avx::step` in the AVX2
//! clone: the same bits); nothing in an iteration waits for the one before, so the out-of-order
//! window overlaps the lanes' chains. The loop has no data-dependent branch: the first choice
//! (dome, sun or tree: a coin flip per lane) and a lane's end of descent (a leaf or not) only set a
//! count; the lanes that go on descending are compacted in place, and the light index and
//! probability are written at every step, so each lane's last write is its leaf's.
//!
//! Every lane makes the scalar descent's operations in the same order ([`node::child_weights`],
//! [`node::choose`], `pmf *= w / sum`, `u` rescaled and clamped): the result equals `select` bit
//! for bit (the tests check it for 1 to 300 lights; the bench renders are byte-identical).
//!
//! Kept because measured faster than eight scalar `select` calls: the interleaved levels (more
//! instructions, less time), the node step in AVX2 intrinsics with the short importance of
//! omnidirectional nodes ([`node::omni_importances`]), the first choice 8-wide, and the root for all
//! eight points at once (`avx::root_lanes`: it removes the longest dependent chain). Tried and
//! dropped: two passes a level, and the levels below the root vertical as well; measurements: `docs/perf.md#light-tree-lanes-lightstreelanesrs`.

#[cfg(doc)]
use super::node;
use super::node::{step, Node, Step, LEAF};
use super::{LightSelector, ONE_MINUS_EPSILON};
use lanekit::saturating_i32;

use lanekit::{Lanes, Lanes3, U32Lanes, LANES};

impl LightSelector {
    /// [`LightSelector::select`] at the eight points `p` (x, y, z columns) with `u_select`: each
    /// lane's light index (selection-list) into `light` and its probability into `pmf`, bit for
    /// bit the scalar results. Must not be empty.
    pub fn select_lanes(&self, p: &Lanes3, u_select: &Lanes, light: &mut U32Lanes, pmf: &mut Lanes) {
        select_in(self, p, u_select, light, pmf);
    }
}

/// [`LightSelector::select_lanes`] under [`multiversion`]: the first choice 8-wide ([`first_choice`]
/// and [`pick`], or their AVX2 forms: a clamp, one `cvttps2dq` and one `vpermd` for all lanes,
/// where `as usize` and a bounds-checked load took about 40 scalar instructions a lane), then the
/// descents of the lanes in the tree's slot: in the AVX2 clone the root's step of all eight lanes
/// at once when the root's children all emit in every direction (`avx::root_lanes`), then the
/// lanes that did not reach a light interleaved level by level.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
fn select_in(selector: &LightSelector, p: &Lanes3, u_select: &Lanes, light: &mut U32Lanes, pmf: &mut Lanes) {
    let infinite = &selector.infinite[..];
    let (mut slot, mut u) = ([0i32; LANES], [0.0f32; LANES]);
    multiversion::target::match_target! {
        "x86_64+avx+avx2+fma" => super::avx::first_choice(u_select, selector.slots, infinite.len(), &mut slot, &mut u),
        _ => first_choice(u_select, selector.slots, infinite.len(), &mut slot, &mut u),
    }
    *light = if infinite.len() <= LANES {
        multiversion::target::match_target! {
            "x86_64+avx+avx2+fma" => super::avx::pick(&selector.infinite_lanes, &slot),
            _ => pick(&selector.infinite_lanes, &slot),
        }
    } else {
        let last_infinite = infinite.len() - 1;
        std::array::from_fn(|k| infinite[(slot[k] as usize).min(last_infinite)])
    };
    // Lanes in the tree's slot got a light at infinity above and get their own from the descent.
    let mut tree_lanes = 0u32;
    for k in 0..LANES {
        tree_lanes |= ((slot[k] as usize >= infinite.len()) as u32) << k;
    }
    // Lanes that did not descend multiply 1: exactly the slot's probability.
    let mut path_pmf = [1.0f32; LANES];
    if tree_lanes != 0 {
        let nodes = &selector.tree.nodes[..];
        let mut descents = Descents { u, at: [0; LANES], light, pmf: &mut path_pmf };
        multiversion::target::match_target! {
            "x86_64+avx+avx2+fma" => {
                let Descents { u, at, light, pmf } = &mut descents;
                let lanes = super::avx::root_lanes(&nodes[0], p, tree_lanes, u, at, light, pmf).unwrap_or(tree_lanes);
                descents.run(nodes, p, lanes, |n, q, u| super::avx::step(n, q, u));
            },
            _ => descents.run(nodes, p, tree_lanes, step),
        }
    }
    for k in 0..LANES {
        pmf[k] = selector.slot_pmf * path_pmf[k];
    }
}

/// Each lane's slot of the first choice, `((u_select · slots) as usize).min(slots − 1)` as
/// [`LightSelector::select`] computes it, and `u_select` stretched over the tree's slot (the last;
/// `infinite` slots come before it).
#[inline(always)]
pub(super) fn first_choice(
    u_select: &Lanes,
    slots: u32,
    infinite: usize,
    slot: &mut [i32; LANES],
    u: &mut Lanes,
) {
    for k in 0..LANES {
        let scaled = u_select[k] * slots as f32;
        slot[k] = saturating_i32(scaled).max(0).min(slots as i32 - 1);
        u[k] = (scaled - infinite as f32).clamp(0.0, ONE_MINUS_EPSILON);
    }
}

/// `table[min(slot, 7)]` in each lane.
#[inline(always)]
pub(super) fn pick(table: &U32Lanes, slot: &[i32; LANES]) -> U32Lanes {
    std::array::from_fn(|k| table[(slot[k] as usize).min(LANES - 1)])
}

/// [`LightSelector::infinite_lanes`] for the lights at infinity `infinite`.
pub(super) fn padded(infinite: &[u32]) -> U32Lanes {
    std::array::from_fn(|i| infinite.get(i.min(infinite.len().saturating_sub(1))).copied().unwrap_or(0))
}

/// The lanes of each 8-bit mask, lowest first, one byte each (`LANE_LISTS[m]`'s byte `i` is the
/// `i`-th set bit of `m`): a mask's list of lanes in one load, where a loop over the bits took a
/// compare, an add and a store a lane.
const LANE_LISTS: [u64; 256] = {
    let mut lists = [0u64; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut list, mut count, mut k) = (0u64, 0, 0);
        while k < LANES {
            if mask & (1 << k) != 0 {
                list |= (k as u64) << (8 * count);
                count += 1;
            }
            k += 1;
        }
        lists[mask] = list;
        mask += 1;
    }
    lists
};

/// Descents of lanes from their node `at` (the root, or the root's chosen child), with their `u`
/// rescaled at each node: at the end `light[k]` is lane `k`'s light and `pmf[k]` the product of
/// its choices' probabilities (from 1), as [`super::descend`] returns them.
struct Descents<'a> {
    u: Lanes,
    /// Each lane's current node.
    at: U32Lanes,
    light: &'a mut U32Lanes,
    pmf: &'a mut Lanes,
}

impl Descents<'_> {
    /// Level by level, the lanes of the bit mask `lanes` from their node `at`: each lane's node
    /// step (`step`: [`node::step`] or `avx::step`, the same bits), `pmf` and `u` updated with the
    /// scalar descent's operations, and its child.
    #[inline(always)]
    fn run(&mut self, nodes: &[Node], p: &Lanes3, lanes: u32, step: impl Fn(&Node, [f32; 3], f32) -> Step) {
        let mut descending = LANE_LISTS[lanes as usize & 0xff].to_le_bytes();
        let mut count = lanes.count_ones() as usize;
        while count > 0 {
            let mut next = 0;
            for j in 0..count.min(LANES) {
                let k = descending[j] as usize % LANES;
                let node = &nodes[self.at[k] as usize];
                let Step { chosen, weight, below, sum, target } =
                    step(node, [p[0][k], p[1][k], p[2][k]], self.u[k]);
                self.pmf[k] *= weight / sum;
                self.u[k] = ((target - below) / weight).clamp(0.0, ONE_MINUS_EPSILON);
                // A node index until the lane reaches a leaf, then its light.
                self.at[k] = node.child[chosen];
                self.light[k] = node.child[chosen];
                // `next <= j`: the slot written was read already.
                descending[next % LANES] = k as u8;
                next += (node.flags[chosen] & LEAF == 0) as usize;
            }
            count = next;
        }
    }
}

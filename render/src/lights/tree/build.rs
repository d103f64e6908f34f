//! The tree's build: a binary SAH tree (PBRT-v4's `BVHLightSampler::buildBVH` cost), collapsed
//! into nodes of up to eight children (Embree's BVH2 → BVH8 collapse).
//!
//! The binary tree is built by binned SAH over the three axes (12 buckets; PBRT's cost
//! φ · M_Ω · surface area · K_r, which also weighs how spread the emission cones are), falling
//! back to a median split by light index order when no axis separates the centroids, and a forced
//! median split once the depth could exceed the 42 levels the 128 path bits hold. The collapse: a
//! node starts with the binary node's two children and, while it has fewer than eight, opens the
//! interior child of largest φ · M_Ω · surface area (then φ: lights at one point have no area) in
//! place. Opening the child with the most lights instead lost on the floor test (figures:
//! `docs/perf.md#light-tree-lightstreemodrs`). Every step is a deterministic function of the input
//! order: same scene, same tree.

use super::node::{Node, LEAF, WIDTH};
use super::{LightBounds, Path};
use glam::Vec3;
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// SAH buckets per axis.
const BUCKETS: usize = 12;
/// Deepest level of a wide node: three path bits per level fit [`Path::digits`]' 128 bits.
const MAX_LEVELS: usize = 42;

/// One node of the binary tree the wide tree is collapsed from.
struct Binary {
    bounds: LightBounds,
    /// An interior node's children (indices into the binary nodes), or `None` for a light.
    children: Option<[usize; 2]>,
    /// A light's selection-list index.
    light: u32,
}

/// The wide nodes over `items` (selection-list index, bounds), the root first, and each light's
/// path, written into `paths` (indexed by selection-list index). `items` must not be empty.
pub(super) fn build(items: &[(u32, LightBounds)], paths: &mut [Path]) -> Vec<Node> {
    let mut binary = Vec::with_capacity(2 * items.len());
    let mut items = items.to_vec();
    let root = build_binary(&mut binary, &mut items, 0);
    let mut nodes = Vec::with_capacity(items.len().div_ceil(WIDTH - 1));
    collapse(&binary, root, 0, 0, &mut nodes, paths);
    nodes
}

/// Appends the binary subtree of `items` at `depth`; returns its root's index.
fn build_binary(binary: &mut Vec<Binary>, items: &mut [(u32, LightBounds)], depth: usize) -> usize {
    if let [(light, bounds)] = items {
        binary.push(Binary { bounds: *bounds, children: None, light: *light });
        return binary.len() - 1;
    }
    let mid = split(items, depth);
    let (first, second) = items.split_at_mut(mid);
    let a = build_binary(binary, first, depth + 1);
    let b = build_binary(binary, second, depth + 1);
    let bounds = binary[a].bounds.union(&binary[b].bounds);
    binary.push(Binary { bounds, children: Some([a, b]), light: 0 });
    binary.len() - 1
}

/// Emits the wide node standing for binary node `at` (level `level`, reached by `digits`) and
/// its subtree; returns its index. Its children start as `at`'s two (or `at` itself, a tree of one
/// light); while there are fewer than eight, the interior child of the largest
/// [`opening_cost`] is replaced by its two children, in place, so a node's lanes keep the binary
/// tree's left-to-right order. Ties go to the first: deterministic.
fn collapse(
    binary: &[Binary],
    at: usize,
    level: usize,
    digits: u128,
    nodes: &mut Vec<Node>,
    paths: &mut [Path],
) -> u32 {
    let mut open: Vec<usize> = match binary[at].children {
        Some(children) => children.to_vec(),
        None => vec![at],
    };
    while open.len() < WIDTH {
        let mut widest: Option<(usize, (f32, f32))> = None;
        for (slot, &b) in open.iter().enumerate() {
            if binary[b].children.is_some() {
                let cost = opening_cost(&binary[b].bounds);
                if widest.is_none_or(|(_, c)| cost.0.total_cmp(&c.0).then(cost.1.total_cmp(&c.1)).is_gt()) {
                    widest = Some((slot, cost));
                }
            }
        }
        let Some((slot, _)) = widest else { break };
        let [a, b] = binary[open[slot]].children.expect("an interior node");
        open.splice(slot..=slot, [a, b]);
    }
    let index = nodes.len();
    nodes.push(Node::EMPTY);
    let mut node = Node::EMPTY;
    for (k, &b) in open.iter().enumerate() {
        let digits = digits | (k as u128) << (3 * level);
        let child = &binary[b];
        if child.children.is_some() {
            let child_index = collapse(binary, b, level + 1, digits, nodes, paths);
            node.push(&child.bounds, 0, child_index);
        } else {
            node.push(&child.bounds, LEAF, child.light);
            paths[child.light as usize] = Path { digits, depth: level as u32 + 1 };
        }
    }
    nodes[index] = node;
    index as u32
}

/// How much a child would gain from being opened: PBRT's SAH cost without the split's aspect
/// term (power × the solid angle its emission may cover × box area), then its power alone (lights
/// at one point have no area).
fn opening_cost(b: &LightBounds) -> (f32, f32) {
    let d = b.hi - b.lo;
    (b.phi * b.m_omega() * 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x), b.phi)
}

impl LightBounds {
    /// The solid angle PBRT's cost weighs the emission cone by.
    fn m_omega(&self) -> f32 {
        let theta_o = self.theta_o;
        let theta_w = (theta_o + self.theta_e).min(PI);
        let (sin_o, cos_o) = theta_o.sin_cos();
        TAU * (1.0 - cos_o)
            + FRAC_PI_2
                * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o + cos_o)
    }

    /// PBRT's SAH-like cost of a node with these bounds split along `axis` of the parent's box
    /// `diagonal`: power × the solid angle its emission may cover × box area × how thin the box is
    /// along the split.
    fn cost(&self, diagonal: Vec3, axis: usize) -> f32 {
        let kr = diagonal.max_element() / diagonal[axis];
        let d = self.hi - self.lo;
        let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        self.phi * self.m_omega() * kr * area
    }
}

/// Partitions `items` for a binary node at `depth` and returns the size of the first part (in
/// 1..len).
fn split(items: &mut [(u32, LightBounds)], depth: usize) -> usize {
    let n = items.len();
    let centroid = |b: &LightBounds| (b.lo + b.hi) * 0.5;
    let (lo, hi) = items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (_, b)| {
        let c = centroid(b);
        (lo.min(c), hi.max(c))
    });
    let extent = hi - lo;
    // Past this depth the path bits could run out below a chain of uneven splits: halve instead.
    // (A wide level takes at least one binary level, so binary depth bounds the wide depth.)
    let must_halve = depth + (usize::BITS - (n - 1).leading_zeros()) as usize >= MAX_LEVELS;
    let best = if must_halve { None } else { best_bucket_split(items, lo, extent) };
    if let Some((axis, bucket)) = best {
        let bucket_of = |b: &LightBounds| bucket_index(centroid(b)[axis], lo[axis], extent[axis]);
        let mid = partition(items, |(_, b)| bucket_of(b) <= bucket);
        if mid > 0 && mid < n {
            return mid;
        }
    }
    // Median along the widest axis, ties by light index: deterministic and balanced.
    let axis = extent.max_position();
    let mid = n / 2;
    items.select_nth_unstable_by(mid, |(i, a), (j, b)| {
        centroid(a)[axis].total_cmp(&centroid(b)[axis]).then(i.cmp(j))
    });
    mid
}

fn bucket_index(c: f32, lo: f32, extent: f32) -> usize {
    (((c - lo) / extent * BUCKETS as f32) as usize).min(BUCKETS - 1)
}

/// The SAH's best (axis, last bucket of the first part), or `None` if no axis spreads the centroids.
fn best_bucket_split(items: &[(u32, LightBounds)], lo: Vec3, extent: Vec3) -> Option<(usize, usize)> {
    let (box_lo, box_hi) =
        items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), (_, b)| (l.min(b.lo), h.max(b.hi)));
    let diagonal = box_hi - box_lo;
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis].is_nan() || extent[axis] <= 0.0 {
            continue;
        }
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in items {
            let k = bucket_index((b.lo[axis] + b.hi[axis]) * 0.5, lo[axis], extent[axis]);
            buckets[k] = Some(buckets[k].map_or(*b, |acc| acc.union(b)));
        }
        let merge = |acc: Option<LightBounds>, b: &Option<LightBounds>| match (acc, b) {
            (Some(a), Some(b)) => Some(a.union(b)),
            (a, b) => a.or(*b),
        };
        for last in 0..BUCKETS - 1 {
            let below = buckets[..=last].iter().fold(None, merge);
            let above = buckets[last + 1..].iter().fold(None, merge);
            let (Some(below), Some(above)) = (below, above) else { continue };
            let cost = below.cost(diagonal, axis) + above.cost(diagonal, axis);
            if cost.is_finite() && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, last));
            }
        }
    }
    best.map(|(_, axis, last)| (axis, last))
}

/// Moves the items for which `first` holds to the front (in place, deterministic); returns how many.
fn partition<T>(items: &mut [T], first: impl Fn(&T) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..items.len() {
        if first(&items[i]) {
            items.swap(i, mid);
            mid += 1;
        }
    }
    mid
}

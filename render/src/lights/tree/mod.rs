//! Light selection for next-event estimation: importance sampling of bounded lights with a light
//! BVH, after PBRT-v4's `BVHLightSampler` (our own code; the cost and importance functions follow
//! its text).
//!
//! Data flow: [`crate::lights::Lights::new`] gives every selection-list entry that has a position
//! (point, sphere, rect and disk lights, and the one entry standing for all emissive triangles) its
//! [`LightBounds`] — box, power φ, emission cone (axis, θ_o, θ_e), two-sidedness — and
//! [`LightSelector::new`] builds the tree over them once. Lights at infinity (domes, distant lights)
//! have no bounds: each takes one slot of a uniform first choice, the tree (when it is not empty)
//! one more slot, as PBRT does (one slot per bounded light instead measured no better than uniform
//! selection). Scenes with lights at infinity only therefore select exactly as the uniform selection
//! did. [`LightSelector::select`] turns one uniform number into a light and its
//! probability at a shading point; [`LightSelector::pmf`] gives the probability any light would
//! have had there. The scalar integrator and the MIS weights of emission found by BSDF rays go
//! through these two functions; the wavefront's lane kernel calls [`LightSelector::select_lanes`]
//! (`tree/lanes.rs`: eight lanes' descents interleaved, each lane's result `select`'s bit for bit).
//!
//! Importance uses the shading point only, not its normal. A BSDF ray that meets a light needs the
//! probability that light sampling at the previous vertex would have chosen that light; both
//! integrators carry the previous vertex's position (`prev_p`) but not its normal, and growing
//! every ray's state by a normal for this one weight was rejected. The normal term (PBRT's
//! `cos θ_i` bound) would mostly help points facing away from whole clusters of lights.
//!
//! Node layout (`tree/node.rs`): the tree is 8-wide, each [`Node`] holding its children's bounds
//! column by column, so one node's eight importances are one 8-lane pass. Each light's path
//! from the root (three bits per level: the child slot) is stored beside the tree, so `pmf` replays
//! the same decisions as sampling and multiplies the same factors in the same order: the two agree
//! bit for bit. Build (`tree/build.rs`): a binary tree by binned SAH, collapsed into 8-wide nodes;
//! deterministic: same scene, same tree.
//!
//! Sampling descends with one uniform number: at each node the children's probabilities (their
//! share of the node's importance; 1 / children each where none may contribute, so the
//! probabilities over all lights always sum to 1), the categorical choice among them (branch-free:
//! pairwise prefix sums of the importances, the run of those at or below `u` · their sum), and
//! `u` rescaled into the chosen child's slice (clamped below 1). A child of probability 0 is never
//! chosen. The descent is latency-bound (square roots and divisions in a chain, then the next
//! node's address depends on the choice), so the choice compares weights rather than dividing
//! all eight first, and φ / d² is divided before the angles are known; nodes of omnidirectional
//! children take a short importance of one division (`tree/node.rs`).
//!
//! The wavefront's descents (`tree/lanes.rs`) run the node step in AVX2 intrinsics (`tree/avx.rs`);
//! the baseline clone and the scalar `descend` and `replay` run the portable functions in
//! `tree/node.rs`, and the tests hold the two to the same bits. Measurements:
//! `docs/perf.md#light-tree-lightstreemodrs`.

#[cfg(target_arch = "x86_64")]
mod avx;
mod build;
mod lanes;
mod node;

use crate::lights::light::{Light, Shape};
use glam::Vec3;
use node::{child_weights, step, Node, Step, LEAF};
use std::f32::consts::{FRAC_PI_2, PI};

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// What the tree knows of a light with a position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// World box of the emitting surface.
    pub lo: Vec3,
    /// Upper corner.
    pub hi: Vec3,
    /// Power (max RGB channel): what importance scales with.
    pub phi: f32,
    /// Unit axis of the cone of surface normals.
    pub axis: Vec3,
    /// Half-angle of the normals' cone.
    pub theta_o: f32,
    /// Angle beyond the normals at which emission ends (π/2 for every surface here).
    pub theta_e: f32,
    /// Emits on both sides of the surface.
    pub two_sided: bool,
}

impl LightBounds {
    /// Bounds of a light with a position; `None` for lights at infinity and for the emissive
    /// triangles' entry (whose bounds [`crate::lights::Lights::new`] computes from the triangles).
    pub fn of(light: &Light) -> Option<Self> {
        let max = light.radiance.max_element().max(0.0);
        let everywhere = |lo, hi, phi| Self::omnidirectional(lo, hi, phi, false);
        match light.shape {
            // `radiance` holds the intensity: power 4π I.
            Shape::Point { position } => Some(everywhere(position, position, 4.0 * PI * max)),
            // A Lambertian emitter of area A emits π L A.
            Shape::Sphere { center, radius } => {
                Some(everywhere(center - radius, center + radius, PI * max * 4.0 * PI * radius * radius))
            }
            Shape::Rect { center, ex, ey, normal, area } | Shape::Disk { center, ex, ey, normal, area } => {
                let half = ex.abs() + ey.abs();
                Some(LightBounds {
                    lo: center - half,
                    hi: center + half,
                    phi: PI * max * area,
                    axis: normal,
                    theta_o: 0.0,
                    theta_e: FRAC_PI_2,
                    two_sided: false,
                })
            }
            _ => None,
        }
    }

    /// Bounds of two-sided emitting triangles (`corners` of each) of total power `phi`.
    pub fn of_triangles(corners: impl Iterator<Item = Vec3>, phi: f32) -> Option<Self> {
        let (lo, hi) =
            corners.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(c), hi.max(c)));
        (lo.cmple(hi).all()).then_some(Self::omnidirectional(lo, hi, phi, true))
    }

    /// Bounds of emitters in the box `lo`..`hi` that may emit in every direction (the cone is the
    /// whole sphere, so the axis is arbitrary).
    fn omnidirectional(lo: Vec3, hi: Vec3, phi: f32, two_sided: bool) -> Self {
        LightBounds { lo, hi, phi, axis: Vec3::Z, theta_o: PI, theta_e: FRAC_PI_2, two_sided }
    }

    /// The bounds of both (PBRT's `Union`: boxes, power, the cone holding both cones).
    fn union(&self, other: &LightBounds) -> LightBounds {
        let (axis, theta_o) = cone_union(self.axis, self.theta_o, other.axis, other.theta_o);
        LightBounds {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
            phi: self.phi + other.phi,
            axis,
            theta_o,
            theta_e: self.theta_e.max(other.theta_e),
            two_sided: self.two_sided || other.two_sided,
        }
    }
}

/// The smallest cone (axis, half-angle) holding the cones (`a`, `theta_a`) and (`b`, `theta_b`).
fn cone_union(a: Vec3, theta_a: f32, b: Vec3, theta_b: f32) -> (Vec3, f32) {
    let theta_d = a.dot(b).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (a, theta_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (b, theta_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    let turn = a.cross(b);
    if theta_o >= PI || turn.length_squared() == 0.0 {
        return (Vec3::Z, PI);
    }
    // Rotate `a` towards `b` by θ_o − θ_a about their common normal.
    let rotation = glam::Quat::from_axis_angle(turn.normalize(), theta_o - theta_a);
    ((rotation * a).normalize(), theta_o)
}

/// A light's place in the tree: the child slot chosen at each level from the root, three bits
/// a level (level `i` in bits `3i..3i + 3`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Path {
    digits: u128,
    /// Levels: nodes from the root to the light's.
    depth: u32,
}

/// No path: the light is not in the tree.
const NOT_IN_TREE: Path = Path { digits: 0, depth: u32::MAX };

/// The light BVH over the bounded lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightTree {
    /// The root first.
    nodes: Vec<Node>,
    /// By selection-list index.
    paths: Vec<Path>,
}

impl LightTree {
    /// Builds the tree over `items` (selection-list index, bounds); `count` is the length of the
    /// selection list.
    pub fn new(items: &[(u32, LightBounds)], count: usize) -> Self {
        let mut paths = vec![NOT_IN_TREE; count];
        let nodes = if items.is_empty() { Vec::new() } else { build::build(items, &mut paths) };
        LightTree { nodes, paths }
    }

    /// Whether no light is in the tree.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Chooses a light at `p` with `u` in [0, 1): its selection-list index and probability. The
    /// tree must not be empty.
    #[inline]
    pub fn sample(&self, p: Vec3, u: f32) -> (usize, f32) {
        descend(&self.nodes, p.to_array(), u)
    }

    /// The probability [`LightTree::sample`] chooses `light` at `p` (0 if it is not in the tree).
    #[inline]
    pub fn pmf(&self, p: Vec3, light: usize) -> f32 {
        match self.paths.get(light) {
            Some(&path) if path.depth != u32::MAX => replay(&self.nodes, p.to_array(), path),
            _ => 0.0,
        }
    }

    /// Number of levels of the deepest light.
    #[cfg(test)]
    fn depth(&self) -> u32 {
        self.paths.iter().filter(|p| p.depth != u32::MAX).map(|p| p.depth).max().unwrap_or(0)
    }
}

/// [`LightTree::sample`]: at each node, one 8-lane pass for the children's weights, then the child
/// whose slice of the cumulative weights holds `u · sum` (`node::choose`), and `u` rescaled into that
/// slice; the probability it multiplies is the chosen child's `w / sum`, as [`replay`]'s.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
fn descend(nodes: &[Node], p: [f32; 3], mut u: f32) -> (usize, f32) {
    let (mut node, mut pmf) = (&nodes[0], 1.0f32);
    loop {
        let Step { chosen, weight, below, sum, target } = step(node, p, u);
        pmf *= weight / sum;
        u = ((target - below) / weight).clamp(0.0, ONE_MINUS_EPSILON);
        if node.flags[chosen] & LEAF != 0 {
            return (node.child[chosen] as usize, pmf);
        }
        node = &nodes[node.child[chosen] as usize];
    }
}

/// [`LightTree::pmf`]: the same probabilities (`w / sum` of the same weights) as [`descend`],
/// multiplied in the same order along the light's stored path, so the two agree bit for bit.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
fn replay(nodes: &[Node], p: [f32; 3], path: Path) -> f32 {
    let (mut node, mut pmf) = (&nodes[0], 1.0f32);
    for level in 0..path.depth {
        let slot = (path.digits >> (3 * level) & 7) as usize;
        let weights = child_weights(node, p);
        pmf *= weights.w[slot] / weights.sum();
        if level + 1 < path.depth {
            node = &nodes[node.child[slot] as usize];
        }
    }
    pmf
}

/// Light selection: a uniform first choice among the lights at infinity and the tree, then the
/// tree's descent.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightSelector {
    /// Selection-list indices of the lights at infinity (domes, distant lights), in list order.
    infinite: Vec<u32>,
    /// `infinite[min(i, len − 1)]` in lane `i` (0 if there is none): the lanes' first choice picks
    /// from it with one permutation when there are at most eight (`tree/lanes.rs`).
    infinite_lanes: lanekit::U32Lanes,
    tree: LightTree,
    /// Slots of the first choice: one per light at infinity, one for the tree if it has lights.
    slots: u32,
    /// The probability of each slot, 1 / `slots`.
    slot_pmf: f32,
}

impl LightSelector {
    /// Selection over `lights`; `triangles` are the bounds of the emissive triangles' entry.
    pub fn new(lights: &[Light], triangles: Option<LightBounds>) -> Self {
        let mut infinite = Vec::new();
        let mut bounded = Vec::new();
        for (i, light) in lights.iter().enumerate() {
            let bounds = match light.shape {
                Shape::Triangles => triangles,
                _ => LightBounds::of(light),
            };
            match (bounds, light.shape) {
                (Some(b), _) => bounded.push((i as u32, b)),
                (None, Shape::Dome | Shape::TexturedDome { .. } | Shape::Distant { .. }) => {
                    infinite.push(i as u32)
                }
                // An entry without bounds (triangles with none given): never selected.
                (None, _) => {}
            }
        }
        let tree = LightTree::new(&bounded, lights.len());
        let slots = infinite.len() as u32 + !tree.is_empty() as u32;
        LightSelector {
            infinite_lanes: lanes::padded(&infinite),
            infinite,
            tree,
            slots,
            slot_pmf: if slots == 0 { 0.0 } else { 1.0 / slots as f32 },
        }
    }

    /// Uniform selection over all `count` lights, as before the tree: the reference of the tests.
    #[cfg(test)]
    pub fn uniform(count: usize) -> Self {
        let infinite: Vec<u32> = (0..count as u32).collect();
        LightSelector {
            infinite_lanes: lanes::padded(&infinite),
            infinite,
            tree: LightTree::default(),
            slots: count as u32,
            slot_pmf: if count == 0 { 0.0 } else { 1.0 / count as f32 },
        }
    }

    /// Whether nothing can be selected.
    pub fn is_empty(&self) -> bool {
        self.slots == 0
    }

    /// Whether selection is the uniform choice over all `count` lights in list order (every light
    /// at infinity): the same light and probability at every point.
    pub fn is_uniform_over(&self, count: usize) -> bool {
        self.tree.is_empty()
            && self.infinite.len() == count
            && self.infinite.iter().enumerate().all(|(i, &light)| light as usize == i)
    }

    /// The slot `u_select` falls in (`((u · slots) as usize).min(slots − 1)`).
    #[inline]
    fn slot(&self, u_select: f32) -> usize {
        ((u_select * self.slots as f32) as usize).min(self.slots as usize - 1)
    }

    /// The light at infinity `u_select` selects, if it selects one (the choice does not depend on
    /// the shading point).
    pub fn infinite_choice(&self, u_select: f32) -> Option<usize> {
        if self.slots == 0 {
            return None;
        }
        self.infinite.get(self.slot(u_select)).map(|&i| i as usize)
    }

    /// The selection probability of each light at infinity.
    pub fn infinite_pmf(&self) -> f32 {
        self.slot_pmf
    }

    /// Chooses a light at `p`: its selection-list index and probability. Must not be empty.
    #[inline]
    pub fn select(&self, p: Vec3, u_select: f32) -> (usize, f32) {
        let slot = self.slot(u_select);
        if let Some(&i) = self.infinite.get(slot) {
            return (i as usize, self.slot_pmf);
        }
        // The tree's slot is the last: stretch `u_select` over it.
        let u = (u_select * self.slots as f32 - self.infinite.len() as f32).clamp(0.0, ONE_MINUS_EPSILON);
        let (light, pmf) = self.tree.sample(p, u);
        (light, self.slot_pmf * pmf)
    }

    /// The probability [`LightSelector::select`] returns for `light` at `p`.
    #[inline]
    pub fn pmf(&self, p: Vec3, light: usize) -> f32 {
        if self.infinite.contains(&(light as u32)) {
            self.slot_pmf
        } else {
            self.slot_pmf * self.tree.pmf(p, light)
        }
    }
}

#[cfg(test)]
mod tests;

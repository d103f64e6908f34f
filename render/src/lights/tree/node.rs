//! The wide tree's node: up to [`WIDTH`] children whose bounds are stored column by column, so
//! the importance of all of a node's children is one 8-lane pass ([`child_weights`]).
//!
//! Layout: a [`Node`] (512 bytes, `repr(C, align(64))`) holds up to eight children's bounds —
//! `[f32; 8]` columns of the centre and squared radius of each child's bounding sphere, the cone's
//! axis, cos/sin θ_o, cos θ_e, φ, flags, and the child's node index or light index — so one node's
//! eight importances are one 8-lane pass (AVX2 under [`multiversion`], 4 `vsqrtps` and 3 `vdivps`
//! for all eight), where the binary tree made two scalar calls per level. Nodes sit in a `Vec`,
//! root first.
//!
//! A node whose children all emit in every direction (spheres, points, the emissive triangles'
//! entry, and nodes over them only: `Node::omni`, set at build) weighs them by φ / max(d², r²)
//! alone, which is what the whole formula gives there bit for bit wherever the squared distances
//! are finite (the proof is at [`omni_importances`]): one division for eight children where the
//! cone terms took four square roots and three divisions.

use super::LightBounds;
use std::f32::consts::{FRAC_PI_2, PI};

/// Children per node: one AVX2 register of `f32` lanes.
pub(super) const WIDTH: usize = 8;

/// Flag of a child that is a light (its `child` entry is a selection-list index).
pub(super) const LEAF: u32 = 1;
/// Flag of a child whose lights emit on both sides.
pub(super) const TWO_SIDED: u32 = 2;

/// One node, 512 bytes (eight cache lines), `repr(C, align(64))`: per child column, the centre and
/// squared radius of its box's bounding sphere, its emission cone (unit axis, cos/sin θ_o, cos θ_e),
/// its power φ, its flags and its child index (a node's index, or a light's for a [`LEAF`]).
/// Lanes from `len` on are empty: φ = 0, cos θ_e = +∞ and a bounding sphere of radius 1 (so that
/// φ / d² is 0 at the centre too), so their importance is 0 at every point that is not NaN.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Node {
    pub center: [[f32; WIDTH]; 3],
    pub radius2: [f32; WIDTH],
    pub axis: [[f32; WIDTH]; 3],
    pub cos_o: [f32; WIDTH],
    pub sin_o: [f32; WIDTH],
    pub cos_e: [f32; WIDTH],
    pub phi: [f32; WIDTH],
    /// [`LEAF`] | [`TWO_SIDED`].
    pub flags: [u32; WIDTH],
    /// A [`LEAF`]'s light (selection-list index), else the child node's index.
    pub child: [u32; WIDTH],
    /// Children in use (1..=8), from lane 0.
    pub len: u32,
    /// 1 when every child emits in all directions ([`Node::push`]): see [`omni_importances`].
    pub omni: u32,
    _pad: [u32; 14],
}

const _: () = assert!(std::mem::size_of::<Node>() == 512);

impl Node {
    /// A node without children.
    pub const EMPTY: Node = Node {
        center: [[0.0; WIDTH]; 3],
        radius2: [1.0; WIDTH],
        axis: [[0.0; WIDTH]; 3],
        cos_o: [1.0; WIDTH],
        sin_o: [0.0; WIDTH],
        cos_e: [f32::INFINITY; WIDTH],
        phi: [0.0; WIDTH],
        flags: [0; WIDTH],
        child: [0; WIDTH],
        len: 0,
        omni: 1,
        _pad: [0; 14],
    };

    /// Appends a child with bounds `b`; `flags` is [`LEAF`] or 0.
    pub fn push(&mut self, b: &LightBounds, flags: u32, child: u32) {
        let k = self.len as usize;
        assert!(k < WIDTH, "a light tree node has at most {WIDTH} children");
        let center = (b.lo + b.hi) * 0.5;
        let (sin_o, cos_o) = if b.theta_o >= PI { (0.0, -1.0) } else { b.theta_o.sin_cos() };
        for c in 0..3 {
            self.center[c][k] = center[c];
            self.axis[c][k] = b.axis[c];
        }
        self.radius2[k] = (b.hi - center).length_squared();
        self.cos_o[k] = cos_o;
        self.sin_o[k] = sin_o.max(0.0);
        // Every emitter here ends at θ_e = π/2; store its cosine as exactly 0.
        self.cos_e[k] = if b.theta_e == FRAC_PI_2 { 0.0 } else { b.theta_e.cos() };
        self.phi[k] = b.phi;
        self.flags[k] = flags | if b.two_sided { TWO_SIDED } else { 0 };
        self.child[k] = child;
        let omni = self.cos_o[k] == -1.0 && self.sin_o[k] == 0.0 && self.cos_e[k] < 1.0;
        self.omni &= omni as u32;
        self.len += 1;
    }
}

/// How much child `k`'s lights may contribute at `p`: φ · cos θ' / d², where θ' is the smallest
/// angle between the emission cone and the direction to `p` over the child's bounding sphere
/// (PBRT's `LightBounds::Importance` without the receiver's normal term). Zero only where no light
/// below can emit towards `p`.
///
/// Branch-free (every `if` is a select) so that the loop over a node's lanes in
/// [`importances`] compiles to 8-wide code; the tests hold it to the branchy textbook form
/// bit for bit.
#[inline(always)]
pub(super) fn importance(n: &Node, k: usize, p: [f32; 3]) -> f32 {
    let v = [p[0] - n.center[0][k], p[1] - n.center[1][k], p[2] - n.center[2][k]];
    let dist2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    let radius2 = n.radius2[k];
    // Inside the bounding sphere the distance says nothing: clamp it to the radius.
    let d2 = dist2.max(radius2);
    // cos θ_w = axis · v / |v|: one division rather than normalising `v` (three).
    let dot = n.axis[0][k] * v[0] + n.axis[1][k] * v[1] + n.axis[2][k] * v[2];
    let cos_w = dot / dist2.sqrt();
    let cos_w = if dist2 > 0.0 { cos_w } else { 0.0 };
    let cos_w = if n.flags[k] & TWO_SIDED != 0 { cos_w.abs() } else { cos_w };
    let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
    // The angle the bounding sphere subtends from `p` (everything from inside).
    let inside = dist2 <= radius2;
    let sin2 = radius2 / dist2;
    let cos_b = if inside { -1.0 } else { (1.0 - sin2).max(0.0).sqrt() };
    let sin_b = if inside { 0.0 } else { sin2.sqrt() };
    // cos(max(0, θ_w − θ_o)), then cos(max(0, θ_x − θ_b)).
    let (cos_o, sin_o) = (n.cos_o[k], n.sin_o[k]);
    let within = cos_w > cos_o;
    let cos_x = if within { 1.0 } else { cos_w * cos_o + sin_w * sin_o };
    let sin_x = if within { 0.0 } else { sin_w * cos_o - cos_w * sin_o };
    let cos_p = if cos_x > cos_b { 1.0 } else { cos_x * cos_b + sin_x * sin_b };
    // φ / d² first: that division does not wait for the angles.
    let value = n.phi[k] / d2 * cos_p;
    if cos_p <= n.cos_e[k] {
        0.0
    } else {
        value
    }
}

/// The importance of each of the node's lanes at `p` (0 for empty lanes): one 8-lane pass, the
/// short one of [`omni_importances`] where it gives the same bits.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
pub(super) fn importances(n: &Node, p: [f32; 3]) -> [f32; WIDTH] {
    if n.omni != 0 {
        if let Some(w) = omni_importances(n, p) {
            return w;
        }
    }
    let mut out = [0.0; WIDTH];
    for k in 0..WIDTH {
        out[k] = importance(n, k, p);
    }
    out
}

/// [`importance`] of every lane of a node whose children all emit in every direction (cos θ_o =
/// −1, sin θ_o = 0, cos θ_e < 1: sphere and point lights, the emissive triangles' entry, and
/// nodes over them only), where it is φ / max(d², r²): `None` where a squared distance is not
/// finite (there [`importance`] may give NaN where this would not).
///
/// For such a cone every direction is within θ_o of the axis, so the angle terms give cos θ' = 1
/// exactly: `cos θ_w > −1` gives (cos θ_x, sin θ_x) = (1, 0), otherwise cos θ_w ≤ −1 gives
/// (−cos θ_w ≥ 1, 0) because sin θ_w = 0; either way cos θ_x ≥ cos θ_b, and where they are both 1
/// the product form is 1·1 + 0·sin θ_b = 1. `φ / d² · 1` is `φ / d²`, and 1 > cos θ_e. So the two
/// square roots and two divisions of the angles are skipped: one division for eight lanes. Empty
/// lanes (φ = 0, r² = 1) give 0 as in [`importance`].
#[allow(clippy::needless_range_loop)]
#[inline(always)]
pub(super) fn omni_importances(n: &Node, p: [f32; 3]) -> Option<[f32; WIDTH]> {
    let (mut w, mut finite) = ([0.0; WIDTH], [false; WIDTH]);
    for k in 0..WIDTH {
        let v = [p[0] - n.center[0][k], p[1] - n.center[1][k], p[2] - n.center[2][k]];
        let dist2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        finite[k] = dist2 < f32::INFINITY;
        w[k] = n.phi[k] / dist2.max(n.radius2[k]);
    }
    finite.iter().all(|&f| f).then_some(w)
}

/// A node's children's weights at a point and their running sums: child `k`'s probability is
/// `w[k] / cdf[WIDTH - 1]`, and its slice of `[0, sum)` is `cdf[k - 1]..cdf[k]`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Weights {
    pub w: [f32; WIDTH],
    /// Pairwise prefix sums of `w` ([`prefix_sums`]); the last is the sum.
    pub cdf: [f32; WIDTH],
}

impl Weights {
    /// The sum of the weights (`cdf`'s last entry).
    #[inline(always)]
    pub fn sum(&self) -> f32 {
        self.cdf[WIDTH - 1]
    }
}

/// The children's weights at `p` and their prefix sums: child `k`'s probability is `w[k] / sum`,
/// its share of the node's importance, or 1 / `len` each (weights 1, sum `len`) when no child may
/// contribute or a sum is not finite (`p` on a point light), so the probabilities over all lights
/// always sum to 1. Empty lanes weigh 0.
#[inline(always)]
pub(super) fn child_weights(n: &Node, p: [f32; 3]) -> Weights {
    let w = importances(n, p);
    let cdf = prefix_sums(&w);
    // `0 < sum < ∞` rather than `sum > 0 && sum.is_finite()`: the same test (NaN fails both
    // compares), two compares where `is_finite` took a dozen integer instructions.
    if cdf[WIDTH - 1] > 0.0 && cdf[WIDTH - 1] < f32::INFINITY {
        Weights { w, cdf }
    } else {
        let w = std::array::from_fn(|k| if (k as u32) < n.len { 1.0 } else { 0.0 });
        Weights { cdf: prefix_sums(&w), w }
    }
}

/// The running sums of `w` in a fixed pairwise order: `w0`, `w0+w1`, `(w0+w1)+w2`,
/// `(w0+w1)+(w2+w3)`, then that plus `w4`, `w4+w5`, `(w4+w5)+w6`, `(w4+w5)+(w6+w7)`. Three
/// dependent steps, not seven, in shapes LLVM turns into shuffles and 8-wide adds; the last is
/// the node's sum, bit for bit the same in sampling and in `pmf` (which share this function). For
/// weights that are not negative the sums never decrease, and a lane of weight 0 repeats the sum
/// before it exactly.
#[inline(always)]
pub(super) fn prefix_sums(w: &[f32; WIDTH]) -> [f32; WIDTH] {
    let pairs: [f32; WIDTH] = std::array::from_fn(|k| if k % 2 == 1 { w[k - 1] + w[k] } else { w[k] });
    let quads: [f32; WIDTH] =
        std::array::from_fn(|k| if k % 4 >= 2 { pairs[k / 4 * 4 + 1] + pairs[k] } else { pairs[k] });
    std::array::from_fn(|k| if k >= 4 { quads[3] + quads[k] } else { quads[k] })
}

/// The categorical choice among the first `len` lanes of `weights` at `target` in [0, sum): the
/// first lane whose cumulative weight exceeds `target`, and the cumulative weight below it. Never
/// a lane of weight 0: a `target` at or past the rounded total takes the last lane that has
/// weight.
///
/// Weights, not probabilities: [`descend`](super::descend) compares `u · sum` with them, so the
/// next node's importance does not wait for eight divisions (its one division, the chosen
/// child's probability, is off that chain). Branch-free: the choice is a coin flip per node, and a
/// scan that breaks at the child mispredicts about once a node. Two 8-lane compares become bit
/// masks: the sums at or below `target` are a run of ones from lane 0 (the sums never decrease,
/// and a lane of weight 0 repeats the sum before it, so the first sum above `target` belongs to a
/// lane with weight) whose length is the chosen lane; the highest bit of the lanes with weight is
/// the fallback. That needs weights that are not negative: every emitter here has θ_e = π/2, so
/// cos θ_e = 0 and an importance is 0 or positive. (The count of the sums at or below `target`,
/// the former form, is the same number then.)
#[inline(always)]
pub(super) fn choose(weights: &Weights, len: u32, target: f32) -> (usize, f32) {
    let (mut at_or_below, mut positive) = (0u32, 0u32);
    for k in 0..WIDTH {
        at_or_below |= ((weights.cdf[k] <= target) as u32) << k;
        positive |= ((weights.w[k] > 0.0) as u32) << k;
    }
    let run = (!at_or_below).trailing_zeros();
    let last_with_probability = 31 - (positive | 1).leading_zeros();
    let chosen = if run < len { run } else { last_with_probability } as usize;
    (chosen, if chosen == 0 { 0.0 } else { weights.cdf[chosen.wrapping_sub(1) % WIDTH] })
}

/// One node's step at `p` with `u`, as [`super::descend`] makes it: the chosen child, its weight,
/// the running sum below it, the node's sum and `u · sum`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Step {
    pub chosen: usize,
    pub weight: f32,
    pub below: f32,
    pub sum: f32,
    pub target: f32,
}

/// One node's step at `p` with `u`: [`child_weights`], then [`choose`] at `target = u · sum`
/// (the baseline clone's step in `lanes.rs`, and the reference of `avx::step`).
#[inline(always)]
pub(super) fn step(n: &Node, p: [f32; 3], u: f32) -> Step {
    let weights = child_weights(n, p);
    let (sum, target) = (weights.sum(), u * weights.sum());
    let (chosen, below) = choose(&weights, n.len, target);
    Step { chosen, weight: weights.w[chosen], below, sum, target }
}

//! The wide tree's node: up to [`WIDTH`] children whose bounds are stored column by column, so
//! the importance of all of a node's children is one 8-lane pass ([`child_weights`]).

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
/// Lanes from `len` on are empty: φ = 0 and cos θ_e = +∞, so their importance is 0 at every point
/// that is not NaN.
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
    _pad: [u32; 15],
}

const _: () = assert!(std::mem::size_of::<Node>() == 512);

impl Node {
    /// A node without children.
    pub const EMPTY: Node = Node {
        center: [[0.0; WIDTH]; 3],
        radius2: [0.0; WIDTH],
        axis: [[0.0; WIDTH]; 3],
        cos_o: [1.0; WIDTH],
        sin_o: [0.0; WIDTH],
        cos_e: [f32::INFINITY; WIDTH],
        phi: [0.0; WIDTH],
        flags: [0; WIDTH],
        child: [0; WIDTH],
        len: 0,
        _pad: [0; 15],
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

/// The importance of each of the node's lanes at `p` (0 for empty lanes): one 8-lane pass.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
pub(super) fn importances(n: &Node, p: [f32; 3]) -> [f32; WIDTH] {
    let mut out = [0.0; WIDTH];
    for k in 0..WIDTH {
        out[k] = importance(n, k, p);
    }
    out
}

/// The children's weights at `p` and their sum: child `k`'s probability is `w[k] / sum`, its share
/// of the node's importance, or 1 / `len` each (weights 1, sum `len`) when no child may contribute
/// or a sum is not finite (`p` on a point light), so the probabilities over all lights always sum
/// to 1. Empty lanes weigh 0.
#[inline(always)]
pub(super) fn child_weights(n: &Node, p: [f32; 3]) -> ([f32; WIDTH], f32) {
    let w = importances(n, p);
    // A fixed pairwise order: the same sum (and so the same bits) in sampling and in `pmf`; it is
    // also the last of `choose`'s prefix sums.
    let sum = ((w[0] + w[1]) + (w[2] + w[3])) + ((w[4] + w[5]) + (w[6] + w[7]));
    if sum > 0.0 && sum.is_finite() {
        (w, sum)
    } else {
        (std::array::from_fn(|k| if (k as u32) < n.len { 1.0 } else { 0.0 }), n.len as f32)
    }
}

/// The categorical choice among the first `len` lanes of weights `w` at `target` in [0, sum of
/// `w`): the first lane whose cumulative weight exceeds `target`, and the cumulative weight below
/// it. Never a lane of weight 0: a `target` at or past the rounded total takes the last lane that
/// has weight.
///
/// Weights, not probabilities: [`descend`](super::descend) compares `u · sum` with them, so the
/// next node's importance does not wait for eight divisions (its one division, the chosen
/// child's probability, is off that chain). Branch-free (a count of the prefix sums at or below
/// `target`, then selects): the choice is a coin flip per node, and a scan that breaks at the
/// child mispredicts about once a node. The prefix sums add pairwise (three dependent additions,
/// not seven); they never decrease, and a lane of weight 0 repeats the sum before it exactly, so
/// the first sum above `target` always belongs to a lane with weight.
#[inline(always)]
pub(super) fn choose(w: &[f32; WIDTH], len: u32, target: f32) -> (usize, f32) {
    let (s01, s23, s45, s67) = (w[0] + w[1], w[2] + w[3], w[4] + w[5], w[6] + w[7]);
    let s0123 = s01 + s23;
    let cdf =
        [w[0], s01, s01 + w[2], s0123, s0123 + w[4], s0123 + s45, s0123 + (s45 + w[6]), s0123 + (s45 + s67)];
    let at_or_below = cdf.iter().map(|&c| (c <= target) as u32).sum::<u32>();
    let last_with_probability =
        (0..WIDTH as u32).fold(0, |last, k| if w[k as usize] > 0.0 { k } else { last });
    let chosen = if at_or_below < len { at_or_below } else { last_with_probability } as usize;
    (chosen, if chosen == 0 { 0.0 } else { cdf[chosen - 1] })
}

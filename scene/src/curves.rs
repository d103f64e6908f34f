//! Curve math at ingest time: every USD basis becomes exact cubic Bézier segments, NURBS are fitted,
//! and segments are split adaptively for the camera that will look at them.
//!
//! Control values are `Vec4`s so that position and radius (or any attribute packed into a `Vec4`) go
//! through the same basis change. The basis-change matrices are exact:
//!
//! ```text
//! bspline → Bézier      B0 = (P0 + 4P1 + P2)/6   B1 = (2P1 + P2)/3   B2 = (P1 + 2P2)/3   B3 = (P1 + 4P2 + P3)/6
//! catmullRom → Bézier   B0 = P1   B1 = P1 + (P2 − P0)/6   B2 = P2 − (P3 − P1)/6   B3 = P2
//! linear → Bézier       B0 = A   B1 = (2A + B)/3   B2 = (A + 2B)/3   B3 = B
//! ```
//! Segment indexing follows UsdGeomBasisCurves (vstep 3 for bezier, 1 for bspline/catmullRom;
//! periodic curves wrap their indices); `pinned` pads the ends as Hydra's
//! `HdsiPinnedCurveExpandingSceneIndex` does: bspline end points appear three times, catmullRom end
//! points twice, so the curve starts and ends on its first and last control points.

use glam::Vec4;

/// `BasisCurves.type`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveType {
    /// Straight segments between consecutive points.
    Linear,
    /// Cubic segments with a [`Basis`].
    Cubic,
}

/// `BasisCurves.basis` (cubic curves).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Basis {
    /// Bézier, vstep 3.
    Bezier,
    /// Uniform cubic B-spline, vstep 1.
    Bspline,
    /// Catmull-Rom, vstep 1.
    CatmullRom,
}

/// `BasisCurves.wrap`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Open.
    Nonperiodic,
    /// Closed: indices wrap around.
    Periodic,
    /// Open, ends pinned to the first and last control points.
    Pinned,
}

/// Number of segments USD assigns to a curve of `n` vertices (`UsdGeomBasisCurves::ComputeSegmentCounts`
/// for valid curves), or `None` when `n` is too small to make one.
pub fn usd_segment_count(n: usize, ty: CurveType, basis: Basis, wrap: Wrap) -> Option<usize> {
    let count = match (ty, wrap) {
        (CurveType::Linear, Wrap::Periodic) => n,
        (CurveType::Linear, _) => n.checked_sub(1)?,
        (CurveType::Cubic, Wrap::Periodic) => n / vstep(basis),
        (CurveType::Cubic, Wrap::Pinned) if basis != Basis::Bezier => n.checked_sub(1)?,
        (CurveType::Cubic, _) => n.checked_sub(4)? / vstep(basis) + 1,
    };
    let minimum = match (ty, wrap) {
        (CurveType::Linear, _) => 2,
        (_, Wrap::Pinned) if basis != Basis::Bezier => 2,
        (_, Wrap::Periodic) => 3,
        _ => 4,
    };
    (count > 0 && n >= minimum).then_some(count)
}

fn vstep(basis: Basis) -> usize {
    if basis == Basis::Bezier {
        3
    } else {
        1
    }
}

/// Converts one curve's control values to cubic Bézier segments (empty if too few values).
pub fn to_bezier(values: &[Vec4], ty: CurveType, basis: Basis, wrap: Wrap) -> Vec<[Vec4; 4]> {
    let n = values.len();
    if ty == CurveType::Linear {
        let count = if wrap == Wrap::Periodic && n > 2 { n } else { n.saturating_sub(1) };
        return (0..count).map(|i| line(values[i], values[(i + 1) % n])).collect();
    }
    if usd_segment_count(n, ty, basis, wrap).is_none() {
        return Vec::new();
    }
    let padded: Vec<Vec4>;
    let (points, wrap) = match (wrap, basis) {
        (Wrap::Pinned, Basis::Bspline) => {
            padded = [values[0], values[0]]
                .into_iter()
                .chain(values.iter().copied())
                .chain([values[n - 1], values[n - 1]])
                .collect();
            (&padded[..], Wrap::Nonperiodic)
        }
        (Wrap::Pinned, Basis::CatmullRom) => {
            padded = std::iter::once(values[0])
                .chain(values.iter().copied())
                .chain(std::iter::once(values[n - 1]))
                .collect();
            (&padded[..], Wrap::Nonperiodic)
        }
        _ => (values, wrap),
    };
    let n = points.len();
    let step = vstep(basis);
    let count = if wrap == Wrap::Periodic { n / step } else { (n - 4) / step + 1 };
    (0..count)
        .map(|k| {
            let q = [0, 1, 2, 3].map(|i| points[(k * step + i) % n]);
            convert(q, basis)
        })
        .collect()
}

/// The Bézier control points of the cubic that `basis` defines on four control values.
pub fn convert(p: [Vec4; 4], basis: Basis) -> [Vec4; 4] {
    match basis {
        Basis::Bezier => p,
        Basis::Bspline => [
            (p[0] + 4.0 * p[1] + p[2]) / 6.0,
            (2.0 * p[1] + p[2]) / 3.0,
            (p[1] + 2.0 * p[2]) / 3.0,
            (p[1] + 4.0 * p[2] + p[3]) / 6.0,
        ],
        Basis::CatmullRom => [p[1], p[1] + (p[2] - p[0]) / 6.0, p[2] - (p[3] - p[1]) / 6.0, p[2]],
    }
}

/// A straight segment as a cubic Bézier.
pub fn line(a: Vec4, b: Vec4) -> [Vec4; 4] {
    [a, (2.0 * a + b) / 3.0, (a + 2.0 * b) / 3.0, b]
}

/// Evaluates a cubic Bézier at `t`.
pub fn eval(p: &[Vec4; 4], t: f32) -> Vec4 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

/// Splits a cubic Bézier at `t` (de Casteljau).
pub fn split(p: &[Vec4; 4], t: f32) -> ([Vec4; 4], [Vec4; 4]) {
    let ab = p[0].lerp(p[1], t);
    let bc = p[1].lerp(p[2], t);
    let cd = p[2].lerp(p[3], t);
    let abc = ab.lerp(bc, t);
    let bcd = bc.lerp(cd, t);
    let m = abc.lerp(bcd, t);
    ([p[0], ab, abc, m], [m, bcd, cd, p[3]])
}

/// Upper bound on the distance between the curve's centreline and its chord: ¾ of the largest second
/// difference of the control polygon (the classic bound for the linear interpolant of a cubic).
pub fn flatness(p: &[Vec4; 4]) -> f32 {
    let d = |a: Vec4, b: Vec4, c: Vec4| (a - 2.0 * b + c).truncate().length();
    0.75 * d(p[0], p[1], p[2]).max(d(p[1], p[2], p[3]))
}

/// How finely a segment must be split: the largest chord deviation ([`flatness`]) acceptable for
/// a piece, which may depend on where the piece is and how wide it is (`f32::INFINITY`: no split).
pub trait Tolerance {
    /// Largest acceptable chord deviation of the piece `p` (world units).
    fn of(&self, p: &[Vec4; 4]) -> f32;
}

/// Splits `p` in halves (de Casteljau) until each piece's chord deviation ([`flatness`]) is within
/// `tolerance` of that piece, at most `2^max_depth` pieces; returns the pieces with their parameter
/// ranges in the input's [0, 1], in curve order.
pub fn split_adaptive(
    p: &[Vec4; 4],
    tolerance: &dyn Tolerance,
    max_depth: u32,
) -> Vec<([Vec4; 4], [f32; 2])> {
    let mut out = Vec::new();
    let mut stack = vec![(*p, [0.0f32, 1.0f32], 0u32)];
    while let Some((q, range, depth)) = stack.pop() {
        if depth >= max_depth || flatness(&q) <= tolerance.of(&q) {
            out.push((q, range));
            continue;
        }
        let (a, b) = split(&q, 0.5);
        let m = 0.5 * (range[0] + range[1]);
        // Right half first so the left half pops first and the output stays in curve order.
        stack.push((b, [m, range[1]], depth + 1));
        stack.push((a, [range[0], m], depth + 1));
    }
    out
}

/// Splits `p` into `pieces` equal parameter ranges.
pub fn split_uniform(p: &[Vec4; 4], pieces: u32) -> Vec<([Vec4; 4], [f32; 2])> {
    let mut out = Vec::with_capacity(pieces as usize);
    let mut rest = *p;
    for i in 0..pieces {
        let (t0, t1) = (i as f32 / pieces as f32, (i + 1) as f32 / pieces as f32);
        if i + 1 == pieces {
            out.push((rest, [t0, t1]));
        } else {
            // Split the remainder [t0, 1] at the local parameter of t1.
            let (a, b) = split(&rest, (t1 - t0) / (1.0 - t0));
            out.push((a, [t0, t1]));
            rest = b;
        }
    }
    out
}

/// A NURBS curve (one entry of a NurbsCurves prim) in homogeneous-free form: control values with
/// their weights.
pub struct Nurbs<'a> {
    /// `order` = degree + 1.
    pub order: usize,
    /// `n + order` non-decreasing knots.
    pub knots: &'a [f64],
    /// Control values (position and radius).
    pub values: &'a [Vec4],
    /// Weights (empty = all 1).
    pub weights: &'a [f64],
}

impl Nurbs<'_> {
    /// The curve at parameter `u` (rational de Boor).
    pub fn eval(&self, u: f64) -> Vec4 {
        let p = self.order - 1;
        let n = self.values.len();
        // Span k with knots[k] <= u < knots[k + 1], clamped to the valid range [p, n − 1].
        let mut k = p;
        while k + 1 < n && self.knots[k + 1] <= u {
            k += 1;
        }
        let w = |i: usize| self.weights.get(i).copied().unwrap_or(1.0);
        let mut d: Vec<(glam::DVec4, f64)> = (0..=p)
            .map(|j| {
                let i = j + k - p;
                (self.values[i].as_dvec4() * w(i), w(i))
            })
            .collect();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let i = j + k - p;
                let denom = self.knots[i + p + 1 - r] - self.knots[i];
                let a = if denom > 0.0 { (u - self.knots[i]) / denom } else { 0.0 };
                d[j] = (d[j - 1].0 * (1.0 - a) + d[j].0 * a, d[j - 1].1 * (1.0 - a) + d[j].1 * a);
            }
        }
        let (v, w) = d[p];
        (v / w).as_vec4()
    }

    /// Cubic Bézier segments approximating the curve on its valid range `[knots[order−1], knots[n]]`
    /// (or `range` when given): each non-empty knot span gets the cubic interpolating the curve at 0, ⅓,
    /// ⅔ and 1 of the span — exact for non-rational curves of order ≤ 4 — halved until the deviation
    /// measured at 16 points per piece is below `tolerance`. Returns the segments and the largest
    /// measured deviation.
    pub fn to_bezier(&self, range: Option<[f64; 2]>, tolerance: f32) -> (Vec<[Vec4; 4]>, f32) {
        let p = self.order - 1;
        let n = self.values.len();
        let [lo, hi] = range.unwrap_or([self.knots[p], self.knots[n]]);
        let mut breaks: Vec<f64> = self.knots[p..=n].iter().copied().filter(|&k| k > lo && k < hi).collect();
        breaks.insert(0, lo);
        breaks.push(hi);
        breaks.dedup();
        let mut out = Vec::new();
        let mut max_error = 0.0f32;
        let mut stack: Vec<(f64, f64, u32)> = breaks.windows(2).rev().map(|w| (w[0], w[1], 0)).collect();
        while let Some((a, b, depth)) = stack.pop() {
            let q = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0].map(|s| self.eval(a + (b - a) * s));
            let a1 = 27.0 * q[1] - 8.0 * q[0] - q[3];
            let c1 = 27.0 * q[2] - q[0] - 8.0 * q[3];
            let bez = [q[0], (2.0 * a1 - c1) / 18.0, (2.0 * c1 - a1) / 18.0, q[3]];
            let error = (1..16)
                .map(|i| {
                    let s = i as f32 / 16.0;
                    (eval(&bez, s) - self.eval(a + (b - a) * s as f64)).truncate().length()
                })
                .fold(0.0f32, f32::max);
            if error > tolerance && depth < 8 {
                let m = 0.5 * (a + b);
                stack.push((m, b, depth + 1));
                stack.push((a, m, depth + 1));
                continue;
            }
            max_error = max_error.max(error);
            out.push(bez);
        }
        (out, max_error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32) -> Vec4 {
        Vec4::new(x, y, z, 0.1)
    }

    fn close(a: Vec4, b: Vec4) -> bool {
        (a - b).length() < 1e-5
    }

    #[test]
    fn bases_agree_on_the_same_cubic() {
        // A Bézier cubic, and the bspline and catmullRom control points that define the same cubic
        // (inverse basis changes), must convert to the same Bézier control points.
        let bez = [v(0., 0., 0.), v(1., 2., 0.), v(3., 2., 1.), v(4., 0., 0.)];
        // Inverse of the B-spline → Bézier matrix.
        let [b0, b1, b2, b3] = bez;
        let bs =
            [6.0 * b0 - 7.0 * b1 + 2.0 * b2, 2.0 * b1 - b2, -b1 + 2.0 * b2, 2.0 * b1 - 7.0 * b2 + 6.0 * b3];
        let cr = [b3 + 6.0 * (b0 - b1), b0, b3, b0 + 6.0 * (b3 - b2)];
        for (basis, control) in [(Basis::Bspline, bs), (Basis::CatmullRom, cr)] {
            let out = to_bezier(&control, CurveType::Cubic, basis, Wrap::Nonperiodic);
            assert_eq!(out.len(), 1);
            for (a, b) in out[0].iter().zip(&bez) {
                assert!(close(*a, *b), "{basis:?}: {a} vs {b}");
            }
        }
        assert_eq!(to_bezier(&bez, CurveType::Cubic, Basis::Bezier, Wrap::Nonperiodic), vec![bez]);
    }

    #[test]
    fn segment_counts_follow_usd() {
        use Basis::*;
        use CurveType::*;
        use Wrap::*;
        // (n, type, basis, wrap, usd-core ComputeSegmentCounts)
        let cases = [
            (4, Linear, Bezier, Nonperiodic, 3),
            (4, Linear, Bezier, Periodic, 4),
            (7, Cubic, Bezier, Nonperiodic, 2),
            (10, Cubic, Bezier, Nonperiodic, 3),
            (6, Cubic, Bezier, Periodic, 2),
            (7, Cubic, Bspline, Nonperiodic, 4),
            (7, Cubic, Bspline, Periodic, 7),
            (7, Cubic, CatmullRom, Periodic, 7),
            (7, Cubic, Bspline, Pinned, 6),
            (7, Cubic, CatmullRom, Pinned, 6),
            (10, Cubic, CatmullRom, Nonperiodic, 7),
        ];
        for (n, ty, basis, wrap, expected) in cases {
            assert_eq!(
                usd_segment_count(n, ty, basis, wrap),
                Some(expected),
                "{n} {ty:?} {basis:?} {wrap:?}"
            );
            let values: Vec<Vec4> = (0..n).map(|i| v(i as f32, (i * i) as f32, 0.0)).collect();
            let bez = to_bezier(&values, ty, basis, wrap);
            // Pinned bspline gains two short end segments from the tripled end points (Hydra).
            let extra = if wrap == Pinned && basis == Bspline { 2 } else { 0 };
            assert_eq!(bez.len(), expected + extra, "{n} {ty:?} {basis:?} {wrap:?}");
        }
    }

    #[test]
    fn periodic_curves_close_and_pinned_curves_hit_their_ends() {
        let ring: Vec<Vec4> = (0..8)
            .map(|i| (i as f32 * std::f32::consts::TAU / 8.0).sin_cos())
            .map(|(s, c)| v(c, s, 0.0))
            .collect();
        for basis in [Basis::Bspline, Basis::CatmullRom] {
            let segs = to_bezier(&ring, CurveType::Cubic, basis, Wrap::Periodic);
            assert!(close(segs[0][0], segs[segs.len() - 1][3]), "{basis:?} closes");
            for w in segs.windows(2) {
                assert!(close(w[0][3], w[1][0]), "{basis:?} continuous");
            }
        }
        let bez: Vec<Vec4> = (0..6).map(|i| ring[i]).collect();
        let segs = to_bezier(&bez, CurveType::Cubic, Basis::Bezier, Wrap::Periodic);
        assert_eq!(segs.len(), 2);
        assert!(close(segs[1][3], segs[0][0]));
        let lin = to_bezier(&ring[..4], CurveType::Linear, Basis::Bezier, Wrap::Periodic);
        assert!(close(lin[3][3], lin[0][0]));
        for basis in [Basis::Bspline, Basis::CatmullRom] {
            let segs = to_bezier(&ring[..5], CurveType::Cubic, basis, Wrap::Pinned);
            assert!(
                close(segs[0][0], ring[0]) && close(segs[segs.len() - 1][3], ring[4]),
                "{basis:?} pinned"
            );
        }
    }

    #[test]
    fn splitting_preserves_the_curve() {
        let p = [v(0., 0., 0.), v(1., 3., 0.), v(2., -3., 1.), v(3., 0., 0.)];
        struct Fixed(f32);
        impl Tolerance for Fixed {
            fn of(&self, _: &[Vec4; 4]) -> f32 {
                self.0
            }
        }
        let pieces = split_adaptive(&p, &Fixed(0.01), 10);
        assert!(pieces.len() > 4);
        for (q, [u0, u1]) in &pieces {
            assert!(flatness(q) <= 0.01);
            for s in [0.0, 0.3, 1.0] {
                let u = u0 + (u1 - u0) * s;
                assert!(close(eval(q, s), eval(&p, u)));
            }
        }
        let uniform = split_uniform(&p, 5);
        assert_eq!(uniform.len(), 5);
        assert!(close(eval(&uniform[3].0, 0.5), eval(&p, 0.7)));
    }

    #[test]
    fn nurbs_cubic_is_exact_and_circle_is_approximated() {
        // Non-rational uniform cubic B-spline as NURBS equals the bspline basis conversion.
        let values: Vec<Vec4> = (0..6).map(|i| v(i as f32, (i % 2) as f32, 0.0)).collect();
        let knots: Vec<f64> = (0..10).map(|k| k as f64).collect();
        let nurbs = Nurbs { order: 4, knots: &knots, values: &values, weights: &[] };
        let (segs, err) = nurbs.to_bezier(None, 1e-4);
        let expected = to_bezier(&values, CurveType::Cubic, Basis::Bspline, Wrap::Nonperiodic);
        assert_eq!(segs.len(), expected.len());
        assert!(err < 1e-5, "{err}");
        for (a, b) in segs.iter().zip(&expected) {
            for (x, y) in a.iter().zip(b) {
                assert!((*x - *y).length() < 1e-4, "{x} {y}");
            }
        }
        // Rational quadratic quarter circle: approximated within the tolerance.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let quarter = [v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)];
        let nurbs =
            Nurbs { order: 3, knots: &[0., 0., 0., 1., 1., 1.], values: &quarter, weights: &[1.0, s, 1.0] };
        let (segs, err) = nurbs.to_bezier(None, 1e-4);
        assert!(err <= 1e-4 && !segs.is_empty());
        for seg in &segs {
            let r = eval(seg, 0.5).truncate().length();
            assert!((r - 1.0).abs() < 2e-4, "{r}");
        }
    }
}

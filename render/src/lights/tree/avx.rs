//! One node step of a descent — the children's importances, their running sums and the child
//! `u · sum` falls in — in AVX2 intrinsics, for [`super::lanes`]' interleaved descents. The same
//! IEEE operations in the same order as the portable [`node::importances`], [`node::prefix_sums`]
//! and [`node::choose`] (no FMA), so the results are the same bits (the tests hold them to it).
//!
//! Written with `std::arch` rather than left to LLVM: compiled from the portable lane loops, the
//! running sums came out as scalar additions and inserts, each bit mask of the choice as eight
//! scalar compares and shifts, the short path of [`node::omni_importances`] scalar, and the
//! weights went through memory between the two (about 255 instructions a node step); here the
//! eight weights stay in one register from the importance to the choice, the running sums are
//! three shuffle-and-add steps, and each mask is one `vmovmskps`.
//!
//! The sum is not the running sums' last lane broadcast (four dependent shuffles and adds, then a
//! `vpermps`) but its own three swap-and-add steps ([`total`]: every lane ends with the same two
//! addends, in one order or the other, so with the same bits); the target `u · sum` is formed
//! 8-wide from it, and the running sum below the chosen lane is read from the sums moved up one
//! lane, 0 in lane 0, where a branch on `chosen == 0` mispredicted. [`root_lanes`] is the root's
//! step for eight points at once (see `lanes.rs`).

#[cfg(doc)]
use super::node;
use super::node::{Node, Step, LEAF, TWO_SIDED, WIDTH};
use super::ONE_MINUS_EPSILON;
use std::arch::x86_64::*;

#[inline]
#[target_feature(enable = "avx")]
fn load(column: &[f32; WIDTH]) -> __m256 {
    // SAFETY: `column` is eight readable `f32`s; the load is unaligned.
    unsafe { _mm256_loadu_ps(column.as_ptr()) }
}

#[inline]
#[target_feature(enable = "avx")]
fn load_u32(column: &[u32; WIDTH]) -> __m256i {
    // SAFETY: `column` is eight readable `u32`s; the load is unaligned.
    unsafe { _mm256_loadu_si256(column.as_ptr().cast()) }
}

/// Lane `k` (0..8) of `v`.
#[inline]
#[target_feature(enable = "avx,avx2")]
fn lane(v: __m256, k: usize) -> f32 {
    _mm256_cvtss_f32(_mm256_permutevar8x32_ps(v, _mm256_set1_epi32(k as i32)))
}

/// [`node::importances`]: φ / d² alone for a node of omnidirectional children where every squared
/// distance is finite ([`node::omni_importances`]), else [`node::importance`]'s formula.
#[inline]
#[target_feature(enable = "avx,avx2")]
pub(super) fn importances(n: &Node, p: [f32; 3]) -> __m256 {
    let v: [__m256; 3] = std::array::from_fn(|c| _mm256_sub_ps(_mm256_set1_ps(p[c]), load(&n.center[c])));
    let dist2 = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(v[0], v[0]), _mm256_mul_ps(v[1], v[1])),
        _mm256_mul_ps(v[2], v[2]),
    );
    let radius2 = load(&n.radius2);
    // `dist2.max(radius2)`: `vmaxps` returns its second operand, the radius, when `dist2` is NaN.
    let d2 = _mm256_max_ps(dist2, radius2);
    let phi_d2 = _mm256_div_ps(load(&n.phi), d2);
    let finite = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(dist2, _mm256_set1_ps(f32::INFINITY)));
    if n.omni != 0 && finite == 0xff {
        return phi_d2;
    }
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let axis: [__m256; 3] = std::array::from_fn(|c| load(&n.axis[c]));
    let dot = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(axis[0], v[0]), _mm256_mul_ps(axis[1], v[1])),
        _mm256_mul_ps(axis[2], v[2]),
    );
    let cos_w = _mm256_div_ps(dot, _mm256_sqrt_ps(dist2));
    let cos_w = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(dist2, zero), cos_w);
    let two_sided = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
        _mm256_and_si256(load_u32(&n.flags), _mm256_set1_epi32(TWO_SIDED as i32)),
        _mm256_set1_epi32(TWO_SIDED as i32),
    ));
    let abs = _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX));
    let cos_w = _mm256_blendv_ps(cos_w, _mm256_and_ps(cos_w, abs), two_sided);
    // `(1 − x).max(0)`: `vmaxps` returns 0, its second operand, for NaN as `f32::max` does.
    let sin_w = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, _mm256_mul_ps(cos_w, cos_w)), zero));
    let inside = _mm256_cmp_ps::<_CMP_LE_OQ>(dist2, radius2);
    let sin2 = _mm256_div_ps(radius2, dist2);
    let cos_b = _mm256_blendv_ps(
        _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, sin2), zero)),
        _mm256_set1_ps(-1.0),
        inside,
    );
    let sin_b = _mm256_andnot_ps(inside, _mm256_sqrt_ps(sin2));
    let (cos_o, sin_o) = (load(&n.cos_o), load(&n.sin_o));
    let within = _mm256_cmp_ps::<_CMP_GT_OQ>(cos_w, cos_o);
    let cos_x = _mm256_blendv_ps(
        _mm256_add_ps(_mm256_mul_ps(cos_w, cos_o), _mm256_mul_ps(sin_w, sin_o)),
        one,
        within,
    );
    let sin_x =
        _mm256_andnot_ps(within, _mm256_sub_ps(_mm256_mul_ps(sin_w, cos_o), _mm256_mul_ps(cos_w, sin_o)));
    let cos_p = _mm256_blendv_ps(
        _mm256_add_ps(_mm256_mul_ps(cos_x, cos_b), _mm256_mul_ps(sin_x, sin_b)),
        one,
        _mm256_cmp_ps::<_CMP_GT_OQ>(cos_x, cos_b),
    );
    let value = _mm256_mul_ps(phi_d2, cos_p);
    // 0 where `cos_p <= cos_e`; NaN stays.
    _mm256_and_ps(_mm256_cmp_ps::<_CMP_NLE_UQ>(cos_p, load(&n.cos_e)), value)
}

/// `lanes::first_choice`: the slot as a clamp before the truncation (exact: the clamp's ends are
/// integers, and `vmaxps` returns 0, its second operand, for NaN, as the saturating cast does),
/// and `u` stretched with `vmaxps`/`vminps` in the order that returns NaN as `f32::clamp` does.
#[inline]
#[target_feature(enable = "avx,avx2")]
pub(super) fn first_choice(
    u_select: &[f32; WIDTH],
    slots: u32,
    infinite: usize,
    slot: &mut [i32; WIDTH],
    u: &mut [f32; WIDTH],
) {
    let zero = _mm256_setzero_ps();
    let scaled = _mm256_mul_ps(load(u_select), _mm256_set1_ps(slots as f32));
    let clamped = _mm256_min_ps(_mm256_max_ps(scaled, zero), _mm256_set1_ps((slots - 1) as f32));
    // SAFETY: `slot` is eight writable `i32`s; the store is unaligned.
    unsafe { _mm256_storeu_si256(slot.as_mut_ptr().cast(), _mm256_cvttps_epi32(clamped)) };
    let stretched = _mm256_sub_ps(scaled, _mm256_set1_ps(infinite as f32));
    let clamped = _mm256_min_ps(_mm256_set1_ps(ONE_MINUS_EPSILON), _mm256_max_ps(zero, stretched));
    // SAFETY: `u` is eight writable `f32`s; the store is unaligned.
    unsafe { _mm256_storeu_ps(u.as_mut_ptr(), clamped) };
}

/// `table[min(slot, 7)]` in each lane: one `vpermd`.
#[inline]
#[target_feature(enable = "avx,avx2")]
pub(super) fn pick(table: &[u32; WIDTH], slot: &[i32; WIDTH]) -> [u32; WIDTH] {
    let index = _mm256_min_epi32(load_u32(bytemuck::cast_ref(slot)), _mm256_set1_epi32(WIDTH as i32 - 1));
    let mut out = [0u32; WIDTH];
    // SAFETY: `out` is eight writable `u32`s; the store is unaligned.
    unsafe {
        _mm256_storeu_si256(out.as_mut_ptr().cast(), _mm256_permutevar8x32_epi32(load_u32(table), index))
    };
    out
}

/// [`node::prefix_sums`]: odd lanes add their left neighbour, then lanes 2, 3 (6, 7) add lane 1
/// (5), then the upper half adds lane 3.
#[inline]
#[target_feature(enable = "avx,avx2")]
pub(super) fn prefix_sums(w: __m256) -> __m256 {
    // Lanes (0, 0, 2, 2) of each half.
    let pairs = _mm256_blend_ps::<0b1010_1010>(w, _mm256_add_ps(_mm256_permute_ps::<0b10_10_00_00>(w), w));
    let quads = _mm256_blend_ps::<0b1100_1100>(
        pairs,
        _mm256_add_ps(_mm256_permute_ps::<0b01_01_01_01>(pairs), pairs),
    );
    // Lane 3 in every lane.
    let low3 = _mm256_permute2f128_ps::<0x00>(_mm256_permute_ps::<0b11_11_11_11>(quads), quads);
    _mm256_blend_ps::<0b1111_0000>(quads, _mm256_add_ps(low3, quads))
}

/// The sum of the eight weights in every lane, in [`node::prefix_sums`]' order (`((w0 + w1) +
/// (w2 + w3)) + ((w4 + w5) + (w6 + w7))`; each step adds lanes swapped in pairs, so every lane adds
/// the same two numbers, in one order or the other: the same bits). Three swap-and-add steps where
/// the running sums' last lane, broadcast, came four dependent steps later.
#[inline]
#[target_feature(enable = "avx,avx2")]
fn total(w: __m256) -> __m256 {
    let pairs = _mm256_add_ps(w, _mm256_permute_ps::<0b10_11_00_01>(w));
    let quads = _mm256_add_ps(pairs, _mm256_permute_ps::<0b01_00_11_10>(pairs));
    _mm256_add_ps(quads, _mm256_permute2f128_ps::<0x01>(quads, quads))
}

/// [`node::child_weights`]: the weights, their running sums and their sum (in every lane).
#[inline]
#[target_feature(enable = "avx,avx2")]
pub(super) fn weights(n: &Node, p: [f32; 3]) -> (__m256, __m256, __m256) {
    let w = importances(n, p);
    let sums = total(w);
    // `0 < sum < ∞` on the vector: LLVM turned the scalar test into a dozen integer instructions.
    let positive_finite = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(sums, _mm256_setzero_ps()),
        _mm256_cmp_ps::<_CMP_LT_OQ>(sums, _mm256_set1_ps(f32::INFINITY)),
    );
    if _mm256_movemask_ps(positive_finite) != 0 {
        return (w, prefix_sums(w), sums);
    }
    // The uniform fallback (rare: a point on a point light, or no child may contribute).
    let live = _mm256_cmpgt_epi32(_mm256_set1_epi32(n.len as i32), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    let w = _mm256_and_ps(_mm256_castsi256_ps(live), _mm256_set1_ps(1.0));
    (w, prefix_sums(w), total(w))
}

/// [`node::choose`] at `target = u · sum` among the first `len` lanes of the weights `w`, their
/// running sums `cdf` and their sum `sums` (every lane). Branch-free: the running sum below the
/// chosen lane is a lane of `cdf` moved up one lane with 0 in lane 0 (a branch on `chosen == 0`
/// mispredicted).
#[inline]
#[target_feature(enable = "avx,avx2")]
pub(super) fn choose(w: __m256, cdf: __m256, sums: __m256, len: u32, u: f32) -> Step {
    let targets = _mm256_mul_ps(_mm256_set1_ps(u), sums);
    let at_or_below = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(cdf, targets)) as u32;
    let positive = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(w, _mm256_setzero_ps())) as u32;
    let run = (!at_or_below).trailing_zeros();
    let last_with_probability = 31 - (positive | 1).leading_zeros();
    let chosen = if run < len { run } else { last_with_probability } as usize;
    let before = _mm256_blend_ps::<1>(
        _mm256_permutevar8x32_ps(cdf, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6)),
        _mm256_setzero_ps(),
    );
    Step {
        chosen,
        weight: lane(w, chosen),
        below: lane(before, chosen),
        sum: _mm256_cvtss_f32(sums),
        target: _mm256_cvtss_f32(targets),
    }
}

/// [`node::step`]: [`weights`] then [`choose`].
#[inline]
#[target_feature(enable = "avx,avx2")]
pub(super) fn step(n: &Node, p: [f32; 3], u: f32) -> Step {
    let (w, cdf, sums) = weights(n, p);
    choose(w, cdf, sums, n.len, u)
}

/// The root's step for the eight lanes at once, the lanes in the register's lanes (one pass per
/// child rather than one per lane), where the root's children all emit in every direction
/// ([`node::omni_importances`]: φ / max(d², r²), one division per child for all lanes) and every
/// squared distance is finite; `None` (and nothing written) otherwise. For the lanes of the bit
/// mask `lanes` it writes what [`node::step`] and the descent's first level give — the chosen child
/// into `at` and `light`, `u` rescaled, `pmf` times the child's probability — and returns the mask of
/// those whose child is a node.
///
/// The same operations as the per-lane step in the same order: the weights, the pairwise running
/// sums written out (`c1 = w0 + w1`, `c2 = c1 + w2`, `c3 = c1 + (w2 + w3)`, then `c3` plus `w4`,
/// `w4 + w5`, `(w4 + w5) + w6`, `(w4 + w5) + (w6 + w7)`), the uniform fallback per lane. The
/// choice is the last child `j` whose running sum before it is at or below the target and whose
/// weight is positive: the running sums never decrease, so that is the run's end of [`node::choose`]
/// (whose child has weight), or past the run the last child with weight, its fallback.
#[inline]
#[target_feature(enable = "avx,avx2")]
#[allow(clippy::too_many_arguments)]
pub(super) fn root_lanes(
    n: &Node,
    p: &[[f32; WIDTH]; 3],
    lanes: u32,
    u: &mut [f32; WIDTH],
    at: &mut [u32; WIDTH],
    light: &mut [u32; WIDTH],
    pmf: &mut [f32; WIDTH],
) -> Option<u32> {
    if n.omni == 0 {
        return None;
    }
    let (zero, infinity) = (_mm256_setzero_ps(), _mm256_set1_ps(f32::INFINITY));
    let q: [__m256; 3] = std::array::from_fn(|c| load(&p[c]));
    let mut finite = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    let w: [__m256; WIDTH] = std::array::from_fn(|j| {
        let v: [__m256; 3] = std::array::from_fn(|c| _mm256_sub_ps(q[c], _mm256_set1_ps(n.center[c][j])));
        let dist2 = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(v[0], v[0]), _mm256_mul_ps(v[1], v[1])),
            _mm256_mul_ps(v[2], v[2]),
        );
        finite = _mm256_and_ps(finite, _mm256_cmp_ps::<_CMP_LT_OQ>(dist2, infinity));
        _mm256_div_ps(_mm256_set1_ps(n.phi[j]), _mm256_max_ps(dist2, _mm256_set1_ps(n.radius2[j])))
    });
    if _mm256_movemask_ps(finite) != 0xff {
        return None;
    }
    let running = |w: &[__m256; WIDTH]| -> [__m256; WIDTH] {
        let (w01, w23, w45, w67) = (
            _mm256_add_ps(w[0], w[1]),
            _mm256_add_ps(w[2], w[3]),
            _mm256_add_ps(w[4], w[5]),
            _mm256_add_ps(w[6], w[7]),
        );
        let c3 = _mm256_add_ps(w01, w23);
        [
            w[0],
            w01,
            _mm256_add_ps(w01, w[2]),
            c3,
            _mm256_add_ps(c3, w[4]),
            _mm256_add_ps(c3, w45),
            _mm256_add_ps(c3, _mm256_add_ps(w45, w[6])),
            _mm256_add_ps(c3, _mm256_add_ps(w45, w67)),
        ]
    };
    let mut cdf = running(&w);
    let mut w = w;
    // `0 < sum < ∞`, else every child of the node weighs 1 (the uniform fallback).
    let sum_ok = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(cdf[WIDTH - 1], zero),
        _mm256_cmp_ps::<_CMP_LT_OQ>(cdf[WIDTH - 1], infinity),
    );
    if _mm256_movemask_ps(sum_ok) != 0xff {
        for (j, w) in w.iter_mut().enumerate() {
            let uniform = _mm256_set1_ps(if (j as u32) < n.len { 1.0 } else { 0.0 });
            *w = _mm256_blendv_ps(uniform, *w, sum_ok);
        }
        cdf = running(&w);
    }
    let sum = cdf[WIDTH - 1];
    let target = _mm256_mul_ps(load(u), sum);
    let (mut weight, mut below) = (w[0], zero);
    let mut child = _mm256_set1_epi32(n.child[0] as i32);
    let mut flags = _mm256_set1_epi32(n.flags[0] as i32);
    for j in 1..WIDTH {
        let take = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LE_OQ>(cdf[j - 1], target),
            _mm256_cmp_ps::<_CMP_GT_OQ>(w[j], zero),
        );
        weight = _mm256_blendv_ps(weight, w[j], take);
        below = _mm256_blendv_ps(below, cdf[j - 1], take);
        let take = _mm256_castps_si256(take);
        child = _mm256_blendv_epi8(child, _mm256_set1_epi32(n.child[j] as i32), take);
        flags = _mm256_blendv_epi8(flags, _mm256_set1_epi32(n.flags[j] as i32), take);
    }
    // `pmf *= w / sum`, `u = ((target − below) / w).clamp(0, 1 − ε)` (NaN kept, as `f32::clamp`).
    let path = _mm256_mul_ps(load(pmf), _mm256_div_ps(weight, sum));
    let rescaled = _mm256_div_ps(_mm256_sub_ps(target, below), weight);
    let rescaled = _mm256_min_ps(_mm256_set1_ps(ONE_MINUS_EPSILON), _mm256_max_ps(zero, rescaled));
    let mine = _mm256_cmpgt_epi32(
        _mm256_and_si256(_mm256_set1_epi32(lanes as i32), _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128)),
        _mm256_setzero_si256(),
    );
    let store = |out: &mut [f32; WIDTH], v: __m256| {
        // SAFETY: `out` is eight writable `f32`s; the store is unaligned.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) }
    };
    let store_u32 = |out: &mut [u32; WIDTH], v: __m256i| {
        // SAFETY: `out` is eight writable `u32`s; the store is unaligned.
        unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), v) }
    };
    store(pmf, _mm256_blendv_ps(load(pmf), path, _mm256_castsi256_ps(mine)));
    store(u, rescaled);
    store_u32(at, child);
    store_u32(light, _mm256_blendv_epi8(load_u32(light), child, mine));
    let leaf = _mm256_cmpeq_epi32(
        _mm256_and_si256(flags, _mm256_set1_epi32(LEAF as i32)),
        _mm256_set1_epi32(LEAF as i32),
    );
    Some(lanes & !(_mm256_movemask_ps(_mm256_castsi256_ps(leaf)) as u32))
}

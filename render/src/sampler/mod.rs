//! A stateless sampler: padded 2D Owen-scrambled Sobol (Burley 2020, "Practical Hash-based Owen
//! Scrambling", JCGT 9(4)).
//!
//! A sample value is a pure function of its key — (pixel, sample index, seed), the path vertex and the
//! dimension — so a path needs no sampler state beyond its vertex and dimension counters and a wavefront
//! integrator can reproduce the scalar integrator's numbers exactly.
//!
//! Dimensions are used in pairs: dimensions `2k` and `2k+1` of one vertex are the two coordinates of a
//! 2D Sobol (0,2)-sequence whose index is shuffled by a hash of (pixel, seed, vertex, k) and whose
//! coordinates are Owen-scrambled with independent hashes. Padding in 2D keeps the best stratification for
//! the pairs the integrator actually uses (pixel position, light position, BSDF direction); 1D uses take
//! one coordinate of a pair.

pub mod lanes;

/// Identifies one camera sample: which pixel, which sample of that pixel, under which seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleKey {
    /// Linear pixel index `y * width + x`.
    pub pixel: u32,
    /// Sample index within the pixel.
    pub sample: u32,
    /// The user's seed.
    pub seed: u32,
}

/// Per-vertex dimension layout. Pairs share one 2D sequence; see the module docs.
pub mod dim {
    /// Light selection (1D, paired with [`OPACITY`]).
    pub const LIGHT_SELECT: u32 = 0;
    /// Stochastic transparency decision (1D).
    pub const OPACITY: u32 = 1;
    /// Position on the chosen light (2D: this and the next).
    pub const LIGHT_UV: u32 = 2;
    /// BSDF lobe selection (1D, paired with [`RUSSIAN_ROULETTE`]).
    pub const LOBE: u32 = 4;
    /// Russian roulette (1D).
    pub const RUSSIAN_ROULETTE: u32 = 5;
    /// BSDF direction (2D).
    pub const BSDF_UV: u32 = 6;
    /// Position inside the pixel (2D, vertex 0 only).
    pub const PIXEL: u32 = 8;
    /// Position on the camera's lens (2D, vertex 0 only; drawn only when the camera has depth of
    /// field, so pinhole images keep their numbers).
    pub const LENS: u32 = 10;
    /// The camera ray's time inside the shutter (1D, vertex 0 only, the first of its own pair;
    /// drawn only when the shutter is open, so images without motion blur keep their numbers).
    pub const TIME: u32 = 12;
}

/// Sobol direction numbers for the first two dimensions, most significant bit first.
/// Dimension 0 is van der Corput; dimension 1 uses the primitive polynomial x + 1 (Joe & Kuo, s = 1,
/// a = 0, m = 1). The sampler computes them in closed form ([`sobol1_reversed`]); these are the
/// tests' reference.
#[cfg(test)]
const SOBOL_DIRECTIONS: [[u32; 32]; 2] = {
    let mut dirs = [[0u32; 32]; 2];
    let mut i = 0;
    while i < 32 {
        dirs[0][i] = 1u32 << (31 - i);
        i += 1;
    }
    dirs[1][0] = 1u32 << 31;
    let mut i = 1;
    while i < 32 {
        dirs[1][i] = dirs[1][i - 1] ^ (dirs[1][i - 1] >> 1);
        i += 1;
    }
    dirs
};

/// Dimension 1 of Sobol, bit-reversed, without tables (dimension 0 reversed is the index itself).
///
/// Its direction numbers are Pascal's triangle mod 2: bit `31 − k` of direction `j` is set when
/// `C(j, k)` is odd, that is (Lucas) when the bits of `k` are a subset of those of `j`. So bit `k` of
/// the reversed value is the XOR of the index bits `j ⊇ k`, a superset transform that takes five
/// shift-and-XOR steps, and the scrambler's reversal of its input cancels the reversal here.
///
/// It replaced four byte-indexed tables (one lookup per index byte, themselves the replacement of a
/// 32-step bit-serial loop that made the sampler half of the render time): about as many scalar
/// instructions, with one `reverse_bits` fewer around it, and it vectorises where table lookups need
/// gathers (the lane sampler, [`crate::sampler::lanes`]). The scalar integrator gained
/// little (callgrind, tractor, 120×80, 8 spp: 642.9 M → 639.9 M instructions: LLVM already folds
/// a reversal of a reversal, so only dimension 1's reversal and table lookups went); its sampler calls are still 12.5 % of its instructions, mostly the
/// pair-seed hashes each call recomputes.
#[inline]
pub(crate) fn sobol1_reversed(index: u32) -> u32 {
    let mut a = index;
    a ^= (a >> 1) & 0x5555_5555;
    a ^= (a >> 2) & 0x3333_3333;
    a ^= (a >> 4) & 0x0f0f_0f0f;
    a ^= (a >> 8) & 0x00ff_00ff;
    a ^= (a >> 16) & 0x0000_ffff;
    a
}

/// Bit-serial Sobol (the reference for the tests).
#[cfg(test)]
fn sobol_reference(index: u32, dimension: usize) -> u32 {
    let mut x = 0u32;
    let mut i = index;
    let mut bit = 0;
    while i != 0 {
        if i & 1 != 0 {
            x ^= SOBOL_DIRECTIONS[dimension][bit];
        }
        i >>= 1;
        bit += 1;
    }
    x
}

/// A 32-bit integer hash with good avalanche ("lowbias32", Chris Wellons).
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Combines a hash with another value (boost-style, then re-hashed).
#[inline]
pub fn hash_combine(seed: u32, value: u32) -> u32 {
    hash_u32(seed ^ value.wrapping_add(0x9e37_79b9).wrapping_add(seed << 6).wrapping_add(seed >> 2))
}

/// The seed of the shadow ray a path casts at `vertex`, from the hashed user seed and its pixel and
/// sample: one definition for the scalar integrator, the curve shading and the lanes (the transparent
/// shadow's stochastic opacity draws from it).
#[inline(always)]
pub fn shadow_seed(seed_hash: u32, pixel: u32, sample: u32, vertex: u32) -> u32 {
    hash_combine(hash_combine(seed_hash, pixel), sample) ^ vertex
}

/// Laine–Karras style permutation, improved constants from Burley 2020.
#[inline]
pub(crate) fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scrambling of a 32-bit fixed-point value (the reference formulation).
#[cfg(test)]
fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// The shuffled Sobol index of a pair: the sample index, Owen-scrambled by the pair's seed.
#[inline(always)]
pub(crate) fn pair_index(sample: u32, pair_seed: u32) -> u32 {
    laine_karras_permutation(sample.reverse_bits(), pair_seed).reverse_bits()
}

/// The Owen-scrambled coordinate of a Sobol value given bit-reversed (`reversed`), scrambled by
/// `seed`, as a float in [0, 1). Scrambling reverses its input, so taking the value reversed saves a
/// reversal per coordinate; dimension 0 is the reversed index, so its reversed value is the index.
#[inline(always)]
pub(crate) fn unit_from_reversed(reversed: u32, seed: u32) -> f32 {
    let x = laine_karras_permutation(reversed, seed).reverse_bits();
    // 24 significant bits: exactly representable, so the result is < 1; as i32 the conversion is
    // the same value and one AVX2 instruction in the lane sampler.
    ((x >> 8) as i32) as f32 * (1.0 / 16_777_216.0)
}

/// Coordinate `d` (0 or 1) of the pair with seed `pair_seed` for sample `sample`.
#[inline(always)]
fn coordinate(sample: u32, pair_seed: u32, d: u32) -> f32 {
    let index = pair_index(sample, pair_seed);
    let reversed = if d == 0 { index } else { sobol1_reversed(index) };
    unit_from_reversed(reversed, hash_combine(pair_seed, d))
}

/// One sample value in [0, 1) for `key` at path vertex `vertex`, dimension `dimension`.
#[inline]
pub fn sample_1d(key: SampleKey, vertex: u32, dimension: u32) -> f32 {
    coordinate(key.sample, pair_seed(key, vertex, dimension / 2), dimension & 1)
}

/// Two sample values for dimensions `dimension` and `dimension + 1` (`dimension` must be even).
#[inline]
pub fn sample_2d(key: SampleKey, vertex: u32, dimension: u32) -> [f32; 2] {
    debug_assert!(dimension.is_multiple_of(2), "2D samples start on an even dimension");
    PairSeeds::new(hash_u32(key.seed), key.pixel, vertex, dimension).sample_2d(key.sample)
}

/// The dimensions a path vertex draws with [`vertex_samples`]: `0..DIMS`, of which
/// [`dim::OPACITY`] is left 0 (it decides whether the vertex scatters at all, so it is drawn first,
/// on its own, with [`sample_1d`]).
pub const DIMS: usize = 8;

/// `out[d]` = `sample_1d(key, vertex, d)` for `d < DIMS` but [`dim::OPACITY`] (0), for the path of
/// `pixel`, `sample` under the seed whose `hash_u32` is `seed_hash`: every random number a
/// scattering vertex uses, with the (seed, pixel, vertex) prefix of the pair seeds hashed once
/// rather than once per dimension. Integer hashing only, so it is the same per lane: both
/// integrators call it once per vertex, [`lanes::vertex_lanes`] once per lane.
#[inline(always)]
pub fn vertex_samples(seed_hash: u32, pixel: u32, sample: u32, vertex: u32) -> [f32; DIMS] {
    const _: () = assert!(dim::LIGHT_SELECT == 0 && dim::OPACITY == 1 && dim::BSDF_UV + 2 == DIMS as u32);
    let prefix = vertex_prefix(seed_hash, pixel, vertex);
    let light_select = coordinate(sample, hash_combine(prefix, 0), 0);
    let [u2, u3] = PairSeeds::of_pair(prefix, 1).sample_2d(sample);
    let [u4, u5] = PairSeeds::of_pair(prefix, 2).sample_2d(sample);
    let [u6, u7] = PairSeeds::of_pair(prefix, 3).sample_2d(sample);
    [light_select, 0.0, u2, u3, u4, u5, u6, u7]
}

/// The (seed, pixel, vertex) prefix every pair seed of a vertex starts from.
#[inline(always)]
fn vertex_prefix(seed_hash: u32, pixel: u32, vertex: u32) -> u32 {
    hash_combine(hash_combine(seed_hash, pixel), vertex)
}

/// The hashes of one (seed, pixel, vertex, pair) that every sample of the pixel shares: the pair
/// seed that shuffles the Sobol index and the scramble seeds of its two coordinates. Five of the
/// seven hashes of a 2D sample, so a caller drawing many samples of one pixel computes them once
/// (the wavefront's camera jitter, [`crate::sampler::lanes::pair_lanes`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PairSeeds {
    /// Scrambles the sample index.
    pub index: u32,
    /// Scrambles the first coordinate (dimension `2·pair`).
    pub first: u32,
    /// Scrambles the second coordinate (dimension `2·pair + 1`).
    pub second: u32,
}

impl PairSeeds {
    /// The seeds of dimensions `dimension`, `dimension + 1` (even) at `vertex` of `pixel`'s paths;
    /// `seed_hash` is `hash_u32(seed)`.
    #[inline(always)]
    pub fn new(seed_hash: u32, pixel: u32, vertex: u32, dimension: u32) -> Self {
        Self::of_pair(vertex_prefix(seed_hash, pixel, vertex), dimension / 2)
    }

    /// The seeds of pair `pair` of the vertex whose prefix ([`vertex_prefix`]) is `prefix`.
    #[inline(always)]
    fn of_pair(prefix: u32, pair: u32) -> Self {
        let pair_seed = hash_combine(prefix, pair);
        PairSeeds { index: pair_seed, first: hash_combine(pair_seed, 0), second: hash_combine(pair_seed, 1) }
    }

    /// `sample_2d` of sample `sample` of the pixel, vertex and pair these seeds were made for.
    #[inline(always)]
    pub fn sample_2d(&self, sample: u32) -> [f32; 2] {
        let index = pair_index(sample, self.index);
        [unit_from_reversed(index, self.first), unit_from_reversed(sobol1_reversed(index), self.second)]
    }
}

/// The sampler as first written (bit-serial Sobol, every scramble reversing in and out): the
/// reference the fast formulation above must equal bit for bit.
#[cfg(test)]
fn sample_1d_reference(key: SampleKey, vertex: u32, dimension: u32) -> f32 {
    let pair_seed = pair_seed(key, vertex, dimension / 2);
    let index = nested_uniform_scramble(key.sample, pair_seed);
    let d = (dimension & 1) as usize;
    let x = nested_uniform_scramble(sobol_reference(index, d), hash_combine(pair_seed, d as u32));
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[inline]
fn pair_seed(key: SampleKey, vertex: u32, pair: u32) -> u32 {
    hash_combine(vertex_prefix(hash_u32(key.seed), key.pixel, vertex), pair)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(pixel: u32, sample: u32) -> SampleKey {
        SampleKey { pixel, sample, seed: 7 }
    }

    #[test]
    fn fast_sampler_equals_the_reference_formulation_bit_for_bit() {
        let mut x = 3u32;
        for round in 0..20_000u32 {
            x = hash_u32(x);
            // Small sample indices and the full 32-bit range (every Sobol index bit in use).
            let sample = if round % 2 == 0 { x % 4096 } else { hash_u32(x ^ 1) };
            let key = SampleKey { pixel: x % 1_000_000, sample, seed: round % 3 };
            let vertex = x % 70;
            for d in 0..10 {
                let expected = sample_1d_reference(key, vertex, d);
                assert_eq!(sample_1d(key, vertex, d).to_bits(), expected.to_bits(), "{key:?} {vertex} {d}");
            }
            let [a, b] = sample_2d(key, vertex, dim::BSDF_UV);
            assert_eq!(a.to_bits(), sample_1d_reference(key, vertex, dim::BSDF_UV).to_bits());
            assert_eq!(b.to_bits(), sample_1d_reference(key, vertex, dim::BSDF_UV + 1).to_bits());
        }
    }

    #[test]
    fn vertex_samples_equal_sample_1d_in_every_dimension_but_opacity() {
        let mut x = 11u32;
        for round in 0..5_000u32 {
            x = hash_u32(x);
            let key = SampleKey { pixel: x % 1_000_000, sample: hash_u32(x ^ 3) % 65_536, seed: round % 4 };
            let vertex = x % 70;
            let got = vertex_samples(hash_u32(key.seed), key.pixel, key.sample, vertex);
            for d in 0..DIMS as u32 {
                let want = if d == dim::OPACITY { 0.0 } else { sample_1d_reference(key, vertex, d) };
                assert_eq!(
                    got[d as usize].to_bits(),
                    want.to_bits(),
                    "{key:?} vertex {vertex} dimension {d}"
                );
            }
        }
    }

    #[test]
    fn table_free_sobol1_matches_the_bit_serial_reference() {
        let mut x = 5u32;
        for i in (0..4096).chain([u32::MAX, 1 << 31, 0x8000_0001]) {
            x = hash_u32(x);
            for index in [i, x] {
                assert_eq!(sobol1_reversed(index), sobol_reference(index, 1).reverse_bits(), "{index:#x}");
            }
        }
    }

    #[test]
    fn values_are_in_unit_interval_and_deterministic() {
        for s in 0..2000 {
            for d in 0..10 {
                let v = sample_1d(key(3, s), 2, d);
                assert!((0.0..1.0).contains(&v), "{v}");
                assert_eq!(v.to_bits(), sample_1d(key(3, s), 2, d).to_bits());
            }
        }
        let [a, b] = sample_2d(key(5, 9), 1, 2);
        assert_eq!(a, sample_1d(key(5, 9), 1, 2));
        assert_eq!(b, sample_1d(key(5, 9), 1, 3));
    }

    #[test]
    fn mean_of_4096_samples_is_one_half() {
        for d in 0..10 {
            let mean: f64 = (0..4096).map(|s| sample_1d(key(11, s), 0, d) as f64).sum::<f64>() / 4096.0;
            assert!((mean - 0.5).abs() < 0.01, "dimension {d}: mean {mean}");
        }
    }

    #[test]
    fn first_256_points_of_a_pair_stratify_a_16x16_grid() {
        // An Owen-scrambled (0,2)-sequence: every elementary interval of area 1/256 holds one point.
        for vertex in 0..3 {
            let mut cells = [0u32; 256];
            let mut rows = [0u32; 256];
            for s in 0..256 {
                let [u, v] = sample_2d(key(42, s), vertex, dim::BSDF_UV);
                cells[(u * 16.0) as usize * 16 + (v * 16.0) as usize] += 1;
                rows[(u * 256.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "vertex {vertex}: {cells:?}");
            assert!(rows.iter().all(|&c| c == 1));
        }
    }

    #[test]
    fn pixels_and_seeds_decorrelate() {
        let a: Vec<f32> = (0..64).map(|s| sample_1d(key(1, s), 0, 0)).collect();
        let b: Vec<f32> = (0..64).map(|s| sample_1d(key(2, s), 0, 0)).collect();
        let c: Vec<f32> =
            (0..64).map(|s| sample_1d(SampleKey { pixel: 1, sample: s, seed: 8 }, 0, 0)).collect();
        assert_ne!(a, b);
        assert_ne!(a, c);
    }
}

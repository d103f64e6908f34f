//! The sampler ([`crate::sampler`]) for eight paths at once: the random numbers one path vertex uses
//! ([`crate::sampler::vertex_samples`]) and the camera's pixel position ([`PairSeeds::sample_2d`]).
//! Each kernel is a loop over the lanes around the scalar function itself; integer hashing is exact,
//! so lanes equal the scalar values bit for bit.
//!
//! LLVM emits the loops as 8-wide AVX2 integer code (`vpmulld` for the hashes, `vpshufb` nibble
//! tables for `reverse_bits`) because the per-coordinate functions have no tables (Sobol's
//! dimension 1 is [`crate::sampler::sobol1_reversed`]'s shift-and-XOR) and no reversal that
//! cancels. The kernels that reverse bits ([`vertex_lanes`], [`pair_lanes`]) have a GFNI clone
//! ahead of the AVX2 one (a byte swap and one `vgf2p8affineqb` per reversal; same integer
//! operations, same bits). Measurements: `docs/perf.md#sampler-lanes-samplerlanesrs`.

pub use crate::sampler::DIMS;
use crate::sampler::{dim, vertex_samples, PairSeeds};
use lanekit::{Lanes, U32Lanes, LANES};

lanekit::soa! {
    /// Eight paths' keys at their current vertex.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct KeyLanes for struct KeyLane {
        /// Linear pixel index.
        pub pixel: u32,
        /// Sample index.
        pub sample: u32,
        /// Vertex counter.
        pub vertex: u32,
    }
}

/// `out[d][k]` = `sample_1d(key_k, vertex_k, d)` for `d < DIMS`, `d != dim::OPACITY` (left as it was):
/// [`vertex_samples`] per lane; `seed_hash` is `hash_u32(seed)`.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma+gfni", "x86_64+avx+avx2+fma"))]
pub fn vertex_lanes(seed_hash: u32, keys: &KeyLanes, out: &mut [Lanes; DIMS]) {
    for k in 0..LANES {
        let u = vertex_samples(seed_hash, keys.pixel[k], keys.sample[k], keys.vertex[k]);
        for d in (0..DIMS).filter(|&d| d != dim::OPACITY as usize) {
            out[d][k] = u[d];
        }
    }
}

lanekit::soa! {
    /// Eight paths' [`PairSeeds`], one field per array.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct PairSeedLanes for PairSeeds {
        /// [`PairSeeds::index`] per lane.
        pub index: u32,
        /// [`PairSeeds::first`] per lane.
        pub first: u32,
        /// [`PairSeeds::second`] per lane.
        pub second: u32,
    }
}

/// `out` lane `k` = `PairSeeds::new(seed_hash, pixel[k], vertex, dimension)`: the seeds of eight
/// pixels at once (the camera jitter's, a tile row at a time).
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn pair_seed_lanes(
    seed_hash: u32,
    pixel: &U32Lanes,
    vertex: u32,
    dimension: u32,
    out: &mut PairSeedLanes,
) {
    for k in 0..LANES {
        out.set(k, &PairSeeds::new(seed_hash, pixel[k], vertex, dimension));
    }
}

/// `out[i][k]` = `seeds_k.sample_2d(sample[k])[i]`: a 2D sample of eight paths whose pair seeds
/// were hashed beforehand (the camera jitter: once per pixel, not once per path).
///
/// It replaced `sample_2d_lanes`, which hashed the (seed, pixel, vertex, pair) prefix and the two
/// scramble seeds in every lane: five `hash_combine`s, a chain of ten dependent `vpmulld`s (10
/// cycles each) ahead of the eight of the index and coordinate scrambles, so the kernel was
/// latency-bound (perf, simple, 320×213, 16 spp: 3.4 % of the samples, above `vertex_lanes`).
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma+gfni", "x86_64+avx+avx2+fma"))]
pub fn pair_lanes(seeds: &PairSeedLanes, sample: &U32Lanes, out: &mut [Lanes; 2]) {
    for k in 0..LANES {
        [out[0][k], out[1][k]] = seeds.get(k).sample_2d(sample[k]);
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lane-indexed comparisons read clearest as index loops
mod tests {
    use super::*;
    use crate::sampler::{dim, hash_combine, hash_u32, pair_index, sample_1d, sample_2d, SampleKey};
    use crate::sampler::{sobol1_reversed, unit_from_reversed};

    #[test]
    fn lanes_equal_the_scalar_sampler_bit_for_bit() {
        let mut x = 17u32;
        for seed in [0u32, 3, 0xdead_beef] {
            for _ in 0..500 {
                let mut keys = KeyLanes::default();
                for k in 0..LANES {
                    x = hash_u32(x);
                    keys.pixel[k] = x % 100_000;
                    keys.sample[k] = (x >> 17) % 4096;
                    keys.vertex[k] = x % 70;
                }
                let mut out = [[0.0; LANES]; DIMS];
                vertex_lanes(hash_u32(seed), &keys, &mut out);
                for k in 0..LANES {
                    let key = SampleKey { pixel: keys.pixel[k], sample: keys.sample[k], seed };
                    for d in (0..DIMS).filter(|&d| d != dim::OPACITY as usize) {
                        let expected = sample_1d(key, keys.vertex[k], d as u32);
                        assert_eq!(out[d][k].to_bits(), expected.to_bits(), "lane {k} dimension {d}");
                    }
                }
            }
        }
    }

    #[test]
    fn pair_lanes_equal_the_scalar_2d_sampler_bit_for_bit() {
        let mut x = 23u32;
        let mut cases = 0;
        for seed in [0u32, 1, 0x1234_5678] {
            for round in 0..700 {
                let (mut pixel, mut sample, mut seeds) =
                    ([0u32; LANES], [0u32; LANES], PairSeedLanes::default());
                let vertex = round % 5;
                let dimension = 2 * (round % 5);
                for k in 0..LANES {
                    x = hash_u32(x);
                    // Small pixels and samples, and the full 32-bit range (every Sobol index bit).
                    pixel[k] = if round % 2 == 0 { x % 1_000_000 } else { x };
                    sample[k] = if round % 3 == 0 { hash_u32(x) } else { (x >> 11) % 65_536 };
                    seeds.set(k, &PairSeeds::new(hash_u32(seed), pixel[k], vertex, dimension));
                }
                let mut hashed = PairSeedLanes::default();
                pair_seed_lanes(hash_u32(seed), &pixel, vertex, dimension, &mut hashed);
                assert_eq!(
                    (hashed.index, hashed.first, hashed.second),
                    (seeds.index, seeds.first, seeds.second)
                );
                let mut out = [[0.0; LANES]; 2];
                pair_lanes(&seeds, &sample, &mut out);
                for k in 0..LANES {
                    let key = SampleKey { pixel: pixel[k], sample: sample[k], seed };
                    let expected = sample_2d(key, vertex, dimension);
                    // The scalar reference as first written: five hashes from the key.
                    let pair_seed = hash_combine(
                        hash_combine(hash_combine(hash_u32(seed), pixel[k]), vertex),
                        dimension / 2,
                    );
                    let index = pair_index(sample[k], pair_seed);
                    let reference = [
                        unit_from_reversed(index, hash_combine(pair_seed, 0)),
                        unit_from_reversed(sobol1_reversed(index), hash_combine(pair_seed, 1)),
                    ];
                    assert_eq!(reference.map(f32::to_bits), expected.map(f32::to_bits));
                    assert_eq!([out[0][k].to_bits(), out[1][k].to_bits()], expected.map(f32::to_bits));
                    cases += 1;
                }
            }
        }
        assert!(cases >= 10_000);
    }
}

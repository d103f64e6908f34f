//! The sampler ([`crate::sampler`]) for eight paths at once: every random number one path vertex uses
//! (dimensions 0–7: light selection, opacity, light position, lobe, roulette, BSDF direction), with
//! the scalar [`sample_1d`] as the reference.
//!
//! Integer hashing is exact, so lanes equal the scalar values bit for bit. Besides running eight paths
//! per instruction, the lanes hash the (seed, pixel, vertex) prefix of the pair seeds once per vertex
//! instead of once per dimension as each scalar call does.

use super::lanes::LANES;
use crate::sampler::{hash_combine, nested_uniform_scramble, sobol, to_unit_float};

/// Dimensions drawn per vertex.
pub const DIMS: usize = 8;

/// Eight paths' keys at their current vertex.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct KeyLanes {
    /// Linear pixel index.
    pub pixel: [u32; LANES],
    /// Sample index.
    pub sample: [u32; LANES],
    /// Vertex counter.
    pub vertex: [u32; LANES],
}

/// `out[d][k]` = `sample_1d(key_k, vertex_k, d)` for `d < DIMS`; `seed_hash` is
/// `hash_u32(seed)`.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn vertex_lanes(seed_hash: u32, keys: &KeyLanes, out: &mut [[f32; LANES]; DIMS]) {
    for k in 0..LANES {
        let prefix = hash_combine(hash_combine(seed_hash, keys.pixel[k]), keys.vertex[k]);
        for pair in 0..DIMS / 2 {
            let pair_seed = hash_combine(prefix, pair as u32);
            let index = nested_uniform_scramble(keys.sample[k], pair_seed);
            out[2 * pair][k] =
                to_unit_float(nested_uniform_scramble(sobol(index, 0), hash_combine(pair_seed, 0)));
            out[2 * pair + 1][k] =
                to_unit_float(nested_uniform_scramble(sobol(index, 1), hash_combine(pair_seed, 1)));
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lane-indexed comparisons read clearest as index loops
mod tests {
    use super::*;
    use crate::sampler::{hash_u32, sample_1d, SampleKey};

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
                    for d in 0..DIMS {
                        let expected = sample_1d(key, keys.vertex[k], d as u32);
                        assert_eq!(out[d][k].to_bits(), expected.to_bits(), "lane {k} dimension {d}");
                    }
                }
            }
        }
    }
}

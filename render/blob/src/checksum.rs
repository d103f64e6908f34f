//! A fast 64-bit checksum for section integrity.
//!
//! Written by hand because this crate depends on bytemuck only (the format must not pull in a hashing
//! crate). It is not cryptographic; it detects corruption. Each 8-byte word goes through a bijective
//! step (xor, multiply by an odd constant, rotate) in one of four independent lanes, so changing any one
//! word — in particular any single byte — always changes the result; four lanes keep the multiplies
//! independent so the loop runs at several GB/s.

const K0: u64 = 0x9E37_79B9_7F4A_7C15;
const K1: u64 = 0xC2B2_AE3D_27D4_EB4F;

#[inline(always)]
fn step(lane: u64, word: u64) -> u64 {
    (lane ^ word).wrapping_mul(K0).rotate_left(29)
}

#[inline(always)]
fn finish(mut x: u64) -> u64 {
    x ^= x >> 33;
    x = x.wrapping_mul(K1);
    x ^= x >> 29;
    x
}

/// Checksum of `bytes`.
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut lanes = [K1, K1 ^ 1, K1 ^ 2, K1 ^ 3];
    let mut blocks = bytes.chunks_exact(32);
    for block in &mut blocks {
        for (lane, word) in lanes.iter_mut().zip(block.chunks_exact(8)) {
            *lane = step(*lane, u64::from_le_bytes(word.try_into().expect("8-byte chunk")));
        }
    }
    let tail = blocks.remainder();
    let mut padded = [0u8; 32];
    padded[..tail.len()].copy_from_slice(tail);
    for (lane, word) in lanes.iter_mut().zip(padded.chunks_exact(8)) {
        *lane = step(*lane, u64::from_le_bytes(word.try_into().expect("8-byte chunk")));
    }
    let mut h = (bytes.len() as u64).wrapping_mul(K0);
    for (i, lane) in lanes.iter().enumerate() {
        h ^= finish(*lane).rotate_left(16 * i as u32);
    }
    finish(h)
}

#[cfg(test)]
mod tests {
    use super::checksum;

    #[test]
    fn every_single_byte_change_changes_the_checksum() {
        let data: Vec<u8> = (0..200u32).map(|i| (i * 37 % 251) as u8).collect();
        let base = checksum(&data);
        for i in 0..data.len() {
            for flip in [1u8, 0x80, 0xff] {
                let mut changed = data.clone();
                changed[i] ^= flip;
                assert_ne!(checksum(&changed), base, "byte {i} flip {flip:#x}");
            }
        }
    }

    #[test]
    fn length_is_part_of_the_checksum() {
        assert_ne!(checksum(&[0u8; 5]), checksum(&[0u8; 6]));
        assert_ne!(checksum(&[]), checksum(&[0u8; 32]));
    }
}

//! Rewrites the one layout openusd 0.6 misreads in old crate files, so that it composes them as
//! usd-core does.
//!
//! Time samples store their times as a `DoubleVector` (C++ `std::vector<double>`), which every
//! crate version writes as a 64-bit size followed by the doubles. Arrays are written differently
//! before version 0.7.0: a 32-bit size, after a 32-bit rank before 0.5.0. openusd reads a
//! `DoubleVector` like an array of the file's version, so in a file older than 0.7.0 it reads the
//! low and high halves of the 64-bit size as rank and count, finds no times, and rejects every
//! time-sampled attribute ("Invalid time samples count"; OpenUSD's own
//! `extras/usd/tutorials/animatedTop/top.geom.usd` is a 0.4.0 file).
//!
//! [`repair`] copies each such times vector to the end of the file in the array layout of the
//! file's version (nothing the reader indexes lies past the last section) and points the times rep
//! at the copy, so openusd decodes the same doubles usd-core does. Only what the 64-bit layout
//! says is read; the repaired file is checked again before it is used.

use std::collections::HashMap;

use super::coding::Reader;
use super::{read_fields, read_header, read_tokens, Version};

/// Crate versions from this one on write array sizes as 64 bits, like vectors.
const SIZES_64_BIT: Version = Version(0, 7, 0);
/// Before this version every array is preceded by its 32-bit rank.
const RANK_DROPPED: Version = Version(0, 5, 0);
const TIME_SAMPLES: u8 = 46;
const DOUBLE_VECTOR: u8 = 48;
const INLINED: u64 = 1 << 62;
const PAYLOAD_MASK: u64 = (1 << 48) - 1;

fn value_type(bits: u64) -> u8 {
    ((bits >> 48) & 0xff) as u8
}

/// The crate file `bytes` with the times of its time samples rewritten in the layout openusd
/// reads (see the module docs), or `None` when nothing needs rewriting or the file cannot be
/// repaired (openusd then reports it as before).
pub(crate) fn repair(bytes: &[u8]) -> Option<Vec<u8>> {
    let (version, sections) = read_header(bytes).ok()?;
    if version >= SIZES_64_BIT {
        return None;
    }
    let section = |name: &str| sections.iter().find(|s| s.name == name);
    let reader = |name: &str| section(name).map(|s| Reader::new(bytes, s.start as usize, s.end as usize));
    let tokens = read_tokens(&mut reader("TOKENS")?).ok()?;
    let fields = read_fields(&mut reader("FIELDS")?, tokens.ranges.len()).ok()?;

    let mut out = bytes.to_vec();
    // Original times payload -> payload of its copy (samples share stored times).
    let mut copies: HashMap<u64, u64> = HashMap::new();
    for &(_, bits) in &fields {
        if value_type(bits) != TIME_SAMPLES || bits & INLINED != 0 {
            continue;
        }
        let Some((rep_at, times)) = times_rep(bytes, bits & PAYLOAD_MASK) else { continue };
        if value_type(times) != DOUBLE_VECTOR || times & INLINED != 0 || times & PAYLOAD_MASK == 0 {
            continue;
        }
        let original = times & PAYLOAD_MASK;
        let copy = match copies.get(&original) {
            Some(&copy) => copy,
            None => {
                let copy = append_as_array(bytes, original, version, &mut out)?;
                copies.insert(original, copy);
                copy
            }
        };
        let repaired = (times & !PAYLOAD_MASK) | copy;
        out[rep_at..rep_at + 8].copy_from_slice(&repaired.to_le_bytes());
    }
    if copies.is_empty() {
        return None;
    }
    super::check(&out).ok()?;
    Some(out)
}

/// Where the times rep of the time samples at `payload` is stored, and its bits: after the
/// recursive offset that starts the time samples (a forward jump from the offset's own position).
fn times_rep(bytes: &[u8], payload: u64) -> Option<(usize, u64)> {
    let mut r = Reader::new(bytes, 0, bytes.len());
    r.seek(payload, "time samples").ok()?;
    let jump = r.i64("time samples offset").ok()?;
    if jump < 8 {
        return None;
    }
    r.seek(payload.checked_add(jump as u64)?, "sample times").ok()?;
    let at = r.pos;
    Some((at, r.u64("sample times").ok()?))
}

/// Appends the vector of doubles stored at `payload` (a 64-bit count, then the doubles) to `out`
/// as an array of the file's `version`; returns the copy's offset.
fn append_as_array(bytes: &[u8], payload: u64, version: Version, out: &mut Vec<u8>) -> Option<u64> {
    let mut r = Reader::new(bytes, 0, bytes.len());
    r.seek(payload, "sample times").ok()?;
    let count = r.u64("sample time count").ok()?;
    let count32 = u32::try_from(count).ok()?;
    r.holds(count, 8, "sample times").ok()?;
    let doubles = r.take(count as usize * 8, "sample times").ok()?;
    let copy = out.len() as u64;
    if copy > PAYLOAD_MASK {
        return None;
    }
    if version < RANK_DROPPED {
        out.extend_from_slice(&1u32.to_le_bytes());
    }
    out.extend_from_slice(&count32.to_le_bytes());
    out.extend_from_slice(doubles);
    Some(copy)
}

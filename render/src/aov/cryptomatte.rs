//! Cryptomatte 1.2 ids, ranked coverage and manifests.
//!
//! * **Ids**: MurmurHash3_x86_32 (seed 0) of the UTF-8 name — the gprim's prim path for
//!   `CryptoObject`, its bound material's path for `CryptoMaterial` — with the spec's fix-up so
//!   the bits are a normal float (an exponent of all zeros or all ones has its lowest bit
//!   flipped: [`id_of`]); the float with those bits is what the id channels hold.
//! * **Coverage** is the fraction of a pixel's camera samples whose first hit carries the id (a
//!   box filter: the film's). Each pixel keeps [`SLOTS`] distinct ids with their sample counts, in
//!   the order first seen; a sample of a further id is dropped (its coverage is lost, so the ranks
//!   sum below 1 only in pixels where more than eight objects meet). [`RANKS`] ranks are written,
//!   by coverage, ties broken by the smaller id, as the spec's `<name>00` … layers: `R` id, `G`
//!   coverage of rank 2k, `B` id, `A` coverage of rank 2k + 1.
//! * **Metadata**: `cryptomatte/<key>/name`, `…/hash` = `MurmurHash3_32`, `…/conversion` =
//!   `uint32_to_float32` and `…/manifest` (a JSON object from every name of the kind in the scene to
//!   its id as eight hex digits, sorted by name), `<key>` the first seven hex digits of the
//!   layer name's hash.
//! * Blob materials are stored once per class of equal materials (ingest's packer), so two
//!   differently named materials with identical programs share the first one's name.

/// Distinct ids tracked per pixel.
pub const SLOTS: usize = 8;
/// Ranks written (three RGBA layers).
pub const RANKS: usize = 6;

/// MurmurHash3_x86_32 of `data` with `seed`.
pub fn murmur3_32(data: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mut h = seed;
    let mut blocks = data.chunks_exact(4);
    for b in &mut blocks {
        let mut k = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        k = k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
        h ^= k;
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let mut k = 0u32;
        for (i, &byte) in tail.iter().enumerate() {
            k |= u32::from(byte) << (8 * i);
        }
        h ^= k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    }
    h ^= data.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The Cryptomatte id of `name`: its hash with the exponent fixed so the float is normal.
pub fn id_of(name: &str) -> u32 {
    let hash = murmur3_32(name.as_bytes(), 0);
    let exponent = (hash >> 23) & 0xff;
    if exponent == 0 || exponent == 0xff {
        hash ^ (1 << 23)
    } else {
        hash
    }
}

/// The metadata key of a Cryptomatte layer named `name`.
pub fn key_of(name: &str) -> String {
    format!("{:08x}", murmur3_32(name.as_bytes(), 0))[..7].to_string()
}

/// The manifest of `names`: `{"name":"id in hex",…}` sorted by name, without repeats.
pub fn manifest<'n>(names: impl IntoIterator<Item = &'n str>) -> String {
    let mut names: Vec<&str> = names.into_iter().collect();
    names.sort_unstable();
    names.dedup();
    let entries: Vec<String> = names
        .iter()
        .map(|n| format!("{}:\"{:08x}\"", serde_json::Value::String(n.to_string()), id_of(n)))
        .collect();
    format!("{{{}}}", entries.join(","))
}

/// Adds one sample of `id` to a pixel's slots (`2 × SLOTS` floats: id bits, count).
#[inline]
pub(crate) fn add(slots: &mut [f32], id: u32) {
    for s in slots.chunks_exact_mut(2) {
        if s[1] == 0.0 {
            s[0] = f32::from_bits(id);
            s[1] = 1.0;
            return;
        }
        if s[0].to_bits() == id {
            s[1] += 1.0;
            return;
        }
    }
}

/// Merges a later sample slice's slots `later` of a pixel into `slots` (both `2 × SLOTS` floats):
/// each id's count is added to the same id's slot, or takes the first free one, in the later
/// slice's order. This is what adding the later samples one by one does, so the merge equals the
/// single render's slots exactly wherever no slice of the pixel dropped a sample (saw more than
/// [`SLOTS`] distinct ids); where one did, both keep [`SLOTS`] ids and may lose different samples.
pub(crate) fn merge(slots: &mut [f32], later: &[f32]) {
    for b in later.chunks_exact(2).filter(|b| b[1] > 0.0) {
        let id = b[0].to_bits();
        for s in slots.chunks_exact_mut(2) {
            if s[1] == 0.0 {
                s[0] = b[0];
                s[1] = b[1];
                break;
            }
            if s[0].to_bits() == id {
                s[1] += b[1];
                break;
            }
        }
    }
}

/// A pixel's ranked `(id, coverage)` pairs, `RANKS` long (zeros past the ids it has).
pub(crate) fn ranked(slots: &[f32], samples: u32) -> [(f32, f32); RANKS] {
    let mut seen: Vec<(f32, f32)> =
        slots.chunks_exact(2).filter(|s| s[1] > 0.0).map(|s| (s[0], s[1] / samples.max(1) as f32)).collect();
    seen.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.to_bits().cmp(&b.0.to_bits())));
    let mut out = [(0.0, 0.0); RANKS];
    for (o, s) in out.iter_mut().zip(seen) {
        *o = s;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn murmur3_matches_the_reference_vectors() {
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"hello", 0), 0x248b_fa47);
        assert_eq!(murmur3_32(b"The quick brown fox jumps over the lazy dog", 0), 0x2e4f_f723);
    }

    #[test]
    fn ids_are_normal_floats_and_keys_seven_digits() {
        for name in ["/World/card", "/a", "", "/World/Looks/Steel", "CryptoObject"] {
            let f = f32::from_bits(id_of(name));
            assert!(f.is_normal(), "{name}: {f}");
        }
        assert_eq!(key_of("CryptoObject").len(), 7);
        assert_eq!(key_of("CryptoObject"), format!("{:08x}", murmur3_32(b"CryptoObject", 0))[..7]);
    }

    #[test]
    fn slots_rank_by_coverage_then_id() {
        let mut slots = [0.0f32; 2 * SLOTS];
        for id in [id_of("/b"), id_of("/a"), id_of("/a"), id_of("/c"), id_of("/b"), id_of("/a")] {
            add(&mut slots, id);
        }
        let r = ranked(&slots, 6);
        assert_eq!(r[0], (f32::from_bits(id_of("/a")), 0.5));
        assert_eq!(r[1], (f32::from_bits(id_of("/b")), 2.0 / 6.0));
        assert_eq!(r[2], (f32::from_bits(id_of("/c")), 1.0 / 6.0));
        assert_eq!(r[3], (0.0, 0.0));
        // Two slices merged equal the samples added one by one, even as they fill every slot,
        // unless a slice saw more than SLOTS ids (cut 1: the second slice drops a later sample of
        // the id the first slice holds, which the whole render counts).
        let ids: Vec<u32> = (0..12).map(|i| id_of(&format!("/o{}", (i * 7) % 9))).collect();
        let distinct = |s: &[u32]| s.iter().collect::<std::collections::BTreeSet<_>>().len();
        let mut differ = 0;
        for cut in 0..ids.len() {
            let mut whole = [0.0f32; 2 * SLOTS];
            ids.iter().for_each(|&id| add(&mut whole, id));
            let (mut first, mut second) = ([0.0f32; 2 * SLOTS], [0.0f32; 2 * SLOTS]);
            ids[..cut].iter().for_each(|&id| add(&mut first, id));
            ids[cut..].iter().for_each(|&id| add(&mut second, id));
            merge(&mut first, &second);
            let exact = distinct(&ids[..cut]) <= SLOTS && distinct(&ids[cut..]) <= SLOTS;
            let equal = first.map(f32::to_bits) == whole.map(f32::to_bits);
            assert!(equal || !exact, "cut at {cut}");
            differ += usize::from(!equal);
        }
        assert!(differ > 0, "an overflowing slice loses samples the whole render keeps");
        let m = manifest(["/b", "/a", "/a"]);
        assert_eq!(m, format!("{{\"/a\":\"{:08x}\",\"/b\":\"{:08x}\"}}", id_of("/a"), id_of("/b")));
    }
}

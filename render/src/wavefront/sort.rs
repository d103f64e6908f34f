//! Stage 3: sorting the shade queue. Reads the shade queue and the hit side table; leaves the queue
//! grouped by material (one contiguous segment per material: the per-material shade queues, sharing
//! one preallocated buffer) and, within a material, ordered by sort key.
//!
//! # Entry and key layout
//! A shade-queue entry is 64 bits: `key << 32 | ray-state index` ([`entry`]), as in MoonRay §5.2.
//! The 32-bit key ([`shade_key`]) is
//!
//! | bits  | field                                   | width            |
//! |-------|-----------------------------------------|------------------|
//! | 25–31 | light set                               | 7 bits: 128 sets |
//! | 18–24 | UDIM tile of the first texture lookup   | 7 bits           |
//! | 14–17 | mip level                               | 4 bits           |
//! | 0–13  | Morton code of the tile-fractional uv   | 2 × 7 bits       |
//!
//! (bits 0–24 are [`texture::shading_sort_key`], computed by [`crate::Scene::shading_sort_key`]). This
//! renderer has no light linking yet, so the light set is always 0 and its byte is never sorted.
//!
//! The radix sort is LSD with 8-bit digits and skips every digit in which all keys agree, so a queue of
//! untextured hits (all keys 0) is not sorted at all, and a textured one costs one pass per byte that
//! varies (usually the Morton bytes and the mip level: 2–3 passes).

use super::StageQueues;

/// A shade-queue entry: 32-bit sort key above a 32-bit [`super::RayState`] index.
pub type ShadeEntry = u64;
const _: () = assert!(std::mem::size_of::<ShadeEntry>() == 8);

/// Bits of the light-set field.
pub const LIGHT_SET_BITS: u32 = 7;
/// Shift of the light-set field.
pub const LIGHT_SET_SHIFT: u32 = 25;

/// The shade key of a hit in light set `light_set` whose texture key is `texture_key` (bits 0–24, see
/// [`texture::shading_sort_key`]). Out-of-range fields saturate.
#[inline]
pub fn shade_key(light_set: u32, texture_key: u32) -> u32 {
    let light_set = light_set.min((1 << LIGHT_SET_BITS) - 1);
    (light_set << LIGHT_SET_SHIFT) | texture_key.min((1 << LIGHT_SET_SHIFT) - 1)
}

/// Packs a key and a ray-state index.
#[inline]
pub fn entry(key: u32, index: u32) -> ShadeEntry {
    (key as u64) << 32 | index as u64
}

/// The ray-state index of an entry.
#[inline]
pub fn index(e: ShadeEntry) -> u32 {
    e as u32
}

/// The sort key of an entry.
#[inline]
pub fn key(e: ShadeEntry) -> u32 {
    (e >> 32) as u32
}

/// Stable LSD radix sort of `entries` by key, 8 bits per pass, passes only over the bytes in which
/// some keys differ. `scratch` must be at least as long as `entries`.
pub fn radix_sort_by_key(entries: &mut [ShadeEntry], scratch: &mut [ShadeEntry]) {
    // The key bits that differ between entries: a byte where every key agrees needs no pass (all
    // zero, as in untextured queues, or all equal, as the UDIM tile and mip level often are).
    if entries.is_empty() {
        return;
    }
    let (or, and) = entries.iter().fold((0u32, u32::MAX), |(o, a), &e| (o | key(e), a & key(e)));
    let used = or ^ and;
    let scratch = &mut scratch[..entries.len()];
    let mut in_scratch = false;
    for pass in 0..4 {
        let shift = 32 + pass * 8;
        if (used >> (pass * 8)) & 0xff == 0 {
            continue;
        }
        let (src, dst): (&[u64], &mut [u64]) =
            if in_scratch { (&*scratch, &mut *entries) } else { (&*entries, &mut *scratch) };
        let mut counts = [0u32; 257];
        for &e in src {
            counts[((e >> shift) & 0xff) as usize + 1] += 1;
        }
        for d in 0..256 {
            counts[d + 1] += counts[d];
        }
        for &e in src {
            let d = ((e >> shift) & 0xff) as usize;
            dst[counts[d] as usize] = e;
            counts[d] += 1;
        }
        in_scratch = !in_scratch;
    }
    if in_scratch {
        entries.copy_from_slice(scratch);
    }
}

/// Sorts the shade queue by key, then groups it by material (a stable counting pass), recording the
/// start of each material's segment in `queues.material_starts`; `materials` is each path's hit
/// material.
pub(super) fn shade_queue(queues: &mut StageQueues, materials: &[u32]) {
    let StageQueues { shade, scratch, material_starts, .. } = queues;
    radix_sort_by_key(shade, scratch);
    group_by_material(shade, scratch, materials, material_starts);
}

/// Stable counting sort of `entries` by the material of their path (`materials[index]`, clamped to
/// the last bucket); `starts` (one more than the buckets) receives each bucket's first position.
/// The materials come from a per-path side table the sort-key pass fills in queue order: looking
/// them up through the hits here read a 20-byte hit and the triangle's material by sorted index,
/// twice per entry (tractor at 120×80, 8 spp: 62 k L1 data misses, 3.4 % of the render's).
pub fn group_by_material(
    entries: &mut [ShadeEntry],
    scratch: &mut [ShadeEntry],
    materials: &[u32],
    starts: &mut [u32],
) {
    let buckets = starts.len() - 1;
    let bucket = |e: ShadeEntry| (materials[index(e) as usize] as usize).min(buckets - 1);
    starts.fill(0);
    for &e in entries.iter() {
        starts[bucket(e) + 1] += 1;
    }
    for m in 0..buckets {
        starts[m + 1] += starts[m];
    }
    // Scatter into scratch with a moving cursor per bucket, then shift the starts back.
    let scratch = &mut scratch[..entries.len()];
    for &e in entries.iter() {
        let b = bucket(e);
        scratch[starts[b] as usize] = e;
        starts[b] += 1;
    }
    for m in (1..=buckets).rev() {
        starts[m] = starts[m - 1];
    }
    starts[0] = 0;
    entries.copy_from_slice(scratch);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radix_sort_is_a_stable_sort_by_key() {
        let mut x = 12345u32;
        let mut next = || {
            x = crate::sampler::hash_u32(x);
            x
        };
        for bits in [0u32, 8, 14, 25, 32] {
            let mask = if bits == 32 { u32::MAX } else { (1u32 << bits) - 1 };
            let mut v: Vec<u64> = (0..1000).map(|i| entry(next() & mask & 0xff00_ff0f, i)).collect();
            let mut expected = v.clone();
            expected.sort_by_key(|&e| key(e)); // stable
            let mut scratch = vec![0; v.len()];
            radix_sort_by_key(&mut v, &mut scratch);
            assert_eq!(v, expected, "{bits} key bits");
        }
    }

    #[test]
    fn bytes_shared_by_every_key_cost_no_pass_and_keep_order() {
        // Same UDIM tile and mip (byte 2 and 3 equal everywhere), varying Morton bytes.
        let mut v: Vec<u64> =
            (0..500u32).map(|i| entry(0x0312_0000 | (crate::sampler::hash_u32(i) & 0xffff), i)).collect();
        let mut expected = v.clone();
        expected.sort_by_key(|&e| key(e));
        let mut scratch = vec![0; v.len()];
        radix_sort_by_key(&mut v, &mut scratch);
        assert_eq!(v, expected);
        // Every key equal: nothing moves.
        let mut same: Vec<u64> = (0..100).map(|i| entry(0xdead_beef, i)).collect();
        let before = same.clone();
        radix_sort_by_key(&mut same, &mut scratch);
        assert_eq!(same, before);
    }

    #[test]
    fn key_layout_and_range_checks() {
        assert_eq!(shade_key(0, 0x1ff_ffff), 0x1ff_ffff);
        assert_eq!(shade_key(1, 0), 1 << 25);
        assert_eq!(shade_key(500, u32::MAX), u32::MAX);
        assert_eq!(entry(7, 9) >> 32, 7);
        assert_eq!(index(entry(7, 9)), 9);
    }

    #[test]
    fn grouping_by_material_is_stable_and_records_segment_starts() {
        // Paths 0..300 on materials 0..5 (4 and above share the last of 5 buckets), entries in a
        // shuffled key order.
        let materials: Vec<u32> = (0..300u32).map(|i| crate::sampler::hash_u32(i) % 7).collect();
        let mut v: Vec<u64> = (0..300u32).map(|i| entry(crate::sampler::hash_u32(i ^ 77) >> 8, i)).collect();
        radix_sort_by_key(&mut v, &mut vec![0; 300]);
        let before = v.clone();
        let mut starts = vec![0u32; 6];
        group_by_material(&mut v, &mut vec![0; 300], &materials, &mut starts);
        let bucket = |e: u64| materials[index(e) as usize].min(4) as usize;
        // Every entry exactly once, grouped by bucket, in key order inside a bucket (stable).
        let mut expected = before.clone();
        expected.sort_by_key(|&e| bucket(e));
        assert_eq!(v, expected);
        for b in 0..5 {
            let segment = &v[starts[b] as usize..starts[b + 1] as usize];
            assert!(segment.iter().all(|&e| bucket(e) == b), "bucket {b}");
            assert_eq!(segment.len(), before.iter().filter(|&&e| bucket(e) == b).count());
        }
        assert_eq!(starts[5], 300);
    }
}

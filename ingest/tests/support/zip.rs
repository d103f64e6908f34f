//! Zip repair for the fuzzer: a mutated package whose stored checksums still match reaches the
//! layer readers instead of stopping at the zip reader's CRC check.

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at.checked_add(4)?)?.try_into().ok()?))
}

/// CRC-32 (IEEE), as zip stores it.
fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

/// Recomputes the CRC of every stored entry of a zip file (in its local header and its
/// central-directory entry), so a mutated package's layers reach the layer readers instead of
/// failing the zip reader's checksum.
pub fn fix_zip_checksums(bytes: &mut [u8]) {
    let mut local = 0;
    while let Some(found) = bytes[local..].windows(4).position(|w| w == b"PK\x03\x04") {
        local += found;
        let (Some(size), Some(name), Some(extra)) =
            (u32_at(bytes, local + 18), bytes.get(local + 26..local + 28), bytes.get(local + 28..local + 30))
        else {
            return;
        };
        let data = local
            + 30
            + usize::from(u16::from_le_bytes([name[0], name[1]]))
            + usize::from(u16::from_le_bytes([extra[0], extra[1]]));
        let Some(content) = bytes.get(data..data.saturating_add(size as usize)) else { return };
        let crc = crc32(content).to_le_bytes();
        bytes[local + 14..local + 18].copy_from_slice(&crc);
        let cds: Vec<usize> = bytes
            .windows(4)
            .enumerate()
            .filter(|(i, w)| *w == b"PK\x01\x02" && u32_at(bytes, i + 42) == Some(local as u32))
            .map(|(i, _)| i)
            .collect();
        for cd in cds {
            bytes[cd + 16..cd + 20].copy_from_slice(&crc);
        }
        local += 4;
    }
}

#[test]
fn crc32_matches_the_standard_check_value() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
}

//! The byte-level encodings of a crate file: a bounded little-endian reader, LZ4 blocks and USD's
//! integer compression, each decoded the way openusd's reader decodes them so that the checks
//! built on them see exactly what the reader will.

/// Numbers far beyond any real count print in scientific notation (`6.1e18`), so a corrupt count
/// reads as absurd at a glance.
pub(super) fn big(n: u64) -> String {
    if n >= 1_000_000_000 {
        format!("{:.1e}", n as f64)
    } else {
        n.to_string()
    }
}

/// A cursor over `bytes[..end]`; every read is checked against `end`.
pub(super) struct Reader<'a> {
    bytes: &'a [u8],
    pub(super) pos: usize,
    end: usize,
}

impl<'a> Reader<'a> {
    /// A reader over `bytes[start..end]` (clamped to the file).
    pub(super) fn new(bytes: &'a [u8], start: usize, end: usize) -> Self {
        let end = end.min(bytes.len());
        Reader { bytes, pos: start, end }
    }

    pub(super) fn remaining(&self) -> usize {
        self.end.saturating_sub(self.pos)
    }

    /// The next `n` bytes.
    pub(super) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        if n > self.remaining() {
            return Err(format!(
                "{what} needs {} bytes at offset {} but only {} remain (truncated?)",
                big(n as u64),
                self.pos,
                self.remaining()
            ));
        }
        let slice = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(slice)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        Ok(self.take(N, what)?.try_into().expect("take returns N bytes"))
    }

    pub(super) fn u8(&mut self, what: &str) -> Result<u8, String> {
        Ok(self.array::<1>(what)?[0])
    }

    pub(super) fn u32(&mut self, what: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub(super) fn u64(&mut self, what: &str) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    pub(super) fn i64(&mut self, what: &str) -> Result<i64, String> {
        Ok(i64::from_le_bytes(self.array(what)?))
    }

    /// Moves to `pos`, which must lie inside the range.
    pub(super) fn seek(&mut self, pos: u64, what: &str) -> Result<(), String> {
        if pos > self.end as u64 {
            return Err(format!("{what} points to offset {} past the end ({})", big(pos), self.end));
        }
        self.pos = pos as usize;
        Ok(())
    }

    /// Checks that `count` elements of `size` bytes follow, before anything allocates them.
    pub(super) fn holds(&self, count: u64, size: u64, what: &str) -> Result<(), String> {
        match count.checked_mul(size) {
            Some(need) if need <= self.remaining() as u64 => Ok(()),
            _ => Err(format!(
                "{what} claims {} elements of {size} bytes at offset {}, but only {} bytes follow",
                big(count),
                self.pos,
                self.remaining()
            )),
        }
    }
}

/// The most an LZ4 block can expand: a match token plus its length bytes (each adding at most
/// 255) writes under 255 bytes per input byte, literals one per byte. The slack covers the
/// shortest blocks.
fn lz4_max_output(compressed: u64) -> u64 {
    compressed.saturating_mul(255).saturating_add(64)
}

/// Reads a compressed block as openusd does (`u64` compressed size, then the block whose first
/// byte counts LZ4 chunks) into a buffer of `capacity` bytes, the size the reader allocates.
///
/// The reader allocates both the compressed buffer and `capacity` before decompressing, so both
/// are bounded first: the compressed size by the bytes that follow, and `needed` (the fewest
/// decompressed bytes the claimed contents take; `capacity` is a fixed multiple of it) by what
/// that many compressed bytes can expand to.
pub(super) fn read_compressed(
    r: &mut Reader,
    capacity: u64,
    needed: u64,
    what: &str,
) -> Result<Vec<u8>, String> {
    let size = r.u64(what)?;
    r.holds(size, 1, &format!("{what} (compressed)"))?;
    if needed > lz4_max_output(size) {
        return Err(format!(
            "{what} claims at least {} bytes decompressed from {size} compressed bytes (LZ4 expands at most 255x)",
            big(needed)
        ));
    }
    let input = r.take(size as usize, what)?;
    let Some((&chunks, block)) = input.split_first() else {
        return Err(format!("{what}: empty compressed block"));
    };
    // openusd decodes single-chunk blocks only (it stops on a `todo!` otherwise); USD splits
    // blocks into chunks only past 2 GiB of input.
    if chunks != 0 {
        return Err(format!("{what}: block split into {chunks} LZ4 chunks, which the reader cannot decode"));
    }
    let mut out = vec![0u8; capacity as usize];
    let n = lz4_flex::block::decompress_into(block, &mut out)
        .map_err(|e| format!("{what}: corrupt LZ4 block ({e})"))?;
    out.truncate(n);
    Ok(out)
}

/// The buffer openusd sizes for `count` compressed integers: a 32-bit common value, 2 code bits
/// per integer and up to 4 bytes each (it uses 32-bit sizes even for 64-bit integers).
/// Saturating, so an absurd count fails the LZ4 bound instead of wrapping.
fn encoded_capacity(count: u64) -> u64 {
    if count == 0 {
        0
    } else {
        4u64.saturating_add(count.div_ceil(4)).saturating_add(count.saturating_mul(4))
    }
}

/// Reads `count` integers in USD's integer compression (LZ4 over: the most common delta, 2-bit
/// codes per value, then the deltas that are not the common one at 1, 2 or 4 bytes — 2, 4 or 8
/// for 64-bit integers).
///
/// openusd slices past the common value and the codes without checking the block holds them
/// (a panic when it does not): checked here always. The values themselves are decoded only when
/// `decode` (the caller needs them as indices); otherwise a short payload is left for the
/// reader, which reports it as an error.
pub(super) fn read_ints(
    r: &mut Reader,
    count: u64,
    wide: bool,
    decode: bool,
    what: &str,
) -> Result<Vec<i64>, String> {
    let common_size = if wide { 8 } else { 4 };
    let needed = if count == 0 { 0 } else { common_size + count.div_ceil(4) };
    let data = read_compressed(r, encoded_capacity(count), needed, what)?;
    if count == 0 {
        return Ok(Vec::new());
    }
    let (common_size, codes_len) = (common_size as usize, count.div_ceil(4) as usize);
    if data.len() < common_size + codes_len {
        return Err(format!(
            "{what}: {} integers need {} bytes of codes, the block holds {}",
            big(count),
            common_size + codes_len,
            data.len()
        ));
    }
    if !decode {
        return Ok(Vec::new());
    }
    decode_ints(&data, count as usize, wide).map_err(|e| format!("{what}: {e}"))
}

/// Decodes `count` integers from a decompressed block whose common value and codes are known to fit.
fn decode_ints(data: &[u8], count: usize, wide: bool) -> Result<Vec<i64>, String> {
    let common_size = if wide { 8 } else { 4 };
    let common = if wide {
        i64::from_le_bytes(data[..8].try_into().expect("8 bytes"))
    } else {
        i64::from(i32::from_le_bytes(data[..4].try_into().expect("4 bytes")))
    };
    let (codes, mut payload) = data[common_size..].split_at(count.div_ceil(4));
    let mut out = Vec::with_capacity(count);
    let mut value = 0i64;
    for i in 0..count {
        let code = (codes[i / 4] >> (2 * (i % 4))) & 3;
        // Delta widths per code: 32-bit integers use 1/2/4 bytes, 64-bit ones 2/4/8.
        let width = match (code, wide) {
            (0, _) => 0,
            (1, false) => 1,
            (2, false) | (1, true) => 2,
            (3, false) | (2, true) => 4,
            _ => 8,
        };
        if payload.len() < width {
            return Err(format!("integer {i} of {count}: payload ends early"));
        }
        let (bytes, rest) = payload.split_at(width);
        payload = rest;
        let delta = match width {
            0 => common,
            1 => i64::from(bytes[0] as i8),
            2 => i64::from(i16::from_le_bytes([bytes[0], bytes[1]])),
            4 => i64::from(i32::from_le_bytes(bytes.try_into().expect("4 bytes"))),
            _ => i64::from_le_bytes(bytes.try_into().expect("8 bytes")),
        };
        value = value.wrapping_add(delta);
        out.push(value);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Encodes `values` (32-bit) in USD's integer compression with common delta `common`, the
    /// way USD's writer lays it out, to test the decoder against hand-checked bytes.
    fn encode32(values: &[i32], common: i32) -> Vec<u8> {
        let mut out = common.to_le_bytes().to_vec();
        let mut codes = vec![0u8; values.len().div_ceil(4)];
        let mut payload = Vec::new();
        let mut prev = 0i32;
        for (i, &v) in values.iter().enumerate() {
            let d = v.wrapping_sub(prev);
            prev = v;
            let code = if d == common {
                0
            } else if i8::try_from(d).is_ok() {
                payload.push(d as i8 as u8);
                1
            } else if i16::try_from(d).is_ok() {
                payload.extend((d as i16).to_le_bytes());
                2
            } else {
                payload.extend(d.to_le_bytes());
                3
            };
            codes[i / 4] |= code << (2 * (i % 4));
        }
        out.extend(codes);
        out.extend(payload);
        out
    }

    fn block(raw: &[u8]) -> Vec<u8> {
        let compressed = lz4_flex::block::compress(raw);
        let mut bytes = ((compressed.len() + 1) as u64).to_le_bytes().to_vec();
        bytes.push(0);
        bytes.extend(compressed);
        bytes
    }

    #[test]
    fn integer_coding_round_trips_every_width() {
        let values = [0, 1, 2, 3, 4, -5, 300, 70_000, 70_001, -2_000_000_000];
        let bytes = block(&encode32(&values, 1));
        let mut r = Reader::new(&bytes, 0, bytes.len());
        let decoded = read_ints(&mut r, values.len() as u64, false, true, "test").unwrap();
        assert_eq!(decoded, values.iter().map(|&v| i64::from(v)).collect::<Vec<_>>());
        assert_eq!(r.remaining(), 0);
    }

    #[test]
    fn a_block_too_short_for_its_codes_is_an_error() {
        // 100 integers need 4 + 25 bytes of header and codes; 8 bytes hold far fewer.
        let bytes = block(&[0u8; 8]);
        let mut r = Reader::new(&bytes, 0, bytes.len());
        let e = read_ints(&mut r, 100, false, false, "ints").unwrap_err();
        assert!(e.contains("100 integers need 29 bytes of codes, the block holds 8"), "{e}");
    }

    #[test]
    fn a_capacity_beyond_lz4s_expansion_is_refused_before_allocating() {
        let bytes = block(&[1, 2, 3]);
        let mut r = Reader::new(&bytes, 0, bytes.len());
        let e = read_compressed(&mut r, 6_000_000_000_000_000_000, 6_000_000_000_000_000_000, "TOKENS")
            .unwrap_err();
        assert!(e.contains("claims at least 6.0e18 bytes decompressed from"), "{e}");
    }

    #[test]
    fn counts_beyond_the_bytes_that_follow_are_refused() {
        let bytes = [0u8; 16];
        let r = Reader::new(&bytes, 4, 16);
        assert!(r.holds(3, 4, "x").is_ok());
        let e = r.holds(u64::MAX / 2, 12, "points").unwrap_err();
        assert_eq!(e, "points claims 9.2e18 elements of 12 bytes at offset 4, but only 12 bytes follow");
    }
}

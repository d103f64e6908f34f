//! Mutations of layer files: byte-level ones for any format, and structure-aware ones that aim at
//! the counts, offsets and sizes of crate files (`.usdc`) and zip packages (`.usdz`), which
//! random bytes rarely hit.

use proptest::prelude::*;

/// Tokens of the usda grammar (and of what our normalizer rewrites), inserted to reach deeper states
/// of the parser than random bytes do.
pub const TOKENS: &[&str] = &[
    "def ",
    "over ",
    "class ",
    "Xform ",
    "Mesh ",
    "\"",
    "{",
    "}",
    "(",
    ")",
    "[",
    "]",
    "<",
    ">",
    "@",
    "@@@",
    "=",
    ",",
    ":",
    ".",
    "-",
    "1e39",
    "-1e39",
    "nan",
    "inf",
    ".5",
    "4294967296",
    "99999999999999999999",
    "-2147483649",
    "references = ",
    "payload = ",
    "inherits = ",
    "specializes = ",
    "variants = ",
    "variantSet \"v\" = ",
    "prepend ",
    "append ",
    "delete ",
    "subLayers = ",
    "offset = ",
    "scale = ",
    "instanceable = true",
    "int[] faceVertexIndices = ",
    "point3f[] points = ",
    "timeSamples = ",
    "float3 xformOp:translate = ",
    "uniform token[] xformOpOrder = ",
    "matrix4d ",
    "Vec3f",
    "PointFloat",
    "rel material:binding = ",
    "asset inputs:file = ",
    "</World>",
    "<../x>",
    "@./scene.usda@",
    "@scene.usdz[x.png]@",
    "#usda 1.0\n",
    "\n",
    " ",
    "\0",
    "\u{feff}",
    "é",
];

#[derive(Clone, Debug)]
pub enum Mutation {
    /// Flips bits of the byte at a relative position.
    Flip { at: f64, bits: u8 },
    /// Overwrites 4 bytes with a little-endian integer (counts, offsets, indices in usdc).
    Int { at: f64, value: u32 },
    /// Inserts a grammar token.
    Token { at: f64, token: usize },
    /// Removes a range.
    Delete { at: f64, len: usize },
    /// Copies a range elsewhere (repeats structure).
    Splice { from: f64, to: f64, len: usize },
    /// Cuts the file.
    Truncate { at: f64 },
    /// Crate files only: overwrites one of the `u64`s the reader trusts (the table of contents'
    /// offset, a section's start or size, the counts that open a section).
    Crate { target: usize, value: u64 },
    /// Zip packages only: overwrites a count, size or offset of the end-of-central-directory
    /// record, a central-directory entry or a local header, or cuts the central directory.
    Zip { target: usize, value: u32 },
}

pub fn mutation() -> impl Strategy<Value = Mutation> {
    let at = 0.0..1.0f64;
    let value64 = prop_oneof![
        Just(0u64),
        Just(u64::MAX),
        Just(1u64 << 62),
        Just(6_052_837_899_185_946_628),
        1..64u64,
        any::<u32>().prop_map(u64::from),
        any::<u64>(),
    ];
    let value32 = prop_oneof![Just(0u32), Just(u32::MAX), Just(0xffff), 1..64u32, any::<u32>()];
    prop_oneof![
        (at.clone(), 1..=255u8).prop_map(|(at, bits)| Mutation::Flip { at, bits }),
        (at.clone(), prop_oneof![Just(0u32), Just(u32::MAX), Just(0x7fff_ffff), 1..64u32, any::<u32>()])
            .prop_map(|(at, value)| Mutation::Int { at, value }),
        (at.clone(), 0..TOKENS.len()).prop_map(|(at, token)| Mutation::Token { at, token }),
        (at.clone(), 1..64usize).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (at.clone(), at.clone(), 1..256usize).prop_map(|(from, to, len)| Mutation::Splice { from, to, len }),
        at.prop_map(|at| Mutation::Truncate { at }),
        (any::<usize>(), value64).prop_map(|(target, value)| Mutation::Crate { target, value }),
        (any::<usize>(), value32).prop_map(|(target, value)| Mutation::Zip { target, value }),
    ]
}

fn position(at: f64, len: usize) -> usize {
    ((at * len as f64) as usize).min(len)
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(bytes.get(at..at.checked_add(8)?)?.try_into().ok()?))
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at.checked_add(4)?)?.try_into().ok()?))
}

/// Offsets of the `u64`s a crate reader trusts first, as far as the file still parses.
fn crate_targets(bytes: &[u8]) -> Vec<usize> {
    let mut targets = Vec::new();
    let Some(toc) = u64_at(bytes, 16).and_then(|t| usize::try_from(t).ok()) else { return targets };
    targets.push(16);
    targets.push(toc);
    let count = u64_at(bytes, toc).unwrap_or(0).min(16) as usize;
    for i in 0..count {
        let entry = toc + 8 + 32 * i + 16;
        targets.extend([entry, entry + 8]);
        if let Some(start) = u64_at(bytes, entry).and_then(|s| usize::try_from(s).ok()) {
            // A section opens with its counts (and, compressed, block sizes).
            targets.extend([start, start + 8, start + 16]);
        }
    }
    targets.retain(|&t| t.checked_add(8).is_some_and(|end| end <= bytes.len()));
    targets
}

/// (offset, width in bytes) of the counts, sizes and offsets of a zip file's records.
fn zip_fields(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut fields = Vec::new();
    let find = |sig: &[u8]| -> Vec<usize> {
        bytes.windows(4).enumerate().filter(|(_, w)| *w == sig).map(|(i, _)| i).collect()
    };
    if let Some(&eocd) = find(b"PK\x05\x06").last() {
        fields.extend([(eocd + 8, 2), (eocd + 10, 2), (eocd + 12, 4), (eocd + 16, 4), (eocd + 20, 2)]);
    }
    for cd in find(b"PK\x01\x02") {
        fields.extend([(cd + 20, 4), (cd + 24, 4), (cd + 28, 2), (cd + 30, 2), (cd + 42, 4)]);
    }
    for local in find(b"PK\x03\x04") {
        fields.extend([(local + 18, 4), (local + 22, 4), (local + 26, 2), (local + 28, 2)]);
    }
    fields.retain(|&(at, width)| at + width <= bytes.len());
    fields
}

pub fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let n = bytes.len();
    match *m {
        // In text, half the flips that would set the top bit keep the byte ASCII: invalid UTF-8
        // fails the whole layer at once, and the other half still tests that.
        Mutation::Flip { at, bits } if n > 0 => {
            let text = bytes.starts_with(b"#usda");
            let bits = if text && bits & 0x81 == 0x80 { bits & 0x7f } else { bits };
            bytes[position(at, n - 1)] ^= bits;
        }
        Mutation::Int { at, value } if n >= 4 => {
            let i = position(at, n - 4);
            bytes[i..i + 4].copy_from_slice(&value.to_le_bytes());
        }
        // Inserted in text; in binary files written over bytes in place, so the offsets that
        // follow stay valid and the mutation reaches past the header.
        Mutation::Token { at, token } if bytes.starts_with(b"#usda") => {
            let i = position(at, n);
            bytes.splice(i..i, TOKENS[token].bytes());
        }
        Mutation::Token { at, token } => {
            let token = TOKENS[token].as_bytes();
            let i = position(at, n.saturating_sub(token.len()));
            let end = (i + token.len()).min(n);
            bytes[i..end].copy_from_slice(&token[..end - i]);
        }
        Mutation::Delete { at, len } => {
            let i = position(at, n);
            bytes.drain(i..(i + len).min(n));
        }
        Mutation::Splice { from, to, len } => {
            let i = position(from, n);
            let chunk = bytes[i..(i + len).min(n)].to_vec();
            let j = position(to, n);
            bytes.splice(j..j, chunk);
        }
        Mutation::Truncate { at } => bytes.truncate(position(at, n)),
        Mutation::Crate { target, value } if bytes.starts_with(b"PXR-USDC") => {
            let targets = crate_targets(bytes);
            if !targets.is_empty() {
                let at = targets[target % targets.len()];
                bytes[at..at + 8].copy_from_slice(&value.to_le_bytes());
            }
        }
        Mutation::Zip { target, value } if bytes.starts_with(b"PK") => {
            let fields = zip_fields(bytes);
            // One target in eight cuts the central directory short instead.
            if target % 8 == 0 {
                if let Some(eocd) = bytes.windows(4).rposition(|w| w == b"PK\x05\x06") {
                    let cd = u32_at(bytes, eocd + 16).unwrap_or(0) as usize;
                    bytes.truncate(cd.saturating_add(value as usize % 64).min(bytes.len()));
                }
            } else if !fields.is_empty() {
                let (at, width) = fields[target % fields.len()];
                bytes[at..at + width].copy_from_slice(&value.to_le_bytes()[..width]);
            }
        }
        _ => {}
    }
}

//! Crate files from the fuzz corpus (written by usd-core), broken one structure at a time.

use super::coding::{read_ints, Reader};
use super::*;

fn corpus(name: &str) -> Vec<u8> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets/fuzz/corpus");
    std::fs::read(dir.join(name)).unwrap()
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
}

/// (name, offset of the entry's start field, start, end) per table-of-contents entry.
fn toc(bytes: &[u8]) -> Vec<(String, usize, u64, u64)> {
    let toc = u64_at(bytes, 16) as usize;
    (0..u64_at(bytes, toc) as usize)
        .map(|i| {
            let entry = toc + 8 + 32 * i;
            let name = &bytes[entry..entry + 16];
            let name =
                String::from_utf8(name[..name.iter().position(|&b| b == 0).unwrap()].to_vec()).unwrap();
            let start = u64_at(bytes, entry + 16);
            (name, entry + 16, start, start + u64_at(bytes, entry + 24))
        })
        .collect()
}

fn section_reader<'a>(bytes: &'a [u8], name: &str) -> Reader<'a> {
    let (_, _, start, end) = toc(bytes).into_iter().find(|s| s.0 == name).unwrap();
    Reader::new(bytes, start as usize, end as usize)
}

/// Appends `body` and points section `name` at it.
fn replace_section(bytes: &mut Vec<u8>, name: &str, body: &[u8]) {
    let (_, entry, _, _) = toc(bytes).into_iter().find(|s| s.0 == name).unwrap();
    let start = bytes.len() as u64;
    bytes.extend_from_slice(body);
    bytes[entry..entry + 8].copy_from_slice(&start.to_le_bytes());
    bytes[entry + 8..entry + 16].copy_from_slice(&(body.len() as u64).to_le_bytes());
}

/// A compressed block as the writer stores it: size, chunk count 0, LZ4 block.
fn block(raw: &[u8]) -> Vec<u8> {
    let compressed = lz4_flex::block::compress(raw);
    let mut out = ((compressed.len() + 1) as u64).to_le_bytes().to_vec();
    out.push(0);
    out.extend(compressed);
    out
}

/// 32-bit integer coding with common delta 0 and every other delta stored in 4 bytes.
fn encoded(values: &[i64]) -> Vec<u8> {
    let mut raw = 0i32.to_le_bytes().to_vec();
    let mut codes = vec![0u8; values.len().div_ceil(4)];
    let mut payload = Vec::new();
    let mut prev = 0i64;
    for (i, &v) in values.iter().enumerate() {
        let delta = v.wrapping_sub(prev) as i32;
        prev = v;
        if delta != 0 {
            codes[i / 4] |= 3 << (2 * (i % 4));
            payload.extend(delta.to_le_bytes());
        }
    }
    raw.extend(codes);
    raw.extend(payload);
    block(&raw)
}

fn decode(r: &mut Reader, count: u64) -> Vec<i64> {
    read_ints(r, count, false, true, "test").unwrap()
}

/// `bytes` with field `field`'s value rep replaced by `rep` (FIELDS rewritten at the end).
fn with_field_rep(mut bytes: Vec<u8>, field: usize, rep: u64) -> Vec<u8> {
    let mut r = section_reader(&bytes, "FIELDS");
    let count = r.u64("").unwrap();
    let names = decode(&mut r, count);
    let mut reps = read_compressed(&mut r, count * 8, 0, "").unwrap();
    reps[8 * field..8 * field + 8].copy_from_slice(&rep.to_le_bytes());
    let mut body = count.to_le_bytes().to_vec();
    body.extend(encoded(&names));
    body.extend(block(&reps));
    replace_section(&mut bytes, "FIELDS", &body);
    bytes
}

const DICTIONARY_REP: u64 = 31 << 48;

#[test]
fn layers_written_by_usd_core_pass() {
    for name in ["scene.usdc", "arcs.usdc"] {
        check(&corpus(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn an_absurd_array_count_is_refused_before_anything_allocates() {
    let mut bytes = corpus("scene.usdc");
    // The cube's points, (-1,-1,-1), (1,-1,-1), ..., stored after their u64 count of 8.
    let points: Vec<u8> = [-1f32, -1., -1., 1., -1., -1.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let at = bytes.windows(points.len()).position(|w| w == points).unwrap();
    assert_eq!(u64_at(&bytes, at - 8), 8);
    bytes[at - 8..at].copy_from_slice(&6_052_837_899_185_946_628u64.to_le_bytes());
    let e = check(&bytes).unwrap_err();
    assert_eq!(e.section, "FIELDS");
    let expected = format!(
        "(default): array claims 6.1e18 elements of 12 bytes at offset {at}, but only {} bytes follow",
        bytes.len() - at
    );
    assert!(e.message.starts_with("value of field ") && e.message.ends_with(&expected), "{e}");
}

#[test]
fn a_truncated_file_is_refused() {
    let bytes = corpus("scene.usdc");
    let e = check(&bytes[..bytes.len() / 2]).unwrap_err();
    assert_eq!(e.section, "TOC");
    assert!(e.message.contains(&format!("outside the {}-byte file (truncated?)", bytes.len() / 2)), "{e}");
    let e = check(&bytes[..20]).unwrap_err();
    assert_eq!(e.to_string(), "bootstrap: header needs 32 bytes at offset 0 but only 20 remain (truncated?)");
}

#[test]
fn a_section_past_the_end_is_refused() {
    let mut bytes = corpus("scene.usdc");
    let (_, entry, _, _) = toc(&bytes).into_iter().find(|s| s.0 == "SPECS").unwrap();
    bytes[entry + 8..entry + 16].copy_from_slice(&u64::MAX.to_le_bytes());
    let e = check(&bytes).unwrap_err();
    assert_eq!(e.section, "TOC");
    assert!(e.message.starts_with("section SPECS (1.8e19 bytes at offset"), "{e}");
}

#[test]
fn old_crate_versions_the_reader_cannot_decode_are_refused() {
    let mut bytes = corpus("scene.usdc");
    bytes[8..11].copy_from_slice(&[0, 3, 0]);
    assert_eq!(
        check(&bytes).unwrap_err().to_string(),
        "bootstrap: crate version 0.3.0 cannot be read (versions 0.4.0 to 0.12.0 can)"
    );
}

#[test]
fn a_string_naming_a_missing_token_is_refused() {
    let mut bytes = corpus("scene.usdc");
    let (_, _, start, _) = toc(&bytes).into_iter().find(|s| s.0 == "STRINGS").unwrap();
    let start = start as usize;
    assert!(u64_at(&bytes, start) > 0);
    bytes[start + 8..start + 12].copy_from_slice(&u32::MAX.to_le_bytes());
    let e = check(&bytes).unwrap_err();
    assert_eq!(e.section, "STRINGS");
    assert!(e.message.starts_with("string 0 names token 4294967295 of "), "{e}");
}

#[test]
fn overlapping_path_jumps_are_refused() {
    let mut bytes = corpus("scene.usdc");
    let mut r = section_reader(&bytes, "PATHS");
    let path_count = r.u64("").unwrap();
    let count = r.u64("").unwrap();
    let (indices, elements, mut jumps) =
        (decode(&mut r, count), decode(&mut r, count), decode(&mut r, count));
    // Entry 1 (the first root prim) gets a sibling at entry 2, which is also its first child:
    // the reader would build that subtree twice (and, nested, exponentially often).
    assert_eq!(jumps[0], -1, "the pseudo-root has only a child");
    jumps[1] = 1;
    let mut body = path_count.to_le_bytes().to_vec();
    body.extend(count.to_le_bytes());
    for part in [&indices, &elements, &jumps] {
        body.extend(encoded(part));
    }
    replace_section(&mut bytes, "PATHS", &body);
    assert_eq!(check(&bytes).unwrap_err().to_string(), "PATHS: entry 2 is reached twice (overlapping jumps)");
}

/// A dictionary at the end of `bytes` with one entry (keyed by string 0) whose value is `value`.
fn append_dictionary(bytes: &mut Vec<u8>, value: impl Fn(u64) -> u64) -> u64 {
    let at = bytes.len() as u64;
    bytes.extend(1u64.to_le_bytes());
    bytes.extend(0u32.to_le_bytes());
    bytes.extend(8i64.to_le_bytes());
    bytes.extend(value(at).to_le_bytes());
    at
}

#[test]
fn a_dictionary_containing_itself_is_refused() {
    let mut bytes = corpus("scene.usdc");
    let at = append_dictionary(&mut bytes, |at| DICTIONARY_REP | at);
    let e = check(&with_field_rep(bytes, 0, DICTIONARY_REP | at)).unwrap_err();
    assert_eq!(e.section, "FIELDS");
    assert!(e.message.starts_with("value of field 0 ("), "{e}");
    assert!(e.message.ends_with(&format!("): value at offset {at} contains itself")), "{e}");
}

#[test]
fn dictionaries_nested_too_deep_are_refused() {
    let mut bytes = corpus("scene.usdc");
    // Each dictionary's value is the next one, 100 deep; the last holds an inlined empty one.
    let mut outer = 0;
    for i in 0..100 {
        let at = append_dictionary(&mut bytes, |at| {
            if i < 99 {
                DICTIONARY_REP | (at + 28)
            } else {
                DICTIONARY_REP | 1 << 62
            }
        });
        if i == 0 {
            outer = at;
        }
    }
    let e = check(&with_field_rep(bytes, 0, DICTIONARY_REP | outer)).unwrap_err();
    assert!(e.message.ends_with("): values nest deeper than 64 levels"), "{e}");
}

#[test]
fn dictionaries_nested_a_few_levels_pass() {
    let mut bytes = corpus("scene.usdc");
    let mut outer = 0;
    for i in 0..10 {
        let at = append_dictionary(&mut bytes, |at| {
            if i < 9 {
                DICTIONARY_REP | (at + 28)
            } else {
                DICTIONARY_REP | 1 << 62
            }
        });
        if i == 0 {
            outer = at;
        }
    }
    check(&with_field_rep(bytes, 0, DICTIONARY_REP | outer)).unwrap();
}

/// `CRATE_CHECK_SURVEY=DIR cargo test --release -p ingest --lib crate_check::tests::survey --
/// --ignored --nocapture` checks every crate file under DIR and prints what the check costs.
#[test]
#[ignore = "needs CRATE_CHECK_SURVEY=<folder of USD assets>"]
fn survey() {
    let root = std::env::var("CRATE_CHECK_SURVEY").expect("CRATE_CHECK_SURVEY");
    let mut stack = vec![std::path::PathBuf::from(root)];
    let mut files = Vec::new();
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if std::fs::read(&path).is_ok_and(|b| b.starts_with(MAGIC)) {
                files.push(path);
            }
        }
    }
    files.sort();
    for path in files {
        let bytes = std::fs::read(&path).unwrap();
        let runs = 20;
        let start = std::time::Instant::now();
        for _ in 0..runs {
            check(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
        let ms = start.elapsed().as_secs_f64() * 1e3 / runs as f64;
        println!("{:8.3} ms {:9} bytes {}", ms, bytes.len(), path.display());
    }
}

/// PATHS rewritten as one chain of `depth` prims under the pseudo-root, all named by token 1.
fn with_path_chain(depth: usize) -> Vec<u8> {
    let mut bytes = corpus("scene.usdc");
    let count = depth + 1;
    let indices: Vec<i64> = (0..count as i64).collect();
    let elements = vec![1i64; count];
    let mut jumps = vec![-1i64; count];
    jumps[depth] = -2;
    let mut body = (count as u64).to_le_bytes().to_vec();
    body.extend((count as u64).to_le_bytes());
    for part in [&indices, &elements, &jumps] {
        body.extend(encoded(part));
    }
    replace_section(&mut bytes, "PATHS", &body);
    bytes
}

#[test]
fn a_namespace_deeper_than_the_limit_is_refused() {
    let e = check(&with_path_chain(MAX_PATH_DEPTH as usize + 1)).unwrap_err();
    assert_eq!(e.to_string(), "PATHS: paths nest deeper than 256 levels");
    // At the limit the tree itself passes (the specs then name paths the chain does not hold,
    // which the reader handles).
    let e = check(&with_path_chain(MAX_PATH_DEPTH as usize));
    assert!(e.as_ref().map_or_else(|e| e.section != "PATHS", |_| true), "{e:?}");
}

/// A triangle whose points are time-sampled at 1 (x up to 1) and 2 (x up to 2), startTimeCode 1,
/// written by usd-core as crate `version` (`USD_WRITE_NEW_USDC_FILES_AS_VERSION`).
fn time_sampled(version: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(format!("src/usd/compat/crate_check/testdata/time_samples_{}.usdc", version.replace('.', "_")))
}

/// The largest x of the triangle's world points, ingested at `frame`.
fn max_x(path: &std::path::Path, frame: f64) -> f32 {
    let options = crate::usd::LoadOptions { frame: Some(frame), ..Default::default() };
    let scene = crate::usd::load(path, &options).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let mesh = scene.meshes.iter().find(|m| m.path == "/Tri").expect("/Tri is drawn");
    mesh.positions.iter().map(|p| p.x).fold(f32::NEG_INFINITY, f32::max)
}

#[test]
fn time_sample_times_of_old_crate_files_are_rewritten_in_the_layout_openusd_reads() {
    for version in ["0.4.0", "0.6.0"] {
        let bytes = std::fs::read(time_sampled(version)).unwrap();
        let repaired = repair(&bytes).unwrap_or_else(|| panic!("{version}: nothing repaired"));
        // Only the times rep changes in place; the copy goes after everything else.
        assert!(repaired.len() > bytes.len(), "{version}");
        let changed = repaired[..bytes.len()].iter().zip(&bytes).filter(|(a, b)| a != b).count();
        assert!(changed <= 8, "{version}: {changed} bytes changed");
        check(&repaired).unwrap();
        // Both samples decode (openusd alone rejects them: 'Invalid time samples count').
        assert_eq!(max_x(&time_sampled(version), 1.0), 1.0, "{version}");
        assert_eq!(max_x(&time_sampled(version), 2.0), 2.0, "{version}");
        assert_eq!(max_x(&time_sampled(version), 1.5), 1.5, "{version}: linear between the samples");
    }
}

#[test]
fn crate_files_openusd_reads_as_written_are_not_rewritten() {
    let bytes = std::fs::read(time_sampled("0.8.0")).unwrap();
    assert!(repair(&bytes).is_none());
    assert_eq!(max_x(&time_sampled("0.8.0"), 2.0), 2.0);
}

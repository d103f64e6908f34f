//! Replays the coverage-guided fuzz targets' inputs (`ingest/fuzz`, run by `scripts/fuzz.sh`)
//! through the functions the targets call, without libFuzzer, so CI checks them on every run:
//!
//! - `ingest/fuzz/corpus/<target>/`: the committed seeds, small files from tests/assets (the
//!   texture seeds start with the byte that picks their decoder). Each must be accepted: a seed
//!   the reader refuses would only fuzz its error path.
//! - `ingest/fuzz/regressions/<target>/`: inputs libFuzzer found a panic with, kept after the
//!   fix (named after the bug). Errors are fine; a panic (or a reader panic, which
//!   `fuzz_entry` re-raises) fails the test with the file's name.

use ingest::fuzz_entry;
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};

type Entry = fn(&[u8]) -> Result<(), String>;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz")
}

/// The files of `dir`, sorted; none if it does not exist.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries.map(|e| e.expect("readable directory entry").path()).collect(),
        Err(_) => Vec::new(),
    };
    files.sort();
    files
}

/// Runs `entry` on `file`: the panic message if it panicked, else its result.
fn run(entry: Entry, file: &Path) -> Result<Result<(), String>, String> {
    let bytes = std::fs::read(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    panic::catch_unwind(AssertUnwindSafe(|| entry(&bytes))).map_err(|payload| {
        payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default()
    })
}

/// Every seed of `target` is accepted and every regression input of it gives no panic; returns
/// the number of files replayed.
fn replay(target: &str, entry: Entry) -> usize {
    let seeds = files(&fuzz_dir().join("corpus").join(target));
    assert!(!seeds.is_empty(), "no seeds in ingest/fuzz/corpus/{target}");
    let regressions = files(&fuzz_dir().join("regressions").join(target));
    let mut failures = Vec::new();
    for seed in &seeds {
        match run(entry, seed) {
            Ok(Ok(())) => {}
            Ok(Err(e)) => failures.push(format!("seed {} refused: {e}", seed.display())),
            Err(p) => failures.push(format!("seed {} panicked: {p}", seed.display())),
        }
    }
    for input in &regressions {
        if let Err(p) = run(entry, input) {
            failures.push(format!("regression {} panicked: {p}", input.display()));
        }
    }
    assert!(failures.is_empty(), "{target}:\n{}", failures.join("\n"));
    seeds.len() + regressions.len()
}

#[test]
fn usda_corpus_replays() {
    assert!(replay("usda", fuzz_entry::usda) >= 3);
}

#[test]
fn usdc_corpus_replays() {
    assert!(replay("usdc", fuzz_entry::usdc) >= 2);
}

#[test]
fn usdz_corpus_replays() {
    assert!(replay("usdz", fuzz_entry::usdz) >= 2);
}

#[test]
fn abc_corpus_replays() {
    assert!(replay("abc", fuzz_entry::abc) >= 2);
}

#[test]
fn mtlx_corpus_replays() {
    assert!(replay("mtlx", fuzz_entry::mtlx) >= 1);
}

#[test]
fn texture_decode_corpus_replays() {
    assert!(replay("texture_decode", fuzz_entry::texture_decode) >= 7);
}

/// The entries refuse garbage with the reader's error, naming the file, instead of accepting it:
/// the replay's "accepted" would mean nothing if they swallowed every input.
#[test]
fn fuzz_entries_refuse_garbage_with_named_errors() {
    let garbage = b"\x00\x01not a layer\xff";
    let usda = fuzz_entry::usda(garbage).unwrap_err();
    assert!(usda.contains("layer.usda"), "{usda}");
    let usdc = fuzz_entry::usdc(garbage).unwrap_err();
    assert!(usdc.contains("layer.usdc"), "{usdc}");
    let mtlx = fuzz_entry::mtlx(b"<notmaterialx/>").unwrap_err();
    assert!(mtlx.contains("doc.mtlx") && mtlx.contains("not <materialx>"), "{mtlx}");
    let abc = fuzz_entry::abc(garbage).unwrap_err();
    assert!(abc.contains("archive.abc") && abc.contains("not a readable Alembic archive"), "{abc}");
    let png = fuzz_entry::texture_decode(b"\x00\x89PNG\r\n\x1a\nshort").unwrap_err();
    assert!(png.contains("fuzz.png"), "{png}");
}

/// A 4 KiB crate file libFuzzer found (`usdc`, a timeout): its PATHS tree gives one path index to
/// two entries. usd-core refuses it ("Corrupt path index"); openusd composed it and its instancing
/// queries ran for minutes. The crate check refuses it before composition, naming the entry.
#[test]
fn a_crate_file_repeating_a_path_index_is_refused_at_once() {
    let file = fuzz_dir().join("regressions/usdc/corrupt-path-index-repeated.usdc");
    let bytes = std::fs::read(&file).unwrap();
    let e = fuzz_entry::usdc(&bytes).unwrap_err();
    assert!(e.contains("PATHS: entry 12 names path 6 again (a corrupt path index)"), "{e}");
}

//! Fuzzes the layer readers (usda tokenizer/parser with our normalizer, usdc crate files, usdz packages)
//! and everything ingest does with what they return: no input may panic, hang or allocate without bound;
//! it either loads or fails with an error that names the file.
//!
//! cargo-fuzz needs a nightly compiler, which this machine does not have, so the fuzzer is proptest
//! driving structure-aware mutations of a seed corpus (tests/assets/fuzz/corpus, written by
//! make_corpus.py). Each case copies the corpus to a temporary folder (the seeds reference each other),
//! mutates one file and ingests it. `FUZZ_CASES` sets the number of cases (default 200, what CI runs);
//! `FUZZ_CASES=20000 cargo test --release -p ingest --test fuzz_layers` is the long run. A failing input
//! is written to target/fuzz-failures/; copy it to tests/assets/fuzz/regressions/ so every run replays it.

use ingest::usd::{self, LoadOptions};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets/fuzz")
}

/// The seed files, in a fixed order so a case's seed index is reproducible.
fn corpus() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(fuzz_dir().join("corpus")).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    files
}

/// Tokens of the usda grammar (and of what our normalizer rewrites), inserted to reach deeper states
/// of the parser than random bytes do.
const TOKENS: &[&str] = &[
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
enum Mutation {
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
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let at = 0.0..1.0f64;
    prop_oneof![
        (at.clone(), 1..=255u8).prop_map(|(at, bits)| Mutation::Flip { at, bits }),
        (at.clone(), prop_oneof![Just(0u32), Just(u32::MAX), Just(0x7fff_ffff), 1..64u32, any::<u32>()])
            .prop_map(|(at, value)| Mutation::Int { at, value }),
        (at.clone(), 0..TOKENS.len()).prop_map(|(at, token)| Mutation::Token { at, token }),
        (at.clone(), 1..64usize).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (at.clone(), at.clone(), 1..256usize).prop_map(|(from, to, len)| Mutation::Splice { from, to, len }),
        at.prop_map(|at| Mutation::Truncate { at }),
    ]
}

fn position(at: f64, len: usize) -> usize {
    ((at * len as f64) as usize).min(len)
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let n = bytes.len();
    match *m {
        Mutation::Flip { at, bits } if n > 0 => bytes[position(at, n - 1)] ^= bits,
        Mutation::Int { at, value } if n >= 4 => {
            let i = position(at, n - 4);
            bytes[i..i + 4].copy_from_slice(&value.to_le_bytes());
        }
        Mutation::Token { at, token } => {
            let i = position(at, n);
            bytes.splice(i..i, TOKENS[token].bytes());
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
        _ => {}
    }
}

/// Ingests `file` as the binary would (lenient, so a broken sibling does not end the case early, and at
/// subdivision level 1 to keep cases fast). Returns whether it loaded, or the panic message if ingest
/// panicked.
fn ingest_without_panic(file: &Path) -> Result<bool, String> {
    let mut options = LoadOptions { lenient: true, ..LoadOptions::default() };
    options.subdiv.forced_level = Some(1);
    let outcome = panic::catch_unwind(AssertUnwindSafe(|| match usd::load(file, &options) {
        // Packing walks every index the reader produced; a bad one must be an error, not a panic.
        Ok(scene) => ingest::pack::pack(&scene).is_ok(),
        Err(_) => false,
    }));
    outcome.map_err(|payload| {
        payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default()
    })
}

fn save_failure(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fuzz-failures");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn mutated_layers_load_or_fail_cleanly() {
    let seeds = corpus();
    assert!(seeds.len() >= 5, "corpus missing: run tests/assets/fuzz/make_corpus.py");
    let cases = std::env::var("FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(200);
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let strategy = (0..seeds.len(), prop::collection::vec(mutation(), 1..6));
    // The default hook would print every caught panic; the failure message carries it instead.
    let hook = panic::take_hook();
    panic::set_hook(Box::new(|_| {}));
    let loaded = std::cell::Cell::new(0u32);
    let result = runner.run(&strategy, |(seed, mutations)| {
        let dir = tempfile::tempdir().unwrap();
        for file in &seeds {
            std::fs::copy(file, dir.path().join(file.file_name().unwrap())).unwrap();
        }
        let target = dir.path().join(seeds[seed].file_name().unwrap());
        let mut bytes = std::fs::read(&target).unwrap();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        std::fs::write(&target, &bytes).unwrap();
        match ingest_without_panic(&target) {
            Ok(true) => loaded.set(loaded.get() + 1),
            Ok(false) => {}
            Err(message) => {
                let saved = save_failure(&target.file_name().unwrap().to_string_lossy(), &bytes);
                let message = format!("panic `{message}`; input saved to {}", saved.display());
                return Err(TestCaseError::fail(message));
            }
        }
        Ok(())
    });
    panic::set_hook(hook);
    if let Err(e) = result {
        panic!("{e}");
    }
    // Mutations that still parse reach composition, tessellation and packing; a fuzzer whose inputs
    // all fail at the first token would test only the tokenizer.
    let loaded = loaded.get();
    eprintln!("fuzz: {cases} cases, {loaded} loaded and packed");
    assert!(loaded * 10 >= cases, "only {loaded} of {cases} mutated inputs loaded");
}

/// Inputs that once broke ingest, replayed in every run next to the corpus they came from.
#[test]
fn regressions_fail_cleanly() {
    let dir = fuzz_dir().join("regressions");
    let Ok(entries) = std::fs::read_dir(&dir) else { return };
    for entry in entries {
        let path = entry.unwrap().path();
        let work = tempfile::tempdir().unwrap();
        for file in corpus() {
            std::fs::copy(&file, work.path().join(file.file_name().unwrap())).unwrap();
        }
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        // Regression files are named `<n>-<seed file name>` so they replace the seed they mutate.
        let seed_name = name.split_once('-').map(|(_, s)| s.to_string()).unwrap_or(name);
        let target = work.path().join(seed_name);
        std::fs::copy(&path, &target).unwrap();
        assert!(ingest_without_panic(&target).is_ok(), "{} panics", path.display());
    }
}

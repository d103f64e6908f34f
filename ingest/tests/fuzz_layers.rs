//! Fuzzes the layer readers (usda tokenizer/parser with our normalizer, usdc crate files with our
//! crate check, usdz packages) and everything ingest does with what they return: no input may
//! panic, hang or allocate without bound; it either loads or fails with an error that names the
//! file.
//!
//! cargo-fuzz needs a nightly compiler, which this machine does not have, so the fuzzer is proptest
//! driving structure-aware mutations (see `support/mutate.rs`) of a seed corpus
//! (tests/assets/fuzz/corpus, written by make_corpus.py). Each case copies the corpus to a
//! temporary folder (the seeds reference each other), mutates one file and ingests it.
//!
//! - `FUZZ_CASES` sets the number of cases (default 2000, what CI runs: about 15 s).
//! - `FUZZ_SEED` seeds the generator (default fixed, so CI runs the same cases every time):
//!   `FUZZ_SEED=7 FUZZ_CASES=5000 cargo test --release -p ingest --test integration fuzz_layers` is a long run.
//! - `FUZZ_VERBOSE=1` prints every error the mutated inputs give (to review their messages).
//! - A failing input is written to target/fuzz-failures/ (after an abort, the input it died on is
//!   the newest `last-case-*` there); copy it to
//!   tests/assets/fuzz/regressions/ as `<name>-<seed file name>` (it replaces that seed in a copy
//!   of the corpus) so every run replays it.
//!
//! Besides panics (and openusd panics, which `usd::load` reports as internal errors), a case fails
//! when one allocation exceeds [`LARGEST_ALLOCATION`] (the seeds are a few kilobytes, so that is a
//! count the readers trusted) or when it takes longer than [`SLOWEST_CASE`]; a case still running
//! after [`HANG`] ends the run with its input saved as `hang-*`.

use crate::support::mutate::{apply, mutation};
use crate::support::zip::fix_zip_checksums;
use ingest::usd::{self, LoadOptions, UsdErrorKind};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::alloc::{GlobalAlloc, Layout, System};
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Largest single allocation a case may make. Corpus files are under 5 KB; the biggest honest
/// allocations (scene, BVH, blob at subdivision level 1) stay under a few MiB.
const LARGEST_ALLOCATION: usize = 256 << 20;

/// Longest a case may take (a hang shows up as the slowest case, or as the test never ending).
const SLOWEST_CASE: Duration = Duration::from_secs(20);

/// A case still running after this is taken to hang.
const HANG: Duration = Duration::from_secs(120);

/// Seed used when `FUZZ_SEED` is unset.
const DEFAULT_SEED: u64 = 0x5eed_0007;

/// The system allocator, recording the largest request made since [`take_largest`].
struct Tracking;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards every call unchanged to `System`, which upholds `GlobalAlloc`'s contract;
// the atomic bookkeeping neither allocates nor touches the memory.
unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract for `alloc` is passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: as for `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by `System` with `layout` (every allocation goes through it).
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        // SAFETY: as for `dealloc`; `new_size` is the caller's, passed on.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Tracking = Tracking;

fn take_largest() -> usize {
    LARGEST.swap(0, Ordering::Relaxed)
}

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

/// How ingesting one input went.
enum Outcome {
    Loaded,
    Failed,
    /// A panic, in ingest or (reported as an internal error) in the USD reader.
    Panicked(String),
}

/// Ingests `file` as the binary would (lenient, so a broken sibling does not end the case early, and at
/// subdivision level 1 to keep cases fast).
fn ingest(file: &Path) -> Outcome {
    let mut options = LoadOptions { lenient: true, ..LoadOptions::default() };
    options.subdiv.forced_level = Some(1);
    let outcome = panic::catch_unwind(AssertUnwindSafe(|| match usd::load(file, &options) {
        // Packing walks every index the reader produced; a bad one must be an error, not a panic.
        Ok(scene) => Ok(ingest::pack::pack(&scene).is_ok()),
        Err(e) if matches!(e.kind(), UsdErrorKind::Internal(_)) => Err(e.to_string()),
        Err(e) => {
            // Every error names the layer it is about (the mutated one or a sibling it reaches).
            assert!(e.to_string().contains(".usd"), "error names no layer: {e}");
            if std::env::var_os("FUZZ_VERBOSE").is_some() {
                eprintln!("fuzz-error: {e}");
            }
            Ok(false)
        }
    }));
    match outcome {
        Ok(Ok(true)) => Outcome::Loaded,
        Ok(Ok(false)) => Outcome::Failed,
        Ok(Err(internal)) => Outcome::Panicked(internal),
        Err(payload) => Outcome::Panicked(
            payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default(),
        ),
    }
}

fn save_failure(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fuzz-failures");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// The generator's seed: `FUZZ_SEED` or [`DEFAULT_SEED`], spread over ChaCha's 32 seed bytes.
fn rng() -> (u64, TestRng) {
    let seed = std::env::var("FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(DEFAULT_SEED);
    let mut bytes = [0u8; 32];
    for (i, chunk) in bytes.chunks_mut(8).enumerate() {
        chunk.copy_from_slice(
            &seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(i as u32 * 16).to_le_bytes(),
        );
    }
    (seed, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

#[test]
fn mutated_layers_load_or_fail_cleanly() {
    let seeds = corpus();
    assert!(seeds.len() >= 6, "corpus missing: run tests/assets/fuzz/make_corpus.py");
    let cases = std::env::var("FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(2000);
    let (fuzz_seed, rng) = rng();
    let config = Config { cases, failure_persistence: None, max_shrink_iters: 256, ..Config::default() };
    let mut runner = TestRunner::new_with_rng(config, rng);
    // One seed file, one to three mutations (stacking more leaves almost nothing loadable, and a
    // case that fails at the header tests only the header), and whether to repair zip checksums
    // afterwards (so mutated layers inside packages reach the layer readers).
    let strategy = (0..seeds.len(), prop::collection::vec(mutation(), 1..4), any::<bool>());
    // The default hook would print every caught panic; the failure message carries it instead.
    let hook = panic::take_hook();
    panic::set_hook(Box::new(|_| {}));
    let loaded = std::cell::Cell::new(0u32);
    // (cases, loaded) per seed file, printed at the end.
    let per_seed = std::cell::RefCell::new(vec![(0u32, 0u32); seeds.len()]);
    let slowest = std::cell::Cell::new(Duration::ZERO);
    let result = runner.run(&strategy, |(seed, mutations, fix_checksums)| {
        let dir = tempfile::tempdir().unwrap();
        for file in &seeds {
            std::fs::copy(file, dir.path().join(file.file_name().unwrap())).unwrap();
        }
        let target = dir.path().join(seeds[seed].file_name().unwrap());
        let mut bytes = std::fs::read(&target).unwrap();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        if fix_checksums {
            fix_zip_checksums(&mut bytes);
        }
        std::fs::write(&target, &bytes).unwrap();
        // An abort (stack overflow, failed allocation) ends the process before any report: the
        // input it died on is the last one written here.
        save_failure(&format!("last-case-{}", seeds[seed].file_name().unwrap().to_string_lossy()), &bytes);
        take_largest();
        let start = Instant::now();
        // On its own thread, so a case that never returns (a reader looping) fails the run after
        // HANG instead of stalling it; the thread keeps the default 2 MiB stack.
        let (sender, receiver) = std::sync::mpsc::channel();
        let input = target.clone();
        std::thread::spawn(move || sender.send(ingest(&input)));
        let Ok(outcome) = receiver.recv_timeout(HANG) else {
            let name = format!("hang-{}", seeds[seed].file_name().unwrap().to_string_lossy());
            let saved = save_failure(&name, &bytes);
            // Shrinking would wait out every hang again; end the run here.
            eprintln!(
                "FUZZ_SEED={fuzz_seed}: a case did not finish in {HANG:?}; input saved to {}",
                saved.display()
            );
            std::process::exit(1);
        };
        let (elapsed, largest) = (start.elapsed(), take_largest());
        slowest.set(slowest.get().max(elapsed));
        per_seed.borrow_mut()[seed].0 += 1;
        if matches!(outcome, Outcome::Loaded) {
            per_seed.borrow_mut()[seed].1 += 1;
        }
        let problem = match outcome {
            Outcome::Panicked(message) => Some(format!("panic `{message}`")),
            _ if largest > LARGEST_ALLOCATION => Some(format!("one allocation of {largest} bytes")),
            _ if elapsed > SLOWEST_CASE => Some(format!("took {elapsed:?}")),
            Outcome::Loaded => {
                loaded.set(loaded.get() + 1);
                None
            }
            Outcome::Failed => None,
        };
        if let Some(problem) = problem {
            let saved = save_failure(&target.file_name().unwrap().to_string_lossy(), &bytes);
            return Err(TestCaseError::fail(format!("{problem}; input saved to {}", saved.display())));
        }
        Ok(())
    });
    panic::set_hook(hook);
    if let Err(e) = result {
        panic!("FUZZ_SEED={fuzz_seed}: {e}");
    }
    // Mutations that still parse reach composition, tessellation and packing; a fuzzer whose inputs
    // all fail at the first token would test only the tokenizer.
    let loaded = loaded.get();
    eprintln!(
        "fuzz: seed {fuzz_seed}, {cases} cases, {loaded} loaded and packed, slowest {:?}",
        slowest.get()
    );
    for (file, (tried, ok)) in seeds.iter().zip(per_seed.borrow().iter()) {
        eprintln!("fuzz:   {}: {ok} of {tried} loaded", file.file_name().unwrap().to_string_lossy());
    }
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
        take_largest();
        if let Outcome::Panicked(message) = ingest(&target) {
            panic!("{} panics: {message}", path.display());
        }
        let largest = take_largest();
        assert!(largest <= LARGEST_ALLOCATION, "{} allocates {largest} bytes at once", path.display());
    }
}

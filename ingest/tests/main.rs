//! ingest's integration tests: one binary (`cargo test --release -p ingest --test integration`),
//! a module per area.
//!
//! - `bad_layers`: broken crate files, packages and text layers give errors naming the file, the
//!   section and the problem, from the library and from the `ingest` binary.
//! - `fuzz_layers`: the layer fuzzer (proptest-driven mutations of `tests/assets/fuzz/corpus`)
//!   and the replay of its regressions; run it alone with `--test integration fuzz_layers`.
//! - `fuzz_corpus`: replays the libFuzzer targets' committed corpora and regressions
//!   (`ingest/fuzz/corpus`, `ingest/fuzz/regressions`) through `ingest::fuzz_entry`, no libFuzzer.
//! - `list_only`: `ingest ASSET --dump-json FILE` without `-o`.
//! - `materialx`: MaterialX looks (`.mtlx` documents, inline `ND_*` networks, the surface mappings).
//! - `outputs`: outputs that name an input (or each other) are refused, inputs kept; stale
//!   temporaries removed.
//! - `sequences`: `ingest --frames`: each blob of a sequence equals a single `--frame N` ingest byte
//!   for byte; bad ranges and patterns are refused.
//! - `support`: the fuzzer's mutations and zip repair, shared by the modules above.
//!
//! `fuzz_layers` installs the binary's global allocator (it records the largest allocation); the
//! other modules run under it too, which costs them nothing.

mod bad_layers;
mod fuzz_corpus;
mod fuzz_layers;
mod list_only;
mod materialx;
mod outputs;
mod sequences;
mod support;

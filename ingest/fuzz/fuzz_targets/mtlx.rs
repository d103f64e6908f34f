//! A MaterialX document (`ingest::fuzz_entry::mtlx`): its translation to USDA, then a stage referencing it; either may refuse, neither may panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ingest::fuzz_entry::mtlx(data);
});

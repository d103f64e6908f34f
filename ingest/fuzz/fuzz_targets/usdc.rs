//! A `.usdc` crate file through the ingest reader (`ingest::fuzz_entry::usdc`): the crate check must refuse what openusd's crate reader would trust, so nothing panics.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ingest::fuzz_entry::usdc(data);
});

//! A `.usda` layer through the ingest reader (`ingest::fuzz_entry::usda`): normalization, the USDA parser, composition and conversion may refuse the bytes, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ingest::fuzz_entry::usda(data);
});

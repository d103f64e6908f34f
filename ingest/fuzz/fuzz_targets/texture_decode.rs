//! A texture file (`ingest::fuzz_entry::texture_decode`): the first byte picks the decoder, the rest is decoded within the fuzz pixel budget; refusals are fine, panics and unbudgeted allocations are not.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ingest::fuzz_entry::texture_decode(data);
});

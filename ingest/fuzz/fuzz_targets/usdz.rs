//! A `.usdz` package through the ingest reader (`ingest::fuzz_entry::usdz`): the zip reader and the layers and textures inside it may refuse, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ingest::fuzz_entry::usdz(data);
});

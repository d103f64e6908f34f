//! An Alembic archive through the ingest reader (`ingest::fuzz_entry::abc`): the Ogawa reader and
//! the translation must refuse a damaged archive with an error, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ingest::fuzz_entry::abc(data);
});

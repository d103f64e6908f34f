//! Blob parse plus a one-sample render of whatever parses.
//!
//! The input is a blob whose `file_size` and checksums the harness rewrites (`blob::reseal`) before
//! parsing, so libFuzzer's mutations get past the integrity checks to the structural validation and the
//! renderer, the way a crafted blob would. Whatever `SceneView::parse` accepts is rendered at 8×8, one
//! sample, three bounces, one thread, under a 256 MiB memory limit: parse may refuse, render may refuse,
//! neither may panic, abort, hang or read out of bounds.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut bytes = data.to_vec();
    blob::reseal(&mut bytes);
    let aligned = blob::AlignedBytes::copy_from(&bytes);
    let Ok(view) = blob::SceneView::parse(&aligned) else { return };
    let options = render::RenderOptions {
        spp: 1,
        resolution: Some([8, 8]),
        threads: 1,
        max_depth: 3,
        max_memory: Some(256 << 20),
        ..render::RenderOptions::default()
    };
    let _ = render::render_image(&view, &options);
});

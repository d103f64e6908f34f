//! Which `multiversion` clone of the kernels this CPU runs, and the hook that lets
//! `scripts/test-fallback.sh` compare images across CPUs.
//!
//! The development and CI machines have AVX2, so without help only the AVX2 clones would ever be
//! tested. The script runs the kernel tests again under qemu-user on CPU models without AVX2 and sets
//! `RENDER_EMULATED_CPU`, so [`tests::dispatch_picks_the_clone_the_cpu_supports`] can insist the
//! baseline clones really ran there; qemu raises SIGILL on any instruction the model lacks, so a
//! passing run also proves no AVX2 code was reached. Every image the integrator equivalence tests
//! compare is written to `RENDER_TEST_IMAGE_DIR` when it is set ([`record_image`]): the script diffs
//! those from a native run against those from an emulated one, which checks that the AVX2 and baseline
//! clones give the same bits (no FMA contraction in either).

use crate::Image;

/// Writes `image` (raw little-endian `f32`s: beauty, albedo, normal, depth) to
/// `$RENDER_TEST_IMAGE_DIR/<what>.f32` when that variable is set; does nothing otherwise.
pub(crate) fn record_image(what: &str, image: &Image) {
    let Some(dir) = std::env::var_os("RENDER_TEST_IMAGE_DIR") else { return };
    let name: String =
        what.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect::<String>() + ".f32";
    let mut bytes = Vec::new();
    bytes.extend_from_slice(&image.width.to_le_bytes());
    bytes.extend_from_slice(&image.height.to_le_bytes());
    for channel in [
        bytemuck::cast_slice::<[f32; 4], f32>(&image.beauty),
        bytemuck::cast_slice::<[f32; 3], f32>(&image.albedo),
        bytemuck::cast_slice::<[f32; 3], f32>(&image.normal),
        &image.depth[..],
    ] {
        channel.iter().for_each(|v| bytes.extend_from_slice(&v.to_le_bytes()));
    }
    let path = std::path::Path::new(&dir).join(name);
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
}

#[cfg(target_arch = "x86_64")]
mod tests {
    /// The clone the lane kernels dispatch to: the same target list as `wavefront/*_lanes.rs`,
    /// `camera.rs`, `trig.rs` (`multiversion` checks the CPU the same way for every function).
    #[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
    fn lane_kernel_clone() -> &'static str {
        multiversion::target::match_target! {
            "x86_64+avx+avx2+fma" => "avx+avx2+fma",
            _ => "baseline (SSE2)",
        }
    }

    /// The clone the traversal and surface kernels dispatch to (`accel.rs`, `wavefront/packet.rs`,
    /// `integrator.rs`).
    #[multiversion::multiversion(targets("x86_64+avx2+fma"))]
    fn traversal_kernel_clone() -> &'static str {
        multiversion::target::match_target! {
            "x86_64+avx2+fma" => "avx2+fma",
            _ => "baseline (SSE2)",
        }
    }

    #[test]
    fn dispatch_picks_the_clone_the_cpu_supports() {
        let avx = is_x86_feature_detected!("avx");
        let avx2 = is_x86_feature_detected!("avx2");
        let fma = is_x86_feature_detected!("fma");
        let (lanes, traversal) = (lane_kernel_clone(), traversal_kernel_clone());
        eprintln!(
            "cpu: avx {avx}, avx2 {avx2}, fma {fma}; lane kernels run the {lanes} clone, traversal and \
             surface kernels the {traversal} clone"
        );
        assert_eq!(lanes == "avx+avx2+fma", avx && avx2 && fma);
        assert_eq!(traversal == "avx2+fma", avx2 && fma);
        match std::env::var("RENDER_EMULATED_CPU").as_deref() {
            Err(_) => {}
            Ok("no-avx") => {
                assert!(!avx && !avx2 && !fma, "the emulated CPU should have no AVX, AVX2 or FMA");
                assert_eq!((lanes, traversal), ("baseline (SSE2)", "baseline (SSE2)"));
            }
            Ok("avx-no-avx2") => {
                assert!(avx && !avx2 && !fma, "the emulated CPU should have AVX but no AVX2 or FMA");
                assert_eq!((lanes, traversal), ("baseline (SSE2)", "baseline (SSE2)"));
            }
            Ok(other) => panic!("RENDER_EMULATED_CPU={other:?}: expected \"no-avx\" or \"avx-no-avx2\""),
        }
    }
}

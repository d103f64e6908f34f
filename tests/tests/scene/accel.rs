//! The BVH on an ingested asset: the bundled tractor through ingest (USD in), its traversal against
//! brute force and the scalar kernels. Moved here from render's unit tests, which no longer build
//! USD (issue 18).

use glam::Vec3;
use render::accel::{assert_same_closest, offset_ray_origin, Accel};

/// SplitMix64: deterministic rays without a dependency.
struct Rng(u64);

impl Rng {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

#[test]
fn bvh_agrees_with_brute_force_on_the_bundled_tractor() {
    let dir = tempfile::tempdir().unwrap();
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
    let out = dir.path().join("tractor.blob");
    ingest::pipeline::ingest_file(&example, &out, &Default::default()).expect("ingest the example");
    let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&out).unwrap());
    let view = blob::SceneView::parse(&bytes).unwrap();
    let accel = Accel::new(&view);
    let lo = Vec3::from(view.info.bounds_min);
    let hi = Vec3::from(view.info.bounds_max);
    let mut rng = Rng(4242);
    let mut hits = 0;
    for i in 0..3000 {
        // Rays from outside towards points inside the bounds, and rays leaving surface points.
        let pick = |rng: &mut Rng| lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let (origin, dir) = if i % 2 == 0 {
            let target = pick(&mut rng);
            let origin = target + (hi - lo).length() * (pick(&mut rng) - target).normalize();
            (origin, (target - origin).normalize())
        } else {
            let t = (rng.next_f32() * view.triangles.len() as f32) as u32 % view.triangles.len() as u32;
            let [a, b, c] = accel.triangle_vertices(t);
            let n = (b - a).cross(c - a).normalize_or_zero();
            let p = (a + b + c) / 3.0;
            let d = (pick(&mut rng) - p).normalize_or_zero();
            (offset_ray_origin(p, if d.dot(n) >= 0.0 { n } else { -n }), d)
        };
        if dir == Vec3::ZERO || !dir.is_finite() {
            continue;
        }
        let fast = accel.closest_hit(origin, dir, f32::INFINITY);
        let slow = accel.closest_hit_brute_force(origin, dir, f32::INFINITY);
        hits += slow.is_some() as usize;
        assert_same_closest(fast, slow, "tractor");
        assert_eq!(fast, accel.closest_hit_scalar(origin, dir, f32::INFINITY), "SIMD vs scalar traversal");
        assert_eq!(accel.any_hit(origin, dir, f32::INFINITY, |_, _| true), slow.is_some());
    }
    assert!(hits > 1000, "the test should exercise many hits, got {hits}");
}

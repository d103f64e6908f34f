use super::*;
use crate::lights::Lights;
use crate::testscene::{area_light_records, lights_only, Rng};

/// A translation-only light record.
fn at(kind: u32, c: Vec3, radiance: f32, radius: f32) -> blob::Light {
    blob::Light {
        kind,
        radiance: [radiance, 0.8 * radiance, 0.5 * radiance],
        radius,
        world_from_light: [[1.0, 0.0, 0.0, c.x], [0.0, 1.0, 0.0, c.y], [0.0, 0.0, 1.0, c.z]],
        ..Default::default()
    }
}

/// `count` random lights of every bounded kind (spheres, rects, disks facing every way, points),
/// with a dome and a distant light when `infinite`.
fn random_lights(count: usize, infinite: bool, rng: &mut Rng) -> Vec<blob::Light> {
    let mut u = || rng.next_f32();
    let mut records = area_light_records(count, 5.0, (0.02, 0.3), (0.05, 0.6), &mut u);
    for (i, r) in records.iter_mut().enumerate() {
        if i % 7 == 3 {
            r.kind = blob::light_kind::SPHERE;
            r.flags |= blob::LIGHT_TREAT_AS_POINT;
        }
    }
    if infinite {
        records.push(blob::Light { kind: blob::light_kind::DOME, radiance: [0.3; 3], ..Default::default() });
        let mut sun = at(blob::light_kind::DISTANT, Vec3::ZERO, 2.0, 0.0);
        sun.angle_degrees = 1.0;
        records.insert(count / 2, sun);
    }
    records
}

fn random_point(rng: &mut Rng, spread: f32) -> Vec3 {
    Vec3::new(rng.range(-spread, spread), rng.range(-spread, spread), rng.range(-spread, spread))
}

/// The selection probabilities of all lights sum to 1 at any point (inside boxes, behind one-sided
/// lights, far away), for 1 to 300 lights.
#[test]
fn pmf_sums_to_one_over_random_light_sets() {
    let mut rng = Rng(41);
    for (case, count) in [1usize, 2, 3, 5, 8, 17, 64, 150, 300].into_iter().enumerate() {
        let bytes = lights_only(random_lights(count, case % 2 == 1, &mut rng));
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let n = lights.lights().len();
        for point in 0..200 {
            let p = random_point(&mut rng, if point % 4 == 0 { 40.0 } else { 6.0 });
            let sum: f64 = (0..n).map(|i| lights.selector().pmf(p, i) as f64).sum();
            assert!((sum - 1.0).abs() < 1e-5, "{count} lights at {p}: sum {sum}");
        }
    }
}

/// `pmf(p, light)` of the light `select` returned equals the probability it returned, bit for bit.
#[test]
fn pmf_of_the_selected_light_equals_the_selection_probability_exactly() {
    let mut rng = Rng(7);
    let mut tree_picks = 0;
    for count in [2usize, 9, 120, 300] {
        let bytes = lights_only(random_lights(count, count % 2 == 1, &mut rng));
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        for _ in 0..20_000 {
            let p = random_point(&mut rng, 7.0);
            let u = rng.next_f32();
            let (light, pmf) = lights.selector().select(p, u);
            assert!(pmf > 0.0, "{count} lights: light {light} selected with probability 0");
            assert_eq!(
                pmf.to_bits(),
                lights.selector().pmf(p, light).to_bits(),
                "{count} lights, light {light}"
            );
            tree_picks += (pmf < lights.selector().infinite_pmf()) as u32;
        }
    }
    assert!(tree_picks > 40_000, "the tree chose only {tree_picks} lights");
}

/// Chi-square test of the selection frequencies against `pmf` at a few points, 10⁵ draws each.
#[test]
fn selection_frequencies_match_the_pmf() {
    let mut rng = Rng(19);
    let bytes = lights_only(random_lights(40, true, &mut rng));
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let lights = Lights::new(&view);
    let n = lights.lights().len();
    let draws = 100_000;
    for p in [Vec3::ZERO, Vec3::new(3.0, -2.0, 4.5), Vec3::new(-8.0, 1.0, 0.5), Vec3::new(0.2, 5.5, -5.0)] {
        let mut counts = vec![0u32; n];
        for i in 0..draws {
            // Stratified-free uniform numbers: independent draws, as the chi-square test assumes.
            let _ = i;
            counts[lights.selector().select(p, rng.next_f32()).0] += 1;
        }
        let pmf: Vec<f64> = (0..n).map(|i| lights.selector().pmf(p, i) as f64).collect();
        // Bins with at least 5 expected draws; the rest pooled into one.
        let (mut chi2, mut bins, mut pooled_expected, mut pooled_count) = (0.0, 0, 0.0, 0.0);
        for i in 0..n {
            let expected = pmf[i] * draws as f64;
            if pmf[i] == 0.0 {
                assert_eq!(counts[i], 0, "light {i} has probability 0 at {p} but was drawn");
            } else if expected >= 5.0 {
                chi2 += (counts[i] as f64 - expected).powi(2) / expected;
                bins += 1;
            } else {
                pooled_expected += expected;
                pooled_count += counts[i] as f64;
            }
        }
        if pooled_expected >= 5.0 {
            chi2 += (pooled_count - pooled_expected).powi(2) / pooled_expected;
            bins += 1;
        }
        let dof = (bins - 1) as f64;
        // Mean dof, standard deviation √(2 dof): six deviations is p < 1e-6.
        assert!(bins > 10, "only {bins} bins at {p}");
        assert!(chi2 < dof + 6.0 * (2.0 * dof).sqrt(), "chi² {chi2:.1} with {dof} dof at {p}");
    }
}

/// Same input, same tree; lights at one point still give a balanced tree (median splits).
#[test]
fn the_build_is_deterministic_and_bounded_in_depth() {
    let mut rng = Rng(3);
    let records = random_lights(300, false, &mut rng);
    let build = |records: &[blob::Light]| {
        let lights: Vec<Light> = records.iter().map(Light::from_blob).collect();
        LightSelector::new(&lights, None)
    };
    let a = build(&records);
    assert_eq!(a, build(&records));
    assert!(a.tree.depth() < 40, "depth {}", a.tree.depth());
    let same: Vec<blob::Light> =
        (0..300).map(|_| at(blob::light_kind::SPHERE, Vec3::ONE, 1.0, 0.1)).collect();
    let tree = build(&same).tree;
    assert_eq!(tree.depth(), 9, "300 coincident lights: ⌈log₂ 300⌉ levels");
    assert_eq!(tree.nodes.len(), 599);
}

/// Irradiance at `p` on a +Z-facing surface estimated by light sampling: mean and standard error.
fn irradiance(lights: &Lights, p: Vec3, n: usize, rng: &mut Rng) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let u_select = rng.next_f32();
        let u = [rng.next_f32(), rng.next_f32()];
        if let Some(s) = lights.sample(p, u_select, u) {
            let e = (s.li.x * s.wi.z.max(0.0) / s.pdf) as f64;
            sum += e;
            sum2 += e * e;
        }
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
}

/// `count` small sphere lights above the floor z = 0 over [−spread, spread]²; their analytic
/// irradiance at floor points (every sphere wholly above the horizon: E = π L (r/d)² cos θ).
fn lights_over_a_floor(count: usize, spread: f32, rng: &mut Rng) -> (Vec<blob::Light>, impl Fn(Vec3) -> f64) {
    let spheres: Vec<(Vec3, f32, f32)> = (0..count)
        .map(|_| {
            let c = Vec3::new(rng.range(-spread, spread), rng.range(-spread, spread), rng.range(0.4, 1.5));
            (c, rng.range(0.03, 0.1), rng.range(5.0, 50.0))
        })
        .collect();
    let records = spheres.iter().map(|&(c, r, l)| at(blob::light_kind::SPHERE, c, l, r)).collect();
    let exact = move |p: Vec3| {
        spheres
            .iter()
            .map(|&(c, r, l)| {
                let to = (c - p).as_dvec3();
                let d2 = to.length_squared();
                std::f64::consts::PI * l as f64 * (r as f64).powi(2) / d2 * to.z / d2.sqrt()
            })
            .sum::<f64>()
    };
    (records, exact)
}

/// Unbiased: under 100 sphere lights the tree's estimate of the irradiance equals the analytic
/// value within noise; and under random one-sided rects and disks facing every way (where a wrong
/// zero importance would lose light) it equals the uniform selection's estimate within noise.
#[test]
fn tree_selection_is_unbiased() {
    let mut rng = Rng(5);
    let (records, exact) = lights_over_a_floor(100, 4.0, &mut rng);
    let bytes = lights_only(records);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let lights = Lights::new(&view);
    for p in [Vec3::ZERO, Vec3::new(2.5, -1.0, 0.0), Vec3::new(-4.5, 4.5, 0.0)] {
        let (e, se) = irradiance(&lights, p, 200_000, &mut rng);
        let expected = exact(p);
        assert!((e - expected).abs() < 4.0 * se + 1e-4 * expected, "at {p}: {e} ± {se}, exact {expected}");
        assert!(se < 0.01 * expected, "at {p}: standard error {se} of {expected}");
    }
    let bytes = lights_only(random_lights(60, true, &mut rng));
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let tree = Lights::new(&view);
    let uniform = Lights::new(&view).with_uniform_selection();
    for p in [Vec3::new(0.5, 0.5, -6.0), Vec3::new(-2.0, 1.0, 0.0), Vec3::new(4.0, -3.0, 2.0)] {
        let (a, sa) = irradiance(&tree, p, 400_000, &mut rng);
        let (b, sb) = irradiance(&uniform, p, 400_000, &mut rng);
        let se = (sa * sa + sb * sb).sqrt();
        assert!((a - b).abs() < 4.5 * se, "at {p}: tree {a} ± {sa}, uniform {b} ± {sb}");
        assert!(se < 0.03 * b, "at {p}: noise {se} of {b}");
    }
}

/// Variance: RMSE of 16-sample irradiance estimates at 256 floor points under 128 small sphere
/// lights spread over the floor, against the analytic value: the tree's is well below uniform
/// selection's (measured 2.37×, asserted 2×: without the receiver's normal, lights far off to the
/// side, seen at grazing angles, keep more probability than their light deserves).
#[test]
fn tree_selection_beats_uniform_selection_on_many_lights() {
    let mut rng = Rng(13);
    let (records, exact) = lights_over_a_floor(128, 10.0, &mut rng);
    let bytes = lights_only(records);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let tree = Lights::new(&view);
    let uniform = Lights::new(&view).with_uniform_selection();
    let points: Vec<Vec3> =
        (0..256).map(|_| Vec3::new(rng.range(-9.0, 9.0), rng.range(-9.0, 9.0), 0.0)).collect();
    let rmse = |lights: &Lights, rng: &mut Rng| {
        let squared: f64 =
            points.iter().map(|&p| (irradiance(lights, p, 16, rng).0 - exact(p)).powi(2)).sum();
        (squared / points.len() as f64).sqrt()
    };
    let (tree_error, uniform_error) = (rmse(&tree, &mut rng), rmse(&uniform, &mut rng));
    eprintln!("irradiance RMSE at 16 samples: tree {tree_error:.4}, uniform {uniform_error:.4}");
    assert!(uniform_error > 2.0 * tree_error, "tree {tree_error}, uniform {uniform_error}");
}

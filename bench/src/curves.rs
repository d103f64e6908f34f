//! `bench curves`: speed against accuracy of curve splitting on a generated groom.
//!
//! A sphere of radius 1 carries `strands` hairs (one cubic Bézier each, 0.35 long, bent, tapering
//! from radius 0.004 to 0.001), seen by a 50 mm camera at distance 4. For each splitting policy —
//! fixed 1, 2, 4, 8 pieces per segment and camera-adaptive at 2, 1, 0.5, 0.25, 0.1 pixels — the blob
//! is packed through `ingest::pack::pack_with` and traced as `render` traces it (BVH slot pieces,
//! render-time refinement to 5 % of the radius), and we measure primary-ray throughput (one thread,
//! Mrays/s of thread CPU time) and the RMSE of a coverage × N·L image (4×4 stratified rays per
//! pixel) against a reference of 16 fixed pieces per segment. Then the same groom is moved away
//! from the camera to show how many pieces the default split keeps at each distance.

use glam::{Mat4, Vec3};
use ingest::pack::Split;
use plotters::prelude::*;
use render::accel::curves::CurveAccel;
use std::path::Path;

/// The groom scene.
fn groom(strands: usize, res: u32, seed: u64) -> ingest::Scene {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / 16_777_216.0
    };
    let mut segments = Vec::with_capacity(strands);
    for _ in 0..strands {
        let z = 1.0 - 2.0 * next();
        let phi = std::f32::consts::TAU * next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        let t = n.any_orthonormal_vector();
        let bend = (t * (next() - 0.5) + n.cross(t) * (next() - 0.5)) * 0.5;
        let len = 0.35;
        let root = n;
        let p = [
            root.extend(0.004),
            (root + n * len * 0.35 + bend * len * 0.3).extend(0.003),
            (root + n * len * 0.65 + bend * len * 0.9).extend(0.002),
            (root + n * len * 0.85 + bend * len * 1.6).extend(0.001),
        ];
        segments.push(ingest::BezierSegment { p, u: [0.0, 1.0], ..Default::default() });
    }
    ingest::Scene {
        curves: vec![ingest::Curves {
            path: "/Groom".into(),
            segments,
            material: 0,
            curve_count: strands,
            ..Default::default()
        }],
        materials: vec![ingest::Material::default()],
        cameras: vec![ingest::Camera {
            path: "/Cam".into(),
            world_from_camera: Mat4::from_translation(Vec3::new(0.0, 0.0, 4.0)),
            orthographic: false,
            focal_length: 50.0,
            horizontal_aperture: 36.0,
            vertical_aperture: 36.0,
            horizontal_aperture_offset: 0.0,
            vertical_aperture_offset: 0.0,
            clipping_range: [0.1, 100.0],
            lens: Default::default(),
            shutter: [0.0; 2],
            motion: None,
        }],
        default_camera: Some(0),
        // The resolution the rays are traced at: the camera split asks for pixels of this image.
        resolution: Some([res, res]),
        meters_per_unit: 1.0,
        ..Default::default()
    }
}

/// Primary rays: `s × s` stratified rays per pixel of a `res²` image.
fn rays(res: u32, s: u32) -> Vec<(Vec3, Vec3)> {
    let eye = Vec3::new(0.0, 0.0, 4.0);
    let half = 18.0 / 50.0; // tan of the half field of view
    let mut out = Vec::with_capacity((res * res * s * s) as usize);
    for y in 0..res {
        for x in 0..res {
            for j in 0..s {
                for i in 0..s {
                    let fx = (x as f32 + (i as f32 + 0.5) / s as f32) / res as f32;
                    let fy = (y as f32 + (j as f32 + 0.5) / s as f32) / res as f32;
                    let d = Vec3::new((2.0 * fx - 1.0) * half, (1.0 - 2.0 * fy) * half, -1.0).normalize();
                    out.push((eye, d));
                }
            }
        }
    }
    out
}

/// Coverage × (0.2 + 0.8 |n·l|) per pixel, and the thread CPU seconds spent in closest-hit queries.
fn image(accel: &CurveAccel, rays: &[(Vec3, Vec3)], per_pixel: usize) -> anyhow::Result<(Vec<f32>, f64)> {
    let light = Vec3::new(0.5, 0.7, 0.5).normalize();
    let start = thread_cpu_seconds()?;
    let values: Vec<f32> = rays
        .iter()
        .map(|(o, d)| {
            accel.closest_hit(*o, *d, f32::INFINITY).map_or(0.0, |h| 0.2 + 0.8 * h.n.dot(light).abs())
        })
        .collect();
    let seconds = thread_cpu_seconds()? - start;
    Ok((values.chunks(per_pixel).map(|c| c.iter().sum::<f32>() / per_pixel as f32).collect(), seconds))
}

/// CPU time of the calling thread (`/proc/thread-self/schedstat`, nanoseconds on the CPU). The
/// machine this runs on is shared, so wall-clock time measures the neighbours as much as the
/// tracer; time on the CPU does not (cache sharing still does).
fn thread_cpu_seconds() -> anyhow::Result<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat")?;
    let ns: f64 = stat.split_whitespace().next().unwrap_or("").parse()?;
    Ok(ns * 1e-9)
}

/// The 1-minute load average (`/proc/loadavg`), recorded beside the timings.
fn load_average() -> f64 {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|v| v.parse().ok()))
        .unwrap_or(f64::NAN)
}

/// Runs the sweep; writes `curves.json` and `curves.svg` into `out`.
pub fn run(strands: usize, res: u32, out: &Path) -> anyhow::Result<()> {
    let scene = groom(strands, res, 7);
    let s = 4;
    let rays = rays(res, s);
    let per_pixel = (s * s) as usize;
    let build = |scene: &ingest::Scene, split: Split| -> anyhow::Result<blob::AlignedBytes> {
        let data = ingest::pack::pack_with(scene, split)?;
        Ok(blob::AlignedBytes::copy_from(&data.encode()))
    };
    let reference_bytes = build(&scene, Split::Fixed(16))?;
    let reference_view = blob::SceneView::parse(&reference_bytes)?;
    let (reference, _) = image(&CurveAccel::new(&reference_view), &rays, per_pixel)?;
    println!("groom: {strands} strands, {res}x{res} px, {} rays per policy", rays.len());
    println!(
        "{:<16} {:>10} {:>10} {:>10} {:>12} {:>10}",
        "split", "segments", "slots", "seg/curve", "Mrays/s cpu", "rmse"
    );
    let mut rows = Vec::new();
    let policies: Vec<(String, Split)> = [1u32, 2, 4, 8]
        .iter()
        .map(|&n| (format!("fixed {n}"), Split::Fixed(n)))
        .chain([2.0f32, 1.0, 0.5, 0.25, 0.1].iter().map(|&p| {
            (format!("adaptive {p}px"), Split::Adaptive { pixels: p, width_fraction: 0.1, max_depth: 6 })
        }))
        .collect();
    let load_before = load_average();
    for (name, split) in policies {
        let bytes = build(&scene, split)?;
        let view = blob::SceneView::parse(&bytes)?;
        let (img, seconds) = image(&CurveAccel::new(&view), &rays, per_pixel)?;
        let rmse = (img.iter().zip(&reference).map(|(a, b)| ((a - b) as f64).powi(2)).sum::<f64>()
            / img.len() as f64)
            .sqrt();
        let segments = view.curves.segments.len();
        let slots = view.curves.bvh_primitives.len();
        let per_curve = segments as f64 / strands as f64;
        let mrays = rays.len() as f64 / seconds / 1e6;
        println!("{name:<16} {segments:>10} {slots:>10} {per_curve:>10.2} {mrays:>12.3} {rmse:>10.5}");
        let adaptive = matches!(split, Split::Adaptive { .. });
        rows.push(serde_json::json!({"split": name, "adaptive": adaptive, "segments": segments,
            "bvh_slots": slots, "segments_per_curve": per_curve, "mrays_per_s_1thr_cpu": mrays,
            "rmse": rmse}));
    }
    dump_for_embree(&build(&scene, Split::default())?, &rays, out)?;
    // The same groom moved away from the camera: the default split asks for fewer pieces.
    let mut distances = Vec::new();
    println!("{:<16} {:>10} {:>10}", "distance", "segments", "seg/curve");
    for distance in [4.0f32, 8.0, 16.0, 32.0, 64.0, 128.0] {
        let mut far = scene.clone();
        far.cameras[0].world_from_camera = Mat4::from_translation(Vec3::new(0.0, 0.0, distance));
        let segments = ingest::pack::pack_with(&far, Split::default())?.curves.segments.len();
        let per_curve = segments as f64 / strands as f64;
        println!("{distance:<16} {segments:>10} {per_curve:>10.2}");
        distances.push(serde_json::json!({"camera_distance": distance, "segments": segments,
            "segments_per_curve": per_curve}));
    }
    let json = serde_json::json!({"strands": strands, "resolution": res, "rays_per_pixel": per_pixel,
        "reference": "fixed 16 pieces per segment", "traced_as": "render: BVH slot pieces, refinement depth 4",
        "timing": "thread CPU time, single thread", "load_average_1min": [load_before, load_average()],
        "rows": rows, "default_split_by_distance": distances});
    std::fs::write(out.join("curves.json"), serde_json::to_string_pretty(&json)?)?;
    chart(&rows, &out.join("curves.svg"))?;
    println!("figures written to {}", out.join("curves.json").display());
    Ok(())
}

/// Writes the default split's segments, the rays and where we hit for `bench/embree_curves.c`:
/// `curves.control.f32` (segments × 4 × xyz radius), `curves.rays.f32` (origin, direction) and
/// `curves.ours_hit.u8`.
fn dump_for_embree(bytes: &[u8], rays: &[(Vec3, Vec3)], out: &Path) -> anyhow::Result<()> {
    let view = blob::SceneView::parse(bytes)?;
    let accel = CurveAccel::new(&view);
    let bytes = |v: &mut dyn Iterator<Item = f32>| -> Vec<u8> { v.flat_map(f32::to_le_bytes).collect() };
    let control = bytes(&mut view.curves.segments.iter().flat_map(|s| s.p.into_iter().flatten()));
    let ray_floats = bytes(&mut rays.iter().flat_map(|(o, d)| o.to_array().into_iter().chain(d.to_array())));
    let hits: Vec<u8> =
        rays.iter().map(|(o, d)| accel.closest_hit(*o, *d, f32::INFINITY).is_some() as u8).collect();
    std::fs::write(out.join("curves.control.f32"), control)?;
    std::fs::write(out.join("curves.rays.f32"), ray_floats)?;
    std::fs::write(out.join("curves.ours_hit.u8"), &hits)?;
    Ok(())
}

fn chart(rows: &[serde_json::Value], path: &Path) -> anyhow::Result<()> {
    let get = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let series = |adaptive: bool| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r["adaptive"].as_bool() == Some(adaptive))
            .map(|r| (get(r, "segments_per_curve"), get(r, "rmse").max(1e-6)))
            .collect()
    };
    let all: Vec<(f64, f64)> = series(true).into_iter().chain(series(false)).collect();
    let (x0, x1) = all.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(p.0), hi.max(p.0)));
    let (y0, y1) = all.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Curve splitting: image RMSE vs segments per curve", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((x0 * 0.8..x1 * 1.25).log_scale(), (y0 * 0.8..y1 * 1.25).log_scale())?;
    chart.configure_mesh().x_desc("stored segments per curve").y_desc("RMSE vs reference").draw()?;
    for (adaptive, color, label) in [(false, RED, "fixed"), (true, BLUE, "adaptive (camera)")] {
        let points = series(adaptive);
        chart
            .draw_series(LineSeries::new(points.clone(), color))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart.draw_series(points.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
    }
    chart.configure_series_labels().border_style(BLACK).draw()?;
    root.present()?;
    Ok(())
}

//! `bench curves`: speed against accuracy of curve splitting on a generated groom.
//!
//! A sphere of radius 1 carries `strands` hairs (one cubic Bézier each, 0.35 long, bent, tapering
//! from radius 0.004 to 0.001), seen by a 50 mm camera at distance 4. For each splitting policy —
//! fixed 1, 2, 4, 8 pieces per segment and adaptive at 2, 1, 0.5, 0.25, 0.1 pixels — the blob is
//! packed through `ingest::pack::pack_with`, the curve test runs without render-time refinement
//! (`max_refine = 0`, so each stored piece is one chord: accuracy comes from the split alone), and we
//! measure primary-ray throughput (single thread, Mrays/s) and the RMSE of a coverage × N·L image
//! (4×4 stratified rays per pixel) against a reference of 16 fixed pieces per segment with render-time
//! refinement (up to 16 × 16 chords per segment).

use glam::{Mat4, Vec3};
use ingest::pack_curves::Split;
use plotters::prelude::*;
use render::curves::CurveAccel;
use std::path::Path;
use std::time::Instant;

/// The groom scene.
fn groom(strands: usize, seed: u64) -> ingest::Scene {
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
        }],
        default_camera: Some(0),
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

/// Coverage × (0.2 + 0.8 |n·l|) per pixel, and seconds spent in closest-hit queries.
fn image(accel: &CurveAccel, rays: &[(Vec3, Vec3)], per_pixel: usize) -> (Vec<f32>, f64) {
    let light = Vec3::new(0.5, 0.7, 0.5).normalize();
    let start = Instant::now();
    let values: Vec<f32> = rays
        .iter()
        .map(|(o, d)| {
            accel.closest_hit(*o, *d, f32::INFINITY).map_or(0.0, |h| 0.2 + 0.8 * h.n.dot(light).abs())
        })
        .collect();
    let seconds = start.elapsed().as_secs_f64();
    (values.chunks(per_pixel).map(|c| c.iter().sum::<f32>() / per_pixel as f32).collect(), seconds)
}

/// Runs the sweep; writes `curves.json` and `curves.svg` into `out`.
pub fn run(strands: usize, res: u32, out: &Path) -> anyhow::Result<()> {
    let scene = groom(strands, 7);
    let s = 4;
    let rays = rays(res, s);
    let per_pixel = (s * s) as usize;
    let build = |split: Split| -> anyhow::Result<blob::AlignedBytes> {
        let data = ingest::pack::pack_with(&scene, split)?;
        Ok(blob::AlignedBytes::copy_from(&data.encode()))
    };
    let reference_bytes = build(Split::Fixed(16))?;
    let reference_view = blob::SceneView::parse(&reference_bytes)?;
    let mut accel = CurveAccel::new(&reference_view);
    accel.max_refine = 4;
    let (reference, _) = image(&accel, &rays, per_pixel);
    println!("groom: {strands} strands, {res}x{res} px, {} rays per policy", rays.len());
    println!("{:<16} {:>10} {:>12} {:>10} {:>10}", "split", "segments", "seg/curve", "Mrays/s", "rmse");
    let mut rows = Vec::new();
    let policies: Vec<(String, Split)> = [1u32, 2, 4, 8]
        .iter()
        .map(|&n| (format!("fixed {n}"), Split::Fixed(n)))
        .chain([2.0f32, 1.0, 0.5, 0.25, 0.1].iter().map(|&p| {
            (format!("adaptive {p}px"), Split::Adaptive { pixels: p, width_fraction: 0.1, max_depth: 6 })
        }))
        .collect();
    for (name, split) in policies {
        let bytes = build(split)?;
        let view = blob::SceneView::parse(&bytes)?;
        let mut accel = CurveAccel::new(&view);
        accel.max_refine = 0;
        let (img, seconds) = image(&accel, &rays, per_pixel);
        let rmse = (img.iter().zip(&reference).map(|(a, b)| ((a - b) as f64).powi(2)).sum::<f64>()
            / img.len() as f64)
            .sqrt();
        let segments = view.curves.segments.len();
        let per_curve = segments as f64 / strands as f64;
        let mrays = rays.len() as f64 / seconds / 1e6;
        println!("{name:<16} {segments:>10} {per_curve:>12.2} {mrays:>10.3} {rmse:>10.5}");
        let adaptive = matches!(split, Split::Adaptive { .. });
        rows.push(serde_json::json!({"split": name, "adaptive": adaptive, "segments": segments,
            "segments_per_curve": per_curve, "mrays_per_s_1thr": mrays, "rmse": rmse}));
    }
    let json = serde_json::json!({"strands": strands, "resolution": res, "rays_per_pixel": per_pixel,
        "reference": "fixed 16 pieces per segment + render-time refinement depth 4", "rows": rows});
    std::fs::write(out.join("curves.json"), serde_json::to_string_pretty(&json)?)?;
    chart(&rows, &out.join("curves.svg"))?;
    println!("figures written to {}", out.join("curves.json").display());
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

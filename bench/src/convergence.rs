//! `bench convergence`: error against time. Renders a reference at high spp, then spp = 1, 2, 4, …,
//! timing each render and measuring its RMSE against the reference; writes the figures as JSON and a
//! log–log chart (RMSE versus seconds) as SVG.

use plotters::prelude::*;
use render::{render_image, Image, RenderOptions};
use std::path::Path;
use std::time::Instant;

fn render_timed(
    view: &blob::SceneView,
    spp: u32,
    resolution: [u32; 2],
    seed: u32,
) -> anyhow::Result<(Image, f64)> {
    let options = RenderOptions { spp, resolution: Some(resolution), seed, ..RenderOptions::default() };
    let start = Instant::now();
    let image = render_image(view, &options)?;
    Ok((image, start.elapsed().as_secs_f64()))
}

/// Root-mean-square error over the RGB channels of two equally sized images.
pub fn rmse(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a
        .beauty
        .iter()
        .zip(&b.beauty)
        .map(|(p, q)| (0..3).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>())
        .sum();
    (sum / (3 * a.beauty.len()) as f64).sqrt()
}

/// Runs the sweep and writes `convergence.json` and `convergence.svg` into `out`.
pub fn run(
    view: &blob::SceneView,
    reference_spp: u32,
    max_spp: u32,
    width: u32,
    out: &Path,
) -> anyhow::Result<()> {
    let height = render::camera::default_height(view.cameras.get(view.info.default_camera as usize), width);
    let resolution = [width, height];
    // A different seed for the reference, so its noise is independent of the sweep's.
    let (reference, reference_seconds) = render_timed(view, reference_spp, resolution, 0x5EED)?;
    println!("reference: {reference_spp} spp at {width}x{height} in {reference_seconds:.2} s");
    println!("{:>6} {:>10} {:>10}", "spp", "seconds", "rmse");
    let mut rows = Vec::new();
    let mut spp = 1;
    while spp <= max_spp {
        let (image, seconds) = render_timed(view, spp, resolution, 1)?;
        let error = rmse(&image, &reference);
        println!("{spp:>6} {seconds:>10.3} {error:>10.5}");
        rows.push((spp, seconds, error));
        spp *= 2;
    }
    let json = serde_json::json!({
        "resolution": resolution,
        "reference_spp": reference_spp,
        "reference_seconds": reference_seconds,
        "rows": rows.iter().map(|(s, t, e)| serde_json::json!({"spp": s, "seconds": t, "rmse": e})).collect::<Vec<_>>(),
    });
    std::fs::write(out.join("convergence.json"), serde_json::to_string_pretty(&json)?)?;
    chart(&rows, &out.join("convergence.svg"))?;
    println!("figures written to {}", out.join("convergence.json").display());
    Ok(())
}

fn chart(rows: &[(u32, f64, f64)], path: &Path) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let (t0, t1) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.1), hi.max(r.1)));
    let (e0, e1) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.2), hi.max(r.2)));
    let mut chart = ChartBuilder::on(&root)
        .caption("Scalar path tracer: RMSE vs render time (spp = 1..)", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((t0 * 0.8..t1 * 1.25).log_scale(), (e0 * 0.8..e1 * 1.25).log_scale())?;
    chart.configure_mesh().x_desc("render seconds").y_desc("RMSE vs reference").draw()?;
    chart
        .draw_series(LineSeries::new(rows.iter().map(|r| (r.1, r.2)), &BLUE))?
        .label("ours (scalar)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    chart.draw_series(rows.iter().map(|r| Circle::new((r.1, r.2), 3, BLUE.filled())))?;
    chart.draw_series(
        rows.iter().map(|r| Text::new(format!("{}", r.0), (r.1, r.2 * 1.08), ("sans-serif", 11).into_font())),
    )?;
    chart.configure_series_labels().border_style(BLACK).draw()?;
    root.present()?;
    Ok(())
}

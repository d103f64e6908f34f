//! `bench adaptive`: time to equal error, adaptive against uniform sampling on one scene. Renders
//! a reference at high spp (another seed), then a uniform sweep (spp = 4, 8, …) and an adaptive
//! sweep (`--adaptive-threshold` 0.2 … 0.005, at most the reference's spp), timing each render and
//! measuring its RMSE against the reference. For each adaptive render, the uniform time of equal
//! RMSE is interpolated on the uniform curve (log–log), and the speed-up is their ratio. Writes
//! `adaptive.json` and a log–log chart, `adaptive.svg` (RMSE versus seconds, both curves).

use crate::convergence::rmse;
use plotters::prelude::*;
use render::{render_image, Image, RenderOptions};
use std::path::Path;
use std::time::Instant;

fn render_timed(view: &blob::SceneView, options: &RenderOptions) -> anyhow::Result<(Image, f64)> {
    let start = Instant::now();
    let image = render_image(view, options)?;
    Ok((image, start.elapsed().as_secs_f64()))
}

/// The uniform seconds at which the (seconds, rmse) curve `uniform` reaches `error`, interpolated
/// linearly in log–log between the two renders around it (`None` outside the sweep).
fn uniform_seconds_at(uniform: &[(u32, f64, f64)], error: f64) -> Option<f64> {
    uniform.windows(2).find_map(|w| {
        let ((_, t0, e0), (_, t1, e1)) = (w[0], w[1]);
        if !(e1 <= error && error <= e0) || e0 <= e1 {
            return None;
        }
        let f = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
        Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
    })
}

/// Runs the sweeps and writes `adaptive.json` and `adaptive.svg` into `out`.
pub fn run(view: &blob::SceneView, reference_spp: u32, width: u32, out: &Path) -> anyhow::Result<()> {
    let height = render::camera::default_height(view.cameras.get(view.info.default_camera as usize), width);
    let base = RenderOptions { resolution: Some([width, height]), seed: 1, ..RenderOptions::default() };
    let reference_options = RenderOptions { spp: reference_spp, seed: 0x5EED, ..base.clone() };
    let (reference, reference_seconds) = render_timed(view, &reference_options)?;
    println!("reference: {reference_spp} spp at {width}x{height} in {reference_seconds:.2} s");
    let mut uniform = Vec::new();
    let mut spp = 4;
    while spp <= reference_spp / 4 {
        let (image, seconds) = render_timed(view, &RenderOptions { spp, ..base.clone() })?;
        let error = rmse(&image, &reference);
        println!("uniform  {spp:>6} spp {seconds:>9.3} s  rmse {error:.5}");
        uniform.push((spp, seconds, error));
        spp *= 2;
    }
    let mut adaptive = Vec::new();
    for threshold in [0.2f32, 0.1, 0.05, 0.02, 0.01, 0.005] {
        let options =
            RenderOptions { spp: reference_spp / 4, adaptive: Some((threshold, 16)), ..base.clone() };
        let (image, seconds) = render_timed(view, &options)?;
        let error = rmse(&image, &reference);
        let mean_spp = image.stats.samples as f64 / f64::from(width * height);
        let equal = uniform_seconds_at(&uniform, error);
        let speedup = equal.map(|t| t / seconds);
        println!(
            "adaptive T {threshold:<6} {mean_spp:>8.1} spp {seconds:>9.3} s  rmse {error:.5}  uniform at equal error {}",
            equal.map_or("outside the sweep".to_string(), |t| format!("{t:.3} s ({:.2}x)", t / seconds))
        );
        adaptive.push((threshold, mean_spp, seconds, error, equal, speedup));
    }
    let json = serde_json::json!({
        "resolution": [width, height],
        "reference_spp": reference_spp,
        "reference_seconds": reference_seconds,
        "uniform": uniform.iter().map(|(s, t, e)| serde_json::json!({"spp": s, "seconds": t, "rmse": e})).collect::<Vec<_>>(),
        "adaptive": adaptive.iter().map(|(th, s, t, e, u, x)| serde_json::json!({
            "threshold": th, "mean_spp": s, "seconds": t, "rmse": e,
            "uniform_seconds_at_equal_rmse": u, "speedup": x,
        })).collect::<Vec<_>>(),
    });
    std::fs::write(out.join("adaptive.json"), serde_json::to_string_pretty(&json)?)?;
    let adaptive_points: Vec<(f64, f64)> = adaptive.iter().map(|a| (a.2, a.3)).collect();
    let uniform_points: Vec<(f64, f64)> = uniform.iter().map(|u| (u.1, u.2)).collect();
    chart(&uniform_points, &adaptive_points, &out.join("adaptive.svg"))?;
    println!("figures written to {}", out.join("adaptive.json").display());
    Ok(())
}

fn chart(uniform: &[(f64, f64)], adaptive: &[(f64, f64)], path: &Path) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let all = || uniform.iter().chain(adaptive);
    let (t0, t1) = all().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.0), hi.max(r.0)));
    let (e0, e1) = all().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.1), hi.max(r.1)));
    let mut chart = ChartBuilder::on(&root)
        .caption("Adaptive vs uniform sampling: RMSE vs render time", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((t0 * 0.8..t1 * 1.25).log_scale(), (e0 * 0.8..e1 * 1.25).log_scale())?;
    chart.configure_mesh().x_desc("render seconds").y_desc("RMSE vs reference").draw()?;
    for (points, colour, label) in [(uniform, BLUE, "uniform"), (adaptive, RED, "adaptive")] {
        chart
            .draw_series(LineSeries::new(points.iter().copied(), colour))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
    }
    chart.configure_series_labels().border_style(BLACK).draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn equal_error_time_interpolates_in_log_log() {
        let uniform = [(4, 1.0, 0.4), (8, 2.0, 0.2), (16, 4.0, 0.1)];
        let t = super::uniform_seconds_at(&uniform, 0.2f64.sqrt() * 0.1f64.sqrt()).unwrap();
        assert!((t - 8f64.sqrt()).abs() < 1e-9, "{t}");
        assert_eq!(super::uniform_seconds_at(&uniform, 0.05), None);
    }
}

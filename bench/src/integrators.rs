//! `bench integrators BLOB`: the scalar (depth-first) and wavefront (breadth-first) integrators on the
//! same blob, options and threads, side by side in one process: Msamples/s, Mrays/s, the ratio, the
//! wavefront's stage times, and whether the two images agree.

use render::{render_image, Image, Integrator, RenderOptions};
use std::path::Path;

fn best_of(view: &blob::SceneView, options: &RenderOptions, repeat: usize) -> anyhow::Result<Image> {
    let mut best: Option<Image> = None;
    for _ in 0..repeat.max(1) {
        let image = render_image(view, options)?;
        if best.as_ref().is_none_or(|b| image.stats.seconds < b.stats.seconds) {
            best = Some(image);
        }
    }
    Ok(best.expect("at least one run"))
}

/// Runs both integrators and writes `out/integrators.json`.
pub fn run(view: &blob::SceneView, options: &RenderOptions, repeat: usize, out: &Path) -> anyhow::Result<()> {
    let scalar = best_of(view, &RenderOptions { integrator: Integrator::Scalar, ..options.clone() }, repeat)?;
    let wave =
        best_of(view, &RenderOptions { integrator: Integrator::Wavefront, ..options.clone() }, repeat)?;
    let figures = |i: &Image| {
        let s = i.stats.seconds.max(1e-9);
        (i.stats.samples as f64 / s / 1e6, i.stats.rays.total() as f64 / s / 1e6)
    };
    let (ss, sr) = figures(&scalar);
    let (ws, wr) = figures(&wave);
    let max_diff = scalar
        .beauty
        .iter()
        .flatten()
        .zip(wave.beauty.iter().flatten())
        .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
    let st = wave.stats.stages;
    println!(
        "{}x{} @ {} spp, {} threads\nscalar:    {ss:.3} Msamples/s, {sr:.2} Mrays/s, {:.3} s\n\
         wavefront: {ws:.3} Msamples/s, {wr:.2} Mrays/s, {:.3} s\nwavefront/scalar: {:.3}\n\
         wavefront stages (CPU s): generate {:.3}, intersect {:.3}, sort {:.3}, shade {:.3}, occlusion {:.3}, accumulate {:.3}\n\
         max abs beauty difference: {max_diff:e}",
        scalar.width,
        scalar.height,
        options.spp,
        scalar.stats.threads,
        scalar.stats.seconds,
        wave.stats.seconds,
        ws / ss,
        st.generate,
        st.intersect,
        st.sort,
        st.shade,
        st.occlusion,
        st.accumulate,
    );
    let json = serde_json::json!({
        "width": scalar.width, "height": scalar.height, "spp": options.spp, "threads": scalar.stats.threads,
        "scalar": { "seconds": scalar.stats.seconds, "msamples_per_second": ss, "mrays_per_second": sr },
        "wavefront": { "seconds": wave.stats.seconds, "msamples_per_second": ws, "mrays_per_second": wr,
                       "stage_cpu_seconds": st },
        "ratio_wavefront_over_scalar": ws / ss,
        "max_abs_beauty_difference": max_diff,
    });
    std::fs::write(out.join("integrators.json"), serde_json::to_string_pretty(&json)?)?;
    Ok(())
}

//! `bench peers-table PEERS.json`: turns the sweeps of `scripts/bench-peers.sh` (ours, Cycles, Mitsuba 3:
//! RMSE against one reference and render seconds per spp) into a markdown table of the time each renderer
//! needs to reach one RMSE, and a log–log chart of RMSE against seconds with one curve per renderer.

use anyhow::Context;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::Path;

/// One renderer's sweep: (spp, seconds, RMSE) in increasing spp.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    pub name: String,
    pub points: Vec<Point>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub spp: u32,
    pub seconds: f64,
    pub rmse: f64,
}

/// When a curve first gets down to a target RMSE.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reach {
    /// Between two sweep points, interpolated on the log–log line through them (Monte-Carlo error
    /// falls as a power of time, so that line is the model, not a straight line in linear seconds).
    At { seconds: f64, spp: f64 },
    /// Already at the first point: the time is an upper bound.
    AtOrBefore { seconds: f64, spp: f64 },
    /// Not within the sweep.
    Never,
}

impl Reach {
    pub fn seconds(self) -> Option<f64> {
        match self {
            Reach::At { seconds, .. } | Reach::AtOrBefore { seconds, .. } => Some(seconds),
            Reach::Never => None,
        }
    }
}

/// Which time a curve plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Clock {
    /// Wall seconds to the image (`seconds`).
    Wall,
    /// CPU-seconds of the render (`cpu_seconds`): the work done, less sensitive to other processes
    /// taking the cores on a shared machine.
    Cpu,
}

impl Clock {
    fn field(self) -> &'static str {
        match self {
            Clock::Wall => "seconds",
            Clock::Cpu => "cpu_seconds",
        }
    }

    fn label(self) -> &'static str {
        match self {
            Clock::Wall => "wall seconds (time to image)",
            Clock::Cpu => "CPU-seconds of the render",
        }
    }
}

/// Reads the curves of `peers.json` (`renderers[].points[]` with `spp`, `rmse` and the clock's field).
pub fn curves(json: &serde_json::Value, clock: Clock) -> anyhow::Result<Vec<Curve>> {
    let renderers = json["renderers"].as_array().context("peers.json: no `renderers` array")?;
    renderers
        .iter()
        .map(|r| {
            let name = r["name"].as_str().context("peers.json: a renderer without a `name`")?.to_string();
            let points = r["points"]
                .as_array()
                .with_context(|| format!("peers.json: renderer {name} has no `points`"))?
                .iter()
                .map(|p| {
                    let field = |k: &str| {
                        p[k].as_f64()
                            .with_context(|| format!("peers.json: renderer {name}: a point without `{k}`"))
                    };
                    Ok(Point {
                        spp: field("spp")? as u32,
                        seconds: field(clock.field())?,
                        rmse: field("rmse")?,
                    })
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            let mut curve = Curve { name, points };
            curve.points.sort_by_key(|p| p.spp);
            Ok(curve)
        })
        .collect()
}

/// The first time `curve` gets down to `target` RMSE.
pub fn time_to_reach(curve: &Curve, target: f64) -> Reach {
    let Some(first) = curve.points.first() else { return Reach::Never };
    if first.rmse <= target {
        return Reach::AtOrBefore { seconds: first.seconds, spp: first.spp as f64 };
    }
    for pair in curve.points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if a.rmse > target && b.rmse <= target {
            // Fraction of the way from a to b in log RMSE; the same fraction in log seconds and log spp.
            let f = (target.ln() - a.rmse.ln()) / (b.rmse.ln() - a.rmse.ln());
            let lerp_log = |x: f64, y: f64| (x.ln() + f * (y.ln() - x.ln())).exp();
            return Reach::At {
                seconds: lerp_log(a.seconds, b.seconds),
                spp: lerp_log(a.spp as f64, b.spp as f64),
            };
        }
    }
    Reach::Never
}

/// The RMSE of `renderer`'s sweep at `spp`.
pub fn target_rmse(curves: &[Curve], renderer: &str, spp: u32) -> anyhow::Result<f64> {
    let curve = curves
        .iter()
        .find(|c| c.name == renderer)
        .with_context(|| format!("peers.json: no renderer {renderer} for the target RMSE"))?;
    curve
        .points
        .iter()
        .find(|p| p.spp == spp)
        .map(|p| p.rmse)
        .with_context(|| format!("peers.json: renderer {renderer} has no {spp}-spp point"))
}

/// Markdown: per renderer, the seconds to reach `target` RMSE (fastest first), the ratio to the
/// fastest, the spp that took, and the lowest RMSE of the sweep with its seconds.
pub fn table(curves: &[Curve], target: f64, target_label: &str, clock: Clock) -> String {
    let mut rows: Vec<(&Curve, Reach)> = curves.iter().map(|c| (c, time_to_reach(c, target))).collect();
    rows.sort_by(|a, b| {
        let key = |r: Reach| r.seconds().unwrap_or(f64::INFINITY);
        key(a.1).total_cmp(&key(b.1)).then_with(|| a.0.name.cmp(&b.0.name))
    });
    let fastest = rows.first().and_then(|r| r.1.seconds());
    let mut md = String::new();
    let _ = writeln!(md, "Time to reach RMSE {target:.5} ({target_label}), in {}:\n", clock.label());
    let _ =
        writeln!(md, "| renderer | seconds to reach | × the fastest | spp needed | lowest RMSE (seconds) |");
    let _ = writeln!(md, "|---|---|---|---|---|");
    for (curve, reach) in rows {
        let (seconds, ratio, spp) = match (reach, fastest) {
            (Reach::At { seconds, spp }, Some(f)) => {
                (format!("{seconds:.3}"), format!("{:.2}", seconds / f), format!("{spp:.1}"))
            }
            (Reach::AtOrBefore { seconds, spp }, Some(f)) => {
                (format!("≤ {seconds:.3}"), format!("≤ {:.2}", seconds / f), format!("≤ {spp:.0}"))
            }
            _ => ("not reached".into(), "–".into(), "–".into()),
        };
        let lowest = curve.points.iter().min_by(|a, b| a.rmse.total_cmp(&b.rmse));
        let lowest =
            lowest.map_or("–".into(), |p| format!("{:.5} ({:.2} s, {} spp)", p.rmse, p.seconds, p.spp));
        let _ = writeln!(md, "| {} | {seconds} | {ratio} | {spp} | {lowest} |", curve.name);
    }
    md
}

/// RMSE against seconds, log–log, one curve per renderer, the target RMSE as a dashed line.
pub fn chart(curves: &[Curve], target: f64, title: &str, clock: Clock, path: &Path) -> anyhow::Result<()> {
    let points = || curves.iter().flat_map(|c| c.points.iter());
    let (t0, t1) =
        points().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(p.seconds), hi.max(p.seconds)));
    let (e0, e1) = points().fold((target, target), |(lo, hi), p| (lo.min(p.rmse), hi.max(p.rmse)));
    anyhow::ensure!(
        t0.is_finite() && t0 > 0.0 && e0 > 0.0,
        "peers.json: no positive seconds and RMSE to chart"
    );
    let root = SVGBackend::new(path, (800, 540)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d((t0 * 0.8..t1 * 1.25).log_scale(), (e0 * 0.8..e1 * 1.25).log_scale())?;
    chart.configure_mesh().x_desc(clock.label()).y_desc("RMSE vs reference").draw()?;
    chart.draw_series(DashedLineSeries::new(
        [(t0 * 0.8, target), (t1 * 1.25, target)],
        6,
        4,
        BLACK.mix(0.5).stroke_width(1),
    ))?;
    for (i, curve) in curves.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                curve.points.iter().map(|p| (p.seconds, p.rmse)),
                colour.stroke_width(2),
            ))?
            .label(curve.name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
        chart
            .draw_series(curve.points.iter().map(|p| Circle::new((p.seconds, p.rmse), 3, colour.filled())))?;
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE.mix(0.9)).draw()?;
    root.present()?;
    Ok(())
}

/// Reads `peers.json`, writes the table and chart for each clock into `out` (`peers.md`, `peers.svg`
/// for wall seconds; `peers_cpu.md`, `peers_cpu.svg` for CPU-seconds) and prints the tables.
pub fn run(json_path: &Path, target_renderer: &str, target_spp: u32, out: &Path) -> anyhow::Result<()> {
    let text =
        std::fs::read_to_string(json_path).with_context(|| format!("cannot read {}", json_path.display()))?;
    let json: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{} is not JSON", json_path.display()))?;
    std::fs::create_dir_all(out)?;
    let reference = &json["reference"];
    let label = format!("{target_renderer} at {target_spp} spp");
    for (clock, stem) in [(Clock::Wall, "peers"), (Clock::Cpu, "peers_cpu")] {
        let curves = curves(&json, clock).with_context(|| format!("{}", json_path.display()))?;
        let target = target_rmse(&curves, target_renderer, target_spp)?;
        let md = table(&curves, target, &label, clock);
        let (md_path, svg_path) = (out.join(format!("{stem}.md")), out.join(format!("{stem}.svg")));
        std::fs::write(&md_path, &md)?;
        let title = format!(
            "RMSE vs {}, reference {} at {} spp",
            if clock == Clock::Wall { "wall seconds" } else { "CPU-seconds" },
            reference["renderer"].as_str().unwrap_or("?"),
            reference["spp"].as_u64().unwrap_or(0)
        );
        chart(&curves, target, &title, clock, &svg_path)?;
        println!("{md}");
        println!("written to {} and {}\n", md_path.display(), svg_path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Monte-Carlo-like curve: RMSE = c / sqrt(spp), seconds = overhead + per_spp · spp.
    fn mc_curve(name: &str, c: f64, per_spp: f64) -> Curve {
        let points = (0..8)
            .map(|k| {
                let spp = 1u32 << k;
                Point { spp, seconds: per_spp * spp as f64, rmse: c / (spp as f64).sqrt() }
            })
            .collect();
        Curve { name: name.into(), points }
    }

    #[test]
    fn a_power_law_curve_is_interpolated_exactly() {
        // RMSE = 0.4 / sqrt(spp) reaches 0.4 / sqrt(10) at 10 spp = 10 × 0.05 s, between 8 and 16 spp.
        let curve = mc_curve("a", 0.4, 0.05);
        match time_to_reach(&curve, 0.4 / 10f64.sqrt()) {
            Reach::At { seconds, spp } => {
                assert!((spp - 10.0).abs() < 1e-9, "spp {spp}");
                assert!((seconds - 0.5).abs() < 1e-9, "seconds {seconds}");
            }
            other => panic!("expected an interpolated reach, got {other:?}"),
        }
    }

    #[test]
    fn a_target_at_the_first_point_is_an_upper_bound_and_a_floor_above_it_is_never_reached() {
        let curve = mc_curve("a", 0.4, 0.05);
        assert_eq!(time_to_reach(&curve, 0.5), Reach::AtOrBefore { seconds: 0.05, spp: 1.0 });
        // A biased renderer: RMSE levels off at 0.03 above the target.
        let mut biased = mc_curve("biased", 0.4, 0.01);
        for p in &mut biased.points {
            p.rmse = (p.rmse * p.rmse + 0.03 * 0.03).sqrt();
        }
        assert_eq!(time_to_reach(&biased, 0.02), Reach::Never);
        // The first crossing counts, even if noise takes a later point back above the target.
        let mut noisy = mc_curve("noisy", 0.4, 0.05);
        noisy.points[5].rmse = 1.0;
        assert_eq!(time_to_reach(&noisy, 0.4 / 8f64.sqrt()).seconds(), Some(0.4));
    }

    #[test]
    fn the_table_orders_by_time_with_ratios_to_the_fastest() {
        // Same noise per sample; "slow" takes 3× as long per sample, so 3× as long to any RMSE.
        let curves = vec![mc_curve("slow", 0.4, 0.15), mc_curve("fast", 0.4, 0.05), {
            let mut c = mc_curve("floor", 0.4, 0.01);
            c.points.iter_mut().for_each(|p| p.rmse = p.rmse.max(0.2));
            c
        }];
        let target = target_rmse(&curves, "fast", 16).unwrap();
        assert!((target - 0.1).abs() < 1e-12);
        let md = table(&curves, target, "fast at 16 spp", Clock::Wall);
        let rows: Vec<&str> =
            md.lines().filter(|l| l.starts_with("| ") && !l.starts_with("| renderer")).collect();
        assert_eq!(rows.len(), 3, "{md}");
        assert!(rows[0].starts_with("| fast | 0.800 | 1.00 | 16.0 |"), "{md}");
        assert!(rows[1].starts_with("| slow | 2.400 | 3.00 | 16.0 |"), "{md}");
        assert!(rows[2].starts_with("| floor | not reached |"), "{md}");
        assert!(md.contains("RMSE 0.10000 (fast at 16 spp)"), "{md}");
    }

    #[test]
    fn curves_are_read_from_peers_json_and_a_missing_field_is_named() {
        let json = serde_json::json!({"renderers": [
            {"name": "cycles", "points": [{"spp": 2, "seconds": 0.4, "rmse": 0.1}, {"spp": 1, "seconds": 0.2, "rmse": 0.14}]}
        ]});
        let c = curves(&json, Clock::Wall).unwrap();
        assert_eq!(c[0].name, "cycles");
        assert_eq!(c[0].points.iter().map(|p| p.spp).collect::<Vec<_>>(), vec![1, 2]);
        let bad =
            serde_json::json!({"renderers": [{"name": "cycles", "points": [{"spp": 1, "seconds": 0.2}]}]});
        let err = format!("{:#}", curves(&bad, Clock::Wall).unwrap_err());
        assert!(err.contains("cycles") && err.contains("`rmse`"), "{err}");
        // The CPU clock reads `cpu_seconds`, and names it when it is missing.
        let err = format!("{:#}", curves(&json, Clock::Cpu).unwrap_err());
        assert!(err.contains("`cpu_seconds`"), "{err}");
        let cpu = serde_json::json!({"renderers": [{"name": "ours", "points": [{"spp": 1, "seconds": 0.5, "cpu_seconds": 0.9, "rmse": 0.1}]}]});
        assert_eq!(curves(&cpu, Clock::Cpu).unwrap()[0].points[0].seconds, 0.9);
        assert!(target_rmse(&c, "mitsuba", 16).is_err());
        assert!(format!("{:#}", target_rmse(&c, "cycles", 16).unwrap_err()).contains("16-spp"));
    }

    #[test]
    fn the_chart_is_an_svg_with_one_legend_entry_per_renderer() {
        let dir = std::env::temp_dir().join(format!("peers-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("peers.svg");
        chart(&[mc_curve("ours", 0.4, 0.05), mc_curve("cycles", 0.4, 0.15)], 0.1, "test", Clock::Cpu, &path)
            .unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        // plotters writes each text element's content on a line of its own.
        let texts: Vec<&str> = svg.lines().map(str::trim).collect();
        assert!(svg.starts_with("<svg") && texts.contains(&"ours") && texts.contains(&"cycles"), "{svg}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

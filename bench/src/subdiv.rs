//! `bench subdiv`: subdivision tessellation error against ingest time and blob size.
//!
//! For each asset, the whole ingest (USD → diced limit surfaces → BVH → blob) runs once per
//! uniform level 0…max and, per dicing rate (4, 2, 1, 0.5 px), once with uniform dicing (one
//! level per mesh) and once with adaptive dicing (segments per cage edge, Bfr), and the
//! tessellation's chordal error is measured in pixels at the render camera. The machine's load
//! average is recorded beside the figures (timings on a shared machine are contended). Assets without a camera get one:
//! a wrapper layer sublayers the asset and adds the camera `render` would frame it with (45°
//! horizontal field of view, 512 × 512), so dicing and error see the same view as the image.
//!
//! ## The error measure
//!
//! The triangles' vertices are exact limit points, so the error lives between them. For a level-N
//! face, the level-(N+1) vertices inside it are also exact limit points, at known parameters:
//! the edge children at the parametric midpoints of the face's edges and (Catmull–Clark,
//! bilinear) the face child at its centre. The flat level-N tessellation puts the same parameters
//! at the chord midpoints `(P(a) + P(b)) / 2` and, for quads, at the midpoint of the diagonal the
//! quad was split along. The distance between the two is the chordal deviation at that
//! parameter; for a surface that is locally quadratic (which the error of a fine tessellation
//! is), the deviation along an edge peaks at its midpoint, so the maximum over these samples is
//! the standard midpoint estimate of the chordal error (it can miss a larger deviation in the
//! interior of a triangle, by a bounded factor). Each sample's world distance is scaled by the
//! camera's pixels per unit at its depth; samples outside the view are left out.
//!
//! An adaptive tessellation is measured the same way, at the parametric midpoint of every
//! triangle edge (which, for the uniform grid, are exactly the level-(N+1) edge children and the
//! quad centres on the split diagonals): the cage is re-tessellated with the recorded edge rates,
//! keeping each triangle corner's (u, v) in its face, and Bfr evaluates the limit at the midpoint
//! of each edge's (u, v). Triangles of faces Bfr splits into quadrilateral sub-faces
//! (Catmull–Clark non-quads) have no single (u, v) chart and are left out (counted).
//!
//! The level-(N+1) children of a level-N face are found topologically, without relying on
//! OpenSubdiv's vertex numbering: child faces are contiguous per parent (Vtr refines face by
//! face; checked against the `coarse_face` ancestry), the face child is the vertex every child
//! shares, a vertex child appears in one child and sits on its parent's limit point, and the
//! child of edge (a, b) is the vertex the children at a and at b share besides the face child.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

use ::subdiv::{AdaptiveRefiner, Refiner, Scheme};
use anyhow::{bail, Context};
use glam::DVec3;
use ingest::dicing::{DicingCamera, SubdivMode, SubdivOptions};
use plotters::prelude::*;

/// Dicing rates of the sweep, in pixels.
const RATES: [f32; 4] = [4.0, 2.0, 1.0, 0.5];

/// One asset of the sweep: a name and its root layer; `max_level` caps dicing (both modes) and
/// `forced_max` is the highest forced uniform level run.
pub struct Asset {
    pub name: String,
    pub path: PathBuf,
    pub max_level: u32,
    pub forced_max: u32,
}

/// Chordal error statistics, in pixels.
#[derive(Clone, Copy, Debug, Default)]
struct ErrorStats {
    max: f64,
    sum_sq: f64,
    samples: u64,
    /// Faces whose children could not be paired with their corners (left out).
    skipped_faces: u64,
}

impl ErrorStats {
    fn add(&mut self, px: f64) {
        self.max = self.max.max(px);
        self.sum_sq += px * px;
        self.samples += 1;
    }

    fn merge(&mut self, o: &ErrorStats) {
        self.max = self.max.max(o.max);
        self.sum_sq += o.sum_sq;
        self.samples += o.samples;
        self.skipped_faces += o.skipped_faces;
    }

    fn rms(&self) -> f64 {
        (self.sum_sq / self.samples.max(1) as f64).sqrt()
    }
}

/// How the meshes of one ingest were diced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A forced uniform level (`--subdiv-level`).
    Level,
    /// Uniform dicing from the camera at a rate.
    Uniform,
    /// Adaptive (per-edge) dicing from the camera at a rate.
    Adaptive,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Level => "level",
            Kind::Uniform => "uniform",
            Kind::Adaptive => "adaptive",
        }
    }
}

/// One ingest of the sweep.
struct Row {
    asset: String,
    mode: String,
    kind: Kind,
    /// Dicing rate in pixels (rate rows).
    rate: Option<f32>,
    levels: Vec<u32>,
    /// Smallest and largest segments per cage edge (adaptive rows).
    edge_rates: Option<(u32, u32)>,
    /// Pixels of the render camera's image.
    pixels: u64,
    triangles: usize,
    seconds: f64,
    blob_bytes: usize,
    error: ErrorStats,
    /// 1-minute load average after the ingest.
    load: Option<f64>,
}

/// A root layer that adds `render`'s framing camera to an asset without one.
fn with_framing_camera(asset: &Path, out: &Path, name: &str) -> anyhow::Result<PathBuf> {
    let options = ingest::usd::LoadOptions {
        subdiv: SubdivOptions { forced_level: Some(0), ..SubdivOptions::default() },
        ..ingest::usd::LoadOptions::default()
    };
    let scene =
        ingest::usd::load(asset, &options).with_context(|| format!("cannot load {}", asset.display()))?;
    if scene.default_camera.is_some() {
        return Ok(asset.to_path_buf());
    }
    let (lo, hi) = scene
        .meshes
        .iter()
        .flat_map(|m| &m.positions)
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.as_dvec3()), hi.max(p.as_dvec3()))
        });
    if !lo.cmple(hi).all() {
        bail!("{} has no geometry", asset.display());
    }
    // As render::camera::Camera::framing: the bounding sphere fit into a 45° field of view.
    let (centre, radius) = ((lo + hi) / 2.0, ((hi - lo).length() / 2.0).max(1e-3));
    let half_fov = 22.5f64.to_radians();
    let distance = radius / half_fov.sin() * 1.05;
    let z_up = scene.up_axis == ingest::UpAxis::Z;
    let (eye, rotate) = if z_up {
        (centre - DVec3::Y * distance, "(90, 0, 0)")
    } else {
        (centre + DVec3::Z * distance, "(0, 0, 0)")
    };
    let focal = 18.0 / half_fov.tan();
    let text = format!(
        r#"#usda 1.0
(
    subLayers = [@{asset}@]
    upAxis = "{up}"
)

def Camera "BenchCamera" {{
    float focalLength = {focal}
    float horizontalAperture = 36
    float verticalAperture = 36
    float2 clippingRange = ({near}, {far})
    double3 xformOp:translate = ({x}, {y}, {z})
    float3 xformOp:rotateXYZ = {rotate}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}}
"#,
        asset = std::fs::canonicalize(asset)?.display(),
        up = if z_up { "Z" } else { "Y" },
        near = (distance - radius).max(distance * 1e-3),
        far = distance + 2.0 * radius,
        x = eye.x,
        y = eye.y,
        z = eye.z,
    );
    let path = out.join(format!("subdiv_{name}.usda"));
    std::fs::write(&path, text)?;
    Ok(path)
}

/// The cage points of `s` in world space (subdivision commutes with affine maps, so the world-space
/// cage refines to the world-space surface).
fn world_cage(s: &ingest::Subdivision) -> Vec<[f32; 3]> {
    s.points
        .iter()
        .map(|p| {
            s.world_from_local.transform_point3(glam::Vec3::from_array(*p).as_dvec3()).as_vec3().to_array()
        })
        .collect()
}

/// Chordal error of one subdivision surface refined to `level`, in pixels at `camera`.
fn chordal_error(s: &ingest::Subdivision, level: u32, camera: &DicingCamera) -> anyhow::Result<ErrorStats> {
    let world = world_cage(s);
    let coarse = Refiner::new(&s.topology, level)?;
    let fine = Refiner::new(&s.topology, coarse.level() + 1)?;
    let (f0, f1) = (coarse.faces(None)?, fine.faces(None)?);
    let (p0, p1) = (coarse.limit(&world)?.positions, fine.limit(&world)?.positions);
    let v = |p: [f64; 3]| DVec3::from_array(p);

    let mut stats = ErrorStats::default();
    let mut skipped = 0;
    let mut sample = |flat: DVec3, exact: DVec3| {
        if !camera.outside(exact, exact) {
            stats.add(flat.distance(exact) * camera.pixels_per_unit_at(exact));
        }
    };
    let mut seen_edges = HashSet::new();
    let (mut start0, mut child) = (0usize, 0usize);
    let mut start1 = vec![0usize; f1.counts.len() + 1];
    for (i, &n) in f1.counts.iter().enumerate() {
        start1[i + 1] = start1[i] + n as usize;
    }
    for (face, &n) in f0.counts.iter().enumerate() {
        let n = n as usize;
        let parent = &f0.vertices[start0..start0 + n];
        start0 += n;
        // Quads and n-gons split into n quads (Catmull–Clark, bilinear), triangles into 4 (loop).
        let children = if fine.scheme() == Scheme::Loop { 4 } else { n };
        let group = child..child + children;
        child += children;
        if group.end > f1.counts.len() || group.clone().any(|c| f1.coarse_face[c] != f0.coarse_face[face]) {
            bail!("refined faces are not grouped by parent face; cannot pair levels");
        }
        if f0.is_hole[face] {
            continue;
        }
        let faces: Vec<&[u32]> = group.map(|c| &f1.vertices[start1[c]..start1[c + 1]]).collect();
        let mut uses: HashMap<u32, usize> = HashMap::new();
        for f in &faces {
            for &x in *f {
                *uses.entry(x).or_default() += 1;
            }
        }
        let face_child = uses.iter().find(|(_, &u)| u == faces.len()).map(|(&x, _)| x);
        let singles: Vec<u32> = uses.iter().filter(|(_, &u)| u == 1).map(|(&x, _)| x).collect();
        // The child of each parent corner: the single-use vertex on its limit point. Faces whose
        // children cannot be told apart (coincident cage points, non-manifold neighbourhoods)
        // are skipped and counted.
        let corner_child: Option<Vec<u32>> = parent
            .iter()
            .map(|&p| {
                let at = v(p0[p as usize]);
                singles.iter().copied().min_by(|&a, &b| {
                    v(p1[a as usize]).distance(at).total_cmp(&v(p1[b as usize]).distance(at))
                })
            })
            .collect();
        let Some(corner_child) = corner_child else {
            skipped += 1;
            continue;
        };
        let holder = |x: u32| faces.iter().find(|f| f.contains(&x));
        let mut edge_samples = Vec::with_capacity(n);
        for j in 0..n {
            let (a, b) = (parent[j], parent[(j + 1) % n]);
            let shared = holder(corner_child[j])
                .zip(holder(corner_child[(j + 1) % n]))
                .and_then(|(fa, fb)| fa.iter().copied().find(|x| Some(*x) != face_child && fb.contains(x)));
            match shared {
                Some(edge_child) => edge_samples.push((a, b, edge_child)),
                None => break,
            }
        }
        if edge_samples.len() != n {
            skipped += 1;
            continue;
        }
        for (a, b, edge_child) in edge_samples {
            if seen_edges.insert((a.min(b), a.max(b))) {
                sample((v(p0[a as usize]) + v(p0[b as usize])) / 2.0, v(p1[edge_child as usize]));
            }
        }
        if let (4, Some(centre)) = (n, face_child) {
            // The flat quad's centre lies on the diagonal it was split along (the shorter one,
            // as `subdiv::tessellate` splits).
            let q = parent.iter().map(|&p| v(p0[p as usize])).collect::<Vec<_>>();
            let mid = if q[0].distance(q[2]) <= q[1].distance(q[3]) {
                (q[0] + q[2]) / 2.0
            } else {
                (q[1] + q[3]) / 2.0
            };
            sample(mid, v(p1[centre as usize]));
        }
    }
    stats.skipped_faces = skipped;
    Ok(stats)
}

/// Chordal error of one adaptively tessellated surface, in pixels at `camera`: the flat
/// triangle edges against the limit at their parametric midpoints (see the module docs).
fn adaptive_chordal_error(s: &ingest::Subdivision, camera: &DicingCamera) -> anyhow::Result<ErrorStats> {
    let world = world_cage(s);
    let refiner = AdaptiveRefiner::new(&s.topology)?;
    let tess = refiner.tessellate(&world, None, &s.edge_rates, true)?;
    let mesh = &tess.mesh;
    // Faces Bfr parameterizes with quadrilateral sub-faces: no single chart for midpoints.
    let sub_faces = |f: u32| {
        let n = refiner.face(f as usize).0.len();
        n != 4 && !(n == 3 && s.topology.options().scheme == Scheme::Loop)
    };
    let mut skipped = HashSet::new();
    let mut seen = HashSet::new();
    let (mut samples, mut chords) = (Vec::new(), Vec::new());
    for ((t, corners), &face) in mesh.triangles.iter().zip(&tess.corner_coords).zip(&mesh.coarse_face) {
        if sub_faces(face) {
            skipped.insert(face);
            continue;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if !seen.insert((a.min(b), a.max(b))) {
                continue;
            }
            let (ca, cb) = (corners[k], corners[(k + 1) % 3]);
            let uv = [f64::from(ca[0] + cb[0]) / 2.0, f64::from(ca[1] + cb[1]) / 2.0];
            samples.push((face, uv));
            let p = |i: u32| glam::Vec3::from_array(mesh.positions[i as usize]).as_dvec3();
            chords.push((p(a) + p(b)) / 2.0);
        }
    }
    let exact = refiner.evaluate(&world, &samples)?;
    let mut stats = ErrorStats::default();
    for (flat, exact) in chords.iter().zip(exact) {
        let exact = DVec3::from_array(exact);
        if !camera.outside(exact, exact) {
            stats.add(flat.distance(exact) * camera.pixels_per_unit_at(exact));
        }
    }
    stats.skipped_faces = skipped.len() as u64;
    Ok(stats)
}

/// The 1-minute load average, for the record.
fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

/// Runs the sweep and writes `subdiv.json` and `subdiv.svg` into `out`.
pub fn run(assets: &[Asset], out: &Path) -> anyhow::Result<()> {
    let load_start = load_average();
    let mut rows = Vec::new();
    for asset in assets {
        let root = with_framing_camera(&asset.path, out, &asset.name)?;
        let blob = out.join(format!("subdiv_{}.blob", asset.name));
        // Errors per (mesh, level), shared by every run that picks that level for that mesh.
        let mut cache: HashMap<(usize, u32), ErrorStats> = HashMap::new();
        let mut modes: Vec<(String, Kind, Option<f32>, SubdivOptions)> = (0..=asset.forced_max)
            .map(|l| {
                let options = SubdivOptions { forced_level: Some(l), ..SubdivOptions::default() };
                (format!("level {l}"), Kind::Level, None, options)
            })
            .collect();
        for &r in &RATES {
            for (kind, mode) in [(Kind::Uniform, SubdivMode::Uniform), (Kind::Adaptive, SubdivMode::Adaptive)]
            {
                let options = SubdivOptions {
                    dicing_rate: r,
                    max_level: asset.max_level,
                    mode,
                    ..SubdivOptions::default()
                };
                modes.push((format!("{} {r} px", kind.name()), kind, Some(r), options));
            }
        }
        for (mode, kind, rate, subdiv) in modes {
            let options = ingest::usd::LoadOptions { subdiv, ..ingest::usd::LoadOptions::default() };
            let start = Instant::now();
            let (scene, report) = ingest::pipeline::ingest_file(&root, &blob, &options)?;
            let seconds = start.elapsed().as_secs_f64();
            let camera = scene
                .default_camera
                .map(|i| DicingCamera::new(&scene.cameras[i], scene.resolution))
                .context("no render camera")?;
            let mut error = ErrorStats::default();
            for (k, s) in scene.subdivisions.iter().enumerate() {
                if !s.edge_rates.is_empty() {
                    let stats = adaptive_chordal_error(s, &camera)
                        .with_context(|| scene.meshes[s.mesh].path.clone())?;
                    error.merge(&stats);
                    continue;
                }
                let stats = match cache.get(&(k, s.level)) {
                    Some(stats) => *stats,
                    None => {
                        let stats = chordal_error(s, s.level, &camera)
                            .with_context(|| scene.meshes[s.mesh].path.clone())?;
                        cache.insert((k, s.level), stats);
                        stats
                    }
                };
                error.merge(&stats);
            }
            let mut levels: Vec<u32> = scene.subdivisions.iter().map(|s| s.level).collect();
            levels.sort_unstable();
            let rates = scene.subdivisions.iter().flat_map(|s| &s.edge_rates);
            let edge_rates = rates.clone().min().copied().zip(rates.max().copied());
            let [w, h] = camera.resolution();
            let row = Row {
                asset: asset.name.clone(),
                mode,
                kind,
                rate,
                levels,
                edge_rates,
                pixels: u64::from(w) * u64::from(h),
                triangles: report.triangles,
                seconds,
                blob_bytes: report.blob_bytes,
                error,
                load: load_average(),
            };
            print_row(&row);
            rows.push(row);
        }
        let _ = std::fs::remove_file(&blob);
    }
    let json = serde_json::json!({
        "error": "chordal error at the parametric midpoints of the tessellation's edges (uniform: level-N edge midpoints and quad centres against the level-(N+1) limit points; adaptive: Bfr limit at the (u, v) midpoint of each triangle edge), pixels at the render camera",
        "load_average": { "start": load_start, "end": load_average() },
        "rows": rows.iter().map(|r| {
            let (lo, hi) = (r.levels.first().copied(), r.levels.last().copied());
            serde_json::json!({
                "asset": r.asset, "mode": r.mode, "kind": r.kind.name(), "dicing_rate_px": r.rate,
                "min_level": lo, "max_level": hi,
                "min_edge_rate": r.edge_rates.map(|e| e.0), "max_edge_rate": r.edge_rates.map(|e| e.1),
                "subdivision_meshes": r.levels.len(), "triangles": r.triangles,
                "triangles_per_pixel": r.triangles as f64 / r.pixels.max(1) as f64,
                "load_average": r.load,
                "ingest_seconds": r.seconds, "blob_bytes": r.blob_bytes,
                "error_max_px": r.error.max, "error_rms_px": r.error.rms(), "error_samples": r.error.samples,
                "skipped_faces": r.error.skipped_faces,
            })
        }).collect::<Vec<_>>(),
    });
    std::fs::write(out.join("subdiv.json"), serde_json::to_string_pretty(&json)?)?;
    chart(&rows, &out.join("subdiv.svg"))?;
    println!("figures written to {}", out.join("subdiv.json").display());
    Ok(())
}

fn print_row(r: &Row) {
    let (lo, hi) = (r.levels.first().copied().unwrap_or(0), r.levels.last().copied().unwrap_or(0));
    let rates = r.edge_rates.map_or(String::new(), |(a, b)| format!(" rates {a}..{b}"));
    println!(
        "{:<8} {:<16} levels {lo}..{hi}{rates}  {:>10} tris ({:.2}/px)  {:>7.2} s  {:>8.1} MiB  err max {:>8.4} px  rms {:>8.4} px  load {:.1}",
        r.asset,
        r.mode,
        r.triangles,
        r.triangles as f64 / r.pixels.max(1) as f64,
        r.seconds,
        r.blob_bytes as f64 / (1 << 20) as f64,
        r.error.max,
        r.error.rms(),
        r.load.unwrap_or(f64::NAN),
    );
}

/// A log-scaled range around `values` (positive, finite ones), padded by a factor.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi {
        return 0.1..10.0;
    }
    lo / 1.5..hi * 1.5
}

/// One panel: `y(row)` against `x(row)`, log–log, one line per asset and kind (solid: uniform
/// dicing, dashed: adaptive, thin: forced levels), labelled with the mode.
fn panel(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    rows: &[&Row],
    caption: &str,
    (x_desc, x): (&str, &dyn Fn(&Row) -> f64),
    (y_desc, y): (&str, &dyn Fn(&Row) -> f64),
    kinds: &[Kind],
) -> anyhow::Result<()> {
    let rows: Vec<&Row> =
        rows.iter().copied().filter(|r| kinds.contains(&r.kind) && x(r) > 0.0 && y(r) > 0.0).collect();
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(34)
        .y_label_area_size(56)
        .build_cartesian_2d(
            log_range(rows.iter().map(|r| x(r))).log_scale(),
            log_range(rows.iter().map(|r| y(r))).log_scale(),
        )?;
    chart.configure_mesh().x_desc(x_desc).y_desc(y_desc).label_style(("sans-serif", 11)).draw()?;
    let palette = [BLUE, RED, GREEN, MAGENTA];
    let mut assets: Vec<&str> = rows.iter().map(|r| r.asset.as_str()).collect();
    assets.dedup();
    for (k, asset) in assets.iter().enumerate() {
        let colour = palette[k % palette.len()];
        for &kind in kinds {
            let pts: Vec<&Row> =
                rows.iter().copied().filter(|r| r.asset == *asset && r.kind == kind).collect();
            if pts.is_empty() {
                continue;
            }
            let style = match kind {
                Kind::Level => colour.mix(0.4).stroke_width(1),
                Kind::Uniform => colour.stroke_width(2),
                Kind::Adaptive => colour.mix(0.6).stroke_width(3),
            };
            let points: Vec<(f64, f64)> = pts.iter().map(|r| (x(r), y(r))).collect();
            if kind == Kind::Adaptive {
                chart
                    .draw_series(DashedLineSeries::new(points.clone(), 6, 4, style))?
                    .label(format!("{asset}: {}", kind.name()))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
            } else {
                chart
                    .draw_series(LineSeries::new(points.clone(), style))?
                    .label(format!("{asset}: {}", kind.name()))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
            }
            chart.draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
            chart.draw_series(pts.iter().map(|r| {
                let label = r
                    .mode
                    .replace("level ", "L")
                    .replace("uniform ", "")
                    .replace("adaptive ", "")
                    .replace(" px", "");
                Text::new(label, (x(r), y(r) * 1.1), ("sans-serif", 10).into_font())
            }))?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 10))
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    Ok(())
}

/// Six panels: max and RMS error, triangles, ingest seconds and blob size against the dicing
/// rate (uniform vs adaptive), and max error against ingest seconds for every run.
fn chart(rows: &[Row], path: &Path) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (1500, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled("Subdivision: uniform vs adaptive (per-edge) dicing", ("sans-serif", 20))?;
    let areas = root.split_evenly((2, 3));
    let rows: Vec<&Row> = rows.iter().collect();
    let rate_px = |r: &Row| f64::from(r.rate.unwrap_or(0.0));
    let rate: (&str, &dyn Fn(&Row) -> f64) = ("dicing rate, px", &rate_px);
    let diced = [Kind::Uniform, Kind::Adaptive];
    panel(&areas[0], &rows, "max chordal error", rate, ("px", &|r: &Row| r.error.max), &diced)?;
    panel(&areas[1], &rows, "RMS chordal error", rate, ("px", &|r: &Row| r.error.rms()), &diced)?;
    panel(&areas[2], &rows, "triangles", rate, ("triangles", &|r: &Row| r.triangles as f64), &diced)?;
    panel(&areas[3], &rows, "ingest seconds (USD → blob)", rate, ("s", &|r: &Row| r.seconds), &diced)?;
    panel(
        &areas[4],
        &rows,
        "blob size",
        rate,
        ("MiB", &|r: &Row| r.blob_bytes as f64 / f64::from(1 << 20)),
        &diced,
    )?;
    panel(
        &areas[5],
        &rows,
        "max error vs ingest seconds (all runs)",
        ("ingest seconds", &|r: &Row| r.seconds),
        ("max error, px", &|r: &Row| r.error.max),
        &[Kind::Level, Kind::Uniform, Kind::Adaptive],
    )?;
    root.present()?;
    Ok(())
}

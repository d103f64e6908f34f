//! UsdGeomBasisCurves, UsdGeomNurbsCurves and UsdGeomPoints: topology, widths, normals and the
//! displayColor / st primvars, converted to world-space cubic Bézier segments (`crate::curves` holds
//! the basis math) or spheres.
//!
//! Schema facts used here: `type` (fallback cubic), `basis` (fallback bezier), `wrap` (fallback
//! nonperiodic). `widths` has no schema fallback in usd-core; Hydra (Storm) draws unauthored widths as
//! 1, and so do we ([`super::fallback::CURVE_WIDTH`]). `primvars:widths` / `primvars:normals` win over
//! `widths` / `normals`. When a primvar's interpolation is unauthored it is inferred from its size
//! (1 → constant, curves → uniform, varying count → varying, points → vertex), as Hydra does.

use glam::{DMat3, Vec2, Vec3, Vec4};

use super::stage::Value;
use super::{fallback, Inherited, Reader, UsdError};
use crate::curves::{self, Basis, CurveType, Wrap};
use crate::scene::{BezierSegment, CurveKind, Curves, PointSphere};

/// Highest NurbsCurves `order` read (degree 63). usd-core sets none; modelling tools stop far
/// below (Rhino at degree 11), and the knots and the de Boor evaluation of each curve are sized by
/// it (`order = 2147483647` asked for 17 GB).
pub(crate) const MAX_NURBS_ORDER: usize = 64;

/// Primvar interpolation along curves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Interp {
    Constant,
    Uniform,
    Varying,
    Vertex,
}

/// A primvar with indices flattened, components padded into a `Vec4`.
struct Primvar {
    values: Vec<Vec4>,
    interp: Interp,
}

/// Per-curve counts of a BasisCurves prim.
struct Topology {
    /// Vertex count per curve.
    counts: Vec<usize>,
    /// Varying values per curve.
    varying: Vec<usize>,
    wrap: Wrap,
}

impl Topology {
    fn total(&self, interp: Interp) -> usize {
        match interp {
            Interp::Constant => 1,
            Interp::Uniform => self.counts.len(),
            Interp::Varying => self.varying.iter().sum(),
            Interp::Vertex => self.counts.iter().sum(),
        }
    }
}

/// How world space scales lengths: the transform's mean scale (cube root of |det|).
fn length_scale(m: &glam::DMat4) -> f32 {
    DMat3::from_mat4(*m).determinant().abs().cbrt() as f32
}

impl Reader<'_> {
    /// Reads a primvar `names[0]` (or the first present of `names`) with `N` components.
    fn curve_primvar<const N: usize>(
        &mut self,
        path: &str,
        names: &[&str],
        topology: &Topology,
    ) -> Result<Option<Primvar>, UsdError> {
        let Some(name) = names.iter().find(|n| self.stage.attr(path, n).ok().flatten().is_some()) else {
            return Ok(None);
        };
        let value = self.stage.attr(path, name)?.unwrap_or(Value::Other);
        let raw: Vec<[f64; N]> = match (&value, value.as_array::<N>(), value.as_tuple::<N>()) {
            (Value::Scalar(s), _, _) if N == 1 => vec![[*s; N]],
            (_, Some(a), _) => a,
            (_, None, Some(t)) => vec![t],
            _ => {
                self.warn(path, format!("{name} has an unexpected type; ignored"));
                return Ok(None);
            }
        };
        let values: Vec<[f64; N]> = match self.ints(path, &format!("{name}:indices")).ok().flatten() {
            Some(indices) => {
                match indices
                    .iter()
                    .map(|&i| usize::try_from(i).ok().and_then(|i| raw.get(i).copied()))
                    .collect()
                {
                    Some(v) => v,
                    None => {
                        self.warn(path, format!("{name}:indices indexes past {} values; ignored", raw.len()));
                        return Ok(None);
                    }
                }
            }
            None => raw,
        };
        let authored = self.stage.attr_metadata(path, name, "interpolation");
        let interp = match authored.as_ref().and_then(|v| v.as_str()) {
            Some("constant") => Some(Interp::Constant),
            Some("uniform") => Some(Interp::Uniform),
            Some("varying") => Some(Interp::Varying),
            Some("vertex") => Some(Interp::Vertex),
            Some(other) => {
                self.warn(
                    path,
                    format!("{name} has interpolation {other:?}, not defined for curves; inferring"),
                );
                None
            }
            None => None,
        };
        let fits = |i: Interp| topology.total(i) == values.len();
        let interp = match interp {
            Some(i) if fits(i) || (i == Interp::Constant && !values.is_empty()) => i,
            _ => {
                let inferred = [Interp::Vertex, Interp::Varying, Interp::Uniform, Interp::Constant]
                    .into_iter()
                    .find(|&i| fits(i));
                match inferred {
                    Some(i) => {
                        if interp.is_some() {
                            self.warn(path, format!("{name} has {} values; read as {i:?}", values.len()));
                        }
                        i
                    }
                    None => {
                        self.warn(
                            path,
                            format!("{name} has {} values, matching no interpolation; ignored", values.len()),
                        );
                        return Ok(None);
                    }
                }
            }
        };
        let values = values
            .into_iter()
            .map(|v| {
                let mut out = [0.0f32; 4];
                for (o, x) in out.iter_mut().zip(v) {
                    *o = x as f32;
                }
                Vec4::from_array(out)
            })
            .collect();
        Ok(Some(Primvar { values, interp }))
    }

    /// Reads a BasisCurves prim.
    pub(super) fn read_basis_curves(&mut self, path: &str, state: &Inherited) -> Result<(), UsdError> {
        let ty = match self.token(path, "type")?.as_deref().unwrap_or(fallback::CURVE_TYPE) {
            "linear" => CurveType::Linear,
            "cubic" => CurveType::Cubic,
            other => {
                self.warn(path, format!("unknown curve type {other:?}; curves skipped"));
                return Ok(());
            }
        };
        let basis = match self.token(path, "basis")?.as_deref().unwrap_or(fallback::CURVE_BASIS) {
            "bezier" => Basis::Bezier,
            "bspline" => Basis::Bspline,
            "catmullRom" => Basis::CatmullRom,
            other => {
                self.warn(path, format!("basis {other:?} not supported; curves skipped"));
                return Ok(());
            }
        };
        let wrap = match self.token(path, "wrap")?.as_deref().unwrap_or(fallback::CURVE_WRAP) {
            "nonperiodic" => Wrap::Nonperiodic,
            "periodic" => Wrap::Periodic,
            "pinned" => Wrap::Pinned,
            other => {
                self.warn(path, format!("unknown wrap {other:?}; curves skipped"));
                return Ok(());
            }
        };
        let points = self.vec3s(path, "points")?.unwrap_or_default();
        let counts: Vec<usize> = match self
            .ints(path, "curveVertexCounts")?
            .unwrap_or_default()
            .into_iter()
            .map(usize::try_from)
            .collect()
        {
            Ok(c) => c,
            Err(_) => return Err(self.invalid(path, "curveVertexCounts", "negative vertex count".into())),
        };
        // Saturating: counts near usize::MAX could wrap to the point count and index past it.
        let vertex_total = counts.iter().fold(0usize, |sum, &n| sum.saturating_add(n));
        if vertex_total != points.len() {
            self.warn(
                path,
                format!(
                    "curveVertexCounts sum to {vertex_total} but there are {} points; curves skipped",
                    points.len()
                ),
            );
            return Ok(());
        }
        let varying = counts
            .iter()
            .map(|&n| {
                let segments = curves::usd_segment_count(n, ty, basis, wrap).unwrap_or(0);
                if wrap == Wrap::Periodic {
                    segments
                } else {
                    segments + 1
                }
            })
            .collect();
        let topology = Topology { counts, varying, wrap };
        let widths = self.curve_primvar::<1>(path, &["primvars:widths", "widths"], &topology)?;
        let normals = self.curve_primvar::<3>(path, &["primvars:normals", "normals"], &topology)?;
        let colors = self.curve_primvar::<3>(path, &["primvars:displayColor"], &topology)?;
        let uvs = match self.st_primvar_name(path) {
            Some(name) => self.curve_primvar::<2>(path, &[name.as_str()], &topology)?,
            None => None,
        };
        let material = self.gprim_material(path)?;
        let world = state.world_from_local;
        let normal_from_local = DMat3::from_mat4(world).inverse().transpose();
        let scale = length_scale(&world);
        let mut out = Curves {
            path: path.to_string(),
            kind: if normals.is_some() { CurveKind::Ribbon } else { CurveKind::Tube },
            material,
            curve_count: topology.counts.len(),
            has_normals: normals.is_some(),
            has_colors: colors.as_ref().is_some_and(|c| c.interp != Interp::Constant),
            has_uvs: uvs.is_some(),
            ..Curves::default()
        };
        let mut skipped = 0;
        let (mut first_vertex, mut first_varying) = (0usize, 0usize);
        for (c, &n) in topology.counts.iter().enumerate() {
            let vertex_range = first_vertex..first_vertex + n;
            let varying_range = first_varying..first_varying + topology.varying[c];
            first_vertex += n;
            first_varying += topology.varying[c];
            let vertex_width = widths.as_ref().filter(|w| w.interp == Interp::Vertex);
            let control: Vec<Vec4> = vertex_range
                .clone()
                .map(|i| {
                    let r = vertex_width.map_or(0.0, |w| 0.5 * w.values[i].x);
                    points[i].as_vec3().extend(r)
                })
                .collect();
            let bez = curves::to_bezier(&control, ty, basis, wrap);
            if bez.is_empty() {
                skipped += 1;
                continue;
            }
            let k_total = bez.len();
            // Vertex-interpolated attributes go through the same basis change; their segment ends are
            // exact. Others are looked up by curve parameter.
            let ends = |pv: &Primvar, k: usize| -> [Vec4; 2] {
                let u = [k as f32 / k_total as f32, (k + 1) as f32 / k_total as f32];
                match pv.interp {
                    Interp::Constant => [pv.values[0]; 2],
                    Interp::Uniform => [pv.values[c]; 2],
                    // Handled once per curve by `cache`.
                    Interp::Vertex => [pv.values[vertex_range.start]; 2],
                    Interp::Varying => {
                        u.map(|u| varying_at(&pv.values[varying_range.clone()], u, topology.wrap))
                    }
                }
            };
            // Both ends of every segment, per primvar.
            let cache = |pv: &Option<Primvar>| -> Option<Vec<[Vec4; 2]>> {
                pv.as_ref().map(|pv| match pv.interp {
                    Interp::Vertex => curves::to_bezier(&pv.values[vertex_range.clone()], ty, basis, wrap)
                        .iter()
                        .map(|b| [b[0], b[3]])
                        .collect(),
                    _ => (0..k_total).map(|k| ends(pv, k)).collect(),
                })
            };
            let (w_ends, n_ends, c_ends, uv_ends) = (
                cache(&widths).filter(|_| vertex_width.is_none()),
                cache(&normals),
                cache(&colors),
                cache(&uvs),
            );
            for (k, mut p) in bez.into_iter().enumerate() {
                match &w_ends {
                    Some(w) => {
                        let line = curves::line(Vec4::splat(0.5 * w[k][0].x), Vec4::splat(0.5 * w[k][1].x));
                        for (q, r) in p.iter_mut().zip(line) {
                            q.w = r.x;
                        }
                    }
                    None if widths.is_none() => {
                        for q in &mut p {
                            q.w = 0.5 * fallback::CURVE_WIDTH;
                        }
                    }
                    None => {}
                }
                let p = p.map(|q| {
                    world.transform_point3(q.truncate().as_dvec3()).as_vec3().extend(q.w.max(0.0) * scale)
                });
                let normal = n_ends.as_ref().map_or([Vec3::ZERO; 2], |n| {
                    n[k].map(|v| (normal_from_local * v.truncate().as_dvec3()).normalize_or_zero().as_vec3())
                });
                let color = c_ends.as_ref().map_or([Vec3::ZERO; 2], |c| c[k].map(|v| v.truncate()));
                let uv = uv_ends.as_ref().map_or([Vec2::ZERO; 2], |t| t[k].map(|v| Vec2::new(v.x, v.y)));
                let u = [k as f32 / k_total as f32, (k + 1) as f32 / k_total as f32];
                out.segments.push(BezierSegment { p, u, normal, color, uv });
            }
        }
        if skipped > 0 {
            self.warn(
                path,
                format!("{skipped} curves have too few vertices for their type/basis/wrap; skipped"),
            );
        }
        if !out.segments.is_empty() {
            self.scene.curves.push(out);
        }
        Ok(())
    }

    /// Reads a Points prim: one sphere of diameter `widths` per point.
    pub(super) fn read_points(&mut self, path: &str, state: &Inherited) -> Result<(), UsdError> {
        let points = self.vec3s(path, "points")?.unwrap_or_default();
        if points.is_empty() {
            return Ok(());
        }
        // A Points prim is one "curve" per point for interpolation purposes: vertex = varying = points.
        let topology = Topology {
            counts: vec![1; points.len()],
            varying: vec![1; points.len()],
            wrap: Wrap::Nonperiodic,
        };
        let widths = self.curve_primvar::<1>(path, &["primvars:widths", "widths"], &topology)?;
        let colors = self.curve_primvar::<3>(path, &["primvars:displayColor"], &topology)?;
        let material = self.gprim_material(path)?;
        let diffuse = self.scene.materials[material as usize].diffuse_color;
        let world = state.world_from_local;
        let scale = length_scale(&world);
        let pick =
            |pv: &Primvar, i: usize| if pv.interp == Interp::Constant { pv.values[0] } else { pv.values[i] };
        let spheres = points
            .iter()
            .enumerate()
            .map(|(i, p)| PointSphere {
                center: world.transform_point3(*p).as_vec3(),
                radius: 0.5
                    * widths.as_ref().map_or(fallback::CURVE_WIDTH, |w| pick(w, i).x).max(0.0)
                    * scale,
                color: colors.as_ref().map_or(diffuse, |c| pick(c, i).truncate()),
            })
            .collect();
        self.scene.curves.push(Curves {
            path: path.to_string(),
            kind: CurveKind::Points,
            spheres,
            material,
            curve_count: points.len(),
            has_colors: colors.is_some(),
            ..Curves::default()
        });
        Ok(())
    }

    /// Reads a NurbsCurves prim, fitting cubic Bézier segments (exact for non-rational curves of order
    /// ≤ 4) and warning with the largest deviation measured otherwise.
    pub(super) fn read_nurbs_curves(&mut self, path: &str, state: &Inherited) -> Result<(), UsdError> {
        let points = self.vec3s(path, "points")?.unwrap_or_default();
        let counts: Vec<usize> = self
            .ints(path, "curveVertexCounts")?
            .unwrap_or_default()
            .into_iter()
            .map(|c| c.max(0) as usize)
            .collect();
        let orders: Vec<usize> =
            self.ints(path, "order")?.unwrap_or_default().into_iter().map(|c| c.max(0) as usize).collect();
        if let Some((c, order)) = orders.iter().enumerate().find(|(_, &o)| o > MAX_NURBS_ORDER) {
            return Err(self.invalid(
                path,
                "order",
                format!("curve {c}: order {order} is above the limit of {MAX_NURBS_ORDER}"),
            ));
        }
        // Checked before knots are made up from the counts: a count far beyond the points would
        // size them (and the per-curve buffers) from the file's word alone.
        let vertex_total = counts.iter().fold(0usize, |sum, &n| sum.saturating_add(n));
        if vertex_total != points.len() {
            self.warn(path, "curveVertexCounts, order, knots and points disagree; NurbsCurves skipped");
            return Ok(());
        }
        let floats = |v: Option<Value>| match v {
            Some(Value::Array { data, arity: 1 }) => data,
            _ => Vec::new(),
        };
        let mut knots = floats(self.stage.attr(path, "knots")?);
        let weights = floats(self.stage.attr(path, "pointWeights")?);
        let ranges = self.stage.attr(path, "ranges")?.and_then(|v| v.as_array::<2>()).unwrap_or_default();
        let knot_total: usize = counts.iter().zip(&orders).map(|(n, o)| n + o).sum();
        if knots.len() != knot_total && orders.len() == counts.len() {
            // No (or mis-sized) knots: the clamped uniform knot vector, so the curve runs from its
            // first to its last point.
            self.warn(
                path,
                format!("knots has {} values, {knot_total} needed; using clamped uniform knots", knots.len()),
            );
            knots = counts
                .iter()
                .zip(&orders)
                .flat_map(|(&n, &order)| {
                    let spans = n.saturating_sub(order) + 1;
                    (0..n + order).map(move |i| i.saturating_sub(order - 1).min(spans) as f64)
                })
                .collect();
        }
        if counts.iter().sum::<usize>() != points.len()
            || orders.len() != counts.len()
            || knots.len() != knot_total
        {
            self.warn(path, "curveVertexCounts, order, knots and points disagree; NurbsCurves skipped");
            return Ok(());
        }
        let topology = Topology { counts: counts.clone(), varying: counts.clone(), wrap: Wrap::Nonperiodic };
        let widths = self.curve_primvar::<1>(path, &["primvars:widths", "widths"], &topology)?;
        let material = self.gprim_material(path)?;
        let world = state.world_from_local;
        let scale = length_scale(&world);
        let mut out =
            Curves { path: path.to_string(), material, curve_count: counts.len(), ..Curves::default() };
        let (mut v0, mut k0) = (0usize, 0usize);
        let (mut max_error, mut approximated) = (0.0f32, false);
        for (c, (&n, &order)) in counts.iter().zip(&orders).enumerate() {
            let values: Vec<Vec4> = (v0..v0 + n)
                .map(|i| {
                    let w = match &widths {
                        Some(w) if w.interp == Interp::Vertex || w.interp == Interp::Varying => w.values[i].x,
                        Some(w) if w.interp == Interp::Uniform => w.values[c].x,
                        Some(w) => w.values[0].x,
                        None => fallback::CURVE_WIDTH,
                    };
                    points[i].as_vec3().extend(0.5 * w)
                })
                .collect();
            let curve_knots = &knots[k0..k0 + n + order];
            let curve_weights = if weights.len() == points.len() { &weights[v0..v0 + n] } else { &[][..] };
            v0 += n;
            k0 += n + order;
            if order < 2 || n < order || curve_knots.windows(2).any(|w| w[1] < w[0]) {
                self.warn(
                    path,
                    format!("curve {c}: order {order} with {n} points or knots decreasing; skipped"),
                );
                continue;
            }
            let rational = curve_weights.windows(2).any(|w| w[0] != w[1]);
            approximated |= rational || order > 4;
            let size = values.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v.truncate()), hi.max(v.truncate()))
            });
            let tolerance = 1e-3 * (size.1 - size.0).length().max(1e-6);
            let nurbs = curves::Nurbs { order, knots: curve_knots, values: &values, weights: curve_weights };
            let range = ranges.get(c).map(|r| [r[0], r[1]]).filter(|r| r[0] < r[1]);
            let (segments, error) = nurbs.to_bezier(range, tolerance);
            max_error = max_error.max(error);
            let count = segments.len();
            for (k, p) in segments.into_iter().enumerate() {
                let p = p.map(|q| {
                    world.transform_point3(q.truncate().as_dvec3()).as_vec3().extend(q.w.max(0.0) * scale)
                });
                out.segments.push(BezierSegment {
                    p,
                    u: [k as f32 / count as f32, (k + 1) as f32 / count as f32],
                    ..BezierSegment::default()
                });
            }
        }
        if approximated {
            self.warn(
                path,
                format!(
                    "NurbsCurves approximated by cubic Bézier segments (rational or order > 4); max deviation {max_error:.3e} in object space"
                ),
            );
        }
        if !out.segments.is_empty() {
            self.scene.curves.push(out);
        }
        Ok(())
    }
}

/// A varying primvar of one curve at parameter `u` ∈ [0, 1]: linear between its values, wrapping for
/// periodic curves.
fn varying_at(values: &[Vec4], u: f32, wrap: Wrap) -> Vec4 {
    let m = values.len();
    if m == 1 {
        return values[0];
    }
    let intervals = if wrap == Wrap::Periodic { m } else { m - 1 };
    let x = (u * intervals as f32).clamp(0.0, intervals as f32);
    let i = (x.floor() as usize).min(intervals - 1);
    values[i % m].lerp(values[(i + 1) % m], x - i as f32)
}

//! Curves and Points objects.
//!
//! `curveBasisAndType` holds (type, wrap, basis): type 0 cubic, 1 linear, 2 variable order
//! (NURBS, with `.orders` and `.knots`); basis 1 Bézier, 2 B-spline, 3 Catmull–Rom. Widths are
//! diameters, as USD's.

use super::archive::Compound;
use super::geom::{interpolation, Counts};
use super::translate::{as_ints, finite, Translator};
use super::usda::{floats, ints, tuples};

impl Translator {
    /// `curveBasisAndType` as `[type, wrap, basis]`.
    pub(super) fn curve_kind(&mut self, p: &Compound) -> Result<[u8; 3], String> {
        let v = self.sampler.held(p, "curveBasisAndType")?.ok_or("curveBasisAndType is missing")?;
        match v.as_slice() {
            [ty, wrap, basis, ..] => Ok([*ty as u8, *wrap as u8, *basis as u8]),
            _ => Err(format!("curveBasisAndType has {} values, not 4", v.len())),
        }
    }

    /// Points and vertex counts common to both curve prims.
    fn curve_points(&mut self, p: &Compound) -> Result<(Vec<f64>, Vec<i64>), String> {
        let points = self.sampler.blended(p, "P")?.ok_or("P is missing")?;
        finite("P", &points)?;
        let counts = as_ints(&self.sampler.held(p, "nVertices")?.ok_or("nVertices is missing")?);
        self.layer.attr("int[] curveVertexCounts", &ints(&counts), None);
        self.layer.attr("point3f[] points", &tuples(&points, 3), None);
        Ok((points, counts))
    }

    /// Widths (`width` geometry parameter), and normals when authored.
    fn curve_primvars(&mut self, p: &Compound, counts: Counts, width_name: &str) -> Result<(), String> {
        if let Some(w) = self.sampler.geom_param(p, width_name)? {
            finite(width_name, &w.values)?;
            // Indexed widths are expanded: USD widths take no indices.
            let values: Vec<f64> = match &w.indices {
                Some(ix) => ix
                    .iter()
                    .map(|&i| {
                        w.values
                            .get(i as usize)
                            .copied()
                            .ok_or(format!("{width_name} index {i} out of range"))
                    })
                    .collect::<Result<_, _>>()?,
                None => w.values.clone(),
            };
            let interp = interpolation(&w, values.len(), &counts)?;
            self.layer.attr(
                "float[] widths",
                &floats(&values),
                Some(&format!("interpolation = \"{interp}\"")),
            );
        }
        if let Some(n) = self.sampler.geom_param(p, "N")? {
            finite("N", &n.values)?;
            if n.indices.is_none() {
                let interp = interpolation(&n, n.values.len() / 3, &counts)?;
                let meta = format!("interpolation = \"{interp}\"");
                self.layer.attr("normal3f[] normals", &tuples(&n.values, 3), Some(&meta));
            }
        }
        Ok(())
    }

    /// A linear or cubic curves object as BasisCurves.
    pub(super) fn basis_curves(&mut self, p: &Compound) -> Result<(), String> {
        let [ty, wrap, basis] = self.curve_kind(p)?;
        let (ty, basis) = match (ty, basis) {
            (1, _) => ("linear", None),
            (0, 1) => ("cubic", Some("bezier")),
            (0, 2) => ("cubic", Some("bspline")),
            (0, 3) => ("cubic", Some("catmullRom")),
            (0, b) => {
                // Hermite and power bases have no USD counterpart; the points are drawn as
                // polylines, which pass through every control point.
                let what =
                    ["no", "", "", "", "Hermite", "power"].get(b as usize).copied().unwrap_or("unknown");
                self.warnings.push((self.current.clone(), format!("{what} curve basis drawn as linear")));
                ("linear", None)
            }
            (t, _) => return Err(format!("curve type {t} is not cubic, linear or variable order")),
        };
        self.layer.attr("uniform token type", &format!("\"{ty}\""), None);
        if let Some(b) = basis {
            self.layer.attr("uniform token basis", &format!("\"{b}\""), None);
        }
        let wrap = if wrap == 1 { "periodic" } else { "nonperiodic" };
        self.layer.attr("uniform token wrap", &format!("\"{wrap}\""), None);
        let (points, counts) = self.curve_points(p)?;
        let sizes = Counts { points: points.len() / 3, faces: counts.len(), corners: usize::MAX };
        self.curve_primvars(p, sizes, "width")
    }

    /// A variable-order curves object as NurbsCurves.
    pub(super) fn nurbs_curves(&mut self, p: &Compound) -> Result<(), String> {
        let (points, counts) = self.curve_points(p)?;
        let orders = as_ints(&self.sampler.held(p, ".orders")?.unwrap_or_default());
        let mut knots = self.sampler.held(p, ".knots")?.unwrap_or_default();
        finite(".knots", &knots)?;
        if knots.is_empty() && orders.len() == counts.len() {
            // Knots are optional in Alembic (Blender writes none): readers take each curve's
            // clamped uniform vector, 0 (order times), 1, 2, ..., n − order + 1 (order times).
            for (&n, &k) in counts.iter().zip(&orders) {
                if k < 1 || n < k {
                    return Err(format!("a curve of {n} points cannot have order {k}"));
                }
                let spans = (n - k + 1) as f64;
                knots.extend(std::iter::repeat_n(0.0, k as usize));
                knots.extend((1..n - k + 1).map(|i| i as f64));
                knots.extend(std::iter::repeat_n(spans, k as usize));
            }
        }
        self.layer.attr("int[] order", &ints(&orders), None);
        let knots: Vec<String> = knots.iter().map(|k| format!("{k:?}")).collect();
        self.layer.attr("double[] knots", &format!("[{}]", knots.join(", ")), None);
        if let Some(w) = self.sampler.held(p, "w")?.filter(|w| !w.is_empty()) {
            finite("w", &w)?;
            let w: Vec<String> = w.iter().map(|v| format!("{v:?}")).collect();
            self.layer.attr("double[] pointWeights", &format!("[{}]", w.join(", ")), None);
        }
        let sizes = Counts { points: points.len() / 3, faces: counts.len(), corners: usize::MAX };
        self.curve_primvars(p, sizes, "width")
    }

    /// A Points object.
    pub(super) fn points(&mut self, p: &Compound) -> Result<(), String> {
        let points = self.sampler.blended(p, "P")?.ok_or("P is missing")?;
        finite("P", &points)?;
        self.layer.attr("point3f[] points", &tuples(&points, 3), None);
        if let Some(ids) = self.sampler.held(p, ".pointIds")? {
            self.layer.attr("int64[] ids", &ints(&as_ints(&ids)), None);
        }
        let n = points.len() / 3;
        self.curve_primvars(p, Counts { points: n, faces: usize::MAX, corners: usize::MAX }, ".widths")
    }
}

//! Limit positions, tangents and normals at the vertices of the last refinement level.
//!
//! `PrimvarRefiner::Limit` applies the scheme's exact limit masks to the refined control points,
//! so a vertex's limit point does not depend on the level it is evaluated at; only the density
//! of sample points does.

use crate::refine::{Evaluation, Refiner};
use crate::{Error, Result};

/// Limit surface samples at the last level's vertices, in f64: tangents at extraordinary
/// vertices can be short, and the cross product loses precision in f32.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LimitSurface {
    /// Limit positions.
    pub positions: Vec<[f64; 3]>,
    /// First limit tangent (∂P/∂u at the vertex, in OpenSubdiv's convention).
    pub du: Vec<[f64; 3]>,
    /// Second limit tangent (∂P/∂v).
    pub dv: Vec<[f64; 3]>,
}

fn to_vec3(flat: Vec<f64>) -> Vec<[f64; 3]> {
    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

impl Refiner {
    /// Limit positions and tangents of cage `positions` at every last-level vertex.
    pub fn limit(&self, positions: &[[f32; 3]]) -> Result<LimitSurface> {
        if positions.len() != self.base_vertex_count() {
            return Err(Error::PrimvarSize {
                what: "points",
                expected: self.base_vertex_count(),
                got: positions.len(),
            });
        }
        let flat: Vec<f32> = positions.iter().flatten().copied().collect();
        let (mut du, mut dv) = (Vec::new(), Vec::new());
        let p = self.vertex_primvar_f64(&flat, 3, Evaluation::Limit, Some((&mut du, &mut dv)))?;
        Ok(LimitSurface { positions: to_vec3(p), du: to_vec3(du), dv: to_vec3(dv) })
    }
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn length(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Unit normal `du × dv`, or `None` when the tangents are (nearly) parallel or degenerate, as at
/// some sharp corners, where the caller falls back to the surrounding faces.
pub fn normal_from_tangents(du: [f64; 3], dv: [f64; 3]) -> Option<[f64; 3]> {
    let n = cross(du, dv);
    let len = length(n);
    // Relative test: the tangents' scale follows the refined edge length.
    let scale = length(du) * length(dv);
    (len.is_finite() && len > 1e-9 * scale && len > 0.0).then(|| [n[0] / len, n[1] / len, n[2] / len])
}

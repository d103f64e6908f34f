//! Triangles for the renderer: limit positions and normals at the last level's vertices, faces
//! split into triangles, hole faces dropped, vertices split along UV seams.

use crate::limit::{cross, dot, length, normal_from_tangents, sub};
use crate::refine::{Evaluation, Refiner};
use crate::{Error, Result};

/// A face-varying UV primvar: the channel holding its indices and its values.
#[derive(Debug, Clone, Copy)]
pub struct UvSource<'a> {
    /// Face-varying channel of the [`crate::Cage`] the indices were given in.
    pub channel: usize,
    /// One UV per value of that channel.
    pub values: &'a [[f32; 2]],
}

/// An indexed triangle mesh on the limit surface.
///
/// Without UVs there is one output vertex per refined vertex in use; with UVs, one per refined
/// face-varying value in use, so a vertex on a seam appears once per side with the same
/// position and normal.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tessellation {
    /// Limit positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit limit normals, `du × dv`, on the side the faces' winding points to.
    pub normals: Vec<[f32; 3]>,
    /// Limit UVs, when a [`UvSource`] was given.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Triangles, wound like the cage faces.
    pub triangles: Vec<[u32; 3]>,
    /// The cage face each triangle came from (for `GeomSubset` materials and uniform primvars).
    pub coarse_face: Vec<u32>,
    /// The last-level vertex each output vertex sits on, to gather further vertex primvars
    /// refined with [`Refiner::vertex_primvar`] (see [`Tessellation::gather`]).
    pub refined_vertex: Vec<u32>,
}

impl Tessellation {
    /// Picks the values of a refined vertex primvar (`N` floats per last-level vertex) for the
    /// output vertices.
    pub fn gather<const N: usize>(&self, refined: &[f32]) -> Result<Vec<[f32; N]>> {
        let needed = self.refined_vertex.iter().map(|&v| v as usize + 1).max().unwrap_or(0) * N;
        if refined.len() < needed || !refined.len().is_multiple_of(N.max(1)) {
            return Err(Error::PrimvarSize { what: "refined primvar", expected: needed, got: refined.len() });
        }
        Ok(self
            .refined_vertex
            .iter()
            .map(|&v| std::array::from_fn(|k| refined[v as usize * N + k]))
            .collect())
    }
}

/// Tessellates the surface `refiner` describes, with cage `positions` and optional UVs.
///
/// ```
/// use subdiv::{tessellate, Cage, Refiner, Topology};
///
/// // A unit cube.
/// let points = [
///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0],
///     [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0],
/// ];
/// let counts = [4; 6];
/// let indices = [
///     0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7,
/// ];
/// let cage = Cage {
///     face_vertex_counts: &counts,
///     face_vertex_indices: &indices,
///     vertex_count: points.len(),
///     ..Default::default()
/// };
/// let topology = Topology::new(&cage)?;
/// let refiner = Refiner::new(&topology, 2)?;
/// let mesh = tessellate(&refiner, &points, None)?;
/// assert_eq!(mesh.triangles.len(), 2 * 6 * 4usize.pow(2));
/// # Ok::<(), subdiv::Error>(())
/// ```
pub fn tessellate(
    refiner: &Refiner,
    positions: &[[f32; 3]],
    uvs: Option<UvSource<'_>>,
) -> Result<Tessellation> {
    let limit = refiner.limit(positions)?;
    let faces = refiner.faces(uvs.map(|uv| uv.channel))?;
    let uv_values = match uvs {
        Some(uv) => {
            let flat: Vec<f32> = uv.values.iter().flatten().copied().collect();
            Some(refiner.face_varying_primvar(uv.channel, &flat, 2, Evaluation::Limit)?)
        }
        None => None,
    };

    // Output vertices are keyed by refined vertex, or by face-varying value when splitting seams.
    let key_count = match &uv_values {
        Some(v) => v.len() / 2,
        None => limit.positions.len(),
    };
    let mut output_of_key = vec![u32::MAX; key_count];
    let mut refined_vertex = Vec::new();
    let mut uv_out = Vec::new();
    let mut triangles = Vec::new();
    let mut coarse_face = Vec::new();

    let mut start = 0;
    for (f, &count) in faces.counts.iter().enumerate() {
        let range = start..start + count as usize;
        start = range.end;
        if faces.is_hole[f] {
            continue;
        }
        let verts = &faces.vertices[range.clone()];
        let keys = if uv_values.is_some() { &faces.fvar_values[range] } else { verts };
        let mut corner = |i: usize| -> u32 {
            let slot = &mut output_of_key[keys[i] as usize];
            if *slot == u32::MAX {
                *slot = refined_vertex.len() as u32;
                refined_vertex.push(verts[i]);
                if let Some(uv) = &uv_values {
                    let k = keys[i] as usize;
                    uv_out.push([uv[2 * k], uv[2 * k + 1]]);
                }
            }
            *slot
        };
        let c: Vec<u32> = (0..verts.len()).map(&mut corner).collect();
        let p = |i: usize| limit.positions[verts[i] as usize];
        if c.len() == 4 {
            // Split along the shorter diagonal: better-shaped triangles where the surface bends.
            if length(sub(p(0), p(2))) <= length(sub(p(1), p(3))) {
                triangles.extend([[c[0], c[1], c[2]], [c[0], c[2], c[3]]]);
            } else {
                triangles.extend([[c[0], c[1], c[3]], [c[1], c[2], c[3]]]);
            }
            coarse_face.extend([faces.coarse_face[f]; 2]);
        } else {
            // Triangles, and n-gons at level 0 of bilinear cages: a fan.
            for i in 1..c.len() - 1 {
                triangles.push([c[0], c[i], c[i + 1]]);
                coarse_face.push(faces.coarse_face[f]);
            }
        }
    }

    let slot_triangles = triangles.iter().map(|t| t.map(|c| refined_vertex[c as usize] as usize));
    let normals = oriented_normals(&limit.positions, &limit.du, &limit.dv, slot_triangles);

    let to_f32 = |a: [f64; 3]| a.map(|x| x as f32);
    Ok(Tessellation {
        positions: refined_vertex.iter().map(|&v| to_f32(limit.positions[v as usize])).collect(),
        normals: refined_vertex.iter().map(|&v| to_f32(normals[v as usize])).collect(),
        uvs: uv_values.map(|_| uv_out),
        triangles,
        coarse_face,
        refined_vertex,
    })
}

/// Unit limit normals at limit samples ("slots": refined vertices, or Bfr points) from their
/// tangents, on the side the faces' winding points to. `triangles` index the slots.
pub(crate) fn oriented_normals(
    positions: &[[f64; 3]],
    du: &[[f64; 3]],
    dv: &[[f64; 3]],
    triangles: impl Iterator<Item = [usize; 3]>,
) -> Vec<[f64; 3]> {
    // Area-weighted face normals per slot: the orientation reference for the tangent normals,
    // and the fallback where the tangents are degenerate.
    let mut face_normal_sum = vec![[0.0f64; 3]; positions.len()];
    for v in triangles {
        let n = cross(sub(positions[v[1]], positions[v[0]]), sub(positions[v[2]], positions[v[0]]));
        for &i in &v {
            let s = &mut face_normal_sum[i];
            *s = [s[0] + n[0], s[1] + n[1], s[2] + n[2]];
        }
    }
    (0..positions.len())
        .map(|v| {
            let reference = face_normal_sum[v];
            match normal_from_tangents(du[v], dv[v]) {
                // OpenSubdiv's du × dv follows the face winding (the tests find no exception at
                // boundaries, creases, corners, valence 3 and 5); the faces still decide the side,
                // so that a convention change or a twisted cage cannot turn a shading normal
                // inside out.
                Some(n) if dot(n, reference) < 0.0 => [-n[0], -n[1], -n[2]],
                Some(n) => n,
                None => {
                    let len = length(reference);
                    if len > 0.0 && len.is_finite() {
                        reference.map(|x| x / len)
                    } else {
                        [0.0, 0.0, 1.0]
                    }
                }
            }
        })
        .collect()
}

/// Refinement level for a dicing rate: `ceil(log2(edge_px / rate_px))` clamped to
/// `0..=max_level`, so that refined edges come out no longer than `rate_px` pixels.
///
/// `edge_px` is the cage's longest edge projected to pixels (see
/// [`crate::Topology::longest_edge`]). A non-finite or non-positive edge gives 0; a rate that is
/// not positive asks for the finest level.
pub fn level_for_dicing_rate(edge_px: f32, rate_px: f32, max_level: u32) -> u32 {
    if !(edge_px.is_finite() && edge_px > 0.0) {
        return 0;
    }
    if rate_px.is_nan() || rate_px <= 0.0 {
        return max_level;
    }
    let level = (edge_px as f64 / rate_px as f64).log2().ceil();
    if level <= 0.0 {
        0
    } else {
        (level.min(max_level as f64)) as u32
    }
}

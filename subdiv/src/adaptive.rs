//! Per-face tessellation through OpenSubdiv's Bfr interface: each base face's limit surface is
//! evaluated at the points of a `Bfr::Tessellation` whose rate (segments) is chosen per cage
//! edge, so that large or near faces get many triangles and small or far ones few.
//!
//! Rates live on the edges, not the faces: both faces of an edge split it the same way, and the
//! shim evaluates the points of an edge (and of a vertex) once and shares them, so the mesh is
//! watertight with bit-identical positions along cage edges. A face's interior rate is the
//! maximum of its opposite edges (quads) or of all its edges.
//!
//! Creases, corners, holes, boundary interpolation and face-varying interpolation are Bfr's
//! business: it builds each face's surface from the same `Far::TopologyRefiner` the uniform path
//! refines.

use std::ffi::c_int;
use std::ptr::{self, NonNull};

use crate::ffi;
use crate::refine::{check, to_c_int, Refiner};
use crate::tessellate::{oriented_normals, Tessellation, UvSource};
use crate::{Error, Result};
use crate::{Scheme, Topology};

/// Highest rate (segments per cage edge) accepted: the rate of [`crate::MAX_LEVEL`].
pub const MAX_RATE: u32 = 1 << crate::MAX_LEVEL;

/// The cage of one mesh, ready for per-face tessellation: its unrefined `Far::TopologyRefiner`,
/// its edges and the edges of each face.
#[derive(Debug)]
pub struct AdaptiveRefiner {
    base: Refiner,
    scheme: Scheme,
    /// Vertex pairs, one per edge, in OpenSubdiv's edge order (the order rates are given in).
    edges: Vec<[u32; 2]>,
    /// Vertices and edges of each face, concatenated; edge `i` of a face runs from its vertex `i`
    /// to vertex `i + 1`.
    face_vertices: Vec<u32>,
    face_edges: Vec<u32>,
    face_start: Vec<usize>,
    /// Faces listed in `holeIndices` (Bfr gives them no surface).
    is_hole: Vec<bool>,
}

/// UVs carried through a per-face tessellation.
#[derive(Debug, Clone, Copy)]
pub enum AdaptiveUv<'a> {
    /// A face-varying channel: evaluated on its own limit surface, with vertices split along
    /// seams.
    FaceVarying(UvSource<'a>),
    /// One UV per cage vertex, evaluated on the vertex limit surface like the positions.
    Vertex(&'a [[f32; 2]]),
}

/// A per-face tessellation: the triangle mesh plus what measurements need.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AdaptiveTessellation {
    /// Positions, normals, UVs, triangles and cage faces, as from [`crate::tessellate`];
    /// `refined_vertex` is empty (there is no refined level to gather from).
    pub mesh: Tessellation,
    /// With `want_coords`: the (u, v) of each triangle corner in its cage face's Bfr
    /// parameterization (see [`AdaptiveRefiner::evaluate`]); empty otherwise.
    pub corner_coords: Vec<[[f32; 2]; 3]>,
}

/// Owns the shim's output buffers until they are copied out.
struct RawAdaptive(NonNull<ffi::OsdAdaptive>);

impl Drop for RawAdaptive {
    fn drop(&mut self) {
        // SAFETY: the pointer came from `osd_tessellate_adaptive` and is freed once, here.
        unsafe { ffi::osd_adaptive_free(self.0.as_ptr()) }
    }
}

fn flatten_f64<const N: usize>(values: &[[f32; N]]) -> Vec<f64> {
    values.iter().flatten().map(|&x| x.into()).collect()
}

impl AdaptiveRefiner {
    /// Builds the unrefined refiner and reads its edges.
    pub fn new(topology: &Topology) -> Result<Self> {
        let base = Refiner::unrefined(topology)?;
        let mut count = 0;
        // SAFETY: `base.raw()` is a live refiner; `count` a valid out-pointer.
        check(unsafe { ffi::osd_base_edge_count(base.raw(), &mut count) })?;
        let mut edge_vertices = vec![0 as c_int; 2 * count as usize];
        let mut face_edges = vec![0 as c_int; topology.face_vertex_indices().len()];
        // SAFETY: the buffers hold 2 ints per base edge and one per face-vertex, as the shim
        // writes.
        check(unsafe {
            ffi::osd_base_edges(base.raw(), edge_vertices.as_mut_ptr(), face_edges.as_mut_ptr())
        })?;
        let mut face_start = Vec::with_capacity(topology.face_count() + 1);
        face_start.push(0);
        for &n in topology.face_vertex_counts() {
            face_start.push(face_start.last().unwrap() + n as usize);
        }
        let mut is_hole = vec![false; topology.face_count()];
        for &h in topology.hole_indices() {
            is_hole[h as usize] = true;
        }
        Ok(Self {
            base,
            scheme: topology.options().scheme,
            edges: edge_vertices.chunks_exact(2).map(|e| [e[0] as u32, e[1] as u32]).collect(),
            face_vertices: topology.face_vertex_indices().iter().map(|&v| v as u32).collect(),
            face_edges: face_edges.into_iter().map(|e| e as u32).collect(),
            face_start,
            is_hole,
        })
    }

    /// The cage edges as vertex pairs; rates are given in this order.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Number of cage faces.
    pub fn face_count(&self) -> usize {
        self.face_start.len() - 1
    }

    /// Vertices and edges of face `f` (edge `i` runs from vertex `i` to vertex `i + 1`).
    pub fn face(&self, f: usize) -> (&[u32], &[u32]) {
        let range = self.face_start[f]..self.face_start[f + 1];
        (&self.face_vertices[range.clone()], &self.face_edges[range])
    }

    /// Whether face `f` is listed in `holeIndices`.
    pub fn is_hole(&self, f: usize) -> bool {
        self.is_hole[f]
    }

    /// Triangles [`AdaptiveRefiner::tessellate`] makes from `rates`, not counting holes: exact
    /// where a face's edges share one rate, a close upper estimate elsewhere (the transition
    /// strips along unequal edges have fewer).
    pub fn triangle_estimate(&self, rates: &[u32]) -> u64 {
        (0..self.face_count())
            .filter(|&f| !self.is_hole[f])
            .map(|f| {
                let (_, edges) = self.face(f);
                // Missing rates count as 1 (`tessellate` refuses a short list before estimating).
                let r = |i: usize| u64::from(rates.get(edges[i] as usize).copied().unwrap_or(1).max(1));
                let n = edges.len() as u64;
                let max = (0..edges.len()).map(r).max().unwrap_or(1);
                match (self.scheme, edges.len()) {
                    (_, 4) => 2 * r(0).max(r(2)) * r(1).max(r(3)),
                    (Scheme::Loop, _) => max * max,
                    // Quadrangulated n-gons: n sub-quads of half the rate each, at least a fan.
                    _ => (n * max * max / 2).max(n),
                }
            })
            .sum()
    }

    /// The unrefined refiner.
    pub(crate) fn base(&self) -> &Refiner {
        &self.base
    }

    pub(crate) fn check_rates(&self, rates: &[u32]) -> Result<Vec<c_int>> {
        if rates.len() != self.edges.len() {
            return Err(Error::PrimvarSize {
                what: "edge rates",
                expected: self.edges.len(),
                got: rates.len(),
            });
        }
        if let Some(at) = rates.iter().position(|&r| r == 0 || r > MAX_RATE) {
            return Err(Error::Invalid {
                attribute: "edge rates",
                reason: format!("rate {} of edge {at} is outside 1..={MAX_RATE}", rates[at]),
            });
        }
        Ok(rates.iter().map(|&r| r as c_int).collect())
    }

    fn check_points(&self, positions: &[[f32; 3]]) -> Result<()> {
        if positions.len() != self.base.base_vertex_count() {
            return Err(Error::PrimvarSize {
                what: "points",
                expected: self.base.base_vertex_count(),
                got: positions.len(),
            });
        }
        Ok(())
    }

    /// Tessellates every face with a limit surface at `rates` (one per [`AdaptiveRefiner::edges`]
    /// entry, in `1..=`[`MAX_RATE`]): limit positions, unit normals from the limit derivatives,
    /// and optional limit UVs. With `want_coords` the parametric coordinates of each triangle
    /// corner are returned too.
    pub fn tessellate(
        &self,
        positions: &[[f32; 3]],
        uvs: Option<AdaptiveUv<'_>>,
        rates: &[u32],
        want_coords: bool,
    ) -> Result<AdaptiveTessellation> {
        self.check_points(positions)?;
        let checked = self.check_rates(rates)?;
        let estimate = self.triangle_estimate(rates);
        let rates = checked;
        // The shim counts triangle corners in `int`.
        if estimate > i32::MAX as u64 / 3 {
            return Err(Error::Invalid {
                attribute: "edge rates",
                reason: format!("about {estimate} triangles, more than 32-bit indices can address"),
            });
        }
        // Vertex UVs ride along with the positions on the vertex surface.
        let (vertex_data, width) = match uvs {
            Some(AdaptiveUv::Vertex(uv)) => {
                if uv.len() != positions.len() {
                    return Err(Error::PrimvarSize {
                        what: "vertex UVs",
                        expected: positions.len(),
                        got: uv.len(),
                    });
                }
                let data = positions
                    .iter()
                    .zip(uv)
                    .flat_map(|(p, t)| [p[0], p[1], p[2], t[0], t[1]])
                    .map(f64::from)
                    .collect();
                (data, 5)
            }
            _ => (flatten_f64(positions), 3),
        };
        let (channel, fvar_data) = match uvs {
            Some(AdaptiveUv::FaceVarying(source)) => {
                let expected = self.base.base_fvar_value_count(source.channel)?;
                if source.values.len() != expected {
                    return Err(Error::PrimvarSize {
                        what: "face-varying UVs",
                        expected,
                        got: source.values.len(),
                    });
                }
                (to_c_int(source.channel), flatten_f64(source.values))
            }
            _ => (-1, Vec::new()),
        };

        let mut raw = ptr::null_mut();
        // SAFETY: `vertex_data` holds `width` doubles per cage vertex, `fvar_data` 2 per value of
        // `channel` (checked above), `rates` one int per base edge; the shim only reads them.
        check(unsafe {
            ffi::osd_tessellate_adaptive(
                self.base.raw(),
                vertex_data.as_ptr(),
                width as c_int,
                channel,
                if channel >= 0 { fvar_data.as_ptr() } else { ptr::null() },
                2,
                rates.as_ptr(),
                want_coords.into(),
                &mut raw,
            )
        })?;
        let raw =
            RawAdaptive(NonNull::new(raw).ok_or_else(|| Error::OpenSubdiv("null tessellation".into()))?);
        let (mut vertex_count, mut triangle_count) = (0, 0);
        // SAFETY: `raw` is live; the out-pointers are valid locals.
        unsafe { ffi::osd_adaptive_counts(raw.0.as_ptr(), &mut vertex_count, &mut triangle_count) };
        let (nv, nt) = (vertex_count as usize, triangle_count as usize);
        let mut data = vec![0.0f64; nv * width];
        let mut du = vec![0.0f64; nv * width];
        let mut dv = vec![0.0f64; nv * width];
        let mut fvar = vec![0.0f64; if channel >= 0 { nv * 2 } else { 0 }];
        let mut triangles = vec![0 as c_int; nt * 3];
        let mut coarse_face = vec![0 as c_int; nt];
        let mut coords = vec![0.0f32; if want_coords { nt * 6 } else { 0 }];
        // SAFETY: every buffer is sized from the counts just read, with the widths the
        // tessellation was made with; optional buffers are null when not wanted.
        unsafe {
            ffi::osd_adaptive_copy(
                raw.0.as_ptr(),
                data.as_mut_ptr(),
                du.as_mut_ptr(),
                dv.as_mut_ptr(),
                if channel >= 0 { fvar.as_mut_ptr() } else { ptr::null_mut() },
                triangles.as_mut_ptr(),
                coarse_face.as_mut_ptr(),
                if want_coords { coords.as_mut_ptr() } else { ptr::null_mut() },
            )
        };
        drop(raw);

        let xyz =
            |buf: &[f64]| -> Vec<[f64; 3]> { buf.chunks_exact(width).map(|c| [c[0], c[1], c[2]]).collect() };
        let (positions, du, dv) = (xyz(&data), xyz(&du), xyz(&dv));
        let triangles: Vec<[u32; 3]> =
            triangles.chunks_exact(3).map(|t| [t[0], t[1], t[2]].map(|i| i as u32)).collect();
        let normals = oriented_normals(&positions, &du, &dv, triangles.iter().map(|t| t.map(|i| i as usize)));
        let uvs = match uvs {
            Some(AdaptiveUv::FaceVarying(_)) => {
                Some(fvar.chunks_exact(2).map(|c| [c[0] as f32, c[1] as f32]).collect())
            }
            Some(AdaptiveUv::Vertex(_)) => {
                Some(data.chunks_exact(width).map(|c| [c[3] as f32, c[4] as f32]).collect())
            }
            None => None,
        };
        let to_f32 = |a: &[f64; 3]| a.map(|x| x as f32);
        Ok(AdaptiveTessellation {
            mesh: Tessellation {
                positions: positions.iter().map(to_f32).collect(),
                normals: normals.iter().map(to_f32).collect(),
                uvs,
                triangles,
                coarse_face: coarse_face.into_iter().map(|f| f as u32).collect(),
                refined_vertex: Vec::new(),
            },
            corner_coords: coords
                .chunks_exact(6)
                .map(|c| [[c[0], c[1]], [c[2], c[3]], [c[4], c[5]]])
                .collect(),
        })
    }

    /// Limit positions of cage `positions` at `samples`: (cage face, (u, v) in its Bfr
    /// parameterization). Samples of one face should be consecutive: the face's surface is built
    /// once per run of samples.
    pub fn evaluate(&self, positions: &[[f32; 3]], samples: &[(u32, [f64; 2])]) -> Result<Vec<[f64; 3]>> {
        self.check_points(positions)?;
        if let Some(&(f, _)) = samples.iter().find(|(f, _)| *f as usize >= self.face_count()) {
            return Err(Error::Invalid {
                attribute: "samples",
                reason: format!("face {f} is outside 0..{}", self.face_count()),
            });
        }
        let data = flatten_f64(positions);
        let faces: Vec<c_int> = samples.iter().map(|s| s.0 as c_int).collect();
        let coords: Vec<f64> = samples.iter().flat_map(|s| s.1).collect();
        let mut out = vec![0.0f64; samples.len() * 3];
        // SAFETY: `data` holds 3 doubles per cage vertex, `faces` and `coords` one face and two
        // doubles per sample, `out` 3 doubles per sample; face indices are in range.
        check(unsafe {
            ffi::osd_evaluate_limit(
                self.base.raw(),
                data.as_ptr(),
                3,
                to_c_int(samples.len()),
                faces.as_ptr(),
                coords.as_ptr(),
                out.as_mut_ptr(),
            )
        })?;
        Ok(out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }
}

/// Segments for one cage edge at a dicing rate: `ceil(edge_px / rate_px)` clamped to
/// `1..=max_rate`, so that segments come out no longer than `rate_px` pixels. A non-finite or
/// non-positive length gives 1; a rate that is not positive asks for `max_rate`.
pub fn rate_for_dicing_rate(edge_px: f64, rate_px: f64, max_rate: u32) -> u32 {
    let max_rate = max_rate.clamp(1, MAX_RATE);
    if !(edge_px.is_finite() && edge_px > 0.0) {
        return 1;
    }
    if rate_px.is_nan() || rate_px <= 0.0 {
        return max_rate;
    }
    let segments = (edge_px / rate_px).ceil();
    if segments >= f64::from(max_rate) {
        max_rate
    } else {
        (segments as u32).max(1)
    }
}

/// The uniform level whose edges are as fine as `rate` segments per cage edge:
/// `ceil(log2(rate))`.
pub fn level_for_rate(rate: u32) -> u32 {
    rate.max(1).next_power_of_two().trailing_zeros()
}

//! Cage description as USD authors it ([`Cage`]) and its validated, owned form ([`Topology`]).
//!
//! Everything OpenSubdiv could trip over is checked here, in Rust, so that the C++ side only ever
//! sees in-range indices and consistent lengths. USD's crease chains are flattened to the edge
//! pairs `Far::TopologyDescriptor` expects; the accessors hand `subdiv` those arrays as they are.

use std::collections::HashSet;
use std::str::FromStr;

use crate::{Error, Result};

/// Subdivision scheme (`UsdGeomMesh.subdivisionScheme`; USD's `none` is a polygon mesh, not ours).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Scheme {
    /// `catmullClark`: quads, the USD fallback.
    #[default]
    CatmullClark,
    /// `loop`: triangles only.
    Loop,
    /// `bilinear`: flat refinement.
    Bilinear,
}

/// `interpolateBoundary`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum BoundaryInterpolation {
    /// `none`: boundary faces are not part of the surface (OpenSubdiv tags them as holes).
    None,
    /// `edgeOnly`: boundary edges are sharp, corners smooth.
    EdgeOnly,
    /// `edgeAndCorner`: boundary edges and corners sharp (USD fallback).
    #[default]
    EdgeAndCorner,
}

/// `faceVaryingLinearInterpolation`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum FaceVaryingInterpolation {
    /// `none`: smooth everywhere.
    None,
    /// `cornersOnly`.
    CornersOnly,
    /// `cornersPlus1` (USD fallback).
    #[default]
    CornersPlus1,
    /// `cornersPlus2`.
    CornersPlus2,
    /// `boundaries`: linear along all face-varying boundaries.
    Boundaries,
    /// `all`: linear everywhere.
    All,
}

/// `triangleSubdivisionRule` (Catmull–Clark only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum TriangleSubdivision {
    /// `catmullClark`: ordinary Catmull–Clark weights (USD fallback).
    #[default]
    CatmullClark,
    /// `smooth`: weights that give rounder results on triangles.
    Smooth,
}

/// Parsing a USD token that is not one of the values of its attribute.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown token {token:?}")]
pub struct UnknownToken {
    /// The token as authored.
    pub token: String,
}

macro_rules! usd_tokens {
    ($ty:ty { $($token:literal => $variant:expr),+ $(,)? }) => {
        impl FromStr for $ty {
            type Err = UnknownToken;
            fn from_str(s: &str) -> std::result::Result<Self, UnknownToken> {
                match s {
                    $($token => Ok($variant),)+
                    _ => Err(UnknownToken { token: s.to_owned() }),
                }
            }
        }
    };
}

usd_tokens!(Scheme { "catmullClark" => Scheme::CatmullClark, "loop" => Scheme::Loop, "bilinear" => Scheme::Bilinear });
usd_tokens!(BoundaryInterpolation {
    "none" => BoundaryInterpolation::None,
    "edgeOnly" => BoundaryInterpolation::EdgeOnly,
    "edgeAndCorner" => BoundaryInterpolation::EdgeAndCorner,
});
usd_tokens!(FaceVaryingInterpolation {
    "none" => FaceVaryingInterpolation::None,
    "cornersOnly" => FaceVaryingInterpolation::CornersOnly,
    "cornersPlus1" => FaceVaryingInterpolation::CornersPlus1,
    "cornersPlus2" => FaceVaryingInterpolation::CornersPlus2,
    "boundaries" => FaceVaryingInterpolation::Boundaries,
    "all" => FaceVaryingInterpolation::All,
});
usd_tokens!(TriangleSubdivision {
    "catmullClark" => TriangleSubdivision::CatmullClark,
    "smooth" => TriangleSubdivision::Smooth,
});

/// Scheme and rule options; `Default` is USD's fallback for every attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Options {
    /// `subdivisionScheme`.
    pub scheme: Scheme,
    /// `interpolateBoundary`.
    pub boundary: BoundaryInterpolation,
    /// `faceVaryingLinearInterpolation`.
    pub face_varying: FaceVaryingInterpolation,
    /// `triangleSubdivisionRule`.
    pub triangle_subdivision: TriangleSubdivision,
}

/// Topology of one face-varying channel (e.g. an indexed `primvars:st`).
///
/// For a face-varying primvar authored without indices, pass `0..faceVertexIndices.len()`.
#[derive(Debug, Clone, Copy, Default)]
pub struct FaceVaryingChannel<'a> {
    /// One value index per face-vertex.
    pub indices: &'a [i32],
    /// Number of values the indices refer to.
    pub value_count: usize,
}

/// A subdivision cage exactly as USD authors it, borrowed. Validate it with [`Topology::new`].
///
/// Empty slices mean "not authored"; `Default` gives an empty cage to fill with struct update
/// syntax.
#[derive(Debug, Clone, Copy, Default)]
pub struct Cage<'a> {
    /// `faceVertexCounts`.
    pub face_vertex_counts: &'a [i32],
    /// `faceVertexIndices`.
    pub face_vertex_indices: &'a [i32],
    /// Number of points.
    pub vertex_count: usize,
    /// Scheme and rules.
    pub options: Options,
    /// `creaseIndices`: the crease chains, concatenated.
    pub crease_indices: &'a [i32],
    /// `creaseLengths`: vertices per chain (≥ 2).
    pub crease_lengths: &'a [i32],
    /// `creaseSharpnesses`: one per chain, or one per edge of all chains.
    pub crease_sharpnesses: &'a [f32],
    /// `cornerIndices`.
    pub corner_indices: &'a [i32],
    /// `cornerSharpnesses`, one per corner.
    pub corner_sharpnesses: &'a [f32],
    /// `holeIndices`: faces to leave out.
    pub hole_indices: &'a [i32],
    /// Face-varying channels; channel `i` is addressed as `i` later.
    pub face_varying: &'a [FaceVaryingChannel<'a>],
}

/// A validated cage, owned, in the layout `Far::TopologyDescriptor` takes.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    options: Options,
    vertex_count: usize,
    face_vertex_counts: Vec<i32>,
    face_vertex_indices: Vec<i32>,
    /// Crease edges as vertex pairs, flattened from USD's chains.
    crease_pairs: Vec<i32>,
    /// One sharpness per crease edge.
    crease_sharpnesses: Vec<f32>,
    corner_indices: Vec<i32>,
    corner_sharpnesses: Vec<f32>,
    hole_indices: Vec<i32>,
    /// Per channel: value indices and value count.
    face_varying: Vec<(Vec<i32>, usize)>,
}

/// OpenSubdiv indexes with `int`.
const MAX_INDEX: usize = i32::MAX as usize;

fn check_range(attribute: &'static str, values: &[i32], bound: usize) -> Result<()> {
    match values.iter().position(|&i| i < 0 || i as usize >= bound) {
        Some(at) => Err(Error::IndexOutOfRange { attribute, at, index: values[at].into(), bound }),
        None => Ok(()),
    }
}

fn check_finite(attribute: &'static str, values: &[f32]) -> Result<()> {
    match values.iter().position(|s| !s.is_finite()) {
        Some(at) => Err(Error::Invalid { attribute, reason: format!("entry {at} is {}", values[at]) }),
        None => Ok(()),
    }
}

impl Topology {
    /// Validates `cage`: face sizes, index ranges, array lengths, crease chains along existing
    /// edges, hole and corner indices, face-varying channels.
    pub fn new(cage: &Cage<'_>) -> Result<Self> {
        let counts = cage.face_vertex_counts;
        let indices = cage.face_vertex_indices;
        if counts.is_empty() {
            return Err(Error::NoFaces);
        }
        if let Some(face) = counts.iter().position(|&c| c < 3) {
            return Err(Error::DegenerateFace { face, count: counts[face].into() });
        }
        let sum: u64 = counts.iter().map(|&c| c as u64).sum();
        if sum != indices.len() as u64 {
            return Err(Error::CountMismatch { sum, len: indices.len() });
        }
        if cage.vertex_count > MAX_INDEX || indices.len() > MAX_INDEX {
            return Err(Error::Invalid { attribute: "points", reason: "more than 2^31 entries".into() });
        }
        check_range("faceVertexIndices", indices, cage.vertex_count)?;
        if cage.options.scheme == Scheme::Loop {
            if let Some(face) = counts.iter().position(|&c| c != 3) {
                return Err(Error::Invalid {
                    attribute: "faceVertexCounts",
                    reason: format!(
                        "the loop scheme needs triangles; face {face} has {} vertices",
                        counts[face]
                    ),
                });
            }
        }

        let (crease_pairs, crease_sharpnesses) = flatten_creases(cage)?;

        if cage.corner_indices.len() != cage.corner_sharpnesses.len() {
            return Err(Error::Invalid {
                attribute: "cornerSharpnesses",
                reason: format!(
                    "{} sharpnesses for {} cornerIndices",
                    cage.corner_sharpnesses.len(),
                    cage.corner_indices.len()
                ),
            });
        }
        check_range("cornerIndices", cage.corner_indices, cage.vertex_count)?;
        check_finite("cornerSharpnesses", cage.corner_sharpnesses)?;
        check_range("holeIndices", cage.hole_indices, counts.len())?;

        let mut face_varying = Vec::with_capacity(cage.face_varying.len());
        for channel in cage.face_varying {
            if channel.indices.len() != indices.len() {
                return Err(Error::Invalid {
                    attribute: "face-varying indices",
                    reason: format!("{} indices for {} face-vertices", channel.indices.len(), indices.len()),
                });
            }
            if channel.value_count > MAX_INDEX {
                return Err(Error::Invalid {
                    attribute: "face-varying values",
                    reason: "more than 2^31 values".into(),
                });
            }
            check_range("face-varying indices", channel.indices, channel.value_count)?;
            face_varying.push((channel.indices.to_vec(), channel.value_count));
        }

        Ok(Self {
            options: cage.options,
            vertex_count: cage.vertex_count,
            face_vertex_counts: counts.to_vec(),
            face_vertex_indices: indices.to_vec(),
            crease_pairs,
            crease_sharpnesses,
            corner_indices: cage.corner_indices.to_vec(),
            corner_sharpnesses: cage.corner_sharpnesses.to_vec(),
            hole_indices: cage.hole_indices.to_vec(),
            face_varying,
        })
    }

    /// Scheme and rules.
    pub fn options(&self) -> Options {
        self.options
    }

    /// Number of cage vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// Vertices per face, as authored (left-handed faces already reversed).
    pub fn face_vertex_counts(&self) -> &[i32] {
        &self.face_vertex_counts
    }

    /// The faces' vertex indices, face after face.
    pub fn face_vertex_indices(&self) -> &[i32] {
        &self.face_vertex_indices
    }

    /// Crease edges as vertex pairs, flattened from USD's chains.
    pub fn crease_pairs(&self) -> &[i32] {
        &self.crease_pairs
    }

    /// One sharpness per crease edge.
    pub fn crease_sharpnesses(&self) -> &[f32] {
        &self.crease_sharpnesses
    }

    /// Sharp corner vertices.
    pub fn corner_indices(&self) -> &[i32] {
        &self.corner_indices
    }

    /// One sharpness per corner.
    pub fn corner_sharpnesses(&self) -> &[f32] {
        &self.corner_sharpnesses
    }

    /// Faces that are holes.
    pub fn hole_indices(&self) -> &[i32] {
        &self.hole_indices
    }

    /// Per face-varying channel: value indices and value count.
    pub fn face_varying(&self) -> &[(Vec<i32>, usize)] {
        &self.face_varying
    }

    /// Number of cage faces.
    pub fn face_count(&self) -> usize {
        self.face_vertex_counts.len()
    }

    /// Number of face-varying channels.
    pub fn face_varying_channels(&self) -> usize {
        self.face_varying.len()
    }

    /// Value count of face-varying `channel`, if it exists.
    pub fn face_varying_value_count(&self, channel: usize) -> Option<usize> {
        self.face_varying.get(channel).map(|c| c.1)
    }

    /// A cheap key for finding equal topologies (e.g. one asset referenced many times, which
    /// can share one refiner): the sizes, the options and a sample of at most 64 face-vertex
    /// indices. Equal topologies have equal keys; compare with `==` to be sure.
    pub fn sharing_key(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (self.vertex_count, self.face_vertex_counts.len(), self.face_vertex_indices.len()).hash(&mut h);
        self.options.hash(&mut h);
        let step = (self.face_vertex_indices.len() / 64).max(1);
        self.face_vertex_indices.iter().step_by(step).for_each(|i| i.hash(&mut h));
        (self.hole_indices.len(), self.crease_pairs.len(), self.face_varying.len()).hash(&mut h);
        h.finish()
    }

    /// Faces as slices of vertex indices.
    pub fn faces(&self) -> impl Iterator<Item = &[i32]> + '_ {
        let mut start = 0;
        self.face_vertex_counts.iter().map(move |&n| {
            let face = &self.face_vertex_indices[start..start + n as usize];
            start += n as usize;
            face
        })
    }

    /// Length of the longest cage edge, measured with `positions` transformed by the caller (e.g.
    /// to raster space), for `subdiv::level_for_dicing_rate`.
    pub fn longest_edge(&self, positions: &[[f32; 3]]) -> Result<f32> {
        if positions.len() != self.vertex_count {
            return Err(Error::PrimvarSize {
                what: "points",
                expected: self.vertex_count,
                got: positions.len(),
            });
        }
        let mut longest = 0.0f32;
        for face in self.faces() {
            for (i, &a) in face.iter().enumerate() {
                let b = face[(i + 1) % face.len()];
                let (p, q) = (positions[a as usize], positions[b as usize]);
                let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
                longest = longest.max(d);
            }
        }
        Ok(longest)
    }
}

/// USD authors creases as vertex chains with a sharpness per chain or per edge; OpenSubdiv takes
/// one (vertex pair, sharpness) per edge.
fn flatten_creases(cage: &Cage<'_>) -> Result<(Vec<i32>, Vec<f32>)> {
    let (chains, lengths, sharpnesses) = (cage.crease_indices, cage.crease_lengths, cage.crease_sharpnesses);
    if chains.is_empty() && lengths.is_empty() && sharpnesses.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    if let Some(at) = lengths.iter().position(|&n| n < 2) {
        return Err(Error::Invalid {
            attribute: "creaseLengths",
            reason: format!("entry {at} is {}; a crease chain needs at least 2 vertices", lengths[at]),
        });
    }
    let vertex_sum: u64 = lengths.iter().map(|&n| n as u64).sum();
    if vertex_sum != chains.len() as u64 {
        return Err(Error::Invalid {
            attribute: "creaseLengths",
            reason: format!("lengths sum to {vertex_sum} but creaseIndices has {} entries", chains.len()),
        });
    }
    check_range("creaseIndices", chains, cage.vertex_count)?;
    check_finite("creaseSharpnesses", sharpnesses)?;
    let edge_count = chains.len() - lengths.len();
    let per_edge = match sharpnesses.len() {
        n if n == lengths.len() => false,
        n if n == edge_count => true,
        n => {
            return Err(Error::Invalid {
                attribute: "creaseSharpnesses",
                reason: format!(
                    "{n} entries; expected {} (per crease) or {edge_count} (per edge)",
                    lengths.len()
                ),
            })
        }
    };

    // Far drops a crease along a missing edge with only a warning; a crease that does nothing is
    // an authoring error worth reporting.
    let key = |a: i32, b: i32| (a.min(b), a.max(b));
    let mut edges = HashSet::new();
    for face in cage_faces(cage) {
        for (i, &a) in face.iter().enumerate() {
            edges.insert(key(a, face[(i + 1) % face.len()]));
        }
    }

    let mut pairs = Vec::with_capacity(2 * edge_count);
    let mut weights = Vec::with_capacity(edge_count);
    let mut start = 0;
    for (crease, &n) in lengths.iter().enumerate() {
        let chain = &chains[start..start + n as usize];
        for w in chain.windows(2) {
            if !edges.contains(&key(w[0], w[1])) {
                return Err(Error::Invalid {
                    attribute: "creaseIndices",
                    reason: format!("crease {crease} runs along {}–{}, which is not an edge", w[0], w[1]),
                });
            }
            pairs.extend_from_slice(w);
            weights.push(if per_edge { sharpnesses[weights.len()] } else { sharpnesses[crease] });
        }
        start += n as usize;
    }
    Ok((pairs, weights))
}

/// Faces of an unvalidated cage whose counts are already known to sum to the index count.
fn cage_faces<'a>(cage: &'a Cage<'_>) -> impl Iterator<Item = &'a [i32]> + 'a {
    let mut start = 0;
    cage.face_vertex_counts.iter().map(move |&n| {
        let face = &cage.face_vertex_indices[start..start + n as usize];
        start += n as usize;
        face
    })
}

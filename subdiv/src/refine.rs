//! Uniform refinement: [`Refiner`] owns a `Far::TopologyRefiner` refined to one level and refines
//! vertex and face-varying primvars to that level.

use std::ffi::c_int;
use std::ptr::{self, NonNull};

use crate::ffi;
use crate::{BoundaryInterpolation, FaceVaryingInterpolation, Scheme, Topology, TriangleSubdivision};
use crate::{Error, Result};

/// Highest uniform level accepted. OpenSubdiv stores the level in 4 bits (15), but a cube at
/// level 10 is already 6.3 M quads; anything finer belongs to adaptive tessellation.
pub const MAX_LEVEL: u32 = 10;

/// Where refined primvar values are evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Evaluation {
    /// The control points of the last level (what `PrimvarRefiner::Interpolate` gives).
    Refined,
    /// Those control points projected onto the limit surface (`PrimvarRefiner::Limit`).
    Limit,
}

/// Faces of the last refinement level.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RefinedFaces {
    /// Vertices per face: 4 for Catmull–Clark and bilinear quads after one level, 3 for loop.
    pub counts: Vec<u32>,
    /// Refined vertex indices, concatenated.
    pub vertices: Vec<u32>,
    /// Face-varying value indices of the requested channel, parallel to `vertices` (empty
    /// without a channel).
    pub fvar_values: Vec<u32>,
    /// The cage face each face descends from.
    pub coarse_face: Vec<u32>,
    /// Faces inside holes, including the boundary faces dropped by `interpolateBoundary = none`.
    pub is_hole: Vec<bool>,
}

/// A `Far::TopologyRefiner` uniformly refined to [`Refiner::level`]; freed on drop.
#[derive(Debug)]
pub struct Refiner {
    raw: NonNull<ffi::OsdRefiner>,
    level: u32,
    scheme: Scheme,
    base_vertices: usize,
    base_faces: usize,
    base_fvar_values: Vec<usize>,
}

// SAFETY: after construction the refiner is only read (`const` methods of TopologyRefiner and
// PrimvarRefiner, which keep no mutable state); the shim's error state is thread-local.
unsafe impl Send for Refiner {}
// SAFETY: as above, concurrent reads of a refined TopologyRefiner are safe.
unsafe impl Sync for Refiner {}

impl Drop for Refiner {
    fn drop(&mut self) {
        // SAFETY: `raw` came from `osd_refiner_new` and is freed exactly once, here.
        unsafe { ffi::osd_refiner_free(self.raw.as_ptr()) }
    }
}

pub(crate) fn check(status: c_int) -> Result<()> {
    if status == 0 {
        Ok(())
    } else {
        Err(Error::OpenSubdiv(ffi::last_error()))
    }
}

pub(crate) fn to_c_int(n: usize) -> c_int {
    // Topology validation caps every count at i32::MAX.
    c_int::try_from(n).expect("count validated to fit in an int")
}

impl Refiner {
    /// Builds the refiner and refines uniformly to `level`.
    ///
    /// Catmull–Clark cages with a non-quad face are refined at least once: the limit masks used
    /// for positions and normals assume an all-quad neighbourhood, which only holds from level 1.
    pub fn new(topology: &Topology, level: u32) -> Result<Self> {
        Self::refined_to(topology, Self::level_for(topology, level))
    }

    /// The level [`Refiner::new`] refines `topology` to when asked for `level`.
    pub fn level_for(topology: &Topology, level: u32) -> u32 {
        let all_quads = topology.face_vertex_counts().iter().all(|&n| n == 4);
        let bump = level == 0 && topology.options().scheme == Scheme::CatmullClark && !all_quads;
        if bump {
            1
        } else {
            level
        }
    }

    /// The finest level `topology` can be refined to: each level multiplies the face-vertex
    /// count by 4 (for every scheme after level 1), and OpenSubdiv counts them in `int`.
    pub fn highest_level(topology: &Topology) -> u32 {
        let fv = topology.face_vertex_indices().len() as u64;
        (0..=MAX_LEVEL).take_while(|&l| fv << (2 * l) <= i32::MAX as u64).last().unwrap_or(0)
    }

    /// Per cage face, whether it has no surface: listed in `holeIndices`, or a boundary face
    /// that `interpolateBoundary = none` drops (Far tags both; refined faces inherit the tag).
    pub fn base_face_holes(&self) -> Result<Vec<bool>> {
        let mut holes = vec![0u8; self.base_faces];
        // SAFETY: `raw` is a live refiner; `holes` has one byte per base face, as the shim writes.
        check(unsafe { ffi::osd_base_face_holes(self.raw.as_ptr(), holes.as_mut_ptr()) })?;
        Ok(holes.into_iter().map(|h| h != 0).collect())
    }

    /// The base level only, for Bfr, which builds each face's limit surface from it.
    pub(crate) fn unrefined(topology: &Topology) -> Result<Self> {
        Self::refined_to(topology, 0)
    }

    /// The owned C++ refiner, for the other modules' shim calls.
    pub(crate) fn raw(&self) -> *const ffi::OsdRefiner {
        self.raw.as_ptr()
    }

    fn refined_to(topology: &Topology, level: u32) -> Result<Self> {
        let scheme = topology.options().scheme;
        let max = Self::highest_level(topology);
        if level > max {
            return Err(Error::LevelTooHigh { level, max });
        }

        let fvar_counts: Vec<c_int> = topology.face_varying().iter().map(|c| to_c_int(c.1)).collect();
        let fvar_ptrs: Vec<*const c_int> = topology.face_varying().iter().map(|c| c.0.as_ptr()).collect();
        let desc = ffi::OsdDesc {
            scheme: match scheme {
                Scheme::Bilinear => 0,
                Scheme::CatmullClark => 1,
                Scheme::Loop => 2,
            },
            boundary: match topology.options().boundary {
                BoundaryInterpolation::None => 0,
                BoundaryInterpolation::EdgeOnly => 1,
                BoundaryInterpolation::EdgeAndCorner => 2,
            },
            fvar_linear: match topology.options().face_varying {
                FaceVaryingInterpolation::None => 0,
                FaceVaryingInterpolation::CornersOnly => 1,
                FaceVaryingInterpolation::CornersPlus1 => 2,
                FaceVaryingInterpolation::CornersPlus2 => 3,
                FaceVaryingInterpolation::Boundaries => 4,
                FaceVaryingInterpolation::All => 5,
            },
            triangle_subdivision: match topology.options().triangle_subdivision {
                TriangleSubdivision::CatmullClark => 0,
                TriangleSubdivision::Smooth => 1,
            },
            num_vertices: to_c_int(topology.vertex_count()),
            num_faces: to_c_int(topology.face_vertex_counts().len()),
            face_vertex_counts: topology.face_vertex_counts().as_ptr(),
            face_vertex_indices: topology.face_vertex_indices().as_ptr(),
            num_creases: to_c_int(topology.crease_sharpnesses().len()),
            crease_vertex_pairs: topology.crease_pairs().as_ptr(),
            crease_sharpnesses: topology.crease_sharpnesses().as_ptr(),
            num_corners: to_c_int(topology.corner_indices().len()),
            corner_indices: topology.corner_indices().as_ptr(),
            corner_sharpnesses: topology.corner_sharpnesses().as_ptr(),
            num_holes: to_c_int(topology.hole_indices().len()),
            hole_indices: topology.hole_indices().as_ptr(),
            num_fvar_channels: to_c_int(fvar_ptrs.len()),
            fvar_value_counts: fvar_counts.as_ptr(),
            fvar_value_indices: fvar_ptrs.as_ptr(),
            level: level as c_int,
        };

        let mut raw = ptr::null_mut();
        // SAFETY: every pointer in `desc` borrows a Vec that outlives the call, with the length
        // stated beside it; `Topology::new` checked all indices against those lengths.
        check(unsafe { ffi::osd_refiner_new(&desc, &mut raw) })?;
        let raw = NonNull::new(raw).ok_or_else(|| Error::OpenSubdiv("null refiner".into()))?;
        Ok(Self {
            raw,
            level,
            scheme,
            base_vertices: topology.vertex_count(),
            base_faces: topology.face_vertex_counts().len(),
            base_fvar_values: topology.face_varying().iter().map(|c| c.1).collect(),
        })
    }

    /// The level refined to (may exceed the requested level, see [`Refiner::new`]).
    pub fn level(&self) -> u32 {
        self.level
    }

    /// The subdivision scheme.
    pub fn scheme(&self) -> Scheme {
        self.scheme
    }

    /// Number of cage vertices (the length vertex primvars must have).
    pub fn base_vertex_count(&self) -> usize {
        self.base_vertices
    }

    /// Counts at the last level: (vertices, faces, face-vertices, values of `channel`).
    fn counts(&self, channel: Option<usize>) -> Result<(usize, usize, usize, usize)> {
        let (mut v, mut f, mut fv, mut values) = (0, 0, 0, 0);
        let channel = channel.map_or(-1, to_c_int);
        // SAFETY: `raw` is a live refiner; the out-pointers are valid locals.
        check(unsafe {
            ffi::osd_refiner_counts(self.raw.as_ptr(), channel, &mut v, &mut f, &mut fv, &mut values)
        })?;
        Ok((v as usize, f as usize, fv as usize, values as usize))
    }

    /// Number of vertices at the last level.
    pub fn vertex_count(&self) -> Result<usize> {
        Ok(self.counts(None)?.0)
    }

    /// Number of cage values of face-varying `channel`, or an error naming the missing channel.
    pub(crate) fn base_fvar_value_count(&self, channel: usize) -> Result<usize> {
        self.check_channel(channel)
    }

    fn check_channel(&self, channel: usize) -> Result<usize> {
        self.base_fvar_values.get(channel).copied().ok_or_else(|| Error::Invalid {
            attribute: "face-varying channel",
            reason: format!("channel {channel} does not exist ({} channels)", self.base_fvar_values.len()),
        })
    }

    /// Faces of the last level, with the face-varying indices of `channel` if given.
    pub fn faces(&self, channel: Option<usize>) -> Result<RefinedFaces> {
        if let Some(c) = channel {
            self.check_channel(c)?;
        }
        let (_, faces, face_vertices, _) = self.counts(channel)?;
        let mut counts = vec![0 as c_int; faces];
        let mut vertices = vec![0 as c_int; face_vertices];
        let mut fvar = vec![0 as c_int; if channel.is_some() { face_vertices } else { 0 }];
        let mut coarse = vec![0 as c_int; faces];
        let mut hole = vec![0u8; faces];
        let fvar_ptr = if channel.is_some() { fvar.as_mut_ptr() } else { ptr::null_mut() };
        // SAFETY: buffers are sized from the counts the same refiner just reported: `faces`
        // entries for per-face arrays, `face_vertices` for per-face-vertex arrays.
        check(unsafe {
            ffi::osd_refiner_faces(
                self.raw.as_ptr(),
                channel.map_or(0, to_c_int),
                counts.as_mut_ptr(),
                vertices.as_mut_ptr(),
                fvar_ptr,
                coarse.as_mut_ptr(),
                hole.as_mut_ptr(),
            )
        })?;
        let unsigned = |v: Vec<c_int>| v.into_iter().map(|i| i as u32).collect();
        Ok(RefinedFaces {
            counts: unsigned(counts),
            vertices: unsigned(vertices),
            fvar_values: unsigned(fvar),
            coarse_face: unsigned(coarse),
            is_hole: hole.into_iter().map(|h| h != 0).collect(),
        })
    }

    /// Refines a vertex primvar of `width` floats per cage vertex (positions, or any float-n
    /// data) to the last level.
    pub fn vertex_primvar(&self, data: &[f32], width: usize, eval: Evaluation) -> Result<Vec<f32>> {
        let (n, ..) = self.counts(None)?;
        let out = self.vertex_primvar_f64(data, width, eval, None)?;
        debug_assert_eq!(out.len(), n * width);
        Ok(out.into_iter().map(|x| x as f32).collect())
    }

    /// Shared by [`Refiner::vertex_primvar`] and the limit frame: refines in f64 and optionally
    /// returns the limit tangents (only with [`Evaluation::Limit`]).
    pub(crate) fn vertex_primvar_f64(
        &self,
        data: &[f32],
        width: usize,
        eval: Evaluation,
        tangents: Option<(&mut Vec<f64>, &mut Vec<f64>)>,
    ) -> Result<Vec<f64>> {
        if width == 0 || data.len() != self.base_vertices * width {
            return Err(Error::PrimvarSize {
                what: "vertex primvar",
                expected: self.base_vertices * width.max(1),
                got: data.len(),
            });
        }
        let (n, ..) = self.counts(None)?;
        let src: Vec<f64> = data.iter().map(|&x| x.into()).collect();
        let mut dst = vec![0.0; n * width];
        let (du, dv) = match tangents {
            Some((du, dv)) if eval == Evaluation::Limit => {
                du.clear();
                du.resize(n * width, 0.0);
                dv.clear();
                dv.resize(n * width, 0.0);
                (du.as_mut_ptr(), dv.as_mut_ptr())
            }
            _ => (ptr::null_mut(), ptr::null_mut()),
        };
        // SAFETY: `src` holds width values per cage vertex and `dst` (and `du`/`dv` when non-null)
        // width values per last-level vertex, as the shim reads and writes.
        check(unsafe {
            ffi::osd_refine_vertex(
                self.raw.as_ptr(),
                src.as_ptr(),
                to_c_int(width),
                (eval == Evaluation::Limit).into(),
                dst.as_mut_ptr(),
                du,
                dv,
            )
        })?;
        Ok(dst)
    }

    /// Refines a face-varying primvar of `width` floats per value of `channel`.
    pub fn face_varying_primvar(
        &self,
        channel: usize,
        data: &[f32],
        width: usize,
        eval: Evaluation,
    ) -> Result<Vec<f32>> {
        let base = self.check_channel(channel)?;
        if width == 0 || data.len() != base * width {
            return Err(Error::PrimvarSize {
                what: "face-varying primvar",
                expected: base * width.max(1),
                got: data.len(),
            });
        }
        let (.., values) = self.counts(Some(channel))?;
        let src: Vec<f64> = data.iter().map(|&x| x.into()).collect();
        let mut dst = vec![0.0f64; values * width];
        // SAFETY: `src` holds width values per cage value of the channel, `dst` width values per
        // last-level value, as counted by the same refiner.
        check(unsafe {
            ffi::osd_refine_fvar(
                self.raw.as_ptr(),
                to_c_int(channel),
                src.as_ptr(),
                to_c_int(width),
                (eval == Evaluation::Limit).into(),
                dst.as_mut_ptr(),
            )
        })?;
        Ok(dst.into_iter().map(|x| x as f32).collect())
    }
}

//! Tessellation plans: how many triangles each cage face will be diced into, from the topology
//! and the level or edge rates alone, without evaluating any limit surface.
//!
//! A listing (what a scene renders, triangle counts included) needs the counts but not the
//! surface, and limit evaluation is most of the cost of dicing. The plans mirror the two
//! tessellators exactly:
//!
//! - uniform ([`crate::tessellate`]): every face that is not a hole becomes `4^L` quads of a
//!   quad, `n·4^(L−1)` quads of an n-gon (Catmull–Clark and bilinear, `L ≥ 1`), `4^L` triangles
//!   of a triangle (loop), or, at level 0, itself (a quad is two triangles, an n-gon a fan of
//!   `n − 2`); quads split in two. Holes are read from the base level of a `Far::TopologyRefiner`
//!   (which tags the boundary faces `interpolateBoundary = none` drops), and refined faces
//!   inherit them, so no refinement is needed.
//! - per edge ([`AdaptiveRefiner::tessellate`]): the shim builds the same `Bfr::Tessellation` of
//!   each face (its parameterization and rates) and counts its facets, once per distinct pattern,
//!   without building a surface.

use crate::adaptive::AdaptiveRefiner;
use crate::ffi;
use crate::refine::{check, Refiner};
use crate::Result;
use crate::{Scheme, Topology};

/// Triangles [`crate::tessellate`] makes of one face of `size` vertices at (effective) uniform
/// `level` ([`Refiner::level_for`]), unless the face is a hole.
pub fn uniform_face_triangles(scheme: Scheme, size: usize, level: u32) -> u64 {
    let four = |l: u32| 4u64.saturating_pow(l);
    match (scheme, size, level) {
        (Scheme::Loop, _, l) => four(l),
        (_, 4, l) => 2 * four(l),
        (_, n, 0) => n.saturating_sub(2) as u64,
        (_, n, l) => (2 * n as u64).saturating_mul(four(l - 1)),
    }
}

/// A uniform tessellation, planned.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UniformPlan {
    /// The level refined to ([`Refiner::level_for`]).
    pub level: u32,
    /// Triangles per cage face (0 for holes).
    pub face_triangles: Vec<u64>,
}

impl UniformPlan {
    /// Plans `topology` at `level` as [`Refiner::new`] and [`crate::tessellate`] would refine it.
    /// Builds the unrefined `Far::TopologyRefiner` (to read holes), so a topology OpenSubdiv
    /// rejects fails here as it would there; a level past [`Refiner::highest_level`] is
    /// [`crate::Error::LevelTooHigh`], as from [`Refiner::new`].
    pub fn new(topology: &Topology, level: u32) -> Result<Self> {
        Self::with_holes(topology, level, &Self::holes(topology)?)
    }

    /// Per cage face, whether it has no surface ([`Refiner::base_face_holes`] of the unrefined
    /// refiner, which this builds): what [`UniformPlan::with_holes`] takes, to be shared by
    /// cages with one topology.
    pub fn holes(topology: &Topology) -> Result<Vec<bool>> {
        Refiner::unrefined(topology)?.base_face_holes()
    }

    /// [`UniformPlan::new`] with the holes already read ([`UniformPlan::holes`]).
    pub fn with_holes(topology: &Topology, level: u32, holes: &[bool]) -> Result<Self> {
        let level = Refiner::level_for(topology, level);
        let max = Refiner::highest_level(topology);
        if level > max {
            return Err(crate::Error::LevelTooHigh { level, max });
        }
        if holes.len() != topology.face_count() {
            return Err(crate::Error::PrimvarSize {
                what: "face hole flags",
                expected: topology.face_count(),
                got: holes.len(),
            });
        }
        let scheme = topology.options().scheme;
        let face_triangles = topology
            .face_vertex_counts()
            .iter()
            .zip(holes)
            .map(|(&n, &hole)| if hole { 0 } else { uniform_face_triangles(scheme, n as usize, level) })
            .collect();
        Ok(Self { level, face_triangles })
    }
}

impl AdaptiveRefiner {
    /// Triangles [`AdaptiveRefiner::tessellate`] makes of each cage face at `rates` (0 for faces
    /// without a limit surface), without evaluating anything.
    pub fn planned_face_triangles(&self, rates: &[u32]) -> Result<Vec<u64>> {
        let rates = self.check_rates(rates)?;
        let mut out = vec![0i64; self.face_count()];
        // SAFETY: `rates` has one int per base edge (checked), `out` one entry per base face.
        check(unsafe { ffi::osd_plan_adaptive(self.base().raw(), rates.as_ptr(), out.as_mut_ptr()) })?;
        Ok(out.into_iter().map(|n| n.max(0) as u64).collect())
    }
}

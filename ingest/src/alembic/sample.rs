//! Property values at the requested time: the sample picked by the property's time sampling,
//! blended linearly with the next one for positions and transforms, held otherwise.

use super::archive::{Archive, Compound, Kind};
use super::time::When;

/// A geometry parameter (`GeomParam`): values, optional indices and the USD interpolation its
/// `geoScope` names.
pub(super) struct GeomParam {
    /// Flattened values (`extent` per element).
    pub values: Vec<f64>,
    pub indices: Option<Vec<i64>>,
    /// `constant`, `uniform`, `varying`, `vertex`, `faceVarying`, or `None` when the scope is
    /// not authored (the caller infers it from the element count).
    pub interpolation: Option<&'static str>,
}

/// Reads properties at one time.
pub(super) struct Sampler {
    pub archive: Archive,
    pub when: When,
}

impl Sampler {
    /// Sample of `name` held at the picked time, or `None` if the property is absent or has no
    /// samples.
    pub(super) fn held(&mut self, c: &Compound, name: &str) -> Result<Option<Vec<f64>>, String> {
        let Some((_, h)) = c.find(name) else { return Ok(None) };
        if h.samples == 0 {
            return Ok(None);
        }
        let pick = self.archive.time_samplings[h.time_sampling].pick(self.when, h.samples);
        self.archive.numbers(c, name, pick.lo).map(Some)
    }

    /// Sample of `name` blended between the two samples around the picked time when both have
    /// the same length (positions of a mesh whose topology changes are held instead).
    pub(super) fn blended(&mut self, c: &Compound, name: &str) -> Result<Option<Vec<f64>>, String> {
        let Some((_, h)) = c.find(name) else { return Ok(None) };
        if h.samples == 0 {
            return Ok(None);
        }
        let pick = self.archive.time_samplings[h.time_sampling].pick(self.when, h.samples);
        let a = self.archive.numbers(c, name, pick.lo)?;
        if pick.hi == pick.lo || pick.weight == 0.0 {
            return Ok(Some(a));
        }
        let b = self.archive.numbers(c, name, pick.hi)?;
        if a.len() != b.len() {
            return Ok(Some(a));
        }
        let w = pick.weight;
        Ok(Some(a.iter().zip(&b).map(|(x, y)| x + (y - x) * w).collect()))
    }

    /// The string sample of `name`, held.
    pub(super) fn strings(&mut self, c: &Compound, name: &str) -> Result<Option<Vec<String>>, String> {
        let Some((_, h)) = c.find(name) else { return Ok(None) };
        if h.samples == 0 {
            return Ok(None);
        }
        let pick = self.archive.time_samplings[h.time_sampling].pick(self.when, h.samples);
        self.archive.strings(c, name, pick.lo).map(Some)
    }

    /// A geometry parameter: an array property, or a compound of `.vals` and `.indices`.
    pub(super) fn geom_param(&mut self, c: &Compound, name: &str) -> Result<Option<GeomParam>, String> {
        let Some((_, h)) = c.find(name) else { return Ok(None) };
        let interpolation = h.metadata.get("geoScope").and_then(|s| scope(s));
        let (values, indices) = if h.kind == Kind::Compound {
            let sub = self.archive.compound(c, name)?.expect("found above");
            let values = self.blended(&sub, ".vals").map_err(|e| format!("{name}/{e}"))?;
            let indices = self.held(&sub, ".indices").map_err(|e| format!("{name}/{e}"))?;
            let Some(values) = values else { return Ok(None) };
            (values, indices.map(|v| v.into_iter().map(|i| i as i64).collect()))
        } else {
            let Some(values) = self.blended(c, name)? else { return Ok(None) };
            (values, None)
        };
        Ok(Some(GeomParam { values, indices, interpolation }))
    }
}

/// The USD interpolation of an Alembic `geoScope`.
fn scope(s: &str) -> Option<&'static str> {
    Some(match s {
        "con" => "constant",
        "uni" => "uniform",
        "var" => "varying",
        "vtx" => "vertex",
        "fvr" => "faceVarying",
        _ => return None,
    })
}

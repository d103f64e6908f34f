//! PolyMesh and SubD objects, with their face sets, normals and texture coordinates.
//!
//! Alembic winds faces clockwise seen from the front, so meshes are written `leftHanded` and the
//! USD reader reverses them. Face sets become GeomSubsets bound to one default-grey material
//! per face-set name (Alembic carries no materials; exporters name face sets after them).

use super::archive::{Compound, Object};
use super::sample::GeomParam;
use super::translate::{as_ints, finite, schema, Translator, DEFAULT_MATERIAL};
use super::usda::{floats, ints, tuples};

/// Element counts a primvar's interpolation is inferred from when `geoScope` is unauthored.
pub(super) struct Counts {
    pub points: usize,
    pub faces: usize,
    pub corners: usize,
}

/// The USD interpolation of `param` with `elements` entries.
pub(super) fn interpolation(
    param: &GeomParam,
    elements: usize,
    counts: &Counts,
) -> Result<&'static str, String> {
    if let Some(i) = param.interpolation {
        return Ok(i);
    }
    Ok(match elements {
        n if n == counts.corners => "faceVarying",
        n if n == counts.points => "vertex",
        n if n == counts.faces => "uniform",
        1 => "constant",
        n => {
            return Err(format!(
                "{n} values fit none of {} points, {} faces, {} face corners",
                counts.points, counts.faces, counts.corners
            ))
        }
    })
}

/// SubD `.scheme` → `subdivisionScheme`.
fn scheme(name: &str) -> Result<&'static str, String> {
    Ok(match name {
        "catmull-clark" | "catmullClark" | "" => "catmullClark",
        "loop" => "loop",
        "bilinear" => "bilinear",
        other => return Err(format!(".scheme {other:?} is not catmull-clark, loop or bilinear")),
    })
}

impl Translator {
    /// Writes a Mesh prim (polygonal, or a subdivision cage for SubD objects).
    pub(super) fn mesh(&mut self, object: &Object, p: &Compound, subd: bool) -> Result<(), String> {
        let points = self.sampler.blended(p, "P")?.ok_or("P is missing")?;
        finite("P", &points)?;
        let counts = as_ints(&self.sampler.held(p, ".faceCounts")?.ok_or(".faceCounts is missing")?);
        let indices = as_ints(&self.sampler.held(p, ".faceIndices")?.ok_or(".faceIndices is missing")?);
        let sizes = Counts { points: points.len() / 3, faces: counts.len(), corners: indices.len() };
        if subd {
            let name =
                self.sampler.strings(p, ".scheme")?.and_then(|s| s.into_iter().next()).unwrap_or_default();
            self.layer.attr("uniform token subdivisionScheme", &format!("\"{}\"", scheme(&name)?), None);
        } else {
            self.layer.attr("uniform token subdivisionScheme", "\"none\"", None);
        }
        self.layer.attr("uniform token orientation", "\"leftHanded\"", None);
        self.layer.attr("int[] faceVertexCounts", &ints(&counts), None);
        self.layer.attr("int[] faceVertexIndices", &ints(&indices), None);
        self.layer.attr("point3f[] points", &tuples(&points, 3), None);
        if subd {
            self.subd_tags(p)?;
        } else if let Some(n) = self.sampler.geom_param(p, "N")? {
            finite("N", &n.values)?;
            self.primvar("normal3f[]", "primvars:normals", &n, 3, &sizes)?;
        }
        if let Some(uv) = self.sampler.geom_param(p, "uv")? {
            finite("uv", &uv.values)?;
            self.primvar("texCoord2f[]", "primvars:st", &uv, 2, &sizes)?;
        }
        let default = self.material(DEFAULT_MATERIAL);
        self.layer.line(&format!("rel material:binding = <{default}>"));
        self.face_sets(object, counts.len())
    }

    fn primvar(
        &mut self,
        ty: &str,
        name: &str,
        param: &GeomParam,
        extent: usize,
        counts: &Counts,
    ) -> Result<(), String> {
        if !param.values.len().is_multiple_of(extent) {
            return Err(format!("{name}: {} values are not whole {extent}-tuples", param.values.len()));
        }
        let elements = param.indices.as_ref().map_or(param.values.len() / extent, Vec::len);
        let interpolation = interpolation(param, elements, counts).map_err(|e| format!("{name}: {e}"))?;
        let metadata = format!("interpolation = \"{interpolation}\"");
        self.layer.attr(&format!("{ty} {name}"), &tuples(&param.values, extent), Some(&metadata));
        if let Some(indices) = &param.indices {
            self.layer.attr(&format!("int[] {name}:indices"), &ints(indices), None);
        }
        Ok(())
    }

    /// Creases, corners, holes and boundary rules of a SubD.
    fn subd_tags(&mut self, p: &Compound) -> Result<(), String> {
        for (alembic, usd, integer) in [
            (".creaseIndices", "int[] creaseIndices", true),
            (".creaseLengths", "int[] creaseLengths", true),
            (".creaseSharpnesses", "float[] creaseSharpnesses", false),
            (".cornerIndices", "int[] cornerIndices", true),
            (".cornerSharpnesses", "float[] cornerSharpnesses", false),
            (".holes", "int[] holeIndices", true),
        ] {
            let Some(values) = self.sampler.held(p, alembic)? else { continue };
            finite(alembic, &values)?;
            let text = if integer { ints(&as_ints(&values)) } else { floats(&values) };
            self.layer.attr(usd, &text, None);
        }
        // Rule numbering as usdAbc reads it.
        if let Some(v) = self.sampler.held(p, ".interpolateBoundary")? {
            let token = match v.first().copied().unwrap_or(1.0) as i64 {
                0 => "none",
                2 => "edgeOnly",
                _ => "edgeAndCorner",
            };
            self.layer.attr("token interpolateBoundary", &format!("\"{token}\""), None);
        }
        if let Some(v) = self.sampler.held(p, ".faceVaryingInterpolateBoundary")? {
            let token = match v.first().copied().unwrap_or(1.0) as i64 {
                0 => "all",
                2 => "none",
                3 => "boundaries",
                _ => "cornersPlus1",
            };
            self.layer.attr("token faceVaryingLinearInterpolation", &format!("\"{token}\""), None);
        }
        Ok(())
    }

    /// Face-set children as GeomSubsets bound to their materials.
    fn face_sets(&mut self, object: &Object, faces: usize) -> Result<(), String> {
        for i in 0..object.children.len() {
            let header = object.children[i].clone();
            if schema(&header) != Some("AbcGeom_FaceSet_v1") {
                continue;
            }
            let child = self.sampler.archive.child(object, i).map_err(|e| format!("{}: {e}", header.name))?;
            let set = self.sampler.archive.compound(&child.properties, ".faceset")?;
            let Some(set) = set else { continue };
            let members = as_ints(&self.sampler.held(&set, ".faces")?.unwrap_or_default());
            if members.is_empty() {
                continue;
            }
            if let Some(bad) = members.iter().find(|&&f| f < 0 || f as usize >= faces) {
                return Err(format!("face set {}: face {bad} of {faces}", header.name));
            }
            let material = self.material(&header.name);
            self.layer.open("GeomSubset", &header.name, &header.path, true);
            self.layer.attr("uniform token elementType", "\"face\"", None);
            self.layer.attr("uniform token familyName", "\"materialBind\"", None);
            self.layer.attr("int[] indices", &ints(&members), None);
            self.layer.line(&format!("rel material:binding = <{material}>"));
            self.layer.close();
        }
        Ok(())
    }
}

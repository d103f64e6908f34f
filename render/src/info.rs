//! `render BLOB --info`: scene counts and bounds as one JSON object.

use blob::SceneView;
use serde::Serialize;

/// What `--info` prints.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneSummary {
    /// Composed Mesh prims (`SceneInfo::gprim_count`).
    pub meshes: u32,
    /// Expanded instances (`SceneInfo::instance_count`).
    pub instances: u32,
    /// Triangles.
    pub triangles: usize,
    /// Curves after composition (entries of `curveVertexCounts` over all curve prims).
    pub curves: u64,
    /// Curve prims (BasisCurves, NurbsCurves) after composition.
    pub curve_prims: usize,
    /// Cubic Bézier segments after expansion and splitting.
    pub curve_segments: usize,
    /// Points (spheres) of Points prims.
    pub points: usize,
    /// Materials.
    pub materials: usize,
    /// UsdLux lights.
    pub lights: usize,
    /// Cameras.
    pub cameras: usize,
    /// World bounds minimum.
    pub bounds_min: [f32; 3],
    /// World bounds maximum.
    pub bounds_max: [f32; 3],
}

/// Summarizes a validated blob.
pub fn summarize(view: &SceneView) -> SceneSummary {
    SceneSummary {
        meshes: view.info.gprim_count,
        instances: view.info.instance_count,
        triangles: view.triangles.len(),
        curves: view
            .curves
            .groups
            .iter()
            .filter(|g| g.kind != blob::curves::CURVE_POINTS)
            .map(|g| g.curve_count as u64)
            .sum(),
        curve_prims: view.curves.groups.iter().filter(|g| g.kind != blob::curves::CURVE_POINTS).count(),
        curve_segments: view.curves.segments.len(),
        points: view.curves.spheres.len(),
        materials: view.materials.len(),
        lights: view.lights.len(),
        cameras: view.cameras.len(),
        bounds_min: view.info.bounds_min,
        bounds_max: view.info.bounds_max,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene;

    #[test]
    fn info_json_has_the_documented_keys() {
        let bytes = testscene::encode(&testscene::random_triangles(12, 3));
        let view = SceneView::parse(&bytes).unwrap();
        let json = serde_json::to_value(summarize(&view)).unwrap();
        assert_eq!(json["triangles"], 12);
        assert_eq!(json["meshes"], 1);
        assert_eq!(json["instances"], 0);
        assert_eq!(json["materials"], 1);
        for key in ["lights", "cameras", "bounds_min", "bounds_max", "curves", "curve_segments", "points"] {
            assert!(json.get(key).is_some(), "{key}");
        }
    }
}

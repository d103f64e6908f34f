//! `render BLOB --info`: scene counts and bounds as one JSON object.

use blob::SceneView;
use serde::Serialize;

/// What `--info` prints.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneSummary {
    /// Composed Mesh prims (`SceneInfo::gprim_count`).
    pub meshes: u32,
    /// Expanded instances (`SceneInfo::instance_count`: instanceable prims and point-instancer
    /// entries, nested ones included).
    pub instances: u32,
    /// Triangles rendered (each instance counts its prototype's triangles).
    pub triangles: usize,
    /// Triangles stored in the blob (each prototype once).
    pub triangles_stored: usize,
    /// Shared prototypes (two-level instancing).
    pub prototypes: usize,
    /// Instance records placing those prototypes (the outermost instances that share one).
    pub instanced: usize,
    /// Bytes the prototypes' mesh data (vertices, triangles, materials, mesh records, BVH nodes and
    /// blocks) would take once per instance, minus what instancing stores instead (one copy,
    /// instance records, the top-level BVH): an estimate of the blob bytes saved versus
    /// `ingest --flatten-instances` (prim-path strings excluded, and a BVH over all flattened
    /// triangles has somewhat different node counts; within a few percent in the tests).
    pub bytes_saved: i64,
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
    /// Materials by how the renderer shades them.
    pub material_models: MaterialModels,
    /// UsdLux lights.
    pub lights: usize,
    /// Cameras.
    pub cameras: usize,
    /// Each camera's lens, in the cameras section's order.
    pub lenses: Vec<LensSummary>,
    /// World bounds minimum, relative to `world_origin`.
    pub bounds_min: [f32; 3],
    /// World bounds maximum, relative to `world_origin`.
    pub bounds_max: [f32; 3],
    /// Where the blob's origin lies in the stage's world space (ingest stores positions
    /// camera-relative; `SceneInfo::world_origin`).
    pub world_origin: [f64; 3],
}

/// One camera's lens as the renderer builds it ([`crate::camera::Camera::from_blob`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LensSummary {
    /// Camera prim path.
    pub camera: String,
    /// `perspective` or `orthographic`.
    pub projection: &'static str,
    /// `focalLength`, tenths of a scene unit.
    pub focal_length: f32,
    /// `fStop`; 0 is a pinhole.
    pub f_stop: f32,
    /// `focusDistance`, scene units.
    pub focus_distance: f32,
    /// Radius of the aperture in scene units (`0.1 · focalLength / (2 · fStop)`); 0 for a pinhole
    /// (no depth of field: `fStop` 0, or an orthographic camera).
    pub aperture_radius: f32,
    /// Blades of a polygonal aperture, 0 for a round one.
    pub aperture_blades: u32,
    /// Rotation of the polygonal aperture, degrees.
    pub aperture_rotation: f32,
}

/// See [`LensSummary`].
fn lenses(view: &SceneView) -> Vec<LensSummary> {
    view.cameras
        .iter()
        .map(|c| {
            let lens = crate::camera::Camera::from_blob(c, 1, 1).lens().copied();
            LensSummary {
                camera: view.string(c.name).to_string(),
                projection: if c.projection == blob::PROJECTION_ORTHOGRAPHIC {
                    "orthographic"
                } else {
                    "perspective"
                },
                focal_length: c.focal_length,
                f_stop: c.f_stop,
                focus_distance: c.focus_distance,
                aperture_radius: lens.map_or(0.0, |l| l.radius),
                aperture_blades: c.aperture_blades,
                aperture_rotation: c.aperture_rotation,
            }
        })
        .collect()
}

/// Materials counted by the surface the renderer makes of them (a UsdPreviewSurface's `opacity`,
/// `opacityThreshold` and `ior`, constant or driven by its program): every look, MaterialX
/// included, is mapped onto these at ingest.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct MaterialModels {
    /// Opaque: opacity 1 and no program writing it.
    pub opaque: usize,
    /// Glass: opacity below 1 (or from a program), `opacityThreshold` 0 and `ior` ≠ 1; the
    /// `1 − opacity` part refracts.
    pub glass: usize,
    /// Cut-out: `opacityThreshold` > 0.
    pub cut_out: usize,
    /// See-through: opacity below 1 (or from a program) with `ior` 1, a hole the path passes.
    pub see_through: usize,
}

/// See [`MaterialModels`].
fn material_models(view: &SceneView) -> MaterialModels {
    let shading = crate::shading::Shading::new(view);
    let mut models = MaterialModels::default();
    for (i, m) in view.materials.iter().enumerate() {
        let inputs = crate::shading::ShadingInputs::constant(m);
        let partial = inputs.opacity < 1.0 || shading.flags(i as u32).textured_opacity;
        let count = if inputs.opacity_threshold > 0.0 {
            &mut models.cut_out
        } else if partial && inputs.refracts() {
            &mut models.glass
        } else if partial {
            &mut models.see_through
        } else {
            &mut models.opaque
        };
        *count += 1;
    }
    models
}

/// Summarizes a validated blob.
pub fn summarize(view: &SceneView) -> SceneSummary {
    SceneSummary {
        meshes: view.info.gprim_count,
        instances: view.info.instance_count,
        triangles: rendered_triangles(view),
        triangles_stored: view.triangles.len(),
        prototypes: view.instancing.prototypes.len(),
        instanced: view.instancing.instances.len(),
        bytes_saved: bytes_saved(view),
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
        material_models: material_models(view),
        lights: view.lights.len(),
        cameras: view.cameras.len(),
        lenses: lenses(view),
        bounds_min: view.info.bounds_min,
        bounds_max: view.info.bounds_max,
        world_origin: view.info.world_origin,
    }
}

/// Triangles rendered: the top-level ones plus every instance's prototype.
fn rendered_triangles(view: &SceneView) -> usize {
    let inst = &view.instancing;
    let top = inst.top_level_triangles(view.triangles.len());
    let instanced: usize =
        inst.instances.iter().map(|i| inst.prototypes[i.prototype as usize].triangle_count as usize).sum();
    top + instanced
}

/// See [`SceneSummary::bytes_saved`].
fn bytes_saved(view: &SceneView) -> i64 {
    use std::mem::size_of;
    let inst = &view.instancing;
    let vertex_bytes = size_of::<[f32; 3]>()
        + if view.normals.is_empty() { 0 } else { size_of::<[f32; 3]>() }
        + if view.uvs.is_empty() { 0 } else { size_of::<[f32; 2]>() };
    let prototype_bytes: Vec<i64> = inst
        .prototypes
        .iter()
        .map(|p| {
            let meshes = &view.meshes[p.first_mesh as usize..(p.first_mesh + p.mesh_count) as usize];
            let vertices: usize = meshes.iter().map(|m| m.vertex_count as usize).sum();
            (vertices * vertex_bytes
                + p.triangle_count as usize * (size_of::<blob::Triangle>() + size_of::<u32>())
                + std::mem::size_of_val(meshes)
                + p.node_count as usize * size_of::<blob::BvhNode>()
                + p.block_count as usize * size_of::<blob::TriangleBlock>()) as i64
        })
        .collect();
    let flattened: i64 = inst.instances.iter().map(|i| prototype_bytes[i.prototype as usize]).sum();
    let overhead = (std::mem::size_of_val(inst.prototypes)
        + std::mem::size_of_val(inst.instances)
        + std::mem::size_of_val(inst.bvh_nodes)
        + std::mem::size_of_val(inst.bvh_items)) as i64;
    flattened - prototype_bytes.iter().sum::<i64>() - overhead
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
        for key in [
            "lights",
            "cameras",
            "bounds_min",
            "bounds_max",
            "world_origin",
            "curves",
            "curve_segments",
            "points",
        ] {
            assert!(json.get(key).is_some(), "{key}");
        }
        assert_eq!((json["prototypes"].clone(), json["bytes_saved"].clone()), (0.into(), 0.into()));
        assert_eq!(json["material_models"]["opaque"], 1);
    }

    #[test]
    fn info_shows_each_cameras_lens() {
        let mut scene = testscene::instanced_spheres(1, 5);
        let mut pinhole = testscene::camera_looking_down_z(glam::Vec3::Z, 50.0);
        let mut lens = pinhole.clone();
        lens.path = "/lens".into();
        lens.lens = scene_pack::Lens {
            f_stop: 2.0,
            focus_distance: 7.5,
            aperture_blades: 6,
            aperture_rotation: 15.0,
        };
        let mut ortho = lens.clone();
        (ortho.path, ortho.orthographic) = ("/ortho".into(), true);
        pinhole.path = "/pinhole".into();
        scene.cameras = vec![pinhole, lens, ortho];
        let bytes = testscene::bytes(&scene);
        let view = SceneView::parse(&bytes).unwrap();
        let json = serde_json::to_value(summarize(&view)).unwrap();
        let lenses = json["lenses"].as_array().unwrap();
        assert_eq!(lenses.len(), 3);
        assert_eq!(
            (lenses[0]["camera"].as_str(), lenses[0]["aperture_radius"].as_f64()),
            (Some("/pinhole"), Some(0.0))
        );
        // 50 tenths of a unit at f/2: a 2.5-unit aperture, radius 1.25.
        assert_eq!(lenses[1]["aperture_radius"].as_f64(), Some(1.25));
        assert_eq!(lenses[1]["focus_distance"].as_f64(), Some(7.5));
        assert_eq!(
            (lenses[1]["aperture_blades"].as_u64(), lenses[1]["f_stop"].as_f64()),
            (Some(6), Some(2.0))
        );
        assert_eq!(
            (lenses[2]["projection"].as_str(), lenses[2]["aperture_radius"].as_f64()),
            (Some("orthographic"), Some(0.0))
        );
    }

    #[test]
    fn info_counts_materials_by_model() {
        let mut scene = testscene::instanced_spheres(2, 5);
        let lambert = testscene::lambert(0.5);
        let material = |opacity: f32, threshold: f32, ior: f32| scene_pack::Material {
            opacity,
            opacity_threshold: threshold,
            ior,
            ..lambert.clone()
        };
        scene.materials = vec![
            material(1.0, 0.0, 1.5),
            material(0.0, 0.0, 1.5),
            material(0.3, 0.0, 1.33),
            material(0.5, 0.5, 1.5),
            material(0.5, 0.0, 1.0),
        ];
        let bytes = testscene::bytes(&scene);
        let view = SceneView::parse(&bytes).unwrap();
        assert_eq!(
            summarize(&view).material_models,
            MaterialModels { opaque: 1, glass: 2, cut_out: 1, see_through: 1 }
        );
    }

    #[test]
    fn info_counts_instances_and_the_bytes_they_save() {
        let scene = testscene::instanced_spheres(30, 5);
        let bytes = testscene::bytes(&scene);
        let view = SceneView::parse(&bytes).unwrap();
        let summary = summarize(&view);
        let sphere = scene.meshes[0].triangles.len();
        assert_eq!((summary.prototypes, summary.instanced), (1, 30));
        assert_eq!(summary.triangles, scene.triangle_count(), "rendered = the flattened count");
        assert_eq!(summary.triangles_stored, sphere + 60, "one sphere plus the world-space cloud");
        let flat = scene_pack::pack::pack_scene(
            &scene,
            &scene_pack::pack::PackOptions { flatten_instances: true, ..Default::default() },
        )
        .unwrap()
        .encode();
        // An estimate: one BVH over all flattened triangles is not 30 prototype BVHs, and mesh
        // names and section padding are left out (1.2 % off when written).
        let actual = flat.len() as i64 - bytes.len() as i64;
        let error = (summary.bytes_saved - actual).abs() as f64 / actual as f64;
        assert!(error < 0.05, "estimate {} vs actual {actual}", summary.bytes_saved);
    }
}

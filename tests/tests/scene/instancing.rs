//! Two-level instancing end to end: instanceable prims and PointInstancer entries become one
//! prototype plus per-instance transforms in the blob, and render like the flattened scene.

use render::{render_image, Integrator, RenderOptions};
use scene_tests::*;
use std::path::Path;

const DOME: &str = "def DomeLight \"Dome\"\n{\n    float inputs:intensity = 1\n}\n";
const SUN: &str = "def DistantLight \"Sun\"\n{\n    float inputs:intensity = 2\n    bool inputs:normalize = true\n    float3 xformOp:rotateXYZ = (-40, 25, 0)\n    uniform token[] xformOpOrder = [\"xformOp:rotateXYZ\"]\n}\n";

/// A stage with `n` instanceable references to a sphere prototype on a 10-wide grid (rotated and
/// scaled non-uniformly so normals need the inverse transpose), seen by a camera from +Z.
fn instanced_spheres_stage(n: usize) -> String {
    let mut prims = String::new();
    for i in 0..n {
        let (x, y, z) = ((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32);
        prims.push_str(&format!(
            "def \"I{i}\" (\n    instanceable = true\n    references = </Proto>\n)\n{{\n    \
             double3 xformOp:translate = ({}, {}, {})\n    float xformOp:rotateY = {}\n    \
             float3 xformOp:scale = (1, {}, 1)\n    \
             uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateY\", \"xformOp:scale\"]\n}}\n",
            2.0 * x - 9.0,
            2.0 * y - 9.0,
            -2.0 * z,
            (i * 37 % 360) as f32,
            0.7 + 0.05 * (i % 7) as f32,
        ));
    }
    let body = [
        lambert_material("/World/Grey", 0.6),
        prims,
        camera_prim("Cam", [0.0, 0.0, 30.0], 35.0, 36.0),
        DOME.to_string(),
        SUN.to_string(),
    ]
    .join("\n");
    let proto = format!(
        "class Xform \"Proto\"\n{{\n{}}}\n",
        sphere_mesh("Ball", [0.0, 0.0, 0.0], 0.8, 12, 24, "/World/Grey")
    );
    let world = stage(&body);
    // The prototype class sits beside /World, after the layer metadata.
    let split = world.find("def Xform \"World\"").expect("stage() writes /World");
    format!("{}{proto}\n{}", &world[..split], &world[split..])
}

/// Ingests `usda`, optionally flattening instances; returns the scene and the blob bytes.
fn ingest(dir: &Path, name: &str, usda: &str, flatten: bool) -> (ingest::Scene, blob::AlignedBytes) {
    let input = write(dir, &format!("{name}.usda"), usda);
    let output = dir.join(format!("{name}.blob"));
    let pack = ingest::pack::PackOptions { flatten_instances: flatten, ..Default::default() };
    let (scene, _) =
        ingest::pipeline::ingest_file_with(&input, &output, &Default::default(), &pack).expect("ingest");
    (scene, blob::AlignedBytes::copy_from(&std::fs::read(&output).expect("read blob")))
}

#[test]
fn a_thousand_instances_store_one_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, bytes) = ingest(dir.path(), "many", &instanced_spheres_stage(1000), false);
    let (_, one) = ingest(dir.path(), "one", &instanced_spheres_stage(1), false);
    let (_, flat) = ingest(dir.path(), "flat", &instanced_spheres_stage(1000), true);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let sphere = scene.meshes[0].triangle_count();
    assert_eq!(sphere, 12 * 24 * 2, "rings × segments quads, two triangles each");
    assert_eq!(view.triangles.len(), sphere, "the sphere is stored once");
    assert_eq!(view.instancing.instances.len(), 1000);
    assert_eq!(view.instancing.prototypes.len(), 1);
    let record = std::mem::size_of::<blob::Instance>();
    assert_eq!(record, 112);
    eprintln!(
        "blob bytes: one sphere {}, 1000 instanced {}, 1000 flattened {}",
        one.len(),
        bytes.len(),
        flat.len()
    );
    // Per instance: its record, its share of the top-level BVH (8-wide nodes of 256 bytes over
    // one-instance leaves, ~5 children per node: ~50 bytes) and its name (~12 bytes).
    assert!(bytes.len() < 2 * one.len() + 1000 * (record + 64), "{} bytes", bytes.len());
    assert!(flat.len() > 20 * bytes.len(), "flattening costs far more: {} vs {}", flat.len(), bytes.len());

    let info = render::info::summarize(&view);
    assert_eq!((info.instances, info.instanced, info.prototypes), (1000, 1000, 1));
    assert_eq!((info.triangles, info.triangles_stored), (1000 * sphere, sphere));
    let actual_saving = flat.len() as f64 - bytes.len() as f64;
    assert!(
        (info.bytes_saved as f64 - actual_saving).abs() < 0.05 * actual_saving,
        "{info:?} vs {actual_saving}"
    );
    // --dump-json still lists every rendered gprim (the instance proxies) with world bounds.
    let dump = ingest::pipeline::dump_json(&scene);
    let gprims = dump["gprims"].as_array().unwrap();
    assert_eq!(gprims.len(), 1000);
    let g = gprims.iter().find(|g| g["path"] == "/World/I999/Ball").expect("instance proxy path");
    assert_eq!(g["triangles"], sphere);
    let z = g["bounds_max"][2].as_f64().unwrap();
    assert!((z - (-18.0 + 0.8)).abs() < 0.01, "bounds follow the instance transform: max z {z}");
    assert_eq!(dump["instances"], 1000);
}

fn mean_abs_diff(a: &render::Image, b: &render::Image) -> (f64, f32) {
    let (mut sum, mut max, mut n) = (0.0f64, 0.0f32, 0usize);
    for (x, y) in a.beauty.iter().flatten().zip(b.beauty.iter().flatten()) {
        let d = (x - y).abs();
        sum += d as f64;
        max = max.max(d);
        n += 1;
    }
    (sum / n as f64, max)
}

#[test]
fn instanced_render_equals_flattened_and_wavefront_equals_scalar() {
    let dir = tempfile::tempdir().unwrap();
    let usda = instanced_spheres_stage(200);
    let (_, instanced) = ingest(dir.path(), "inst", &usda, false);
    let (_, flat) = ingest(dir.path(), "flat", &usda, true);
    let options = RenderOptions {
        spp: 16,
        resolution: Some([48, 48]),
        integrator: Integrator::Scalar,
        threads: 2,
        ..RenderOptions::default()
    };
    let vi = blob::SceneView::parse(&instanced).unwrap();
    let vf = blob::SceneView::parse(&flat).unwrap();
    assert_eq!(vi.instancing.instances.len(), 200);
    assert!(vf.instancing.instances.is_empty());
    let a = render_image(&vi, &options).expect("instanced render");
    let b = render_image(&vf, &options).expect("flattened render");
    let mean_radiance =
        b.beauty.iter().flatten().map(|&v| v as f64).sum::<f64>() / (b.beauty.len() * 4) as f64;
    let (mean, max) = mean_abs_diff(&a, &b);
    let signed =
        a.beauty.iter().flatten().zip(b.beauty.iter().flatten()).map(|(x, y)| (x - y) as f64).sum::<f64>()
            / (a.beauty.len() * 4) as f64;
    // Monte Carlo noise: the flattened scene against itself with another seed.
    let c = render_image(&vf, &RenderOptions { seed: 99, ..options.clone() }).expect("reseeded render");
    let (noise, _) = mean_abs_diff(&b, &c);
    eprintln!(
        "instanced vs flattened: mean abs diff {mean:e} (signed {signed:e}), max {max:e}; noise {noise:e}; \
         mean radiance {mean_radiance}"
    );
    // Same sampler and same paths: only float rounding of the world-space geometry differs
    // (prototype vertices moved by f32 transforms instead of f64 at ingest), which flips the odd
    // path grazing a silhouette; far below the noise, and unbiased.
    assert!(mean_radiance > 0.1);
    assert!(mean < 0.1 * noise, "mean abs diff {mean} vs noise {noise}");
    assert!(signed.abs() < 1e-4 * mean_radiance, "bias {signed}");
    assert_eq!(a.depth.len(), b.depth.len());

    // The wavefront integrator traces the same two-level structure as the scalar one.
    let w = render_image(&vi, &RenderOptions { integrator: Integrator::Wavefront, ..options.clone() })
        .expect("wavefront render");
    let (mean, max) = mean_abs_diff(&a, &w);
    eprintln!("wavefront vs scalar on instances: mean {mean:e}, max {max:e}");
    assert!(max <= 1e-5, "wavefront vs scalar max abs diff {max}");
    assert_eq!(a.stats.rays, w.stats.rays);
}

/// The PointInstancer of the usd-core cross-check stage, with each prototype used at least twice so
/// both are shared: orientations (float quaternions), non-uniform scales and invisibleIds.
fn point_instancer_stage() -> String {
    let tri = |name: &str| {
        mesh_prim(
            name,
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[3],
            &[0, 1, 2],
            None,
            "/World/Grey",
        )
    };
    let boxy = open_box_mesh("Geo", "/World/Grey");
    let body = format!(
        "{}\ndef PointInstancer \"Scatter\"\n{{\n    double3 xformOp:translate = (0, 2, 0)\n    \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    \
         point3f[] positions = [(0, 0, 0), (5, 0, 0), (0, 5, 0), (0, 0, 5), (7, 7, 7), (-4, 1, 2), (3, -3, 1)]\n    \
         quatf[] orientationsf = [(1, 0, 0, 0), (0.70710677, 0, 0.70710677, 0), (0, 1, 0, 0), (0.5, 0.5, 0.5, 0.5), (1, 0, 0, 0), (0.9238795, 0.3826834, 0, 0), (0.5, -0.5, 0.5, 0.5)]\n    \
         float3[] scales = [(1, 1, 1), (2, 2, 2), (1, 0.5, 1), (1, 1, 3), (1, 1, 1), (0.5, 2, 1), (-1, 1, 1)]\n    \
         int[] protoIndices = [0, 1, 0, 1, 0, 0, 1]\n    int64[] invisibleIds = [4]\n    \
         rel prototypes = [</World/Scatter/Protos/Boxy>, </World/Scatter/Protos/Tri>]\n\n    \
         def Scope \"Protos\"\n    {{\n        def Xform \"Boxy\"\n        {{\n            \
         double3 xformOp:translate = (0.5, 0, 0)\n            uniform token[] xformOpOrder = [\"xformOp:translate\"]\n{}        }}\n{}    }}\n}}\n",
        lambert_material("/World/Grey", 0.5),
        boxy.lines().map(|l| format!("            {l}\n")).collect::<String>(),
        tri("Tri").lines().map(|l| format!("        {l}\n")).collect::<String>(),
    );
    stage(&[body, camera_prim("Cam", [0.0, 4.0, 30.0], 35.0, 36.0)].join("\n"))
}

#[test]
fn point_instancer_entries_render_where_the_flattened_gprims_are() {
    let dir = tempfile::tempdir().unwrap();
    let usda = point_instancer_stage();
    let (scene, bytes) = ingest(dir.path(), "pi", &usda, false);
    let (_, flat) = ingest(dir.path(), "pi_flat", &usda, true);
    let view = blob::SceneView::parse(&bytes).unwrap();
    // Six visible entries (id 4 is invisible): four boxes and two triangles, both prototypes shared.
    assert_eq!(scene.instance_count, 6);
    assert_eq!(view.instancing.instances.len(), 6);
    assert_eq!(view.instancing.prototypes.len(), 2);
    assert!(view.instancing.instances.iter().all(|i| view.string(i.name) != "/World/Scatter[4]"));
    // Every instance's prototype vertices, moved by its transform, are the flattened gprim's world
    // points (which the usd-core cross-check compares through --dump-json).
    let accel = render::Accel::new(&view);
    for (index, inst) in view.instancing.instances.iter().enumerate() {
        let name = view.string(inst.name);
        let proto = &view.instancing.prototypes[inst.prototype as usize];
        let mesh_record = &view.meshes[proto.first_mesh as usize];
        let suffix = view.string(mesh_record.name).rsplit('/').next().unwrap();
        let i: usize = name.trim_start_matches("/World/Scatter[").trim_end_matches(']').parse().unwrap();
        let flattened = scene
            .meshes
            .iter()
            .find(|m| {
                m.instance_index().is_some_and(|i| scene.instances[i as usize].path == name)
                    && m.path.ends_with(suffix)
            })
            .expect("flattened gprim of the entry");
        let hit = render::Hit { t: 0.0, triangle: 0, b1: 0.0, b2: 0.0, instance: index as u32, time: 0.0 };
        let stored = &view.positions[mesh_record.first_vertex as usize
            ..(mesh_record.first_vertex + mesh_record.vertex_count) as usize];
        let world_copy = flattened.in_world();
        assert_eq!(stored.len(), world_copy.positions.len());
        for (p, world) in stored.iter().zip(&world_copy.positions) {
            let q = accel.instances().to_world_point(hit.instance, 0.0, glam::Vec3::from(*p));
            assert!((q - *world).length() < 1e-5, "entry {i}: {q} vs {world}");
        }
    }
    // Rays from the camera agree with the flattened blob hit for hit.
    let flat_view = blob::SceneView::parse(&flat).unwrap();
    let flat_accel = render::Accel::new(&flat_view);
    let (mut hits, mut mismatched) = (0, 0);
    for y in 0..64 {
        for x in 0..64 {
            let target = glam::Vec3::new(-8.0 + 18.0 * x as f32 / 63.0, -4.0 + 16.0 * y as f32 / 63.0, 0.0);
            let origin = glam::Vec3::new(1.0, 4.0, 30.0);
            let dir = (target - origin).normalize();
            let a = accel.closest_hit(origin, dir, f32::INFINITY).map(|h| h.t);
            let b = flat_accel.closest_hit(origin, dir, f32::INFINITY).map(|h| h.t);
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() < 1e-4 * b, "pixel ({x}, {y}): {a} vs {b}");
                    hits += 1;
                }
                (None, None) => {}
                // A ray through a silhouette edge may round either way in either space.
                _ => mismatched += 1,
            }
        }
    }
    assert!(hits > 150 && mismatched <= 4, "{hits} hits, {mismatched} hit in only one blob");
}

/// Three instanceable references to `/Proto` (defined by `proto_body`) at x = 0, 5, 10.
fn three_instances(proto_body: &str, extra_classes: &str) -> String {
    let instances: String = (0..3)
        .map(|i| {
            format!(
                "def \"I{i}\" (\n    instanceable = true\n    references = </Proto>\n)\n{{\n    \
                 double3 xformOp:translate = ({}, 0, 0)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}}\n",
                5 * i
            )
        })
        .collect();
    let world = stage(&[lambert_material("/World/Grey", 0.5), instances].join("\n"));
    let split = world.find("def Xform \"World\"").expect("stage() writes /World");
    format!(
        "{}{extra_classes}class Xform \"Proto\"\n{{\n{proto_body}}}\n\n{}",
        &world[..split],
        &world[split..]
    )
}

#[test]
fn subdivision_surfaces_diced_alike_share_a_prototype() {
    let dir = tempfile::tempdir().unwrap();
    let cube = open_box_mesh("Cup", "/World/Grey").replace("\"none\"", "\"catmullClark\"");
    let input = write(dir.path(), "subdiv.usda", &three_instances(&cube, ""));
    let output = dir.path().join("subdiv.blob");
    let options = ingest::usd::LoadOptions {
        subdiv: ingest::dicing::SubdivOptions { forced_level: Some(2), ..Default::default() },
        ..Default::default()
    };
    let (scene, report) =
        ingest::pipeline::ingest_file_with(&input, &output, &options, &Default::default()).expect("ingest");
    assert_eq!(scene.subdivisions.len(), 3, "each instance proxy is diced");
    assert_eq!((report.prototypes, report.instances), (1, 3));
    assert_eq!(report.stored_triangles * 3, report.triangles, "one tessellation stored for three");
}

#[test]
fn nested_instances_are_expanded_inside_the_outermost_prototype() {
    let dir = tempfile::tempdir().unwrap();
    let tri = mesh_prim(
        "Tri",
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[3],
        &[0, 1, 2],
        None,
        "/World/Grey",
    );
    let inner = format!("class Xform \"Inner\"\n{{\n{tri}}}\n\n");
    // The prototype holds two instances of /Inner, one shifted up.
    let proto = "def \"A\" (\n    instanceable = true\n    references = </Inner>\n)\n{\n}\n\
                 def \"B\" (\n    instanceable = true\n    references = </Inner>\n)\n{\n    \
                 double3 xformOp:translate = (0, 2, 0)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n";
    let (scene, bytes) = ingest(dir.path(), "nested", &three_instances(proto, &inner), false);
    let view = blob::SceneView::parse(&bytes).unwrap();
    assert_eq!(scene.meshes.len(), 6, "three outer instances of two inner ones");
    assert_eq!(scene.instance_count, 9, "3 outer + 6 nested instanceable prims");
    assert_eq!(scene.instances.len(), 3, "only the outermost instances become records");
    assert_eq!((view.instancing.prototypes.len(), view.instancing.instances.len()), (1, 3));
    assert_eq!(view.triangles.len(), 2, "the prototype holds both nested triangles");
    let info = render::info::summarize(&view);
    assert_eq!(info.triangles, 6);
}

#[test]
fn instanced_gprims_keep_one_mesh_through_ingest() {
    let dir = tempfile::tempdir().unwrap();
    let input = write(dir.path(), "many.usda", &instanced_spheres_stage(300));
    let scene = ingest::usd::load(&input, &Default::default()).expect("load");
    assert_eq!(scene.meshes.len(), 300);
    let first = scene.meshes[0].placed.as_ref().expect("instance proxies are placed, not copied");
    for mesh in &scene.meshes {
        let placed = mesh.placed.as_ref().expect("placed");
        assert!(std::sync::Arc::ptr_eq(&placed.geometry, &first.geometry), "{} has its own copy", mesh.path);
        assert!(
            mesh.positions.is_empty() && mesh.triangles.is_empty(),
            "no world copy is made while loading"
        );
        // The bounds kept for the listing are those of the world copy made on demand.
        let world = mesh.in_world();
        let lo = world.positions.iter().fold(glam::Vec3::INFINITY, |a, p| a.min(*p));
        let hi = world.positions.iter().fold(glam::Vec3::NEG_INFINITY, |a, p| a.max(*p));
        assert_eq!(mesh.world_bounds(), [lo, hi]);
        assert_eq!(world.triangles.len(), mesh.triangle_count());
    }
    assert_eq!(std::sync::Arc::strong_count(&first.geometry), 300, "one geometry for 300 instances");
    // Flattening at pack time gives the world copies; the listing is the same either way.
    let pack = |flatten| {
        let options = ingest::pack::PackOptions { flatten_instances: flatten, ..Default::default() };
        ingest::pack::pack_scene(&scene, &options).expect("pack")
    };
    let (shared, flat) = (pack(false), pack(true));
    assert_eq!(shared.triangles.len(), 576);
    assert_eq!(flat.triangles.len(), 300 * 576);
    assert_eq!(shared.info.bounds_min, flat.info.bounds_min);
    assert_eq!(shared.info.bounds_max, flat.info.bounds_max);
}

/// Instanceable references to `/Proto` (defined by `proto_body`) translated to each of `places`,
/// seen by a camera at z = 10 looking down −Z.
fn instances_at(proto_body: &str, places: &[[f64; 3]]) -> String {
    let instances: String = places
        .iter()
        .enumerate()
        .map(|(i, [x, y, z])| {
            format!(
                "def \"I{i}\" (\n    instanceable = true\n    references = </Proto>\n)\n{{\n    \
                 double3 xformOp:translate = ({x}, {y}, {z})\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}}\n"
            )
        })
        .collect();
    let world = stage(
        &[lambert_material("/World/Grey", 0.5), instances, camera_prim("Cam", [0.0, 0.0, 10.0], 35.0, 36.0)]
            .join("\n"),
    );
    let split = world.find("def Xform \"World\"").expect("stage() writes /World");
    format!("{}class Xform \"Proto\"\n{{\n{proto_body}}}\n\n{}", &world[..split], &world[split..])
}

#[test]
fn subdivision_instances_at_different_distances_share_one_prototype_diced_for_the_nearest() {
    let dir = tempfile::tempdir().unwrap();
    let cup = open_box_mesh("Cup", "/World/Grey").replace("\"none\"", "\"catmullClark\"");
    let places = [[0.0, 0.0, 0.0], [3.0, 0.0, -20.0], [-6.0, 2.0, -80.0]];
    let input = write(dir.path(), "cups.usda", &instances_at(&cup, &places));
    let output = dir.path().join("cups.blob");
    let (scene, report) =
        ingest::pipeline::ingest_file(&input, &output, &Default::default()).expect("ingest");
    assert_eq!((report.prototypes, report.instances), (1, 3), "one prototype for the three cups");
    assert_eq!(report.stored_triangles * 3, report.triangles);
    assert_eq!(scene.subdivisions.len(), 3);
    let shared = &scene.subdivisions[0].edge_rates;
    assert!(scene.subdivisions.iter().all(|s| &s.edge_rates == shared));
    // Each cup diced alone, as the only instance on the stage.
    let mut finest = vec![0u32; shared.len()];
    let mut alone_totals = Vec::new();
    for (i, place) in places.iter().enumerate() {
        let input = write(dir.path(), &format!("cup{i}.usda"), &instances_at(&cup, &[*place]));
        let alone = ingest::usd::load(&input, &Default::default()).expect("load");
        let rates = &alone.subdivisions[0].edge_rates;
        assert_eq!(rates.len(), shared.len(), "same cage, same edges");
        for (e, (&need, &got)) in rates.iter().zip(shared).enumerate() {
            assert!(got >= need, "cup {i} edge {e}: shared rate {got} below its own need {need}");
        }
        finest.iter_mut().zip(rates).for_each(|(f, &r)| *f = (*f).max(r));
        alone_totals.push(rates.iter().sum::<u32>());
    }
    assert_eq!(shared, &finest, "the shared rates are the finest any instance needs, edge by edge");
    eprintln!(
        "segments per cup alone (near to far): {alone_totals:?}; shared {}",
        shared.iter().sum::<u32>()
    );
    assert!(alone_totals[0] > alone_totals[2], "distance changes the need: {alone_totals:?}");
}

#[test]
fn display_color_materials_equal_in_value_are_stored_once() {
    let dir = tempfile::tempdir().unwrap();
    // Two prototypes without a bound material: each instance proxy gets its own
    // `<gprim>.displayColor` material, equal in value within a prototype.
    let unbound = |name: &str, color: &str| {
        let tri = mesh_prim(
            name,
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[3],
            &[0, 1, 2],
            None,
            "/X",
        );
        tri.replace(
            "    rel material:binding = </X>\n",
            &format!("    color3f[] primvars:displayColor = [{color}]\n"),
        )
    };
    let red_proto = unbound("Red", "(0.8, 0.1, 0.1)");
    let blue = format!("class Xform \"BlueProto\"\n{{\n{}}}\n\n", unbound("Blue", "(0.1, 0.1, 0.8)"));
    let mut usda = instances_at(&red_proto, &(0..10).map(|i| [i as f64, 0.0, 0.0]).collect::<Vec<_>>());
    let blues: String = (0..5)
        .map(|i| format!("    def \"B{i}\" (\n        instanceable = true\n        references = </BlueProto>\n    )\n    {{\n        double3 xformOp:translate = ({i}, 3, 0)\n        uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    }}\n"))
        .collect();
    let split = usda.find("def Xform \"World\"").unwrap();
    usda.insert_str(split, &blue);
    let close = usda.rfind('}').unwrap();
    usda.insert_str(close, &blues);
    let (scene, bytes) = ingest(dir.path(), "colors", &usda, false);
    let view = blob::SceneView::parse(&bytes).unwrap();
    let display: Vec<&str> =
        scene.materials.iter().map(|m| m.path.as_str()).filter(|p| p.ends_with(".displayColor")).collect();
    assert_eq!(display.len(), 15, "one displayColor material per instance proxy: {display:?}");
    // Grey (bound by nothing but still read) may or may not be listed; the displayColor ones fold
    // into one record per colour.
    let colors: std::collections::BTreeSet<[u32; 3]> =
        view.materials.iter().map(|m| m.diffuse_color.map(f32::to_bits)).collect();
    assert_eq!(colors.len(), view.materials.len(), "no two blob materials are equal in value");
    assert!(view.materials.len() <= scene.materials.len() - 13, "{} blob materials", view.materials.len());
    assert_eq!(view.instancing.prototypes.len(), 2);
    assert_eq!(view.instancing.instances.len(), 15);
    // Every triangle still shades with its own colour.
    let (_, flat) = ingest(dir.path(), "colors_flat", &usda, true);
    let flat_view = blob::SceneView::parse(&flat).unwrap();
    for (t, &m) in flat_view.triangles.iter().zip(flat_view.triangle_materials) {
        let name = flat_view.string(flat_view.meshes[t.mesh as usize].name);
        let material = &flat_view.materials[m as usize];
        let red = material.diffuse_color[0] > material.diffuse_color[2];
        assert_eq!(red, name.ends_with("/Red"), "{name}");
    }
}

//! Subdivision surfaces through the reader: levels, limit normals, creases, corners, holes,
//! GeomSubset materials, handedness, dicing against the render camera, bad topology.

use glam::Vec3;

use super::*;
use crate::dicing::{SubdivMode, SubdivOptions};
use crate::scene::{Mesh, Scene};

/// The unit cube [0, 1]³ as a Catmull–Clark cage (the USD fallback scheme), faces wound
/// counter-clockwise seen from outside: bottom, top, y = 0, x = 1, y = 1, x = 0.
const CUBE_POINTS: [[f32; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 1.0],
];
const CUBE_INDICES: [i32; 24] = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7];

fn points_text(points: &[[f32; 3]]) -> String {
    let p: Vec<String> = points.iter().map(|p| format!("({}, {}, {})", p[0], p[1], p[2])).collect();
    p.join(", ")
}

fn ints_text(values: &[i32]) -> String {
    values.iter().map(i32::to_string).collect::<Vec<_>>().join(", ")
}

/// A cube cage Mesh prim named `name` with extra attribute lines `extra`.
fn cube_prim(name: &str, points: &[[f32; 3]], indices: &[i32], extra: &str) -> String {
    format!(
        r#"def Mesh "{name}" {{
    int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
    int[] faceVertexIndices = [{}]
    point3f[] points = [{}]
    {extra}
}}
"#,
        ints_text(indices),
        points_text(points)
    )
}

/// Loads `body` diced with `subdiv`, after checking that the plan matches the dicing (see
/// [`diced_with_its_plan`]).
fn load_with(body: &str, subdiv: SubdivOptions) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("scene.usda");
    std::fs::write(&root, format!("#usda 1.0\n\n{body}\n")).unwrap();
    diced_with_its_plan(&root, &LoadOptions { subdiv, ..LoadOptions::default() })
}

/// Loads `path` twice, diced and for a listing (planned only), and checks that the plan is what
/// dicing makes: per subdivision mesh the planned triangles and materials equal the diced
/// mesh's, the listing evaluates no surface, and both dumps are the same bytes. Returns the
/// diced scene.
fn diced_with_its_plan(path: &std::path::Path, options: &LoadOptions) -> Scene {
    let diced = load(path, options).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let listing_options = LoadOptions {
        subdiv: SubdivOptions { tessellate: false, ..options.subdiv },
        bake_textures: false,
        ..options.clone()
    };
    let listed = load(path, &listing_options).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    for s in &diced.subdivisions {
        let m = &diced.meshes[s.mesh];
        assert_eq!(s.triangles, m.triangle_count() as u64, "{}: {} planned vs diced", path.display(), m.path);
        let mut materials = m.triangle_materials.clone();
        materials.sort_unstable();
        materials.dedup();
        assert_eq!(s.materials, materials, "{}: {} materials", path.display(), m.path);
        let [lo, hi] = s.cage_world_bounds();
        let [mesh_lo, mesh_hi] = m.world_bounds();
        let slack = 1e-4 * (hi - lo).max_element().max(1.0);
        // The limit surface lies inside the cage's convex hull.
        assert!(
            mesh_lo.cmpge(lo - slack).all() && mesh_hi.cmple(hi + slack).all() || m.triangle_count() == 0,
            "{}: {} diced {mesh_lo}..{mesh_hi} outside cage {lo}..{hi}",
            path.display(),
            m.path
        );
    }
    assert!(listed.subdivisions.iter().all(|s| listed.meshes[s.mesh].triangle_count() == 0));
    let text = |scene: &Scene| serde_json::to_string_pretty(&crate::pipeline::dump_json(scene)).unwrap();
    assert_eq!(text(&listed), text(&diced), "{}: listing and diced dumps differ", path.display());
    diced
}

fn forced(level: u32) -> SubdivOptions {
    SubdivOptions { forced_level: Some(level), ..SubdivOptions::default() }
}

/// Camera dicing with one uniform level per mesh (`--subdiv-mode uniform`).
fn uniform() -> SubdivOptions {
    SubdivOptions { mode: SubdivMode::Uniform, ..SubdivOptions::default() }
}

fn mesh<'a>(scene: &'a Scene, path: &str) -> &'a Mesh {
    scene.meshes.iter().find(|m| m.path == path).unwrap_or_else(|| panic!("no mesh {path}"))
}

fn level_of(scene: &Scene, path: &str) -> u32 {
    let s = scene.subdivisions.iter().find(|s| scene.meshes[s.mesh].path == path);
    s.unwrap_or_else(|| panic!("{path} was not subdivided")).level
}

fn centroid(m: &Mesh, t: [u32; 3]) -> Vec3 {
    t.map(|i| m.positions[i as usize]).iter().sum::<Vec3>() / 3.0
}

/// Unit normals on the side the triangles face, pointing away from `centre`.
fn assert_outward(m: &Mesh, centre: Vec3) {
    assert_eq!(m.normals.len(), m.positions.len());
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!((n.length() - 1.0).abs() < 1e-4, "normal {n} is not unit");
        assert!(n.dot(*p - centre) > 0.0, "normal {n} at {p} points inwards");
    }
    for &t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let face = (b - a).cross(c - a);
        let shading: Vec3 = t.map(|i| m.normals[i as usize]).iter().sum();
        assert!(face.dot(shading) > 0.0, "triangle {t:?} winds against its normals");
        assert!(face.dot(centroid(m, t) - centre) > 0.0, "triangle {t:?} faces inwards");
    }
}

#[test]
fn cube_cage_quadruples_triangles_per_level_with_smooth_unit_normals() {
    let centre = Vec3::splat(0.5);
    for level in 0..=3u32 {
        let scene = load_with(&cube_prim("Cube", &CUBE_POINTS, &CUBE_INDICES, ""), forced(level));
        let m = mesh(&scene, "/Cube");
        assert_eq!(m.triangles.len(), 12 * 4usize.pow(level), "level {level}");
        assert_eq!(level_of(&scene, "/Cube"), level);
        assert_outward(m, centre);
        // The limit surface lies inside the cage and is rounded away from the corners (the limit
        // point of corner 0 is (1/4, 1/4, 1/4)).
        for p in &m.positions {
            assert!(p.cmpge(Vec3::splat(-1e-6)).all() && p.cmple(Vec3::splat(1.0 + 1e-6)).all(), "{p}");
            assert!((*p - Vec3::ZERO).length() > 0.1);
        }
        // Smooth: normals at shared positions agree (no faceted splits), and on the face centres
        // they are the face normals.
        let top = m
            .positions
            .iter()
            .zip(&m.normals)
            .filter(|(p, _)| (p.x - 0.5).abs() < 1e-4 && (p.y - 0.5).abs() < 1e-4);
        for (p, n) in top {
            let expected = if p.z > 0.5 { Vec3::Z } else { -Vec3::Z };
            assert!((*n - expected).length() < 1e-4, "{p} {n}");
        }
        assert!(scene.warnings.iter().all(|w| !w.message.contains("subdivi")), "{:?}", scene.warnings);
    }
}

#[test]
fn infinitely_sharp_corner_and_crease_keep_the_cage_corner() {
    // Corner 0 tagged infinitely sharp (USD: sharpness 10).
    let corner = cube_prim(
        "Corner",
        &CUBE_POINTS,
        &CUBE_INDICES,
        "int[] cornerIndices = [0]\n    float[] cornerSharpnesses = [10]",
    );
    // The three edges at corner 0 creased: a vertex with three sharp edges is a corner.
    let crease = cube_prim(
        "Crease",
        &CUBE_POINTS,
        &CUBE_INDICES,
        "int[] creaseIndices = [0, 1, 0, 3, 0, 4]\n    int[] creaseLengths = [2, 2, 2]\n    float[] creaseSharpnesses = [10, 10, 10]",
    );
    let plain = cube_prim("Plain", &CUBE_POINTS, &CUBE_INDICES, "");
    let scene = load_with(&format!("{corner}{crease}{plain}"), forced(3));
    let nearest = |path: &str| -> f32 {
        mesh(&scene, path).positions.iter().map(|p| p.length()).fold(f32::INFINITY, f32::min)
    };
    assert!(nearest("/Corner") < 1e-5, "corner: nearest vertex {} from the cage corner", nearest("/Corner"));
    assert!(nearest("/Crease") < 1e-5, "crease: nearest vertex {} from the cage corner", nearest("/Crease"));
    // A smooth corner is rounded off to its limit point (1/4, 1/4, 1/4).
    assert!((nearest("/Plain") - 0.75f32.sqrt() / 2.0).abs() < 1e-5, "{}", nearest("/Plain"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

#[test]
fn holes_leave_no_faces() {
    let body = cube_prim("Holey", &CUBE_POINTS, &CUBE_INDICES, "int[] holeIndices = [1]");
    for level in 0..=2u32 {
        let scene = load_with(&body, forced(level));
        let m = mesh(&scene, "/Holey");
        assert_eq!(m.triangles.len(), 10 * 4usize.pow(level));
        // Nothing covers the middle of the top face (z = 1).
        for &t in &m.triangles {
            let c = centroid(m, t);
            assert!(!(c.z > 0.8 && (c.x - 0.5).abs() < 0.2 && (c.y - 0.5).abs() < 0.2), "{c}");
        }
    }
}

#[test]
fn geom_subset_materials_follow_the_cage_faces() {
    let subset = r#"rel material:binding = </Looks/Blue>
    def GeomSubset "Top" (prepend apiSchemas = ["MaterialBindingAPI"]) {
        uniform token elementType = "face"
        uniform token familyName = "materialBind"
        int[] indices = [1]
        rel material:binding = </Looks/Red>
    }"#;
    let looks = r#"def Scope "Looks" {
    def Material "Red" {
        token outputs:surface.connect = </Looks/Red/Surface.outputs:surface>
        def Shader "Surface" {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            token outputs:surface
        }
    }
    def Material "Blue" {
        token outputs:surface.connect = </Looks/Blue/Surface.outputs:surface>
        def Shader "Surface" {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0, 0, 1)
            token outputs:surface
        }
    }
}
"#;
    let body = format!("{looks}{}", cube_prim("Cube", &CUBE_POINTS, &CUBE_INDICES, subset));
    let scene = load_with(&body, forced(2));
    let m = mesh(&scene, "/Cube");
    let index = |path: &str| scene.materials.iter().position(|x| x.path == path).unwrap() as u32;
    let (red, blue) = (index("/Looks/Red"), index("/Looks/Blue"));
    assert_eq!(m.triangle_materials.iter().filter(|&&x| x == blue).count(), 10 * 16);
    let reds: Vec<_> = m.triangles.iter().zip(&m.triangle_materials).filter(|(_, &mat)| mat == red).collect();
    assert_eq!(reds.len(), 2 * 16);
    for (&t, _) in reds {
        assert!(centroid(m, t).z > 0.7, "red triangle at {}", centroid(m, t));
    }
    assert_eq!(m.triangle_materials.len(), m.triangles.len());
}

#[test]
fn left_handed_normals_point_outwards_like_the_right_handed_mirror() {
    // An irregular cage (one corner pulled out) and its mirror image in x: mirroring reverses
    // the winding, which `orientation = "leftHanded"` declares.
    let mut points = CUBE_POINTS;
    points[6] = [1.4, 1.3, 1.2];
    let mirrored: Vec<[f32; 3]> = points.iter().map(|p| [-p[0], p[1], p[2]]).collect();
    let rh = cube_prim("Right", &points, &CUBE_INDICES, "");
    let lh = cube_prim("Left", &mirrored, &CUBE_INDICES, "uniform token orientation = \"leftHanded\"");
    let scene = load_with(&format!("{rh}{lh}"), forced(2));
    let (r, l) = (mesh(&scene, "/Right"), mesh(&scene, "/Left"));
    assert_eq!(r.triangles.len(), l.triangles.len());
    assert_outward(r, Vec3::splat(0.5));
    assert_outward(l, Vec3::new(-0.5, 0.5, 0.5));
    // Every left-handed vertex is the mirror of a right-handed one, with the mirrored normal.
    let flip = Vec3::new(-1.0, 1.0, 1.0);
    for (p, n) in l.positions.iter().zip(&l.normals) {
        let i = (0..r.positions.len())
            .min_by(|&a, &b| {
                (r.positions[a] * flip).distance(*p).total_cmp(&(r.positions[b] * flip).distance(*p))
            })
            .unwrap();
        assert!((r.positions[i] * flip).distance(*p) < 1e-5, "{p} has no mirror");
        assert!((r.normals[i] * flip).distance(*n) < 1e-4, "{p}: {n} vs mirrored {}", r.normals[i] * flip);
    }
}

/// A camera at the origin looking down −Z, 1000 × 1000 px with a 1000 px focal length (so a
/// unit length d units away is 1000/d px); its view is |x|, |y| ≤ z/2.
const CAMERA_1000: &str = r#"def Camera "Cam" {
    float focalLength = 36
    float horizontalAperture = 36
    float verticalAperture = 36
    float2 clippingRange = (0.1, 10000)
}
def Scope "Render" {
    def RenderSettings "Settings" {
        rel camera = </Cam>
        uniform int2 resolution = (1000, 1000)
    }
}
"#;

#[test]
fn dicing_follows_distance_frustum_and_cap() {
    // The same unit cube 4, 49 and 1999 units in front of CAMERA_1000, and one behind it.
    let camera = CAMERA_1000;
    let placed = |name: &str, z: f32| {
        let points: Vec<[f32; 3]> = CUBE_POINTS.iter().map(|p| [p[0] - 0.5, p[1] - 0.5, p[2] + z]).collect();
        cube_prim(name, &points, &CUBE_INDICES, "")
    };
    let body = format!(
        "{camera}{}{}{}{}",
        placed("Near", -5.0),
        placed("Mid", -50.0),
        placed("Far", -2000.0),
        placed("Behind", 20.0)
    );
    let scene = load_with(&body, uniform());
    let level = |p: &str| level_of(&scene, p);
    // Longest edge 1 at distance 4: 1000/4 = 250 px → level 8, capped at 5; at 49: 20.4 px → 5;
    // at 1999: 0.5 px → 0.
    assert_eq!((level("/Near"), level("/Mid"), level("/Far")), (5, 5, 0));
    assert!(level("/Behind") <= 1);
    let coarse = load_with(&body, SubdivOptions { dicing_rate: 8.0, ..uniform() });
    let coarse_level = |p: &str| level_of(&coarse, p);
    // 250/8 → 5; 20.4/8 → 2; 0.5/8 → 0.
    assert_eq!((coarse_level("/Near"), coarse_level("/Mid"), coarse_level("/Far")), (5, 2, 0));
    let capped = load_with(&body, SubdivOptions { max_level: 3, ..uniform() });
    assert!(capped.subdivisions.iter().all(|s| s.level <= 3));
    assert_eq!(level_of(&capped, "/Near"), 3);
    // The listing: the saving against level 3 everywhere.
    let dump = crate::pipeline::dump_json(&capped);
    let fixed = 4 * 12 * 64;
    assert_eq!(dump["triangles_at_fixed_level"], fixed);
    assert_eq!(dump["triangles"], capped.triangle_count());
    assert_eq!(dump["triangles_saved"], fixed - capped.triangle_count() as i64);
    let near = dump["gprims"].as_array().unwrap().iter().find(|g| g["path"] == "/Near").unwrap();
    assert_eq!(near["subdiv_level"], 3);
    assert_eq!(near["scheme"], "catmullClark");
    assert_eq!(near["subdiv_mode"], "uniform");
    assert!(near.get("max_edge_rate").is_none());
}

#[test]
fn no_camera_dices_for_the_framing_camera_within_the_pixel_budget() {
    // `render` frames the unit cube 1.88 units from its front face with a 618 px focal length
    // (512 px, 45°): a 329 px edge, level 9, capped at 5.
    let body = cube_prim("Cube", &CUBE_POINTS, &CUBE_INDICES, "");
    let scene = load_with(&body, uniform());
    assert_eq!(level_of(&scene, "/Cube"), 5);
    assert_eq!(mesh(&scene, "/Cube").triangles.len(), 12 * 1024);
    // At 64 px the edge wants level 3, but 2·512²/64² = 128 triangles only pay for level 1.
    let scene = load_with(&body, SubdivOptions { dicing_rate: 64.0, ..uniform() });
    assert_eq!(level_of(&scene, "/Cube"), 1);
}

#[test]
fn bad_topology_warns_once_and_renders_the_cage() {
    let mut indices = CUBE_INDICES;
    indices[5] = 12;
    let out_of_range = cube_prim("OutOfRange", &CUBE_POINTS, &indices, "");
    let bad_crease = cube_prim(
        "BadCrease",
        &CUBE_POINTS,
        &CUBE_INDICES,
        "int[] creaseIndices = [0, 6]\n    int[] creaseLengths = [2]\n    float[] creaseSharpnesses = [10]",
    );
    let scene = load_with(&format!("{out_of_range}{bad_crease}"), SubdivOptions::default());
    let warnings = |prim: &str| -> Vec<&str> {
        scene.warnings.iter().filter(|w| w.prim == prim).map(|w| w.message.as_str()).collect()
    };
    let w = warnings("/OutOfRange");
    assert_eq!(w.len(), 2, "{w:?}");
    assert_eq!(
        w[0],
        "cannot subdivide: faceVertexIndices[5] = 12 is outside 0..8; rendering the triangulated cage instead"
    );
    assert_eq!(w[1], "1 faces with a point index out of range skipped");
    // The cage less the face with the bad index, flat (no normals).
    let m = mesh(&scene, "/OutOfRange");
    assert_eq!(m.triangles.len(), 10);
    assert!(m.normals.is_empty());
    let w = warnings("/BadCrease");
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].starts_with("cannot subdivide: creaseIndices: crease 0 runs along 0–6"), "{}", w[0]);
    assert_eq!(mesh(&scene, "/BadCrease").triangles.len(), 12);
    assert!(scene.subdivisions.is_empty());
}

#[test]
fn face_varying_and_vertex_uvs_are_refined() {
    // Face-varying st with one UV island per face (every cage edge a seam), and vertex st.
    let fv: Vec<String> = (0..6)
        .flat_map(|f| {
            let u = f as f32;
            [(u, 0.0), (u + 1.0, 0.0), (u + 1.0, 1.0), (u, 1.0)].map(|(a, b)| format!("({a}, {b})"))
        })
        .collect();
    let face_varying =
        format!("texCoord2f[] primvars:st = [{}] (interpolation = \"faceVarying\")", fv.join(", "));
    let vertex_st: Vec<String> = CUBE_POINTS.iter().map(|p| format!("({}, {})", p[0], p[1])).collect();
    let vertex =
        format!("texCoord2f[] primvars:st = [{}] (interpolation = \"vertex\")", vertex_st.join(", "));
    let body = format!(
        "{}{}",
        cube_prim("FaceVarying", &CUBE_POINTS, &CUBE_INDICES, &face_varying),
        cube_prim("Vertex", &CUBE_POINTS, &CUBE_INDICES, &vertex)
    );
    let scene = load_with(&body, forced(2));
    let m = mesh(&scene, "/FaceVarying");
    assert_eq!(m.uvs.len(), m.positions.len());
    // Seams split vertices: every face has its own (4 + 1)² grid of vertices at level 2.
    assert_eq!(m.positions.len(), 6 * 25);
    for &t in &m.triangles {
        // A triangle's UVs stay in its face's island.
        let island = (t.map(|i| m.uvs[i as usize].x).iter().sum::<f32>() / 3.0).floor();
        for i in t {
            let uv = m.uvs[i as usize];
            assert!(
                uv.x >= island - 1e-5 && uv.x <= island + 1.0 + 1e-5 && (0.0..=1.0).contains(&uv.y),
                "{uv}"
            );
        }
    }
    let m = mesh(&scene, "/Vertex");
    assert_eq!(m.uvs.len(), m.positions.len());
    assert_eq!(m.positions.len(), 6 * 16 + 2);
    assert!(m.uvs.iter().all(|uv| (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y)));
}

/// A flat grid Mesh prim of `nx × ny` unit quads with corners `corner(i, j)`.
fn grid_prim(name: &str, nx: usize, ny: usize, corner: impl Fn(usize, usize) -> [f32; 3]) -> String {
    let points: Vec<[f32; 3]> =
        (0..=ny).flat_map(|j| (0..=nx).map(move |i| (i, j))).map(|(i, j)| corner(i, j)).collect();
    let mut indices = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let v = (j * (nx + 1) + i) as i32;
            let w = v + nx as i32 + 1;
            indices.extend([v, v + 1, w + 1, w]);
        }
    }
    format!(
        r#"def Mesh "{name}" {{
    int[] faceVertexCounts = [{}]
    int[] faceVertexIndices = [{}]
    point3f[] points = [{}]
}}
"#,
        vec!["4"; nx * ny].join(", "),
        ints_text(&indices),
        points_text(&points)
    )
}

/// A triangle edge allowed by a 2 px dicing rate: the diagonal of a 2 × 2 px cell (plus f32
/// rounding of the positions).
const DIAGONAL_2PX: f32 = 2.0 * std::f32::consts::SQRT_2 * 1.0001;

/// Longest triangle edge of `m` on screen for CAMERA_1000, in pixels.
fn longest_projected_edge(m: &Mesh) -> f32 {
    let raster = |p: Vec3| glam::Vec2::new(p.x, p.y) * (1000.0 / -p.z);
    m.triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .map(|(a, b)| raster(m.positions[a as usize]).distance(raster(m.positions[b as usize])))
        .fold(0.0, f32::max)
}

fn dump_entry(scene: &Scene, path: &str) -> serde_json::Value {
    let dump = crate::pipeline::dump_json(scene);
    dump["gprims"].as_array().unwrap().iter().find(|g| g["path"] == path).unwrap().clone()
}

#[test]
fn adaptive_dicing_gives_a_receding_plane_fewer_triangles_at_the_same_pixel_size() {
    // A floor strip 1 unit wide at y = −0.5, from 10 to 50 units in front of the camera, at 2 px.
    // Its nearest cross edge is 1000/10 = 100 px → 50 segments (uniform: level ⌈log2 50⌉ = 6,
    // 40·2·4⁶ triangles); its farthest is 1000/50 = 20 px → 10 segments.
    let body = format!(
        "{CAMERA_1000}{}",
        grid_prim("Floor", 1, 40, |i, j| [i as f32 - 0.5, -0.5, -10.0 - j as f32])
    );
    let options = SubdivOptions { dicing_rate: 2.0, max_level: 6, ..SubdivOptions::default() };
    let adaptive = load_with(&body, options);
    let uniform = load_with(&body, SubdivOptions { mode: SubdivMode::Uniform, ..options });
    let (a, u) = (mesh(&adaptive, "/Floor"), mesh(&uniform, "/Floor"));
    assert_eq!(u.triangles.len(), 40 * 2 * 4096);
    let entry = dump_entry(&adaptive, "/Floor");
    assert_eq!(entry["subdiv_mode"], "adaptive");
    assert_eq!((entry["min_edge_rate"].as_u64(), entry["max_edge_rate"].as_u64()), (Some(10), Some(50)));
    assert_eq!(entry["subdiv_level"], 6);
    assert_eq!(entry["triangles"], a.triangles.len());
    // Both keep every edge within the 2 px rate (a triangle's diagonal within 2√2 px) …
    let (la, lu) = (longest_projected_edge(a), longest_projected_edge(u));
    assert!(la <= DIAGONAL_2PX && lu <= DIAGONAL_2PX, "adaptive {la} px, uniform {lu} px");
    // … with far fewer triangles where the floor recedes: Σ 2·(50·10/d)² over d = 10…49 ≈ 43 k.
    assert!(a.triangles.len() < u.triangles.len() / 6, "{} vs {}", a.triangles.len(), u.triangles.len());
    assert!(a.triangles.len() > 35_000, "{}", a.triangles.len());
    assert!(adaptive.warnings.is_empty(), "{:?}", adaptive.warnings);
}

#[test]
fn adaptive_dicing_coarsens_faces_off_screen() {
    // A wall of 12 unit quads facing the camera 10 units away, x from 0 to 12: the view ends at
    // x = 5. At 2 px its edges are 100 px → 50 segments on screen; faces wholly outside the view
    // (grown by half their size: faces 7…11) keep 2 segments per edge, 8 triangles each.
    let body = format!("{CAMERA_1000}{}", grid_prim("Wall", 12, 1, |i, j| [i as f32, j as f32 - 0.5, -10.0]));
    let options = SubdivOptions { dicing_rate: 2.0, max_level: 6, ..SubdivOptions::default() };
    let adaptive = load_with(&body, options);
    let uniform = load_with(&body, SubdivOptions { mode: SubdivMode::Uniform, ..options });
    let (a, u) = (mesh(&adaptive, "/Wall"), mesh(&uniform, "/Wall"));
    assert_eq!(u.triangles.len(), 12 * 2 * 4096);
    let off_screen = |m: &Mesh| m.triangles.iter().filter(|&&t| centroid(m, t).x > 8.0).count();
    assert_eq!(off_screen(a), 4 * 8, "faces 8…11");
    assert_eq!(off_screen(u), 4 * 2 * 4096);
    let entry = dump_entry(&adaptive, "/Wall");
    assert_eq!((entry["min_edge_rate"].as_u64(), entry["max_edge_rate"].as_u64()), (Some(2), Some(50)));
    // On screen the same pixel size: every edge with both ends in view stays within 2√2 px.
    let in_view = |p: Vec3| p.x <= 5.0;
    let visible = Mesh {
        triangles: a
            .triangles
            .iter()
            .copied()
            .filter(|t| t.iter().all(|&i| in_view(a.positions[i as usize])))
            .collect(),
        ..a.clone()
    };
    let lv = longest_projected_edge(&visible);
    assert!(lv <= DIAGONAL_2PX, "{lv} px; rates {:?}", adaptive.subdivisions[0].edge_rates);
    // The visible half costs what it did, the hidden half almost nothing: ≈ 6 · 2 · 50² + 200.
    assert!(a.triangles.len() < u.triangles.len() / 3, "{} vs {}", a.triangles.len(), u.triangles.len());
}

#[test]
fn adaptive_framing_camera_matches_uniform_when_every_edge_is_capped() {
    // The framing camera of the uniform test: every cube edge is ≥ 200 px, so all 12 edges take
    // the cap of 2⁵ segments, exactly level 5's triangles.
    let body = cube_prim("Cube", &CUBE_POINTS, &CUBE_INDICES, "");
    let scene = load_with(&body, SubdivOptions::default());
    assert_eq!(level_of(&scene, "/Cube"), 5);
    assert_eq!(mesh(&scene, "/Cube").triangles.len(), 12 * 1024);
    let entry = dump_entry(&scene, "/Cube");
    assert_eq!((entry["min_edge_rate"].as_u64(), entry["max_edge_rate"].as_u64()), (Some(32), Some(32)));
    assert_outward(mesh(&scene, "/Cube"), Vec3::splat(0.5));
    // At 64 px the 2·512²/64² = 128 triangle budget holds per edge too.
    let scene = load_with(&body, SubdivOptions { dicing_rate: 64.0, ..SubdivOptions::default() });
    let m = mesh(&scene, "/Cube");
    assert!(m.triangles.len() <= 128 && m.triangles.len() > 12 * 4, "{}", m.triangles.len());
}

#[test]
fn adaptive_tessellation_keeps_corners_creases_holes_seams_and_closes_the_surface() {
    let corner = cube_prim(
        "Corner",
        &CUBE_POINTS,
        &CUBE_INDICES,
        "int[] cornerIndices = [0]\n    float[] cornerSharpnesses = [10]",
    );
    let crease = cube_prim(
        "Crease",
        &CUBE_POINTS,
        &CUBE_INDICES,
        "int[] creaseIndices = [0, 1, 0, 3, 0, 4]\n    int[] creaseLengths = [2, 2, 2]\n    float[] creaseSharpnesses = [10, 10, 10]",
    );
    let holey = cube_prim("Holey", &CUBE_POINTS, &CUBE_INDICES, "int[] holeIndices = [1]");
    let fv: Vec<String> = (0..6)
        .flat_map(|f| {
            let u = f as f32;
            [(u, 0.0), (u + 1.0, 0.0), (u + 1.0, 1.0), (u, 1.0)].map(|(a, b)| format!("({a}, {b})"))
        })
        .collect();
    let seams = cube_prim(
        "Seams",
        &CUBE_POINTS,
        &CUBE_INDICES,
        &format!("texCoord2f[] primvars:st = [{}] (interpolation = \"faceVarying\")", fv.join(", ")),
    );
    // Dice coarsely so that edges get different rates around the framing camera.
    let options = SubdivOptions { dicing_rate: 24.0, ..SubdivOptions::default() };
    let scene = load_with(&format!("{corner}{crease}{holey}{seams}"), options);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let nearest = |path: &str| -> f32 {
        mesh(&scene, path).positions.iter().map(|p| p.length()).fold(f32::INFINITY, f32::min)
    };
    assert!(nearest("/Corner") < 1e-5, "corner: nearest vertex {}", nearest("/Corner"));
    assert!(nearest("/Crease") < 1e-5, "crease: nearest vertex {}", nearest("/Crease"));
    let m = mesh(&scene, "/Holey");
    for &t in &m.triangles {
        let c = centroid(m, t);
        assert!(!(c.z > 0.8 && (c.x - 0.5).abs() < 0.2 && (c.y - 0.5).abs() < 0.2), "{c}");
    }
    // Seams: triangles keep to their face's UV island, and the surface is closed by position.
    let m = mesh(&scene, "/Seams");
    let entry = dump_entry(&scene, "/Seams");
    assert!(entry["min_edge_rate"].as_u64() < entry["max_edge_rate"].as_u64(), "{entry}");
    for &t in &m.triangles {
        let island = (t.map(|i| m.uvs[i as usize].x).iter().sum::<f32>() / 3.0).floor();
        for i in t {
            let uv = m.uvs[i as usize];
            assert!(
                uv.x >= island - 1e-5 && uv.x <= island + 1.0 + 1e-5 && (0.0..=1.0).contains(&uv.y),
                "{uv}"
            );
        }
    }
    let key = |i: u32| m.positions[i as usize].to_array().map(f32::to_bits);
    let mut uses = std::collections::HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    assert!(uses.values().all(|&n| n == 2), "an edge of the closed cube is not shared by two triangles");
}

/// Catmull–Clark refinement is affine-invariant, so a vertex primvar equal to the cage points refines to
/// the limit points themselves: in both dicing modes every tessellated vertex must carry its own
/// position as the value (the adaptive path evaluates primvars in separate passes that must line up).
#[test]
fn vertex_primvars_refine_like_the_points_in_both_modes() {
    let colors = points_text(&CUBE_POINTS);
    let body = cube_prim(
        "Cube",
        &CUBE_POINTS,
        &CUBE_INDICES,
        &format!("color3f[] primvars:displayColor = [{colors}] (interpolation = \"vertex\")"),
    );
    let camera = r#"def Camera "Cam" { double3 xformOp:translate = (0.5, 0.5, 4)
        uniform token[] xformOpOrder = ["xformOp:translate"] }"#;
    for options in [SubdivOptions::default(), uniform(), forced(2)] {
        let scene = load_with(&format!("{body}\n{camera}"), options);
        let m = mesh(&scene, "/Cube");
        let p = m.primvars.iter().find(|p| p.name == "displayColor").expect("displayColor stored");
        assert_eq!(p.layout, crate::scene::PrimvarLayout::PerVertex, "{options:?}");
        assert_eq!(p.values.len(), m.positions.len(), "{options:?}");
        let worst = p
            .values
            .iter()
            .zip(&m.positions)
            .map(|(v, x)| (Vec3::new(v[0], v[1], v[2]) - *x).abs().max_element())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "{options:?}: primvar strays {worst} from the limit point");
        assert!(m.triangles.len() > 12, "{options:?}: the cube was refined");
    }
}

/// Every subdivision mesh of the shared assets that carry subdivision test cases (OpenUSD's
/// subdivision tests, the usd-wg pyramids) and of the three largest assets, at the default
/// (adaptive) dicing and uniform: planned == diced. Skipped, with a note, without the library.
#[test]
fn shared_subdivision_assets_dice_as_planned() {
    let assets = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/assets");
    if !assets.is_dir() {
        eprintln!("skipped: no shared asset library at {}", assets.display());
        return;
    }
    let mut files: Vec<std::path::PathBuf> = Vec::new();
    for dir in ["openusd_subdiv", "subdiv_pyramids/full_assets/SubdivisionSurfaces"] {
        let mut stack = vec![assets.join(dir)];
        while let Some(d) = stack.pop() {
            for entry in std::fs::read_dir(&d).unwrap().map(Result::unwrap) {
                let p = entry.path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|e| e.to_str().is_some_and(|e| e.starts_with("usd"))) {
                    files.push(p);
                }
            }
        }
    }
    files.sort();
    files.extend(
        [
            "open_chess_set/full_assets/OpenChessSet/chess_set.usda",
            "standard_shader_ball/full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
            "teapot/full_assets/Teapot/DrawModes.usd",
        ]
        .map(|f| assets.join(f)),
    );
    let mut meshes = 0;
    for file in &files {
        let options = LoadOptions { lenient: true, ..LoadOptions::default() };
        if load(file, &options).is_err() {
            continue; // layers that are not stages on their own (e.g. a payload's material layer)
        }
        meshes += diced_with_its_plan(file, &options).subdivisions.len();
        if file.metadata().unwrap().len() < 1 << 20 {
            let uniform = LoadOptions { subdiv: uniform(), ..options.clone() };
            meshes += diced_with_its_plan(file, &uniform).subdivisions.len();
        }
    }
    assert!(meshes > 100, "{meshes} subdivision meshes checked");
}

#[test]
fn copies_of_one_cage_share_a_refiner_but_not_their_rates() {
    // Two identical grids (not instances) at 10 and 40 units: one topology, so one refiner, but
    // each is diced for its own distance, in both modes.
    let grid = |name: &str, z: f32| {
        grid_prim(name, 4, 4, move |i, j| [i as f32 * 0.5 - 1.0, j as f32 * 0.5 - 1.0, z])
    };
    let body = format!("{CAMERA_1000}{}{}", grid("Near", -10.0), grid("Far", -40.0));
    for mode in [SubdivMode::Adaptive, SubdivMode::Uniform] {
        let options = SubdivOptions { dicing_rate: 4.0, max_level: 6, mode, ..SubdivOptions::default() };
        let scene = load_with(&body, options);
        let (near, far) = (mesh(&scene, "/Near").triangle_count(), mesh(&scene, "/Far").triangle_count());
        assert!(near > far && far > 0, "{mode:?}: near {near}, far {far}");
        assert_eq!(dump_entry(&scene, "/Near")["triangles"], near);
        assert_eq!(dump_entry(&scene, "/Far")["triangles"], far);
    }
}

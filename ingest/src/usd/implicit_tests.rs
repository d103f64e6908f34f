//! Implicit surfaces through the reader: fallbacks, axes, transforms, bindings, visibility and
//! purpose, doubleSided, refused values (expectations from the UsdGeom schema, cross-checked
//! against usd-core's extents in tests/python).

use std::path::PathBuf;

use glam::Vec3;

use super::*;
use crate::scene::{Mesh, Scene};

fn load_text(text: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let root: PathBuf = dir.path().join("scene.usda");
    std::fs::write(&root, format!("#usda 1.0\n\n{text}\n")).unwrap();
    load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn mesh<'a>(scene: &'a Scene, path: &str) -> &'a Mesh {
    scene.meshes.iter().find(|m| m.path == path).unwrap_or_else(|| {
        panic!("no mesh {path}; have {:?}", scene.meshes.iter().map(|m| &m.path).collect::<Vec<_>>())
    })
}

fn bounds(m: &Mesh) -> (Vec3, Vec3) {
    let lo = m.positions.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
    let hi = m.positions.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
    (lo, hi)
}

/// Bounds within `tol` of the analytic box.
fn assert_bounds(scene: &Scene, path: &str, lo: [f32; 3], hi: [f32; 3], tol: f32) {
    let (l, h) = bounds(mesh(scene, path));
    let ok =
        (l - Vec3::from(lo)).abs().max_element() <= tol && (h - Vec3::from(hi)).abs().max_element() <= tol;
    assert!(ok, "{path}: bounds {l}..{h}, expected {lo:?}..{hi:?}");
}

#[test]
fn every_shape_draws_with_its_schema_fallbacks() {
    let scene = load_text(
        r#"def Cube "Cube" {}
def Sphere "Sphere" {}
def Cylinder "Cylinder" {}
def Cone "Cone" {}
def Capsule "Capsule" {}
def Plane "Plane" {}"#,
    );
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let count = |p: &str| mesh(&scene, p).triangles.len();
    assert_eq!(
        [
            count("/Cube"),
            count("/Sphere"),
            count("/Cylinder"),
            count("/Cone"),
            count("/Capsule"),
            count("/Plane")
        ],
        [12, 960, 128, 64, 1024, 2]
    );
    // usd-core's extents: every shape ±1, except the Capsule (±0.5 across, ±1 along Z) and the
    // flat Plane. The round shapes' rings lie on ±X and ±Y at segments 0, 8, 16, 24 of 32.
    let t = 1e-6;
    assert_bounds(&scene, "/Cube", [-1.0; 3], [1.0; 3], t);
    assert_bounds(&scene, "/Sphere", [-1.0; 3], [1.0; 3], t);
    assert_bounds(&scene, "/Cylinder", [-1.0; 3], [1.0; 3], t);
    assert_bounds(&scene, "/Cone", [-1.0; 3], [1.0; 3], t);
    assert_bounds(&scene, "/Capsule", [-0.5, -0.5, -1.0], [0.5, 0.5, 1.0], t);
    assert_bounds(&scene, "/Plane", [-1.0, -1.0, 0.0], [1.0, 1.0, 0.0], t);
    // Plane is the one gprim double-sided by default.
    let sided: Vec<bool> = scene.meshes.iter().map(|m| m.double_sided).collect();
    assert_eq!(sided, [false, false, false, false, false, true]);
}

#[test]
fn authored_sizes_and_axes() {
    let scene = load_text(
        r#"def Sphere "Ball" { double radius = 2 }
def Cube "Box" { double size = 0.5 }
def Cylinder "Log" { double radius = 0.25
    double height = 3
    uniform token axis = "X" }
def Cone "Spike" { double radius = 0.5
    double height = 4
    uniform token axis = "Y" }
def Capsule "Pill" { double radius = 1
    double height = 2
    uniform token axis = "X" }
def Plane "Floor" { double width = 4
    double length = 6
    uniform token axis = "Y"
    uniform bool doubleSided = 0 }"#,
    );
    let t = 1e-5;
    assert_bounds(&scene, "/Ball", [-2.0; 3], [2.0; 3], t);
    assert_bounds(&scene, "/Box", [-0.25; 3], [0.25; 3], t);
    assert_bounds(&scene, "/Log", [-1.5, -0.25, -0.25], [1.5, 0.25, 0.25], t);
    assert_bounds(&scene, "/Spike", [-0.5, -2.0, -0.5], [0.5, 2.0, 0.5], t);
    assert_bounds(&scene, "/Pill", [-2.0, -1.0, -1.0], [2.0, 1.0, 1.0], t);
    // UsdGeomPlane, axis Y: width along X, length along Z.
    assert_bounds(&scene, "/Floor", [-2.0, 0.0, -3.0], [2.0, 0.0, 3.0], t);
    assert!(!mesh(&scene, "/Floor").double_sided, "doubleSided as authored");
    // The cone's apex points to +axis.
    let spike = mesh(&scene, "/Spike");
    let top = spike.positions.iter().filter(|p| p.y > 1.999).collect::<Vec<_>>();
    assert!(!top.is_empty() && top.iter().all(|p| p.x.abs() < 1e-6 && p.z.abs() < 1e-6), "{top:?}");
    // The sphere's tessellated area is within 1 % of 4πr².
    let ball = mesh(&scene, "/Ball");
    let area: f32 = ball
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| ball.positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let exact = 4.0 * std::f32::consts::PI * 4.0;
    assert!((area / exact - 1.0).abs() < 0.01, "area {area} vs {exact}");
}

#[test]
fn transforms_bindings_visibility_and_purpose() {
    let scene = load_text(
        r#"def Scope "Looks" {
    def Material "Red" {
        token outputs:surface.connect = </Looks/Red/Surface.outputs:surface>
        def Shader "Surface" {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            token outputs:surface
        }
    }
}
def Xform "World" {
    double3 xformOp:translate = (10, 0, 0)
    double3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
    def Cylinder "Bound" (prepend apiSchemas = ["MaterialBindingAPI"]) {
        uniform token axis = "X"
        rel material:binding = </Looks/Red>
    }
    def Cone "Tinted" {
        color3f[] primvars:displayColor = [(0, 0.5, 1)]
        float[] primvars:displayOpacity = [0.25]
    }
    def Capsule "Hidden" { token visibility = "invisible" }
    def Plane "Guide" { uniform token purpose = "guide" }
    def Xform "Proxy" {
        uniform token purpose = "proxy"
        def Sphere "Inner" {}
    }
}"#,
    );
    let paths: Vec<&str> = scene.meshes.iter().map(|m| m.path.as_str()).collect();
    assert_eq!(paths, ["/World/Bound", "/World/Tinted"], "invisible and guide/proxy shapes are not drawn");
    // Height 2 along X, scaled by 2 and moved by 10 along X.
    assert_bounds(&scene, "/World/Bound", [8.0, -2.0, -2.0], [12.0, 2.0, 2.0], 1e-5);
    let material = |p: &str| &scene.materials[mesh(&scene, p).triangle_materials[0] as usize];
    assert_eq!(material("/World/Bound").path, "/Looks/Red");
    assert_eq!(material("/World/Bound").diffuse_color, Vec3::new(1.0, 0.0, 0.0));
    assert!(mesh(&scene, "/World/Bound")
        .triangle_materials
        .iter()
        .all(|&m| m == mesh(&scene, "/World/Bound").triangle_materials[0]));
    assert_eq!(material("/World/Tinted").path, "/World/Tinted.displayColor");
    assert_eq!(material("/World/Tinted").diffuse_color, Vec3::new(0.0, 0.5, 1.0));
    assert_eq!(material("/World/Tinted").opacity, 0.25);
    // World-space normals follow the transform and still face outwards from the shape's centre.
    let m = mesh(&scene, "/World/Bound");
    let centre = Vec3::new(10.0, 0.0, 0.0);
    for &t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) > 0.0, "triangle {t:?} faces inwards");
    }
}

#[test]
fn bad_values_skip_the_prim_with_a_warning() {
    let scene = load_text(
        r#"def Sphere "Negative" { double radius = -1 }
def Cylinder "Sideways" { uniform token axis = "W" }
def Capsule "Short" { double height = -0.5 }
def Cube "Good" {}"#,
    );
    let paths: Vec<&str> = scene.meshes.iter().map(|m| m.path.as_str()).collect();
    assert_eq!(paths, ["/Good"]);
    let warnings: Vec<(&str, &str)> =
        scene.warnings.iter().map(|w| (w.prim.as_str(), w.message.as_str())).collect();
    assert_eq!(
        warnings,
        [
            ("/Negative", "radius -1 is negative or not finite; Sphere skipped"),
            ("/Sideways", "axis \"W\" is not X, Y or Z; Cylinder skipped"),
            ("/Short", "height -0.5 is negative or not finite; Capsule skipped"),
        ]
    );
}

#[test]
fn instanced_shapes_share_their_tessellation() {
    let scene = load_text(
        r#"class "Proto" {
    def Capsule "Pill" {
        uniform token axis = "Y"
    }
}
def Xform "A" (instanceable = true inherits = </Proto>) {
    double3 xformOp:translate = (10, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "B" (instanceable = true inherits = </Proto>) {
}
def PointInstancer "PI" {
    rel prototypes = [</PI/Protos/Spike>]
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 5), (0, 0, 9)]
    def Scope "Protos" {
        def Cone "Spike" {
        }
    }
}"#,
    );
    let paths: Vec<&str> = scene.meshes.iter().map(|m| m.path.as_str()).collect();
    assert_eq!(paths, ["/A/Pill", "/B/Pill", "/PI/Protos/Spike", "/PI/Protos/Spike"]);
    let placed = |i: usize| scene.meshes[i].placed.as_ref().expect("an instanced shape is placed");
    assert!(std::sync::Arc::ptr_eq(&placed(0).geometry, &placed(1).geometry), "one Capsule tessellation");
    assert!(std::sync::Arc::ptr_eq(&placed(2).geometry, &placed(3).geometry), "one Cone tessellation");
    assert_eq!(placed(0).geometry.triangles.len(), 1024);
    assert_eq!(placed(2).geometry.triangles.len(), 64);
    let world = |i: usize| bounds(&scene.meshes[i].in_world());
    let close = |(l, h): (Vec3, Vec3), lo: Vec3, hi: Vec3| {
        (l - lo).abs().max_element() < 1e-5 && (h - hi).abs().max_element() < 1e-5
    };
    assert!(close(world(0), Vec3::new(9.5, -1.0, -0.5), Vec3::new(10.5, 1.0, 0.5)), "{:?}", world(0));
    assert!(close(world(1), Vec3::new(-0.5, -1.0, -0.5), Vec3::new(0.5, 1.0, 0.5)), "{:?}", world(1));
    assert!(close(world(3), Vec3::new(-1.0, -1.0, 8.0), Vec3::new(1.0, 1.0, 10.0)), "{:?}", world(3));
}

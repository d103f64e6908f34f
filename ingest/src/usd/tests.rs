//! Reader tests on generated .usda stages (hand-computed expectations, cross-checked with usd-core).

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3, Vec4};

use super::*;
use crate::scene::{LightKind, Scene};

/// Writes `files` (name, text) into a fresh temporary directory; returns it and the first file.
fn write(files: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let root = dir.path().join(files[0].0);
    (dir, root)
}

fn load_text(text: &str) -> Scene {
    let (_dir, root) = write(&[("scene.usda", text)]);
    load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn usda(body: &str) -> String {
    format!("#usda 1.0\n\n{body}\n")
}

fn mesh<'a>(scene: &'a Scene, path: &str) -> &'a crate::Mesh {
    scene.meshes.iter().find(|m| m.path == path).unwrap_or_else(|| {
        panic!("no mesh {path}; have {:?}", scene.meshes.iter().map(|m| &m.path).collect::<Vec<_>>())
    })
}

fn assert_mat(actual: Mat4, expected: Mat4) {
    assert!(actual.abs_diff_eq(expected, 1e-5), "\nactual   {actual}\nexpected {expected}");
}

fn has_warning(scene: &Scene, prim: &str, needle: &str) -> bool {
    scene.warnings.iter().any(|w| w.prim == prim && w.message.contains(needle))
}

/// A triangle mesh with scheme none, for transform and binding tests.
const TRI: &str = r#"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        uniform token subdivisionScheme = "none""#;

#[test]
fn xform_stack_translate_rotate_xyz_scale() {
    let scene = load_text(&usda(
        r#"def Xform "A" {
    double3 xformOp:translate = (1, 2, 3)
    float3 xformOp:rotateXYZ = (30, 45, 60)
    float3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ", "xformOp:scale"]
    def Camera "Cam" {}
}"#,
    ));
    let (x, y, z) = (30f32.to_radians(), 45f32.to_radians(), 60f32.to_radians());
    let expected = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
        * Mat4::from_rotation_z(z)
        * Mat4::from_rotation_y(y)
        * Mat4::from_rotation_x(x)
        * Mat4::from_scale(Vec3::splat(2.0));
    assert_mat(scene.cameras[0].world_from_camera, expected);
    // usd-core: UsdGeom.Xformable(A).ComputeLocalToWorldTransform(0) row 0 (GfMatrix4d is row-vector).
    // (0.7071067811865476, 1.224744871391589, -1.4142135623730951)
    let usd_row0 = [std::f32::consts::FRAC_1_SQRT_2, 1.5f32.sqrt(), -std::f32::consts::SQRT_2];
    let m = scene.cameras[0].world_from_camera;
    for (i, v) in usd_row0.iter().enumerate() {
        assert!((m.col(0)[i] - v).abs() < 1e-5, "{m}");
    }
}

#[test]
fn xform_orient_invert_pivot_and_matrix() {
    let scene = load_text(&usda(
        r#"def Xform "Parent" {
    float3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:scale"]
    def Camera "Orient" {
        quatf xformOp:orient = (0.70710678, 0, 0.70710678, 0)
        uniform token[] xformOpOrder = ["xformOp:orient"]
    }
    def Camera "Pivot" {
        double3 xformOp:translate = (10, 0, 0)
        double3 xformOp:translate:pivot = (1, 0, 0)
        double xformOp:rotateZ = 90
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:translate:pivot", "xformOp:rotateZ", "!invert!xformOp:translate:pivot"]
    }
    def Camera "Matrix" {
        matrix4d xformOp:transform = ( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (5, 6, 7, 1) )
        uniform token[] xformOpOrder = ["xformOp:transform"]
    }
    def Camera "Reset" {
        double3 xformOp:translate = (0, 1, 0)
        uniform token[] xformOpOrder = ["!resetXformStack!", "xformOp:translate"]
    }
}"#,
    ));
    let cam = |name: &str| scene.cameras.iter().find(|c| c.path == format!("/Parent/{name}")).unwrap();
    let s = Mat4::from_scale(Vec3::splat(2.0));
    assert_mat(cam("Orient").world_from_camera, s * Mat4::from_rotation_y(90f32.to_radians()));
    let pivot = Mat4::from_translation(Vec3::X);
    let expected = s
        * Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0))
        * pivot
        * Mat4::from_rotation_z(90f32.to_radians())
        * pivot.inverse();
    assert_mat(cam("Pivot").world_from_camera, expected);
    // The pivot point itself stays put under the rotation: (1,0,0) local → 2 * (11, 0, 0).
    let p = cam("Pivot").world_from_camera.transform_point3(Vec3::X);
    assert!((p - Vec3::new(22.0, 0.0, 0.0)).length() < 1e-4, "{p}");
    assert_mat(cam("Matrix").world_from_camera, s * Mat4::from_translation(Vec3::new(5.0, 6.0, 7.0)));
    assert_mat(cam("Reset").world_from_camera, Mat4::from_translation(Vec3::Y));
}

#[test]
fn ngon_triangulation_counts_and_holes() {
    let scene = load_text(&usda(
        r#"def Mesh "M" {
    int[] faceVertexCounts = [3, 4, 5, 4]
    int[] faceVertexIndices = [0, 1, 2,  0, 1, 2, 3,  0, 1, 2, 3, 4,  4, 3, 2, 1]
    int[] holeIndices = [3]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (1.5, 1, 0), (0.5, 1.5, 0), (-0.5, 1, 0)]
    uniform token subdivisionScheme = "none"
}"#,
    ));
    let m = mesh(&scene, "/M");
    assert_eq!(m.triangles.len(), 1 + 2 + 3, "hole face skipped");
    assert_eq!(m.triangle_materials.len(), m.triangles.len());
    assert!(scene.warnings.iter().all(|w| !w.message.contains("subdivision")));
}

#[test]
fn concave_face_area_is_preserved() {
    let scene = load_text(&usda(
        r#"def Mesh "L" {
    int[] faceVertexCounts = [6]
    int[] faceVertexIndices = [0, 1, 2, 3, 4, 5]
    point3f[] points = [(0, 0, 0), (2, 0, 0), (2, 1, 0), (1, 1, 0), (1, 2, 0), (0, 2, 0)]
    uniform token subdivisionScheme = "none"
}"#,
    ));
    let m = mesh(&scene, "/L");
    assert_eq!(m.triangles.len(), 4);
    let area: f32 = m
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            0.5 * (b - a).cross(c - a).z
        })
        .sum();
    assert!((area - 3.0).abs() < 1e-5, "signed area {area}: all triangles CCW about +Z");
}

#[test]
fn left_handed_and_mirrored_winding() {
    let scene = load_text(&usda(&format!(
        r#"def Mesh "Right" {{{TRI}
}}
def Mesh "Left" {{{TRI}
    uniform token orientation = "leftHanded"
}}
def Mesh "Mirrored" {{{TRI}
    float3 xformOp:scale = (-1, 1, 1)
    uniform token[] xformOpOrder = ["xformOp:scale"]
}}"#
    )));
    let normal = |path: &str| {
        let m = mesh(&scene, path);
        let [a, b, c] = m.triangles[0].map(|i| m.positions[i as usize]);
        (b - a).cross(c - a).normalize()
    };
    assert!((normal("/Right") - Vec3::Z).length() < 1e-6);
    assert!((normal("/Left") + Vec3::Z).length() < 1e-6, "leftHanded flips the winding");
    // A mirroring transform keeps the surface facing +Z (the authored front side).
    assert!((normal("/Mirrored") - Vec3::Z).length() < 1e-6);
}

#[test]
fn face_varying_indexed_uvs_split_vertices() {
    let scene = load_text(&usda(
        r#"def Mesh "M" {
    int[] faceVertexCounts = [4, 4]
    int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
    normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)] (
        interpolation = "vertex"
    )
    texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (
        interpolation = "faceVarying"
    )
    int[] primvars:st:indices = [0, 1, 2, 3, 3, 2, 1, 0]
    uniform token subdivisionScheme = "none"
}
def Mesh "Shared" {
    int[] faceVertexCounts = [4, 4]
    int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
    float3[] primvars:normals = [(0, 0, 1)] (
        interpolation = "constant"
    )
    texCoord2f[] primvars:uv = [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (2, 1)] (
        interpolation = "vertex"
    )
    uniform token subdivisionScheme = "none"
}"#,
    ));
    let m = mesh(&scene, "/M");
    assert_eq!(m.positions.len(), 8, "faceVarying st splits per face corner");
    assert_eq!(m.uvs.len(), 8);
    assert_eq!(m.normals.len(), 8);
    // Second face's corners read st indices [3, 2, 1, 0].
    assert_eq!(m.uvs[4], glam::Vec2::new(0.0, 1.0));
    assert_eq!(m.uvs[7], glam::Vec2::new(0.0, 0.0));
    assert_eq!(m.positions[4], Vec3::new(1.0, 0.0, 0.0));
    let s = mesh(&scene, "/Shared");
    assert_eq!(s.positions.len(), 6, "vertex/constant primvars keep shared vertices");
    assert_eq!(s.uvs[5], glam::Vec2::new(2.0, 1.0), "first texCoord2f[] primvar used when st is absent");
    assert!(s.normals.iter().all(|&n| n == Vec3::Z));
    assert_eq!(s.triangles.len(), 4);
}

#[test]
fn normals_transform_by_inverse_transpose() {
    let scene = load_text(&usda(
        r#"def Mesh "M" {
    float3 xformOp:scale = (1, 4, 1)
    uniform token[] xformOpOrder = ["xformOp:scale"]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    normal3f[] normals = [(0.7071, 0.7071, 0), (0.7071, 0.7071, 0), (0.7071, 0.7071, 0)]
    uniform token subdivisionScheme = "none"
}"#,
    ));
    let n = mesh(&scene, "/M").normals[0];
    let expected = Vec3::new(1.0, 0.25, 0.0).normalize();
    assert!((n - expected).length() < 1e-4, "{n}");
}

#[test]
fn subdivision_mesh_gets_limit_normals_not_authored_ones() {
    let scene = load_text(&usda(
        r#"def Mesh "S" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1)]
}"#,
    ));
    // A lone triangle is 3 quads after one level, 3·4^(L−1) quads at level L, with limit normals
    // (a flat cage: ±z, here +z).
    let m = mesh(&scene, "/S");
    let level = scene.subdivisions[0].level;
    assert_eq!(m.triangles.len(), 2 * 3 * 4usize.pow(level - 1));
    assert_eq!(m.normals.len(), m.positions.len());
    assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-5), "{:?}", m.normals);
    assert!(scene.warnings.iter().all(|w| w.prim != "/S"), "{:?}", scene.warnings);
}

#[test]
fn bad_index_and_degenerate_faces() {
    let (_dir, root) = write(&[(
        "scene.usda",
        &usda(
            r#"def Xform "World" {
    def Mesh "Mesh" {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 12]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)]
        uniform token subdivisionScheme = "none"
    }
}"#,
        ),
    )]);
    let err = load(&root, &LoadOptions::default()).unwrap_err();
    let text = err.to_string();
    assert!(
        text.ends_with("scene.usda: /World/Mesh.faceVertexIndices: index 12 out of range (8 points)"),
        "{text}"
    );
    assert_eq!(err.prim(), Some("/World/Mesh"));
    assert_eq!(err.attribute_name(), Some("faceVertexIndices"));

    let scene = load_text(&usda(
        r#"def Mesh "D" {
    int[] faceVertexCounts = [2, 3, 1]
    int[] faceVertexIndices = [0, 1, 0, 1, 2, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
}"#,
    ));
    assert_eq!(mesh(&scene, "/D").triangles.len(), 1);
    assert!(has_warning(&scene, "/D", "2 degenerate faces"));
}

const MATERIALS: &str = r#"
def Scope "Looks" {
    def Material "Red" {
        token outputs:surface.connect = </Looks/Red/Surface.outputs:surface>
        def Shader "Surface" {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            float inputs:roughness = 0.25
            float inputs:metallic = 1
            int inputs:useSpecularWorkflow = 1
            float inputs:ior = 1.33
            float inputs:opacity = 0.5
            token outputs:surface
        }
    }
    def Material "Blue" {
        color3f inputs:tint = (0, 0, 1)
        token outputs:surface.connect = </Looks/Blue/Surface.outputs:surface>
        def Shader "Surface" {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor.connect = </Looks/Blue.inputs:tint>
            color3f inputs:emissiveColor.connect = </Looks/Blue/Tex.outputs:rgb>
            token outputs:surface
        }
        def Shader "Tex" {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @tex.png@
            float4 inputs:fallback = (0.1, 0.2, 0.3, 1)
            float3 outputs:rgb
        }
    }
    def Material "X" {
        token outputs:mtlx:surface.connect = </Looks/X/S.outputs:out>
        def Shader "S" {
            uniform token info:id = "ND_standard_surface_surfaceshader"
            token outputs:out
        }
    }
}"#;

#[test]
fn material_binding_direct_inherited_and_subsets() {
    let scene = load_text(&usda(&format!(
        r#"{MATERIALS}
def Xform "Group" (prepend apiSchemas = ["MaterialBindingAPI"]) {{
    rel material:binding = </Looks/Red>
    def Mesh "Inherits" {{{TRI}
    }}
    def Mesh "Direct" (prepend apiSchemas = ["MaterialBindingAPI"]) {{{TRI}
        rel material:binding = </Looks/Blue>
    }}
}}
def Mesh "Subsets" (prepend apiSchemas = ["MaterialBindingAPI"]) {{
    int[] faceVertexCounts = [3, 3]
    int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Looks/Red>
    def GeomSubset "Second" (prepend apiSchemas = ["MaterialBindingAPI"]) {{
        uniform token elementType = "face"
        uniform token familyName = "materialBind"
        int[] indices = [1]
        rel material:binding = </Looks/Blue>
    }}
}}
def Mesh "Mtlx" (prepend apiSchemas = ["MaterialBindingAPI"]) {{{TRI}
    rel material:binding = </Looks/X>
    color3f[] primvars:displayColor = [(0, 1, 0)]
}}"#
    )));
    let mat = |mesh_path: &str, tri: usize| {
        &scene.materials[mesh(&scene, mesh_path).triangle_materials[tri] as usize]
    };
    let red = mat("/Group/Inherits", 0);
    assert_eq!(red.path, "/Looks/Red");
    assert_eq!(red.diffuse_color, Vec3::new(1.0, 0.0, 0.0));
    assert_eq!((red.roughness, red.metallic, red.ior, red.opacity), (0.25, 1.0, 1.33, 0.5));
    assert!(red.use_specular_workflow);
    assert_eq!(red.clearcoat_roughness, 0.01, "unauthored inputs keep the spec fallback");

    let blue = mat("/Group/Direct", 0);
    assert_eq!(blue.path, "/Looks/Blue");
    assert_eq!(blue.diffuse_color, Vec3::new(0.0, 0.0, 1.0), "interface input followed");
    // tex.png does not exist: the program's texture op has no texture and returns the fallback.
    assert!(
        blue.program.iter().any(|n| matches!(n, crate::scene::ShaderNode::Texture { texture: None, fallback, .. } if *fallback == [0.1, 0.2, 0.3, 1.0])),
        "texture fallback used: {:?}",
        blue.program
    );
    assert!(blue.program.iter().any(|n| matches!(
        n,
        crate::scene::ShaderNode::Output { input: crate::scene::ShadingInput::EmissiveColor, .. }
    )));
    assert!(has_warning(
        &scene,
        "/Looks/Blue/Tex",
        "tex.png not found; using its fallback [0.1, 0.2, 0.3, 1.0]"
    ));

    assert_eq!(mat("/Subsets", 0).path, "/Looks/Red");
    assert_eq!(mat("/Subsets", 1).path, "/Looks/Blue");

    // A MaterialX standard_surface with no inputs authored: the model's defaults, mapped.
    let x = mat("/Mtlx", 0);
    assert_eq!(x.path, "/Looks/X");
    assert_eq!((x.diffuse_color, x.roughness), (Vec3::splat(0.8), 0.2));
    assert_eq!(x.look.surface_model, "standard_surface");

    let paths: Vec<&str> = scene.materials.iter().map(|m| m.path.as_str()).collect();
    assert_eq!(paths.len(), 3, "materials deduplicated: {paths:?}");
}

#[test]
fn stronger_than_descendants_binding_wins() {
    let scene = load_text(&usda(&format!(
        r#"{MATERIALS}
def Xform "Group" {{
    rel material:binding = </Looks/Red> (
        bindMaterialAs = "strongerThanDescendants"
    )
    def Mesh "M" {{{TRI}
        rel material:binding = </Looks/Blue>
    }}
}}
def Mesh "Preview" {{{TRI}
    rel material:binding:preview = </Looks/Blue>
}}"#
    )));
    let m = mesh(&scene, "/Group/M");
    assert_eq!(scene.materials[m.triangle_materials[0] as usize].path, "/Looks/Red");
    let p = mesh(&scene, "/Preview");
    assert_eq!(scene.materials[p.triangle_materials[0] as usize].path, "/Looks/Blue");
    assert!(has_warning(&scene, "/Preview", "preview-purpose"));
}

#[test]
fn display_color_fallbacks() {
    let scene = load_text(&usda(&format!(
        r#"def Mesh "Constant" {{{TRI}
    color3f[] primvars:displayColor = [(0.5, 0.25, 1)] (interpolation = "constant")
    float[] primvars:displayOpacity = [0.5]
}}
def Mesh "Varying" {{{TRI}
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0), (0, 0, 1)] (interpolation = "vertex")
}}
def Mesh "None" {{{TRI}
}}"#
    )));
    let mat = |p: &str| &scene.materials[mesh(&scene, p).triangle_materials[0] as usize];
    assert_eq!(mat("/Constant").path, "/Constant.displayColor");
    assert_eq!(mat("/Constant").diffuse_color, Vec3::new(0.5, 0.25, 1.0));
    assert_eq!(mat("/Constant").opacity, 0.5);
    // A varying displayColor keeps its average as the constant and is read per hit by a program; the
    // mesh carries the primvar per vertex.
    assert!((mat("/Varying").diffuse_color - Vec3::splat(1.0 / 3.0)).length() < 1e-6);
    assert!(
        matches!(&mat("/Varying").program[0], crate::scene::ShaderNode::Primvar { name, .. } if name == "displayColor")
    );
    let varying = mesh(&scene, "/Varying");
    assert_eq!(varying.primvars.len(), 1);
    assert_eq!(varying.primvars[0].layout, crate::scene::PrimvarLayout::PerVertex);
    assert_eq!(varying.primvars[0].values.len(), varying.positions.len());
    assert!(mat("/Constant").program.is_empty());
    assert!(mesh(&scene, "/Constant").primvars.is_empty());
    assert_eq!(mat("/None").diffuse_color, Vec3::splat(0.18));
}

#[test]
fn visibility_purpose_and_active() {
    let scene = load_text(&usda(&format!(
        r#"def Xform "Hidden" {{
    token visibility = "invisible"
    def Mesh "M" {{{TRI}
    }}
}}
def Xform "Guides" {{
    uniform token purpose = "guide"
    def Mesh "G" {{{TRI}
    }}
    def Mesh "R" {{{TRI}
        uniform token purpose = "render"
    }}
}}
def Mesh "Proxy" {{{TRI}
    uniform token purpose = "proxy"
}}
def Mesh "Inactive" (active = false) {{{TRI}
}}
def Mesh "Visible" {{{TRI}
    token visibility = "inherited"
}}"#
    )));
    let paths: Vec<&str> = scene.meshes.iter().map(|m| m.path.as_str()).collect();
    assert_eq!(paths, ["/Guides/R", "/Visible"]);
}

#[test]
fn light_fallbacks_and_radiance() {
    let scene = load_text(&usda(
        r#"def SphereLight "Sphere" {}
def DistantLight "Sun" {
    float inputs:intensity = 2
    float inputs:exposure = 1
    color3f inputs:color = (1, 0.5, 0.25)
    float inputs:angle = 1
}
def RectLight "Old" {
    float intensity = 3
    float width = 2
}
def DiskLight "Both" {
    float intensity = 5
    float inputs:intensity = 7
    bool inputs:normalize = 1
}
def DomeLight "Dome" {
    asset inputs:texture:file = @sky.exr@
}
def CylinderLight "Cyl" {}"#,
    ));
    let light = |p: &str| scene.lights.iter().find(|l| l.path == p).unwrap();
    assert_eq!(light("/Sphere").kind, LightKind::Sphere { radius: 0.5, treat_as_point: false });
    assert_eq!(light("/Sphere").radiance, Vec3::ONE);
    assert!(!light("/Sphere").normalize);
    assert_eq!(light("/Sun").kind, LightKind::Distant { angle_degrees: 1.0 });
    assert_eq!(light("/Sun").radiance, Vec3::new(4.0, 2.0, 1.0));
    assert_eq!(light("/Old").kind, LightKind::Rect { width: 2.0, height: 1.0 });
    assert_eq!(light("/Old").radiance, Vec3::splat(3.0));
    assert_eq!(light("/Both").radiance, Vec3::splat(7.0), "inputs: wins");
    assert!(light("/Both").normalize);
    assert_eq!(light("/Both").kind, LightKind::Disk { radius: 0.5 });
    assert_eq!(light("/Dome").kind, LightKind::Dome);
    assert!(
        has_warning(&scene, "/Dome", "sky.exr not found; using its uniform color"),
        "{:?}",
        scene.warnings
    );
    assert!(has_warning(&scene, "/Cyl", "CylinderLight"));
    assert_eq!(scene.lights.len(), 5);
    assert_eq!(
        scene.lights.iter().find(|l| l.path == "/Sun").unwrap().kind,
        LightKind::Distant { angle_degrees: 1.0 }
    );
}

#[test]
fn camera_fallbacks_and_render_settings() {
    let scene = load_text(&usda(
        r#"def Camera "First" {}
def Camera "Second" {
    float focalLength = 35
    token projection = "orthographic"
    float2 clippingRange = (0.1, 100)
    float horizontalApertureOffset = 1
}
def Scope "Render" {
    def RenderSettings "Settings" {
        rel camera = </Second>
        uniform int2 resolution = (640, 360)
    }
}"#,
    ));
    let first = &scene.cameras[0];
    assert_eq!(first.path, "/First");
    assert_eq!(
        (first.focal_length, first.horizontal_aperture, first.vertical_aperture),
        (50.0, 20.955, 15.2908)
    );
    assert_eq!((first.horizontal_aperture_offset, first.vertical_aperture_offset), (0.0, 0.0));
    assert_eq!(first.clipping_range, [1.0, 1_000_000.0]);
    assert!(!first.orthographic);
    assert_eq!(first.world_from_camera, Mat4::IDENTITY);
    let second = &scene.cameras[1];
    assert_eq!((second.focal_length, second.orthographic, second.clipping_range), (35.0, true, [0.1, 100.0]));
    assert_eq!(second.horizontal_aperture_offset, 1.0);
    assert_eq!(scene.default_camera, Some(1));
    assert_eq!(scene.resolution, Some([640, 360]));

    let scene = load_text(&usda(r#"def Camera "Only" {}"#));
    assert_eq!(scene.default_camera, Some(0));
    assert_eq!(scene.resolution, None);
}

#[test]
fn render_settings_data_windows() {
    let settings = |window: &str| {
        load_text(&usda(&format!(
            "def Camera \"Cam\" {{}}\ndef RenderSettings \"Settings\" {{\n    uniform float4 dataWindowNDC = {window}\n}}"
        )))
    };
    let scene = settings("(0.25, 0, 0.75, 0.5)");
    assert_eq!(scene.data_window_ndc, Some([0.25, 0.0, 0.75, 0.5]));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(settings("(0, 0, 1, 1)").data_window_ndc, None, "the whole frame is no crop");
    let inverted = settings("(0.75, 0, 0.25, 1)");
    assert_eq!(inverted.data_window_ndc, None);
    assert!(
        has_warning(
            &inverted,
            "/Settings",
            "dataWindowNDC [0.75, 0.0, 0.25, 1.0] is not an upright rectangle"
        ),
        "{:?}",
        inverted.warnings
    );
}

#[test]
fn render_products_and_vars() {
    let scene = load_text(&usda(
        r#"def Camera "Cam" {}
def DistantLight "Key" ( prepend apiSchemas = ["LightAPI"] ) { string lightGroup = "keys" }
def SphereLight "Fill" {}
def Scope "Render" {
    def RenderSettings "Settings" {
        rel products = [</Render/Comp>, </Render/Nameless>]
    }
    def RenderProduct "Comp" {
        token productName = "comp.exr"
        rel orderedVars = [</Render/Vars/diffuse>, </Render/Vars/N>, </Render/Vars/bogus>, </Render/Vars/prim>, </Render/Vars/odd>]
    }
    def RenderProduct "Nameless" {
        rel orderedVars = [</Render/Vars/N>]
    }
    def Scope "Vars" {
        def RenderVar "diffuse" {
            uniform string sourceName = "C<RD>L"
            uniform token sourceType = "lpe"
        }
        def RenderVar "N" {
            uniform string sourceName = "N"
            uniform token dataType = "normal3f"
        }
        def RenderVar "bogus" {
            uniform string sourceName = "Ngarbage"
        }
        def RenderVar "prim" {
            uniform string sourceName = "uv"
            uniform token sourceType = "intrinsic"
        }
        def RenderVar "odd" {
            uniform string sourceName = "albedo"
            uniform token dataType = "matrix4d"
        }
    }
}"#,
    ));
    assert_eq!(scene.render_products.len(), 1, "{:?}", scene.warnings);
    let comp = &scene.render_products[0];
    assert_eq!((comp.path.as_str(), comp.name.as_str()), ("/Render/Comp", "comp.exr"));
    let vars: Vec<(&str, &str, u32, u32)> =
        comp.vars.iter().map(|v| (v.path.as_str(), v.source.as_str(), v.source_type, v.data_type)).collect();
    use blob::outputs::{data_type as dt, source_type as st};
    assert_eq!(
        vars,
        [
            ("/Render/Vars/diffuse", "C<RD>L", st::LPE, dt::COLOR3),
            ("/Render/Vars/N", "N", st::RAW, dt::VECTOR3)
        ]
    );
    assert!(
        has_warning(&scene, "/Render/Vars/bogus", "sourceName \"Ngarbage\" is not a raw value"),
        "{:?}",
        scene.warnings
    );
    assert!(has_warning(&scene, "/Render/Vars/prim", "sourceType \"intrinsic\""), "{:?}", scene.warnings);
    assert!(has_warning(&scene, "/Render/Vars/odd", "dataType \"matrix4d\""), "{:?}", scene.warnings);
    assert!(has_warning(&scene, "/Render/Nameless", "no productName"), "{:?}", scene.warnings);
    assert_eq!(scene.warnings.len(), 4, "one warning per prim: {:?}", scene.warnings);
    assert_eq!(scene.light_groups, [Some("keys".to_string()), None]);
}

#[test]
fn stage_metadata() {
    let scene = load_text("#usda 1.0\n(\n    upAxis = \"Z\"\n    metersPerUnit = 1\n)\n");
    assert_eq!(scene.up_axis, UpAxis::Z);
    assert_eq!(scene.meters_per_unit, 1.0);
    let scene = load_text("#usda 1.0\n");
    assert_eq!(scene.up_axis, UpAxis::Y);
    assert_eq!(scene.meters_per_unit, 0.01);
}

#[test]
fn missing_reference_names_referencing_layer() {
    let files = [
        (
            "scene.usda",
            "#usda 1.0\n\ndef Xform \"World\" {\n    def \"Ref\" (references = @middle.usda@) {}\n}\n",
        ),
        (
            "middle.usda",
            "#usda 1.0\n(defaultPrim = \"M\")\n\ndef Xform \"M\" (references = @missing.usda@) {}\n",
        ),
    ];
    let (_dir, root) = write(&files);
    let err = load(&root, &LoadOptions::default()).unwrap_err();
    assert!(err.layer().ends_with("middle.usda"), "{err}");
    assert!(
        matches!(err.kind(), UsdErrorKind::MissingAsset { asset, .. } if asset.contains("missing.usda")),
        "{err}"
    );
    let scene = load(&root, &LoadOptions { lenient: true, ..LoadOptions::default() }).unwrap();
    assert!(scene.warnings.iter().any(|w| w.message.contains("missing.usda")), "{:?}", scene.warnings);

    let (_dir, root) = write(&[("scene.usda", "#usda 1.0\n(\n    subLayers = [@gone.usda@]\n)\n")]);
    let err = load(&root, &LoadOptions::default()).unwrap_err();
    assert!(err.layer().ends_with("scene.usda") && err.to_string().contains("gone.usda"), "{err}");
}

#[test]
fn an_mtlx_reference_composes_its_materials() {
    let files = [
        (
            "scene.usda",
            "#usda 1.0\n\ndef Xform \"World\" {\n    def \"Look\" (references = @look.mtlx@) {}\n}\n",
        ),
        (
            "look.mtlx",
            "<?xml version=\"1.0\"?>\n<materialx version=\"1.38\"><standard_surface name=\"S\" type=\"surfaceshader\"/><surfacematerial name=\"M\" type=\"material\"><input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"S\"/></surfacematerial></materialx>\n",
        ),
    ];
    let (_dir, root) = write(&files);
    let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // The reference names no prim: the document's default prim, /MaterialX, lands on /World/Look.
    let stage = Stage::open(&root, &LoadOptions::default()).unwrap();
    assert_eq!(stage.type_name("/World/Look/Materials/M"), "Material");
    assert_eq!(stage.type_name("/World/Look/Materials/M/S"), "Shader");
    assert_eq!(
        stage.connections("/World/Look/Materials/M", "outputs:mtlx:surface"),
        ["/World/Look/Materials/M/S.outputs:out"]
    );
}

#[test]
fn a_sublayered_mtlx_document_adds_its_materials_at_usdmtlx_paths() {
    let files = [
        (
            "scene.usda",
            "#usda 1.0\n(\n    subLayers = [@./looks/look.mtlx@]\n)\ndef Mesh \"Tri\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n    uniform token subdivisionScheme = \"none\"\n    rel material:binding = </MaterialX/Materials/Red>\n}\n",
        ),
        (
            "looks/look.mtlx",
            "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n  <open_pbr_surface name=\"S\" type=\"surfaceshader\">\n    <input name=\"base_color\" type=\"color3\" value=\"1, 0, 0\"/>\n  </open_pbr_surface>\n  <surfacematerial name=\"Red\" type=\"material\">\n    <input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"S\"/>\n  </surfacematerial>\n</materialx>\n",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("looks")).unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let scene =
        load(&dir.path().join("scene.usda"), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let red = &scene.materials[mesh(&scene, "/Tri").triangle_materials[0] as usize];
    assert_eq!(red.path, "/MaterialX/Materials/Red");
    // base_weight 1 × base_color (1, 0, 0).
    assert_eq!(red.diffuse_color, Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(red.look.surface_model, "open_pbr_surface");
}

#[test]
fn malformed_file_names_the_file() {
    let (_dir, root) = write(&[("broken.usda", "#usda 1.0\n\ndef Mesh \"M\" {\n    int[] x = [1, \n")]);
    let err = load(&root, &LoadOptions::default()).unwrap_err();
    assert!(err.to_string().contains("broken.usda"), "{err}");
}

#[test]
fn instances_and_point_instancers_are_expanded() {
    let scene = load_text(&usda(&format!(
        r#"class "Proto" {{
    def Mesh "Tri" {{{TRI}
    }}
}}
def Xform "A" (instanceable = true inherits = </Proto>) {{
    double3 xformOp:translate = (10, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def Xform "B" (instanceable = true inherits = </Proto>) {{}}
def PointInstancer "PI" {{
    rel prototypes = [</PI/Protos/Tri>]
    int[] protoIndices = [0, 0, 0]
    point3f[] positions = [(0, 0, 5), (0, 0, 6), (0, 0, 7)]
    float3[] scales = [(1, 1, 1), (2, 2, 2), (1, 1, 1)]
    int64[] invisibleIds = [2]
    def Scope "Protos" {{
        def Mesh "Tri" {{{TRI}
        }}
    }}
}}"#
    )));
    let paths: Vec<&str> = scene.meshes.iter().map(|m| m.path.as_str()).collect();
    assert_eq!(paths, ["/A/Tri", "/B/Tri", "/PI/Protos/Tri", "/PI/Protos/Tri"]);
    assert_eq!(scene.instance_count, 4);
    assert_eq!(mesh(&scene, "/A/Tri").in_world().positions[1], Vec3::new(11.0, 0.0, 0.0));
    assert_eq!(scene.meshes[3].in_world().positions[1], Vec3::new(2.0, 0.0, 6.0));
}

#[test]
fn shapes_and_unsupported_prims() {
    let scene = load_text(&usda(
        r#"def Cube "C" { double size = 4 }
def Sphere "S" {}
def HermiteCurves "Hair" {}
def BasisCurves "Empty" {}
def Points "P" {}"#,
    ));
    let c = mesh(&scene, "/C");
    assert_eq!(c.triangles.len(), 12);
    assert!(c.positions.iter().all(|p| p.abs().max_element() == 2.0));
    let s = mesh(&scene, "/S");
    assert!(s.positions.iter().all(|p| (p.length() - 1.0).abs() < 1e-5));
    assert!(has_warning(&scene, "/Hair", "HermiteCurves"));
    assert!(scene.curves.is_empty(), "curve and point prims without points draw nothing");
}

#[test]
fn basis_curves_points_and_nurbs() {
    let scene = load_text(&usda(
        r#"def BasisCurves "Hair" {
    uniform token basis = "catmullRom"
    uniform token wrap = "pinned"
    int[] curveVertexCounts = [4, 3]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 1, 0), (3, 1, 0), (0, 2, 0), (1, 2, 0), (2, 2, 0)]
    float[] widths = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7] (interpolation = "vertex")
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0)] (interpolation = "uniform")
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def BasisCurves "Lines" {
    uniform token type = "linear"
    uniform token wrap = "periodic"
    int[] curveVertexCounts = [3]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    normal3f[] normals = [(0, 0, 1)] (interpolation = "constant")
}
def Points "P" {
    point3f[] points = [(0, 0, 0), (1, 1, 1)]
    float[] widths = [0.5]
}
def NurbsCurves "N" {
    int[] curveVertexCounts = [4]
    int[] order = [4]
    double[] knots = [0, 0, 0, 0, 1, 1, 1, 1]
    point3f[] points = [(0, 0, 0), (1, 1, 0), (2, 1, 0), (3, 0, 0)]
}"#,
    ));
    let find = |p: &str| scene.curves.iter().find(|c| c.path == p).unwrap_or_else(|| panic!("{p}"));
    let hair = find("/Hair");
    assert_eq!(
        (hair.curve_count, hair.segments.len()),
        (2, 5),
        "catmullRom pinned: n − 1 segments per curve"
    );
    let first = &hair.segments[0];
    assert_eq!(first.p[0], Vec4::new(0.0, 0.0, 10.0, 0.05), "pinned start, translated, radius = width / 2");
    assert_eq!(hair.segments[2].p[3].truncate(), Vec3::new(3.0, 1.0, 10.0), "pinned end");
    assert!(hair.has_colors && first.color[0] == Vec3::X && hair.segments[4].color[1] == Vec3::Y);
    assert_eq!(hair.kind, crate::scene::CurveKind::Tube);
    let lines = find("/Lines");
    assert_eq!(lines.segments.len(), 3, "periodic linear closes");
    assert_eq!(lines.segments[2].p[3], lines.segments[0].p[0]);
    assert_eq!(lines.kind, crate::scene::CurveKind::Ribbon);
    assert_eq!(lines.segments[0].p[0].w, 0.5, "unauthored widths are 1 (Hydra)");
    let points = find("/P");
    assert_eq!(points.spheres.len(), 2);
    assert_eq!(points.spheres[1].radius, 0.25);
    let nurbs = find("/N");
    assert_eq!(nurbs.segments.len(), 1, "a clamped cubic NURBS span is one Bézier");
    assert!((nurbs.segments[0].p[1].truncate() - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-5);
}

/// The shared asset folder beside the checkout (`../shared/assets`), if present.
fn shared_assets() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/assets");
    dir.is_dir().then_some(dir)
}

#[test]
fn real_assets_load_with_triangles() {
    let Some(assets) = shared_assets() else {
        eprintln!("skipping: ../shared/assets not found");
        return;
    };
    for (file, min_triangles) in [
        ("mini_car_kit/full_assets/Vehicles/USD_Mini_Car_Kit/assets/vehicles/vehicleVariants.usda", 1000),
        ("teapot/full_assets/Teapot/Teapot.usd", 100),
    ] {
        let scene = load(&assets.join(file), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert!(scene.triangle_count() >= min_triangles, "{file}: {} triangles", scene.triangle_count());
        for m in &scene.meshes {
            assert_eq!(m.triangles.len(), m.triangle_materials.len());
            assert!(m.triangle_materials.iter().all(|&i| (i as usize) < scene.materials.len()));
            assert!(m.triangles.iter().flatten().all(|&i| (i as usize) < m.positions.len()));
            assert!(m.normals.is_empty() || m.normals.len() == m.positions.len());
            assert!(m.uvs.is_empty() || m.uvs.len() == m.positions.len());
        }
    }
}

/// Curves and their segments on the shared OpenUSD curve assets, against usd-core 26.11
/// (`UsdGeomBasisCurves::ComputeSegmentCounts`, curves with at least one segment). Pinned bspline
/// curves get two more segments each from Hydra's tripled end points.
#[test]
fn curve_segment_counts_match_usd_core_on_shared_assets() {
    let Some(assets) = shared_assets() else {
        eprintln!("shared assets not found; skipped");
        return;
    };
    let root = assets.join("openusd_curves_points/pxr");
    // (file, usd-core curves with segments, usd-core segments, extra Hydra pinned-bspline segments)
    let cases = [
        ("usdImaging/usdImagingGL/testenv/testUsdImagingGLCurves/basicCurves.usda", 7, 16, 0),
        ("usdImaging/usdImagingGL/testenv/testUsdImagingGLCurves/pinnedCurves.usda", 3, 7, 6),
        ("usd/usdGeom/testenv/testUsdGeomBBoxCache/pointsAndCurves.usda", 3, 3, 0),
        ("usdImaging/usdImagingGL/testenv/testUsdImagingGLBasicLighting/BasisCurves1.usda", 16, 70, 0),
        ("usdImaging/usdImagingGL/testenv/testUsdImagingGLBasicLighting/BasisCurves2.usda", 451, 1096, 0),
        ("usdImaging/usdImagingGL/testenv/testUsdImagingGLBasicLighting/BasisCurves3.usda", 4051, 8102, 0),
        ("usdImaging/usdImagingGL/testenv/testUsdImagingGLBasisCurvesWithNormals/curve-authored-normals.usd", 1, 3, 0),
    ];
    for (file, curves, segments, extra) in cases {
        let scene = load(&root.join(file), &LoadOptions::default()).unwrap();
        let basis: Vec<_> =
            scene.curves.iter().filter(|c| c.kind != crate::scene::CurveKind::Points).collect();
        let got_segments: usize = basis.iter().map(|c| c.segments.len()).sum();
        // Curves with segments: segment parameter ranges restart at u = 0 once per curve.
        let got_curves: usize =
            basis.iter().map(|c| c.segments.iter().filter(|s| s.u[0] == 0.0).count()).sum();
        assert_eq!((got_curves, got_segments), (curves, segments + extra), "{file}");
    }
}

/// A material whose only surface is RenderMan's (`outputs:ri:surface`) reads its PxrDisney; a
/// universal `outputs:surface` beside it wins; connected inputs and unsupported lobes are named.
#[test]
fn renderman_pxr_disney_surfaces_are_read_from_their_constants() {
    let scene = load_text(&usda(&format!(
        r#"def Scope "Looks" {{
    def Material "Felt" {{
        token outputs:ri:surface.connect = </Looks/Felt/Disney.outputs:out>
        def Shader "Disney" {{
            uniform token info:id = "PxrDisney"
            color3f inputs:baseColor = (0, 0.25, 0.5)
            float inputs:specular = 0
            float inputs:presence = 0.75
            float inputs:sheen = 0.3
            float inputs:roughness.connect = </Looks/Felt/Noise.outputs:resultF>
            token outputs:out
        }}
        def Shader "Noise" {{
            uniform token info:id = "PxrFractal"
            float outputs:resultF
        }}
    }}
    def Material "Both" {{
        token outputs:surface.connect = </Looks/Both/Preview.outputs:surface>
        token outputs:ri:surface.connect = </Looks/Both/Disney.outputs:out>
        def Shader "Preview" {{
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            token outputs:surface
        }}
        def Shader "Disney" {{
            uniform token info:id = "PxrDisney"
            color3f inputs:baseColor = (0, 1, 0)
            token outputs:out
        }}
    }}
}}
def Mesh "A" (prepend apiSchemas = ["MaterialBindingAPI"]) {{{TRI}
    rel material:binding = </Looks/Felt>
}}
def Mesh "B" (prepend apiSchemas = ["MaterialBindingAPI"]) {{{TRI}
    rel material:binding = </Looks/Both>
}}"#
    )));
    let material = |m: &str| &scene.materials[mesh(&scene, m).triangle_materials[0] as usize];
    let felt = material("/A");
    assert_eq!(felt.path, "/Looks/Felt");
    assert_eq!(felt.diffuse_color, Vec3::new(0.0, 0.25, 0.5));
    assert_eq!(
        (felt.ior, felt.opacity, felt.roughness),
        (1.0, 0.75, 0.25),
        "specular 0 is ior 1; default roughness"
    );
    assert!(has_warning(
        &scene,
        "/Looks/Felt",
        "PxrDisney input roughness is connected to /Looks/Felt/Noise"
    ));
    assert!(has_warning(&scene, "/Looks/Felt", "PxrDisney sheen not supported"));
    let both = material("/B");
    assert_eq!((both.path.as_str(), both.diffuse_color), ("/Looks/Both", Vec3::new(1.0, 0.0, 0.0)));
}

/// `tests/assets/light_linking/linked.usda`: each gprim's light set as usd-core's
/// `ComputeMembershipQuery` answers for the four lights (Key, Fill, Rim, Dome; the expected
/// values are usd-core 26.11's), equal sets stored once, the curve's warning, and the packed
/// blob: the differently linked instance gets no shared prototype with the other two.
#[test]
fn light_and_shadow_links_follow_usd_core_membership() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets/light_linking/linked.usda");
    let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let lights: Vec<&str> = scene.lights.iter().map(|l| l.path.as_str()).collect();
    assert_eq!(lights, ["/Key", "/Fill", "/Rim", "/Dome"]);
    let (t, f) = (true, false);
    let expected: [(&str, [bool; 4], [bool; 4]); 7] = [
        ("/World/A/a1", [t, t, f, t], [t; 4]),
        ("/World/A/a2", [f, t, f, t], [t; 4]),
        ("/World/AB/ab1", [f, t, t, t], [t; 4]),
        ("/World/B/b1", [f, t, f, t], [t, f, t, t]),
        ("/World/Inst1/geo", [f, t, f, t], [t; 4]),
        ("/World/Inst2/geo", [f, t, t, t], [t; 4]),
        ("/World/Inst3/geo", [f, t, f, t], [t; 4]),
    ];
    for (path, lit_by, shadows) in expected {
        let set = &scene.light_sets[mesh(&scene, path).light_set as usize];
        assert_eq!((set.lit_by.as_slice(), set.shadows.as_slice()), (&lit_by[..], &shadows[..]), "{path}");
    }
    // Everything, a1, a2 (= Inst1 = Inst3), ab1 (= Inst2), b1.
    assert_eq!(scene.light_sets.len(), 5);
    assert_eq!(scene.light_sets[0], crate::scene::LightSet::everything(4));
    assert!(has_warning(
        &scene,
        "/Fill",
        "light linking of curves and points not supported yet: /World/B/hair"
    ));
    let dump = crate::pipeline::dump_json(&scene);
    let b1 = dump["gprims"].as_array().unwrap().iter().find(|g| g["path"] == "/World/B/b1").unwrap();
    assert_eq!(b1["light_link"], serde_json::json!(["/Fill", "/Dome"]));
    assert_eq!(b1["shadow_link"], serde_json::json!(["/Key", "/Rim", "/Dome"]));

    let data = crate::pack::pack(&scene).unwrap();
    let bytes = blob::AlignedBytes::copy_from(&data.encode());
    let view = blob::SceneView::parse(&bytes).unwrap();
    assert_eq!(view.light_set_count(), 5);
    // Inst1 and Inst3 share a prototype; Inst2 (lit by Rim too) is drawn on its own.
    assert_eq!(view.instancing.prototypes.len(), 1);
    assert_eq!(view.instancing.instances.len(), 2);
    let proto = view.instancing.prototypes[0];
    let proto_set = view.meshes[proto.first_mesh as usize].light_set;
    assert_eq!(proto_set, mesh(&scene, "/World/Inst1/geo").light_set);
    let b1_set = view.meshes.iter().find(|m| view.string(m.name) == "/World/B/b1").unwrap().light_set;
    assert_eq!(b1_set, mesh(&scene, "/World/B/b1").light_set);
}

/// A stage whose lights author nothing, or author collections that hold every gprim, has no
/// light sets: its blob is the unlinked one.
#[test]
fn collections_holding_everything_leave_the_scene_unlinked() {
    let scene = load_text(&usda(&format!(
        r#"def Mesh "M" {{{TRI}
}}
def DistantLight "Sun" {{
    rel collection:lightLink:includes = </M>
    rel collection:shadowLink:excludes = </Nothing>
}}
def DistantLight "Plain" {{}}"#
    )));
    assert!(scene.light_sets.is_empty(), "{:?}", scene.light_sets);
    assert_eq!(mesh(&scene, "/M").light_set, 0);
    assert!(crate::pipeline::dump_json(&scene)["gprims"][0].get("light_link").is_none());
}

#[test]
fn unsupported_collection_parts_are_warned_about() {
    let scene = load_text(&usda(&format!(
        r#"def Mesh "M" {{{TRI}
}}
def DistantLight "Sun" {{
    uniform token collection:lightLink:expansionRule = "expandEverything"
    rel collection:shadowLink:includes = </Other.collection:set>
    uniform bool collection:shadowLink:includeRoot = 0
}}"#
    )));
    assert!(has_warning(
        &scene,
        "/Sun",
        "collection:lightLink:expansionRule \"expandEverything\" is not an expansion rule"
    ));
    assert!(has_warning(&scene, "/Sun", "target </Other.collection:set> is a collection"));
    // The nested target ignored and no root: the mesh does not shadow the sun.
    let set = &scene.light_sets[mesh(&scene, "/M").light_set as usize];
    assert_eq!((set.lit_by.as_slice(), set.shadows.as_slice()), (&[true][..], &[false][..]));
}

/// Camera visibility of lights, as the renderers' attributes author it (only where authored).
#[test]
fn lights_hidden_from_the_camera_by_karma_renderman_and_arnold_attributes() {
    let scene = load_text(&usda(
        r#"def SphereLight "Plain" {}
def SphereLight "KarmaOn" { bool karma:light:renderlightgeo = 1 }
def SphereLight "KarmaOff" { bool karma:light:renderlightgeo = 0 }
def SphereLight "RiOff" { int primvars:ri:attributes:visibility:camera = 0 }
def SphereLight "ArnoldOff" { float primvars:arnold:camera = 0 }
def SphereLight "ArnoldHalf" { float primvars:arnold:camera = 0.5 }"#,
    ));
    let hidden: Vec<&str> =
        scene.camera_hidden_lights.iter().map(|&l| scene.lights[l].path.as_str()).collect();
    assert_eq!(hidden, ["/KarmaOff", "/RiOff", "/ArnoldOff"]);
}

#[test]
fn positions_are_stored_relative_to_the_render_camera_snapped_to_64_units() {
    // The RenderSettings camera (the second one) decides; a resetXformStack prim moves too.
    let scene = load_text(&usda(
        r#"def Xform "Far" {
    double3 xformOp:translate = (100000, -5000.5, 40)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Camera "Near" {}
    def Camera "Shot" { double3 xformOp:translate = (10, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"] }
    def Mesh "Tri" {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        uniform token subdivisionScheme = "none"
    }
}
def Mesh "Reset" {
    uniform token[] xformOpOrder = ["!resetXformStack!", "xformOp:translate"]
    double3 xformOp:translate = (100000, 0, 0)
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
}
def RenderSettings "Settings" { rel camera = </Far/Shot> }"#,
    ));
    // (100010, −5000.5, 40) snapped: 1563·64, −78·64, 1·64.
    assert_eq!(scene.world_origin, glam::DVec3::new(100_032.0, -4_992.0, 64.0));
    let tri = mesh(&scene, "/Far/Tri");
    assert_eq!(tri.positions[1], Vec3::new(100_001.0 - 100_032.0, -8.5, -24.0));
    let reset = mesh(&scene, "/Reset");
    assert_eq!(reset.positions[0], Vec3::new(-32.0, 4_992.0, -64.0));
    let shot = &scene.cameras[scene.default_camera.unwrap()];
    assert_eq!(shot.world_from_camera.w_axis.truncate(), Vec3::new(-22.0, -8.5, -24.0));
    // The listing gives stage-world bounds.
    let dump = crate::pipeline::dump_json(&scene);
    assert_eq!(dump["world_origin"], serde_json::json!([100_032.0, -4_992.0, 64.0]));
    let listed = dump["gprims"].as_array().unwrap().iter().find(|g| g["path"] == "/Far/Tri").unwrap();
    assert_eq!(listed["bounds_max"], serde_json::json!([100_001.0, -4_999.5, 40.0]));
}

#[test]
fn a_camera_too_close_for_f32_positions_is_warned_about() {
    // A card 0.0005 units in front of a camera 20 units from the origin: positions there are
    // spaced 2⁴·2⁻²³ = 1.9e-6 apart, while a pixel of a 50 mm lens on a 36 mm back at 1920 px
    // covers 0.0005·36/50/1920 = 1.9e-7 (10 pixels per step). At 5 units it covers 1.9e-3.
    let shot = |distance: f64| {
        load_text(&usda(&format!(
            r#"def Camera "Cam" {{
    float focalLength = 50
    float horizontalAperture = 36
    float2 clippingRange = (0.0001, 1000)
    double3 xformOp:translate = (20, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def Mesh "Card" {{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(19.999, 0, -{distance}), (20.001, 0, -{distance}), (20, 0.001, -{distance})]
    uniform token subdivisionScheme = "none"
}}"#
        )))
    };
    let near = shot(0.0005);
    assert!(has_warning(&near, "/Cam", "spaced 1.91e-6 apart"), "{:?}", near.warnings);
    let far = shot(5.0);
    assert!(!far.warnings.iter().any(|w| w.message.contains("f32 positions")), "{:?}", far.warnings);
}

#[test]
fn typeless_visibility_and_non_material_bind_subsets_are_ignored_as_usd_core_does() {
    let scene = load_text(&usda(
        r#"def Material "Green" {}
def "Typeless" {
    token visibility = "invisible"
    uniform token purpose = "guide"
    def Mesh "Tri" (prepend apiSchemas = ["MaterialBindingAPI"]) {
        int[] faceVertexCounts = [3, 3]
        int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
        uniform token subdivisionScheme = "none"
        def GeomSubset "Part" (prepend apiSchemas = ["MaterialBindingAPI"]) {
            uniform token elementType = "face"
            uniform token familyName = "partition"
            int[] indices = [1]
            rel material:binding = </Green>
        }
    }
}"#,
    ));
    let tri = mesh(&scene, "/Typeless/Tri");
    assert_eq!(tri.triangle_materials[0], tri.triangle_materials[1], "the partition subset binds nothing");
    assert!(has_warning(
        &scene,
        "/Typeless/Tri/Part",
        "material binding on a GeomSubset with familyName \"partition\", not \"materialBind\"; ignored"
    ));
}

//! Shared helpers for the end-to-end tests: write small USD stages as text, ingest them, render them.
//!
//! Stages are generated rather than stored so each test states its whole setup (geometry, material,
//! lights, camera) in one place and the expected radiance follows from it analytically.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A UsdPreviewSurface material definition with a constant diffuse color (everything else at fallback
/// except `roughness` 1 / specular 0 via `ior = 1`, which makes it a pure Lambertian).
pub fn lambert_material(path: &str, albedo: f32) -> String {
    let name = path.rsplit('/').next().unwrap_or("M");
    format!(
        r#"def Material "{name}"
{{
    token outputs:surface.connect = <{path}/Surface.outputs:surface>
    def Shader "Surface"
    {{
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = ({albedo}, {albedo}, {albedo})
        float inputs:roughness = 1
        float inputs:ior = 1
        token outputs:surface
    }}
}}
"#
    )
}

/// A UV sphere as a polygon Mesh prim (subdivisionScheme none) with per-vertex normals.
pub fn sphere_mesh(
    name: &str,
    center: [f32; 3],
    radius: f32,
    rings: usize,
    segments: usize,
    material: &str,
) -> String {
    let mut points = Vec::new();
    let mut normals = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
            points.push([center[0] + radius * n[0], center[1] + radius * n[1], center[2] + radius * n[2]]);
            normals.push(n);
        }
    }
    let mut counts = Vec::new();
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let a = r * segments + s;
            let b = r * segments + (s + 1) % segments;
            let c = (r + 1) * segments + (s + 1) % segments;
            let d = (r + 1) * segments + s;
            // Counter-clockwise seen from outside (right-handed, outward normal).
            counts.push(4);
            indices.extend_from_slice(&[a, b, c, d]);
        }
    }
    mesh_prim(name, &points, &counts, &indices, Some(&normals), material)
}

/// A Mesh prim from explicit topology.
pub fn mesh_prim(
    name: &str,
    points: &[[f32; 3]],
    counts: &[usize],
    indices: &[usize],
    normals: Option<&[[f32; 3]]>,
    material: &str,
) -> String {
    let list3 = |v: &[[f32; 3]]| {
        v.iter().map(|p| format!("({}, {}, {})", p[0], p[1], p[2])).collect::<Vec<_>>().join(", ")
    };
    let list = |v: &[usize]| v.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", ");
    let mut s = String::new();
    writeln!(s, "def Mesh \"{name}\" (\n    prepend apiSchemas = [\"MaterialBindingAPI\"]\n)\n{{").unwrap();
    writeln!(s, "    uniform token subdivisionScheme = \"none\"").unwrap();
    writeln!(s, "    int[] faceVertexCounts = [{}]", list(counts)).unwrap();
    writeln!(s, "    int[] faceVertexIndices = [{}]", list(indices)).unwrap();
    writeln!(s, "    point3f[] points = [{}]", list3(points)).unwrap();
    if let Some(n) = normals {
        writeln!(s, "    normal3f[] normals = [{}] (\n        interpolation = \"vertex\"\n    )", list3(n))
            .unwrap();
    }
    writeln!(s, "    rel material:binding = <{material}>\n}}").unwrap();
    s
}

/// A camera at `eye` looking down −Z (identity rotation) with the given focal length and square aperture.
pub fn camera_prim(name: &str, eye: [f32; 3], focal_length: f32, aperture: f32) -> String {
    format!(
        r#"def Camera "{name}"
{{
    float focalLength = {focal_length}
    float horizontalAperture = {aperture}
    float verticalAperture = {aperture}
    double3 xformOp:translate = ({}, {}, {})
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
"#,
        eye[0], eye[1], eye[2]
    )
}

/// Wraps prims into a stage with `/World` as default prim.
pub fn stage(body: &str) -> String {
    let mut s = String::from(
        "#usda 1.0\n(\n    defaultPrim = \"World\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n\n",
    );
    s.push_str("def Xform \"World\"\n{\n");
    for line in body.lines() {
        if line.is_empty() {
            s.push('\n');
        } else {
            writeln!(s, "    {line}").unwrap();
        }
    }
    s.push_str("}\n");
    s
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write test stage");
    path
}

/// Ingests `usda` (written into `dir`) and returns the blob bytes, aligned for parsing.
pub fn ingest_text(dir: &Path, usda: &str) -> blob::AlignedBytes {
    let input = write(dir, "scene.usda", usda);
    let output = dir.join("scene.blob");
    ingest::pipeline::ingest_file(&input, &output, &ingest::usd::LoadOptions::default()).expect("ingest");
    blob::AlignedBytes::copy_from(&std::fs::read(&output).expect("read blob"))
}

/// Mean of channel 0..3 over the pixels selected by `keep(x, y)` of a `width`-wide RGB(A) image.
pub fn mean_where(pixels: &[[f32; 3]], width: usize, keep: impl Fn(usize, usize) -> bool) -> [f32; 3] {
    let mut sum = [0.0f64; 3];
    let mut n = 0usize;
    for (i, p) in pixels.iter().enumerate() {
        if keep(i % width, i / width) {
            for c in 0..3 {
                sum[c] += p[c] as f64;
            }
            n += 1;
        }
    }
    assert!(n > 0, "no pixels selected");
    sum.map(|s| (s / n as f64) as f32)
}

/// A 2-unit cube centred on the origin with its +Z face missing (a cup open towards +Z): light entering
/// it reflects many times before escaping, which makes it a furnace test of interreflection.
pub fn open_box_mesh(name: &str, material: &str) -> String {
    let p = [
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, -1.0],
        [1.0, 1.0, -1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
        [1.0, -1.0, 1.0],
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, 1.0],
    ];
    let faces = [[0, 3, 2, 1], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]];
    let indices: Vec<usize> = faces.iter().flatten().copied().collect();
    mesh_prim(name, &p, &[4; 5], &indices, None, material)
}

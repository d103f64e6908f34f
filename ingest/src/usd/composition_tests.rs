//! Composition tests: legacy `.usda` text, parse-error locations, cycles, search paths,
//! PointInstancer `inactiveIds`, evaluation at a chosen frame.

use std::path::{Path, PathBuf};

use super::*;
use crate::scene::Scene;

/// Writes `files` (relative name, text) under a fresh temporary directory.
fn write(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        let path = dir.path().join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
    dir
}

fn load_with(root: &Path, options: &LoadOptions) -> Scene {
    load(root, options).unwrap_or_else(|e| panic!("{e}"))
}

fn mesh_paths(scene: &Scene) -> Vec<&str> {
    scene.meshes.iter().map(|m| m.path.as_str()).collect()
}

/// The world-space x extent of the mesh at `path`.
fn x_range(scene: &Scene, path: &str) -> (f32, f32) {
    let mesh = scene.meshes.iter().find(|m| m.path == path).unwrap_or_else(|| panic!("no mesh {path}"));
    let xs = mesh.positions.iter().map(|p| p.x);
    (xs.clone().fold(f32::INFINITY, f32::min), xs.fold(f32::NEG_INFINITY, f32::max))
}

const TRI: &str = r#"int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        uniform token subdivisionScheme = "none""#;

#[test]
fn legacy_usda_spellings_open() {
    let dir = write(&[(
        "legacy.usda",
        r#"#usda 1.0
def Xform "A"
{
    Vec3f xformOp:translate = (.5, 0., 2)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Mesh "M"
    {
        int[] faceVertexCounts = [4]
        PointIndex[] faceVertexIndices = [0, 1, 2, 3]
        PointFloat[] points = [(0, 0, 0), (.5, 0, 0), (.5, .5, 0), (0, .5, 0)]
        Vec3f[] extent = [(0, 0, 0), (.5, .5, 0)]
        uniform token subdivisionScheme = "none"
    }
    def Shader "Tex"
    {
        asset inputs:file = "grid.png"
        asset inputs:other.timeSamples = {
            1: @grid.png@,
            2: @grid_1.png@,
        }
    }
}
"#,
    )]);
    let scene = load_with(&dir.path().join("legacy.usda"), &LoadOptions::default());
    assert_eq!(mesh_paths(&scene), ["/A/M"]);
    assert_eq!(scene.meshes[0].triangles.len(), 2);
    assert_eq!(x_range(&scene, "/A/M"), (0.5, 1.0));
}

#[test]
fn unparseable_root_names_file_line_and_construct() {
    let dir =
        write(&[("bad.usda", "#usda 1.0\ndef \"A\"\n{\n    float a = 1\n    bogus3f b = (1, 2, 3)\n}\n")]);
    let root = dir.path().join("bad.usda");
    let error = load(&root, &LoadOptions::default()).unwrap_err();
    let text = error.to_string();
    assert!(matches!(error.kind(), UsdErrorKind::Open(_)), "{text}");
    assert!(text.contains("bad.usda"), "{text}");
    assert!(text.contains("line 5"), "{text}");
    assert!(text.contains("bogus3f b"), "{text}");
}

#[test]
fn unparseable_reference_names_file_line_and_construct() {
    let dir = write(&[
        ("root.usda", "#usda 1.0\ndef \"A\" (\n    references = @part.usda@\n)\n{\n}\n"),
        ("part.usda", "#usda 1.0\n(\n    defaultPrim = \"P\"\n)\ndef \"P\"\n{\n    int x = (\n}\n"),
    ]);
    let error = load(&dir.path().join("root.usda"), &LoadOptions::default()).unwrap_err();
    let text = error.to_string();
    assert!(matches!(error.kind(), UsdErrorKind::MalformedAsset { .. }), "{text}");
    assert!(text.contains("part.usda: line 7, column 13: `int x = (`"), "{text}");
}

#[test]
fn reference_cycle_is_an_error_naming_the_cycle() {
    let dir = write(&[
        ("a.usda", "#usda 1.0\ndef Xform \"A\" (\n    references = @b.usda@</B>\n)\n{\n}\n"),
        ("b.usda", "#usda 1.0\ndef Xform \"B\" (\n    references = @a.usda@</A>\n)\n{\n}\n"),
    ]);
    let root = dir.path().join("a.usda");
    let error = load(&root, &LoadOptions::default()).unwrap_err();
    let text = error.to_string();
    assert_eq!(error.prim(), Some("/A"), "{text}");
    assert!(
        text.contains("</A> in a.usda -reference-> </B> in b.usda -reference-> </A> in a.usda"),
        "{text}"
    );
    // Lenient: a warning, and the stage still loads.
    let scene = load_with(&root, &LoadOptions { lenient: true, ..LoadOptions::default() });
    assert!(scene.warnings.iter().any(|w| w.message.contains("composition cycle")));
}

#[test]
fn sublayer_cycle_is_an_error() {
    let dir = write(&[
        ("s1.usda", "#usda 1.0\n(\n    subLayers = [@s2.usda@]\n)\n"),
        ("s2.usda", "#usda 1.0\n(\n    subLayers = [@s1.usda@]\n)\n"),
    ]);
    let text = load(&dir.path().join("s1.usda"), &LoadOptions::default()).unwrap_err().to_string();
    assert!(text.contains("sublayer cycle") && text.contains("s1.usda"), "{text}");
}

#[test]
fn asset_paths_are_searched_after_the_layer_directory() {
    let part = format!("#usda 1.0\n(\n    defaultPrim = \"P\"\n)\ndef Mesh \"P\"\n{{\n        {TRI}\n}}\n");
    let dir = write(&[
        ("shot/root.usda", "#usda 1.0\ndef \"A\" (\n    references = @parts/part.usda@\n)\n{\n}\n"),
        ("lib1/other.usda", "#usda 1.0\n"),
        ("lib2/parts/part.usda", &part),
    ]);
    let root = dir.path().join("shot/root.usda");
    let error = load(&root, &LoadOptions::default()).unwrap_err();
    assert!(matches!(error.kind(), UsdErrorKind::MissingAsset { .. }), "{error}");
    let asset_paths: Vec<PathBuf> = vec![dir.path().join("lib1"), dir.path().join("lib2")];
    let scene = load_with(&root, &LoadOptions { asset_paths, ..LoadOptions::default() });
    assert_eq!(mesh_paths(&scene), ["/A"]);
}

#[test]
fn point_instancer_inactive_ids_compose_as_a_list_op() {
    let instancer = |metadata: &str| {
        format!(
            r#"#usda 1.0
def PointInstancer "PI" (
    {metadata}
)
{{
    int[] protoIndices = [0, 0, 0, 0]
    point3f[] positions = [(0, 0, 0), (10, 0, 0), (20, 0, 0), (30, 0, 0)]
    int64[] ids = [5, 6, 7, 8]
    rel prototypes = </PI/Protos/Tri>
    def Scope "Protos"
    {{
        def Mesh "Tri"
        {{
            {TRI}
        }}
    }}
}}
"#
        )
    };
    let weak = instancer("inactiveIds = [6]");
    let dir = write(&[
        ("root.usda", "#usda 1.0\n(\n    subLayers = [@weak.usda@]\n)\nover \"PI\" (\n    append inactiveIds = [8]\n)\n{\n}\n"),
        ("weak.usda", &weak),
    ]);
    let scene = load_with(&dir.path().join("root.usda"), &LoadOptions::default());
    let mut xs: Vec<f32> = scene.meshes.iter().map(|m| m.in_world().positions[0].x).collect();
    xs.sort_by(f32::total_cmp);
    assert_eq!(xs, [0.0, 20.0]);
}

#[test]
fn frame_interpolates_samples_through_layer_offsets() {
    let part = format!(
        r#"#usda 1.0
(
    defaultPrim = "P"
)
def Xform "P"
{{
    double3 xformOp:translate.timeSamples = {{ 0: (0, 0, 0), 10: (10, 0, 0) }}
    token visibility.timeSamples = {{ 0: "inherited", 5: "invisible" }}
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Mesh "M"
    {{
        {TRI}
    }}
}}
"#
    );
    let dir = write(&[
        ("root.usda", "#usda 1.0\n(\n    startTimeCode = 2\n)\ndef \"A\" (\n    references = @part.usda@ (offset = 4)\n)\n{\n}\n"),
        ("part.usda", &part),
    ]);
    let root = dir.path().join("root.usda");
    let at = |frame: Option<f64>| load_with(&root, &LoadOptions { frame, ..LoadOptions::default() });
    // Default: startTimeCode 2 is part time -2, held at the first sample.
    assert_eq!(x_range(&at(None), "/A/M"), (0.0, 1.0));
    // Stage time 6.5 is part time 2.5: linear between the samples; visibility is held.
    assert_eq!(x_range(&at(Some(6.5)), "/A/M"), (2.5, 3.5));
    // Stage time 9 is part time 5: invisible from then on.
    assert!(at(Some(9.0)).meshes.is_empty());
}

#[test]
fn class_cycles_are_errors_naming_the_chain() {
    // A cycle among classes the composing prim reaches, not through it: openusd 0.6 recursed on
    // these until the stack overflowed (SIGABRT).
    for (arc, name) in [("inherits", "inherit"), ("specializes", "specialize")] {
        let text = format!(
            "#usda 1.0\ndef Xform \"X\" ({arc} = </C1>)\n{{\n}}\nclass \"C1\" ({arc} = </C2>)\n{{\n}}\nclass \"C2\" ({arc} = </C1>)\n{{\n}}\n"
        );
        let dir = write(&[("cls.usda", &text)]);
        let root = dir.path().join("cls.usda");
        for lenient in [false, true] {
            let error = load(&root, &LoadOptions { lenient, ..LoadOptions::default() }).unwrap_err();
            let text = error.to_string();
            assert_eq!(error.prim(), Some("/C1"), "{text}");
            assert!(text.contains("cls.usda"), "{text}");
            assert!(
                text.contains(&format!(
                    "composition cycle: </C1> in cls.usda -{name}-> </C2> in cls.usda -{name}-> </C1> in cls.usda"
                )),
                "{text}"
            );
        }
    }
    // A class that specializes itself, in a referenced layer.
    let dir = write(&[
        ("root.usda", "#usda 1.0\ndef Xform \"A\" (\n    references = @part.usda@</P>\n)\n{\n}\n"),
        (
            "part.usda",
            "#usda 1.0\ndef Xform \"P\" (specializes = </S>)\n{\n}\nclass \"S\" (specializes = </S>)\n{\n}\n",
        ),
    ]);
    let error = load(&dir.path().join("root.usda"), &LoadOptions::default()).unwrap_err();
    let text = error.to_string();
    assert!(text.contains("part.usda"), "{text}");
    assert!(text.contains("composition cycle: </S> in part.usda -specialize-> </S> in part.usda"), "{text}");
}

/// `n` layers `l0.usda` .. `l{n-1}.usda`, each referencing the next, the last a triangle mesh.
fn reference_chain(n: usize) -> tempfile::TempDir {
    let mut files: Vec<(String, String)> = (0..n)
        .map(|i| {
            (
                format!("l{i}.usda"),
                format!("#usda 1.0\ndef \"P\" (references = @l{}.usda@</P>)\n{{\n}}\n", i + 1),
            )
        })
        .collect();
    files.push((format!("l{n}.usda"), format!("#usda 1.0\ndef Mesh \"P\"\n{{\n        {TRI}\n}}\n")));
    let refs: Vec<(&str, &str)> = files.iter().map(|(a, b)| (a.as_str(), b.as_str())).collect();
    write(&refs)
}

#[test]
fn reference_chains_compose_up_to_the_depth_limit_and_name_it_beyond() {
    // usd-core composes a 500-deep chain; upstream openusd 0.6 stopped at 100 (the vendored copy
    // composes 1000). Beyond the limit the error names the limit, not a cycle.
    let dir = reference_chain(500);
    let scene = load_with(&dir.path().join("l0.usda"), &LoadOptions::default());
    assert_eq!(mesh_paths(&scene), ["/P"]);
    let dir = reference_chain(1050);
    let error = load(&dir.path().join("l0.usda"), &LoadOptions::default()).unwrap_err();
    let text = error.to_string();
    assert_eq!(error.prim(), Some("/P"), "{text}");
    assert!(text.contains("l0.usda"), "{text}");
    assert!(
        text.contains(
            "composition depth limit: </P> in l0.usda nests more than 1000 arcs (the composition depth limit; the deeper arcs are dropped): </P> in l0.usda -reference-> </P> in l1.usda"
        ),
        "{text}"
    );
    assert!(text.contains("-reference-> </P> in l999.usda"), "{text}");
    assert!(!text.contains("cycle"), "{text}");
}

#[test]
fn a_deep_inherits_chain_composes() {
    // 900 classes deep: the crate recurses once per class, on the reader's own large stack.
    let mut text = String::from("#usda 1.0\ndef Xform \"X\" (inherits = </C0>)\n{\n}\n");
    for i in 0..900 {
        text.push_str(&format!("class \"C{i}\" (inherits = </C{}>)\n{{\n}}\n", i + 1));
    }
    text.push_str(&format!("class \"C900\"\n{{\n    def Mesh \"M\"\n    {{\n        {TRI}\n    }}\n}}\n"));
    let dir = write(&[("chain.usda", &text)]);
    let scene = load_with(&dir.path().join("chain.usda"), &LoadOptions::default());
    assert_eq!(mesh_paths(&scene), ["/X/M"]);
}

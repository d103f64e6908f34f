//! Outputs never destroy inputs: an output path naming any input (the root layer, a referenced
//! layer, a texture) or another output is refused with an error naming both, and the input is left
//! as it was; temporaries of killed runs are removed by the next run.

use std::path::Path;
use std::process::Command;

use crate::support::tiny_png;

const ROOT: &str = r#"#usda 1.0
def "World" (
    references = @part.usda@</Part>
)
{
}
def Mesh "Tri" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Look>
}
def Material "Look"
{
    token outputs:surface.connect = </Look/S.outputs:surface>
    def Shader "S"
    {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.connect = </Look/T.outputs:rgb>
        token outputs:surface
    }
    def Shader "T"
    {
        uniform token info:id = "UsdUVTexture"
        asset inputs:file = @tex.png@
        float3 outputs:rgb
    }
}
def DistantLight "Sun"
{
}
"#;

const PART: &str = r#"#usda 1.0
def Mesh "Part"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
}
"#;

fn asset() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.usda"), ROOT).unwrap();
    std::fs::write(dir.path().join("part.usda"), PART).unwrap();
    std::fs::write(dir.path().join("tex.png"), tiny_png()).unwrap();
    dir
}

/// Runs the binary in `dir`; (exit code, stderr).
fn ingest(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ingest")).current_dir(dir).args(args).output().unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn an_output_naming_an_input_is_refused_and_the_input_kept() {
    let dir = asset();
    let d = dir.path();
    let before: Vec<Vec<u8>> =
        ["a.usda", "part.usda", "tex.png"].iter().map(|f| std::fs::read(d.join(f)).unwrap()).collect();
    let cases: &[(&[&str], &str)] = &[
        (&["a.usda", "-o", "a.usda"], "error: refusing to write a.usda: it is the input a.usda"),
        (&["a.usda", "-o", "./a.usda"], "error: refusing to write ./a.usda: it is the input a.usda"),
        (
            &["a.usda", "-o", "x.blob", "--dump-json", "a.usda"],
            "error: refusing to write a.usda: it is the input a.usda",
        ),
        (&["a.usda", "--dump-json", "a.usda"], "error: refusing to write a.usda: it is the input a.usda"),
        (
            &["a.usda", "-o", "x.blob", "--dump-json", "x.blob"],
            "error: refusing to write x.blob and x.blob: they are the same file",
        ),
        (
            &["a.usda", "-o", "part.usda"],
            "part.usda: is also an output of this run (part.usda); refusing to overwrite an input",
        ),
        (
            &["a.usda", "--dump-json", "part.usda"],
            "part.usda: is also an output of this run (part.usda); refusing to overwrite an input",
        ),
        (
            &["a.usda", "-o", "tex.png"],
            "tex.png: is also an output of this run (tex.png); refusing to overwrite an input",
        ),
    ];
    for (args, expected) in cases {
        let (code, stderr) = ingest(d, args);
        assert_eq!(code, Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        let after: Vec<Vec<u8>> =
            ["a.usda", "part.usda", "tex.png"].iter().map(|f| std::fs::read(d.join(f)).unwrap()).collect();
        assert!(after == before, "{args:?} changed an input");
        assert!(!d.join("x.blob").exists(), "{args:?} wrote the blob");
    }
    // The same run with distinct outputs works, and the texture was baked (so it was an input).
    let (code, stderr) = ingest(d, &["a.usda", "-o", "x.blob", "--dump-json", "x.json"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stderr.contains("ingest: 2 meshes") && stderr.contains("2 materials"), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(d.join("x.blob").exists() && d.join("x.json").exists());
}

#[test]
fn temporaries_of_killed_runs_are_removed_by_the_next_run() {
    let dir = asset();
    let d = dir.path();
    // Pids above the kernel's maximum (2^22) belong to no live process.
    for name in [".x.blob.tmp-4194305", ".x.json.tmp-4194306"] {
        std::fs::write(d.join(name), vec![0u8; 4096]).unwrap();
    }
    std::fs::write(d.join(".y.blob.tmp-4194305"), b"another output's").unwrap();
    let (code, stderr) = ingest(d, &["a.usda", "-o", "x.blob", "--dump-json", "x.json"]);
    assert_eq!(code, Some(0), "{stderr}");
    let mut left: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    left.sort();
    assert_eq!(left, [".y.blob.tmp-4194305"]);
}

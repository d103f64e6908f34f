//! `ingest --frames`: a sequence composes the stage once and shares its texture bakes and
//! unchanged BVHs, and every blob it writes equals a single `ingest --frame N` byte for byte; bad
//! ranges and patterns are refused before anything is written.

use crate::support::tiny_png;
use std::path::Path;
use std::process::Command;

/// A textured card sliding along x (time-sampled translate), two instancer copies of a triangle
/// rising along y (time-sampled positions; one shared prototype), a textured dome-free sun and a
/// still camera.
const SHOT: &str = r#"#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 4
)
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 12)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Mesh "Card" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    double3 xformOp:translate.timeSamples = { 1: (0, 0, 0), 4: (3, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
    uniform token subdivisionScheme = "none"
    rel material:binding = </Look>
}
def PointInstancer "Crowd"
{
    rel prototypes = [</Crowd/Protos/Tri>]
    int[] protoIndices = [0, 0]
    point3f[] positions.timeSamples = { 1: [(-3, 2, 0), (-2, 2, 0)], 4: [(-3, 3.5, 0), (-2, 3.5, 0)] }
    def Scope "Protos"
    {
        def Mesh "Tri" (prepend apiSchemas = ["MaterialBindingAPI"])
        {
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (0.8, 0, 0), (0, 0.8, 0)]
            uniform token subdivisionScheme = "none"
            rel material:binding = </Look>
        }
    }
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
        float2 inputs:st.connect = </Look/P.outputs:result>
        float3 outputs:rgb
    }
    def Shader "P"
    {
        uniform token info:id = "UsdPrimvarReader_float2"
        string inputs:varname = "st"
        float2 outputs:result
    }
}
def DistantLight "Sun"
{
}
"#;

fn shot() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.usda"), SHOT).unwrap();
    std::fs::write(dir.path().join("tex.png"), tiny_png()).unwrap();
    dir
}

/// Runs the binary in `dir`; (exit code, stderr).
fn ingest(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ingest")).current_dir(dir).args(args).output().unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn each_frame_of_a_sequence_equals_a_single_ingest_of_that_frame_byte_for_byte() {
    let dir = shot();
    let d = dir.path();
    let (code, stderr) = ingest(d, &["shot.usda", "--frames", "1-4", "-o", "seq.####.blob"]);
    assert_eq!(code, Some(0), "{stderr}");
    // Frames 2-4 take frame 1's texture bake; the triangle prototype's BVH is reused at every
    // later frame (it does not move in prototype space), the world BVH (the card moves) is not.
    assert!(
        stderr.contains("ingest: 4 frames (1-4) -> seq.####.blob")
            && stderr.contains("3 texture bakes reused, 3 of 8 BVHs reused"),
        "{stderr}"
    );
    let mut blobs = Vec::new();
    for frame in 1..=4 {
        let single = format!("single.{frame}.blob");
        let (code, stderr) = ingest(d, &["shot.usda", "--frame", &frame.to_string(), "-o", &single]);
        assert_eq!(code, Some(0), "{stderr}");
        let (a, b) = (
            std::fs::read(d.join(format!("seq.{frame:04}.blob"))).unwrap(),
            std::fs::read(d.join(&single)).unwrap(),
        );
        assert!(a == b, "frame {frame}: the sequence's blob differs from the single ingest's");
        let bytes = blob::AlignedBytes::copy_from(&a);
        let view = blob::SceneView::parse(&bytes).unwrap();
        assert_eq!((view.texture_records.len(), view.instancing.instances.len()), (1, 2), "frame {frame}");
        blobs.push(a);
    }
    assert!(blobs.windows(2).all(|w| w[0] != w[1]), "the animation changes every frame's blob");

    // %04d patterns and steps: frames 1 and 3, the same bytes again.
    let (code, stderr) = ingest(d, &["shot.usda", "--frames", "1-4x2", "-o", "step.%04d.blob", "-q"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!d.join("step.0002.blob").exists() && !d.join("step.0004.blob").exists());
    for frame in [1, 3] {
        let (a, b) = (d.join(format!("step.{frame:04}.blob")), d.join(format!("single.{frame}.blob")));
        assert!(std::fs::read(a).unwrap() == std::fs::read(b).unwrap(), "frame {frame}");
    }
}

#[test]
fn a_sequence_writes_one_listing_per_frame_and_the_library_reports_what_it_shared() {
    let dir = shot();
    let d = dir.path();
    let (code, stderr) =
        ingest(d, &["shot.usda", "--frames", "2-3", "-o", "s.#.blob", "--dump-json", "s.#.json", "-q"]);
    assert_eq!(code, Some(0), "{stderr}");
    let listing = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join(f)).unwrap()).unwrap()
    };
    let (two, three) = (listing("s.2.json"), listing("s.3.json"));
    let card_x = |v: &serde_json::Value| v["gprims"][0]["bounds_min"][0].as_f64().unwrap();
    assert_eq!((card_x(&two), card_x(&three)), (0.0, 1.0), "the card at x = -1 + 1 and -1 + 2");

    // The library call reports what it shared.
    let options = ingest::usd::LoadOptions::default();
    let frames: Vec<(f64, std::path::PathBuf)> =
        (1..=3).map(|f| (f as f64, d.join(format!("lib.{f}.blob")))).collect();
    let mut seen = Vec::new();
    let report = ingest::pipeline::ingest_sequence(
        &d.join("shot.usda"),
        &frames,
        &options,
        &Default::default(),
        |time, _, scene, _| {
            seen.push((time, scene.meshes.len()));
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(seen, [(1.0, 3), (2.0, 3), (3.0, 3)]);
    assert_eq!(
        (report.frames, report.texture_bakes_reused, report.bvhs_reused, report.bvhs_built),
        (3, 2, 2, 4)
    );
    assert!(std::fs::read(d.join("lib.2.blob")).unwrap() == std::fs::read(d.join("s.2.blob")).unwrap());
}

#[test]
fn bad_ranges_and_patterns_are_refused_before_anything_is_written() {
    let dir = shot();
    let d = dir.path();
    let cases: &[(&[&str], &str)] = &[
        (
            &["--frames", "4-1", "-o", "o.#.blob"],
            "error: frame range \"4-1\": the last frame is before the first",
        ),
        (
            &["--frames", "1-4x0", "-o", "o.#.blob"],
            "error: frame range \"1-4x0\": the step must be at least 1",
        ),
        (&["--frames", "1..4", "-o", "o.#.blob"], "error: frame range \"1..4\": expected A-B, A-BxSTEP or N"),
        (
            &["--frames", "1-4", "-o", "o.blob"],
            "error: -o \"o.blob\" has no frame field (`#`, `####` or `%04d`) for a range of 4 frames",
        ),
        (&["--frames", "1-4", "-o", "o.#.#.blob"], "error: -o \"o.#.#.blob\" has more than one frame field"),
        (
            &["--frames", "1-2", "-o", "o.#.blob", "--dump-json", "list.json"],
            "error: --dump-json \"list.json\" has no frame field",
        ),
        (&["--frames", "1-2", "--dump-json", "l.#.json"], "error: --frames needs -o with a frame field"),
        (&["--frames", "1-2", "--frame", "1", "-o", "o.#.blob"], "cannot be used with"),
    ];
    for (args, expected) in cases {
        let mut all = vec!["shot.usda"];
        all.extend_from_slice(args);
        let (code, stderr) = ingest(d, &all);
        assert_ne!(code, Some(0), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        let written: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n != "shot.usda" && n != "tex.png")
            .collect();
        assert!(written.is_empty(), "{args:?} wrote {written:?}");
    }
    // A frame's output that is an input (the texture) is refused before the first frame is written.
    std::fs::rename(d.join("tex.png"), d.join("tex.1.png")).unwrap();
    let text = std::fs::read_to_string(d.join("shot.usda")).unwrap().replace("@tex.png@", "@tex.1.png@");
    std::fs::write(d.join("shot.usda"), text).unwrap();
    let (code, stderr) = ingest(d, &["shot.usda", "--frames", "1-2", "-o", "tex.#.png"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("tex.1.png: is also an output of this run (tex.1.png)"), "{stderr}");
    assert!(!d.join("tex.2.png").exists(), "no frame written");
}

//! `ingest ASSET --dump-json FILE` without `-o`: the listing alone, no blob, no texture baked.

use std::path::Path;
use std::process::Command;

const LAYER: &str = r#"#usda 1.0
(
    upAxis = "Y"
)
def Xform "World"
{
    def Mesh "Quad" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
        uniform token subdivisionScheme = "none"
        rel material:binding = </World/Look>
    }
    def Material "Look"
    {
        token outputs:surface.connect = </World/Look/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor.connect = </World/Look/Tex.outputs:rgb>
            token outputs:surface
        }
        def Shader "Tex"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @missing.png@
            float3 outputs:rgb
        }
    }
}
"#;

fn ingest(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_ingest")).current_dir(dir).args(args).output().expect("run ingest")
}

#[test]
fn listing_without_output_matches_the_full_ingest_and_writes_no_blob() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.usda"), LAYER).unwrap();
    let full = ingest(dir.path(), &["scene.usda", "-o", "scene.blob", "--dump-json", "full.json", "-q"]);
    assert!(full.status.success(), "{}", String::from_utf8_lossy(&full.stderr));
    std::fs::remove_file(dir.path().join("scene.blob")).unwrap();
    let list = ingest(dir.path(), &["scene.usda", "--dump-json", "list.json", "-q"]);
    assert!(list.status.success(), "{}", String::from_utf8_lossy(&list.stderr));
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap();
    let listing: serde_json::Value = serde_json::from_str(&read("list.json")).unwrap();
    assert_eq!(listing["gprims"][0]["path"], "/World/Quad");
    assert_eq!(listing["gprims"][0]["triangles"], 2);
    assert_eq!(listing["gprims"][0]["materials"][0], "/World/Look");
    assert_eq!(read("list.json"), read("full.json"));
    let mut files: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into())
        .collect();
    files.sort();
    assert_eq!(files, ["full.json", "list.json", "scene.usda"], "no blob is written");
    // The texture is never opened: the full ingest warns about it, the listing does not.
    assert!(String::from_utf8_lossy(&full.stderr).contains("missing.png"));
    assert!(!String::from_utf8_lossy(&list.stderr).contains("missing.png"));
}

#[test]
fn neither_output_nor_listing_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.usda"), LAYER).unwrap();
    let run = ingest(dir.path(), &["scene.usda"]);
    assert!(!run.status.success());
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("--output"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

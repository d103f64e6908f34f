//! Broken crate files and packages give errors that name the file, the section and the problem,
//! from the library and from the binary (exit 1, one line, no panic).

use crate::support::zip;
use ingest::usd::{self, LoadOptions};
use std::path::{Path, PathBuf};

fn corpus_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets/fuzz/corpus");
    for entry in std::fs::read_dir(corpus).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.path().join(path.file_name().unwrap())).unwrap();
    }
    dir
}

/// Offset of the cube's points in a crate file: (-1,-1,-1), (1,-1,-1), ... after their u64 count.
fn points_at(bytes: &[u8]) -> usize {
    let points: Vec<u8> = [-1f32, -1., -1., 1., -1., -1.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let at = bytes.windows(points.len()).position(|w| w == points).unwrap();
    assert_eq!(u64::from_le_bytes(bytes[at - 8..at].try_into().unwrap()), 8, "the cube's 8 points");
    at
}

/// The count openusd once tried to allocate for (`memory allocation of 6052837899185946628 bytes`).
const ABSURD: u64 = 6_052_837_899_185_946_628;

fn with_absurd_points(bytes: &mut [u8]) -> usize {
    let at = points_at(bytes);
    bytes[at - 8..at].copy_from_slice(&ABSURD.to_le_bytes());
    at
}

fn load_error(path: &Path) -> String {
    match usd::load(path, &LoadOptions::default()) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    }
}

fn expected_absurd(at: usize, len: usize) -> String {
    format!(
        "FIELDS: value of field 81 (default): array claims 6.1e18 elements of 12 bytes at offset {at}, but only {} bytes follow",
        len - at
    )
}

#[test]
fn an_absurd_array_count_is_an_error_not_an_abort() {
    let dir = corpus_copy();
    let path = dir.path().join("scene.usdc");
    let mut bytes = std::fs::read(&path).unwrap();
    let at = with_absurd_points(&mut bytes);
    std::fs::write(&path, &bytes).unwrap();
    let e = load_error(&path);
    let expected = format!("scene.usdc: {}", expected_absurd(at, bytes.len()));
    assert!(e.ends_with(&expected), "{e}");
    // Through a sublayer, the error names the layer that asked for it.
    let e = load_error(&dir.path().join("arcs.usda"));
    assert!(e.contains("arcs.usda: sublayer @./scene.usdc@ could not be read: "), "{e}");
    assert!(e.ends_with(&expected), "{e}");
}

#[test]
fn a_truncated_crate_file_is_an_error() {
    let dir = corpus_copy();
    let path = dir.path().join("scene.usdc");
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..2000]).unwrap();
    let e = load_error(&path);
    let toc = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    let expected =
        format!("scene.usdc: TOC: table of contents at offset {toc} outside the 2000-byte file (truncated?)");
    assert!(e.ends_with(&expected), "{e}");
}

#[test]
fn a_crate_file_inside_a_package_is_checked_too() {
    let dir = corpus_copy();
    let path = dir.path().join("scene_c.usdz");
    let mut bytes = std::fs::read(&path).unwrap();
    let inner = points_at(&bytes) - points_at(&std::fs::read(dir.path().join("scene.usdc")).unwrap());
    let at = with_absurd_points(&mut bytes) - inner;
    // With the stored CRC repaired the zip reader hands the entry on; the check stops it.
    zip::fix_zip_checksums(&mut bytes);
    std::fs::write(&path, &bytes).unwrap();
    let e = load_error(&path);
    let expected = format!("scene_c.usdz[scene.usdc]: {}", expected_absurd(at, 4274));
    assert!(e.ends_with(&expected), "{e}");
}

#[test]
fn a_package_with_a_cut_central_directory_is_an_error() {
    let dir = corpus_copy();
    let path = dir.path().join("scene.usdz");
    let bytes = std::fs::read(&path).unwrap();
    let eocd = bytes.windows(4).rposition(|w| w == b"PK\x05\x06").unwrap();
    let directory = u32::from_le_bytes(bytes[eocd + 16..eocd + 20].try_into().unwrap()) as usize;
    for cut in [directory + 10, eocd + 4] {
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let e = load_error(&path);
        assert!(e.starts_with(&format!("{}: cannot open stage: ", path.display())), "{e}");
        assert!(e.contains("Zip archive"), "{e}");
    }
    // An end record pointing the central directory past the end of the file.
    let mut bad = bytes.clone();
    bad[eocd + 16..eocd + 20].copy_from_slice(&u32::MAX.to_le_bytes());
    std::fs::write(&path, &bad).unwrap();
    let e = load_error(&path);
    assert!(e.contains("Zip archive"), "{e}");
}

fn ingest_binary(asset: &Path, out: &Path) -> (Option<i32>, String) {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_ingest"))
        .arg(asset)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    (output.status.code(), String::from_utf8_lossy(&output.stderr).into_owned())
}

#[test]
fn the_binary_exits_1_with_one_error_line() {
    let dir = corpus_copy();
    let path: PathBuf = dir.path().join("scene.usdc");
    let mut bytes = std::fs::read(&path).unwrap();
    let at = with_absurd_points(&mut bytes);
    std::fs::write(&path, &bytes).unwrap();
    let (code, stderr) = ingest_binary(&path, &dir.path().join("out.blob"));
    assert_eq!(code, Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.starts_with("error: cannot ingest "), "{stderr}");
    assert!(stderr.trim_end().ends_with(&expected_absurd(at, bytes.len())), "{stderr}");
    assert!(!dir.path().join("out.blob").exists());
}

/// Nesting at the limit of what text layers may use loads on a 2 MiB stack (a spawned thread's
/// default; the binary's main thread has 8 MiB); one level more is an error, not a stack overflow.
#[test]
fn deep_nesting_stops_at_the_limit_without_overflowing_the_stack() {
    let dir = tempfile::tempdir().unwrap();
    let levels = 256;
    let prims = format!("#usda 1.0\n{}{}", "def Xform \"a\" {\n".repeat(levels), "}\n".repeat(levels));
    let dicts = format!(
        "#usda 1.0\n(\n customLayerData = {{\n{}{}}}\n)\ndef Xform \"a\" {{}}\n",
        "dictionary a = {\n".repeat(levels - 2),
        "}\n".repeat(levels - 2)
    );
    let cases = [("prims.usda", prims.clone(), true), ("dicts.usda", dicts, true)];
    let deeper =
        format!("#usda 1.0\n{}{}", "def Xform \"a\" {\n".repeat(levels + 1), "}\n".repeat(levels + 1));
    for (name, text, loads) in cases.into_iter().chain([("deeper.usda", deeper, false)]) {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let result = std::thread::Builder::new()
            .stack_size(2 << 20)
            .spawn(move || usd::load(&path, &LoadOptions::default()).map(|s| s.instance_count))
            .unwrap()
            .join()
            .unwrap();
        match result {
            Ok(_) => assert!(loads, "{name} loaded"),
            Err(e) => {
                assert!(!loads, "{name}: {e}");
                assert!(e.to_string().ends_with("line 258, column 15: nested deeper than 256 levels"), "{e}");
            }
        }
    }
}

/// A PointInstancer whose prototype holds the instancer itself (directly, through the
/// pseudo-root, or through a second instancer) would expand forever; the prototype is skipped
/// with a warning and the rest of the stage loads.
#[test]
fn a_prototype_containing_its_instancer_is_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let instancer = |name: &str, proto: &str| {
        format!(
            "def PointInstancer \"{name}\" {{\n rel prototypes = <{proto}>\n int[] protoIndices = [0, 0]\n point3f[] positions = [(0, 0, 0), (2, 0, 0)]\n}}\n"
        )
    };
    let cube = "def Mesh \"Tri\" {\n point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\n int[] faceVertexCounts = [3]\n int[] faceVertexIndices = [0, 1, 2]\n uniform token subdivisionScheme = \"none\"\n}\n";
    // (text, the prototype that loops): A's prototype is the pseudo-root; B expands /World,
    // whose A expands /World again.
    let cases = [
        (format!("#usda 1.0\ndef Xform \"World\" {{\n{}{cube}}}\n", instancer("A", "/")), "/"),
        (
            format!(
                "#usda 1.0\ndef Xform \"World\" {{\n{}{cube}}}\n{}",
                instancer("A", "/World"),
                instancer("B", "/World")
            ),
            "/World",
        ),
    ];
    for (text, looped) in cases {
        let path = dir.path().join("loop.usda");
        std::fs::write(&path, text).unwrap();
        let scene = usd::load(&path, &LoadOptions::default()).unwrap();
        let warning = format!("prototype <{looped}> contains its own PointInstancer; skipped");
        assert!(scene.warnings.iter().any(|w| w.message == warning), "{looped}: {:?}", scene.warnings);
        assert!(scene.meshes.iter().any(|m| m.path.ends_with("/Tri")), "the rest loads");
    }
}

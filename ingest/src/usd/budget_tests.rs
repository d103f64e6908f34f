//! Memory budgets: hostile sizes in a stage are refused before they are allocated, each with an
//! error or warning naming the file, the prim and the value.

use super::*;

/// Writes `files` (relative name, bytes) under a fresh temporary directory.
fn write(files: &[(&str, &[u8])]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}

/// CRC-32 (PNG's polynomial), for chunks written by hand.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// A PNG of under 100 bytes whose header declares `width`×`height` RGBA8.
fn png_declaring(width: u32, height: u32) -> Vec<u8> {
    png_with(width, height, &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01])
}

/// A valid grey `width`×`height` RGBA8 PNG (its pixels in one stored deflate block).
fn png_solid(width: u32, height: u32) -> Vec<u8> {
    let row = 1 + 4 * width as usize;
    let raw: Vec<u8> = (0..height as usize * row).map(|i| if i % row == 0 { 0 } else { 128 }).collect();
    assert!(raw.len() <= 0xFFFF);
    let (mut a, mut b) = (1u32, 0u32);
    for &x in &raw {
        a = (a + u32::from(x)) % 65521;
        b = (b + a) % 65521;
    }
    let len = raw.len() as u16;
    let mut zlib = vec![0x78, 0x01, 0x01];
    zlib.extend_from_slice(&len.to_le_bytes());
    zlib.extend_from_slice(&(!len).to_le_bytes());
    zlib.extend_from_slice(&raw);
    zlib.extend_from_slice(&((b << 16) | a).to_be_bytes());
    png_with(width, height, &zlib)
}

fn png_with(width: u32, height: u32, idat: &[u8]) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let ihdr: Vec<u8> =
        width.to_be_bytes().into_iter().chain(height.to_be_bytes()).chain([8, 6, 0, 0, 0]).collect();
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", idat);
    chunk(b"IEND", &[]);
    out
}

const TRI: &str = r#"int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        uniform token subdivisionScheme = "none""#;

#[test]
fn textures_declaring_huge_sizes_are_refused_from_their_header() {
    let stage = format!(
        r#"#usda 1.0
def Material "M"
{{
    token outputs:surface.connect = </M/S.outputs:surface>
    def Shader "S"
    {{
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.connect = </M/T.outputs:rgb>
        token outputs:surface
    }}
    def Shader "T"
    {{
        uniform token info:id = "UsdUVTexture"
        asset inputs:file = @huge.png@
        float3 outputs:rgb
    }}
}}
def Mesh "Tri" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    {TRI}
    rel material:binding = </M>
}}
def DomeLight "Dome"
{{
    asset inputs:texture:file = @huge.hdr@
}}
"#
    );
    let hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n\x02\x02\x00\x10".to_vec();
    let png = png_declaring(100_000, 100_000);
    assert!(png.len() < 100);
    let dir = write(&[("scene.usda", stage.as_bytes()), ("huge.png", &png), ("huge.hdr", &hdr)]);
    let scene =
        load(&dir.path().join("scene.usda"), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let warning = |prim: &str| {
        scene.warnings.iter().find(|w| w.prim == prim).map(|w| w.message.clone()).unwrap_or_default()
    };
    let declares = "image declares 100000x100000 = 10000000000 pixels, above the limit of 268435456 pixels";
    let (png_warning, dome_warning) = (warning("/M/T"), warning("/Dome"));
    assert!(png_warning.contains("huge.png") && png_warning.contains(declares), "{:?}", scene.warnings);
    assert!(dome_warning.contains("huge.hdr") && dome_warning.contains(declares), "{:?}", scene.warnings);
    assert!(scene.textures.is_empty());

    // A caller's tighter budget applies to real files too.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("huge.png"), png_solid(40, 30)).unwrap();
    std::fs::write(dir.path().join("scene.usda"), stage.replace("@huge.hdr@", "@\"\"@")).unwrap();
    let tight = LoadOptions { max_texture_pixels: 1000, ..LoadOptions::default() };
    let scene = load(&dir.path().join("scene.usda"), &tight).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        scene.warnings.iter().any(|w| w.prim == "/M/T"
            && w.message.contains("image declares 40x30 = 1200 pixels, above the limit of 1000 pixels")),
        "{:?}",
        scene.warnings
    );
    let scene =
        load(&dir.path().join("scene.usda"), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.textures.len(), 1);
}

fn load_error(text: &str) -> UsdError {
    let dir = write(&[("scene.usda", text.as_bytes())]);
    let error = load(&dir.path().join("scene.usda"), &LoadOptions::default()).unwrap_err();
    assert!(error.to_string().contains("scene.usda"), "{error}");
    error
}

#[test]
fn nurbs_orders_are_bounded() {
    let error = load_error(
        r#"#usda 1.0
def NurbsCurves "C"
{
    int[] curveVertexCounts = [4]
    int[] order = [2147483647]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)]
}
"#,
    );
    assert_eq!(error.prim(), Some("/C"), "{error}");
    assert_eq!(error.attribute_name(), Some("order"), "{error}");
    assert!(error.to_string().contains("curve 0: order 2147483647 is above the limit of 64"), "{error}");
}

#[test]
fn render_resolutions_are_bounded() {
    let error = load_error(
        r#"#usda 1.0
(
    renderSettingsPrimPath = "/Render/Settings"
)
def Scope "Render"
{
    def RenderSettings "Settings"
    {
        uniform int2 resolution = (1, 2147483647)
    }
}
"#,
    );
    assert_eq!(error.prim(), Some("/Render/Settings"), "{error}");
    assert_eq!(error.attribute_name(), Some("resolution"), "{error}");
    assert!(
        error.to_string().contains("resolution 1x2147483647 is above the limit of 65535 per side"),
        "{error}"
    );
}

#[test]
fn a_camera_implying_a_huge_image_is_refused() {
    let error = load_error(
        r#"#usda 1.0
def Camera "Cam"
{
    float horizontalAperture = 36
    float verticalAperture = 192000
}
"#,
    );
    assert_eq!(error.prim(), Some("/Cam"), "{error}");
    assert_eq!(error.attribute_name(), Some("verticalAperture"), "{error}");
    assert!(
        error
            .to_string()
            .contains("verticalAperture 192000 with horizontalAperture 36 gives a 512x2730667 image"),
        "{error}"
    );
}

/// Fault isolation: one NaN point or out-of-range index is that mesh's problem, not the stage's.
const BAD_MESHES: &str = r#"#usda 1.0
def Mesh "Good"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
}
def Mesh "NotFinite"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (nan, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
}
def Mesh "OutOfRange"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 7]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
}
def Mesh "AlsoGood"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 2), (1, 0, 2), (0, 1, 2)]
}
"#;

#[test]
fn bad_meshes_are_all_named_and_skipped_when_lenient() {
    let dir = write(&[("scene.usda", BAD_MESHES.as_bytes())]);
    let root = dir.path().join("scene.usda");
    let error = load(&root, &LoadOptions::default()).unwrap_err();
    let text = error.to_string();
    let file = root.display().to_string();
    assert!(
        text.starts_with(&format!(
            "{file}: /NotFinite.points: 2 prims have bad data (--lenient skips them): "
        )),
        "{text}"
    );
    assert!(
        text.contains(&format!("{file}: /NotFinite.points: point 1 is not finite (NaN, 0, 0)")),
        "{text}"
    );
    assert!(
        text.contains(&format!("{file}: /OutOfRange.faceVertexIndices: index 7 out of range (3 points)")),
        "{text}"
    );

    let scene = load(&root, &LoadOptions { lenient: true, ..LoadOptions::default() })
        .unwrap_or_else(|e| panic!("{e}"));
    let meshes: Vec<&str> = scene.meshes.iter().map(|m| m.path.as_str()).collect();
    assert_eq!(meshes, ["/Good", "/AlsoGood"]);
    let warnings: Vec<(&str, &str)> =
        scene.warnings.iter().map(|w| (w.prim.as_str(), w.message.as_str())).collect();
    let bad: Vec<_> = warnings.iter().filter(|(p, _)| *p == "/NotFinite" || *p == "/OutOfRange").collect();
    assert_eq!(bad.len(), 2, "{warnings:?}");
    assert_eq!(
        *bad[0],
        (
            "/NotFinite",
            format!("Mesh skipped (--lenient): {file}: /NotFinite.points: point 1 is not finite (NaN, 0, 0)")
                .as_str()
        )
    );
    assert!(
        bad[1].1.ends_with("/OutOfRange.faceVertexIndices: index 7 out of range (3 points)"),
        "{warnings:?}"
    );
}

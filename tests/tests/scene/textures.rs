//! Textures end to end: PNGs written by the test → UsdShade networks → ingest (bake, program) → blob →
//! render, read back as pixel values.
//!
//! Most scenes look at an emissive card through an orthographic camera with no light, so a pixel reads
//! the texture's linear value exactly (no noise); the lit scenes state their analytic expectation.

use render::{render_image, RenderOptions};
use std::path::Path;

/// Writes an 8-bit RGBA PNG of `w × h` from rows given top to bottom.
fn png(dir: &Path, name: &str, w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4]) {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(texel(x, y)));
    img.save(dir.join(name)).expect("write png");
}

/// A stage with an orthographic camera at z = 5 looking down −Z whose frame is `width × height` scene
/// units centred on `(cx, cy)`, plus `body`.
fn ortho_stage(width: f32, height: f32, cx: f32, cy: f32, body: &str) -> String {
    format!(
        r#"#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
    upAxis = "Y"
)
def Xform "World"
{{
    def Camera "Cam"
    {{
        token projection = "orthographic"
        float horizontalAperture = {}
        float verticalAperture = {}
        double3 xformOp:translate = ({cx}, {cy}, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
{body}
}}
"#,
        width * 10.0,
        height * 10.0
    )
}

/// A card in the z = 0 plane spanning `[x0, x1] × [y0, y1]` with `st` spanning `[s0, s1] × [t0, t1]`,
/// bound to `/World/Looks/M`.
fn card(x: [f32; 2], y: [f32; 2], s: [f32; 2], t: [f32; 2]) -> String {
    format!(
        r#"    def Mesh "Card" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [({x0}, {y0}, 0), ({x1}, {y0}, 0), ({x1}, {y1}, 0), ({x0}, {y1}, 0)]
        texCoord2f[] primvars:st = [({s0}, {t0}), ({s1}, {t0}), ({s1}, {t1}), ({s0}, {t1})] (interpolation = "vertex")
        rel material:binding = </World/Looks/M>
    }}
"#,
        x0 = x[0],
        x1 = x[1],
        y0 = y[0],
        y1 = y[1],
        s0 = s[0],
        s1 = s[1],
        t0 = t[0],
        t1 = t[1]
    )
}

/// `/World/Looks/M`: a rough, IOR-1 PreviewSurface (pure Lambertian: a pixel under a white dome reads its
/// albedo) with `surface_inputs`, followed by the material's other `shaders` (their connections name
/// `/World/Looks/M/<shader>`).
fn lambert_material(surface_inputs: &str, shaders: &str) -> String {
    format!(
        r#"    def Scope "Looks"
    {{
        def Material "M"
        {{
            token outputs:surface.connect = </World/Looks/M/Surface.outputs:surface>
            def Shader "Surface"
            {{
                uniform token info:id = "UsdPreviewSurface"
                float inputs:ior = 1
                float inputs:roughness = 1
                {surface_inputs}
                token outputs:surface
            }}
{shaders}        }}
    }}
"#
    )
}

/// `/World/Looks/M`: [`lambert_material`] with `surface_inputs` (connections into `Tex`/`St`) and a
/// UsdUVTexture `Tex` reading `file` through a `st` primvar reader, with `tex_inputs` added.
fn material(surface_inputs: &str, file: &str, tex_inputs: &str) -> String {
    let shaders = format!(
        r#"            def Shader "Tex"
            {{
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = @{file}@
                float2 inputs:st.connect = </World/Looks/M/St.outputs:result>
                {tex_inputs}
                float3 outputs:rgb
                float outputs:r
                float outputs:a
            }}
            def Shader "St"
            {{
                uniform token info:id = "UsdPrimvarReader_float2"
                string inputs:varname = "st"
                float2 outputs:result
            }}
"#
    );
    lambert_material(surface_inputs, &shaders)
}

const EMISSIVE: &str = "color3f inputs:diffuseColor = (0, 0, 0)\n                color3f inputs:emissiveColor.connect = </World/Looks/M/Tex.outputs:rgb>";

struct Rendered {
    rgb: Vec<[f32; 3]>,
    alpha: Vec<f32>,
    width: usize,
    warnings: Vec<String>,
    stats: render::RenderStats,
}

impl Rendered {
    fn at(&self, x: usize, y: usize) -> [f32; 3] {
        self.rgb[y * self.width + x]
    }
}

fn ingest_and_render(dir: &Path, usda: &str, options: &RenderOptions) -> Rendered {
    let input = dir.join("scene.usda");
    std::fs::write(&input, usda).unwrap();
    let output = dir.join("scene.blob");
    let (_, report) =
        ingest::pipeline::ingest_file(&input, &output, &ingest::usd::LoadOptions::default()).expect("ingest");
    let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&output).unwrap());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let image = render_image(&view, options).expect("render");
    Rendered {
        rgb: image.beauty.iter().map(|p| [p[0], p[1], p[2]]).collect(),
        alpha: image.beauty.iter().map(|p| p[3]).collect(),
        width: image.width as usize,
        warnings: report.warnings,
        stats: image.stats,
    }
}

fn options(w: u32, h: u32, spp: u32) -> RenderOptions {
    RenderOptions { spp, resolution: Some([w, h]), threads: 2, ..RenderOptions::default() }
}

fn assert_rgb(v: [f32; 3], expected: [f32; 3], tol: f32, what: &str) {
    for c in 0..3 {
        assert!((v[c] - expected[c]).abs() <= tol, "{what}: reads {v:?}, expected {expected:?} ± {tol}");
    }
}

/// Four UDIM tiles 1001–1004 of solid red, green, blue, white on a 4 × 1 card: each quarter reads its
/// tile, every pixel pure (pixel edges fall on tile edges, and lookups never filter across a seam).
#[test]
fn udim_card_shows_its_four_tiles_in_order_without_seams() {
    let dir = tempfile::tempdir().unwrap();
    let colours = [[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [255, 255, 255, 255]];
    for (i, c) in colours.iter().enumerate() {
        // Tiles are 16×16 with a 1-texel darker border, so bilinear blending across a seam would show.
        png(dir.path(), &format!("tile.{}.png", 1001 + i), 16, 16, |_, _| *c);
    }
    let body =
        [card([0.0, 4.0], [0.0, 1.0], [0.0, 4.0], [0.0, 1.0]), material(EMISSIVE, "./tile.<UDIM>.png", "")]
            .join("\n");
    let r = ingest_and_render(dir.path(), &ortho_stage(4.0, 1.0, 2.0, 0.5, &body), &options(32, 8, 4));
    for x in 0..32 {
        let expected = colours[x / 8].map(|c| c as f32 / 255.0);
        for y in 0..8 {
            assert_rgb(r.at(x, y), [expected[0], expected[1], expected[2]], 1e-5, &format!("pixel {x},{y}"));
        }
    }
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
}

/// Tile 1003 absent: that quarter reads the texture's fallback, and ingest names the missing file.
#[test]
fn missing_udim_tile_reads_the_fallback_and_warns() {
    let dir = tempfile::tempdir().unwrap();
    for i in [1001, 1002, 1004] {
        png(dir.path(), &format!("tile.{i}.png"), 8, 8, |_, _| [255, 255, 255, 255]);
    }
    let body = [
        card([0.0, 4.0], [0.0, 1.0], [0.0, 4.0], [0.0, 1.0]),
        material(EMISSIVE, "./tile.<UDIM>.png", "float4 inputs:fallback = (1, 0, 1, 1)"),
    ]
    .join("\n");
    let r = ingest_and_render(dir.path(), &ortho_stage(4.0, 1.0, 2.0, 0.5, &body), &options(16, 4, 1));
    assert_rgb(r.at(1, 2), [1.0; 3], 1e-5, "tile 1001");
    assert_rgb(r.at(9, 2), [1.0, 0.0, 1.0], 1e-5, "missing tile 1003");
    assert_rgb(r.at(13, 2), [1.0; 3], 1e-5, "tile 1004");
    eprintln!("warnings: {:?}", r.warnings);
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("UDIM tile 1003") && w.contains("tile.1003.png") && w.contains("fallback")),
        "{:?}",
        r.warnings
    );
}

/// A missing plain file: a warning naming it, and the fallback everywhere (never an error).
#[test]
fn missing_texture_file_is_a_warning_and_reads_the_fallback() {
    let dir = tempfile::tempdir().unwrap();
    let body = [
        card([0.0, 1.0], [0.0, 1.0], [0.0, 1.0], [0.0, 1.0]),
        material(EMISSIVE, "./nowhere.png", "float4 inputs:fallback = (0.25, 0.5, 0.75, 1)"),
    ]
    .join("\n");
    let r = ingest_and_render(dir.path(), &ortho_stage(1.0, 1.0, 0.5, 0.5, &body), &options(4, 4, 1));
    assert_rgb(r.at(2, 2), [0.25, 0.5, 0.75], 1e-6, "fallback");
    assert!(
        r.warnings.iter().any(|w| w.contains("nowhere.png") && w.contains("not found")),
        "{:?}",
        r.warnings
    );
}

/// An 8 × 1 texture, left half black and right half white, on a card whose `s` runs −1…2: the interior
/// texels of each unit interval show what each wrap mode does outside [0, 1).
#[test]
fn wrap_modes_repeat_mirror_clamp_black() {
    let expected = |mode: &str, interval: i32, right_half: bool| -> f32 {
        let inside = if right_half { 1.0 } else { 0.0 };
        match (mode, interval) {
            (_, 0) | ("repeat", _) => inside,
            ("mirror", _) => 1.0 - inside,
            ("clamp", -1) => 0.0,
            ("clamp", _) => 1.0,
            _ => 0.0, // black
        }
    };
    for mode in ["repeat", "mirror", "clamp", "black"] {
        let dir = tempfile::tempdir().unwrap();
        png(dir.path(), "half.png", 8, 1, |x, _| if x < 4 { [0, 0, 0, 255] } else { [255, 255, 255, 255] });
        // wrapT clamp: the texture is one row, and black rows above and below would darken it.
        let wraps =
            format!("token inputs:wrapS = \"{mode}\"\n                token inputs:wrapT = \"clamp\"");
        let body = [
            card([-1.0, 2.0], [0.0, 1.0], [-1.0, 2.0], [0.25, 0.75]),
            material(EMISSIVE, "./half.png", &wraps),
        ]
        .join("\n");
        // 24 pixels across 3 units: one pixel per texel, pixel centres on texel centres.
        let r = ingest_and_render(dir.path(), &ortho_stage(3.0, 1.0, 0.5, 0.5, &body), &options(24, 2, 4));
        for interval in -1..=1 {
            for k in [1, 2, 5, 6] {
                let x = ((interval + 1) * 8 + k) as usize;
                let want = expected(mode, interval, k >= 4);
                assert_rgb(r.at(x, 1), [want; 3], 1e-3, &format!("{mode}: s interval {interval}, texel {k}"));
            }
        }
    }
}

/// sRGB decode end to end: a Lambertian card whose diffuse texture is sRGB 128 everywhere, under a white
/// dome of radiance 1, reads the linear value 0.2158605 (within 2% at 256 spp).
#[test]
fn srgb_texture_on_lambertian_card_under_white_dome() {
    let dir = tempfile::tempdir().unwrap();
    png(dir.path(), "grey.png", 4, 4, |_, _| [128, 128, 128, 255]);
    let body = [
        card([-1.0, 1.0], [-1.0, 1.0], [0.0, 1.0], [0.0, 1.0]),
        material("color3f inputs:diffuseColor.connect = </World/Looks/M/Tex.outputs:rgb>", "./grey.png", ""),
        "    def DomeLight \"Dome\"\n    {\n        float inputs:intensity = 1\n    }\n".to_string(),
    ]
    .join("\n");
    let r = ingest_and_render(dir.path(), &ortho_stage(1.0, 1.0, 0.0, 0.0, &body), &options(8, 8, 256));
    let mean: f32 = r.rgb.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).sum::<f32>() / r.rgb.len() as f32;
    eprintln!("sRGB 128 under a white dome: {mean:.6} (expected 0.2158605)");
    assert!((mean / 0.2158605 - 1.0).abs() < 0.02, "{mean}");
}

/// opacityThreshold cut-out: opacity from the texture's red channel (left half 0, right half 1), threshold
/// 0.5, on a black card under a white dome: the left half shows the dome (1), the right half is black.
#[test]
fn opacity_threshold_cut_out_lets_the_dome_through() {
    let dir = tempfile::tempdir().unwrap();
    png(dir.path(), "mask.png", 8, 8, |x, _| if x < 4 { [0, 0, 0, 255] } else { [255, 255, 255, 255] });
    let surface = "color3f inputs:diffuseColor = (0, 0, 0)\n                float inputs:opacity.connect = </World/Looks/M/Tex.outputs:r>\n                float inputs:opacityThreshold = 0.5";
    let body = [
        card([0.0, 1.0], [0.0, 1.0], [0.0, 1.0], [0.0, 1.0]),
        material(surface, "./mask.png", "token inputs:sourceColorSpace = \"raw\""),
        "    def DomeLight \"Dome\"\n    {\n        float inputs:intensity = 1\n    }\n".to_string(),
    ]
    .join("\n");
    let r = ingest_and_render(dir.path(), &ortho_stage(1.0, 1.0, 0.5, 0.5, &body), &options(8, 8, 16));
    for y in 0..8 {
        for x in [0, 1, 2] {
            assert_rgb(r.at(x, y), [1.0; 3], 1e-4, &format!("cut-out pixel {x},{y}"));
        }
        for x in [5, 6, 7] {
            assert_rgb(r.at(x, y), [0.0; 3], 1e-4, &format!("opaque pixel {x},{y}"));
        }
    }
}

/// Normal maps under a distant light from 45° (towards +x): a constant (0.5, 0.5, 1) map matches the
/// unmapped card; a constant map tilted by θ towards +x (the tangent, along +s) scales the Lambertian
/// radiance by n·l / cos 45°, n decoded from the stored 8-bit values (·2 − 1; 128 is 0.0039, a 0.3°
/// tilt, so even the "flat" map brightens the card by 0.39%).
#[test]
fn normal_map_tilts_shading_by_the_expected_cosine() {
    let render_with = |normal: Option<[u8; 3]>| -> f32 {
        let dir = tempfile::tempdir().unwrap();
        let surface = match normal {
            Some(n) => {
                png(dir.path(), "n.png", 4, 4, |_, _| [n[0], n[1], n[2], 255]);
                "color3f inputs:diffuseColor = (0.5, 0.5, 0.5)\n                normal3f inputs:normal.connect = </World/Looks/M/Tex.outputs:rgb>"
            }
            None => "color3f inputs:diffuseColor = (0.5, 0.5, 0.5)",
        };
        let sun = "    def DistantLight \"Sun\"\n    {\n        float inputs:intensity = 2\n        float inputs:angle = 0\n        float xformOp:rotateY = 45\n        uniform token[] xformOpOrder = [\"xformOp:rotateY\"]\n    }\n";
        let body = [
            card([-1.0, 1.0], [-1.0, 1.0], [0.0, 1.0], [0.0, 1.0]),
            material(surface, "./n.png", "token inputs:sourceColorSpace = \"raw\""),
            sun.to_string(),
        ]
        .join("\n");
        let r = ingest_and_render(dir.path(), &ortho_stage(1.0, 1.0, 0.0, 0.0, &body), &options(4, 4, 16));
        r.rgb.iter().map(|p| p[1]).sum::<f32>() / r.rgb.len() as f32
    };
    let plain = render_with(None);
    let flat = render_with(Some([128, 128, 255]));
    let tilted_bytes = [191u8, 128, 238];
    let tilted = render_with(Some(tilted_bytes));
    let ratio = |bytes: [u8; 3]| {
        let n = bytes.map(|b| b as f32 / 255.0 * 2.0 - 1.0);
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        (n[0] + n[2]) / len // (n · l) / cos 45° with l = (sin 45°, 0, cos 45°)
    };
    let n = tilted_bytes.map(|b| b as f32 / 255.0 * 2.0 - 1.0);
    let theta = n[0].atan2(n[2]);
    let expected = ratio(tilted_bytes);
    eprintln!(
        "normal map: plain {plain:.5}, flat map {flat:.5}, tilted {:.2}° map {tilted:.5}; ratio {:.5} expected {expected:.5}",
        theta.to_degrees(),
        tilted / plain
    );
    assert!(plain > 0.1);
    let expected_flat = ratio([128, 128, 255]);
    assert!((flat / plain / expected_flat - 1.0).abs() < 1e-3, "flat map {flat} vs plain {plain}");
    assert!((flat / plain - 1.0).abs() < 5e-3, "flat map {flat} vs plain {plain}");
    assert!((tilted / plain / expected - 1.0).abs() < 5e-3, "ratio {} expected {expected}", tilted / plain);
}

/// Texture statistics: the bytes touched never exceed the texel bytes in the blob, and the thread count
/// does not change a textured image.
#[test]
fn texture_stats_and_thread_determinism() {
    let dir = tempfile::tempdir().unwrap();
    png(dir.path(), "check.png", 64, 64, |x, y| {
        if (x / 8 + y / 8) % 2 == 0 {
            [200, 30, 30, 255]
        } else {
            [20, 20, 200, 255]
        }
    });
    let body = [
        card([-1.0, 1.0], [-1.0, 1.0], [0.0, 3.0], [0.0, 3.0]),
        material("color3f inputs:diffuseColor.connect = </World/Looks/M/Tex.outputs:rgb>", "./check.png", ""),
        "    def DomeLight \"Dome\"\n    {\n        float inputs:intensity = 1\n    }\n".to_string(),
    ]
    .join("\n");
    let usda = ortho_stage(2.0, 2.0, 0.0, 0.0, &body);
    let mut o = options(16, 16, 4);
    o.texture_stats = true;
    let one = ingest_and_render(dir.path(), &usda, &RenderOptions { threads: 1, ..o.clone() });
    let two = ingest_and_render(dir.path(), &usda, &o);
    assert_eq!(one.rgb, two.rgb, "1 and 2 threads differ");
    eprintln!(
        "texture bytes: {} touched of {}",
        two.stats.texture_bytes_touched, two.stats.texture_bytes_total
    );
    assert!(two.stats.texture_bytes_total > 0);
    assert!(
        two.stats.texture_bytes_touched > 0
            && two.stats.texture_bytes_touched <= two.stats.texture_bytes_total
    );
}

/// The wavefront integrator equals the scalar one on a textured, lit, cut-out, normal-mapped card seen
/// at an angle (texture filtering with ray-cone footprints, sort keys with mip levels and uvs).
#[test]
fn wavefront_equals_scalar_on_a_textured_card() {
    let dir = tempfile::tempdir().unwrap();
    png(dir.path(), "noise.png", 64, 64, |x, y| {
        let h = (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)).wrapping_mul(2_654_435_761);
        [(h >> 24) as u8, (h >> 16) as u8, (h >> 8) as u8, if (x / 8 + y / 8) % 3 == 0 { 0 } else { 255 }]
    });
    let surface = "color3f inputs:diffuseColor.connect = </World/Looks/M/Tex.outputs:rgb>\n                float inputs:opacity.connect = </World/Looks/M/Tex.outputs:a>\n                float inputs:opacityThreshold = 0.5";
    let body = [
        card([-1.0, 1.0], [-1.0, 1.0], [0.0, 3.0], [0.0, 3.0]),
        material(surface, "./noise.png", "token inputs:wrapS = \"repeat\"\n                token inputs:wrapT = \"repeat\"\n                float outputs:a"),
        "    def DomeLight \"Dome\"\n    {\n        float inputs:intensity = 1\n    }\n".to_string(),
        "    def DistantLight \"Sun\"\n    {\n        float inputs:intensity = 2\n    }\n".to_string(),
    ]
    .join("\n");
    let usda = ortho_stage(2.5, 2.5, 0.0, 0.0, &body);
    let input = dir.path().join("scene.usda");
    std::fs::write(&input, usda).unwrap();
    let output = dir.path().join("scene.blob");
    ingest::pipeline::ingest_file(&input, &output, &ingest::usd::LoadOptions::default()).expect("ingest");
    let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&output).unwrap());
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let opts = |integrator| RenderOptions {
        spp: 16,
        resolution: Some([40, 40]),
        tile_size: 8,
        integrator,
        ..options(40, 40, 16)
    };
    let a = render_image(&view, &opts(render::Integrator::Scalar)).unwrap();
    let b = render_image(&view, &opts(render::Integrator::Wavefront)).unwrap();
    let (mut max, mut sum) = (0.0f32, 0.0f64);
    for (x, y) in a.beauty.iter().flatten().zip(b.beauty.iter().flatten()) {
        max = max.max((x - y).abs());
        sum += (x - y).abs() as f64;
    }
    let mean = sum / (a.beauty.len() * 4) as f64;
    eprintln!("textured card: wavefront vs scalar: max abs diff {max:e}, mean {mean:e}");
    assert!(max <= 1e-5, "{max}");
    assert_eq!(a.albedo, b.albedo);
    assert_eq!(a.stats.rays, b.stats.rays);
    let lum: Vec<f32> = a.beauty.iter().map(|p| p[0] + p[1] + p[2]).collect();
    assert!(lum.iter().any(|&l| l > 0.05) && lum.iter().any(|&l| l < lum[0] * 0.5 || l > lum[0] * 2.0));
}

// ---- Primvar readers ----------------------------------------------------------------------------------

const WHITE_DOME: &str = "    def DomeLight \"Dome\"\n    {\n        float inputs:intensity = 1\n    }\n";

/// `/World/Looks/M`: a black [`lambert_material`] whose `input` is connected to a `reader`
/// (`UsdPrimvarReader_*`) of `varname`, with the reader's `extra` inputs.
fn primvar_material(input: &str, reader: &str, varname: &str, extra: &str) -> String {
    let (ty, out) = match reader {
        "UsdPrimvarReader_float" | "UsdPrimvarReader_int" => ("float", "float"),
        _ => ("color3f", "float3"),
    };
    let surface_inputs = format!(
        "color3f inputs:diffuseColor = (0, 0, 0)\n                \
         {ty} inputs:{input}.connect = </World/Looks/M/Reader.outputs:result>"
    );
    let shaders = format!(
        r#"            def Shader "Reader"
            {{
                uniform token info:id = "{reader}"
                string inputs:varname = "{varname}"
                {extra}
                {out} outputs:result
            }}
"#
    );
    lambert_material(&surface_inputs, &shaders)
}

/// Two quads side by side spanning `[-1, 1] × [-1, 1]` (shared edge at x = 0), corners counter-clockwise
/// from the bottom left, with `primvars` authored on the mesh and a binding to `/World/Looks/M` if `bound`.
fn two_quads(primvars: &str, bound: bool) -> String {
    let binding = if bound { "rel material:binding = </World/Looks/M>" } else { "" };
    format!(
        r#"    def Mesh "Card" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4, 4]
        int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]
        point3f[] points = [(-1, -1, 0), (0, -1, 0), (1, -1, 0), (-1, 1, 0), (0, 1, 0), (1, 1, 0)]
        {primvars}
        {binding}
    }}
"#
    )
}

/// The mean over pixel column `x` of a 2 × 2-unit frame rendered `w × h`.
fn column_mean(r: &Rendered, x: usize, h: usize) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    for y in 0..h {
        let p = r.at(x, y);
        (0..3).for_each(|c| sum[c] += p[c] / h as f32);
    }
    sum
}

/// Asserts `v` within 1% of `expected` (relative, per channel; absolute 0.01 where expected is 0).
fn assert_within_1_percent(v: [f32; 3], expected: [f32; 3], what: &str) {
    for c in 0..3 {
        let tol = 0.01 * expected[c].max(1.0);
        assert!((v[c] - expected[c]).abs() <= tol, "{what}: reads {v:?}, expected {expected:?} within 1%");
    }
}

/// Renders a 2 × 2 frame of `body` under the white dome, `w` pixels square, 256 spp.
fn render_card(body: &str, w: u32) -> Rendered {
    let dir = tempfile::tempdir().unwrap();
    let usda = ortho_stage(2.0, 2.0, 0.0, 0.0, &format!("{body}\n{WHITE_DOME}"));
    ingest_and_render(dir.path(), &usda, &options(w, w, 256))
}

/// A vertex displayColor red at x = −1 and green at x = +1 (points at x = 0 halfway), read by a
/// UsdPrimvarReader_float3 into diffuseColor: under the white dome each column reads the albedo
/// interpolated at its centre (the mean of a linear ramp over a pixel is its centre value), so the
/// middle column of a 9-wide image reads (0.5, 0.5, 0) and the others follow the ramp, within 1%.
#[test]
fn vertex_display_color_is_interpolated_across_the_card() {
    let primvars = r#"color3f[] primvars:displayColor = [(1, 0, 0), (0.5, 0.5, 0), (0, 1, 0), (1, 0, 0), (0.5, 0.5, 0), (0, 1, 0)] (interpolation = "vertex")"#;
    let body = [
        two_quads(primvars, true),
        primvar_material("diffuseColor", "UsdPrimvarReader_float3", "displayColor", ""),
    ]
    .join("\n");
    let r = render_card(&body, 9);
    for x in 0..9 {
        let t = (x as f32 + 0.5) / 9.0;
        let v = column_mean(&r, x, 9);
        eprintln!("vertex displayColor column {x}: {v:?} (expected ({:.4}, {:.4}, 0))", 1.0 - t, t);
        assert_within_1_percent(v, [1.0 - t, t, 0.0], &format!("column {x}"));
    }
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
}

/// faceVarying (indexed): the left quad ramps red → green, the right quad is blue at every corner, so
/// the points on the shared edge carry different values per face, which only per-corner storage keeps.
#[test]
fn face_varying_display_color_keeps_per_face_corners() {
    let primvars = r#"color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0), (0, 0, 1)] (interpolation = "faceVarying")
        int[] primvars:displayColor:indices = [0, 1, 1, 0, 2, 2, 2, 2]"#;
    let body = [
        two_quads(primvars, true),
        primvar_material("diffuseColor", "UsdPrimvarReader_float3", "displayColor", ""),
    ]
    .join("\n");
    let r = render_card(&body, 8);
    for x in 0..4 {
        let t = (x as f32 + 0.5) / 4.0;
        assert_within_1_percent(column_mean(&r, x, 8), [1.0 - t, t, 0.0], &format!("left column {x}"));
    }
    for x in 4..8 {
        assert_within_1_percent(column_mean(&r, x, 8), [0.0, 0.0, 1.0], &format!("right column {x}"));
    }
}

/// uniform: one colour per quad, no bleeding across the shared edge (pixel edges fall on it).
#[test]
fn uniform_display_color_is_one_value_per_face() {
    let primvars =
        r#"color3f[] primvars:displayColor = [(0.8, 0.1, 0.1), (0.1, 0.1, 0.8)] (interpolation = "uniform")"#;
    let body = [
        two_quads(primvars, true),
        primvar_material("diffuseColor", "UsdPrimvarReader_float3", "displayColor", ""),
    ]
    .join("\n");
    let r = render_card(&body, 8);
    for x in 0..8 {
        let expected = if x < 4 { [0.8, 0.1, 0.1] } else { [0.1, 0.1, 0.8] };
        assert_within_1_percent(column_mean(&r, x, 8), expected, &format!("column {x}"));
    }
}

/// A mesh without a bound material renders with its displayColor (USD's fallback), interpolated when
/// it varies (the fallback material is not Lambertian, so each column is compared with a card whose
/// constant displayColor is the column's expected colour); a bound reader of a primvar the mesh lacks returns its `inputs:fallback`; a constant
/// primvar authored on an ancestor is inherited.
#[test]
fn unbound_display_color_missing_primvar_fallback_and_inheritance() {
    // Unbound, vertex displayColor: the same ramp as the bound case.
    let primvars = r#"color3f[] primvars:displayColor = [(1, 0, 0), (0.5, 0.5, 0), (0, 1, 0), (1, 0, 0), (0.5, 0.5, 0), (0, 1, 0)] (interpolation = "vertex")"#;
    let r = render_card(&two_quads(primvars, false), 9);
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    for x in [0, 4, 7] {
        let t = (x as f32 + 0.5) / 9.0;
        let constant = format!("color3f[] primvars:displayColor = [({}, {t}, 0)]", 1.0 - t);
        let c = render_card(&two_quads(&constant, false), 9);
        let (v, expected) = (column_mean(&r, x, 9), column_mean(&c, x, 9));
        eprintln!("unbound column {x}: {v:?}, constant card {expected:?}");
        assert!(expected[0] + expected[1] > 0.5, "{expected:?}");
        assert_within_1_percent(v, expected, &format!("unbound column {x}"));
    }

    // Bound reader of a primvar the mesh does not carry: the fallback.
    let body = [
        two_quads("", true),
        primvar_material(
            "diffuseColor",
            "UsdPrimvarReader_float3",
            "tint",
            "float3 inputs:fallback = (0.25, 0.5, 0.75)",
        ),
    ]
    .join("\n");
    let r = render_card(&body, 4);
    assert_within_1_percent(column_mean(&r, 1, 4), [0.25, 0.5, 0.75], "fallback");

    // Inherited: `tint` authored (constant) on the parent Xform of the mesh.
    let body = format!(
        "    def Xform \"Group\"\n    {{\n        color3f primvars:tint = (0.6, 0.3, 0.1) (interpolation = \"constant\")\n{}\n    }}\n{}",
        two_quads("", true),
        primvar_material("diffuseColor", "UsdPrimvarReader_float3", "tint", "float3 inputs:fallback = (1, 1, 1)"),
    );
    let r = render_card(&body, 4);
    assert_within_1_percent(column_mean(&r, 2, 4), [0.6, 0.3, 0.1], "inherited");
}

/// UsdPrimvarReader_float (a vertex `coverage` ramp 0 → 1) and UsdPrimvarReader_int (a uniform `solid`
/// of 0 and 1) drive `opacity` of a black card: a pixel reads the dome through the card, 1 − opacity.
#[test]
fn float_and_int_readers_drive_opacity() {
    let float = r#"float[] primvars:coverage = [0, 0.5, 1, 0, 0.5, 1] (interpolation = "vertex")"#;
    let body =
        [two_quads(float, true), primvar_material("opacity", "UsdPrimvarReader_float", "coverage", "")]
            .join("\n");
    let r = render_card(&body, 9);
    for x in [0, 4, 8] {
        let t = (x as f32 + 0.5) / 9.0;
        assert_within_1_percent(column_mean(&r, x, 9), [1.0 - t; 3], &format!("float column {x}"));
    }
    let int = r#"int[] primvars:solid = [0, 1] (interpolation = "uniform")"#;
    let body =
        [two_quads(int, true), primvar_material("opacity", "UsdPrimvarReader_int", "solid", "")].join("\n");
    let r = render_card(&body, 4);
    assert_within_1_percent(column_mean(&r, 0, 4), [1.0; 3], "int 0: transparent");
    assert_within_1_percent(column_mean(&r, 3, 4), [0.0; 3], "int 1: opaque");
}

/// A string primvar reader cannot drive a shading input: a warning, and its fallback.
#[test]
fn string_reader_reads_its_fallback_with_a_warning() {
    let body = [
        two_quads(r#"string primvars:label = "x" (interpolation = "constant")"#, true),
        primvar_material(
            "diffuseColor",
            "UsdPrimvarReader_string",
            "label",
            "float3 inputs:fallback = (0.2, 0.4, 0.6)",
        ),
    ]
    .join("\n");
    let r = render_card(&body, 4);
    assert_within_1_percent(column_mean(&r, 1, 4), [0.2, 0.4, 0.6], "string fallback");
    assert!(r.warnings.iter().any(|w| w.contains("UsdPrimvarReader_string")), "{:?}", r.warnings);
}

/// The Utah teapot of usd-wg/assets (copied to `tests/assets/teapot`), whose Ceramic material drives
/// diffuseColor from a UsdPrimvarReader_float3 of the constant displayColor authored per shading
/// variant, under a white dome: the teapot's pixels are that colour. Specular reflection of the dome
/// adds the same grey to every channel, so `(G − B) / (R − B)` is the authored ratio (interreflection
/// between lid, body and handle raises it a little).
#[test]
fn teapot_ceramic_variants_render_their_display_color() {
    let teapot = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/teapot/full_assets/Teapot/Teapot.usd");
    for (variant, color) in
        [("CeramicLimeGreen", [0.325f32, 0.825, 0.0]), ("CeramicBlue", [0.013679987, 0.19873393, 0.912])]
    {
        let dir = tempfile::tempdir().unwrap();
        // The default variant is CeramicLimeGreen; selecting it explicitly is a no-op.
        let usda = format!(
            "#usda 1.0\n(\n    defaultPrim = \"World\"\n    upAxis = \"Y\"\n)\ndef Xform \"World\"\n{{\n    def \"Teapot\" (\n        prepend references = @{}@\n        variants = {{ string shadingVariant = \"{variant}\" }}\n    )\n    {{\n    }}\n{WHITE_DOME}}}\n",
            teapot.display()
        );
        let r = ingest_and_render(dir.path(), &usda, &options(64, 48, 64));
        let covered: Vec<[f32; 3]> =
            r.rgb.iter().zip(&r.alpha).filter(|(_, &a)| a > 0.99).map(|(p, _)| *p).collect();
        assert!(covered.len() > 200, "teapot covers {} pixels", covered.len());
        let n = covered.len() as f32;
        let mean: [f32; 3] = std::array::from_fn(|c| covered.iter().map(|p| p[c]).sum::<f32>() / n);
        eprintln!(
            "teapot {variant}: mean colour {mean:?} over {} pixels (authored {color:?})",
            covered.len()
        );
        // Channels ordered as authored, and the colour ratio within 10% (specular grey cancels).
        let order = |v: [f32; 3]| {
            let mut i = [0, 1, 2];
            i.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
            i
        };
        assert_eq!(order(mean), order(color), "{variant}: {mean:?}");
        let [lo, mid, hi] = order(color);
        let ratio = (mean[hi] - mean[lo]) / (mean[mid] - mean[lo]);
        let expected = (color[hi] - color[lo]) / (color[mid] - color[lo]);
        assert!((ratio / expected - 1.0).abs() < 0.1, "{variant}: ratio {ratio}, authored {expected}");
        assert!(r.warnings.iter().all(|w| !w.contains("primvar")), "{:?}", r.warnings);
    }
}

// ---- Textures inside .usdz packages ------------------------------------------------------------------

/// Writes a USDZ package (stored, 64-byte-aligned entries, root layer first) at `path`.
fn usdz(path: &Path, entries: &[(&str, Vec<u8>)]) {
    let mut archive = openusd::usdz::ArchiveWriter::create(path).expect("create usdz");
    for (name, bytes) in entries {
        archive.add_layer(name, bytes).expect("add entry");
    }
    archive.finish().expect("finish usdz");
}

/// The bytes of a solid `w × h` RGBA PNG.
fn png_bytes(w: u32, h: u32, rgba: [u8; 4]) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    png(dir.path(), "t.png", w, h, |_, _| rgba);
    std::fs::read(dir.path().join("t.png")).unwrap()
}

/// 8-bit sRGB → linear, the exact curve.
fn srgb(code: u8) -> f32 {
    let c = code as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// An emissive card whose texture lives inside a `.usdz`: referenced from the package's own layer as
/// `@textures/a.png@` and `@./textures/a.png@`, and from a layer outside the package as
/// `@pkg.usdz[textures/a.png]@`. Each reads the texel value (sRGB-decoded) without extracting anything,
/// and no warning; a texture missing from the package is a warning naming the packaged path.
#[test]
fn usdz_textures_resolve_inside_the_package() {
    let colour = [200u8, 100, 50, 255];
    let expected = [srgb(200), srgb(100), srgb(50)];
    let body = |file: &str| {
        ortho_stage(
            2.0,
            2.0,
            0.0,
            0.0,
            &[card([-1.0, 1.0], [-1.0, 1.0], [0.0, 1.0], [0.0, 1.0]), material(EMISSIVE, file, "")]
                .join("\n"),
        )
    };
    let render_root = |root: &Path| {
        let dir = tempfile::tempdir().unwrap();
        let output = dir.path().join("scene.blob");
        let (_, report) = ingest::pipeline::ingest_file(root, &output, &ingest::usd::LoadOptions::default())
            .expect("ingest");
        let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&output).unwrap());
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let image = render_image(&view, &options(4, 4, 1)).expect("render");
        (image.beauty.iter().map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>(), report.warnings)
    };
    let dir = tempfile::tempdir().unwrap();
    for file in ["textures/a.png", "./textures/a.png"] {
        let package = dir.path().join("inside.usdz");
        usdz(
            &package,
            &[("scene.usda", body(file).into_bytes()), ("textures/a.png", png_bytes(4, 4, colour))],
        );
        let (pixels, warnings) = render_root(&package);
        assert!(warnings.is_empty(), "{file}: {warnings:?}");
        for p in &pixels {
            assert_rgb(*p, expected, 1e-5, &format!("@{file}@ inside the package"));
        }
    }
    // From outside: a package-relative asset path into a package that holds only the texture.
    let package = dir.path().join("pkg.usdz");
    usdz(&package, &[("textures/a.png", png_bytes(2, 2, colour))]);
    let outside = write_text(dir.path(), "outside.usda", &body("pkg.usdz[textures/a.png]"));
    let (pixels, warnings) = render_root(&outside);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_rgb(pixels[5], expected, 1e-5, "@pkg.usdz[textures/a.png]@");
    // Missing from the package (and not beside it): the fallback, and a warning naming the entry.
    let package = dir.path().join("missing.usdz");
    usdz(&package, &[("scene.usda", body("textures/b.png").into_bytes())]);
    let (pixels, warnings) = render_root(&package);
    assert_rgb(pixels[5], [0.0; 3], 0.0, "missing packaged texture");
    eprintln!("missing packaged texture: {warnings:?}");
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("missing.usdz[textures/b.png]") && w.contains("not found in the package")),
        "{warnings:?}"
    );
}

fn write_text(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

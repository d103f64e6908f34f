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

/// `/World/Looks/M`: a PreviewSurface with `surface_inputs` (connections into `Tex`/`St`) and a
/// UsdUVTexture `Tex` reading `file` through a `st` primvar reader, with `tex_inputs` added.
fn material(surface_inputs: &str, file: &str, tex_inputs: &str) -> String {
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
            def Shader "Tex"
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
        }}
    }}
"#
    )
}

const EMISSIVE: &str = "color3f inputs:diffuseColor = (0, 0, 0)\n                color3f inputs:emissiveColor.connect = </World/Looks/M/Tex.outputs:rgb>";

struct Rendered {
    rgb: Vec<[f32; 3]>,
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

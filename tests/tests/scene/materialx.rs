//! MaterialX looks end to end: the Open Chess Set pawn's `.mtlx` look (`tests/assets/open_chess_set`)
//! referenced from USD, ingested and rendered; the albedo AOV reads the base colour the document
//! authors.

use render::{render_image, RenderOptions};
use std::path::{Path, PathBuf};

fn pawn() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/open_chess_set/full_assets/OpenChessSet/assets/Pawn")
        .canonicalize()
        .expect("the pawn test asset")
}

/// The sRGB transfer function inverted (what the `srgb_texture` colour space decodes).
fn linear(c: u8) -> f64 {
    let c = c as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The mean diffuse albedo of a metallic-workflow surface textured with `base` (sRGB) and
/// `metallic` (raw), as a magnified render sees it: `base · (1 − metallic)` with each texture
/// interpolated bilinearly (texel centres at `(i + ½) / size`, repeat wrap), averaged over an
/// `n × n` grid of points. (The product of the interpolated textures is what a pixel reads; the
/// mean of the per-texel products differs from it by the textures' correlation, 3 % on the black
/// pawn.)
fn mean_albedo(base: &Path, metallic: &Path, n: u32) -> [f64; 3] {
    let base = image::open(base).expect("base colour texture").to_rgb8();
    let metal = image::open(metallic).expect("metallic texture").to_luma8();
    let (w, h) = base.dimensions();
    assert_eq!((w, h), metal.dimensions());
    let bilinear = |texel: &dyn Fn(u32, u32) -> f64, u: f64, v: f64| {
        let (x, y) = (u * w as f64 - 0.5, v * h as f64 - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: f64, j: f64| {
            // Rows run bottom-up in texture space: t = 0 is the image's last row.
            let (i, j) = (i.rem_euclid(w as f64) as u32, j.rem_euclid(h as f64) as u32);
            texel(i, h - 1 - j)
        };
        (at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx) * (1.0 - fy)
            + (at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx) * fy
    };
    let mut sum = [0.0; 3];
    for j in 0..n {
        for i in 0..n {
            let (u, v) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let keep = 1.0 - bilinear(&|x, y| metal.get_pixel(x, y)[0] as f64 / 255.0, u, v);
            for (c, total) in sum.iter_mut().enumerate() {
                *total += bilinear(&|x, y| linear(base.get_pixel(x, y)[c]), u, v) * keep;
            }
        }
    }
    sum.map(|s| s / (n * n) as f64)
}

/// Two unit cards side by side, each with `st` over [0, 1]², bound to the pawn's white and black
/// body materials from `Pawn_mat.mtlx`, filling an orthographic frame magnified 4× (256 pixels
/// across a 64-texel texture): each card's pixels average its textures over the whole image.
#[test]
fn chess_pawn_albedo_reads_the_mtlx_base_colour() {
    let card = |name: &str, x0: f32, material: &str| {
        format!(
            r#"    def Mesh "{name}" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [({x0}, 0, 0), ({x1}, 0, 0), ({x1}, 1, 0), ({x0}, 1, 0)]
        texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
        rel material:binding = </World/Looks/{material}>
    }}
"#,
            x1 = x0 + 1.0
        )
    };
    let usda = format!(
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
        float horizontalAperture = 20
        float verticalAperture = 10
        double3 xformOp:translate = (1, 0.5, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }}
    def DomeLight "Sky" {{}}
    def Scope "Looks" (references = @{mtlx}@</MaterialX/Materials>) {{}}
{white}{black}}}
"#,
        mtlx = pawn().join("Pawn_mat.mtlx").display(),
        white = card("White", 0.0, "M_Pawn_Body_W"),
        black = card("Black", 1.0, "M_Pawn_Body_B"),
    );
    let dir = tempfile::tempdir().unwrap();
    let bytes = scene_tests::ingest_text(dir.path(), &usda);
    let view = blob::SceneView::parse(&bytes).expect("valid blob");
    let options =
        RenderOptions { spp: 4, resolution: Some([512, 256]), threads: 2, ..RenderOptions::default() };
    let image = render_image(&view, &options).expect("render");
    let width = image.width as usize;
    let white = scene_tests::mean_where(&image.albedo, width, |x, _| x < 256);
    let black = scene_tests::mean_where(&image.albedo, width, |x, _| x >= 256);
    let tex = pawn().join("tex");
    let metallic = tex.join("pawn_shared_metallic.jpg");
    for (what, got, file) in
        [("white", white, "pawn_white_base_color.jpg"), ("black", black, "pawn_black_base_color.jpg")]
    {
        let want = mean_albedo(&tex.join(file), &metallic, 256);
        for c in 0..3 {
            let error = (got[c] as f64 - want[c]).abs() / want[c];
            assert!(
                error <= 0.02,
                "{what} pawn albedo {got:?}, the texture's mean {want:?}: {error:.4} off in channel {c}"
            );
        }
    }
    // The white pawn is lighter than the black one by far, not one grey.
    assert!(white[0] > 2.5 * black[0], "white {white:?} against black {black:?}");
}

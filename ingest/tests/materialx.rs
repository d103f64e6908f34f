//! MaterialX looks read at ingest: `.mtlx` documents referenced from USD (the Open Chess Set's
//! pawn), inline UsdShade networks of `ND_*` shaders, and the standard_surface / open_pbr_surface
//! mappings onto the renderer's UsdPreviewSurface inputs.

use std::path::{Path, PathBuf};

use ingest::scene::{MathOp, Scene, ShaderNode, ShadingInput};
use ingest::usd::{load, LoadOptions};
use ingest::Material;

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets/open_chess_set")
}

fn pawn_texture(name: &str) -> String {
    assets()
        .join("full_assets/OpenChessSet/assets/Pawn/tex")
        .join(name)
        .canonicalize()
        .unwrap()
        .display()
        .to_string()
}

fn material<'s>(scene: &'s Scene, path: &str) -> &'s Material {
    scene.materials.iter().find(|m| m.path == path).unwrap_or_else(|| {
        panic!("no material {path}: {:?}", scene.materials.iter().map(|m| &m.path).collect::<Vec<_>>())
    })
}

/// The node writing register `r` last before the program's end.
fn writer(program: &[ShaderNode], r: u32) -> &ShaderNode {
    program
        .iter()
        .rev()
        .find(|n| match n {
            ShaderNode::Const { dst, .. }
            | ShaderNode::PrimvarUv { dst, .. }
            | ShaderNode::Primvar { dst, .. }
            | ShaderNode::Transform2d { dst, .. }
            | ShaderNode::Texture { dst, .. }
            | ShaderNode::Math { dst, .. } => *dst == r,
            ShaderNode::Output { .. } => false,
        })
        .unwrap_or_else(|| panic!("no writer of register {r} in {program:?}"))
}

/// The node an input's output op reads.
fn source_of(m: &Material, input: ShadingInput) -> &ShaderNode {
    let src = m
        .program
        .iter()
        .find_map(|n| match n {
            ShaderNode::Output { input: i, src, .. } if *i == input => Some(*src),
            _ => None,
        })
        .unwrap_or_else(|| panic!("{}: {input:?} is not driven by the program {:?}", m.path, m.program));
    writer(&m.program, src)
}

/// The file and colour space of the texture an input reads directly.
fn texture_of(scene: &Scene, m: &Material, input: ShadingInput) -> (String, texture::ColorSpace) {
    match source_of(m, input) {
        ShaderNode::Texture { texture: Some(t), .. } => {
            let t = &scene.textures[*t as usize];
            (t.path.file_name().unwrap().to_string_lossy().into_owned(), t.color_space)
        }
        other => panic!("{}: {input:?} reads {other:?}, not a baked texture", m.path),
    }
}

#[test]
fn chess_pawn_materials_read_their_authored_textures() {
    let scene = load(&assets().join("pawns.usda"), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let white = material(&scene, "/Pawns/White/Materials/M_Pawn_Body_W");
    let black = material(&scene, "/Pawns/Black/Materials/M_Pawn_Body_B");
    use texture::ColorSpace::{Raw, Srgb};
    assert_eq!(
        texture_of(&scene, white, ShadingInput::DiffuseColor),
        ("pawn_white_base_color.jpg".into(), Srgb)
    );
    assert_eq!(
        texture_of(&scene, black, ShadingInput::DiffuseColor),
        ("pawn_black_base_color.jpg".into(), Srgb)
    );
    for m in [white, black] {
        assert_eq!(m.look.surface_model, "standard_surface");
        assert_eq!(m.look.node_categories, ["image", "normalmap"]);
        assert_eq!(texture_of(&scene, m, ShadingInput::Roughness), ("pawn_shared_roughness.jpg".into(), Raw));
        assert_eq!(texture_of(&scene, m, ShadingInput::Metallic), ("pawn_shared_metallic.jpg".into(), Raw));
        // normalmap(image): 2·texel − 1 in tangent space.
        match source_of(m, ShadingInput::Normal) {
            ShaderNode::Math { op: MathOp::NormalMap, srcs, .. } => {
                assert!(matches!(writer(&m.program, srcs[0]), ShaderNode::Texture { .. }));
            }
            other => panic!("normal reads {other:?}"),
        }
    }
    // The glass tops: transmission 1 is clear glass of specular_IOR (the default 1.5).
    let top = material(&scene, "/Pawns/White/Materials/M_Pawn_Top_W");
    assert_eq!((top.opacity, top.opacity_threshold, top.ior), (0.0, 0.0, 1.5));
    assert_eq!(top.diffuse_color, glam::Vec3::ONE, "base_color 1 × base 1");
    // Each mesh is bound to its variant's materials.
    let bound = |mesh: &str| {
        let m = scene.meshes.iter().find(|m| m.path == mesh).unwrap_or_else(|| panic!("no mesh {mesh}"));
        scene.materials[m.triangle_materials[0] as usize].path.clone()
    };
    assert_eq!(bound("/Pawns/White/Geom_Body/Render"), "/Pawns/White/Materials/M_Pawn_Body_W");
    assert_eq!(bound("/Pawns/Black/Geom_Body/Render"), "/Pawns/Black/Materials/M_Pawn_Body_B");
}

/// A shader-ball-style look: an `ND_*` network with texture reads, channel picks, conversions and
/// arithmetic, written inline in USD and as a `.mtlx` document.
fn shader_ball_usda(image: &str) -> String {
    format!(
        r#"#usda 1.0
def Mesh "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Looks/Inline>
}}
def Mesh "Ball2" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Looks/FromMtlx/M_Look>
}}
def Scope "Looks"
{{
    def Scope "FromMtlx" (references = @./look.mtlx@</MaterialX/Materials>) {{}}
    def Material "Inline"
    {{
        token outputs:mtlx:surface.connect = </Looks/Inline/Net.outputs:out>
        def NodeGraph "Net"
        {{
            token outputs:out.connect = </Looks/Inline/Net/Surface.outputs:out>
            def Shader "Surface"
            {{
                uniform token info:id = "ND_standard_surface_surfaceshader"
                float inputs:base = 0.9
                color3f inputs:base_color.connect = </Looks/Inline/Net/Tint.outputs:out>
                float inputs:specular_roughness.connect = </Looks/Inline/Net/Rough.outputs:out>
                float inputs:emission.connect = </Looks/Inline/Net/Extract.outputs:out>
                color3f inputs:emission_color.connect = </Looks/Inline/Net/Convert.outputs:out>
                float inputs:coat = 0.5
                token outputs:out
            }}
            def Shader "Uv"
            {{
                uniform token info:id = "ND_texcoord_vector2"
                float2 outputs:out
            }}
            def Shader "Place"
            {{
                uniform token info:id = "ND_place2d_vector2"
                float2 inputs:texcoord.connect = </Looks/Inline/Net/Uv.outputs:out>
                float2 inputs:scale = (0.5, 0.25)
                float2 inputs:offset = (0.1, 0)
                float2 outputs:out
            }}
            def Shader "Albedo"
            {{
                uniform token info:id = "ND_image_color3"
                asset inputs:file = @{image}@ (colorSpace = "srgb_texture")
                float2 inputs:texcoord.connect = </Looks/Inline/Net/Place.outputs:out>
                color3f outputs:out
            }}
            def Shader "Tint"
            {{
                uniform token info:id = "ND_multiply_color3FA"
                color3f inputs:in1.connect = </Looks/Inline/Net/Albedo.outputs:out>
                float inputs:in2 = 0.5
                color3f outputs:out
            }}
            def Shader "Mask"
            {{
                uniform token info:id = "ND_tiledimage_vector3"
                asset inputs:file = @{image}@
                float2 inputs:uvtiling = (4, 4)
                string inputs:uaddressmode = "clamp"
                vector3f outputs:out
            }}
            def Shader "Extract"
            {{
                uniform token info:id = "ND_extract_vector3"
                vector3f inputs:in.connect = </Looks/Inline/Net/Mask.outputs:out>
                int inputs:index = 1
                float outputs:out
            }}
            def Shader "Convert"
            {{
                uniform token info:id = "ND_convert_vector3_color3"
                vector3f inputs:in.connect = </Looks/Inline/Net/Mask.outputs:out>
                color3f outputs:out
            }}
            def Shader "Rough"
            {{
                uniform token info:id = "ND_clamp_float"
                float inputs:in.connect = </Looks/Inline/Net/Mixed.outputs:out>
                float inputs:low = 0.1
                float inputs:high = 0.8
                float outputs:out
            }}
            def Shader "Mixed"
            {{
                uniform token info:id = "ND_mix_float"
                float inputs:fg.connect = </Looks/Inline/Net/Extract.outputs:out>
                float inputs:bg = 0.3
                float inputs:mix = 0.25
                float outputs:out
            }}
        }}
    }}
}}
"#
    )
}

fn shader_ball_mtlx(image: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<materialx version="1.38">
  <nodegraph name="Net">
    <texcoord name="Uv" type="vector2" />
    <place2d name="Place" type="vector2">
      <input name="texcoord" type="vector2" nodename="Uv" />
      <input name="scale" type="vector2" value="0.5, 0.25" />
      <input name="offset" type="vector2" value="0.1, 0" />
    </place2d>
    <image name="Albedo" type="color3">
      <input name="file" type="filename" value="{image}" colorspace="srgb_texture" />
      <input name="texcoord" type="vector2" nodename="Place" />
    </image>
    <multiply name="Tint" type="color3">
      <input name="in1" type="color3" nodename="Albedo" />
      <input name="in2" type="float" value="0.5" />
    </multiply>
    <tiledimage name="Mask" type="vector3">
      <input name="file" type="filename" value="{image}" />
      <input name="uvtiling" type="vector2" value="4, 4" />
      <input name="uaddressmode" type="string" value="clamp" />
    </tiledimage>
    <extract name="Extract" type="float">
      <input name="in" type="vector3" nodename="Mask" />
      <input name="index" type="integer" value="1" />
    </extract>
    <convert name="Convert" type="color3">
      <input name="in" type="vector3" nodename="Mask" />
    </convert>
    <mix name="Mixed" type="float">
      <input name="fg" type="float" nodename="Extract" />
      <input name="bg" type="float" value="0.3" />
      <input name="mix" type="float" value="0.25" />
    </mix>
    <clamp name="Rough" type="float">
      <input name="in" type="float" nodename="Mixed" />
      <input name="low" type="float" value="0.1" />
      <input name="high" type="float" value="0.8" />
    </clamp>
    <output name="tint_out" type="color3" nodename="Tint" />
    <output name="rough_out" type="float" nodename="Rough" />
    <output name="emission_out" type="float" nodename="Extract" />
    <output name="emission_color_out" type="color3" nodename="Convert" />
  </nodegraph>
  <standard_surface name="Surface" type="surfaceshader">
    <input name="base" type="float" value="0.9" />
    <input name="base_color" type="color3" nodegraph="Net" output="tint_out" />
    <input name="specular_roughness" type="float" nodegraph="Net" output="rough_out" />
    <input name="emission" type="float" nodegraph="Net" output="emission_out" />
    <input name="emission_color" type="color3" nodegraph="Net" output="emission_color_out" />
    <input name="coat" type="float" value="0.5" />
  </standard_surface>
  <surfacematerial name="M_Look" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="Surface" />
  </surfacematerial>
</materialx>
"#
    )
}

fn write(files: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let root = dir.path().join(files[0].0);
    (dir, root)
}

#[test]
fn shader_ball_inline_network_and_mtlx_document_read_alike_without_warnings() {
    let image = pawn_texture("pawn_white_base_color.jpg");
    let (_dir, root) =
        write(&[("ball.usda", &shader_ball_usda(&image)), ("look.mtlx", &shader_ball_mtlx(&image))]);
    let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let inline = material(&scene, "/Looks/Inline");
    let document = material(&scene, "/Looks/FromMtlx/M_Look");
    // The same look, however published: equal constants and programs.
    assert_eq!(
        Material { path: String::new(), ..inline.clone() },
        Material { path: String::new(), ..document.clone() }
    );
    assert_eq!(inline.look.surface_model, "standard_surface");
    assert_eq!(
        inline.look.node_categories,
        ["clamp", "convert", "extract", "image", "mix", "multiply", "place2d", "texcoord", "tiledimage"]
    );
    assert_eq!(inline.clearcoat, 0.5, "a constant input lands in the material");
    // base_color = image · 0.5, then diffuseColor = base_color · base (0.9).
    match source_of(inline, ShadingInput::DiffuseColor) {
        ShaderNode::Math { op: MathOp::Multiply, srcs, .. } => {
            assert!(matches!(
                writer(&inline.program, srcs[0]),
                ShaderNode::Math { op: MathOp::Multiply, .. }
            ));
            assert!(
                matches!(writer(&inline.program, srcs[1]), ShaderNode::Const { value, .. } if *value == [0.9; 4])
            );
        }
        other => panic!("diffuse reads {other:?}"),
    }
    // The albedo lookup goes through place2d as one UsdTransform2d: scale 1/s, then − offset.
    let transform = inline.program.iter().find_map(|n| match n {
        ShaderNode::Transform2d { scale, translation, .. } if *scale == [2.0, 4.0] => Some(*translation),
        _ => None,
    });
    assert_eq!(transform, Some([-0.1, 0.0]), "{:?}", inline.program);
    // roughness = clamp(mix(extract(mask).y, 0.3, 0.25), 0.1, 0.8).
    assert!(matches!(source_of(inline, ShadingInput::Roughness), ShaderNode::Math { op: MathOp::Clamp, .. }));
    assert!(inline
        .program
        .iter()
        .any(|n| matches!(n, ShaderNode::Math { op: MathOp::Swizzle([1, 1, 1, 1]), .. })));
}

#[test]
fn an_unsupported_node_is_one_warning_naming_the_file_node_and_category() {
    let layer = r#"#usda 1.0
def Mesh "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Look>
}
def Material "Look"
{
    token outputs:mtlx:surface.connect = </Look/Surface.outputs:out>
    def Shader "Surface"
    {
        uniform token info:id = "ND_open_pbr_surface_surfaceshader"
        color3f inputs:base_color = (0.5, 0.25, 0.125)
        color3f inputs:base_color.connect = </Look/Hsv.outputs:out>
        color3f inputs:emission_color.connect = </Look/Hsv.outputs:out>
        float inputs:emission_luminance = 2
        token outputs:out
    }
    def Shader "Hsv"
    {
        uniform token info:id = "ND_hsvtorgb_color3"
        color3f inputs:in = (0.1, 1, 1)
        color3f outputs:out
    }
}
"#;
    let (_dir, root) = write(&[("look.usda", layer)]);
    let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    let w = &scene.warnings[0];
    assert_eq!(w.prim, "/Look/Hsv");
    let file = root.canonicalize().unwrap().display().to_string();
    assert_eq!(
        w.message,
        format!("MaterialX node \"hsvtorgb\" (ND_hsvtorgb_color3) in {file}: not supported; the inputs it feeds keep their authored value or default")
    );
    let m = material(&scene, "/Look");
    assert_eq!(m.diffuse_color, glam::Vec3::new(0.5, 0.25, 0.125), "base_color keeps its authored value");
    assert_eq!(
        m.emissive_color,
        glam::Vec3::splat(2.0),
        "emission_color keeps its default (1) × luminance 2"
    );
    assert!(m.program.is_empty());
    assert_eq!(m.look.node_categories, ["hsvtorgb"]);
}

/// A Material whose `outputs:mtlx:surface` is one shader with constant inputs.
fn constant_surface(id: &str, inputs: &str) -> Material {
    let layer = format!(
        r#"#usda 1.0
def Mesh "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Look>
}}
def Material "Look"
{{
    token outputs:mtlx:surface.connect = </Look/Surface.outputs:out>
    def Shader "Surface"
    {{
        uniform token info:id = "{id}"
        {inputs}
        token outputs:out
    }}
}}
"#
    );
    let (_dir, root) = write(&[("look.usda", &layer)]);
    let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let m = material(&scene, "/Look").clone();
    assert!(m.program.is_empty(), "constants fold: {:?}", m.program);
    m
}

#[test]
fn standard_surface_constants_map_onto_the_preview_surface() {
    use glam::Vec3;
    let m = constant_surface("ND_standard_surface_surfaceshader", "");
    // The specification's defaults: base 1 × base_color 0.8, roughness 0.2, coat roughness 0.1.
    assert_eq!(m.diffuse_color, Vec3::splat(0.8));
    assert_eq!(
        (m.roughness, m.metallic, m.ior, m.clearcoat, m.clearcoat_roughness),
        (0.2, 0.0, 1.5, 0.0, 0.1)
    );
    assert_eq!((m.opacity, m.opacity_threshold, m.use_specular_workflow), (1.0, 0.0, false));
    assert_eq!(m.look.surface_model, "standard_surface");
    let m = constant_surface(
        "ND_standard_surface_surfaceshader",
        "float inputs:base = 0.5
        color3f inputs:base_color = (1, 0.5, 0.25)
        float inputs:metalness = 1
        float inputs:specular_roughness = 0.35
        float inputs:specular_IOR = 1.8
        float inputs:emission = 2
        color3f inputs:emission_color = (1, 0.5, 0)
        float inputs:coat = 0.75
        float inputs:coat_roughness = 0.3
        color3f inputs:opacity = (0.25, 0.25, 0.25)",
    );
    assert_eq!(m.diffuse_color, Vec3::new(0.5, 0.25, 0.125));
    assert_eq!((m.metallic, m.roughness, m.ior), (1.0, 0.35, 1.8));
    assert_eq!(m.emissive_color, Vec3::new(2.0, 1.0, 0.0));
    assert_eq!((m.clearcoat, m.clearcoat_roughness), (0.75, 0.3));
    assert_eq!((m.opacity, m.opacity_threshold), (0.25, 0.5), "opacity is a cut-out");
    assert!(!m.use_specular_workflow, "a metal keeps the metallic workflow");
    // Transmission: clear glass of specular_IOR; specular 0.5 and a specular colour on a dielectric:
    // OpenPBR's specular weight and colour, in the metallic workflow.
    let m = constant_surface(
        "ND_standard_surface_surfaceshader",
        "float inputs:transmission = 0.75
        float inputs:specular_IOR = 1.33
        float inputs:specular = 0.5
        color3f inputs:specular_color = (1, 1, 0.5)",
    );
    assert_eq!((m.opacity, m.opacity_threshold, m.ior), (0.25, 0.0, 1.33));
    assert!(!m.use_specular_workflow);
    assert_eq!((m.specular_weight, m.specular_tint), (0.5, Vec3::new(1.0, 1.0, 0.5)));
}

#[test]
fn open_pbr_surface_constants_map_onto_the_preview_surface() {
    use glam::Vec3;
    let m = constant_surface("ND_open_pbr_surface_surfaceshader", "");
    assert_eq!(m.diffuse_color, Vec3::splat(0.8));
    assert_eq!(
        (m.roughness, m.metallic, m.ior, m.clearcoat, m.clearcoat_roughness),
        (0.3, 0.0, 1.5, 0.0, 0.0)
    );
    assert_eq!(m.look.surface_model, "open_pbr_surface");
    let m = constant_surface(
        "ND_open_pbr_surface_surfaceshader",
        "float inputs:base_weight = 0.5
        color3f inputs:base_color = (0.2, 0.4, 0.6)
        float inputs:base_metalness = 0.25
        float inputs:specular_roughness = 0.05
        float inputs:specular_ior = 1.6
        float inputs:emission_luminance = 4
        color3f inputs:emission_color = (0.5, 0.25, 1)
        float inputs:coat_weight = 1
        float inputs:coat_roughness = 0.2
        float inputs:geometry_opacity = 0",
    );
    assert_eq!(m.diffuse_color, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!((m.metallic, m.roughness, m.ior), (0.25, 0.05, 1.6));
    assert_eq!(m.emissive_color, Vec3::new(2.0, 1.0, 4.0));
    assert_eq!((m.clearcoat, m.clearcoat_roughness), (1.0, 0.2));
    assert_eq!((m.opacity, m.opacity_threshold), (0.0, 0.5));
    let m = constant_surface(
        "ND_open_pbr_surface_surfaceshader",
        "float inputs:transmission_weight = 1
        float inputs:specular_ior = 1.54",
    );
    assert_eq!((m.opacity, m.opacity_threshold, m.ior), (0.0, 0.0, 1.54));
    // MaterialX's own UsdPreviewSurface node reads its inputs by their USD names.
    let m = constant_surface(
        "ND_UsdPreviewSurface_surfaceshader",
        "color3f inputs:diffuseColor = (0.1, 0.2, 0.3)
        float inputs:roughness = 0.7
        float inputs:opacity = 0.5
        float inputs:opacityThreshold = 0.25",
    );
    assert_eq!(m.diffuse_color, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!((m.roughness, m.opacity, m.opacity_threshold), (0.7, 0.5, 0.25));
    assert_eq!(m.look.surface_model, "UsdPreviewSurface");
}

#[test]
fn a_broken_mtlx_reference_names_the_file_and_line() {
    let (_dir, root) = write(&[
        ("scene.usda", "#usda 1.0\ndef Scope \"Looks\" (references = @./look.mtlx@</MaterialX/Materials>) {}\n"),
        ("look.mtlx", "<?xml version=\"1.0\"?>\n<materialx version=\"1.38\">\n  <image name=\"a\" type=\"color3\">\n</materialx>\n"),
    ]);
    let err = load(&root, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        err.ends_with("could not be read: look.mtlx: expected 'image' tag, not 'materialx' at 4:1"),
        "{err}"
    );
}

#[test]
fn primvar_reads_channel_picks_and_a_world_space_normal() {
    let layer = r#"#usda 1.0
def Mesh "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    color3f[] primvars:tint = [(1, 0, 0), (0, 1, 0), (0, 0, 1)] (interpolation = "vertex")
    uniform token subdivisionScheme = "none"
    rel material:binding = </Look>
}
def Material "Look"
{
    token outputs:mtlx:surface.connect = </Look/Surface.outputs:out>
    def Shader "Surface"
    {
        uniform token info:id = "ND_standard_surface_surfaceshader"
        color3f inputs:base_color.connect = </Look/Picked.outputs:out>
        float inputs:specular_roughness.connect = </Look/Split.outputs:outg>
        color3f inputs:emission_color.connect = </Look/Combined.outputs:out>
        float inputs:emission = 1
        float3 inputs:normal.connect = </Look/Tint.outputs:out>
        token outputs:out
    }
    def Shader "Tint"
    {
        uniform token info:id = "ND_geompropvalue_color3"
        string inputs:geomprop = "tint"
        color3f inputs:default = (0.5, 0.5, 0.5)
        color3f outputs:out
    }
    def Shader "Picked"
    {
        uniform token info:id = "ND_swizzle_color3_color3"
        color3f inputs:in.connect = </Look/Tint.outputs:out>
        string inputs:channels = "bgr"
        color3f outputs:out
    }
    def Shader "Split"
    {
        uniform token info:id = "ND_separate3_color3"
        color3f inputs:in.connect = </Look/Tint.outputs:out>
        float outputs:outr
        float outputs:outg
        float outputs:outb
    }
    def Shader "Combined"
    {
        uniform token info:id = "ND_combine3_color3"
        float inputs:in1 = 0.25
        float inputs:in2.connect = </Look/Split.outputs:outb>
        float inputs:in3 = 0.75
        color3f outputs:out
    }
}
"#;
    let (_dir, root) = write(&[("look.usda", layer)]);
    let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let warnings: Vec<&str> = scene.warnings.iter().map(|w| w.message.as_str()).collect();
    assert_eq!(
        warnings,
        ["normal reads /Look/Tint (geompropvalue), not a normalmap: a world-space normal the renderer cannot take; using the interpolated normal"]
    );
    let m = material(&scene, "/Look");
    assert!(!m.program.iter().any(|n| matches!(n, ShaderNode::Output { input: ShadingInput::Normal, .. })));
    // base_color = tint.bgr, a swizzle of the primvar read.
    match source_of(m, ShadingInput::DiffuseColor) {
        ShaderNode::Math { op: MathOp::Swizzle([2, 1, 0, _]), srcs, .. } => {
            assert!(matches!(writer(&m.program, srcs[0]), ShaderNode::Primvar { name, fallback, .. }
                if name == "tint" && *fallback == [0.5, 0.5, 0.5, 1.0]));
        }
        other => panic!("diffuse reads {other:?}"),
    }
    // separate3's outg: channel 1 moved to x.
    assert!(matches!(
        source_of(m, ShadingInput::Roughness),
        ShaderNode::Math { op: MathOp::Swizzle([1, 1, 1, 1]), .. }
    ));
    // combine3(0.25, tint.b, 0.75): the constants fold into one vector, the primvar's channel added.
    assert!(matches!(source_of(m, ShadingInput::EmissiveColor), ShaderNode::Math { op: MathOp::Add, .. }));
    assert_eq!(m.look.node_categories, ["combine3", "geompropvalue", "separate3", "swizzle"]);
}

/// An open_pbr_surface `.mtlx` look with a tinted coat of its own index, a metal with an F82 edge
/// tint (`specular_color`), a specular weight and a fuzz arrives in the blob's material record with those
/// values, and `--dump-json` lists them; an inline `ND_open_pbr_surface_surfaceshader` reads alike,
/// and out-of-range values are clamped into the blob's ranges with one warning each.
#[test]
fn open_pbr_coat_and_f82_values_reach_the_blob_and_the_json_listing() {
    let usda = r#"#usda 1.0
def Mesh "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Looks/M_Coated>
}
def Scope "Looks" (references = @./look.mtlx@</MaterialX/Materials>) {}
"#;
    let mtlx = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <open_pbr_surface name="Surface" type="surfaceshader">
    <input name="base_color" type="color3" value="0.95, 0.64, 0.54" />
    <input name="base_metalness" type="float" value="1" />
    <input name="specular_weight" type="float" value="0.75" />
    <input name="specular_color" type="color3" value="0.9, 0.7, 0.5" />
    <input name="specular_roughness" type="float" value="0.25" />
    <input name="coat_weight" type="float" value="0.8" />
    <input name="coat_color" type="color3" value="0.9, 0.5, 0.25" />
    <input name="coat_roughness" type="float" value="0.15" />
    <input name="coat_ior" type="float" value="1.4" />
    <input name="fuzz_weight" type="float" value="0.6" />
    <input name="fuzz_color" type="color3" value="0.3, 0.6, 0.9" />
    <input name="fuzz_roughness" type="float" value="0.35" />
  </open_pbr_surface>
  <surfacematerial name="M_Coated" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="Surface" />
  </surfacematerial>
</materialx>
"#;
    let (dir, root) = write(&[("scene.usda", usda), ("look.mtlx", mtlx)]);
    let out = dir.path().join("scene.blob");
    let (scene, _) = ingest::pipeline::ingest_file(&root, &out, &LoadOptions::default()).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let bytes = blob::AlignedBytes::copy_from(&std::fs::read(&out).unwrap());
    let view = blob::SceneView::parse(&bytes).unwrap();
    let record = view
        .materials
        .iter()
        .find(|m| view.string(m.name) == "/Looks/M_Coated")
        .unwrap_or_else(|| panic!("no /Looks/M_Coated in the blob"));
    assert_eq!((record.clearcoat, record.clearcoat_roughness, record.coat_ior), (0.8, 0.15, 1.4));
    assert_eq!(record.coat_color, [0.9, 0.5, 0.25]);
    assert_eq!((record.metallic, record.roughness, record.specular_weight), (1.0, 0.25, 0.75));
    assert_eq!(record.specular_tint, [0.9, 0.7, 0.5]);
    assert_eq!(record.diffuse_color, [0.95, 0.64, 0.54]);
    assert_eq!((record.fuzz_weight, record.fuzz_color, record.fuzz_roughness), (0.6, [0.3, 0.6, 0.9], 0.35));
    let json = ingest::pipeline::dump_json(&scene);
    let listed = json["materials"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["path"] == "/Looks/M_Coated")
        .unwrap_or_else(|| panic!("{json}"));
    let c = &listed["constants"];
    assert_eq!(listed["surface_model"], "open_pbr_surface");
    let close = |v: &serde_json::Value, x: f64| (v.as_f64().unwrap() - x).abs() < 1e-6;
    assert!(close(&c["coat_ior"], 1.4) && close(&c["clearcoat"], 0.8), "{c}");
    assert!(close(&c["specular_weight"], 0.75) && close(&c["coat_color"][2], 0.25), "{c}");
    assert!(close(&c["specular_color"][1], 0.7) && close(&c["clearcoatRoughness"], 0.15), "{c}");
    assert!(close(&c["fuzz_weight"], 0.6) && close(&c["fuzz_color"][2], 0.9), "{c}");
    assert!(close(&c["fuzz_roughness"], 0.35), "{c}");

    // Inline, with the defaults where unauthored (coat_ior 1.6 is OpenPBR's) and two values out
    // of range.
    let m = constant_surface(
        "ND_open_pbr_surface_surfaceshader",
        "float inputs:coat_weight = 1
        color3f inputs:coat_color = (0.5, 0.25, 1)",
    );
    assert_eq!((m.clearcoat, m.coat_color, m.coat_ior), (1.0, glam::Vec3::new(0.5, 0.25, 1.0), 1.6));
    assert_eq!((m.specular_weight, m.specular_tint), (1.0, glam::Vec3::ONE));
    let m = constant_surface(
        "ND_standard_surface_surfaceshader",
        "float inputs:coat_IOR = 1.3
        float inputs:sheen = 0.5
        color3f inputs:sheen_color = (1, 0, 0)",
    );
    assert_eq!((m.coat_ior, m.coat_color), (1.3, glam::Vec3::ONE));
    assert_eq!((m.fuzz_weight, m.fuzz_color, m.fuzz_roughness), (0.5, glam::Vec3::X, 0.3));
}

#[test]
fn open_pbr_values_out_of_range_are_clamped_with_a_warning() {
    let layer = r#"#usda 1.0
def Mesh "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
    rel material:binding = </Look>
}
def Material "Look"
{
    token outputs:mtlx:surface.connect = </Look/Surface.outputs:out>
    def Shader "Surface"
    {
        uniform token info:id = "ND_open_pbr_surface_surfaceshader"
        float inputs:coat_ior = 0.5
        float inputs:specular_weight = 2
        token outputs:out
    }
}
"#;
    let (_dir, root) = write(&[("look.usda", layer)]);
    let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let m = material(&scene, "/Look");
    assert_eq!((m.coat_ior, m.specular_weight), (1.0, 1.0));
    let messages: Vec<&str> = scene.warnings.iter().map(|w| w.message.as_str()).collect();
    assert_eq!(
        messages,
        [
            "coat_ior = 0.5 outside [1, 10] (or not finite); clamped to 1",
            "specular_weight = 2 outside [0, 1] (or not finite); clamped to 1",
        ],
        "{:?}",
        scene.warnings
    );
}

//! `bench textures`: speed against accuracy of the texture filters.
//!
//! The scene is generated: a ground plane to the horizon under a white dome, its diffuse colour a
//! 1024² high-frequency texture (1-texel checker overlaid with thin stripes, repeated 64 times), seen
//! by a low camera so each image row covers a different mip level and the far rows alias without
//! prefiltering. The reference is a 1024-spp render reading level 0 at each sample point (the
//! supersampled integral of the unfiltered texture). For each filter, at equal spp: RMSE against it,
//! render seconds, and lookups per second of the filter alone on the footprints the render produces.

use plotters::prelude::*;
use render::{render_image, Image, RenderOptions};
use std::path::Path;
use std::time::Instant;
use texture::Filter;

fn plane_scene() -> ingest::Scene {
    use glam::{Mat4, Vec2, Vec3};
    use ingest::scene::{SceneTexture, ShaderNode, TextureData};
    let n = 1024u32;
    let texels: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            let (x, y) = (i % n, i / n);
            let checker = (x + y) % 2 == 0;
            let stripe = x % 37 < 2 || y % 53 < 3;
            if stripe {
                [250, 240, 40]
            } else if checker {
                [230, 230, 230]
            } else {
                [20, 30, 120]
            }
        })
        .collect();
    let src =
        texture::SourceImage { width: n, height: n, channels: 3, samples: texture::Samples::U8(texels) };
    let baked = texture::bake(&src, &texture::BakeOptions::default()).expect("valid image");
    let far = 2000.0;
    let repeat = 64.0;
    let mesh = ingest::Mesh {
        path: "/Ground".into(),
        positions: vec![
            Vec3::new(-far, 0.0, far),
            Vec3::new(far, 0.0, far),
            Vec3::new(far, 0.0, -far),
            Vec3::new(-far, 0.0, -far),
        ],
        normals: vec![],
        uvs: vec![
            Vec2::ZERO,
            Vec2::new(repeat * 2.0 * far / 100.0, 0.0),
            Vec2::splat(repeat * 2.0 * far / 100.0),
            Vec2::new(0.0, repeat * 2.0 * far / 100.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![0, 0],
        double_sided: true,
        instance: None,
        placed: None,
        motion: None,
        deformation: None,
        primvars: Vec::new(),
        light_set: 0,
    };
    let mut material =
        ingest::Material { path: "/Looks/Ground".into(), ior: 1.0, ..ingest::Material::default() };
    material.program = ShaderNode::diffuse_texture_program(0, [0.0, 0.0, 0.0, 1.0]);
    let camera = ingest::Camera {
        path: "/Cam".into(),
        world_from_camera: Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)) * Mat4::from_rotation_x(-0.12),
        orthographic: false,
        focal_length: 20.0,
        horizontal_aperture: 24.0,
        vertical_aperture: 16.0,
        horizontal_aperture_offset: 0.0,
        vertical_aperture_offset: 0.0,
        clipping_range: [0.01, 1e6],
        lens: Default::default(),
        shutter: [0.0; 2],
        motion: None,
    };
    let dome = ingest::Light {
        path: "/Dome".into(),
        kind: ingest::LightKind::Dome,
        radiance: Vec3::ONE,
        normalize: false,
        world_from_light: Mat4::IDENTITY,
    };
    ingest::Scene {
        meshes: vec![mesh],
        materials: vec![material],
        lights: vec![dome],
        cameras: vec![camera],
        default_camera: Some(0),
        meters_per_unit: 1.0,
        textures: vec![SceneTexture {
            path: "generated".into(),
            color_space: texture::ColorSpace::Auto,
            data: TextureData::Image(baked),
        }],
        ..ingest::Scene::default()
    }
}

fn render_timed(view: &blob::SceneView, options: &RenderOptions) -> anyhow::Result<(Image, f64)> {
    let start = Instant::now();
    let image = render_image(view, options)?;
    Ok((image, start.elapsed().as_secs_f64()))
}

/// Filter-only throughput: `count` lookups at pseudo-random uvs with footprints spread over the
/// levels (1/16 .. 64 texels), single thread.
fn lookups_per_second(set: &texture::TextureSetView, filter: Filter, count: usize) -> f64 {
    let tex = set.texture(0).expect("one texture");
    let mut state = 0x1234_5678u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as f32 / u32::MAX as f32
    };
    let mut sum = 0.0f32;
    let start = Instant::now();
    for _ in 0..count {
        let uv = [next() * 8.0, next() * 8.0];
        let size = (2.0f32).powf(next() * 10.0 - 4.0) / 1024.0;
        let dx = [size, 0.0];
        let dy = [0.0, size * (1.0 + 7.0 * next())];
        let c = texture::sample(&tex, uv, dx, dy, filter, texture::Wrap::Repeat, texture::Wrap::Repeat);
        sum += c[0];
    }
    let seconds = start.elapsed().as_secs_f64();
    std::hint::black_box(sum);
    count as f64 / seconds
}

/// Runs the comparison and writes `textures.json` and `textures.svg` into `out`.
pub fn run(reference_spp: u32, spp: u32, width: u32, out: &Path) -> anyhow::Result<()> {
    let data = ingest::pack::pack(&plane_scene())?;
    let bytes = blob::AlignedBytes::copy_from(&data.encode());
    let view = blob::SceneView::parse(&bytes)?;
    let resolution = [width, width * 2 / 3];
    let base = RenderOptions { resolution: Some(resolution), max_depth: 1, ..RenderOptions::default() };
    let reference_options = RenderOptions {
        spp: reference_spp,
        seed: 0x5EED,
        texture_filter: Filter::Bilinear,
        texture_footprint_scale: 0.0,
        ..base.clone()
    };
    let (reference, reference_seconds) = render_timed(&view, &reference_options)?;
    println!(
        "reference: {reference_spp} spp, level-0 lookups, {}x{} in {reference_seconds:.2} s",
        resolution[0], resolution[1]
    );
    let scene = render::Scene::new(view);
    println!("{:<12} {:>5} {:>10} {:>10} {:>14}", "filter", "spp", "seconds", "rmse", "Mlookups/s");
    let mut rows = Vec::new();
    let mut unfiltered = None;
    for (name, filter, scale) in [
        ("none", Filter::Bilinear, 0.0f32),
        ("moonray", Filter::Moonray, 1.0),
        ("bilinear", Filter::Bilinear, 1.0),
        ("trilinear", Filter::Trilinear, 1.0),
        ("anisotropic", Filter::Anisotropic, 1.0),
        ("ewa", Filter::Ewa, 1.0),
    ] {
        let options = RenderOptions {
            spp,
            seed: 1,
            texture_filter: filter,
            texture_footprint_scale: scale,
            ..base.clone()
        };
        let (image, seconds) = render_timed(&view, &options)?;
        let error = crate::convergence::rmse(&image, &reference);
        let rate = if scale == 0.0 {
            f64::NAN
        } else {
            lookups_per_second(scene.shading.textures(), filter, 2_000_000) / 1e6
        };
        println!("{name:<12} {spp:>5} {seconds:>10.3} {error:>10.5} {rate:>14.2}");
        if scale == 0.0 {
            unfiltered = Some((seconds, error));
        }
        rows.push((name, seconds, error, rate));
    }
    let json = serde_json::json!({
        "resolution": resolution,
        "spp": spp,
        "reference_spp": reference_spp,
        "reference_seconds": reference_seconds,
        "rows": rows.iter().map(|(n, t, e, r)| serde_json::json!({"filter": n, "seconds": t, "rmse": e, "mlookups_per_second": if r.is_nan() { serde_json::Value::Null } else { (*r).into() }})).collect::<Vec<_>>(),
        "unfiltered_note": "filter `none`: level-0 bilinear at the sample point (what the reference integrates), at the same spp",
    });
    std::fs::write(out.join("textures.json"), serde_json::to_string_pretty(&json)?)?;
    chart(&rows, unfiltered, spp, &out.join("textures.svg"))?;
    println!("figures written to {}", out.join("textures.json").display());
    Ok(())
}

fn chart(
    rows: &[(&str, f64, f64, f64)],
    _unfiltered: Option<(f64, f64)>,
    spp: u32,
    path: &Path,
) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let (t0, t1) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.1), hi.max(r.1)));
    let (e0, e1) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.2), hi.max(r.2)));
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("Texture filters on a receding plane: RMSE vs render time ({spp} spp)"),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(t0 * 0.9..t1 * 1.1, (e0 * 0.8..e1 * 1.25).log_scale())?;
    chart.configure_mesh().x_desc("render seconds").y_desc("RMSE vs 1024-spp reference").draw()?;
    let colours = [BLACK, BLUE, GREEN, MAGENTA, RED, CYAN];
    for (r, colour) in rows.iter().zip(colours) {
        chart.draw_series(std::iter::once(Circle::new((r.1, r.2), 5, colour.filled())))?;
        let label = if r.3.is_nan() { r.0.to_string() } else { format!("{} ({:.1} Mlookups/s)", r.0, r.3) };
        chart.draw_series(std::iter::once(Text::new(
            label,
            (r.1, r.2 * 1.05),
            ("sans-serif", 12).into_font(),
        )))?;
    }
    root.present()?;
    Ok(())
}

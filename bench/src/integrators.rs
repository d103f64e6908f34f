//! `bench integrators [BLOB…]`: the scalar (depth-first) and wavefront (breadth-first) integrators on
//! the same scenes, options and threads, side by side in one process (MoonRay, HPG 2017, Table 2).
//!
//! Without blobs the bench runs four scenes: the bundled tractor (`examples/tractor.usda`), a
//! generated shading-heavy scene (textured spheres and ground, 48 sphere lights, a dome and a sun), the
//! same geometry and lights with production-style materials (material-heavy: per material a
//! UsdTransform2d and base-colour, roughness, metallic and normal maps) and a generated simple one (a
//! grey sphere under a dome). Per scene and integrator:
//!
//! * speed: best of `repeat` renders without phase timers, in process CPU seconds (all threads) and
//!   wall seconds, as Mrays and M shader evaluations per CPU second;
//! * the phase breakdown from the least disturbed of `repeat` more renders with `phase_stats` (their
//!   lap timers cost time, so they never time the speed runs): intersection, shading, texturing,
//!   integration, overhead; the shading+texturing+integration speed-up applies each integrator's
//!   share of those phases to its untimed CPU seconds;
//! * the wavefront's SIMD lane utilisation, and the largest beauty difference between the two images;
//!
//! Outputs in `out`: `integrators.json`, `integrators.md` (the table) and `integrators.svg` (stacked
//! bars of CPU µs per sample by phase, scalar beside wavefront per scene).

use glam::{Mat4, Vec2, Vec3};
use plotters::prelude::*;
use render::{render_image, Image, Integrator, RenderOptions};
use std::path::Path;
use std::time::Instant;

/// One measured render.
struct Run {
    image: Image,
    cpu: f64,
    wall: f64,
}

fn timed_render(view: &blob::SceneView, options: &RenderOptions) -> anyhow::Result<Run> {
    let (wall, cpu) = (Instant::now(), crate::ingest_speed::process_cpu_seconds());
    let image = render_image(view, options)?;
    Ok(Run {
        image,
        cpu: crate::ingest_speed::process_cpu_seconds() - cpu,
        wall: wall.elapsed().as_secs_f64(),
    })
}

fn best_of(view: &blob::SceneView, options: &RenderOptions, repeat: usize) -> anyhow::Result<Run> {
    let mut best: Option<Run> = None;
    for _ in 0..repeat.max(1) {
        let run = timed_render(view, options)?;
        if best.as_ref().is_none_or(|b| run.cpu < b.cpu) {
            best = Some(run);
        }
    }
    Ok(best.expect("at least one run"))
}

/// Figures of one integrator on one scene.
#[derive(Clone, Debug, Default)]
struct Figures {
    cpu: f64,
    wall: f64,
    mrays_per_cpu_s: f64,
    mshaders_per_cpu_s: f64,
    phases: render::stats::PhaseSeconds,
    samples: u64,
    bsdf_lanes: f64,
    light_lanes: f64,
}

fn figures(speed: &Run, timed: &Image) -> Figures {
    let s = speed.cpu.max(1e-9);
    let c = &timed.stats.counters;
    let lanes = |active: u64| {
        if c.bsdf_lane_groups > 0 {
            100.0 * active as f64 / (8 * c.bsdf_lane_groups) as f64
        } else {
            0.0
        }
    };
    Figures {
        cpu: speed.cpu,
        wall: speed.wall,
        mrays_per_cpu_s: speed.image.stats.rays.total() as f64 / s / 1e6,
        mshaders_per_cpu_s: speed.image.stats.shader_evaluations as f64 / s / 1e6,
        phases: timed.stats.phases,
        samples: speed.image.stats.samples,
        bsdf_lanes: lanes(c.bsdf_lanes_active),
        light_lanes: lanes(c.light_lanes_active),
    }
}

/// One scene's result.
struct SceneResult {
    name: String,
    size: [u32; 2],
    scalar: Figures,
    wave: Figures,
    max_diff: f32,
    mean_diff: f64,
}

impl SceneResult {
    fn speedup(&self) -> f64 {
        self.scalar.cpu / self.wave.cpu.max(1e-9)
    }
    /// Speed-up of shading + texturing + integration, from the phase fractions of the timed runs
    /// applied to the untimed CPU seconds.
    fn shading_speedup(&self) -> f64 {
        let part = |f: &Figures| {
            let p = &f.phases;
            let total = p.total();
            if total <= 0.0 {
                return f64::NAN;
            }
            f.cpu * (p.shading + p.texturing + p.integration) / total
        };
        part(&self.scalar) / part(&self.wave)
    }
}

fn measure(
    name: &str,
    view: &blob::SceneView,
    options: &RenderOptions,
    repeat: usize,
) -> anyhow::Result<SceneResult> {
    let with = |integrator, phase_stats| RenderOptions { integrator, phase_stats, ..options.clone() };
    let scalar = best_of(view, &with(Integrator::Scalar, false), repeat)?;
    let wave = best_of(view, &with(Integrator::Wavefront, false), repeat)?;
    // Phase shares from the least disturbed of `repeat` timed runs, as the speed is.
    let scalar_timed = best_of(view, &with(Integrator::Scalar, true), repeat)?.image;
    let wave_timed = best_of(view, &with(Integrator::Wavefront, true), repeat)?.image;
    let (mut max_diff, mut sum, mut n) = (0.0f32, 0.0f64, 0usize);
    for (a, b) in scalar.image.beauty.iter().flatten().zip(wave.image.beauty.iter().flatten()) {
        let d = (a - b).abs();
        max_diff = max_diff.max(d);
        sum += d as f64;
        n += 1;
    }
    Ok(SceneResult {
        name: name.into(),
        size: [scalar.image.width, scalar.image.height],
        scalar: figures(&scalar, &scalar_timed),
        wave: figures(&wave, &wave_timed),
        max_diff,
        mean_diff: sum / n.max(1) as f64,
    })
}

/// A UV sphere of `rings × segments` quads (two triangles each) with normals and uvs.
fn sphere(path: &str, center: Vec3, radius: f32, rings: u32, segments: u32, material: u32) -> ingest::Mesh {
    let (mut positions, mut normals, mut uvs, mut triangles) = (vec![], vec![], vec![], vec![]);
    for r in 0..=rings {
        let v = r as f32 / rings as f32;
        let theta = v * std::f32::consts::PI;
        for s in 0..=segments {
            let u = s as f32 / segments as f32;
            let phi = u * std::f32::consts::TAU;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            positions.push(center + n * radius);
            normals.push(n);
            uvs.push(Vec2::new(u * 4.0, v * 2.0));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * row + s, r * row + s + 1);
            let (c, d) = (a + row, b + row);
            triangles.push([a, c, b]);
            triangles.push([b, c, d]);
        }
    }
    let n = triangles.len();
    ingest::Mesh {
        path: path.into(),
        positions,
        normals,
        uvs,
        triangles,
        triangle_materials: vec![material; n],
        double_sided: false,
        ..Default::default()
    }
}

fn camera(eye: Vec3, target: Vec3) -> ingest::Camera {
    ingest::Camera {
        path: "/Cam".into(),
        // Camera looks down its −Z with +Y up.
        world_from_camera: {
            let f = (target - eye).normalize();
            let x = f.cross(Vec3::Y).normalize();
            let y = x.cross(f);
            Mat4::from_cols(x.extend(0.0), y.extend(0.0), (-f).extend(0.0), eye.extend(1.0))
        },
        orthographic: false,
        focal_length: 30.0,
        horizontal_aperture: 36.0,
        vertical_aperture: 24.0,
        horizontal_aperture_offset: 0.0,
        vertical_aperture_offset: 0.0,
        clipping_range: [0.01, 1e6],
        lens: Default::default(),
        shutter: [0.0; 2],
        motion: None,
    }
}

fn light(path: String, kind: ingest::LightKind, radiance: Vec3, at: Vec3) -> ingest::Light {
    ingest::Light { path, kind, radiance, normalize: false, world_from_light: Mat4::from_translation(at) }
}

/// Textured spheres on a textured ground under 48 sphere lights, a dome and a sun: most of a path's
/// time goes to shading, texturing and light sampling.
fn shading_heavy_scene() -> anyhow::Result<ingest::Scene> {
    use ingest::scene::{SceneTexture, ShaderNode, ShadingInput, TextureData};
    let n = 512u32;
    // RGB = colour, A = roughness: a tile pattern with noise, so every lookup reads varied texels.
    let texels: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            let (x, y) = (i % n, i / n);
            let h = (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)).wrapping_mul(2_654_435_761);
            let tile = ((x / 32 + y / 32) % 2) as u8;
            [60 + tile * 150 + (h >> 28) as u8, 90 + (h >> 27) as u8, 200 - tile * 120, 40 + (h >> 25) as u8]
        })
        .collect();
    let src =
        texture::SourceImage { width: n, height: n, channels: 4, samples: texture::Samples::U8(texels) };
    let baked = texture::bake(&src, &texture::BakeOptions::default())?;
    let textured = |path: &str, metallic: f32, clearcoat: f32| {
        let mut m = ingest::Material {
            path: path.into(),
            ior: 1.5,
            metallic,
            clearcoat,
            clearcoat_roughness: 0.1,
            ..ingest::Material::default()
        };
        m.program = {
            let mut program = ShaderNode::diffuse_texture_program(0, [0.5, 0.5, 0.5, 0.5]);
            program.push(ShaderNode::Output { input: ShadingInput::Roughness, src: 1, swizzle: [3; 4] });
            program
        };
        m
    };
    let materials = vec![
        textured("/Looks/Plastic", 0.0, 0.0),
        textured("/Looks/Metal", 1.0, 0.0),
        textured("/Looks/Coated", 0.0, 1.0),
    ];
    let mut meshes = vec![ingest::Mesh {
        path: "/Ground".into(),
        positions: vec![
            Vec3::new(-20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, -20.0),
            Vec3::new(-20.0, 0.0, -20.0),
        ],
        normals: vec![],
        uvs: vec![Vec2::ZERO, Vec2::new(16.0, 0.0), Vec2::splat(16.0), Vec2::new(0.0, 16.0)],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![0, 0],
        double_sided: true,
        ..Default::default()
    }];
    for i in 0..5 {
        for j in 0..5 {
            let c = Vec3::new(-4.0 + 2.0 * i as f32, 0.8, -4.0 + 2.0 * j as f32);
            meshes.push(sphere(&format!("/Ball_{i}_{j}"), c, 0.8, 24, 48, ((i + j) % 3) as u32));
        }
    }
    let mut lights = vec![
        light("/Dome".into(), ingest::LightKind::Dome, Vec3::splat(0.2), Vec3::ZERO),
        ingest::Light {
            path: "/Sun".into(),
            kind: ingest::LightKind::Distant { angle_degrees: 2.0 },
            radiance: Vec3::new(2.0, 1.8, 1.5),
            normalize: true,
            world_from_light: Mat4::from_rotation_x(-1.0),
        },
    ];
    for k in 0..48u32 {
        let a = k as f32 * 0.7;
        let at = Vec3::new(7.0 * a.cos(), 2.0 + (k % 4) as f32, 7.0 * a.sin());
        let colour = Vec3::new(0.5 + 0.5 * (a * 1.3).sin().abs(), 0.6, 0.5 + 0.5 * (a * 0.7).cos().abs());
        let kind = ingest::LightKind::Sphere { radius: 0.15, treat_as_point: false };
        lights.push(light(format!("/Light_{k}"), kind, colour * 40.0, at));
    }
    Ok(ingest::Scene {
        meshes,
        materials,
        lights,
        cameras: vec![camera(Vec3::new(0.0, 5.0, 11.0), Vec3::new(0.0, 0.5, 0.0))],
        default_camera: Some(0),
        meters_per_unit: 1.0,
        textures: vec![SceneTexture {
            path: "generated".into(),
            color_space: texture::ColorSpace::Auto,
            data: TextureData::Image(baked),
        }],
        ..ingest::Scene::default()
    })
}

/// A procedural `n`² texture of `channels` 8-bit channels: value noise over a brick pattern, seeded so
/// each map of each material differs (every lookup reads varied texels, as a painted map's would).
fn procedural_texture(
    n: u32,
    channels: u32,
    seed: u32,
    color_space: texture::ColorSpace,
    texel: impl Fn(u32, u32, u32) -> [u8; 4],
) -> anyhow::Result<ingest::scene::SceneTexture> {
    use ingest::scene::{SceneTexture, TextureData};
    let samples: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            let (x, y) = (i % n, i / n);
            let h = (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663) ^ seed.wrapping_mul(83_492_791))
                .wrapping_mul(2_654_435_761);
            texel(x, y, h)[..channels as usize].to_vec()
        })
        .collect();
    let src = texture::SourceImage { width: n, height: n, channels, samples: texture::Samples::U8(samples) };
    let baked = texture::bake(&src, &texture::BakeOptions { color_space, ..Default::default() })?;
    Ok(SceneTexture {
        path: format!("generated-{seed}").into(),
        color_space,
        data: TextureData::Image(baked),
    })
}

/// The shading-heavy scene's geometry and lights with production-style materials: six
/// UsdPreviewSurface networks, each reading its own base-colour, roughness, metallic and normal maps
/// (sRGB colour, raw data) through a UsdTransform2d, as a published asset's look does. The maps are
/// 256² so that texel density on screen is a production render's: at the bench's 320-pixel width a
/// map repeat covers ~40 pixels, so lookups read levels 2–3, as a 4K map does filling a 2K frame
/// (1024² maps put every lookup on level 4 or coarser and made a 72 MB blob).
fn material_heavy_scene() -> anyhow::Result<ingest::Scene> {
    use ingest::scene::{ShaderNode, ShadingInput};
    use texture::{ColorSpace, Wrap};
    let mut scene = shading_heavy_scene()?;
    let n = 256;
    let mut textures = vec![];
    let mut materials = vec![];
    for m in 0..6u32 {
        let base = textures.len() as u32;
        let brick = move |x: u32, y: u32| (((x + (y / 32) % 2 * 32) / 64 + y / 32) % 2) as u8;
        textures.push(procedural_texture(n, 3, 4 * m, ColorSpace::Srgb, move |x, y, h| {
            let b = brick(x, y);
            [
                40 + 30 * m as u8 + b * 90 + (h >> 28) as u8,
                70 + b * 60 + (h >> 27) as u8,
                180 - b * 100 + (h >> 28) as u8,
                255,
            ]
        })?);
        textures.push(procedural_texture(n, 1, 4 * m + 1, ColorSpace::Raw, move |x, y, h| {
            [30 + brick(x, y) * 120 + (h >> 26) as u8, 0, 0, 0]
        })?);
        textures.push(procedural_texture(n, 1, 4 * m + 2, ColorSpace::Raw, move |x, y, h| {
            [if (m % 3 == 1) ^ (brick(x, y) == 1 && h >> 30 == 0) { 250 } else { 5 }, 0, 0, 0]
        })?);
        textures.push(procedural_texture(n, 3, 4 * m + 3, ColorSpace::Raw, move |x, y, h| {
            // Tangent-space normals: bevelled brick edges plus a little noise.
            let (ex, ey) = ((x % 64) as i32 - 32, (y % 32) as i32 - 16);
            let tx = if ex.abs() > 28 { ex.signum() * 60 } else { 0 } + ((h >> 29) as i32 - 4);
            let ty = if ey.abs() > 13 { ey.signum() * 60 } else { 0 } + ((h >> 26 & 7) as i32 - 4);
            [(128 + tx) as u8, (128 + ty) as u8, 230, 255]
        })?);
        let lookup = |dst: u32, texture: u32, scale: [f32; 4], bias: [f32; 4]| ShaderNode::Texture {
            dst,
            src: 1,
            texture: Some(texture),
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            scale,
            bias,
            fallback: [0.5; 4],
        };
        let mut program = ShaderNode::transformed_uvs(15.0 * m as f32, [2.0, 2.0], [0.1 * m as f32, 0.0]);
        program.extend([
            lookup(2, base, [1.0; 4], [0.0; 4]),
            lookup(3, base + 1, [1.0; 4], [0.0; 4]),
            lookup(4, base + 2, [1.0; 4], [0.0; 4]),
            lookup(5, base + 3, [2.0, 2.0, 2.0, 1.0], [-1.0, -1.0, -1.0, 0.0]),
            ShaderNode::Output { input: ShadingInput::DiffuseColor, src: 2, swizzle: [0, 1, 2, 3] },
            ShaderNode::Output { input: ShadingInput::Roughness, src: 3, swizzle: [0; 4] },
            ShaderNode::Output { input: ShadingInput::Metallic, src: 4, swizzle: [0; 4] },
            ShaderNode::Output { input: ShadingInput::Normal, src: 5, swizzle: [0, 1, 2, 3] },
        ]);
        materials.push(ingest::Material {
            path: format!("/Looks/Pbr_{m}"),
            ior: 1.5,
            clearcoat: if m == 5 { 1.0 } else { 0.0 },
            clearcoat_roughness: 0.1,
            program,
            ..ingest::Material::default()
        });
    }
    for (k, mesh) in scene.meshes.iter_mut().enumerate() {
        let m = k as u32 % 6;
        mesh.triangle_materials.iter_mut().for_each(|t| *t = m);
    }
    scene.materials = materials;
    scene.textures = textures;
    Ok(scene)
}

/// One grey Lambert sphere under a white dome: the least shading per ray.
fn simple_scene() -> ingest::Scene {
    let grey = ingest::Material {
        path: "/Looks/Grey".into(),
        diffuse_color: Vec3::splat(0.5),
        ior: 1.0,
        ..ingest::Material::default()
    };
    ingest::Scene {
        meshes: vec![sphere("/Ball", Vec3::ZERO, 1.0, 32, 64, 0)],
        materials: vec![grey],
        lights: vec![light("/Dome".into(), ingest::LightKind::Dome, Vec3::ONE, Vec3::ZERO)],
        cameras: vec![camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO)],
        default_camera: Some(0),
        meters_per_unit: 1.0,
        ..ingest::Scene::default()
    }
}

/// Packs `scene` and also writes it to `path`, so `render` can reproduce a figure.
fn blob_of(scene: &ingest::Scene, path: &Path) -> anyhow::Result<blob::AlignedBytes> {
    let bytes = ingest::pack::pack(scene)?.encode();
    std::fs::write(path, &bytes)?;
    Ok(blob::AlignedBytes::copy_from(&bytes))
}

/// The scenes the bench runs without arguments: (name, blob bytes).
fn default_scenes(work: &Path) -> anyhow::Result<Vec<(String, blob::AlignedBytes)>> {
    let tractor = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
    let out = work.join("tractor.blob");
    ingest::pipeline::ingest_file(&tractor, &out, &Default::default())?;
    Ok(vec![
        ("tractor".into(), blob::AlignedBytes::copy_from(&std::fs::read(&out)?)),
        ("shading-heavy".into(), blob_of(&shading_heavy_scene()?, &work.join("shading-heavy.blob"))?),
        ("material-heavy".into(), blob_of(&material_heavy_scene()?, &work.join("material-heavy.blob"))?),
        ("simple".into(), blob_of(&simple_scene(), &work.join("simple.blob"))?),
    ])
}

/// Runs both integrators on `blobs` (or the default scenes) and writes the table, JSON and chart.
pub fn run(
    blobs: &[std::path::PathBuf],
    spp: u32,
    width: u32,
    threads: usize,
    repeat: usize,
    out: &Path,
) -> anyhow::Result<()> {
    let scenes = if blobs.is_empty() {
        default_scenes(out)?
    } else {
        blobs
            .iter()
            .map(|p| Ok((p.display().to_string(), crate::load(p)?)))
            .collect::<anyhow::Result<Vec<_>>>()?
    };
    let mut results = Vec::new();
    for (name, bytes) in &scenes {
        let view = blob::SceneView::parse(bytes).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let scene = render::Scene::new(view);
        let camera = scene.camera_index(None)?;
        let [w0, h0] = scene.resolution(None, camera);
        let height = (h0 as u64 * width as u64 / w0.max(1) as u64).max(1) as u32;
        let options =
            RenderOptions { spp, resolution: Some([width, height]), threads, ..RenderOptions::default() };
        let r = measure(name, &view, &options, repeat)?;
        eprintln!(
            "{name}: scalar {:.3} CPU s, wavefront {:.3} CPU s: {:.2}× overall, {:.2}× shading+integration; \
             max |Δ| {:e}",
            r.scalar.cpu,
            r.wave.cpu,
            r.speedup(),
            r.shading_speedup(),
            r.max_diff
        );
        results.push(r);
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let report = table(&results, spp, threads, load.trim());
    std::fs::write(out.join("integrators.md"), &report)?;
    std::fs::write(
        out.join("integrators.json"),
        serde_json::to_string_pretty(&json(&results, spp, load.trim()))?,
    )?;
    chart(&results, &out.join("integrators.svg"))?;
    println!("{report}");
    Ok(())
}

fn pct(p: &render::stats::PhaseSeconds) -> [f64; 5] {
    let t = p.total().max(1e-12);
    [p.intersect, p.shading, p.texturing, p.integration, p.overhead].map(|x| 100.0 * x / t)
}

fn table(results: &[SceneResult], spp: u32, threads: usize, load: &str) -> String {
    let mut s = format!(
        "# Scalar against wavefront ({spp} spp, {} threads; load average at the end: {load})\n\n\
         Speed from the best of the untimed runs in process CPU seconds; phases (% of CPU time) from one \
         run with phase timers.\n\n\
         | scene | size | integrator | CPU s | wall s | Mrays/CPU s | M shaders/CPU s | isect % | shading % | \
         texturing % | integration % | overhead % | BSDF lanes % | light lanes % |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        if threads == 0 { "all".to_string() } else { threads.to_string() }
    );
    for r in results {
        for (label, f) in [("scalar", &r.scalar), ("wavefront", &r.wave)] {
            let p = pct(&f.phases);
            s += &format!(
                "| {} | {}×{} | {label} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {} |\n",
                r.name,
                r.size[0],
                r.size[1],
                f.cpu,
                f.wall,
                f.mrays_per_cpu_s,
                f.mshaders_per_cpu_s,
                p[0],
                p[1],
                p[2],
                p[3],
                p[4],
                if label == "scalar" { "–".into() } else { format!("{:.1}", f.bsdf_lanes) },
                if label == "scalar" { "–".into() } else { format!("{:.1}", f.light_lanes) },
            );
        }
    }
    s += "\n| scene | wavefront speed-up (CPU) | shading+texturing+integration speed-up | max abs Δ beauty | mean abs Δ |\n\
          |---|---|---|---|---|\n";
    for r in results {
        s += &format!(
            "| {} | {:.2}× | {:.2}× | {:e} | {:e} |\n",
            r.name,
            r.speedup(),
            r.shading_speedup(),
            r.max_diff,
            r.mean_diff,
        );
    }
    s
}

fn json(results: &[SceneResult], spp: u32, load: &str) -> serde_json::Value {
    let f = |f: &Figures| {
        serde_json::json!({
            "cpu_seconds": f.cpu, "wall_seconds": f.wall, "mrays_per_cpu_second": f.mrays_per_cpu_s,
            "mshaders_per_cpu_second": f.mshaders_per_cpu_s, "phase_seconds": f.phases,
            "bsdf_lane_utilisation": f.bsdf_lanes, "light_lane_utilisation": f.light_lanes,
        })
    };
    serde_json::json!({
        "spp": spp,
        "loadavg": load,
        "scenes": results.iter().map(|r| serde_json::json!({
            "name": r.name, "width": r.size[0], "height": r.size[1],
            "scalar": f(&r.scalar), "wavefront": f(&r.wave),
            "speedup": r.speedup(), "shading_speedup": r.shading_speedup(),
            "max_abs_beauty_difference": r.max_diff, "mean_abs_beauty_difference": r.mean_diff,
        })).collect::<Vec<_>>(),
    })
}

/// Stacked bars: CPU µs per sample by phase (the timed run's fractions of the untimed CPU seconds).
fn chart(results: &[SceneResult], path: &Path) -> anyhow::Result<()> {
    let bars: Vec<(String, [f64; 5])> = results
        .iter()
        .flat_map(|r| {
            [("scalar", &r.scalar), ("wavefront", &r.wave)].map(|(label, f)| {
                let per_sample = 1e6 * f.cpu / f.samples.max(1) as f64;
                (format!("{} {label}", r.name), pct(&f.phases).map(|p| p / 100.0 * per_sample))
            })
        })
        .collect();
    let top = bars.iter().map(|(_, v)| v.iter().sum::<f64>()).fold(0.0, f64::max) * 1.1;
    let root = SVGBackend::new(path, (200 + 110 * bars.len() as u32, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Scalar vs wavefront: CPU µs per sample by phase", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(60)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..bars.len() as f64, 0.0..top.max(1e-9))?;
    chart.configure_mesh().disable_x_mesh().x_labels(0).y_desc("CPU µs per sample").draw()?;
    // Each bar's name above it (tick labels would not land on the bar centres).
    chart.draw_series(bars.iter().enumerate().map(|(i, (name, v))| {
        let y = v.iter().sum::<f64>() + 0.02 * top;
        Text::new(name.clone(), (i as f64 + 0.1, y), ("sans-serif", 11))
    }))?;
    let names = ["intersection", "shading", "texturing", "integration", "overhead"];
    let colours = [
        RGBColor(70, 110, 200),
        RGBColor(230, 150, 50),
        RGBColor(200, 80, 80),
        RGBColor(90, 170, 90),
        RGBColor(150, 150, 150),
    ];
    for (phase, (name, colour)) in names.iter().zip(colours).enumerate() {
        chart
            .draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
                let y0: f64 = v[..phase].iter().sum();
                Rectangle::new([(i as f64 + 0.15, y0), (i as f64 + 0.85, y0 + v[phase])], colour.filled())
            }))?
            .label(*name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour.filled()));
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    root.present()?;
    Ok(())
}

//! The whole ingest step as one library call, used by the binary and by the end-to-end tests.
//!
//! The readers here check the options before any file is read
//! ([`crate::dicing::SubdivOptions::validate`]), and every failure is an [`IngestError`] naming
//! the file being worked on.

use crate::pack::PackOptions;
use crate::scene::Scene;
use crate::usd::{self, LoadOptions};
use crate::IngestError;
use std::path::Path;
use std::time::Instant;

/// What an ingest run produced, for the summary line and the tests.
#[derive(Debug, Clone)]
pub struct IngestReport {
    /// Gprims written.
    pub meshes: usize,
    /// Triangles rendered (every instance counted).
    pub triangles: usize,
    /// Triangles stored in the blob (each prototype once).
    pub stored_triangles: usize,
    /// Prototypes shared by instances.
    pub prototypes: usize,
    /// Instances of those prototypes.
    pub instances: usize,
    /// Materials written (each class of materials equal in value once).
    pub materials: usize,
    /// Lights written.
    pub lights: usize,
    /// Cameras written.
    pub cameras: usize,
    /// Size of the blob in bytes.
    pub blob_bytes: usize,
    /// Seconds spent composing and reading USD.
    pub load_seconds: f64,
    /// Seconds spent packing (including the BVH build).
    pub pack_seconds: f64,
    /// Warnings, as `prim: message`.
    pub warnings: Vec<String>,
    /// Subdivision meshes diced.
    pub subdivision_meshes: usize,
    /// Triangles the scene would have with every subdivision mesh at the level cap.
    pub triangles_at_fixed_level: u64,
}

/// Composes `input` (a USD stage, or an Alembic archive by its `.abc` extension), packs it and
/// writes the blob to `output` atomically.
pub fn ingest_file(
    input: &Path,
    output: &Path,
    options: &LoadOptions,
) -> Result<(Scene, IngestReport), IngestError> {
    ingest_file_with(input, output, options, &PackOptions::default())
}

/// [`ingest_file`] with explicit packing options (e.g. `--flatten-instances`).
pub fn ingest_file_with(
    input: &Path,
    output: &Path,
    options: &LoadOptions,
    pack: &PackOptions,
) -> Result<(Scene, IngestReport), IngestError> {
    let mut options = options.clone();
    if !options.outputs.iter().any(|o| crate::outputs::same_file(o, output)) {
        options.outputs.push(output.to_path_buf());
    }
    let start = Instant::now();
    let scene = load(input, &options)?;
    let load_seconds = start.elapsed().as_secs_f64();
    let report = pack_and_write(input, output, &scene, load_seconds, pack, None)?;
    Ok((scene, report))
}

/// Packs `scene` (read from `input` in `load_seconds`) and writes its blob to `output`
/// atomically; `cache` reuses a sequence's earlier BVHs.
fn pack_and_write(
    input: &Path,
    output: &Path,
    scene: &Scene,
    load_seconds: f64,
    pack: &PackOptions,
    cache: Option<&mut crate::pack::BvhCache>,
) -> Result<IngestReport, IngestError> {
    let start = Instant::now();
    let data = crate::pack::pack_scene_reusing(scene, pack, cache)
        .map_err(|error| IngestError::Pack { path: input.to_path_buf(), error })?;
    let bytes = data.encode();
    let pack_seconds = start.elapsed().as_secs_f64();
    crate::outputs::write_atomic(output, &bytes)?;
    Ok(IngestReport {
        meshes: scene.meshes.len(),
        triangles: scene.triangle_count(),
        stored_triangles: data.triangles.len(),
        prototypes: data.instancing.prototypes.len(),
        instances: data.instancing.instances.len(),
        materials: data.materials.len(),
        lights: scene.lights.len(),
        cameras: scene.cameras.len(),
        blob_bytes: bytes.len(),
        load_seconds,
        pack_seconds,
        warnings: scene.warnings.iter().map(|w| format!("{}: {}", w.prim, w.message)).collect(),
        subdivision_meshes: scene.subdivisions.len(),
        triangles_at_fixed_level: triangles_at_fixed_level(scene),
    })
}

/// What a frame sequence shared between its frames ([`ingest_sequence`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SequenceReport {
    /// Frames written.
    pub frames: usize,
    /// Texture bakes served from an earlier frame (see [`usd::SequenceSharing`]).
    pub texture_bakes_reused: usize,
    /// BVHs (world, prototypes) taken from the previous frame because their triangles were the
    /// same bits (see [`crate::pack::BvhCache`]).
    pub bvhs_reused: usize,
    /// BVHs built.
    pub bvhs_built: usize,
}

/// Ingests `input` at every frame of `frames` (time code, blob path), each blob written
/// atomically as [`ingest_file_with`] writes it, and equal to it byte for byte: a USD stage is
/// composed once for the whole sequence and its texture bakes are shared
/// ([`usd::load_sequence`]), and BVHs over unchanged triangles (instance prototypes, a still
/// world) are reused from the previous frame ([`crate::pack::BvhCache`]). Everything else is read
/// and packed per frame. An Alembic archive is read afresh per frame (it bakes no texture), its
/// BVHs still reused.
///
/// `on_frame` sees each frame's scene and report once its blob is written (the binary prints
/// warnings and writes listings there); an error from it, or any frame's, stops the sequence,
/// leaving the frames before it written. Every output is checked against the inputs before the
/// first frame is read.
pub fn ingest_sequence(
    input: &Path,
    frames: &[(f64, std::path::PathBuf)],
    options: &LoadOptions,
    pack: &PackOptions,
    mut on_frame: impl FnMut(f64, &Path, &Scene, &IngestReport) -> Result<(), IngestError> + Send,
) -> Result<SequenceReport, IngestError> {
    let mut options = options.clone();
    for (_, output) in frames {
        if !options.outputs.iter().any(|o| crate::outputs::same_file(o, output)) {
            options.outputs.push(output.clone());
        }
    }
    options.subdiv.validate()?;
    crate::outputs::check_outputs(input, &options.outputs)?;
    let mut cache = crate::pack::BvhCache::default();
    let mut report = SequenceReport::default();
    let mut mark = Instant::now();
    let in_frame =
        |frame: f64| move |error: IngestError| IngestError::Frame { frame, error: Box::new(error) };
    let mut write = |time: f64, scene: Scene| -> Result<(), IngestError> {
        let (_, output) =
            frames.iter().find(|(t, _)| t.to_bits() == time.to_bits()).expect("a frame we asked for");
        let load_seconds = mark.elapsed().as_secs_f64();
        let frame_report = pack_and_write(input, output, &scene, load_seconds, pack, Some(&mut cache))
            .map_err(in_frame(time))?;
        cache.end_frame();
        report.frames += 1;
        on_frame(time, output, &scene, &frame_report).map_err(in_frame(time))?;
        mark = Instant::now();
        Ok(())
    };
    let times: Vec<f64> = frames.iter().map(|(t, _)| *t).collect();
    if crate::alembic::is_alembic(input) {
        for &time in &times {
            let frame = LoadOptions { frame: Some(time), ..options.clone() };
            let scene = crate::alembic::load(input, &frame)
                .map_err(|error| IngestError::Alembic { path: input.to_path_buf(), error })
                .map_err(in_frame(time))?;
            write(time, scene)?;
        }
    } else {
        let path = input.to_path_buf();
        let shared = usd::load_sequence(
            input,
            &options,
            &times,
            |frame, error| {
                let error = IngestError::Usd { path: path.clone(), error };
                match frame {
                    Some(frame) => in_frame(frame)(error),
                    None => error,
                }
            },
            &mut write,
        )?;
        report.texture_bakes_reused = shared.texture_bakes_reused;
    }
    report.bvhs_reused = cache.reused;
    report.bvhs_built = cache.built;
    Ok(report)
}

/// Reads `input` (a USD stage, or an Alembic archive by its `.abc` extension) into a [`Scene`].
pub fn load(input: &Path, options: &LoadOptions) -> Result<Scene, IngestError> {
    read(input, options, usd::load)
}

/// [`load`] for a process that exits once it has used the scene (the `ingest` binary's listing):
/// a USD stage is left for the OS to reclaim, see [`usd::load_until_exit`].
pub fn load_until_exit(input: &Path, options: &LoadOptions) -> Result<Scene, IngestError> {
    read(input, options, usd::load_until_exit)
}

/// Checks the options, then reads `input` as Alembic (by extension) or with `read_usd`.
fn read(
    input: &Path,
    options: &LoadOptions,
    read_usd: fn(&Path, &LoadOptions) -> Result<Scene, usd::UsdError>,
) -> Result<Scene, IngestError> {
    options.subdiv.validate()?;
    crate::outputs::check_outputs(input, &options.outputs)?;
    let path = input.to_path_buf();
    if crate::alembic::is_alembic(input) {
        crate::alembic::load(input, options).map_err(|error| IngestError::Alembic { path, error })
    } else {
        read_usd(input, options).map_err(|error| IngestError::Usd { path, error })
    }
}

/// Writes the [`dump_json`] listing of `scene` to `path`, atomically (see [`crate::outputs`]).
pub fn write_dump(scene: &Scene, path: &Path) -> Result<(), IngestError> {
    let text =
        serde_json::to_string_pretty(&dump_json(scene)).map_err(|e| IngestError::write(path, e.into()))?;
    crate::outputs::write_atomic(path, text.as_bytes())
}

/// Triangles of `scene` if every subdivision mesh were refined to the level cap instead of its
/// diced level (from the face-count formula, see [`crate::dicing::triangles_at_level`]).
pub fn triangles_at_fixed_level(scene: &Scene) -> u64 {
    let fixed: u64 = scene.subdivisions.iter().map(|s| s.triangles_at_max_level).sum();
    polygon_triangles(scene) + fixed
}

/// Triangles `scene` renders, with each subdivision mesh counted as planned
/// ([`crate::scene::Subdivision::triangles`], what dicing makes), so that a scene read for a
/// listing (nothing tessellated) counts the same as a diced one.
pub fn listed_triangles(scene: &Scene) -> u64 {
    polygon_triangles(scene) + scene.subdivisions.iter().map(|s| s.triangles).sum::<u64>()
}

/// Triangles of the meshes that are not diced subdivision surfaces.
fn polygon_triangles(scene: &Scene) -> u64 {
    let diced: u64 = scene.subdivisions.iter().map(|s| scene.meshes[s.mesh].triangle_count() as u64).sum();
    scene.triangle_count() as u64 - diced
}

/// The warning the `ingest` binary prints for a stage nothing lights (it renders black): no
/// UsdLux light read and no material that emits (a constant `emissiveColor` above zero, or a
/// program writing it). Printed by the binary, not kept in [`Scene::warnings`]: library callers
/// build unlit scenes on purpose (listings, geometry tests).
pub fn unlit_warning(scene: &Scene) -> Option<&'static str> {
    use crate::scene::{ShaderNode, ShadingInput};
    let emits = |m: &crate::scene::Material| {
        m.emissive_color.max_element() > 0.0
            || m.program
                .iter()
                .any(|n| matches!(n, ShaderNode::Output { input: ShadingInput::EmissiveColor, .. }))
    };
    (scene.lights.is_empty() && !scene.materials.iter().any(emits))
        .then_some("the stage has no light (no UsdLux light read, no emissive material): it renders black")
}

/// The `--dump-json` listing: every rendered gprim with its world bounds, triangle count and
/// material; when some light's `lightLink` or `shadowLink` collection leaves gprims out, every
/// gprim also lists the lights that light it (`light_link`) and whose shadow rays it blocks
/// (`shadow_link`), by prim path. A subdivision surface is listed from its plan, so that the listing needs no
/// tessellation and reads the same with or without one: its triangles as diced
/// ([`crate::scene::Subdivision::triangles`]), the materials of the cage faces that make them,
/// and its cage's world bounds (USD's extent; the limit surface lies inside). Subdivision
/// surfaces add their `scheme`, the `subdiv_level` refined to (adaptive: the
/// level as fine as the finest edge), `subdiv_mode` and, when adaptive, `min_edge_rate` and
/// `max_edge_rate` (segments per cage edge). Bounds are in the stage's world space (the scene's
/// positions plus its `world_origin`, listed at the top level). `materials` lists every material read with its
/// `surface_model` (`UsdPreviewSurface`, `standard_surface`, `open_pbr_surface`, `PxrDisney`; empty
/// for a displayColor material), the `node_categories` of the shading nodes read and its
/// `constants` (every UsdPreviewSurface and OpenPBR constant of the blob record by name). The top
/// level has the scene's `triangles`, `triangles_at_fixed_level` (every subdivision mesh at the
/// level cap) and `triangles_saved` (their difference; negative when a forced level exceeds the
/// cap).
pub fn dump_json(scene: &Scene) -> serde_json::Value {
    // Positions in the stage's world space: the scene's are relative to its world origin.
    let stage_world = |scene: &Scene, p: glam::Vec3| -> serde_json::Value {
        if scene.world_origin == glam::DVec3::ZERO {
            p.to_array().into()
        } else {
            (p.as_dvec3() + scene.world_origin).to_array().into()
        }
    };
    let mut subdivision = vec![None; scene.meshes.len()];
    for s in &scene.subdivisions {
        subdivision[s.mesh] = Some(s);
    }
    let gprims: Vec<serde_json::Value> = scene
        .meshes
        .iter()
        .zip(&subdivision)
        .map(|(m, subdivision)| {
            let ([lo, hi], triangles, material_indices) = match subdivision {
                Some(s) => (s.cage_world_bounds(), s.triangles, s.materials.as_slice()),
                None => (m.world_bounds(), m.triangle_count() as u64, m.triangle_materials.as_slice()),
            };
            let mut materials: Vec<&str> =
                material_indices.iter().map(|&i| scene.materials[i as usize].path.as_str()).collect();
            materials.sort_unstable();
            materials.dedup();
            let mut entry = serde_json::json!({
                "path": m.path,
                "type": "Mesh",
                "triangles": triangles,
                "bounds_min": stage_world(scene, lo),
                "bounds_max": stage_world(scene, hi),
                "materials": materials,
            });
            if let Some(set) = scene.light_sets.get(m.light_set as usize) {
                let named = |on: &[bool]| -> Vec<&str> {
                    scene.lights.iter().zip(on).filter(|(_, &on)| on).map(|(l, _)| l.path.as_str()).collect()
                };
                entry["light_link"] = named(&set.lit_by).into();
                entry["shadow_link"] = named(&set.shadows).into();
            }
            if let Some(s) = subdivision {
                entry["scheme"] = crate::dicing::scheme_token(s.topology.options().scheme).into();
                entry["subdiv_level"] = s.level.into();
                let adaptive = !s.edge_rates.is_empty();
                entry["subdiv_mode"] = if adaptive { "adaptive" } else { "uniform" }.into();
                if adaptive {
                    entry["min_edge_rate"] = s.edge_rates.iter().min().copied().into();
                    entry["max_edge_rate"] = s.edge_rates.iter().max().copied().into();
                }
            }
            entry
        })
        .collect();
    let triangles = listed_triangles(scene);
    let fixed = triangles_at_fixed_level(scene);
    let materials: Vec<serde_json::Value> = scene
        .materials
        .iter()
        .map(|m| {
            serde_json::json!({
                "path": m.path,
                "surface_model": m.look.surface_model,
                "node_categories": m.look.node_categories,
                "constants": material_constants(m),
            })
        })
        .collect();
    serde_json::json!({
        "gprims": gprims,
        "materials": materials,
        "instances": scene.instance_count,
        "world_origin": scene.world_origin.to_array(),
        "triangles": triangles,
        "triangles_at_fixed_level": fixed,
        "triangles_saved": fixed as i64 - triangles as i64,
    })
}

/// A material's constants by their blob names ([`blob::preview_surface_constants!`]): colours as
/// `[r, g, b]`, flags as booleans. Inputs a program drives are listed with their constant too.
fn material_constants(m: &crate::scene::Material) -> serde_json::Value {
    macro_rules! constants {
        ($($field:ident: $kind:ident = $fallback:expr, $usd:literal;)*) => {{
            let mut map = serde_json::Map::new();
            $(map.insert($usd.into(), constant_json!($kind, m.$field));)*
            serde_json::Value::Object(map)
        }};
    }
    macro_rules! constant_json {
        (color, $v:expr) => {
            serde_json::json!($v.to_array())
        };
        (float, $v:expr) => {
            serde_json::json!($v)
        };
        (flag, $v:expr) => {
            serde_json::json!($v)
        };
    }
    blob::preview_surface_constants!(constants)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dicing::{SubdivOptions, SubdivOptionsError};

    #[test]
    fn unlit_stages_are_warned_about_and_lit_ones_are_not() {
        let mut scene = Scene { materials: vec![crate::scene::Material::default()], ..Scene::default() };
        assert!(unlit_warning(&scene).is_some_and(|w| w.contains("no light")));
        scene.materials[0].emissive_color = glam::Vec3::new(0.0, 0.5, 0.0);
        assert_eq!(unlit_warning(&scene), None, "an emissive material lights the stage");
        scene.materials[0].emissive_color = glam::Vec3::ZERO;
        scene.lights.push(crate::scene::Light {
            path: "/Sun".into(),
            kind: crate::scene::LightKind::Distant { angle_degrees: 0.53 },
            radiance: glam::Vec3::ONE,
            normalize: false,
            world_from_light: glam::Mat4::IDENTITY,
        });
        assert_eq!(unlit_warning(&scene), None);
    }

    #[test]
    fn out_of_range_subdivision_options_are_refused_before_reading() {
        let above = subdiv::MAX_LEVEL + 1;
        let options = LoadOptions {
            subdiv: SubdivOptions { max_level: above, ..SubdivOptions::default() },
            ..LoadOptions::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let output = dir.path().join("out.blob");
        // The input does not exist: the options are checked first.
        let input = dir.path().join("scene.usda");
        let e = ingest_file(&input, &output, &options).unwrap_err();
        assert!(
            matches!(e, IngestError::SubdivOptions(SubdivOptionsError::LevelOutOfRange { option: "max_level", level }) if level == above),
            "{e:?}"
        );
        let message = format!(
            "invalid subdivision options: max_level is {above}, above the highest subdivision level {}",
            subdiv::MAX_LEVEL
        );
        assert_eq!(e.to_string(), message);
        assert!(!output.exists());
        // The USD reader refuses them too, naming the root layer.
        let e = usd::load(&input, &options).unwrap_err();
        assert_eq!(e.to_string(), format!("{}: {message}", input.display()));
        assert!(matches!(e.kind(), usd::UsdErrorKind::Invalid(_)));
    }
}

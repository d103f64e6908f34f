//! The whole ingest step as one library call, used by the binary and by the end-to-end tests.

use crate::scene::Scene;
use crate::usd::{self, LoadOptions};
use anyhow::Context;
use std::path::Path;
use std::time::Instant;

/// What an ingest run produced, for the summary line and the tests.
#[derive(Debug, Clone)]
pub struct IngestReport {
    /// Gprims written.
    pub meshes: usize,
    /// Triangles written.
    pub triangles: usize,
    /// Materials written.
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
}

/// Composes `input`, packs it and writes the blob to `output` atomically.
pub fn ingest_file(
    input: &Path,
    output: &Path,
    options: &LoadOptions,
) -> anyhow::Result<(Scene, IngestReport)> {
    let start = Instant::now();
    let scene = usd::load(input, options).with_context(|| format!("cannot ingest {}", input.display()))?;
    let load_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let data = crate::pack::pack(&scene).with_context(|| format!("cannot pack {}", input.display()))?;
    let bytes = data.encode();
    let pack_seconds = start.elapsed().as_secs_f64();
    blob::write_atomic(output, &bytes).with_context(|| format!("cannot write {}", output.display()))?;
    let report = IngestReport {
        meshes: scene.meshes.len(),
        triangles: scene.triangle_count(),
        materials: scene.materials.len(),
        lights: scene.lights.len(),
        cameras: scene.cameras.len(),
        blob_bytes: bytes.len(),
        load_seconds,
        pack_seconds,
        warnings: scene.warnings.iter().map(|w| format!("{}: {}", w.prim, w.message)).collect(),
    };
    Ok((scene, report))
}

/// The `--dump-json` listing: every rendered gprim with its world bounds, triangle count and material.
pub fn dump_json(scene: &Scene) -> serde_json::Value {
    let gprims: Vec<serde_json::Value> = scene
        .meshes
        .iter()
        .map(|m| {
            let (lo, hi) = m.positions.iter().fold(
                (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            );
            let mut materials: Vec<&str> =
                m.triangle_materials.iter().map(|&i| scene.materials[i as usize].path.as_str()).collect();
            materials.sort_unstable();
            materials.dedup();
            serde_json::json!({
                "path": m.path,
                "type": "Mesh",
                "triangles": m.triangles.len(),
                "bounds_min": lo.to_array(),
                "bounds_max": hi.to_array(),
                "materials": materials,
            })
        })
        .collect();
    serde_json::json!({ "gprims": gprims, "instances": scene.instance_count })
}

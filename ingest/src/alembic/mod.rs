//! Alembic reader: an Ogawa `.abc` archive becomes a [`Scene`] at one time.
//!
//! The archive is read with bounds checks on every field (`ogawa` for the container, `archive`
//! for Alembic's objects and properties, `time` for time samplings), and the objects at the
//! requested time are translated (`translate`, with `xform`, `geom`, `curves`, `camera`) into an
//! equivalent USD layer (`usda`) that the USD reader then reads. Going through USD is what makes
//! the Alembic path *the same* as the USD one without a second copy of it: n-gon triangulation,
//! face-varying splits, subdivision surfaces (OpenSubdiv cages, creases, dicing against the
//! camera), curve basis conversion, Points, cameras and visibility all run through
//! [`crate::usd`]. The layer is written to a temporary file (the USD stage opens files) and
//! removed after reading; prim paths in the scene and its warnings are mapped back to the
//! Alembic object paths.
//!
//! What maps to what:
//! - Xform → Xform with one `xformOp:transform` (`.inherits = false` resets the stack);
//! - PolyMesh → Mesh (`subdivisionScheme = "none"`), SubD → Mesh with its scheme, creases,
//!   corners and holes; `N` and `uv` → `primvars:normals` and `primvars:st`;
//! - face sets → GeomSubsets, each bound to a default-grey UsdPreviewSurface named after the
//!   face set (`faceset:NAME`); faces in no set get `default grey`. Alembic has no materials;
//! - Curves → BasisCurves (linear, or cubic Bézier / B-spline / Catmull–Rom) or NurbsCurves
//!   (variable order); Points → Points; widths are diameters in both;
//! - Camera → Camera (apertures ×10, as usdAbc does);
//! - `visible = 0` → `visibility = "invisible"`.
//!
//! Time: `--frame F` reads time F / fps seconds, fps being the archive's `FramesPerTimeUnit`
//! (Blender writes it) or the rate of its first uniform time sampling, else 24. Each property
//! is read at the last sample at or before that time; positions, transforms, normals, widths and
//! camera lenses are blended linearly with the next sample, everything else is held. Without
//! `--frame` every property's first sample is read. The archive is Y-up in meters.

mod archive;
mod camera;
mod curves;
mod geom;
mod ogawa;
mod sample;
mod time;
mod translate;
mod usda;
mod xform;

#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::scene::Scene;
use crate::usd::{self, LoadOptions};
use archive::Archive;
use sample::Sampler;
use time::When;
use translate::Translator;

/// A file that cannot be read, or an object in it that cannot be translated.
///
/// Displays as `file: /object/path: message`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}: {}{message}", object.as_ref().map(|o| format!("{o}: ")).unwrap_or_default())]
pub struct AlembicError {
    /// The archive.
    pub file: String,
    /// The Alembic object path, when the problem is in one object.
    pub object: Option<String>,
    /// What is wrong.
    pub message: String,
}

/// Whether `path` names an Alembic archive (by extension, `.abc` in any case).
pub fn is_alembic(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("abc"))
}

/// Frames per second of the archive: `FramesPerTimeUnit`, else its first uniform sampling.
fn frames_per_second(archive: &Archive) -> f64 {
    if let Some(fps) = archive.metadata.get("FramesPerTimeUnit").and_then(|s| s.parse::<f64>().ok()) {
        if fps.is_finite() && fps > 0.0 {
            return fps;
        }
    }
    // Sampling 0 is the identity sampling (one second per sample), not a frame rate.
    archive.time_samplings.iter().skip(1).find_map(|s| s.uniform_step()).map_or(24.0, |step| 1.0 / step)
}

/// Reads the archive at `path` into a world-space [`Scene`], at `options.frame` (see the
/// module documentation); subdivision options apply as for USD.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, AlembicError> {
    let file = path.display().to_string();
    let error =
        |object: Option<String>, message: String| AlembicError { file: file.clone(), object, message };
    let bytes = std::fs::read(path).map_err(|e| error(None, format!("cannot read: {e}")))?;
    let archive =
        Archive::open(bytes).map_err(|m| error(None, format!("not a readable Alembic archive: {m}")))?;
    let when = match options.frame {
        Some(frame) => When::At(frame / frames_per_second(&archive)),
        None => When::First,
    };
    let mut translator = Translator::new(Sampler { archive, when });
    translator.run().map_err(|(object, message)| error(Some(object), message))?;
    let warnings = std::mem::take(&mut translator.warnings);
    let (text, paths) = translator.layer.finish();

    let layer = TempLayer::write(&text)
        .map_err(|e| error(None, format!("cannot write the translated layer: {e}")))?;
    let usd_options = LoadOptions { frame: None, lenient: false, asset_paths: Vec::new(), ..options.clone() };
    let mut scene = usd::load(&layer.0, &usd_options).map_err(|e| {
        let message = match e.attribute_name() {
            Some(attr) => format!("{attr}: {}", e.kind()),
            None => e.kind().to_string(),
        };
        error(e.prim().map(|p| paths.restore(p)), message)
    })?;
    drop(layer);

    for m in &mut scene.meshes {
        m.path = paths.restore(&m.path);
    }
    for c in &mut scene.curves {
        c.path = paths.restore(&c.path);
    }
    for c in &mut scene.cameras {
        c.path = paths.restore(&c.path);
    }
    for m in &mut scene.materials {
        m.path = paths.restore(&m.path);
    }
    for w in &mut scene.warnings {
        w.prim = paths.restore(&w.prim);
    }
    for (object, message) in warnings {
        scene.warn(object, message);
    }
    Ok(scene)
}

/// The translated layer on disk, removed when dropped.
struct TempLayer(PathBuf);

impl TempLayer {
    fn write(text: &str) -> std::io::Result<Self> {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let name =
            format!("ingest-alembic-{}-{}.usda", std::process::id(), NEXT.fetch_add(1, Ordering::Relaxed));
        let path = std::env::temp_dir().join(name);
        std::fs::write(&path, text)?;
        Ok(TempLayer(path))
    }
}

impl Drop for TempLayer {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

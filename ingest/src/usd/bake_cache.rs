//! Texture bakes shared by the frames of a sequence ([`super::load_sequence`]).
//!
//! Decoding a texture file and building its mip pyramid is the same work at every frame (the
//! file does not change while a sequence is ingested), so a sequence bakes each (file, bake
//! options) once and hands every later frame a copy of the result. A failure is kept as its
//! message, so a later frame warns with the same words as the first. A frame whose material
//! names another file (a time-sampled `inputs:file`) simply misses the cache and bakes it.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// A baked image, or why it could not be baked.
pub(super) type Baked = Arc<Result<texture::BakedTexture, String>>;
/// A baked dome image with the scale that fitted it into half-float range, or why not.
pub(super) type BakedDome = Arc<Result<(texture::BakedTexture, f32), String>>;

/// The bakes of one sequence, by file and options. Shared by the tiles of a UDIM set baked in
/// parallel (hence the lock; it is held for the look-up and the insert, never for a bake).
#[derive(Default)]
pub(crate) struct BakeCache {
    images: Mutex<HashMap<(PathBuf, texture::BakeOptions), Baked>>,
    domes: Mutex<HashMap<PathBuf, BakedDome>>,
    /// Bakes served from the cache (for the sequence report and its tests).
    hits: std::sync::atomic::AtomicUsize,
}

impl BakeCache {
    /// The bake of `path` with `options`, from the cache or made by `bake` (and kept).
    pub(super) fn image(
        &self,
        path: &Path,
        options: texture::BakeOptions,
        bake: impl FnOnce() -> Result<texture::BakedTexture, String>,
    ) -> Baked {
        let key = (path.to_path_buf(), options);
        if let Some(hit) = self.images.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
            self.hits.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            return hit.clone();
        }
        let baked = Arc::new(bake());
        self.images.lock().unwrap_or_else(|p| p.into_inner()).insert(key, baked.clone());
        baked
    }

    /// The dome bake of `path`, from the cache or made by `bake` (and kept).
    pub(super) fn dome(
        &self,
        path: &Path,
        bake: impl FnOnce() -> Result<(texture::BakedTexture, f32), String>,
    ) -> BakedDome {
        if let Some(hit) = self.domes.lock().unwrap_or_else(|p| p.into_inner()).get(path) {
            self.hits.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            return hit.clone();
        }
        let baked = Arc::new(bake());
        self.domes.lock().unwrap_or_else(|p| p.into_inner()).insert(path.to_path_buf(), baked.clone());
        baked
    }

    /// How many bakes were served from the cache so far.
    pub(crate) fn hits(&self) -> usize {
        self.hits.load(std::sync::atomic::Ordering::Relaxed)
    }
}

//! The asset resolver the stage opens layers through: `openusd`'s filesystem resolver plus
//! search paths and the text-layer fixes of [`super::layer_fix`].
//!
//! The crate reads every layer's bytes through [`ar::Resolver::open_asset`], so a resolver is
//! the one place where a `.usda` layer (plain, `.usd` holding text, or inside a `.usdz`) can be
//! handed to the crate already normalized, without copying or patching the crate's parser.
//!
//! Search paths follow usd-core's `ArDefaultResolver`: an asset path that is relative but not
//! file-relative (`tex/a.usda`, not `./a.usda` or `../a.usda`) is looked up next to the layer
//! that names it first, then in each search directory in order.

use std::collections::HashSet;
use std::io::{self, Cursor, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use openusd::ar::{self, Asset, DefaultResolver, ResolvedPath, Resolver};

use super::{crate_check, layer_fix};

/// Magic bytes that open every text layer.
const USDA_MAGIC: &[u8] = b"#usda";

/// [`DefaultResolver`] with search paths, `.usda` normalization and crate-file checks.
pub(crate) struct IngestResolver {
    inner: DefaultResolver,
    search_paths: Vec<PathBuf>,
    /// Crate files already checked: openusd opens a `.usd` twice (once to sniff its format).
    checked_crates: Mutex<HashSet<ResolvedPath>>,
}

impl IngestResolver {
    /// A resolver searching `search_paths` (in order) after the referencing layer's directory.
    pub(crate) fn new(search_paths: &[PathBuf]) -> Self {
        let search_paths: Vec<PathBuf> =
            search_paths.iter().map(|p| p.canonicalize().unwrap_or_else(|_| p.clone())).collect();
        IngestResolver { inner: DefaultResolver::new(), search_paths, checked_crates: Mutex::default() }
    }

    /// Runs [`crate_check::check`] on a crate file's bytes, once per file; the error names the
    /// file, the section and the problem.
    fn check_crate(&self, resolved: &ResolvedPath, bytes: &[u8]) -> io::Result<()> {
        let mut checked = self.checked_crates.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if checked.contains(resolved) {
            return Ok(());
        }
        crate_check::check(bytes).map_err(|e| {
            let name =
                resolved.file_name().map_or_else(|| resolved.to_string(), |n| n.to_string_lossy().into());
            io::Error::new(io::ErrorKind::InvalidData, format!("{name}: {e}"))
        })?;
        checked.insert(resolved.clone());
        Ok(())
    }

    /// The layer's text as the crate receives it, if `resolved` is a text layer.
    pub(crate) fn layer_text(&self, resolved: &ResolvedPath) -> Option<String> {
        let bytes = self.open_asset(resolved).ok()?.read_all().ok()?;
        bytes.starts_with(USDA_MAGIC).then(|| String::from_utf8(bytes).ok()).flatten()
    }

    /// `asset_path` names a search-path asset: relative, not `./`- or `../`-anchored, no package.
    fn is_search_path(asset_path: &str) -> bool {
        !(asset_path.is_empty()
            || Path::new(asset_path).is_absolute()
            || asset_path.starts_with("./")
            || asset_path.starts_with("../")
            || ar::is_package_relative_path(asset_path))
    }
}

impl Resolver for IngestResolver {
    fn create_identifier(&self, asset_path: &str, anchor: Option<&ResolvedPath>) -> String {
        let anchored = self.inner.create_identifier(asset_path, anchor);
        if self.search_paths.is_empty()
            || !Self::is_search_path(asset_path)
            || self.inner.resolve(&anchored).is_some()
        {
            return anchored;
        }
        self.search_paths
            .iter()
            .map(|dir| dir.join(asset_path))
            .find(|candidate| candidate.exists())
            .map(|found| self.inner.create_identifier(&found.to_string_lossy(), None))
            .unwrap_or(anchored)
    }

    fn resolve(&self, asset_path: &str) -> Option<ResolvedPath> {
        self.inner.resolve(asset_path)
    }

    fn resolve_for_new_asset(&self, asset_path: &str) -> Option<ResolvedPath> {
        self.inner.resolve_for_new_asset(asset_path)
    }

    /// Text layers are normalized; crate files (`.usdc`, binary `.usd`, either inside a `.usdz`)
    /// are checked by [`crate_check`] first, because openusd's crate reader trusts their counts
    /// and indices; every other asset (packages, images) is passed through. Only the first bytes
    /// are read to tell them apart, so packages and images are not buffered here.
    fn open_asset(&self, resolved: &ResolvedPath) -> io::Result<Box<dyn Asset>> {
        let mut asset = self.inner.open_asset(resolved)?;
        let mut magic = [0u8; crate_check::MAGIC.len()];
        let mut filled = 0;
        while filled < magic.len() {
            match asset.read(&mut magic[filled..])? {
                0 => break,
                n => filled += n,
            }
        }
        asset.seek(SeekFrom::Start(0))?;
        if magic[..filled] == *crate_check::MAGIC {
            let bytes = asset.read_all()?;
            self.check_crate(resolved, &bytes)?;
            // Old files' time-sample times, in the layout openusd reads (checked again).
            let bytes = crate_check::repair(&bytes).unwrap_or(bytes);
            return Ok(Box::new(Cursor::new(bytes)));
        }
        if !magic[..filled].starts_with(USDA_MAGIC) {
            return Ok(asset);
        }
        let bytes = asset.read_all()?;
        // Invalid UTF-8 is passed through for the crate to report.
        let Ok(text) = std::str::from_utf8(&bytes) else { return Ok(Box::new(Cursor::new(bytes))) };
        if let Some(problem) = layer_fix::structural_problem(text) {
            let name =
                resolved.file_name().map_or_else(|| resolved.to_string(), |n| n.to_string_lossy().into());
            return Err(io::Error::new(io::ErrorKind::InvalidData, format!("{name}: {problem}")));
        }
        match layer_fix::normalize(text) {
            std::borrow::Cow::Borrowed(_) => Ok(Box::new(Cursor::new(bytes))),
            std::borrow::Cow::Owned(fixed) => Ok(Box::new(Cursor::new(fixed.into_bytes()))),
        }
    }

    fn get_asset_info(&self, asset_path: &str, resolved: &ResolvedPath) -> ar::AssetInfo {
        self.inner.get_asset_info(asset_path, resolved)
    }

    fn identity(&self) -> String {
        format!("ingest:{:?}", self.search_paths)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn search_paths_apply_to_search_path_assets_only() {
        assert!(IngestResolver::is_search_path("tex/a.usda"));
        assert!(IngestResolver::is_search_path("a.usda"));
        assert!(!IngestResolver::is_search_path("./a.usda"));
        assert!(!IngestResolver::is_search_path("../a.usda"));
        assert!(!IngestResolver::is_search_path("/abs/a.usda"));
        assert!(!IngestResolver::is_search_path("pkg.usdz[a.usda]"));
    }

    #[test]
    fn anchored_asset_wins_over_search_paths() {
        let dir = tempfile::tempdir().unwrap();
        let (near, lib) = (dir.path().join("near"), dir.path().join("lib"));
        std::fs::create_dir_all(&near).unwrap();
        std::fs::create_dir_all(lib.join("sub")).unwrap();
        std::fs::write(near.join("a.usda"), "#usda 1.0\n").unwrap();
        std::fs::write(lib.join("a.usda"), "#usda 1.0\n").unwrap();
        std::fs::write(lib.join("sub/b.usda"), "#usda 1.0\n").unwrap();
        let resolver = IngestResolver::new(std::slice::from_ref(&lib));
        let anchor =
            ResolvedPath::new(near.join("root.usda").canonicalize().unwrap_or(near.join("root.usda")));
        let a = resolver.create_identifier("a.usda", Some(&anchor));
        assert_eq!(Path::new(&a), near.join("a.usda").canonicalize().unwrap());
        let b = resolver.create_identifier("sub/b.usda", Some(&anchor));
        assert_eq!(Path::new(&b), lib.join("sub/b.usda").canonicalize().unwrap());
        // File-relative paths never consult the search paths.
        let c = resolver.create_identifier("./sub/b.usda", Some(&anchor));
        assert!(resolver.resolve(&c).is_none());
    }

    #[test]
    fn text_layers_are_normalized_and_others_passed_through() {
        let dir = tempfile::tempdir().unwrap();
        let text = dir.path().join("a.usd");
        let binary = dir.path().join("b.png");
        std::fs::write(&text, "#usda 1.0\nfloat a = .5\n").unwrap();
        std::fs::write(&binary, b"\x89PNG .5").unwrap();
        let resolver = IngestResolver::new(&[]);
        let read = |p: &Path| resolver.open_asset(&ResolvedPath::new(p)).unwrap().read_all().unwrap();
        assert_eq!(read(&text), b"#usda 1.0\nfloat a = 0.5\n");
        assert_eq!(read(&binary), b"\x89PNG .5");
    }

    #[test]
    fn crate_files_are_checked_before_the_crate_reads_them() {
        let dir = tempfile::tempdir().unwrap();
        let broken = dir.path().join("broken.usd");
        std::fs::write(&broken, b"PXR-USDC .5").unwrap();
        let resolver = IngestResolver::new(&[]);
        let Err(e) = resolver.open_asset(&ResolvedPath::new(&broken)) else {
            panic!("broken crate file accepted")
        };
        assert_eq!(
            e.to_string(),
            "broken.usd: bootstrap: header needs 32 bytes at offset 0 but only 11 remain (truncated?)"
        );
    }
}

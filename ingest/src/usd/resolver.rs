//! The asset resolver the stage opens layers through: `openusd`'s filesystem resolver plus
//! search paths and the text-layer fixes of [`super::compat::layer_fix`].
//!
//! The crate reads every layer's bytes through [`ar::Resolver::open_asset`], so a resolver is
//! the one place where a `.usda` layer (plain, `.usd` holding text, or inside a `.usdz`) can be
//! handed to the crate already normalized, and a crate file already checked, without copying or
//! patching the crate's parser.
//!
//! MaterialX documents are layers too, as usdMtlx makes them: a `.mtlx` file resolves to a
//! stand-in path beside it ending in `.mtlx.usda` (the crate picks a layer's format by the resolved
//! path's extension), and opening that path serves the document translated to USDA by
//! [`super::mtlx_document`], so `.mtlx` references and sublayers compose like any layer.
//!
//! Search paths follow usd-core's `ArDefaultResolver`: an asset path that is relative but not
//! file-relative (`tex/a.usda`, not `./a.usda` or `../a.usda`) is looked up next to the layer
//! that names it first, then in each search directory in order.

use std::collections::HashMap;
use std::io::{self, Cursor, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use openusd::ar::{self, Asset, DefaultResolver, ResolvedPath, Resolver};

use super::compat::{crate_check, layer_fix};

/// Magic bytes that open every text layer.
const USDA_MAGIC: &[u8] = b"#usda";

/// Extensions of the layers a text layer's asset paths may name that are prepared ahead of need.
const LAYER_EXTENSIONS: &[&str] = &["usda", "usd", "usdc"];

/// [`DefaultResolver`] with search paths, `.usda` normalization and crate-file checks.
///
/// Layers are prepared once each and ahead of need: when a text layer is prepared, the layers
/// its asset paths name are prepared on rayon's pool while the crate parses this one (the crate
/// opens and parses layers one at a time; preparing a text layer costs about half of parsing
/// it, and checking a crate file a few milliseconds per megabyte).
pub(crate) struct IngestResolver {
    shared: Arc<Shared>,
}

/// The resolver's state, shared with the prefetch tasks.
struct Shared {
    inner: DefaultResolver,
    search_paths: Vec<PathBuf>,
    /// Every file opened or prefetched, by resolved path, once prepared. openusd opens a layer
    /// more than once (a `.usd` once to sniff its format and once to read it; the root layer
    /// once for its expression variables and once for its stack), so a file is read, checked
    /// and normalized once, not per open; the cell makes a reader that arrives while a
    /// prefetch task prepares the file wait for it instead of redoing it.
    prepared: Mutex<HashMap<ResolvedPath, Arc<OnceLock<Prepared>>>>,
    /// Identifiers already created, by (asset path, anchor); see [`Shared::create_identifier`].
    identifiers: Mutex<HashMap<(String, Option<ResolvedPath>), String>>,
    /// The MaterialX document behind each stand-in layer path handed out by [`Shared::layer_path`].
    mtlx_documents: Mutex<HashMap<ResolvedPath, ResolvedPath>>,
}

/// A file as [`Shared::prepare`] left it.
enum Prepared {
    /// A text layer checked and normalized, or a crate file checked and repaired: the bytes the
    /// crate is given.
    Layer(Arc<[u8]>),
    /// A text layer [`layer_fix::prepare`] or a crate file [`crate_check::check`] rejected, or
    /// a crate file that could not be read, with the problem.
    Rejected(String),
    /// Not a layer (a package, an image), or unopenable: opened the plain way, so the crate
    /// reports a missing file as missing.
    Other,
}

/// A prepared layer's bytes, shared with the cache.
struct SharedBytes(Cursor<Arc<[u8]>>);

impl Read for SharedBytes {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.0.read(buf)
    }
}

impl Seek for SharedBytes {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.0.seek(pos)
    }
}

impl Asset for SharedBytes {
    fn size(&self) -> io::Result<u64> {
        Ok(self.0.get_ref().len() as u64)
    }
}

fn file_name(resolved: &ResolvedPath) -> String {
    resolved.file_name().map_or_else(|| resolved.to_string(), |n| n.to_string_lossy().into())
}

/// Reads the first `n` bytes of `asset` (fewer if it is shorter) and rewinds it.
fn read_magic(asset: &mut dyn Asset, n: usize) -> io::Result<Vec<u8>> {
    let mut magic = vec![0u8; n];
    let mut filled = 0;
    while filled < n {
        match asset.read(&mut magic[filled..])? {
            0 => break,
            k => filled += k,
        }
    }
    magic.truncate(filled);
    asset.seek(SeekFrom::Start(0))?;
    Ok(magic)
}

impl IngestResolver {
    /// A resolver searching `search_paths` (in order) after the referencing layer's directory.
    pub(crate) fn new(search_paths: &[PathBuf]) -> Self {
        let search_paths: Vec<PathBuf> =
            search_paths.iter().map(|p| p.canonicalize().unwrap_or_else(|_| p.clone())).collect();
        IngestResolver {
            shared: Arc::new(Shared {
                inner: DefaultResolver::new(),
                search_paths,
                prepared: Mutex::default(),
                identifiers: Mutex::default(),
                mtlx_documents: Mutex::default(),
            }),
        }
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

impl Shared {
    /// [`Self::identify`], once per (asset path, anchor): openusd asks again for every arc
    /// that names the same asset (a thousand references to one file in a layout), and each
    /// answer canonicalizes the path on the filesystem (a `readlink` per path component: 1,600
    /// system calls listing the teapot scene).
    fn create_identifier(&self, asset_path: &str, anchor: Option<&ResolvedPath>) -> String {
        let key = (asset_path.to_string(), anchor.cloned());
        let lock = || self.identifiers.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(identifier) = lock().get(&key) {
            return identifier.clone();
        }
        let identifier = self.identify(asset_path, anchor);
        lock().insert(key, identifier.clone());
        identifier
    }

    /// The identifier of `asset_path` authored in the layer at `anchor`: next to that layer,
    /// else in the first search directory holding it.
    fn identify(&self, asset_path: &str, anchor: Option<&ResolvedPath>) -> String {
        let anchored = self.inner.create_identifier(asset_path, anchor);
        if self.search_paths.is_empty()
            || !IngestResolver::is_search_path(asset_path)
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

    /// The layer the crate opens for `resolved`: itself, or for a MaterialX document the stand-in
    /// `<file>.mtlx.usda` path that [`Self::prepare`] serves translated (see the module docs).
    fn layer_path(&self, resolved: ResolvedPath) -> ResolvedPath {
        let text = resolved.to_string_lossy();
        if !super::mtlx_document::is_mtlx(&resolved) || ar::is_package_relative_path(&text) {
            return resolved;
        }
        let stand_in = ResolvedPath::new(format!("{text}.usda"));
        let mut documents = self.mtlx_documents.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        documents.insert(stand_in.clone(), resolved);
        stand_in
    }

    /// A MaterialX document as the USDA layer [`super::mtlx_document::translate`] makes of it.
    fn prepare_mtlx(&self, document: &ResolvedPath) -> Prepared {
        let name = file_name(document);
        let text = match self.inner.open_asset(document).and_then(|mut a| a.read_all()) {
            Ok(bytes) => match String::from_utf8(bytes) {
                Ok(text) => text,
                Err(_) => return Prepared::Rejected(format!("{name}: not UTF-8 text")),
            },
            Err(e) => return Prepared::Rejected(format!("{name}: {e}")),
        };
        match super::mtlx_document::translate(&text, &name) {
            Ok(layer) => Prepared::Layer(layer.into_bytes().into()),
            Err(problem) => Prepared::Rejected(problem),
        }
    }

    /// The cell of `resolved` and whether this call created it.
    fn cell(&self, resolved: &ResolvedPath) -> (Arc<OnceLock<Prepared>>, bool) {
        let mut prepared = self.prepared.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        match prepared.get(resolved) {
            Some(cell) => (Arc::clone(cell), false),
            None => {
                let cell = Arc::new(OnceLock::new());
                prepared.insert(resolved.clone(), Arc::clone(&cell));
                (cell, true)
            }
        }
    }

    /// Reads `resolved` and, if it is a text layer, checks and normalizes it, then starts the
    /// preparation of the layers it names; if it is a crate file, checks and repairs it.
    fn prepare(self: &Arc<Self>, resolved: &ResolvedPath) -> Prepared {
        let document = self.mtlx_documents.lock().unwrap_or_else(|p| p.into_inner()).get(resolved).cloned();
        if let Some(document) = document {
            return self.prepare_mtlx(&document);
        }
        let Ok(mut asset) = self.inner.open_asset(resolved) else { return Prepared::Other };
        let magic = match read_magic(asset.as_mut(), crate_check::MAGIC.len()) {
            Ok(magic) => magic,
            Err(_) => return Prepared::Other,
        };
        if magic == crate_check::MAGIC {
            return Self::prepare_crate(resolved, asset.as_mut());
        }
        if !magic.starts_with(USDA_MAGIC) {
            return Prepared::Other;
        }
        let Ok(bytes) = asset.read_all() else { return Prepared::Other };
        // Invalid UTF-8 is passed through for the crate to report.
        let Ok(text) = std::str::from_utf8(&bytes) else { return Prepared::Layer(bytes.into()) };
        match layer_fix::prepare(text) {
            Err(problem) => Prepared::Rejected(format!("{}: {problem}", file_name(resolved))),
            Ok(layer) => {
                self.prefetch(resolved, &layer.asset_paths);
                Prepared::Layer(match layer.text {
                    std::borrow::Cow::Borrowed(_) => bytes.into(),
                    std::borrow::Cow::Owned(fixed) => fixed.into_bytes().into(),
                })
            }
        }
    }

    /// A crate file (`.usdc`, binary `.usd`, either inside a `.usdz`) checked by
    /// [`crate_check`], because openusd's crate reader trusts its counts and indices, and
    /// repaired where openusd misreads old files; the error names the file, the section and
    /// the problem.
    fn prepare_crate(resolved: &ResolvedPath, asset: &mut dyn Asset) -> Prepared {
        let rejected = |problem: &dyn std::fmt::Display| {
            Prepared::Rejected(format!("{}: {problem}", file_name(resolved)))
        };
        let bytes = match asset.read_all() {
            Ok(bytes) => bytes,
            Err(e) => return rejected(&e),
        };
        if let Err(e) = crate_check::check(&bytes) {
            return rejected(&e);
        }
        // Old files' time-sample times, in the layout openusd reads (checked again).
        Prepared::Layer(crate_check::repair(&bytes).unwrap_or(bytes).into())
    }

    /// Starts preparing, on rayon's pool, each layer `asset_paths` (authored in the layer at
    /// `anchor`) names that no one has asked for yet. A file the crate never opens (an
    /// unselected variant's, an unloaded payload's) costs background time only: its problems
    /// are reported if and when the crate opens it.
    fn prefetch(self: &Arc<Self>, anchor: &ResolvedPath, asset_paths: &[&str]) {
        for asset_path in asset_paths {
            let is_layer = Path::new(asset_path)
                .extension()
                .is_some_and(|e| LAYER_EXTENSIONS.iter().any(|t| e.eq_ignore_ascii_case(t)));
            if !is_layer || ar::is_package_relative_path(asset_path) {
                continue;
            }
            let identifier = self.create_identifier(asset_path, Some(anchor));
            let Some(resolved) = self.inner.resolve(&identifier) else { continue };
            let (cell, created) = self.cell(&resolved);
            if created {
                let shared = Arc::clone(self);
                rayon::spawn(move || {
                    cell.get_or_init(|| shared.prepare(&resolved));
                });
            }
        }
    }

    /// The asset the crate reads: see [`Resolver::open_asset`] on [`IngestResolver`].
    fn open_asset(self: &Arc<Self>, resolved: &ResolvedPath) -> io::Result<Box<dyn Asset>> {
        let (cell, _) = self.cell(resolved);
        match cell.get_or_init(|| self.prepare(resolved)) {
            Prepared::Layer(bytes) => Ok(Box::new(SharedBytes(Cursor::new(Arc::clone(bytes))))),
            Prepared::Rejected(problem) => Err(io::Error::new(io::ErrorKind::InvalidData, problem.clone())),
            Prepared::Other => self.inner.open_asset(resolved),
        }
    }
}

impl Resolver for IngestResolver {
    fn create_identifier(&self, asset_path: &str, anchor: Option<&ResolvedPath>) -> String {
        self.shared.create_identifier(asset_path, anchor)
    }

    fn resolve(&self, asset_path: &str) -> Option<ResolvedPath> {
        self.shared.inner.resolve(asset_path).map(|resolved| self.shared.layer_path(resolved))
    }

    fn resolve_for_new_asset(&self, asset_path: &str) -> Option<ResolvedPath> {
        self.shared.inner.resolve_for_new_asset(asset_path)
    }

    /// Text layers are checked and normalized and crate files (`.usdc`, binary `.usd`, either
    /// inside a `.usdz`) checked by [`crate_check`] first, because openusd's crate reader trusts
    /// their counts and indices (once each, see [`IngestResolver`]); every other asset
    /// (packages, images) is passed through. Only the first bytes are read to tell them apart,
    /// so packages and images are not buffered here.
    fn open_asset(&self, resolved: &ResolvedPath) -> io::Result<Box<dyn Asset>> {
        self.shared.open_asset(resolved)
    }

    fn get_asset_info(&self, asset_path: &str, resolved: &ResolvedPath) -> ar::AssetInfo {
        self.shared.inner.get_asset_info(asset_path, resolved)
    }

    fn identity(&self) -> String {
        format!("ingest:{:?}", self.shared.search_paths)
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
    fn identifiers_are_created_once_per_asset_path_and_anchor() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.usda"), dir.path().join("b.usda"));
        std::fs::write(&a, "#usda 1.0\n").unwrap();
        let resolver = IngestResolver::new(&[]);
        let anchor = ResolvedPath::new(dir.path().join("root.usda"));
        let first = resolver.create_identifier("./a.usda", Some(&anchor));
        assert_eq!(Path::new(&first), a.canonicalize().unwrap());
        // Moved on disk afterwards: the identifier is the one created first, for this load.
        std::fs::rename(&a, &b).unwrap();
        assert_eq!(resolver.create_identifier("./a.usda", Some(&anchor)), first);
        // Another anchor is another question.
        let elsewhere = ResolvedPath::new(dir.path().join("sub/root.usda"));
        assert_ne!(resolver.create_identifier("./a.usda", Some(&elsewhere)), first);
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

    /// Waits until `resolved` has been prepared (by a prefetch task), or panics after a minute.
    fn wait_prepared(resolver: &IngestResolver, resolved: &ResolvedPath) {
        for _ in 0..6000 {
            let cell = resolver.shared.prepared.lock().unwrap().get(resolved).cloned();
            if cell.is_some_and(|c| c.get().is_some()) {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        panic!("{resolved} never prepared");
    }

    #[test]
    fn text_layers_are_prepared_once_and_the_layers_they_name_ahead_of_need() {
        let dir = tempfile::tempdir().unwrap();
        let (root, child, image) =
            (dir.path().join("root.usd"), dir.path().join("child.usda"), dir.path().join("t.png"));
        std::fs::write(&root, "#usda 1.0\ndef \"A\" (references = @./child.usda@) { asset f = @./t.png@ }\n")
            .unwrap();
        std::fs::write(&child, "#usda 1.0\nfloat a = .5\n").unwrap();
        std::fs::write(&image, b"\x89PNG").unwrap();
        let resolver = IngestResolver::new(&[]);
        let read = |p: &Path| resolver.open_asset(&ResolvedPath::new(p)).unwrap().read_all().unwrap();
        let first = read(&root);
        let child_resolved = resolver
            .resolve(&resolver.create_identifier("./child.usda", Some(&ResolvedPath::new(&root))))
            .unwrap();
        wait_prepared(&resolver, &child_resolved);
        // Rewritten on disk after preparation: the crate is served what was prepared, once.
        std::fs::write(&root, "#usda 1.0\n").unwrap();
        std::fs::write(&child, "#usda 1.0\n").unwrap();
        assert_eq!(read(&root), first);
        assert_eq!(read(&child), b"#usda 1.0\nfloat a = 0.5\n");
        // Only layers are prefetched; other assets are opened as they are asked for.
        let image_resolved = ResolvedPath::new(image.canonicalize().unwrap());
        assert!(!resolver.shared.prepared.lock().unwrap().contains_key(&image_resolved));
        assert_eq!(read(&image), b"\x89PNG");
    }

    #[test]
    fn a_rejected_layer_is_reported_every_time_it_is_opened() {
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.usda");
        std::fs::write(&bad, "#usda 1.0\ndef \"a b\" {}\n").unwrap();
        let resolver = IngestResolver::new(&[]);
        for _ in 0..2 {
            let Err(e) = resolver.open_asset(&ResolvedPath::new(&bad)) else { panic!("accepted") };
            assert_eq!(
                e.to_string(),
                "bad.usda: line 2, column 5: prim name \"a b\" is malformed: unexpected ' ' at character 1"
            );
        }
    }

    #[test]
    fn crate_files_are_read_checked_and_repaired_once_and_ahead_of_need() {
        let dir = tempfile::tempdir().unwrap();
        let testdata = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/usd/compat/crate_check/testdata");
        // 0.6.0: a layout `crate_check::repair` rewrites, so the served bytes differ from the file.
        let original = std::fs::read(testdata.join("time_samples_0_6_0.usdc")).unwrap();
        let (root, geo) = (dir.path().join("root.usda"), dir.path().join("geo.usd"));
        std::fs::write(&root, "#usda 1.0\ndef \"A\" (references = @./geo.usd@) {}\n").unwrap();
        std::fs::write(&geo, &original).unwrap();
        let resolver = IngestResolver::new(&[]);
        let read = |p: &Path| resolver.open_asset(&ResolvedPath::new(p)).unwrap().read_all().unwrap();
        read(&root);
        let geo_resolved = resolver
            .resolve(&resolver.create_identifier("./geo.usd", Some(&ResolvedPath::new(&root))))
            .unwrap();
        wait_prepared(&resolver, &geo_resolved);
        // Truncated on disk after preparation: every open (the crate's sniff, then its read) is
        // served the bytes checked and repaired once.
        std::fs::write(&geo, b"PXR-USDC").unwrap();
        let served = read(&geo);
        assert_eq!(served, crate_check::repair(&original).expect("0.6.0 times are repaired"));
        assert_eq!(read(&geo), served);
        assert!(crate_check::check(&served).is_ok());
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

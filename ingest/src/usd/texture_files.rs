//! Texture files named by asset paths: resolution against the authoring layer (with `.usdz`
//! packages as USD's resolver anchors them) and decoding, from disk or from a package entry in
//! place. Used by UsdUVTexture nodes and by textured dome lights.

use openusd::ar::{self, Resolver};
use std::path::{Path, PathBuf};

/// Resolves a texture asset path against the layer that authored it: absolute paths as they are,
/// relative ones (`./`, `../` or bare) next to the layer file. Inside a `.usdz` package (a layer
/// `pkg.usdz[inner.usdc]`, or the package itself as the root layer) and for package-relative assets
/// (`pkg.usdz[textures/a.png]`) the result is package-relative, `…/pkg.usdz[textures/a.png]`, as
/// USD's resolver anchors it; [`decode_texture`] reads such an entry from the zip.
pub(super) fn resolve_asset(layer: &str, asset: &str) -> Result<PathBuf, String> {
    let packaged = ar::is_package_relative_path(asset)
        || ar::is_package_relative_path(layer)
        || layer.to_ascii_lowercase().ends_with(".usdz");
    if packaged {
        let anchor = ar::ResolvedPath::new(layer);
        let id = ar::DefaultResolver::new().create_identifier(asset, Some(&anchor));
        if ar::split_package_relative_path_inner(&id)
            .is_some_and(|(package, _)| ar::is_package_relative_path(&package))
        {
            return Err("textures inside nested packages are not supported".into());
        }
        return Ok(PathBuf::from(id));
    }
    let asset_path = Path::new(asset);
    if asset_path.is_absolute() {
        return Ok(asset_path.to_path_buf());
    }
    let base = Path::new(layer).parent().unwrap_or(Path::new("."));
    let joined = base.join(asset_path.strip_prefix("./").unwrap_or(asset_path));
    Ok(joined)
}

/// A package-relative texture path split into the package file and the entry inside it.
pub(super) fn packaged(path: &Path) -> Option<(PathBuf, String)> {
    let text = path.to_str()?;
    let (package, inner) = ar::split_package_relative_path_outer(text)?;
    Some((PathBuf::from(package), inner))
}

/// Where a texture is read from: a package entry stays package-relative when the package holds it;
/// one the package lacks is looked for beside the package, as a file (a package may ship only its
/// layer and reference textures next to it, like OpenUSD's `usdUdims.usdz`). `<UDIM>` patterns in
/// a package are read beside it only (tiles are not listed from the zip).
pub(super) fn texture_location(path: &Path) -> PathBuf {
    let Some((package, inner)) = packaged(path) else { return path.to_path_buf() };
    let in_package = !texture::udim::is_udim(Path::new(&inner))
        && path.to_str().is_some_and(|p| ar::DefaultResolver::new().resolve(p).is_some());
    if in_package {
        return path.to_path_buf();
    }
    package.parent().unwrap_or(Path::new(".")).join(inner)
}

/// Decodes a texture file, or a package entry in place from the zip (usdz entries are stored
/// uncompressed, so this is a copy of the entry's bytes, never a file extracted to disk), within
/// `limits` (checked against the size the file declares, before decoding).
pub(super) fn decode_texture(
    path: &Path,
    limits: &texture::DecodeLimits,
) -> Result<texture::SourceImage, texture::Error> {
    let Some((_, inner)) = packaged(path) else { return texture::decode_with(path, limits) };
    let io = |e: std::io::Error| texture::Error { path: path.to_path_buf(), kind: texture::ErrorKind::Io(e) };
    let resolved = ar::ResolvedPath::new(path);
    let bytes =
        ar::DefaultResolver::new().open_asset(&resolved).and_then(|mut a| a.read_all()).map_err(io)?;
    texture::decode_bytes_with(&bytes, Path::new(&inner), limits)
        .map_err(|e| texture::Error { path: path.to_path_buf(), ..e })
}

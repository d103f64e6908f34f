//! `<UDIM>` patterns → the tile files present on disk.
//!
//! UDIM tile `1001 + u + 10 v` covers texture space `[u, u+1) × [v, v+1)`, `u` in `0..10`. A pattern names
//! the tiles with the token in the file name (`body.<UDIM>.png`); the directory is listed once and every
//! file that matches with four digits in `1001..=1999` in place of the token becomes a tile.

use std::path::{Path, PathBuf};

use crate::error::{Error, ErrorKind};

/// The token a UDIM path contains.
pub const UDIM_TOKEN: &str = "<UDIM>";

/// One tile found on disk.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UdimTile {
    /// UDIM number, `1001 + u + 10 v`.
    pub number: u32,
    /// Column, `0..10`.
    pub u: u32,
    /// Row.
    pub v: u32,
    /// The tile's file.
    pub path: PathBuf,
}

/// `true` if `path` is a UDIM pattern.
pub fn is_udim(path: &Path) -> bool {
    path.to_string_lossy().contains(UDIM_TOKEN)
}

/// The file tile `number` of `pattern` would be in.
pub fn tile_path(pattern: &Path, number: u32) -> PathBuf {
    PathBuf::from(pattern.to_string_lossy().replace(UDIM_TOKEN, &number.to_string()))
}

/// Lists the tiles of `pattern` present on disk, sorted by number. Errors if the pattern is malformed, the
/// directory cannot be read or no tile exists.
pub fn expand(pattern: &Path) -> Result<Vec<UdimTile>, Error> {
    let fail = |what: &str| Error::new(pattern, ErrorKind::Udim(what.to_string()));
    let name = pattern.file_name().and_then(|n| n.to_str()).ok_or_else(|| fail("no UTF-8 file name"))?;
    let (prefix, suffix) =
        name.split_once(UDIM_TOKEN).ok_or_else(|| fail("<UDIM> must be in the file name"))?;
    if suffix.contains(UDIM_TOKEN) {
        return Err(fail("<UDIM> appears twice"));
    }
    let dir = match pattern.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let entries = std::fs::read_dir(dir).map_err(|e| Error::new(pattern, ErrorKind::Io(e)))?;
    let mut tiles = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| Error::new(pattern, ErrorKind::Io(e)))?;
        let file_name = entry.file_name();
        let Some(middle) = file_name.to_str().and_then(|n| n.strip_prefix(prefix)?.strip_suffix(suffix))
        else {
            continue;
        };
        if middle.len() != 4 || !middle.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let number: u32 = middle.parse().expect("four ASCII digits parse");
        if !(1001..=1999).contains(&number) {
            continue;
        }
        let k = number - 1001;
        tiles.push(UdimTile { number, u: k % 10, v: k / 10, path: dir.join(&file_name) });
    }
    if tiles.is_empty() {
        return Err(fail("no tile file matches the pattern"));
    }
    tiles.sort_by_key(|t| t.number);
    Ok(tiles)
}

//! Structural check of `.usdc` crate files, run on a layer's bytes before `openusd` reads them.
//!
//! openusd 0.6's crate reader trusts the file. It allocates `vec![T; count]` for counts read
//! from the file before checking the file holds that many bytes, so one corrupt count aborts the
//! process on a multi-exabyte allocation, which no `catch_unwind` can stop. It indexes its token,
//! string, field and path tables with indices from the file (a panic when out of range), follows
//! the path tree's jumps without checking that they stay in range or visit each entry once
//! (overlapping jumps make the walk exponential), and recurses through dictionaries and time
//! samples without a depth limit (a stack overflow, again an abort).
//!
//! [`check`] walks everything the reader will walk, reading it the way the reader does (the same
//! sections, LZ4 blocks and integer coding, in the same order), and checks each count, offset,
//! size and index first:
//!
//! - the bootstrap header (magic, a version the reader decodes, the table of contents' place);
//! - the table of contents: every section inside the file;
//! - TOKENS, STRINGS, FIELDS, FIELDSETS, PATHS, SPECS: every count against the bytes of its
//!   section (or, for compressed data, against what its compressed size can expand to), every
//!   index against the table it names, the path tree's jumps (each entry reached once), its
//!   depth, the total length of the paths it builds and the syntax of each path element (the
//!   reader's path queries loop forever on malformed ones, see [`super::path_syntax`]);
//! - every field's value: see [`values`].
//!
//! A failure names the section and the problem, e.g. `FIELDS: value of field 81 (default):
//! array claims 6.1e18 elements of 12 bytes at offset 936, but only 3338 bytes follow`.
//! Problems the reader itself reports as errors (an unknown value type, a bad enum) are left to
//! it. The check runs once per layer and costs a few milliseconds per megabyte.
//!
//! [`repair`] then rewrites the one layout openusd misreads in crate files older than 0.7.0 (the
//! times of time samples), so their animated attributes compose as in usd-core.

mod coding;
mod repair;
mod values;

use std::fmt;

use coding::{big, read_compressed, read_ints, Reader};
pub(crate) use repair::repair;
use values::Values;

/// Magic bytes of every crate file.
pub(crate) const MAGIC: &[u8] = b"PXR-USDC";

/// Newest crate version openusd 0.6 reads (`SW_VERSION` in its reader).
const NEWEST: Version = Version(0, 12, 0);
/// Oldest crate version openusd 0.6 decodes: older sections stop it on a `todo!`.
const OLDEST: Version = Version(0, 4, 0);

/// What is wrong with a crate file, and in which part of it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CrateError {
    /// `bootstrap`, `TOC`, a section name (`TOKENS`, `FIELDS`, ...).
    pub(crate) section: String,
    pub(crate) message: String,
}

impl fmt::Display for CrateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.section, self.message)
    }
}

impl std::error::Error for CrateError {}

fn fail<T>(section: &str, message: impl Into<String>) -> Result<T, CrateError> {
    Err(CrateError { section: section.to_string(), message: message.into() })
}

/// A crate file version, ordered as (major, minor, patch).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct Version(pub(crate) u8, pub(crate) u8, pub(crate) u8);

impl fmt::Display for Version {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}.{}", self.0, self.1, self.2)
    }
}

/// The tables values index into, reduced to what the value checks need.
pub(crate) struct Tables {
    /// Byte length of each token.
    token_lengths: Vec<u32>,
    /// Token index of each string.
    strings: Vec<u32>,
    /// Byte length of each path the reader builds (0 for a slot it leaves empty).
    path_lengths: Vec<u64>,
}

/// One table-of-contents entry.
struct Section {
    name: String,
    start: u64,
    end: u64,
}

/// Checks the crate file `bytes`; `Ok` means openusd's reader can read it without panicking,
/// aborting or allocating more than the file's contents justify.
pub(crate) fn check(bytes: &[u8]) -> Result<(), CrateError> {
    let (version, sections) = read_header(bytes)?;
    let section = |name: &str| sections.iter().find(|s| s.name == name);
    let reader = |name: &str| section(name).map(|s| Reader::new(bytes, s.start as usize, s.end as usize));
    let in_section = |name: &'static str| move |message: String| CrateError { section: name.into(), message };

    let tokens = match reader("TOKENS") {
        Some(mut r) => read_tokens(&mut r).map_err(in_section("TOKENS"))?,
        None => Tokens::default(),
    };
    let token_lengths: Vec<u32> = tokens.ranges.iter().map(|&(_, len)| len).collect();
    let strings = match reader("STRINGS") {
        Some(mut r) => read_strings(&mut r, token_lengths.len()).map_err(in_section("STRINGS"))?,
        None => Vec::new(),
    };
    let fields = match reader("FIELDS") {
        Some(mut r) => read_fields(&mut r, token_lengths.len()).map_err(in_section("FIELDS"))?,
        None => Vec::new(),
    };
    let fieldsets = match reader("FIELDSETS") {
        Some(mut r) => read_fieldsets(&mut r, fields.len()).map_err(in_section("FIELDSETS"))?,
        None => 0,
    };
    let path_lengths = match reader("PATHS") {
        Some(mut r) => read_paths(&mut r, &tokens, bytes.len()).map_err(in_section("PATHS"))?,
        None => Vec::new(),
    };
    if let Some(mut r) = reader("SPECS") {
        read_specs(&mut r, path_lengths.len(), fieldsets).map_err(in_section("SPECS"))?;
    }

    let tables = Tables { token_lengths, strings, path_lengths };
    let mut values = Values::new(bytes, &tables, version);
    for (i, &(token, rep)) in fields.iter().enumerate() {
        values.check(rep, 0).map_err(|e| {
            let name = token_name(bytes, &sections, token).unwrap_or_default();
            CrateError { section: "FIELDS".into(), message: format!("value of field {i} ({name}): {e}") }
        })?;
    }
    Ok(())
}

/// The bootstrap header and the table of contents.
fn read_header(bytes: &[u8]) -> Result<(Version, Vec<Section>), CrateError> {
    let mut r = Reader::new(bytes, 0, bytes.len());
    let header = r.take(32, "header").or_else(|e| fail("bootstrap", e))?;
    if &header[..8] != MAGIC {
        return fail("bootstrap", "not a crate file (no PXR-USDC magic)");
    }
    let version = Version(header[8], header[9], header[10]);
    if version.0 != NEWEST.0 || version.1 > NEWEST.1 || version < OLDEST {
        return fail(
            "bootstrap",
            format!("crate version {version} cannot be read (versions {OLDEST} to {NEWEST} can)"),
        );
    }
    let toc = u64::from_le_bytes(header[16..24].try_into().expect("8 bytes"));
    if toc == 0 || toc >= bytes.len() as u64 {
        return fail(
            "TOC",
            format!(
                "table of contents at offset {} outside the {}-byte file (truncated?)",
                big(toc),
                bytes.len()
            ),
        );
    }
    let mut r = Reader::new(bytes, toc as usize, bytes.len());
    let count = r.u64("section count").or_else(|e| fail("TOC", e))?;
    if count == 0 || count >= 64 {
        return fail("TOC", format!("{} sections (the reader accepts 1 to 63)", big(count)));
    }
    r.holds(count, 32, "sections").or_else(|e| fail("TOC", e))?;
    let mut sections = Vec::with_capacity(count as usize);
    for _ in 0..count {
        let name = r.take(16, "section name").or_else(|e| fail("TOC", e))?;
        // As the reader reads it: up to the first NUL, empty when not UTF-8 or unterminated.
        let name = match name.iter().position(|&b| b == 0) {
            Some(end) => std::str::from_utf8(&name[..end]).unwrap_or_default().to_string(),
            None => String::new(),
        };
        let start = r.u64("section start").or_else(|e| fail("TOC", e))?;
        let size = r.u64("section size").or_else(|e| fail("TOC", e))?;
        match start.checked_add(size) {
            Some(end) if end <= bytes.len() as u64 => sections.push(Section { name, start, end }),
            _ => {
                return fail(
                    "TOC",
                    format!(
                        "section {name} ({} bytes at offset {}) runs past the end of the {}-byte file",
                        big(size),
                        big(start),
                        bytes.len()
                    ),
                )
            }
        }
    }
    // The reader uses the first section of each name.
    let mut seen = std::collections::HashSet::new();
    sections.retain(|s| seen.insert(s.name.clone()));
    Ok((version, sections))
}

/// The token table: the decompressed text and each token's (start, length) in it.
#[derive(Default)]
struct Tokens {
    text: Vec<u8>,
    ranges: Vec<(u32, u32)>,
}

impl Tokens {
    fn get(&self, index: usize) -> Option<&str> {
        let &(start, len) = self.ranges.get(index)?;
        // Checked as UTF-8 as a whole, and split at NULs (ASCII), so every token is UTF-8.
        std::str::from_utf8(&self.text[start as usize..(start + len) as usize]).ok()
    }
}

/// TOKENS: a count, the uncompressed size, then one compressed block of NUL-terminated UTF-8
/// strings.
fn read_tokens(r: &mut Reader) -> Result<Tokens, String> {
    let count = r.u64("token count")?;
    let size = r.u64("tokens size")?;
    let text = read_compressed(r, size, size, "tokens")?;
    if text.len() as u64 != size {
        return Err(format!("tokens decompress to {} bytes, not the {} claimed", text.len(), big(size)));
    }
    let Some((&last, body)) = text.split_last() else {
        return if count == 0 {
            Ok(Tokens::default())
        } else {
            Err(format!("{} tokens claimed, none stored", big(count)))
        };
    };
    if last != 0 {
        return Err("tokens are not NUL-terminated".into());
    }
    std::str::from_utf8(body).map_err(|e| format!("tokens are not UTF-8 ({e})"))?;
    let mut ranges = Vec::new();
    let mut start = 0u32;
    for token in body.split(|&b| b == 0) {
        ranges.push((start, token.len() as u32));
        start += token.len() as u32 + 1;
    }
    if ranges.len() as u64 != count {
        return Err(format!("{} tokens claimed, {} stored", big(count), ranges.len()));
    }
    Ok(Tokens { text, ranges })
}

/// STRINGS: a count, then one token index per string.
fn read_strings(r: &mut Reader, tokens: usize) -> Result<Vec<u32>, String> {
    let count = r.u64("string count")?;
    r.holds(count, 4, "strings")?;
    let strings: Vec<u32> = (0..count).map(|_| r.u32("string")).collect::<Result<_, _>>()?;
    if let Some((i, &t)) = strings.iter().enumerate().find(|&(_, &t)| t as usize >= tokens) {
        return Err(format!("string {i} names token {t} of {tokens}"));
    }
    Ok(strings)
}

/// FIELDS: a count, compressed token indices (the field names), then a compressed block of
/// value reps. Returns (token index, value rep) per field, as many as the reader pairs up.
fn read_fields(r: &mut Reader, tokens: usize) -> Result<Vec<(u32, u64)>, String> {
    let count = r.u64("field count")?;
    let names = read_ints(r, count, false, true, "field names")?;
    let reps = read_compressed(r, count.saturating_mul(8), count.saturating_mul(8), "field values")?;
    let fields: Vec<(u32, u64)> = names
        .iter()
        .zip(reps.chunks_exact(8))
        .map(|(&name, rep)| (name as u32, u64::from_le_bytes(rep.try_into().expect("8 bytes"))))
        .collect();
    if let Some((i, &(t, _))) = fields.iter().enumerate().find(|&(_, &(t, _))| t as usize >= tokens) {
        return Err(format!("field {i} is named by token {t} of {tokens}"));
    }
    Ok(fields)
}

/// FIELDSETS: a count, then compressed field indices, each set ended by `u32::MAX`. Returns
/// the number of entries.
fn read_fieldsets(r: &mut Reader, fields: usize) -> Result<usize, String> {
    let count = r.u64("fieldset count")?;
    let entries = read_ints(r, count, false, true, "fieldsets")?;
    for (i, &entry) in entries.iter().enumerate() {
        let entry = entry as u32;
        if entry != u32::MAX && entry as usize >= fields {
            return Err(format!("entry {i} names field {entry} of {fields}"));
        }
    }
    Ok(entries.len())
}

/// Depth of the namespace allowed: composition and the scene walk recurse once per level, so a
/// deeper tree overflows the stack (an abort); real scenes nest a few dozen levels. The same
/// limit as text layers' nesting ([`super::layer_fix::MAX_NESTING`]).
const MAX_PATH_DEPTH: u32 = super::layer_fix::MAX_NESTING as u32;

/// Total bytes of path text the PATHS section may build, beyond which the tree is rejected:
/// the reader builds every path as a full string, so a deep tree or long tokens can multiply a
/// small section into gigabytes.
fn path_budget(file_len: usize) -> u64 {
    (1u64 << 30).saturating_add(64 * file_len as u64)
}

/// PATHS: the number of paths, then the tree in pre-order as three compressed arrays of the same
/// length (path index, element token with the sign telling property from prim, jump to the next
/// sibling: -1 only a child, -2 a leaf, 0 only a sibling, > 0 both). Returns each path's length.
///
/// Walks the tree as openusd's `build_compressed_paths` does, checking every index it will use
/// and that each entry is reached once.
fn read_paths(r: &mut Reader, tokens: &Tokens, file_len: usize) -> Result<Vec<u64>, String> {
    let start = r.pos;
    let path_count = r.u64("path count")?;
    let count = r.u64("encoded path count")?;
    let indices = read_ints(r, count, false, true, "path indices")?;
    let elements = read_ints(r, count, false, true, "path elements")?;
    let jumps = read_ints(r, count, false, true, "path jumps")?;
    // The reader allocates `path_count` paths up front. usd-core writes a few more than it
    // encodes (slots left empty); allow one per byte of the section beyond the encoded ones.
    let section_len = (r.pos - start) as u64;
    if path_count < count || path_count - count > section_len {
        return Err(format!("{} paths claimed, {} encoded", big(path_count), big(count)));
    }
    let (count, path_count) = (count as usize, path_count as usize);
    let mut lengths = vec![0u64; path_count];
    if count == 0 {
        return Ok(lengths);
    }
    let budget = path_budget(file_len);
    let mut total = 0u64;
    let mut reached = vec![false; count];
    let mut written = vec![false; path_count];
    let mut depths = vec![0u32; path_count];
    // Whether each (token, is property) was found a valid path element.
    let mut valid: std::collections::HashMap<(usize, bool), bool> = std::collections::HashMap::new();
    // (next entry, (length, depth) of the parent path or None for the empty path).
    let mut pending: Vec<(usize, Option<(u64, u32)>)> = vec![(0, None)];
    while let Some((mut next, mut parent)) = pending.pop() {
        loop {
            let index = next;
            next += 1;
            if index >= count {
                return Err(format!("the tree's jumps run past its {count} entries"));
            }
            if std::mem::replace(&mut reached[index], true) {
                return Err(format!("entry {index} is reached twice (overlapping jumps)"));
            }
            let slot = indices[index] as u32 as usize;
            if slot >= path_count {
                return Err(format!("entry {index} names path {slot} of {path_count}"));
            }
            // usd-core refuses a path index given twice ("Corrupt path index"); openusd builds
            // both, and instancing queries over such a namespace ran for minutes (fuzz finding).
            if std::mem::replace(&mut written[slot], true) {
                return Err(format!("entry {index} names path {slot} again (a corrupt path index)"));
            }
            match parent {
                // The reader writes the root at the entry's own index, not its path index.
                None => {
                    lengths[index] = 1;
                    depths[index] = 0;
                    parent = Some((1, 0));
                }
                Some((parent_len, parent_depth)) => {
                    let property = (elements[index] as i32) < 0;
                    let token = (elements[index] as i32).unsigned_abs() as usize;
                    let Some(name) = tokens.get(token) else {
                        return Err(format!("entry {index} names token {token} of {}", tokens.ranges.len()));
                    };
                    // The reader appends the element's text to its parent's path unchecked; a
                    // malformed one makes a path its queries loop on (see `path_syntax`).
                    if !*valid.entry((token, property)).or_insert_with(|| element_ok(name, property)) {
                        let what = if property { "property" } else { "prim or variant" };
                        return Err(format!("entry {index}: {what} name {name:?} is malformed"));
                    }
                    let token_len = name.len() as u32;
                    // Parent, separator, element.
                    let len = parent_len + 1 + u64::from(token_len);
                    lengths[slot] = len;
                    depths[slot] = parent_depth + 1;
                    if parent_depth + 1 > MAX_PATH_DEPTH {
                        return Err(format!("paths nest deeper than {MAX_PATH_DEPTH} levels"));
                    }
                    total = total.saturating_add(len);
                    if total > budget {
                        return Err(format!("paths spell more than {} bytes", big(budget)));
                    }
                }
            }
            let jump = jumps[index] as i32;
            let has_child = jump > 0 || jump == -1;
            let has_sibling = jump >= 0;
            if has_child {
                if has_sibling {
                    pending.push((index + jump as usize, parent));
                }
                parent = match lengths[slot] {
                    0 => None,
                    len => Some((len, depths[slot])),
                };
            }
            if !has_child && !has_sibling {
                break;
            }
        }
    }
    Ok(lengths)
}

/// Whether `name` is a path element of its kind: a namespaced property name, or a prim name or
/// a `{set=selection}` variant element (the reader tells them by the leading `{`).
fn element_ok(name: &str, property: bool) -> bool {
    use super::path_syntax::{check_element, Element};
    let element = match (property, name.starts_with('{')) {
        (true, _) => Element::Property,
        (false, true) => Element::Variant,
        (false, false) => Element::Prim,
    };
    check_element(name, element).is_ok()
}

/// SPECS: a count, then compressed path indices, fieldset indices and spec types.
fn read_specs(r: &mut Reader, paths: usize, fieldsets: usize) -> Result<(), String> {
    let count = r.u64("spec count")?;
    let spec_paths = read_ints(r, count, false, true, "spec paths")?;
    let spec_fieldsets = read_ints(r, count, false, true, "spec fieldsets")?;
    read_ints(r, count, false, false, "spec types")?;
    for (i, (&path, &fieldset)) in spec_paths.iter().zip(&spec_fieldsets).enumerate() {
        if path as u32 as usize >= paths {
            return Err(format!("spec {i} names path {} of {paths}", path as u32));
        }
        if fieldset as u32 as usize >= fieldsets {
            return Err(format!("spec {i} names fieldset entry {} of {fieldsets}", fieldset as u32));
        }
    }
    Ok(())
}

/// The name of token `index`, for error messages (decoded again: errors are rare).
fn token_name(bytes: &[u8], sections: &[Section], index: u32) -> Option<String> {
    let s = sections.iter().find(|s| s.name == "TOKENS")?;
    let mut r = Reader::new(bytes, s.start as usize, s.end as usize);
    r.u64("").ok()?;
    let size = r.u64("").ok()?;
    let text = read_compressed(&mut r, size, size, "").ok()?;
    let token = text.split(|&b| b == 0).nth(index as usize)?;
    Some(String::from_utf8_lossy(token).into_owned())
}

#[cfg(test)]
mod tests;

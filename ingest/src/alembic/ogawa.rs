//! The Ogawa container: a tree of groups (lists of child addresses) and data chunks (sized byte
//! runs), read from the archive held in memory.
//!
//! Group headers are parsed by the `ogawa-rs` crate ([`ogawa_rs::GroupChunk::load`]), and data
//! sizes by [`ogawa_rs::DataChunk::load`]; every byte range they point at is checked against the
//! file here before it is sliced, so a truncated or corrupt archive is an error, never a panic
//! or an allocation sized by a corrupt field. The crate's own higher layers are not used: they
//! index child lists and allocate buffers from unchecked sizes (a corrupt file aborts the
//! process), `assert!` on duplicate child names, reach `todo!()` on boolean and wide-string
//! samples, read array samples after the first from the wrong chunk (Ogawa stores each array
//! sample as a data/dimensions pair), and parse only PolyMesh, Curves and Xform headers.

use std::io::{Cursor, Read, Seek, SeekFrom};

use ogawa_rs::{is_data, is_group, ArchiveReader, DataChunk, GroupChunk};

/// The whole archive in memory, readable by `ogawa-rs` through [`ArchiveReader`].
pub(super) struct Bytes {
    cursor: Cursor<Vec<u8>>,
}

impl Read for Bytes {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.cursor.read(buf)
    }
}

impl Seek for Bytes {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.cursor.seek(pos)
    }
}

impl ArchiveReader for Bytes {
    fn size(&self) -> u64 {
        self.cursor.get_ref().len() as u64
    }
}

/// Ogawa file magic, then the frozen flag and the format version.
const MAGIC: &[u8; 5] = b"Ogawa";
/// Bytes before the root group: magic, frozen flag, version, root group address.
const HEADER_LEN: usize = 16;

impl Bytes {
    /// Wraps the archive, checking the Ogawa header.
    pub(super) fn new(data: Vec<u8>) -> Result<Self, String> {
        if data.len() < HEADER_LEN {
            return Err(format!("{} bytes is too short for an Ogawa header", data.len()));
        }
        if &data[..5] != MAGIC {
            return Err("not an Ogawa archive (HDF5 Alembic archives are not supported)".into());
        }
        Ok(Bytes { cursor: Cursor::new(data) })
    }

    /// The root group.
    pub(super) fn root(&mut self) -> Result<GroupChunk, String> {
        let address = u64::from_le_bytes(self.cursor.get_ref()[8..16].try_into().expect("8 bytes"));
        if !is_group(address) {
            return Err("root address is not a group".into());
        }
        self.load_group(address)
    }

    fn load_group(&mut self, address: u64) -> Result<GroupChunk, String> {
        if address >= self.size() {
            return Err(format!("group at {address} is past the end of the file ({} bytes)", self.size()));
        }
        // A child count that cannot fit in the file loads as an empty group; the object or
        // property reading it then reports the missing child.
        GroupChunk::load(address, false, self).map_err(|e| format!("group at {address}: {e}"))
    }

    /// Child `index` of `group`, which must be a group.
    pub(super) fn group(&mut self, group: &GroupChunk, index: usize) -> Result<GroupChunk, String> {
        let child = *group.children.get(index).ok_or_else(|| {
            format!("group has {} children, child {index} is missing", group.children.len())
        })?;
        if !is_group(child) {
            return Err(format!("child {index} is data where a group was expected"));
        }
        self.load_group(child)
    }

    /// The bytes of child `index` of `group`, which must be data (empty for the empty chunk).
    pub(super) fn data(&mut self, group: &GroupChunk, index: usize) -> Result<&[u8], String> {
        let child = *group.children.get(index).ok_or_else(|| {
            format!("group has {} children, child {index} is missing", group.children.len())
        })?;
        if !is_data(child) {
            return Err(format!("child {index} is a group where data was expected"));
        }
        let len = self.size();
        let address = child & 0x7fff_ffff_ffff_ffff;
        if address == 0 {
            return Ok(&[]);
        }
        if address.checked_add(8).is_none_or(|end| end > len) {
            return Err(format!("data at {address} is past the end of the file ({len} bytes)"));
        }
        let chunk = DataChunk::load(child, self).map_err(|e| format!("data at {address}: {e}"))?;
        let start = address + 8;
        match start.checked_add(chunk.size) {
            Some(end) if end <= len => Ok(&self.cursor.get_ref()[start as usize..end as usize]),
            _ => Err(format!(
                "data at {address} claims {} bytes, past the end of the file ({len} bytes)",
                chunk.size
            )),
        }
    }
}

/// Reads little-endian fields from a data chunk, failing (not panicking) past its end.
pub(super) struct Fields<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Fields<'a> {
    pub(super) fn new(bytes: &'a [u8]) -> Self {
        Fields { bytes, pos: 0 }
    }

    pub(super) fn at_end(&self) -> bool {
        self.pos >= self.bytes.len()
    }

    pub(super) fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| {
            format!("field of {n} bytes at offset {} runs past a {}-byte record", self.pos, self.bytes.len())
        })?;
        let out = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(out)
    }

    pub(super) fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }

    pub(super) fn u16(&mut self) -> Result<u16, String> {
        Ok(u16::from_le_bytes(self.take(2)?.try_into().expect("2 bytes")))
    }

    pub(super) fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }

    pub(super) fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }

    /// A UTF-8 string of `n` bytes.
    pub(super) fn string(&mut self, n: usize) -> Result<String, String> {
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| "a name or metadata string is not UTF-8".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal archive: header, then a root group with one data child holding "abc".
    fn tiny() -> Vec<u8> {
        let mut v = Vec::new();
        v.extend_from_slice(b"Ogawa");
        v.push(0xff);
        v.extend_from_slice(&1u16.to_le_bytes());
        v.extend_from_slice(&16u64.to_le_bytes());
        // Root group at 16: one child, data at 32.
        v.extend_from_slice(&1u64.to_le_bytes());
        v.extend_from_slice(&(32u64 | 1 << 63).to_le_bytes());
        v.extend_from_slice(&3u64.to_le_bytes());
        v.extend_from_slice(b"abc");
        v
    }

    #[test]
    fn reads_a_data_child() {
        let mut bytes = Bytes::new(tiny()).unwrap();
        let root = bytes.root().unwrap();
        assert_eq!(bytes.data(&root, 0).unwrap(), b"abc");
        assert!(bytes.data(&root, 1).unwrap_err().contains("child 1 is missing"));
        assert!(bytes.group(&root, 0).unwrap_err().contains("is data"));
    }

    #[test]
    fn oversized_data_is_an_error() {
        let mut v = tiny();
        v[32..40].copy_from_slice(&u64::MAX.to_le_bytes());
        let mut bytes = Bytes::new(v).unwrap();
        let root = bytes.root().unwrap();
        assert!(bytes.data(&root, 0).unwrap_err().contains("past the end"), "{:?}", bytes.data(&root, 0));
    }

    #[test]
    fn every_truncation_is_an_error() {
        let full = tiny();
        for len in 0..full.len() {
            let result = Bytes::new(full[..len].to_vec()).and_then(|mut b| {
                let root = b.root()?;
                b.data(&root, 0).map(<[u8]>::to_vec)
            });
            assert!(result.is_err(), "{len} bytes");
        }
    }
}

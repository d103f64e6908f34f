//! The Alembic layer over Ogawa: archive header, time samplings, objects, compound properties,
//! property headers and their samples (AbcCoreOgawa's layout).
//!
//! Layout, for reference:
//! - root group: `[0]` and `[1]` version data, `[2]` top object group, `[3]` archive metadata,
//!   `[4]` time samplings, `[5]` indexed metadata;
//! - object group: `[0]` its top compound property group, `[1..=n]` child object groups, last a
//!   data chunk with the child headers followed by 32 bytes of hashes;
//! - compound group: one group per property, last a data chunk with the property headers;
//! - scalar property group: one data chunk per stored sample; array property group: a data and
//!   a dimensions chunk per stored sample. Sample data starts with a 16-byte digest.
//!
//! Every count and size read from the file is checked against what is left before it is used.

use std::collections::BTreeMap;

use ogawa_rs::GroupChunk;

use super::ogawa::{Bytes, Fields};
use super::time::TimeSampling;

/// `key=value;key=value` metadata.
pub(super) type MetaData = BTreeMap<String, String>;

fn parse_metadata(text: &str) -> MetaData {
    text.split(';')
        .filter_map(|pair| pair.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

/// Plain-old-data types of property samples (`Alembic::Util::PlainOldDataType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pod {
    Bool,
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F16,
    F32,
    F64,
    String,
    WString,
}

impl Pod {
    fn from_bits(bits: u32) -> Option<Pod> {
        use Pod::*;
        [Bool, U8, I8, U16, I16, U32, I32, U64, I64, F16, F32, F64, String, WString]
            .get(bits as usize)
            .copied()
    }

    /// Bytes per value (strings have no fixed size).
    fn size(self) -> usize {
        match self {
            Pod::Bool | Pod::U8 | Pod::I8 | Pod::String => 1,
            Pod::U16 | Pod::I16 | Pod::F16 => 2,
            Pod::U32 | Pod::I32 | Pod::F32 | Pod::WString => 4,
            Pod::U64 | Pod::I64 | Pod::F64 => 8,
        }
    }
}

/// Compound, scalar or array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Compound,
    Scalar,
    Array,
}

/// One property's header.
#[derive(Clone, Debug)]
pub(super) struct PropertyHeader {
    pub name: String,
    pub kind: Kind,
    pub pod: Pod,
    /// Values per element (3 for a point).
    pub extent: u8,
    /// Number of samples.
    pub samples: u32,
    /// Samples before this one repeat sample 0.
    first_changed: u32,
    /// Samples after this one repeat it.
    last_changed: u32,
    /// Index into [`Archive::time_samplings`].
    pub time_sampling: usize,
    pub metadata: MetaData,
}

impl PropertyHeader {
    /// The stored sample holding sample `index` (repeated samples are stored once).
    fn stored(&self, index: u32) -> u32 {
        let (first, last) = (self.first_changed, self.last_changed);
        if index < first || (first == 0 && last == 0) {
            0
        } else if index >= last {
            last - first + 1
        } else {
            index - first + 1
        }
    }
}

/// A compound property: its group and its children's headers.
pub(super) struct Compound {
    group: GroupChunk,
    pub headers: Vec<PropertyHeader>,
}

impl Compound {
    /// The header of the property `name`, with its index.
    pub(super) fn find(&self, name: &str) -> Option<(usize, &PropertyHeader)> {
        self.headers.iter().enumerate().find(|(_, h)| h.name == name)
    }
}

/// An object's name, full path and metadata (`schema=...`).
#[derive(Clone, Debug)]
pub(super) struct ObjectHeader {
    pub name: String,
    pub path: String,
    pub metadata: MetaData,
}

/// An object: its top compound property and its children's headers.
pub(super) struct Object {
    pub header: ObjectHeader,
    group: GroupChunk,
    pub children: Vec<ObjectHeader>,
    pub properties: Compound,
}

impl Object {
    /// File offset of the object's group: Ogawa groups may be shared (instancing), so this
    /// identifies the stored object, not the path.
    pub(super) fn offset(&self) -> u64 {
        self.group.position
    }
}

/// An opened archive.
pub(super) struct Archive {
    bytes: Bytes,
    root: GroupChunk,
    /// Archive metadata (`_ai_Application`, `FramesPerTimeUnit`, ...).
    pub metadata: MetaData,
    indexed_metadata: Vec<MetaData>,
    pub time_samplings: Vec<TimeSampling>,
}

/// The time sampling value Alembic writes for acyclic samplings.
const ACYCLIC_TIME_PER_CYCLE: f64 = f64::MAX / 32.0;

impl Archive {
    /// Parses the archive header, metadata and time samplings.
    pub(super) fn open(data: Vec<u8>) -> Result<Archive, String> {
        let mut bytes = Bytes::new(data)?;
        let root = bytes.root()?;
        if root.children.len() < 6 {
            return Err(format!("root group has {} children, an Alembic archive has 6", root.children.len()));
        }
        let metadata = parse_metadata(&text(bytes.data(&root, 3)?)?);
        let time_samplings = read_time_samplings(bytes.data(&root, 4)?)?;
        let indexed_metadata = read_indexed_metadata(bytes.data(&root, 5)?)?;
        Ok(Archive { bytes, root, metadata, indexed_metadata, time_samplings })
    }

    /// The top object (path `/`).
    pub(super) fn top(&mut self) -> Result<Object, String> {
        let group = self.bytes.group(&self.root, 2)?;
        let header =
            ObjectHeader { name: String::new(), path: String::new(), metadata: self.metadata.clone() };
        self.object(group, header)
    }

    /// Child `index` of `parent`.
    pub(super) fn child(&mut self, parent: &Object, index: usize) -> Result<Object, String> {
        let header = parent.children.get(index).cloned().ok_or("child index out of range")?;
        let group = self.bytes.group(&parent.group, index + 1)?;
        self.object(group, header)
    }

    fn object(&mut self, group: GroupChunk, header: ObjectHeader) -> Result<Object, String> {
        let n = group.children.len();
        let children = match n {
            0 => Vec::new(),
            _ if ogawa_rs::is_data(group.children[n - 1]) => {
                let data = self.bytes.data(&group, n - 1)?;
                read_object_headers(data, &header.path, &self.indexed_metadata)?
            }
            _ => Vec::new(),
        };
        if !children.is_empty() && children.len() + 2 > n {
            return Err(format!("object lists {} children but its group has {n} entries", children.len()));
        }
        let properties = if n > 0 && ogawa_rs::is_group(group.children[0]) {
            let g = self.bytes.group(&group, 0)?;
            self.compound_of(g)?
        } else {
            Compound {
                group: GroupChunk { position: 0, child_count: 0, children: Vec::new() },
                headers: Vec::new(),
            }
        };
        Ok(Object { header, group, children, properties })
    }

    fn compound_of(&mut self, group: GroupChunk) -> Result<Compound, String> {
        let n = group.children.len();
        let headers = if n > 0 && ogawa_rs::is_data(group.children[n - 1]) {
            let data = self.bytes.data(&group, n - 1)?;
            read_property_headers(data, &self.indexed_metadata, self.time_samplings.len())?
        } else {
            Vec::new()
        };
        if headers.len() > n.saturating_sub(1) {
            return Err(format!("compound lists {} properties but its group has {n} entries", headers.len()));
        }
        Ok(Compound { group, headers })
    }

    /// The compound property `name` of `parent`, if it has one.
    pub(super) fn compound(&mut self, parent: &Compound, name: &str) -> Result<Option<Compound>, String> {
        let Some((index, header)) = parent.find(name) else { return Ok(None) };
        if header.kind != Kind::Compound {
            return Err(format!("{name} is not a compound property"));
        }
        let group = self.bytes.group(&parent.group, index)?;
        self.compound_of(group).map(Some).map_err(|e| format!("{name}: {e}"))
    }

    /// The raw bytes (after the digest) of sample `index` of the scalar or array property at
    /// `index_in_parent`.
    fn sample_bytes(&mut self, parent: &Compound, property: usize, index: u32) -> Result<&[u8], String> {
        let header = &parent.headers[property];
        if index >= header.samples {
            return Err(format!("sample {index} of {} requested", header.samples));
        }
        let stored = header.stored(index) as usize;
        let chunk = match header.kind {
            Kind::Scalar => stored,
            Kind::Array => stored.checked_mul(2).ok_or("sample index overflows")?,
            Kind::Compound => return Err("a compound property has no samples".into()),
        };
        let group = self.bytes.group(&parent.group, property)?;
        let data = self.bytes.data(&group, chunk)?;
        match data.len() {
            0 => Ok(&[]),
            1..16 => Err(format!("sample of {} bytes is shorter than its 16-byte digest", data.len())),
            _ => Ok(&data[16..]),
        }
    }

    /// Sample `index` of property `name` as numbers (every numeric and boolean type widened to
    /// `f64`), flattened (`extent` values per element).
    pub(super) fn numbers(&mut self, parent: &Compound, name: &str, index: u32) -> Result<Vec<f64>, String> {
        let (property, header) = parent.find(name).ok_or_else(|| format!("{name} is missing"))?;
        let pod = header.pod;
        let bytes = self.sample_bytes(parent, property, index).map_err(|e| format!("{name}: {e}"))?;
        decode_numbers(bytes, pod).map_err(|e| format!("{name}: {e}"))
    }

    /// Sample `index` of the string property `name`.
    pub(super) fn strings(
        &mut self,
        parent: &Compound,
        name: &str,
        index: u32,
    ) -> Result<Vec<String>, String> {
        let (property, header) = parent.find(name).ok_or_else(|| format!("{name} is missing"))?;
        if header.pod != Pod::String {
            return Err(format!("{name} is not a string property"));
        }
        let bytes = self.sample_bytes(parent, property, index).map_err(|e| format!("{name}: {e}"))?;
        bytes
            .split(|&b| b == 0)
            .take(bytes.iter().filter(|&&b| b == 0).count())
            .map(|s| String::from_utf8(s.to_vec()).map_err(|_| format!("{name}: a string is not UTF-8")))
            .collect()
    }
}

fn text(bytes: &[u8]) -> Result<String, String> {
    String::from_utf8(bytes.to_vec()).map_err(|_| "archive metadata is not UTF-8".into())
}

fn decode_numbers(bytes: &[u8], pod: Pod) -> Result<Vec<f64>, String> {
    if matches!(pod, Pod::String | Pod::WString) {
        return Err("is a string property where numbers were expected".into());
    }
    let size = pod.size();
    if !bytes.len().is_multiple_of(size) {
        return Err(format!("{} bytes is not a whole number of {size}-byte values", bytes.len()));
    }
    let chunks = bytes.chunks_exact(size);
    let le2 = |c: &[u8]| [c[0], c[1]];
    let le4 = |c: &[u8]| [c[0], c[1], c[2], c[3]];
    let le8 = |c: &[u8]| [c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]];
    Ok(match pod {
        Pod::Bool | Pod::U8 => chunks.map(|c| f64::from(c[0])).collect(),
        Pod::I8 => chunks.map(|c| f64::from(c[0] as i8)).collect(),
        Pod::U16 => chunks.map(|c| f64::from(u16::from_le_bytes(le2(c)))).collect(),
        Pod::I16 => chunks.map(|c| f64::from(i16::from_le_bytes(le2(c)))).collect(),
        Pod::F16 => chunks.map(|c| half::f16::from_le_bytes(le2(c)).to_f64()).collect(),
        Pod::U32 => chunks.map(|c| f64::from(u32::from_le_bytes(le4(c)))).collect(),
        Pod::I32 => chunks.map(|c| f64::from(i32::from_le_bytes(le4(c)))).collect(),
        Pod::F32 => chunks.map(|c| f64::from(f32::from_le_bytes(le4(c)))).collect(),
        Pod::U64 => chunks.map(|c| u64::from_le_bytes(le8(c)) as f64).collect(),
        Pod::I64 => chunks.map(|c| i64::from_le_bytes(le8(c)) as f64).collect(),
        Pod::F64 => chunks.map(|c| f64::from_le_bytes(le8(c))).collect(),
        Pod::String | Pod::WString => unreachable!("rejected above"),
    })
}

fn read_time_samplings(bytes: &[u8]) -> Result<Vec<TimeSampling>, String> {
    let mut f = Fields::new(bytes);
    let mut out = Vec::new();
    while !f.at_end() {
        let _max_sample = f.u32()?;
        let time_per_cycle = f.f64()?;
        let count = f.u32()? as usize;
        // Checked against the bytes left before anything is allocated.
        let raw = f.take(count.checked_mul(8).ok_or("time sampling count overflows")?)?;
        let times: Vec<f64> =
            raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect();
        let sampling = if time_per_cycle == ACYCLIC_TIME_PER_CYCLE {
            TimeSampling::acyclic(times)
        } else {
            TimeSampling::cyclic(times, time_per_cycle)
        };
        out.push(sampling.map_err(|e| format!("time sampling {}: {e}", out.len()))?);
    }
    if out.is_empty() {
        // Sampling 0 is the identity sampling and always exists.
        out.push(TimeSampling::cyclic(vec![0.0], 1.0).expect("valid"));
    }
    Ok(out)
}

fn read_indexed_metadata(bytes: &[u8]) -> Result<Vec<MetaData>, String> {
    let mut f = Fields::new(bytes);
    let mut out = vec![MetaData::new()];
    while !f.at_end() {
        let n = f.u8()? as usize;
        out.push(parse_metadata(&f.string(n)?));
    }
    Ok(out)
}

fn metadata_at(index: usize, indexed: &[MetaData]) -> Result<MetaData, String> {
    indexed.get(index).cloned().ok_or_else(|| format!("metadata index {index} of {}", indexed.len()))
}

/// Bytes of hashes after the child object headers.
const OBJECT_HASHES: usize = 32;

fn read_object_headers(
    bytes: &[u8],
    parent: &str,
    indexed: &[MetaData],
) -> Result<Vec<ObjectHeader>, String> {
    if bytes.len() <= OBJECT_HASHES {
        return Ok(Vec::new());
    }
    let mut f = Fields::new(&bytes[..bytes.len() - OBJECT_HASHES]);
    let mut out = Vec::new();
    while !f.at_end() {
        let n = f.u32()? as usize;
        let name = f.string(n)?;
        let index = f.u8()?;
        let metadata = if index == 0xff {
            let n = f.u32()? as usize;
            parse_metadata(&f.string(n)?)
        } else {
            metadata_at(index.into(), indexed)?
        };
        if name.is_empty() || name.contains('/') || out.iter().any(|h: &ObjectHeader| h.name == name) {
            return Err(format!("child object name {name:?} is empty, has a '/' or is repeated"));
        }
        out.push(ObjectHeader { path: format!("{parent}/{name}"), name, metadata });
    }
    Ok(out)
}

fn read_property_headers(
    bytes: &[u8],
    indexed: &[MetaData],
    samplings: usize,
) -> Result<Vec<PropertyHeader>, String> {
    let mut f = Fields::new(bytes);
    let mut out = Vec::new();
    while !f.at_end() {
        let info = f.u32()?;
        let kind = match info & 0x3 {
            0 => Kind::Compound,
            1 => Kind::Scalar,
            _ => Kind::Array,
        };
        let hint = (info >> 2) & 0x3;
        let sized = |f: &mut Fields| -> Result<u32, String> {
            match hint {
                0 => f.u8().map(u32::from),
                1 => f.u16().map(u32::from),
                2 => f.u32(),
                _ => Err("invalid size hint 3".into()),
            }
        };
        let mut header = PropertyHeader {
            name: String::new(),
            kind,
            pod: Pod::U8,
            extent: 0,
            samples: 0,
            first_changed: 0,
            last_changed: 0,
            time_sampling: 0,
            metadata: MetaData::new(),
        };
        if kind != Kind::Compound {
            header.pod = Pod::from_bits((info >> 4) & 0xf).ok_or("invalid POD type")?;
            header.extent = ((info >> 12) & 0xff) as u8;
            header.samples = sized(&mut f)?;
            if info & 0x200 != 0 {
                header.first_changed = sized(&mut f)?;
                header.last_changed = sized(&mut f)?;
            } else if info & 0x800 != 0 {
                (header.first_changed, header.last_changed) = (0, 0);
            } else {
                (header.first_changed, header.last_changed) = (1, header.samples.saturating_sub(1));
            }
            if header.last_changed < header.first_changed && header.last_changed != 0 {
                return Err("property's last changed sample precedes its first".into());
            }
            if info & 0x100 != 0 {
                header.time_sampling = sized(&mut f)? as usize;
                if header.time_sampling >= samplings {
                    return Err(format!("time sampling {} of {samplings}", header.time_sampling));
                }
            }
        }
        let n = sized(&mut f)? as usize;
        header.name = f.string(n)?;
        let index = (info >> 20) & 0xff;
        header.metadata = if index == 0xff {
            let n = sized(&mut f)? as usize;
            parse_metadata(&f.string(n)?)
        } else {
            metadata_at(index as usize, indexed)?
        };
        out.push(header);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stored_sample_indices_follow_first_and_last_changed() {
        let mut h = PropertyHeader {
            name: "P".into(),
            kind: Kind::Array,
            pod: Pod::F32,
            extent: 3,
            samples: 10,
            first_changed: 1,
            last_changed: 9,
            time_sampling: 0,
            metadata: MetaData::new(),
        };
        assert_eq!((0..10).map(|i| h.stored(i)).collect::<Vec<_>>(), (0..10).collect::<Vec<_>>());
        // Constant: everything is sample 0.
        (h.first_changed, h.last_changed) = (0, 0);
        assert!((0..10).all(|i| h.stored(i) == 0));
        // Changes between samples 3 and 5 only.
        (h.first_changed, h.last_changed) = (3, 5);
        assert_eq!((0..10).map(|i| h.stored(i)).collect::<Vec<_>>(), [0, 0, 0, 1, 2, 3, 3, 3, 3, 3]);
    }

    #[test]
    fn metadata_pairs() {
        let m = parse_metadata("schema=AbcGeom_Xform_v3;schemaObjTitle=AbcGeom_Xform_v3:.xform");
        assert_eq!(m["schema"], "AbcGeom_Xform_v3");
        assert_eq!(m["schemaObjTitle"], "AbcGeom_Xform_v3:.xform");
    }

    #[test]
    fn numbers_decode_every_pod() {
        assert_eq!(decode_numbers(&[1, 255], Pod::I8).unwrap(), [1.0, -1.0]);
        assert_eq!(decode_numbers(&1.5f32.to_le_bytes(), Pod::F32).unwrap(), [1.5]);
        assert_eq!(decode_numbers(&(-7i32).to_le_bytes(), Pod::I32).unwrap(), [-7.0]);
        assert!(decode_numbers(&[0, 0, 0], Pod::F32).is_err());
    }
}

//! Checks of field values (`ValueRep`s): every array count against the bytes after its offset,
//! every token/string/path index against its table, every nested dictionary and time-sample
//! value for depth, cycles and total decoded size.
//!
//! The dispatch mirrors openusd's `CrateFile::value` arm for arm (its `is_array` guards come
//! first, then inlined forms, then values stored at an offset), because the same bits mean
//! different reads in different arms. Where the reader itself reports a problem as an error (an
//! unknown type, an inlined value where it wants an offset, a bad enum), nothing is checked here.

use std::collections::{HashMap, HashSet};

use super::coding::{big, read_ints, Reader};
use super::{Tables, Version};

/// Nesting depth of dictionaries and time samples allowed. openusd recurses once per level with
/// no limit, so a self-referencing dictionary overflows the stack (an abort). Real layers nest a
/// handful of levels (customData inside assetInfo inside a time sample).
const MAX_NESTING: u32 = 64;

/// Bytes one field value may decode to. Values share storage in a crate file (a time-sampled
/// attribute whose samples all name one array decodes it once per sample), so a small file can
/// describe a huge value; past this the reader would exhaust the machine.
pub(super) const MAX_DECODED_BYTES: u64 = 4 << 30;

/// What decoding one value costs the reader.
#[derive(Clone, Copy, Default)]
pub(super) struct Decoded {
    /// Bytes it allocates (strings and paths counted with their text).
    pub(super) bytes: u64,
    /// Elements of an array value (the time-sample check compares it with the sample count).
    len: u64,
}

impl Decoded {
    fn array(len: u64, size: u64) -> Self {
        Decoded { bytes: len.saturating_mul(size), len }
    }
}

// `Type` codes of the crate format, as openusd's `layout::Type` numbers them.
const BOOL: u8 = 1;
const UCHAR: u8 = 2;
const INT: u8 = 3;
const UINT: u8 = 4;
const INT64: u8 = 5;
const UINT64: u8 = 6;
const HALF: u8 = 7;
const FLOAT: u8 = 8;
const DOUBLE: u8 = 9;
const STRING: u8 = 10;
const TOKEN: u8 = 11;
const ASSET_PATH: u8 = 12;
const DICTIONARY: u8 = 31;
const TOKEN_LIST_OP: u8 = 32;
const STRING_LIST_OP: u8 = 33;
const PATH_LIST_OP: u8 = 34;
const REFERENCE_LIST_OP: u8 = 35;
const INT_LIST_OP: u8 = 36;
const INT64_LIST_OP: u8 = 37;
const UINT_LIST_OP: u8 = 38;
const UINT64_LIST_OP: u8 = 39;
const PATH_VECTOR: u8 = 40;
const TOKEN_VECTOR: u8 = 41;
const VARIANT_SELECTION_MAP: u8 = 45;
const TIME_SAMPLES: u8 = 46;
const PAYLOAD: u8 = 47;
const DOUBLE_VECTOR: u8 = 48;
const LAYER_OFFSET_VECTOR: u8 = 49;
const STRING_VECTOR: u8 = 50;
const UNREGISTERED_VALUE: u8 = 53;
const UNREGISTERED_VALUE_LIST_OP: u8 = 54;
const PAYLOAD_LIST_OP: u8 = 55;
const TIME_CODE: u8 = 56;
const PATH_EXPRESSION: u8 = 57;
const RELOCATES: u8 = 58;

/// Element size of arrays of fixed-size types read without compression (bool and uchar,
/// vectors, matrices, quaternions), as openusd reads them; `None` for other types.
fn fixed_element_size(ty: u8) -> Option<u64> {
    Some(match ty {
        BOOL | UCHAR => 1,
        13 => 32,  // Matrix2d
        14 => 72,  // Matrix3d
        15 => 128, // Matrix4d
        16 => 32,  // Quatd
        17 => 16,  // Quatf
        18 => 8,   // Quath
        19 => 16,  // Vec2d
        20 => 8,   // Vec2f
        21 => 4,   // Vec2h
        22 => 8,   // Vec2i
        23 => 24,  // Vec3d
        24 => 12,  // Vec3f
        25 => 6,   // Vec3h
        26 => 12,  // Vec3i
        27 => 32,  // Vec4d
        28 => 16,  // Vec4f
        29 => 8,   // Vec4h
        30 => 16,  // Vec4i
        _ => return None,
    })
}

/// How openusd decides whether an array is compressed.
#[derive(Clone, Copy, PartialEq)]
enum ArrayKind {
    Ints,
    Floats,
    Other,
}

/// Items of a list op, by how they are stored.
#[derive(Clone, Copy)]
enum Items {
    Tokens,
    Strings,
    Paths,
    Pod(u64),
    References,
    Payloads,
}

/// One value rep's fields.
#[derive(Clone, Copy)]
struct Rep {
    ty: u8,
    array: bool,
    inlined: bool,
    compressed: bool,
    payload: u64,
}

impl Rep {
    fn new(bits: u64) -> Self {
        Rep {
            ty: ((bits >> 48) & 0xff) as u8,
            array: bits & (1 << 63) != 0,
            inlined: bits & (1 << 62) != 0,
            compressed: bits & (1 << 61) != 0,
            payload: bits & ((1 << 48) - 1),
        }
    }
}

/// Walks values as openusd's reader would, remembering values already checked: crate files
/// share one stored value between fields and samples.
pub(super) struct Values<'a> {
    bytes: &'a [u8],
    tables: &'a Tables,
    version: Version,
    checked: HashMap<u64, Decoded>,
    /// Values being checked, to find one that contains itself.
    open: HashSet<u64>,
}

impl<'a> Values<'a> {
    pub(super) fn new(bytes: &'a [u8], tables: &'a Tables, version: Version) -> Self {
        Values { bytes, tables, version, checked: HashMap::new(), open: HashSet::new() }
    }

    /// A reader at a value's offset, bounded by the file.
    fn at(&self, offset: u64, what: &str) -> Result<Reader<'a>, String> {
        let mut r = Reader::new(self.bytes, 0, self.bytes.len());
        r.seek(offset, what)?;
        Ok(r)
    }

    /// Checks the value `bits` and returns what decoding it costs.
    pub(super) fn check(&mut self, bits: u64, depth: u32) -> Result<Decoded, String> {
        let rep = Rep::new(bits);
        // Values stored at an offset are shared; inlined ones cost nothing to re-check.
        let shared = !rep.inlined && rep.payload != 0;
        if shared {
            if let Some(&done) = self.checked.get(&bits) {
                return Ok(done);
            }
            if !self.open.insert(bits) {
                return Err(format!("value at offset {} contains itself", rep.payload));
            }
        }
        if depth > MAX_NESTING {
            return Err(format!("values nest deeper than {MAX_NESTING} levels"));
        }
        let result = self.dispatch(rep, depth);
        if shared {
            self.open.remove(&bits);
            if let Ok(done) = result {
                self.checked.insert(bits, done);
            }
        }
        let done = result?;
        if done.bytes > MAX_DECODED_BYTES {
            return Err(format!(
                "value at offset {} decodes to {} bytes (more than the {} allowed)",
                rep.payload,
                big(done.bytes),
                big(MAX_DECODED_BYTES)
            ));
        }
        Ok(done)
    }

    fn dispatch(&mut self, rep: Rep, depth: u32) -> Result<Decoded, String> {
        let p = rep.payload;
        let none = Ok(Decoded::default());
        match rep.ty {
            ty if rep.array && fixed_element_size(ty).is_some() => {
                let size = fixed_element_size(ty).expect("guarded");
                let (count, r) = self.array_len(rep, ArrayKind::Other)?;
                r.holds(count, size, "array")?;
                Ok(Decoded::array(count, size))
            }
            INT | UINT if rep.array => self.int_array(rep, 4),
            INT64 | UINT64 if rep.array => self.int_array(rep, 8),
            HALF if rep.array => self.float_array(rep, 2),
            FLOAT if rep.array => self.float_array(rep, 4),
            DOUBLE | TIME_CODE if rep.array => self.float_array(rep, 8),
            DOUBLE_VECTOR => self.float_array(rep, 8),
            STRING_VECTOR if rep.inlined => none,
            STRING_VECTOR => self.indexed(&mut self.at(p, "string vector")?, Items::Strings, depth),
            STRING | ASSET_PATH | PATH_EXPRESSION if rep.array => {
                self.indexed(&mut self.at(p, "string array")?, Items::Strings, depth)
            }
            STRING => {
                let index = self.scalar_u32(rep)?;
                self.string(index)
            }
            ASSET_PATH | PATH_EXPRESSION => {
                // Inlined, the index names a token; stored, a string.
                let index = self.scalar_u32(rep)?;
                if rep.inlined {
                    self.token(u64::from(index))
                } else {
                    self.string(index)
                }
            }
            TOKEN if rep.array => {
                let (count, mut r) = self.array_len(rep, ArrayKind::Other)?;
                self.indices(&mut r, count, Items::Tokens, depth)
            }
            TOKEN | UNREGISTERED_VALUE => {
                let index = if rep.inlined { p & 0xffff_ffff } else { self.at(p, "token")?.u64("token")? };
                self.token(index)
            }
            TOKEN_LIST_OP
            | STRING_LIST_OP
            | PATH_LIST_OP
            | REFERENCE_LIST_OP
            | INT_LIST_OP
            | INT64_LIST_OP
            | UINT_LIST_OP
            | UINT64_LIST_OP
            | UNREGISTERED_VALUE_LIST_OP
                if rep.inlined =>
            {
                none
            }
            TOKEN_LIST_OP => self.list_op(p, Items::Tokens, depth),
            STRING_LIST_OP | UNREGISTERED_VALUE_LIST_OP => self.list_op(p, Items::Strings, depth),
            PATH_LIST_OP => self.list_op(p, Items::Paths, depth),
            REFERENCE_LIST_OP => self.list_op(p, Items::References, depth),
            INT_LIST_OP | UINT_LIST_OP => self.list_op(p, Items::Pod(4), depth),
            INT64_LIST_OP | UINT64_LIST_OP => self.list_op(p, Items::Pod(8), depth),
            // openusd reads payload list ops at the offset even when marked inlined.
            PAYLOAD_LIST_OP => self.list_op(p, Items::Payloads, depth),
            TOKEN_VECTOR | PATH_VECTOR if rep.inlined => none,
            TOKEN_VECTOR => self.indexed(&mut self.at(p, "token vector")?, Items::Tokens, depth),
            PATH_VECTOR => self.indexed(&mut self.at(p, "path vector")?, Items::Paths, depth),
            LAYER_OFFSET_VECTOR | PAYLOAD | VARIANT_SELECTION_MAP
                if rep.inlined || rep.array || rep.compressed =>
            {
                none
            }
            LAYER_OFFSET_VECTOR => self.indexed(&mut self.at(p, "layer offsets")?, Items::Pod(16), depth),
            PAYLOAD => self.payload(&mut self.at(p, "payload")?),
            VARIANT_SELECTION_MAP => {
                let mut r = self.at(p, "variant selections")?;
                let count = r.u64("variant selection count")?;
                // The reader sizes a map for `count` entries before reading them.
                r.holds(count, 8, "variant selections")?;
                let mut done = Decoded::default();
                for _ in 0..count * 2 {
                    let index = r.u32("variant selection")?;
                    done.bytes = done.bytes.saturating_add(self.string(index)?.bytes);
                }
                Ok(done)
            }
            TIME_SAMPLES if rep.inlined || rep.compressed => none,
            TIME_SAMPLES => self.time_samples(p, depth),
            DICTIONARY if rep.inlined || rep.compressed || rep.array => none,
            DICTIONARY => self.dictionary(&mut self.at(p, "dictionary")?, depth),
            RELOCATES if rep.inlined => none,
            RELOCATES => {
                let mut r = self.at(p, "relocates")?;
                let count = r.u64("relocate count")?;
                r.holds(count, 8, "relocates")?;
                self.indices(&mut r, count * 2, Items::Paths, depth)
            }
            // Scalars: inlined, or read as one fixed-size value whose absence the reader reports.
            _ => none,
        }
    }

    /// An array's element count as openusd's `unpack_array_len` reads it, and the reader
    /// positioned after it. Also whether the elements are compressed (`kind`'s rules).
    fn array_len_compressed(&self, rep: Rep, kind: ArrayKind) -> Result<(u64, bool, Reader<'a>), String> {
        let mut r = self.at(rep.payload, "array")?;
        if rep.payload == 0 {
            return Ok((0, false, r));
        }
        let v = self.version;
        if v < Version(0, 5, 0) {
            r.u32("array shape")?;
        }
        let mut compressed = match kind {
            ArrayKind::Ints => v >= Version(0, 5, 0) && rep.compressed,
            ArrayKind::Floats => v >= Version(0, 6, 0) && rep.compressed,
            ArrayKind::Other => false,
        };
        let count =
            if v < Version(0, 7, 0) { u64::from(r.u32("array length")?) } else { r.u64("array length")? };
        if count < 4 {
            compressed = false;
        }
        Ok((count, compressed, r))
    }

    fn array_len(&self, rep: Rep, kind: ArrayKind) -> Result<(u64, Reader<'a>), String> {
        let (count, _, r) = self.array_len_compressed(rep, kind)?;
        Ok((count, r))
    }

    fn int_array(&self, rep: Rep, size: u64) -> Result<Decoded, String> {
        let (count, compressed, mut r) = self.array_len_compressed(rep, ArrayKind::Ints)?;
        if count == 0 {
            return Ok(Decoded::default());
        }
        if compressed {
            read_ints(&mut r, count, size == 8, false, "compressed integer array")?;
        } else {
            r.holds(count, size, "integer array")?;
        }
        Ok(Decoded::array(count, size))
    }

    fn float_array(&self, rep: Rep, size: u64) -> Result<Decoded, String> {
        if rep.inlined {
            return Ok(Decoded::default());
        }
        let (count, compressed, mut r) = self.array_len_compressed(rep, ArrayKind::Floats)?;
        if !compressed {
            r.holds(count, size, "floating-point array")?;
            return Ok(Decoded::array(count, size));
        }
        match r.u8("compression code")? {
            b'i' => {
                read_ints(&mut r, count, false, false, "integer-coded floating-point array")?;
            }
            b't' => {
                // A lookup table, then one table index per element; openusd indexes the table
                // with them unchecked.
                let table = r.u32("lookup table size")?;
                r.holds(u64::from(table), size, "lookup table")?;
                r.take(table as usize * size as usize, "lookup table")?;
                let indices = read_ints(&mut r, count, false, true, "lookup indices")?;
                if let Some((i, &index)) = indices.iter().enumerate().find(|&(_, &x)| x as u32 >= table) {
                    return Err(format!(
                        "lookup index {i} is {} but the table has {table} entries",
                        index as u32
                    ));
                }
            }
            // Any other code is an error the reader reports.
            _ => return Ok(Decoded::default()),
        }
        Ok(Decoded::array(count, size))
    }

    /// A scalar `u32` as openusd's `unpack_value` reads it: the low bits of an inlined
    /// payload, else 4 bytes at the offset.
    fn scalar_u32(&self, rep: Rep) -> Result<u32, String> {
        if rep.inlined {
            Ok((rep.payload & 0xffff_ffff) as u32)
        } else {
            self.at(rep.payload, "index")?.u32("index")
        }
    }

    fn token(&self, index: u64) -> Result<Decoded, String> {
        match self.tables.token_lengths.get(index as usize) {
            Some(&len) => Ok(Decoded { bytes: 24 + u64::from(len), len: 1 }),
            None => {
                Err(format!("token index {} out of {} tokens", big(index), self.tables.token_lengths.len()))
            }
        }
    }

    fn string(&self, index: u32) -> Result<Decoded, String> {
        match self.tables.strings.get(index as usize) {
            Some(&token) => self.token(u64::from(token)),
            None => Err(format!("string index {index} out of {} strings", self.tables.strings.len())),
        }
    }

    fn path(&self, index: u32) -> Result<Decoded, String> {
        match self.tables.path_lengths.get(index as usize) {
            Some(&len) => Ok(Decoded { bytes: 24 + len, len: 1 }),
            None => Err(format!("path index {index} out of {} paths", self.tables.path_lengths.len())),
        }
    }

    /// A `u64` count then that many items.
    fn indexed(&mut self, r: &mut Reader, items: Items, depth: u32) -> Result<Decoded, String> {
        let count = r.u64("count")?;
        self.indices(r, count, items, depth)
    }

    /// `count` items at `r`; every index checked against its table.
    fn indices(&mut self, r: &mut Reader, count: u64, items: Items, depth: u32) -> Result<Decoded, String> {
        let mut done = Decoded { bytes: 0, len: count };
        let what = match items {
            Items::Tokens => "token indices",
            Items::Strings => "string indices",
            Items::Paths => "path indices",
            Items::Pod(_) => "list items",
            Items::References => "references",
            Items::Payloads => "payloads",
        };
        // Every item is at least this big on disk, and the reader allocates per item first.
        let min_size = match items {
            Items::Tokens | Items::Strings | Items::Paths => 4,
            Items::Pod(size) => size,
            // String index, path index, layer offset, custom-data count.
            Items::References => 32,
            Items::Payloads if self.version >= Version(0, 8, 0) => 24,
            Items::Payloads => 8,
        };
        r.holds(count, min_size, what)?;
        for _ in 0..count {
            let item = match items {
                Items::Tokens => self.token(u64::from(r.u32(what)?))?,
                Items::Strings => self.string(r.u32(what)?)?,
                Items::Paths => self.path(r.u32(what)?)?,
                Items::Pod(size) => {
                    r.take(size as usize, what)?;
                    Decoded { bytes: size, len: 1 }
                }
                Items::References => {
                    let asset = self.string(r.u32("reference asset")?)?;
                    let prim = self.path(r.u32("reference prim")?)?;
                    r.take(16, "reference layer offset")?;
                    let data = self.dictionary(r, depth + 1)?;
                    Decoded { bytes: asset.bytes + prim.bytes + data.bytes, len: 1 }
                }
                Items::Payloads => self.payload(r)?,
            };
            done.bytes = done.bytes.saturating_add(item.bytes);
            if done.bytes > MAX_DECODED_BYTES {
                break;
            }
        }
        Ok(done)
    }

    fn payload(&self, r: &mut Reader) -> Result<Decoded, String> {
        let asset = self.string(r.u32("payload asset")?)?;
        let prim = self.path(r.u32("payload prim")?)?;
        // Layer offsets joined payloads in crate version 0.8.0.
        if self.version >= Version(0, 8, 0) {
            r.take(16, "payload layer offset")?;
        }
        Ok(Decoded { bytes: asset.bytes + prim.bytes, len: 1 })
    }

    fn list_op(&mut self, offset: u64, items: Items, depth: u32) -> Result<Decoded, String> {
        let mut r = self.at(offset, "list op")?;
        let header = r.u8("list op header")?;
        let mut done = Decoded::default();
        // The reader's order: explicit, added, prepended, appended, deleted, ordered items.
        for bit in [1, 2, 5, 6, 3, 4] {
            if header & (1 << bit) != 0 {
                let part = self.indexed(&mut r, items, depth)?;
                done.bytes = done.bytes.saturating_add(part.bytes);
            }
        }
        Ok(done)
    }

    /// Follows a recursive offset as openusd does (relative to the offset's own position).
    /// Only forward jumps are accepted: the writer places nested data after the offset, and a
    /// backward jump lets a few bytes describe an endless dictionary.
    fn jump(r: &mut Reader, what: &str) -> Result<(), String> {
        let at = r.pos as u64;
        let offset = r.i64(what)?;
        if offset < 8 {
            return Err(format!("{what} at offset {at} jumps by {offset} bytes (must skip forward)"));
        }
        r.seek(at.saturating_add(offset as u64), what)
    }

    /// A dictionary at `r`: a count, then per entry a key string, a recursive offset and the
    /// value rep it leads to. `r` is left after the last entry's rep, as the reader leaves it.
    fn dictionary(&mut self, r: &mut Reader, depth: u32) -> Result<Decoded, String> {
        if depth > MAX_NESTING {
            return Err(format!("values nest deeper than {MAX_NESTING} levels"));
        }
        let count = r.u64("dictionary size")?;
        // Key, offset and rep: 20 bytes per entry at least, each entry after the last.
        r.holds(count, 20, "dictionary entries")?;
        let mut done = Decoded { bytes: 0, len: count };
        for _ in 0..count {
            let key = self.string(r.u32("dictionary key")?)?;
            Self::jump(r, "dictionary value offset")?;
            let value = r.u64("dictionary value")?;
            let value = self.check(value, depth + 1)?;
            done.bytes = done.bytes.saturating_add(64 + key.bytes + value.bytes);
        }
        Ok(done)
    }

    /// Time samples: a recursive offset to the times (a double array), then another to the
    /// sample count and one value rep per sample.
    fn time_samples(&mut self, offset: u64, depth: u32) -> Result<Decoded, String> {
        let mut r = self.at(offset, "time samples")?;
        Self::jump(&mut r, "time samples offset")?;
        let times = r.u64("sample times")?;
        let times_rep = Rep::new(times);
        if !(times_rep.ty == DOUBLE_VECTOR || (times_rep.ty == DOUBLE && times_rep.array)) {
            return Ok(Decoded::default());
        }
        let times = self.check(times, depth + 1)?;
        Self::jump(&mut r, "sample values offset")?;
        let count = r.u64("sample count")?;
        if count != times.len {
            return Ok(Decoded::default());
        }
        r.holds(count, 8, "sample values")?;
        let mut done = times;
        for _ in 0..count {
            let value = r.u64("sample value")?;
            let value = self.check(value, depth + 1)?;
            done.bytes = done.bytes.saturating_add(value.bytes);
            if done.bytes > MAX_DECODED_BYTES {
                break;
            }
        }
        Ok(done)
    }
}

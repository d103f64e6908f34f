//! [`SceneData`] (owned, what ingest fills) and [`SceneView`] (borrowed, validated, what render reads).

use crate::checksum::checksum;
use crate::container::{Header, SectionEntry, SectionKind, FORMAT_VERSION, MAGIC, SECTION_ALIGN};
use crate::error::BlobError;
use crate::records::*;
use bytemuck::Pod;

/// Upper bound on the section table length, so a corrupted count cannot make us read far.
const MAX_SECTIONS: u32 = 64;

/// A whole scene as owned vectors. `encode` turns it into blob bytes; the same data always gives the
/// same bytes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneData {
    /// Scene-wide facts.
    pub info: SceneInfo,
    /// Bytes referenced by every [`StrRef`].
    pub strings: Vec<u8>,
    /// World-space positions.
    pub positions: Vec<[f32; 3]>,
    /// Per-vertex normals; empty, or as long as `positions`.
    pub normals: Vec<[f32; 3]>,
    /// Per-vertex uvs; empty, or as long as `positions`.
    pub uvs: Vec<[f32; 2]>,
    /// Triangles.
    pub triangles: Vec<Triangle>,
    /// Material per triangle (as long as `triangles`).
    pub triangle_materials: Vec<u32>,
    /// Meshes.
    pub meshes: Vec<Mesh>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Cameras.
    pub cameras: Vec<Camera>,
    /// Emissive triangles with their sampling distribution.
    pub emissive_triangles: Vec<EmissiveTriangle>,
    /// BVH nodes (root first).
    pub bvh_nodes: Vec<BvhNode>,
    /// Triangle index per BVH primitive slot.
    pub bvh_primitives: Vec<u32>,
    /// Curves and points with their BVH.
    pub curves: crate::CurveData,
}

impl SceneData {
    /// Appends `text` to the strings section and returns its reference.
    pub fn add_string(&mut self, text: &str) -> StrRef {
        let offset = self.strings.len() as u32;
        self.strings.extend_from_slice(text.as_bytes());
        StrRef { offset, len: text.len() as u32 }
    }

    /// Serializes to blob bytes: header, section table, then each section 64-byte aligned.
    pub fn encode(&self) -> Vec<u8> {
        const { assert!(cfg!(target_endian = "little"), "the blob format is little-endian") };
        let sections: Vec<(SectionKind, u32, &[u8])> = vec![
            section(SectionKind::SceneInfo, std::slice::from_ref(&self.info)),
            (SectionKind::Strings, 1, &self.strings[..]),
            section(SectionKind::Positions, &self.positions),
            section(SectionKind::Normals, &self.normals),
            section(SectionKind::Uvs, &self.uvs),
            section(SectionKind::Triangles, &self.triangles),
            section(SectionKind::TriangleMaterials, &self.triangle_materials),
            section(SectionKind::Meshes, &self.meshes),
            section(SectionKind::Materials, &self.materials),
            section(SectionKind::Lights, &self.lights),
            section(SectionKind::Cameras, &self.cameras),
            section(SectionKind::EmissiveTriangles, &self.emissive_triangles),
            section(SectionKind::BvhNodes, &self.bvh_nodes),
            section(SectionKind::BvhPrimitives, &self.bvh_primitives),
            section(SectionKind::CurveGroups, &self.curves.groups),
            section(SectionKind::CurveSegments, &self.curves.segments),
            section(SectionKind::CurveAttributes, &self.curves.attributes),
            section(SectionKind::PointSpheres, &self.curves.spheres),
            section(SectionKind::CurveBvhNodes, &self.curves.bvh_nodes),
            section(SectionKind::CurveBvhPrimitives, &self.curves.bvh_primitives),
        ];
        let table_len = sections.len() * std::mem::size_of::<SectionEntry>();
        let mut cursor = align_up(std::mem::size_of::<Header>() + table_len);
        let mut table = Vec::with_capacity(sections.len());
        for (kind, record_size, bytes) in &sections {
            table.push(SectionEntry {
                kind: *kind as u32,
                record_size: *record_size,
                offset: cursor as u64,
                byte_len: bytes.len() as u64,
                checksum: checksum(bytes),
            });
            cursor = align_up(cursor + bytes.len());
        }
        let file_size = cursor;
        let table_bytes: &[u8] = bytemuck::cast_slice(&table);
        let mut header = Header {
            magic: MAGIC,
            version: FORMAT_VERSION,
            section_count: sections.len() as u32,
            file_size: file_size as u64,
            table_checksum: checksum(table_bytes),
            ..Header::default()
        };
        header.seal();

        let mut out = vec![0u8; file_size];
        out[..64].copy_from_slice(bytemuck::bytes_of(&header));
        out[64..64 + table_len].copy_from_slice(table_bytes);
        for (entry, (_, _, bytes)) in table.iter().zip(&sections) {
            let start = entry.offset as usize;
            out[start..start + bytes.len()].copy_from_slice(bytes);
        }
        out
    }
}

fn section<T: Pod>(kind: SectionKind, records: &[T]) -> (SectionKind, u32, &[u8]) {
    (kind, std::mem::size_of::<T>() as u32, bytemuck::cast_slice(records))
}

fn align_up(n: usize) -> usize {
    n.div_ceil(SECTION_ALIGN) * SECTION_ALIGN
}

/// A validated, zero-copy view of blob bytes. Every section bound, record size, checksum and
/// cross-reference index was checked by [`SceneView::parse`], so the typed slices can be indexed by the
/// stored indices without further checks.
#[derive(Clone, Copy, Debug)]
pub struct SceneView<'a> {
    /// Scene-wide facts.
    pub info: &'a SceneInfo,
    /// String bytes (every [`StrRef`] in the blob is a valid UTF-8 range of it).
    pub strings: &'a [u8],
    /// World-space positions.
    pub positions: &'a [[f32; 3]],
    /// Normals (empty or as long as `positions`).
    pub normals: &'a [[f32; 3]],
    /// Uvs (empty or as long as `positions`).
    pub uvs: &'a [[f32; 2]],
    /// Triangles.
    pub triangles: &'a [Triangle],
    /// Material per triangle.
    pub triangle_materials: &'a [u32],
    /// Meshes.
    pub meshes: &'a [Mesh],
    /// Materials.
    pub materials: &'a [Material],
    /// Lights.
    pub lights: &'a [Light],
    /// Cameras.
    pub cameras: &'a [Camera],
    /// Emissive triangles.
    pub emissive_triangles: &'a [EmissiveTriangle],
    /// BVH nodes, root first.
    pub bvh_nodes: &'a [BvhNode],
    /// Triangle index per BVH primitive slot.
    pub bvh_primitives: &'a [u32],
    /// Curves and points with their BVH.
    pub curves: crate::CurveView<'a>,
}

impl<'a> SceneView<'a> {
    /// Validates `bytes` completely and returns typed slices into it.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let sections = parse_container(bytes)?;
        let get = |kind: SectionKind| sections[kind.slot()].ok_or(BlobError::MissingSection(kind));
        let info_slice: &[SceneInfo] = typed(bytes, get(SectionKind::SceneInfo)?, SectionKind::SceneInfo)?;
        let [info] = info_slice else {
            return Err(BlobError::BadIndex {
                kind: SectionKind::SceneInfo,
                record: 0,
                what: "must hold exactly one record",
            });
        };
        let view = SceneView {
            info,
            strings: typed(bytes, get(SectionKind::Strings)?, SectionKind::Strings)?,
            positions: typed(bytes, get(SectionKind::Positions)?, SectionKind::Positions)?,
            normals: typed(bytes, get(SectionKind::Normals)?, SectionKind::Normals)?,
            uvs: typed(bytes, get(SectionKind::Uvs)?, SectionKind::Uvs)?,
            triangles: typed(bytes, get(SectionKind::Triangles)?, SectionKind::Triangles)?,
            triangle_materials: typed(
                bytes,
                get(SectionKind::TriangleMaterials)?,
                SectionKind::TriangleMaterials,
            )?,
            meshes: typed(bytes, get(SectionKind::Meshes)?, SectionKind::Meshes)?,
            materials: typed(bytes, get(SectionKind::Materials)?, SectionKind::Materials)?,
            lights: typed(bytes, get(SectionKind::Lights)?, SectionKind::Lights)?,
            cameras: typed(bytes, get(SectionKind::Cameras)?, SectionKind::Cameras)?,
            emissive_triangles: typed(
                bytes,
                get(SectionKind::EmissiveTriangles)?,
                SectionKind::EmissiveTriangles,
            )?,
            bvh_nodes: typed(bytes, get(SectionKind::BvhNodes)?, SectionKind::BvhNodes)?,
            bvh_primitives: typed(bytes, get(SectionKind::BvhPrimitives)?, SectionKind::BvhPrimitives)?,
            curves: crate::CurveView {
                groups: typed(bytes, get(SectionKind::CurveGroups)?, SectionKind::CurveGroups)?,
                segments: typed(bytes, get(SectionKind::CurveSegments)?, SectionKind::CurveSegments)?,
                attributes: typed(bytes, get(SectionKind::CurveAttributes)?, SectionKind::CurveAttributes)?,
                spheres: typed(bytes, get(SectionKind::PointSpheres)?, SectionKind::PointSpheres)?,
                bvh_nodes: typed(bytes, get(SectionKind::CurveBvhNodes)?, SectionKind::CurveBvhNodes)?,
                bvh_primitives: typed(
                    bytes,
                    get(SectionKind::CurveBvhPrimitives)?,
                    SectionKind::CurveBvhPrimitives,
                )?,
            },
        };
        view.validate_indices()?;
        Ok(view)
    }

    /// The text of a string reference (validated at parse time).
    pub fn string(&self, s: StrRef) -> &'a str {
        let range = s.offset as usize..s.offset as usize + s.len as usize;
        std::str::from_utf8(&self.strings[range]).unwrap_or("")
    }

    fn validate_indices(&self) -> Result<(), BlobError> {
        use SectionKind as K;
        let bad = |kind, record: usize, what| Err(BlobError::BadIndex { kind, record: record as u64, what });
        let vertex_count = self.positions.len();
        if !self.normals.is_empty() && self.normals.len() != vertex_count {
            return bad(K::Normals, 0, "normal count differs from position count");
        }
        if !self.uvs.is_empty() && self.uvs.len() != vertex_count {
            return bad(K::Uvs, 0, "uv count differs from position count");
        }
        if self.triangle_materials.len() != self.triangles.len() {
            return bad(K::TriangleMaterials, 0, "material count differs from triangle count");
        }
        let strings_ok = |s: StrRef| {
            let end = s.offset as u64 + s.len as u64;
            end <= self.strings.len() as u64
                && std::str::from_utf8(&self.strings[s.offset as usize..end as usize]).is_ok()
        };
        for (i, mesh) in self.meshes.iter().enumerate() {
            if !strings_ok(mesh.name) {
                return bad(K::Meshes, i, "name outside the strings section");
            }
            let tri_end = mesh.first_triangle as u64 + mesh.triangle_count as u64;
            let vtx_end = mesh.first_vertex as u64 + mesh.vertex_count as u64;
            if tri_end > self.triangles.len() as u64 || vtx_end > vertex_count as u64 {
                return bad(K::Meshes, i, "triangle or vertex range outside its section");
            }
            if mesh.flags & MESH_HAS_NORMALS != 0 && self.normals.is_empty() {
                return bad(K::Meshes, i, "claims normals but the blob has none");
            }
            if mesh.flags & MESH_HAS_UVS != 0 && self.uvs.is_empty() {
                return bad(K::Meshes, i, "claims uvs but the blob has none");
            }
        }
        for (i, tri) in self.triangles.iter().enumerate() {
            let Some(mesh) = self.meshes.get(tri.mesh as usize) else {
                return bad(K::Triangles, i, "mesh index out of range");
            };
            let lo = mesh.first_vertex as u64;
            let hi = lo + mesh.vertex_count as u64;
            if tri.vertices.iter().any(|&v| (v as u64) < lo || v as u64 >= hi) {
                return bad(K::Triangles, i, "vertex index outside its mesh");
            }
        }
        if let Some(i) = self.triangle_materials.iter().position(|&m| m as usize >= self.materials.len()) {
            return bad(K::TriangleMaterials, i, "material index out of range");
        }
        for (i, m) in self.materials.iter().enumerate() {
            if !strings_ok(m.name) {
                return bad(K::Materials, i, "name outside the strings section");
            }
        }
        for (i, l) in self.lights.iter().enumerate() {
            if !strings_ok(l.name) || l.kind > light_kind::DISK {
                return bad(K::Lights, i, "bad name or unknown light kind");
            }
        }
        for (i, c) in self.cameras.iter().enumerate() {
            if !strings_ok(c.name) || c.projection > PROJECTION_ORTHOGRAPHIC {
                return bad(K::Cameras, i, "bad name or unknown projection");
            }
        }
        let mut previous_cdf = 0.0f32;
        for (i, e) in self.emissive_triangles.iter().enumerate() {
            if e.triangle as usize >= self.triangles.len() || !(e.cdf >= previous_cdf && e.cdf <= 1.0) {
                return bad(K::EmissiveTriangles, i, "triangle out of range or cdf not increasing in [0, 1]");
            }
            previous_cdf = e.cdf;
        }
        if self.info.default_camera != NONE && self.info.default_camera as usize >= self.cameras.len() {
            return bad(K::SceneInfo, 0, "default camera out of range");
        }
        if self.info.dome_light != NONE
            && self.lights.get(self.info.dome_light as usize).map(|l| l.kind) != Some(light_kind::DOME)
        {
            return bad(K::SceneInfo, 0, "dome light index does not name a dome light");
        }
        if let Some(i) = self.bvh_primitives.iter().position(|&t| t as usize >= self.triangles.len()) {
            return bad(K::BvhPrimitives, i, "triangle index out of range");
        }
        if self.bvh_nodes.is_empty() != self.triangles.is_empty() {
            return bad(K::BvhNodes, 0, "a BVH is required exactly when there are triangles");
        }
        validate_cwbvh(self.bvh_nodes, self.bvh_primitives.len())
            .or_else(|(i, what)| bad(K::BvhNodes, i, what))?;
        self.curves.validate(self.materials.len(), strings_ok).or_else(|(kind, i, what)| bad(kind, i, what))
    }
}

/// Checks a CWBVH's child and leaf ranges against its node count and `primitives` slots.
pub(crate) fn validate_cwbvh(nodes: &[BvhNode], primitives: usize) -> Result<(), (usize, &'static str)> {
    for (i, node) in nodes.iter().enumerate() {
        let internal = node.imask.count_ones() as u64;
        if internal > 0 && node.child_base_idx as u64 + internal > nodes.len() as u64 {
            return Err((i, "child node range out of bounds"));
        }
        for (slot, &meta) in node.child_meta.iter().enumerate() {
            let is_internal = node.imask & (1 << slot) != 0;
            if meta == 0 || is_internal {
                continue;
            }
            // Leaf: low 5 bits = first primitive offset, high 3 bits = unary primitive count.
            let first = node.primitive_base_idx as u64 + (meta & 0b1_1111) as u64;
            let count = (meta >> 5).count_ones() as u64;
            if first + count > primitives as u64 {
                return Err((i, "leaf primitive range out of bounds"));
            }
        }
    }
    Ok(())
}

/// Validates header and table; returns each known kind's entry by [`SectionKind::slot`].
fn parse_container(bytes: &[u8]) -> Result<Vec<Option<SectionEntry>>, BlobError> {
    let actual = bytes.len() as u64;
    let header_len = std::mem::size_of::<Header>();
    if bytes.len() < header_len {
        return Err(BlobError::Truncated { needed: header_len as u64, actual });
    }
    let header: Header = bytemuck::pod_read_unaligned(&bytes[..header_len]);
    if header.magic != MAGIC {
        return Err(BlobError::BadMagic);
    }
    if header.header_checksum != header.expected_checksum() {
        return Err(BlobError::HeaderChecksum);
    }
    if header.version != FORMAT_VERSION {
        return Err(BlobError::UnsupportedVersion { found: header.version, supported: FORMAT_VERSION });
    }
    if header.file_size != actual {
        return Err(BlobError::FileSize { header: header.file_size, actual });
    }
    if header.section_count > MAX_SECTIONS {
        return Err(BlobError::SectionCount(header.section_count));
    }
    let table_end = header_len + header.section_count as usize * std::mem::size_of::<SectionEntry>();
    if bytes.len() < table_end {
        return Err(BlobError::Truncated { needed: table_end as u64, actual });
    }
    let table_bytes = &bytes[header_len..table_end];
    if header.table_checksum != checksum(table_bytes) {
        return Err(BlobError::TableChecksum);
    }
    let mut found: Vec<Option<SectionEntry>> = vec![None; SectionKind::ALL.len()];
    for raw in table_bytes.chunks_exact(std::mem::size_of::<SectionEntry>()) {
        let entry: SectionEntry = bytemuck::pod_read_unaligned(raw);
        let kind = SectionKind::from_u32(entry.kind).ok_or(BlobError::UnknownSection(entry.kind))?;
        let slot = &mut found[kind.slot()];
        if slot.is_some() {
            return Err(BlobError::DuplicateSection(kind));
        }
        let end = entry.offset.checked_add(entry.byte_len);
        let in_bounds = entry.offset.is_multiple_of(SECTION_ALIGN as u64)
            && entry.offset >= table_end as u64
            && end.is_some_and(|end| end <= actual);
        if !in_bounds {
            return Err(BlobError::SectionBounds { kind, offset: entry.offset, byte_len: entry.byte_len });
        }
        let expected = expected_record_size(kind);
        if entry.record_size != expected {
            return Err(BlobError::RecordSize { kind, found: entry.record_size, expected });
        }
        if !entry.byte_len.is_multiple_of(expected as u64) {
            return Err(BlobError::SectionBounds { kind, offset: entry.offset, byte_len: entry.byte_len });
        }
        let data = &bytes[entry.offset as usize..(entry.offset + entry.byte_len) as usize];
        if checksum(data) != entry.checksum {
            return Err(BlobError::SectionChecksum(kind));
        }
        *slot = Some(entry);
    }
    check_layout(bytes, table_end, &found)?;
    Ok(found)
}

/// Sections must not overlap, and every byte outside the header, the table and the sections (the
/// alignment padding) must be zero: checksums cover the sections, this covers the rest, so no byte of
/// the file can change unnoticed.
fn check_layout(bytes: &[u8], table_end: usize, found: &[Option<SectionEntry>]) -> Result<(), BlobError> {
    let mut sections: Vec<SectionEntry> = found.iter().flatten().copied().collect();
    // Empty sections share the offset of the next one; order them first.
    sections.sort_by_key(|e| (e.offset, e.byte_len));
    let mut cursor = table_end;
    for entry in &sections {
        let start = entry.offset as usize;
        let kind = SectionKind::from_u32(entry.kind).ok_or(BlobError::UnknownSection(entry.kind))?;
        if start < cursor {
            return Err(BlobError::SectionBounds { kind, offset: entry.offset, byte_len: entry.byte_len });
        }
        if bytes[cursor..start].iter().any(|&b| b != 0) {
            return Err(BlobError::Padding { offset: cursor as u64 });
        }
        cursor = start + entry.byte_len as usize;
    }
    if bytes[cursor..].iter().any(|&b| b != 0) {
        return Err(BlobError::Padding { offset: cursor as u64 });
    }
    Ok(())
}

fn expected_record_size(kind: SectionKind) -> u32 {
    use std::mem::size_of;
    (match kind {
        SectionKind::SceneInfo => size_of::<SceneInfo>(),
        SectionKind::Strings => 1,
        SectionKind::Positions | SectionKind::Normals => size_of::<[f32; 3]>(),
        SectionKind::Uvs => size_of::<[f32; 2]>(),
        SectionKind::Triangles => size_of::<Triangle>(),
        SectionKind::TriangleMaterials | SectionKind::BvhPrimitives => size_of::<u32>(),
        SectionKind::Meshes => size_of::<Mesh>(),
        SectionKind::Materials => size_of::<Material>(),
        SectionKind::Lights => size_of::<Light>(),
        SectionKind::Cameras => size_of::<Camera>(),
        SectionKind::EmissiveTriangles => size_of::<EmissiveTriangle>(),
        SectionKind::BvhNodes | SectionKind::CurveBvhNodes => size_of::<BvhNode>(),
        SectionKind::CurveGroups => size_of::<crate::CurveGroup>(),
        SectionKind::CurveSegments => size_of::<crate::CurveSegment>(),
        SectionKind::CurveAttributes => size_of::<crate::CurveAttributes>(),
        SectionKind::PointSpheres => size_of::<crate::PointSphere>(),
        SectionKind::CurveBvhPrimitives => size_of::<u32>(),
    }) as u32
}

fn typed<T: Pod>(bytes: &[u8], entry: SectionEntry, kind: SectionKind) -> Result<&[T], BlobError> {
    let data = &bytes[entry.offset as usize..(entry.offset + entry.byte_len) as usize];
    bytemuck::try_cast_slice(data).map_err(|_| BlobError::Misaligned(kind))
}

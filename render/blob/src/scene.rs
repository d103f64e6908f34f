//! [`SceneData`] (owned, what ingest fills) and [`SceneView`] (borrowed, validated, what render reads).

use crate::bulk::{first_failing, PendingChecksums};
use crate::checksum::checksum;
use crate::container::{
    Header, SectionEntry, SectionKind, FORMAT_VERSION, MAGIC, SECTION_ALIGN, TEXEL_ALIGN,
};
use crate::error::BlobError;
use crate::records::*;
use crate::tree::all_sane;
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
    /// Triangle blocks of the BVH leaves.
    pub bvh_blocks: Vec<TriangleBlock>,
    /// Baked textures (a UDIM tile is a texture).
    pub texture_records: Vec<TextureRecord>,
    /// UDIM sets.
    pub udim_sets: Vec<UdimSet>,
    /// Texture index (or [`NONE`]) per UDIM grid cell.
    pub udim_tiles: Vec<u32>,
    /// Texel bytes; texture records' level offsets point in here.
    pub texels: Vec<u8>,
    /// Every material's shading program, concatenated.
    pub shader_ops: Vec<ShaderOp>,
    /// Primvars the programs read, sorted by `(mesh, name_id)`.
    pub primvars: Vec<PrimvarRecord>,
    /// Their values.
    pub primvar_values: Vec<[f32; 4]>,
    /// Curves and points with their BVH.
    pub curves: crate::CurveData,
    /// Prototypes, instances and the top-level BVH.
    pub instancing: crate::InstanceData,
    /// Textured dome lights' maps and distributions.
    pub dome: crate::DomeData,
    /// Light sets (see [`crate::light_set_words`]); empty when nothing is linked.
    pub light_sets: Vec<u32>,
    /// Render products, their vars and the lights' groups.
    pub outputs: crate::OutputData,
    /// Deforming meshes' keys and their BVH.
    pub deform: crate::DeformData,
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
            section(SectionKind::BvhTriangleBlocks, &self.bvh_blocks),
            section(SectionKind::TextureRecords, &self.texture_records),
            section(SectionKind::UdimSets, &self.udim_sets),
            section(SectionKind::UdimTiles, &self.udim_tiles),
            section(SectionKind::ShaderOps, &self.shader_ops),
            section(SectionKind::Primvars, &self.primvars),
            section(SectionKind::PrimvarValues, &self.primvar_values),
            // Last, so the page padding in front of it is paid once and the small sections stay
            // together at the start of the file.
            (SectionKind::TextureTexels, 1, &self.texels[..]),
            section(SectionKind::CurveGroups, &self.curves.groups),
            section(SectionKind::CurveSegments, &self.curves.segments),
            section(SectionKind::CurveAttributes, &self.curves.attributes),
            section(SectionKind::PointSpheres, &self.curves.spheres),
            section(SectionKind::CurveBvhNodes, &self.curves.bvh_nodes),
            section(SectionKind::CurveBvhPrimitives, &self.curves.bvh_primitives),
            section(SectionKind::Prototypes, &self.instancing.prototypes),
            section(SectionKind::Instances, &self.instancing.instances),
            section(SectionKind::InstanceBvhNodes, &self.instancing.bvh_nodes),
            section(SectionKind::InstanceBvhItems, &self.instancing.bvh_items),
            section(SectionKind::PrototypeBvhNodes, &self.instancing.prototype_nodes),
            section(SectionKind::PrototypeBvhBlocks, &self.instancing.prototype_blocks),
            section(SectionKind::InstanceMotions, &self.instancing.motions),
            section(SectionKind::MotionKeys, &self.instancing.motion_keys),
            section(SectionKind::DomeMaps, &self.dome.maps),
            section(SectionKind::DomeCdfValues, &self.dome.cdf_values),
            section(SectionKind::LightSets, &self.light_sets),
            section(SectionKind::RenderProducts, &self.outputs.products),
            section(SectionKind::RenderVars, &self.outputs.vars),
            section(SectionKind::LightGroups, &self.outputs.light_groups),
            section(SectionKind::MeshMotions, &self.deform.motions),
            section(SectionKind::MeshMotionTimes, &self.deform.times),
            section(SectionKind::MeshMotionPoints, &self.deform.positions),
            section(SectionKind::DeformBvhNodes, &self.deform.bvh_nodes),
            section(SectionKind::DeformBvhBlocks, &self.deform.bvh_blocks),
        ];
        let table_len = sections.len() * std::mem::size_of::<SectionEntry>();
        let mut cursor = align_up(std::mem::size_of::<Header>() + table_len);
        let mut table = Vec::with_capacity(sections.len());
        for (kind, record_size, bytes) in &sections {
            if *kind == SectionKind::TextureTexels && !bytes.is_empty() {
                cursor = cursor.next_multiple_of(TEXEL_ALIGN);
            }
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
    /// BVH nodes, root first: a tree (every internal child after its parent and reached once, depth at
    /// most [`crate::tree::MAX_BVH_DEPTH`]), every leaf's block range in range and non-empty or
    /// [`child_ref::EMPTY`] (see [`crate::tree`]).
    pub bvh_nodes: &'a [BvhNode],
    /// Triangle blocks of the BVH leaves; every lane's triangle index is in range.
    pub bvh_blocks: &'a [TriangleBlock],
    /// Baked textures (every level inside `texels`, checked).
    pub texture_records: &'a [TextureRecord],
    /// UDIM sets (tile ranges inside `udim_tiles`, checked).
    pub udim_sets: &'a [UdimSet],
    /// Texture index or [`NONE`] per UDIM cell (indices checked).
    pub udim_tiles: &'a [u32],
    /// Texel bytes.
    pub texels: &'a [u8],
    /// Shading programs (kinds, registers, texture and input indices checked).
    pub shader_ops: &'a [ShaderOp],
    /// Primvars the programs read: sorted by `(mesh, name_id)` without repeats, mesh in range, value
    /// range inside `primvar_values` and as long as the interpolation needs for the mesh (checked).
    pub primvars: &'a [PrimvarRecord],
    /// Primvar values.
    pub primvar_values: &'a [[f32; 4]],
    /// Curves and points with their BVH.
    pub curves: crate::CurveView<'a>,
    /// Prototypes, instances and the top-level BVH.
    pub instancing: crate::InstanceView<'a>,
    /// Textured dome lights' maps and distributions (texture indices and every CDF checked).
    pub dome: crate::DomeView<'a>,
    /// Light sets (see [`crate::light_set_words`]): a whole number of sets, no bit past the last
    /// light, every mesh's set in range (checked).
    pub light_sets: &'a [u32],
    /// Render products, vars and light groups (checked: see [`crate::outputs`]).
    pub outputs: crate::OutputView<'a>,
    /// Deforming meshes' keys and their BVH (checked: see [`crate::deform`]).
    pub deform: crate::DeformView<'a>,
}

impl<'a> SceneView<'a> {
    /// Validates `bytes` completely — structure and checksums — and returns typed slices into it.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let (view, pending) = Self::parse_deferring_checksums(bytes)?;
        pending.verify(bytes)?;
        Ok(view)
    }

    /// Proves everything the typed slices' safety rests on and returns them with the section checksums
    /// still to verify (see [`crate::bulk`]): the caller must call [`PendingChecksums::verify`] before it
    /// trusts the data's values (render does so in the background and before writing any output).
    /// Errors are those of [`SceneView::parse`]: a refused structure with a checksum mismatch reports
    /// the mismatch.
    pub fn parse_deferring_checksums(bytes: &'a [u8]) -> Result<(Self, PendingChecksums), BlobError> {
        let (sections, pending) = parse_container(bytes)?;
        match Self::parse_sections(bytes, &sections) {
            Ok(view) => Ok((view, pending)),
            Err(e) => Err(pending.prefer_mismatch(bytes, e)),
        }
    }

    fn parse_sections(bytes: &'a [u8], sections: &[Option<SectionEntry>]) -> Result<Self, BlobError> {
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
            bvh_blocks: typed(bytes, get(SectionKind::BvhTriangleBlocks)?, SectionKind::BvhTriangleBlocks)?,
            texture_records: typed(bytes, get(SectionKind::TextureRecords)?, SectionKind::TextureRecords)?,
            udim_sets: typed(bytes, get(SectionKind::UdimSets)?, SectionKind::UdimSets)?,
            udim_tiles: typed(bytes, get(SectionKind::UdimTiles)?, SectionKind::UdimTiles)?,
            texels: typed(bytes, get(SectionKind::TextureTexels)?, SectionKind::TextureTexels)?,
            shader_ops: typed(bytes, get(SectionKind::ShaderOps)?, SectionKind::ShaderOps)?,
            primvars: typed(bytes, get(SectionKind::Primvars)?, SectionKind::Primvars)?,
            primvar_values: typed(bytes, get(SectionKind::PrimvarValues)?, SectionKind::PrimvarValues)?,
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
            instancing: crate::InstanceView {
                prototypes: typed(bytes, get(SectionKind::Prototypes)?, SectionKind::Prototypes)?,
                instances: typed(bytes, get(SectionKind::Instances)?, SectionKind::Instances)?,
                bvh_nodes: typed(bytes, get(SectionKind::InstanceBvhNodes)?, SectionKind::InstanceBvhNodes)?,
                bvh_items: typed(bytes, get(SectionKind::InstanceBvhItems)?, SectionKind::InstanceBvhItems)?,
                prototype_nodes: typed(
                    bytes,
                    get(SectionKind::PrototypeBvhNodes)?,
                    SectionKind::PrototypeBvhNodes,
                )?,
                prototype_blocks: typed(
                    bytes,
                    get(SectionKind::PrototypeBvhBlocks)?,
                    SectionKind::PrototypeBvhBlocks,
                )?,
                motions: typed(bytes, get(SectionKind::InstanceMotions)?, SectionKind::InstanceMotions)?,
                motion_keys: typed(bytes, get(SectionKind::MotionKeys)?, SectionKind::MotionKeys)?,
            },
            dome: crate::DomeView {
                maps: typed(bytes, get(SectionKind::DomeMaps)?, SectionKind::DomeMaps)?,
                cdf_values: typed(bytes, get(SectionKind::DomeCdfValues)?, SectionKind::DomeCdfValues)?,
            },
            light_sets: typed(bytes, get(SectionKind::LightSets)?, SectionKind::LightSets)?,
            outputs: crate::OutputView {
                products: typed(bytes, get(SectionKind::RenderProducts)?, SectionKind::RenderProducts)?,
                vars: typed(bytes, get(SectionKind::RenderVars)?, SectionKind::RenderVars)?,
                light_groups: typed(bytes, get(SectionKind::LightGroups)?, SectionKind::LightGroups)?,
            },
            deform: crate::DeformView {
                motions: typed(bytes, get(SectionKind::MeshMotions)?, SectionKind::MeshMotions)?,
                times: typed(bytes, get(SectionKind::MeshMotionTimes)?, SectionKind::MeshMotionTimes)?,
                positions: typed(bytes, get(SectionKind::MeshMotionPoints)?, SectionKind::MeshMotionPoints)?,
                bvh_nodes: typed(bytes, get(SectionKind::DeformBvhNodes)?, SectionKind::DeformBvhNodes)?,
                bvh_blocks: typed(bytes, get(SectionKind::DeformBvhBlocks)?, SectionKind::DeformBvhBlocks)?,
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

    /// Texture records against the texel section (every level's bytes inside it), UDIM sets against the
    /// tile table, tiles and ops against the texture tables, op registers and inputs against their
    /// ranges: everything a lookup or a program step indexes.
    fn validate_textures(&self) -> Result<(), BlobError> {
        use SectionKind as K;
        let bad = |kind, record: usize, what| Err(BlobError::BadIndex { kind, record: record as u64, what });
        for (i, rec) in self.texture_records.iter().enumerate() {
            if let Err(what) = check_texture(rec, self.texels.len() as u64) {
                return bad(K::TextureRecords, i, what);
            }
        }
        for (i, set) in self.udim_sets.iter().enumerate() {
            let cells = set.u_count as u64 * set.v_count as u64;
            if !(1..=10).contains(&set.u_count)
                || set.v_count == 0
                || set.first_tile as u64 + cells > self.udim_tiles.len() as u64
            {
                return bad(K::UdimSets, i, "tile range outside the tile table or bad grid size");
            }
        }
        let textures = self.texture_records.len();
        if let Some(i) = self.udim_tiles.iter().position(|&t| t != NONE && t as usize >= textures) {
            return bad(K::UdimTiles, i, "texture index out of range");
        }
        for (i, op) in self.shader_ops.iter().enumerate() {
            let register_ok = |r: u32| r < MAX_REGISTERS;
            let ok = match op.kind {
                op_kind::CONST | op_kind::PRIMVAR_UV | op_kind::PRIMVAR => register_ok(op.dst),
                op_kind::TRANSFORM_2D => register_ok(op.dst) && register_ok(op.src),
                op_kind::TEXTURE => {
                    let limit = if op.flags & OP_UDIM != 0 { self.udim_sets.len() } else { textures };
                    register_ok(op.dst)
                        && register_ok(op.src)
                        && (op.texture == NONE || (op.texture as usize) < limit)
                }
                op_kind::OUTPUT => op.dst < shading_input::COUNT && register_ok(op.src),
                op_kind::MATH => {
                    crate::op_math(op.flags) < crate::math_op::COUNT
                        && [op.dst, op.src, op.src2, op.src3].into_iter().all(register_ok)
                }
                _ => false,
            };
            if !ok {
                return bad(K::ShaderOps, i, "unknown kind, register, texture or input index out of range");
            }
        }
        Ok(())
    }

    /// Primvar records against the meshes (index, and the value count the interpolation needs) and the
    /// value section, and their order (strictly increasing `(mesh, name_id)`, which the render-time
    /// binary search relies on).
    fn validate_primvars(&self, strings_ok: impl Fn(StrRef) -> bool) -> Result<(), BlobError> {
        let bad = |record: usize, what| {
            Err(BlobError::BadIndex { kind: SectionKind::Primvars, record: record as u64, what })
        };
        let mut previous: Option<(u32, u32)> = None;
        for (i, p) in self.primvars.iter().enumerate() {
            let Some(mesh) = self.meshes.get(p.mesh as usize) else {
                return bad(i, "mesh index out of range");
            };
            if !strings_ok(p.name) {
                return bad(i, "name outside the strings section");
            }
            if previous.is_some_and(|prev| prev >= (p.mesh, p.name_id)) {
                return bad(i, "records not sorted by (mesh, name id) or repeated");
            }
            previous = Some((p.mesh, p.name_id));
            let expected = match p.interpolation {
                primvar_interpolation::CONSTANT => 1,
                primvar_interpolation::UNIFORM => mesh.triangle_count as u64,
                primvar_interpolation::VERTEX => mesh.vertex_count as u64,
                primvar_interpolation::FACE_VARYING => 3 * mesh.triangle_count as u64,
                _ => return bad(i, "unknown interpolation"),
            };
            if !(1..=4).contains(&p.components) || p.value_count as u64 != expected {
                return bad(i, "components outside 1..=4 or value count does not match the mesh");
            }
            if p.first_value as u64 + p.value_count as u64 > self.primvar_values.len() as u64 {
                return bad(i, "value range outside the primvar-value section");
            }
        }
        Ok(())
    }

    /// Scene bounds sane (or the empty encoding: min = +inf, max = −inf), the authored resolution
    /// unauthored (0×0) or within [`crate::tree::MAX_RESOLUTION_AXIS`] and [`crate::tree::MAX_PIXELS`],
    /// and the data window unset or an upright rectangle within ±[`crate::tree::MAX_NDC`].
    fn validate_info(&self) -> Result<(), BlobError> {
        use crate::tree::{MAX_PIXELS, MAX_RESOLUTION_AXIS};
        let bad = |what| Err(BlobError::BadIndex { kind: SectionKind::SceneInfo, record: 0, what });
        let info = self.info;
        let empty = info.bounds_min.iter().all(|&x| x == f32::INFINITY)
            && info.bounds_max.iter().all(|&x| x == f32::NEG_INFINITY);
        let sane_bounds = all_sane(&info.bounds_min) && all_sane(&info.bounds_max);
        if !(empty || sane_bounds) {
            return bad("scene bounds non-finite or beyond ±1e12 (and not the empty encoding)");
        }
        if !info.world_origin.iter().all(|x| x.is_finite()) {
            return bad("world origin not finite");
        }
        let [w, h] = info.resolution;
        if (w == 0) != (h == 0) {
            return bad("resolution has one zero axis");
        }
        if w > MAX_RESOLUTION_AXIS || h > MAX_RESOLUTION_AXIS || w as u64 * h as u64 > MAX_PIXELS {
            return bad("resolution beyond 65536 per axis or 2^28 pixels");
        }
        if !(info.meters_per_unit.is_finite() && info.meters_per_unit >= 0.0) {
            return bad("metersPerUnit non-finite or negative");
        }
        let [x0, y0, x1, y1] = info.data_window_ndc;
        let window_unset = x0 == x1 || y0 == y1;
        if !info.data_window_ndc.iter().all(|v| v.is_finite() && v.abs() <= crate::tree::MAX_NDC)
            || !(window_unset || (x0 < x1 && y0 < y1))
        {
            return bad("data window non-finite, beyond ±16 or inverted");
        }
        Ok(())
    }

    /// The number of light sets (0: nothing is linked).
    pub fn light_set_count(&self) -> usize {
        let per_set = 2 * crate::light_set_words(self.lights.len());
        self.light_sets.len().checked_div(per_set).unwrap_or(0)
    }

    /// Light sets: whole sets of `2 × light_set_words` words, no bit set past the last light, and
    /// every mesh's index below the set count (or 0 when there are none).
    fn validate_light_sets(&self) -> Result<(), BlobError> {
        use SectionKind as K;
        let bad = |kind, record: usize, what| Err(BlobError::BadIndex { kind, record: record as u64, what });
        let words = crate::light_set_words(self.lights.len());
        if !self.light_sets.is_empty() && (words == 0 || !self.light_sets.len().is_multiple_of(2 * words)) {
            return bad(K::LightSets, 0, "not a whole number of light sets for the blob's lights");
        }
        let tail = self.lights.len() % 32;
        if tail != 0 {
            let past = !((1u32 << tail) - 1);
            if let Some(i) = self.light_sets.chunks(words).position(|half| half[words - 1] & past != 0) {
                return bad(K::LightSets, i * words, "bit set past the last light");
            }
        }
        let sets = self.light_set_count();
        if let Some(i) = self.meshes.iter().position(|m| m.light_set as usize >= sets.max(1)) {
            return bad(K::Meshes, i, "light set index out of range");
        }
        Ok(())
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
        let meshes = self.meshes;
        if let Some(i) = first_failing(self.triangles, |tri| {
            meshes.get(tri.mesh as usize).is_some_and(|mesh| {
                let lo = mesh.first_vertex as u64;
                let hi = lo + mesh.vertex_count as u64;
                tri.vertices.iter().all(|&v| (v as u64) >= lo && (v as u64) < hi)
            })
        }) {
            let tri = &self.triangles[i];
            let what = if meshes.get(tri.mesh as usize).is_none() {
                "mesh index out of range"
            } else {
                "vertex index outside its mesh"
            };
            return bad(K::Triangles, i, what);
        }
        let material_count = self.materials.len();
        if let Some(i) = first_failing(self.triangle_materials, |&m| (m as usize) < material_count) {
            return bad(K::TriangleMaterials, i, "material index out of range");
        }
        for (i, m) in self.materials.iter().enumerate() {
            if !strings_ok(m.name) {
                return bad(K::Materials, i, "name outside the strings section");
            }
            if m.program_start as u64 + m.program_len as u64 > self.shader_ops.len() as u64 {
                return bad(K::Materials, i, "program range outside the shader-op section");
            }
            if let Some(what) = m.openpbr_out_of_range() {
                return bad(K::Materials, i, what);
            }
        }
        self.validate_textures()?;
        self.validate_primvars(strings_ok)?;
        for (i, l) in self.lights.iter().enumerate() {
            if !strings_ok(l.name) || l.kind > light_kind::TEXTURED_DOME {
                return bad(K::Lights, i, "bad name or unknown light kind");
            }
            let shape = [l.radius, l.width, l.height, l.angle_degrees];
            if !all_sane(bytemuck::cast_slice(&l.world_from_light))
                || !all_sane(&shape)
                || !l.radiance.iter().all(|x| x.is_finite())
            {
                return bad(K::Lights, i, "non-finite or huge transform, size or radiance");
            }
            if l.kind == light_kind::TEXTURED_DOME && l.dome_map as usize >= self.dome.maps.len() {
                return bad(K::Lights, i, "dome map index out of range");
            }
        }
        self.dome.validate(self.texture_records.len()).or_else(|(i, what)| bad(K::DomeMaps, i, what))?;
        self.validate_light_sets()?;
        self.outputs.validate(self.lights.len(), strings_ok).or_else(|(kind, i, what)| bad(kind, i, what))?;
        for (i, c) in self.cameras.iter().enumerate() {
            if !strings_ok(c.name) || c.projection > PROJECTION_ORTHOGRAPHIC {
                return bad(K::Cameras, i, "bad name or unknown projection");
            }
            let lens = [
                c.focal_length,
                c.horizontal_aperture,
                c.vertical_aperture,
                c.horizontal_aperture_offset,
                c.vertical_aperture_offset,
            ];
            if !all_sane(bytemuck::cast_slice(&c.world_from_camera)) || !all_sane(&lens) {
                return bad(K::Cameras, i, "non-finite or huge transform, focal length or aperture");
            }
            if let Err(what) = check_thin_lens(c) {
                return bad(K::Cameras, i, what);
            }
        }
        // Emissive triangles and the world BVH address only the top-level triangles: prototype
        // triangles are in prototype space and reached through their instances.
        let top_level = self.instancing.top_level_triangles(self.triangles.len());
        let mut previous_cdf = 0.0f32;
        for (i, e) in self.emissive_triangles.iter().enumerate() {
            if e.triangle as usize >= top_level || !(e.cdf >= previous_cdf && e.cdf <= 1.0) {
                return bad(K::EmissiveTriangles, i, "triangle out of range or cdf not increasing in [0, 1]");
            }
            previous_cdf = e.cdf;
        }
        self.validate_info()?;
        // One pass over all coordinates; the offending record is looked for only on failure.
        if let Some(i) = first_failing(self.positions, |p| all_sane(p)) {
            return bad(K::Positions, i, "non-finite or huge position");
        }
        if self.info.default_camera != NONE && self.info.default_camera as usize >= self.cameras.len() {
            return bad(K::SceneInfo, 0, "default camera out of range");
        }
        if self.info.dome_light != NONE
            && !matches!(
                self.lights.get(self.info.dome_light as usize).map(|l| l.kind),
                Some(light_kind::DOME | light_kind::TEXTURED_DOME)
            )
        {
            return bad(K::SceneInfo, 0, "dome light index does not name a dome light");
        }
        let mut block_error = None;
        // One pass over the blocks for both of their checks; the tree's errors come between the two.
        let index_ok = |b: &TriangleBlock| b.triangles.iter().all(|&t| (t as usize) < top_level);
        let block_ok = |b: &TriangleBlock| all_sane(bytemuck::cast_slice(&b.vertices));
        if let Some(i) = first_failing(self.bvh_blocks, |b| index_ok(b) & block_ok(b)) {
            if let Some(i) = self.bvh_blocks[i..].iter().position(|b| !index_ok(b)).map(|j| i + j) {
                return bad(K::BvhTriangleBlocks, i, "triangle index out of range or inside a prototype");
            }
            block_error = Some(i);
        }
        if self.bvh_nodes.is_empty() != (top_level == 0) {
            return bad(K::BvhNodes, 0, "a BVH is required exactly when there are top-level triangles");
        }
        // The world BVH is a tree (see `tree`): every query visits each node at most once.
        let blocks = self.bvh_blocks.len() as u64;
        let nodes = self.bvh_nodes;
        crate::tree::check_tree(0, nodes.len(), crate::tree::MAX_BVH_DEPTH, |n| {
            crate::tree::bvh8_children(nodes, n, nodes.len(), (0, blocks), "leaf block range out of bounds")
        })
        .or_else(|(i, what)| bad(K::BvhNodes, i, what))?;
        if let Some(i) = block_error {
            return bad(K::BvhTriangleBlocks, i, "non-finite or huge vertex");
        }
        self.instancing
            .validate(self.triangles.len(), self.meshes.len(), strings_ok)
            .or_else(|(kind, i, what)| bad(kind, i, what))?;
        self.deform
            .validate(self.meshes, self.triangles, top_level)
            .or_else(|(kind, i, what)| bad(kind, i, what))?;
        self.validate_camera_motion()?;
        self.curves.validate(self.materials.len(), strings_ok).or_else(|(kind, i, what)| bad(kind, i, what))
    }
}

impl SceneView<'_> {
    /// A moving camera's keys (format 16): 2..=[`crate::MAX_MOTION_KEYS`] records of the motion keys
    /// section, times as an instance's, matrices finite and invertible; a still camera has none.
    fn validate_camera_motion(&self) -> Result<(), BlobError> {
        let bad = |record: usize, what| {
            Err(BlobError::BadIndex { kind: SectionKind::Cameras, record: record as u64, what })
        };
        for (i, c) in self.cameras.iter().enumerate() {
            if c.motion_key_count == 0 {
                if c.first_motion_key != 0 {
                    return bad(i, "a still camera's first motion key is not zero");
                }
                continue;
            }
            if !(2..=crate::MAX_MOTION_KEYS).contains(&c.motion_key_count) {
                return bad(i, "motion key count not 0 or within 2..=256");
            }
            let first = c.first_motion_key as usize;
            let Some(keys) = self.instancing.motion_keys.get(first..first + c.motion_key_count as usize)
            else {
                return bad(i, "motion key range outside the motion keys section");
            };
            if crate::deform::key_times_ok(keys.iter().map(|k| k.time)).is_some() {
                return bad(
                    i,
                    "motion key time NaN, infinite, beyond ±1e4 time codes or not after the previous key",
                );
            }
            if !keys.iter().all(|k| crate::instances::key_matrix_ok(&k.world_from_object)) {
                return bad(i, "motion key transform NaN, beyond ±1e12 or not invertible");
            }
        }
        Ok(())
    }
}

/// Validates header and table; returns each known kind's entry by [`SectionKind::slot`] and the section
/// checksums to verify. An error found after some sections' bounds were proven is reported as a
/// checksum mismatch of one of them if there is one (the order the eager checks had).
fn parse_container(bytes: &[u8]) -> Result<(Vec<Option<SectionEntry>>, PendingChecksums), BlobError> {
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
    let mut pending = PendingChecksums::default();
    for raw in table_bytes.chunks_exact(std::mem::size_of::<SectionEntry>()) {
        let entry: SectionEntry = bytemuck::pod_read_unaligned(raw);
        let slot =
            check_entry(bytes, table_end, entry, &found).map_err(|e| pending.prefer_mismatch(bytes, e))?;
        found[slot] = Some(entry);
        pending.push(entry);
    }
    check_layout(bytes, table_end, &found).map_err(|e| pending.prefer_mismatch(bytes, e))?;
    Ok((found, pending))
}

/// One section-table entry's kind, uniqueness, alignment, bounds and record size; returns its slot.
fn check_entry(
    bytes: &[u8],
    table_end: usize,
    entry: SectionEntry,
    found: &[Option<SectionEntry>],
) -> Result<usize, BlobError> {
    let actual = bytes.len() as u64;
    {
        let kind = SectionKind::from_u32(entry.kind).ok_or(BlobError::UnknownSection(entry.kind))?;
        if found[kind.slot()].is_some() {
            return Err(BlobError::DuplicateSection(kind));
        }
        let end = entry.offset.checked_add(entry.byte_len);
        let align = if kind == SectionKind::TextureTexels && entry.byte_len > 0 {
            TEXEL_ALIGN
        } else {
            SECTION_ALIGN
        };
        let in_bounds = entry.offset.is_multiple_of(align as u64)
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
        Ok(kind.slot())
    }
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

/// The depth-of-field fields of a camera: a pinhole (`f_stop` 0) or a thin lens with a positive
/// f-stop up to [`MAX_F_STOP`] and a positive focus distance, and an aperture that is round or a
/// polygon of 3..=[`MAX_APERTURE_BLADES`] blades with a bounded rotation; and a shutter interval.
fn check_thin_lens(c: &Camera) -> Result<(), &'static str> {
    if !(c.f_stop >= 0.0 && c.f_stop <= MAX_F_STOP) {
        return Err("fStop not in [0, 1e6] (or NaN)");
    }
    if !(c.focus_distance >= 0.0 && crate::tree::sane(c.focus_distance)) {
        return Err("focusDistance negative, NaN or huge");
    }
    if c.f_stop > 0.0 && c.focus_distance == 0.0 {
        return Err("focusDistance 0 with a nonzero fStop (the thin lens needs a focus plane)");
    }
    if c.aperture_blades != 0 && !(3..=MAX_APERTURE_BLADES).contains(&c.aperture_blades) {
        return Err("aperture blades not 0 (round) or 3..=64");
    }
    if c.aperture_rotation.is_nan() || c.aperture_rotation.abs() > 360.0 {
        return Err("aperture rotation not within ±360 degrees (or NaN)");
    }
    let shutter_ok = |t: f32| t.is_finite() && t.abs() <= MAX_SHUTTER;
    if !(shutter_ok(c.shutter_open) && shutter_ok(c.shutter_close) && c.shutter_open <= c.shutter_close) {
        return Err("shutter open/close not finite within ±1e4 time codes with open <= close");
    }
    Ok(())
}

/// The checks of `texture::TextureView::new`, repeated here so that the blob alone guarantees that no
/// lookup reads outside the texel section: format, size, channels, tile size, level count, and every
/// level's tiled byte range (edge tiles padded, as the bake lays them out) inside `texel_len`.
fn check_texture(rec: &TextureRecord, texel_len: u64) -> Result<(), &'static str> {
    if rec.format > 2 {
        return Err("unknown texel format");
    }
    if !(1..=MAX_TEXTURE_DIMENSION).contains(&rec.width) || !(1..=MAX_TEXTURE_DIMENSION).contains(&rec.height)
    {
        return Err("width or height out of range");
    }
    if !(1..=4).contains(&rec.channels) {
        return Err("channels must be 1..=4");
    }
    if !(2..=12).contains(&rec.tile_log2) {
        return Err("tile_log2 must be 2..=12");
    }
    let full_chain = 32 - rec.width.max(rec.height).leading_zeros();
    if rec.mip_count == 0 || rec.mip_count > full_chain {
        return Err("mip_count must be 1..=full chain");
    }
    let texel_bytes = rec.channels as u64 * if rec.format == 2 { 2 } else { 1 };
    let tile = 1u64 << rec.tile_log2;
    for level in 0..rec.mip_count {
        let w = ((rec.width >> level).max(1)) as u64;
        let h = ((rec.height >> level).max(1)) as u64;
        let (tw, th) = (w.min(tile), h.min(tile));
        let len = w.div_ceil(tw) * h.div_ceil(th) * tw * th * texel_bytes;
        if rec.level_offsets[level as usize].checked_add(len).is_none_or(|end| end > texel_len) {
            return Err("mip level runs past the texel section");
        }
    }
    Ok(())
}

fn expected_record_size(kind: SectionKind) -> u32 {
    use std::mem::size_of;
    (match kind {
        SectionKind::SceneInfo => size_of::<SceneInfo>(),
        SectionKind::Strings | SectionKind::TextureTexels => 1,
        SectionKind::Positions | SectionKind::Normals => size_of::<[f32; 3]>(),
        SectionKind::Uvs => size_of::<[f32; 2]>(),
        SectionKind::Triangles => size_of::<Triangle>(),
        SectionKind::TriangleMaterials | SectionKind::UdimTiles => size_of::<u32>(),
        SectionKind::TextureRecords => size_of::<TextureRecord>(),
        SectionKind::UdimSets => size_of::<UdimSet>(),
        SectionKind::ShaderOps => size_of::<ShaderOp>(),
        SectionKind::Primvars => size_of::<PrimvarRecord>(),
        SectionKind::PrimvarValues => size_of::<[f32; 4]>(),
        SectionKind::Meshes => size_of::<Mesh>(),
        SectionKind::Materials => size_of::<Material>(),
        SectionKind::Lights => size_of::<Light>(),
        SectionKind::Cameras => size_of::<Camera>(),
        SectionKind::EmissiveTriangles => size_of::<EmissiveTriangle>(),
        SectionKind::BvhNodes => size_of::<BvhNode>(),
        SectionKind::BvhTriangleBlocks => size_of::<TriangleBlock>(),
        SectionKind::CurveBvhNodes => size_of::<CwBvhNode>(),
        SectionKind::CurveGroups => size_of::<crate::CurveGroup>(),
        SectionKind::CurveSegments => size_of::<crate::CurveSegment>(),
        SectionKind::CurveAttributes => size_of::<crate::CurveAttributes>(),
        SectionKind::PointSpheres => size_of::<crate::PointSphere>(),
        SectionKind::CurveBvhPrimitives | SectionKind::InstanceBvhItems | SectionKind::LightSets => {
            size_of::<u32>()
        }
        SectionKind::Prototypes => size_of::<crate::Prototype>(),
        SectionKind::Instances => size_of::<crate::Instance>(),
        SectionKind::InstanceBvhNodes | SectionKind::PrototypeBvhNodes => size_of::<BvhNode>(),
        SectionKind::PrototypeBvhBlocks => size_of::<TriangleBlock>(),
        SectionKind::InstanceMotions => size_of::<crate::InstanceMotion>(),
        SectionKind::MotionKeys => size_of::<crate::MotionKey>(),
        SectionKind::DomeMaps => size_of::<crate::DomeMap>(),
        SectionKind::DomeCdfValues => size_of::<f32>(),
        SectionKind::RenderProducts => size_of::<crate::RenderProduct>(),
        SectionKind::RenderVars => size_of::<crate::RenderVar>(),
        SectionKind::LightGroups => size_of::<StrRef>(),
        SectionKind::MeshMotions => size_of::<crate::MeshMotion>(),
        SectionKind::MeshMotionTimes => size_of::<f32>(),
        SectionKind::MeshMotionPoints => size_of::<[f32; 3]>(),
        SectionKind::DeformBvhNodes => size_of::<BvhNode>(),
        SectionKind::DeformBvhBlocks => size_of::<TriangleBlock>(),
    }) as u32
}

fn typed<T: Pod>(bytes: &[u8], entry: SectionEntry, kind: SectionKind) -> Result<&[T], BlobError> {
    let data = &bytes[entry.offset as usize..(entry.offset + entry.byte_len) as usize];
    bytemuck::try_cast_slice(data).map_err(|_| BlobError::Misaligned(kind))
}

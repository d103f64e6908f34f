//! What the packing steps share: the error they report, the vertex layout every mesh is
//! stored with, and the blob's affine-matrix rows. A leaf module, so that `pack` and its
//! children (`curves`, `dome`, `instances`) all use it without importing from each other.

use crate::scene::PrimvarLayout;
use blob::records as rec;
use glam::{Mat4, Vec3};

/// A scene that cannot be packed, naming the prim and the problem.
#[derive(Debug, thiserror::Error)]
#[error("{prim}: {problem}")]
pub struct PackError {
    /// Prim path.
    pub prim: String,
    /// What is wrong.
    pub problem: String,
}

/// Which optional vertex sections the blob has (all meshes share them, so a mesh without normals
/// or uvs gets filler entries when another mesh has them).
pub(super) struct MeshLayout {
    pub(super) any_normals: bool,
    pub(super) any_uvs: bool,
    /// Scene-wide id of each primvar name programs read (the `PRIMVAR` op's key).
    pub(super) primvar_ids: std::collections::BTreeMap<String, u32>,
    /// Blob material per scene material (materials equal in value share one record).
    pub(super) material_slot: Vec<u32>,
}

impl MeshLayout {
    /// Appends one mesh, whose vertices, triangles and primvars are in the space it is stored in
    /// (world, or its prototype's), and its mesh record.
    pub(super) fn push(&self, data: &mut blob::SceneData, mesh: &crate::scene::Mesh) {
        let (positions, normals, triangles) = (&mesh.positions, &mesh.normals, &mesh.triangles);
        let mesh_index = data.meshes.len() as u32;
        let first_vertex = data.positions.len() as u32;
        let first_triangle = data.triangles.len() as u32;
        let name = data.add_string(&mesh.path);
        data.positions.extend(positions.iter().map(|p| p.to_array()));
        if self.any_normals {
            if normals.is_empty() {
                data.normals.extend(std::iter::repeat_n([0.0, 0.0, 1.0], positions.len()));
            } else {
                data.normals.extend(normals.iter().map(|n| n.normalize_or(Vec3::Z).to_array()));
            }
        }
        if self.any_uvs {
            if mesh.uvs.is_empty() {
                data.uvs.extend(std::iter::repeat_n([0.0, 0.0], positions.len()));
            } else {
                data.uvs.extend(mesh.uvs.iter().map(|uv| uv.to_array()));
            }
        }
        for tri in triangles {
            data.triangles.push(rec::Triangle { vertices: tri.map(|v| v + first_vertex), mesh: mesh_index });
        }
        data.triangle_materials
            .extend(mesh.triangle_materials.iter().map(|&m| self.material_slot[m as usize]));
        let mut flags = 0;
        if !normals.is_empty() {
            flags |= rec::MESH_HAS_NORMALS;
        }
        if !mesh.uvs.is_empty() {
            flags |= rec::MESH_HAS_UVS;
        }
        if mesh.double_sided {
            flags |= rec::MESH_DOUBLE_SIDED;
        }
        // Values are in the storage space's winding: corner values follow their triangle's vertex
        // order (see `LocalGeometry::transformed`).
        let mut primvars: Vec<_> = mesh.primvars.iter().map(|p| (self.primvar_ids[&p.name], p)).collect();
        primvars.sort_by_key(|&(id, _)| id);
        for (name_id, p) in primvars {
            let name = data.add_string(&p.name);
            data.primvars.push(rec::PrimvarRecord {
                name,
                name_id,
                mesh: mesh_index,
                interpolation: match p.layout {
                    PrimvarLayout::Constant => rec::primvar_interpolation::CONSTANT,
                    PrimvarLayout::PerTriangle => rec::primvar_interpolation::UNIFORM,
                    PrimvarLayout::PerVertex => rec::primvar_interpolation::VERTEX,
                    PrimvarLayout::PerCorner => rec::primvar_interpolation::FACE_VARYING,
                },
                components: p.components,
                first_value: data.primvar_values.len() as u32,
                value_count: p.values.len() as u32,
            });
            data.primvar_values.extend_from_slice(&p.values);
        }
        data.meshes.push(rec::Mesh {
            name,
            first_triangle,
            triangle_count: triangles.len() as u32,
            first_vertex,
            vertex_count: positions.len() as u32,
            flags,
            light_set: mesh.light_set,
        });
    }
}

/// Rows 0..3 of a 4×4 affine matrix (column-vector convention), as stored in the blob.
pub(super) fn affine_rows(m: &Mat4) -> [[f32; 4]; 3] {
    let rows = m.transpose().to_cols_array_2d();
    [rows[0], rows[1], rows[2]]
}

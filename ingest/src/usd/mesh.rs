//! UsdGeomMesh: topology, triangulation, primvars, world transform.

use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::sync::Arc;

use glam::{DMat4, DVec2, DVec3, Vec2};

use super::stage::Value;
use super::{fallback, Inherited, Reader, UsdError};
use crate::scene::{LocalGeometry, Mesh, MeshPrimvar, PlacedMesh, PrimvarLayout};

/// Primvar interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Interpolation {
    Constant,
    Uniform,
    Vertex,
    FaceVarying,
}

impl Interpolation {
    fn parse(token: &str) -> Option<Self> {
        match token {
            "constant" => Some(Interpolation::Constant),
            "uniform" => Some(Interpolation::Uniform),
            // `varying` is linear across the face: per point for a polygonal mesh.
            "vertex" | "varying" => Some(Interpolation::Vertex),
            "faceVarying" => Some(Interpolation::FaceVarying),
            _ => None,
        }
    }

    /// Whether vertices must be split per face corner to carry this primvar.
    fn splits(self) -> bool {
        matches!(self, Interpolation::Uniform | Interpolation::FaceVarying)
    }
}

/// A validated primvar: every lookup is in range.
#[derive(PartialEq)]
pub(super) struct Primvar<T> {
    pub values: Vec<T>,
    pub indices: Option<Vec<usize>>,
    pub interpolation: Interpolation,
}

impl<T: Copy> Primvar<T> {
    /// The value at face `face`, face-vertex `corner` (running index into faceVertexIndices),
    /// point `point`.
    pub(super) fn get(&self, face: usize, corner: usize, point: usize) -> T {
        let element = match self.interpolation {
            Interpolation::Constant => 0,
            Interpolation::Uniform => face,
            Interpolation::Vertex => point,
            Interpolation::FaceVarying => corner,
        };
        match &self.indices {
            Some(indices) => self.values[indices[element]],
            None => self.values[element],
        }
    }
}

/// A primvar a material program reads, as authored on the cage (elements widened to `vec4`).
#[derive(PartialEq)]
pub(super) struct CagePrimvar {
    pub name: String,
    pub components: u32,
    pub primvar: Primvar<[f32; 4]>,
}

impl CagePrimvar {
    /// The layout of the triangulated values.
    pub(super) fn layout(&self) -> PrimvarLayout {
        match self.primvar.interpolation {
            Interpolation::Constant => PrimvarLayout::Constant,
            Interpolation::Uniform => PrimvarLayout::PerTriangle,
            Interpolation::Vertex => PrimvarLayout::PerVertex,
            Interpolation::FaceVarying => PrimvarLayout::PerCorner,
        }
    }

    pub(super) fn empty(&self) -> MeshPrimvar {
        MeshPrimvar {
            name: self.name.clone(),
            layout: self.layout(),
            components: self.components,
            values: Vec::new(),
        }
    }
}

/// Widens `components` numbers to a `vec4` the way the primvar readers read them: a scalar broadcast to
/// rgb, missing components 0, alpha 1.
pub(super) fn widen(c: &[f64]) -> [f32; 4] {
    match *c {
        [s] => [s as f32, s as f32, s as f32, 1.0],
        [x, y] => [x as f32, y as f32, 0.0, 1.0],
        [x, y, z] => [x as f32, y as f32, z as f32, 1.0],
        [x, y, z, w, ..] => [x as f32, y as f32, z as f32, w as f32],
        [] => [0.0, 0.0, 0.0, 1.0],
    }
}

/// Element counts a primvar must provide per interpolation.
pub(super) struct Topology {
    faces: usize,
    points: usize,
    corners: usize,
}

/// A triangulated mesh in its local space, before the world transform.
#[derive(Clone, Default)]
pub(super) struct LocalMesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    pub triangle_materials: Vec<u32>,
    pub double_sided: bool,
    pub primvars: Vec<MeshPrimvar>,
}

/// A mesh's cage as authored, checked enough to triangulate: the polygon path, and the fallback
/// of a subdivision surface OpenSubdiv cannot take.
pub(super) struct PolygonCage {
    pub points: Vec<DVec3>,
    /// `faceVertexCounts` (non-negative).
    pub counts: Vec<usize>,
    /// Point per face corner; [`INVALID_POINT`] where a subdivision mesh authors an index out of
    /// range (its face is left out of the cage).
    pub corners_to_points: Vec<usize>,
    pub holes: HashSet<i64>,
    pub left_handed: bool,
    pub normals: Option<Primvar<DVec3>>,
    pub uvs: Option<Primvar<DVec2>>,
    /// Primvars the bound materials read.
    pub primvars: Vec<CagePrimvar>,
    /// Material index per face.
    pub face_materials: Vec<u32>,
    pub double_sided: bool,
}

/// Marks a face corner whose point index is out of range.
pub(super) const INVALID_POINT: usize = usize::MAX;

/// What [`PolygonCage::triangulate`] left out.
#[derive(Default)]
pub(super) struct Skipped {
    /// Faces with fewer than 3 vertices.
    pub degenerate: usize,
    /// Faces with a point index out of range.
    pub invalid: usize,
}

impl PolygonCage {
    /// Triangulates every face that is not a hole, splitting vertices per face corner where a
    /// primvar is uniform or face-varying.
    pub(super) fn triangulate(&self) -> (LocalMesh, Skipped) {
        let (points, corners_to_points) = (&self.points, &self.corners_to_points);
        let (normals, uvs) = (&self.normals, &self.uvs);
        let split = normals.as_ref().is_some_and(|p| p.interpolation.splits())
            || uvs.as_ref().is_some_and(|p| p.interpolation.splits());
        let mut out = LocalMesh { double_sided: self.double_sided, ..LocalMesh::default() };
        let mut primvars: Vec<MeshPrimvar> = self.primvars.iter().map(CagePrimvar::empty).collect();
        for (cage, mesh) in self.primvars.iter().zip(&mut primvars) {
            match mesh.layout {
                PrimvarLayout::Constant => mesh.values.push(cage.primvar.get(0, 0, 0)),
                PrimvarLayout::PerVertex if !split => {
                    mesh.values = (0..points.len()).map(|p| cage.primvar.get(0, 0, p)).collect();
                }
                _ => {}
            }
        }
        if !split {
            out.positions = points.clone();
            if let Some(n) = normals {
                out.normals = (0..points.len()).map(|p| n.get(0, 0, p)).collect();
            }
            if let Some(uv) = uvs {
                out.uvs = (0..points.len()).map(|p| uv.get(0, 0, p).as_vec2()).collect();
            }
        }
        let mut skipped = Skipped::default();
        let mut start = 0usize;
        let mut polygon = Vec::new();
        for (face, &n) in self.counts.iter().enumerate() {
            let corners = start..start + n;
            start += n;
            if n < 3 {
                skipped.degenerate += 1;
                continue;
            }
            if corners.clone().any(|c| corners_to_points[c] == INVALID_POINT) {
                skipped.invalid += 1;
                continue;
            }
            if self.holes.contains(&(face as i64)) {
                continue;
            }
            polygon.clear();
            polygon.extend(corners.clone().map(|c| points[corners_to_points[c]]));
            let triangles = triangulate(&polygon);
            let vertex_of = |k: usize| -> u32 { corners_to_points[corners.start + k] as u32 };
            let base = out.positions.len() as u32;
            if split {
                for c in corners.clone() {
                    let p = corners_to_points[c];
                    out.positions.push(points[p]);
                    if let Some(nv) = normals {
                        out.normals.push(nv.get(face, c, p));
                    }
                    if let Some(uv) = uvs {
                        out.uvs.push(uv.get(face, c, p).as_vec2());
                    }
                    for (cage, mesh) in self.primvars.iter().zip(&mut primvars) {
                        if mesh.layout == PrimvarLayout::PerVertex {
                            mesh.values.push(cage.primvar.get(face, c, p));
                        }
                    }
                }
            }
            for [a, b, c] in triangles {
                let tri = if split {
                    [base + a as u32, base + b as u32, base + c as u32]
                } else {
                    [vertex_of(a), vertex_of(b), vertex_of(c)]
                };
                let order = if self.left_handed { [a, c, b] } else { [a, b, c] };
                out.triangles.push(if self.left_handed { [tri[0], tri[2], tri[1]] } else { tri });
                out.triangle_materials.push(self.face_materials[face]);
                for (cage, mesh) in self.primvars.iter().zip(&mut primvars) {
                    match mesh.layout {
                        PrimvarLayout::PerTriangle => mesh.values.push(cage.primvar.get(face, 0, 0)),
                        PrimvarLayout::PerCorner => mesh.values.extend(order.map(|k| {
                            let c = corners.start + k;
                            cage.primvar.get(face, c, corners_to_points[c])
                        })),
                        _ => {}
                    }
                }
            }
        }
        out.primvars = primvars;
        (out, skipped)
    }
}

impl Reader<'_> {
    /// Reads a Mesh prim into the scene: subdivision surfaces (any `subdivisionScheme` but
    /// `none`) are queued for dicing once the camera is known (`super::subdivision`), polygon
    /// meshes are triangulated here.
    pub(super) fn read_mesh(&mut self, path: &str, state: &Inherited) -> Result<(), UsdError> {
        // A topology attribute of the wrong type makes the mesh unreadable, not the stage.
        let (points, counts, indices) = match (
            self.vec3s(path, "points"),
            self.ints(path, "faceVertexCounts"),
            self.ints(path, "faceVertexIndices"),
        ) {
            (Ok(p), Ok(c), Ok(i)) => (p.unwrap_or_default(), c.unwrap_or_default(), i.unwrap_or_default()),
            (Err(e), _, _) | (_, Err(e), _) | (_, _, Err(e)) => {
                let message = e.to_string();
                let message = message.rsplit(": ").next().unwrap_or(&message);
                let attr = e.attribute_name().unwrap_or("topology").to_string();
                self.warn(path, format!("{attr}: {message}; mesh skipped"));
                return Ok(());
            }
        };
        if points.is_empty() || counts.is_empty() {
            self.warn(path, "mesh has no points or no faces; skipped");
            return Ok(());
        }
        if let Some((i, p)) = points.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(self.invalid(
                path,
                "points",
                format!("point {i} is not finite ({}, {}, {})", p.x, p.y, p.z),
            ));
        }
        let mut sizes = Vec::with_capacity(counts.len());
        for &c in &counts {
            sizes.push(usize::try_from(c).map_err(|_| {
                self.invalid(path, "faceVertexCounts", format!("negative face vertex count {c}"))
            })?);
        }
        let total: usize = sizes.iter().sum();
        if total != indices.len() {
            return Err(self.invalid(
                path,
                "faceVertexCounts",
                format!("counts sum to {total} but faceVertexIndices has {} entries", indices.len()),
            ));
        }
        let scheme = self
            .token(path, "subdivisionScheme")?
            .unwrap_or_else(|| fallback::SUBDIVISION_SCHEME.to_string());
        let subdivided = scheme != "none";
        let mut corners_to_points = Vec::with_capacity(indices.len());
        for &i in &indices {
            match usize::try_from(i) {
                Ok(i) if i < points.len() => corners_to_points.push(i),
                // A subdivision surface with bad topology falls back to its cage (less the bad
                // faces) with a warning, like every other topology OpenSubdiv rejects.
                _ if subdivided => corners_to_points.push(INVALID_POINT),
                _ => {
                    return Err(self.invalid(
                        path,
                        "faceVertexIndices",
                        format!("index {i} out of range ({} points)", points.len()),
                    ))
                }
            }
        }
        let holes: HashSet<i64> = self.ints(path, "holeIndices")?.unwrap_or_default().into_iter().collect();
        let left_handed =
            self.token(path, "orientation")?.as_deref().unwrap_or(fallback::ORIENTATION) == "leftHanded";
        let topology = Topology { faces: counts.len(), points: points.len(), corners: indices.len() };

        // Authored normals are ignored on subdivision surfaces (USD spec: the limit surface
        // defines them); `primvars:normals` wins over `normals`.
        let normals = if subdivided {
            None
        } else if self.stage.attr(path, "primvars:normals")?.is_some() {
            self.primvar3(path, "primvars:normals", Interpolation::Constant, &topology)?
        } else {
            self.primvar3(path, "normals", Interpolation::Vertex, &topology)?
        };
        let uvs = match self.st_primvar_name(path) {
            Some(name) => self.primvar2(path, &name, &topology)?,
            None => None,
        };
        let face_materials = self.mesh_face_materials(path, counts.len())?;
        let primvars = self.program_primvars(path, &face_materials, Some(&topology))?;
        let double_sided = self.bool(path, "doubleSided")?.unwrap_or(fallback::DOUBLE_SIDED);
        let cage = PolygonCage {
            points,
            counts: sizes,
            corners_to_points,
            holes,
            left_handed,
            normals,
            uvs,
            primvars,
            face_materials,
            double_sided,
        };
        let cage = if subdivided {
            match self.queue_subdivision(path, &scheme, &counts, &indices, cage, state)? {
                Some(rejected) => rejected,
                None => return Ok(()),
            }
        } else {
            cage
        };
        let (out, skipped) = cage.triangulate();
        if skipped.degenerate > 0 {
            let n = skipped.degenerate;
            self.warn(path, format!("{n} degenerate faces (fewer than 3 vertices) skipped"));
        }
        if skipped.invalid > 0 {
            self.warn(path, format!("{} faces with a point index out of range skipped", skipped.invalid));
        }
        self.push_mesh(path, out, state);
        Ok(())
    }

    /// The name of the texture-coordinate primvar of a mesh or curve prim: `primvars:st`, else the
    /// first `texCoord2f[]`.
    pub(super) fn st_primvar_name(&self, path: &str) -> Option<String> {
        let names = self.stage.property_names(path);
        if names.iter().any(|n| n == "primvars:st") {
            return Some("primvars:st".into());
        }
        names.into_iter().find(|n| {
            n.starts_with("primvars:")
                && !n.ends_with(":indices")
                && self.stage.attr_type(path, n).as_deref() == Some("texCoord2f[]")
        })
    }

    fn interpolation(&mut self, path: &str, name: &str, default: Interpolation) -> Option<Interpolation> {
        match self.stage.attr_metadata(path, name, "interpolation") {
            None => Some(default),
            Some(v) => match v.as_str().and_then(Interpolation::parse) {
                Some(i) => Some(i),
                None => {
                    self.warn(path, format!("{name} has unknown interpolation {v:?}; ignored"));
                    None
                }
            },
        }
    }

    /// Reads and validates a primvar whose elements have `N` components.
    fn primvar<const N: usize>(
        &mut self,
        path: &str,
        name: &str,
        default: Interpolation,
        topology: &Topology,
    ) -> Result<Option<Primvar<[f64; N]>>, UsdError> {
        let Some(value) = self.stage.attr(path, name)? else { return Ok(None) };
        let Some(values) = value.as_array::<N>() else {
            self.warn(path, format!("{name} is not an array of {N}-vectors; ignored"));
            return Ok(None);
        };
        self.checked_primvar(path, name, values, default, topology)
    }

    /// The primvar `primvars:{name}` a material program reads, with any 1..=4 components (numbers,
    /// ints, bools), widened to `vec4`. A constant primvar not authored on the gprim is inherited
    /// from the nearest ancestor that authors it (USD's primvar inheritance). `topology` is `None`
    /// for implicit shapes, which only take constant primvars. `None` (with a warning where the
    /// primvar exists but cannot be used) makes the readers return their fallback.
    pub(super) fn program_primvar(
        &mut self,
        path: &str,
        name: &str,
        topology: Option<&Topology>,
    ) -> Result<Option<CagePrimvar>, UsdError> {
        let attr = format!("primvars:{name}");
        let mut owner = path.to_string();
        let value = loop {
            if let Some(v) = self.stage.attr(&owner, &attr)? {
                let constant = owner == path
                    || self.interpolation(&owner, &attr, Interpolation::Constant)
                        == Some(Interpolation::Constant);
                if constant {
                    break v;
                }
            }
            let parent = super::parent_of(&owner);
            if owner == "/" || parent == "/" || parent.is_empty() {
                return Ok(None);
            }
            owner = parent.to_string();
        };
        let (elements, components, array) = match &value {
            Value::Array { data, arity } if (1..=4).contains(arity) => {
                (data.chunks_exact(*arity).map(widen).collect::<Vec<_>>(), *arity as u32, true)
            }
            Value::Scalar(s) => (vec![widen(&[*s])], 1, false),
            Value::Tuple(t) if (1..=4).contains(&t.len()) => (vec![widen(t)], t.len() as u32, false),
            Value::Str(_) | Value::StrArray(_) => {
                self.warn(path, format!("{attr} is a string primvar; readers of it use their fallback"));
                return Ok(None);
            }
            _ => {
                self.warn(
                    path,
                    format!(
                        "{attr} is not a numeric primvar of 1 to 4 components; readers use their fallback"
                    ),
                );
                return Ok(None);
            }
        };
        let constant =
            |values: Vec<[f32; 4]>| Primvar { values, indices: None, interpolation: Interpolation::Constant };
        let primvar = match topology {
            // A single value, or an inherited one, is constant whatever its metadata says.
            _ if !array || owner != path => Some(constant(elements)),
            Some(t) => self.checked_primvar(path, &attr, elements, Interpolation::Constant, t)?,
            None => {
                if self.interpolation(path, &attr, Interpolation::Constant) != Some(Interpolation::Constant) {
                    self.warn(
                        path,
                        format!("{attr} is not constant on an implicit shape; using its first value"),
                    );
                }
                elements.first().map(|&e| constant(vec![e]))
            }
        };
        Ok(primvar.map(|primvar| CagePrimvar { name: name.to_string(), components, primvar }))
    }

    /// Checks a primvar's element count (or its indices) against its interpolation.
    fn checked_primvar<T>(
        &mut self,
        path: &str,
        name: &str,
        values: Vec<T>,
        default: Interpolation,
        topology: &Topology,
    ) -> Result<Option<Primvar<T>>, UsdError> {
        let Some(interpolation) = self.interpolation(path, name, default) else { return Ok(None) };
        let expected = match interpolation {
            Interpolation::Constant => 1,
            Interpolation::Uniform => topology.faces,
            Interpolation::Vertex => topology.points,
            Interpolation::FaceVarying => topology.corners,
        };
        let indices = match self.stage.attr(path, &format!("{name}:indices"))? {
            Some(Value::Array { data, arity: 1 }) => Some(data),
            _ => None,
        };
        let indices = match indices {
            Some(indices) => {
                let valid = indices.len() >= expected
                    && indices.iter().all(|&i| i >= 0.0 && (i as usize) < values.len());
                if !valid {
                    self.warn(
                        path,
                        format!(
                            "{name}:indices has {} entries (need {expected}) or indexes past {} values; ignored",
                            indices.len(),
                            values.len()
                        ),
                    );
                    return Ok(None);
                }
                Some(indices.into_iter().map(|i| i as usize).collect())
            }
            None => {
                if values.len() < expected {
                    self.warn(
                        path,
                        format!(
                            "{name} has {} values, {interpolation:?} needs {expected}; ignored",
                            values.len()
                        ),
                    );
                    return Ok(None);
                }
                None
            }
        };
        Ok(Some(Primvar { values, indices, interpolation }))
    }

    fn primvar3(
        &mut self,
        path: &str,
        name: &str,
        default: Interpolation,
        topology: &Topology,
    ) -> Result<Option<Primvar<DVec3>>, UsdError> {
        Ok(self.primvar::<3>(path, name, default, topology)?.map(|p| Primvar {
            values: p.values.into_iter().map(DVec3::from_array).collect(),
            indices: p.indices,
            interpolation: p.interpolation,
        }))
    }

    fn primvar2(
        &mut self,
        path: &str,
        name: &str,
        topology: &Topology,
    ) -> Result<Option<Primvar<DVec2>>, UsdError> {
        Ok(self.primvar::<2>(path, name, Interpolation::Constant, topology)?.map(|p| Primvar {
            values: p.values.into_iter().map(DVec2::from_array).collect(),
            indices: p.indices,
            interpolation: p.interpolation,
        }))
    }

    /// Adds a local mesh to the scene: in world space, or inside an instance as a reference to
    /// geometry shared with every identical instance (see [`GeometryInterner`]).
    pub(super) fn push_mesh(&mut self, path: &str, local: LocalMesh, state: &Inherited) {
        let mesh = match state.instance {
            Some(frame) => self.placed_mesh(path, local, frame, state.world_from_local),
            None => world_mesh(path, local, state.world_from_local),
        };
        self.scene.meshes.push(mesh);
    }

    /// A gprim inside the instance `frame`: its materials and a reference to its interned geometry.
    pub(super) fn placed_mesh(
        &mut self,
        path: &str,
        local: LocalMesh,
        frame: super::InstanceFrame,
        world_from_local: DMat4,
    ) -> Mesh {
        let (geometry, triangle_materials, double_sided) = local.split();
        let geometry = self.geometry.intern(geometry);
        placed_with(path, geometry, triangle_materials, double_sided, frame, world_from_local)
    }
}

/// A gprim inside the instance `frame` drawing the shared `geometry`.
pub(super) fn placed_with(
    path: &str,
    geometry: Arc<LocalGeometry>,
    triangle_materials: Vec<u32>,
    double_sided: bool,
    frame: super::InstanceFrame,
    world_from_local: DMat4,
) -> Mesh {
    Mesh {
        path: path.to_string(),
        triangle_materials,
        double_sided,
        placed: Some(PlacedMesh::new(frame.index, geometry, world_from_local, frame.instance_from_local)),
        motion: None,
        deformation: None,
        ..Mesh::default()
    }
}

impl LocalMesh {
    /// The shareable geometry, the per-triangle materials and `doubleSided`.
    pub(super) fn split(self) -> (LocalGeometry, Vec<u32>, bool) {
        let geometry = LocalGeometry {
            positions: self.positions,
            normals: self.normals,
            uvs: self.uvs,
            triangles: self.triangles,
            primvars: self.primvars,
        };
        (geometry, self.triangle_materials, self.double_sided)
    }
}

/// One allocation per distinct instanced gprim geometry: every instance proxy of a prototype is
/// read (its bindings and inherited primvars may differ), but an identical copy is dropped at once
/// for the one already kept, so ingest holds one mesh per prototype, not one per instance.
#[derive(Default)]
pub(super) struct GeometryInterner {
    by_hash: HashMap<u64, Vec<Arc<LocalGeometry>>>,
}

impl GeometryInterner {
    /// The shared copy of `geometry`.
    pub(super) fn intern(&mut self, geometry: LocalGeometry) -> Arc<LocalGeometry> {
        let candidates = self.by_hash.entry(geometry_hash(&geometry)).or_default();
        if let Some(found) = candidates.iter().find(|g| ***g == geometry) {
            return Arc::clone(found);
        }
        let shared = Arc::new(geometry);
        candidates.push(Arc::clone(&shared));
        shared
    }
}

fn geometry_hash(g: &LocalGeometry) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    g.positions.iter().for_each(|p| p.to_array().map(f64::to_bits).hash(&mut h));
    g.normals.iter().for_each(|n| n.to_array().map(f64::to_bits).hash(&mut h));
    g.uvs.iter().for_each(|uv| uv.to_array().map(f32::to_bits).hash(&mut h));
    g.triangles.hash(&mut h);
    for p in &g.primvars {
        (&p.name, p.layout as u8, p.components).hash(&mut h);
        p.values.iter().for_each(|v| v.map(f32::to_bits).hash(&mut h));
    }
    h.finish()
}

/// A local mesh in world space (see [`LocalGeometry::transformed`] for the winding).
pub(super) fn world_mesh(path: &str, local: LocalMesh, world_from_local: DMat4) -> Mesh {
    let (geometry, triangle_materials, double_sided) = local.split();
    let world = geometry.transformed(world_from_local);
    Mesh {
        path: path.to_string(),
        positions: world.positions,
        normals: world.normals,
        uvs: geometry.uvs,
        triangles: world.triangles,
        triangle_materials,
        double_sided,
        instance: None,
        primvars: world.primvars,
        // Assigned once every light is read (`Reader::assign_light_sets`).
        light_set: 0,
        placed: None,
        motion: None,
        deformation: None,
    }
}

/// Triangulates a simple polygon, returning corner-index triples with the polygon's winding.
///
/// Convex polygons (the common case) are fanned from corner 0; concave ones are ear-clipped in
/// the polygon's plane (Newell normal). A self-intersecting polygon that ear clipping cannot finish
/// has its remainder fanned.
pub(super) fn triangulate(polygon: &[DVec3]) -> Vec<[usize; 3]> {
    let n = polygon.len();
    if n < 3 {
        return Vec::new();
    }
    let fan = |ids: &[usize]| -> Vec<[usize; 3]> {
        (1..ids.len() - 1).map(|i| [ids[0], ids[i], ids[i + 1]]).collect()
    };
    let all: Vec<usize> = (0..n).collect();
    if n == 3 {
        return fan(&all);
    }
    // Newell normal: robust for non-planar and concave polygons.
    let mut normal = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (polygon[i], polygon[(i + 1) % n]);
        normal += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    if normal.length_squared() == 0.0 {
        return fan(&all);
    }
    let normal = normal.normalize();
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    // (u, v, normal) is right-handed, so the polygon winds counter-clockwise in (u, v).
    let p2: Vec<DVec2> = polygon.iter().map(|p| DVec2::new(p.dot(u), p.dot(v))).collect();
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let convex = (0..n).all(|i| cross(p2[(i + n - 1) % n], p2[i], p2[(i + 1) % n]) >= 0.0);
    if convex {
        return fan(&all);
    }
    let mut remaining = all;
    let mut out = Vec::with_capacity(n - 2);
    while remaining.len() > 3 {
        let m = remaining.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (remaining[(i + m - 1) % m], remaining[i], remaining[(i + 1) % m]);
            if cross(p2[a], p2[b], p2[c]) <= 0.0 {
                return false; // reflex or degenerate corner
            }
            // No other remaining vertex may lie inside the candidate ear.
            !remaining.iter().any(|&o| {
                o != a
                    && o != b
                    && o != c
                    && cross(p2[a], p2[b], p2[o]) >= 0.0
                    && cross(p2[b], p2[c], p2[o]) >= 0.0
                    && cross(p2[c], p2[a], p2[o]) >= 0.0
            })
        });
        let Some(i) = ear else { break };
        out.push([remaining[(i + m - 1) % m], remaining[i], remaining[(i + 1) % m]]);
        remaining.remove(i);
    }
    out.extend(fan(&remaining));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(polygon: &[DVec3], tris: &[[usize; 3]]) -> f64 {
        tris.iter()
            .map(|&[a, b, c]| 0.5 * (polygon[b] - polygon[a]).cross(polygon[c] - polygon[a]).length())
            .sum()
    }

    #[test]
    fn triangulation_counts() {
        let quad = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        assert_eq!(triangulate(&quad).len(), 2);
        let pentagon: Vec<DVec3> = (0..5)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 5.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert_eq!(triangulate(&pentagon).len(), 3);
    }

    #[test]
    fn concave_l_shape_is_ear_clipped() {
        // L of three unit squares, area 3, with a reflex corner at (1, 1); in the XZ plane, wound
        // so its normal is +Y... and the plane orientation must not matter.
        let l = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)];
        for poly in [
            l.iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect::<Vec<_>>(),
            l.iter().map(|&(x, y)| DVec3::new(x, 5.0, -y)).collect::<Vec<_>>(),
            l.iter().rev().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect::<Vec<_>>(),
        ] {
            let tris = triangulate(&poly);
            assert_eq!(tris.len(), 4);
            assert!((area(&poly, &tris) - 3.0).abs() < 1e-12, "area {}", area(&poly, &tris));
            // Every triangle keeps the polygon's winding.
            let newell: DVec3 = (0..poly.len()).map(|i| poly[i].cross(poly[(i + 1) % poly.len()])).sum();
            for &[a, b, c] in &tris {
                assert!((poly[b] - poly[a]).cross(poly[c] - poly[a]).dot(newell) > 0.0);
            }
        }
    }
}

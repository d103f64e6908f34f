//! Subdivision surfaces: every Mesh whose `subdivisionScheme` is not `none`.
//!
//! During the walk `queue_subdivision` turns the mesh into a validated OpenSubdiv cage (scheme
//! and rule tokens, creases, corners, holes, the st primvar as a face-varying channel or a vertex
//! primvar; left-handed faces reversed) and reserves the mesh's slot in `Scene::meshes`, so the
//! mesh order stays the traversal order. Dicing needs the render camera, which is only known
//! once the walk has ended (RenderSettings may name a camera anywhere on the stage), so
//! `tessellate_subdivisions` runs after the walk: it picks each mesh's edge rates (adaptive, the
//! default) or level (uniform) (`crate::dicing`), tessellates the queued cages in parallel, and
//! fills the slots with world-space limit surfaces. A cage OpenSubdiv rejects is rendered as its
//! triangulated cage, with one warning naming the problem.
//!
//! Instances of one subdivision prototype (identical local cages inside instances) are queued
//! once: later copies only add their placement (a *follower*) and drop their cage. The surface is
//! diced once at, per cage edge, the finest rate any of its instances needs (uniform: the finest
//! level), so every instance shares one tessellation and one prototype.

use std::str::FromStr;

use std::sync::Arc;

use glam::{DMat4, DVec3, Vec2};
use rayon::prelude::*;
use subdiv::{
    tessellate, AdaptiveRefiner, AdaptiveUv, BoundaryInterpolation, Cage, Evaluation, FaceVaryingChannel,
    FaceVaryingInterpolation, Options, Refiner, Scheme, Tessellation, Topology, TriangleSubdivision,
    UniformPlan, UvSource,
};

use super::mesh::{placed_with, world_mesh, Interpolation, LocalMesh, PolygonCage, INVALID_POINT};
use super::{Inherited, Reader, UsdError};
use crate::dicing::{choose_edge_rates, choose_level, triangles_at_level, DicingCamera, SubdivOptions};
use crate::scene::{Mesh, MeshPrimvar, PrimvarLayout, Subdivision};

/// The st primvar in the form the refiner takes.
#[derive(PartialEq)]
enum UvInput {
    None,
    /// Face-varying channel 0 of the cage (faceVarying primvars, and uniform ones as one value
    /// per face): one UV per channel value.
    FaceVarying(Vec<[f32; 2]>),
    /// One UV per cage point (vertex and varying primvars), refined like the points.
    Vertex(Vec<[f32; 2]>),
    /// One UV for the whole mesh.
    Constant(Vec2),
}

/// A subdivision mesh read during the walk, waiting for its level.
pub(super) struct QueuedSubdivision {
    /// Index of its placeholder in `Scene::meshes`.
    slot: usize,
    path: String,
    topology: Topology,
    /// Cage points in the space the surface is refined in: local, or world under a projective
    /// transform.
    points: Vec<[f32; 3]>,
    /// Transform from that space to world.
    world_from_points: DMat4,
    /// The refined space is mirrored relative to the cage's orientation (a projective transform
    /// with negative determinant): flip the triangles and normals.
    mirrored: bool,
    uv: UvInput,
    /// The instance the mesh is inside, when its points are in local space (not projective):
    /// instances diced to the same level share a prototype.
    instance: Option<super::InstanceFrame>,
    /// The polygon cage: per-face materials, and the fallback if refinement fails.
    cage: PolygonCage,
    world_from_local: DMat4,
    /// Other instances of the same cage, diced with this one.
    followers: Vec<Follower>,
}

/// Another instance of a queued instanced cage: where it is and what it is bound to.
struct Follower {
    slot: usize,
    path: String,
    frame: super::InstanceFrame,
    world_from_local: DMat4,
    face_materials: Vec<u32>,
    double_sided: bool,
}

impl QueuedSubdivision {
    /// The same surface in local space (materials and placement aside).
    fn same_cage(&self, topology: &Topology, uv: &UvInput, cage: &PolygonCage) -> bool {
        let (a, b) = (&self.cage, cage);
        self.topology == *topology
            && self.uv == *uv
            && a.points == b.points
            && a.counts == b.counts
            && a.corners_to_points == b.corners_to_points
            && a.holes == b.holes
            && a.left_handed == b.left_handed
            && a.uvs == b.uvs
            && a.primvars == b.primvars
    }

    /// Local-to-world of the queued instance and of each follower.
    fn placements(&self) -> impl Iterator<Item = DMat4> + '_ {
        std::iter::once(self.world_from_points).chain(self.followers.iter().map(|f| f.world_from_local))
    }
}

/// Buckets instanced cages: their points and face sizes.
fn cage_hash(cage: &PolygonCage) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    cage.points.iter().for_each(|p| p.to_array().map(f64::to_bits).hash(&mut h));
    cage.counts.hash(&mut h);
    cage.corners_to_points.hash(&mut h);
    h.finish()
}

/// A diced subdivision mesh: its plan, and its tessellation in local space unless only planned.
struct Diced {
    /// The tessellation and the cage face of each triangle (for the followers' materials);
    /// `None` when only planned ([`SubdivOptions::tessellate`] off).
    tessellated: Option<(LocalMesh, Vec<u32>)>,
    level: u32,
    /// Segments per cage edge (adaptive tessellation; empty for uniform).
    edge_rates: Vec<u32>,
    /// Planned triangles per cage face.
    face_triangles: Vec<u64>,
    triangles_at_max_level: u64,
    note: Option<String>,
}

impl Diced {
    /// The subdivision record of one placement, whose cage faces are bound to `face_materials`.
    fn record(
        &self,
        mesh: usize,
        q: &QueuedSubdivision,
        world_from_local: DMat4,
        face_materials: &[u32],
    ) -> Subdivision {
        let mut materials: Vec<u32> =
            self.face_triangles.iter().zip(face_materials).filter(|(&n, _)| n > 0).map(|(_, &m)| m).collect();
        materials.sort_unstable();
        materials.dedup();
        Subdivision {
            mesh,
            topology: q.topology.clone(),
            points: q.points.clone(),
            world_from_local,
            level: self.level,
            edge_rates: self.edge_rates.clone(),
            triangles_at_max_level: self.triangles_at_max_level,
            triangles: self.face_triangles.iter().sum(),
            materials,
        }
    }
}

/// USD stores indices as `int`; anything beyond is out of range for OpenSubdiv as well.
fn to_i32(v: i64) -> i32 {
    v.clamp(-1, i32::MAX.into()) as i32
}

impl Reader<'_> {
    fn floats(&self, prim: &str, attr: &str) -> Result<Vec<f32>, UsdError> {
        Ok(match self.stage.attr(prim, attr)? {
            Some(super::stage::Value::Array { data, arity: 1 }) => {
                data.into_iter().map(|x| x as f32).collect()
            }
            Some(super::stage::Value::Scalar(x)) => vec![x as f32],
            _ => Vec::new(),
        })
    }

    fn i32s(&self, prim: &str, attr: &str) -> Result<Vec<i32>, UsdError> {
        Ok(self.ints(prim, attr)?.unwrap_or_default().into_iter().map(to_i32).collect())
    }

    /// A rule token, or its USD fallback with a warning when it is not one of the attribute's
    /// values.
    fn rule<T: FromStr + Default>(&mut self, path: &str, attr: &str) -> Result<T, UsdError> {
        let Some(token) = self.token(path, attr)? else { return Ok(T::default()) };
        match token.parse() {
            Ok(value) => Ok(value),
            Err(_) => {
                self.warn(path, format!("{attr} {token:?} is not a known value; using the USD fallback"));
                Ok(T::default())
            }
        }
    }

    /// Validates a subdivision mesh's cage and queues it for dicing. Returns the polygon cage
    /// back, after one warning, when OpenSubdiv cannot take it.
    pub(super) fn queue_subdivision(
        &mut self,
        path: &str,
        scheme: &str,
        counts: &[i64],
        indices: &[i64],
        cage: PolygonCage,
        state: &Inherited,
    ) -> Result<Option<PolygonCage>, UsdError> {
        match self.subdivision_cage(path, scheme, counts, indices, &cage)? {
            Ok((topology, uv)) => {
                for p in
                    cage.primvars.iter().filter(|p| p.primvar.interpolation == Interpolation::FaceVarying)
                {
                    let name = &p.name;
                    self.warn(
                        path,
                        format!("faceVarying primvar {name} on a subdivision surface is read as its average per cage face"),
                    );
                }
                let slot = self.scene.meshes.len();
                self.scene.meshes.push(Mesh {
                    path: path.to_string(),
                    double_sided: cage.double_sided,
                    ..Mesh::default()
                });
                // Subdivision commutes with affine maps, so the surface is refined in local space
                // and transformed. A projective transform (points divided through, as for
                // polygon meshes) does not commute: the cage is projected first and refined in
                // world space, which keeps the surface inside the projected cage.
                let m = state.world_from_local;
                let projective = m.row(3) != glam::DVec4::W;
                if let Some(frame) = state.instance.filter(|_| !projective) {
                    let hash = cage_hash(&cage);
                    let group = self.subdivision_groups.entry(hash).or_default();
                    let leader = group
                        .iter()
                        .copied()
                        .find(|&i| self.subdivisions[i].same_cage(&topology, &uv, &cage));
                    match leader {
                        Some(i) => {
                            self.subdivisions[i].followers.push(Follower {
                                slot,
                                path: path.to_string(),
                                frame,
                                world_from_local: m,
                                face_materials: cage.face_materials,
                                double_sided: cage.double_sided,
                            });
                            return Ok(None);
                        }
                        None => group.push(self.subdivisions.len()),
                    }
                }
                let (points, world_from_points) = if projective {
                    (
                        cage.points.iter().map(|&p| m.project_point3(p).as_vec3().to_array()).collect(),
                        DMat4::IDENTITY,
                    )
                } else {
                    (cage.points.iter().map(|p| p.as_vec3().to_array()).collect(), m)
                };
                self.subdivisions.push(QueuedSubdivision {
                    slot,
                    path: path.to_string(),
                    topology,
                    points,
                    world_from_points,
                    mirrored: projective && m.determinant() < 0.0,
                    uv,
                    instance: if projective { None } else { state.instance },
                    cage,
                    world_from_local: m,
                    followers: Vec::new(),
                });
                Ok(None)
            }
            Err(problem) => {
                self.warn(
                    path,
                    format!("cannot subdivide: {problem}; rendering the triangulated cage instead"),
                );
                Ok(Some(cage))
            }
        }
    }

    /// The OpenSubdiv cage of a mesh, or what is wrong with it.
    #[allow(clippy::type_complexity)]
    fn subdivision_cage(
        &mut self,
        path: &str,
        scheme: &str,
        counts: &[i64],
        indices: &[i64],
        cage: &PolygonCage,
    ) -> Result<Result<(Topology, UvInput), String>, UsdError> {
        let Ok(scheme) = Scheme::from_str(scheme) else {
            return Ok(Err(format!("subdivisionScheme {scheme:?} is not a known scheme")));
        };
        if let Some(at) = cage.corners_to_points.iter().position(|&p| p == INVALID_POINT) {
            let (index, bound) = (indices[at], cage.points.len());
            return Ok(Err(format!("faceVertexIndices[{at}] = {index} is outside 0..{bound}")));
        }
        let options = Options {
            scheme,
            boundary: self.rule::<BoundaryInterpolation>(path, "interpolateBoundary")?,
            face_varying: self.rule::<FaceVaryingInterpolation>(path, "faceVaryingLinearInterpolation")?,
            triangle_subdivision: self.rule::<TriangleSubdivision>(path, "triangleSubdivisionRule")?,
        };

        // Left-handed faces are reversed (first corner kept), with their face-varying indices, so
        // that OpenSubdiv's du × dv and the triangles come out counter-clockwise.
        let mut order = Vec::with_capacity(indices.len());
        let mut face_of_corner = Vec::with_capacity(indices.len());
        let mut start = 0;
        for (face, &n) in cage.counts.iter().enumerate() {
            if cage.left_handed && n > 0 {
                order.push(start);
                order.extend((start + 1..start + n).rev());
            } else {
                order.extend(start..start + n);
            }
            face_of_corner.extend(std::iter::repeat_n(face, n));
            start += n;
        }
        let face_vertex_counts: Vec<i32> = counts.iter().map(|&c| to_i32(c)).collect();
        let face_vertex_indices: Vec<i32> =
            order.iter().map(|&c| to_i32(cage.corners_to_points[c] as i64)).collect();

        let (uv, fvar_indices) = match &cage.uvs {
            None => (UvInput::None, Vec::new()),
            Some(p) => {
                let value = |element: usize| p.indices.as_ref().map_or(element, |ix| ix[element]);
                let f32x2 = |v: glam::DVec2| v.as_vec2().to_array();
                match p.interpolation {
                    Interpolation::Constant => (UvInput::Constant(p.values[value(0)].as_vec2()), Vec::new()),
                    Interpolation::Vertex => (
                        UvInput::Vertex(
                            (0..cage.points.len()).map(|pt| f32x2(p.values[value(pt)])).collect(),
                        ),
                        Vec::new(),
                    ),
                    Interpolation::FaceVarying | Interpolation::Uniform => {
                        let element = |c: usize| {
                            if p.interpolation == Interpolation::Uniform {
                                face_of_corner[c]
                            } else {
                                c
                            }
                        };
                        let channel = order.iter().map(|&c| to_i32(value(element(c)) as i64)).collect();
                        (UvInput::FaceVarying(p.values.iter().map(|&v| f32x2(v)).collect()), channel)
                    }
                }
            }
        };
        let channels = match &uv {
            UvInput::FaceVarying(values) => {
                vec![FaceVaryingChannel { indices: &fvar_indices, value_count: values.len() }]
            }
            _ => Vec::new(),
        };

        let crease_indices = self.i32s(path, "creaseIndices")?;
        let crease_lengths = self.i32s(path, "creaseLengths")?;
        let crease_sharpnesses = self.floats(path, "creaseSharpnesses")?;
        let corner_indices = self.i32s(path, "cornerIndices")?;
        let corner_sharpnesses = self.floats(path, "cornerSharpnesses")?;
        let hole_indices = self.i32s(path, "holeIndices")?;
        let topology = Topology::new(&Cage {
            face_vertex_counts: &face_vertex_counts,
            face_vertex_indices: &face_vertex_indices,
            vertex_count: cage.points.len(),
            options,
            crease_indices: &crease_indices,
            crease_lengths: &crease_lengths,
            crease_sharpnesses: &crease_sharpnesses,
            corner_indices: &corner_indices,
            corner_sharpnesses: &corner_sharpnesses,
            hole_indices: &hole_indices,
            face_varying: &channels,
        });
        Ok(topology.map(|t| (t, uv)).map_err(|e| e.to_string()))
    }

    /// Dices, refines and tessellates every queued subdivision mesh (in parallel) into its slot.
    pub(super) fn tessellate_subdivisions(&mut self, options: &SubdivOptions) {
        let queued = std::mem::take(&mut self.subdivisions);
        if queued.is_empty() {
            return;
        }
        let camera = match self.scene.default_camera {
            Some(i) => DicingCamera::new(&self.scene.cameras[i], self.scene.resolution),
            None => {
                // `render` frames the whole scene; the cages bound their limit surfaces.
                let cages = queued.iter().flat_map(|q| {
                    q.placements().flat_map(|m| {
                        q.points
                            .iter()
                            .map(move |p| m.transform_point3(glam::Vec3::from_array(*p).as_dvec3()))
                    })
                });
                let meshes = self.scene.meshes.iter().flat_map(|m| m.world_bounds()).map(|p| p.as_dvec3());
                let (lo, hi) = cages
                    .chain(meshes)
                    .filter(|p| p.is_finite())
                    .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
                DicingCamera::framing(lo, hi, self.scene.up_axis == crate::scene::UpAxis::Z)
            }
        };
        let camera = Some(camera);
        // One task per topology builds its shape and dices the cages that share it (in
        // parallel too), so a large mesh's refiner is not waited for by the other meshes.
        let per_shape: Vec<Vec<(usize, subdiv::Result<Diced>)>> = shared_topologies(&queued)
            .par_iter()
            .map(|members| {
                let shape = Shape::new(&queued[members[0]].topology, options);
                members
                    .par_iter()
                    .map(|&i| {
                        let shape = shape.as_ref().map_err(Clone::clone);
                        (i, shape.and_then(|shape| dice(&queued[i], options, camera.as_ref(), shape)))
                    })
                    .collect()
            })
            .collect();
        let mut diced: Vec<Option<subdiv::Result<Diced>>> = (0..queued.len()).map(|_| None).collect();
        for (i, result) in per_shape.into_iter().flatten() {
            diced[i] = Some(result);
        }
        let diced = diced.into_iter().map(|d| d.expect("every queued cage belongs to one shape"));
        for (mut q, result) in queued.into_iter().zip(diced) {
            let followers = std::mem::take(&mut q.followers);
            match result {
                Ok(mut d) => {
                    if let Some(note) = d.note.take() {
                        self.warn(&q.path, note);
                    }
                    for f in &followers {
                        let record = d.record(f.slot, &q, f.world_from_local, &f.face_materials);
                        self.scene.subdivisions.push(record);
                    }
                    let record = d.record(q.slot, &q, q.world_from_points, &q.cage.face_materials);
                    self.scene.subdivisions.push(record);
                    // A listing keeps the placeholders pushed during the walk.
                    let Some((local, coarse_face)) = d.tessellated else { continue };
                    self.scene.meshes[q.slot] = match q.instance {
                        // One geometry for the queued instance and its followers; each keeps its
                        // own materials (per cage face, through the face each triangle comes from).
                        Some(frame) => {
                            let (geometry, materials, double_sided) = local.split();
                            let geometry = self.geometry.intern(geometry);
                            for f in followers {
                                let materials =
                                    coarse_face.iter().map(|&c| f.face_materials[c as usize]).collect();
                                self.scene.meshes[f.slot] = placed_with(
                                    &f.path,
                                    Arc::clone(&geometry),
                                    materials,
                                    f.double_sided,
                                    f.frame,
                                    f.world_from_local,
                                );
                            }
                            placed_with(
                                &q.path,
                                geometry,
                                materials,
                                double_sided,
                                frame,
                                q.world_from_points,
                            )
                        }
                        None => world_mesh(&q.path, local, q.world_from_points),
                    };
                }
                Err(e) => {
                    let message = format!("cannot subdivide: {e}; rendering the triangulated cage instead");
                    for mut f in followers {
                        self.warn(&f.path, message.clone());
                        std::mem::swap(&mut q.cage.face_materials, &mut f.face_materials);
                        let (mut local, _) = q.cage.triangulate();
                        std::mem::swap(&mut q.cage.face_materials, &mut f.face_materials);
                        local.double_sided = f.double_sided;
                        self.scene.meshes[f.slot] =
                            self.placed_mesh(&f.path, local, f.frame, f.world_from_local);
                    }
                    self.warn(&q.path, message);
                    let (local, _) = q.cage.triangulate();
                    self.scene.meshes[q.slot] = match q.instance {
                        Some(frame) => self.placed_mesh(&q.path, local, frame, q.world_from_local),
                        None => world_mesh(&q.path, local, q.world_from_local),
                    };
                }
            }
        }
    }
}

/// World-space bounds of `points`.
fn bounds(points: &[[f32; 3]]) -> (DVec3, DVec3) {
    points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        let p = glam::Vec3::from_array(*p).as_dvec3();
        (lo.min(p), hi.max(p))
    })
}

/// The primvars the materials read, on the tessellated limit surface: vertex (and varying) primvars
/// refined like the points, uniform ones per triangle from its cage face, and face-varying ones as
/// their average over the cage face (OpenSubdiv would need a channel per primvar for better).
///
/// `vertex` refines one value per cage point onto the tessellation's vertices (uniform: the
/// refiner's limit primvar; adaptive: the per-face limit evaluation).
fn refined_primvars(
    q: &QueuedSubdivision,
    tess: &Tessellation,
    vertex: &RefineVertexValues,
) -> subdiv::Result<Vec<MeshPrimvar>> {
    let mut first_corner = Vec::with_capacity(q.cage.counts.len() + 1);
    first_corner.push(0);
    for &n in &q.cage.counts {
        first_corner.push(first_corner.last().copied().unwrap_or(0) + n);
    }
    let mut out = Vec::with_capacity(q.cage.primvars.len());
    for p in &q.cage.primvars {
        let pv = &p.primvar;
        let (layout, values) = match pv.interpolation {
            Interpolation::Constant => (PrimvarLayout::Constant, vec![pv.get(0, 0, 0)]),
            Interpolation::Uniform => (
                PrimvarLayout::PerTriangle,
                tess.coarse_face.iter().map(|&f| pv.get(f as usize, 0, 0)).collect(),
            ),
            Interpolation::FaceVarying => {
                let average = |f: usize| {
                    let corners = first_corner[f]..first_corner[f + 1];
                    let n = corners.len().max(1) as f32;
                    corners.fold([0.0f32; 4], |sum, c| {
                        let v = pv.get(f, c, q.cage.corners_to_points[c]);
                        std::array::from_fn(|k| sum[k] + v[k] / n)
                    })
                };
                (PrimvarLayout::PerTriangle, tess.coarse_face.iter().map(|&f| average(f as usize)).collect())
            }
            Interpolation::Vertex => {
                let cage: Vec<[f32; 4]> = (0..q.cage.points.len()).map(|pt| pv.get(0, 0, pt)).collect();
                (PrimvarLayout::PerVertex, vertex(&cage)?)
            }
        };
        out.push(MeshPrimvar { name: p.name.clone(), layout, components: p.components, values });
    }
    Ok(out)
}

/// Chooses the level (uniform) or edge rates (adaptive) of one queued mesh, plans its triangles
/// and, with [`SubdivOptions::tessellate`], tessellates it (local space).
/// What dicing reads from a cage's topology alone, built once for every queued cage with that
/// topology: the unrefined refiner with its edges (adaptive), or the faces without a surface
/// (uniform).
enum Shape {
    Adaptive(AdaptiveRefiner),
    Uniform { holes: Vec<bool> },
}

impl Shape {
    fn new(topology: &Topology, options: &SubdivOptions) -> subdiv::Result<Self> {
        Ok(if options.adaptive() {
            Shape::Adaptive(AdaptiveRefiner::new(topology)?)
        } else {
            Shape::Uniform { holes: UniformPlan::holes(topology)? }
        })
    }
}

/// Groups the queued cages by topology (indices into `queued`, in queue order, groups in the
/// order of their first cage). An asset referenced many times without instancing (the teapot
/// scene's 35 teapots) then builds one `Far::TopologyRefiner`, not 35: building it was most of a
/// listing's subdivision time.
fn shared_topologies(queued: &[QueuedSubdivision]) -> Vec<Vec<usize>> {
    let mut by_key: std::collections::HashMap<u64, Vec<usize>> = std::collections::HashMap::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, q) in queued.iter().enumerate() {
        let candidates = by_key.entry(q.topology.sharing_key()).or_default();
        match candidates.iter().find(|&&g| queued[groups[g][0]].topology == q.topology) {
            Some(&g) => groups[g].push(i),
            None => {
                candidates.push(groups.len());
                groups.push(vec![i]);
            }
        }
    }
    groups
}

fn dice(
    q: &QueuedSubdivision,
    options: &SubdivOptions,
    camera: Option<&DicingCamera>,
    shape: &Shape,
) -> subdiv::Result<Diced> {
    // The cage as each instance places it.
    let worlds: Vec<Vec<DVec3>> = q
        .placements()
        .map(|m| q.points.iter().map(|p| m.transform_point3(glam::Vec3::from_array(*p).as_dvec3())).collect())
        .collect();
    let (level, edge_rates, face_triangles, note, tessellated) = match shape {
        Shape::Adaptive(refiner) => {
            let rates = adaptive_rates(options, camera, &worlds, refiner);
            let face_triangles = refiner.planned_face_triangles(&rates)?;
            let tessellated =
                options.tessellate.then(|| tessellate_adaptive(q, refiner, &rates)).transpose()?;
            let level = subdiv::level_for_rate(rates.iter().copied().max().unwrap_or(1));
            (level, rates, face_triangles, None, tessellated)
        }
        Shape::Uniform { holes } => dice_uniform(q, options, camera, &worlds, holes)?,
    };

    // Faces that reach the surface (not holes, not dropped by interpolateBoundary = none), for
    // the triangle count at the level cap.
    let all_quads = q.cage.counts.iter().all(|&n| n == 4);
    let drawn_sizes = q.cage.counts.iter().zip(&face_triangles).filter(|(_, &t)| t > 0).map(|(&n, _)| n);
    let triangles_at_max_level =
        triangles_at_level(q.topology.options().scheme, drawn_sizes, all_quads, options.max_level);

    let tessellated = tessellated.map(|(tess, uvs, primvars)| {
        debug_assert_eq!(tess.triangles.len() as u64, face_triangles.iter().sum::<u64>(), "{}", q.path);
        let f64x3 = |p: &[f32; 3]| glam::Vec3::from_array(*p).as_dvec3();
        let mut local = LocalMesh {
            positions: tess.positions.iter().map(f64x3).collect(),
            normals: tess.normals.iter().map(f64x3).collect(),
            uvs,
            triangle_materials: tess.coarse_face.iter().map(|&f| q.cage.face_materials[f as usize]).collect(),
            triangles: tess.triangles,
            double_sided: q.cage.double_sided,
            primvars,
        };
        if q.mirrored {
            local.triangles.iter_mut().for_each(|t| t.swap(1, 2));
            local.normals.iter_mut().for_each(|n| *n = -*n);
        }
        (local, tess.coarse_face)
    });
    Ok(Diced { tessellated, level, edge_rates, face_triangles, triangles_at_max_level, note })
}

/// Refines one `vec4` per cage point onto a tessellation's vertices.
type RefineVertexValues<'a> = dyn Fn(&[[f32; 4]]) -> subdiv::Result<Vec<[f32; 4]>> + 'a;

/// A tessellation with its UVs and primvars.
type Tessellated = (Tessellation, Vec<Vec2>, Vec<MeshPrimvar>);

/// A mesh's level, edge rates (none), planned triangles per cage face, note for the log and
/// tessellation (unless only planned).
type Planned = (u32, Vec<u32>, Vec<u64>, Option<String>, Option<Tessellated>);

/// One uniform level for the whole mesh, the finest any placement (`worlds`) needs, planned
/// over the cage's `holes` and tessellated with [`SubdivOptions::tessellate`].
fn dice_uniform(
    q: &QueuedSubdivision,
    options: &SubdivOptions,
    camera: Option<&DicingCamera>,
    worlds: &[Vec<DVec3>],
    holes: &[bool],
) -> subdiv::Result<Planned> {
    let mut level = 0;
    for world in worlds {
        level = level.max(uniform_level(q, options, camera, world)?);
    }
    let (plan, note) = match UniformPlan::with_holes(&q.topology, level, holes) {
        Err(subdiv::Error::LevelTooHigh { level, max }) => (
            UniformPlan::with_holes(&q.topology, max, holes)?,
            Some(format!("level {level} is too fine for this cage's size; refined to level {max}")),
        ),
        other => (other?, None),
    };
    let tessellated = options.tessellate.then(|| refine_uniform(q, plan.level)).transpose()?;
    Ok((plan.level, Vec::new(), plan.face_triangles, note, tessellated))
}

/// The uniform level one placement of the cage (`world`) needs (`--subdiv-level`,
/// `--subdiv-mode uniform`); the mesh is refined to the finest any placement needs.
fn uniform_level(
    q: &QueuedSubdivision,
    options: &SubdivOptions,
    camera: Option<&DicingCamera>,
    world: &[DVec3],
) -> subdiv::Result<u32> {
    let world_f32: Vec<[f32; 3]> = world.iter().map(|p| p.as_vec3().to_array()).collect();
    let (lo, hi) = bounds(&world_f32);
    let longest = q.topology.longest_edge(&world_f32)?;
    let all_quads = q.cage.counts.iter().all(|&n| n == 4);
    let scheme = q.topology.options().scheme;
    let surface_faces = || {
        q.cage
            .counts
            .iter()
            .enumerate()
            .filter(|(f, _)| !q.cage.holes.contains(&(*f as i64)))
            .map(|(_, &n)| n)
    };
    Ok(choose_level(options, camera, longest.into(), lo, hi, |l| {
        triangles_at_level(scheme, surface_faces(), all_quads, l)
    }))
}

/// Tessellates the cage at uniform `level` (as planned: at most [`Refiner::highest_level`]).
fn refine_uniform(q: &QueuedSubdivision, level: u32) -> subdiv::Result<Tessellated> {
    let refiner = Refiner::new(&q.topology, level)?;
    let uv_source = match &q.uv {
        UvInput::FaceVarying(values) => Some(UvSource { channel: 0, values }),
        _ => None,
    };
    let tess = tessellate(&refiner, &q.points, uv_source)?;
    let uvs: Vec<Vec2> = match &q.uv {
        UvInput::None => Vec::new(),
        UvInput::FaceVarying(_) => tess.uvs.iter().flatten().map(|&uv| Vec2::from_array(uv)).collect(),
        UvInput::Vertex(values) => {
            let flat: Vec<f32> = values.iter().flatten().copied().collect();
            let refined = refiner.vertex_primvar(&flat, 2, Evaluation::Limit)?;
            tess.gather::<2>(&refined)?.into_iter().map(Vec2::from_array).collect()
        }
        UvInput::Constant(uv) => vec![*uv; tess.positions.len()],
    };
    let primvars = refined_primvars(q, &tess, &|cage| {
        let flat: Vec<f32> = cage.iter().flatten().copied().collect();
        let refined = refiner.vertex_primvar(&flat, 4, Evaluation::Limit)?;
        tess.gather::<4>(&refined)
    })?;
    Ok((tess, uvs, primvars))
}

/// Segments per cage edge from the camera: per edge, the finest rate any placement (`worlds`,
/// the cage as each instance places it) needs.
fn adaptive_rates(
    options: &SubdivOptions,
    camera: Option<&DicingCamera>,
    worlds: &[Vec<DVec3>],
    refiner: &AdaptiveRefiner,
) -> Vec<u32> {
    let mut rates: Vec<u32> = Vec::new();
    for world in worlds {
        let need = choose_edge_rates(options, camera, world, refiner);
        if rates.is_empty() {
            rates = need;
        } else {
            rates.iter_mut().zip(need).for_each(|(r, n)| *r = (*r).max(n));
        }
    }
    rates
}

/// Each face tessellated on its limit surface at `rates`.
fn tessellate_adaptive(
    q: &QueuedSubdivision,
    refiner: &AdaptiveRefiner,
    rates: &[u32],
) -> subdiv::Result<Tessellated> {
    let uv = match &q.uv {
        UvInput::FaceVarying(values) => Some(AdaptiveUv::FaceVarying(UvSource { channel: 0, values })),
        UvInput::Vertex(values) => Some(AdaptiveUv::Vertex(values)),
        UvInput::None | UvInput::Constant(_) => None,
    };
    let tess = refiner.tessellate(&q.points, uv, rates, false)?.mesh;
    let uvs: Vec<Vec2> = match &q.uv {
        UvInput::None => Vec::new(),
        UvInput::Constant(uv) => vec![*uv; tess.positions.len()],
        UvInput::FaceVarying(_) | UvInput::Vertex(_) => {
            tess.uvs.iter().flatten().map(|&uv| Vec2::from_array(uv)).collect()
        }
    };
    // The adaptive tessellator refines two components per point (as UVs); four-component primvars
    // take two extra passes with the same rates, so their vertices line up with these.
    let primvars = refined_primvars(q, &tess, &|cage| {
        let mut out = vec![[0.0f32; 4]; tess.positions.len()];
        for half in 0..2 {
            let pairs: Vec<[f32; 2]> = cage.iter().map(|v| [v[2 * half], v[2 * half + 1]]).collect();
            let pass = refiner.tessellate(&q.points, Some(AdaptiveUv::Vertex(&pairs)), rates, false)?.mesh;
            for (o, uv) in out.iter_mut().zip(pass.uvs.iter().flatten()) {
                o[2 * half] = uv[0];
                o[2 * half + 1] = uv[1];
            }
        }
        Ok(out)
    })?;
    Ok((tess, uvs, primvars))
}

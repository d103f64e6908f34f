//! Which gprims become shared prototypes and which are drawn in world space.
//!
//! The USD reader keeps every gprim inside an instance (an instanceable prim or a PointInstancer
//! entry) as a reference to interned local-space geometry plus its transforms
//! ([`crate::scene::PlacedMesh`]); hand-built scenes may give an instance-space copy instead
//! ([`crate::scene::InstancedMesh`]). Here the instances whose gprims are identical in the
//! instance's space — same points, normals, uvs, triangles, primvars, double-sidedness,
//! light set (light and shadow linking) and materials equal in value — are grouped into one prototype, so 1,000 instances of a mesh store
//! one mesh plus 1,000 transforms.
//!
//! Kept in world space ("top level"), with the reason:
//! - gprims outside instances, and curves/points (split per instance against the camera, and
//!   intersected through their own BVH);
//! - emissive gprims: light sampling draws from a world-space distribution over emissive
//!   triangles, which would otherwise need per-instance entries and transforms;
//! - prototypes used by a single instance: sharing saves nothing and costs a transform per ray;
//! - instances with a non-invertible or non-finite transform (e.g. a PointInstancer scale of 0).
//!
//! Moving gprims ([`crate::scene::Mesh::motion`]) go the other way: each becomes a prototype of its
//! own (its world-space geometry at the frame) with one instance carrying the motion keys, so a ray
//! meets it through the instance's transform at the ray's time and the top-level BVH bounds it
//! over the whole shutter. Exceptions stay in world space at the frame, unmoved: emissive gprims
//! (light sampling is world-space) and gprims whose keys are not finite and invertible.
//!
//! The decision depends only on the scene, never on hash-map iteration order, so packing stays
//! deterministic.
//!
//! Subdivision surfaces inside instances are diced once per distinct cage, at the finest rate any
//! instance needs (ingest's subdivision reader), so their instances share a prototype too.

use crate::scene::{Mesh, Scene};
use glam::DMat4;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};

/// The split of a scene's meshes into world-space meshes and instanced prototypes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Instancing {
    /// Indices into `Scene::meshes` drawn in world space, in scene order.
    pub top_level: Vec<usize>,
    /// Shared mesh sets.
    pub prototypes: Vec<Prototype>,
    /// Placements of the prototypes.
    pub instances: Vec<Instance>,
}

/// A set of meshes shared by several instances.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Prototype {
    /// Indices into `Scene::meshes` of the first instance's gprims; their instance-space copies
    /// ([`Mesh::in_instance`]) are the prototype geometry.
    pub meshes: Vec<usize>,
}

/// One placement of a prototype.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Instancing::prototypes`].
    pub prototype: u32,
    /// Instance prim path (or `<instancer>[i]`).
    pub path: String,
    /// Prototype-to-world transform (for a moving instance: its placement at the frame, time 0).
    pub world_from_prototype: DMat4,
    /// Transform motion keys (`world_from_prototype` at each key time), empty for an instance that
    /// stands still.
    pub motion: Vec<crate::scene::MotionKey>,
}

impl Instancing {
    /// Every mesh in world space (the `--flatten-instances` behaviour).
    pub fn flattened(scene: &Scene) -> Self {
        Instancing { top_level: (0..scene.meshes.len()).collect(), ..Instancing::default() }
    }

    /// Triangles the blob stores for meshes (top level plus one copy of each prototype).
    pub fn stored_triangles(&self, scene: &Scene) -> usize {
        let top: usize = self.top_level.iter().map(|&m| scene.meshes[m].triangle_count()).sum();
        let shared: usize =
            self.prototypes.iter().flat_map(|p| &p.meshes).map(|&m| scene.meshes[m].triangle_count()).sum();
        top + shared
    }
}

/// Groups the scene's instances into prototypes (see the module docs for what stays in world space).
/// `emissive[material]` says whether a material emits; `canonical[material]` names one material per
/// class of materials equal in value (the blob stores each class once).
pub fn plan(scene: &Scene, emissive: &[bool], canonical: &[u32]) -> Instancing {
    let usable: Vec<bool> = scene.instances.iter().map(|i| invertible(&i.world_from_instance)).collect();
    // Instanced meshes per scene instance, in scene order.
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); scene.instances.len()];
    let mut top_level = Vec::new();
    let mut moving = Vec::new();
    for (index, mesh) in scene.meshes.iter().enumerate() {
        if let Some(motion) = &mesh.motion {
            let drawable = mesh.triangle_count() > 0
                && !mesh.triangle_materials.iter().any(|&m| emissive[m as usize])
                && motion.keys.len() >= 2
                && motion.keys.iter().all(|k| k.time.is_finite() && invertible(&k.world_from_stored))
                && motion.keys.windows(2).all(|w| w[0].time < w[1].time);
            if drawable {
                moving.push(index);
                continue;
            }
        }
        let shareable = mesh.instance_index().is_some_and(|i| {
            usable[i as usize]
                && mesh.triangle_count() > 0
                && !mesh.triangle_materials.iter().any(|&m| emissive[m as usize])
        });
        match mesh.instance_index() {
            Some(i) if shareable => members[i as usize].push(index),
            _ => top_level.push(index),
        }
    }
    let shapes = Shapes::of(scene, &members);
    // Prototype candidates by key hash; equal hashes are confirmed by comparing keys.
    // The light set is part of the key: a prototype's meshes carry one light set for all its
    // instances, so instances linked differently get prototypes of their own.
    let key = |meshes: &[usize]| -> Vec<(u32, bool, u32)> {
        meshes
            .iter()
            .map(|&m| (shapes.id[&m], scene.meshes[m].double_sided, scene.meshes[m].light_set))
            .collect()
    };
    let same_materials = |a: &[usize], b: &[usize]| {
        a.iter().zip(b).all(|(&x, &y)| {
            let (x, y) = (&scene.meshes[x].triangle_materials, &scene.meshes[y].triangle_materials);
            x.len() == y.len()
                && x.iter().zip(y).all(|(&p, &q)| canonical[p as usize] == canonical[q as usize])
        })
    };
    let mut by_hash: HashMap<u64, Vec<usize>> = HashMap::new();
    let mut groups: Vec<(Vec<usize>, Vec<u32>)> = Vec::new(); // (representative meshes, scene instances)
    for (instance, meshes) in members.iter().enumerate() {
        if meshes.is_empty() {
            continue;
        }
        let mut h = std::collections::hash_map::DefaultHasher::new();
        key(meshes).hash(&mut h);
        for &m in meshes {
            scene.meshes[m].triangle_materials.iter().for_each(|&t| canonical[t as usize].hash(&mut h));
        }
        let candidates = by_hash.entry(h.finish()).or_default();
        let found = candidates.iter().copied().find(|&g| {
            let first = &groups[g].0;
            key(first) == key(meshes) && same_materials(first, meshes)
        });
        match found {
            Some(g) => groups[g].1.push(instance as u32),
            None => {
                candidates.push(groups.len());
                groups.push((meshes.clone(), vec![instance as u32]));
            }
        }
    }
    let mut out = Instancing::default();
    for (meshes, instances) in groups {
        if instances.len() < 2 {
            top_level.extend(instances.iter().flat_map(|&i| members[i as usize].iter().copied()));
            continue;
        }
        let prototype = out.prototypes.len() as u32;
        out.prototypes.push(Prototype { meshes });
        for i in instances {
            let source = &scene.instances[i as usize];
            out.instances.push(Instance {
                prototype,
                path: source.path.clone(),
                world_from_prototype: source.world_from_instance,
                motion: Vec::new(),
            });
        }
    }
    for m in moving {
        let mesh = &scene.meshes[m];
        let Some(motion) = &mesh.motion else { continue };
        let prototype = out.prototypes.len() as u32;
        out.prototypes.push(Prototype { meshes: vec![m] });
        out.instances.push(Instance {
            prototype,
            path: mesh.path.clone(),
            world_from_prototype: motion.at(0.0),
            motion: motion.keys.clone(),
        });
    }
    top_level.sort_unstable();
    out.top_level = top_level;
    out
}

/// A transform an instance can use: finite, and invertible in `f32` as the renderer stores it.
fn invertible(m: &DMat4) -> bool {
    let f = m.as_mat4();
    m.is_finite() && f.is_finite() && f.determinant().abs() > 1e-12 && f.inverse().is_finite()
}

/// Per instanced mesh, an id of its instance-space geometry (materials aside): equal ids, equal
/// geometry. Placed meshes are compared by their shared geometry and local-to-instance transform,
/// without making their instance-space copies; explicit copies by content.
struct Shapes {
    id: HashMap<usize, u32>,
}

impl Shapes {
    fn of(scene: &Scene, members: &[Vec<usize>]) -> Self {
        let mut id = HashMap::new();
        let mut placed: HashMap<(usize, [u64; 16]), u32> = HashMap::new();
        let mut copies: HashMap<u64, Vec<(usize, u32)>> = HashMap::new();
        let mut next = 0u32;
        for &m in members.iter().flatten() {
            let mesh = &scene.meshes[m];
            let shape = match &mesh.placed {
                Some(p) => {
                    let key = (
                        std::sync::Arc::as_ptr(&p.geometry) as usize,
                        p.instance_from_local.to_cols_array().map(f64::to_bits),
                    );
                    *placed.entry(key).or_insert_with(|| {
                        next += 1;
                        next - 1
                    })
                }
                None => {
                    let candidates = copies.entry(copy_hash(mesh)).or_default();
                    match candidates.iter().find(|&&(other, _)| same_copy(&scene.meshes[other], mesh)) {
                        Some(&(_, shape)) => shape,
                        None => {
                            candidates.push((m, next));
                            next += 1;
                            next - 1
                        }
                    }
                }
            };
            id.insert(m, shape);
        }
        Shapes { id }
    }
}

/// Hash of an explicit instance-space copy ([`crate::scene::InstancedMesh`]) with the mesh's uvs.
fn copy_hash(mesh: &Mesh) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    if let Some(local) = &mesh.instance {
        local.positions.iter().for_each(|p| p.to_array().map(f32::to_bits).hash(&mut h));
        local.normals.iter().for_each(|n| n.to_array().map(f32::to_bits).hash(&mut h));
        local.triangles.hash(&mut h);
    }
    mesh.uvs.iter().for_each(|uv| uv.to_array().map(f32::to_bits).hash(&mut h));
    h.finish()
}

fn same_copy(x: &Mesh, y: &Mesh) -> bool {
    let (Some(lx), Some(ly)) = (&x.instance, &y.instance) else { return false };
    let bits = |v: &[glam::Vec3]| v.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    bits(&lx.positions) == bits(&ly.positions)
        && bits(&lx.normals) == bits(&ly.normals)
        && x.uvs
            .iter()
            .map(|u| u.to_array().map(f32::to_bits))
            .eq(y.uvs.iter().map(|u| u.to_array().map(f32::to_bits)))
        && lx.triangles == ly.triangles
        && x.primvars == y.primvars
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{InstancedMesh, Material, SceneInstance};
    use glam::{DVec3, Vec3};

    fn instanced_triangle(instance: u32, offset: f32, material: u32) -> Mesh {
        let local = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        Mesh {
            path: format!("/I{instance}/Tri"),
            positions: local.iter().map(|p| *p + Vec3::splat(offset)).collect(),
            triangles: vec![[0, 1, 2]],
            triangle_materials: vec![material],
            primvars: Vec::new(),
            instance: Some(InstancedMesh {
                instance,
                positions: local,
                triangles: vec![[0, 1, 2]],
                ..InstancedMesh::default()
            }),
            ..Mesh::default()
        }
    }

    fn scene(materials: Vec<Material>, meshes: Vec<Mesh>, instances: usize) -> Scene {
        Scene {
            materials,
            meshes,
            instances: (0..instances)
                .map(|i| SceneInstance {
                    path: format!("/I{i}"),
                    world_from_instance: DMat4::from_translation(DVec3::splat(i as f64)),
                })
                .collect(),
            ..Scene::default()
        }
    }

    #[test]
    fn identical_instances_share_one_prototype_and_singletons_stay_flat() {
        let grey = |p: &str| Material { path: p.into(), ..Material::default() };
        // Three instances with value-equal displayColor materials, one with a different colour.
        let red =
            Material { path: "/I3/Tri.displayColor".into(), diffuse_color: Vec3::X, ..Material::default() };
        let s = scene(
            vec![
                grey("/I0/Tri.displayColor"),
                grey("/I1/Tri.displayColor"),
                grey("/I2/Tri.displayColor"),
                red,
            ],
            vec![
                instanced_triangle(0, 0.0, 0),
                instanced_triangle(1, 1.0, 1),
                instanced_triangle(2, 2.0, 2),
                instanced_triangle(3, 3.0, 3),
                Mesh { path: "/Ground".into(), triangles: vec![[0, 0, 0]], ..Mesh::default() },
            ],
            4,
        );
        let plan = plan(&s, &[false; 4], &[0, 0, 0, 3]);
        assert_eq!(plan.prototypes, vec![Prototype { meshes: vec![0] }]);
        assert_eq!(plan.instances.iter().map(|i| i.path.as_str()).collect::<Vec<_>>(), ["/I0", "/I1", "/I2"]);
        assert_eq!(plan.top_level, vec![3, 4], "the red singleton and the ground stay in world space");
        assert_eq!(plan.stored_triangles(&s), 3);
    }

    #[test]
    fn emissive_and_degenerate_instances_stay_flat() {
        let lamp = Material { path: "/Lamp".into(), emissive_color: Vec3::ONE, ..Material::default() };
        let mut s = scene(
            vec![lamp, Material::default()],
            vec![instanced_triangle(0, 0.0, 0), instanced_triangle(1, 1.0, 0), instanced_triangle(2, 0.0, 1)],
            3,
        );
        s.meshes.push(instanced_triangle(3, 0.0, 1));
        s.instances
            .push(SceneInstance { path: "/I3".into(), world_from_instance: DMat4::from_scale(DVec3::ZERO) });
        s.instances[2].world_from_instance.w_axis.x = f64::NAN;
        let plan = plan(&s, &[true, false], &[0, 1]);
        assert!(plan.prototypes.is_empty());
        assert_eq!(plan.top_level, vec![0, 1, 2, 3]);
    }
}

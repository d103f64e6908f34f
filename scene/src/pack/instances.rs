//! Prototypes and instances → blob records: prototype meshes after the top-level ones, one BVH per
//! prototype in prototype space, instance records with both transforms, and the top-level BVH over
//! the instances' world bounds (see `blob::instances` for the layout).

use super::common::{affine_rows, MeshLayout};
use crate::instancing::Instancing;
use crate::scene::Scene;
use blob::child_ref;
use glam::{DVec3, Vec3};

/// Appends the prototypes and instances of `plan` to `data` (whose top-level meshes are packed).
pub(super) fn pack_instances(
    scene: &Scene,
    plan: &Instancing,
    layout: &MeshLayout,
    data: &mut blob::SceneData,
    mut cache: Option<&mut super::BvhCache>,
) {
    let mut bounds = Vec::with_capacity(plan.prototypes.len());
    for prototype in &plan.prototypes {
        let first_mesh = data.meshes.len() as u32;
        let first_triangle = data.triangles.len();
        for &m in &prototype.meshes {
            let mesh = &scene.meshes[m];
            if mesh.motion.is_some() {
                // A moving gprim's prototype is its world-space geometry at the frame.
                layout.push(data, &mesh.in_world());
                continue;
            }
            // `plan` only lists meshes inside instances.
            let Some(local) = mesh.in_instance() else { continue };
            layout.push(data, &local);
        }
        let corners: Vec<[Vec3; 3]> = data.triangles[first_triangle..]
            .iter()
            .map(|t| t.vertices.map(|v| Vec3::from_array(data.positions[v as usize])))
            .collect();
        let (lo, hi) = corners
            .iter()
            .flatten()
            .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        bounds.push((lo, hi));
        let bvh = match cache.as_deref_mut() {
            Some(cache) => cache.build(corners),
            None => crate::bvh::build(&corners),
        };
        let inst = &mut data.instancing;
        let (first_node, first_block) =
            (inst.prototype_nodes.len() as u32, inst.prototype_blocks.len() as u32);
        // The prototype's BVH was built with local indices; the blob stores absolute ones.
        inst.prototype_nodes.extend(bvh.nodes.iter().map(|node| {
            let mut node = *node;
            for r in &mut node.children {
                if *r & child_ref::LEAF == 0 {
                    *r += first_node;
                } else if *r != child_ref::EMPTY {
                    let (first, count) = child_ref::leaf_range(*r);
                    *r = child_ref::leaf(first + first_block, count)
                        .expect("more prototype BVH blocks than a leaf reference can address");
                }
            }
            node
        }));
        inst.prototype_blocks.extend(bvh.blocks.iter().map(|b| {
            let mut b = *b;
            b.triangles = b.triangles.map(|t| t + first_triangle as u32);
            b
        }));
        inst.prototypes.push(blob::Prototype {
            first_triangle: first_triangle as u32,
            triangle_count: (data.triangles.len() - first_triangle) as u32,
            first_node,
            node_count: bvh.nodes.len() as u32,
            first_block,
            block_count: bvh.blocks.len() as u32,
            first_mesh,
            mesh_count: data.meshes.len() as u32 - first_mesh,
            bounds_min: lo.to_array(),
            bounds_max: hi.to_array(),
            reserved: [0; 2],
        });
    }
    let mut world_boxes = Vec::with_capacity(plan.instances.len());
    for instance in &plan.instances {
        let world_from_object = instance.world_from_prototype;
        let object_from_world = world_from_object.inverse();
        let name = data.add_string(&instance.path);
        let motion = if instance.motion.is_empty() {
            blob::NONE
        } else {
            let inst = &mut data.instancing;
            inst.motions.push(blob::InstanceMotion {
                first_key: inst.motion_keys.len() as u32,
                key_count: instance.motion.len() as u32,
                reserved: [0; 2],
            });
            inst.motion_keys.extend(instance.motion.iter().map(|k| blob::MotionKey {
                time: k.time,
                reserved: [0; 3],
                world_from_object: affine_rows(&k.world_from_stored.as_mat4()),
            }));
            inst.motions.len() as u32 - 1
        };
        data.instancing.instances.push(blob::Instance {
            world_from_object: affine_rows(&world_from_object.as_mat4()),
            object_from_world: affine_rows(&object_from_world.as_mat4()),
            prototype: instance.prototype,
            name,
            motion,
        });
        // World bounds: the eight transformed corners of the prototype box, in f64, widened by a
        // few ulps so the f32 box contains every f32-transformed vertex. A moving instance's box is
        // the union over its keys: between keys every point moves on a straight segment (the
        // renderer interpolates matrices), which stays inside the union of its ends' boxes.
        let (lo, hi) = bounds[instance.prototype as usize];
        let (mut wlo, mut whi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let placements = std::iter::once(world_from_object)
            .chain(instance.motion.iter().map(|k| k.world_from_stored.as_mat4().as_dmat4()));
        for placement in placements {
            for corner in 0..8 {
                let pick = |axis: usize| (if corner & (1 << axis) == 0 { lo[axis] } else { hi[axis] }) as f64;
                let p = placement.transform_point3(DVec3::new(pick(0), pick(1), pick(2)));
                wlo = wlo.min(p);
                whi = whi.max(p);
            }
        }
        let pad = (whi - wlo).max_element().max(wlo.abs().max(whi.abs()).max_element()) * 1e-6;
        world_boxes.push(((wlo - pad).as_vec3(), (whi + pad).as_vec3()));
    }
    let top = crate::bvh::build_boxes(&world_boxes);
    data.instancing.bvh_nodes = top.nodes;
    data.instancing.bvh_items = top.items;
}

#[cfg(test)]
mod tests {
    use crate::scene::{InstancedMesh, Material, Mesh, Scene, SceneInstance};
    use glam::{DMat4, DVec3, Vec3};

    /// A unit quad at the origin instanced `n` times along x (instance space = local space).
    fn quads(n: usize) -> Scene {
        let local = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let triangles = vec![[0, 1, 2], [0, 2, 3]];
        let instances: Vec<SceneInstance> = (0..n)
            .map(|i| SceneInstance {
                path: format!("/Q{i}"),
                world_from_instance: DMat4::from_translation(DVec3::new(2.0 * i as f64, 0.0, 0.0)),
            })
            .collect();
        let meshes = instances
            .iter()
            .enumerate()
            .map(|(i, inst)| Mesh {
                path: format!("{}/Mesh", inst.path),
                positions: local.iter().map(|p| *p + Vec3::new(2.0 * i as f32, 0.0, 0.0)).collect(),
                triangles: triangles.clone(),
                triangle_materials: vec![0; 2],
                primvars: Vec::new(),
                instance: Some(InstancedMesh {
                    instance: i as u32,
                    positions: local.clone(),
                    triangles: triangles.clone(),
                    ..InstancedMesh::default()
                }),
                ..Mesh::default()
            })
            .collect();
        Scene {
            meshes,
            instances,
            materials: vec![Material::default()],
            meters_per_unit: 1.0,
            ..Scene::default()
        }
    }

    #[test]
    fn instances_share_one_prototype_with_its_own_bvh() {
        let data = crate::pack::pack(&quads(50)).unwrap();
        assert_eq!(data.triangles.len(), 2, "the quad is stored once");
        assert!(data.bvh_nodes.is_empty(), "no top-level triangles");
        let inst = &data.instancing;
        assert_eq!((inst.prototypes.len(), inst.instances.len()), (1, 50));
        assert_eq!(inst.instances[7].world_from_object[0][3], 14.0);
        assert_eq!(inst.instances[7].object_from_world[0][3], -14.0);
        let mut items = inst.bvh_items.clone();
        items.sort_unstable();
        assert_eq!(items, (0..50).collect::<Vec<u32>>(), "every instance is in the top-level BVH once");
        let bytes = blob::AlignedBytes::copy_from(&data.encode());
        let view = blob::SceneView::parse(&bytes).expect("valid");
        assert_eq!(view.instancing.top_level_triangles(view.triangles.len()), 0);
        let flat = crate::pack::pack_scene(
            &quads(50),
            &crate::pack::PackOptions { flatten_instances: true, ..Default::default() },
        )
        .unwrap();
        assert_eq!(flat.triangles.len(), 100);
        assert!(flat.instancing.instances.is_empty());
        assert_eq!(data.encode(), crate::pack::pack(&quads(50)).unwrap().encode(), "deterministic bytes");
    }

    /// A moving gprim is its own prototype (its frame geometry) placed by one instance with the
    /// keys; the top-level box spans every key; an emissive moving gprim stays in world space.
    #[test]
    fn a_moving_mesh_becomes_a_keyed_instance_bounded_over_its_keys() {
        use crate::scene::{MotionKey, TransformMotion};
        let key = |time: f32, x: f64| MotionKey {
            time,
            world_from_stored: DMat4::from_translation(DVec3::new(x, 0.0, 0.0)),
        };
        let moving = Mesh {
            path: "/Card".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            triangles: vec![[0, 1, 2]],
            triangle_materials: vec![0],
            motion: Some(TransformMotion { keys: vec![key(-0.5, -2.0), key(0.0, 0.0), key(0.5, 3.0)] }),
            ..Mesh::default()
        };
        let lamp = Mesh { triangle_materials: vec![1], path: "/Lamp".into(), ..moving.clone() };
        let scene = Scene {
            meshes: vec![moving, lamp],
            materials: vec![
                Material::default(),
                Material { emissive_color: Vec3::ONE, ..Material::default() },
            ],
            meters_per_unit: 1.0,
            ..Scene::default()
        };
        let data = crate::pack::pack(&scene).unwrap();
        let inst = &data.instancing;
        assert_eq!((inst.prototypes.len(), inst.instances.len(), inst.motions.len()), (1, 1, 1));
        assert_eq!(data.triangles.len(), 2, "the lamp in world space, the card as a prototype");
        assert_eq!(inst.instances[0].motion, 0);
        assert_eq!(inst.instances[0].world_from_object[0][3], 0.0, "the placement at the frame");
        let times: Vec<f32> = inst.motion_keys.iter().map(|k| k.time).collect();
        assert_eq!(times, [-0.5, 0.0, 0.5]);
        assert_eq!(inst.motion_keys[2].world_from_object[0][3], 3.0);
        // The root's box over the one instance: x from −2 (key 0) to 1 + 3 (key 2).
        let root = &inst.bvh_nodes[0];
        let (lo, hi) = (root.bounds[0][0], root.bounds[3][0]);
        assert!((lo + 2.0).abs() < 1e-4 && (hi - 4.0).abs() < 1e-4, "x bounds {lo}..{hi}");
        let bytes = blob::AlignedBytes::copy_from(&data.encode());
        blob::SceneView::parse(&bytes).expect("a valid blob");
    }
}

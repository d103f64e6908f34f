//! The second level of the acceleration structure: instances of prototypes.
//!
//! A ray first walks the top-level BVH over the instances' world bounds (the same 8-wide node
//! layout and kernels as the triangle BVH); at each instance it is moved into prototype space with
//! the instance's `object_from_world` and walks that prototype's own BVH. The direction is
//! transformed but not renormalized, so the ray parameter `t` — and with it `tmax`, the culling of
//! farther subtrees and the barycentrics — is the same in both spaces, and a hit needs no
//! conversion beyond recording the instance. Shading moves the hit triangle's vertices to world
//! space ([`crate::Accel::hit_vertices`]) and its normals by the inverse transpose
//! ([`crate::Accel::normal_to_world`]), so everything downstream sees world-space geometry.
//!
//! Instance leaves hold one instance each (a leaf visit is a transform plus a whole prototype
//! walk, so grouping instances in leaves would only add work).
//!
//! Transform motion: a moving instance (`blob::Instance::motion`) is placed, for a ray of time
//! `τ`, by [`Instances::placement`]: its keys' `world_from_object` matrices interpolated linearly
//! around `τ` (end keys held outside them) and inverted for the ray. Every query and every hit
//! rebuilt from it (the hit carries `τ`) goes through that one function, so both integrators and
//! the lane kernels see the same bits. A still instance's placement is its record's transforms.
//! An interpolated matrix that cannot be inverted (two keys mirroring each other pass through a
//! flat matrix) makes the instance invisible to that ray, never a NaN.

use crate::accel::ray::Hit;
use crate::accel::traverse::{self, BlockHits, NodeRay, WatertightRay};
use blob::{child_ref, BvhNode, Instance, TriangleBlock, BVH_WIDTH};
use glam::{Affine3A, Vec3, Vec3A};

/// Where an instance is at one time: its transforms, as the blob's [`Instance`] stores them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Placement {
    /// Row-major 3×4 affine `world_from_object`.
    pub world_from_object: [[f32; 4]; 3],
    /// Row-major 3×4 affine `object_from_world`, its inverse.
    pub object_from_world: [[f32; 4]; 3],
}

impl Placement {
    /// The record's own transforms (a still instance at any time).
    #[inline(always)]
    fn of(inst: &Instance) -> Self {
        Placement { world_from_object: inst.world_from_object, object_from_world: inst.object_from_world }
    }
}

/// The keys' row-major `world_from_object` matrices interpolated linearly at `time`, the end keys
/// held outside them (`keys` is not empty; moving instances and moving cameras).
pub(crate) fn interpolate_rows(keys: &[blob::MotionKey], time: f32) -> [[f32; 4]; 3] {
    let (first, last) = (&keys[0], &keys[keys.len() - 1]);
    if time <= first.time {
        first.world_from_object
    } else if time >= last.time {
        last.world_from_object
    } else {
        let i = keys.partition_point(|k| k.time <= time).clamp(1, keys.len() - 1);
        let (a, b) = (&keys[i - 1], &keys[i]);
        let w = (time - a.time) / (b.time - a.time);
        let (x, y) = (&a.world_from_object, &b.world_from_object);
        std::array::from_fn(|r| std::array::from_fn(|c| x[r][c] * (1.0 - w) + y[r][c] * w))
    }
}

/// The keys' matrices interpolated at `time` (the end keys held outside them), with the inverse;
/// `None` when that matrix cannot be inverted in `f32`.
fn interpolate(keys: &[blob::MotionKey], time: f32) -> Option<Placement> {
    if keys.is_empty() {
        return None;
    }
    let rows = interpolate_rows(keys, time);
    let m = Affine3A::from_cols(
        Vec3A::new(rows[0][0], rows[1][0], rows[2][0]),
        Vec3A::new(rows[0][1], rows[1][1], rows[2][1]),
        Vec3A::new(rows[0][2], rows[1][2], rows[2][2]),
        Vec3A::new(rows[0][3], rows[1][3], rows[2][3]),
    );
    if m.matrix3.determinant().abs() < 1e-12 {
        return None;
    }
    let inv = m.inverse();
    let cols = [inv.matrix3.x_axis, inv.matrix3.y_axis, inv.matrix3.z_axis, inv.translation];
    let inverse: [[f32; 4]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| cols[c][r]));
    inverse
        .iter()
        .flatten()
        .all(|v| v.is_finite())
        .then_some(Placement { world_from_object: rows, object_from_world: inverse })
}

/// The validated instancing tables of a blob, ready for queries.
#[derive(Clone, Copy, Debug, Default)]
pub struct Instances<'a> {
    instances: &'a [Instance],
    prototypes: &'a [blob::Prototype],
    top_nodes: &'a [BvhNode],
    top_items: &'a [u32],
    prototype_nodes: &'a [BvhNode],
    prototype_blocks: &'a [TriangleBlock],
    motions: &'a [blob::InstanceMotion],
    motion_keys: &'a [blob::MotionKey],
}

/// `rows · (x, y, z, w)` of a row-major 3×4 affine matrix (`w` = 1 for points, 0 for vectors).
#[inline(always)]
fn apply(rows: &[[f32; 4]; 3], v: Vec3, w: f32) -> Vec3 {
    Vec3::from_array(std::array::from_fn(|r| {
        rows[r][0] * v.x + rows[r][1] * v.y + rows[r][2] * v.z + rows[r][3] * w
    }))
}

/// A prototype-space point of an instance placed by `inst` in world space.
#[inline(always)]
pub fn point_to_world(inst: &Placement, p: Vec3) -> Vec3 {
    apply(&inst.world_from_object, p, 1.0)
}

/// A prototype-space normal of an instance placed by `inst` in world space: `object_from_worldᵀ · n`
/// (the inverse transpose of `world_from_object`), not normalized.
#[inline(always)]
pub fn normal_to_world(inst: &Placement, n: Vec3) -> Vec3 {
    let m = &inst.object_from_world;
    Vec3::new(
        m[0][0] * n.x + m[1][0] * n.y + m[2][0] * n.z,
        m[0][1] * n.x + m[1][1] * n.y + m[2][1] * n.z,
        m[0][2] * n.x + m[1][2] * n.y + m[2][2] * n.z,
    )
}

impl<'a> Instances<'a> {
    /// Wraps the validated view's instancing sections.
    pub fn new(view: &blob::SceneView<'a>) -> Self {
        let v = &view.instancing;
        Instances {
            instances: v.instances,
            prototypes: v.prototypes,
            top_nodes: v.bvh_nodes,
            top_items: v.bvh_items,
            prototype_nodes: v.prototype_nodes,
            prototype_blocks: v.prototype_blocks,
            motions: v.motions,
            motion_keys: v.motion_keys,
        }
    }

    /// Where `inst` is at ray time `time` (see the module docs); `None` when its interpolated
    /// transform cannot be inverted there.
    #[inline(always)]
    fn place(&self, inst: &Instance, time: f32) -> Option<Placement> {
        if inst.motion == blob::NONE {
            return Some(Placement::of(inst));
        }
        // Validated: the motion index and its key range are in bounds.
        let m = &self.motions[inst.motion as usize];
        let first = m.first_key as usize;
        interpolate(&self.motion_keys[first..first + m.key_count as usize], time)
    }

    /// True when the scene has no instances (the single-level fast path).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    /// Number of instances.
    pub fn len(&self) -> usize {
        self.instances.len()
    }

    /// Number of prototypes.
    pub fn prototype_count(&self) -> usize {
        self.prototypes.len()
    }

    /// Triangles before the first prototype: the top-level, world-space ones.
    pub fn top_level_triangles(&self, triangles: usize) -> usize {
        self.prototypes.first().map_or(triangles, |p| p.first_triangle as usize)
    }

    /// The triangle range of `instance`'s prototype.
    pub fn prototype_triangles(&self, instance: u32) -> std::ops::Range<u32> {
        let p = &self.prototypes[self.instances[instance as usize].prototype as usize];
        p.first_triangle..p.first_triangle + p.triangle_count
    }

    /// Triangles drawn through instances (each instance counts its prototype's triangles).
    pub fn instanced_triangles(&self) -> u64 {
        self.instances.iter().map(|i| self.prototypes[i.prototype as usize].triangle_count as u64).sum()
    }

    /// The record of `instance`.
    #[inline]
    pub fn record(&self, instance: u32) -> &'a Instance {
        &self.instances[instance as usize]
    }

    /// Where `instance` is at ray time `time` (for callers that move several points or normals of
    /// one hit: one lookup, then [`point_to_world`] and [`normal_to_world`]). A hit is only ever
    /// found where the placement exists; elsewhere this is the record's own transforms.
    #[inline]
    pub fn placement(&self, instance: u32, time: f32) -> Placement {
        let inst = self.record(instance);
        self.place(inst, time).unwrap_or_else(|| Placement::of(inst))
    }

    /// A prototype-space point of `instance` at time `time` in world space.
    #[inline]
    pub fn to_world_point(&self, instance: u32, time: f32, p: Vec3) -> Vec3 {
        point_to_world(&self.placement(instance, time), p)
    }

    /// A prototype-space normal of `instance` at time `time` in world space: `object_from_worldᵀ ·
    /// n` (the inverse transpose of `world_from_object`), not normalized.
    #[inline]
    pub fn to_world_normal(&self, instance: u32, time: f32, n: Vec3) -> Vec3 {
        normal_to_world(&self.placement(instance, time), n)
    }

    /// The ray in the prototype space of an instance placed by `inst` (same `t`).
    #[inline(always)]
    fn object_ray(inst: &Placement, origin: Vec3, direction: Vec3) -> (Vec3, Vec3) {
        (apply(&inst.object_from_world, origin, 1.0), apply(&inst.object_from_world, direction, 0.0))
    }

    /// The closest instance hit nearer than `best` (or `tmax` without one); `best` otherwise.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn closest(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        time: f32,
        mut best: Option<Hit>,
        node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
        block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
    ) -> Option<Hit> {
        let nray = NodeRay::new(origin, direction);
        let start = best.map_or(tmax, |h| h.t);
        traverse::walk_closest(self.top_nodes, 0, &nray, start, node_kernel, &mut |leaf, mut tmax| {
            let (first, count) = child_ref::leaf_range(leaf);
            for &instance in &self.top_items[first as usize..(first + count) as usize] {
                let inst = &self.instances[instance as usize];
                let root = self.prototypes[inst.prototype as usize].first_node;
                let Some(placement) = self.place(inst, time) else { continue };
                let (o, d) = Self::object_ray(&placement, origin, direction);
                let found = traverse::closest(
                    self.prototype_nodes,
                    self.prototype_blocks,
                    root,
                    o,
                    d,
                    tmax,
                    node_kernel,
                    block_kernel,
                );
                if let Some((t, triangle, b1, b2)) = found {
                    tmax = t;
                    best = Some(Hit { t, triangle, b1, b2, instance, time });
                }
            }
            tmax
        });
        best
    }

    /// True when a prototype triangle for which `blocks(triangle, instance)` holds is hit in (0, `tmax`).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn any(
        &self,
        origin: Vec3,
        direction: Vec3,
        tmax: f32,
        time: f32,
        node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
        block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
        blocks: &mut impl FnMut(u32, u32) -> bool,
    ) -> bool {
        let nray = NodeRay::new(origin, direction);
        traverse::walk_any(self.top_nodes, 0, &nray, tmax, node_kernel, |leaf| {
            let (first, count) = child_ref::leaf_range(leaf);
            self.top_items[first as usize..(first + count) as usize].iter().any(|&instance| {
                let inst = &self.instances[instance as usize];
                let root = self.prototypes[inst.prototype as usize].first_node;
                let Some(placement) = self.place(inst, time) else { return false };
                let (o, d) = Self::object_ray(&placement, origin, direction);
                let mut blocker = |triangle| blocks(triangle, instance);
                traverse::any(
                    self.prototype_nodes,
                    self.prototype_blocks,
                    root,
                    o,
                    d,
                    tmax,
                    node_kernel,
                    block_kernel,
                    &mut blocker,
                )
            })
        })
    }
}

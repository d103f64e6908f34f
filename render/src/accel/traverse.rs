//! The walk written once and the kernels it is generic over: the 8-wide node test ([`NodeRay`]), the
//! watertight four-triangle block test ([`WatertightRay`]), their lane ([`Lanes`]) and scalar
//! ([`Scalar`]) implementations of [`Kernels`], tested against each other, and the closest- and any-hit
//! loops over one BVH.

use blob::{child_ref, BvhNode, TriangleBlock, BLOCK_WIDTH, BVH_WIDTH};
use glam::{Vec3, Vec4};

/// `1 + 2γ₃` with `γₙ = nε/(1 − nε)`, ε = 2⁻²⁴ (Ize 2013): scaling far slab distances by it makes the
/// box test conservative under rounding. (`f32::EPSILON` is 2⁻²³, hence the halving.)
const ROBUST_FAR: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Per-ray data of the node kernel.
#[derive(Clone, Copy, Debug)]
pub struct NodeRay {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    /// `inv_dir · (1 + 2γ₃)`, for far planes (one more rounding than Ize's `t · (1 + 2γ₃)`, still
    /// conservative: 2γ₃ ≈ 6ε exceeds the four roundings involved).
    inv_dir_far: [f32; 3],
    /// Index into [`BvhNode::bounds`] of the near plane per axis (min for a positive direction).
    near: [usize; 3],
    /// Index of the far plane per axis.
    far: [usize; 3],
}

impl NodeRay {
    /// Prepares `origin + t·direction`.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        let mut near = [0; 3];
        let mut far = [0; 3];
        for axis in 0..3 {
            let negative = direction[axis].is_sign_negative() as usize;
            near[axis] = axis + 3 * negative;
            far[axis] = axis + 3 * (1 - negative);
        }
        let inv_dir = direction.recip().to_array();
        NodeRay {
            origin: origin.to_array(),
            inv_dir,
            inv_dir_far: inv_dir.map(|i| i * ROBUST_FAR),
            near,
            far,
        }
    }
}

/// A node or leaf on the traversal stack with its entry distance.
#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    child: u32,
    t: f32,
}

/// Traversal stack: a fixed array, spilling to the heap only past its capacity (see module docs).
/// 32 entries (256 bytes) are zeroed inline per query; 64 compiled to a `memset` call, a visible cost
/// at ~250 cycles per primary ray.
struct Stack {
    items: [Entry; 32],
    len: usize,
    spill: Vec<Entry>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Stack { items: [Entry::default(); 32], len: 0, spill: Vec::new() }
    }

    #[inline(always)]
    fn push(&mut self, e: Entry) {
        if self.len == self.items.len() {
            self.spill.extend_from_slice(&self.items);
            self.len = 0;
        }
        self.items[self.len] = e;
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        if self.len > 0 {
            self.len -= 1;
            Some(self.items[self.len])
        } else {
            self.spill.pop()
        }
    }
}

/// The two kernels of a traversal. [`Lanes`] is the vectorizable one, [`Scalar`] the reference.
pub trait Kernels {
    /// Bit `i` set if child `i` of `node` overlaps the ray's `(0, tmax)` interval; with the entry
    /// distance per child.
    fn node(node: &BvhNode, ray: &NodeRay, tmax: f32) -> (u32, [f32; BVH_WIDTH]);
    /// Per lane `(hit, t, b1, b2)` as [`WatertightRay::intersect`] with this `tmax` would give.
    fn block(block: &TriangleBlock, ray: &WatertightRay, tmax: f32) -> BlockHits;
}

/// Result of a block test: lane mask of hits and the per-lane hit data (meaningful where hit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BlockHits {
    /// Bit `lane` set where the lane's triangle is hit.
    pub mask: u32,
    /// Ray parameter per lane.
    pub t: [f32; BLOCK_WIDTH],
    /// Barycentric of vertex 1 per lane.
    pub b1: [f32; BLOCK_WIDTH],
    /// Barycentric of vertex 2 per lane.
    pub b2: [f32; BLOCK_WIDTH],
}

/// The vectorizable kernels: fixed-width lane loops with branch-free bodies.
pub struct Lanes;

// Lane loops index several arrays by lane on purpose: that is the shape LLVM vectorizes.
#[allow(clippy::needless_range_loop)]
impl Kernels for Lanes {
    #[inline(always)]
    fn node(node: &BvhNode, ray: &NodeRay, tmax: f32) -> (u32, [f32; BVH_WIDTH]) {
        let mut near = [0.0f32; BVH_WIDTH];
        let mut far = [tmax; BVH_WIDTH];
        for axis in 0..3 {
            let lo = &node.bounds[ray.near[axis]];
            let (o, inv) = (ray.origin[axis], ray.inv_dir[axis]);
            for i in 0..BVH_WIDTH {
                let t0 = (lo[i] - o) * inv;
                near[i] = if t0 > near[i] { t0 } else { near[i] };
            }
        }
        for axis in 0..3 {
            let hi = &node.bounds[ray.far[axis]];
            let (o, inv) = (ray.origin[axis], ray.inv_dir_far[axis]);
            for i in 0..BVH_WIDTH {
                let t1 = (hi[i] - o) * inv;
                far[i] = if t1 < far[i] { t1 } else { far[i] };
            }
        }
        let bits: [u32; BVH_WIDTH] = std::array::from_fn(|i| ((near[i] <= far[i]) as u32) << i);
        (bits.iter().fold(0, |a, b| a | b), near)
    }

    #[inline(always)]
    fn block(block: &TriangleBlock, ray: &WatertightRay, tmax: f32) -> BlockHits {
        // One `Vec4` per quantity, lane = triangle: glam's `Vec4` is an SSE register on x86-64 (and
        // four scalars elsewhere), so this is the same IEEE arithmetic as `WatertightRay::intersect`
        // lane for lane, with no FMA contraction. See the module docs for why not `[f32; 4]` loops.
        let [kx, ky, kz] = ray.axes;
        let [ox, oy, oz] = ray.origin_k.map(Vec4::splat);
        let (sx, sy, sz) = (Vec4::splat(ray.sx), Vec4::splat(ray.sy), Vec4::splat(ray.sz));
        // A corner translated to the ray origin and sheared: (x, y) in the ray's 2D frame, and z.
        let corner = |p: &[[f32; BLOCK_WIDTH]; 3]| {
            let x = Vec4::from_array(p[kx]) - ox;
            let y = Vec4::from_array(p[ky]) - oy;
            let z = Vec4::from_array(p[kz]) - oz;
            (x - sx * z, y - sy * z, sz * z)
        };
        let [p0, p1, p2] = &block.vertices;
        let (ax, ay, az) = corner(p0);
        let (bx, by, bz) = corner(p1);
        let (cx, cy, cz) = corner(p2);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        // Rare: an edge function is exactly zero; those lanes are redone by the scalar test (which
        // retries in double precision) after the fast path, out of line.
        let on_edge = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask();
        // The scalar test's early returns as one mask. `(t_scaled > 0) & (t_scaled < tmax·det)`
        // differs from the scalar `!(t_scaled <= 0 | …)` only for NaN operands, and those make `t`
        // NaN, which the finiteness test rejects in both.
        let negative = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let positive = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let det = u + v + w;
        let t_scaled = u * az + v * bz + w * cz;
        let limit = Vec4::splat(tmax) * det;
        let front = det.cmpgt(zero) & t_scaled.cmpgt(zero) & t_scaled.cmplt(limit);
        let back = det.cmplt(zero) & t_scaled.cmplt(zero) & t_scaled.cmpgt(limit);
        let inv = Vec4::ONE / det;
        let t = t_scaled * inv;
        let hit = !(negative & positive) & (front | back) & t.abs().cmplt(Vec4::INFINITY);
        let hits = BlockHits {
            mask: hit.bitmask(),
            t: t.to_array(),
            b1: (v * inv).to_array(),
            b2: (w * inv).to_array(),
        };
        if on_edge != 0 {
            return redo_lanes(hits, on_edge, block, ray, tmax);
        }
        hits
    }
}

// The lane kernel holds one triangle per `Vec4` lane.
const _: () = assert!(BLOCK_WIDTH == 4);

/// The lanes of `on_edge` redone with the scalar test [`WatertightRay::intersect`]: its
/// double-precision retry of an exactly zero edge function. Out of line and cold, so the fast path
/// keeps its values in registers (an in-line retry indexed by lane forced the lane arrays onto the
/// stack and scalarized the test).
#[cold]
#[inline(never)]
pub(crate) fn redo_lanes(
    mut hits: BlockHits,
    mut on_edge: u32,
    block: &TriangleBlock,
    ray: &WatertightRay,
    tmax: f32,
) -> BlockHits {
    while on_edge != 0 {
        let lane = on_edge.trailing_zeros() as usize;
        on_edge &= on_edge - 1;
        hits.mask &= !(1 << lane);
        if let Some((t, b1, b2)) = ray.intersect(block_triangle(block, lane), tmax) {
            hits.mask |= 1 << lane;
            (hits.t[lane], hits.b1[lane], hits.b2[lane]) = (t, b1, b2);
        }
    }
    hits
}

/// The three corners of lane `lane` of a block.
#[inline]
pub(crate) fn block_triangle(block: &TriangleBlock, lane: usize) -> [Vec3; 3] {
    std::array::from_fn(|c| Vec3::from(std::array::from_fn(|axis| block.vertices[c][axis][lane])))
}

/// The reference kernels: one child, one triangle at a time.
pub struct Scalar;

// The child and lane indices address several SoA arrays at once.
#[allow(clippy::needless_range_loop)]
impl Kernels for Scalar {
    fn node(node: &BvhNode, ray: &NodeRay, tmax: f32) -> (u32, [f32; BVH_WIDTH]) {
        let mut mask = 0;
        let mut dist = [0.0; BVH_WIDTH];
        for child in 0..BVH_WIDTH {
            let (mut near, mut far) = (0.0f32, tmax);
            for axis in 0..3 {
                let mut t0 = (node.bounds[axis][child] - ray.origin[axis]) * ray.inv_dir[axis];
                let mut t1 = (node.bounds[3 + axis][child] - ray.origin[axis]) * ray.inv_dir_far[axis];
                if ray.inv_dir[axis].is_sign_negative() {
                    t0 = (node.bounds[3 + axis][child] - ray.origin[axis]) * ray.inv_dir[axis];
                    t1 = (node.bounds[axis][child] - ray.origin[axis]) * ray.inv_dir_far[axis];
                }
                // NaN (origin on the plane of a zero direction component): the slab does not constrain.
                if t0 > near {
                    near = t0;
                }
                if t1 < far {
                    far = t1;
                }
            }
            dist[child] = near;
            if near <= far {
                mask |= 1 << child;
            }
        }
        (mask, dist)
    }

    fn block(block: &TriangleBlock, ray: &WatertightRay, tmax: f32) -> BlockHits {
        let mut hits = BlockHits::default();
        for lane in 0..BLOCK_WIDTH {
            if let Some((t, b1, b2)) = ray.intersect(block_triangle(block, lane), tmax) {
                hits.mask |= 1 << lane;
                hits.t[lane] = t;
                hits.b1[lane] = b1;
                hits.b2[lane] = b2;
            }
        }
        hits
    }
}

/// Closest-hit traversal of the triangle BVH rooted at node `root` of `nodes`: `(t, triangle, b1, b2)`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn closest(
    nodes: &[BvhNode],
    blocks: &[TriangleBlock],
    root: u32,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
) -> Option<(f32, u32, f32, f32)> {
    let wray = WatertightRay::new(origin, direction);
    let nray = NodeRay::new(origin, direction);
    let mut leaves = TriangleLeaves { blocks, wray: &wray, tmax, block_kernel, best: None };
    walk_closest(nodes, root, &nray, tmax, node_kernel, &mut leaves);
    leaves.best
}

/// What a closest-hit walk ([`walk_closest`]) does at a leaf: test it and return the (possibly
/// shortened) limit. Closures `FnMut(leaf, tmax) -> tmax` implement it (the instance level); the
/// triangle level is [`TriangleLeaves`], a struct so that its test is forced inline into the walk
/// (`#[inline(always)]` cannot be put on a closure argument, and LLVM kept the closure out of line,
/// compiled for the baseline target with a `vzeroupper` per call: 2–3 % of the tractor's samples).
pub(crate) trait ClosestLeaf {
    /// Tests leaf `leaf` (a [`child_ref`]) with limit `tmax`; returns the new limit.
    fn visit(&mut self, leaf: u32, tmax: f32) -> f32;
}

impl<F: FnMut(u32, f32) -> f32> ClosestLeaf for F {
    #[inline(always)]
    fn visit(&mut self, leaf: u32, tmax: f32) -> f32 {
        self(leaf, tmax)
    }
}

/// The leaf test of a closest-hit query over triangles: the best `(t, triangle, b1, b2)` so far.
struct TriangleLeaves<'a, B> {
    blocks: &'a [TriangleBlock],
    wray: &'a WatertightRay,
    /// The query's own limit (a hit must lie before it even when ties widen the walk's limit).
    tmax: f32,
    block_kernel: &'a B,
    best: Option<(f32, u32, f32, f32)>,
}

impl<B: Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits> ClosestLeaf for TriangleLeaves<'_, B> {
    #[inline(always)]
    fn visit(&mut self, leaf: u32, limit: f32) -> f32 {
        let (first, count) = child_ref::leaf_range(leaf);
        for block in &self.blocks[first as usize..(first + count) as usize] {
            let hits = (self.block_kernel)(block, self.wray, limit);
            let mut m = hits.mask;
            while m != 0 {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                let (t, triangle) = (hits.t[lane], block.triangles[lane]);
                if t < self.tmax && self.best.is_none_or(|(bt, btri, ..)| precedes(t, triangle, bt, btri)) {
                    self.best = Some((t, triangle, hits.b1[lane], hits.b2[lane]));
                }
            }
        }
        self.best.map_or(self.tmax, |(t, ..)| tie_limit(t))
    }
}

/// Whether a hit at `t` on `triangle` wins over the best one so far: it is nearer, or exactly as near
/// on a lower triangle index. The order is total, so the closest hit does not depend on the order in
/// which leaves are visited (single rays and packets visit them differently).
#[inline(always)]
pub(crate) fn precedes(t: f32, triangle: u32, best_t: f32, best_triangle: u32) -> bool {
    t < best_t || (t == best_t && triangle < best_triangle)
}

/// `1 + 2⁻¹⁶`: see [`tie_limit`].
const TIE_WIDEN: f32 = 1.0 + 1.0 / 65536.0;

/// The traversal limit once a hit at `t` is known: a little beyond `t` (256 ulps) rather than `t`
/// itself, so that a triangle met at exactly `t` (the tie [`precedes`] settles) is never culled by
/// the box test's or the triangle test's own rounding of a limit equal to `t`. Without the margin
/// the first of two tied triangles visited would win, and a packet, which visits leaves in another
/// order, could return the other one. The margin costs a few box tests just past the hit.
#[inline(always)]
pub(crate) fn tie_limit(t: f32) -> f32 {
    t * TIE_WIDEN
}

/// The node walk of a closest-hit query: children visited nearest first, subtrees farther than the
/// best hit culled. `leaf(child_ref, tmax)` tests one leaf and returns the (possibly shortened) `tmax`.
#[inline(always)]
pub(crate) fn walk_closest(
    nodes: &[BvhNode],
    root: u32,
    nray: &NodeRay,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    leaf: &mut impl ClosestLeaf,
) {
    let mut tmax = tmax;
    let mut stack = Stack::new();
    let mut current = Entry { child: root, t: 0.0 };
    loop {
        if child_ref::is_leaf(current.child) {
            tmax = leaf.visit(current.child, tmax);
        } else {
            let node = &nodes[current.child as usize];
            let (mut mask, dist) = node_kernel(node, nray, tmax);
            if mask != 0 {
                if mask & (mask - 1) == 0 {
                    // One child hit: descend without touching the stack.
                    let i = mask.trailing_zeros() as usize;
                    current = Entry { child: node.children[i], t: dist[i] };
                    continue;
                }
                // Several: sort them far to near (insertion sort; at most eight), push all but the
                // nearest, descend into the nearest.
                let mut hit = [Entry::default(); BVH_WIDTH];
                let mut n = 0;
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let e = Entry { child: node.children[i], t: dist[i] };
                    let mut j = n;
                    while j > 0 && hit[j - 1].t < e.t {
                        hit[j] = hit[j - 1];
                        j -= 1;
                    }
                    hit[j] = e;
                    n += 1;
                }
                for &e in &hit[..n - 1] {
                    stack.push(e);
                }
                current = hit[n - 1];
                continue;
            }
        }
        loop {
            match stack.pop() {
                None => return,
                // Entirely behind the best hit so far.
                Some(e) if e.t > tmax => {}
                Some(e) => {
                    current = e;
                    break;
                }
            }
        }
    }
}

/// Any-hit traversal of the triangle BVH rooted at node `root`: true when a triangle for which
/// `blocks(triangle)` holds is hit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn any(
    nodes: &[BvhNode],
    blocks: &[TriangleBlock],
    root: u32,
    origin: Vec3,
    direction: Vec3,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
    blocker: &mut impl FnMut(u32) -> bool,
) -> bool {
    let wray = WatertightRay::new(origin, direction);
    let nray = NodeRay::new(origin, direction);
    walk_any(nodes, root, &nray, tmax, node_kernel, |leaf| {
        let (first, count) = child_ref::leaf_range(leaf);
        for block in &blocks[first as usize..(first + count) as usize] {
            let mut m = block_kernel(block, &wray, tmax).mask;
            while m != 0 {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                if blocker(block.triangles[lane]) {
                    return true;
                }
            }
        }
        false
    })
}

/// The node walk of an any-hit query: no ordering (any blocker ends the walk), early exit when
/// `leaf(child_ref)` returns true.
#[inline(always)]
pub(crate) fn walk_any(
    nodes: &[BvhNode],
    root: u32,
    nray: &NodeRay,
    tmax: f32,
    node_kernel: &impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    mut leaf: impl FnMut(u32) -> bool,
) -> bool {
    let mut stack = Stack::new();
    let mut current = root;
    loop {
        if child_ref::is_leaf(current) {
            if leaf(current) {
                return true;
            }
        } else {
            let node = &nodes[current as usize];
            let (mut mask, _) = node_kernel(node, nray, tmax);
            if mask != 0 {
                current = node.children[mask.trailing_zeros() as usize];
                mask &= mask - 1;
                while mask != 0 {
                    stack.push(Entry { child: node.children[mask.trailing_zeros() as usize], t: 0.0 });
                    mask &= mask - 1;
                }
                continue;
            }
        }
        match stack.pop() {
            None => return false,
            Some(e) => current = e.child,
        }
    }
}

/// Edge functions in double precision (the watertight test's fallback when one is exactly zero).
#[inline]
pub(crate) fn edge_functions_f64(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> [f32; 3] {
    let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
    [(cx * by - cy * bx) as f32, (ax * cy - ay * cx) as f32, (bx * ay - by * ax) as f32]
}

/// Per-ray precomputation of the watertight test: the axis permutation and shear that map the ray to
/// +Z through the origin.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    pub(crate) origin: Vec3,
    /// `origin[kx], origin[ky], origin[kz]`, so SIMD code needs no per-block component lookup.
    pub(crate) origin_k: [f32; 3],
    /// `[kx, ky, kz]`: `kz` is the dominant axis of the direction, `kx`, `ky` the other two, swapped
    /// when the direction's `kz` component is negative (keeps the triangles' winding).
    pub(crate) axes: [usize; 3],
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    pub(crate) sz: f32,
}

/// `[kx, ky, kz]` by `2·kz + (direction[kz] < 0)`.
const AXES: [[usize; 3]; 6] = [[1, 2, 0], [2, 1, 0], [2, 0, 1], [0, 2, 1], [0, 1, 2], [1, 0, 2]];

impl WatertightRay {
    /// Prepares `origin + t·direction`.
    ///
    /// Built once per query (and per instance entered), so it is branch-free: the dominant axis
    /// comes from comparisons turned into an index and the permutation from a table (the `if`
    /// chain and a swap mispredicted on incoherent rays: 6 % of the tractor's samples), and the
    /// three quotients are one vector division (the same IEEE quotients as three scalar ones).
    #[inline(always)]
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        let a = direction.abs();
        // kz: x if it is strictly the largest, else y if larger than z, else z (ties as before).
        let x_wins = (a.x > a.y) & (a.x > a.z);
        let y_wins = a.y > a.z;
        let kz = (!x_wins as usize) * (2 - y_wins as usize);
        let d = direction.to_array();
        let dz = d[kz];
        let axes = AXES[2 * kz + (dz < 0.0) as usize];
        let [kx, ky, _] = axes;
        let o = origin.to_array();
        let [sx, sy, sz, _] = (Vec4::new(d[kx], d[ky], 1.0, 1.0) / Vec4::splat(dz)).to_array();
        WatertightRay { origin, origin_k: [o[kx], o[ky], o[kz]], axes, sx, sy, sz }
    }

    /// `(t, b1, b2)` if the ray hits the triangle with `0 < t < tmax`.
    #[inline]
    pub fn intersect(&self, [p0, p1, p2]: [Vec3; 3], tmax: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.axes;
        let a = p0 - self.origin;
        let b = p1 - self.origin;
        let c = p2 - self.origin;
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Edge case: redo the 2D edge tests in double precision, as the paper prescribes.
            [u, v, w] = edge_functions_f64(ax, ay, bx, by, cx, cy);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        if det > 0.0 {
            if t_scaled <= 0.0 || t_scaled >= tmax * det {
                return None;
            }
        } else if t_scaled >= 0.0 || t_scaled <= tmax * det {
            return None;
        }
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !t.is_finite() {
            return None;
        }
        Some((t, v * inv, w * inv))
    }
}

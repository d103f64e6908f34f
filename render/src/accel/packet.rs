//! Packet traversal of the BVH8: closest hit ([`closest_packet`]) and any hit ([`any_packet`]),
//! measured against single-ray traversal and kept out of the wavefront (see below); the bench's
//! traversal table uses them.
//!
//! Up to eight rays share one traversal: at an inner node each active ray runs the 8-wide slab test
//! ([`Lanes::node`]) and each child is entered with the mask of the rays that hit it (its distance is
//! the nearest of theirs); children are visited near to far (closest hit) or in slot order (any
//! hit) and the packet narrows to those rays. At a leaf each ray of the mask runs the 4-wide triangle
//! test ([`Lanes::block`]) with its own limit. The node is fetched once for the packet: the saving
//! packet tracers count on for coherent rays. Any hit: a ray leaves every pending mask once a
//! triangle its `blocks` accepts is hit, and the walk ends when none is left; instances are walked
//! per ray after the packet, for both queries.
//!
//! The answers equal [`Accel::closest_hit`] and [`Accel::any_hit`] per ray, bit for bit (tested on
//! random, instanced and exact-tie scenes): a closest hit is the least `(t, triangle index)`
//! (`accel::precedes`), so the visiting order, which differs between a packet and a single
//! ray, never decides a tie; an any-hit answer does not depend on the order at all.
//!
//! Kept out of the wavefront: as camera-wave and occlusion packets they ran +2.5 / +3.8 / +7.9 %
//! instructions in the BVH queries and the intersect stage (simple / tractor / shading-heavy), and
//! lose on incoherent rays in the bench's traversal table. The node kernel is already 8-wide across
//! children, so a packet adds no SIMD width, only a shared node fetch, and these BVHs sit in L2.
//! Where to measure next: scenes whose BVH spills out of L2, and a ray-major triangle test;
//! measurements: `docs/perf.md#packet-traversal-accelpacketrs`.
//!
//! [`Lanes::node`]: crate::accel::Kernels::node
//! [`Lanes::block`]: crate::accel::Kernels::block

use crate::accel::ray::Hit;
use crate::accel::traverse::{precedes, tie_limit, BlockHits, NodeRay, WatertightRay};
use crate::accel::Accel;
use blob::{child_ref, BvhNode, TriangleBlock, BVH_WIDTH};
use glam::Vec3;

/// Rays per packet.
pub const PACKET: usize = 8;

/// The 3-bit direction octant (sign bits of x, y, z).
#[inline]
pub fn octant(d: Vec3) -> u32 {
    (d.x.is_sign_negative() as u32)
        | (d.y.is_sign_negative() as u32) << 1
        | (d.z.is_sign_negative() as u32) << 2
}

/// Closest hits of up to [`PACKET`] rays (`origins[k] + t·dirs[k]`, `t` in (0, `tmax`)) into `out`:
/// the same hits as [`Accel::closest_hit`] per ray. The world BVH is walked by the packet, the
/// instances (if any) by each ray alone.
pub fn closest_packet(accel: &Accel, origins: &[Vec3], dirs: &[Vec3], tmax: f32, out: &mut [Option<Hit>]) {
    let n = origins.len().min(PACKET).min(dirs.len()).min(out.len());
    out[..n].fill(None);
    if n == 0 {
        return;
    }
    if !accel.nodes.is_empty() {
        closest_packet_simd(accel, &origins[..n], &dirs[..n], tmax, &mut out[..n]);
    }
    for k in 0..n {
        out[k] = accel.closest_in_instances(origins[k], dirs[k], tmax, out[k]);
    }
}

/// Any-hit queries of up to [`PACKET`] rays (`origins[k] + t·dirs[k]`, `t` in (0, `tmax[k]`)): bit
/// `k` of the result is set when ray `k` hits a triangle for which `blocks(k, triangle, instance)`
/// holds, as [`Accel::any_hit`] answers per ray (`blocks` must be pure, as there). The world BVH is
/// walked by the packet, the instances (if any) by each ray not yet blocked.
pub fn any_packet(
    accel: &Accel,
    origins: &[Vec3],
    dirs: &[Vec3],
    tmax: &[f32],
    mut blocks: impl FnMut(usize, u32, u32) -> bool,
) -> u32 {
    let n = origins.len().min(PACKET).min(dirs.len()).min(tmax.len());
    if n == 0 {
        return 0;
    }
    let mut blocked = 0;
    if !accel.nodes.is_empty() {
        blocked = any_packet_simd(accel, &origins[..n], &dirs[..n], &tmax[..n], &mut blocks);
    }
    for k in 0..n {
        if blocked & (1 << k) == 0
            && accel.any_in_instances(origins[k], dirs[k], tmax[k], |t, i| blocks(k, t, i))
        {
            blocked |= 1 << k;
        }
    }
    blocked
}

#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn closest_packet_simd(accel: &Accel, origins: &[Vec3], dirs: &[Vec3], tmax: f32, out: &mut [Option<Hit>]) {
    let (node, block) = crate::accel::lane_kernels!();
    let rays = PacketRays::new(origins, dirs);
    let mut limit = [tmax; PACKET];
    let leaf = |leaf, mask, limit: &mut [f32; PACKET]| {
        leaf_closest(accel, leaf, mask, &rays, tmax, limit, out, &block);
        0
    };
    walk(accel.nodes, rays.n, &mut limit, true, per_ray_children(&rays, node), leaf);
}

/// Calls `f` with the index of every set bit of `mask`, lowest first.
#[inline(always)]
fn for_each_ray(mut mask: u32, mut f: impl FnMut(usize)) {
    while mask != 0 {
        f(mask.trailing_zeros() as usize);
        mask &= mask - 1;
    }
}

/// The children test of a packet whose rays each run the node kernel: per child, the mask of the
/// rays that hit it and the nearest of their entry distances.
#[inline(always)]
fn per_ray_children<'r>(
    rays: &'r PacketRays,
    node_kernel: impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]) + 'r,
) -> impl Fn(&BvhNode, u32, &[f32; PACKET]) -> ([u32; BVH_WIDTH], [f32; BVH_WIDTH]) + 'r {
    move |node, mask, limit| {
        let mut child_mask = [0u32; BVH_WIDTH];
        let mut child_t = [f32::INFINITY; BVH_WIDTH];
        for_each_ray(mask, |k| {
            let (mut hit, dist) = node_kernel(node, &rays.node[k], limit[k]);
            while hit != 0 {
                let i = hit.trailing_zeros() as usize;
                hit &= hit - 1;
                child_mask[i] |= 1 << k;
                child_t[i] = child_t[i].min(dist[i]);
            }
        });
        (child_mask, child_t)
    }
}

#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn any_packet_simd<F: FnMut(usize, u32, u32) -> bool>(
    accel: &Accel,
    origins: &[Vec3],
    dirs: &[Vec3],
    tmax: &[f32],
    blocks: &mut F,
) -> u32 {
    let (node, block) = crate::accel::lane_kernels!();
    let rays = PacketRays::new(origins, dirs);
    let mut limit: [f32; PACKET] = std::array::from_fn(|k| tmax[k.min(tmax.len() - 1)]);
    let mut blocked = 0;
    walk(accel.nodes, rays.n, &mut limit, false, per_ray_children(&rays, node), |leaf, mask, limit| {
        let now = leaf_any(accel, leaf, mask, &rays, limit, blocks, &block);
        blocked |= now;
        now
    });
    blocked
}

/// The per-ray data of the two kernels, for the `n` rays of a packet.
struct PacketRays {
    n: usize,
    node: [NodeRay; PACKET],
    triangle: [WatertightRay; PACKET],
}

impl PacketRays {
    fn new(origins: &[Vec3], dirs: &[Vec3]) -> Self {
        let n = origins.len();
        PacketRays {
            n,
            node: std::array::from_fn(|k| NodeRay::new(origins[k.min(n - 1)], dirs[k.min(n - 1)])),
            triangle: std::array::from_fn(|k| WatertightRay::new(origins[k.min(n - 1)], dirs[k.min(n - 1)])),
        }
    }
}

/// Tests the rays of `mask` against the triangles of `leaf`, keeping per ray the hit that
/// [`precedes`] (so the visiting order never decides a tie) and shortening its limit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn leaf_closest(
    accel: &Accel,
    leaf: u32,
    mask: u32,
    rays: &PacketRays,
    tmax: f32,
    limit: &mut [f32; PACKET],
    out: &mut [Option<Hit>],
    block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
) {
    let (first, count) = child_ref::leaf_range(leaf);
    for b in &accel.blocks[first as usize..(first + count) as usize] {
        let mut m = mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let hits = block_kernel(b, &rays.triangle[k], limit[k]);
            let mut h = hits.mask;
            while h != 0 {
                let lane = h.trailing_zeros() as usize;
                h &= h - 1;
                let (t, triangle) = (hits.t[lane], b.triangles[lane]);
                if t < tmax && out[k].is_none_or(|o| precedes(t, triangle, o.t, o.triangle)) {
                    out[k] =
                        Some(Hit { t, triangle, b1: hits.b1[lane], b2: hits.b2[lane], instance: blob::NONE });
                    limit[k] = tie_limit(t);
                }
            }
        }
    }
}

/// Tests the rays of `mask` against the triangles of `leaf`; returns the rays a blocker stopped.
#[inline(always)]
fn leaf_any(
    accel: &Accel,
    leaf: u32,
    mask: u32,
    rays: &PacketRays,
    limit: &[f32; PACKET],
    blocks: &mut impl FnMut(usize, u32, u32) -> bool,
    block_kernel: &impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
) -> u32 {
    let (first, count) = child_ref::leaf_range(leaf);
    let mut stopped = 0;
    for b in &accel.blocks[first as usize..(first + count) as usize] {
        let mut m = mask & !stopped;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let mut h = block_kernel(b, &rays.triangle[k], limit[k]).mask;
            while h != 0 {
                let lane = h.trailing_zeros() as usize;
                h &= h - 1;
                if blocks(k, b.triangles[lane], blob::NONE) {
                    stopped |= 1 << k;
                    break;
                }
            }
        }
    }
    stopped
}

/// A subtree on the packet's stack: the rays that entered it and the nearest entry distance of
/// theirs.
#[derive(Clone, Copy, Default)]
struct Entry {
    child: u32,
    mask: u32,
    t: f32,
}

/// The packet's node walk. At an inner node each ray of the packet's mask runs the node kernel with
/// its own `limit`, and each child hit is entered with the mask of the rays that hit it. `ordered`
/// (closest hit): children visited near to far by their nearest ray's entry distance, and a popped
/// subtree keeps only the rays whose limit still reaches it. `leaf(leaf, mask, limit)` tests a
/// leaf, may shorten the limits, and returns rays that are finished (any hit): those leave every
/// pending mask, and the walk ends when none is left.
#[inline(always)]
fn walk(
    nodes: &[BvhNode],
    n: usize,
    limit: &mut [f32; PACKET],
    ordered: bool,
    children: impl Fn(&BvhNode, u32, &[f32; PACKET]) -> ([u32; BVH_WIDTH], [f32; BVH_WIDTH]),
    mut leaf: impl FnMut(u32, u32, &mut [f32; PACKET]) -> u32,
) {
    let mut live = (1u32 << n) - 1;
    // Eight rays push at most seven children per level; 96 entries are never exceeded by a BVH
    // built by ingest, and a deeper walk spills to the heap rather than fail.
    let mut stack = [Entry::default(); 96];
    let mut len = 0usize;
    let mut spill: Vec<Entry> = Vec::new();
    let mut current = Entry { child: 0, mask: live, t: 0.0 };
    loop {
        if current.child & child_ref::LEAF != 0 {
            live &= !leaf(current.child, current.mask, limit);
            if live == 0 {
                return;
            }
        } else {
            let node = &nodes[current.child as usize];
            let (child_mask, child_t) = children(node, current.mask, limit);
            // Children far to near (closest hit) or in slot order; push all but the last.
            let mut order = [Entry::default(); BVH_WIDTH];
            let mut count = 0;
            for i in 0..BVH_WIDTH {
                if child_mask[i] != 0 {
                    let e = Entry { child: node.children[i], mask: child_mask[i], t: child_t[i] };
                    let mut j = count;
                    if ordered {
                        while j > 0 && order[j - 1].t < e.t {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                    } else {
                        // Slot order reversed, so the first slot is entered first, as single rays do.
                        while j > 0 {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                    }
                    order[j] = e;
                    count += 1;
                }
            }
            if count > 0 {
                for &e in &order[..count - 1] {
                    if len == stack.len() {
                        spill.extend_from_slice(&stack);
                        len = 0;
                    }
                    stack[len] = e;
                    len += 1;
                }
                current = order[count - 1];
                continue;
            }
        }
        loop {
            let e = if len > 0 {
                len -= 1;
                stack[len]
            } else if let Some(e) = spill.pop() {
                e
            } else {
                return;
            };
            let mut mask = e.mask & live;
            if ordered {
                // Drop the rays whose best hit is already nearer than the subtree's nearest entry.
                let mut m = mask;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    if e.t > limit[k] {
                        mask &= !(1 << k);
                    }
                }
            }
            if mask != 0 {
                current = Entry { mask, ..e };
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::{self, Rng};

    /// Packets of rays from random origins around the scene: coherent (one origin, directions within
    /// ±0.02) for even `p`, incoherent for odd, every few rays a zero direction component.
    fn packet_rays(rng: &mut Rng, p: usize, reach: f32) -> (Vec<Vec3>, Vec<Vec3>) {
        let o = Vec3::new(rng.range(-0.5, 0.5) * reach, rng.range(-0.5, 0.5) * reach, reach);
        let spread = if p.is_multiple_of(2) { 0.02 } else { 1.0 };
        let base = Vec3::new(rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), -1.0);
        let dirs = (0..PACKET)
            .map(|k| {
                if k == 3 && p.is_multiple_of(5) {
                    return Vec3::NEG_Z;
                }
                (base + Vec3::new(rng.range(-spread, spread), rng.range(-spread, spread), 0.0)).normalize()
            })
            .collect();
        let origins = (0..PACKET)
            .map(|k| if p.is_multiple_of(3) { o + Vec3::splat(0.01 * k as f32) } else { o })
            .collect();
        (origins, dirs)
    }

    /// Scenes: random triangles, transformed instances (with world-space triangles), exact ties.
    fn scenes() -> Vec<(&'static str, blob::AlignedBytes)> {
        vec![
            ("random", testscene::encode(&testscene::random_triangles(3000, 5))),
            ("instances", testscene::bytes(&testscene::instanced_spheres(40, 0xbeef))),
            ("ties", testscene::encode(&testscene::stacked_copies(24, 400, 0x71e5))),
        ]
    }

    #[test]
    fn closest_packets_equal_single_rays() {
        for (name, bytes) in scenes() {
            let view = blob::SceneView::parse(&bytes).unwrap();
            let accel = Accel::new(&view);
            let mut rng = Rng(11);
            let mut hits = 0;
            for p in 0..400 {
                let (origins, dirs) = packet_rays(&mut rng, p, 3.0);
                // Partial packets too.
                let n = if p.is_multiple_of(7) { 1 + p % PACKET } else { PACKET };
                let tmax = if p % 4 == 1 { 3.5 } else { f32::INFINITY };
                let mut out = [None; PACKET];
                closest_packet(&accel, &origins[..n], &dirs[..n], tmax, &mut out);
                for k in 0..n {
                    let single = accel.closest_hit(origins[k], dirs[k], tmax);
                    assert_eq!(out[k], single, "{name}: packet {p} ray {k}");
                    hits += single.is_some() as u32;
                }
            }
            assert!(hits > 1000, "{name}: {hits} hits");
        }
    }

    #[test]
    fn any_packets_equal_single_rays() {
        // A pure blocker that differs per ray, triangle and instance, as the stochastic shadow
        // decisions do.
        let blocks = |k: usize, triangle: u32, instance: u32| {
            !(triangle.wrapping_mul(0x9e37_79b9) ^ instance ^ (k as u32).wrapping_mul(0x85eb_ca6b))
                .is_multiple_of(3)
        };
        for (name, bytes) in scenes() {
            let view = blob::SceneView::parse(&bytes).unwrap();
            let accel = Accel::new(&view);
            let mut rng = Rng(23);
            let (mut blocked, mut clear) = (0, 0);
            for p in 0..400 {
                let (origins, dirs) = packet_rays(&mut rng, p, 3.0);
                let n = if p.is_multiple_of(7) { 1 + p % PACKET } else { PACKET };
                let tmax: Vec<f32> = (0..n)
                    .map(|k| if (p + k) % 3 == 0 { rng.range(0.5, 5.0) } else { f32::INFINITY })
                    .collect();
                let mask = any_packet(&accel, &origins[..n], &dirs[..n], &tmax, blocks);
                for k in 0..n {
                    let single = accel.any_hit(origins[k], dirs[k], tmax[k], |t, i| blocks(k, t, i));
                    assert_eq!(mask & (1 << k) != 0, single, "{name}: packet {p} ray {k}");
                    blocked += single as u32;
                    clear += !single as u32;
                }
                assert_eq!(mask >> n, 0, "{name}: no bits past the packet");
            }
            assert!(blocked > 300 && clear > 300, "{name}: {blocked} blocked, {clear} clear");
        }
    }
}

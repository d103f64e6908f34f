//! Packet traversal of the BVH8 (an experiment measured against single-ray traversal; see below).
//!
//! Up to eight rays share one traversal: at an inner node each active ray runs the 8-wide slab test
//! ([`Lanes::node`]) and each child is entered with the mask of the rays that hit it (its distance is
//! the nearest of theirs); children are visited near to far and the packet narrows to those rays. At a
//! leaf each ray of the mask runs the 4-wide triangle test ([`Lanes::block`]) with its own `tmax`. The
//! node is fetched once for the packet: the saving packet tracers count on for coherent rays. Rays are
//! grouped by direction octant first ([`octant`]), as in the streaming-traversal post, so a packet's
//! rays agree on the near planes and on the visiting order.
//!
//! Per ray the closest hit is the nearest triangle the ray meets, as in [`Accel::closest_hit`]; only
//! when two triangles are met at exactly the same `t` can the visiting order pick a different one
//! (the bench counts these).
//!
//! # Measurement (`bench integrators`, traversal table)
//! Against single-ray traversal on the same rays, per queue type: primary rays in packets of 8
//! neighbouring pixels, diffuse bounce rays and shadow rays from the primary hits (octant-sorted),
//! 320×213, one thread, best of 3 in CPU seconds on the loaded 2-core machine (load average ~10):
//!
//! | scene | primary | incoherent | occlusion |
//! |---|---|---|---|
//! | tractor (2 k triangles) | 1.14× | 0.74× | 0.97× |
//! | shading-heavy (60 k) | 0.93× | 0.93× | 1.14× |
//! | simple (4 k) | 1.25× | 1.02× | 0.94× |
//!
//! Repeated runs move these by ±15 %, so no queue wins consistently, and the wavefront keeps
//! single-ray traversal for every queue. Why packets gain little here: the node kernel is already
//! 8-wide across children, so a packet adds no SIMD width, only a shared node fetch; these BVHs fit in
//! L2, so the shared fetch is cheap, while the packet's looser culling (a child is entered while any
//! ray of the packet still wants it) adds node tests. Scenes whose BVH spills out of cache are where
//! primary-ray packets should be measured next.
//!
//! [`Lanes::node`]: crate::accel::Kernels::node
//! [`Lanes::block`]: crate::accel::Kernels::block

use crate::accel::{Accel, BlockHits, Hit, NodeRay, WatertightRay};
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

/// Closest hits of up to [`PACKET`] rays (`origins[k] + t·dirs[k]`, `t` in (0, `tmax`)) into `out`.
pub fn closest_packet(accel: &Accel, origins: &[Vec3], dirs: &[Vec3], tmax: f32, out: &mut [Option<Hit>]) {
    let n = origins.len().min(PACKET).min(dirs.len()).min(out.len());
    if accel.nodes.is_empty() || n == 0 {
        out[..n].fill(None);
        return;
    }
    closest_packet_simd(accel, &origins[..n], &dirs[..n], tmax, &mut out[..n]);
}

#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn closest_packet_simd(accel: &Accel, origins: &[Vec3], dirs: &[Vec3], tmax: f32, out: &mut [Option<Hit>]) {
    let (node, block) = crate::accel::lane_kernels!();
    traverse(accel, origins, dirs, tmax, out, node, block);
}

#[derive(Clone, Copy, Default)]
struct Entry {
    child: u32,
    mask: u32,
    t: f32,
}

fn traverse(
    accel: &Accel,
    origins: &[Vec3],
    dirs: &[Vec3],
    tmax0: f32,
    out: &mut [Option<Hit>],
    node_kernel: impl Fn(&BvhNode, &NodeRay, f32) -> (u32, [f32; BVH_WIDTH]),
    block_kernel: impl Fn(&TriangleBlock, &WatertightRay, f32) -> BlockHits,
) {
    let n = origins.len();
    let nrays: [NodeRay; PACKET] =
        std::array::from_fn(|k| NodeRay::new(origins[k.min(n - 1)], dirs[k.min(n - 1)]));
    let wrays: [WatertightRay; PACKET] =
        std::array::from_fn(|k| WatertightRay::new(origins[k.min(n - 1)], dirs[k.min(n - 1)]));
    let mut tmax = [tmax0; PACKET];
    out.fill(None);
    // Eight rays push at most seven children per level; 64 levels of that never occur in a BVH
    // built by ingest, and a deeper walk spills to the heap rather than fail.
    let mut stack = [Entry::default(); 96];
    let mut len = 0usize;
    let mut spill: Vec<Entry> = Vec::new();
    let mut current = Entry { child: 0, mask: (1u32 << n) - 1, t: 0.0 };
    loop {
        if current.child & child_ref::LEAF != 0 {
            let (first, count) = child_ref::leaf_range(current.child);
            for b in &accel.blocks[first as usize..(first + count) as usize] {
                let mut m = current.mask;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let hits = block_kernel(b, &wrays[k], tmax[k]);
                    let mut best: Option<usize> = None;
                    let mut h = hits.mask;
                    while h != 0 {
                        let lane = h.trailing_zeros() as usize;
                        h &= h - 1;
                        if best.is_none_or(|x| hits.t[lane] < hits.t[x]) {
                            best = Some(lane);
                        }
                    }
                    if let Some(lane) = best {
                        tmax[k] = hits.t[lane];
                        out[k] = Some(Hit {
                            t: hits.t[lane],
                            triangle: b.triangles[lane],
                            b1: hits.b1[lane],
                            b2: hits.b2[lane],
                            // Packets walk the world BVH only; instanced scenes keep single rays.
                            instance: blob::NONE,
                        });
                    }
                }
            }
        } else {
            let node = &accel.nodes[current.child as usize];
            let mut child_mask = [0u32; BVH_WIDTH];
            let mut child_t = [f32::INFINITY; BVH_WIDTH];
            let mut m = current.mask;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let (mut hit, dist) = node_kernel(node, &nrays[k], tmax[k]);
                while hit != 0 {
                    let i = hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    child_mask[i] |= 1 << k;
                    child_t[i] = child_t[i].min(dist[i]);
                }
            }
            // Children far to near; push all but the nearest.
            let mut order = [Entry::default(); BVH_WIDTH];
            let mut count = 0;
            for i in 0..BVH_WIDTH {
                if child_mask[i] != 0 {
                    let e = Entry { child: node.children[i], mask: child_mask[i], t: child_t[i] };
                    let mut j = count;
                    while j > 0 && order[j - 1].t < e.t {
                        order[j] = order[j - 1];
                        j -= 1;
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
            // Drop the rays whose best hit is already nearer than the child's nearest entry.
            let mut mask = e.mask;
            let mut m = e.mask;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                if e.t > tmax[k] {
                    mask &= !(1 << k);
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

    #[test]
    fn packets_find_the_single_ray_hits() {
        let data = crate::testscene::random_triangles(3000, 5);
        let bytes = crate::testscene::encode(&data);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let accel = Accel::new(&view);
        let mut rng = crate::testscene::Rng(11);
        let (mut hits, mut ties) = (0, 0);
        for p in 0..400 {
            let o = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), 3.0);
            // Coherent packets for even p, incoherent for odd.
            let spread = if p % 2 == 0 { 0.02 } else { 1.0 };
            let base = Vec3::new(rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), -1.0);
            let dirs: Vec<Vec3> = (0..PACKET)
                .map(|_| {
                    (base + Vec3::new(rng.range(-spread, spread), rng.range(-spread, spread), 0.0))
                        .normalize()
                })
                .collect();
            let origins = vec![o; PACKET];
            let mut out = [None; PACKET];
            closest_packet(&accel, &origins, &dirs, f32::INFINITY, &mut out);
            for k in 0..PACKET {
                let single = accel.closest_hit(o, dirs[k], f32::INFINITY);
                match (single, out[k]) {
                    (Some(a), Some(b)) if a.t == b.t && a.triangle != b.triangle => ties += 1,
                    (a, b) => assert_eq!(a, b, "packet {p} ray {k}"),
                }
                hits += single.is_some() as u32;
            }
        }
        assert!(hits > 1000, "{hits} hits");
        assert!(ties <= 2, "{ties} exact ties resolved differently");
    }
}

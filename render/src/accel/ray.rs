//! What a traversal takes and gives: a [`Ray`], its closest [`Hit`], and the origin offset that keeps a
//! new ray off the surface it leaves.

use glam::Vec3;
use lanekit::{saturating_i32, Lanes3, LANES};

/// A ray for the batch query [`crate::Accel::trace_closest`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin, world space.
    pub origin: Vec3,
    /// Direction (need not be unit length; `t` is measured in multiples of it).
    pub direction: Vec3,
    /// Largest accepted hit distance.
    pub tmax: f32,
}

/// The closest intersection of a ray with the scene's triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Index into the blob's triangles.
    pub triangle: u32,
    /// Barycentric weight of the triangle's vertex 1.
    pub b1: f32,
    /// Barycentric weight of the triangle's vertex 2.
    pub b2: f32,
    /// Index into the blob's instances when `triangle` is a prototype triangle (then `t`, `b1` and
    /// `b2` are the same in prototype and world space), or [`blob::NONE`] for a top-level triangle.
    pub instance: u32,
    /// The ray's time (time codes from the frame): where a moving instance was when it was hit
    /// ([`crate::accel::instanced::Instances::placement`]); 0 for an instantaneous shutter.
    pub time: f32,
}

/// Offsets a surface point along its geometric normal `n` (pointing to the side the new ray leaves
/// towards) so the new ray cannot re-hit the surface it starts on: Wächter & Binder, "A Fast and Robust
/// Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6. Far from the origin the offset is a
/// fixed number of ULPs (scales with the magnitude of the point); near the origin a small absolute one.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let offset_axis = |p: f32, n: f32| {
        let of_i = (INT_SCALE * n) as i32;
        let bits = p.to_bits() as i32;
        let moved = f32::from_bits(bits.wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32);
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            moved
        }
    };
    Vec3::new(offset_axis(p.x, n.x), offset_axis(p.y, n.y), offset_axis(p.z, n.z))
}

/// [`crate::accel::offset_ray_origin`] on eight lanes: each point `p` moved off its surface along
/// the normal `n` (Wächter & Binder, Ray Tracing Gems ch. 6: integer ulps away from the origin, a
/// float offset near it), the same integer and IEEE operations per component.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn offset_origin_lanes(p: &Lanes3, n: &Lanes3, out: &mut Lanes3) {
    // The constants of `offset_ray_origin`.
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    for c in 0..3 {
        for k in 0..LANES {
            let (p, n) = (p[c][k], n[c][k]);
            let of_i = saturating_i32(INT_SCALE * n);
            let bits = p.to_bits() as i32;
            let moved =
                f32::from_bits(bits.wrapping_add(if p < 0.0 { of_i.wrapping_neg() } else { of_i }) as u32);
            out[c][k] = if p.abs() < ORIGIN { p + FLOAT_SCALE * n } else { moved };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_origin_lanes_equal_the_scalar_offset_bit_for_bit() {
        let mut x = 41u32;
        let mut u = || {
            x = crate::sampler::hash_u32(x);
            (x >> 8) as f32 / 16_777_216.0
        };
        let (mut near, mut far) = (0, 0);
        for _ in 0..2000 {
            let (mut p, mut n) = ([[0.0f32; LANES]; 3], [[0.0f32; LANES]; 3]);
            for k in 0..LANES {
                // Points near the origin (the float offset), far from it (ulps), either sign.
                let scale = [0.01, 1.0, 100.0, 1e5][(u() * 4.0) as usize % 4];
                let dir = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize_or(Vec3::Z);
                for c in 0..3 {
                    p[c][k] = (2.0 * u() - 1.0) * scale;
                    n[c][k] = dir[c];
                }
            }
            let mut out = [[0.0f32; LANES]; 3];
            offset_origin_lanes(&p, &n, &mut out);
            for k in 0..LANES {
                let at = |c: &Lanes3| Vec3::new(c[0][k], c[1][k], c[2][k]);
                let expected = offset_ray_origin(at(&p), at(&n));
                assert_eq!(at(&out).to_array().map(f32::to_bits), expected.to_array().map(f32::to_bits));
                for axis in &p {
                    if axis[k].abs() < 1.0 / 32.0 {
                        near += 1;
                    } else {
                        far += 1;
                    }
                }
            }
        }
        assert!(near > 1000 && far > 10_000, "{near} components near the origin, {far} far");
    }
}

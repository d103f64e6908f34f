//! The eight-lane toolkit the render and texture kernels share.
//!
//! A lane kernel works on [`LANES`] items at once, one item per lane of an AVX2 register: its data
//! are columns ([`Lanes`], [`Lanes3`]) that the compiler keeps in `ymm` registers, and its body is
//! written once, per lane, so the scalar reference and the lanes compute the same IEEE operations.
//! Every kernel in the workspace uses this one width and these types, so a column filled by one
//! kernel is the input of the next without a transpose.

//!
//! Lane structs are declared once with [`soa!`] (their columns and transposes are generated):
//!
//! ```
//! lanekit::soa! {
//!     /// Eight throughput updates.
//!     #[derive(Clone, Copy, Debug)]
//!     #[repr(C, align(32))]
//!     pub struct UpdateLanes for struct Update {
//!         /// Throughput.
//!         pub beta: [f32; 3],
//!         /// Probability of going on.
//!         pub q: f32,
//!     }
//! }
//! let mut lanes = UpdateLanes::default();
//! lanes.set(1, &Update { beta: [1.0, 0.5, 0.25], q: 0.9 });
//! assert_eq!(lanes.beta[2], [0.0, 0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
//! ```
//!
//! Modules: [`soa`] (the declaration macro and the [`Lane`] column of each scalar type), [`cpu`]
//! (the run-time feature tests of the hand-written intrinsics paths).

#![deny(missing_docs)]

pub mod cpu;
pub mod soa;

pub use soa::{Column, Lane};

/// Items per lane group: eight `f32`s fill one AVX2 register.
pub const LANES: usize = 8;

/// One `f32` per lane.
pub type Lanes = [f32; LANES];

/// A vector of three components, each a column of lanes (structure of arrays).
pub type Lanes3 = [Lanes; 3];

/// One `u32` per lane.
pub type U32Lanes = [u32; LANES];

/// `x as i32` (saturating, NaN → 0) in a form LLVM vectorises: its own lowering of the saturating
/// cast runs one `cvttss2si` and two compares per lane (the ray-origin kernel took 217 instructions
/// per group that way), this one is a blend, a clamp and one `cvttps2dq` for eight lanes.
#[inline(always)]
pub fn saturating_i32(x: f32) -> i32 {
    // The largest f32 below 2³¹; from 2³¹ on the cast saturates to `i32::MAX`.
    const BELOW_2_31: f32 = 2_147_483_520.0;
    // `f32::max` returns the number when one side is NaN, so `clamped` is never NaN.
    let clamped = x.max(i32::MIN as f32).min(BELOW_2_31);
    // SAFETY: `clamped` is a number within [−2³¹, 2³¹ − 128], which truncates to a valid `i32`.
    let truncated = unsafe { clamped.to_int_unchecked::<i32>() };
    // Integer selects after the conversion: a NaN test before it became a branch per lane.
    let saturated = if x >= 2_147_483_648.0 { i32::MAX } else { truncated };
    if x.is_nan() {
        0
    } else {
        saturated
    }
}

/// A 3-vector of one lane, with glam's operation order (shared by the lane kernels): the
/// body of a lane kernel reads lane `k` of its columns with [`V::at`], computes with these operations
/// in the order glam's `Vec3` performs them, and writes back with [`V::store`], so it returns the
/// scalar reference's bits.
#[derive(Clone, Copy)]
pub struct V {
    /// x component.
    pub x: f32,
    /// y component.
    pub y: f32,
    /// z component.
    pub z: f32,
}

impl V {
    /// (0, 0, 0).
    pub const ZERO: V = V { x: 0.0, y: 0.0, z: 0.0 };
    /// Lane `k` of column vector `c`.
    #[inline(always)]
    pub fn at(c: &Lanes3, k: usize) -> V {
        V { x: c[0][k], y: c[1][k], z: c[2][k] }
    }
    /// Dot product, summed x + y + z as glam does.
    #[inline(always)]
    pub fn dot(self, o: V) -> f32 {
        (self.x * o.x) + (self.y * o.y) + (self.z * o.z)
    }
    /// Cross product in glam's order: `(y·z' − y'·z, z·x' − z'·x, x·y' − x'·y)`.
    #[inline(always)]
    pub fn cross(self, o: V) -> V {
        V { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }
    /// Every component times `s`.
    #[inline(always)]
    pub fn scale(self, s: f32) -> V {
        V { x: self.x * s, y: self.y * s, z: self.z * s }
    }
    /// `self / |self|` as glam normalizes (times the reciprocal length).
    #[inline(always)]
    pub fn normalize(self) -> V {
        self.scale(1.0 / self.dot(self).sqrt())
    }
    /// `a` where `c`, else `b`.
    #[inline(always)]
    pub fn select(c: bool, a: V, b: V) -> V {
        V { x: if c { a.x } else { b.x }, y: if c { a.y } else { b.y }, z: if c { a.z } else { b.z } }
    }
    /// Writes `self` into lane `k` of `c`.
    #[inline(always)]
    pub fn store(self, c: &mut Lanes3, k: usize) {
        c[0][k] = self.x;
        c[1][k] = self.y;
        c[2][k] = self.z;
    }
}

impl std::ops::Div<f32> for V {
    type Output = V;
    #[inline(always)]
    fn div(self, s: f32) -> V {
        V { x: self.x / s, y: self.y / s, z: self.z / s }
    }
}

impl std::ops::Neg for V {
    type Output = V;
    #[inline(always)]
    fn neg(self) -> V {
        V { x: -self.x, y: -self.y, z: -self.z }
    }
}

impl std::ops::Add<V> for V {
    type Output = V;
    #[inline(always)]
    fn add(self, o: V) -> V {
        V { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl std::ops::Sub<V> for V {
    type Output = V;
    #[inline(always)]
    fn sub(self, o: V) -> V {
        V { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl std::ops::Mul<V> for V {
    type Output = V;
    #[inline(always)]
    fn mul(self, o: V) -> V {
        V { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturating_i32_equals_the_cast() {
        let mut x = 3u32;
        let mut specials = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            255.9,
            -256.0,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            2_147_483_520.0,
            2_147_483_648.0,
            -2_147_483_648.0,
            -2_147_483_904.0,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
        ];
        for _ in 0..100_000 {
            // xorshift32: any spread of bit patterns will do.
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            specials.push(f32::from_bits(x));
        }
        for v in specials {
            assert_eq!(saturating_i32(v), v as i32, "{v} ({:#x})", v.to_bits());
        }
    }
}

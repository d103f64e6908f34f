//! The eight-lane toolkit the render and texture kernels share.
//!
//! A lane kernel works on [`LANES`] items at once, one item per lane of an AVX2 register: its data
//! are columns ([`Lanes`], [`Lanes3`]) that the compiler keeps in `ymm` registers, and its body is
//! written once, per lane, so the scalar reference and the lanes compute the same IEEE operations.
//! Every kernel in the workspace uses this one width and these types, so a column filled by one
//! kernel is the input of the next without a transpose.

#![deny(missing_docs)]

/// Items per lane group: eight `f32`s fill one AVX2 register.
pub const LANES: usize = 8;

/// One `f32` per lane.
pub type Lanes = [f32; LANES];

/// A vector of three components, each a column of lanes (structure of arrays).
pub type Lanes3 = [Lanes; 3];

/// One `u32` per lane.
pub type U32Lanes = [u32; LANES];

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
    /// Every component times `s`.
    #[inline(always)]
    pub fn scale(self, s: f32) -> V {
        V { x: self.x * s, y: self.y * s, z: self.z * s }
    }
    /// Every component divided by `s`.
    #[inline(always)]
    pub fn div(self, s: f32) -> V {
        V { x: self.x / s, y: self.y / s, z: self.z / s }
    }
    /// Component-wise sum.
    #[inline(always)]
    pub fn add(self, o: V) -> V {
        V { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
    /// Component-wise difference.
    #[inline(always)]
    pub fn sub(self, o: V) -> V {
        V { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
    /// Component-wise product.
    #[inline(always)]
    pub fn mul(self, o: V) -> V {
        V { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
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

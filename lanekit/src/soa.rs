//! Lane structs declared once: [`soa!`](crate::soa) turns the field list of a scalar work item into
//! its lane struct (one column per field) and the transposes between the two, as pbrt-v4's
//! `workitems.soa` and its `soac` generator do for the wavefront queues.
//!
//! A field's column is chosen by its scalar type through [`Lane`]: `f32` → [`Lanes`], `u32` →
//! [`U32Lanes`], `bool` → a `U32Lanes` mask (1 where true), `[f32; N]` → `[Lanes; N]` (so
//! `[f32; 3]` → [`Lanes3`]). A type of the caller's crate becomes a column by converting through
//! one of those (`glam::Vec3 as [f32; 3]`, which needs `From` both ways) or by implementing
//! [`Lane`] itself.

use crate::{Lanes, Lanes3, U32Lanes, LANES};

/// A scalar that has a lane column: what [`soa!`](crate::soa) stores for a field of this type.
pub trait Lane: Copy {
    /// [`LANES`] of `Self`, as the lane struct's field.
    type Column: Copy;
    /// The column with every lane zero (all bits 0): the generated `Default`.
    const ZERO: Self::Column;
    /// Writes `v` into lane `k` of `column`.
    fn put(column: &mut Self::Column, k: usize, v: Self);
    /// Lane `k` of `column`.
    fn take(column: &Self::Column, k: usize) -> Self;
}

/// The column of `T`: the type of a lane struct's field declared as `T`.
pub type Column<T> = <T as Lane>::Column;

impl Lane for f32 {
    type Column = Lanes;
    const ZERO: Lanes = [0.0; LANES];
    #[inline(always)]
    fn put(column: &mut Lanes, k: usize, v: f32) {
        column[k] = v;
    }
    #[inline(always)]
    fn take(column: &Lanes, k: usize) -> f32 {
        column[k]
    }
}

impl Lane for u32 {
    type Column = U32Lanes;
    const ZERO: U32Lanes = [0; LANES];
    #[inline(always)]
    fn put(column: &mut U32Lanes, k: usize, v: u32) {
        column[k] = v;
    }
    #[inline(always)]
    fn take(column: &U32Lanes, k: usize) -> u32 {
        column[k]
    }
}

/// A mask column: 1 where true, 0 where false; any non-zero lane reads back as true.
impl Lane for bool {
    type Column = U32Lanes;
    const ZERO: U32Lanes = [0; LANES];
    #[inline(always)]
    fn put(column: &mut U32Lanes, k: usize, v: bool) {
        column[k] = v as u32;
    }
    #[inline(always)]
    fn take(column: &U32Lanes, k: usize) -> bool {
        column[k] != 0
    }
}

/// `N` columns, one per component (structure of arrays): `[f32; 3]` is [`Lanes3`].
impl<const N: usize> Lane for [f32; N] {
    type Column = [Lanes; N];
    const ZERO: [Lanes; N] = [[0.0; LANES]; N];
    #[inline(always)]
    fn put(column: &mut [Lanes; N], k: usize, v: [f32; N]) {
        for (c, x) in column.iter_mut().zip(v) {
            c[k] = x;
        }
    }
    #[inline(always)]
    fn take(column: &[Lanes; N], k: usize) -> [f32; N] {
        std::array::from_fn(|c| column[c][k])
    }
}

const _: () = assert!(size_of::<Column<[f32; 3]>>() == size_of::<Lanes3>());

/// Declares a lane struct once, from its scalar item's fields, and derives the rest.
///
/// ```
/// lanekit::soa! {
///     /// Eight samples.
///     #[derive(Clone, Copy, Debug)]
///     #[repr(C, align(32))]
///     pub struct SampleLanes for struct Sample {
///         /// Direction.
///         pub wi: [f32; 3],
///         /// Density.
///         pub pdf: f32,
///         /// Whether the sample exists.
///         pub ok: bool,
///     }
/// }
/// let mut lanes = SampleLanes::default();
/// let s = Sample { wi: [0.0, 1.0, 0.0], pdf: 0.5, ok: true };
/// lanes.set(3, &s);
/// assert_eq!(lanes.get(3), s);
/// assert_eq!((lanes.wi[1][3], lanes.pdf[3], lanes.ok[3]), (1.0, 0.5, 1));
/// ```
///
/// Generates, from `$vis struct Lanes for … { $field: T, … }`:
/// - the lane struct: field `$field` of type [`Column<T>`](crate::Column) (`f32` → `[f32; LANES]`,
///   `[f32; 3]` → `Lanes3`, `bool` → a `u32` mask, …), with the field's docs and visibility, and the
///   attributes written before `struct` (derives, `repr`);
/// - `Default`, every column zero (so do not derive it);
/// - `set(k, &item)`, which writes `item` into lane `k`, and `get(k) -> item`, which reads it back.
///
/// The item is either generated (`for struct Item`: a struct with the same fields in their scalar
/// types, deriving `Clone, Copy, Debug, Default, PartialEq`) or an existing struct of the caller's
/// (`for Item`), whose fields must then be exactly these (a field added to one and not the other
/// does not compile). `$field: Outer as Inner` stores an `Outer` through `Inner`'s column
/// (`glam::Vec3 as [f32; 3]`), converting with `From` each way.
///
/// **Layout rule**: the columns are the fields in declaration order, each exactly its
/// `Column<T>` (`[T; LANES]` or `[[f32; LANES]; N]`), nothing inserted; with `#[repr(C)]` on the
/// declaration the memory layout is the one the same struct written by hand has, so converting a
/// hand-written lane struct keeps its layout (and the code the kernels compile to) as long as the
/// field order is kept.
#[macro_export]
macro_rules! soa {
    (
        $(#[$attr:meta])*
        $vis:vis struct $name:ident for struct $item:ident {
            $($(#[$fattr:meta])* $fvis:vis $field:ident : $ty:ty $(as $repr:ty)?),* $(,)?
        }
    ) => {
        #[doc = concat!("One lane of [`", stringify!($name), "`].")]
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        $vis struct $item {
            $($(#[$fattr])* $fvis $field: $ty,)*
        }
        $crate::soa! {
            $(#[$attr])*
            $vis struct $name for $item {
                $($(#[$fattr])* $fvis $field: $ty $(as $repr)?,)*
            }
        }
    };
    (
        $(#[$attr:meta])*
        $vis:vis struct $name:ident for $item:ident {
            $($(#[$fattr:meta])* $fvis:vis $field:ident : $ty:ty $(as $repr:ty)?),* $(,)?
        }
    ) => {
        $(#[$attr])*
        $vis struct $name {
            $($(#[$fattr])* $fvis $field: $crate::Column<$crate::soa!(@repr $ty $(, $repr)?)>,)*
        }

        impl Default for $name {
            #[inline]
            fn default() -> Self {
                $name { $($field: <$crate::soa!(@repr $ty $(, $repr)?) as $crate::Lane>::ZERO,)* }
            }
        }

        #[allow(dead_code)]
        impl $name {
            #[doc = concat!("Writes `item` into lane `k` (`k < LANES`).")]
            #[inline(always)]
            $vis fn set(&mut self, k: usize, item: &$item) {
                $(<$crate::soa!(@repr $ty $(, $repr)?) as $crate::Lane>::put(
                    &mut self.$field,
                    k,
                    <$crate::soa!(@repr $ty $(, $repr)?)>::from(item.$field),
                );)*
            }

            #[doc = concat!("Lane `k` (what [`", stringify!($name), "::set`] wrote there).")]
            #[inline(always)]
            $vis fn get(&self, k: usize) -> $item {
                $item {
                    $($field: <$ty>::from(
                        <$crate::soa!(@repr $ty $(, $repr)?) as $crate::Lane>::take(&self.$field, k),
                    ),)*
                }
            }
        }
    };
    (@repr $ty:ty) => { $ty };
    (@repr $ty:ty, $repr:ty) => { $repr };
}

#[cfg(test)]
mod tests {
    use crate::{Lanes, Lanes3, U32Lanes, LANES};

    /// A type of "another crate" stored through `[f32; 3]`, as render stores `glam::Vec3`.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    struct P(f32, f32, f32);
    impl From<P> for [f32; 3] {
        fn from(p: P) -> Self {
            [p.0, p.1, p.2]
        }
    }
    impl From<[f32; 3]> for P {
        fn from(a: [f32; 3]) -> Self {
            P(a[0], a[1], a[2])
        }
    }

    crate::soa! {
        /// Every kind of field.
        #[derive(Clone, Copy, Debug)]
        #[repr(C, align(32))]
        struct Mixed for struct Item {
            /// A vector.
            v: [f32; 3],
            x: f32,
            n: u32,
            flag: bool,
            uv: [f32; 2],
            p: P as [f32; 3],
        }
    }

    /// What the macro must generate, written out: the layout it must keep.
    #[allow(dead_code)]
    #[repr(C, align(32))]
    struct ByHand {
        v: Lanes3,
        x: Lanes,
        n: U32Lanes,
        flag: U32Lanes,
        uv: [Lanes; 2],
        p: Lanes3,
    }

    #[derive(Clone, Copy, Debug, PartialEq)]
    struct Existing {
        a: f32,
        b: u32,
    }
    crate::soa! {
        #[derive(Clone, Copy)]
        struct ExistingLanes for Existing {
            a: f32,
            b: u32,
        }
    }

    fn item(k: usize) -> Item {
        let f = k as f32;
        Item {
            v: [f, -f, f * 0.5],
            x: f32::from_bits(0x7fc0_0001 + k as u32), // a NaN payload must survive
            n: u32::MAX - k as u32,
            flag: k.is_multiple_of(3),
            uv: [f + 0.25, f - 0.25],
            p: P(f, 2.0 * f, -0.0),
        }
    }

    #[test]
    fn set_then_get_round_trips_every_lane_bit_for_bit() {
        let mut lanes = Mixed::default();
        for k in 0..LANES {
            lanes.set(k, &item(k));
        }
        for k in 0..LANES {
            let (got, want) = (lanes.get(k), item(k));
            assert_eq!(got.x.to_bits(), want.x.to_bits(), "lane {k}");
            assert_eq!(Item { x: 0.0, ..got }, Item { x: 0.0, ..want }, "lane {k}");
        }
        // Columns hold what `set` wrote, lane by lane.
        assert_eq!(lanes.v[1][5], -5.0);
        assert_eq!(lanes.flag, [1, 0, 0, 1, 0, 0, 1, 0]);
        assert_eq!(lanes.uv[0][2], 2.25);
        assert_eq!(lanes.p[1][4], 8.0);
        let mut e = ExistingLanes::default();
        e.set(7, &Existing { a: 1.5, b: 9 });
        assert_eq!(e.get(7), Existing { a: 1.5, b: 9 });
        assert_eq!((e.a[7], e.b[7]), (1.5, 9));
    }

    #[test]
    fn default_is_all_zero_bits_and_set_touches_one_lane() {
        let zero = Mixed::default();
        for k in 0..LANES {
            assert_eq!(zero.get(k), Item::default());
        }
        let bytes = |m: &Mixed| {
            // SAFETY: `Mixed` is `repr(C)` of `f32`/`u32` arrays only: no padding, every byte initialised.
            unsafe { std::slice::from_raw_parts(m as *const Mixed as *const u8, size_of::<Mixed>()) }.to_vec()
        };
        assert!(bytes(&zero).iter().all(|&b| b == 0));
        let mut one = zero;
        one.set(2, &item(2));
        for k in (0..LANES).filter(|&k| k != 2) {
            assert_eq!(one.get(k), Item::default(), "lane {k} untouched");
        }
    }

    #[test]
    fn layout_is_the_hand_written_one() {
        use std::mem::offset_of;
        assert_eq!((size_of::<Mixed>(), align_of::<Mixed>()), (size_of::<ByHand>(), align_of::<ByHand>()));
        assert_eq!(
            [offset_of!(Mixed, v), offset_of!(Mixed, x), offset_of!(Mixed, n)],
            [offset_of!(ByHand, v), offset_of!(ByHand, x), offset_of!(ByHand, n)]
        );
        assert_eq!(
            [offset_of!(Mixed, flag), offset_of!(Mixed, uv), offset_of!(Mixed, p)],
            [offset_of!(ByHand, flag), offset_of!(ByHand, uv), offset_of!(ByHand, p)]
        );
    }
}

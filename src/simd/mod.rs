//! Lane abstraction: the one module that names `wide`.
//!
//! The triangle test, the slab test and the kd-tree interval arithmetic are
//! written once, generic over [`Lane`]. The scalar path runs them with
//! `f32` (one lane), the packet path with [`F4`] (four lanes) or [`F8`]
//! (eight). Every operation used is an exact IEEE-754 operation (`+ - * /`, compares,
//! selects), so a lane of the packet computes bit for bit what the scalar
//! path computes for that ray. No fused multiply-add, no approximate
//! reciprocal (`rcpps`).

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

mod f8;
pub use f8::{F8, M8, U8};

/// Four `f32` lanes (SSE on the default x86-64 target, wider ISAs with
/// `-C target-cpu=native`).
pub type F4 = wide::f32x4;

/// A value computed for every lane of a ray packet: `f32` (1 lane) or
/// [`F4`] (4 lanes).
///
/// Comparisons return a [`Lane::Mask`]; `select` picks per lane. The
/// `*_keep` helpers are the crate's NaN policy in one place: they keep the
/// left operand when the right one is NaN, which turns the `0 * inf` of a
/// ray lying in a plane into "unconstrained" instead of "miss".
///
/// ```
/// use packtrace::simd::{Lane, F4};
/// let a = F4::from([1.0, 2.0, 5.0, 4.0]);
/// let b = F4::from([3.0, f32::NAN, 3.0, f32::NAN]);
/// // a NaN on the right is ignored: the left operand is kept
/// assert_eq!(a.max_keep(b).to_array(), [3.0, 2.0, 5.0, 4.0]);
/// assert_eq!(Lane::max_keep(3.0f32, f32::NAN), 3.0);
/// ```
pub trait Lane:
    'static
    + Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + std::fmt::Debug
    + PartialEq
{
    /// Per-lane boolean.
    type Mask: Copy
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>
        + Not<Output = Self::Mask>
        + std::fmt::Debug;
    /// Number of lanes.
    const WIDTH: usize;
    /// Every lane set to `x`.
    fn splat(x: f32) -> Self;
    /// `self < o` per lane (false if either is NaN).
    fn lt(self, o: Self) -> Self::Mask;
    /// `self <= o` per lane.
    fn le(self, o: Self) -> Self::Mask;
    /// `self > o` per lane.
    fn gt(self, o: Self) -> Self::Mask;
    /// `self == o` per lane.
    fn eq(self, o: Self) -> Self::Mask;
    /// Per lane: `if m { a } else { b }`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Is any lane of the mask set?
    fn any(m: Self::Mask) -> bool;
    /// Bit `i` set when lane `i` of the mask is set.
    fn bits(m: Self::Mask) -> u32;
    /// Lane `i` as `f32`.
    fn lane(self, i: usize) -> f32;
    /// Copy with lane `i` replaced by `x`.
    fn with_lane(self, i: usize, x: f32) -> Self;
    /// Mask with lane `i` set iff bit `i` of `bits` is set.
    fn mask_from_bits(bits: u32) -> Self::Mask;
    /// Lane `i` set to `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    /// Bit `i` set when lane `i` has its sign bit set (`-0.0` and
    /// negative NaNs included): the scalar path's `is_sign_negative`.
    fn sign_bits(self) -> u32;

    /// Per-lane `u32` (triangle indices of a packet's hits).
    type Index: Copy + PartialEq + std::fmt::Debug;
    /// Every index lane set to `x`.
    fn index_splat(x: u32) -> Self::Index;
    /// Per lane `a < b` (unsigned).
    fn index_lt(a: Self::Index, b: Self::Index) -> Self::Mask;
    /// Per lane: `if m { a } else { b }` for index lanes.
    fn index_select(m: Self::Mask, a: Self::Index, b: Self::Index) -> Self::Index;
    /// Index lane `i`.
    fn index_lane(x: Self::Index, i: usize) -> u32;
    /// Copy with index lane `i` replaced by `x`.
    fn index_with_lane(v: Self::Index, i: usize, x: u32) -> Self::Index;

    /// `max(self, o)`, keeping `self` when `o` is NaN (or both are equal).
    #[inline(always)]
    fn max_keep(self, o: Self) -> Self {
        Self::select(o.gt(self), o, self)
    }
    /// `min(self, o)`, keeping `self` when `o` is NaN (or both are equal).
    #[inline(always)]
    fn min_keep(self, o: Self) -> Self {
        Self::select(o.lt(self), o, self)
    }
}

impl Lane for f32 {
    type Mask = bool;
    const WIDTH: usize = 1;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn lt(self, o: Self) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: Self) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn eq(self, o: Self) -> bool {
        self == o
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m { a } else { b }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn any(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn bits(m: bool) -> u32 {
        m as u32
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> f32 {
        self
    }
    #[inline(always)]
    fn with_lane(self, _i: usize, x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn mask_from_bits(bits: u32) -> bool {
        bits & 1 != 0
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        f(0)
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        self.is_sign_negative() as u32
    }
    type Index = u32;
    #[inline(always)]
    fn index_splat(x: u32) -> u32 {
        x
    }
    #[inline(always)]
    fn index_lt(a: u32, b: u32) -> bool {
        a < b
    }
    #[inline(always)]
    fn index_select(m: bool, a: u32, b: u32) -> u32 {
        if m { a } else { b }
    }
    #[inline(always)]
    fn index_lane(x: u32, _i: usize) -> u32 {
        x
    }
    #[inline(always)]
    fn index_with_lane(_v: u32, _i: usize, x: u32) -> u32 {
        x
    }
}

impl Lane for F4 {
    type Mask = F4;
    const WIDTH: usize = 4;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        F4::splat(x)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> F4 {
        self.simd_lt(o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> F4 {
        self.simd_le(o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> F4 {
        self.simd_gt(o)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> F4 {
        self.simd_eq(o)
    }
    #[inline(always)]
    fn select(m: F4, a: Self, b: Self) -> Self {
        m.select(a, b)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F4::abs(self)
    }
    #[inline(always)]
    fn any(m: F4) -> bool {
        m.any()
    }
    #[inline(always)]
    fn bits(m: F4) -> u32 {
        m.to_bitmask()
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.as_array()[i]
    }
    #[inline(always)]
    fn with_lane(self, i: usize, x: f32) -> Self {
        let mut a = self.to_array();
        a[i] = x;
        F4::from(a)
    }
    // `minps a, b` is `a < b ? a : b`, and `maxps a, b` is `a > b ? a : b`:
    // with the operands swapped they are exactly the `*_keep` rule, in one
    // instruction instead of a compare and a three-instruction SSE2 blend.
    #[cfg(target_feature = "sse")]
    #[inline(always)]
    fn max_keep(self, o: Self) -> Self {
        o.fast_max(self)
    }
    #[cfg(target_feature = "sse")]
    #[inline(always)]
    fn min_keep(self, o: Self) -> Self {
        o.fast_min(self)
    }
    #[inline(always)]
    fn mask_from_bits(bits: u32) -> F4 {
        let on = f32::from_bits(u32::MAX);
        F4::from([
            if bits & 1 != 0 { on } else { 0.0 },
            if bits & 2 != 0 { on } else { 0.0 },
            if bits & 4 != 0 { on } else { 0.0 },
            if bits & 8 != 0 { on } else { 0.0 },
        ])
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        F4::from(std::array::from_fn::<f32, 4, _>(f))
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        self.to_bitmask()
    }
    type Index = U4;
    #[inline(always)]
    fn index_splat(x: u32) -> U4 {
        U4::splat(x)
    }
    #[inline(always)]
    fn index_lt(a: U4, b: U4) -> F4 {
        lt_u4(a, b)
    }
    #[inline(always)]
    fn index_select(m: F4, a: U4, b: U4) -> U4 {
        select_u4(m, a, b)
    }
    #[inline(always)]
    fn index_lane(x: U4, i: usize) -> u32 {
        x.as_array()[i]
    }
    #[inline(always)]
    fn index_with_lane(v: U4, i: usize, x: u32) -> U4 {
        let mut a = v.to_array();
        a[i] = x;
        U4::from(a)
    }
}

/// Four `u32` lanes (triangle indices of a packet's hits).
pub type U4 = wide::u32x4;

/// The indices of the set bits of `m`, lowest first (lanes of a mask,
/// packets of a group).
#[inline(always)]
pub(crate) fn set_bits(mut m: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            i
        })
    })
}

/// Per lane `a < b` (unsigned) as an [`F4`] mask.
#[inline(always)]
pub(crate) fn lt_u4(a: U4, b: U4) -> F4 {
    F4::from_bits(a.simd_lt(b))
}

/// Per lane: `if m { a } else { b }` for index lanes.
#[inline(always)]
pub(crate) fn select_u4(m: F4, a: U4, b: U4) -> U4 {
    m.select(a, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keep_helpers_ignore_nan_on_the_right_only() {
        assert_eq!(1.0f32.max_keep(f32::NAN), 1.0);
        assert_eq!(1.0f32.min_keep(f32::NAN), 1.0);
        assert!(f32::NAN.max_keep(1.0).is_nan());
        let a = F4::from([1.0, -1.0, 0.0, f32::INFINITY]);
        let b = F4::from([f32::NAN, 2.0, -0.0, 3.0]);
        assert_eq!(a.max_keep(b).to_array(), [1.0, 2.0, 0.0, f32::INFINITY]);
        assert_eq!(a.min_keep(b).to_array(), [1.0, -1.0, 0.0, 3.0]);
        // Lane by lane equal to the scalar rule, signed zeros included.
        let (mx, mn) = (a.max_keep(b).to_array(), a.min_keep(b).to_array());
        for (i, (x, y)) in a.to_array().into_iter().zip(b.to_array()).enumerate() {
            assert_eq!(mx[i].to_bits(), x.max_keep(y).to_bits());
            assert_eq!(mn[i].to_bits(), x.min_keep(y).to_bits());
        }
    }

    #[test]
    fn mask_bits_round_trip() {
        for bits in 0..16u32 {
            assert_eq!(<F4 as Lane>::bits(F4::mask_from_bits(bits)), bits);
        }
        assert!(<f32 as Lane>::mask_from_bits(1));
        assert!(!<f32 as Lane>::mask_from_bits(0));
    }
}

#[cfg(test)]
mod u4_tests {
    use super::*;

    #[test]
    fn select_and_compare_index_lanes() {
        let m = F4::mask_from_bits(0b0101);
        let r = select_u4(m, U4::splat(7), U4::splat(u32::MAX));
        assert_eq!(r.to_array(), [7, u32::MAX, 7, u32::MAX]);
        let lt = lt_u4(U4::splat(5), U4::from([u32::MAX, 3, 5, 6]));
        assert_eq!(<F4 as Lane>::bits(lt), 0b1001);
    }
}

//! Eight `f32` lanes as a plain aligned array, written so that LLVM turns
//! every operation into one AVX instruction inside a kernel compiled with
//! `#[target_feature(enable = "avx2")]` (`kdtree/kernel.rs`), and into two
//! SSE instructions everywhere else. No intrinsics, so no `unsafe`: the
//! same source is the AVX2 and the SSE kernel, chosen at run time.
//!
//! Why not `wide::f32x8`: `wide` picks its representation when it is
//! compiled (`cfg(target_feature = "avx")`), so in a default build it is
//! two `f32x4` halves even inside an AVX2 kernel, and LLVM does not fuse
//! the halves (measured on the node step: 2 x 11 SSE instructions against
//! 11 AVX ones for this type). The mask-to-bits step borrows `wide`'s
//! `movmskps`, which LLVM does fuse into one `vmovmskps ymm`.
//!
//! Every operation is the exact IEEE operation lane by lane, as the
//! scalar path performs it, so a lane equals the scalar result bit for bit.

use super::Lane;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

/// Eight `f32` lanes (AVX in the AVX2 kernel, two SSE halves otherwise).
///
/// ```
/// use packtrace::simd::{F8, Lane};
/// let a = F8::from([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
/// let b = F8::splat(4.5);
/// assert_eq!(<F8 as Lane>::bits(a.lt(b)), 0b0000_1111);
/// assert_eq!((a * b).to_array()[7], 36.0);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct F8([f32; 8]);

/// A per-lane mask of [`F8`]: all ones or all zeros per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct M8([u32; 8]);

/// Eight `u32` lanes (triangle indices of an 8-wide packet's hits).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct U8([u32; 8]);

impl From<[f32; 8]> for F8 {
    #[inline(always)]
    fn from(a: [f32; 8]) -> F8 {
        F8(a)
    }
}

impl F8 {
    /// Every lane set to `x`.
    #[inline(always)]
    #[must_use]
    pub fn splat(x: f32) -> F8 {
        F8([x; 8])
    }
    /// The lanes as an array.
    #[inline(always)]
    #[must_use]
    pub fn to_array(self) -> [f32; 8] {
        self.0
    }
    #[inline(always)]
    fn zip(self, o: F8, f: impl Fn(f32, f32) -> f32) -> F8 {
        F8(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }
    #[inline(always)]
    fn cmp(self, o: F8, f: impl Fn(f32, f32) -> bool) -> M8 {
        M8(std::array::from_fn(|i| {
            if f(self.0[i], o.0[i]) { u32::MAX } else { 0 }
        }))
    }
}

impl From<[u32; 8]> for U8 {
    #[inline(always)]
    fn from(a: [u32; 8]) -> U8 {
        U8(a)
    }
}

impl U8 {
    /// The lanes as an array.
    #[inline(always)]
    #[must_use]
    pub fn to_array(self) -> [u32; 8] {
        self.0
    }
}

impl Add for F8 {
    type Output = F8;
    #[inline(always)]
    fn add(self, o: F8) -> F8 {
        self.zip(o, |a, b| a + b)
    }
}
impl Sub for F8 {
    type Output = F8;
    #[inline(always)]
    fn sub(self, o: F8) -> F8 {
        self.zip(o, |a, b| a - b)
    }
}
impl Mul for F8 {
    type Output = F8;
    #[inline(always)]
    fn mul(self, o: F8) -> F8 {
        self.zip(o, |a, b| a * b)
    }
}
impl Div for F8 {
    type Output = F8;
    #[inline(always)]
    fn div(self, o: F8) -> F8 {
        self.zip(o, |a, b| a / b)
    }
}
impl BitAnd for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitand(self, o: M8) -> M8 {
        M8(std::array::from_fn(|i| self.0[i] & o.0[i]))
    }
}
impl BitOr for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitor(self, o: M8) -> M8 {
        M8(std::array::from_fn(|i| self.0[i] | o.0[i]))
    }
}
impl Not for M8 {
    type Output = M8;
    #[inline(always)]
    fn not(self) -> M8 {
        M8(self.0.map(|x| !x))
    }
}

impl Lane for F8 {
    type Mask = M8;
    const WIDTH: usize = 8;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        F8::splat(x)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> M8 {
        self.cmp(o, |a, b| a < b)
    }
    #[inline(always)]
    fn le(self, o: Self) -> M8 {
        self.cmp(o, |a, b| a <= b)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> M8 {
        self.cmp(o, |a, b| a > b)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> M8 {
        self.cmp(o, |a, b| a == b)
    }
    #[inline(always)]
    fn select(m: M8, a: Self, b: Self) -> Self {
        F8(std::array::from_fn(|i| {
            f32::from_bits((m.0[i] & a.0[i].to_bits()) | (!m.0[i] & b.0[i].to_bits()))
        }))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F8(self.0.map(f32::abs))
    }
    // An OR over the lanes: one `vtestps` (AVX2) or `kortestb` (AVX-512)
    // inside the kernels. Through `bits` it was a move-mask of two halves
    // joined by a shift and an OR on the node step's critical path (27 %
    // slower kernel on Sponza primary rays than a native build).
    #[inline(always)]
    fn any(m: M8) -> bool {
        m.0.iter().fold(0, |a, &x| a | x) != 0
    }
    #[inline(always)]
    fn bits(m: M8) -> u32 {
        // `movmskps` per half, fused into one `vmovmskps ymm` under AVX.
        wide::f32x8::from(m.0.map(f32::from_bits)).to_bitmask()
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.0[i]
    }
    #[inline(always)]
    fn with_lane(mut self, i: usize, x: f32) -> Self {
        self.0[i] = x;
        self
    }
    #[inline(always)]
    fn mask_from_bits(bits: u32) -> M8 {
        // Bit `i` splat, AND-ed with lane `i`'s bit and compared: a vector
        // AND and compare. Shifting by the lane index was scalar code whose
        // four-byte stores the next vector load could not forward from.
        const BIT: [u32; 8] = [1, 2, 4, 8, 16, 32, 64, 128];
        M8(std::array::from_fn(|i| {
            if bits & BIT[i] == BIT[i] { u32::MAX } else { 0 }
        }))
    }
    // Written as `minps`/`maxps` compute them (`a < b ? a : b`), so each
    // is one instruction.
    #[inline(always)]
    fn max_keep(self, o: Self) -> Self {
        self.zip(o, |s, o| if o > s { o } else { s })
    }
    #[inline(always)]
    fn min_keep(self, o: Self) -> Self {
        self.zip(o, |s, o| if o < s { o } else { s })
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        F8(std::array::from_fn(f))
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        wide::f32x8::from(self.0).to_bitmask()
    }
    type Index = U8;
    #[inline(always)]
    fn index_splat(x: u32) -> U8 {
        U8([x; 8])
    }
    #[inline(always)]
    fn index_lt(a: U8, b: U8) -> M8 {
        M8(std::array::from_fn(|i| {
            if a.0[i] < b.0[i] { u32::MAX } else { 0 }
        }))
    }
    #[inline(always)]
    fn index_select(m: M8, a: U8, b: U8) -> U8 {
        U8(std::array::from_fn(|i| {
            (m.0[i] & a.0[i]) | (!m.0[i] & b.0[i])
        }))
    }
    #[inline(always)]
    fn index_lane(x: U8, i: usize) -> u32 {
        x.0[i]
    }
    #[inline(always)]
    fn index_with_lane(mut v: U8, i: usize, x: u32) -> U8 {
        v.0[i] = x;
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every F8 operation equals the scalar operation lane by lane, bit for
    /// bit, on infinities and signed zeros; a NaN result is a NaN on both
    /// sides (which NaN the hardware returns depends on operand order,
    /// which LLVM may commute; no traversal decision reads a NaN's bits).
    #[test]
    fn f8_equals_scalar_lane_by_lane() {
        let v = [
            0.0f32,
            -0.0,
            1.0,
            -1.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            3.0e-39,
        ];
        for r in 0..8 {
            let a = F8::from(v);
            let b = F8::from(std::array::from_fn(|i| v[(i + r) % 8]));
            let (x, y) = (a.to_array(), b.to_array());
            let eqb = |f: F8, g: &dyn Fn(f32, f32) -> f32| {
                for i in 0..8 {
                    let (got, want) = (f.lane(i), g(x[i], y[i]));
                    if want.is_nan() {
                        assert!(got.is_nan(), "lane {i}");
                    } else {
                        assert_eq!(got.to_bits(), want.to_bits(), "lane {i}");
                    }
                }
            };
            eqb(a + b, &|p, q| p + q);
            eqb(a - b, &|p, q| p - q);
            eqb(a * b, &|p, q| p * q);
            eqb(a / b, &|p, q| p / q);
            eqb(a.max_keep(b), &|p, q| p.max_keep(q));
            eqb(a.min_keep(b), &|p, q| p.min_keep(q));
            eqb(a.abs(), &|p, _| p.abs());
            let m = a.lt(b);
            eqb(F8::select(m, a, b), &|p, q| if p < q { p } else { q });
            let want = (0..8).fold(0, |acc, i| acc | ((x[i] < y[i]) as u32) << i);
            assert_eq!(F8::bits(m), want);
            let want_le = (0..8).fold(0, |acc, i| acc | ((x[i] <= y[i]) as u32) << i);
            assert_eq!(F8::bits(a.le(b)), want_le);
            assert_eq!(F8::bits(!a.le(b)), !want_le & 0xFF);
            assert_eq!(F8::bits(a.le(b) & a.lt(b)), want_le & want);
            assert_eq!(F8::bits(a.eq(b) | a.gt(b)), {
                (0..8).fold(0, |acc, i| acc | ((x[i] >= y[i]) as u32) << i)
            });
        }
        for bits in 0..256 {
            assert_eq!(F8::bits(F8::mask_from_bits(bits)), bits);
            assert_eq!(F8::any(F8::mask_from_bits(bits)), bits != 0);
        }
        let i = F8::index_select(
            F8::mask_from_bits(0b1010_0101),
            F8::index_splat(7),
            U8(std::array::from_fn(|i| i as u32)),
        );
        assert_eq!(i.to_array(), [7, 1, 7, 3, 4, 7, 6, 7]);
        assert_eq!(F8::bits(F8::index_lt(i, F8::index_splat(5))), 0b0001_1010);
        assert_eq!(F8::index_lane(F8::index_with_lane(i, 2, 9), 2), 9);
    }
}

//! [`A8`]: eight `f32` lanes in one AVX register, every operation one
//! intrinsic, for the stream kernels' leaves (`kdtree/stream/leaf.rs`).
//!
//! Why not [`crate::simd::F8`] there: `F8` is a plain array whose
//! element-wise loops LLVM's SLP vectoriser packs into vectors, and inside
//! the stream kernels it packed most of the triangle test into pairs of
//! 128-bit operations (callgrind, avx2 kernel, bunny ao rays at 1024 x
//! 1024: 86 `vsubps xmm` against 4 `vsubps ymm` in the closest-hit
//! kernel, the F8 subtractions alone 13 % of its instructions), the
//! fragility the packet kernels met before `kernel::Given`. Here every
//! operation is written as the instruction it is, so the register width
//! no longer depends on the vectoriser.
//!
//! Every operation is the exact IEEE operation lane by lane (no FMA, no
//! approximate reciprocal), so a lane equals the scalar path bit for bit,
//! as `F8`'s lanes do (tested against `F8` below).
//!
//! # Where it may be used
//! Executing an AVX2 instruction on a CPU without AVX2 is undefined
//! behaviour, and this type's methods are AVX2 instructions. So `A8` is
//! named only inside this module and, through the AVX2 and AVX-512
//! stream forms (`partition::Avx2::Lanes`, `partition::Avx512::Lanes`),
//! only by code those forms run: a form exists only after
//! `is_x86_feature_detected!("avx2")` said yes (`partition::Avx2::detect`),
//! and the stream kernels that use it are compiled with AVX2 enabled.
//! That is the invariant every `// SAFETY:` comment below relies on.

#![cfg(target_arch = "x86_64")]

use crate::simd::Lane;
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

/// Eight `f32` lanes in an AVX register (see the module docs for where it
/// may be used).
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct A8(__m256);

/// A per-lane mask of [`A8`]: all ones or all zeros per lane.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct A8Mask(__m256);

/// Eight `u32` lanes (triangle indices of the hits).
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct A8Index(__m256i);

impl A8 {
    /// Loads eight lanes from `a`.
    #[inline(always)]
    pub(crate) fn from_array(a: [f32; 8]) -> A8 {
        // SAFETY: AVX2 runs here (module docs); `a` is eight `f32`.
        A8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
    }

    /// The lanes as an array.
    #[inline(always)]
    pub(crate) fn to_array(self) -> [f32; 8] {
        let mut a = [0.0f32; 8];
        // SAFETY: AVX2 runs here (module docs); `a` has room for eight.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }

    /// The register (for the stream forms' gathers).
    #[inline(always)]
    pub(crate) fn from_raw(v: __m256) -> A8 {
        A8(v)
    }
}

impl A8Index {
    /// The register (for the stream forms' gathers).
    #[inline(always)]
    pub(crate) fn from_raw(v: __m256i) -> A8Index {
        A8Index(v)
    }

    #[inline(always)]
    fn to_array(self) -> [u32; 8] {
        let mut a = [0u32; 8];
        // SAFETY: AVX2 runs here (module docs); `a` has room for eight.
        unsafe { _mm256_storeu_si256(a.as_mut_ptr().cast(), self.0) };
        a
    }

    #[inline(always)]
    fn from_array(a: [u32; 8]) -> A8Index {
        // SAFETY: AVX2 runs here (module docs); `a` is eight `u32`.
        A8Index(unsafe { _mm256_loadu_si256(a.as_ptr().cast()) })
    }
}

impl PartialEq for A8Index {
    #[inline(always)]
    fn eq(&self, o: &A8Index) -> bool {
        self.to_array() == o.to_array()
    }
}

impl PartialEq for A8 {
    /// Every lane equal as `f32` (NaN unequal), as `F8`'s derived `==`.
    #[inline(always)]
    fn eq(&self, o: &A8) -> bool {
        // SAFETY: AVX2 runs here (module docs).
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0)) == 0xFF }
    }
}

macro_rules! binary {
    ($trait:ident, $method:ident, $intrinsic:ident) => {
        impl $trait for A8 {
            type Output = A8;
            #[inline(always)]
            fn $method(self, o: A8) -> A8 {
                // SAFETY: AVX2 runs here (module docs).
                A8(unsafe { $intrinsic(self.0, o.0) })
            }
        }
    };
}
binary!(Add, add, _mm256_add_ps);
binary!(Sub, sub, _mm256_sub_ps);
binary!(Mul, mul, _mm256_mul_ps);
binary!(Div, div, _mm256_div_ps);

impl BitAnd for A8Mask {
    type Output = A8Mask;
    #[inline(always)]
    fn bitand(self, o: A8Mask) -> A8Mask {
        // SAFETY: AVX2 runs here (module docs).
        A8Mask(unsafe { _mm256_and_ps(self.0, o.0) })
    }
}

impl BitOr for A8Mask {
    type Output = A8Mask;
    #[inline(always)]
    fn bitor(self, o: A8Mask) -> A8Mask {
        // SAFETY: AVX2 runs here (module docs).
        A8Mask(unsafe { _mm256_or_ps(self.0, o.0) })
    }
}

impl Not for A8Mask {
    type Output = A8Mask;
    #[inline(always)]
    fn not(self) -> A8Mask {
        // SAFETY: AVX2 runs here (module docs).
        A8Mask(unsafe { _mm256_xor_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(-1))) })
    }
}

impl Lane for A8 {
    type Mask = A8Mask;
    const WIDTH: usize = 8;

    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: AVX2 runs here (module docs).
        A8(unsafe { _mm256_set1_ps(x) })
    }
    #[inline(always)]
    fn lt(self, o: Self) -> A8Mask {
        // SAFETY: AVX2 runs here (module docs). Ordered: false on NaN.
        A8Mask(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn le(self, o: Self) -> A8Mask {
        // SAFETY: as in `lt`.
        A8Mask(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn gt(self, o: Self) -> A8Mask {
        // SAFETY: as in `lt`.
        A8Mask(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn eq(self, o: Self) -> A8Mask {
        // SAFETY: as in `lt`.
        A8Mask(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn select(m: A8Mask, a: Self, b: Self) -> Self {
        // SAFETY: AVX2 runs here (module docs). A mask lane is all ones or
        // all zeros, so `blendv` (which reads its sign bit) picks as the
        // bitwise select does.
        A8(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // SAFETY: AVX2 runs here (module docs).
        A8(unsafe { _mm256_and_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX))) })
    }
    #[inline(always)]
    fn any(m: A8Mask) -> bool {
        // SAFETY: AVX2 runs here (module docs).
        unsafe { _mm256_movemask_ps(m.0) != 0 }
    }
    #[inline(always)]
    fn bits(m: A8Mask) -> u32 {
        // SAFETY: AVX2 runs here (module docs).
        unsafe { _mm256_movemask_ps(m.0) as u32 }
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.to_array()[i]
    }
    #[inline(always)]
    fn with_lane(self, i: usize, x: f32) -> Self {
        let mut a = self.to_array();
        a[i] = x;
        A8::from_array(a)
    }
    #[inline(always)]
    fn mask_from_bits(bits: u32) -> A8Mask {
        // SAFETY: AVX2 runs here (module docs).
        A8Mask(unsafe {
            let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let b = _mm256_and_si256(_mm256_set1_epi32(bits as i32), bit);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(b, bit))
        })
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        let mut a = [0.0f32; 8];
        for (i, x) in a.iter_mut().enumerate() {
            *x = f(i);
        }
        A8::from_array(a)
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        // SAFETY: AVX2 runs here (module docs).
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }
    // `maxps(o, s)` is `o > s ? o : s`: the `*_keep` rule in one
    // instruction (as `F8`'s).
    #[inline(always)]
    fn max_keep(self, o: Self) -> Self {
        // SAFETY: AVX2 runs here (module docs).
        A8(unsafe { _mm256_max_ps(o.0, self.0) })
    }
    #[inline(always)]
    fn min_keep(self, o: Self) -> Self {
        // SAFETY: AVX2 runs here (module docs).
        A8(unsafe { _mm256_min_ps(o.0, self.0) })
    }

    type Index = A8Index;
    #[inline(always)]
    fn index_splat(x: u32) -> A8Index {
        // SAFETY: AVX2 runs here (module docs).
        A8Index(unsafe { _mm256_set1_epi32(x as i32) })
    }
    #[inline(always)]
    fn index_lt(a: A8Index, b: A8Index) -> A8Mask {
        // Unsigned `a < b` as a signed compare of both with the top bit
        // flipped (AVX2 has no unsigned compare).
        // SAFETY: AVX2 runs here (module docs).
        A8Mask(unsafe {
            let top = _mm256_set1_epi32(i32::MIN);
            let (a, b) = (_mm256_xor_si256(a.0, top), _mm256_xor_si256(b.0, top));
            _mm256_castsi256_ps(_mm256_cmpgt_epi32(b, a))
        })
    }
    #[inline(always)]
    fn index_select(m: A8Mask, a: A8Index, b: A8Index) -> A8Index {
        // SAFETY: AVX2 runs here (module docs); as in `select`.
        A8Index(unsafe {
            _mm256_castps_si256(_mm256_blendv_ps(
                _mm256_castsi256_ps(b.0),
                _mm256_castsi256_ps(a.0),
                m.0,
            ))
        })
    }
    #[inline(always)]
    fn index_lane(x: A8Index, i: usize) -> u32 {
        x.to_array()[i]
    }
    #[inline(always)]
    fn index_with_lane(v: A8Index, i: usize, x: u32) -> A8Index {
        let mut a = v.to_array();
        a[i] = x;
        A8Index::from_array(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::F8;

    /// Every `A8` operation equals `F8`'s lane by lane, bit for bit
    /// (NaNs: NaN on both sides), on infinities, signed zeros and NaNs;
    /// masks, indices and lane access agree. Runs only where the CPU has
    /// AVX2 (the module's invariant); small enough for Miri.
    #[test]
    fn a8_equals_f8_lane_by_lane() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("note: no AVX2 on this CPU; A8 is not used here");
            return;
        }
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
        let same = |a: A8, f: F8| {
            for (x, y) in a.to_array().iter().zip(f.to_array()) {
                assert!(
                    x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                    "{x} {y}"
                );
            }
        };
        for r in 0..8 {
            let w: [f32; 8] = std::array::from_fn(|i| v[(i + r) % 8]);
            let (a, b) = (A8::from_array(v), A8::from_array(w));
            let (fa, fb) = (F8::from(v), F8::from(w));
            same(a + b, fa + fb);
            same(a - b, fa - fb);
            same(a * b, fa * fb);
            same(a / b, fa / fb);
            same(a.max_keep(b), fa.max_keep(fb));
            same(a.min_keep(b), fa.min_keep(fb));
            same(a.abs(), fa.abs());
            same(A8::select(a.lt(b), a, b), F8::select(fa.lt(fb), fa, fb));
            assert_eq!(A8::bits(a.lt(b)), F8::bits(fa.lt(fb)));
            assert_eq!(A8::bits(a.le(b)), F8::bits(fa.le(fb)));
            assert_eq!(A8::bits(a.gt(b)), F8::bits(fa.gt(fb)));
            assert_eq!(A8::bits(a.eq(b)), F8::bits(fa.eq(fb)));
            assert_eq!(
                A8::bits(!a.le(b) & a.eq(b) | a.gt(b)),
                F8::bits(!fa.le(fb) & fa.eq(fb) | fa.gt(fb))
            );
            assert_eq!(a.sign_bits(), fa.sign_bits());
            assert_eq!(A8::any(a.lt(b)), F8::any(fa.lt(fb)));
            assert_eq!(a == b, fa == fb);
            assert_eq!(a == a, fa == fa);
            for i in 0..8 {
                assert_eq!(a.lane(i).to_bits(), fa.lane(i).to_bits());
                same(a.with_lane(i, 7.5), fa.with_lane(i, 7.5));
            }
            same(A8::from_fn(|i| w[i]), F8::from_fn(|i| w[i]));
        }
        for bits in 0..256 {
            assert_eq!(A8::bits(A8::mask_from_bits(bits)), bits);
        }
        let idx = A8Index::from_array([0, 1, u32::MAX, 7, 8, 0x8000_0000, 5, 6]);
        let five = A8::index_splat(5);
        assert_eq!(A8::bits(A8::index_lt(idx, five)), 0b0000_0011);
        let s = A8::index_select(A8::mask_from_bits(0b1010_0101), five, idx);
        assert_eq!(s.to_array(), [5, 1, 5, 7, 8, 5, 5, 5]);
        assert_eq!(A8::index_lane(A8::index_with_lane(s, 3, 9), 3), 9);
    }
}

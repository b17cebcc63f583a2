//! Rays, hits and the ray policy shared by every query.
//!
//! # Ray policy
//! - A hit is the closest intersection with `t_min < t <= t_max`
//!   (docs/PROTOCOL.md, "Camera and primary rays"). A reported hit always
//!   has a finite `t` in that interval and finite `u`, `v`, on every path
//!   and for any finite coordinates (the triangle test redoes in f64 what
//!   over- or underflows in f32).
//! - Ties in `t` go to the smaller triangle index, so brute force, the
//!   scalar kd traversal and the packet traversal return the same triangle
//!   whatever order they test triangles in.
//! - A zero direction component (`+0.0` or `-0.0`) is allowed: its
//!   reciprocal is `±inf` and the sign bit decides near/far. A ray lying in
//!   a box face's or split plane's plane is *inside* that slab (boxes are
//!   closed), never a miss: the `0 * inf = NaN` this produces is ignored by
//!   the `*_keep` helpers of [`crate::simd::Lane`].
//! - A subnormal direction component (`0 < |d| < f32::MIN_POSITIVE`,
//!   about `1.18e-38`) is flushed to zero with its sign kept ("denormals
//!   are zero"), by [`Ray::new`], [`Ray::new_unchecked`] and so by every
//!   packet constructor. This covers every component whose reciprocal
//!   overflows to `±inf` (`|d| < 1 / f32::MAX`, about `2.9e-39`): the
//!   traversal would treat that axis like a zero component while the
//!   triangle test used the real `d`. With the flush both see the same
//!   ray, parallel to that axis; it moves by less than `1.18e-38 * t` on
//!   that axis.
//! - [`Ray::new`] rejects a zero direction vector (also one that is zero
//!   only after the flush), non-finite origin or direction and NaN bounds
//!   with a [`RayError`]. An empty interval (`t_min >= t_max`) is a valid
//!   ray that never hits.
//! - [`Ray::new_unchecked`] skips the checks; an invalid ray built with it
//!   never panics or loops, and never hits (NaN compares false).

use glam::{Vec3, Vec3A};
use std::fmt;

/// A ray `origin + t * dir` with `t_min < t <= t_max`. The fields are
/// read through accessors and set only by the constructors, so `inv_dir`
/// always matches `dir` and the ray policy's flush holds.
///
/// ```
/// use glam::Vec3;
/// use packtrace::Ray;
/// let r = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, -2.0), 0.0, f32::INFINITY).unwrap();
/// assert_eq!(r.inv_dir().z, -0.5);
/// assert!(r.inv_dir().x.is_infinite());
/// assert_eq!((r.origin(), r.dir(), r.t_min(), r.t_max()), (Vec3::ZERO, Vec3::new(0.0, 0.0, -2.0), 0.0, f32::INFINITY));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub(crate) origin: Vec3,
    pub(crate) dir: Vec3,
    pub(crate) inv_dir: Vec3,
    pub(crate) t_min: f32,
    pub(crate) t_max: f32,
}

/// The miss marker of a hit's triangle index: no hit yet, or none.
pub(crate) const NO_PRIM: u32 = u32::MAX;

/// Why [`Ray::new`] refused a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RayError {
    /// All three direction components are zero or subnormal (subnormal
    /// components are flushed to zero, see the ray policy).
    ZeroDirection,
    /// The origin has a NaN or infinite component.
    NonFiniteOrigin(Vec3),
    /// The direction has a NaN or infinite component.
    NonFiniteDirection(Vec3),
    /// `t_min` or `t_max` is NaN.
    NanBound {
        /// The given lower bound.
        t_min: f32,
        /// The given upper bound.
        t_max: f32,
    },
}

impl fmt::Display for RayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RayError::ZeroDirection => write!(f, "ray direction is the zero vector"),
            RayError::NonFiniteOrigin(o) => write!(f, "ray origin {o} is not finite"),
            RayError::NonFiniteDirection(d) => write!(f, "ray direction {d} is not finite"),
            RayError::NanBound { t_min, t_max } => {
                write!(f, "ray interval ({t_min}, {t_max}] contains NaN")
            }
        }
    }
}

impl std::error::Error for RayError {}

impl Ray {
    /// A checked ray.
    ///
    /// # Errors
    /// [`RayError`] for a zero direction (also after flushing subnormal
    /// components), a non-finite origin or direction, or a NaN bound. `t_min >= t_max` is accepted (the ray never hits).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Ray, RayError};
    /// assert_eq!(Ray::new(Vec3::ZERO, Vec3::ZERO, 0.0, 1.0), Err(RayError::ZeroDirection));
    /// let tiny = Vec3::new(1e-40, 0.0, 0.0);
    /// assert_eq!(Ray::new(Vec3::ZERO, tiny, 0.0, 1.0), Err(RayError::ZeroDirection));
    /// ```
    pub fn new(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Result<Ray, RayError> {
        if !origin.is_finite() {
            return Err(RayError::NonFiniteOrigin(origin));
        }
        if !dir.is_finite() {
            return Err(RayError::NonFiniteDirection(dir));
        }
        if flush_tiny(dir) == Vec3::ZERO {
            return Err(RayError::ZeroDirection);
        }
        if t_min.is_nan() || t_max.is_nan() {
            return Err(RayError::NanBound { t_min, t_max });
        }
        Ok(Ray::new_unchecked(origin, dir, t_min, t_max))
    }

    /// A ray without checks (for hot loops over rays known to be valid).
    /// An invalid ray never hits; see the module's ray policy. Subnormal
    /// direction components are flushed to a zero of the same sign, as in
    /// [`Ray::new`].
    ///
    /// ```
    /// use glam::Vec3;
    /// let r = packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::X, 0.0, 1.0);
    /// assert_eq!(r.inv_dir().x, 1.0);
    /// let t = packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::new(-1e-40, 0.0, 1.0), 0.0, 1.0);
    /// assert!(t.dir().x == 0.0 && t.dir().x.is_sign_negative());
    /// assert_eq!(t.inv_dir().x, f32::NEG_INFINITY);
    /// ```
    #[inline]
    pub fn new_unchecked(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Ray {
        let (dir, inv_dir) = flush_and_invert(dir);
        Ray {
            origin,
            dir,
            inv_dir,
            t_min,
            t_max,
        }
    }

    /// The origin.
    ///
    /// ```
    /// use glam::Vec3;
    /// assert_eq!(packtrace::Ray::new_unchecked(Vec3::ONE, Vec3::X, 0.0, 1.0).origin(), Vec3::ONE);
    /// ```
    #[inline]
    #[must_use]
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// The direction (not necessarily normalised; `t` is in units of it),
    /// with subnormal components flushed to a zero of the same sign (the
    /// ray policy).
    ///
    /// ```
    /// use glam::Vec3;
    /// let r = packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::new(1e-40, 0.0, 2.0), 0.0, 1.0);
    /// assert_eq!(r.dir(), Vec3::new(0.0, 0.0, 2.0));
    /// ```
    #[inline]
    #[must_use]
    pub fn dir(&self) -> Vec3 {
        self.dir
    }

    /// `1 / dir` per axis, exact division (`±inf` for a zero component).
    ///
    /// ```
    /// use glam::Vec3;
    /// let r = packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::new(4.0, -0.0, 2.0), 0.0, 1.0);
    /// assert_eq!(r.inv_dir(), Vec3::new(0.25, f32::NEG_INFINITY, 0.5));
    /// ```
    #[inline]
    #[must_use]
    pub fn inv_dir(&self) -> Vec3 {
        self.inv_dir
    }

    /// The exclusive lower bound of the hit distance.
    ///
    /// ```
    /// use glam::Vec3;
    /// assert_eq!(packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::X, 0.5, 1.0).t_min(), 0.5);
    /// ```
    #[inline]
    #[must_use]
    pub fn t_min(&self) -> f32 {
        self.t_min
    }

    /// The inclusive upper bound of the hit distance.
    ///
    /// ```
    /// use glam::Vec3;
    /// assert_eq!(packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::X, 0.5, 1.0).t_max(), 1.0);
    /// ```
    #[inline]
    #[must_use]
    pub fn t_max(&self) -> f32 {
        self.t_max
    }

    /// The same ray with another interval `(t_min, t_max]`: e.g. a shadow
    /// ray cut at the light, or a ray re-traced beyond its last hit.
    ///
    /// # Errors
    /// [`RayError::NanBound`] if a bound is NaN.
    ///
    /// ```
    /// use glam::Vec3;
    /// let r = packtrace::Ray::new(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY).unwrap();
    /// let cut = r.with_interval(0.0, 5.0).unwrap();
    /// assert_eq!((cut.dir(), cut.t_max()), (Vec3::X, 5.0));
    /// assert!(r.with_interval(f32::NAN, 1.0).is_err());
    /// ```
    pub fn with_interval(&self, t_min: f32, t_max: f32) -> Result<Ray, RayError> {
        if t_min.is_nan() || t_max.is_nan() {
            return Err(RayError::NanBound { t_min, t_max });
        }
        Ok(Ray {
            t_min,
            t_max,
            ..*self
        })
    }

    /// The point at distance `t`.
    ///
    /// ```
    /// use glam::Vec3;
    /// let r = packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::X, 0.0, 1.0);
    /// assert_eq!(r.at(2.0), Vec3::new(2.0, 0.0, 0.0));
    /// ```
    #[inline]
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// Per axis: does the direction point towards negative values? Uses the
    /// sign bit, so `-0.0` counts as negative, in line with `1 / -0.0 = -inf`.
    #[inline]
    pub(crate) fn dir_neg(&self) -> [bool; 3] {
        [
            self.dir.x.is_sign_negative(),
            self.dir.y.is_sign_negative(),
            self.dir.z.is_sign_negative(),
        ]
    }
}

/// Bounds of [`flush_and_invert`]'s common case: `2^-60` and `2^60`.
const FAST_LO: f32 = f32::from_bits((127 - 60) << 23);
const FAST_HI: f32 = f32::from_bits((127 + 60) << 23);

/// [`flush_tiny`] and the reciprocal of the three components at once, in
/// one SIMD register (SSE on x86-64): bit-equal to the rule applied per
/// component (`|x| < MIN_POSITIVE` is "subnormal or zero", and a zero
/// "flushed" to its own sign is unchanged; `x * 0` is `0.copysign(x)` for
/// the finite `x` that get flushed). Six scalar divisions were most of the
/// cost of a scene's object-space ray (docs/instances.md).
#[inline]
fn flush_and_invert(dir: Vec3) -> (Vec3, Vec3) {
    // Every magnitude in [2^-60, 2^60]: no component can be flushed
    // (|d_i| / max|d| >= 2^-120), so the reciprocal need not wait for the
    // test's division (a predicted branch; a scene's object-space ray
    // starts its traversal that much sooner).
    let a = Vec3A::from(dir).abs();
    if a.min_element() >= FAST_LO && a.max_element() <= FAST_HI {
        return (dir, (Vec3A::ONE / Vec3A::from(dir)).into());
    }
    // The largest magnitude as `flush_tiny` takes it (`Vec3`'s
    // `max_element`), so that NaN components pick the same one.
    let max = Vec3A::splat(dir.abs().max_element());
    let d = Vec3A::from(dir);
    let a = d.abs();
    let tiny = Vec3A::splat(f32::MIN_POSITIVE);
    let flush = a.cmplt(tiny) | (a / max).cmplt(tiny);
    let d = Vec3A::select(flush, d * Vec3A::ZERO, d);
    (d.into(), (Vec3A::ONE / d).into())
}

/// Flush each direction component that f32 cannot tell apart from zero to
/// a zero of the same sign: a subnormal one (which includes every one whose
/// reciprocal overflows to `±inf`), and one negligible against the largest
/// component (`|d_i| / max|d| < f32::MIN_POSITIVE`). The triangle test
/// shears by `d_i / d_max`, which underflows to zero for such a component,
/// so it sees the ray parallel to that axis; the traversal must see the
/// same ray. Zeros, NaN, infinities and normal values otherwise unchanged.
fn flush_tiny(d: Vec3) -> Vec3 {
    let max = d.abs().max_element();
    let f = |x: f32| {
        if x.is_subnormal() || (x.abs() / max) < f32::MIN_POSITIVE {
            0.0f32.copysign(x)
        } else {
            x
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// A ray/triangle hit: distance, triangle index and barycentrics, with the
/// hit point `(1 - u - v) * v0 + u * v1 + v * v2`.
///
/// ```
/// let h = packtrace::Hit { t: 1.0, prim: 3, u: 0.25, v: 0.5 };
/// assert_eq!(h.prim, 3);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray, in units of its direction.
    pub t: f32,
    /// Index of the triangle in the mesh.
    pub prim: u32,
    /// Barycentric weight of the triangle's second vertex.
    pub u: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub v: f32,
}

impl Hit {
    /// The crate's closest-hit order: smaller `t` first, ties to the smaller
    /// triangle index. Every query uses it, so all paths agree exactly.
    ///
    /// ```
    /// use packtrace::Hit;
    /// let a = Hit { t: 1.0, prim: 2, u: 0.0, v: 0.0 };
    /// let b = Hit { t: 1.0, prim: 5, u: 0.0, v: 0.0 };
    /// assert!(a.closer_than(&b) && !b.closer_than(&a));
    /// ```
    #[inline]
    #[must_use]
    pub fn closer_than(&self, other: &Hit) -> bool {
        self.t < other.t || (self.t == other.t && self.prim < other.prim)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SIMD flush and reciprocal equal the per-component rule bit for
    /// bit on every combination of awkward components.
    #[test]
    fn simd_flush_equals_the_per_component_rule() {
        let vals = [
            0.0f32,
            -0.0,
            1e-40,
            -1e-40,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-30,
            -3e-8,
            1.0,
            -2.5,
            1e30,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
            // Either side of the common case's bounds (2^-60, 2^60).
            FAST_LO,
            -FAST_LO.next_down(),
            FAST_HI,
            FAST_HI.next_up(),
        ];
        for &x in &vals {
            for &y in &vals {
                for &z in &vals {
                    let d = Vec3::new(x, y, z);
                    let want = flush_tiny(d);
                    let want_inv = Vec3::new(1.0 / want.x, 1.0 / want.y, 1.0 / want.z);
                    let (got, got_inv) = flush_and_invert(d);
                    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                    assert_eq!(bits(got), bits(want), "{d:?}");
                    assert_eq!(bits(got_inv), bits(want_inv), "{d:?}");
                }
            }
        }
    }

    #[test]
    fn checked_constructor_rejects_each_bad_input() {
        let o = Vec3::ZERO;
        assert_eq!(
            Ray::new(o, Vec3::ZERO, 0.0, 1.0),
            Err(RayError::ZeroDirection)
        );
        assert!(matches!(
            Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X, 0.0, 1.0),
            Err(RayError::NonFiniteOrigin(_))
        ));
        assert!(matches!(
            Ray::new(o, Vec3::new(f32::INFINITY, 0.0, 0.0), 0.0, 1.0),
            Err(RayError::NonFiniteDirection(_))
        ));
        assert!(matches!(
            Ray::new(o, Vec3::X, f32::NAN, 1.0),
            Err(RayError::NanBound { .. })
        ));
        assert!(Ray::new(o, Vec3::X, 2.0, 1.0).is_ok());
        assert!(Ray::new(o, Vec3::new(-0.0, 0.0, 1.0), 0.0, f32::INFINITY).is_ok());
    }

    #[test]
    fn negligible_components_are_flushed_keeping_the_sign() {
        // 2.35e-38 is normal, but 2.7e-57 of the dominant component.
        let r = Ray::new_unchecked(Vec3::ZERO, Vec3::new(1e-28, -2.35e-38, -8.8e18), 0.0, 1.0);
        assert_eq!(r.dir.x.to_bits(), 0);
        assert_eq!(r.dir.y.to_bits(), 0x8000_0000);
        assert_eq!(r.dir.z, -8.8e18);
        assert_eq!(r.inv_dir.y, f32::NEG_INFINITY);
        // Just above the threshold: kept.
        let d = Vec3::new(1.0, 2.0 * f32::MIN_POSITIVE, 0.0);
        assert_eq!(Ray::new_unchecked(Vec3::ZERO, d, 0.0, 1.0).dir, d);
        // Protocol-like directions are untouched.
        let d = Vec3::new(0.3, -1e-20, 0.9);
        assert_eq!(Ray::new_unchecked(Vec3::ZERO, d, 0.0, 1.0).dir, d);
    }

    #[test]
    fn subnormal_components_are_flushed_keeping_the_sign() {
        let min_sub = f32::from_bits(1);
        let r = Ray::new_unchecked(
            Vec3::ZERO,
            Vec3::new(-min_sub, 1e-40, -f32::MIN_POSITIVE.next_down()),
            0.0,
            1.0,
        );
        assert_eq!(r.dir.x.to_bits(), (-0.0f32).to_bits());
        assert_eq!(r.dir.y.to_bits(), 0.0f32.to_bits());
        assert_eq!(r.dir.z.to_bits(), (-0.0f32).to_bits());
        assert_eq!(r.inv_dir.x, f32::NEG_INFINITY);
        assert_eq!(r.inv_dir.y, f32::INFINITY);
        assert_eq!(r.inv_dir.z, f32::NEG_INFINITY);
        // The smallest normal component is kept, with a finite reciprocal.
        let keep = f32::MIN_POSITIVE;
        let k = Ray::new_unchecked(Vec3::ZERO, Vec3::new(keep, 0.0, 1.0), 0.0, 1.0);
        assert_eq!(k.dir.x, keep);
        assert!(k.inv_dir.x.is_finite());
        // A direction that is zero after the flush is refused.
        assert_eq!(
            Ray::new(Vec3::ZERO, Vec3::new(1e-40, -min_sub, 0.0), 0.0, 1.0),
            Err(RayError::ZeroDirection)
        );
        assert_eq!(
            Ray::new(Vec3::ZERO, Vec3::new(1e-40, 0.0, 2.0), 0.0, 1.0).map(|r| r.dir),
            Ok(Vec3::new(0.0, 0.0, 2.0))
        );
    }

    #[test]
    fn negative_zero_direction_is_negative() {
        let r = Ray::new_unchecked(Vec3::ZERO, Vec3::new(-0.0, 0.0, 1.0), 0.0, 1.0);
        assert_eq!(r.dir_neg(), [true, false, false]);
        assert_eq!(r.inv_dir.x, f32::NEG_INFINITY);
        assert_eq!(r.inv_dir.y, f32::INFINITY);
    }
}

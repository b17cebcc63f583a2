//! Rays, hits and the ray policy shared by every query.
//!
//! # Ray policy
//! - A hit is the closest intersection with `t_min < t <= t_max`
//!   (BENCH_PROTOCOL, "Camera and primary rays").
//! - Ties in `t` go to the smaller triangle index, so brute force, the
//!   scalar kd traversal and the packet traversal return the same triangle
//!   whatever order they test triangles in.
//! - A zero direction component (`+0.0` or `-0.0`) is allowed: its
//!   reciprocal is `±inf` and the sign bit decides near/far. A ray lying in
//!   a box face's or split plane's plane is *inside* that slab (boxes are
//!   closed), never a miss: the `0 * inf = NaN` this produces is ignored by
//!   the `*_keep` helpers of [`crate::simd::Lane`].
//! - [`Ray::new`] rejects a zero direction vector, non-finite origin or
//!   direction and NaN bounds with a [`RayError`]. An empty interval
//!   (`t_min >= t_max`) is a valid ray that never hits.
//! - [`Ray::new_unchecked`] skips the checks; an invalid ray built with it
//!   never panics or loops, and never hits (NaN compares false).

use glam::Vec3;
use std::fmt;

/// A ray `origin + t * dir` with `t_min < t <= t_max`.
///
/// ```
/// use glam::Vec3;
/// use packtrace::Ray;
/// let r = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, -2.0), 0.0, f32::INFINITY).unwrap();
/// assert_eq!(r.inv_dir.z, -0.5);
/// assert!(r.inv_dir.x.is_infinite());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Ray origin.
    pub origin: Vec3,
    /// Direction (not necessarily normalised; `t` is in units of it).
    pub dir: Vec3,
    /// `1 / dir` per axis, exact division (`±inf` for a zero component).
    pub inv_dir: Vec3,
    /// Exclusive lower bound of the hit distance.
    pub t_min: f32,
    /// Inclusive upper bound of the hit distance.
    pub t_max: f32,
}

/// Why [`Ray::new`] refused a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RayError {
    /// All three direction components are zero.
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
    /// [`RayError`] for a zero direction, a non-finite origin or direction,
    /// or a NaN bound. `t_min >= t_max` is accepted (the ray never hits).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Ray, RayError};
    /// assert_eq!(Ray::new(Vec3::ZERO, Vec3::ZERO, 0.0, 1.0), Err(RayError::ZeroDirection));
    /// ```
    pub fn new(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Result<Ray, RayError> {
        if !origin.is_finite() {
            return Err(RayError::NonFiniteOrigin(origin));
        }
        if !dir.is_finite() {
            return Err(RayError::NonFiniteDirection(dir));
        }
        if dir == Vec3::ZERO {
            return Err(RayError::ZeroDirection);
        }
        if t_min.is_nan() || t_max.is_nan() {
            return Err(RayError::NanBound { t_min, t_max });
        }
        Ok(Ray::new_unchecked(origin, dir, t_min, t_max))
    }

    /// A ray without checks (for hot loops over rays known to be valid).
    /// An invalid ray never hits; see the module's ray policy.
    ///
    /// ```
    /// use glam::Vec3;
    /// let r = packtrace::Ray::new_unchecked(Vec3::ZERO, Vec3::X, 0.0, 1.0);
    /// assert_eq!(r.inv_dir.x, 1.0);
    /// ```
    #[inline]
    pub fn new_unchecked(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Ray {
        Ray {
            origin,
            dir,
            inv_dir: Vec3::new(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z),
            t_min,
            t_max,
        }
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
    fn negative_zero_direction_is_negative() {
        let r = Ray::new_unchecked(Vec3::ZERO, Vec3::new(-0.0, 0.0, 1.0), 0.0, 1.0);
        assert_eq!(r.dir_neg(), [true, false, false]);
        assert_eq!(r.inv_dir.x, f32::NEG_INFINITY);
        assert_eq!(r.inv_dir.y, f32::INFINITY);
    }
}

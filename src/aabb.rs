//! Axis-aligned boxes and the slab test (Kay & Kajiya 1986), written once
//! for any lane width.

use crate::ray::Ray;
use crate::simd::Lane;
use glam::{Vec3, Vec3A};

/// An axis-aligned bounding box. Closed: points on a face are inside.
///
/// ```
/// use glam::Vec3A;
/// use packtrace::Aabb;
/// let mut b = Aabb::EMPTY;
/// b.grow(Vec3A::new(1.0, 2.0, 3.0));
/// b.grow(Vec3A::ZERO);
/// assert_eq!(b.extent(), Vec3A::new(1.0, 2.0, 3.0));
/// assert_eq!(b.surface_area(), 22.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3A,
    /// Largest corner.
    pub max: Vec3A,
}

impl Aabb {
    /// The empty box (`min = +inf`, `max = -inf`), the identity of `grow`.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    /// Box from two corners.
    ///
    /// ```
    /// use glam::Vec3A;
    /// let b = packtrace::Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    /// assert!(b.contains(Vec3A::splat(0.5)));
    /// ```
    #[must_use]
    pub fn new(min: Vec3A, max: Vec3A) -> Aabb {
        Aabb { min, max }
    }

    /// Box of a set of points.
    ///
    /// ```
    /// use glam::Vec3;
    /// let b = packtrace::Aabb::from_points(&[Vec3::ZERO, Vec3::ONE]);
    /// assert_eq!(b.max.x, 1.0);
    /// ```
    #[must_use]
    pub fn from_points(points: &[Vec3]) -> Aabb {
        let mut b = Aabb::EMPTY;
        for &p in points {
            b.grow(p.into());
        }
        b
    }

    /// Enlarge to contain `p`.
    ///
    /// ```
    /// let mut b = packtrace::Aabb::EMPTY;
    /// b.grow(glam::Vec3A::ONE);
    /// assert_eq!(b.min, b.max);
    /// ```
    #[inline]
    pub fn grow(&mut self, p: Vec3A) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Smallest box containing both.
    ///
    /// ```
    /// use glam::Vec3A;
    /// use packtrace::Aabb;
    /// let u = Aabb::new(Vec3A::ZERO, Vec3A::ONE).union(&Aabb::new(Vec3A::ONE, Vec3A::splat(2.0)));
    /// assert_eq!(u.max, Vec3A::splat(2.0));
    /// ```
    #[must_use]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb::new(self.min.min(o.min), self.max.max(o.max))
    }

    /// True when the box contains no point (`min > max` on some axis).
    ///
    /// ```
    /// assert!(packtrace::Aabb::EMPTY.is_empty());
    /// ```
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// `max - min`.
    ///
    /// ```
    /// use glam::Vec3A;
    /// assert_eq!(packtrace::Aabb::new(Vec3A::ZERO, Vec3A::X).extent(), Vec3A::X);
    /// ```
    #[must_use]
    pub fn extent(&self) -> Vec3A {
        self.max - self.min
    }

    /// Surface area (0 for an empty box), the SAH's probability measure.
    ///
    /// ```
    /// use glam::Vec3A;
    /// assert_eq!(packtrace::Aabb::new(Vec3A::ZERO, Vec3A::ONE).surface_area(), 6.0);
    /// ```
    #[must_use]
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Does the (closed) box contain `p`?
    ///
    /// ```
    /// use glam::Vec3A;
    /// assert!(packtrace::Aabb::new(Vec3A::ZERO, Vec3A::ONE).contains(Vec3A::ONE));
    /// ```
    #[must_use]
    pub fn contains(&self, p: Vec3A) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Do the two closed boxes share a point?
    ///
    /// ```
    /// use glam::Vec3A;
    /// use packtrace::Aabb;
    /// let a = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    /// assert!(a.overlaps(&Aabb::new(Vec3A::ONE, Vec3A::splat(2.0))));
    /// ```
    #[must_use]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && o.min.cmple(self.max).all()
    }

    /// Scalar slab test: the part `[t0, t1]` of `[ray.t_min, ray.t_max]`
    /// inside the box, or `None`. A ray lying in a face's plane is inside
    /// (ray policy in [`crate::ray`]).
    ///
    /// ```
    /// use glam::{Vec3, Vec3A};
    /// use packtrace::{Aabb, Ray};
    /// let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    /// let r = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0.0, f32::INFINITY).unwrap();
    /// assert_eq!(b.intersect(&r), Some((1.0, 2.0)));
    /// // along the face y = 0: inside, not a miss
    /// let r = Ray::new(Vec3::new(-1.0, 0.0, 0.5), Vec3::X, 0.0, f32::INFINITY).unwrap();
    /// assert_eq!(b.intersect(&r), Some((1.0, 2.0)));
    /// ```
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32)> {
        let org = ray.origin.to_array();
        let (hit, t0, t1) = slab(
            self,
            &org,
            &org,
            &ray.inv_dir.to_array(),
            &ray.dir_neg(),
            ray.t_min,
            ray.t_max,
        );
        hit.then_some((t0, t1))
    }
}

/// The slab test for any lane width: per lane, clip `[t_min, t_max]` to the
/// box. `neg[axis]` says the direction's sign bit is set, which makes the
/// `max` face the near one. Returns (hit mask, entry, exit). Entries are
/// measured from `org_entry`, exits from `org_exit`: the same origin for
/// the exact test, the origin shifted by the traversal's margin for a box
/// widened by it (`kdtree/margin.rs`).
///
/// The near/far distances of an axis are NaN only for a ray lying in that
/// face's plane (`0 * inf`); `max_keep`/`min_keep` then leave the interval
/// unconstrained on that axis, so boxes are closed sets for every ray.
#[inline(always)]
pub(crate) fn slab<L: Lane>(
    b: &Aabb,
    org_entry: &[L; 3],
    org_exit: &[L; 3],
    inv_dir: &[L; 3],
    neg: &[L::Mask; 3],
    t_min: L,
    t_max: L,
) -> (L::Mask, L, L) {
    let mut t0 = t_min;
    let mut t1 = t_max;
    for axis in 0..3 {
        let lo = L::splat(b.min[axis]);
        let hi = L::splat(b.max[axis]);
        let near = L::select(neg[axis], hi, lo);
        let far = L::select(neg[axis], lo, hi);
        t0 = t0.max_keep((near - org_entry[axis]) * inv_dir[axis]);
        t1 = t1.min_keep((far - org_exit[axis]) * inv_dir[axis]);
    }
    (t0.le(t1), t0, t1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb::new(Vec3A::ZERO, Vec3A::ONE)
    }

    #[test]
    fn axis_parallel_rays_inside_outside_and_on_faces() {
        let b = unit();
        let r = |o: Vec3, d: Vec3| Ray::new_unchecked(o, d, 0.0, f32::INFINITY);
        // parallel to x, outside in y: miss
        assert_eq!(b.intersect(&r(Vec3::new(-1.0, 2.0, 0.5), Vec3::X)), None);
        // on the max face, -0.0 components
        let d = Vec3::new(1.0, -0.0, -0.0);
        assert_eq!(
            b.intersect(&r(Vec3::new(-1.0, 1.0, 1.0), d)),
            Some((1.0, 2.0))
        );
        // origin inside: entry is t_min
        assert_eq!(
            b.intersect(&r(Vec3::splat(0.5), Vec3::NEG_Y)),
            Some((0.0, 0.5))
        );
        // pointing away
        assert_eq!(b.intersect(&r(Vec3::new(2.0, 0.5, 0.5), Vec3::X)), None);
    }

    #[test]
    fn empty_interval_and_nan_never_hit_a_box_wrongly() {
        let b = unit();
        let r = Ray::new_unchecked(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 3.0, 2.0);
        assert_eq!(b.intersect(&r), None);
        let r = Ray::new_unchecked(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0.0, 0.5);
        assert_eq!(b.intersect(&r), None);
    }
}

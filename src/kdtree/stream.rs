//! Streams: any number of rays, grouped into coherent 8-wide packets by
//! the engine itself, results in the caller's order.
//!
//! The grouping key is the direction octant first (a packet of one octant
//! never splits), then a Morton code of the origin in the scene box, then
//! one of the direction: rays sharing an origin (a pinhole camera's)
//! fall into direction-coherent groups, rays from nearby points (shadow
//! rays of neighbouring hits) into origin-coherent ones. A stable sort
//! keeps the caller's order among equal keys, so identical rays stay
//! together. The key costs one pass and one sort of `u64`s per stream.

use super::KdTree;
use super::hybrid::trace;
use super::layout::Layout;
use super::stats::NoCount;
use crate::aabb::Aabb;
use crate::packet::RayPacket8;
use crate::ray::{Hit, Ray};
use glam::Vec3;

/// Bits per axis of each Morton code (3 x 10 for the origin, 3 x 10 for
/// the direction, 3 for the octant: 63 bits).
const BITS: u32 = 10;

/// Spread the low 10 bits of `x` to every third bit.
fn spread(x: u32) -> u64 {
    let mut x = u64::from(x) & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

/// Morton code of a point of the box `lo..lo + size` (clamped into it).
fn morton(p: Vec3, lo: Vec3, size: Vec3) -> u64 {
    let scale = ((1u32 << BITS) - 1) as f32;
    let q =
        ((p - lo) / size.max(Vec3::splat(f32::MIN_POSITIVE))).clamp(Vec3::ZERO, Vec3::ONE) * scale;
    // `as u32` saturates and maps NaN (an invalid ray) to 0.
    spread(q.x as u32) | spread(q.y as u32) << 1 | spread(q.z as u32) << 2
}

/// The grouping key of a ray.
fn key(r: &Ray, bounds: &Aabb) -> u64 {
    let d = r.dir();
    let octant = (0..3).fold(0u64, |o, a| o | u64::from(d[a].is_sign_negative()) << a);
    let (lo, hi) = (Vec3::from(bounds.min), Vec3::from(bounds.max));
    let origin = morton(r.origin(), lo, hi - lo);
    let dir = morton(
        d / d.abs().max_element(),
        Vec3::splat(-1.0),
        Vec3::splat(2.0),
    );
    octant << 60 | origin << 30 | dir
}

/// The rays' indices in grouping order, origins keyed within `bounds`
/// (the tree's box, or a scene's world box).
pub(crate) fn order(bounds: &Aabb, rays: &[Ray]) -> Vec<u32> {
    let mut keyed: Vec<(u64, u32)> = rays
        .iter()
        .enumerate()
        .map(|(i, r)| (key(r, bounds), i as u32))
        .collect();
    // (key, index) pairs are distinct, so an unstable sort is stable here.
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

impl KdTree {
    /// Closest hits of a stream of rays, `hits[i]` for `rays[i]`: the rays
    /// are sorted into coherent 8-wide packets (by direction octant, then
    /// origin, then direction; `stream.rs`) and traced at the fastest
    /// width. Use it for rays the host has not grouped itself (secondary
    /// rays from many surfaces); rays already grouped by screen tile trace
    /// fastest as packets, and a lone ray with [`KdTree::intersect`].
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let rays: Vec<Ray> = (0..7)
    ///     .map(|i| Ray::new(Vec3::new(0.1 * i as f32, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap())
    ///     .collect();
    /// let mut hits = vec![None; 7];
    /// t.intersect_rays(&rays, &mut hits);
    /// assert!(hits.iter().zip(&rays).all(|(h, r)| *h == t.intersect(r)));
    /// ```
    pub fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        intersect_rays(self, rays, hits);
    }

    /// Occlusion of a stream of rays, sorted and traced as
    /// [`KdTree::intersect_rays`] does.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.1, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// let mut occ = vec![false; 5];
    /// t.occluded_rays(&[r; 5], &mut occ);
    /// assert!(occ.iter().all(|&o| o));
    /// ```
    pub fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        occluded_rays(self, rays, occluded);
    }
}

/// Closest hits of a stream, `hits[i]` for `rays[i]`.
pub(crate) fn intersect_rays<T: Layout>(tree: &T, rays: &[Ray], hits: &mut [Option<Hit>]) {
    assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
    for group in order(tree.bounds(), rays).chunks(8) {
        let p = RayPacket8::from_fn(|l| group.get(l).map(|&i| rays[i as usize]));
        let h = trace::<_, _, false, _>(tree, &p, &mut NoCount);
        for (l, &i) in group.iter().enumerate() {
            hits[i as usize] = h.hit(l);
        }
    }
}

/// Occlusion of a stream, `occluded[i]` for `rays[i]`.
pub(crate) fn occluded_rays<T: Layout>(tree: &T, rays: &[Ray], occluded: &mut [bool]) {
    assert_eq!(rays.len(), occluded.len(), "one slot per ray");
    for group in order(tree.bounds(), rays).chunks(8) {
        let p = RayPacket8::from_fn(|l| group.get(l).map(|&i| rays[i as usize]));
        let m = trace::<_, _, true, _>(tree, &p, &mut NoCount).mask();
        for (l, &i) in group.iter().enumerate() {
            occluded[i as usize] = m >> l & 1 == 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_codes_interleave_and_clamp() {
        assert_eq!(spread(0b11), 0b1001);
        assert_eq!(spread(0x3ff).count_ones(), 10);
        let (lo, size) = (Vec3::ZERO, Vec3::ONE);
        assert_eq!(morton(Vec3::ZERO, lo, size), 0);
        assert_eq!(morton(Vec3::ONE, lo, size), (1 << 30) - 1);
        assert_eq!(morton(Vec3::splat(5.0), lo, size), (1 << 30) - 1);
        assert_eq!(morton(Vec3::splat(f32::NAN), lo, size), 0);
        assert_eq!(morton(Vec3::new(1.0, 0.0, 0.0), lo, size), spread(0x3ff));
    }
}

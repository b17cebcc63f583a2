//! The stream sort key: any number of rays, grouped into coherent
//! 8-wide packets, results in the caller's order. The kd-tree's streams
//! used it before the breadth-first traversal (`traverse.rs`); a scene's
//! streams still do (`scene/mod.rs`), and its key orders the rays of a
//! breadth-first stream too when asked (`StreamOptions::sort`).
//!
//! The grouping key is the direction octant first (a packet of one octant
//! never splits), then a Morton code of the origin in the scene box, then
//! one of the direction: rays sharing an origin (a pinhole camera's)
//! fall into direction-coherent groups, rays from nearby points (shadow
//! rays of neighbouring hits) into origin-coherent ones. A stable sort
//! keeps the caller's order among equal keys, so identical rays stay
//! together. The key costs one pass and one sort of `u64`s per stream.

use crate::aabb::Aabb;
use crate::ray::Ray;
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

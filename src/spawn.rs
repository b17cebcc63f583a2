//! Secondary rays that leave a surface without re-hitting it.
//!
//! A hit point computed in f32, whether as `origin + t * dir` or from the
//! barycentrics, lies a few ulps off its triangle, on either side. A ray
//! started there can hit the triangle it leaves again ("acne"): from
//! Sponza's primary hits, 20 % of shadow rays started at `origin + t *
//! dir` did (issue 15). The self-hit rule of the triangle test (a hit
//! within its `t` error bound of the origin is dropped) removes most of
//! them, not all: it is no offset.
//!
//! [`offset_origin`] moves the point off the surface along the geometric
//! normal as Wächter and Binder do ("A Fast and Robust Method for Avoiding
//! Self-Intersection", Ray Tracing Gems, 2019, chapter 6): by a fixed
//! number of ulps of each coordinate, which scales with the coordinate's
//! own rounding error wherever the surface is, and by a small absolute
//! step near the world origin, where ulps vanish. [`spawn_ray`] does the
//! whole job for a [`Hit`]: the point from the barycentrics (more accurate
//! than `origin + t * dir` far from the ray origin), the normal turned to
//! the side the new ray leaves on, the offset, the ray.

use crate::mesh::Mesh;
use crate::ray::{Hit, Ray, RayError};
use glam::Vec3;

/// Below this magnitude a coordinate moves by an absolute step (paper:
/// `1 / 32`).
const ORIGIN: f32 = 1.0 / 32.0;
/// The absolute step near the origin, per unit of normal (paper: `1 /
/// 65536`).
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
/// Ulps per unit of normal elsewhere (paper: 256).
const INT_SCALE: f32 = 256.0;

/// `p` moved off a surface along its unit normal `n` (towards the side `n`
/// points to), far enough that no f32 rounding puts it back on the other
/// side: `256 n_i` ulps of each coordinate, or `n_i / 65536` for a
/// coordinate below `1 / 32` in magnitude (Wächter and Binder 2019).
///
/// ```
/// use packtrace::glam::Vec3;
/// let p = Vec3::new(1000.0, 0.0, -3.0);
/// let q = packtrace::spawn::offset_origin(p, Vec3::Y);
/// assert_eq!((q.x, q.z), (p.x, p.z));
/// assert!(q.y > 0.0 && q.y < 1e-4);
/// let q = packtrace::spawn::offset_origin(p, Vec3::X);
/// assert!(q.x > 1000.0 && q.x < 1000.02);
/// ```
#[must_use]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    let axis = |p: f32, n: f32| {
        if p.abs() < ORIGIN {
            return p + FLOAT_SCALE * n;
        }
        // Moving the bits moves the magnitude: outwards for the sign of p.
        let ulps = (INT_SCALE * n) as i32;
        let ulps = if p < 0.0 { -ulps } else { ulps };
        f32::from_bits((p.to_bits() as i32).wrapping_add(ulps) as u32)
    };
    Vec3::new(axis(p.x, n.x), axis(p.y, n.y), axis(p.z, n.z))
}

/// The point of `hit` on its triangle, from the barycentrics: `(1 - u -
/// v) p0 + u p1 + v p2`.
///
/// ```
/// use packtrace::glam::Vec3;
/// use packtrace::{Hit, Mesh};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;
/// let hit = Hit { t: 1.0, prim: 0, u: 0.25, v: 0.5 };
/// assert_eq!(packtrace::spawn::hit_point(&mesh, &hit), Vec3::new(0.25, 0.5, 0.0));
/// # Ok::<(), packtrace::MeshError>(())
/// ```
///
/// # Panics
/// If `hit.prim` is not a triangle of `mesh` (a hit from another mesh).
#[must_use]
pub fn hit_point(mesh: &Mesh, hit: &Hit) -> Vec3 {
    let c = mesh.corners(hit.prim as usize);
    c[0] * (1.0 - hit.u - hit.v) + c[1] * hit.u + c[2] * hit.v
}

/// A ray leaving the surface of `hit` in direction `dir`, over `(0,
/// t_max]`: it starts at the hit point moved off the surface to the side
/// `dir` goes to ([`offset_origin`] along the geometric normal), so it
/// does not re-hit the triangle it leaves, and a ray into a closed mesh
/// does not tunnel out through it. For a shadow ray to a point light at
/// `l`, pass `dir = l - hit_point(..)` and `t_max` just below 1.
///
/// ```
/// use packtrace::glam::Vec3;
/// use packtrace::{KdBuildParams, KdTree, Ray, spawn};
/// let tree = KdTree::build(packtrace::protocol::generate::sphere(500), &KdBuildParams::default())?;
/// let eye = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;
/// let hit = tree.intersect(&eye).expect("the sphere");
/// // Back towards the eye: nothing in the way, not even the surface itself.
/// let back = spawn::spawn_ray(tree.mesh(), &hit, Vec3::Z, f32::INFINITY)?;
/// assert!(tree.intersect(&back).is_none());
/// // Into the sphere: the far side, never the triangle it left.
/// let into = spawn::spawn_ray(tree.mesh(), &hit, Vec3::NEG_Z, f32::INFINITY)?;
/// let far = tree.intersect(&into).expect("the inside of the sphere");
/// assert!(far.prim != hit.prim && far.t > 1.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// # Errors
/// [`RayError`] as [`Ray::new`] gives it for `dir` and `t_max` (a zero,
/// infinite or NaN `dir`, a NaN `t_max`).
///
/// # Panics
/// If `hit.prim` is not a triangle of `mesh`.
pub fn spawn_ray(mesh: &Mesh, hit: &Hit, dir: Vec3, t_max: f32) -> Result<Ray, RayError> {
    let n = mesh.normal(hit.prim as usize);
    let n = if n.dot(dir) < 0.0 { -n } else { n };
    Ray::new(offset_origin(hit_point(mesh, hit), n), dir, 0.0, t_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_move_outwards_by_ulps_or_by_a_step_near_the_origin() {
        // Away from the origin: 256 ulps along a unit axis, whatever the sign.
        for p in [1.0f32, -1.0, 1e6, -1e6, 4e-2, -4e-2] {
            let up = offset_origin(Vec3::splat(p), Vec3::X).x;
            let down = offset_origin(Vec3::splat(p), Vec3::NEG_X).x;
            assert!(up > p && down < p, "{p}: {down} {up}");
            let ulps = |a: f32, b: f32| (a.to_bits() as i64 - b.to_bits() as i64).abs();
            assert_eq!(ulps(up, p), 256, "{p}");
            assert_eq!(ulps(down, p), 256, "{p}");
        }
        // Near the origin: n / 65536 exactly.
        let q = offset_origin(Vec3::new(0.0, -0.01, 0.03), Vec3::new(0.6, -0.8, 0.0));
        assert_eq!(q, Vec3::new(0.6 / 65536.0, -0.01 - 0.8 / 65536.0, 0.03));
    }

    #[test]
    fn spawned_rays_start_on_the_side_they_leave_to() {
        let mesh = Mesh::new(
            vec![
                Vec3::new(-1.0, 5.0, -1.0),
                Vec3::new(3.0, 5.0, -1.0),
                Vec3::new(-1.0, 5.0, 3.0),
            ],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let hit = Hit {
            t: 1.0,
            prim: 0,
            u: 0.25,
            v: 0.25,
        };
        assert_eq!(hit_point(&mesh, &hit), Vec3::new(0.0, 5.0, 0.0));
        let up = spawn_ray(&mesh, &hit, Vec3::new(0.3, 1.0, 0.0), 1.0).unwrap();
        let down = spawn_ray(&mesh, &hit, Vec3::new(0.3, -1.0, 0.0), 1.0).unwrap();
        assert!(up.origin.y > 5.0 && down.origin.y < 5.0);
        assert_eq!((up.t_min, up.t_max), (0.0, 1.0));
        assert_eq!(
            spawn_ray(&mesh, &hit, Vec3::ZERO, 1.0).unwrap_err(),
            RayError::ZeroDirection
        );
    }
}

//! The query trait shared by the kd-tree and the brute-force oracle.

use crate::kdtree::KdTree;
use crate::ray::{Hit, Ray};

/// Closest-hit and occlusion queries of one ray. Every accelerator and the
/// brute-force oracle implement it, so tests treat them alike.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{BruteForce, KdBuildParams, KdTree, Mesh, Ray, RayQuery};
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let tree = KdTree::build(m.clone(), &KdBuildParams::default()).unwrap();
/// let brute = BruteForce::new(&m);
/// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// let engines: [&dyn RayQuery; 2] = [&tree, &brute];
/// assert_eq!(engines[0].intersect(&r), engines[1].intersect(&r));
/// ```
pub trait RayQuery {
    /// Closest hit in `(t_min, t_max]`, ties to the smaller triangle index.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Is there any hit in `(t_min, t_max]`?
    fn occluded(&self, ray: &Ray) -> bool;
}

impl RayQuery for KdTree {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        KdTree::intersect(self, ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        KdTree::occluded(self, ray)
    }
}

//! The brute-force scene oracle: every live instance, in id order, its
//! ray transformed naively (the same [`super::Transform`] map every path
//! uses), every triangle of its mesh tested with the one triangle routine;
//! no top level, no kd-tree, no pad.

use super::{GeometryId, InstanceId, Query, Scene, SceneHit, SceneHits, SceneHits4, SceneHits8};
use crate::packet::{RayPacket, RayPacket4, RayPacket8};
use crate::ray::Ray;
use crate::simd::Lane;
use crate::triangle::intersect_ray;

/// Tests every triangle of every instance of a [`Scene`]: slow, obviously
/// right, the reference the scene's traversals are checked against.
///
/// ```
/// use packtrace::glam::{Affine3A, Vec3};
/// use packtrace::scene::{BruteScene, Query, Scene, SceneQuery};
/// # let mut scene = Scene::new();
/// # let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// # let g = scene.add_geometry("g", packtrace::KdTree::build(m, &Default::default()).unwrap());
/// let mut e = scene.edit();
/// let a = e.add_instance(g, Affine3A::IDENTITY)?;
/// let b = e.add_instance(g, Affine3A::IDENTITY)?; // the same place: a tie
/// e.commit();
/// let r = packtrace::Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// let hit = BruteScene::new(&scene).intersect_with(&r, &Query::new()).unwrap();
/// assert_eq!(hit.instance, a); // ties go to the smaller instance id
/// # let _ = b;
/// # Ok::<(), packtrace::scene::SceneError>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct BruteScene<'a> {
    scene: &'a Scene,
}

impl<'a> BruteScene<'a> {
    /// The oracle over `scene`.
    ///
    /// ```
    /// let s = packtrace::scene::Scene::new();
    /// let _ = packtrace::scene::BruteScene::new(&s);
    /// ```
    #[must_use]
    pub fn new(scene: &'a Scene) -> BruteScene<'a> {
        BruteScene { scene }
    }

    /// Every hit of `ray` that passes the mask `mask` and the filter, in
    /// instance and triangle order; `first` stops at the first one.
    fn hits(&self, ray: &Ray, mask: u32, q: &Query<'_>, first: bool) -> Option<SceneHit> {
        let mut best: Option<SceneHit> = None;
        for (id, inst) in self.scene.instances() {
            if inst.mask & mask == 0 {
                continue;
            }
            let Some(geo) = self.scene.geometry(inst.geometry) else {
                continue;
            };
            let mesh = geo.mesh();
            let local = inst.transform.ray_to_object(ray, ray.t_max);
            for i in 0..mesh.triangle_count() {
                if mesh.is_degenerate(i) {
                    continue;
                }
                let Some((t, u, v)) = intersect_ray(&local, mesh.corners(i)) else {
                    continue;
                };
                let h = SceneHit {
                    t,
                    u,
                    v,
                    prim: i as u32,
                    geometry: GeometryId(inst.geometry.0),
                    instance: InstanceId(id.0),
                };
                if q.filter().is_some_and(|f| !f(&h)) {
                    continue;
                }
                if first {
                    return Some(h);
                }
                if best.is_none_or(|b| h.closer_than(&b)) {
                    best = Some(h);
                }
            }
        }
        best
    }

    fn lanes<L: Lane>(&self, p: &RayPacket<L>, q: &Query<'_>, first: bool) -> SceneHits<L> {
        let mut out = SceneHits::default();
        for i in 0..L::WIDTH {
            if let Some(r) = p.ray(i) {
                out.set(i, self.hits(&r, q.mask(i), q, first));
            }
        }
        out
    }
}

impl super::SceneQuery for BruteScene<'_> {
    fn intersect_with(&self, ray: &Ray, q: &Query<'_>) -> Option<SceneHit> {
        self.hits(ray, q.mask(0), q, false)
    }
    fn occluded_with(&self, ray: &Ray, q: &Query<'_>) -> bool {
        self.hits(ray, q.mask(0), q, true).is_some()
    }
    fn intersect4_with(&self, p: &RayPacket4, q: &Query<'_>) -> SceneHits4 {
        self.lanes(p, q, false)
    }
    fn occluded4_with(&self, p: &RayPacket4, q: &Query<'_>) -> u32 {
        self.lanes(p, q, true).mask()
    }
    fn intersect8_with(&self, p: &RayPacket8, q: &Query<'_>) -> SceneHits8 {
        self.lanes(p, q, false)
    }
    fn occluded8_with(&self, p: &RayPacket8, q: &Query<'_>) -> u32 {
        self.lanes(p, q, true).mask()
    }
}

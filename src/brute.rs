//! The brute-force oracle: every triangle, the same triangle routine.

use crate::mesh::Mesh;
use crate::packet::{HitPacket4, RayPacket4};
use crate::query::{PacketQuery, RayQuery};
use crate::ray::{Hit, Ray};
use crate::triangle::intersect_ray;

/// Tests every triangle of a mesh: slow, obviously right, the reference
/// that every accelerated path is checked against.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{BruteForce, Mesh, Ray, RayQuery};
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2], [0, 1, 2]]).unwrap();
/// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// // two coincident triangles: the tie goes to the smaller index
/// assert_eq!(BruteForce::new(&m).intersect(&r).unwrap().prim, 0);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct BruteForce<'a> {
    mesh: &'a Mesh,
}

impl<'a> BruteForce<'a> {
    /// An oracle over `mesh`.
    ///
    /// ```
    /// let m = packtrace::Mesh::default();
    /// let _ = packtrace::BruteForce::new(&m);
    /// ```
    #[must_use]
    pub fn new(mesh: &'a Mesh) -> BruteForce<'a> {
        BruteForce { mesh }
    }
}

impl RayQuery for BruteForce<'_> {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for i in 0..self.mesh.triangle_count() {
            if self.mesh.is_degenerate(i) {
                continue;
            }
            if let Some((t, u, v)) = intersect_ray(ray, self.mesh.corners(i)) {
                let h = Hit {
                    t,
                    prim: i as u32,
                    u,
                    v,
                };
                if best.is_none_or(|b| h.closer_than(&b)) {
                    best = Some(h);
                }
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        (0..self.mesh.triangle_count()).any(|i| {
            !self.mesh.is_degenerate(i) && intersect_ray(ray, self.mesh.corners(i)).is_some()
        })
    }
}

/// Lane by lane: the oracle for packets too.
impl PacketQuery for BruteForce<'_> {
    fn intersect4(&self, packet: &RayPacket4) -> HitPacket4 {
        let mut out = HitPacket4::default();
        for i in 0..4 {
            if let Some(r) = packet.ray(i) {
                out.set(i, RayQuery::intersect(self, &r));
            }
        }
        out
    }
    fn occluded4(&self, packet: &RayPacket4) -> u32 {
        (0..4).fold(0, |m, i| {
            let hit = packet.ray(i).is_some_and(|r| RayQuery::occluded(self, &r));
            m | (hit as u32) << i
        })
    }
}

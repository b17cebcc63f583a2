//! The brute-force oracle: every triangle, the same triangle routine.

use crate::mesh::Mesh;
use crate::packet::{HitPacket, HitPacket4, HitPacket8, RayPacket, RayPacket4, RayPacket8};
use crate::query::{PacketQuery, RayQuery};
use crate::ray::{Hit, Ray};
use crate::simd::Lane;
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
        self.intersect_lanes(packet)
    }
    fn occluded4(&self, packet: &RayPacket4) -> u32 {
        self.occluded_lanes(packet)
    }
    fn intersect8(&self, packet: &RayPacket8) -> HitPacket8 {
        self.intersect_lanes(packet)
    }
    fn occluded8(&self, packet: &RayPacket8) -> u32 {
        self.occluded_lanes(packet)
    }
}

impl BruteForce<'_> {
    fn intersect_lanes<L: Lane>(&self, packet: &RayPacket<L>) -> HitPacket<L> {
        let mut out = HitPacket::default();
        for i in 0..L::WIDTH {
            if let Some(r) = packet.ray(i) {
                out.set(i, RayQuery::intersect(self, &r));
            }
        }
        out
    }
    fn occluded_lanes<L: Lane>(&self, packet: &RayPacket<L>) -> u32 {
        (0..L::WIDTH).fold(0, |m, i| {
            let hit = packet.ray(i).is_some_and(|r| RayQuery::occluded(self, &r));
            m | (hit as u32) << i
        })
    }
}

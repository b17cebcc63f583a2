//! What the renderer traces: a bare kd-tree ([`TreeTarget`]) or a scene
//! of instances ([`SceneTarget`]), each with its diffuse colours. The
//! tile code in `shade.rs` is generic over [`Target`] and monomorphised
//! for each, so the kd-tree's path is the same code (and the same image,
//! bit for bit) as before scenes existed.

use crate::kdtree::KdTree;
use crate::mesh::Mesh;
use crate::packet::RayPacket;
use crate::protocol::frame::SceneFrame;
use crate::ray::{Hit, Ray};
use crate::scene::{Query, Scene, SceneHit, SceneQuery};
use crate::simd::Lane;
use crate::spawn::hit_point;
use glam::{Affine3A, Vec3};

/// The diffuse colour of a triangle without one (Lambertian grey).
pub(super) const GREY: Vec3 = Vec3::splat(0.75);

/// Tracing and shading queries of what is rendered.
pub(super) trait Target: Sync + Sized {
    /// A closest hit.
    type Hit: Copy;

    /// The diagonal `D` of the box AO rays are scaled by (a quarter of it
    /// is their reach).
    fn diagonal(&self) -> f32;

    /// Closest hit of one ray.
    fn intersect(&self, ray: &Ray) -> Option<Self::Hit>;

    /// Any hit of one ray?
    fn occluded(&self, ray: &Ray) -> bool;

    /// Closest hits of a packet, lane `i` into `out[i]` (`out` holds at
    /// most `L::WIDTH` slots).
    fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>, out: &mut [Option<Self::Hit>]);

    /// Occlusion of a packet, bit `i` for lane `i`.
    fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32;

    /// Closest hits of a stream, `hits[i]` for `rays[i]`.
    fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Self::Hit>]);

    /// Occlusion of a stream, `occluded[i]` for `rays[i]`.
    fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]);

    /// The world-space hit point (from the barycentrics), the unit
    /// geometric normal (either side) and the diffuse colour of a hit.
    fn shading(&self, hit: &Self::Hit) -> (Vec3, Vec3, Vec3);

    /// The kd-tree, for the group modes' group traversal; `None` for a
    /// target without one (its group modes are rendered in 4 x 2
    /// packets, the same image).
    fn groups(&self) -> Option<&TreeTarget<'_>> {
        None
    }
}

/// A kd-tree and its per-triangle colours (empty: grey).
pub(super) struct TreeTarget<'a> {
    pub(super) tree: &'a KdTree,
    albedo: &'a [Vec3],
}

impl<'a> TreeTarget<'a> {
    pub(super) fn new(tree: &'a KdTree, albedo: &'a [Vec3]) -> TreeTarget<'a> {
        TreeTarget { tree, albedo }
    }
}

impl Target for TreeTarget<'_> {
    type Hit = Hit;

    fn diagonal(&self) -> f32 {
        SceneFrame::of(self.tree.mesh()).diagonal
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.tree.intersect(ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.tree.occluded(ray)
    }

    #[inline]
    fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>, out: &mut [Option<Hit>]) {
        let h = self.tree.intersect_packet(p);
        for (i, o) in out.iter_mut().enumerate() {
            *o = h.hit(i);
        }
    }

    #[inline]
    fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32 {
        self.tree.occluded_packet(p)
    }

    #[inline]
    fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.tree.intersect_rays(rays, hits);
    }

    #[inline]
    fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.tree.occluded_rays(rays, occluded);
    }

    #[inline]
    fn shading(&self, hit: &Hit) -> (Vec3, Vec3, Vec3) {
        let mesh = self.tree.mesh();
        (
            hit_point(mesh, hit),
            mesh.normal(hit.prim as usize),
            self.albedo.get(hit.prim as usize).copied().unwrap_or(GREY),
        )
    }

    fn groups(&self) -> Option<&TreeTarget<'_>> {
        Some(self)
    }
}

/// A scene, its geometries' meshes, and their per-triangle colours.
pub(super) struct SceneTarget<'a> {
    scene: &'a Scene,
    /// The mesh of each geometry, by id.
    meshes: Vec<&'a Mesh>,
    /// Per geometry (by id), per-triangle colours; a missing or empty
    /// list is grey.
    albedo: &'a [Vec<Vec3>],
    /// By instance id: the object-to-world map of an instance that moves
    /// its geometry, `None` for an identity instance (shaded from its
    /// object-space point and normal as they are, so that a scene of one
    /// identity instance renders exactly as the bare tree).
    to_world: Vec<Option<Affine3A>>,
    diagonal: f32,
}

impl<'a> SceneTarget<'a> {
    pub(super) fn new(scene: &'a Scene, albedo: &'a [Vec<Vec3>]) -> SceneTarget<'a> {
        let meshes: Vec<&Mesh> = (0..scene.geometry_count() as u32)
            .filter_map(|g| scene.geometry(crate::scene::GeometryId(g)))
            .map(|g| g.tree().mesh())
            .collect();
        let slots = scene.instances().map(|(id, _)| id.0 as usize + 1).max();
        let mut to_world = vec![None; slots.unwrap_or(0)];
        for (id, inst) in scene.instances() {
            let m = inst.transform().to_world();
            to_world[id.0 as usize] = (m != Affine3A::IDENTITY).then_some(m);
        }
        SceneTarget {
            scene,
            meshes,
            albedo,
            to_world,
            diagonal: SceneFrame::of_scene(scene).diagonal,
        }
    }
}

impl Target for SceneTarget<'_> {
    type Hit = SceneHit;

    fn diagonal(&self) -> f32 {
        self.diagonal
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<SceneHit> {
        self.scene.intersect(ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded(ray)
    }

    #[inline]
    fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>, out: &mut [Option<SceneHit>]) {
        let h = self.scene.intersect_packet(p, &Query::new());
        for (i, o) in out.iter_mut().enumerate() {
            *o = h.hit(i);
        }
    }

    #[inline]
    fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32 {
        self.scene.occluded_packet(p, &Query::new())
    }

    fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<SceneHit>]) {
        self.scene.intersect_rays_with(rays, hits, &Query::new());
    }

    fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.scene.occluded_rays_with(rays, occluded, &Query::new());
    }

    fn shading(&self, hit: &SceneHit) -> (Vec3, Vec3, Vec3) {
        let g = hit.geometry.0 as usize;
        let prim = hit.prim as usize;
        let mesh = self.meshes[g];
        let local = hit_point(
            mesh,
            &Hit {
                t: hit.t,
                prim: hit.prim,
                u: hit.u,
                v: hit.v,
            },
        );
        let (p, n) = match self
            .to_world
            .get(hit.instance.0 as usize)
            .copied()
            .flatten()
        {
            None => (local, mesh.normal(prim)),
            Some(m) => (
                m.transform_point3(local),
                self.scene.normal(hit).unwrap_or(Vec3::ZERO),
            ),
        };
        let albedo = self
            .albedo
            .get(g)
            .and_then(|a| a.get(prim))
            .copied()
            .unwrap_or(GREY);
        (p, n, albedo)
    }
}

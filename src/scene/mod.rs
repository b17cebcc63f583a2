//! Scenes of many meshes: geometries (one kd-tree or 8-wide BVH each,
//! built once),
//! instances that place a geometry with an affine transform, a top-level
//! BVH over the instances' world boxes, per-instance ray masks and an
//! any-hit filter (issue 16; the lecture notes' two-level structures,
//! Wald, Benthin and Slusallek 2003 "Distributed interactive ray tracing
//! of dynamic scenes"; Embree's instances and filter functions).
//!
//! ```
//! use packtrace::glam::{Affine3A, Vec3};
//! use packtrace::scene::{Query, Scene};
//! use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
//!
//! let quad = Mesh::new(
//!     vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
//!     vec![[0, 1, 2], [1, 3, 2]],
//! )?;
//! let mut scene = Scene::new();
//! let g = scene.add_geometry("quad", KdTree::build(quad, &KdBuildParams::default())?);
//! let mut edit = scene.edit();
//! let near = edit.add_instance(g, Affine3A::from_translation(Vec3::new(0.0, 0.0, 1.0)))?;
//! let far = edit.add_instance(g, Affine3A::IDENTITY)?;
//! edit.commit();
//!
//! let ray = Ray::new(Vec3::new(0.5, 0.25, 5.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;
//! let hit = scene.intersect(&ray).expect("hits the near quad");
//! assert_eq!((hit.t, hit.instance, hit.geometry, hit.prim), (4.0, near, g, 0));
//!
//! // Masks skip instances; a filter rejects hits (alpha testing).
//! scene.edit().set_mask(near, 0b10)?;
//! assert_eq!(scene.intersect_with(&ray, &Query::new().with_mask(0b01)).unwrap().instance, far);
//! let no_near = |h: &packtrace::scene::SceneHit| h.instance != near;
//! assert_eq!(scene.intersect_with(&ray, &Query::new().with_filter(&no_near)).unwrap().t, 5.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Rules
//! - **Ties**: the closest hit wins; at equal `t`, the smaller instance
//!   id, then the smaller triangle index. Every path (scalar, packets of
//!   every width, streams, [`BruteScene`]) returns the same hit, bit for
//!   bit.
//! - **Parameters**: an instance sees the ray as `A o + b`, `A d` (the
//!   stored world-to-object map, [`Transform`]) with the same interval,
//!   so `t` is the world ray's parameter and `u`, `v` the barycentrics
//!   of the object-space triangle.
//! - **Masks**: an instance is traced only for rays whose mask shares a
//!   bit with the instance's ([`Query::with_mask`]; both default to all
//!   ones).
//! - **Filters**: a filter sees each candidate hit that lies within the
//!   ray's current interval and returns whether to keep it. It must be a
//!   pure function of the hit: paths call it in different orders and a
//!   different number of times.
//! - **Edits**: [`Scene::edit`] adds, moves, re-masks and removes
//!   instances; the top level is rebuilt once when the edit ends, never
//!   the meshes' trees. Instance ids stay fixed; a removed instance's id
//!   is not reused.

mod brute;
mod tlas;
mod transform;

pub use brute::BruteScene;
pub use tlas::TopLevel;
pub use transform::{
    HierarchyError, HierarchyNode, MAX_CONDITION, Transform, TransformError, flatten,
};

use crate::aabb::Aabb;
use crate::bvh::Bvh8;
use crate::kdtree::{Avx2, BuildPacket, Counters, KdTree, NoCount, affine_packet8, stream_order};
use crate::mesh::Mesh;
use crate::packet::{HitPacket, RayPacket, RayPacket4, RayPacket8};
use crate::ray::{Hit, Ray};
use crate::simd::{F4, F8, Lane};
use glam::{Affine3A, Vec3};
use std::fmt;
use std::sync::Arc;
use tlas::{PaddedRay, Tlas};
use transform::Pad;

/// A geometry's index in its scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct GeometryId(pub u32);

/// An instance's index in its scene; fixed for the instance's lifetime.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct InstanceId(pub u32);

/// A hit in a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// The ray parameter (world and object space alike).
    pub t: f32,
    /// Barycentric of the triangle's second vertex.
    pub u: f32,
    /// Barycentric of the triangle's third vertex.
    pub v: f32,
    /// The triangle's index in its geometry's mesh.
    pub prim: u32,
    /// The geometry hit.
    pub geometry: GeometryId,
    /// The instance hit.
    pub instance: InstanceId,
}

impl SceneHit {
    /// The scene's order of hits: closer, or as close with a smaller
    /// instance id, or the same instance with a smaller triangle index.
    ///
    /// ```
    /// use packtrace::scene::{GeometryId, InstanceId, SceneHit};
    /// let h = |t, i| SceneHit { t, u: 0.0, v: 0.0, prim: 0, geometry: GeometryId(0), instance: InstanceId(i) };
    /// assert!(h(1.0, 5).closer_than(&h(2.0, 0)));
    /// assert!(h(1.0, 0).closer_than(&h(1.0, 5)));
    /// ```
    #[must_use]
    pub fn closer_than(&self, o: &SceneHit) -> bool {
        (self.t, self.instance.0, self.prim) < (o.t, o.instance.0, o.prim)
    }
}

/// The hits of a packet: lane `i` is the query of ray `i`.
#[derive(Clone, Copy, Debug)]
pub struct SceneHits<L: Lane> {
    hits: HitPacket<L>,
    // Index lanes (aligned, one vector select per update) rather than
    // `[u32; 8]` arrays: per 8-wide query, the ids' lane-by-lane selects
    // and an unaligned 224-byte result copied with `memcpy` cost about 70
    // instructions more (callgrind, teapot primary rays).
    instance: L::Index,
    geometry: L::Index,
}

/// The hits of a 4-wide packet.
pub type SceneHits4 = SceneHits<F4>;
/// The hits of an 8-wide packet.
pub type SceneHits8 = SceneHits<F8>;

impl<L: Lane> Default for SceneHits<L> {
    fn default() -> Self {
        SceneHits {
            hits: HitPacket::default(),
            instance: L::index_splat(u32::MAX),
            geometry: L::index_splat(u32::MAX),
        }
    }
}

impl<L: Lane> SceneHits<L> {
    /// Lane `i`'s hit, or `None`.
    ///
    /// ```
    /// let h = packtrace::scene::SceneHits8::default();
    /// assert_eq!(h.hit(3), None);
    /// ```
    #[must_use]
    pub fn hit(&self, i: usize) -> Option<SceneHit> {
        self.hits.hit(i).map(|h| SceneHit {
            t: h.t,
            u: h.u,
            v: h.v,
            prim: h.prim,
            geometry: GeometryId(L::index_lane(self.geometry, i)),
            instance: InstanceId(L::index_lane(self.instance, i)),
        })
    }

    /// Bit `i` set when lane `i` has a hit.
    ///
    /// ```
    /// assert_eq!(packtrace::scene::SceneHits4::default().mask(), 0);
    /// ```
    #[must_use]
    pub fn mask(&self) -> u32 {
        self.hits.mask()
    }

    fn set(&mut self, i: usize, h: Option<SceneHit>) {
        self.hits.set(
            i,
            h.map(|h| Hit {
                t: h.t,
                prim: h.prim,
                u: h.u,
                v: h.v,
            }),
        );
        if let Some(h) = h {
            self.instance = L::index_with_lane(self.instance, i, h.instance.0);
            self.geometry = L::index_with_lane(self.geometry, i, h.geometry.0);
        }
    }
}

/// An any-hit filter: `true` keeps the hit. See the module's rules.
pub type Filter<'a> = &'a (dyn Fn(&SceneHit) -> bool + Sync + 'a);

/// What a scene query may skip: the ray mask (per ray, or per packet
/// lane) and an any-hit filter.
///
/// ```
/// use packtrace::scene::Query;
/// let q = Query::new().with_mask(0b100);
/// assert_eq!((q.mask(0), q.mask(7)), (0b100, 0b100));
/// let q = q.with_lane_masks([1, 2, 3, 4, 5, 6, 7, 8]);
/// assert_eq!(q.mask(2), 3);
/// assert!(q.filter().is_none());
/// ```
#[derive(Clone, Copy)]
pub struct Query<'a> {
    masks: [u32; 8],
    filter: Option<Filter<'a>>,
}

impl Default for Query<'_> {
    fn default() -> Self {
        Query::new()
    }
}

impl fmt::Debug for Query<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Query")
            .field("masks", &self.masks)
            .field("filter", &self.filter.is_some())
            .finish()
    }
}

impl<'a> Query<'a> {
    /// Every instance (masks all ones), no filter.
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Query::new().mask(0), u32::MAX);
    /// ```
    #[must_use]
    pub fn new() -> Query<'a> {
        Query {
            masks: [u32::MAX; 8],
            filter: None,
        }
    }

    /// The same ray mask for every ray (and lane).
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Query::new().with_mask(3).mask(5), 3);
    /// ```
    #[must_use]
    pub fn with_mask(mut self, mask: u32) -> Query<'a> {
        self.masks = [mask; 8];
        self
    }

    /// One mask per packet lane (a scalar or stream query uses lane 0's).
    ///
    /// ```
    /// let q = packtrace::scene::Query::new().with_lane_masks([9; 8]);
    /// assert_eq!(q.mask(0), 9);
    /// ```
    #[must_use]
    pub fn with_lane_masks(mut self, masks: [u32; 8]) -> Query<'a> {
        self.masks = masks;
        self
    }

    /// An any-hit filter (see the module's rules).
    ///
    /// ```
    /// let opaque = |_: &packtrace::scene::SceneHit| true;
    /// assert!(packtrace::scene::Query::new().with_filter(&opaque).filter().is_some());
    /// ```
    #[must_use]
    pub fn with_filter(mut self, f: Filter<'a>) -> Query<'a> {
        self.filter = Some(f);
        self
    }

    /// Lane `i`'s mask (`i < 8`).
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Query::new().mask(1), u32::MAX);
    /// ```
    #[must_use]
    pub fn mask(&self, i: usize) -> u32 {
        self.masks[i & 7]
    }

    /// The filter, if any.
    ///
    /// ```
    /// assert!(packtrace::scene::Query::new().filter().is_none());
    /// ```
    #[must_use]
    pub fn filter(&self) -> Option<Filter<'a>> {
        self.filter
    }
}

/// Why a scene refused an edit.
///
/// ```
/// use packtrace::glam::Affine3A;
/// use packtrace::scene::{GeometryId, Scene, SceneError};
/// let mut s = Scene::new();
/// let e = s.edit().add_instance(GeometryId(3), Affine3A::IDENTITY).unwrap_err();
/// assert_eq!(e, SceneError::UnknownGeometry(GeometryId(3)));
/// assert_eq!(e.to_string(), "no geometry 3 in the scene");
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SceneError {
    /// No geometry with this id.
    UnknownGeometry(GeometryId),
    /// No live instance with this id (never added, or removed).
    UnknownInstance(InstanceId),
    /// The transform was refused.
    Transform(TransformError),
    /// More than `u32::MAX - 1` instances or geometries.
    TooMany,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::UnknownGeometry(g) => write!(f, "no geometry {} in the scene", g.0),
            SceneError::UnknownInstance(i) => write!(f, "no instance {} in the scene", i.0),
            // The reason comes through `source()`.
            SceneError::Transform(_) => write!(f, "bad instance transform"),
            SceneError::TooMany => write!(f, "too many instances or geometries"),
        }
    }
}

impl std::error::Error for SceneError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SceneError::Transform(e) => Some(e),
            _ => None,
        }
    }
}

impl From<TransformError> for SceneError {
    fn from(e: TransformError) -> Self {
        SceneError::Transform(e)
    }
}

/// The structure a geometry is traced with: a kd-tree or an 8-wide BVH,
/// shared by the geometry's instances (and by other scenes).
///
/// ```
/// use packtrace::bvh::{Bvh8, BvhBuildParams};
/// use packtrace::scene::GeometryAccel;
/// let m = packtrace::protocol::generate::sphere(100);
/// let a: GeometryAccel = Bvh8::build(m, &BvhBuildParams::default()).unwrap().into();
/// assert_eq!(a.mesh().triangle_count(), 100);
/// ```
#[derive(Clone, Debug)]
pub enum GeometryAccel {
    /// A kd-tree.
    Kd(Arc<KdTree>),
    /// An 8-wide BVH.
    Bvh8(Arc<Bvh8>),
}

impl GeometryAccel {
    /// The mesh it was built over.
    ///
    /// ```
    /// let t = packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap();
    /// assert!(packtrace::scene::GeometryAccel::from(t).mesh().is_empty());
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        match self {
            GeometryAccel::Kd(t) => t.mesh(),
            GeometryAccel::Bvh8(b) => b.mesh(),
        }
    }

    /// The box of its mesh (object space).
    fn bounds(&self) -> Aabb {
        match self {
            GeometryAccel::Kd(t) => t.bounds(),
            GeometryAccel::Bvh8(b) => b.bounds(),
        }
    }
}

impl From<KdTree> for GeometryAccel {
    fn from(t: KdTree) -> Self {
        GeometryAccel::Kd(Arc::new(t))
    }
}

impl From<Arc<KdTree>> for GeometryAccel {
    fn from(t: Arc<KdTree>) -> Self {
        GeometryAccel::Kd(t)
    }
}

impl From<Bvh8> for GeometryAccel {
    fn from(b: Bvh8) -> Self {
        GeometryAccel::Bvh8(Arc::new(b))
    }
}

impl From<Arc<Bvh8>> for GeometryAccel {
    fn from(b: Arc<Bvh8>) -> Self {
        GeometryAccel::Bvh8(b)
    }
}

/// A mesh's structure in a scene (a kd-tree or an 8-wide BVH), shared by
/// its instances.
#[derive(Clone, Debug)]
pub struct Geometry {
    name: String,
    accel: GeometryAccel,
}

impl Geometry {
    /// The name it was added with.
    ///
    /// ```
    /// let mut s = packtrace::scene::Scene::new();
    /// let t = packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap();
    /// let g = s.add_geometry("floor", t);
    /// assert_eq!(s.geometry(g).unwrap().name(), "floor");
    /// ```
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Its mesh.
    ///
    /// ```
    /// let mut s = packtrace::scene::Scene::new();
    /// let t = packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap();
    /// let g = s.add_geometry("empty", t);
    /// assert!(s.geometry(g).unwrap().mesh().is_empty());
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        self.accel.mesh()
    }

    /// Its structure.
    ///
    /// ```
    /// use packtrace::scene::GeometryAccel;
    /// let mut s = packtrace::scene::Scene::new();
    /// let t = packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap();
    /// let g = s.add_geometry("kd", t);
    /// assert!(matches!(s.geometry(g).unwrap().accel(), GeometryAccel::Kd(_)));
    /// ```
    #[must_use]
    pub fn accel(&self) -> &GeometryAccel {
        &self.accel
    }

    /// Its kd-tree, if it is traced with one.
    ///
    /// ```
    /// let mut s = packtrace::scene::Scene::new();
    /// let t = packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap();
    /// let g = s.add_geometry("kd", t);
    /// assert!(s.geometry(g).unwrap().kd_tree().is_some());
    /// ```
    #[must_use]
    pub fn kd_tree(&self) -> Option<&KdTree> {
        match &self.accel {
            GeometryAccel::Kd(t) => Some(t),
            GeometryAccel::Bvh8(_) => None,
        }
    }

    /// Its 8-wide BVH, if it is traced with one.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let mut s = packtrace::scene::Scene::new();
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// let g = s.add_geometry("bvh", b);
    /// assert!(s.geometry(g).unwrap().bvh8().is_some());
    /// ```
    #[must_use]
    pub fn bvh8(&self) -> Option<&Bvh8> {
        match &self.accel {
            GeometryAccel::Bvh8(b) => Some(b),
            GeometryAccel::Kd(_) => None,
        }
    }

    /// Its kd-tree (and through it, the mesh).
    ///
    /// # Panics
    /// If the geometry is traced with an 8-wide BVH: use
    /// [`Geometry::mesh`], [`Geometry::accel`] or [`Geometry::kd_tree`],
    /// which serve both.
    ///
    /// ```
    /// let mut s = packtrace::scene::Scene::new();
    /// let t = packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap();
    /// let g = s.add_geometry("empty", t);
    /// assert!(s.geometry(g).unwrap().tree().mesh().is_empty());
    /// ```
    #[must_use]
    #[allow(clippy::panic)]
    pub fn tree(&self) -> &KdTree {
        match &self.accel {
            GeometryAccel::Kd(t) => t,
            GeometryAccel::Bvh8(_) => panic!(
                "geometry `{}` is traced with an 8-wide BVH, not a kd-tree: use mesh() or accel()",
                self.name
            ),
        }
    }
}

/// A geometry placed in the world.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    geometry: GeometryId,
    transform: Transform,
    mask: u32,
    world: Aabb,
}

impl Instance {
    /// The geometry it places.
    ///
    /// ```
    /// # let mut s = packtrace::scene::Scene::new();
    /// # let g = s.add_geometry("g", packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap());
    /// let i = s.edit().add_instance(g, packtrace::glam::Affine3A::IDENTITY).unwrap();
    /// assert_eq!(s.instance(i).unwrap().geometry(), g);
    /// ```
    #[must_use]
    pub fn geometry(&self) -> GeometryId {
        self.geometry
    }

    /// Its transform.
    ///
    /// ```
    /// # let mut s = packtrace::scene::Scene::new();
    /// # let g = s.add_geometry("g", packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap());
    /// let i = s.edit().add_instance(g, packtrace::glam::Affine3A::IDENTITY).unwrap();
    /// assert_eq!(s.instance(i).unwrap().transform().condition(), 1.0);
    /// ```
    #[must_use]
    pub fn transform(&self) -> &Transform {
        &self.transform
    }

    /// Its mask (all ones unless set).
    ///
    /// ```
    /// # let mut s = packtrace::scene::Scene::new();
    /// # let g = s.add_geometry("g", packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap());
    /// let i = s.edit().add_instance(g, packtrace::glam::Affine3A::IDENTITY).unwrap();
    /// assert_eq!(s.instance(i).unwrap().mask(), u32::MAX);
    /// ```
    #[must_use]
    pub fn mask(&self) -> u32 {
        self.mask
    }

    /// Its world box (conservative: the exact image of the mesh's box,
    /// rounded outwards).
    ///
    /// ```
    /// # use packtrace::glam::{Affine3A, Vec3};
    /// # let mut s = packtrace::scene::Scene::new();
    /// # let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// # let g = s.add_geometry("g", packtrace::KdTree::build(m, &Default::default()).unwrap());
    /// let i = s.edit().add_instance(g, Affine3A::from_translation(Vec3::Z)).unwrap();
    /// assert!(s.instance(i).unwrap().world_bounds().max.z >= 1.0);
    /// ```
    #[must_use]
    pub fn world_bounds(&self) -> Aabb {
        self.world
    }
}

/// Geometries, instances and the top level over them. `Send + Sync`:
/// query from any number of threads; edit with `&mut`.
///
/// See the [module documentation](self) for an example and the rules.
#[derive(Clone, Debug)]
pub struct Scene {
    geometries: Vec<Geometry>,
    instances: Vec<Option<Instance>>,
    top: TopLevel,
    tlas: Tlas,
    /// The top level's pad factors (`transform::Pad`).
    pad: (f32, f32),
    bounds: Aabb,
}

/// Edits to a scene's instances; the top level is rebuilt once, when the
/// edit is committed or dropped.
///
/// ```
/// use packtrace::glam::{Affine3A, Vec3};
/// # let mut scene = packtrace::scene::Scene::new();
/// # let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// # let g = scene.add_geometry("g", packtrace::KdTree::build(m, &Default::default()).unwrap());
/// let ids: Vec<_> = {
///     let mut e = scene.edit();
///     (0..100).map(|i| e.add_instance(g, Affine3A::from_translation(Vec3::X * i as f32)).unwrap()).collect()
/// }; // dropped: committed
/// let mut e = scene.edit();
/// for &id in &ids {
///     e.set_transform(id, Affine3A::from_translation(Vec3::Y))?;
/// }
/// e.remove_instance(ids[0])?;
/// e.commit();
/// assert_eq!(scene.instance_count(), 99);
/// # Ok::<(), packtrace::scene::SceneError>(())
/// ```
#[derive(Debug)]
pub struct SceneEdit<'s> {
    scene: &'s mut Scene,
}

impl Scene {
    /// An empty scene with the default top level ([`TopLevel::Sah`]).
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Scene::new().instance_count(), 0);
    /// ```
    #[must_use]
    pub fn new() -> Scene {
        Scene::with_top_level(TopLevel::Sah)
    }

    /// An empty scene whose top level is built with `top`.
    ///
    /// ```
    /// use packtrace::scene::{Scene, TopLevel};
    /// assert_eq!(Scene::with_top_level(TopLevel::Median).top_level(), TopLevel::Median);
    /// ```
    #[must_use]
    pub fn with_top_level(top: TopLevel) -> Scene {
        Scene {
            geometries: Vec::new(),
            instances: Vec::new(),
            top,
            tlas: Tlas::default(),
            pad: (0.0, 0.0),
            bounds: Aabb::EMPTY,
        }
    }

    /// How the top level is built.
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Scene::new().top_level(), packtrace::scene::TopLevel::Sah);
    /// ```
    #[must_use]
    pub fn top_level(&self) -> TopLevel {
        self.top
    }

    /// Adds a geometry (its kd-tree or 8-wide BVH, built once and never
    /// rebuilt by the scene) and returns its id.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let mut s = packtrace::scene::Scene::new();
    /// let t = packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap();
    /// assert_eq!(s.add_geometry("a", t).0, 0);
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// assert_eq!(s.add_geometry("b", b).0, 1);
    /// ```
    pub fn add_geometry(&mut self, name: &str, accel: impl Into<GeometryAccel>) -> GeometryId {
        self.add_shared_geometry(name, accel)
    }

    /// Adds a geometry whose structure is shared with other scenes (an
    /// `Arc<KdTree>` or an `Arc<Bvh8>`).
    ///
    /// ```
    /// use std::sync::Arc;
    /// let t = Arc::new(packtrace::KdTree::build(packtrace::Mesh::default(), &Default::default()).unwrap());
    /// let (mut a, mut b) = (packtrace::scene::Scene::new(), packtrace::scene::Scene::new());
    /// a.add_shared_geometry("m", t.clone());
    /// b.add_shared_geometry("m", t);
    /// ```
    pub fn add_shared_geometry(
        &mut self,
        name: &str,
        accel: impl Into<GeometryAccel>,
    ) -> GeometryId {
        self.geometries.push(Geometry {
            name: name.to_string(),
            accel: accel.into(),
        });
        GeometryId((self.geometries.len() - 1) as u32)
    }

    /// The geometry `id`, or `None`.
    ///
    /// ```
    /// assert!(packtrace::scene::Scene::new().geometry(packtrace::scene::GeometryId(0)).is_none());
    /// ```
    #[must_use]
    pub fn geometry(&self, id: GeometryId) -> Option<&Geometry> {
        self.geometries.get(id.0 as usize)
    }

    /// Number of geometries.
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Scene::new().geometry_count(), 0);
    /// ```
    #[must_use]
    pub fn geometry_count(&self) -> usize {
        self.geometries.len()
    }

    /// The live instance `id`, or `None`.
    ///
    /// ```
    /// assert!(packtrace::scene::Scene::new().instance(packtrace::scene::InstanceId(0)).is_none());
    /// ```
    #[must_use]
    pub fn instance(&self, id: InstanceId) -> Option<&Instance> {
        self.instances.get(id.0 as usize).and_then(Option::as_ref)
    }

    /// The live instances with their ids, in id order.
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Scene::new().instances().count(), 0);
    /// ```
    pub fn instances(&self) -> impl Iterator<Item = (InstanceId, &Instance)> {
        self.instances
            .iter()
            .enumerate()
            .filter_map(|(i, x)| x.as_ref().map(|x| (InstanceId(i as u32), x)))
    }

    /// Number of live instances.
    ///
    /// ```
    /// assert_eq!(packtrace::scene::Scene::new().instance_count(), 0);
    /// ```
    #[must_use]
    pub fn instance_count(&self) -> usize {
        self.instances.iter().flatten().count()
    }

    /// The world box of every live instance.
    ///
    /// ```
    /// assert!(packtrace::scene::Scene::new().bounds().is_empty());
    /// ```
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Starts editing the instances; the top level is rebuilt when the
    /// returned edit is committed or dropped.
    ///
    /// ```
    /// let mut s = packtrace::scene::Scene::new();
    /// s.edit().commit();
    /// ```
    pub fn edit(&mut self) -> SceneEdit<'_> {
        SceneEdit { scene: self }
    }

    /// The world-space geometric normal of a hit (the object normal by
    /// the inverse transpose; a mirrored instance keeps the winding's
    /// normal pointing out of the mirrored side), or `None` for a hit not
    /// of this scene.
    ///
    /// ```
    /// use packtrace::glam::{Affine3A, Vec3};
    /// # let mut s = packtrace::scene::Scene::new();
    /// # let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// # let g = s.add_geometry("g", packtrace::KdTree::build(m, &Default::default()).unwrap());
    /// s.edit().add_instance(g, Affine3A::from_rotation_x(std::f32::consts::PI))?;
    /// let r = packtrace::Ray::new(Vec3::new(0.2, -0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// let n = s.normal(&s.intersect(&r).unwrap()).unwrap();
    /// assert!((n - Vec3::NEG_Z).length() < 1e-6);
    /// # Ok::<(), packtrace::scene::SceneError>(())
    /// ```
    #[must_use]
    pub fn normal(&self, hit: &SceneHit) -> Option<Vec3> {
        let inst = self.instance(hit.instance)?;
        let mesh = self.geometry(inst.geometry)?.mesh();
        ((hit.prim as usize) < mesh.triangle_count()).then(|| {
            inst.transform
                .normal_to_world(mesh.normal(hit.prim as usize))
        })
    }

    /// Rebuilds the top level and the pad over the live instances.
    fn commit(&mut self) {
        // Instances of empty meshes can never be hit: left out of the top
        // level and of the pad (their boxes are empty, their magnitude
        // infinite).
        let live: Vec<(u32, Aabb)> = self
            .instances()
            .filter(|(_, inst)| !inst.world.is_empty())
            .map(|(id, inst)| (id.0, inst.world))
            .collect();
        self.tlas = Tlas::build(&live, self.top);
        self.bounds = self.tlas.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds);
        let pad = self
            .instances()
            .filter(|(_, inst)| !inst.world.is_empty())
            .map(|(_, inst)| {
                let accel = &self.geometries[inst.geometry.0 as usize].accel;
                inst.transform.pad(&accel.bounds(), &inst.world)
            })
            .fold(Pad::default(), Pad::max);
        self.pad = pad.factors();
    }
}

impl Default for Scene {
    fn default() -> Scene {
        Scene::new()
    }
}

impl SceneEdit<'_> {
    /// Places geometry `g` with the object-to-world transform `to_world`
    /// (mask all ones) and returns the new instance's id.
    ///
    /// # Errors
    /// [`SceneError::UnknownGeometry`], [`SceneError::Transform`] (a
    /// singular, ill-conditioned or non-finite transform), or
    /// [`SceneError::TooMany`].
    pub fn add_instance(
        &mut self,
        g: GeometryId,
        to_world: Affine3A,
    ) -> Result<InstanceId, SceneError> {
        let geo = self
            .scene
            .geometries
            .get(g.0 as usize)
            .ok_or(SceneError::UnknownGeometry(g))?;
        let transform = Transform::new(to_world)?;
        let world = transform.world_bounds(&geo.accel.bounds());
        let id = self.scene.instances.len();
        if id >= u32::MAX as usize {
            return Err(SceneError::TooMany);
        }
        self.scene.instances.push(Some(Instance {
            geometry: g,
            transform,
            mask: u32::MAX,
            world,
        }));
        Ok(InstanceId(id as u32))
    }

    /// Moves an instance.
    ///
    /// # Errors
    /// [`SceneError::UnknownInstance`] or [`SceneError::Transform`]; the
    /// instance is unchanged on error.
    pub fn set_transform(&mut self, id: InstanceId, to_world: Affine3A) -> Result<(), SceneError> {
        let transform = Transform::new(to_world)?;
        let geometries = &self.scene.geometries;
        let inst = live_mut(&mut self.scene.instances, id)?;
        inst.world = transform.world_bounds(&geometries[inst.geometry.0 as usize].accel.bounds());
        inst.transform = transform;
        Ok(())
    }

    /// Sets an instance's mask: rays whose mask shares no bit with it
    /// skip the instance.
    ///
    /// # Errors
    /// [`SceneError::UnknownInstance`].
    pub fn set_mask(&mut self, id: InstanceId, mask: u32) -> Result<(), SceneError> {
        live_mut(&mut self.scene.instances, id)?.mask = mask;
        Ok(())
    }

    /// Removes an instance (its id is not reused).
    ///
    /// # Errors
    /// [`SceneError::UnknownInstance`].
    pub fn remove_instance(&mut self, id: InstanceId) -> Result<(), SceneError> {
        live_mut(&mut self.scene.instances, id)?;
        self.scene.instances[id.0 as usize] = None;
        Ok(())
    }

    /// Ends the edit, rebuilding the top level (dropping the edit does the
    /// same).
    pub fn commit(self) {}
}

/// The live instance `id`, or [`SceneError::UnknownInstance`].
fn live_mut(
    instances: &mut [Option<Instance>],
    id: InstanceId,
) -> Result<&mut Instance, SceneError> {
    instances
        .get_mut(id.0 as usize)
        .and_then(Option::as_mut)
        .ok_or(SceneError::UnknownInstance(id))
}

impl Drop for SceneEdit<'_> {
    fn drop(&mut self) {
        self.scene.commit();
    }
}

/// The query traits of scenes, implemented by [`Scene`] and by the
/// brute-force oracle [`BruteScene`], so tests treat them alike (as
/// [`crate::RayQuery`] and [`crate::PacketQuery`] do for one mesh). Lane
/// `i` of every packet answer equals the single-ray answer of ray `i`.
///
/// ```
/// use packtrace::glam::{Affine3A, Vec3};
/// use packtrace::scene::{BruteScene, Query, Scene, SceneQuery};
/// # let mut scene = Scene::new();
/// # let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// # let g = scene.add_geometry("g", packtrace::KdTree::build(m, &Default::default()).unwrap());
/// scene.edit().add_instance(g, Affine3A::from_rotation_y(0.3))?;
/// let r = packtrace::Ray::new(Vec3::new(0.2, 0.2, 2.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// let q = Query::new();
/// let engines: [&dyn SceneQuery; 2] = [&scene, &BruteScene::new(&scene)];
/// assert_eq!(engines[0].intersect_with(&r, &q), engines[1].intersect_with(&r, &q));
/// # Ok::<(), packtrace::scene::SceneError>(())
/// ```
pub trait SceneQuery {
    /// Closest hit of `ray` under `q`.
    fn intersect_with(&self, ray: &Ray, q: &Query<'_>) -> Option<SceneHit>;
    /// Does `ray` have any hit under `q`?
    fn occluded_with(&self, ray: &Ray, q: &Query<'_>) -> bool;
    /// Closest hits of a 4-wide packet.
    fn intersect4_with(&self, p: &RayPacket4, q: &Query<'_>) -> SceneHits4;
    /// Occlusion of a 4-wide packet (bit `i`: lane `i`).
    fn occluded4_with(&self, p: &RayPacket4, q: &Query<'_>) -> u32;
    /// Closest hits of an 8-wide packet.
    fn intersect8_with(&self, p: &RayPacket8, q: &Query<'_>) -> SceneHits8;
    /// Occlusion of an 8-wide packet.
    fn occluded8_with(&self, p: &RayPacket8, q: &Query<'_>) -> u32;
    /// Closest hits of a stream, `hits[i]` for `rays[i]` (lane 0's mask
    /// of `q` for every ray).
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    fn intersect_rays_with(&self, rays: &[Ray], hits: &mut [Option<SceneHit>], q: &Query<'_>) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        let q = q.with_mask(q.mask(0));
        for (rs, hs) in rays.chunks(8).zip(hits.chunks_mut(8)) {
            let h = self.intersect8_with(&RayPacket8::from_slice(rs), &q);
            for (i, slot) in hs.iter_mut().enumerate() {
                *slot = h.hit(i);
            }
        }
    }
    /// Occlusion of a stream, `occluded[i]` for `rays[i]`.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    fn occluded_rays_with(&self, rays: &[Ray], occluded: &mut [bool], q: &Query<'_>) {
        assert_eq!(rays.len(), occluded.len(), "one slot per ray");
        let q = q.with_mask(q.mask(0));
        for (rs, os) in rays.chunks(8).zip(occluded.chunks_mut(8)) {
            let m = self.occluded8_with(&RayPacket8::from_slice(rs), &q);
            for (i, slot) in os.iter_mut().enumerate() {
                *slot = m >> i & 1 == 1;
            }
        }
    }
}

/// The kd traversal's hooks for one instance: the query's filter, told
/// which instance and geometry the candidate hit belongs to.
struct FilterHook<'f> {
    filter: Filter<'f>,
    instance: u32,
    geometry: u32,
}

impl Counters for FilterHook<'_> {
    const FILTERS: bool = true;
    #[inline]
    fn accept(&mut self, prim: u32, t: f32, u: f32, v: f32) -> bool {
        (self.filter)(&SceneHit {
            t,
            u,
            v,
            prim,
            geometry: GeometryId(self.geometry),
            instance: InstanceId(self.instance),
        })
    }
}

impl Scene {
    /// Closest hit of `ray` over every instance (no mask, no filter).
    ///
    /// ```
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(packtrace::scene::Scene::new().intersect(&r), None);
    /// ```
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<SceneHit> {
        self.intersect_with(ray, &Query::new())
    }

    /// Is there any hit of `ray` (no mask, no filter)?
    ///
    /// ```
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// assert!(!packtrace::scene::Scene::new().occluded(&r));
    /// ```
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, &Query::new())
    }

    /// Closest hits of a packet of any width under `q`.
    ///
    /// ```
    /// use packtrace::{RayPacket8, scene::{Query, Scene}};
    /// let h = Scene::new().intersect_packet(&RayPacket8::from_lanes([None; 8]), &Query::new());
    /// assert_eq!(h.mask(), 0);
    /// ```
    #[must_use]
    pub fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>, q: &Query<'_>) -> SceneHits<L> {
        let mut out = SceneHits::default();
        self.intersect_packet_into(p, q, &mut out);
        out
    }

    /// [`Scene::intersect_packet`] written into `out` (every lane set),
    /// as a host's ray-and-hit buffer is filled in place: no result
    /// copied out of the call (about 3 % of an instance's primary packets
    /// on the teapot, perf).
    ///
    /// ```
    /// use packtrace::{RayPacket8, scene::{Query, Scene, SceneHits8}};
    /// let mut h = SceneHits8::default();
    /// Scene::new().intersect_packet_into(&RayPacket8::from_lanes([None; 8]), &Query::new(), &mut h);
    /// assert_eq!(h.mask(), 0);
    /// ```
    pub fn intersect_packet_into<L: Lane>(
        &self,
        p: &RayPacket<L>,
        q: &Query<'_>,
        out: &mut SceneHits<L>,
    ) {
        match q.filter {
            None => self.trace_packet::<L, false, _>(p, q, |_, _| NoCount, out),
            Some(f) => self.trace_packet::<L, false, _>(
                p,
                q,
                |i, g| FilterHook {
                    filter: f,
                    instance: i,
                    geometry: g,
                },
                out,
            ),
        }
    }

    /// Occlusion of a packet of any width under `q`: bit `i` for lane `i`.
    ///
    /// ```
    /// use packtrace::{RayPacket4, scene::{Query, Scene}};
    /// assert_eq!(Scene::new().occluded_packet(&RayPacket4::from_lanes([None; 4]), &Query::new()), 0);
    /// ```
    #[must_use]
    pub fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>, q: &Query<'_>) -> u32 {
        let mut out = SceneHits::default();
        match q.filter {
            None => self.trace_packet::<L, true, _>(p, q, |_, _| NoCount, &mut out),
            Some(f) => self.trace_packet::<L, true, _>(
                p,
                q,
                |i, g| FilterHook {
                    filter: f,
                    instance: i,
                    geometry: g,
                },
                &mut out,
            ),
        }
        out.mask()
    }

    /// The one scalar scene traversal: the top level finds the instances
    /// whose padded boxes the ray meets, nearest first; each traces the
    /// object-space ray through its geometry's kd-tree up to the closest
    /// hit so far. A top level of one instance skips the walk.
    fn trace_ray<const ANY: bool, C: Counters>(
        &self,
        ray: &Ray,
        q: &Query<'_>,
        hooks: impl Fn(u32, u32) -> C,
    ) -> Option<SceneHit> {
        // One instance under the top level: no walk and no merge, the
        // instance's hit is the scene's (any transform, mask and filter).
        if let Some(&[id]) = self.tlas.lone_leaf() {
            return self.trace_instance::<ANY, C>(ray, q.mask(0), id, ray.t_max, &hooks);
        }
        self.walk_instances::<ANY, C>(ray, q, hooks)
    }

    /// One instance's closest (or any) hit of `ray` up to `t_max`, in
    /// world terms: the mask test, the object-space ray, its tree.
    #[inline(always)]
    fn trace_instance<const ANY: bool, C: Counters>(
        &self,
        ray: &Ray,
        mask: u32,
        id: u32,
        t_max: f32,
        hooks: &impl Fn(u32, u32) -> C,
    ) -> Option<SceneHit> {
        let inst = self.instances[id as usize].as_ref()?;
        // Mask: one AND skips the instance.
        if inst.mask & mask == 0 {
            return None;
        }
        let g = inst.geometry.0;
        let local = inst.transform.ray_to_object(ray, t_max);
        let h = match &self.geometries[g as usize].accel {
            GeometryAccel::Kd(tree) => tree.trace_ray_with::<ANY, C>(&local, &mut hooks(id, g)),
            GeometryAccel::Bvh8(bvh) => bvh.trace_ray::<ANY, C>(&local, &mut hooks(id, g)),
        }?;
        Some(SceneHit {
            t: h.t,
            u: h.u,
            v: h.v,
            prim: h.prim,
            geometry: inst.geometry,
            instance: InstanceId(id),
        })
    }

    /// [`Scene::trace_ray`] through the top level's walk: instances
    /// nearest box first, each up to the closest hit so far. Inlined:
    /// `#[inline(never)]` saved the one-instance path 7 instructions per
    /// ray (a smaller frame) and cost `data/cornell_spheres.scene`'s
    /// scalar rays 13 (callgrind).
    #[inline]
    fn walk_instances<const ANY: bool, C: Counters>(
        &self,
        ray: &Ray,
        q: &Query<'_>,
        hooks: impl Fn(u32, u32) -> C,
    ) -> Option<SceneHit> {
        let org = ray.origin.to_array();
        let padded = || {
            PaddedRay::<f32>::new(
                &org,
                &ray.inv_dir.to_array(),
                ray.dir_neg(),
                self.pad.0,
                self.pad.1,
            )
        };
        let mask = q.mask(0);
        let mut best: Option<SceneHit> = None;
        self.tlas.walk_ray(padded, ray.t_min, ray.t_max, |id| {
            let t_max = best.map_or(ray.t_max, |b| b.t);
            let Some(cand) = self.trace_instance::<ANY, C>(ray, mask, id, t_max, &hooks) else {
                return t_max;
            };
            if ANY {
                best = Some(cand);
                return f32::NAN;
            }
            // Closer, or as close with a smaller instance id (the rule).
            if best.is_none_or(|b| cand.closer_than(&b)) {
                best = Some(cand);
            }
            best.map_or(t_max, |b| b.t)
        });
        best
    }

    /// The one packet scene traversal: the top level for all lanes, the
    /// lanes that meet an instance transformed together, the instance's
    /// tree traced with the width-generic packet query, and each lane's
    /// closest hit kept by the scene's rule.
    fn trace_packet<L: Lane, const ANY: bool, C: Counters>(
        &self,
        p: &RayPacket<L>,
        q: &Query<'_>,
        hooks: impl Fn(u32, u32) -> C,
        out: &mut SceneHits<L>,
    ) {
        // Every line of the packet requested at once, before the first
        // load that waits: read first, the active mask (in the last line)
        // held the others back. Teapot primary packet8 rays, instance /
        // bare tree in pairs (`examples/instance_pairs.rs`, AMD Zen 4):
        // 0.86-0.88 -> 0.93-0.94 (docs/instances.md).
        crate::kdtree::prefetch_all(p);
        *out = SceneHits::default();
        if p.active() == 0 || self.tlas.nodes.is_empty() {
            return;
        }
        // Only a top level with interior nodes needs the padded lanes.
        let padded = || {
            let neg = p.neg_bits().map(|b| L::mask_from_bits(b));
            PaddedRay::<L>::new(p.org(), p.inv_dir(), neg, self.pad.0, self.pad.1)
        };
        let neg_inf = L::splat(f32::NEG_INFINITY);
        let best_t = L::select(L::mask_from_bits(p.active()), p.t_max(), neg_inf);
        let t_min = p.t_min();
        let uniform = (0..L::WIDTH).all(|i| q.mask(i) == q.mask(0));
        self.tlas
            .walk_packet(padded, t_min, best_t, |id, lanes, best_t| {
                let Some(inst) = self.instances[id as usize].as_ref() else {
                    return;
                };
                // Masks: lanes whose mask shares no bit skip the instance (one
                // AND when every lane has the same mask).
                let lanes = if uniform {
                    if inst.mask & q.mask(0) == 0 { 0 } else { lanes }
                } else {
                    (0..L::WIDTH).fold(0, |m, i| {
                        m | (((lanes >> i & 1 == 1) && inst.mask & q.mask(i) != 0) as u32) << i
                    })
                };
                if lanes == 0 {
                    return;
                }
                let g = inst.geometry.0;
                // The lanes in object space, together, built, traced and
                // merged inside the kernel (`ObjectLanes`).
                let mut local = ObjectLanes::<L, ANY> {
                    xf: &inst.transform,
                    world: p,
                    best_t,
                    lanes,
                    instance: id,
                    geometry: g,
                    out: &mut *out,
                };
                match &self.geometries[g as usize].accel {
                    GeometryAccel::Kd(tree) => {
                        tree.trace_built_with::<L, _, ANY, C>(&mut local, &mut hooks(id, g));
                    }
                    GeometryAccel::Bvh8(bvh) => {
                        bvh.trace_built_with::<L, _, ANY, C>(&mut local, &mut hooks(id, g));
                    }
                }
            });
    }
}

/// A packet's lanes in an instance's space, for the kernel to build, and
/// the scene's best hits so far, which the kernel's hits join (closest
/// hit, or any hit with `ANY`).
struct ObjectLanes<'a, L: Lane, const ANY: bool> {
    xf: &'a Transform,
    /// The world packet (one reference: two, for its origins and
    /// directions, were copied together as one 16-byte load of the two
    /// 8-byte stores that made them, which stalled on store forwarding; a
    /// third of this closure's samples, perf).
    world: &'a RayPacket<L>,
    /// Each lane's best `t` so far (`-inf` once an occluded lane is done,
    /// and on inactive lanes): the object-space packet's `t_max`, read and
    /// updated in place by the kernel. The top level's walk owns it and
    /// reads it only when it has more to test: a copy returned through the
    /// baseline code around the kernel, read back in halves, stalled on
    /// store forwarding (perf: a fifth of that code's samples).
    best_t: &'a mut L,
    /// The lanes that meet this instance's box and mask.
    lanes: u32,
    instance: u32,
    geometry: u32,
    out: &'a mut SceneHits<L>,
}

impl<L: Lane, const ANY: bool> BuildPacket<L> for ObjectLanes<'_, L, ANY> {
    /// Nothing: `best_t` and `out` are updated in place (a returned `F8`
    /// was copied in pieces by the baseline code around the kernel, and
    /// reading it back stalled on store forwarding: a quarter of that
    /// code's samples, perf).
    type Out = ();
    #[inline(always)]
    fn build(&self) -> RayPacket<L> {
        let w = self.world;
        let (o, d) = self.xf.lanes_to_object(w.org(), w.dir());
        RayPacket::from_lanes_unchecked(o, d, w.t_min(), *self.best_t, self.lanes)
    }
    #[inline(always)]
    fn build_avx2(&self, isa: Avx2) -> RayPacket<L> {
        let (a, b) = self.xf.linear_and_offset();
        let w = self.world;
        affine_packet8(
            isa,
            a,
            b,
            w.org(),
            w.dir(),
            w.t_min(),
            *self.best_t,
            self.lanes,
        )
        .unwrap_or_else(|| self.build())
    }
    /// In the kernel: written with the kernel's instructions, this merge
    /// no longer stalls on the narrow stores the baseline code made of it
    /// (perf: a fifth of the scene's own time on the teapot's primary
    /// packets, outside the kernel).
    #[inline(always)]
    fn finish(&mut self, h: HitPacket<L>) {
        let (id, best_t) = (self.instance, *self.best_t);
        let found = h.mask();
        if found == 0 {
            return;
        }
        let out = &mut *self.out;
        // Keep a lane's hit when it is its first, or closer (the tree
        // returned nothing beyond the lane's best), or as close from a
        // smaller instance id: the scalar rule, lane by lane.
        let ht = h.t_lanes();
        let prev = out.hits.mask();
        let mut take = found & (!prev | L::bits(ht.lt(best_t)));
        let mut ties = found & prev & L::bits(ht.eq(best_t));
        while ties != 0 {
            let i = ties.trailing_zeros() as usize;
            ties &= ties - 1;
            take |= u32::from(id < L::index_lane(out.instance, i)) << i;
        }
        if ANY {
            take = found;
        }
        out.hits.merge(&h, take);
        // The ids: one select each, branch-free.
        let m = L::mask_from_bits(take);
        out.instance = L::index_select(m, L::index_splat(id), out.instance);
        out.geometry = L::index_select(m, L::index_splat(self.geometry), out.geometry);
        let neg_inf = L::splat(f32::NEG_INFINITY);
        *self.best_t = L::select(m, if ANY { neg_inf } else { ht }, best_t);
    }
}

impl Scene {
    /// Closest hit of `ray` under `q` (mask and filter).
    ///
    /// ```
    /// use packtrace::scene::{Query, Scene};
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(Scene::new().intersect_with(&r, &Query::new().with_mask(1)), None);
    /// ```
    #[must_use]
    pub fn intersect_with(&self, ray: &Ray, q: &Query<'_>) -> Option<SceneHit> {
        match q.filter {
            None => self.trace_ray::<false, _>(ray, q, |_, _| NoCount),
            Some(f) => self.trace_ray::<false, _>(ray, q, |i, g| FilterHook {
                filter: f,
                instance: i,
                geometry: g,
            }),
        }
    }
    /// Does `ray` have any hit under `q`?
    ///
    /// ```
    /// use packtrace::scene::{Query, Scene};
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// assert!(!Scene::new().occluded_with(&r, &Query::new()));
    /// ```
    #[must_use]
    pub fn occluded_with(&self, ray: &Ray, q: &Query<'_>) -> bool {
        match q.filter {
            None => self.trace_ray::<true, _>(ray, q, |_, _| NoCount),
            Some(f) => self.trace_ray::<true, _>(ray, q, |i, g| FilterHook {
                filter: f,
                instance: i,
                geometry: g,
            }),
        }
        .is_some()
    }
}

impl SceneQuery for Scene {
    fn intersect_with(&self, ray: &Ray, q: &Query<'_>) -> Option<SceneHit> {
        Scene::intersect_with(self, ray, q)
    }
    fn occluded_with(&self, ray: &Ray, q: &Query<'_>) -> bool {
        Scene::occluded_with(self, ray, q)
    }
    fn intersect4_with(&self, p: &RayPacket4, q: &Query<'_>) -> SceneHits4 {
        self.intersect_packet(p, q)
    }
    fn occluded4_with(&self, p: &RayPacket4, q: &Query<'_>) -> u32 {
        self.occluded_packet(p, q)
    }
    fn intersect8_with(&self, p: &RayPacket8, q: &Query<'_>) -> SceneHits8 {
        self.intersect_packet(p, q)
    }
    fn occluded8_with(&self, p: &RayPacket8, q: &Query<'_>) -> u32 {
        self.occluded_packet(p, q)
    }
    /// Sorted into coherent 8-wide packets as [`KdTree::intersect_rays`]
    /// does (octant, then origin and direction in the scene's box).
    fn intersect_rays_with(&self, rays: &[Ray], hits: &mut [Option<SceneHit>], q: &Query<'_>) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        let q = q.with_mask(q.mask(0));
        for group in stream_order(&self.bounds, rays).chunks(8) {
            let p = RayPacket8::from_fn(|l| group.get(l).map(|&i| rays[i as usize]));
            let h = self.intersect_packet(&p, &q);
            for (l, &i) in group.iter().enumerate() {
                hits[i as usize] = h.hit(l);
            }
        }
    }
    fn occluded_rays_with(&self, rays: &[Ray], occluded: &mut [bool], q: &Query<'_>) {
        assert_eq!(rays.len(), occluded.len(), "one slot per ray");
        let q = q.with_mask(q.mask(0));
        for group in stream_order(&self.bounds, rays).chunks(8) {
            let p = RayPacket8::from_fn(|l| group.get(l).map(|&i| rays[i as usize]));
            let m = self.occluded_packet(&p, &q);
            for (l, &i) in group.iter().enumerate() {
                occluded[i as usize] = m >> l & 1 == 1;
            }
        }
    }
}

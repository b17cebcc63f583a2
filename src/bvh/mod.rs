//! Bounding volume hierarchies beside the kd-tree: the lectures' binary
//! BVH ([`Bvh2`], median or binned-SAH splits) and an 8-wide BVH
//! ([`Bvh8`]) collapsed from the binary SAH tree, with SIMD nodes of eight
//! child boxes and leaves of 4-triangle SIMD blocks.
//!
//! Both answer the same queries as the kd-tree, through the same traits
//! ([`RayQuery`](crate::RayQuery), [`PacketQuery`](crate::PacketQuery)),
//! with the same answers bit for bit: brute force's closest hit (`t`,
//! triangle, `u`, `v`, ties to the smaller triangle index) and occlusion,
//! on every path. So a host switches structure with one line:
//!
//! ```
//! use packtrace::bvh::{Bvh2, Bvh8, BvhBuildParams};
//! use packtrace::glam::Vec3;
//! use packtrace::{KdBuildParams, KdTree, Mesh, PacketQuery, Ray, RayPacket8};
//!
//! let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;
//! let kd = KdTree::build(mesh.clone(), &KdBuildParams::default())?;
//! let bvh8 = Bvh8::build(mesh.clone(), &BvhBuildParams::default())?;
//! let bvh2 = Bvh2::build(mesh, &BvhBuildParams::median())?;
//! let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;
//! let engines: [&dyn PacketQuery; 3] = [&kd, &bvh8, &bvh2];
//! for e in engines {
//!     assert_eq!(e.intersect(&ray).map(|h| (h.t, h.prim)), Some((1.0, 0)));
//!     assert_eq!(e.intersect8(&RayPacket8::from_slice(&[ray; 3])).mask(), 0b111);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! - `params`: [`BvhBuildParams`] (presets `sah`, `sah_binary`, `median`)
//!   and [`BvhBuildError`];
//! - `build`: the binary build (binned SAH or median, parallel, the same
//!   tree for any thread count); `collapse`: the 8-wide tree from it;
//! - [`node`]: the layouts ([`Node2`], [`Node8`], [`Tri4`], [`ChildRef`]);
//! - `slab`: the conservative box tests (the margin, fast and robust);
//! - `single`: the 8-wide single-ray traversal (run-time kernels in
//!   `kdtree/kernel/bvh.rs`); `packet`: its packets; `bvh2`: the binary
//!   tree's traversals; `query`: the query traits and streams;
//! - `validate`, `stats`: invariants and statistics.
//!
//! The design, what was measured and what was rejected: `docs/bvh.md`.

mod build;
pub(crate) mod bvh2;
mod collapse;
pub mod node;
pub(crate) mod packet;
mod params;
pub(crate) mod query;
pub(crate) mod single;
pub(crate) mod slab;
mod stats;
mod validate;

pub use bvh2::Bvh2;
pub use node::{ChildRef, Node2, Node8, Tri4};
pub use params::{BVH_MAX_BINS, BVH_MAX_DEPTH, BVH_MAX_LEAF, BvhBuildError, BvhBuildParams, Split};
pub use stats::BvhStats;
pub use validate::BvhValidationError;

use crate::aabb::Aabb;
use crate::mesh::Mesh;

/// An 8-wide BVH over a [`Mesh`], which it owns: 256-byte nodes of eight
/// child boxes (structure of arrays, cache-line aligned) and leaves of
/// 4-triangle blocks. `Send + Sync`: build once, query from any number of
/// threads.
///
/// ```
/// use packtrace::bvh::{Bvh8, BvhBuildParams};
/// use packtrace::glam::Vec3;
/// use packtrace::{Mesh, Ray};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let bvh = Bvh8::build(mesh, &BvhBuildParams::default()).unwrap();
/// let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
/// assert_eq!(bvh.intersect(&ray).map(|h| (h.t, h.prim)), Some((1.0, 0)));
/// assert!(bvh.occluded(&ray));
/// ```
#[derive(Clone, Debug)]
pub struct Bvh8 {
    mesh: Mesh,
    pub(crate) nodes: Vec<Node8>,
    pub(crate) blocks: Vec<Tri4>,
    /// The root: node 0, a lone leaf, or [`ChildRef::EMPTY`].
    pub(crate) root: ChildRef,
    pub(crate) bounds: Aabb,
    /// The largest coordinate magnitude of `bounds` (the margin's share
    /// from the scene, `slab.rs`), computed once.
    pub(crate) box_magnitude: f32,
    params: BvhBuildParams,
}

/// Runs `f` on the build's threads.
pub(crate) fn with_threads<T: Send>(
    params: &BvhBuildParams,
    f: impl FnOnce() -> T + Send,
) -> Result<T, BvhBuildError> {
    match params.threads {
        None => Ok(f()),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| BvhBuildError::ThreadPool(e.to_string()))?
            .install(f)),
    }
}

/// The checks every build starts with.
fn check_input(mesh: &Mesh, params: &BvhBuildParams) -> Result<(), BvhBuildError> {
    params.validate()?;
    let n = mesh.triangle_count();
    if n > node::MAX_TRIANGLES {
        return Err(BvhBuildError::TooManyTriangles(n));
    }
    Ok(())
}

impl Bvh8 {
    /// Builds the binary tree with `params` (binned SAH by default; a
    /// median build works too), in parallel on the threads
    /// [`BvhBuildParams::threads`] names, and collapses it into 8-wide
    /// nodes. The tree is the same for any thread count.
    ///
    /// # Errors
    /// [`BvhBuildError`] for invalid parameters, a mesh of more than
    /// [`node::MAX_TRIANGLES`] triangles, or a thread pool the system
    /// cannot make.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// assert_eq!(b.node_count(), 0);
    /// ```
    pub fn build(mesh: Mesh, params: &BvhBuildParams) -> Result<Bvh8, BvhBuildError> {
        check_input(&mesh, params)?;
        let wide = with_threads(params, || {
            let bin = build::build(&mesh, params);
            collapse::collapse(&bin, mesh.corner_slice(), params.merge_below)
        })?;
        Ok(Bvh8 {
            bounds: mesh.bounds(),
            box_magnitude: slab::magnitude(&mesh.bounds()),
            mesh,
            nodes: wide.nodes,
            blocks: wide.blocks,
            root: wide.root,
            params: *params,
        })
    }

    /// The mesh the tree was built over.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// assert!(b.mesh().is_empty());
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The box of the mesh (every child box lies inside it).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// assert!(b.bounds().is_empty());
    /// ```
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Number of 8-wide nodes (a mesh that fits in one leaf has none).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let m = packtrace::protocol::generate::sphere(1000);
    /// assert!(Bvh8::build(m, &BvhBuildParams::default()).unwrap().node_count() > 10);
    /// ```
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The nodes, root first (read-only: for tools that inspect the tree).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::protocol::generate::sphere(500), &BvhBuildParams::default()).unwrap();
    /// assert!(b.nodes()[0].child_count() >= 2);
    /// ```
    #[must_use]
    pub fn nodes(&self) -> &[Node8] {
        &self.nodes
    }

    /// The leaves' triangle blocks.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::protocol::generate::sphere(500), &BvhBuildParams::default()).unwrap();
    /// assert!(b.blocks().len() * 4 >= b.mesh().triangle_count());
    /// ```
    #[must_use]
    pub fn blocks(&self) -> &[Tri4] {
        &self.blocks
    }

    /// The root reference: node 0, a single leaf (a small mesh), or
    /// [`ChildRef::EMPTY`] (no triangle that can be hit).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams, ChildRef};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// assert_eq!(b.root(), ChildRef::EMPTY);
    /// ```
    #[must_use]
    pub fn root(&self) -> ChildRef {
        self.root
    }

    /// The parameters the tree was built with.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let p = BvhBuildParams::median();
    /// assert_eq!(*Bvh8::build(packtrace::Mesh::default(), &p).unwrap().params(), p);
    /// ```
    #[must_use]
    pub fn params(&self) -> &BvhBuildParams {
        &self.params
    }
}

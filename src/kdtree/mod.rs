//! The SAH kd-tree: 8-byte nodes in one flat array, scalar and packet
//! traversal over the same nodes.
//!
//! - [`node`]: the 8-byte node encoding;
//! - `build`: SAH build; `params`: typed parameters and errors;
//! - `scalar` / `packet`: the two traversals, side by side;
//! - `validate` / `stats`: structural checks and statistics.

mod blocked;
pub(crate) mod build;
mod clip;
mod events;
mod group;
mod group_query;
mod hybrid;
mod inline_tris;
mod ledger;
// The crate's only `unsafe`: the kernels' dispatch after detection, the
// instance build's intrinsics, the traversals' uninitialised stack, the
// leaves' prefetch hint and the streams' vector partition.
#[allow(unsafe_code)]
mod kernel;
mod layout;
mod margin;
mod naive;
pub mod node;
mod order;
mod packet;
mod params;
mod queries;
mod scalar;
pub(crate) mod stats;
mod stream;
mod validate;
mod walk;

pub use blocked::BlockedKdTree;
pub use hybrid::{MAX_DIR_SPREAD, single_ray_lanes};
pub use inline_tris::InlineKdTree;
pub use kernel::Kernel;
pub(crate) use kernel::bvh as bvh_kernel;
pub(crate) use kernel::prefetch::prefetch_all;
pub(crate) use kernel::stack::Stack;
pub(crate) use kernel::{Avx2, BuildPacket, affine_packet8};
pub use naive::NaiveKdTree;
pub use params::{BuildError, DepthLimit, KdBuildParams, MAX_BINS, MAX_DEPTH_LIMIT};
pub(crate) use stats::{Counters, NoCount};
pub use stats::{TraversalStats, TreeStats};
pub(crate) use stream::order as stream_order;
pub use stream::{MAX_STREAM_SIZE, StreamOptions, StreamOptionsError, StreamScratch};
pub use validate::ValidationError;

/// Entry points with a caller's hooks (a scene's any-hit filter), for
/// `crate::scene`, which traces each instance's object-space rays here.
impl KdTree {
    /// The scalar traversal with hooks `c`; `ANY` selects occlusion.
    #[inline]
    pub(crate) fn trace_ray_with<const ANY: bool, C: Counters>(
        &self,
        ray: &crate::ray::Ray,
        c: &mut C,
    ) -> Option<crate::ray::Hit> {
        scalar::traverse::<_, ANY, C>(self, ray, c)
    }

    /// The packet query (octant split, single-ray switch, run-time kernel)
    /// of a packet the kernel builds itself (`kernel::BuildPacket`), with
    /// hooks `c`.
    #[inline]
    pub(crate) fn trace_built_with<
        L: crate::simd::Lane,
        B: BuildPacket<L>,
        const ANY: bool,
        C: Counters,
    >(
        &self,
        b: &mut B,
        c: &mut C,
    ) -> B::Out {
        hybrid::trace_built::<L, _, B, ANY, C>(self, b, c)
    }
}

use crate::aabb::Aabb;
use crate::mesh::Mesh;
use node::KdNode;

/// A kd-tree over a [`Mesh`], which it owns. `Send + Sync`: build once,
/// query from any number of threads.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
/// let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
/// let hit = tree.intersect(&ray).unwrap();
/// assert_eq!((hit.t, hit.prim), (1.0, 0));
/// assert!(tree.occluded(&ray));
/// ```
#[derive(Clone, Debug)]
pub struct KdTree {
    mesh: Mesh,
    pub(crate) nodes: Vec<KdNode>,
    pub(crate) leaf_prims: Vec<u32>,
    pub(crate) bounds: Aabb,
    params: KdBuildParams,
    depth_limit: u32,
    build_peak_bytes: usize,
}

impl KdTree {
    /// Build the tree with the surface area heuristic, in parallel on the
    /// threads [`KdBuildParams::threads`] names (by default the caller's
    /// rayon pool).
    ///
    /// # Errors
    /// [`BuildError`] for invalid parameters, a tree larger than the node
    /// encoding can address (never a wrapped index), a build over its
    /// memory budget, or a thread pool the system cannot make.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::pbrt()).unwrap();
    /// assert_eq!(t.node_count(), 1);
    /// ```
    pub fn build(mesh: Mesh, params: &KdBuildParams) -> Result<KdTree, BuildError> {
        let depth_limit = params.depth_for(mesh.triangle_count())?;
        let n = mesh.triangle_count();
        if n > node::MAX_INDEX as usize {
            return Err(BuildError::TooManyTriangles(n));
        }
        // The references alone need this much before any node exists.
        let refs_bytes = n * std::mem::size_of::<clip::PrimRef>();
        if let Some(budget) = params.memory_budget
            && refs_bytes > budget
        {
            return Err(BuildError::MemoryBudget {
                needed: refs_bytes,
                budget,
            });
        }
        let prims: Vec<clip::PrimRef> = (0..n)
            .filter(|&i| !mesh.is_degenerate(i))
            .map(|i| clip::PrimRef::new(i as u32, mesh.triangle_bounds(i)))
            .collect();
        let bounds = mesh.bounds();
        let run = || build::build(mesh.corner_slice(), prims, bounds, params, depth_limit);
        let built = match params.threads {
            None => run()?,
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| BuildError::ThreadPool(e.to_string()))?
                .install(run)?,
        };
        Ok(KdTree {
            mesh,
            nodes: built.nodes,
            leaf_prims: built.leaf_prims,
            bounds,
            params: *params,
            depth_limit,
            build_peak_bytes: built.peak_bytes,
        })
    }

    /// The most bytes the build held at once: the references of the nodes
    /// under construction, their sorted split events, each task's scratch
    /// and the tree emitted so far (capacities, counted by the build's own
    /// ledger; not the mesh), plus up to 64 KiB per open build task (each
    /// takes its bytes from the ledger in 32 KiB chunks, so that threads
    /// do not contend on it). [`KdBuildParams::memory_budget`] caps the
    /// bytes needed; a one-thread build whose peak was `p` succeeds with a
    /// budget of `p` (the same charges in the same order). With several
    /// threads the figure depends on how their subtrees interleave.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree};
    /// let mesh = packtrace::protocol::generate::sphere(20_000);
    /// // One thread: the same peak every time.
    /// let p = KdBuildParams { threads: Some(1), ..KdBuildParams::default() };
    /// let t = KdTree::build(mesh.clone(), &p).unwrap();
    /// let peak = t.build_peak_bytes();
    /// assert!(peak >= t.stats().bytes);
    /// let tight = KdBuildParams { memory_budget: Some(peak), ..p };
    /// assert!(KdTree::build(mesh.clone(), &tight).is_ok());
    /// let under = KdBuildParams { memory_budget: Some(peak / 2), ..p };
    /// assert!(KdTree::build(mesh, &under).is_err());
    /// ```
    #[must_use]
    pub fn build_peak_bytes(&self) -> usize {
        self.build_peak_bytes
    }

    /// The mesh the tree was built over.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert!(t.mesh().is_empty());
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The box traversal starts from (the mesh's bounds).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert!(t.bounds().is_empty());
    /// ```
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Number of nodes (interior and leaves).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// assert_eq!(KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap().node_count(), 1);
    /// ```
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The parameters the tree was built with.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::mitsuba()).unwrap();
    /// assert_eq!(*t.params(), KdBuildParams::mitsuba());
    /// ```
    #[must_use]
    pub fn params(&self) -> &KdBuildParams {
        &self.params
    }

    /// The depth limit the build used ([`KdBuildParams::max_depth`] for
    /// this mesh: `6 + log2 N` by default, [`DepthLimit::COMPACT`]).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(t.depth_limit(), 6);
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::pbrt()).unwrap();
    /// assert_eq!(t.depth_limit(), 8);
    /// ```
    #[must_use]
    pub fn depth_limit(&self) -> u32 {
        self.depth_limit
    }

    /// The triangles of leaf `node`, one of this tree's nodes (borrowed in
    /// place: a one-triangle leaf's slice is its own first word).
    #[inline(always)]
    pub(crate) fn leaf_prims<'a>(&'a self, node: &'a KdNode) -> &'a [u32] {
        node.leaf_run(&self.leaf_prims)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::generate;

    #[test]
    fn the_tree_is_the_same_for_any_thread_count() {
        // A soup of 2,000 small triangles (deterministic).
        let mut x = 12345u32;
        let mut next = || {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (x >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut positions = Vec::new();
        for _ in 0..2000 {
            let c = glam::Vec3::new(next(), next(), next()) * 10.0;
            for _ in 0..3 {
                positions.push(c + glam::Vec3::new(next(), next(), next()) * 0.3);
            }
        }
        let triangles = (0..2000u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        let mesh = Mesh::new(positions, triangles).unwrap();
        let with = |threads| {
            let p = KdBuildParams {
                threads,
                ..KdBuildParams::default()
            };
            let t = KdTree::build(mesh.clone(), &p).unwrap();
            (t.nodes, t.leaf_prims)
        };
        let one = with(Some(1));
        assert!(one.0.len() > 100);
        assert_eq!(with(Some(2)), one);
        assert_eq!(with(Some(3)), one);
        assert_eq!(with(None), one);
        let zero = KdBuildParams {
            threads: Some(0),
            ..KdBuildParams::default()
        };
        assert_eq!(
            KdTree::build(mesh, &zero).unwrap_err().to_string(),
            "invalid kd-tree build parameters: threads = 0 (must be None or >= 1)"
        );
    }

    #[test]
    fn memory_budget_is_checked_before_and_during_the_build() {
        let mesh = generate::sphere(10_000);
        // Too small for the references alone: refused before building.
        let tiny = KdBuildParams {
            memory_budget: Some(1000),
            ..KdBuildParams::default()
        };
        let e = KdTree::build(mesh.clone(), &tiny).unwrap_err();
        assert!(
            matches!(e, BuildError::MemoryBudget { budget: 1000, .. }),
            "{e}"
        );
        // Enough for the references, not for the tree: stops mid-build.
        let refs = mesh.triangle_count() * std::mem::size_of::<clip::PrimRef>();
        let mid = KdBuildParams {
            memory_budget: Some(refs + 1000),
            ..KdBuildParams::default()
        };
        assert!(matches!(
            KdTree::build(mesh.clone(), &mid),
            Err(BuildError::MemoryBudget { .. })
        ));
        // A generous budget changes nothing.
        let big = KdBuildParams {
            memory_budget: Some(1 << 30),
            ..KdBuildParams::default()
        };
        let a = KdTree::build(mesh.clone(), &big).unwrap();
        let b = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
        assert_eq!(a.nodes, b.nodes);
    }

    #[test]
    fn trees_are_identical_for_1_2_and_4_threads() {
        // Above both parallel thresholds (subtrees of 8192 references,
        // chunked splits of 32768), so subtrees are built on other threads
        // and appended, and the upper levels bin and partition in chunks.
        let mesh = generate::jittered_sphere(50_000, 9, 0.2);
        for (name, p) in KdBuildParams::presets() {
            let build = |threads| {
                let p = KdBuildParams {
                    threads: Some(threads),
                    ..p
                };
                KdTree::build(mesh.clone(), &p).unwrap()
            };
            let one = build(1);
            assert!(one.node_count() > 1000, "{name}");
            for threads in [2, 4] {
                let many = build(threads);
                assert_eq!(one.nodes, many.nodes, "{name}, {threads} threads");
                assert_eq!(one.leaf_prims, many.leaf_prims, "{name}, {threads} threads");
            }
        }
    }

    #[test]
    fn every_preset_builds_valid_trees_with_and_without_clipping() {
        let mesh = generate::jittered_sphere(3000, 4, 0.3);
        for (name, p) in KdBuildParams::presets() {
            for clip in [false, true] {
                let p = KdBuildParams {
                    split_clipping: clip,
                    ..p
                };
                let t = KdTree::build(mesh.clone(), &p).unwrap();
                assert_eq!(t.validate(), Ok(()), "{name} clip={clip}");
            }
        }
    }

    #[test]
    fn clipping_reduces_references_on_long_triangles() {
        // Long thin triangles spanning the scene: unclipped boxes overlap
        // every cell they cross; clipped boxes only the cells they touch.
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..200u32 {
            let y = i as f32 * 0.01;
            p.extend([
                glam::Vec3::new(0.0, y, 0.0),
                glam::Vec3::new(10.0, y + 1.0, 0.0),
                glam::Vec3::new(0.0, y + 0.005, 0.1),
            ]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let mesh = Mesh::new(p, t).unwrap();
        let on = KdBuildParams::default();
        let off = KdBuildParams {
            split_clipping: false,
            ..on
        };
        let a = KdTree::build(mesh.clone(), &on).unwrap().stats();
        let b = KdTree::build(mesh, &off).unwrap().stats();
        assert!(a.sah_cost < b.sah_cost, "{a:?} {b:?}");
    }
}

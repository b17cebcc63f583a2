//! Build statistics of a tree and traversal counters of queries.

use super::KdTree;
use super::node::KdNode;
use crate::aabb::Aabb;
use std::ops::AddAssign;

/// Hooks of a traversal: its counters, and the scene's any-hit filter
/// (`scene.rs`, issue 16). The normal entry points use a zero-sized
/// counter whose hooks compile to nothing; the `*_counted` entry points
/// pass a [`TraversalStats`].
pub(crate) trait Counters {
    /// `true` when [`Counters::accept`] may reject a hit. The traversals
    /// test it at compile time, so a query without a filter pays nothing.
    const FILTERS: bool = false;
    /// Is the candidate hit (`t` on triangle `prim`) accepted? A rejected
    /// hit is ignored as if the ray had missed the triangle. Called only
    /// when [`Counters::FILTERS`] is set.
    #[inline(always)]
    fn accept(&mut self, _prim: u32, _t: f32, _u: f32, _v: f32) -> bool {
        true
    }
    #[inline(always)]
    fn node(&mut self) {}
    #[inline(always)]
    fn leaf(&mut self) {}
    /// One triangle test with `lanes` active lanes.
    #[inline(always)]
    fn tri(&mut self, _lanes: u32) {}
    /// A packet whose lanes disagreed on a direction sign, split by octant.
    #[inline(always)]
    fn octant_split(&mut self) {}
    /// A lane (or a stream's ray) finished by the single-ray traversal.
    #[inline(always)]
    fn single_ray(&mut self) {}
    /// A node visited by a stream's subset of `rays` rays.
    #[inline(always)]
    fn stream_node(&mut self, _rays: u32) {}
    /// A stream's subset split into a near and a far part, both non-empty.
    #[inline(always)]
    fn partition(&mut self) {}
    /// A group traced with its frustum, which entered the tree at depth
    /// `entry_depth`.
    #[inline(always)]
    fn group(&mut self, _entry_depth: u32) {}
    /// One packet of a group clipped to a cell (leaf or deferred cell).
    #[inline(always)]
    fn cell_test(&mut self) {}
    /// A leaf triangle skipped for a whole group by its frustum.
    #[inline(always)]
    fn culled(&mut self) {}
    /// A grid's mailbox skipped a triangle the ray had tested already.
    #[inline(always)]
    fn mailbox_hit(&mut self) {}
}

/// The counter of the uncounted entry points.
pub(crate) struct NoCount;
impl Counters for NoCount {}

/// Traversal counters, summed over the queries that were given it.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, TraversalStats};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
/// let mut st = TraversalStats::default();
/// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// tree.intersect_counted(&r, &mut st);
/// assert_eq!((st.rays, st.triangle_tests), (1, 1));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraversalStats {
    /// Rays traced (active lanes for packets).
    pub rays: u64,
    /// Packets traced.
    pub packets: u64,
    /// Interior nodes visited (per ray for scalar, per packet for packets).
    pub nodes: u64,
    /// Leaves visited.
    pub leaves: u64,
    /// Triangle tests (one per triangle and ray or packet).
    pub triangle_tests: u64,
    /// Sum over packet triangle tests of the lanes active in the cell.
    pub active_lanes: u64,
    /// Packets split into one sub-packet per direction octant because
    /// their lanes' direction signs differed (and their directions did not
    /// diverge so far that every lane went alone).
    pub octant_splits: u64,
    /// Lanes of packets traced by the single-ray traversal: a sub-packet
    /// with too few lanes for SIMD to pay, or a packet of mixed direction
    /// signs whose directions diverge (ambient occlusion, random rays).
    pub single_rays: u64,
    /// Groups traced with their frustum (group queries).
    pub groups: u64,
    /// Sum over those groups of the entry depth: node steps taken before
    /// the group first had to visit both children of a node.
    pub entry_depth: u64,
    /// Packets of a group clipped to a cell, at a leaf or at a deferred
    /// cell (the group's only per-packet work outside triangle tests).
    pub cell_tests: u64,
    /// Leaf triangles skipped for a whole group by its frustum.
    pub culled_triangles: u64,
    /// Triangles a grid's mailbox skipped because the ray (or packet)
    /// had tested them in an earlier cell.
    pub mailbox_hits: u64,
    /// Interior nodes visited by a stream's subsets (streams only; the
    /// single-ray finishes count in [`TraversalStats::nodes`]).
    pub stream_nodes: u64,
    /// Sum over those visits of the subset's rays: rays per node visit
    /// is `stream_node_rays / stream_nodes`.
    pub stream_node_rays: u64,
    /// Stream node visits whose subset split into a near and a far part
    /// (the far part deferred); the other visits sent every ray one way.
    pub partitions: u64,
}

impl TraversalStats {
    /// Mean active lanes per packet triangle test, over the width (0..=1).
    ///
    /// ```
    /// let s = packtrace::TraversalStats { triangle_tests: 2, active_lanes: 6, packets: 1, ..Default::default() };
    /// assert_eq!(s.lane_utilisation(4), 0.75);
    /// ```
    #[must_use]
    pub fn lane_utilisation(&self, width: u32) -> f64 {
        if self.triangle_tests == 0 {
            return 0.0;
        }
        self.active_lanes as f64 / (self.triangle_tests as f64 * width as f64)
    }
}

impl AddAssign for TraversalStats {
    fn add_assign(&mut self, o: TraversalStats) {
        self.rays += o.rays;
        self.packets += o.packets;
        self.nodes += o.nodes;
        self.leaves += o.leaves;
        self.triangle_tests += o.triangle_tests;
        self.active_lanes += o.active_lanes;
        self.octant_splits += o.octant_splits;
        self.single_rays += o.single_rays;
        self.groups += o.groups;
        self.entry_depth += o.entry_depth;
        self.cell_tests += o.cell_tests;
        self.culled_triangles += o.culled_triangles;
        self.mailbox_hits += o.mailbox_hits;
        self.stream_nodes += o.stream_nodes;
        self.stream_node_rays += o.stream_node_rays;
        self.partitions += o.partitions;
    }
}

impl Counters for TraversalStats {
    #[inline(always)]
    fn node(&mut self) {
        self.nodes += 1;
    }
    #[inline(always)]
    fn leaf(&mut self) {
        self.leaves += 1;
    }
    #[inline(always)]
    fn tri(&mut self, lanes: u32) {
        self.triangle_tests += 1;
        self.active_lanes += lanes as u64;
    }
    #[inline(always)]
    fn octant_split(&mut self) {
        self.octant_splits += 1;
    }
    #[inline(always)]
    fn single_ray(&mut self) {
        self.single_rays += 1;
    }
    #[inline(always)]
    fn stream_node(&mut self, rays: u32) {
        self.stream_nodes += 1;
        self.stream_node_rays += u64::from(rays);
    }
    #[inline(always)]
    fn partition(&mut self) {
        self.partitions += 1;
    }
    #[inline(always)]
    fn group(&mut self, entry_depth: u32) {
        self.groups += 1;
        self.entry_depth += u64::from(entry_depth);
    }
    #[inline(always)]
    fn cell_test(&mut self) {
        self.cell_tests += 1;
    }
    #[inline(always)]
    fn culled(&mut self) {
        self.culled_triangles += 1;
    }
    #[inline(always)]
    fn mailbox_hit(&mut self) {
        self.mailbox_hits += 1;
    }
}

/// Statistics of a built tree.
///
/// ```
/// use packtrace::{KdBuildParams, KdTree, Mesh};
/// let s = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap().stats();
/// assert_eq!((s.nodes, s.leaves, s.empty_leaves), (1, 1, 1));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeStats {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// All nodes.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Leaves without triangles.
    pub empty_leaves: usize,
    /// Deepest leaf (root = 0).
    pub max_depth: u32,
    /// Mean leaf depth.
    pub mean_depth: f64,
    /// Leaf references over triangles.
    pub refs_per_triangle: f64,
    /// Mean triangles per non-empty leaf.
    pub mean_leaf_triangles: f64,
    /// SAH cost of the tree, with the build's `C_t` and `C_i`, relative to
    /// the root: `sum over nodes of SA(node) / SA(root) * cost(node)`.
    pub sah_cost: f64,
    /// Bytes of the node array plus the leaf index array.
    pub bytes: usize,
}

impl KdTree {
    /// Statistics of this tree.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let s = KdTree::build(m, &KdBuildParams::default()).unwrap().stats();
    /// assert_eq!(s.refs_per_triangle, 1.0);
    /// ```
    #[must_use]
    pub fn stats(&self) -> TreeStats {
        let mut s = TreeStats {
            triangles: self.mesh().triangle_count(),
            nodes: self.nodes.len(),
            bytes: self.nodes.len() * std::mem::size_of::<KdNode>()
                + self.leaf_prims.len() * std::mem::size_of::<u32>(),
            ..TreeStats::default()
        };
        let root_sa = self.bounds.surface_area() as f64;
        let p = self.params();
        let (ct, ci) = (p.traversal_cost as f64, p.intersection_cost as f64);
        let mut refs = 0usize;
        let mut depth_sum = 0u64;
        let mut stack: Vec<(usize, Aabb, u32)> = vec![(0, self.bounds, 0)];
        while let Some((i, cell, depth)) = stack.pop() {
            let n = self.nodes[i];
            let w = if root_sa > 0.0 {
                cell.surface_area() as f64 / root_sa
            } else {
                1.0
            };
            if n.is_leaf() {
                s.leaves += 1;
                let c = n.count() as usize;
                if c == 0 {
                    s.empty_leaves += 1;
                }
                refs += c;
                depth_sum += depth as u64;
                s.max_depth = s.max_depth.max(depth);
                s.sah_cost += w * ci * c as f64;
            } else {
                s.sah_cost += w * ct;
                let (axis, split) = (n.axis(), n.split());
                let (mut below, mut above) = (cell, cell);
                below.max[axis] = split;
                above.min[axis] = split;
                stack.push((i + 1, below, depth + 1));
                stack.push((n.child() as usize, above, depth + 1));
            }
        }
        s.mean_depth = depth_sum as f64 / s.leaves.max(1) as f64;
        s.refs_per_triangle = refs as f64 / s.triangles.max(1) as f64;
        s.mean_leaf_triangles = refs as f64 / (s.leaves - s.empty_leaves).max(1) as f64;
        s
    }
}

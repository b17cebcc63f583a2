//! Statistics of the BVHs: sizes, leaf sizes, SAH cost, bytes.

use super::Bvh8;
use super::bvh2::Bvh2;
use super::node::{ChildRef, Node2, Node8, Tri4};
use crate::aabb::Aabb;

/// Statistics of a BVH (either width).
///
/// ```
/// use packtrace::bvh::{Bvh8, BvhBuildParams};
/// let m = packtrace::protocol::generate::sphere(2000);
/// let n = m.triangle_count();
/// let s = Bvh8::build(m, &BvhBuildParams::default()).unwrap().stats();
/// assert_eq!(s.triangles, n);
/// assert!(s.bytes_per_triangle() > 40.0);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// Interior nodes (8-wide or binary).
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Triangle blocks (8-wide tree; 0 for the binary one).
    pub blocks: usize,
    /// Deepest leaf (the root's children are at depth 1).
    pub max_depth: u32,
    /// Mean depth of the leaves.
    pub mean_leaf_depth: f64,
    /// Mean used child slots of the interior nodes (2 for binary).
    pub mean_children: f64,
    /// Mean triangles per leaf.
    pub mean_leaf_triangles: f64,
    /// Leaves of `k` triangles at index `k` (up to 32).
    pub leaf_sizes: Vec<usize>,
    /// SAH cost with `C_t` per interior node and `C_i` per block (8-wide)
    /// or per triangle (binary), relative to the root box.
    pub sah_cost: f64,
    /// Bytes of the nodes, the blocks and (binary) the triangle order.
    pub bytes: usize,
}

impl BvhStats {
    /// [`BvhStats::bytes`] per triangle of the mesh.
    ///
    /// ```
    /// let s = packtrace::bvh::BvhStats { triangles: 4, bytes: 100, ..Default::default() };
    /// assert_eq!(s.bytes_per_triangle(), 25.0);
    /// ```
    #[must_use]
    pub fn bytes_per_triangle(&self) -> f64 {
        self.bytes as f64 / self.triangles.max(1) as f64
    }

    fn leaf(&mut self, tris: usize, depth: u32, depth_sum: &mut u64) {
        self.leaves += 1;
        self.max_depth = self.max_depth.max(depth);
        *depth_sum += u64::from(depth);
        if self.leaf_sizes.len() <= tris {
            self.leaf_sizes.resize(tris + 1, 0);
        }
        self.leaf_sizes[tris] += 1;
    }

    fn finish(&mut self, depth_sum: u64, slots: usize, tris: usize) {
        self.mean_leaf_depth = depth_sum as f64 / self.leaves.max(1) as f64;
        self.mean_children = slots as f64 / self.nodes.max(1) as f64;
        self.mean_leaf_triangles = tris as f64 / self.leaves.max(1) as f64;
    }
}

fn area_ratio(b: &Aabb, root: f64) -> f64 {
    if root > 0.0 {
        f64::from(b.surface_area()) / root
    } else {
        1.0
    }
}

impl Bvh8 {
    /// Statistics of this tree.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// assert_eq!(b.stats().nodes, 0);
    /// ```
    #[must_use]
    pub fn stats(&self) -> BvhStats {
        let mut s = BvhStats {
            triangles: self.mesh().triangle_count(),
            nodes: self.nodes.len(),
            blocks: self.blocks.len(),
            bytes: self.nodes.len() * size_of::<Node8>() + self.blocks.len() * size_of::<Tri4>(),
            ..BvhStats::default()
        };
        let p = self.params();
        let (ct, ci) = (f64::from(p.traversal_cost), f64::from(p.intersection_cost));
        let root = f64::from(self.bounds.surface_area());
        let (mut depth_sum, mut slots, mut tris) = (0u64, 0usize, 0usize);
        let mut stack = vec![(self.root, self.bounds, 0u32)];
        while let Some((r, b, depth)) = stack.pop() {
            if r == ChildRef::EMPTY {
                continue;
            }
            let w = area_ratio(&b, root);
            if r.is_leaf() {
                let range = r.blocks();
                let n: usize = self.blocks[range.clone()]
                    .iter()
                    .map(|b| b.len() as usize)
                    .sum();
                s.sah_cost += w * ci * range.len() as f64;
                tris += n;
                s.leaf(n, depth, &mut depth_sum);
                continue;
            }
            s.sah_cost += w * ct;
            let node = &self.nodes[r.index()];
            let used = node.child_count();
            slots += used;
            for k in 0..used {
                stack.push((node.children[k], node.child_bounds(k), depth + 1));
            }
        }
        s.finish(depth_sum, slots, tris);
        s
    }
}

impl Bvh2 {
    /// Statistics of this tree.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::protocol::generate::sphere(500), &BvhBuildParams::median()).unwrap();
    /// let s = b.stats();
    /// assert_eq!(s.leaves, s.nodes + 1);
    /// ```
    #[must_use]
    pub fn stats(&self) -> BvhStats {
        let mut s = BvhStats {
            triangles: self.mesh().triangle_count(),
            bytes: self.nodes.len() * size_of::<Node2>() + self.prims.len() * size_of::<u32>(),
            ..BvhStats::default()
        };
        if self.nodes.is_empty() {
            return s;
        }
        let p = self.params();
        let (ct, ci) = (f64::from(p.traversal_cost), f64::from(p.intersection_cost));
        let root = f64::from(self.nodes[0].bounds().surface_area());
        let (mut depth_sum, mut tris) = (0u64, 0usize);
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, depth)) = stack.pop() {
            let n = &self.nodes[i];
            let w = area_ratio(&n.bounds(), root);
            if n.is_leaf() {
                s.sah_cost += w * ci * f64::from(n.count);
                tris += n.count as usize;
                s.leaf(n.count as usize, depth, &mut depth_sum);
                continue;
            }
            s.nodes += 1;
            s.sah_cost += w * ct;
            stack.push((i + 1, depth + 1));
            stack.push((n.index as usize, depth + 1));
        }
        s.finish(depth_sum, 2 * s.nodes, tris);
        s
    }
}

//! The blocked node order (`order.rs`; `--accel kd8-blocked`): the same
//! 8-byte nodes and the same tree as a [`KdTree`], with sibling pairs
//! packed into 64-byte cache-line blocks. Traced by the very same generic
//! scalar and packet traversals, so `kd8-blocked / kd8` measures what the
//! order buys on the machine at hand. Measured and not adopted as the
//! default (docs/node-order.md): on an Intel Xeon with
//! 2 MiB of L2 per core it runs at 0.97-1.02x the depth-first order on the
//! protocol scenes' rays (their trees fit in L2) and 1.02-1.08x on a
//! million-triangle scene's.

use super::layout::{Layout, NodeView};
use super::node::KdNode;
use super::order;
use super::queries::layout_queries;
use super::{BuildError, KdTree};
use crate::aabb::Aabb;
use crate::mesh::Mesh;

/// A kd-tree of 8-byte nodes in blocked order (see the module docs). Same
/// answers as the [`KdTree`] it was made from, on every ray, through
/// [`RayQuery`](crate::RayQuery) and [`PacketQuery`](crate::PacketQuery).
///
/// ```
/// use glam::Vec3;
/// use packtrace::{BlockedKdTree, KdBuildParams, KdTree, Mesh, Ray, RayQuery};
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let kd = KdTree::build(m, &KdBuildParams::default()).unwrap();
/// let blocked = BlockedKdTree::from_kd(&kd).unwrap();
/// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// assert_eq!(blocked.intersect(&r), kd.intersect(&r));
/// ```
#[derive(Debug)]
pub struct BlockedKdTree {
    mesh: Mesh,
    /// Blocked order: the root starts a cache line; the slots before it
    /// and the one beside it are unused empty leaves.
    nodes: Vec<KdNode>,
    leaf_prims: Vec<u32>,
    root: u32,
    bounds: Aabb,
    depth_limit: u32,
}

impl Clone for BlockedKdTree {
    /// A copy whose blocks are aligned to its own allocation's lines.
    fn clone(&self) -> BlockedKdTree {
        let (nodes, root) = order::realigned(&self.nodes, self.root);
        BlockedKdTree {
            mesh: self.mesh.clone(),
            nodes,
            leaf_prims: self.leaf_prims.clone(),
            root,
            bounds: self.bounds,
            depth_limit: self.depth_limit,
        }
    }
}

impl BlockedKdTree {
    /// Reorder a tree's nodes into blocks, node for node.
    ///
    /// # Errors
    /// [`BuildError::TooManyNodes`] when the up to eight unused slots that
    /// align the blocks push a node index past the encoding's limit
    /// ([`node::MAX_INDEX`](super::node::MAX_INDEX)).
    ///
    /// ```
    /// use packtrace::{BlockedKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(BlockedKdTree::from_kd(&kd)?.node_count(), kd.node_count());
    /// # Ok::<(), packtrace::BuildError>(())
    /// ```
    pub fn from_kd(kd: &KdTree) -> Result<BlockedKdTree, BuildError> {
        let b = order::blocked(&kd.nodes, &kd.leaf_prims, kd.bounds)
            .map_err(|o| BuildError::TooManyNodes(o.0 as usize))?;
        Ok(BlockedKdTree {
            mesh: kd.mesh().clone(),
            nodes: b.nodes,
            leaf_prims: b.leaf_prims,
            root: b.root,
            bounds: kd.bounds,
            depth_limit: kd.depth_limit(),
        })
    }

    /// Number of nodes (not the unused slots that align the blocks).
    ///
    /// ```
    /// use packtrace::{BlockedKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(BlockedKdTree::from_kd(&kd).unwrap().node_count(), 1);
    /// ```
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len() - self.root as usize - 1
    }

    /// Bytes of the node array (with its unused slots) plus the leaf index
    /// array.
    ///
    /// ```
    /// use packtrace::{BlockedKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert!(BlockedKdTree::from_kd(&kd).unwrap().bytes() >= 16);
    /// ```
    #[must_use]
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.leaf_prims.as_slice())
    }

    /// Check the order's invariants: the unused slots empty, every pair
    /// after its parent at an even offset from the root (so inside one
    /// line), every node reached once, leaf runs in range. The tree's own
    /// invariants are [`KdTree::validate`]'s.
    ///
    /// # Errors
    /// A description of the first broken invariant.
    ///
    /// ```
    /// use packtrace::{BlockedKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(BlockedKdTree::from_kd(&kd).unwrap().validate(), Ok(()));
    /// ```
    pub fn validate(&self) -> Result<(), String> {
        order::check_blocked(&self.nodes, &self.leaf_prims, self.root)
    }
}

impl Layout for BlockedKdTree {
    type Ref = u32;
    type Tri = u32;

    #[inline(always)]
    fn root(&self) -> u32 {
        self.root
    }

    /// The two children side by side.
    #[inline(always)]
    fn view(&self, r: u32) -> NodeView<'_, u32> {
        let node = &self.nodes[r as usize];
        let n = *node;
        if n.is_leaf() {
            NodeView::Leaf(node.leaf_run(&self.leaf_prims))
        } else {
            NodeView::Interior {
                axis: n.axis(),
                split: n.split(),
                below: n.child(),
                above: n.child() + 1,
            }
        }
    }

    #[inline(always)]
    fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    #[inline(always)]
    fn bounds(&self) -> &Aabb {
        &self.bounds
    }

    #[inline(always)]
    fn depth_limit(&self) -> u32 {
        self.depth_limit
    }
}

layout_queries!(BlockedKdTree);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::KdBuildParams;
    use crate::packet::{RayPacket4, RayPacket8};
    use crate::query::{PacketQuery, RayQuery};
    use crate::ray::Ray;
    use glam::Vec3;

    #[test]
    fn same_answers_as_depth_first_on_a_grid_of_triangles() {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..200u32 {
            let x = (i % 20) as f32;
            let y = (i / 20) as f32;
            p.extend([
                Vec3::new(x, y, 0.0),
                Vec3::new(x + 0.9, y, 0.1 * y),
                Vec3::new(x, y + 1.0, 0.3 * x),
            ]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let kd = KdTree::build(Mesh::new(p, t).unwrap(), &KdBuildParams::default()).unwrap();
        let blocked = BlockedKdTree::from_kd(&kd).unwrap();
        assert_eq!(blocked.node_count(), kd.node_count());
        assert_eq!(blocked.validate(), Ok(()));
        assert_eq!(blocked.clone().validate(), Ok(()));
        for i in 0..400 {
            let o = Vec3::new(i as f32 * 0.05, 0.3 + i as f32 * 0.02, -5.0);
            let r = Ray::new_unchecked(o, Vec3::new(0.01, 0.02, 1.0), 0.0, f32::INFINITY);
            assert_eq!(RayQuery::intersect(&blocked, &r), kd.intersect(&r));
            assert_eq!(RayQuery::occluded(&blocked, &r), kd.occluded(&r));
            let p4 = RayPacket4::from_rays(&[r; 4]);
            assert_eq!(blocked.intersect4(&p4), kd.intersect4(&p4));
            let p8 = RayPacket8::from_rays(&[r; 8]);
            assert_eq!(blocked.intersect8(&p8), kd.intersect8(&p8));
        }
    }
}

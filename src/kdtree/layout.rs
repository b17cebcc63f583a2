//! How traversal reads nodes. The scalar and packet traversals are generic
//! over [`Layout`], so the compact 8-byte array and the naive pointer tree
//! (`naive.rs`) run the same algorithm and differ only in memory layout.

use super::KdTree;
use crate::aabb::Aabb;
use crate::mesh::Mesh;

/// One decoded node.
pub(crate) enum NodeView<'a, R> {
    Interior {
        axis: usize,
        split: f32,
        below: R,
        above: R,
    },
    Leaf(&'a [u32]),
}

/// A kd-tree layout: a handle type for nodes and a way to decode one.
pub(crate) trait Layout: Sync {
    /// Node handle kept on the traversal stack (index or pointer).
    type Ref: Copy;
    fn root(&self) -> Self::Ref;
    fn view(&self, r: Self::Ref) -> NodeView<'_, Self::Ref>;
    fn mesh(&self) -> &Mesh;
    fn bounds(&self) -> &Aabb;
    /// No leaf is deeper: bounds the traversal stack.
    fn depth_limit(&self) -> u32;
}

impl Layout for KdTree {
    type Ref = u32;

    #[inline(always)]
    fn root(&self) -> u32 {
        0
    }

    #[inline(always)]
    fn view(&self, r: u32) -> NodeView<'_, u32> {
        let i = r as usize;
        let node = &self.nodes[i];
        let n = *node;
        if n.is_leaf() {
            NodeView::Leaf(self.leaf_prims(node))
        } else {
            NodeView::Interior {
                axis: n.axis(),
                split: n.split(),
                below: r + 1,
                above: n.child(),
            }
        }
    }

    #[inline(always)]
    fn mesh(&self) -> &Mesh {
        KdTree::mesh(self)
    }

    #[inline(always)]
    fn bounds(&self) -> &Aabb {
        &self.bounds
    }

    #[inline(always)]
    fn depth_limit(&self) -> u32 {
        KdTree::depth_limit(self)
    }
}

//! How traversal reads nodes. The scalar and packet traversals are generic
//! over [`Layout`], so the compact 8-byte array and the naive pointer tree
//! (`naive.rs`) run the same algorithm and differ only in memory layout.

use super::KdTree;
use super::kernel::prefetch::prefetch;
use crate::aabb::Aabb;
use crate::mesh::Mesh;
use glam::Vec3;

/// One decoded node; a leaf is a run of `P`, the layout's triangle
/// references ([`LeafTri`]).
pub(crate) enum NodeView<'a, R, P = u32> {
    Interior {
        axis: usize,
        split: f32,
        below: R,
        above: R,
    },
    Leaf(&'a [P]),
}

/// What a leaf holds for each of its triangles: the mesh's index (`u32`,
/// corners read from the mesh) or a copy of the corners beside the index
/// (`inline_tris.rs`). The traversals read both through this trait, so the
/// leaf loops are the same code.
pub(crate) trait LeafTri: Sync {
    /// The mesh's triangle index (`Hit::prim`).
    fn prim(&self) -> u32;
    /// The triangle's corners, from `mesh` (the mesh's corner array) or
    /// from the reference itself.
    fn corners<'a>(&'a self, mesh: &'a [[Vec3; 3]]) -> &'a [Vec3; 3];
}

/// Prefetch the corners of a leaf's triangles after the first, before
/// the first one's test: their loads then overlap it instead of each
/// waiting for the test before it. Used by the scalar traversal, where
/// it measured 1.00-1.05x on every workload (docs/node-order.md); the packet leaves do not, where it measured 0.96x on Sponza's
/// primary and shadow packets (their corners are in cache already) for
/// 1.00-1.04x elsewhere. Prefetching the deferred far child at its push
/// was measured too and rejected: 1.00-1.03x, within the noise.
#[inline(always)]
pub(crate) fn prefetch_corners<P: LeafTri>(prims: &[P], mesh: &[[Vec3; 3]]) {
    if let [_, rest @ ..] = prims {
        for r in rest {
            prefetch(r.corners(mesh));
        }
    }
}

impl LeafTri for u32 {
    #[inline(always)]
    fn prim(&self) -> u32 {
        *self
    }
    #[inline(always)]
    fn corners<'a>(&'a self, mesh: &'a [[Vec3; 3]]) -> &'a [Vec3; 3] {
        &mesh[*self as usize]
    }
}

/// A kd-tree layout: a handle type for nodes and a way to decode one.
pub(crate) trait Layout: Sync {
    /// Node handle kept on the traversal stack (index or pointer).
    type Ref: Copy;
    /// What a leaf holds per triangle.
    type Tri: LeafTri;
    fn root(&self) -> Self::Ref;
    fn view(&self, r: Self::Ref) -> NodeView<'_, Self::Ref, Self::Tri>;
    fn mesh(&self) -> &Mesh;
    fn bounds(&self) -> &Aabb;
    /// No leaf is deeper: bounds the traversal stack.
    fn depth_limit(&self) -> u32;
}

impl Layout for KdTree {
    type Ref = u32;
    type Tri = u32;

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

//! Leaves with their triangles inline (issue 10 item 2; `--accel
//! kd8-inline`): the same 8-byte nodes in the same depth-first order as a
//! [`KdTree`], but a leaf's offset names a run of [`InlineTri`] records,
//! each the triangle's three corners beside its mesh index, laid out leaf
//! after leaf in node order. A leaf's triangles are then one contiguous
//! run read straight after the node: no index load and no scattered
//! corner loads (a [`KdTree`] leaf of `n > 1` triangles loads its index
//! run, then `n` corner records from anywhere in the mesh). A triangle
//! referenced by several leaves (a straddling triangle) gets a copy in
//! each, which is what costs memory: 40 bytes per reference instead of 4.
//!
//! Traced by the very same generic scalar, packet and group traversals
//! (the leaf loops read a [`LeafTri`]), so `kd8-inline / kd8` measures
//! what the copies buy on the machine at hand (docs/node-order.md).

use super::layout::{Layout, LeafTri, NodeView};
use super::node::KdNode;
use super::queries::layout_queries;
use super::{BuildError, KdTree};
use crate::aabb::Aabb;
use crate::mesh::Mesh;
use glam::Vec3;

/// One leaf reference with the triangle's corners copied in: 40 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct InlineTri {
    corners: [Vec3; 3],
    prim: u32,
}

const _: () = assert!(std::mem::size_of::<InlineTri>() == 40);

impl LeafTri for InlineTri {
    #[inline(always)]
    fn prim(&self) -> u32 {
        self.prim
    }
    #[inline(always)]
    fn corners<'a>(&'a self, _mesh: &'a [[Vec3; 3]]) -> &'a [Vec3; 3] {
        &self.corners
    }
}

/// A kd-tree whose leaves hold copies of their triangles' corners (see
/// the module docs). Same answers as the [`KdTree`] it was made from, on
/// every ray, through [`RayQuery`](crate::RayQuery) and
/// [`PacketQuery`](crate::PacketQuery); hits name the mesh's triangle
/// index as before.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{InlineKdTree, KdBuildParams, KdTree, Mesh, Ray, RayQuery};
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let kd = KdTree::build(m, &KdBuildParams::default()).unwrap();
/// let inline = InlineKdTree::from_kd(&kd).unwrap();
/// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// assert_eq!(inline.intersect(&r), kd.intersect(&r));
/// ```
#[derive(Clone, Debug)]
pub struct InlineKdTree {
    mesh: Mesh,
    /// The [`KdTree`]'s nodes; every leaf's first word is an offset into
    /// `tris`, also for one triangle.
    nodes: Vec<KdNode>,
    tris: Vec<InlineTri>,
    bounds: Aabb,
    depth_limit: u32,
}

impl InlineKdTree {
    /// Copy a tree's leaves' triangles into runs, node for node.
    ///
    /// # Errors
    /// [`BuildError::TooManyReferences`] when the runs need more records
    /// than a `u32` offset addresses, and [`BuildError::MemoryBudget`]
    /// when the records exceed the tree's
    /// [`KdBuildParams::memory_budget`](super::KdBuildParams::memory_budget).
    ///
    /// ```
    /// use packtrace::{InlineKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(InlineKdTree::from_kd(&kd)?.node_count(), kd.node_count());
    /// # Ok::<(), packtrace::BuildError>(())
    /// ```
    pub fn from_kd(kd: &KdTree) -> Result<InlineKdTree, BuildError> {
        let refs = references(kd);
        if refs > u32::MAX as usize {
            return Err(BuildError::TooManyReferences(refs));
        }
        let needed = refs * std::mem::size_of::<InlineTri>();
        if let Some(budget) = kd.params().memory_budget
            && needed > budget
        {
            return Err(BuildError::MemoryBudget { needed, budget });
        }
        let corners = kd.mesh().corner_slice();
        let mut tris = Vec::with_capacity(refs);
        let nodes = kd
            .nodes
            .iter()
            .map(|node| {
                if !node.is_leaf() {
                    return Ok(*node);
                }
                let first = tris.len() as u32;
                tris.extend(kd.leaf_prims(node).iter().map(|&prim| InlineTri {
                    corners: corners[prim as usize],
                    prim,
                }));
                KdNode::leaf(first, node.count())
                    .map_err(|o| BuildError::LeafTooLarge(o.0 as usize))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(InlineKdTree {
            mesh: kd.mesh().clone(),
            nodes,
            tris,
            bounds: kd.bounds,
            depth_limit: kd.depth_limit(),
        })
    }

    /// Number of nodes.
    ///
    /// ```
    /// use packtrace::{InlineKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(InlineKdTree::from_kd(&kd).unwrap().node_count(), 1);
    /// ```
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes of the node array plus the triangle records (the tree's
    /// memory beside the mesh, allocator overhead not counted).
    ///
    /// ```
    /// use packtrace::{InlineKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(InlineKdTree::from_kd(&kd).unwrap().bytes(), 8);
    /// ```
    #[must_use]
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice()) + std::mem::size_of_val(self.tris.as_slice())
    }

    /// Check that every leaf's run lies inside the records, that the runs
    /// tile them in node order, and that every record holds its
    /// triangle's corners as the mesh has them.
    ///
    /// # Errors
    /// A description of the first broken invariant.
    ///
    /// ```
    /// use packtrace::{InlineKdTree, KdBuildParams, KdTree, Mesh};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(InlineKdTree::from_kd(&kd).unwrap().validate(), Ok(()));
    /// ```
    pub fn validate(&self) -> Result<(), String> {
        let corners = self.mesh.corner_slice();
        let mut next = 0usize;
        for (i, n) in self.nodes.iter().enumerate() {
            if !n.is_leaf() {
                continue;
            }
            let (first, count) = (n.first() as usize, n.count() as usize);
            if first != next {
                return Err(format!(
                    "leaf {i} starts at record {first}, not {next} (runs out of node order)"
                ));
            }
            next += count;
            if next > self.tris.len() {
                return Err(format!(
                    "leaf {i}'s run {first}..{next} passes the {} records",
                    self.tris.len()
                ));
            }
        }
        if next != self.tris.len() {
            return Err(format!(
                "the leaves use {next} of {} records",
                self.tris.len()
            ));
        }
        for (j, t) in self.tris.iter().enumerate() {
            match corners.get(t.prim as usize) {
                Some(c) if *c == t.corners => {}
                Some(_) => return Err(format!("record {j}'s corners differ from the mesh's")),
                None => return Err(format!("record {j} names triangle {}", t.prim)),
            }
        }
        Ok(())
    }
}

/// The tree's leaf references: one record each.
fn references(kd: &KdTree) -> usize {
    kd.nodes
        .iter()
        .filter(|n| n.is_leaf())
        .map(|n| n.count() as usize)
        .sum()
}

impl Layout for InlineKdTree {
    type Ref = u32;
    type Tri = InlineTri;

    #[inline(always)]
    fn root(&self) -> u32 {
        0
    }

    /// Depth first, as a [`KdTree`]; a leaf is its run of records.
    #[inline(always)]
    fn view(&self, r: u32) -> NodeView<'_, u32, InlineTri> {
        let n = self.nodes[r as usize];
        if n.is_leaf() {
            let first = n.first() as usize;
            NodeView::Leaf(&self.tris[first..first + n.count() as usize])
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

layout_queries!(InlineKdTree);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::KdBuildParams;
    use crate::packet::{RayPacket4, RayPacket8};
    use crate::query::{PacketQuery, RayQuery};
    use crate::ray::Ray;

    fn grid() -> KdTree {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..200u32 {
            let x = (i % 20) as f32;
            let y = (i / 20) as f32;
            p.extend([
                Vec3::new(x, y, 0.0),
                Vec3::new(x + 1.4, y, 0.1 * y),
                Vec3::new(x, y + 1.3, 0.3 * x),
            ]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        KdTree::build(Mesh::new(p, t).unwrap(), &KdBuildParams::default()).unwrap()
    }

    #[test]
    fn same_answers_as_the_index_leaves_on_a_grid_of_overlapping_triangles() {
        let kd = grid();
        let inline = InlineKdTree::from_kd(&kd).unwrap();
        assert_eq!(inline.node_count(), kd.node_count());
        assert_eq!(inline.validate(), Ok(()));
        // Straddling triangles are copied into every leaf that names them.
        let refs = references(&kd);
        assert_eq!(inline.tris.len(), refs);
        assert!(refs > kd.mesh().triangle_count());
        for i in 0..400 {
            let o = Vec3::new(i as f32 * 0.05, 0.3 + i as f32 * 0.02, -5.0);
            let r = Ray::new_unchecked(o, Vec3::new(0.01, 0.02, 1.0), 0.0, f32::INFINITY);
            assert_eq!(RayQuery::intersect(&inline, &r), kd.intersect(&r));
            assert_eq!(RayQuery::occluded(&inline, &r), kd.occluded(&r));
            let p4 = RayPacket4::from_rays(&[r; 4]);
            assert_eq!(inline.intersect4(&p4), kd.intersect4(&p4));
            let p8 = RayPacket8::from_rays(&[r; 8]);
            assert_eq!(inline.intersect8(&p8), kd.intersect8(&p8));
        }
    }

    #[test]
    fn validate_finds_a_moved_run_a_short_run_and_a_changed_corner() {
        let kd = grid();
        let good = InlineKdTree::from_kd(&kd).unwrap();
        let leaf = good
            .nodes
            .iter()
            .rposition(|n| n.is_leaf() && n.count() > 1)
            .unwrap();
        let mut moved = good.clone();
        let n = moved.nodes[leaf];
        moved.nodes[leaf] = KdNode::leaf(n.first() + 1, n.count()).unwrap();
        assert!(moved.validate().unwrap_err().contains("starts at record"));
        let mut short = good.clone();
        short.tris.pop();
        assert!(short.validate().is_err());
        let mut long = good.clone();
        long.tris.push(long.tris[0]);
        assert!(long.validate().unwrap_err().contains("records"));
        let mut changed = good.clone();
        changed.tris[0].corners[1].x += 0.5;
        assert!(changed.validate().unwrap_err().contains("corners differ"));
        let mut named = good;
        named.tris[0].prim = u32::MAX;
        assert!(named.validate().unwrap_err().contains("names triangle"));
    }

    #[test]
    fn a_budget_below_the_records_is_an_error() {
        let mut kd = grid();
        let bytes = InlineKdTree::from_kd(&kd).unwrap().tris.len() * 40;
        kd.params.memory_budget = Some(bytes);
        assert!(InlineKdTree::from_kd(&kd).is_ok());
        kd.params.memory_budget = Some(bytes - 1);
        assert_eq!(
            InlineKdTree::from_kd(&kd).unwrap_err(),
            BuildError::MemoryBudget {
                needed: bytes,
                budget: bytes - 1
            }
        );
    }
}

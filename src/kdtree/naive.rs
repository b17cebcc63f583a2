//! The naive layout, kept only to measure what the 8-byte node gains:
//! fat nodes (split, axis byte, leaf flag, two child indices, and a heap
//! `Vec` of triangles per leaf; 40 bytes plus the leaf's allocation),
//! converted node for node from a [`KdTree`] so the SAH decisions and the
//! node order are identical, and traversed by the very same generic
//! scalar and packet traversals.

use super::KdTree;
use super::hybrid::trace;
use super::layout::{Layout, NodeView};
use super::queries::layout_queries;
use super::scalar::traverse;
use super::stats::NoCount;
use crate::aabb::Aabb;
use crate::mesh::Mesh;
use crate::packet::{HitPacket, HitPacket4, HitPacket8, RayPacket, RayPacket4, RayPacket8};
use crate::ray::{Hit, Ray};
use crate::simd::Lane;

/// A conventional fat node.
#[derive(Clone, Debug)]
struct NaiveNode {
    split: f32,
    axis: u8,
    is_leaf: bool,
    below: u32,
    above: u32,
    prims: Vec<u32>,
}

/// A kd-tree in the naive layout (see the module docs). Same answers as the
/// [`KdTree`] it was made from, on every ray.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, Ray};
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let kd = KdTree::build(m, &KdBuildParams::default()).unwrap();
/// let naive = NaiveKdTree::from_kd(&kd);
/// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// assert_eq!(naive.intersect(&r), kd.intersect(&r));
/// ```
#[derive(Clone, Debug)]
pub struct NaiveKdTree {
    mesh: Mesh,
    nodes: Vec<NaiveNode>,
    bounds: Aabb,
    depth_limit: u32,
}

impl NaiveKdTree {
    /// Convert a compact tree, node for node.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(NaiveKdTree::from_kd(&kd).node_count(), kd.node_count());
    /// ```
    #[must_use]
    pub fn from_kd(kd: &KdTree) -> NaiveKdTree {
        let nodes = (0..kd.nodes.len() as u32)
            .map(|r| match kd.view(r) {
                NodeView::Interior {
                    axis,
                    split,
                    below,
                    above,
                } => NaiveNode {
                    split,
                    axis: axis as u8,
                    is_leaf: false,
                    below,
                    above,
                    prims: Vec::new(),
                },
                NodeView::Leaf(prims) => NaiveNode {
                    split: 0.0,
                    axis: 0,
                    is_leaf: true,
                    below: 0,
                    above: 0,
                    prims: prims.to_vec(),
                },
            })
            .collect();
        NaiveKdTree {
            mesh: kd.mesh().clone(),
            nodes,
            bounds: kd.bounds,
            depth_limit: kd.depth_limit(),
        }
    }

    /// Number of nodes.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(NaiveKdTree::from_kd(&kd).node_count(), 1);
    /// ```
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes used by nodes and leaf triangle lists (allocator overhead not
    /// counted).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(NaiveKdTree::from_kd(&kd).bytes(), 40);
    /// ```
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<NaiveNode>()
            + self
                .nodes
                .iter()
                .map(|n| n.prims.len() * std::mem::size_of::<u32>())
                .sum::<usize>()
    }

    /// Closest hit (as [`KdTree::intersect`]).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, Ray};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(NaiveKdTree::from_kd(&kd).intersect(&r), None);
    /// ```
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        traverse::<_, false, _>(self, ray, &mut NoCount)
    }

    /// Occlusion (as [`KdTree::occluded`]).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, Ray};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// assert!(!NaiveKdTree::from_kd(&kd).occluded(&r));
    /// ```
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        traverse::<_, true, _>(self, ray, &mut NoCount).is_some()
    }

    /// Packet closest hits (as [`KdTree::intersect4`]).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, RayPacket4};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let h = NaiveKdTree::from_kd(&kd).intersect4(&RayPacket4::from_lanes([None; 4]));
    /// assert_eq!(h.mask(), 0);
    /// ```
    #[must_use]
    pub fn intersect4(&self, p: &RayPacket4) -> HitPacket4 {
        trace::<_, _, false, _>(self, p, &mut NoCount)
    }

    /// Packet occlusion (as [`KdTree::occluded4`]).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, RayPacket4};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(NaiveKdTree::from_kd(&kd).occluded4(&RayPacket4::from_lanes([None; 4])), 0);
    /// ```
    #[must_use]
    pub fn occluded4(&self, p: &RayPacket4) -> u32 {
        trace::<_, _, true, _>(self, p, &mut NoCount).mask()
    }

    /// Closest hits of a packet of any width (as
    /// [`KdTree::intersect_packet`]).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, RayPacket8};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let h = NaiveKdTree::from_kd(&kd).intersect_packet(&RayPacket8::from_lanes([None; 8]));
    /// assert_eq!(h.mask(), 0);
    /// ```
    #[must_use]
    pub fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>) -> HitPacket<L> {
        trace::<_, _, false, _>(self, p, &mut NoCount)
    }

    /// Occlusion of a packet of any width (as [`KdTree::occluded_packet`]).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, RayPacket4};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let p = RayPacket4::from_lanes([None; 4]);
    /// assert_eq!(NaiveKdTree::from_kd(&kd).occluded_packet(&p), 0);
    /// ```
    #[must_use]
    pub fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32 {
        trace::<_, _, true, _>(self, p, &mut NoCount).mask()
    }

    /// 8-wide packet closest hits (as [`KdTree::intersect8`]).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, RayPacket8};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let h = NaiveKdTree::from_kd(&kd).intersect8(&RayPacket8::from_lanes([None; 8]));
    /// assert_eq!(h.mask(), 0);
    /// ```
    #[must_use]
    pub fn intersect8(&self, p: &RayPacket8) -> HitPacket8 {
        trace::<_, _, false, _>(self, p, &mut NoCount)
    }

    /// 8-wide packet occlusion (as [`KdTree::occluded8`]).
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, NaiveKdTree, RayPacket8};
    /// let kd = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(NaiveKdTree::from_kd(&kd).occluded8(&RayPacket8::from_lanes([None; 8])), 0);
    /// ```
    #[must_use]
    pub fn occluded8(&self, p: &RayPacket8) -> u32 {
        trace::<_, _, true, _>(self, p, &mut NoCount).mask()
    }
}

impl Layout for NaiveKdTree {
    type Ref = u32;
    type Tri = u32;

    #[inline(always)]
    fn root(&self) -> u32 {
        0
    }

    #[inline(always)]
    fn view(&self, r: u32) -> NodeView<'_, u32> {
        let n = &self.nodes[r as usize];
        if n.is_leaf {
            NodeView::Leaf(&n.prims)
        } else {
            NodeView::Interior {
                axis: usize::from(n.axis & 3),
                split: n.split,
                below: n.below,
                above: n.above,
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

layout_queries!(NaiveKdTree);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::KdBuildParams;
    use glam::Vec3;

    #[test]
    fn naive_node_is_fat() {
        assert_eq!(std::mem::size_of::<NaiveNode>(), 40);
    }

    #[test]
    fn same_answers_as_compact_on_a_grid_of_triangles() {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..20u32 {
            let x = i as f32;
            p.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.9, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.3 * x),
            ]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let kd = KdTree::build(Mesh::new(p, t).unwrap(), &KdBuildParams::default()).unwrap();
        let naive = NaiveKdTree::from_kd(&kd);
        for i in 0..400 {
            let o = Vec3::new(i as f32 * 0.05, 0.3, -5.0);
            let r = Ray::new_unchecked(o, Vec3::new(0.01, 0.0, 1.0), 0.0, f32::INFINITY);
            assert_eq!(naive.intersect(&r), kd.intersect(&r));
            assert_eq!(naive.occluded(&r), kd.occluded(&r));
            let p4 = RayPacket4::from_rays(&[r; 4]);
            assert_eq!(naive.intersect4(&p4), kd.intersect4(&p4));
        }
    }
}

//! The BVHs' memory layouts: the binary node (32 bytes), the 8-wide node
//! (256 bytes, one per four cache lines, children's boxes in SoA form), the
//! child reference of the 8-wide node and the leaves' 4-triangle blocks.

use crate::aabb::Aabb;
use crate::simd::{F4, F8};
use glam::{Vec3, Vec3A};

/// Most triangles a BVH addresses: a leaf reference of the 8-wide tree
/// holds a 28-bit block index (`4 * 2^28` triangle slots).
pub const MAX_TRIANGLES: usize = (1 << 28) - 1;

/// A binary node (32 bytes, two per cache line), in depth-first order:
/// the left child follows its parent, so a subtree is contiguous.
///
/// `count == 0`: interior node whose right child is node `index`.
/// `count > 0`: leaf of the triangles `prims[index..index + count]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Node2 {
    /// The box's smallest corner.
    pub lo: [f32; 3],
    /// Triangles of a leaf; 0 for an interior node.
    pub count: u32,
    /// The box's largest corner.
    pub hi: [f32; 3],
    /// Right child (interior) or first triangle slot (leaf).
    pub index: u32,
}
const _: () = assert!(std::mem::size_of::<Node2>() == 32);

impl Node2 {
    /// The node's box.
    #[inline(always)]
    pub(crate) fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.lo), Vec3A::from_array(self.hi))
    }

    /// Is it a leaf (`count > 0`)?
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let m = packtrace::protocol::generate::sphere(100);
    /// let b = Bvh2::build(m, &BvhBuildParams::median()).unwrap();
    /// assert!(b.nodes().iter().any(|n| n.is_leaf()));
    /// ```
    #[inline(always)]
    #[must_use]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// A child slot of an 8-wide node: an interior node's index, a leaf's
/// first block and block count, or nothing (an empty slot, whose box is
/// inverted so that no ray meets it).
///
/// Bit 31 set: a leaf; bits 28..31 hold `blocks - 1` (1 to 8 blocks),
/// bits 0..28 the first block. Bit 31 clear: node index. Decoding is two
/// shifts and a mask, no table (Embree's node references carry their type
/// in the low bits of a pointer; an index needs the high ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(transparent)]
pub struct ChildRef(pub u32);

impl ChildRef {
    /// The empty slot (never followed: its box is inverted).
    pub const EMPTY: ChildRef = ChildRef(u32::MAX);
    const LEAF: u32 = 1 << 31;
    const FIRST_BITS: u32 = 28;

    /// Interior node `i` (`i < 2^31`).
    #[inline(always)]
    #[must_use]
    pub fn node(i: u32) -> ChildRef {
        debug_assert!(i < Self::LEAF);
        ChildRef(i)
    }

    /// A leaf of `blocks` (1..=8) blocks from block `first` (`< 2^28`).
    #[inline(always)]
    #[must_use]
    pub fn leaf(first: u32, blocks: u32) -> ChildRef {
        debug_assert!((1..=8).contains(&blocks) && first < 1 << Self::FIRST_BITS);
        ChildRef(Self::LEAF | (blocks - 1) << Self::FIRST_BITS | first)
    }

    /// Is it a leaf (or the empty slot)?
    #[inline(always)]
    #[must_use]
    pub fn is_leaf(self) -> bool {
        self.0 & Self::LEAF != 0
    }

    /// The node index of an interior reference.
    #[inline(always)]
    #[must_use]
    pub fn index(self) -> usize {
        self.0 as usize
    }

    /// A leaf's blocks as `first..first + count`.
    #[inline(always)]
    #[must_use]
    pub fn blocks(self) -> std::ops::Range<usize> {
        let first = (self.0 & ((1 << Self::FIRST_BITS) - 1)) as usize;
        let count = ((self.0 >> Self::FIRST_BITS) & 7) as usize + 1;
        first..first + count
    }
}

/// An 8-wide node: 256 bytes, aligned to a cache line, the eight children's
/// boxes as structure of arrays (one [`F8`] per box plane) and their
/// references (Dammertz et al. 2008; Embree's `AABBNode_t<8>`).
///
/// `planes[a]` holds axis `a`'s `[lo, hi]`, so a ray whose direction is
/// negative on axis `a` reads its near plane at `planes[a][1]` and its far
/// plane at `planes[a][0]`: one index per axis (a `bool`, so no bounds
/// check), chosen once per ray, and no branch per node (Embree's
/// `nearX..farZ` offsets). An empty slot has `lo = +inf`, `hi = -inf` on every
/// axis, which every ray misses. Slots are filled from 0; `children` of an
/// empty slot is [`ChildRef::EMPTY`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Node8 {
    /// Box planes of the eight children: `planes[axis][0]` the lower,
    /// `planes[axis][1]` the upper.
    pub planes: [[F8; 2]; 3],
    /// The children's references.
    pub children: [ChildRef; 8],
    /// Triangles under each child (0 for an empty slot): statistics and
    /// validation only; it pads the node to four cache lines.
    pub triangles: [u32; 8],
}
const _: () = assert!(std::mem::size_of::<Node8>() == 256);
const _: () = assert!(std::mem::align_of::<Node8>() == 64);

impl Node8 {
    /// A node of empty slots.
    #[must_use]
    pub fn empty() -> Node8 {
        let (inf, neg) = (F8::splat(f32::INFINITY), F8::splat(f32::NEG_INFINITY));
        Node8 {
            planes: [[inf, neg]; 3],
            children: [ChildRef::EMPTY; 8],
            triangles: [0; 8],
        }
    }

    /// Child slot `i`'s box.
    #[must_use]
    pub fn child_bounds(&self, i: usize) -> Aabb {
        let p = |a: usize, side: usize| self.planes[a][side].to_array()[i];
        Aabb::new(
            Vec3A::new(p(0, 0), p(1, 0), p(2, 0)),
            Vec3A::new(p(0, 1), p(1, 1), p(2, 1)),
        )
    }

    /// Sets child slot `i` to `r` with box `b`, over `triangles` triangles.
    pub(crate) fn set_child(&mut self, i: usize, r: ChildRef, b: &Aabb, triangles: u32) {
        for a in 0..3 {
            for (side, x) in [(0, b.min[a]), (1, b.max[a])] {
                let mut lanes = self.planes[a][side].to_array();
                lanes[i] = x;
                self.planes[a][side] = F8::from(lanes);
            }
        }
        self.children[i] = r;
        self.triangles[i] = triangles;
    }

    /// The used slots (slots are filled from 0).
    #[must_use]
    pub fn child_count(&self) -> usize {
        self.children
            .iter()
            .take_while(|&&c| c != ChildRef::EMPTY)
            .count()
    }
}

/// Four triangles as structure of arrays (160 bytes): corner `j`'s axis
/// `a` of the four is `corners[j][a]`, one [`F4`] each, and their indices
/// in the mesh. The one watertight routine runs on the four at once, its
/// lanes being triangles rather than rays (Embree's `Triangle4`, which
/// stores `v0, e1, e2`; this block keeps the corners, the routine's input).
///
/// A block of fewer than four triangles repeats its first one in the
/// spare lanes (same corners, same index): the repeated lane finds exactly
/// the first lane's hit, so it changes no answer, and a lane of zeros or
/// NaN would have sent the routine to its per-lane f64 route.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct Tri4 {
    /// `corners[j][a]`: axis `a` of corner `j` of the four triangles.
    pub corners: [[F4; 3]; 3],
    /// The triangles' indices in the mesh.
    pub prims: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<Tri4>() == 160);

impl Tri4 {
    /// The block of up to four triangles `prims` (`1..=4` of them), the
    /// first repeated in spare lanes.
    pub(crate) fn new(prims: &[u32], corners: &[[Vec3; 3]]) -> Tri4 {
        debug_assert!((1..=4).contains(&prims.len()));
        let lane = |l: usize| prims.get(l).copied().unwrap_or(prims[0]);
        let ids = [lane(0), lane(1), lane(2), lane(3)];
        let c = |j: usize, a: usize| F4::from(ids.map(|p| corners[p as usize][j][a]));
        Tri4 {
            corners: [0, 1, 2].map(|j| [c(j, 0), c(j, 1), c(j, 2)]),
            prims: ids,
        }
    }

    /// Distinct triangles of the block (1 to 4): lanes after the first
    /// that repeat it are spares.
    #[inline(always)]
    #[must_use]
    pub fn len(&self) -> u32 {
        1 + self.prims[1..]
            .iter()
            .filter(|&&p| p != self.prims[0])
            .count() as u32
    }

    /// Never empty: a block holds at least one triangle.
    #[inline(always)]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Lane `l`'s corners.
    #[must_use]
    pub fn triangle(&self, l: usize) -> [Vec3; 3] {
        let c = |j: usize| {
            let [x, y, z] = self.corners[j];
            Vec3::new(x.as_array()[l], y.as_array()[l], z.as_array()[l])
        };
        [c(0), c(1), c(2)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn child_refs_round_trip_at_their_limits() {
        for (first, blocks) in [(0, 1), (7, 8), ((1 << 28) - 1, 8), (12345, 3)] {
            let r = ChildRef::leaf(first, blocks);
            assert!(r.is_leaf());
            assert_eq!(r.blocks(), first as usize..(first + blocks) as usize);
        }
        for i in [0, 1, (1 << 31) - 1] {
            let r = ChildRef::node(i);
            assert!(!r.is_leaf());
            assert_eq!(r.index(), i as usize);
        }
        assert!(ChildRef::EMPTY.is_leaf());
    }

    #[test]
    fn node_slots_and_blocks_keep_what_was_set() {
        let mut n = Node8::empty();
        assert_eq!(n.child_count(), 0);
        let b = Aabb::new(Vec3A::new(-1.0, 2.0, 3.0), Vec3A::new(4.0, 5.0, 6.5));
        n.set_child(0, ChildRef::node(7), &b, 9);
        n.set_child(1, ChildRef::leaf(3, 2), &b, 5);
        assert_eq!((n.child_count(), n.child_bounds(1)), (2, b));
        assert!(n.child_bounds(2).is_empty());
        let corners = vec![
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [Vec3::Z, Vec3::ONE, Vec3::NEG_X],
        ];
        let t = Tri4::new(&[1, 0], &corners);
        assert_eq!(t.prims, [1, 0, 1, 1]);
        assert_eq!(
            (t.len(), t.triangle(1), t.triangle(3)),
            (2, corners[0], corners[1])
        );
    }
}

//! The 8-byte kd-tree node (PBRT-v3's `KdAccelNode`; Wald's thesis 2004,
//! section 7.2): two `u32` words in one flat array.
//!
//! | word | interior                         | leaf                                   |
//! |------|----------------------------------|----------------------------------------|
//! | `a`  | split position (`f32` bits)      | the triangle (count 1) or offset into the leaf index array |
//! | `b`  | `child << 2 \| axis` (0..2)       | `count << 2 \| 3`                      |
//!
//! What `child` names depends on the array's node order (`order.rs`): in
//! the build's depth-first order it is the above child, the below child
//! being the next node; in a [`KdTree`](super::KdTree)'s blocked order it
//! is the first of the two children, which sit side by side (below, then
//! above).

use std::fmt;

/// Largest child index or leaf count that fits in the 30 upper bits.
pub const MAX_INDEX: u32 = (1 << 30) - 1;

const LEAF_TAG: u32 = 3;

/// One kd-tree node, 8 bytes.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) struct KdNode {
    /// Split `f32` bits, or the triangle / offset of a leaf.
    a: u32,
    /// Tag in bits 0..2 (axis, or 3 for a leaf), child index or count above.
    b: u32,
}

const _: () = assert!(std::mem::size_of::<KdNode>() == 8);
const _: () = assert!(std::mem::align_of::<KdNode>() == 4);

/// A node field that does not fit in 30 bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Overflow(pub u64);

impl KdNode {
    /// An empty leaf; build uses it as the placeholder of an interior node
    /// whose above child is not yet placed. A constant, so nothing can fail.
    pub const EMPTY_LEAF: KdNode = KdNode { a: 0, b: LEAF_TAG };

    /// Interior node splitting `axis` at `split`, naming its children by
    /// `child` (see the module docs for what that index means in each
    /// order).
    #[inline]
    pub fn interior(axis: usize, split: f32, child: u32) -> Result<KdNode, Overflow> {
        debug_assert!(axis < 3);
        if child > MAX_INDEX {
            return Err(Overflow(child as u64));
        }
        Ok(KdNode {
            a: split.to_bits(),
            b: child << 2 | axis as u32,
        })
    }

    /// Leaf with `count` triangles: `first` is the triangle itself when
    /// `count == 1`, else the offset of the leaf's run in the index array.
    #[inline]
    pub fn leaf(first: u32, count: u32) -> Result<KdNode, Overflow> {
        if count > MAX_INDEX {
            return Err(Overflow(count as u64));
        }
        Ok(KdNode {
            a: first,
            b: count << 2 | LEAF_TAG,
        })
    }

    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.b & 3 == LEAF_TAG
    }
    /// Split axis of an interior node.
    #[inline(always)]
    pub fn axis(self) -> usize {
        (self.b & 3) as usize
    }
    #[inline(always)]
    pub fn split(self) -> f32 {
        f32::from_bits(self.a)
    }
    /// The child index of an interior node (the above child in depth-first
    /// order, the pair's first node in blocked order).
    #[inline(always)]
    pub fn child(self) -> u32 {
        self.b >> 2
    }
    /// Triangle count of a leaf.
    #[inline(always)]
    pub fn count(self) -> u32 {
        self.b >> 2
    }
    /// The triangle (count 1) or index-array offset of a leaf.
    #[inline(always)]
    pub fn first(self) -> u32 {
        self.a
    }
    /// The first word in place, so a one-triangle leaf is a slice of one.
    #[inline(always)]
    pub fn first_ref(&self) -> &u32 {
        &self.a
    }
    /// The triangles of this leaf, whose runs are in `leaf_prims` (borrowed
    /// in place: a one-triangle leaf's slice is its own first word, not
    /// indexed again). The same for every node order.
    #[inline(always)]
    pub fn leaf_run<'a>(&'a self, leaf_prims: &'a [u32]) -> &'a [u32] {
        let first = self.first() as usize;
        match self.count() {
            0 => &[],
            1 => std::slice::from_ref(self.first_ref()),
            n => &leaf_prims[first..first + n as usize],
        }
    }
    /// Re-base the child index / leaf offset when a subtree built on its
    /// own is appended at `node_base` / `prim_base` (parallel build).
    #[inline]
    pub fn rebased(self, node_base: u32, prim_base: u32) -> Result<KdNode, Overflow> {
        if self.is_leaf() {
            let first = if self.count() > 1 {
                self.first() + prim_base
            } else {
                self.first()
            };
            KdNode::leaf(first, self.count())
        } else {
            let above = self.child() as u64 + node_base as u64;
            if above > MAX_INDEX as u64 {
                return Err(Overflow(above));
            }
            KdNode::interior(self.axis(), self.split(), above as u32)
        }
    }
}

impl fmt::Debug for KdNode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_leaf() {
            write!(f, "Leaf(first={}, count={})", self.first(), self.count())
        } else {
            write!(
                f,
                "Interior(axis={}, split={}, child={})",
                self.axis(),
                self.split(),
                self.child()
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interior_bit_layout() {
        let n = KdNode::interior(2, 1.5, 7).unwrap();
        assert_eq!(n.a, 1.5f32.to_bits());
        assert_eq!(n.b, 7 << 2 | 2);
        assert!(!n.is_leaf());
        assert_eq!((n.axis(), n.split(), n.child()), (2, 1.5, 7));
        // negative zero and negative splits keep their bits
        let n = KdNode::interior(0, -0.0, 1).unwrap();
        assert_eq!(n.split().to_bits(), (-0.0f32).to_bits());
    }

    #[test]
    fn leaf_bit_layout() {
        let n = KdNode::leaf(42, 1).unwrap();
        assert_eq!((n.a, n.b), (42, 1 << 2 | 3));
        assert!(n.is_leaf());
        assert_eq!((n.first(), n.count()), (42, 1));
        let e = KdNode::leaf(0, 0).unwrap();
        assert_eq!((e.a, e.b), (0, 3));
        assert_eq!(e, KdNode::EMPTY_LEAF);
        // the triangle index of a one-triangle leaf may use all 32 bits
        let n = KdNode::leaf(u32::MAX - 1, 1).unwrap();
        assert_eq!(n.first(), u32::MAX - 1);
    }

    #[test]
    fn limits_fit_and_overflow_is_an_error() {
        let n = KdNode::interior(1, 0.0, MAX_INDEX).unwrap();
        assert_eq!(n.child(), MAX_INDEX);
        assert_eq!(n.b, u32::MAX - 2);
        assert_eq!(
            KdNode::interior(1, 0.0, MAX_INDEX + 1),
            Err(Overflow(1 << 30))
        );
        let n = KdNode::leaf(9, MAX_INDEX).unwrap();
        assert_eq!(n.count(), MAX_INDEX);
        assert_eq!(n.b, u32::MAX);
        assert_eq!(KdNode::leaf(9, MAX_INDEX + 1), Err(Overflow(1 << 30)));
        let deep = KdNode::interior(0, 1.0, 5).unwrap();
        assert!(deep.rebased(MAX_INDEX, 0).is_err());
        // Re-basing exactly onto the largest index is fine, one more is not
        // (the bound of the check itself; a mutation test finding).
        let top = deep.rebased(MAX_INDEX - 5, 0).unwrap();
        assert_eq!((top.child(), top.axis(), top.split()), (MAX_INDEX, 0, 1.0));
        assert_eq!(deep.rebased(MAX_INDEX - 4, 0), Err(Overflow(1 << 30)));
        assert_eq!(deep.rebased(10, 0).unwrap().child(), 15);
        let l = KdNode::leaf(3, 2).unwrap().rebased(10, 100).unwrap();
        assert_eq!(l.first(), 103);
        let l1 = KdNode::leaf(3, 1).unwrap().rebased(10, 100).unwrap();
        assert_eq!(l1.first(), 3);
    }
}

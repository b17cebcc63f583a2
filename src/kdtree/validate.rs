//! Structural validation of a built tree: the invariants traversal (and
//! any future `unsafe` in it) relies on.

use super::KdTree;
use super::clip::{PrimRef, split_refs};
use crate::aabb::Aabb;
use std::fmt;

/// A broken tree invariant, naming the node at fault.
#[derive(Clone, Debug, PartialEq)]
pub enum ValidationError {
    /// The tree has no root node.
    NoRoot,
    /// A node is never reached from the root.
    Unreachable(usize),
    /// A node is reached twice (the tree is not a tree).
    ReachedTwice(usize),
    /// An interior node's above child is out of range or not after it.
    BadChild {
        /// The interior node.
        node: usize,
        /// Its above-child index.
        child: usize,
    },
    /// A split is not finite or not strictly inside the node's cell.
    SplitOutsideCell {
        /// The interior node.
        node: usize,
        /// The split position.
        split: f32,
    },
    /// A leaf's run of the index array is out of range, or it names a
    /// triangle that does not exist.
    BadLeaf {
        /// The leaf.
        node: usize,
    },
    /// A leaf is deeper than the depth limit (and so the traversal stack).
    TooDeep {
        /// The leaf.
        node: usize,
        /// Its depth.
        depth: u32,
        /// The limit.
        limit: u32,
    },
    /// A triangle whose box reaches the leaf's cell is missing from it.
    MissingReference {
        /// The leaf.
        node: usize,
        /// The triangle.
        prim: u32,
    },
    /// A leaf references a triangle whose box does not reach its cell, or
    /// a degenerate triangle.
    ExtraReference {
        /// The leaf.
        node: usize,
        /// The triangle.
        prim: u32,
    },
}

impl fmt::Display for ValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid kd-tree: {self:?}")
    }
}

impl std::error::Error for ValidationError {}

impl KdTree {
    /// Check every invariant: each node reached exactly once from the root,
    /// children after their parent, splits strictly inside their cells,
    /// leaf ranges in bounds, depth within the limit (so within the fixed
    /// traversal stack), and each leaf referencing exactly the
    /// non-degenerate triangles whose boxes reach its cell under the build's
    /// classification rule (a straddling triangle in both children, clipped
    /// to each when split clipping is on; a triangle touching the split
    /// plane on its own side).
    ///
    /// A debug check for tests, fuzzing and doubtful builds, not a step of
    /// normal use: it replays the build's classification of every
    /// reference and costs a large share of a build (45 % of Sponza's, as
    /// measured for issue 15). Every tree [`KdTree::build`] returns is
    /// expected to pass: the test suites and the fuzz targets check it.
    ///
    /// # Errors
    /// The first broken invariant found.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert_eq!(t.validate(), Ok(()));
    /// ```
    pub fn validate(&self) -> Result<(), ValidationError> {
        if self.nodes.is_empty() {
            return Err(ValidationError::NoRoot);
        }
        let mesh = self.mesh();
        let mut seen = vec![false; self.nodes.len()];
        let all: Vec<PrimRef> = (0..mesh.triangle_count())
            .filter(|&i| !mesh.is_degenerate(i))
            .map(|i| PrimRef::new(i as u32, mesh.triangle_bounds(i)))
            .collect();
        let mut stack: Vec<(usize, Aabb, u32, Vec<PrimRef>)> = vec![(0, self.bounds, 0, all)];
        while let Some((i, cell, depth, must)) = stack.pop() {
            if std::mem::replace(&mut seen[i], true) {
                return Err(ValidationError::ReachedTwice(i));
            }
            let n = self.nodes[i];
            if n.is_leaf() {
                if depth > self.depth_limit() {
                    return Err(ValidationError::TooDeep {
                        node: i,
                        depth,
                        limit: self.depth_limit(),
                    });
                }
                let first = n.first() as usize;
                let count = n.count() as usize;
                if count > 1 && first + count > self.leaf_prims.len() {
                    return Err(ValidationError::BadLeaf { node: i });
                }
                let mut refs = self.leaf_prims(&self.nodes[i]).to_vec();
                if refs.iter().any(|&p| p as usize >= mesh.triangle_count()) {
                    return Err(ValidationError::BadLeaf { node: i });
                }
                refs.sort_unstable();
                let mut must: Vec<u32> = must.iter().map(|r| r.prim).collect();
                must.sort_unstable();
                if let Some(&p) = must.iter().find(|p| refs.binary_search(p).is_err()) {
                    return Err(ValidationError::MissingReference { node: i, prim: p });
                }
                if let Some(&p) = refs.iter().find(|p| {
                    must.binary_search(p).is_err()
                        || !mesh.triangle_bounds(**p as usize).overlaps(&cell)
                }) {
                    return Err(ValidationError::ExtraReference { node: i, prim: p });
                }
                continue;
            }
            let above = n.child() as usize;
            if above <= i + 1 || above >= self.nodes.len() || i + 1 >= self.nodes.len() {
                return Err(ValidationError::BadChild {
                    node: i,
                    child: above,
                });
            }
            let (axis, s) = (n.axis(), n.split());
            if !(s > cell.min[axis] && s < cell.max[axis]) {
                return Err(ValidationError::SplitOutsideCell { node: i, split: s });
            }
            let (mut below_set, mut above_set) = (Vec::new(), Vec::new());
            split_refs(
                mesh.corner_slice(),
                &must,
                &cell,
                (axis, s),
                self.params().split_clipping,
                &mut below_set,
                &mut above_set,
            );
            let (mut cb, mut ca) = (cell, cell);
            cb.max[axis] = s;
            ca.min[axis] = s;
            stack.push((i + 1, cb, depth + 1, below_set));
            stack.push((above, ca, depth + 1, above_set));
        }
        if let Some(i) = seen.iter().position(|s| !s) {
            return Err(ValidationError::Unreachable(i));
        }
        Ok(())
    }
}

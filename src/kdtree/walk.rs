//! A hidden view of the tree's interior nodes, for tests that start rays
//! exactly on split planes.

use super::KdTree;

impl KdTree {
    /// The `(axis, split)` of every interior node, in node order (depth
    /// first, below child before above child). Not part of the API: the
    /// integration tests use it to aim rays at split planes.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// assert!(t.split_planes().is_empty());
    /// ```
    #[doc(hidden)]
    #[must_use]
    pub fn split_planes(&self) -> Vec<(usize, f32)> {
        self.nodes
            .iter()
            .filter(|n| !n.is_leaf())
            .map(|n| (n.axis(), n.split()))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use crate::kdtree::KdBuildParams;
    use crate::{KdTree, Mesh};
    use glam::Vec3;

    #[test]
    fn split_planes_are_the_interior_nodes_inside_the_bounds() {
        // A row of 64 small triangles along x: the tree must split x.
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..64u32 {
            let x = i as f32;
            p.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.5, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.25),
            ]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let tree = KdTree::build(Mesh::new(p, t).unwrap(), &KdBuildParams::default()).unwrap();
        let planes = tree.split_planes();
        let s = tree.stats();
        assert_eq!(planes.len(), s.nodes - s.leaves);
        assert!(planes.iter().any(|&(axis, _)| axis == 0), "{planes:?}");
        let (lo, hi) = (tree.bounds().min, tree.bounds().max);
        for &(axis, split) in &planes {
            assert!(axis < 3);
            assert!(lo[axis] <= split && split <= hi[axis], "{axis} {split}");
        }
        // The same planes as the nodes' `Debug` text, in the same order.
        let from_debug: Vec<String> = tree
            .nodes
            .iter()
            .filter(|n| !n.is_leaf())
            .map(|n| format!("{n:?}"))
            .collect();
        for ((axis, split), text) in planes.iter().zip(&from_debug) {
            assert!(
                text.starts_with(&format!("Interior(axis={axis}, split={split},")),
                "{text}"
            );
        }
    }
}

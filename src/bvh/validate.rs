//! Structural checks of both BVHs: what every traversal relies on.

use super::Bvh8;
use super::bvh2::Bvh2;
use super::node::{ChildRef, Node8};
use super::params::BVH_MAX_DEPTH;
use crate::aabb::Aabb;
use crate::mesh::Mesh;
use std::fmt;

/// A broken invariant of a BVH, with what and where.
///
/// ```
/// use packtrace::bvh::{Bvh8, BvhBuildParams};
/// let b = Bvh8::build(packtrace::protocol::generate::sphere(200), &BvhBuildParams::default()).unwrap();
/// assert_eq!(b.validate(), Ok(()));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BvhValidationError(pub String);

impl fmt::Display for BvhValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid BVH: {}", self.0)
    }
}

impl std::error::Error for BvhValidationError {}

fn fail<T>(s: String) -> Result<T, BvhValidationError> {
    Err(BvhValidationError(s))
}

/// `inner` inside `outer` (closed boxes, f32 compares: exact).
fn inside(inner: &Aabb, outer: &Aabb) -> bool {
    inner.min.cmpge(outer.min).all() && inner.max.cmple(outer.max).all()
}

/// Every non-degenerate triangle of `mesh` seen exactly once, no other.
fn check_seen(mesh: &Mesh, seen: &[u32]) -> Result<(), BvhValidationError> {
    for (i, &n) in seen.iter().enumerate() {
        let want = u32::from(!mesh.is_degenerate(i));
        if n != want {
            return fail(format!(
                "triangle {i} is referenced {n} times (want {want}{})",
                if want == 0 { ": degenerate" } else { "" }
            ));
        }
    }
    Ok(())
}

impl Bvh8 {
    /// Checks the tree's invariants: every node reached exactly once from
    /// the root, at most [`BVH_MAX_DEPTH`] deep (within the traversal
    /// stack); slots filled from the first, empty slots with inverted
    /// boxes; every child box inside its parent's (the root's inside the
    /// mesh box); every leaf's blocks in range and used once, their
    /// corners the mesh's exactly, each triangle's box inside its leaf's
    /// box (so the boxes are conservative in f32), spare lanes repeating
    /// the first; per-slot triangle counts right; every non-degenerate
    /// triangle referenced exactly once and no degenerate one.
    ///
    /// # Errors
    /// The first broken invariant, as a [`BvhValidationError`].
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// for (_, p) in BvhBuildParams::presets() {
    ///     let b = Bvh8::build(packtrace::protocol::generate::sphere(300), &p).unwrap();
    ///     assert_eq!(b.validate(), Ok(()));
    /// }
    /// ```
    pub fn validate(&self) -> Result<(), BvhValidationError> {
        let mesh = self.mesh();
        let mut seen = vec![0u32; mesh.triangle_count()];
        let mut node_seen = vec![false; self.nodes.len()];
        let mut block_seen = vec![false; self.blocks.len()];
        if self.root == ChildRef::EMPTY {
            if !self.nodes.is_empty() || !self.blocks.is_empty() {
                return fail("an empty root with nodes or blocks".into());
            }
            return check_seen(mesh, &seen);
        }
        // (reference, its box, the triangles its slot says, depth)
        let mut stack = vec![(self.root, self.bounds, u32::MAX, 1u32)];
        while let Some((r, b, count, depth)) = stack.pop() {
            if depth > BVH_MAX_DEPTH {
                return fail(format!("a node at depth {depth}"));
            }
            if r.is_leaf() {
                let n = self.check_leaf(r, &b, &mut block_seen, &mut seen)?;
                if count != u32::MAX && n != count {
                    return fail(format!(
                        "leaf {r:?} holds {n} triangles, its slot says {count}"
                    ));
                }
                continue;
            }
            let i = r.index();
            let Some(node) = self.nodes.get(i) else {
                return fail(format!("node {i} beyond the {} nodes", self.nodes.len()));
            };
            if std::mem::replace(&mut node_seen[i], true) {
                return fail(format!("node {i} is reached twice"));
            }
            let used = self.check_slots(i, node, &b)?;
            let sum: u32 = node.triangles[..used].iter().sum();
            if count != u32::MAX && sum != count {
                return fail(format!(
                    "node {i} holds {sum} triangles, its slot says {count}"
                ));
            }
            for s in 0..used {
                stack.push((
                    node.children[s],
                    node.child_bounds(s),
                    node.triangles[s],
                    depth + 1,
                ));
            }
        }
        if let Some(i) = node_seen.iter().position(|&s| !s) {
            return fail(format!("node {i} is never reached"));
        }
        if let Some(i) = block_seen.iter().position(|&s| !s) {
            return fail(format!("block {i} is never reached"));
        }
        check_seen(mesh, &seen)
    }

    /// Node `i`'s slots: filled from the first, at least two used (one for
    /// the root), boxes inside `parent`, empty slots inverted. Returns the
    /// used slots.
    fn check_slots(
        &self,
        i: usize,
        node: &Node8,
        parent: &Aabb,
    ) -> Result<usize, BvhValidationError> {
        let used = node.child_count();
        if used < 2 && !(i == 0 && used == 1) {
            return fail(format!("node {i} has {used} children"));
        }
        for s in 0..8 {
            let cb = node.child_bounds(s);
            if s < used {
                if cb.is_empty() || !inside(&cb, parent) {
                    return fail(format!(
                        "node {i} slot {s}: box {cb:?} not inside {parent:?}"
                    ));
                }
                if node.triangles[s] == 0 {
                    return fail(format!("node {i} slot {s} counts no triangle"));
                }
            } else {
                let inverted = cb.min.cmpeq(glam::Vec3A::INFINITY).all()
                    && cb.max.cmpeq(glam::Vec3A::NEG_INFINITY).all();
                if node.children[s] != ChildRef::EMPTY || !inverted || node.triangles[s] != 0 {
                    return fail(format!("node {i} slot {s}: an empty slot is not inverted"));
                }
            }
        }
        Ok(used)
    }

    /// A leaf's blocks; returns its triangles.
    fn check_leaf(
        &self,
        r: ChildRef,
        b: &Aabb,
        block_seen: &mut [bool],
        seen: &mut [u32],
    ) -> Result<u32, BvhValidationError> {
        let range = r.blocks();
        if range.end > self.blocks.len() {
            return fail(format!(
                "leaf {r:?} beyond the {} blocks",
                self.blocks.len()
            ));
        }
        let mesh = self.mesh();
        let mut n = 0;
        for k in range {
            if std::mem::replace(&mut block_seen[k], true) {
                return fail(format!("block {k} is referenced twice"));
            }
            let blk = &self.blocks[k];
            for l in 0..4 {
                let prim = blk.prims[l] as usize;
                if prim >= mesh.triangle_count() {
                    return fail(format!(
                        "block {k} lane {l}: triangle {prim} beyond the mesh"
                    ));
                }
                let want = mesh.corners(prim);
                let got = blk.triangle(l);
                let bits = |c: &[glam::Vec3; 3]| c.map(|v| v.to_array().map(f32::to_bits));
                if bits(&got) != bits(want) {
                    return fail(format!(
                        "block {k} lane {l}: corners differ from triangle {prim}"
                    ));
                }
                if !inside(mesh.triangle_bounds(prim), b) {
                    return fail(format!("block {k}: triangle {prim} outside its leaf's box"));
                }
                let spare = l > 0 && blk.prims[l] == blk.prims[0];
                if !spare {
                    seen[prim] += 1;
                    n += 1;
                }
            }
            // Spares only after the distinct lanes.
            let distinct = blk.len() as usize;
            if blk.prims[..distinct]
                .iter()
                .skip(1)
                .any(|&p| p == blk.prims[0])
            {
                return fail(format!("block {k}: a spare lane among the triangles"));
            }
        }
        Ok(n)
    }
}

impl Bvh2 {
    /// Checks the tree's invariants: every node reached exactly once from
    /// the root, children after their parent, at most [`BVH_MAX_DEPTH`]
    /// deep; every child box inside its parent's (the root's inside the
    /// mesh box); every leaf's triangle range in bounds and non-empty,
    /// each triangle's box inside its leaf's box; every non-degenerate
    /// triangle referenced exactly once and no degenerate one.
    ///
    /// # Errors
    /// The first broken invariant, as a [`BvhValidationError`].
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::protocol::generate::sphere(300), &BvhBuildParams::median()).unwrap();
    /// assert_eq!(b.validate(), Ok(()));
    /// ```
    pub fn validate(&self) -> Result<(), BvhValidationError> {
        let mesh = self.mesh();
        let mut seen = vec![0u32; mesh.triangle_count()];
        if self.nodes.is_empty() {
            return check_seen(mesh, &seen);
        }
        let mut reached = vec![false; self.nodes.len()];
        let mut stack = vec![(0usize, mesh.bounds(), 1u32)];
        while let Some((i, parent, depth)) = stack.pop() {
            if depth > BVH_MAX_DEPTH {
                return fail(format!("node {i} at depth {depth}"));
            }
            let Some(n) = self.nodes.get(i) else {
                return fail(format!("node {i} beyond the {} nodes", self.nodes.len()));
            };
            if std::mem::replace(&mut reached[i], true) {
                return fail(format!("node {i} is reached twice"));
            }
            let b = n.bounds();
            if b.is_empty() || !inside(&b, &parent) {
                return fail(format!("node {i}: box {b:?} not inside {parent:?}"));
            }
            if n.is_leaf() {
                let (s, e) = (n.index as usize, n.index as usize + n.count as usize);
                if e > self.prims.len() {
                    return fail(format!(
                        "leaf {i}: triangles {s}..{e} beyond {}",
                        self.prims.len()
                    ));
                }
                for &p in &self.prims[s..e] {
                    let p = p as usize;
                    if p >= mesh.triangle_count() {
                        return fail(format!("leaf {i}: triangle {p} beyond the mesh"));
                    }
                    if !inside(mesh.triangle_bounds(p), &b) {
                        return fail(format!("leaf {i}: triangle {p} outside its box"));
                    }
                    seen[p] += 1;
                }
                continue;
            }
            let r = n.index as usize;
            if r <= i + 1 {
                return fail(format!(
                    "node {i}: right child {r} does not follow the left"
                ));
            }
            stack.push((i + 1, b, depth + 1));
            stack.push((r, b, depth + 1));
        }
        if let Some(i) = reached.iter().position(|&s| !s) {
            return fail(format!("node {i} is never reached"));
        }
        check_seen(mesh, &seen)
    }
}

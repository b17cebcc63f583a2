//! Node order: where each node of a tree sits in its flat array (issue 10).
//!
//! The build writes nodes **depth first** (PBRT-v3): the below child right
//! after its parent, the above child's index in the node. A ray that takes
//! the above side jumps to an unrelated cache line, and where the tree
//! does not fit in L2 incoherent rays wait on those loads (issue 10's
//! profile, on an AMD EPYC with 512 KiB of L2: 43 % of the samples on the
//! node load).
//!
//! [`KdTree`](super::KdTree) keeps that order. The **blocked** order
//! ([`BlockedKdTree`](super::BlockedKdTree), `--accel kd8-blocked`) is the
//! alternative issue 10 asked for, kept so that any machine can measure it:
//!
//! - the two children of an interior node sit side by side, and the node
//!   names the pair (Wald's thesis 2004, section 7.2): `below = child`,
//!   `above = child + 1`, so both are fetched by one load;
//! - pairs are packed into 64-byte cache-line blocks of four pairs, the
//!   array aligned so that a block is one line. A block starts with a pair
//!   and is filled greedily with the descendant pairs most likely to be
//!   visited next: the children of the node whose cell has the largest
//!   surface area (the SAH's hit probability; a treelet layout in the
//!   sense of Gil and Itai 1999 and Yoon and Manocha 2006, with node
//!   probabilities from the surface areas). Pairs left over when a block is
//!   full start later blocks, which follow depth first; when a block's own
//!   subtree runs out, the next pending pair fills it;
//! - the root sits alone at the start of the first line, beside one unused
//!   slot (an empty leaf), so every pair starts at an even offset from the
//!   root and never straddles a line.
//!
//! ```text
//!   one 64-byte line = 8 nodes = 4 sibling pairs
//!   | a0 a1 | b0 b1 | c0 c1 | d0 d1 |
//!   a: the pair that starts the block (its parent lies in an earlier line)
//!   b: children of a0, c: children of a1 (the larger cells first),
//!   d: children of the largest interior cell among b0..c1
//! ```
//!
//! A ray then crosses about one line per two to three levels instead of
//! one per level on the above side. Leaves' index runs follow the same
//! order, so neighbouring leaves read neighbouring runs.
//!
//! Measured and not adopted (docs/node-order.md): on an
//! Intel Xeon with 2 MiB of L2 per core, 0.97-1.02x the depth-first order
//! on the protocol scenes (trees of 0.3-2.4 MB, which fit in L2) and
//! 1.02-1.08x on a million-triangle scene (26 MB). The depth-first order
//! already keeps a node and its below child in one line most of the time,
//! and the below child's address (`r + 1`) is known before the node loads,
//! where a pair's address comes out of its parent.

use super::node::{KdNode, MAX_INDEX, Overflow};
use crate::aabb::Aabb;

/// Bytes of one cache line, the block size.
pub(crate) const LINE_BYTES: usize = 64;
/// Nodes in one block.
const LINE_NODES: usize = LINE_BYTES / std::mem::size_of::<KdNode>();
/// Sibling pairs in one block.
const LINE_PAIRS: usize = LINE_NODES / 2;

/// A tree's nodes in blocked order.
pub(crate) struct Blocked {
    pub nodes: Vec<KdNode>,
    pub leaf_prims: Vec<u32>,
    /// Index of the root: the first node of a line (the slots before it are
    /// unused empty leaves).
    pub root: u32,
}

/// A pair of children still to place: the node that names it (already
/// placed) and the depth-first index of the below child (the above child
/// is named by the parent in the depth-first array).
#[derive(Clone, Copy)]
struct Pending {
    parent: u32,
    dfs_parent: usize,
    /// The parent's cell: its surface area is how likely a ray reaches
    /// the pair.
    cell: Aabb,
}

impl Pending {
    fn area(&self) -> f32 {
        self.cell.surface_area()
    }
}

/// Unused slots before the root so that it starts a cache line of the
/// allocation `ptr` (0 if the allocation is not even node-aligned).
fn pad_for(ptr: *const KdNode) -> usize {
    let at = ptr as usize % LINE_BYTES;
    let node = std::mem::size_of::<KdNode>();
    if !at.is_multiple_of(node) {
        return 0;
    }
    ((LINE_BYTES - at) % LINE_BYTES) / node
}

/// Reorder a depth-first tree (the build's output) into blocked order.
/// `bounds` is the root cell; the order of the leaves' runs follows the new
/// node order.
pub(crate) fn blocked(
    dfs: &[KdNode],
    dfs_prims: &[u32],
    bounds: Aabb,
) -> Result<Blocked, Overflow> {
    // Every non-root node is placed once, in pairs, with no gaps: the
    // capacity never grows, so the alignment found here holds.
    let mut nodes: Vec<KdNode> = Vec::with_capacity(dfs.len() + LINE_NODES + 1);
    let pad = pad_for(nodes.as_ptr());
    nodes.resize(pad, KdNode::EMPTY_LEAF);
    let root = pad as u32;
    let mut leaf_prims = Vec::with_capacity(dfs_prims.len());
    let mut pending: Vec<Pending> = Vec::new();
    let mut frontier: Vec<Pending> = Vec::new();

    let Some(&root_node) = dfs.first() else {
        nodes.push(KdNode::EMPTY_LEAF);
        nodes.push(KdNode::EMPTY_LEAF);
        return Ok(Blocked {
            nodes,
            leaf_prims,
            root,
        });
    };
    // Root and the unused slot beside it.
    nodes.push(copy_node(root_node, dfs_prims, &mut leaf_prims)?);
    nodes.push(KdNode::EMPTY_LEAF);
    if !root_node.is_leaf() {
        frontier.push(Pending {
            parent: root,
            dfs_parent: 0,
            cell: bounds,
        });
    }
    let mut slots = LINE_PAIRS - 1;
    loop {
        // Next pair for this line: the most probable in the line's own
        // subtree, else the next pending pair (depth first).
        let next = match frontier
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.area().total_cmp(&b.1.area()))
        {
            Some((i, _)) => Some(frontier.swap_remove(i)),
            None => pending.pop(),
        };
        let Some(p) = next else { break };
        place(
            dfs,
            dfs_prims,
            &p,
            &mut nodes,
            &mut leaf_prims,
            &mut frontier,
        )?;
        slots -= 1;
        if slots == 0 {
            // The line is full: what is left of its subtree starts later
            // lines, the smaller cells pushed first so the largest is next.
            frontier.sort_unstable_by(|a, b| a.area().total_cmp(&b.area()));
            pending.append(&mut frontier);
            slots = LINE_PAIRS;
        }
    }
    debug_assert_eq!(nodes.len(), pad + dfs.len() + 1);
    debug_assert_eq!(leaf_prims.len(), dfs_prims.len());
    Ok(Blocked {
        nodes,
        leaf_prims,
        root,
    })
}

/// Place the children of `p` as the next pair, name the pair in the
/// parent, and add the pairs of interior children to the frontier.
fn place(
    dfs: &[KdNode],
    dfs_prims: &[u32],
    p: &Pending,
    nodes: &mut Vec<KdNode>,
    leaf_prims: &mut Vec<u32>,
    frontier: &mut Vec<Pending>,
) -> Result<(), Overflow> {
    let parent = dfs[p.dfs_parent];
    let (axis, split) = (parent.axis(), parent.split());
    let pos = nodes.len() as u32;
    nodes[p.parent as usize] = KdNode::interior(axis, split, pos)?;
    let (mut below, mut above) = (p.cell, p.cell);
    below.max[axis] = split;
    above.min[axis] = split;
    let children = [(p.dfs_parent + 1, below), (parent.child() as usize, above)];
    for (k, (d, cell)) in children.into_iter().enumerate() {
        let n = dfs[d];
        nodes.push(copy_node(n, dfs_prims, leaf_prims)?);
        if !n.is_leaf() {
            frontier.push(Pending {
                parent: pos + k as u32,
                dfs_parent: d,
                cell,
            });
        }
    }
    Ok(())
}

/// A node for the new array: a leaf with its run appended to
/// `leaf_prims`, or an interior node whose child is named when its pair
/// is placed.
fn copy_node(n: KdNode, dfs_prims: &[u32], leaf_prims: &mut Vec<u32>) -> Result<KdNode, Overflow> {
    if !n.is_leaf() {
        return KdNode::interior(n.axis(), n.split(), 0);
    }
    if n.count() <= 1 {
        return Ok(n);
    }
    let first = n.first() as usize;
    let off = leaf_prims.len();
    leaf_prims.extend_from_slice(&dfs_prims[first..first + n.count() as usize]);
    KdNode::leaf(off as u32, n.count())
}

/// The blocked tree `nodes` (root at `root`) in depth-first order again,
/// node for node as the build wrote it (tests: the round trip).
#[cfg(test)]
pub(crate) fn depth_first(
    nodes: &[KdNode],
    leaf_prims: &[u32],
    root: u32,
) -> (Vec<KdNode>, Vec<u32>) {
    let real = nodes.len() - root as usize - 1;
    let mut out: Vec<KdNode> = Vec::with_capacity(real);
    let mut prims = Vec::with_capacity(leaf_prims.len());
    // (blocked index, the depth-first node that names it as above child)
    let mut stack: Vec<(usize, Option<usize>)> = vec![(root as usize, None)];
    while let Some((i, above_of)) = stack.pop() {
        let pos = out.len();
        if let Some(p) = above_of {
            let q = out[p];
            out[p] = KdNode::interior(q.axis(), q.split(), pos as u32)
                .expect("a depth-first index is below the blocked one");
        }
        let n = nodes[i];
        if n.is_leaf() {
            let node = if n.count() <= 1 {
                n
            } else {
                let first = n.first() as usize;
                let off = prims.len();
                prims.extend_from_slice(&leaf_prims[first..first + n.count() as usize]);
                KdNode::leaf(off as u32, n.count()).expect("the same count")
            };
            out.push(node);
        } else {
            out.push(n);
            let c = n.child() as usize;
            // Below first: its whole subtree follows its parent.
            stack.push((c + 1, Some(pos)));
            stack.push((c, None));
        }
    }
    (out, prims)
}

/// A copy of a blocked array whose root starts a line of the new
/// allocation (a clone's allocation has its own alignment). A tree within
/// a line of the index limit keeps its old offset rather than overflow.
pub(crate) fn realigned(nodes: &[KdNode], root: u32) -> (Vec<KdNode>, u32) {
    let body = &nodes[root as usize..];
    let mut out: Vec<KdNode> = Vec::with_capacity(body.len() + LINE_NODES);
    let largest = body
        .iter()
        .filter(|n| !n.is_leaf())
        .map(|n| n.child())
        .max()
        .unwrap_or(0);
    let mut pad = pad_for(out.as_ptr()) as u32;
    if pad > root && u64::from(largest) + u64::from(pad - root) > u64::from(MAX_INDEX) {
        pad = root;
    }
    out.resize(pad as usize, KdNode::EMPTY_LEAF);
    out.extend(body.iter().map(|&n| {
        if n.is_leaf() {
            return n;
        }
        // Within the limit by the check above.
        let c = n.child() + pad - root;
        KdNode::interior(n.axis(), n.split(), c).unwrap_or(n)
    }));
    (out, pad)
}

/// Check a blocked array's invariants (see
/// [`BlockedKdTree::validate`](super::BlockedKdTree::validate)).
pub(crate) fn check_blocked(nodes: &[KdNode], leaf_prims: &[u32], root: u32) -> Result<(), String> {
    let root = root as usize;
    if root >= LINE_NODES || root + 1 >= nodes.len() {
        return Err(format!("root {root} of {} nodes", nodes.len()));
    }
    let mut seen = vec![false; nodes.len()];
    for i in (0..root).chain([root + 1]) {
        seen[i] = true;
        if nodes[i] != KdNode::EMPTY_LEAF {
            return Err(format!("unused slot {i} holds {:?}", nodes[i]));
        }
    }
    let mut stack = vec![root];
    while let Some(i) = stack.pop() {
        if std::mem::replace(&mut seen[i], true) {
            return Err(format!("node {i} reached twice"));
        }
        let n = nodes[i];
        if n.is_leaf() {
            let end = n.first() as usize + n.count() as usize;
            if n.count() > 1 && end > leaf_prims.len() {
                return Err(format!("leaf {i} runs past the index array"));
            }
            continue;
        }
        let c = n.child() as usize;
        if c <= i || c + 1 >= nodes.len() || !(c - root).is_multiple_of(2) {
            return Err(format!("node {i} names the pair at {c}"));
        }
        stack.extend([c, c + 1]);
    }
    match seen.iter().position(|s| !s) {
        Some(i) => Err(format!("node {i} is never reached")),
        None => Ok(()),
    }
}

#[cfg(test)]
/// Is node `i` of a blocked array the start of a cache line in memory?
/// (For validation and tests: the pair rule is what traversal relies on.)
pub(crate) fn starts_line(nodes: &[KdNode], i: usize) -> bool {
    (nodes.as_ptr() as usize + i * std::mem::size_of::<KdNode>()).is_multiple_of(LINE_BYTES)
}

#[cfg(test)]
mod tests {
    use super::super::KdBuildParams;
    use super::super::build;
    use super::super::clip::PrimRef;
    use super::*;
    use crate::mesh::Mesh;
    use glam::Vec3;

    fn soup(n: u32, seed: u32) -> Mesh {
        let mut x = seed;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..n {
            let c = Vec3::new(next(), next(), next()) * 10.0;
            for _ in 0..3 {
                p.push(c + Vec3::new(next(), next(), next()) * 0.5);
            }
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        Mesh::new(p, t).unwrap()
    }

    /// The build's raw depth-first output.
    fn raw(mesh: &Mesh) -> build::Built {
        let params = KdBuildParams::default();
        let prims = (0..mesh.triangle_count())
            .filter(|&i| !mesh.is_degenerate(i))
            .map(|i| PrimRef::new(i as u32, mesh.triangle_bounds(i)))
            .collect();
        let limit = params.depth_for(mesh.triangle_count()).unwrap();
        build::build(mesh.corner_slice(), prims, mesh.bounds(), &params, limit).unwrap()
    }

    #[test]
    fn blocked_and_back_is_the_build_output() {
        for (n, seed) in [(0, 1), (1, 2), (2, 3), (50, 4), (3000, 5)] {
            let mesh = soup(n, seed);
            let dfs = raw(&mesh);
            let b = blocked(&dfs.nodes, &dfs.leaf_prims, mesh.bounds()).unwrap();
            let (nodes, prims) = depth_first(&b.nodes, &b.leaf_prims, b.root);
            assert_eq!(nodes, dfs.nodes, "{n} triangles");
            assert_eq!(prims, dfs.leaf_prims, "{n} triangles");
        }
    }

    /// The blocked form of a random soup's tree.
    fn blocked_soup(n: u32, seed: u32) -> Blocked {
        let mesh = soup(n, seed);
        let dfs = raw(&mesh);
        blocked(&dfs.nodes, &dfs.leaf_prims, mesh.bounds()).unwrap()
    }

    #[test]
    fn root_starts_a_line_and_pairs_stay_inside_lines() {
        let b = blocked_soup(3000, 9);
        assert!(starts_line(&b.nodes, b.root as usize));
        assert_eq!(check_blocked(&b.nodes, &b.leaf_prims, b.root), Ok(()));
        // A copy keeps the rule on its own allocation.
        let (nodes, root) = realigned(&b.nodes, b.root);
        assert!(starts_line(&nodes, root as usize));
        assert_eq!(check_blocked(&nodes, &b.leaf_prims, root), Ok(()));
        assert_eq!(
            depth_first(&nodes, &b.leaf_prims, root),
            depth_first(&b.nodes, &b.leaf_prims, b.root)
        );
    }

    #[test]
    fn the_check_finds_a_broken_order() {
        let b = blocked_soup(500, 3);
        let r = b.root as usize;
        let mut odd = b.nodes.clone();
        let n = odd[r];
        odd[r] = KdNode::interior(n.axis(), n.split(), n.child() + 1).unwrap();
        assert!(check_blocked(&odd, &b.leaf_prims, b.root).is_err());
        let mut filled = b.nodes.clone();
        filled[r + 1] = KdNode::leaf(0, 1).unwrap();
        assert!(check_blocked(&filled, &b.leaf_prims, b.root).is_err());
    }

    #[test]
    fn blocks_keep_a_parent_and_its_children_together() {
        // Most interior nodes reach their children without a new line.
        let b = blocked_soup(3000, 11);
        let line = |i: usize| (i - b.root as usize) / LINE_NODES;
        let (mut same, mut interior) = (0, 0);
        for (i, n) in b.nodes.iter().enumerate().skip(b.root as usize) {
            if !n.is_leaf() {
                interior += 1;
                same += usize::from(line(n.child() as usize) == line(i));
            }
        }
        // Per line, the 8 nodes hold up to 3 parents of pairs in the line.
        assert!(
            same * 3 > interior,
            "{same} of {interior} parents share a line"
        );
    }
}

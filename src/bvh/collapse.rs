//! The 8-wide tree from the binary one: each 8-wide node takes the
//! children of a binary node and opens the largest of them (by surface
//! area) until it holds eight or only leaves are left (the greedy rule of
//! tinybvh's `MBVH::ConvertFrom`; Ylitie, Karras and Laine 2017 choose by
//! SAH instead). Leaves become runs of 4-triangle blocks.
//!
//! Layout: the interior children of a node are stored next to each other,
//! in slot order, and each node's subtree follows in depth-first order.

use super::build::Binary;
use super::node::{ChildRef, Node2, Node8, Tri4};
use glam::Vec3;

/// The 8-wide nodes, the leaf blocks and the root reference.
pub(crate) struct Wide {
    pub nodes: Vec<Node8>,
    pub blocks: Vec<Tri4>,
    pub root: ChildRef,
}

/// Collapses `bin` (over triangles with `corners`).
/// Binary subtrees of at most `merge_below` triangles become one leaf.
pub(crate) fn collapse(bin: &Binary, corners: &[[Vec3; 3]], merge_below: u32) -> Wide {
    let mut w = Wide {
        nodes: Vec::new(),
        blocks: Vec::new(),
        root: ChildRef::EMPTY,
    };
    if bin.nodes.is_empty() {
        return w;
    }
    // Triangles under each binary node and the first of them (children
    // follow their parent; a subtree's triangles are contiguous).
    let mut under = vec![0u32; bin.nodes.len()];
    let mut start = vec![0u32; bin.nodes.len()];
    for (i, n) in bin.nodes.iter().enumerate().rev() {
        (under[i], start[i]) = if n.is_leaf() {
            (n.count, n.index)
        } else {
            (under[i + 1] + under[n.index as usize], start[i + 1])
        };
    }
    let c = Collapser {
        bin,
        corners,
        under,
        start,
        merge: merge_below,
    };
    w.nodes.reserve(bin.nodes.len() / 6 + 1);
    w.blocks.reserve(bin.prims.len() / 3 + 1);
    if c.terminal(0) {
        w.root = c.leaf(0, &mut w.blocks);
    } else {
        w.root = ChildRef::node(0);
        w.nodes.push(Node8::empty());
        c.fill(0, 0, &mut w);
    }
    w
}

struct Collapser<'a> {
    bin: &'a Binary,
    corners: &'a [[Vec3; 3]],
    /// Triangles under each binary node.
    under: Vec<u32>,
    /// The first triangle slot under each binary node.
    start: Vec<u32>,
    /// Subtrees of at most this many triangles become one leaf.
    merge: u32,
}

impl Collapser<'_> {
    fn node(&self, i: usize) -> &Node2 {
        &self.bin.nodes[i]
    }

    /// Does binary node `i` become a leaf (a binary leaf, or a subtree
    /// small enough to merge)?
    fn terminal(&self, i: usize) -> bool {
        self.node(i).is_leaf() || self.under[i] <= self.merge
    }

    /// The binary node `i`'s two children.
    fn children(&self, i: usize) -> [usize; 2] {
        [i + 1, self.node(i).index as usize]
    }

    /// The 8-wide node `at` over the binary interior node `b`.
    fn fill(&self, at: usize, b: usize, w: &mut Wide) {
        // The slots: the children of `b`, then the largest one that is not
        // to be a leaf opened until there are eight.
        let mut slots = [0usize; 8];
        slots[..2].copy_from_slice(&self.children(b));
        let mut used = 2;
        while used < 8 {
            let mut open: Option<(usize, f32)> = None;
            for (k, &s) in slots[..used].iter().enumerate() {
                if self.terminal(s) {
                    continue;
                }
                let a = self.node(s).bounds().surface_area();
                if open.is_none_or(|(_, ba)| a > ba) {
                    open = Some((k, a));
                }
            }
            let Some((k, _)) = open else { break };
            let [l, r] = self.children(slots[k]);
            slots.copy_within(k + 1..used, k + 2);
            slots[k] = l;
            slots[k + 1] = r;
            used += 1;
        }
        let slots = &slots[..used];
        // Interior children next to each other, then each one's subtree.
        let first = w.nodes.len();
        let mut interior = [0usize; 8];
        let mut inner = 0;
        let mut set = [(ChildRef::EMPTY, 0usize); 8];
        for (slot, &s) in slots.iter().enumerate() {
            let r = if self.terminal(s) {
                self.leaf(s, &mut w.blocks)
            } else {
                interior[inner] = s;
                inner += 1;
                ChildRef::node((first + inner - 1) as u32)
            };
            set[slot] = (r, s);
        }
        w.nodes.extend(std::iter::repeat_n(Node8::empty(), inner));
        for (slot, &(r, s)) in set[..slots.len()].iter().enumerate() {
            w.nodes[at].set_child(slot, r, &self.node(s).bounds(), self.under[s]);
        }
        for (k, &s) in interior[..inner].iter().enumerate() {
            self.fill(first + k, s, w);
        }
    }

    /// The triangles under binary node `i` as one leaf: a run of blocks.
    fn leaf(&self, i: usize, blocks: &mut Vec<Tri4>) -> ChildRef {
        let first = self.start[i] as usize;
        let prims = &self.bin.prims[first..first + self.under[i] as usize];
        let first = blocks.len() as u32;
        blocks.extend(prims.chunks(4).map(|p| Tri4::new(p, self.corners)));
        ChildRef::leaf(first, prims.len().div_ceil(4) as u32)
    }
}

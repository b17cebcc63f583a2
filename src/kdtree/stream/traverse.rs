//! The breadth-first stream traversal: a chunk of rays of one direction
//! octant goes through the tree depth first over nodes and breadth first
//! over rays (Wald, Gribble, Boulos and Kensler 2007; Gribble and Ramani
//! 2008; Tsakok 2009; Barringer and Akenine-Möller 2014). Every node is
//! visited once by the subset of rays that reach it: its plane distances
//! are computed 8 or 16 rays per instruction and the subset is split with
//! vector compress into the near rays, which go on, and the far ones,
//! deferred on a stack with their intervals in the far cell
//! (`kernel/partition.rs`). Reads beside the scalar traversal
//! (`scalar.rs`): the same interval arithmetic, the same near/far order
//! (one octant), the same cull when a deferred cell is popped, the same
//! leaf rule (every triangle over the ray's whole interval).
//!
//! A subset smaller than the single-ray threshold finishes its subtree ray
//! by ray with the scalar walk itself (`scalar::walk`), the hybrid of
//! Benthin et al. 2012 and Barringer and Akenine-Möller 2014: deep,
//! sparse parts of the tree then cost what the scalar traversal costs.

use super::cells::{Boxes, Cells, Intervals};
use super::leaf::test_leaf;
use super::rays::StreamRays;
use crate::kdtree::kernel::partition::{SLACK, StreamIsa, Subsets};
use crate::kdtree::kernel::stack::Stack;
use crate::kdtree::layout::{Layout, NodeView};
use crate::kdtree::params::MAX_DEPTH_LIMIT;
use crate::kdtree::scalar::{SMALL_STACK, walk};
use crate::kdtree::stats::Counters;
use crate::ray::Ray;

/// A deferred far cell: its node, its subset (a segment of
/// [`Subsets`]) and what the subset knows of the cell (`cells.rs`).
#[derive(Clone, Copy)]
struct Deferred<R, B> {
    node: R,
    start: usize,
    len: usize,
    cell: B,
}

/// Traces the chunk `input[src[i]]` (one octant, `neg`; sorted by
/// dominant axis), loaded into `rays` (`StreamRays::load`); every ray's
/// answer is left there (its closest hit, or its occlusion). Subsets of
/// fewer than `single_below` rays finish alone; `boxes`: subsets carry
/// their cell's box, not the rays' intervals (`cells.rs`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace_chunk<I: StreamIsa, T: Layout, const ANY: bool, C: Counters>(
    isa: I,
    tree: &T,
    input: &[Ray],
    src: &[u32],
    neg: [bool; 3],
    rays: &mut StreamRays,
    subsets: &mut Subsets,
    single_below: usize,
    boxes: bool,
    c: &mut C,
) {
    let m = rays.load(tree, input, src, neg, subsets);
    if boxes {
        rays.fill_boxes();
        stacked::<I, T, ANY, C, Boxes>(isa, tree, rays, subsets, m, neg, single_below, c);
    } else {
        stacked::<I, T, ANY, C, Intervals>(isa, tree, rays, subsets, m, neg, single_below, c);
    }
}

/// [`trace_with`] with the stack the tree's depth needs.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn stacked<I: StreamIsa, T: Layout, const ANY: bool, C: Counters, B: Cells>(
    isa: I,
    tree: &T,
    rays: &mut StreamRays,
    subsets: &mut Subsets,
    m: usize,
    neg: [bool; 3],
    single_below: usize,
    c: &mut C,
) {
    // A leaf at depth d has at most d far cells deferred above it, for a
    // subset as for a ray.
    if tree.depth_limit() as usize <= SMALL_STACK {
        trace_with::<I, T, ANY, C, B, SMALL_STACK>(
            isa,
            tree,
            rays,
            subsets,
            m,
            neg,
            single_below,
            c,
        );
    } else {
        trace_with::<I, T, ANY, C, B, { MAX_DEPTH_LIMIT as usize }>(
            isa,
            tree,
            rays,
            subsets,
            m,
            neg,
            single_below,
            c,
        );
    }
}

/// [`trace_chunk`] with stacks of `N` entries.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn trace_with<I: StreamIsa, T: Layout, const ANY: bool, C: Counters, B: Cells, const N: usize>(
    isa: I,
    tree: &T,
    rays: &mut StreamRays,
    subsets: &mut Subsets,
    m: usize,
    neg: [bool; 3],
    single_below: usize,
    c: &mut C,
) {
    let corners = tree.mesh().corner_slice();
    // The current subset is the segment `cur..cur + len`; segments are
    // written from `top` on, each followed by the writers' slack.
    let (mut node, mut cur, mut len) = (tree.root(), 0, m);
    let mut cell = B::root(tree.bounds());
    let mut top = m + SLACK;
    let mut stack = Stack::<Deferred<T::Ref, B>, N>::new();
    if len == 0 {
        return;
    }
    loop {
        loop {
            // Few rays left: each finishes the subtree alone.
            if len < single_below {
                for j in cur..cur + len {
                    let i = subsets.ids[j] as usize;
                    c.single_ray();
                    let rc = rays.consts(i, neg);
                    let (t_min, t_max) = cell.interval(subsets, j, rays, neg);
                    let h = walk::<T, ANY, C, N>(tree, rc, node, t_min, t_max, rays.best(i), c);
                    rays.set_best::<ANY>(i, h);
                }
                break;
            }
            match tree.view(node) {
                NodeView::Interior {
                    axis,
                    split,
                    below,
                    above,
                } => {
                    c.stream_node(len as u32);
                    // Near and far child: one order for the whole chunk.
                    let (below_cell, above_cell) = cell.children(axis, split);
                    let ((near, near_cell), (far, far_cell)) = if neg[axis] {
                        ((above, above_cell), (below, below_cell))
                    } else {
                        ((below, below_cell), (above, above_cell))
                    };
                    // Split the subset: near rays in place, far ones at
                    // `top` (with intervals: each with its interval in
                    // its cell; with boxes: ids alone).
                    subsets.reserve_to(top + len);
                    let (n_near, n_far) =
                        cell.split(isa, subsets, (cur, len, top), axis, split, rays, neg);
                    // Three-way step, as the scalar one: both (defer far),
                    // near only, far only; neither: the next deferred cell.
                    match (n_near > 0, n_far > 0) {
                        (true, true) => {
                            c.partition();
                            stack.push(Deferred {
                                node: far,
                                start: top,
                                len: n_far,
                                cell: far_cell,
                            });
                            top += n_far + SLACK;
                            (node, cell) = (near, near_cell);
                            len = n_near;
                        }
                        (true, false) => {
                            (node, cell) = (near, near_cell);
                            len = n_near;
                        }
                        (false, true) => {
                            (node, cell) = (far, far_cell);
                            cur = top;
                            len = n_far;
                            top += n_far + SLACK;
                        }
                        (false, false) => break,
                    }
                }
                NodeView::Leaf(prims) => {
                    // Leaf: every triangle for every ray of the subset over
                    // the ray's whole interval (as in the scalar leaf).
                    c.leaf();
                    if !prims.is_empty() {
                        test_leaf::<I::Lanes, I, _, ANY, C>(
                            isa,
                            rays,
                            &subsets.ids[cur..cur + len],
                            neg,
                            prims,
                            corners,
                            c,
                        );
                    }
                    break;
                }
            }
        }
        // Pop: the next deferred cell, for the rays still in it: a ray
        // leaves when its closest hit lies before the cell, or, for
        // occlusion, once it is occluded (`best_t = -inf`): the scalar
        // pop's rule, applied to the whole subset at once.
        loop {
            let Some(e) = stack.pop() else {
                return;
            };
            top = e.start + e.len + SLACK;
            let kept = e.cell.cull(isa, subsets, e.start, e.len, rays, neg);
            if kept > 0 {
                (node, cell) = (e.node, e.cell);
                cur = e.start;
                len = kept;
                break;
            }
        }
    }
}

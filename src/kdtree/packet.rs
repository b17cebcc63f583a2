//! Packet traversal: `L::WIDTH` rays through the same 8-byte nodes (Wald,
//! Slusallek, Benthin and Wagner 2001; Wald's thesis 2004, section 7.4),
//! one body for every lane type, compiled once per instruction set by
//! `kernel.rs`. Reads side by side with `scalar.rs`: the same interval
//! arithmetic, per lane, with the three-way branch taken on lane masks.
//! The packets it gets share their direction signs (`hybrid.rs` splits
//! the others by octant).

use super::kernel::stack::Stack;
use super::layout::{Layout, LeafTri, NodeView};
use super::margin;
use super::params::MAX_DEPTH_LIMIT;
use super::scalar::{SMALL_STACK, by_axis};
use super::stats::Counters;
use crate::aabb::{Aabb, slab};
use crate::packet::{HitPacket, RayPacket};
use crate::ray::{Hit, NO_PRIM};
use crate::simd::Lane;
use crate::triangle;

/// The lanes of `hits` whose hit on `prim` the filter accepts.
#[inline]
fn accepted<L: Lane, C: Counters>(c: &mut C, hits: u32, prim: u32, h: &triangle::TriHit<L>) -> u32 {
    let mut keep = hits;
    let mut left = hits;
    while left != 0 {
        let i = left.trailing_zeros() as usize;
        left &= left - 1;
        if !c.accept(prim, h.t.lane(i), h.u.lane(i), h.v.lane(i)) {
            keep &= !(1 << i);
        }
    }
    keep
}

/// A deferred far child and the lanes' intervals inside it; lanes not in
/// the cell carry an empty interval.
#[derive(Clone, Copy)]
struct Entry<R, L> {
    node: R,
    t_min: L,
    t_max: L,
}

/// The one packet traversal for a packet whose active lanes share their
/// direction signs, for any node layout and lane type, with a stack
/// sized as in the scalar traversal. Always inlined into the kernels of
/// `kernel.rs`, which compile it once per instruction set.
#[inline(always)]
pub(crate) fn traverse_packet<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    traverse_packet_from::<L, T, ANY, C>(tree, p, tree.root(), tree.bounds(), c)
}

/// [`traverse_packet`] started at node `start`, whose cell is `cell`: the
/// lanes' intervals are cut to the cell widened by their margin, as the
/// steps from the root would cut them (the same plane distances from the
/// same shifted origins). Lane `i` equals the scalar query of ray `i` when
/// no hit of that ray lies outside the cell (the group traversal's entry
/// point, `group.rs`).
#[inline(always)]
pub(crate) fn traverse_packet_from<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    start: T::Ref,
    cell: &Aabb,
    c: &mut C,
) -> HitPacket<L> {
    if tree.depth_limit() as usize <= SMALL_STACK {
        traverse_with::<L, T, ANY, C, SMALL_STACK>(tree, p, start, cell, c)
    } else {
        traverse_with::<L, T, ANY, C, { MAX_DEPTH_LIMIT as usize }>(tree, p, start, cell, c)
    }
}

/// [`traverse_packet`] with a stack of `N` entries.
#[inline(always)]
fn traverse_with<L: Lane, T: Layout, const ANY: bool, C: Counters, const N: usize>(
    tree: &T,
    p: &RayPacket<L>,
    start: T::Ref,
    cell: &Aabb,
    c: &mut C,
) -> HitPacket<L> {
    let mut out = HitPacket::default();
    let active_bits = p.active();
    if active_bits == 0 {
        return out;
    }
    // One near/far order per axis for the whole packet (`trace` split the
    // packet by octant).
    let neg_bits = p.neg_bits();
    debug_assert!(neg_bits.iter().all(|&b| b == 0 || b == active_bits));
    let neg = neg_bits.map(|b| b != 0);
    let neg_mask = neg.map(|n| L::mask_from_bits(if n { u32::MAX } else { 0 }));
    // Cells widened by the margin, per lane as in the scalar traversal.
    let org_m = margin::shifted(tree.bounds(), p.org(), &neg_mask);
    let (_, t0, t1) = slab(
        cell,
        &org_m.entry,
        &org_m.exit,
        p.inv_dir(),
        &neg_mask,
        p.t_min(),
        p.t_max(),
    );
    // Inactive lanes carry the empty interval (the packet's invariant), so
    // they fail `t0 <= t1` here and never enter a cell.
    let hit_box = t0.le(t1);
    if !L::any(hit_box) {
        return out;
    }
    let sh = p.shear();
    let corners = tree.mesh().corner_slice();
    let inf = L::splat(f32::INFINITY);
    let neg_inf = L::splat(f32::NEG_INFINITY);
    // An inactive lane's bound of -inf rejects every triangle hit.
    let mut best_t = p.t_max();
    let mut best_prim = L::index_splat(NO_PRIM);
    let mut best_u = L::splat(0.0);
    let mut best_v = L::splat(0.0);
    let mut found = 0u32;
    let (entry_org, exit_org) = (by_axis(org_m.entry), by_axis(org_m.exit));
    let (inv_dir_ax, neg_ax) = (by_axis(*p.inv_dir()), by_axis(neg));
    let mut node = start;
    let mut stack = Stack::<Entry<T::Ref, L>, N>::new();
    let mut t_min = L::select(hit_box, t0, inf);
    let mut t_max = L::select(hit_box, t1, neg_inf);
    loop {
        match tree.view(node) {
            NodeView::Interior {
                axis,
                split,
                below,
                above,
            } => {
                c.node();
                // Near and far child: one order for the whole packet.
                let (near, far) = if neg_ax[axis] {
                    (above, below)
                } else {
                    (below, above)
                };
                // Per lane as in the scalar step: near exit, far entry,
                // each widened by the lane's margin (minps/maxps).
                let split = L::splat(split);
                let near_t_max = t_max.min_keep((split - exit_org[axis]) * inv_dir_ax[axis]);
                let far_t_min = t_min.max_keep((split - entry_org[axis]) * inv_dir_ax[axis]);
                let go_near = L::any(t_min.le(near_t_max));
                let go_far = L::any(far_t_min.le(t_max));
                // Three-way step on the lane masks: both (defer far), near
                // only, far only. Measured and rejected (docs/packets-and-kernels.md,
                // "The node step"): a branch-free step
                // that selects the next child with masks (235M -> 345M
                // instructions, 45 % slower on Sponza primary rays), and
                // the unconditional far push (12 % slower).
                if go_near {
                    if go_far {
                        stack.push(Entry {
                            node: far,
                            t_min: far_t_min,
                            t_max,
                        });
                    }
                    node = near;
                    t_max = near_t_max;
                    continue;
                }
                if go_far {
                    node = far;
                    t_min = far_t_min;
                    continue;
                }
                // Neither child: every lane's interval is empty on both
                // sides of the plane; fall through to the next deferred cell.
            }
            NodeView::Leaf(prims) => {
                // Leaf: every triangle for all lanes over their whole
                // intervals (as in the scalar leaf); inactive lanes have a
                // bound of -inf and never hit.
                c.leaf();
                let in_cell = L::bits(t_min.le(t_max)).count_ones();
                for r in prims {
                    c.tri(in_cell);
                    let (prim, tri) = (r.prim(), r.corners(corners));
                    let h = triangle::intersect(
                        &sh.shear,
                        sh.corner(&tri[0]),
                        sh.corner(&tri[1]),
                        sh.corner(&tri[2]),
                        p.t_min(),
                        best_t,
                    );
                    let mut hits = L::bits(h.mask);
                    if hits == 0 {
                        continue;
                    }
                    // An any-hit filter (scenes only) may reject the hit,
                    // lane by lane.
                    let mut hit_mask = h.mask;
                    if C::FILTERS {
                        hits = accepted(c, hits, prim, &h);
                        if hits == 0 {
                            continue;
                        }
                        hit_mask = L::mask_from_bits(hits);
                    }
                    // Occlusion: a lane retires at its first hit.
                    if ANY {
                        let new = hits & !found;
                        let mut left = new;
                        while left != 0 {
                            let i = left.trailing_zeros() as usize;
                            left &= left - 1;
                            out.set(
                                i,
                                Some(Hit {
                                    t: h.t.lane(i),
                                    prim,
                                    u: 0.0,
                                    v: 0.0,
                                }),
                            );
                        }
                        found |= new;
                        if found == active_bits {
                            return out;
                        }
                        continue;
                    }
                    // Closer, or as close with a smaller index (ray policy).
                    let prim_l = L::index_splat(prim);
                    let closer = hit_mask
                        & (h.t.lt(best_t) | (h.t.eq(best_t) & L::index_lt(prim_l, best_prim)));
                    best_t = L::select(closer, h.t, best_t);
                    best_u = L::select(closer, h.u, best_u);
                    best_v = L::select(closer, h.v, best_v);
                    best_prim = L::index_select(closer, prim_l, best_prim);
                }
            }
        }
        // Pop: the next deferred cell, for the lanes still in it: a lane
        // leaves when its closest hit lies before the cell (or, for
        // occlusion, when it has any hit). No lane left: skip the cell. As
        // in the scalar pop, strict or not makes no difference since the
        // margin (docs/testing.md, "Mutation testing").
        loop {
            let Some(e) = stack.pop() else {
                if !ANY {
                    let hit = L::index_lt(best_prim, L::index_splat(NO_PRIM));
                    out = HitPacket::from_lanes(
                        L::select(hit, best_t, inf),
                        best_prim,
                        best_u,
                        best_v,
                    );
                }
                return out;
            };
            t_min = e.t_min;
            t_max = if ANY {
                L::select(L::mask_from_bits(found), neg_inf, e.t_max)
            } else {
                e.t_max.min_keep(best_t)
            };
            if L::any(t_min.le(t_max)) {
                node = e.node;
                break;
            }
        }
    }
}

//! Group traversal: a tile's packets steered through the tree as one
//! (Reshetov, Soupikov and Hurley 2005, MLRTA; Wald, Boulos and Shirley
//! 2007 for the interval view). Reads beside `packet.rs`:
//!
//! - **Interior node**: one decision for the whole group. Each child's
//!   cell, widened by twice the largest lane margin, is tested against the
//!   group's frustum (`frustum.rs`); near/far order comes from the apex's
//!   side of the plane, the same for every ray of the group. No per-lane
//!   work at all.
//! - **Entry point**: the first steps, while only one child meets the
//!   frustum, descend without deferring anything; the depth of the first
//!   node where both children do is the group's entry depth (MLRTA's entry
//!   point, found by the same test; counted in the statistics).
//! - **Hand-off** (the default, `RayGroup::with_entry_handoff`): only
//!   that descent ([`entry_point`]); then each packet goes on alone with
//!   the packet traversal from the entry node (`hybrid::trace_from`, in
//!   the packet kernels). The rest of this list is the group steered as
//!   one down to the leaves ([`traverse_group`]), without the hand-off.
//! - **Leaf**: each packet still in play clips its lanes' intervals to the
//!   cell with the scalar traversal's margin (the slab test of the cell
//!   from the shifted origins, faces picked once per axis when the lanes
//!   agree on the sign), so a lane tests the leaf's triangles exactly when
//!   its interval, cut at its closest hit so far, meets the widened cell.
//!   With leaf culling on, a triangle outside the frustum is skipped for
//!   every packet. Empty leaves cost nothing past the node step.
//! - **Pop**: a deferred cell drops the packets none of whose intervals
//!   meets it, testing for closest hit only packets whose lanes all have a
//!   hit (the others must go on anyway; measured: docs/groups.md); with no packet left, the whole subtree is skipped.
//!
//! Exactness: every lane tests every triangle of every leaf whose widened
//! cell its interval meets (a superset of what the scalar traversal needs,
//! `margin.rs`), with the same triangle test and the same tie rule, so its
//! result is the scalar one bit for bit whatever order leaves come in.

use super::kernel::stack::Stack;
use super::layout::{Layout, LeafTri, NodeView};
use super::margin::{self, MARGIN};
use super::params::MAX_DEPTH_LIMIT;
use super::scalar::SMALL_STACK;
use super::stats::Counters;
use crate::aabb::Aabb;
use crate::frustum::{Apex, CellValues, Frustum};
use crate::packet::{HitPacket, PacketShear, RayPacket};
use crate::ray::{Hit, NO_PRIM};
use crate::simd::{Lane, set_bits};
use crate::triangle;
use glam::Vec3A;

/// How a packet's lanes point along one axis: all forwards, all
/// backwards, or mixed (near and far faces then picked per lane).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Sign {
    Pos,
    Neg,
    Mixed,
}

/// One packet of the group and its running state.
struct Lanes<L: Lane> {
    entry: [L; 3],
    exit: [L; 3],
    inv_dir: [L; 3],
    neg: [L::Mask; 3],
    sign: [Sign; 3],
    t_min: L,
    active: u32,
    sh: PacketShear<L>,
    /// The lanes' upper bound now: the closest hit so far, or for
    /// occlusion `t_max` until a lane's first hit and `-inf` after it.
    bound: L,
    best_prim: L::Index,
    best_u: L,
    best_v: L,
    /// Occlusion: lanes with a hit.
    found: u32,
}

impl<L: Lane> Lanes<L> {
    /// Lanes whose interval, up to `bound`, meets the widened cell
    /// `[lo, hi]`: the slab test of `aabb::slab` with the traversal's
    /// shifted origins, with the faces picked once per axis when the
    /// lanes agree on the direction's sign.
    #[inline(always)]
    fn in_cell(&self, lo: &[f32; 3], hi: &[f32; 3]) -> L::Mask {
        let mut t0 = self.t_min;
        let mut t1 = self.bound;
        for a in 0..3 {
            let (near, far) = match self.sign[a] {
                Sign::Pos => (L::splat(lo[a]), L::splat(hi[a])),
                Sign::Neg => (L::splat(hi[a]), L::splat(lo[a])),
                Sign::Mixed => {
                    let (l, h) = (L::splat(lo[a]), L::splat(hi[a]));
                    (L::select(self.neg[a], h, l), L::select(self.neg[a], l, h))
                }
            };
            t0 = t0.max_keep((near - self.entry[a]) * self.inv_dir[a]);
            t1 = t1.min_keep((far - self.exit[a]) * self.inv_dir[a]);
        }
        t0.le(t1)
    }
}

/// A deferred cell: node, its box and frustum values, and the packets
/// that may need it.
#[derive(Clone, Copy)]
struct Entry<R> {
    node: R,
    lo: [f32; 3],
    hi: [f32; 3],
    values: CellValues,
    packets: u32,
}

/// The group traversal for packets `ps` bounded by `fr`, writing one
/// result per packet into `out`. Always inlined into the kernels of
/// `kernel.rs`.
#[inline(always)]
pub(crate) fn traverse_group<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    ps: &[RayPacket<L>],
    fr: &Frustum,
    cull: bool,
    out: &mut [HitPacket<L>],
    c: &mut C,
) {
    // Groups take no any-hit filter (scenes trace packets, not groups).
    const { assert!(!C::FILTERS) };
    if tree.depth_limit() as usize <= SMALL_STACK {
        traverse_with::<L, T, ANY, C, SMALL_STACK>(tree, ps, fr, cull, out, c);
    } else {
        traverse_with::<L, T, ANY, C, { MAX_DEPTH_LIMIT as usize }>(tree, ps, fr, cull, out, c);
    }
}

/// [`traverse_group`] with a stack of `N` entries (at least the tree's
/// depth limit: one deferred cell per level, as in the scalar traversal).
#[inline(always)]
fn traverse_with<L: Lane, T: Layout, const ANY: bool, C: Counters, const N: usize>(
    tree: &T,
    ps: &[RayPacket<L>],
    fr: &Frustum,
    cull: bool,
    out: &mut [HitPacket<L>],
    c: &mut C,
) {
    let bounds = *tree.bounds();
    let (root_lo, root_hi) = (bounds.min.to_array(), bounds.max.to_array());
    // Packet setup: margins, signs, shear, and the root cell's lanes.
    let mut pm = 0u32;
    let mut st: Vec<Lanes<L>> = Vec::with_capacity(ps.len());
    for (i, p) in ps.iter().enumerate() {
        let neg_bits = p.neg_bits();
        let neg = neg_bits.map(L::mask_from_bits);
        let org_m = margin::shifted(&bounds, p.org(), &neg);
        let active = p.active();
        let s = Lanes {
            entry: org_m.entry,
            exit: org_m.exit,
            inv_dir: *p.inv_dir(),
            neg,
            sign: neg_bits.map(|b| match b {
                0 => Sign::Pos,
                b if b == active => Sign::Neg,
                _ => Sign::Mixed,
            }),
            t_min: p.t_min(),
            active,
            sh: p.shear(),
            bound: p.t_max(),
            best_prim: L::index_splat(NO_PRIM),
            best_u: L::splat(0.0),
            best_v: L::splat(0.0),
            found: 0,
        };
        if L::bits(s.in_cell(&root_lo, &root_hi)) & active != 0 {
            pm |= 1 << i;
        }
        st.push(s);
    }
    let eta = reach(&bounds, fr);
    let from_apex = fr.kind == Apex::Origin;
    let corners = tree.mesh().corner_slice();
    let mut done = 0u32;
    let mut node = tree.root();
    let (mut lo, mut hi) = (bounds.min.to_array(), bounds.max.to_array());
    let Some(mut values) = fr
        .cell_values(&lo, &hi, eta)
        .filter(|v| !Frustum::outside(v))
    else {
        c.group(0);
        return finish::<L, ANY>(&st, out);
    };
    let mut stack = Stack::<Entry<T::Ref>, N>::new();
    // Entry point: node steps before the group first defers a cell.
    let mut entry_depth = 0u32;
    let mut at_entry = true;
    if pm == 0 {
        c.group(0);
        return finish::<L, ANY>(&st, out);
    }
    loop {
        match tree.view(node) {
            NodeView::Interior {
                axis,
                split,
                below,
                above,
            } => {
                c.node();
                entry_depth += u32::from(at_entry);
                // Both children against the frustum: one decision for all.
                let mut below_hi = hi;
                below_hi[axis] = split;
                let mut above_lo = lo;
                above_lo[axis] = split;
                let [v_below, v_above] = children_met(fr, &values, &lo, &hi, axis, split, eta);
                // Near first: the apex's side for rays leaving it, the
                // other side for rays going to it.
                let below_first = (fr.apex[axis] <= f64::from(split)) == from_apex;
                match (v_below, v_above) {
                    (Some(vb), Some(va)) => {
                        at_entry = false;
                        let (near, far) = if below_first {
                            ((below, lo, below_hi, vb), (above, above_lo, hi, va))
                        } else {
                            ((above, above_lo, hi, va), (below, lo, below_hi, vb))
                        };
                        stack.push(Entry {
                            node: far.0,
                            lo: far.1,
                            hi: far.2,
                            values: far.3,
                            packets: pm,
                        });
                        (node, lo, hi, values) = near;
                        continue;
                    }
                    (Some(vb), None) => {
                        (node, hi, values) = (below, below_hi, vb);
                        continue;
                    }
                    (None, Some(va)) => {
                        (node, lo, values) = (above, above_lo, va);
                        continue;
                    }
                    (None, None) => {}
                }
            }
            NodeView::Leaf([]) => {
                // An empty leaf: nothing to clip, nothing to test.
                c.leaf();
                at_entry = false;
            }
            NodeView::Leaf(prims) => {
                c.leaf();
                at_entry = false;
                // Leaf culling for the whole group (when asked for): the
                // leaf's triangles that the frustum can reach (leaves of
                // more than 64 skip it), found once for all packets.
                // Measured on Sponza primary 8 x 8 tiles: +190
                // instructions per ray (callgrind) for 0.05 triangle tests
                // culled per ray of 0.8, so off by default (docs/groups.md).
                let neg_inf = L::splat(f32::NEG_INFINITY);
                let mut reach = u64::MAX;
                if cull && prims.len() <= 64 && pm.count_ones() > 1 {
                    for (j, r) in prims.iter().enumerate() {
                        if fr.misses_triangle(r.corners(corners), eta) {
                            c.culled();
                            reach &= !(1 << j);
                        }
                    }
                }
                // Each packet with a lane in the widened cell tests the
                // leaf's triangles, its state held in registers meanwhile.
                // Measured and rejected: no clipping (every packet tests
                // every leaf over its whole interval), 4210 instead of
                // 1797 instructions per ray on Sponza's 8 x 8 tiles.
                for i in set_bits(pm) {
                    c.cell_test();
                    let s = &mut st[i];
                    let cell = s.in_cell(&lo, &hi);
                    if L::bits(cell) & s.active == 0 {
                        continue;
                    }
                    let mut cell_bound = L::select(cell, s.bound, neg_inf);
                    for (j, r) in prims.iter().enumerate() {
                        if j < 64 && reach >> j & 1 == 0 {
                            continue;
                        }
                        let (prim, tri) = (r.prim(), r.corners(corners));
                        c.tri(L::bits(cell_bound.gt(neg_inf)).count_ones());
                        let h = triangle::intersect(
                            &s.sh.shear,
                            s.sh.corner(&tri[0]),
                            s.sh.corner(&tri[1]),
                            s.sh.corner(&tri[2]),
                            s.t_min,
                            cell_bound,
                        );
                        let hits = L::bits(h.mask);
                        if hits == 0 {
                            continue;
                        }
                        if ANY {
                            // Occlusion: a lane retires at its first hit.
                            let new = hits & !s.found;
                            for l in set_bits(new) {
                                out[i].set(
                                    l,
                                    Some(Hit {
                                        t: h.t.lane(l),
                                        prim,
                                        u: 0.0,
                                        v: 0.0,
                                    }),
                                );
                            }
                            s.found |= new;
                            let retired = L::mask_from_bits(new);
                            s.bound = L::select(retired, neg_inf, s.bound);
                            cell_bound = L::select(retired, neg_inf, cell_bound);
                            if s.found == s.active {
                                done |= 1 << i;
                                break;
                            }
                            continue;
                        }
                        // Closer, or as close with a smaller index.
                        let prim_l = L::index_splat(prim);
                        let closer = h.mask
                            & (h.t.lt(s.bound)
                                | (h.t.eq(s.bound) & L::index_lt(prim_l, s.best_prim)));
                        s.bound = L::select(closer, h.t, s.bound);
                        cell_bound = L::select(closer, h.t, cell_bound);
                        s.best_u = L::select(closer, h.u, s.best_u);
                        s.best_v = L::select(closer, h.v, s.best_v);
                        s.best_prim = L::index_select(closer, prim_l, s.best_prim);
                    }
                }
            }
        }
        // Pop: the next deferred cell with the packets that still have a
        // lane whose interval meets it; none: skip its whole subtree.
        loop {
            let Some(e) = stack.pop() else {
                c.group(entry_depth);
                return finish::<L, ANY>(&st, out);
            };
            // Closest hit: only a packet whose every lane has a hit can
            // be done with the cell; the others keep it and the leaves
            // clip them. Occlusion: every packet not yet `done`.
            let mut keep = e.packets & !done;
            for i in set_bits(keep) {
                let s = &st[i];
                let all_hit = L::bits(L::index_lt(s.best_prim, L::index_splat(NO_PRIM)));
                if !ANY && all_hit & s.active != s.active {
                    continue;
                }
                c.cell_test();
                if L::bits(s.in_cell(&e.lo, &e.hi)) & s.active == 0 {
                    keep &= !(1 << i);
                }
            }
            if keep != 0 {
                (node, lo, hi, values, pm) = (e.node, e.lo, e.hi, e.values, keep);
                break;
            }
        }
    }
}

/// Twice the largest lane margin of a group in `bounds`: a cell or
/// triangle outside the frustum by more than this is out of every lane's
/// reach.
#[inline(always)]
fn reach(bounds: &Aabb, fr: &Frustum) -> f64 {
    let box_m = bounds.min.abs().max(bounds.max.abs()).max_element();
    2.0 * f64::from(MARGIN) * f64::from(box_m.max(fr.org_mag))
}

/// The frustum values of the two children (below, above) of the cell
/// `[lo, hi]` (values `v`) split at `split` on `axis`, each `None` when
/// the child is out of the frustum's reach.
#[inline(always)]
fn children_met(
    fr: &Frustum,
    v: &CellValues,
    lo: &[f32; 3],
    hi: &[f32; 3],
    axis: usize,
    split: f32,
    eta: f64,
) -> [Option<CellValues>; 2] {
    [true, false].map(|below| {
        fr.child_values(v, (lo[axis], hi[axis]), axis, split, below, eta)
            .filter(|v| !Frustum::outside(v))
    })
}

/// Where a group hands its packets on (issue 12's descent "down to the
/// width-generic packet traversal"): its entry point and that node's
/// cell.
pub(crate) struct Handoff<R> {
    pub node: R,
    pub cell: Aabb,
}

/// The group's entry point (MLRTA): from the root, the steps while only
/// one child meets the frustum, up to the first node both of whose
/// children do, or the leaf the descent ends in. No cell the group passed
/// by meets the frustum, so every hit of every ray lies in the entry
/// cell, and each packet traced from there by the packet traversal
/// (`hybrid::trace_from`) equals the scalar query lane by lane. `None`:
/// the frustum meets no cell, and no ray of the group hits anything. No
/// per-packet work at all: the packets start from the entry point
/// themselves.
pub(crate) fn entry_point<T: Layout, C: Counters>(
    tree: &T,
    fr: &Frustum,
    c: &mut C,
) -> Option<Handoff<T::Ref>> {
    let bounds = *tree.bounds();
    let eta = reach(&bounds, fr);
    let (mut lo, mut hi) = (bounds.min.to_array(), bounds.max.to_array());
    let mut node = tree.root();
    let mut depth = 0u32;
    let mut values = fr
        .cell_values(&lo, &hi, eta)
        .filter(|v| !Frustum::outside(v));
    while let Some(v) = values {
        let NodeView::Interior {
            axis,
            split,
            below,
            above,
        } = tree.view(node)
        else {
            break;
        };
        c.node();
        depth += 1;
        match children_met(fr, &v, &lo, &hi, axis, split, eta) {
            [Some(_), Some(_)] => break,
            [Some(vb), None] => (node, hi[axis], values) = (below, split, Some(vb)),
            [None, Some(va)] => (node, lo[axis], values) = (above, split, Some(va)),
            [None, None] => values = None,
        }
    }
    c.group(depth);
    values.map(|_| Handoff {
        node,
        cell: Aabb::new(Vec3A::from_array(lo), Vec3A::from_array(hi)),
    })
}

/// Closest hits into `out` (occlusion wrote its lanes as it found them).
#[inline(always)]
fn finish<L: Lane, const ANY: bool>(st: &[Lanes<L>], out: &mut [HitPacket<L>]) {
    if ANY {
        return;
    }
    let inf = L::splat(f32::INFINITY);
    for (s, o) in st.iter().zip(out.iter_mut()) {
        let hit = L::index_lt(s.best_prim, L::index_splat(NO_PRIM));
        *o = HitPacket::from_lanes(
            L::select(hit, s.bound, inf),
            s.best_prim,
            s.best_u,
            s.best_v,
        );
    }
}

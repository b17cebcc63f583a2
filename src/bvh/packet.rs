//! The 8-wide tree's packet traversal: `L::WIDTH` rays of one direction
//! octant through the same nodes, the eight children first against the
//! packet's frustum (`slab::Frustum`), then each child it meets tested for
//! all lanes at once (the lanes are rays here, where the single-ray
//! traversal's lanes are children), the children met visited nearest
//! first by their nearest lane's entry, with the lanes that met them.
//! Reads beside
//! `single.rs` and the kd-tree's `packet.rs`: the same margin, the same
//! leaf rule, the same tie rule.
//!
//! It gets packets whose active lanes share their direction signs and take
//! the fast box test (`query.rs` sends the others ray by ray).

use super::Bvh8;
use super::node::{ChildRef, Tri4};
use super::single::STACK;
use super::slab::{extreme, lane_boxes};
use crate::kdtree::{Counters, Stack};
use crate::packet::{HitPacket, PacketShear, RayPacket};
use crate::ray::{Hit, NO_PRIM};
use crate::simd::Lane;
use crate::triangle::{self, TriHit};

/// A deferred child: the lanes that met it and the nearest of their
/// entries.
#[derive(Clone, Copy)]
struct Entry {
    child: ChildRef,
    lanes: u32,
    t: f32,
}

/// The lanes of `hits` whose hit on `prim` the filter accepts.
/// The lanes of `hits` whose hit on `prim` the filter accepts (the BVHs'
/// and the grid's packets).
#[inline]
pub(crate) fn accepted<L: Lane, C: Counters>(
    c: &mut C,
    hits: u32,
    prim: u32,
    h: &TriHit<L>,
) -> u32 {
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

/// The lanes' best hits so far.
struct Best<L: Lane> {
    t: L,
    prim: L::Index,
    u: L,
    v: L,
    /// Occlusion: lanes with a hit.
    found: u32,
}

/// Tests a leaf's blocks, triangle by triangle, for every lane whose bound
/// allows (the lanes that did not meet the leaf test it too: their hits
/// are real hits, and only a closer one is kept). Returns `true` when,
/// with `ANY`, every lane of `active` has a hit.
#[inline(always)]
fn leaf<L: Lane, const ANY: bool, C: Counters>(
    blocks: &[Tri4],
    p: &RayPacket<L>,
    sh: &PacketShear<L>,
    active: u32,
    best: &mut Best<L>,
    out: &mut HitPacket<L>,
    c: &mut C,
) -> bool {
    for b in blocks {
        for j in 0..b.prims.len() {
            let prim = b.prims[j];
            // Spare lanes repeat the first triangle.
            if j > 0 && prim == b.prims[0] {
                continue;
            }
            c.tri(active.count_ones());
            let tri = b.triangle(j);
            let h = triangle::intersect(
                &sh.shear,
                sh.corner(&tri[0]),
                sh.corner(&tri[1]),
                sh.corner(&tri[2]),
                p.t_min(),
                best.t,
            );
            let mut hits = L::bits(h.mask);
            if hits == 0 {
                continue;
            }
            let mut hit_mask = h.mask;
            if C::FILTERS {
                hits = accepted(c, hits, prim, &h);
                if hits == 0 {
                    continue;
                }
                hit_mask = L::mask_from_bits(hits);
            }
            if ANY {
                // A lane retires at its first hit.
                let new = hits & !best.found;
                let mut left = new;
                while left != 0 {
                    let i = left.trailing_zeros() as usize;
                    left &= left - 1;
                    let hit = Hit {
                        t: h.t.lane(i),
                        prim,
                        u: 0.0,
                        v: 0.0,
                    };
                    out.set(i, Some(hit));
                }
                best.found |= new;
                best.t = L::select(
                    L::mask_from_bits(best.found),
                    L::splat(f32::NEG_INFINITY),
                    best.t,
                );
                if best.found == active {
                    return true;
                }
                continue;
            }
            // Closer, or as close with a smaller index (ray policy).
            let prim_l = L::index_splat(prim);
            let closer =
                hit_mask & (h.t.lt(best.t) | (h.t.eq(best.t) & L::index_lt(prim_l, best.prim)));
            best.t = L::select(closer, h.t, best.t);
            best.u = L::select(closer, h.u, best.u);
            best.v = L::select(closer, h.v, best.v);
            best.prim = L::index_select(closer, prim_l, best.prim);
        }
    }
    false
}

/// The packet traversal of a [`Bvh8`] for a packet whose active lanes
/// share their direction signs and all take the fast box test.
/// `#[inline(always)]`: compiled into each kernel.
#[inline(always)]
pub(crate) fn traverse<L: Lane, const ANY: bool, C: Counters>(
    bvh: &Bvh8,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    let mut out = HitPacket::default();
    let active = p.active();
    if active == 0 || bvh.root == ChildRef::EMPTY {
        return out;
    }
    let lb = lane_boxes(&bvh.bounds, p);
    let sh = p.shear();
    let mut best = Best {
        t: p.t_max(),
        prim: L::index_splat(NO_PRIM),
        u: L::splat(0.0),
        v: L::splat(0.0),
        found: 0,
    };
    let t_min = p.t_min();
    let inf = L::splat(f32::INFINITY);
    let (nodes, blocks) = (&bvh.nodes[..], &bvh.blocks[..]);
    let mut stack = Stack::<Entry, STACK>::new();
    let mut cur = Entry {
        child: bvh.root,
        lanes: active,
        t: f32::NEG_INFINITY,
    };
    let frustum = lb.frustum(active);
    let t_lo = extreme(t_min, active, false);
    'trace: loop {
        // Down the interior nodes: the eight children against the
        // packet's frustum in one 8-wide step, then only the children it
        // meets lane by lane (on coherent packets most children of a node
        // are missed by every lane). Measured and rejected (docs/bvh.md):
        // the frustum alone for interior children, with every lane of the
        // parent passed down, which doubled the bunny's primary packets'
        // instructions (small boxes, loose frustum).
        while !cur.child.is_leaf() {
            let node = &nodes[cur.child.index()];
            c.node();
            let mut fmask = frustum.test(node, t_lo, extreme(best.t, cur.lanes, true));
            let mut met = [Entry {
                child: ChildRef::EMPTY,
                lanes: 0,
                t: 0.0,
            }; 8];
            let mut n = 0;
            while fmask != 0 {
                let i = fmask.trailing_zeros() as usize;
                fmask &= fmask - 1;
                let child = node.children[i];
                if child == ChildRef::EMPTY {
                    continue;
                }
                let lo = [0, 1, 2].map(|a| node.planes[a][0].to_array()[i]);
                let hi = [0, 1, 2].map(|a| node.planes[a][1].to_array()[i]);
                let (t0, t1) = lb.interval(lo, hi, t_min, best.t);
                let lanes = L::bits(t0.le(t1)) & cur.lanes;
                if lanes != 0 {
                    // The nearest entry of the lanes that met it.
                    let t0 = L::select(L::mask_from_bits(lanes), t0, inf);
                    let mut t = f32::INFINITY;
                    for l in 0..L::WIDTH {
                        let x = t0.lane(l);
                        t = if x < t { x } else { t };
                    }
                    met[n] = Entry { child, lanes, t };
                    n += 1;
                }
            }
            if n == 0 {
                break;
            }
            // Farthest deferred first, nearest visited now (insertion
            // sort, at most eight).
            for i in 1..n {
                let x = met[i];
                let mut j = i;
                while j > 0 && met[j - 1].t < x.t {
                    met[j] = met[j - 1];
                    j -= 1;
                }
                met[j] = x;
            }
            for e in &met[..n - 1] {
                stack.push(*e);
            }
            cur = met[n - 1];
        }
        if cur.child.is_leaf() && cur.child != ChildRef::EMPTY {
            c.leaf();
            let bl = &blocks[cur.child.blocks()];
            if leaf::<L, ANY, C>(bl, p, &sh, active, &mut best, &mut out, c) {
                return out;
            }
        }
        // The next deferred child with a lane that may still find a hit
        // there (its entry at or before the lane's best).
        loop {
            let Some(e) = stack.pop() else {
                break 'trace;
            };
            let lanes = e.lanes & L::bits(L::splat(e.t).le(best.t));
            if lanes != 0 {
                cur = Entry { lanes, ..e };
                continue 'trace;
            }
        }
    }
    if !ANY {
        let hit = L::index_lt(best.prim, L::index_splat(NO_PRIM));
        out = HitPacket::from_lanes(L::select(hit, best.t, inf), best.prim, best.u, best.v);
    }
    out
}

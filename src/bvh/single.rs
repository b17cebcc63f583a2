//! The 8-wide tree's single-ray traversal (Wald, Benthin and Boulos 2008,
//! "Getting rid of packets"; Dammertz et al. 2008; Embree's
//! `BVHNIntersector1`): eight child boxes per step with one SIMD slab test,
//! the children met visited nearest first, deferred ones on a stack of
//! `(reference, entry distance)` and skipped when they start beyond the
//! closest hit. Occlusion is its own instance (`ANY`): no sorting, and it
//! stops at the first hit.
//!
//! Leaves are runs of 4-triangle blocks, tested with the crate's one
//! watertight routine over four lanes that are four triangles of one ray.

use super::Bvh8;
use super::node::{ChildRef, Tri4};
use super::slab::NodeTest;
use crate::kdtree::{Counters, Stack, prefetch_all};
use crate::ray::{Hit, NO_PRIM, Ray};
use crate::simd::{F4, Lane};
use crate::triangle::{self, Shear};

/// Deferred children at most: a node defers at most 7 of its 8 children,
/// and a path has at most `BVH_MAX_DEPTH` nodes (the build's bound).
pub(crate) const STACK: usize = 7 * super::params::BVH_MAX_DEPTH as usize + 1;

/// A deferred child: its entry distance's bits above its reference, so
/// that for entries `>= 0` the order of the keys is the order of the
/// distances (a negative entry, possible with `t_min < 0`, sorts last:
/// only the visiting order suffers, never the answer).
#[inline(always)]
fn key(r: ChildRef, t: f32) -> u64 {
    u64::from(t.to_bits()) << 32 | u64::from(r.0)
}

#[inline(always)]
fn unkey(k: u64) -> (ChildRef, f32) {
    (ChildRef(k as u32), f32::from_bits((k >> 32) as u32))
}

/// Asks for the memory of a child the traversal will visit later: every
/// cache line of its node, or of its first block (Embree prefetches each
/// chosen child's lines as it is chosen; `BVH::prefetch`).
#[inline(always)]
fn prefetch_child(bvh: &Bvh8, r: ChildRef) {
    if !r.is_leaf() {
        if let Some(n) = bvh.nodes.get(r.index()) {
            prefetch_all(n);
        }
    } else if let Some(b) = bvh.blocks.get(r.blocks().start) {
        prefetch_all(b);
    }
}

/// The per-ray part of the leaf test: the shear splatted over four lanes
/// and the axis order of the corners.
pub(crate) struct LeafRay {
    shear: Shear<F4>,
    k: [usize; 3],
    t_min: F4,
}

impl LeafRay {
    #[inline(always)]
    pub(crate) fn new(ray: &Ray) -> LeafRay {
        let (sh, k) = triangle::shear(ray);
        LeafRay {
            shear: Shear {
                org: sh.org.map(F4::splat),
                s: sh.s.map(F4::splat),
            },
            k,
            t_min: F4::splat(ray.t_min()),
        }
    }
}

/// Tests the blocks of a leaf, keeping the closest hit in `best` (ties to
/// the smaller triangle index). With `ANY`, returns `true` at the first
/// hit (written to `best`).
#[inline(always)]
pub(crate) fn leaf<const ANY: bool, C: Counters>(
    blocks: &[Tri4],
    lr: &LeafRay,
    best: &mut Hit,
    c: &mut C,
) -> bool {
    let k = lr.k;
    for b in blocks {
        c.tri(b.len());
        let corner = |j: usize| {
            let p = &b.corners[j];
            [p[k[0]], p[k[1]], p[k[2]]]
        };
        let h = triangle::intersect(
            &lr.shear,
            corner(0),
            corner(1),
            corner(2),
            lr.t_min,
            F4::splat(best.t),
        );
        let mut bits = F4::bits(h.mask);
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let cand = Hit {
                t: h.t.lane(i),
                prim: b.prims[i],
                u: h.u.lane(i),
                v: h.v.lane(i),
            };
            // An any-hit filter (scenes only) may reject the hit.
            if C::FILTERS && !c.accept(cand.prim, cand.t, cand.u, cand.v) {
                continue;
            }
            if ANY {
                *best = cand;
                return true;
            }
            if cand.closer_than(best) {
                *best = cand;
            }
        }
    }
    false
}

/// The one single-ray traversal of a [`Bvh8`], for any box test; `ANY`
/// selects occlusion. `#[inline(always)]`: compiled into each kernel.
#[inline(always)]
pub(crate) fn traverse<T: NodeTest, const ANY: bool, C: Counters>(
    bvh: &Bvh8,
    ray: &Ray,
    test: &T,
    c: &mut C,
) -> Option<Hit> {
    let lr = LeafRay::new(ray);
    let t_min = ray.t_min();
    let mut best = Hit {
        t: ray.t_max(),
        prim: NO_PRIM,
        u: 0.0,
        v: 0.0,
    };
    let (nodes, blocks) = (&bvh.nodes[..], &bvh.blocks[..]);
    let mut stack = Stack::<u64, STACK>::new();
    let mut cur = bvh.root;
    'trace: loop {
        // Down the interior nodes: one box test of eight children per step.
        while !cur.is_leaf() {
            let node = &nodes[cur.index()];
            c.node();
            let (mut mask, dist) = test.test(node, t_min, best.t);
            let dist = dist.to_array();
            if mask == 0 {
                break;
            }
            let first = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            // One child met: on to it, nothing deferred.
            if mask == 0 {
                cur = node.children[first];
                continue;
            }
            if ANY {
                // Occlusion: no order; the first slot now, the rest later.
                cur = node.children[first];
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    prefetch_child(bvh, node.children[i]);
                    stack.push(key(node.children[i], dist[i]));
                }
                continue;
            }
            let second = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let (a, b) = (
                key(node.children[first], dist[first]),
                key(node.children[second], dist[second]),
            );
            // Two: one compare, the farther deferred.
            if mask == 0 {
                let (near, far) = if a <= b { (a, b) } else { (b, a) };
                prefetch_child(bvh, unkey(far).0);
                stack.push(far);
                cur = unkey(near).0;
                continue;
            }
            // Three or more: sorted by entry, farthest deferred first, so
            // the nearest is visited now and the next nearest pops next.
            let mut keys = [0u64; 8];
            keys[0] = a;
            keys[1] = b;
            let mut n = 2;
            while mask != 0 {
                let i = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                keys[n] = key(node.children[i], dist[i]);
                n += 1;
            }
            // Insertion sort, descending (at most eight keys).
            for i in 1..n {
                let x = keys[i];
                let mut j = i;
                while j > 0 && keys[j - 1] < x {
                    keys[j] = keys[j - 1];
                    j -= 1;
                }
                keys[j] = x;
            }
            for &k in &keys[..n - 1] {
                prefetch_child(bvh, unkey(k).0);
                stack.push(k);
            }
            cur = unkey(keys[n - 1]).0;
        }
        // A leaf (or nothing, after an empty step).
        if cur.is_leaf() && cur != ChildRef::EMPTY {
            c.leaf();
            if leaf::<ANY, C>(&blocks[cur.blocks()], &lr, &mut best, c) {
                return Some(best);
            }
        }
        // The next deferred child that may still hold a closer hit (a
        // child entered exactly at the best `t` may hold a smaller index).
        loop {
            let Some(k) = stack.pop() else {
                break 'trace;
            };
            let (r, t) = unkey(k);
            if ANY || t <= best.t {
                cur = r;
                continue 'trace;
            }
        }
    }
    (best.prim != NO_PRIM).then_some(best)
}

//! A leaf visited by a subset: every triangle against every ray of the
//! subset with the one watertight routine (`triangle.rs`), eight rays per
//! call (Wald, Gribble, Boulos and Kensler 2007: SIMD across the rays of
//! a stream). Rays go in groups of up to eight, outer; each group's
//! shear, interval and closest hit stay in registers over the leaf's
//! triangles and are written back once.
//!
//! A chunk's rays share their direction signs and come sorted by the
//! dominant axis of their direction (`rays.rs`), which within an octant
//! decides the triangle test's permutation; a group never straddles two
//! axes, so each triangle's corners are permuted once per group, as
//! `triangle::permute` permutes them for the scalar path.

use super::rays::{StreamRays, perm};
use crate::kdtree::kernel::partition::{Ids8, StreamIsa};
use crate::kdtree::layout::LeafTri;
use crate::kdtree::stats::Counters;
use crate::ray::Hit;
use crate::simd::{Lane, set_bits};
use crate::triangle::{self, Shear, TriHit, permute};
use glam::Vec3;

/// The lanes of `hits` whose hit on `prim` the filter accepts (as the
/// packet leaf's).
#[inline]
fn accepted<L: Lane, C: Counters>(c: &mut C, hits: u32, prim: u32, h: &TriHit<L>) -> u32 {
    let mut keep = hits;
    for i in set_bits(hits) {
        if !c.accept(prim, h.t.lane(i), h.u.lane(i), h.v.lane(i)) {
            keep &= !(1 << i);
        }
    }
    keep
}

/// Corner `v` permuted by `k`, in every lane.
#[inline(always)]
fn corner<L: Lane>(v: Vec3, k: [usize; 3]) -> [L; 3] {
    let p = permute(v, k);
    [L::splat(p[0]), L::splat(p[1]), L::splat(p[2])]
}

/// Tests the leaf's triangles `prims` against the rays `ids` of a subset
/// (in id order), updating each ray's closest hit (or, for occlusion,
/// retiring the rays it finds occluded). `neg`: the chunk's octant.
#[inline(always)]
pub(crate) fn test_leaf<
    L: Lane,
    I: StreamIsa<Lanes = L>,
    P: LeafTri,
    const ANY: bool,
    C: Counters,
>(
    isa: I,
    rays: &mut StreamRays,
    ids: &[u32],
    neg: [bool; 3],
    prims: &[P],
    corners: &[[Vec3; 3]],
    c: &mut C,
) {
    let n = rays.n;
    let mut j = 0;
    while j < ids.len() {
        // The group: up to eight rays of one dominant axis.
        let class = rays.class_of(ids[j]);
        let end = rays.class_end[class];
        let mut len = 1;
        while len < 8 && j + len < ids.len() && ids[j + len] < end {
            len += 1;
        }
        let group = &ids[j..j + len];
        j += len;
        let k = perm(class, neg);
        // Lanes past the group's rays repeat its first ray and can never
        // hit (a bound of -inf).
        let g = Ids8::new(group, n);
        let live = (1u32 << len) - 1;
        debug_assert!(L::WIDTH == 8);
        // One record per ray (8 loads and a transpose), not seven gathers.
        let [o0, o1, o2, s0, s1, s2, t_min, _] = isa.gather_leaf(&g, &rays.leaf);
        let shear = Shear {
            org: [o0, o1, o2],
            s: [s0, s1, s2],
        };
        let mut best_t = L::select(
            L::mask_from_bits(live),
            isa.gather(&g, &rays.best_t),
            L::splat(f32::NEG_INFINITY),
        );
        let mut best_prim = isa.gather_index(&g, &rays.best_prim);
        let mut best_u = isa.gather(&g, &rays.best_u);
        let mut best_v = isa.gather(&g, &rays.best_v);
        let mut changed = 0u32;
        let mut found = 0u32;
        for r in prims {
            c.tri(len as u32);
            let (prim, tri) = (r.prim(), r.corners(corners));
            let h = triangle::intersect(
                &shear,
                corner::<L>(tri[0], k),
                corner::<L>(tri[1], k),
                corner::<L>(tri[2], k),
                t_min,
                best_t,
            );
            let mut hits = L::bits(h.mask);
            if hits == 0 {
                continue;
            }
            // An any-hit filter (scenes only) may reject a lane's hit.
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
                found |= new;
                let m = L::mask_from_bits(new);
                best_t = L::select(m, L::splat(f32::NEG_INFINITY), best_t);
                best_prim = L::index_select(m, L::index_splat(prim), best_prim);
                changed |= new;
                if found == live {
                    break;
                }
                continue;
            }
            // Closer, or as close with a smaller index (ray policy).
            let prim_l = L::index_splat(prim);
            let closer =
                hit_mask & (h.t.lt(best_t) | (h.t.eq(best_t) & L::index_lt(prim_l, best_prim)));
            best_t = L::select(closer, h.t, best_t);
            best_u = L::select(closer, h.u, best_u);
            best_v = L::select(closer, h.v, best_v);
            best_prim = L::index_select(closer, prim_l, best_prim);
            changed |= L::bits(closer);
        }
        for l in set_bits(changed & live) {
            let hit = Hit {
                t: best_t.lane(l),
                prim: L::index_lane(best_prim, l),
                u: if ANY { 0.0 } else { best_u.lane(l) },
                v: if ANY { 0.0 } else { best_v.lane(l) },
            };
            rays.set_best::<ANY>(g.lane(l), hit);
        }
    }
}

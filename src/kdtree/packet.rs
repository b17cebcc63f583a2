//! Packet traversal: four rays through the same 8-byte nodes (Wald,
//! Slusallek, Benthin and Wagner 2001; Wald's thesis 2004, section 7.4).
//! Reads side by side with `scalar.rs`: the same interval arithmetic, per
//! lane, with the three-way branch taken on lane masks.

use super::KdTree;
use super::layout::{Layout, NodeView};
use super::margin;
use super::params::MAX_DEPTH_LIMIT;
use super::scalar::{SMALL_STACK, by_axis, traverse};
use super::stats::{Counters, NoCount, TraversalStats};
use crate::aabb::slab;
use crate::packet::{HitPacket4, RayPacket4};
use crate::query::PacketQuery;
use crate::ray::{Hit, NO_PRIM, Ray};
use crate::simd::{F4, Lane, U4, lt_u4, select_u4};
use crate::triangle;

/// A deferred far child and the lanes' intervals inside it; inactive lanes
/// carry an empty interval.
#[derive(Clone, Copy)]
struct Entry4<R> {
    node: R,
    t_min: F4,
    t_max: F4,
}

impl KdTree {
    /// Closest hits of a packet; lane `i` equals `intersect` of ray `i`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket4};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// let h = t.intersect4(&RayPacket4::from_rays(&[r(0.1), r(0.2), r(5.0), r(0.3)]));
    /// assert_eq!(h.mask(), 0b1011);
    /// assert_eq!(h.hit(0), t.intersect(&r(0.1)));
    /// ```
    #[must_use]
    pub fn intersect4(&self, p: &RayPacket4) -> HitPacket4 {
        traverse4::<_, false, _>(self, p, &mut NoCount)
    }

    /// Occlusion of a packet: bit `i` set when lane `i` is occluded. A lane
    /// retires at its first hit; the packet stops when all have.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket4};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// assert_eq!(t.occluded4(&RayPacket4::from_rays(&[r(0.1), r(9.0), r(9.0), r(0.3)])), 0b1001);
    /// ```
    #[must_use]
    pub fn occluded4(&self, p: &RayPacket4) -> u32 {
        traverse4::<_, true, _>(self, p, &mut NoCount).mask()
    }

    /// [`KdTree::intersect4`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, RayPacket4, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// t.intersect4_counted(&RayPacket4::from_lanes([None; 4]), &mut s);
    /// assert_eq!(s.packets, 1);
    /// ```
    pub fn intersect4_counted(&self, p: &RayPacket4, stats: &mut TraversalStats) -> HitPacket4 {
        stats.packets += 1;
        stats.rays += p.active.count_ones() as u64;
        traverse4::<_, false, _>(self, p, stats)
    }

    /// [`KdTree::occluded4`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, RayPacket4, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// assert_eq!(t.occluded4_counted(&RayPacket4::from_lanes([None; 4]), &mut s), 0);
    /// ```
    pub fn occluded4_counted(&self, p: &RayPacket4, stats: &mut TraversalStats) -> u32 {
        stats.packets += 1;
        stats.rays += p.active.count_ones() as u64;
        traverse4::<_, true, _>(self, p, stats).mask()
    }

    /// Closest hits of a stream of rays, traced as 4-wide packets of
    /// consecutive rays (a short tail packet has inactive lanes).
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let rays: Vec<Ray> = (0..7)
    ///     .map(|i| Ray::new(Vec3::new(0.1 * i as f32, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap())
    ///     .collect();
    /// let mut hits = vec![None; 7];
    /// t.intersect_rays(&rays, &mut hits);
    /// assert!(hits.iter().zip(&rays).all(|(h, r)| *h == t.intersect(r)));
    /// ```
    pub fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        PacketQuery::intersect_rays(self, rays, hits);
    }

    /// Occlusion of a stream of rays, traced as 4-wide packets.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.1, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// let mut occ = vec![false; 5];
    /// t.occluded_rays(&[r; 5], &mut occ);
    /// assert!(occ.iter().all(|&o| o));
    /// ```
    pub fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        PacketQuery::occluded_rays(self, rays, occluded);
    }
}

impl PacketQuery for KdTree {
    fn intersect4(&self, packet: &RayPacket4) -> HitPacket4 {
        KdTree::intersect4(self, packet)
    }
    fn occluded4(&self, packet: &RayPacket4) -> u32 {
        KdTree::occluded4(self, packet)
    }
}

/// Lanes of a packet traced one by one (mixed direction signs).
#[cold]
fn per_lane<T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket4,
    c: &mut C,
) -> HitPacket4 {
    c.fallback();
    let mut out = HitPacket4::default();
    for i in 0..4 {
        if let Some(r) = p.ray(i) {
            out.set(i, traverse::<T, ANY, C>(tree, &r, c));
        }
    }
    out
}

/// The one packet traversal, for any node layout; `ANY` selects occlusion
/// over closest hit. The stack is sized as in the scalar traversal.
#[inline]
pub(crate) fn traverse4<T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket4,
    c: &mut C,
) -> HitPacket4 {
    if tree.depth_limit() as usize <= SMALL_STACK {
        traverse4_with::<T, ANY, C, SMALL_STACK>(tree, p, c)
    } else {
        traverse4_with::<T, ANY, C, { MAX_DEPTH_LIMIT as usize }>(tree, p, c)
    }
}

/// [`traverse4`] with a stack of `N` entries.
#[inline(never)]
fn traverse4_with<T: Layout, const ANY: bool, C: Counters, const N: usize>(
    tree: &T,
    p: &RayPacket4,
    c: &mut C,
) -> HitPacket4 {
    let mut out = HitPacket4::default();
    if p.active == 0 {
        return out;
    }
    // One near/far order per axis for the whole packet: all active lanes
    // must agree on the direction's sign, else trace lane by lane.
    let neg_bits = p.neg_bits();
    if neg_bits.iter().any(|&b| b != 0 && b != p.active) {
        return per_lane::<T, ANY, C>(tree, p, c);
    }
    let neg = neg_bits.map(|b| b != 0);
    let neg_mask = neg.map(|n| F4::mask_from_bits(if n { 0xF } else { 0 }));
    // Cells widened by the margin, per lane as in the scalar traversal.
    let org_m = margin::shifted(tree.bounds(), &p.org, &neg_mask);
    let (_, t0, t1) = slab(
        tree.bounds(),
        &org_m.entry,
        &org_m.exit,
        &p.inv_dir,
        &neg_mask,
        p.t_min,
        p.t_max,
    );
    // `active` decides, not the lanes' intervals: a packet built by hand
    // (its fields are public) may hold a valid ray in an inactive lane.
    let active = F4::mask_from_bits(p.active);
    let hit_box = t0.le(t1) & active;
    if !hit_box.any() {
        return out;
    }
    let sh = p.shear();
    let corners = tree.mesh().corner_slice();
    let inf = F4::splat(f32::INFINITY);
    // An inactive lane's bound of -inf rejects every triangle hit.
    let mut best_t = active.select(p.t_max, -inf);
    let mut best_prim = U4::splat(NO_PRIM);
    let mut best_u = F4::splat(0.0);
    let mut best_v = F4::splat(0.0);
    let mut found = 0u32;
    let (entry_org, exit_org) = (by_axis(org_m.entry), by_axis(org_m.exit));
    let (inv_dir_ax, neg_ax) = (by_axis(p.inv_dir), by_axis(neg));
    let mut node = tree.root();
    let mut stack = [Entry4 {
        node,
        t_min: inf,
        t_max: -inf,
    }; N];
    let mut sp = 0;
    let mut t_min = hit_box.select(t0, inf);
    let mut t_max = hit_box.select(t1, -inf);
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
                let split = F4::splat(split);
                let near_t_max = t_max.min_keep((split - exit_org[axis]) * inv_dir_ax[axis]);
                let far_t_min = t_min.max_keep((split - entry_org[axis]) * inv_dir_ax[axis]);
                let go_near = t_min.le(near_t_max).any();
                let go_far = far_t_min.le(t_max).any();
                // Three-way step on the lane masks: both (defer far), near
                // only, far only. Measured and rejected (ARCHITECTURE.md,
                // "Decisions measured and rejected"): a branch-free step
                // that selects the next child with masks (235M -> 345M
                // instructions, 45 % slower on Sponza primary rays), and
                // the unconditional far push (12 % slower).
                if go_near {
                    if go_far {
                        stack[sp] = Entry4 {
                            node: far,
                            t_min: far_t_min,
                            t_max,
                        };
                        sp += 1;
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
                let in_cell = t_min.le(t_max).to_bitmask().count_ones();
                for &prim in prims {
                    c.tri(in_cell);
                    let tri = &corners[prim as usize];
                    let h = triangle::intersect(
                        &sh.shear,
                        sh.corner(&tri[0]),
                        sh.corner(&tri[1]),
                        sh.corner(&tri[2]),
                        p.t_min,
                        best_t,
                    );
                    let hits = h.mask.to_bitmask();
                    if hits == 0 {
                        continue;
                    }
                    // Occlusion: a lane retires at its first hit.
                    if ANY {
                        let new = hits & !found;
                        for i in 0..4 {
                            if new >> i & 1 == 1 {
                                out.prim[i] = prim;
                                out.t[i] = h.t.lane(i);
                            }
                        }
                        found |= new;
                        if found == p.active {
                            return out;
                        }
                        continue;
                    }
                    // Closer, or as close with a smaller index (ray policy).
                    let prim4 = U4::splat(prim);
                    let closer =
                        h.mask & (h.t.lt(best_t) | (h.t.eq(best_t) & lt_u4(prim4, best_prim)));
                    best_t = closer.select(h.t, best_t);
                    best_u = closer.select(h.u, best_u);
                    best_v = closer.select(h.v, best_v);
                    best_prim = select_u4(closer, prim4, best_prim);
                }
            }
        }
        // Pop: the next deferred cell, for the lanes still in it: a lane
        // leaves when its closest hit lies before the cell (or, for
        // occlusion, when it has any hit). No lane left: skip the cell. As
        // in the scalar pop, strict or not makes no difference since the
        // margin (HARDENING.md, "Mutation testing").
        loop {
            if sp == 0 {
                if !ANY {
                    out.prim = best_prim.to_array();
                    let hit = F4::mask_from_bits(out.mask());
                    out.t = hit.select(best_t, inf).to_array();
                    out.u = best_u.to_array();
                    out.v = best_v.to_array();
                }
                return out;
            }
            sp -= 1;
            let e = stack[sp];
            t_min = e.t_min;
            t_max = if ANY {
                F4::mask_from_bits(found).select(-inf, e.t_max)
            } else {
                e.t_max.min_keep(best_t)
            };
            if t_min.le(t_max).any() {
                node = e.node;
                break;
            }
        }
    }
}

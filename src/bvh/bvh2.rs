//! The lectures' binary BVH (Stamminger/Grosso, Bridson, MIT 6.837): two
//! children per node, both boxes tested, the nearer visited first, the
//! farther deferred with its entry distance; leaves of a few triangles
//! tested one at a time. It is the baseline the 8-wide tree is measured
//! against, and the tree that tree is collapsed from.

use super::build;
use super::node::Node2;
use super::params::{BVH_MAX_DEPTH, BvhBuildError, BvhBuildParams};
use super::slab::{LaneBoxes, RayBoxes, Robust8, lane_boxes, magnitude};
use crate::aabb::Aabb;
use crate::kdtree::{Counters, NoCount, Stack, TraversalStats};
use crate::mesh::Mesh;
use crate::packet::{HitPacket, PacketShear, RayPacket};
use crate::ray::{Hit, NO_PRIM, Ray};
use crate::simd::Lane;
use crate::triangle::{self, permute};

/// A binary BVH over a [`Mesh`], which it owns: 32-byte nodes in
/// depth-first order (the left child follows its parent) and leaves that
/// index a permutation of the triangles. `Send + Sync`.
///
/// ```
/// use packtrace::bvh::{Bvh2, BvhBuildParams};
/// use packtrace::glam::Vec3;
/// use packtrace::{Mesh, Ray};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// for p in [BvhBuildParams::median(), BvhBuildParams::sah_binary()] {
///     let bvh = Bvh2::build(mesh.clone(), &p).unwrap();
///     let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
///     assert_eq!(bvh.intersect(&ray).map(|h| h.prim), Some(0));
/// }
/// ```
#[derive(Clone, Debug)]
pub struct Bvh2 {
    mesh: Mesh,
    pub(crate) nodes: Vec<Node2>,
    pub(crate) prims: Vec<u32>,
    params: BvhBuildParams,
}

impl Bvh2 {
    /// Builds the tree with `params` ([`BvhBuildParams::median`] for the
    /// lectures' median split, [`BvhBuildParams::sah_binary`] for the
    /// binned SAH with one-at-a-time leaves), in parallel, the same tree
    /// for any thread count.
    ///
    /// # Errors
    /// As [`Bvh8::build`](super::Bvh8::build).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// assert_eq!(b.node_count(), 0);
    /// ```
    pub fn build(mesh: Mesh, params: &BvhBuildParams) -> Result<Bvh2, BvhBuildError> {
        super::check_input(&mesh, params)?;
        let bin = super::with_threads(params, || build::build(&mesh, params))?;
        Ok(Bvh2 {
            mesh,
            nodes: bin.nodes,
            prims: bin.prims,
            params: *params,
        })
    }

    /// The mesh.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// assert!(b.mesh().is_empty());
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Number of nodes (none for a mesh without a triangle to hit).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let m = packtrace::protocol::generate::sphere(100);
    /// assert!(Bvh2::build(m, &BvhBuildParams::median()).unwrap().node_count() > 10);
    /// ```
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The nodes, root first (read-only).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let m = packtrace::protocol::generate::sphere(100);
    /// let b = Bvh2::build(m, &BvhBuildParams::median()).unwrap();
    /// assert!(!b.nodes()[0].is_leaf());
    /// ```
    #[must_use]
    pub fn nodes(&self) -> &[Node2] {
        &self.nodes
    }

    /// The triangle order the leaves index (`prims()[node.index..]`).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let m = packtrace::protocol::generate::sphere(100);
    /// let b = Bvh2::build(m.clone(), &BvhBuildParams::median()).unwrap();
    /// assert_eq!(b.prims().len(), m.triangle_count());
    /// ```
    #[must_use]
    pub fn prims(&self) -> &[u32] {
        &self.prims
    }

    /// The box of the mesh.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// assert!(b.bounds().is_empty());
    /// ```
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.mesh.bounds()
    }

    /// The parameters it was built with.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let p = BvhBuildParams::median();
    /// assert_eq!(*Bvh2::build(packtrace::Mesh::default(), &p).unwrap().params(), p);
    /// ```
    #[must_use]
    pub fn params(&self) -> &BvhBuildParams {
        &self.params
    }

    /// Closest hit of `ray` (ties to the smaller triangle index), or `None`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh2::build(m, &BvhBuildParams::median()).unwrap();
    /// let r = packtrace::Ray::new(Vec3::new(2.0, 2.0, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// assert_eq!(b.intersect(&r), None);
    /// ```
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.trace_ray::<false, _>(ray, &mut NoCount)
    }

    /// Is there any hit in `(t_min, t_max]`?
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh2::build(m, &BvhBuildParams::median()).unwrap();
    /// let r = packtrace::Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// assert!(b.occluded(&r));
    /// ```
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.trace_ray::<true, _>(ray, &mut NoCount).is_some()
    }

    /// [`Bvh2::intersect`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(b.intersect_counted(&r, &mut s), None);
    /// assert_eq!(s.rays, 1);
    /// ```
    pub fn intersect_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> Option<Hit> {
        stats.rays += 1;
        self.trace_ray::<false, _>(ray, stats)
    }

    /// [`Bvh2::occluded`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// assert!(!b.occluded_counted(&r, &mut s));
    /// ```
    pub fn occluded_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> bool {
        stats.rays += 1;
        self.trace_ray::<true, _>(ray, stats).is_some()
    }

    /// The scalar traversal with hooks `c`: the fast box test where the
    /// ray allows it, else the robust one (`slab.rs`).
    #[inline]
    pub(crate) fn trace_ray<const ANY: bool, C: Counters>(
        &self,
        ray: &Ray,
        c: &mut C,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let r = RayBoxes::with_magnitude(magnitude(&self.mesh.bounds()), ray);
        if r.fast {
            traverse::<_, ANY, C>(self, ray, &Fast1::new(&r), c)
        } else {
            traverse::<_, ANY, C>(self, ray, &Robust8::new(&r, ray), c)
        }
    }
}

/// One box against one ray: hit, and entry distance.
pub(crate) trait BoxTest {
    fn test(&self, n: &Node2, t_min: f32, t_max: f32) -> (bool, f32);
}

/// The fast test of one box (`slab.rs`), scalar.
pub(crate) struct Fast1 {
    near: [bool; 3],
    inv: [f32; 3],
    entry_inv: [f32; 3],
    exit_inv: [f32; 3],
}

impl Fast1 {
    #[inline(always)]
    fn new(r: &RayBoxes) -> Fast1 {
        Fast1 {
            near: r.neg,
            inv: r.inv,
            entry_inv: [0, 1, 2].map(|a| r.entry[a] * r.inv[a]),
            exit_inv: [0, 1, 2].map(|a| r.exit[a] * r.inv[a]),
        }
    }
}

impl BoxTest for Fast1 {
    #[inline(always)]
    fn test(&self, n: &Node2, t_min: f32, t_max: f32) -> (bool, f32) {
        let (mut t0, mut t1) = (t_min, t_max);
        for a in 0..3 {
            let (near, far) = if self.near[a] {
                (n.hi[a], n.lo[a])
            } else {
                (n.lo[a], n.hi[a])
            };
            t0 = t0.max(near * self.inv[a] - self.entry_inv[a]);
            t1 = t1.min(far * self.inv[a] - self.exit_inv[a]);
        }
        (t0 <= t1, t0)
    }
}

impl BoxTest for Robust8 {
    #[inline(always)]
    fn test(&self, n: &Node2, t_min: f32, t_max: f32) -> (bool, f32) {
        let (t0, t1) = self.interval(n.lo, n.hi, t_min, t_max);
        (t0 <= t1, t0 as f32)
    }
}

/// The binary tree's single-ray traversal for any box test.
#[inline]
fn traverse<B: BoxTest, const ANY: bool, C: Counters>(
    bvh: &Bvh2,
    ray: &Ray,
    test: &B,
    c: &mut C,
) -> Option<Hit> {
    let nodes = &bvh.nodes[..];
    let mut best = Hit {
        t: ray.t_max(),
        prim: NO_PRIM,
        u: 0.0,
        v: 0.0,
    };
    let t_min = ray.t_min();
    if !test.test(&nodes[0], t_min, best.t).0 {
        return None;
    }
    let (sh, k) = triangle::shear(ray);
    let corners = bvh.mesh.corner_slice();
    let mut stack = Stack::<(u32, f32), { BVH_MAX_DEPTH as usize }>::new();
    let mut cur = 0usize;
    'trace: loop {
        let n = &nodes[cur];
        if n.is_leaf() {
            // Leaf: its triangles one at a time, as brute force tests them.
            c.leaf();
            let start = n.index as usize;
            for &prim in &bvh.prims[start..start + n.count as usize] {
                c.tri(1);
                let tri = &corners[prim as usize];
                let h = triangle::intersect(
                    &sh,
                    permute(tri[0], k),
                    permute(tri[1], k),
                    permute(tri[2], k),
                    t_min,
                    best.t,
                );
                if h.mask && (!C::FILTERS || c.accept(prim, h.t, h.u, h.v)) {
                    let cand = Hit {
                        t: h.t,
                        prim,
                        u: h.u,
                        v: h.v,
                    };
                    if ANY {
                        return Some(cand);
                    }
                    if cand.closer_than(&best) {
                        best = cand;
                    }
                }
            }
        } else {
            // Both children's boxes; the nearer first, the other deferred.
            c.node();
            let (l, r) = (cur + 1, n.index as usize);
            let (hl, tl) = test.test(&nodes[l], t_min, best.t);
            let (hr, tr) = test.test(&nodes[r], t_min, best.t);
            match (hl, hr) {
                (true, true) => {
                    let (near, far, t_far) = if tl <= tr { (l, r, tr) } else { (r, l, tl) };
                    stack.push((far as u32, t_far));
                    cur = near;
                    continue;
                }
                (true, false) => {
                    cur = l;
                    continue;
                }
                (false, true) => {
                    cur = r;
                    continue;
                }
                (false, false) => {}
            }
        }
        // The next deferred child that may still hold a closer hit.
        loop {
            let Some((i, t)) = stack.pop() else {
                break 'trace;
            };
            if ANY || t <= best.t {
                cur = i as usize;
                continue 'trace;
            }
        }
    }
    (best.prim != NO_PRIM).then_some(best)
}

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

/// The binary tree's packet traversal, for a packet whose active lanes
/// share their direction signs and take the fast box test (as the 8-wide
/// tree's, `packet.rs`, with two children per node).
#[inline(always)]
pub(crate) fn traverse_packet<L: Lane, const ANY: bool, C: Counters>(
    bvh: &Bvh2,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    let mut out = HitPacket::default();
    let active = p.active();
    if active == 0 || bvh.nodes.is_empty() {
        return out;
    }
    let nodes = &bvh.nodes[..];
    let lb: LaneBoxes<L> = lane_boxes(&bvh.mesh.bounds(), p);
    let sh: PacketShear<L> = p.shear();
    let corners = bvh.mesh.corner_slice();
    let (t_min, inf, neg_inf) = (
        p.t_min(),
        L::splat(f32::INFINITY),
        L::splat(f32::NEG_INFINITY),
    );
    let mut best_t = p.t_max();
    let mut best_prim = L::index_splat(NO_PRIM);
    let (mut best_u, mut best_v) = (L::splat(0.0), L::splat(0.0));
    let mut found = 0u32;
    // The lanes that meet a node's box, and their nearest entry. (A
    // function, not a closure: LLVM outlined the closure from the kernels
    // as baseline code.)
    #[inline(always)]
    fn meet<L: Lane>(lb: &LaneBoxes<L>, n: &Node2, lanes: u32, t_min: L, best_t: L) -> (u32, f32) {
        let (t0, t1) = lb.interval(n.lo, n.hi, t_min, best_t);
        let lanes = L::bits(t0.le(t1)) & lanes;
        let t0 = L::select(L::mask_from_bits(lanes), t0, L::splat(f32::INFINITY));
        let mut t = f32::INFINITY;
        for l in 0..L::WIDTH {
            let x = t0.lane(l);
            t = if x < t { x } else { t };
        }
        (lanes, t)
    }
    let (root_lanes, _) = meet(&lb, &nodes[0], active, t_min, best_t);
    if root_lanes == 0 {
        return out;
    }
    let mut stack = Stack::<(u32, u32, f32), { BVH_MAX_DEPTH as usize }>::new();
    let (mut cur, mut lanes) = (0usize, root_lanes);
    'trace: loop {
        let n = &nodes[cur];
        if n.is_leaf() {
            c.leaf();
            let start = n.index as usize;
            for &prim in &bvh.prims[start..start + n.count as usize] {
                c.tri(lanes.count_ones());
                let tri = &corners[prim as usize];
                let h = triangle::intersect(
                    &sh.shear,
                    sh.corner(&tri[0]),
                    sh.corner(&tri[1]),
                    sh.corner(&tri[2]),
                    t_min,
                    best_t,
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
                    let new = hits & !found;
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
                    found |= new;
                    best_t = L::select(L::mask_from_bits(found), neg_inf, best_t);
                    if found == active {
                        return out;
                    }
                    continue;
                }
                let prim_l = L::index_splat(prim);
                let closer =
                    hit_mask & (h.t.lt(best_t) | (h.t.eq(best_t) & L::index_lt(prim_l, best_prim)));
                best_t = L::select(closer, h.t, best_t);
                best_u = L::select(closer, h.u, best_u);
                best_v = L::select(closer, h.v, best_v);
                best_prim = L::index_select(closer, prim_l, best_prim);
            }
        } else {
            c.node();
            let (l, r) = (cur + 1, n.index as usize);
            let (ml, tl) = meet(&lb, &nodes[l], lanes, t_min, best_t);
            let (mr, tr) = meet(&lb, &nodes[r], lanes, t_min, best_t);
            match (ml != 0, mr != 0) {
                (true, true) => {
                    let ((near, mn), (far, mf, t_far)) = if tl <= tr {
                        ((l, ml), (r, mr, tr))
                    } else {
                        ((r, mr), (l, ml, tl))
                    };
                    stack.push((far as u32, mf, t_far));
                    (cur, lanes) = (near, mn);
                    continue;
                }
                (true, false) => {
                    (cur, lanes) = (l, ml);
                    continue;
                }
                (false, true) => {
                    (cur, lanes) = (r, mr);
                    continue;
                }
                (false, false) => {}
            }
        }
        loop {
            let Some((i, m, t)) = stack.pop() else {
                break 'trace;
            };
            let m = m & L::bits(L::splat(t).le(best_t));
            if m != 0 {
                (cur, lanes) = (i as usize, m);
                continue 'trace;
            }
        }
    }
    if !ANY {
        let hit = L::index_lt(best_prim, L::index_splat(NO_PRIM));
        out = HitPacket::from_lanes(L::select(hit, best_t, inf), best_prim, best_u, best_v);
    }
    out
}

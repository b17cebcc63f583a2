//! Scalar traversal: one ray, front to back, fixed stack (PBRT-v3
//! `KdTreeAccel::Intersect`; Wald's thesis 2004, section 7.3), with
//! near/far by the sign of the direction so that it reads like the packet
//! traversal beside it (`packet.rs`).

use super::KdTree;
use super::kernel::stack::Stack;
use super::layout::{Layout, LeafTri, NodeView, prefetch_corners};
use super::margin;
use super::params::MAX_DEPTH_LIMIT;
use super::stats::{Counters, NoCount, TraversalStats};
use crate::aabb::slab;
use crate::query::RayQuery;
use crate::ray::{Hit, NO_PRIM, Ray};
use crate::simd::Lane;
use crate::triangle::{self, permute};

/// A deferred far child and the ray's interval inside it.
#[derive(Clone, Copy)]
struct Entry<R> {
    node: R,
    t_min: f32,
    t_max: f32,
}

/// `[x, y, z, z]`: a per-axis table indexed by a node's 2-bit axis field
/// with no bounds check (four entries because the field has two bits, not
/// because of four lanes).
#[inline(always)]
pub(crate) fn by_axis<T: Copy>(a: [T; 3]) -> [T; 4] {
    [a[0], a[1], a[2], a[2]]
}

impl KdTree {
    /// Closest hit of `ray` (ties to the smaller triangle index), or `None`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(2.0, 2.0, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
    /// assert_eq!(t.intersect(&r), None);
    /// ```
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        traverse::<_, false, _>(self, ray, &mut NoCount)
    }

    /// Is there any hit in `(t_min, t_max]`? Stops at the first one found.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 0.5).unwrap();
    /// assert!(!t.occluded(&r));
    /// ```
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        traverse::<_, true, _>(self, ray, &mut NoCount).is_some()
    }

    /// [`KdTree::intersect`], adding its work to `stats`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(t.intersect_counted(&r, &mut s), None);
    /// assert_eq!(s.rays, 1);
    /// ```
    pub fn intersect_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> Option<Hit> {
        stats.rays += 1;
        traverse::<_, false, _>(self, ray, stats)
    }

    /// [`KdTree::occluded`], adding its work to `stats`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// assert!(!t.occluded_counted(&r, &mut s));
    /// ```
    pub fn occluded_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> bool {
        stats.rays += 1;
        traverse::<_, true, _>(self, ray, stats).is_some()
    }
}

impl RayQuery for KdTree {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        KdTree::intersect(self, ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        KdTree::occluded(self, ray)
    }
}

/// Stack size for trees of depth limit up to 32: every tree of the
/// default depth rule (`6 + log2 N`) below about 9 x 10^7 triangles, and
/// of PBRT's (`8 + 1.3 log2 N`) below about 200,000.
pub(crate) const SMALL_STACK: usize = 32;

/// The one scalar traversal, for any node layout; `ANY` selects occlusion
/// (first hit wins) over closest hit.
#[inline]
pub(crate) fn traverse<T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    ray: &Ray,
    c: &mut C,
) -> Option<Hit> {
    // A leaf at depth d has at most d far children deferred above it.
    if tree.depth_limit() as usize <= SMALL_STACK {
        traverse_with::<T, ANY, C, SMALL_STACK>(tree, ray, c)
    } else {
        traverse_with::<T, ANY, C, { MAX_DEPTH_LIMIT as usize }>(tree, ray, c)
    }
}

/// What the walk needs of a ray beyond its interval, computed once per
/// ray: the origins moved by the margin, the reciprocal direction and its
/// signs (per-axis tables, [`by_axis`]), the triangle test's shear and
/// permutation, and the ray's own `t_min` (every triangle is tested over
/// the ray's whole interval). The stream traversal (`stream/`) keeps the
/// same values per ray and finishes sparse subsets with [`walk`].
#[derive(Clone, Copy)]
pub(crate) struct RayConsts {
    pub entry_org: [f32; 4],
    pub exit_org: [f32; 4],
    pub inv_dir: [f32; 4],
    pub neg: [bool; 4],
    pub shear: triangle::Shear<f32>,
    pub k: [usize; 3],
    pub t_min: f32,
}

/// [`traverse`] with a stack of `N` entries (`N >=` the tree's depth limit).
#[inline]
fn traverse_with<T: Layout, const ANY: bool, C: Counters, const N: usize>(
    tree: &T,
    ray: &Ray,
    c: &mut C,
) -> Option<Hit> {
    let org = ray.origin.to_array();
    let inv_dir = ray.inv_dir.to_array();
    let neg = ray.dir_neg();
    // Every cell widened by the margin in space (`margin.rs`): rounding
    // never skips a grazed cell, nor the cell of a hit at the interval's end.
    let org_m = margin::shifted(tree.bounds(), &org, &neg);
    let (_, t_min, t_max) = slab(
        tree.bounds(),
        &org_m.entry,
        &org_m.exit,
        &inv_dir,
        &neg,
        ray.t_min,
        ray.t_max,
    );
    if !Lane::le(t_min, t_max) {
        return None;
    }
    let (shear, k) = triangle::shear(ray);
    let rc = RayConsts {
        entry_org: by_axis(org_m.entry),
        exit_org: by_axis(org_m.exit),
        inv_dir: by_axis(inv_dir),
        neg: by_axis(neg),
        shear,
        k,
        t_min: ray.t_min,
    };
    let best = Hit {
        t: ray.t_max,
        prim: NO_PRIM,
        u: 0.0,
        v: 0.0,
    };
    let best = walk::<T, ANY, C, N>(tree, rc, tree.root(), t_min, t_max, best, c);
    (best.prim != NO_PRIM).then_some(best)
}

/// The walk itself: from `node`, whose cell the ray crosses over
/// `[t_min, t_max]` (cells widened by the margin), front to back, with the
/// closest hit so far `best` (`prim == NO_PRIM`: none; `best.t` bounds the
/// triangle tests). Returns the closest hit of the subtree and `best`; for
/// occlusion, the first hit found (or `best` unchanged).
#[inline(always)]
pub(crate) fn walk<T: Layout, const ANY: bool, C: Counters, const N: usize>(
    tree: &T,
    rc: RayConsts,
    node: T::Ref,
    t_min: f32,
    t_max: f32,
    best: Hit,
    c: &mut C,
) -> Hit {
    let (mut node, mut t_min, mut t_max, mut best) = (node, t_min, t_max, best);
    // By value and taken apart: passed by reference, the constants were
    // written to the stack and read back (+1.7 % instructions per scalar
    // ray, callgrind).
    let RayConsts {
        entry_org,
        exit_org,
        inv_dir: inv_dir_ax,
        neg: neg_ax,
        shear,
        k,
        t_min: ray_t_min,
    } = rc;
    let corners = tree.mesh().corner_slice();
    let mut stack = Stack::<Entry<T::Ref>, N>::new();
    loop {
        match tree.view(node) {
            NodeView::Interior {
                axis,
                split,
                below,
                above,
            } => {
                c.node();
                // Near and far child, by the direction's sign on the axis.
                let (near, far) = if neg_ax[axis] {
                    (above, below)
                } else {
                    (below, above)
                };
                // Where the ray leaves the near child and enters the far
                // one, each side widened by the margin (margin.rs). A NaN
                // (ray in the plane, zero margin) keeps the interval whole
                // on both sides (`min_keep`/`max_keep`, one minss/maxss).
                let near_t_max = t_max.min_keep((split - exit_org[axis]) * inv_dir_ax[axis]);
                let far_t_min = t_min.max_keep((split - entry_org[axis]) * inv_dir_ax[axis]);
                let go_near = t_min <= near_t_max;
                let go_far = far_t_min <= t_max;
                // Three-way step: both (defer far), near only, far only.
                // Measured and rejected (docs/packets-and-kernels.md,
                // "The node step"): writing the far entry
                // unconditionally and advancing `sp` by `go_far` (+1.5 %
                // instructions, 20 % slower on Sponza primary rays).
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
                // Neither child: the interval is empty on both sides of the
                // plane; fall through to the next deferred cell.
            }
            NodeView::Leaf(prims) => {
                // Leaf: every triangle over the ray's whole interval, so a
                // hit is found in any cell that references its triangle.
                c.leaf();
                prefetch_corners(prims, corners);
                for r in prims {
                    c.tri(1);
                    let (prim, tri) = (r.prim(), r.corners(corners));
                    let h = triangle::intersect(
                        &shear,
                        permute(tri[0], k),
                        permute(tri[1], k),
                        permute(tri[2], k),
                        ray_t_min,
                        best.t,
                    );
                    // An any-hit filter (scenes only) may reject the hit.
                    if h.mask && (!C::FILTERS || c.accept(prim, h.t, h.u, h.v)) {
                        let cand = Hit {
                            t: h.t,
                            prim,
                            u: h.u,
                            v: h.v,
                        };
                        if ANY {
                            return cand;
                        }
                        if cand.closer_than(&best) {
                            best = cand;
                        }
                    }
                }
            }
        }
        // Pop: the next deferred cell; skip cells that start beyond the
        // closest hit. Whether "beyond" is strict makes no difference since
        // the margin (margin.rs): a widened boundary lies eta outside its
        // cell, so a hit exactly there lies in the neighbouring cell, which
        // references its triangle too; mutation testing confirms both forms
        // pass every test (docs/testing.md, "Mutation testing").
        loop {
            let Some(e) = stack.pop() else {
                return best;
            };
            if ANY || e.t_min <= best.t {
                node = e.node;
                t_min = e.t_min;
                t_max = e.t_max.min_keep(best.t);
                break;
            }
        }
    }
}

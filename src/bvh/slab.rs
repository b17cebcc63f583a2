//! The BVHs' box tests, conservative so that no box holding a hit the
//! triangle routine reports is ever missed (`ARCHITECTURE.md`,
//! "Robustness of the traversal").
//!
//! **The margin.** As in the kd-tree (`kdtree/margin.rs`), every box is
//! entered as if it were `eta = MARGIN * M` larger on each side, `M` the
//! largest coordinate magnitude of the ray origin and the scene box: the
//! triangle routine keeps the point of the ray at every `t` it reports
//! within `7/8 eta` of the triangle on every axis, so within `7/8 eta` of
//! every box holding it. The origin is moved by `eta` once per ray,
//! forwards for the entry planes and backwards for the exit planes.
//!
//! **The fast test** (Williams et al. 2005; Embree, tinybvh) computes a
//! plane's distance as `plane * inv_dir - org * inv_dir`, the product
//! `org * inv_dir` taken once per ray, with or without a fused
//! multiply-add. Its rounding, against the exact `(plane - org) / dir`:
//! `inv_dir` is off by `2^-24` relatively, each product and the difference
//! by half an ulp of values at most `|inv_dir| * 2M`, the shifted origin
//! by half an ulp of `M`; along the axis (times `|dir|`) that is below
//! `6 * 2^-24 M`, far inside the `eta / 8 = 2^-19 M` the triangle routine
//! leaves. The bound needs normal, finite values, so a ray takes the fast
//! test only when `|inv_dir|` lies in `[2^-60, 2^60]` on every axis (no
//! zero direction component), `M >= 2^-60` and `M * max |inv_dir| <=
//! 2^100` (no product can overflow; a subnormal one is off by at most
//! `2^-150`, i.e. `2^-90` along the axis, below `2^-19 M`).
//!
//! **The robust test** serves every other ray (zero direction components,
//! coordinates near `f32::MAX` or below `2^-60`): the same planes in f64,
//! `(plane - org) * (1 / dir)`, which neither overflows nor loses a
//! subnormal. A NaN (`0 * inf`: a zero direction component and an origin
//! exactly on a shifted plane) leaves that axis unconstrained; such an
//! origin lies `eta` outside the box, where no hit can be, so either
//! answer would do.

use super::Bvh8;
use super::node::Node8;
use crate::aabb::Aabb;
use crate::packet::RayPacket;
use crate::ray::Ray;
use crate::simd::{F8, Lane};
use crate::triangle::MARGIN;
use std::marker::PhantomData;

/// Per-ray constants of the box tests.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayBoxes {
    /// The origin moved forwards by the margin (entry planes).
    pub entry: [f32; 3],
    /// The origin moved backwards by the margin (exit planes).
    pub exit: [f32; 3],
    /// `1 / dir` (the ray's exact reciprocal).
    pub inv: [f32; 3],
    /// Per axis: the direction's sign bit is set (near plane: the upper).
    pub neg: [bool; 3],
    /// May the fast test be used (see the module's bounds)?
    pub fast: bool,
}

/// The largest coordinate magnitude of a box (`M`'s share from the scene).
#[inline]
pub(crate) fn magnitude(b: &Aabb) -> f32 {
    b.min.abs().max(b.max.abs()).max_element()
}

/// `2^k` as `f32`.
const fn pow2(k: i32) -> f32 {
    f32::from_bits(((127 + k) as u32) << 23)
}

impl RayBoxes {
    /// The constants of `ray` in `bvh` (whose root box's largest
    /// coordinate magnitude is precomputed).
    #[inline(always)]
    pub(crate) fn new(bvh: &Bvh8, ray: &Ray) -> RayBoxes {
        RayBoxes::with_magnitude(bvh.box_magnitude, ray)
    }

    /// The constants of `ray` in a tree whose root box has the largest
    /// coordinate magnitude `box_m`.
    #[inline(always)]
    pub(crate) fn with_magnitude(box_m: f32, ray: &Ray) -> RayBoxes {
        // `maxss` semantics (`a > b ? a : b`), one instruction: `f32::max`
        // adds a NaN check. A NaN origin or direction (an invalid ray built
        // unchecked) fails the fast test below and never hits.
        #[inline(always)]
        fn max(a: f32, b: f32) -> f32 {
            if a > b { a } else { b }
        }
        #[inline(always)]
        fn min(a: f32, b: f32) -> f32 {
            if a < b { a } else { b }
        }
        let org = ray.origin().to_array();
        let inv = ray.inv_dir().to_array();
        let neg = ray.dir_neg();
        let m = max(max(box_m, org[0].abs()), max(org[1].abs(), org[2].abs()));
        let eta = m * MARGIN;
        let fwd = [0, 1, 2].map(|a| if neg[a] { -eta } else { eta });
        let abs_inv = [inv[0].abs(), inv[1].abs(), inv[2].abs()];
        let lo = min(min(abs_inv[0], abs_inv[1]), abs_inv[2]);
        let hi = max(max(abs_inv[0], abs_inv[1]), abs_inv[2]);
        // Written so that NaN and infinity fail every comparison.
        let fast = lo >= pow2(-60) && hi <= pow2(60) && m >= pow2(-60) && m * hi <= pow2(100);
        RayBoxes {
            entry: [0, 1, 2].map(|a| org[a] + fwd[a]),
            exit: [0, 1, 2].map(|a| org[a] - fwd[a]),
            inv,
            neg,
            fast,
        }
    }
}

/// `a * b - c` lane by lane: two roundings, or one (a fused multiply-add,
/// only inside kernels compiled with FMA: elsewhere `mul_add` is a library
/// call). Either is conservative with the margin (module docs).
pub(crate) trait Fms: Copy {
    /// `a * b - c`.
    fn fms(a: F8, b: F8, c: F8) -> F8;
}

/// Multiply, then subtract.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plain;

impl Fms for Plain {
    #[inline(always)]
    fn fms(a: F8, b: F8, c: F8) -> F8 {
        a * b - c
    }
}

/// One fused multiply-add (`vfmsub` in an FMA kernel). The AVX kernels
/// now use their own intrinsics test (`kdtree/kernel/bvh.rs`); this one
/// stays as the generic form the tests hold to the margin.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fused;

#[cfg(test)]
impl Fms for Fused {
    #[inline(always)]
    fn fms(a: F8, b: F8, c: F8) -> F8 {
        let (a, b, c) = (a.to_array(), b.to_array(), c.to_array());
        F8::from(std::array::from_fn(|i| a[i].mul_add(b[i], -c[i])))
    }
}

/// A test of an 8-wide node's eight child boxes against one ray: the hit
/// mask (bit `i`: slot `i` meets the ray within `[t_min, t_max]`) and the
/// entry distances.
pub(crate) trait NodeTest {
    fn test(&self, node: &Node8, t_min: f32, t_max: f32) -> (u32, F8);
}

/// The fast test ([module docs](self)): six multiply-subtracts against the
/// ray's precomputed `org * inv_dir`, near and far planes chosen once per
/// ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fast8<M: Fms> {
    /// Per axis, the side of the near plane (`true`: the upper).
    near: [bool; 3],
    inv: [F8; 3],
    /// `entry * inv` and `exit * inv` per axis.
    entry_inv: [F8; 3],
    exit_inv: [F8; 3],
    _m: PhantomData<M>,
}

impl<M: Fms> Fast8<M> {
    /// The test of `r` (whose `fast` is set).
    #[inline(always)]
    pub(crate) fn new(r: &RayBoxes) -> Self {
        Fast8 {
            near: r.neg,
            inv: r.inv.map(F8::splat),
            entry_inv: [0, 1, 2].map(|a| F8::splat(r.entry[a] * r.inv[a])),
            exit_inv: [0, 1, 2].map(|a| F8::splat(r.exit[a] * r.inv[a])),
            _m: PhantomData,
        }
    }
}

impl<M: Fms> NodeTest for Fast8<M> {
    #[inline(always)]
    fn test(&self, node: &Node8, t_min: f32, t_max: f32) -> (u32, F8) {
        let p = &node.planes;
        let n = self.near;
        // Entry and exit distance of each axis's slab, eight children at
        // once; the far plane is the other side.
        let t0x = M::fms(p[0][n[0] as usize], self.inv[0], self.entry_inv[0]);
        let t0y = M::fms(p[1][n[1] as usize], self.inv[1], self.entry_inv[1]);
        let t0z = M::fms(p[2][n[2] as usize], self.inv[2], self.entry_inv[2]);
        let t1x = M::fms(p[0][!n[0] as usize], self.inv[0], self.exit_inv[0]);
        let t1y = M::fms(p[1][!n[1] as usize], self.inv[1], self.exit_inv[1]);
        let t1z = M::fms(p[2][!n[2] as usize], self.inv[2], self.exit_inv[2]);
        // No NaN here (finite products, inverted empty slots give +-inf),
        // so `max_keep`/`min_keep` are plain `maxps`/`minps`.
        let t0 = t0x.max_keep(t0y).max_keep(t0z).max_keep(F8::splat(t_min));
        let t1 = t1x.min_keep(t1y).min_keep(t1z).min_keep(F8::splat(t_max));
        (F8::bits(t0.le(t1)), t0)
    }
}

/// The robust test ([module docs](self)) in f64.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Robust8 {
    entry: [f64; 3],
    exit: [f64; 3],
    inv: [f64; 3],
    near: [bool; 3],
}

impl Robust8 {
    /// The test of `r`.
    #[inline(always)]
    pub(crate) fn new(r: &RayBoxes, ray: &Ray) -> Self {
        let d = ray.dir().to_array();
        Robust8 {
            entry: r.entry.map(f64::from),
            exit: r.exit.map(f64::from),
            inv: d.map(|x| 1.0 / f64::from(x)),
            near: r.neg,
        }
    }

    /// One box's `(entry, exit)` within `[t_min, t_max]`; NaN distances
    /// (an axis the ray lies in a plane of) leave the interval alone.
    #[inline(always)]
    pub(crate) fn interval(
        &self,
        lo: [f32; 3],
        hi: [f32; 3],
        t_min: f32,
        t_max: f32,
    ) -> (f64, f64) {
        let (mut t0, mut t1) = (f64::from(t_min), f64::from(t_max));
        for a in 0..3 {
            let (near, far) = if self.near[a] {
                (hi[a], lo[a])
            } else {
                (lo[a], hi[a])
            };
            // `f64::max`/`min` return the other operand for a NaN.
            t0 = t0.max((f64::from(near) - self.entry[a]) * self.inv[a]);
            t1 = t1.min((f64::from(far) - self.exit[a]) * self.inv[a]);
        }
        (t0, t1)
    }
}

impl NodeTest for Robust8 {
    #[inline(never)]
    fn test(&self, node: &Node8, t_min: f32, t_max: f32) -> (u32, F8) {
        let p = &node.planes;
        let lane = |a: usize, side: usize, i: usize| p[a][side].to_array()[i];
        let mut mask = 0;
        let mut t = [0.0f32; 8];
        for (i, ti) in t.iter_mut().enumerate() {
            let lo = [lane(0, 0, i), lane(1, 0, i), lane(2, 0, i)];
            let hi = [lane(0, 1, i), lane(1, 1, i), lane(2, 1, i)];
            let (t0, t1) = self.interval(lo, hi, t_min, t_max);
            // Rounded to nearest: an entry at or below an f32 hit distance
            // stays at or below it.
            *ti = t0 as f32;
            mask |= u32::from(t0 <= t1) << i;
        }
        (mask, F8::from(t))
    }
}

/// The fast test's per-lane constants of a packet whose active lanes
/// share their direction signs: a box's interval for all lanes at once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneBoxes<L: Lane> {
    near: [bool; 3],
    inv: [L; 3],
    entry_inv: [L; 3],
    exit_inv: [L; 3],
    /// Lanes that may take the fast test (the others go ray by ray).
    pub fast: u32,
}

/// [`RayBoxes::new`] for every lane of `p`, in a tree whose root box is
/// `bounds`.
#[inline(always)]
pub(crate) fn lane_boxes<L: Lane>(bounds: &Aabb, p: &RayPacket<L>) -> LaneBoxes<L> {
    let (org, inv) = (p.org(), p.inv_dir());
    let neg = p.neg_bits().map(|b| b != 0);
    let box_m = bounds.min.abs().max(bounds.max.abs()).max_element();
    let m = L::splat(box_m)
        .max_keep(org[0].abs())
        .max_keep(org[1].abs())
        .max_keep(org[2].abs());
    let eta = m * L::splat(MARGIN);
    let zero = L::splat(0.0);
    let fwd = [0, 1, 2].map(|a| if neg[a] { zero - eta } else { eta });
    let abs_inv = [inv[0].abs(), inv[1].abs(), inv[2].abs()];
    let hi = abs_inv[0].max_keep(abs_inv[1]).max_keep(abs_inv[2]);
    let lo = abs_inv[0].min_keep(abs_inv[1]).min_keep(abs_inv[2]);
    let fast = L::splat(pow2(-60)).le(lo)
        & hi.le(L::splat(pow2(60)))
        & L::splat(pow2(-60)).le(m)
        & (m * hi).le(L::splat(pow2(100)));
    LaneBoxes {
        near: neg,
        inv: *inv,
        entry_inv: [0, 1, 2].map(|a| (org[a] + fwd[a]) * inv[a]),
        exit_inv: [0, 1, 2].map(|a| (org[a] - fwd[a]) * inv[a]),
        fast: L::bits(fast) & p.active(),
    }
}

impl<L: Lane> LaneBoxes<L> {
    /// The lanes' `(entry, exit)` of the box `lo..hi` within
    /// `[t_min, t_max]` (meaningful for fast lanes only).
    #[inline(always)]
    pub(crate) fn interval(&self, lo: [f32; 3], hi: [f32; 3], t_min: L, t_max: L) -> (L, L) {
        let (mut t0, mut t1) = (t_min, t_max);
        for a in 0..3 {
            let (near, far) = if self.near[a] {
                (hi[a], lo[a])
            } else {
                (lo[a], hi[a])
            };
            t0 = t0.max_keep(L::splat(near) * self.inv[a] - self.entry_inv[a]);
            t1 = t1.min_keep(L::splat(far) * self.inv[a] - self.exit_inv[a]);
        }
        (t0, t1)
    }
}

/// Bounds of a packet's per-lane box constants over its active lanes: the
/// packet's frustum in interval arithmetic (Reshetov, Soupikov and Hurley
/// 2005; Embree's coherent packets), which tests the eight children of a
/// node for the whole packet in one 8-wide step.
///
/// Conservative: `x -> plane * x` is monotone and rounding is monotone,
/// so `min(plane * inv_lo, plane * inv_hi) - entry_hi` is at most every
/// lane's `plane * inv - entry_inv` as the lanes compute it, and the
/// maximum over axes of these lower bounds is at most every lane's entry
/// (a maximum over axes of minima over lanes is at most the minimum over
/// lanes of maxima over axes); likewise for the exits. A child the
/// frustum misses is missed by every lane's own test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frustum {
    near: [bool; 3],
    inv_lo: [F8; 3],
    inv_hi: [F8; 3],
    entry_hi: [F8; 3],
    exit_lo: [F8; 3],
}

/// The smallest (or, with `hi`, the largest) value of `v` over `lanes`
/// (infinity, or minus infinity, for no lane).
#[inline(always)]
pub(crate) fn extreme<L: Lane>(v: L, lanes: u32, hi: bool) -> f32 {
    let mut x = if hi { f32::NEG_INFINITY } else { f32::INFINITY };
    let mut left = lanes;
    while left != 0 {
        let i = left.trailing_zeros() as usize;
        left &= left - 1;
        let y = v.lane(i);
        x = if hi == (y > x) { y } else { x };
    }
    x
}

impl<L: Lane> LaneBoxes<L> {
    /// The frustum of the lanes `lanes` (non-empty, all fast).
    #[inline(always)]
    pub(crate) fn frustum(&self, lanes: u32) -> Frustum {
        let reduce = |v: L, hi: bool| F8::splat(extreme(v, lanes, hi));
        Frustum {
            near: self.near,
            inv_lo: self.inv.map(|v| reduce(v, false)),
            inv_hi: self.inv.map(|v| reduce(v, true)),
            entry_hi: self.entry_inv.map(|v| reduce(v, true)),
            exit_lo: self.exit_inv.map(|v| reduce(v, false)),
        }
    }
}

impl Frustum {
    /// The children of `node` the frustum meets within `[t_lo, t_hi]`
    /// (the lanes' smallest `t_min` and largest bound), as bits.
    #[inline(always)]
    pub(crate) fn test(&self, node: &Node8, t_lo: f32, t_hi: f32) -> u32 {
        let (mut t0, mut t1) = (F8::splat(t_lo), F8::splat(t_hi));
        for a in 0..3 {
            let [lo, hi] = node.planes[a];
            let (near, far) = if self.near[a] { (hi, lo) } else { (lo, hi) };
            let (n0, n1) = (near * self.inv_lo[a], near * self.inv_hi[a]);
            let (f0, f1) = (far * self.inv_lo[a], far * self.inv_hi[a]);
            t0 = t0.max_keep(n0.min_keep(n1) - self.entry_hi[a]);
            t1 = t1.min_keep(f0.max_keep(f1) - self.exit_lo[a]);
        }
        F8::bits(t0.le(t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::node::ChildRef;
    use glam::{Vec3, Vec3A};

    fn node(boxes: &[Aabb]) -> Node8 {
        let mut n = Node8::empty();
        for (i, b) in boxes.iter().enumerate() {
            n.set_child(i, ChildRef::node(i as u32), b, 1);
        }
        n
    }

    /// Both tests agree with the exact slab test of boxes widened by the
    /// margin where they are far from its edge, on rays of every octant.
    #[test]
    fn fast_and_robust_tests_agree_away_from_the_margin() {
        let boxes: Vec<Aabb> = (0..7)
            .map(|i| {
                let c = Vec3A::new(i as f32 - 3.0, (i * i) as f32 * 0.25 - 2.0, 0.5 * i as f32);
                Aabb::new(c - 0.4, c + 0.6)
            })
            .collect();
        let n = node(&boxes);
        let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        for k in 0..64 {
            // Half steps: no direction component is zero (that ray takes
            // the robust test alone, tested below).
            let f = k as f32 + 0.5;
            let dir = Vec3::new((f * 0.7).sin(), (f * 1.3).cos(), (f * 0.3).sin() + 0.05);
            let org = Vec3::new(-6.0 + 0.1 * f, 4.0 - 0.05 * f, -3.0);
            let ray = Ray::new(org, dir, 0.0, f32::INFINITY).unwrap();
            let r = RayBoxes::with_magnitude(magnitude(&bounds), &ray);
            assert!(r.fast, "ray {k}: {r:?} {ray:?}");
            let (m1, t1) = Fast8::<Plain>::new(&r).test(&n, 0.0, 100.0);
            let (m2, t2) = Fast8::<Fused>::new(&r).test(&n, 0.0, 100.0);
            let (m3, t3) = Robust8::new(&r, &ray).test(&n, 0.0, 100.0);
            for (i, b) in boxes.iter().enumerate() {
                let exact = b.intersect(&ray.with_interval(0.0, 100.0).unwrap());
                if let Some((t0, _)) = exact {
                    for (m, t) in [(m1, t1), (m2, t2), (m3, t3)] {
                        assert!(m >> i & 1 == 1, "ray {k} box {i}");
                        assert!(t.to_array()[i] <= t0, "ray {k} box {i}");
                    }
                }
            }
            assert_eq!(m1 >> 7, 0, "the empty slot is never met");
            assert_eq!((m2 >> 7, m3 >> 7), (0, 0));
        }
    }

    /// The frustum never misses a child that one of the packet's lanes
    /// meets (its own per-lane test), for packets of every octant, spread
    /// from nearly parallel to widely divergent, with inactive lanes,
    /// boxes near and far, and bounds that cut the intervals.
    #[test]
    fn frustum_meets_every_child_a_lane_meets() {
        use crate::packet::RayPacket;
        let mut boxes: Vec<Aabb> = (0..7)
            .map(|i| {
                let c = Vec3A::new(i as f32 - 3.0, (i * i) as f32 * 0.25 - 2.0, 0.5 * i as f32);
                Aabb::new(c - 0.05 * (i + 1) as f32, c + 0.3)
            })
            .collect();
        boxes.push(Aabb::new(Vec3A::splat(-0.01), Vec3A::splat(0.01)));
        let n = node(&boxes);
        let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let (mut met, mut culled) = (0, 0);
        for k in 0..2048 {
            let f = k as f32 + 0.5;
            let octant = k % 8;
            let sign = |b: usize| if octant >> b & 1 == 1 { -1.0 } else { 1.0 };
            let spread = [0.001, 0.05, 0.5, 3.0][k / 8 % 4];
            let p = RayPacket::<F8>::from_fn(|i| {
                if (k + i) % 7 == 3 {
                    return None;
                }
                let g = f + i as f32 * 0.37;
                let dir = Vec3::new(
                    sign(0) * (0.2 + spread * (g * 0.7).sin().abs()),
                    sign(1) * (0.3 + spread * (g * 1.3).cos().abs()),
                    sign(2) * (0.1 + spread * (g * 0.3).sin().abs()),
                );
                // Aimed at one of the boxes, so that lanes meet children.
                let b = &boxes[k / 32 % 8];
                let target = Vec3::from((b.min + b.max) * 0.5);
                let org = target - dir.normalize() * 8.0
                    + Vec3::new((g * 0.9).sin(), (g * 0.4).cos(), (g * 1.7).sin()) * spread;
                let t_max = if k % 3 == 0 {
                    9.0 + (g * 2.1).sin()
                } else {
                    f32::INFINITY
                };
                Some(Ray::new(org, dir, 0.1 * (k % 2) as f32, t_max).unwrap())
            });
            let lb = lane_boxes(&bounds, &p);
            let active = p.active() & lb.fast;
            if active == 0 {
                continue;
            }
            let fr = lb.frustum(active);
            let t_lo = extreme(p.t_min(), active, false);
            let t_hi = extreme(p.t_max(), active, true);
            let fmask = fr.test(&n, t_lo, t_hi);
            for (i, b) in boxes.iter().enumerate() {
                let lo = b.min.to_array();
                let hi = b.max.to_array();
                let (t0, t1) = lb.interval(lo, hi, p.t_min(), p.t_max());
                let lanes = F8::bits(t0.le(t1)) & active;
                if lanes != 0 {
                    met += 1;
                    assert!(fmask >> i & 1 == 1, "packet {k} child {i}: lanes {lanes:b}");
                } else if fmask >> i & 1 == 0 {
                    culled += 1;
                }
            }
        }
        // The test must see both outcomes to mean anything.
        assert!(met > 1000 && culled > 1000, "met {met}, culled {culled}");
    }

    #[test]
    fn zero_direction_components_take_the_robust_test() {
        let b = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
        let ray = Ray::new(Vec3::new(0.5, -3.0, 1.0), Vec3::Y, 0.0, f32::INFINITY).unwrap();
        let r = RayBoxes::with_magnitude(magnitude(&b), &ray);
        assert!(!r.fast);
        // Along the face x = ... inside; z = 1 is the box's face: inside.
        let (m, t) = Robust8::new(&r, &ray).test(&node(&[b]), 0.0, f32::INFINITY);
        assert_eq!(m, 1);
        assert!(t.to_array()[0] <= 2.0);
        // A little outside, beyond the margin: a miss.
        let ray = Ray::new(Vec3::new(0.5, -3.0, 1.01), Vec3::Y, 0.0, f32::INFINITY).unwrap();
        let r = RayBoxes::with_magnitude(magnitude(&b), &ray);
        assert_eq!(Robust8::new(&r, &ray).test(&node(&[b]), 0.0, 9.0).0, 0);
    }

    #[test]
    fn huge_coordinates_and_tiny_directions_take_the_robust_test() {
        let b = Aabb::new(Vec3A::splat(-3e38), Vec3A::splat(3e38));
        let ray = Ray::new(Vec3::ZERO, Vec3::ONE, 0.0, 1.0).unwrap();
        assert!(!RayBoxes::with_magnitude(magnitude(&b), &ray).fast);
        let small = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
        let ray = Ray::new(Vec3::ZERO, Vec3::new(1e-20, 1.0, 1.0), 0.0, 1.0).unwrap();
        assert!(!RayBoxes::with_magnitude(magnitude(&small), &ray).fast);
    }
}

//! Packet queries: the public packet entry points, and what stands in
//! front of the SIMD kernels. A packet is split by direction octant (each
//! sub-packet keeps one near/far order per axis, the other lanes masked
//! off), and a sub-packet of at most [`single_ray_lanes`] lanes is traced
//! with the single-ray traversal (Benthin, Wald, Woop, Ernst and Mark
//! 2012; Embree's hybrid traversal). Everything else goes to the kernel
//! chosen at run time (`kernel.rs`).

use super::KdTree;
use super::kernel;
use super::layout::Layout;
use super::scalar::traverse;
use super::stats::{Counters, NoCount, TraversalStats};
use crate::aabb::Aabb;
use crate::packet::{HitPacket, HitPacket4, HitPacket8, RayPacket, RayPacket4, RayPacket8};
use crate::query::PacketQuery;
use crate::ray::{Hit, Ray};
use crate::simd::Lane;

/// Sub-packets of a `width`-lane packet with at most this many active
/// lanes are traced ray by ray: 1 of 4, 3 of 8. Measured on the bunny's
/// and the teapot's ao and random rays with thresholds 1 to 4
/// (docs/packets-and-kernels.md): below half the width a packet step costs more than
/// the single-ray steps it replaces; at 4 of 8, 8-wide random rays were
/// no faster than at 3 and coherent sub-packets would lose their SIMD.
///
/// ```
/// use packtrace::kdtree::single_ray_lanes;
/// assert_eq!((single_ray_lanes(4), single_ray_lanes(8)), (1, 3));
/// ```
#[must_use]
pub const fn single_ray_lanes(width: usize) -> u32 {
    if width >= 4 {
        (width / 2 - 1) as u32
    } else {
        1
    }
}

impl KdTree {
    /// Closest hits of a packet of any width; lane `i` equals
    /// [`KdTree::intersect`] of ray `i`, bit for bit.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).ok();
    /// let h = t.intersect_packet(&RayPacket8::from_fn(|i| r(0.1 + 0.2 * i as f32)));
    /// assert_eq!(h.mask(), 0b0000_1111); // x + y <= 1 for the first four
    /// assert_eq!(h.hit(1), t.intersect(&r(0.3).unwrap()));
    /// ```
    #[must_use]
    pub fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>) -> HitPacket<L> {
        trace::<L, _, false, _>(self, p, &mut NoCount)
    }

    /// Occlusion of a packet of any width: bit `i` set when lane `i` is
    /// occluded. A lane retires at its first hit; the packet stops when
    /// all have.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).ok();
    /// assert_eq!(t.occluded_packet(&RayPacket8::from_fn(|i| r(0.3 * i as f32))), 0b0111);
    /// ```
    #[must_use]
    pub fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32 {
        trace::<L, _, true, _>(self, p, &mut NoCount).mask()
    }

    /// [`KdTree::intersect_packet`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, RayPacket8, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// t.intersect_packet_counted(&RayPacket8::from_lanes([None; 8]), &mut s);
    /// assert_eq!(s.packets, 1);
    /// ```
    pub fn intersect_packet_counted<L: Lane>(
        &self,
        p: &RayPacket<L>,
        stats: &mut TraversalStats,
    ) -> HitPacket<L> {
        stats.packets += 1;
        stats.rays += u64::from(p.active().count_ones());
        trace::<L, _, false, _>(self, p, stats)
    }

    /// [`KdTree::occluded_packet`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::{KdBuildParams, KdTree, Mesh, RayPacket4, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// assert_eq!(t.occluded_packet_counted(&RayPacket4::from_lanes([None; 4]), &mut s), 0);
    /// ```
    pub fn occluded_packet_counted<L: Lane>(
        &self,
        p: &RayPacket<L>,
        stats: &mut TraversalStats,
    ) -> u32 {
        stats.packets += 1;
        stats.rays += u64::from(p.active().count_ones());
        trace::<L, _, true, _>(self, p, stats).mask()
    }

    /// Closest hits of a 4-wide packet ([`KdTree::intersect_packet`]).
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
        self.intersect_packet(p)
    }

    /// Occlusion of a 4-wide packet ([`KdTree::occluded_packet`]).
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
        self.occluded_packet(p)
    }

    /// Closest hits of an 8-wide packet ([`KdTree::intersect_packet`]); AVX2
    /// when the CPU has it.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// assert_eq!(t.intersect8(&RayPacket8::from_rays(&[r; 8])).hit(7), t.intersect(&r));
    /// ```
    #[must_use]
    pub fn intersect8(&self, p: &RayPacket8) -> HitPacket8 {
        self.intersect_packet(p)
    }

    /// Occlusion of an 8-wide packet ([`KdTree::occluded_packet`]).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// assert_eq!(t.occluded8(&RayPacket8::from_slice(&[r; 6])), 0b11_1111);
    /// ```
    #[must_use]
    pub fn occluded8(&self, p: &RayPacket8) -> u32 {
        self.occluded_packet(p)
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
        self.intersect_packet_counted(p, stats)
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
        self.occluded_packet_counted(p, stats)
    }
}

impl PacketQuery for KdTree {
    fn intersect4(&self, packet: &RayPacket4) -> HitPacket4 {
        KdTree::intersect4(self, packet)
    }
    fn occluded4(&self, packet: &RayPacket4) -> u32 {
        KdTree::occluded4(self, packet)
    }
    fn intersect8(&self, packet: &RayPacket8) -> HitPacket8 {
        KdTree::intersect8(self, packet)
    }
    fn occluded8(&self, packet: &RayPacket8) -> u32 {
        KdTree::occluded8(self, packet)
    }
    fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        KdTree::intersect_rays(self, rays, hits);
    }
    fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        KdTree::occluded_rays(self, rays, occluded);
    }
}

/// The packet query for any node layout and lane type; `ANY` selects
/// occlusion over closest hit. Splits the packet by direction octant and
/// hands each part to the run-time kernel (`kernel.rs`), or to the
/// single-ray traversal when it has few lanes.
#[inline]
pub(crate) fn trace<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    // Every line of the packet requested at once, as the scene's packets
    // are (`Scene::trace_packet`): here within the noise (kd8 teapot
    // primary packet8, medians of 10 alternating runs: 30.3 -> 30.8
    // Mrays/s), kept so that the bare tree pays what an instance does.
    super::prefetch_all(p);
    let active = p.active();
    let [nx, ny, nz] = p.neg_bits();
    // Octant of each active lane, as three sign bits.
    let mixed = [nx, ny, nz].iter().any(|&b| b != 0 && b != active);
    if !mixed {
        return trace_octant::<L, T, ANY, C>(tree, p, c);
    }
    // Mixed signs and divergent lanes (ambient occlusion, random rays):
    // each lane alone, with no sub-packets to build.
    if p.dir_spread() > MAX_DIR_SPREAD {
        return single_rays::<L, T, ANY, C>(tree, p, active, c);
    }
    // Mixed signs: one sub-packet per octant present, the other lanes
    // masked off (their intervals emptied by `with_active`).
    c.octant_split();
    let mut out = HitPacket::default();
    for lanes in octants(p) {
        let h = trace_octant::<L, T, ANY, C>(tree, &p.with_active(lanes), c);
        out.merge(&h, lanes);
    }
    out
}

/// The active lanes of `p` by direction octant: one mask per octant
/// present, lowest lane first.
#[inline]
fn octants<L: Lane>(p: &RayPacket<L>) -> impl Iterator<Item = u32> {
    let [nx, ny, nz] = p.neg_bits();
    let mut left = p.active();
    std::iter::from_fn(move || {
        let i = (left != 0).then(|| left.trailing_zeros())?;
        let pick = |b: u32| if b >> i & 1 == 1 { b } else { !b };
        let lanes = left & pick(nx) & pick(ny) & pick(nz);
        left &= !lanes;
        Some(lanes)
    })
}

/// [`trace`] from node `start`, whose cell is `cell` (a group's entry
/// point, `group.rs`): one sub-packet per octant present, each through
/// the built kernel (`kernel::Given`: better code), however few lanes it
/// has (the single-ray traversal starts at the root).
#[inline]
pub(crate) fn trace_from<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    start: T::Ref,
    cell: &Aabb,
    c: &mut C,
) -> HitPacket<L> {
    let mut out = HitPacket::default();
    let active = p.active();
    for lanes in octants(p) {
        let sub = if lanes == active {
            *p
        } else {
            p.with_active(lanes)
        };
        let h = match kernel::built_from::<L, T, _, ANY, C>(
            tree,
            &mut kernel::Given(&sub),
            start,
            cell,
            c,
        ) {
            kernel::Built::Traced(h) => h,
            // Not reached (`Given` is checked); from the root it is exact.
            kernel::Built::Divergent(_) => trace::<L, T, ANY, C>(tree, &sub, c),
        };
        out.merge(&h, lanes);
    }
    out
}

/// The packet query of a packet the kernel builds itself (`kernel.rs`,
/// `BuildPacket`): traced in the kernel when coherent, else as [`trace`].
#[inline]
pub(crate) fn trace_built<
    L: Lane,
    T: Layout,
    B: kernel::BuildPacket<L>,
    const ANY: bool,
    C: Counters,
>(
    tree: &T,
    b: &mut B,
    c: &mut C,
) -> B::Out {
    match kernel::built::<L, T, B, ANY, C>(tree, b, c) {
        kernel::Built::Traced(out) => out,
        kernel::Built::Divergent(p) => {
            let h = trace::<L, T, ANY, C>(tree, &p, c);
            b.finish(h)
        }
    }
}

/// One octant's lanes: the kernel, or ray by ray when few.
#[inline]
fn trace_octant<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    let active = p.active();
    if active.count_ones() <= single_ray_lanes(L::WIDTH) {
        return single_rays::<L, T, ANY, C>(tree, p, active, c);
    }
    if L::WIDTH == 8 {
        // Through the built kernel (`kernel::Given`: better code).
        return match kernel::built::<L, T, _, ANY, C>(tree, &mut kernel::Given(p), c) {
            kernel::Built::Traced(h) => h,
            // Not reached (`Given` is checked: one octant, enough lanes).
            kernel::Built::Divergent(_) => single_rays::<L, T, ANY, C>(tree, p, active, c),
        };
    }
    kernel::packet::<L, T, ANY, C>(tree, p, c)
}

/// Lanes `lanes` of `p`, each with the single-ray traversal.
#[inline]
fn single_rays<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    lanes: u32,
    c: &mut C,
) -> HitPacket<L> {
    let mut out = HitPacket::default();
    let mut left = lanes;
    while left != 0 {
        let i = left.trailing_zeros() as usize;
        left &= left - 1;
        if let Some(r) = p.ray(i) {
            c.single_ray();
            out.set(i, traverse::<T, ANY, C>(tree, &r, c));
        }
    }
    out
}

/// Direction spread ([`RayPacket::dir_spread`]) above which a packet of
/// mixed direction signs is traced lane by lane, with no octant
/// sub-packets. Primary and point-light shadow rays of a 4 x 2 block
/// spread by 0.01 or less; cosine-distributed AO and random rays by 1 or
/// more (docs/packets-and-kernels.md, "What was tried").
///
/// ```
/// assert!(packtrace::kdtree::MAX_DIR_SPREAD > 0.01);
/// ```
pub const MAX_DIR_SPREAD: f32 = 0.25;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::generate;
    use crate::{KdBuildParams, RayPacket8};
    use glam::Vec3;

    /// Divergent lanes of mixed signs go one by one (no octant split);
    /// a coherent block of mixed signs is split by octant; both equal the
    /// single-ray answers lane by lane.
    #[test]
    fn divergent_packets_go_lane_by_lane_and_coherent_ones_by_octant() {
        let tree = KdTree::build(generate::sphere(2_000), &KdBuildParams::default()).unwrap();
        let ray = |o: Vec3, d: Vec3| Ray::new(o, d, 0.0, 100.0).unwrap();
        // From inside the sphere, in eight directions, one per octant.
        let divergent: [Ray; 8] = std::array::from_fn(|i| {
            let s = |b: u32| if i >> b & 1 == 1 { -1.0 } else { 1.0 };
            ray(Vec3::ZERO, Vec3::new(s(0), 0.5 * s(1), 0.7 * s(2)))
        });
        // From outside, straight at it, with x crossing zero: two octants.
        let coherent: [Ray; 8] = std::array::from_fn(|i| {
            ray(
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(0.001 * (i as f32 - 3.5), 0.001, -1.0),
            )
        });
        for (rays, splits, singles) in [(&divergent, 0, 8), (&coherent, 1, 0)] {
            let p = RayPacket8::from_rays(rays);
            let mut stats = TraversalStats::default();
            let hits = tree.intersect_packet_counted(&p, &mut stats);
            assert_eq!((stats.octant_splits, stats.single_rays), (splits, singles));
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(hits.hit(i), tree.intersect(r), "lane {i}");
                assert!(hits.hit(i).is_some());
            }
            assert_eq!(tree.occluded_packet(&p), 0xFF);
        }
    }
}

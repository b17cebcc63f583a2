//! The BVHs' queries: single rays, packets of any width (split by
//! direction octant, few or divergent lanes ray by ray, the rest in the
//! run-time kernel), streams, and the hooks a scene traces its instances
//! with. The packet front mirrors the kd-tree's (`kdtree/hybrid.rs`).

use super::Bvh8;
use super::bvh2::Bvh2;
use super::node::ChildRef;
use super::slab::lane_boxes;
use crate::kdtree::{BuildPacket, Counters, MAX_DIR_SPREAD, NoCount, TraversalStats, bvh_kernel};
use crate::kdtree::{single_ray_lanes, stream_order};
use crate::packet::{HitPacket, HitPacket4, HitPacket8, RayPacket, RayPacket4, RayPacket8};
use crate::query::{PacketQuery, RayQuery};
use crate::ray::{Hit, Ray};
use crate::simd::Lane;

/// The largest direction spread of a packet the 8-wide tree traces in its
/// packet kernel (the others go ray by ray).
pub(crate) const BVH8_PACKET_SPREAD: f32 = 0.05;

/// What the packet front needs of a structure: its single-ray query and
/// its kernel packet traversal (one octant, fast lanes only).
pub(crate) trait Traced: Sync {
    /// Packets of one octant whose directions spread more than this
    /// (`RayPacket::dir_spread`) go ray by ray.
    const OCTANT_SPREAD: f32;
    fn bounds_box(&self) -> crate::aabb::Aabb;
    fn is_empty(&self) -> bool;
    fn single<const ANY: bool, C: Counters>(&self, ray: &Ray, c: &mut C) -> Option<Hit>;
    fn kernel_packet<L: Lane, const ANY: bool, C: Counters>(
        &self,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L>;
}

impl Traced for Bvh8 {
    /// The 8-wide tree's single ray tests eight boxes per step already; its
    /// packet kernel pays per lane and per node and wins only on packets
    /// about as coherent as primary rays (`docs/bvh.md`: a stream's sorted
    /// ambient-occlusion packets took about nine times the single rays'
    /// instructions in the kernel).
    const OCTANT_SPREAD: f32 = BVH8_PACKET_SPREAD;
    fn bounds_box(&self) -> crate::aabb::Aabb {
        self.bounds
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.root == ChildRef::EMPTY
    }
    #[inline(always)]
    fn single<const ANY: bool, C: Counters>(&self, ray: &Ray, c: &mut C) -> Option<Hit> {
        self.trace_ray::<ANY, C>(ray, c)
    }
    #[inline(always)]
    fn kernel_packet<L: Lane, const ANY: bool, C: Counters>(
        &self,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L> {
        bvh_kernel::bvh8_packet::<L, ANY, C>(self, p, c)
    }
}

impl Traced for Bvh2 {
    /// As the kd-tree: every packet of one octant in the kernel.
    const OCTANT_SPREAD: f32 = f32::INFINITY;
    fn bounds_box(&self) -> crate::aabb::Aabb {
        self.bounds()
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
    #[inline(always)]
    fn single<const ANY: bool, C: Counters>(&self, ray: &Ray, c: &mut C) -> Option<Hit> {
        self.trace_ray::<ANY, C>(ray, c)
    }
    #[inline(always)]
    fn kernel_packet<L: Lane, const ANY: bool, C: Counters>(
        &self,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L> {
        bvh_kernel::bvh2_packet::<L, ANY, C>(self, p, c)
    }
}

/// The packet query of any BVH and lane type; `ANY` selects occlusion.
#[inline]
pub(crate) fn trace_packet<T: Traced, L: Lane, const ANY: bool, C: Counters>(
    t: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    let active = p.active();
    if active == 0 || t.is_empty() {
        return HitPacket::default();
    }
    let [nx, ny, nz] = p.neg_bits();
    let mixed = [nx, ny, nz].iter().any(|&b| b != 0 && b != active);
    if !mixed {
        // A divergent octant (a stream's sorted ambient-occlusion rays)
        // ray by ray, where the structure says so.
        if T::OCTANT_SPREAD.is_finite() && p.dir_spread() > T::OCTANT_SPREAD {
            return single_rays::<T, L, ANY, C>(t, p, active, c);
        }
        return trace_octant::<T, L, ANY, C>(t, p, c);
    }
    // Mixed signs and divergent lanes (ambient occlusion, random rays):
    // each lane alone.
    if p.dir_spread() > MAX_DIR_SPREAD.min(T::OCTANT_SPREAD) {
        return single_rays::<T, L, ANY, C>(t, p, active, c);
    }
    c.octant_split();
    let mut out = HitPacket::default();
    let mut left = active;
    while left != 0 {
        // The lanes of the lowest lane's octant.
        let i = left.trailing_zeros();
        let pick = |b: u32| if b >> i & 1 == 1 { b } else { !b };
        let lanes = left & pick(nx) & pick(ny) & pick(nz);
        left &= !lanes;
        let h = trace_octant::<T, L, ANY, C>(t, &p.with_active(lanes), c);
        out.merge(&h, lanes);
    }
    out
}

/// One octant's lanes: the kernel for the lanes that take the fast box
/// test when there are enough of them, the others ray by ray.
#[inline]
fn trace_octant<T: Traced, L: Lane, const ANY: bool, C: Counters>(
    t: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    let active = p.active();
    let fast = lane_boxes(&t.bounds_box(), p).fast;
    if fast.count_ones() <= single_ray_lanes(L::WIDTH) {
        return single_rays::<T, L, ANY, C>(t, p, active, c);
    }
    if fast == active {
        return t.kernel_packet::<L, ANY, C>(p, c);
    }
    let mut out = t.kernel_packet::<L, ANY, C>(&p.with_active(fast), c);
    let slow = single_rays::<T, L, ANY, C>(t, p, active & !fast, c);
    out.merge(&slow, active & !fast);
    out
}

/// Lanes `lanes` of `p`, each with the single-ray traversal.
#[inline]
fn single_rays<T: Traced, L: Lane, const ANY: bool, C: Counters>(
    t: &T,
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
            out.set(i, t.single::<ANY, C>(&r, c));
        }
    }
    out
}

/// A stream: sorted into coherent 8-wide packets (direction octant, then
/// origin, then direction: `kdtree/stream.rs`), each traced by the packet
/// query, which sends divergent ones ray by ray.
pub(crate) fn stream<T: Traced, const ANY: bool>(
    t: &T,
    rays: &[Ray],
    mut put: impl FnMut(usize, Option<Hit>),
) {
    for group in stream_order(&t.bounds_box(), rays).chunks(8) {
        let p = RayPacket8::from_fn(|l| group.get(l).map(|&i| rays[i as usize]));
        let h = trace_packet::<T, _, ANY, _>(t, &p, &mut NoCount);
        for (l, &i) in group.iter().enumerate() {
            put(i as usize, h.hit(l));
        }
    }
}

impl Bvh8 {
    /// The single-ray query with hooks `c` (a scene's filter, counters),
    /// in the run-time kernel.
    #[inline]
    pub(crate) fn trace_ray<const ANY: bool, C: Counters>(
        &self,
        ray: &Ray,
        c: &mut C,
    ) -> Option<Hit> {
        if self.root == ChildRef::EMPTY {
            return None;
        }
        bvh_kernel::bvh8_ray::<ANY, C>(self, ray, c)
    }

    /// The packet query of a packet a scene builds (an instance's lanes in
    /// object space), with hooks `c`.
    #[inline]
    pub(crate) fn trace_built_with<L: Lane, B: BuildPacket<L>, const ANY: bool, C: Counters>(
        &self,
        b: &mut B,
        c: &mut C,
    ) -> B::Out {
        let p = b.build();
        let h = trace_packet::<_, L, ANY, C>(self, &p, c);
        b.finish(h)
    }

    /// Closest hit of `ray` (ties to the smaller triangle index), or `None`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh8::build(m, &BvhBuildParams::default()).unwrap();
    /// let r = packtrace::Ray::new(Vec3::new(2.0, 2.0, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// assert_eq!(b.intersect(&r), None);
    /// ```
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.trace_ray::<false, _>(ray, &mut NoCount)
    }

    /// Is there any hit in `(t_min, t_max]`? Stops at the first one found.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh8::build(m, &BvhBuildParams::default()).unwrap();
    /// let r = packtrace::Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 0.5).unwrap();
    /// assert!(!b.occluded(&r));
    /// ```
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.trace_ray::<true, _>(ray, &mut NoCount).is_some()
    }

    /// [`Bvh8::intersect`], adding its work to `stats` (nodes: 8-wide
    /// steps; triangle tests: the triangles of the blocks tested).
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh8::build(m, &BvhBuildParams::default()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// let r = packtrace::Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// assert!(b.intersect_counted(&r, &mut s).is_some());
    /// assert_eq!((s.rays, s.leaves, s.triangle_tests), (1, 1, 1));
    /// ```
    pub fn intersect_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> Option<Hit> {
        stats.rays += 1;
        self.trace_ray::<false, _>(ray, stats)
    }

    /// [`Bvh8::occluded`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// assert!(!b.occluded_counted(&r, &mut s));
    /// assert_eq!(s.rays, 1);
    /// ```
    pub fn occluded_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> bool {
        stats.rays += 1;
        self.trace_ray::<true, _>(ray, stats).is_some()
    }

    /// Closest hits of a packet of any width; lane `i` equals
    /// [`Bvh8::intersect`] of ray `i`, bit for bit.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// use packtrace::{Ray, RayPacket8};
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh8::build(m, &BvhBuildParams::default()).unwrap();
    /// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).ok();
    /// let h = b.intersect_packet(&RayPacket8::from_fn(|i| r(0.1 + 0.2 * i as f32)));
    /// assert_eq!(h.mask(), 0b0000_1111);
    /// ```
    #[must_use]
    pub fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>) -> HitPacket<L> {
        trace_packet::<_, L, false, _>(self, p, &mut NoCount)
    }

    /// Occlusion of a packet of any width: bit `i` for lane `i`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// use packtrace::{Ray, RayPacket4};
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh8::build(m, &BvhBuildParams::default()).unwrap();
    /// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).ok();
    /// assert_eq!(b.occluded_packet(&RayPacket4::from_fn(|i| r(0.3 * i as f32))), 0b0111);
    /// ```
    #[must_use]
    pub fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32 {
        trace_packet::<_, L, true, _>(self, p, &mut NoCount).mask()
    }

    /// [`Bvh8::intersect_packet`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// b.intersect_packet_counted(&packtrace::RayPacket8::from_lanes([None; 8]), &mut s);
    /// assert_eq!(s.packets, 1);
    /// ```
    pub fn intersect_packet_counted<L: Lane>(
        &self,
        p: &RayPacket<L>,
        stats: &mut TraversalStats,
    ) -> HitPacket<L> {
        stats.packets += 1;
        stats.rays += u64::from(p.active().count_ones());
        trace_packet::<_, L, false, _>(self, p, stats)
    }

    /// [`Bvh8::occluded_packet`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// let b = Bvh8::build(packtrace::Mesh::default(), &BvhBuildParams::default()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// assert_eq!(b.occluded_packet_counted(&packtrace::RayPacket4::from_lanes([None; 4]), &mut s), 0);
    /// ```
    pub fn occluded_packet_counted<L: Lane>(
        &self,
        p: &RayPacket<L>,
        stats: &mut TraversalStats,
    ) -> u32 {
        stats.packets += 1;
        stats.rays += u64::from(p.active().count_ones());
        trace_packet::<_, L, true, _>(self, p, stats).mask()
    }

    /// Closest hits of a stream of rays, `hits[i]` for `rays[i]`, ray by
    /// ray in the run-time kernel: not a stream traversal. (Sorting the
    /// stream into packets, as [`Bvh2::intersect_rays`] does, cost more
    /// than the single rays on every workload measured: `docs/bvh.md`.)
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// use packtrace::Ray;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh8::build(m, &BvhBuildParams::default()).unwrap();
    /// let rays: Vec<Ray> = (0..7)
    ///     .map(|i| Ray::new(Vec3::new(0.1 * i as f32, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap())
    ///     .collect();
    /// let mut hits = vec![None; 7];
    /// b.intersect_rays(&rays, &mut hits);
    /// assert!(hits.iter().zip(&rays).all(|(h, r)| *h == b.intersect(r)));
    /// ```
    pub fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        for (h, r) in hits.iter_mut().zip(rays) {
            *h = self.trace_ray::<false, _>(r, &mut NoCount);
        }
    }

    /// Occlusion of a stream of rays, ray by ray as
    /// [`Bvh8::intersect_rays`] traces them.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh8, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh8::build(m, &BvhBuildParams::default()).unwrap();
    /// let r = packtrace::Ray::new(Vec3::new(0.1, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// let mut occ = vec![false; 5];
    /// b.occluded_rays(&[r; 5], &mut occ);
    /// assert!(occ.iter().all(|&o| o));
    /// ```
    pub fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one slot per ray");
        for (o, r) in occluded.iter_mut().zip(rays) {
            *o = self.trace_ray::<true, _>(r, &mut NoCount).is_some();
        }
    }
}

impl RayQuery for Bvh8 {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        Bvh8::intersect(self, ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        Bvh8::occluded(self, ray)
    }
}

impl PacketQuery for Bvh8 {
    fn intersect4(&self, p: &RayPacket4) -> HitPacket4 {
        self.intersect_packet(p)
    }
    fn occluded4(&self, p: &RayPacket4) -> u32 {
        self.occluded_packet(p)
    }
    fn intersect8(&self, p: &RayPacket8) -> HitPacket8 {
        self.intersect_packet(p)
    }
    fn occluded8(&self, p: &RayPacket8) -> u32 {
        self.occluded_packet(p)
    }
    fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        Bvh8::intersect_rays(self, rays, hits);
    }
    fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        Bvh8::occluded_rays(self, rays, occluded);
    }
}

impl Bvh2 {
    /// Closest hits of a packet of any width; lane `i` equals
    /// [`Bvh2::intersect`] of ray `i`, bit for bit.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// use packtrace::glam::Vec3;
    /// use packtrace::{Ray, RayPacket8};
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let b = Bvh2::build(m, &BvhBuildParams::median()).unwrap();
    /// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).ok();
    /// assert_eq!(b.intersect_packet(&RayPacket8::from_fn(|i| r(0.1 + 0.2 * i as f32))).mask(), 0b1111);
    /// ```
    #[must_use]
    pub fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>) -> HitPacket<L> {
        trace_packet::<_, L, false, _>(self, p, &mut NoCount)
    }

    /// Occlusion of a packet of any width: bit `i` for lane `i`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// assert_eq!(b.occluded_packet(&packtrace::RayPacket4::from_lanes([None; 4])), 0);
    /// ```
    #[must_use]
    pub fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32 {
        trace_packet::<_, L, true, _>(self, p, &mut NoCount).mask()
    }

    /// [`Bvh2::intersect_packet`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// b.intersect_packet_counted(&packtrace::RayPacket8::from_lanes([None; 8]), &mut s);
    /// assert_eq!(s.packets, 1);
    /// ```
    pub fn intersect_packet_counted<L: Lane>(
        &self,
        p: &RayPacket<L>,
        stats: &mut TraversalStats,
    ) -> HitPacket<L> {
        stats.packets += 1;
        stats.rays += u64::from(p.active().count_ones());
        trace_packet::<_, L, false, _>(self, p, stats)
    }

    /// [`Bvh2::occluded_packet`], adding its work to `stats`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// let mut s = packtrace::TraversalStats::default();
    /// assert_eq!(b.occluded_packet_counted(&packtrace::RayPacket4::from_lanes([None; 4]), &mut s), 0);
    /// ```
    pub fn occluded_packet_counted<L: Lane>(
        &self,
        p: &RayPacket<L>,
        stats: &mut TraversalStats,
    ) -> u32 {
        stats.packets += 1;
        stats.rays += u64::from(p.active().count_ones());
        trace_packet::<_, L, true, _>(self, p, stats).mask()
    }

    /// Closest hits of a stream of rays, sorted into coherent packets as
    /// [`Bvh8::intersect_rays`] does.
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// let mut hits = vec![Some(packtrace::Hit { t: 1.0, prim: 0, u: 0.0, v: 0.0 }); 2];
    /// b.intersect_rays(&[r, r], &mut hits);
    /// assert_eq!(hits, vec![None, None]);
    /// ```
    pub fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        stream::<_, false>(self, rays, |i, h| hits[i] = h);
    }

    /// Occlusion of a stream of rays.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    ///
    /// ```
    /// use packtrace::bvh::{Bvh2, BvhBuildParams};
    /// let b = Bvh2::build(packtrace::Mesh::default(), &BvhBuildParams::median()).unwrap();
    /// let r = packtrace::Ray::new(Default::default(), packtrace::glam::Vec3::X, 0.0, 1.0).unwrap();
    /// let mut occ = vec![true];
    /// b.occluded_rays(&[r], &mut occ);
    /// assert_eq!(occ, vec![false]);
    /// ```
    pub fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one slot per ray");
        stream::<_, true>(self, rays, |i, h| occluded[i] = h.is_some());
    }
}

impl RayQuery for Bvh2 {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        Bvh2::intersect(self, ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        Bvh2::occluded(self, ray)
    }
}

impl PacketQuery for Bvh2 {
    fn intersect4(&self, p: &RayPacket4) -> HitPacket4 {
        self.intersect_packet(p)
    }
    fn occluded4(&self, p: &RayPacket4) -> u32 {
        self.occluded_packet(p)
    }
    fn intersect8(&self, p: &RayPacket8) -> HitPacket8 {
        self.intersect_packet(p)
    }
    fn occluded8(&self, p: &RayPacket8) -> u32 {
        self.occluded_packet(p)
    }
    fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        Bvh2::intersect_rays(self, rays, hits);
    }
    fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        Bvh2::occluded_rays(self, rays, occluded);
    }
}

//! Group queries: the public entry points of group tracing. A coherent
//! group goes to the group traversal in the kernel chosen at run time
//! (`group.rs`, `kernel.rs`); a group without a frustum is traced packet
//! by packet through the packet queries (`hybrid.rs`), with the same
//! results.

use super::KdTree;
use super::group;
use super::hybrid::{trace, trace_from};
use super::kernel;
use super::stats::{Counters, NoCount, TraversalStats};
use crate::group::RayGroup;
use crate::packet::HitPacket8;

/// Trace `g` into `out`, one result per packet. Closest hit writes every
/// slot; occlusion writes only the lanes it finds occluded, so its `out`
/// must start empty ([`occluded`]).
fn run<const ANY: bool, C: Counters>(
    tree: &KdTree,
    g: &RayGroup,
    out: &mut [HitPacket8],
    c: &mut C,
) {
    match g.frustum() {
        // Hand-off: the group's descent to its entry point, then each
        // packet alone from there.
        Some(fr) if g.entry_handoff() => match group::entry_point(tree, fr, c) {
            Some(h) => {
                for (p, o) in g.packets().iter().zip(out.iter_mut()) {
                    *o = trace_from::<_, _, ANY, _>(tree, p, h.node, &h.cell, c);
                }
            }
            // No ray of the group reaches a cell: no hits (occlusion's
            // slots start empty).
            None if !ANY => out.fill(HitPacket8::default()),
            None => {}
        },
        Some(fr) => kernel::group::<_, _, ANY, _>(tree, g.packets(), fr, g.leaf_culling(), out, c),
        None => {
            for (p, o) in g.packets().iter().zip(out.iter_mut()) {
                *o = trace::<_, _, ANY, _>(tree, p, c);
            }
        }
    }
}

impl KdTree {
    /// Closest hits of every packet of a group, one [`HitPacket8`] per
    /// packet in the group's order; lane `i` of packet `j` equals
    /// [`KdTree::intersect`] of that ray, bit for bit.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let eye = Vec3::new(0.2, 0.2, 1.0);
    /// let p = [RayPacket8::from_fn(|i| Ray::new(eye, Vec3::new(0.01 * i as f32, 0.0, -1.0), 0.0, 9.0).ok())];
    /// let g = RayGroup::new(&p, eye, Apex::Origin).unwrap();
    /// assert_eq!(t.intersect_group(&g)[0].mask(), 0xFF);
    /// ```
    #[must_use]
    pub fn intersect_group(&self, g: &RayGroup) -> Vec<HitPacket8> {
        let mut out = vec![HitPacket8::default(); g.packets().len()];
        run::<false, _>(self, g, &mut out, &mut NoCount);
        out
    }

    /// [`KdTree::intersect_group`] into a buffer of one slot per packet.
    ///
    /// # Panics
    /// If `out.len()` differs from the group's number of packets.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// use packtrace::{HitPacket8, KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let g = RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap();
    /// t.intersect_group_into(&g, &mut []);
    /// ```
    pub fn intersect_group_into(&self, g: &RayGroup, out: &mut [HitPacket8]) {
        assert_eq!(out.len(), g.packets().len(), "one result slot per packet");
        run::<false, _>(self, g, out, &mut NoCount);
    }

    /// Occlusion of every packet of a group: bit `i` of mask `j` set when
    /// lane `i` of packet `j` is occluded ([`KdTree::occluded`]).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let light = Vec3::new(0.2, 0.2, -1.0);
    /// let p = [RayPacket8::from_fn(|i| {
    ///     let q = Vec3::new(0.1 + 0.01 * i as f32, 0.2, 1.0);
    ///     Ray::new(q, light - q, 0.0, 0.999).ok()
    /// })];
    /// let g = RayGroup::new(&p, light, Apex::Target).unwrap();
    /// assert_eq!(t.occluded_group(&g), vec![0xFF]);
    /// ```
    #[must_use]
    pub fn occluded_group(&self, g: &RayGroup) -> Vec<u32> {
        let mut out = vec![0; g.packets().len()];
        self.occluded_group_into(g, &mut out);
        out
    }

    /// [`KdTree::occluded_group`] into a buffer of one mask per packet.
    ///
    /// # Panics
    /// If `out.len()` differs from the group's number of packets.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// use packtrace::{KdBuildParams, KdTree, Mesh};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let g = RayGroup::new(&[], Vec3::ZERO, Apex::Target).unwrap();
    /// t.occluded_group_into(&g, &mut []);
    /// ```
    pub fn occluded_group_into(&self, g: &RayGroup, out: &mut [u32]) {
        occluded(self, g, out, &mut NoCount);
    }

    /// [`KdTree::intersect_group_into`], adding its work to `stats`.
    ///
    /// # Panics
    /// If `out.len()` differs from the group's number of packets.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// use packtrace::{KdBuildParams, KdTree, Mesh, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let g = RayGroup::new(&[], Vec3::ZERO, Apex::Origin).unwrap();
    /// let mut s = TraversalStats::default();
    /// t.intersect_group_counted(&g, &mut [], &mut s);
    /// assert_eq!(s.groups, 0);
    /// ```
    pub fn intersect_group_counted(
        &self,
        g: &RayGroup,
        out: &mut [HitPacket8],
        stats: &mut TraversalStats,
    ) {
        assert_eq!(out.len(), g.packets().len(), "one result slot per packet");
        count_rays(g, stats);
        run::<false, _>(self, g, out, stats);
    }

    /// [`KdTree::occluded_group_into`], adding its work to `stats`.
    ///
    /// # Panics
    /// If `out.len()` differs from the group's number of packets.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::group::{Apex, RayGroup};
    /// use packtrace::{KdBuildParams, KdTree, Mesh, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let g = RayGroup::new(&[], Vec3::ZERO, Apex::Target).unwrap();
    /// let mut s = TraversalStats::default();
    /// t.occluded_group_counted(&g, &mut [], &mut s);
    /// assert_eq!(s.rays, 0);
    /// ```
    pub fn occluded_group_counted(
        &self,
        g: &RayGroup,
        out: &mut [u32],
        stats: &mut TraversalStats,
    ) {
        assert_eq!(out.len(), g.packets().len(), "one result slot per packet");
        count_rays(g, stats);
        occluded(self, g, out, stats);
    }
}

/// Occlusion masks of `g` into `out` (one per packet), through a result
/// buffer that starts empty.
fn occluded<C: Counters>(tree: &KdTree, g: &RayGroup, out: &mut [u32], c: &mut C) {
    assert_eq!(out.len(), g.packets().len(), "one result slot per packet");
    let mut hits = [HitPacket8::default(); crate::group::MAX_GROUP_PACKETS];
    let hits = &mut hits[..out.len()];
    run::<true, _>(tree, g, hits, c);
    for (o, h) in out.iter_mut().zip(hits.iter()) {
        *o = h.mask();
    }
}

/// The group's packets and active lanes, as the packet queries count them.
fn count_rays(g: &RayGroup, stats: &mut TraversalStats) {
    for p in g.packets() {
        stats.packets += 1;
        stats.rays += u64::from(p.active().count_ones());
    }
}

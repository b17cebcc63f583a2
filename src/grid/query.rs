//! The grids' queries: single rays, packets of any width (through the
//! BVHs' packet front, `bvh/query.rs`: octant split, divergent or few
//! lanes ray by ray, the rest in the run-time kernel), streams, and the
//! query traits.

use super::{Grid, HGrid, single};
use crate::bvh::query::{BVH8_PACKET_SPREAD, Traced, stream, trace_packet};
use crate::kdtree::{Counters, NoCount, TraversalStats, bvh_kernel};
use crate::packet::{HitPacket, HitPacket4, HitPacket8, RayPacket, RayPacket4, RayPacket8};
use crate::query::{PacketQuery, RayQuery};
use crate::ray::{Hit, Ray};
use crate::simd::Lane;
use glam::Vec3A;

fn bounds_of(lo: &[f64; 3], hi: &[f64; 3]) -> crate::aabb::Aabb {
    let f = |v: &[f64; 3]| Vec3A::new(v[0] as f32, v[1] as f32, v[2] as f32);
    crate::aabb::Aabb::new(f(lo), f(hi))
}

impl Traced for Grid {
    // Divergent rays of one octant cross wide rectangles of cells: they go
    // ray by ray, as in the 8-wide BVH.
    const OCTANT_SPREAD: f32 = BVH8_PACKET_SPREAD;
    fn bounds_box(&self) -> crate::aabb::Aabb {
        bounds_of(&self.frame.lo, &self.frame.hi)
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.cells.prims.is_empty()
    }
    #[inline(always)]
    fn single<const ANY: bool, C: Counters>(&self, ray: &Ray, c: &mut C) -> Option<Hit> {
        single::trace::<ANY, C>(self, ray, c)
    }
    #[inline(always)]
    fn kernel_packet<L: Lane, const ANY: bool, C: Counters>(
        &self,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L> {
        bvh_kernel::grid_packet::<L, ANY, C>(self, p, c)
    }
}

impl Traced for HGrid {
    const OCTANT_SPREAD: f32 = f32::INFINITY;
    fn bounds_box(&self) -> crate::aabb::Aabb {
        bounds_of(&self.frame.lo, &self.frame.hi)
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.top.prims.is_empty()
    }
    #[inline(always)]
    fn single<const ANY: bool, C: Counters>(&self, ray: &Ray, c: &mut C) -> Option<Hit> {
        single::trace_h::<ANY, C>(self, ray, c)
    }
    /// Ray by ray: the two-level grid has no packet walk (`docs/grids.md`).
    #[inline(always)]
    fn kernel_packet<L: Lane, const ANY: bool, C: Counters>(
        &self,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L> {
        let mut out = HitPacket::default();
        let mut left = p.active();
        while left != 0 {
            let i = left.trailing_zeros() as usize;
            left &= left - 1;
            if let Some(r) = p.ray(i) {
                c.single_ray();
                out.set(i, single::trace_h::<ANY, C>(self, &r, c));
            }
        }
        out
    }
}

/// The inherent query methods of a grid type, each documented with an
/// example on `$ty`.
macro_rules! grid_queries {
    ($ty:ident, $example:literal) => {
        impl $ty {
            #[doc = concat!("The closest hit of `ray` (brute force's answer bit for bit).\n\n```\n", $example, "\nassert_eq!(g.intersect(&ray).map(|h| h.t), Some(1.0));\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            #[must_use]
            pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
                self.single::<false, _>(ray, &mut NoCount)
            }

            #[doc = concat!("Whether anything blocks `ray` within its interval.\n\n```\n", $example, "\nassert!(g.occluded(&ray));\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            #[must_use]
            pub fn occluded(&self, ray: &Ray) -> bool {
                self.single::<true, _>(ray, &mut NoCount).is_some()
            }

            #[doc = concat!("[`Self::intersect`], counting the work in `stats` (`nodes`: cells walked, `leaves`: non-empty cells tested, `mailbox_hits`).\n\n```\n", $example, "\nlet mut s = packtrace::TraversalStats::default();\nassert!(g.intersect_counted(&ray, &mut s).is_some());\nassert_eq!((s.rays, s.triangle_tests), (1, 1));\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            pub fn intersect_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> Option<Hit> {
                stats.rays += 1;
                self.single::<false, _>(ray, stats)
            }

            #[doc = concat!("[`Self::occluded`], counting the work in `stats`.\n\n```\n", $example, "\nlet mut s = packtrace::TraversalStats::default();\nassert!(g.occluded_counted(&ray, &mut s));\nassert_eq!(s.rays, 1);\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            pub fn occluded_counted(&self, ray: &Ray, stats: &mut TraversalStats) -> bool {
                stats.rays += 1;
                self.single::<true, _>(ray, stats).is_some()
            }

            #[doc = concat!("The closest hits of a packet of any width.\n\n```\n", $example, "\nlet h = g.intersect_packet(&packtrace::RayPacket8::from_slice(&[ray; 5]));\nassert_eq!(h.mask(), 0b11111);\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            #[must_use]
            pub fn intersect_packet<L: Lane>(&self, p: &RayPacket<L>) -> HitPacket<L> {
                trace_packet::<_, L, false, _>(self, p, &mut NoCount)
            }

            #[doc = concat!("The lanes of a packet that something blocks, as bits.\n\n```\n", $example, "\nassert_eq!(g.occluded_packet(&packtrace::RayPacket4::from_slice(&[ray; 2])), 0b11);\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            #[must_use]
            pub fn occluded_packet<L: Lane>(&self, p: &RayPacket<L>) -> u32 {
                trace_packet::<_, L, true, _>(self, p, &mut NoCount).mask()
            }

            #[doc = concat!("[`Self::intersect_packet`], counting the work in `stats`.\n\n```\n", $example, "\nlet mut s = packtrace::TraversalStats::default();\ng.intersect_packet_counted(&packtrace::RayPacket8::from_slice(&[ray; 8]), &mut s);\nassert_eq!((s.packets, s.rays), (1, 8));\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            pub fn intersect_packet_counted<L: Lane>(
                &self,
                p: &RayPacket<L>,
                stats: &mut TraversalStats,
            ) -> HitPacket<L> {
                stats.packets += 1;
                stats.rays += u64::from(p.active().count_ones());
                trace_packet::<_, L, false, _>(self, p, stats)
            }

            #[doc = concat!("[`Self::occluded_packet`], counting the work in `stats`.\n\n```\n", $example, "\nlet mut s = packtrace::TraversalStats::default();\nassert_eq!(g.occluded_packet_counted(&packtrace::RayPacket4::from_slice(&[ray; 4]), &mut s), 0b1111);\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            pub fn occluded_packet_counted<L: Lane>(
                &self,
                p: &RayPacket<L>,
                stats: &mut TraversalStats,
            ) -> u32 {
                stats.packets += 1;
                stats.rays += u64::from(p.active().count_ones());
                trace_packet::<_, L, true, _>(self, p, stats).mask()
            }

            #[doc = concat!("A stream: the rays sorted by octant and position, traced as 8-wide packets.\n\n# Panics\nIf `hits` is not as long as `rays`.\n\n```\n", $example, "\nlet mut hits = vec![None; 3];\ng.intersect_rays(&[ray; 3], &mut hits);\nassert!(hits.iter().all(|h| h.is_some()));\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            pub fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
                assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
                stream::<_, false>(self, rays, |i, h| hits[i] = h);
            }

            #[doc = concat!("A stream of occlusion queries.\n\n# Panics\nIf `occluded` is not as long as `rays`.\n\n```\n", $example, "\nlet mut o = vec![false; 3];\ng.occluded_rays(&[ray; 3], &mut o);\nassert_eq!(o, [true; 3]);\n# Ok::<(), Box<dyn std::error::Error>>(())\n```")]
            pub fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
                assert_eq!(rays.len(), occluded.len(), "one slot per ray");
                stream::<_, true>(self, rays, |i, h| occluded[i] = h.is_some());
            }
        }

        impl RayQuery for $ty {
            fn intersect(&self, ray: &Ray) -> Option<Hit> {
                $ty::intersect(self, ray)
            }
            fn occluded(&self, ray: &Ray) -> bool {
                $ty::occluded(self, ray)
            }
        }

        impl PacketQuery for $ty {
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
                $ty::intersect_rays(self, rays, hits);
            }
            fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
                $ty::occluded_rays(self, rays, occluded);
            }
        }
    };
}

grid_queries!(
    Grid,
    "use packtrace::grid::{Grid, GridParams};\nuse packtrace::glam::Vec3;\nlet mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;\nlet g = Grid::build(mesh, &GridParams::default())?;\nlet ray = packtrace::Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;"
);
grid_queries!(
    HGrid,
    "use packtrace::grid::{HGrid, HGridParams};\nuse packtrace::glam::Vec3;\nlet mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;\nlet g = HGrid::build(mesh, &HGridParams::default())?;\nlet ray = packtrace::Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;"
);

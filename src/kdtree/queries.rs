//! The query traits for the layouts kept only to be measured against
//! [`KdTree`](super::KdTree) (the naive layout, the blocked order): one
//! macro, so their answers come from the very same generic code.

/// `RayQuery` and `PacketQuery` for a layout that is only measured against
/// [`KdTree`](super::KdTree) (the naive layout, the blocked order): the generic scalar
/// traversal, the packet query (`hybrid::trace`) and the stream sorter,
/// with no counters.
macro_rules! layout_queries {
    ($t:ty) => {
        impl $crate::query::RayQuery for $t {
            fn intersect(&self, ray: &$crate::ray::Ray) -> Option<$crate::ray::Hit> {
                $crate::kdtree::scalar::traverse::<_, false, _>(
                    self,
                    ray,
                    &mut $crate::kdtree::stats::NoCount,
                )
            }
            fn occluded(&self, ray: &$crate::ray::Ray) -> bool {
                $crate::kdtree::scalar::traverse::<_, true, _>(
                    self,
                    ray,
                    &mut $crate::kdtree::stats::NoCount,
                )
                .is_some()
            }
        }

        impl $crate::query::PacketQuery for $t {
            fn intersect4(&self, p: &$crate::packet::RayPacket4) -> $crate::packet::HitPacket4 {
                $crate::kdtree::hybrid::trace::<_, _, false, _>(
                    self,
                    p,
                    &mut $crate::kdtree::stats::NoCount,
                )
            }
            fn occluded4(&self, p: &$crate::packet::RayPacket4) -> u32 {
                $crate::kdtree::hybrid::trace::<_, _, true, _>(
                    self,
                    p,
                    &mut $crate::kdtree::stats::NoCount,
                )
                .mask()
            }
            fn intersect8(&self, p: &$crate::packet::RayPacket8) -> $crate::packet::HitPacket8 {
                $crate::kdtree::hybrid::trace::<_, _, false, _>(
                    self,
                    p,
                    &mut $crate::kdtree::stats::NoCount,
                )
            }
            fn occluded8(&self, p: &$crate::packet::RayPacket8) -> u32 {
                $crate::kdtree::hybrid::trace::<_, _, true, _>(
                    self,
                    p,
                    &mut $crate::kdtree::stats::NoCount,
                )
                .mask()
            }
            fn intersect_rays(
                &self,
                rays: &[$crate::ray::Ray],
                hits: &mut [Option<$crate::ray::Hit>],
            ) {
                $crate::kdtree::stream::intersect_rays(self, rays, hits);
            }
            fn occluded_rays(&self, rays: &[$crate::ray::Ray], occluded: &mut [bool]) {
                $crate::kdtree::stream::occluded_rays(self, rays, occluded);
            }
        }
    };
}
pub(crate) use layout_queries;

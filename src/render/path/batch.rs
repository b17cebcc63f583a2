//! How the path tracer traces a batch of rays: the one place it calls a
//! structure, through [`PacketQuery`], in the [`Mode`] the options name.
//! Any structure that implements the query traits (the kd-tree, the
//! brute-force oracle, a BVH) is traced the same way, so swapping the
//! structure is a change of the query handed to
//! [`PathTracer::new`](super::PathTracer::new).
//!
//! A batch is one tile's bounce rays (or shadow rays) of one depth, in
//! path order: the paths of neighbouring pixels sit side by side, so the
//! packet modes cut it into packets of neighbours whose directions are
//! nevertheless scattered over the hemisphere (the packet query splits
//! them by octant or traces them one by one, `kdtree::hybrid`), and the
//! stream mode hands the whole batch to the structure to sort.

use crate::packet::{RayPacket4, RayPacket8};
use crate::query::{Mode, PacketQuery};
use crate::ray::{Hit, Ray};

/// A query and the mode its batches are traced in.
pub(super) struct Batch<'a, Q: ?Sized> {
    pub(super) query: &'a Q,
    pub(super) mode: Mode,
}

impl<Q: PacketQuery + ?Sized> Batch<'_, Q> {
    /// Closest hits, `hits[i]` for `rays[i]`.
    pub(super) fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        let q = self.query;
        match self.mode {
            Mode::Scalar => {
                for (r, h) in rays.iter().zip(hits) {
                    *h = q.intersect(r);
                }
            }
            Mode::Packet4 => {
                for (rs, hs) in rays.chunks(4).zip(hits.chunks_mut(4)) {
                    let out = q.intersect4(&RayPacket4::from_slice(rs));
                    for (i, h) in hs.iter_mut().enumerate() {
                        *h = out.hit(i);
                    }
                }
            }
            // The group modes are refused by `PathOptions::validate`.
            Mode::Packet8 | Mode::Group8x8 | Mode::Group16x16 => {
                for (rs, hs) in rays.chunks(8).zip(hits.chunks_mut(8)) {
                    let out = q.intersect8(&RayPacket8::from_slice(rs));
                    for (i, h) in hs.iter_mut().enumerate() {
                        *h = out.hit(i);
                    }
                }
            }
            Mode::Stream => q.intersect_rays(rays, hits),
        }
    }

    /// Occlusion, `occluded[i]` for `rays[i]`.
    pub(super) fn occluded(&self, rays: &[Ray], occluded: &mut [bool]) {
        let q = self.query;
        let unpack = |mask: u32, os: &mut [bool]| {
            for (i, o) in os.iter_mut().enumerate() {
                *o = mask >> i & 1 == 1;
            }
        };
        match self.mode {
            Mode::Scalar => {
                for (r, o) in rays.iter().zip(occluded) {
                    *o = q.occluded(r);
                }
            }
            Mode::Packet4 => {
                for (rs, os) in rays.chunks(4).zip(occluded.chunks_mut(4)) {
                    unpack(q.occluded4(&RayPacket4::from_slice(rs)), os);
                }
            }
            Mode::Packet8 | Mode::Group8x8 | Mode::Group16x16 => {
                for (rs, os) in rays.chunks(8).zip(occluded.chunks_mut(8)) {
                    unpack(q.occluded8(&RayPacket8::from_slice(rs)), os);
                }
            }
            Mode::Stream => q.occluded_rays(rays, occluded),
        }
    }
}

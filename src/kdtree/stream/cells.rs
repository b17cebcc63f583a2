//! What a subset knows of its cell: each ray's interval in it
//! ([`Intervals`], the default), or the cell's box ([`Boxes`]), from which
//! each ray's interval is recomputed at every node (the choice Wald,
//! Gribble, Boulos and Kensler 2007 leave open for streams). The issue is
//! memory against arithmetic: intervals are written at every split and
//! read back in order (8 bytes a ray, sequential); a box is pushed once
//! per deferred cell, but every node step then reads all three axes of a
//! ray and runs the slab test again.
//!
//! Both give the scalar traversal's decisions. The scalar step keeps
//! `t_min` as the largest entry distance `(plane - entry) * inv_dir` of
//! the planes crossed, and `t_max` as the smallest exit distance; in one
//! octant those planes advance monotonically along each axis, and a
//! rounded `(x - o) * inv_dir` is monotonic in `x`, so the largest (the
//! smallest) is the cell box's face, which is what the root's slab test
//! (`aabb::slab`), run on the cell box, computes. The closest hit so far
//! stands in for the ray's `t_max`: it starts there and only shrinks, and
//! the scalar pop applies it before any node below the popped cell.
//!
//! Measured and rejected as the default (`docs/streams.md`, "Intervals
//! against cell boxes"): the box form is kept behind
//! `StreamOptions::with_cell_boxes` so that the comparison can be rerun.

use super::rays::StreamRays;
use crate::aabb::Aabb;
use crate::kdtree::kernel::partition::{BoxCell, Plane, StreamIsa, Subsets};

/// How the traversal tracks a subset's cell.
pub(crate) trait Cells: Copy {
    /// The root's cell.
    fn root(bounds: &Aabb) -> Self;

    /// The cells below and above `split` on `axis`.
    fn children(self, axis: usize, split: f32) -> (Self, Self);

    /// [`StreamIsa::split`]: the segment `(cur, len, top)`, that is
    /// `cur..cur + len`, split at the plane, near rays in place and far
    /// ones from `top` on.
    #[allow(clippy::too_many_arguments)]
    fn split<I: StreamIsa>(
        self,
        isa: I,
        s: &mut Subsets,
        segment: (usize, usize, usize),
        axis: usize,
        split: f32,
        rays: &StreamRays,
        neg: [bool; 3],
    ) -> (usize, usize);

    /// [`StreamIsa::cull`]: the popped segment's rays that still reach
    /// the cell, kept in place; returns how many.
    fn cull<I: StreamIsa>(
        self,
        isa: I,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        rays: &StreamRays,
        neg: [bool; 3],
    ) -> usize;

    /// The interval in the cell of the ray at entry `j` of the subsets
    /// (ray `i`), for the single-ray finish.
    fn interval(self, s: &Subsets, j: usize, rays: &StreamRays, neg: [bool; 3]) -> (f32, f32);
}

/// The rays' intervals, carried in [`Subsets`] (the default).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Intervals;

impl Cells for Intervals {
    #[inline(always)]
    fn root(_: &Aabb) -> Self {
        Intervals
    }

    #[inline(always)]
    fn children(self, _: usize, _: f32) -> (Self, Self) {
        (Intervals, Intervals)
    }

    #[inline(always)]
    fn split<I: StreamIsa>(
        self,
        isa: I,
        s: &mut Subsets,
        (cur, len, top): (usize, usize, usize),
        axis: usize,
        split: f32,
        rays: &StreamRays,
        _: [bool; 3],
    ) -> (usize, usize) {
        let plane = Plane {
            split,
            rec: &rays.plane[axis][..rays.n],
        };
        isa.split(s, cur, len, top, &plane)
    }

    #[inline(always)]
    fn cull<I: StreamIsa>(
        self,
        isa: I,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        rays: &StreamRays,
        _: [bool; 3],
    ) -> usize {
        isa.cull(s, cur, len, &rays.best_t[..rays.n])
    }

    #[inline(always)]
    fn interval(self, s: &Subsets, j: usize, _: &StreamRays, _: [bool; 3]) -> (f32, f32) {
        (s.t_min[j], s.t_max[j])
    }
}

/// The cell's box: the subsets carry ray ids only.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Boxes(Aabb);

impl Boxes {
    /// The cell as the partition reads it: per axis the face the octant's
    /// rays enter by and the one they leave by (`aabb::slab`'s `near` and
    /// `far`), and the rays' records.
    #[inline(always)]
    fn view<'a>(&self, rays: &'a StreamRays, neg: &[bool; 3]) -> BoxCell<'a> {
        let (lo, hi) = (self.0.min.to_array(), self.0.max.to_array());
        BoxCell {
            entry_face: std::array::from_fn(|a| if neg[a] { hi[a] } else { lo[a] }),
            exit_face: std::array::from_fn(|a| if neg[a] { lo[a] } else { hi[a] }),
            rec: &rays.boxes[..rays.n],
            best_t: &rays.best_t[..rays.n],
        }
    }
}

impl Cells for Boxes {
    #[inline(always)]
    fn root(bounds: &Aabb) -> Self {
        Boxes(*bounds)
    }

    #[inline(always)]
    fn children(self, axis: usize, split: f32) -> (Self, Self) {
        let (mut below, mut above) = (self.0, self.0);
        below.max[axis] = split;
        above.min[axis] = split;
        (Boxes(below), Boxes(above))
    }

    #[inline(always)]
    fn split<I: StreamIsa>(
        self,
        isa: I,
        s: &mut Subsets,
        (cur, len, top): (usize, usize, usize),
        axis: usize,
        split: f32,
        rays: &StreamRays,
        neg: [bool; 3],
    ) -> (usize, usize) {
        isa.split_boxes(s, cur, len, top, &self.view(rays, &neg), axis, split)
    }

    #[inline(always)]
    fn cull<I: StreamIsa>(
        self,
        isa: I,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        rays: &StreamRays,
        neg: [bool; 3],
    ) -> usize {
        isa.cull_boxes(s, cur, len, &self.view(rays, &neg))
    }

    #[inline(always)]
    fn interval(self, s: &Subsets, j: usize, rays: &StreamRays, neg: [bool; 3]) -> (f32, f32) {
        self.view(rays, &neg).interval(s.ids[j] as usize)
    }
}

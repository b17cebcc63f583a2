//! The 3D-DDA (Amanatides and Woo 1987, "A fast voxel traversal
//! algorithm for ray tracing"): a ray's cells front to back, each with the
//! `t` at which the ray leaves it, in `f64` (`cells.rs` says why).
//!
//! The plane distances are computed afresh from each cell's plane rather
//! than accumulated (`t_next += t_delta`), so they never drift; a point
//! outside the box belongs to its nearest border cell, and the walk ends
//! where the ray leaves the box grown by its margin or its interval ends,
//! whichever is first (a ray that runs along a border in the margin stays
//! in the border cells: an axis with no cell beyond has `t_next = +inf`).

use super::cells::Cells;
use crate::ray::Ray;
use crate::triangle::MARGIN;

/// A ray in `f64`, clipped to the scene's box grown by its margin.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Span {
    pub org: [f64; 3],
    pub dir: [f64; 3],
    pub inv: [f64; 3],
    /// The ray's margin, `MARGIN * max(|org|, M)` (`kdtree/margin.rs`).
    pub eta: f64,
    /// Where the walk starts and ends.
    pub t0: f64,
    pub t1: f64,
}

impl Span {
    /// `ray` clipped to `[lo, hi]` (grown by the ray's margin; `m` the
    /// box's coordinate magnitude), or `None` if it misses the grown box.
    #[inline]
    pub(crate) fn new(ray: &Ray, lo: &[f64; 3], hi: &[f64; 3], m: f64) -> Option<Span> {
        let o = ray.origin();
        let d = ray.dir();
        let org = [o.x, o.y, o.z].map(f64::from);
        let dir = [d.x, d.y, d.z].map(f64::from);
        let om = org[0].abs().max(org[1].abs()).max(org[2].abs());
        let eta = f64::from(MARGIN) * m.max(om);
        let inv = dir.map(|x| 1.0 / x);
        let (mut t0, mut t1) = (f64::from(ray.t_min()), f64::from(ray.t_max()));
        for a in 0..3 {
            let (l, h) = (lo[a] - eta, hi[a] + eta);
            if dir[a] == 0.0 {
                if org[a] < l || org[a] > h {
                    return None;
                }
                continue;
            }
            let (ta, tb) = ((l - org[a]) * inv[a], (h - org[a]) * inv[a]);
            let (near, far) = if ta <= tb { (ta, tb) } else { (tb, ta) };
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        (t0 <= t1).then_some(Span {
            org,
            dir,
            inv,
            eta,
            t0,
            t1,
        })
    }

    /// The point at `t`, along axis `a`.
    #[inline(always)]
    pub(crate) fn at(&self, a: usize, t: f64) -> f64 {
        self.org[a] + t * self.dir[a]
    }
}

/// A walk through one grid's cells over `[t_in, t_end]` of a span.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dda {
    /// The current cell.
    pub cell: [u32; 3],
    /// Where the current cell was entered.
    pub t_in: f64,
    /// The `t` at which the ray reaches the next plane along each axis
    /// (`+inf` if there is no cell beyond it).
    t_next: [f64; 3],
    t_end: f64,
    neg: [bool; 3],
    done: bool,
}

impl Dda {
    /// Starts at the cell holding the point at `t_in`.
    #[inline]
    pub(crate) fn new(cells: &Cells, s: &Span, t_in: f64, t_end: f64) -> Dda {
        let cell = std::array::from_fn(|a| cells.coord(a, s.at(a, t_in)));
        let mut w = Dda {
            cell,
            t_in,
            t_next: [f64::INFINITY; 3],
            t_end,
            neg: s.dir.map(|d| d < 0.0),
            done: false,
        };
        for a in 0..3 {
            w.t_next[a] = w.next_plane(cells, s, a);
        }
        w
    }

    /// The `t` of the plane the ray crosses next along axis `a`.
    #[inline(always)]
    fn next_plane(&self, cells: &Cells, s: &Span, a: usize) -> f64 {
        let c = self.cell[a];
        if s.dir[a] == 0.0 {
            f64::INFINITY
        } else if self.neg[a] {
            if c == 0 {
                f64::INFINITY
            } else {
                (cells.plane(a, c) - s.org[a]) * s.inv[a]
            }
        } else if c + 1 >= cells.dims[a] {
            f64::INFINITY
        } else {
            (cells.plane(a, c + 1) - s.org[a]) * s.inv[a]
        }
    }

    /// Where the ray leaves the current cell (or the walk ends).
    #[inline(always)]
    pub(crate) fn t_out(&self) -> f64 {
        self.t_next[0]
            .min(self.t_next[1])
            .min(self.t_next[2])
            .min(self.t_end)
    }

    /// Is this the walk's last cell?
    #[inline(always)]
    pub(crate) fn last(&self) -> bool {
        self.done || self.t_out() >= self.t_end
    }

    /// Moves to the next cell; `false` once the walk has ended.
    #[inline(always)]
    pub(crate) fn step(&mut self, cells: &Cells, s: &Span) -> bool {
        if self.last() {
            self.done = true;
            return false;
        }
        let t = self.t_next;
        let a = if t[0] <= t[1] && t[0] <= t[2] {
            0
        } else if t[1] <= t[2] {
            1
        } else {
            2
        };
        self.t_in = t[a];
        if self.neg[a] {
            self.cell[a] -= 1;
        } else {
            self.cell[a] += 1;
        }
        self.t_next[a] = self.next_plane(cells, s, a);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn cells_of(ray: &Ray) -> Vec<[u32; 3]> {
        let c = Cells::geometry([0.0; 3], [4.0; 3], [4, 4, 4]);
        let s = Span::new(ray, &[0.0; 3], &[4.0; 3], 4.0).unwrap();
        let mut w = Dda::new(&c, &s, s.t0, s.t1);
        let mut out = vec![w.cell];
        while w.step(&c, &s) {
            out.push(w.cell);
        }
        out
    }

    #[test]
    fn an_axis_ray_walks_its_row() {
        let r = Ray::new(Vec3::new(-1.0, 0.5, 2.5), Vec3::X, 0.0, f32::INFINITY).unwrap();
        assert_eq!(cells_of(&r), [[0, 0, 2], [1, 0, 2], [2, 0, 2], [3, 0, 2]]);
        let r = Ray::new(Vec3::new(5.0, 0.5, 2.5), Vec3::NEG_X, 0.0, f32::INFINITY).unwrap();
        assert_eq!(cells_of(&r), [[3, 0, 2], [2, 0, 2], [1, 0, 2], [0, 0, 2]]);
    }

    #[test]
    fn a_diagonal_ray_steps_one_axis_at_a_time_and_ends_with_its_interval() {
        let r = Ray::new(
            Vec3::new(0.5, 0.25, 0.5),
            Vec3::new(1.0, 1.0, 0.0),
            0.0,
            1.6,
        )
        .unwrap();
        assert_eq!(cells_of(&r), [[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 1, 0]]);
    }

    #[test]
    fn a_ray_missing_the_grown_box_has_no_span() {
        let r = Ray::new(Vec3::new(-1.0, 5.0, 0.5), Vec3::X, 0.0, f32::INFINITY).unwrap();
        assert!(Span::new(&r, &[0.0; 3], &[4.0; 3], 4.0).is_none());
        // Within the margin of a face: a span along the border cells.
        let eta = f64::from(MARGIN) * 4.0;
        let y = (4.0 + eta * 0.5) as f32;
        let r = Ray::new(Vec3::new(-1.0, y, 0.5), Vec3::X, 0.0, f32::INFINITY).unwrap();
        assert_eq!(cells_of(&r).len(), 4);
    }
}

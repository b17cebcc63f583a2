//! A single ray through the grids: the 3D-DDA front to back, each cell's
//! triangles tested with the crate's one watertight routine, a per-ray
//! mailbox, and the early exit once the closest hit lies before the
//! cell's far side. Reads beside the binary BVH's `traverse`
//! (`bvh/bvh2.rs`): the same leaf rule, the same tie rule.
//!
//! Why the exit is exact: a hit the triangle test reports lies within
//! `7/8 eta` of its triangle, and each cell lists every triangle within
//! `pad >= eta` of it (or the walk also searches the cells around, for a
//! far origin: `Cells::reach`). So once `best.t < t_out`, every triangle
//! that could report `t <= best.t` lies in a cell already walked, and
//! brute force's answer (ties to the smaller index) is already in hand.
//! A triangle whose hit lies beyond the current cell stays the best
//! candidate until the walk passes it, which is also why the mailbox may
//! skip it in the next cell.

use super::cells::Cells;
use super::walk::{Dda, Span};
use super::{Grid, HGrid};
use crate::kdtree::Counters;
use crate::ray::{Hit, NO_PRIM, Ray};
use crate::triangle::{self, Shear, permute};
use glam::Vec3;

/// Mailbox slots: a direct-mapped table of triangle indices (Benthin's
/// hashed mailboxing; Amanatides and Woo kept the ray's id in each
/// triangle, which would make the grid mutable per ray).
pub(crate) const MAILBOX: usize = 32;

/// A ray's per-query state: its shear, the best hit so far, the mailbox.
pub(crate) struct Tester<'a> {
    sh: Shear<f32>,
    k: [usize; 3],
    t_min: f32,
    corners: &'a [[Vec3; 3]],
    pub best: Hit,
    mailbox: [u32; MAILBOX],
    use_mailbox: bool,
}

impl<'a> Tester<'a> {
    #[inline(always)]
    pub(crate) fn new(ray: &Ray, corners: &'a [[Vec3; 3]], use_mailbox: bool) -> Tester<'a> {
        let (sh, k) = triangle::shear(ray);
        Tester {
            sh,
            k,
            t_min: ray.t_min(),
            corners,
            best: Hit {
                t: ray.t_max(),
                prim: NO_PRIM,
                u: 0.0,
                v: 0.0,
            },
            mailbox: [NO_PRIM; MAILBOX],
            use_mailbox,
        }
    }

    /// Tests a cell's triangles; `true` when `ANY` and one was hit.
    #[inline(always)]
    pub(crate) fn cell<const ANY: bool, C: Counters>(&mut self, prims: &[u32], c: &mut C) -> bool {
        if prims.is_empty() {
            return false;
        }
        c.leaf();
        for &prim in prims {
            // Mailbox: tested in an earlier cell already.
            if self.use_mailbox {
                let slot = &mut self.mailbox[prim as usize % MAILBOX];
                if *slot == prim {
                    c.mailbox_hit();
                    continue;
                }
                *slot = prim;
            }
            c.tri(1);
            let tri = &self.corners[prim as usize];
            let k = self.k;
            let h = triangle::intersect(
                &self.sh,
                permute(tri[0], k),
                permute(tri[1], k),
                permute(tri[2], k),
                self.t_min,
                self.best.t,
            );
            if h.mask && (!C::FILTERS || c.accept(prim, h.t, h.u, h.v)) {
                let cand = Hit {
                    t: h.t,
                    prim,
                    u: h.u,
                    v: h.v,
                };
                if ANY {
                    self.best = cand;
                    return true;
                }
                if cand.closer_than(&self.best) {
                    self.best = cand;
                }
            }
        }
        false
    }

    /// The cells within `reach` of `cell` (a far origin's search).
    #[inline(never)]
    pub(crate) fn around<const ANY: bool, C: Counters>(
        &mut self,
        cells: &Cells,
        cell: [u32; 3],
        reach: [u32; 3],
        c: &mut C,
    ) -> bool {
        let lo: [u32; 3] = std::array::from_fn(|a| cell[a].saturating_sub(reach[a]));
        let hi: [u32; 3] = std::array::from_fn(|a| (cell[a] + reach[a]).min(cells.dims[a] - 1));
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    if self.cell::<ANY, C>(cells.cell(cells.index([x, y, z])), c) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Has the walk passed the best hit (the early exit)?
    #[inline(always)]
    pub(crate) fn passed(&self, t_out: f64) -> bool {
        f64::from(self.best.t) < t_out
    }

    #[inline(always)]
    pub(crate) fn result(&self) -> Option<Hit> {
        (self.best.prim != NO_PRIM).then_some(self.best)
    }
}

/// One cell of a walk: its own triangles, or those around it.
#[inline(always)]
fn visit<const ANY: bool, C: Counters>(
    t: &mut Tester,
    cells: &Cells,
    cell: [u32; 3],
    reach: [u32; 3],
    c: &mut C,
) -> bool {
    c.node();
    if reach == [0; 3] {
        t.cell::<ANY, C>(cells.cell(cells.index(cell)), c)
    } else {
        t.around::<ANY, C>(cells, cell, reach, c)
    }
}

/// A ray through a uniform grid.
#[inline]
pub(crate) fn trace<const ANY: bool, C: Counters>(g: &Grid, ray: &Ray, c: &mut C) -> Option<Hit> {
    if g.cells.prims.is_empty() {
        return None;
    }
    let s = Span::new(ray, &g.frame.lo, &g.frame.hi, g.frame.m)?;
    let reach = g.cells.reach(s.eta, g.frame.pad);
    let mut t = Tester::new(ray, g.mesh.corner_slice(), g.params.mailbox);
    let mut w = Dda::new(&g.cells, &s, s.t0, s.t1);
    loop {
        if visit::<ANY, C>(&mut t, &g.cells, w.cell, reach, c) {
            break;
        }
        if t.passed(w.t_out()) || !w.step(&g.cells, &s) {
            break;
        }
    }
    t.result()
}

/// A ray through a two-level grid: a crowded top cell's span is walked
/// again through its sub-grid (a far origin's search stays on the top
/// level, whose cells list every triangle of their sub-grids).
#[inline]
pub(crate) fn trace_h<const ANY: bool, C: Counters>(
    g: &HGrid,
    ray: &Ray,
    c: &mut C,
) -> Option<Hit> {
    if g.top.prims.is_empty() {
        return None;
    }
    let s = Span::new(ray, &g.frame.lo, &g.frame.hi, g.frame.m)?;
    let reach = g.top.reach(s.eta, g.frame.pad);
    let mut t = Tester::new(ray, g.mesh.corner_slice(), g.params.top.mailbox);
    let mut w = Dda::new(&g.top, &s, s.t0, s.t1);
    loop {
        let sub = g.sub(g.top.index(w.cell));
        match sub {
            Some(sub) if reach == [0; 3] => {
                // The top cell's span, through its sub-grid.
                c.node();
                let mut sw = Dda::new(sub, &s, w.t_in, w.t_out());
                loop {
                    if visit::<ANY, C>(&mut t, sub, sw.cell, reach, c) {
                        return t.result();
                    }
                    if t.passed(sw.t_out()) || !sw.step(sub, &s) {
                        break;
                    }
                }
            }
            _ => {
                if visit::<ANY, C>(&mut t, &g.top, w.cell, reach, c) {
                    break;
                }
            }
        }
        if t.passed(w.t_out()) || !w.step(&g.top, &s) {
            break;
        }
    }
    t.result()
}

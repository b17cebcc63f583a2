//! Coherent grid traversal of a packet (Wald, Ize, Kensler, Knoll and
//! Parker 2006, "Ray tracing animated scenes using coherent grid
//! traversal"): the packet walks the grid slice by slice along its
//! dominant axis; in each slice it visits the rectangle of cells its rays
//! cross there, testing each cell's triangles against every lane at once.
//! Reads beside `single.rs` (the same cells, margin and exit rule, one
//! slice where the single ray has one cell) and the binary BVH's packet
//! traversal (`bvh/bvh2.rs`: the same leaf and tie rule).
//!
//! It gets packets whose active lanes share their direction signs
//! (`bvh/query.rs`'s front splits octants and sends divergent packets ray
//! by ray). Lanes whose rays miss the grid drop out; lanes with no
//! component along the dominant axis, or whose far origin needs the
//! cells around the walk (`Cells::reach`), go alone through `single.rs`.
//!
//! The slice's rectangle is exact per lane rather than the frustum's of
//! the paper (which bounds the packet by its corner rays and so assumes a
//! common origin): each lane's coordinates where it enters and leaves the
//! slice, clipped to its own interval, so origins may differ and rays may
//! start inside the grid.

use super::Grid;
use super::cells::Cells;
use super::single::{MAILBOX, trace};
use super::walk::Span;
use crate::bvh::packet::accepted;
use crate::kdtree::Counters;
use crate::packet::{HitPacket, PacketShear, RayPacket};
use crate::ray::{Hit, NO_PRIM};
use crate::simd::Lane;
use crate::triangle;
use glam::Vec3;

/// The widest packet (8 lanes).
const LANES: usize = 8;

/// The packet's best hits so far and the lanes that are finished.
struct Best<L: Lane> {
    t: L,
    prim: L::Index,
    u: L,
    v: L,
    /// `ANY`: lanes that found a hit.
    found: u32,
}

/// One cell's triangles against every lane; `true` when `ANY` and every
/// lane of `want` has a hit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn cell_test<L: Lane, const ANY: bool, C: Counters>(
    prims: &[u32],
    corners: &[[Vec3; 3]],
    p: &RayPacket<L>,
    sh: &PacketShear<L>,
    want: u32,
    best: &mut Best<L>,
    out: &mut HitPacket<L>,
    mailbox: &mut Option<[u32; MAILBOX]>,
    c: &mut C,
) -> bool {
    if prims.is_empty() {
        return false;
    }
    c.leaf();
    for &prim in prims {
        // Mailbox: the packet tested it in an earlier cell already.
        if let Some(mb) = mailbox.as_mut() {
            let slot = &mut mb[prim as usize % MAILBOX];
            if *slot == prim {
                c.mailbox_hit();
                continue;
            }
            *slot = prim;
        }
        c.tri(want.count_ones());
        let tri = &corners[prim as usize];
        let h = triangle::intersect(
            &sh.shear,
            sh.corner(&tri[0]),
            sh.corner(&tri[1]),
            sh.corner(&tri[2]),
            p.t_min(),
            best.t,
        );
        let mut hits = L::bits(h.mask);
        if hits == 0 {
            continue;
        }
        let mut hit_mask = h.mask;
        if C::FILTERS {
            hits = accepted(c, hits, prim, &h);
            if hits == 0 {
                continue;
            }
            hit_mask = L::mask_from_bits(hits);
        }
        if ANY {
            // A lane retires at its first hit.
            let new = hits & want & !best.found;
            let mut left = new;
            while left != 0 {
                let i = left.trailing_zeros() as usize;
                left &= left - 1;
                let hit = Hit {
                    t: h.t.lane(i),
                    prim,
                    u: 0.0,
                    v: 0.0,
                };
                out.set(i, Some(hit));
            }
            best.found |= new;
            best.t = L::select(
                L::mask_from_bits(best.found),
                L::splat(f32::NEG_INFINITY),
                best.t,
            );
            if best.found & want == want {
                return true;
            }
            continue;
        }
        // Closer, or as close with a smaller index (ray policy).
        let prim_l = L::index_splat(prim);
        let closer =
            hit_mask & (h.t.lt(best.t) | (h.t.eq(best.t) & L::index_lt(prim_l, best.prim)));
        best.t = L::select(closer, h.t, best.t);
        best.u = L::select(closer, h.u, best.u);
        best.v = L::select(closer, h.v, best.v);
        best.prim = L::index_select(closer, prim_l, best.prim);
    }
    false
}

/// Where a lane's ray enters and leaves slice `slice` along axis `k`; a
/// border slice reaches to infinity (points outside the box belong to it).
#[inline(always)]
fn slice_span(cells: &Cells, s: &Span, k: usize, slice: u32) -> (f64, f64) {
    let at = |plane: f64| (plane - s.org[k]) * s.inv[k];
    let below = if slice == 0 {
        None
    } else {
        Some(at(cells.plane(k, slice)))
    };
    let above = if slice + 1 >= cells.dims[k] {
        None
    } else {
        Some(at(cells.plane(k, slice + 1)))
    };
    let (enter, leave) = if s.dir[k] > 0.0 {
        (below, above)
    } else {
        (above, below)
    };
    (
        enter.unwrap_or(f64::NEG_INFINITY),
        leave.unwrap_or(f64::INFINITY),
    )
}

/// A packet through a uniform grid, slice by slice.
#[inline(always)]
pub(crate) fn traverse<L: Lane, const ANY: bool, C: Counters>(
    g: &Grid,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    let mut out = HitPacket::default();
    let active = p.active();
    if active == 0 || g.cells.prims.is_empty() {
        return out;
    }
    let cells = &g.cells;
    // Each lane's span; lanes that miss the grid drop out here.
    let mut spans = [None::<Span>; LANES];
    let (mut live, mut alone) = (0u32, 0u32);
    let mut weight = [0.0f64; 3];
    for (i, slot) in spans.iter_mut().enumerate().take(L::WIDTH) {
        if active >> i & 1 == 0 {
            continue;
        }
        let Some(r) = p.ray(i) else { continue };
        let Some(s) = Span::new(&r, &g.frame.lo, &g.frame.hi, g.frame.m) else {
            continue;
        };
        if cells.reach(s.eta, g.frame.pad) != [0; 3] {
            alone |= 1 << i;
            continue;
        }
        for (w, d) in weight.iter_mut().zip(s.dir) {
            *w += d.abs();
        }
        *slot = Some(s);
        live |= 1 << i;
    }
    // The dominant axis; lanes with no component along it go alone.
    let k = if weight[0] >= weight[1] && weight[0] >= weight[2] {
        0
    } else if weight[1] >= weight[2] {
        1
    } else {
        2
    };
    let (u, v) = ((k + 1) % 3, (k + 2) % 3);
    for (i, s) in spans.iter_mut().enumerate() {
        if s.is_some_and(|s| s.dir[k] == 0.0) {
            *s = None;
            live &= !(1 << i);
            alone |= 1 << i;
        }
    }
    if live != 0 {
        slices::<L, ANY, C>(g, p, &spans, live, k, [u, v], &mut out, c);
    }
    // The lanes that go alone.
    let mut left = alone;
    while left != 0 {
        let i = left.trailing_zeros() as usize;
        left &= left - 1;
        if let Some(r) = p.ray(i) {
            c.single_ray();
            out.set(i, trace::<ANY, C>(g, &r, c));
        }
    }
    out
}

/// The slice walk of the lanes `live` (their spans all run along `k` the
/// same way).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn slices<L: Lane, const ANY: bool, C: Counters>(
    g: &Grid,
    p: &RayPacket<L>,
    spans: &[Option<Span>; LANES],
    live: u32,
    k: usize,
    [u, v]: [usize; 2],
    out: &mut HitPacket<L>,
    c: &mut C,
) {
    let cells = &g.cells;
    let first = live.trailing_zeros() as usize;
    let neg = spans[first].is_some_and(|s| s.dir[k] < 0.0);
    // The slices the lanes cross, in walk order.
    let (mut lo, mut hi) = (u32::MAX, 0u32);
    for s in spans.iter().flatten() {
        for t in [s.t0, s.t1] {
            let x = cells.coord(k, s.at(k, t));
            lo = lo.min(x);
            hi = hi.max(x);
        }
    }
    let sh: PacketShear<L> = p.shear();
    let corners = g.mesh.corner_slice();
    let mut best = Best {
        t: p.t_max(),
        prim: L::index_splat(NO_PRIM),
        u: L::splat(0.0),
        v: L::splat(0.0),
        found: 0,
    };
    let mut mailbox = g.params.mailbox.then_some([NO_PRIM; MAILBOX]);
    let mut running = live;
    let count = hi - lo + 1;
    'walk: for n in 0..count {
        let slice = if neg { hi - n } else { lo + n };
        // The rectangle of cells the running lanes cross in this slice,
        // and each lane's exit from it.
        let (mut u0, mut u1, mut v0, mut v1) = (u32::MAX, 0u32, u32::MAX, 0u32);
        let mut exits = [f64::INFINITY; LANES];
        let mut left = running;
        while left != 0 {
            let i = left.trailing_zeros() as usize;
            left &= left - 1;
            let Some(s) = &spans[i] else { continue };
            let (ta, tb) = slice_span(cells, s, k, slice);
            exits[i] = tb;
            let (ta, tb) = (ta.max(s.t0), tb.min(s.t1));
            if ta > tb {
                continue;
            }
            for t in [ta, tb] {
                let (cu, cv) = (cells.coord(u, s.at(u, t)), cells.coord(v, s.at(v, t)));
                (u0, u1) = (u0.min(cu), u1.max(cu));
                (v0, v1) = (v0.min(cv), v1.max(cv));
            }
        }
        if u0 <= u1 {
            let mut cell = [0u32; 3];
            cell[k] = slice;
            for cv in v0..=v1 {
                for cu in u0..=u1 {
                    cell[u] = cu;
                    cell[v] = cv;
                    c.node();
                    let prims = cells.cell(cells.index(cell));
                    if cell_test::<L, ANY, C>(
                        prims,
                        corners,
                        p,
                        &sh,
                        live,
                        &mut best,
                        out,
                        &mut mailbox,
                        c,
                    ) {
                        break 'walk;
                    }
                }
            }
        }
        // Lanes whose best hit lies before the slice's far side, or whose
        // interval ends in it, are finished.
        let mut left = running;
        while left != 0 {
            let i = left.trailing_zeros() as usize;
            left &= left - 1;
            let Some(s) = &spans[i] else { continue };
            if f64::from(best.t.lane(i)) < exits[i] || s.t1 <= exits[i] {
                running &= !(1 << i);
            }
        }
        if running == 0 {
            break;
        }
    }
    if !ANY {
        let hit = L::index_lt(best.prim, L::index_splat(NO_PRIM));
        let keep = L::mask_from_bits(live);
        let mine = HitPacket::from_lanes(
            L::select(hit, best.t, L::splat(f32::INFINITY)),
            best.prim,
            best.u,
            best.v,
        );
        out.merge(&mine, L::bits(keep));
    }
}

//! Triangle references during the build, their classification against a
//! split, and split clipping ("perfect splits", Havran 2000; Wald & Havran
//! 2006, section 4.3): a triangle that straddles a split is clipped to each
//! child cell, so its box there is the box of the part inside the cell,
//! not of the whole triangle.
//!
//! Clipping is conservative: the polygon is clipped in f64, its box is
//! widened by a bound on the f64 rounding relative to the triangle's own
//! coordinates (not the clipped part's, which can be far smaller: corners
//! of 10 and a part near 1e-40) and rounded outwards to f32, so the box
//! always contains the true part of the triangle in the cell. When the
//! clipped box and the reference's previous box do not overlap on some
//! axis (the true part is empty or within rounding of it), the reference
//! keeps its unclipped box in that child: a reference is never dropped and
//! never gets an inverted box. Traversal correctness needs exactly that
//! (see ARCHITECTURE.md, "Robustness of the traversal"). `validate()`
//! replays this function to know which leaves must reference which
//! triangle.

use crate::aabb::Aabb;
use glam::{DVec3, Vec3};

/// Index of "not in this child" in [`Sides`].
pub(crate) const NONE: u32 = u32::MAX;

/// Per reference of a node: its index in the below child and in the above
/// child, [`NONE`] where it is not there.
pub(crate) type Sides = Vec<[u32; 2]>;

/// A triangle and the box of its part inside the current cell.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PrimRef {
    pub prim: u32,
    pub lo: [f32; 3],
    pub hi: [f32; 3],
}

impl PrimRef {
    pub fn new(prim: u32, b: &Aabb) -> PrimRef {
        PrimRef {
            prim,
            lo: b.min.to_array(),
            hi: b.max.to_array(),
        }
    }
}

/// Does a box `[lo, hi]` (on the split axis) go below split `s`? Yes if it
/// has a part below, or lies in the plane (planar triangles go below).
#[inline]
pub(crate) fn goes_below(lo: f32, hi: f32, s: f32) -> bool {
    lo < s || hi <= s
}

/// Does a box `[lo, hi]` (on the split axis) go above split `s`?
#[inline]
pub(crate) fn goes_above(_lo: f32, hi: f32, s: f32) -> bool {
    hi > s
}

/// How many of `refs` go below and above a split at `s` on `axis`
/// (straddlers to both): the lengths [`split_refs_sided`] gives.
pub(crate) fn side_counts(refs: &[PrimRef], (axis, s): (usize, f32)) -> (usize, usize) {
    refs.iter().fold((0, 0), |(nb, na), r| {
        (
            nb + usize::from(goes_below(r.lo[axis], r.hi[axis], s)),
            na + usize::from(goes_above(r.lo[axis], r.hi[axis], s)),
        )
    })
}

/// Distribute `refs` of `cell` to the children of a split at `s` on `axis`.
/// Straddling references are clipped to each child when `clip` is set.
pub(crate) fn split_refs(
    corners: &[[Vec3; 3]],
    refs: &[PrimRef],
    cell: &Aabb,
    split: (usize, f32),
    clip: bool,
    below: &mut Vec<PrimRef>,
    above: &mut Vec<PrimRef>,
) {
    let mut buffers = clip.then(ClipBuffers::new);
    split_refs_sided(
        corners,
        refs,
        cell,
        split,
        buffers.as_mut(),
        (below, above),
        None,
    );
}

/// [`split_refs`], also recording in `sides` (when given) each reference's
/// index in `below` and in `above` ([`NONE`] where it is not); `clip`
/// holds the buffers of the clipping (the build's task scratch), `None`
/// for a build without clipping.
pub(crate) fn split_refs_sided(
    corners: &[[Vec3; 3]],
    refs: &[PrimRef],
    cell: &Aabb,
    (axis, s): (usize, f32),
    mut clip: Option<&mut ClipBuffers>,
    (below, above): (&mut Vec<PrimRef>, &mut Vec<PrimRef>),
    mut sides: Option<&mut Sides>,
) {
    let cells = child_cells(cell, (axis, s));
    for r in refs {
        let (b, a) = route(corners, r, &cells, (axis, s), clip.as_deref_mut());
        let side = [
            if b.is_some() {
                below.len() as u32
            } else {
                NONE
            },
            if a.is_some() {
                above.len() as u32
            } else {
                NONE
            },
        ];
        if let Some(sides) = sides.as_deref_mut() {
            sides.push(side);
        }
        if let Some(b) = b {
            below.push(b);
        }
        if let Some(a) = a {
            above.push(a);
        }
    }
}

/// [`split_refs_sided`] for one chunk of a node's references (the
/// parallel split of large nodes, `build.rs`): `below` and `above` are
/// the chunk's slices of the children's arrays, sized by [`side_counts`]
/// of the chunk, `base` is where those slices start in the children, and
/// `sides` (when given) is the chunk's slice of the node's.
pub(crate) fn split_refs_into(
    corners: &[[Vec3; 3]],
    refs: &[PrimRef],
    cell: &Aabb,
    split: (usize, f32),
    clip: bool,
    (below, above): (&mut [PrimRef], &mut [PrimRef]),
    (sides, base): (Option<&mut [[u32; 2]]>, (usize, usize)),
) {
    // The `side` entries repeat `split_refs_sided`'s: one shared helper
    // for both measured 3-7 % slower builds (bunny 1 thread, 1M triangles
    // 2 threads; same trees), so each loop keeps its own.
    let cells = child_cells(cell, split);
    let (mut nb, mut na) = (0, 0);
    let mut sides = sides.map(|s| s.iter_mut());
    // Buffers of its own: the chunks of one node run on several threads,
    // so they cannot share the task's (one zeroing per chunk of 8,192).
    let mut buffers = clip.then(ClipBuffers::new);
    for r in refs {
        let (b, a) = route(corners, r, &cells, split, buffers.as_mut());
        let side = [
            if b.is_some() {
                (base.0 + nb) as u32
            } else {
                NONE
            },
            if a.is_some() {
                (base.1 + na) as u32
            } else {
                NONE
            },
        ];
        if let Some(slot) = sides.as_mut().and_then(Iterator::next) {
            *slot = side;
        }
        if let Some(b) = b {
            below[nb] = b;
            nb += 1;
        }
        if let Some(a) = a {
            above[na] = a;
            na += 1;
        }
    }
    debug_assert_eq!((nb, na), (below.len(), above.len()));
}

/// The cells below and above a split at `s` on `axis`.
fn child_cells(cell: &Aabb, (axis, s): (usize, f32)) -> [Aabb; 2] {
    let (mut cell_below, mut cell_above) = (*cell, *cell);
    cell_below.max[axis] = s;
    cell_above.min[axis] = s;
    [cell_below, cell_above]
}

/// Where one reference goes: its reference in the below child and in the
/// above child, `None` where it does not go (a straddler goes to both,
/// clipped to each cell when `clip` is set).
#[inline]
fn route(
    corners: &[[Vec3; 3]],
    r: &PrimRef,
    [cell_below, cell_above]: &[Aabb; 2],
    (axis, s): (usize, f32),
    mut clip: Option<&mut ClipBuffers>,
) -> (Option<PrimRef>, Option<PrimRef>) {
    let b = goes_below(r.lo[axis], r.hi[axis], s);
    let a = goes_above(r.lo[axis], r.hi[axis], s);
    if b && a {
        let tri = &corners[r.prim as usize];
        (
            Some(clipped(tri, r, cell_below, clip.as_deref_mut())),
            Some(clipped(tri, r, cell_above, clip)),
        )
    } else {
        (b.then_some(*r), a.then_some(*r))
    }
}

/// The reference `r` restricted to `cell`: its box intersected with the
/// cell, and, with `clip`, with the box of the triangle clipped to the cell
/// unless that intersection is empty on some axis (then the clipped box is
/// not used at all: see the module docs).
fn clipped(tri: &[Vec3; 3], r: &PrimRef, cell: &Aabb, clip: Option<&mut ClipBuffers>) -> PrimRef {
    let mut lo = [0.0f32; 3];
    let mut hi = [0.0f32; 3];
    for a in 0..3 {
        lo[a] = r.lo[a].max(cell.min[a]);
        hi[a] = r.hi[a].min(cell.max[a]);
    }
    if let Some(buffers) = clip
        && let Some((clo, chi)) = clip_box(tri, cell, buffers)
    {
        let cl: [f32; 3] = std::array::from_fn(|a| lo[a].max(clo[a]));
        let ch: [f32; 3] = std::array::from_fn(|a| hi[a].min(chi[a]));
        if (0..3).all(|a| cl[a] <= ch[a]) {
            (lo, hi) = (cl, ch);
        }
    }
    PrimRef {
        prim: r.prim,
        lo,
        hi,
    }
}

/// Sutherland-Hodgman's two polygon buffers for [`clip_box`]. A triangle
/// clipped by six planes has at most 9 corners in exact arithmetic;
/// rounding can bend the polygon, and a pass outputs at most two points
/// per edge, so each buffer holds twice the most a pass may start with
/// ([`MAX_IN`]). Made once per build task (the build's scratch; once per
/// chunk or split elsewhere) and reused by each straddler's clip: zeroing
/// two fresh buffers per clip was 2 % of the default build's instructions
/// (bunny, callgrind).
pub(crate) struct ClipBuffers([[DVec3; 2 * MAX_IN]; 2]);

/// The most corners a clipping pass may start with.
const MAX_IN: usize = 16;

impl ClipBuffers {
    pub(crate) fn new() -> ClipBuffers {
        ClipBuffers([[DVec3::ZERO; 2 * MAX_IN]; 2])
    }
}

/// Largest f32 not above `x`.
fn down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// Smallest f32 not below `x`.
fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// Box of the triangle clipped to `cell` (Sutherland-Hodgman in f64), or
/// `None` when nothing is left (then the caller keeps the unclipped box,
/// which is conservative).
fn clip_box(
    tri: &[Vec3; 3],
    cell: &Aabb,
    buffers: &mut ClipBuffers,
) -> Option<([f32; 3], [f32; 3])> {
    // Fixed-size buffers keep the clip off the heap: it runs for every
    // straddler at every split, and a `Vec` per call put 13 % of the
    // bunny's build in malloc and free.
    let [a, b] = &mut buffers.0;
    let (mut poly, mut next) = (a, b);
    for (k, v) in tri.iter().enumerate() {
        poly[k] = v.as_dvec3();
    }
    let mut len = 3;
    for axis in 0..3 {
        for (bound, keep_above) in [
            (cell.min[axis] as f64, true),
            (cell.max[axis] as f64, false),
        ] {
            let inside = |p: &DVec3| {
                if keep_above {
                    p[axis] >= bound
                } else {
                    p[axis] <= bound
                }
            };
            // Nothing to clip on this side: skip the pass (most planes of
            // a cell are far from a straddler's part).
            if poly[..len].iter().all(inside) {
                continue;
            }
            // Never reached by a triangle; if rounding ever bent a polygon
            // that far, the unclipped box is still conservative.
            if len > MAX_IN {
                return None;
            }
            let mut out = 0;
            for i in 0..len {
                let (p, q) = (poly[i], poly[(i + 1) % len]);
                let (pin, qin) = (inside(&p), inside(&q));
                if pin {
                    next[out] = p;
                    out += 1;
                }
                if pin != qin {
                    let t = (bound - p[axis]) / (q[axis] - p[axis]);
                    let mut x = p + (q - p) * t;
                    x[axis] = bound;
                    next[out] = x;
                    out += 1;
                }
            }
            std::mem::swap(&mut poly, &mut next);
            len = out;
            if len == 0 {
                return None;
            }
        }
    }
    let poly = &poly[..len];
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for p in poly {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    // The interpolated corners carry f64 rounding of the order of the
    // triangle's coordinates (each is `p + (q - p) * t` with `p`, `q` inside
    // the triangle's box), which can be far larger than the clipped part's
    // (corners of 10, a part near 1e-40): widen by 1e-12 times the largest
    // corner coordinate (several hundred f64 ulps of it) before rounding
    // outwards to f32, so the box stays conservative.
    let scale = tri
        .iter()
        .map(|v| v.abs().max_element())
        .fold(0.0f32, f32::max) as f64;
    let pad = (hi - lo)
        .max_element()
        .max(lo.abs().max(hi.abs()).max_element())
        .max(scale)
        * 1e-12;
    Some((
        [0, 1, 2].map(|a| down(lo[a] - pad)),
        [0, 1, 2].map(|a| up(hi[a] + pad)),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    #[test]
    fn rounding_is_outwards() {
        let x = 0.1f64;
        assert!((down(x) as f64) <= x && (up(x) as f64) >= x);
        assert_eq!(down(1.0), 1.0);
        assert_eq!(up(1.0), 1.0);
    }

    #[test]
    fn clipping_shrinks_a_diagonal_triangle_and_keeps_it_conservative() {
        // A triangle along the diagonal of the unit square, clipped to the
        // lower-left quarter: its part there is far smaller than its box.
        let tri = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 0.1, 0.0),
        ];
        let cell = Aabb::new(Vec3A::new(0.0, 0.0, -1.0), Vec3A::new(0.5, 1.0, 1.0));
        let (lo, hi) = clip_box(&tri, &cell, &mut ClipBuffers::new()).unwrap();
        assert!(hi[1] >= 0.55 && hi[1] < 0.56, "{hi:?}");
        assert!(lo[0] <= 0.0 && hi[0] >= 0.5);
        // sampled points of the triangle inside the cell are in the box
        for i in 0..=20 {
            for j in 0..=(20 - i) {
                let (u, v) = (i as f32 / 20.0, j as f32 / 20.0);
                let p = tri[0] * (1.0 - u - v) + tri[1] * u + tri[2] * v;
                if cell.contains(p.into()) {
                    for a in 0..3 {
                        assert!(p[a] >= lo[a] && p[a] <= hi[a], "{p} {lo:?} {hi:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_sliver_from_f64_rounding_never_inverts_a_box() {
        // From `split_clipping_with_subnormal_coordinates_validates`: the
        // triangle's part in this thin cell is empty (it is at z >= 3.8e-22
        // there), but f64 rounding of order 1e-15 leaves a sliver. The
        // reference must keep a box with `lo <= hi` inside its old box.
        let tri = [
            Vec3::new(14.25, 14.25, 14.25),
            Vec3::new(3.71647e-40, 1.5046342e-36, 4.235169e-22),
            Vec3::new(3.0, 0.0, 0.0),
        ];
        let r = PrimRef {
            prim: 3,
            lo: [3.71647e-40, 0.0, 0.0],
            hi: [0.25, 1.5046342e-36, 2.3509886e-38],
        };
        let cell = Aabb::new(Vec3A::ZERO, Vec3A::new(0.25, 1.5046342e-36, 2.3509886e-38));
        let c = clipped(&tri, &r, &cell, Some(&mut ClipBuffers::new()));
        for a in 0..3 {
            assert!(c.lo[a] <= c.hi[a], "{c:?}");
            assert!(c.lo[a] >= r.lo[a] && c.hi[a] <= r.hi[a], "{c:?}");
        }
        // The pad is relative to the triangle's corners, not the sliver's.
        if let Some((lo, hi)) = clip_box(&tri, &cell, &mut ClipBuffers::new()) {
            assert!(hi[0] - lo[0] >= 1e-12, "{lo:?} {hi:?}");
        }
    }

    #[test]
    fn classification_rule() {
        assert!(goes_below(0.0, 2.0, 1.0) && goes_above(0.0, 2.0, 1.0));
        assert!(goes_below(0.0, 1.0, 1.0) && !goes_above(0.0, 1.0, 1.0));
        assert!(!goes_below(1.0, 2.0, 1.0) && goes_above(1.0, 2.0, 1.0));
        assert!(goes_below(1.0, 1.0, 1.0) && !goes_above(1.0, 1.0, 1.0));
    }

    #[test]
    fn split_refs_clips_only_straddlers() {
        let corners = vec![
            [
                Vec3::ZERO,
                Vec3::new(2.0, 2.0, 0.0),
                Vec3::new(0.0, 0.2, 0.0),
            ],
            [
                Vec3::ZERO,
                Vec3::new(0.5, 0.0, 0.0),
                Vec3::new(0.0, 0.5, 0.0),
            ],
        ];
        let cell = Aabb::new(Vec3A::ZERO, Vec3A::new(2.0, 2.0, 0.0));
        let refs: Vec<PrimRef> = corners
            .iter()
            .enumerate()
            .map(|(i, c)| PrimRef::new(i as u32, &Aabb::from_points(c)))
            .collect();
        let (mut b, mut a) = (Vec::new(), Vec::new());
        split_refs(&corners, &refs, &cell, (0, 1.0), true, &mut b, &mut a);
        assert_eq!(b.iter().map(|r| r.prim).collect::<Vec<_>>(), vec![0, 1]);
        assert_eq!(a.iter().map(|r| r.prim).collect::<Vec<_>>(), vec![0]);
        // the big triangle's part above x = 1 starts at y >= 1 - slack
        assert!(a[0].lo[1] > 0.99 && a[0].lo[0] == 1.0);
        // unclipped, it keeps its whole box within the child
        let (mut b2, mut a2) = (Vec::new(), Vec::new());
        split_refs(&corners, &refs, &cell, (0, 1.0), false, &mut b2, &mut a2);
        assert_eq!(a2[0].lo[1], 0.0);
    }
}

//! Surface area heuristic kd-tree build (MacDonald & Booth 1990; PBRT-v3
//! `KdTreeAccel`; Wald & Havran 2006 for the cost model).
//!
//! Per node, every axis is tried: an exact sweep over the sorted triangle
//! box edges for small nodes (O(n log n) per node, O(N log^2 N) in all),
//! and a binned sweep for large ones (O(n) per node). Large subtrees are
//! built in parallel with `rayon::join` and appended in a fixed order, so
//! the tree is the same for any thread count.
//!
//! References carry the box of their triangle's part in the cell, and
//! are classified and clipped by `clip.rs` (straddlers go to both sides,
//! optionally clipped to each; a triangle lying in the plane goes below).

use super::clip::{PrimRef, split_refs};
use super::node::{KdNode, MAX_INDEX};
use super::params::{BuildError, KdBuildParams};
use crate::aabb::Aabb;
use glam::Vec3;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Subtrees with more triangles than this are built in parallel.
const PARALLEL_ABOVE: usize = 8192;

/// The flat output of a (sub)tree build.
#[derive(Default)]
pub(crate) struct Built {
    pub nodes: Vec<KdNode>,
    pub leaf_prims: Vec<u32>,
}

struct Ctx<'a> {
    corners: &'a [[Vec3; 3]],
    p: &'a KdBuildParams,
    max_depth: u32,
    /// Bytes of nodes and leaf indices emitted so far (all threads).
    emitted: AtomicUsize,
}

/// Buffers of the exact sweep, reused by every node one thread builds
/// (three vectors per axis per node were most of the build's malloc time).
#[derive(Default)]
struct Scratch {
    keys: Vec<u32>,
    mins: Vec<f32>,
    maxs: Vec<f32>,
    planar: Vec<f32>,
    /// Per bin of the binned sweep: box minima, box maxima.
    min_count: Vec<usize>,
    max_count: Vec<usize>,
}

#[derive(Clone, Copy)]
struct Split {
    axis: usize,
    pos: f32,
    cost: f32,
}

/// Build over the references `prims` (non-degenerate triangles) inside
/// `bounds`.
pub(crate) fn build(
    corners: &[[Vec3; 3]],
    prims: Vec<PrimRef>,
    bounds: Aabb,
    p: &KdBuildParams,
    max_depth: u32,
) -> Result<Built, BuildError> {
    let ctx = Ctx {
        corners,
        p,
        max_depth,
        emitted: AtomicUsize::new(0),
    };
    let mut out = Built::default();
    build_node(&ctx, prims, bounds, 0, 0, &mut Scratch::default(), &mut out)?;
    Ok(out)
}

/// Account for `bytes` more output against the memory budget.
fn charge(ctx: &Ctx, bytes: usize) -> Result<(), BuildError> {
    let total = ctx.emitted.fetch_add(bytes, Ordering::Relaxed) + bytes;
    match ctx.p.memory_budget {
        Some(budget) if total > budget => Err(BuildError::MemoryBudget {
            needed: total,
            budget,
        }),
        _ => Ok(()),
    }
}

fn push_leaf(ctx: &Ctx, refs: &[PrimRef], out: &mut Built) -> Result<(), BuildError> {
    let n = refs.len();
    charge(ctx, 8 + if n > 1 { 4 * n } else { 0 })?;
    let count = u32::try_from(n).map_err(|_| BuildError::LeafTooLarge(n))?;
    let first = match refs {
        [only] => only.prim,
        _ => {
            let off = out.leaf_prims.len();
            if off > u32::MAX as usize {
                return Err(BuildError::TooManyReferences(off));
            }
            out.leaf_prims.extend(refs.iter().map(|r| r.prim));
            off as u32
        }
    };
    let node = KdNode::leaf(first, count).map_err(|_| BuildError::LeafTooLarge(n))?;
    out.nodes.push(node);
    Ok(())
}

fn build_node(
    ctx: &Ctx,
    prims: Vec<PrimRef>,
    cell: Aabb,
    depth: u32,
    bad_refines: u32,
    scratch: &mut Scratch,
    out: &mut Built,
) -> Result<(), BuildError> {
    if out.nodes.len() > MAX_INDEX as usize {
        return Err(BuildError::TooManyNodes(out.nodes.len()));
    }
    let n = prims.len();
    if n <= ctx.p.max_leaf_size as usize || depth >= ctx.max_depth {
        return push_leaf(ctx, &prims, out);
    }
    let leaf_cost = ctx.p.intersection_cost * n as f32;
    let Some(best) = find_split(ctx, &prims, &cell, scratch) else {
        return push_leaf(ctx, &prims, out);
    };
    // PBRT's termination: allow a few splits that do not lower the cost
    // below a leaf's ("bad refines"), in the hope that their children pay
    // off. `>=`: a split that only ties the leaf is no refinement either.
    let bad_refines = bad_refines + u32::from(best.cost >= leaf_cost);
    if (best.cost > 4.0 * leaf_cost && n < 16) || bad_refines >= ctx.p.max_bad_refines {
        return push_leaf(ctx, &prims, out);
    }

    let (axis, s) = (best.axis, best.pos);
    let mut below = Vec::with_capacity(n);
    let mut above = Vec::with_capacity(n);
    split_refs(
        ctx.corners,
        &prims,
        &cell,
        (axis, s),
        ctx.p.split_clipping,
        &mut below,
        &mut above,
    );
    drop(prims);
    charge(ctx, 8)?;
    let (mut cell_below, mut cell_above) = (cell, cell);
    cell_below.max[axis] = s;
    cell_above.min[axis] = s;

    let me = out.nodes.len();
    // Placeholder, rewritten once the above child's index is known.
    out.nodes.push(KdNode::EMPTY_LEAF);
    let above_index = if n > PARALLEL_ABOVE {
        let (rb, ra) = rayon::join(
            || {
                let mut sub = Built::default();
                let mut scratch = Scratch::default();
                build_node(
                    ctx,
                    below,
                    cell_below,
                    depth + 1,
                    bad_refines,
                    &mut scratch,
                    &mut sub,
                )
                .map(|_| sub)
            },
            || {
                let mut sub = Built::default();
                let mut scratch = Scratch::default();
                build_node(
                    ctx,
                    above,
                    cell_above,
                    depth + 1,
                    bad_refines,
                    &mut scratch,
                    &mut sub,
                )
                .map(|_| sub)
            },
        );
        append(out, rb?)?;
        let above_index = out.nodes.len();
        append(out, ra?)?;
        above_index
    } else {
        build_node(ctx, below, cell_below, depth + 1, bad_refines, scratch, out)?;
        let above_index = out.nodes.len();
        build_node(ctx, above, cell_above, depth + 1, bad_refines, scratch, out)?;
        above_index
    };
    let above_index =
        u32::try_from(above_index).map_err(|_| BuildError::TooManyNodes(above_index))?;
    out.nodes[me] = KdNode::interior(axis, s, above_index)
        .map_err(|_| BuildError::TooManyNodes(above_index as usize))?;
    Ok(())
}

/// Append a subtree built on its own, re-basing its indices.
fn append(out: &mut Built, sub: Built) -> Result<(), BuildError> {
    let node_base = out.nodes.len();
    let prim_base = out.leaf_prims.len();
    if node_base + sub.nodes.len() > MAX_INDEX as usize + 1 {
        return Err(BuildError::TooManyNodes(node_base + sub.nodes.len()));
    }
    if prim_base + sub.leaf_prims.len() > u32::MAX as usize {
        return Err(BuildError::TooManyReferences(
            prim_base + sub.leaf_prims.len(),
        ));
    }
    for n in sub.nodes {
        let r = n
            .rebased(node_base as u32, prim_base as u32)
            .map_err(|_| BuildError::TooManyNodes(node_base))?;
        out.nodes.push(r);
    }
    out.leaf_prims.extend_from_slice(&sub.leaf_prims);
    Ok(())
}

/// SAH cost of splitting `cell` on `axis` at `s` with `nb` / `na`
/// triangles below / above: PBRT-v3's cost, with the empty-space bonus
/// scaled by the share of the cell's extent the empty child spans.
/// PBRT's flat bonus makes any empty sliver, however thin, beat every
/// balanced split, so trees peel slivers one depth level at a time and
/// reach the depth limit with leaves of dozens of triangles (on
/// `gen:scalable:100000`: SAH cost 405 with the flat bonus, 58 scaled;
/// ARCHITECTURE.md, "The flat empty-space bonus").
#[inline]
fn sah(
    p: &KdBuildParams,
    cell: &Aabb,
    inv_sa: f32,
    axis: usize,
    s: f32,
    nb: usize,
    na: usize,
) -> f32 {
    let e = cell.extent();
    let (o1, o2) = ((axis + 1) % 3, (axis + 2) % 3);
    let face = e[o1] * e[o2];
    let perim = e[o1] + e[o2];
    let (below, above) = (s - cell.min[axis], cell.max[axis] - s);
    let sa_below = 2.0 * (face + below * perim);
    let sa_above = 2.0 * (face + above * perim);
    let empty = if nb == 0 {
        below
    } else if na == 0 {
        above
    } else {
        0.0
    };
    let bonus = p.empty_bonus * (empty / e[axis]);
    p.traversal_cost
        + p.intersection_cost
            * (1.0 - bonus)
            * (sa_below * inv_sa * nb as f32 + sa_above * inv_sa * na as f32)
}

/// The box the SAH prices a cell by. A cell of zero extent on one axis
/// (only possible when the scene box is flat: splits lie strictly inside
/// their cells) gets a virtual thickness there equal to its smallest
/// other extent. Without it the children's areas sum to the parent's, so
/// the SAH charges nothing for duplicating straddling triangles and flat
/// scenes split to the depth limit (749 references per triangle on a
/// 3,400-triangle plane); with it a flat scene is priced like the same
/// scene tilted (12 references per triangle). Other cells are unchanged.
fn priced_cell(cell: &Aabb) -> Aabb {
    let e = cell.extent();
    let thickness = (0..3)
        .map(|k| e[k])
        .filter(|&x| x > 0.0)
        .fold(f32::INFINITY, f32::min);
    let mut priced = *cell;
    for k in 0..3 {
        if e[k] == 0.0 && thickness.is_finite() {
            priced.max[k] = priced.min[k] + thickness;
        }
    }
    priced
}

/// Does a candidate split separate nothing, both children getting all `n`
/// references? Such a split only duplicates; it is never a candidate.
/// Also refusing splits where one child gets all and the other only
/// duplicates was measured and not kept: everywhere it halves references
/// but raises the pbrt preset's SAH cost up to 6 % (bunny); in flat cells,
/// on top of `priced_cell`, it tripled references on `flat_x` (9.6 -> 29.7).
#[inline]
fn separates_nothing(n: usize, nb: usize, na: usize) -> bool {
    nb == n && na == n
}

fn find_split(ctx: &Ctx, prims: &[PrimRef], cell: &Aabb, scratch: &mut Scratch) -> Option<Split> {
    // A cell flat on two axes (or NaN) has no area to split by.
    let sa = cell.surface_area();
    if sa.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !sa.is_finite() {
        return None;
    }
    let e = cell.extent();
    let flat = e.x == 0.0 || e.y == 0.0 || e.z == 0.0;
    let priced = if flat { priced_cell(cell) } else { *cell };
    let sa = priced.surface_area();
    if !sa.is_finite() {
        return None;
    }
    let inv_sa = 1.0 / sa;
    let binned = prims.len() > ctx.p.exact_below;
    let scales = if binned {
        bin_all_axes(ctx.p, prims, &priced, scratch)
    } else {
        [0.0; 3]
    };
    let mut best: Option<Split> = None;
    for (axis, scale) in scales.into_iter().enumerate() {
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        if lo >= hi {
            continue;
        }
        // `priced` equals `cell` on every axis that can be split.
        let cand = if binned {
            binned_axis(ctx, prims.len(), &priced, inv_sa, (axis, scale), scratch)
        } else {
            exact_axis(ctx, prims, &priced, inv_sa, axis, scratch)
        };
        if let Some(c) = cand
            && best.is_none_or(|b| c.cost < b.cost)
        {
            best = Some(c);
        }
    }
    best
}

/// Exact sweep: every distinct box edge strictly inside the cell is a
/// candidate; counts follow the classification rule exactly.
fn exact_axis(
    ctx: &Ctx,
    prims: &[PrimRef],
    cell: &Aabb,
    inv_sa: f32,
    axis: usize,
    scratch: &mut Scratch,
) -> Option<Split> {
    let n = prims.len();
    let Scratch {
        keys,
        mins,
        maxs,
        planar,
        ..
    } = scratch;
    sorted(prims.iter().map(|r| r.lo[axis]), keys, mins);
    sorted(prims.iter().map(|r| r.hi[axis]), keys, maxs);
    sorted(
        prims
            .iter()
            .filter(|r| r.lo[axis] == r.hi[axis])
            .map(|r| r.lo[axis]),
        keys,
        planar,
    );
    let (mins, maxs, planar) = (&mins[..], &maxs[..], &planar[..]);
    let (lo, hi) = (cell.min[axis], cell.max[axis]);
    let (mut i_min, mut i_max, mut p_lo, mut p_hi) = (0, 0, 0, 0);
    let (mut a, mut b) = (0, 0);
    let mut best: Option<Split> = None;
    let mut last = f32::NEG_INFINITY;
    // Merge the two sorted edge lists; each distinct value is a candidate.
    while a < n || b < n {
        let s = if b >= n || (a < n && mins[a] <= maxs[b]) {
            a += 1;
            mins[a - 1]
        } else {
            b += 1;
            maxs[b - 1]
        };
        if s == last || s <= lo || s >= hi {
            last = s;
            continue;
        }
        last = s;
        while i_min < n && mins[i_min] < s {
            i_min += 1;
        }
        while i_max < n && maxs[i_max] <= s {
            i_max += 1;
        }
        while p_lo < planar.len() && planar[p_lo] < s {
            p_lo += 1;
        }
        p_hi = p_hi.max(p_lo);
        while p_hi < planar.len() && planar[p_hi] <= s {
            p_hi += 1;
        }
        let nb = i_min + (p_hi - p_lo);
        let na = n - i_max;
        if separates_nothing(n, nb, na) {
            continue;
        }
        let cost = sah(ctx.p, cell, inv_sa, axis, s, nb, na);
        if best.is_none_or(|bs| cost < bs.cost) {
            best = Some(Split { axis, pos: s, cost });
        }
    }
    best
}

/// The order-preserving integer key of an `f32`: keys compare as
/// `f32::total_cmp` compares the values. The exact sweep sorts keys, an
/// integer comparison instead of `total_cmp`'s per comparison.
#[inline]
fn key(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// `out` := `values` in `f32::total_cmp` order, sorted as integer keys
/// in `keys` (the same order and values as sorting the floats).
fn sorted(values: impl Iterator<Item = f32>, keys: &mut Vec<u32>, out: &mut Vec<f32>) {
    keys.clear();
    keys.extend(values.map(key));
    keys.sort_unstable();
    out.clear();
    out.extend(keys.iter().map(|&k| value(k)));
}

/// The value of a [`key`].
#[inline]
fn value(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

/// Count the references' box minima and maxima per bin on all three axes
/// in one pass (axis `a`'s counts at `a * bins..`); returns the bins per
/// unit of `cell` on each axis, 0 where the cell cannot be binned (no
/// extent, or so thin that the scale overflows). One pass instead of one
/// per axis: the references are read once.
fn bin_all_axes(
    p: &KdBuildParams,
    prims: &[PrimRef],
    cell: &Aabb,
    scratch: &mut Scratch,
) -> [f32; 3] {
    let bins = p.bins as usize;
    let scale: [f32; 3] = std::array::from_fn(|a| {
        let scale = bins as f32 / (cell.max[a] - cell.min[a]);
        if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            0.0
        }
    });
    let lo = cell.min.to_array();
    // Clamped in f32 (`as` saturates negatives to 0): cheaper than an
    // integer clamp, the same bins.
    let last_bin = (bins - 1) as f32;
    let Scratch {
        min_count,
        max_count,
        ..
    } = scratch;
    min_count.clear();
    min_count.resize(3 * bins, 0);
    max_count.clear();
    max_count.resize(3 * bins, 0);
    for r in prims {
        for a in 0..3 {
            let b_min = ((r.lo[a] - lo[a]) * scale[a]).min(last_bin) as usize;
            let b_max = ((r.hi[a] - lo[a]) * scale[a]).min(last_bin) as usize;
            min_count[a * bins + b_min] += 1;
            max_count[a * bins + b_max] += 1;
        }
    }
    scale
}

/// Binned sweep for large nodes over the counts and `scale` of
/// [`bin_all_axes`]:
/// candidates at the inner bin boundaries.
fn binned_axis(
    ctx: &Ctx,
    n: usize,
    cell: &Aabb,
    inv_sa: f32,
    (axis, scale): (usize, f32),
    scratch: &Scratch,
) -> Option<Split> {
    let bins = ctx.p.bins as usize;
    if scale == 0.0 {
        return None;
    }
    let (lo, hi) = (cell.min[axis], cell.max[axis]);
    let min_count = &scratch.min_count[axis * bins..(axis + 1) * bins];
    let max_count = &scratch.max_count[axis * bins..(axis + 1) * bins];
    let mut nb = 0;
    let mut na = n;
    let mut best: Option<Split> = None;
    for k in 1..bins {
        nb += min_count[k - 1];
        na -= max_count[k - 1];
        let s = lo + (hi - lo) * (k as f32 / bins as f32);
        if s <= lo || s >= hi || separates_nothing(n, nb, na) {
            continue;
        }
        let cost = sah(ctx.p, cell, inv_sa, axis, s, nb, na);
        if best.is_none_or(|bs| cost < bs.cost) {
            best = Some(Split { axis, pos: s, cost });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_sort_as_total_cmp_and_give_the_values_back() {
        let xs = [
            f32::NEG_INFINITY,
            f32::MIN,
            -1.0,
            -1.0e-45,
            -0.0,
            0.0,
            1.0e-45,
            1.0,
            2.5,
            f32::MAX,
            f32::INFINITY,
        ];
        for w in xs.windows(2) {
            assert!(key(w[0]) < key(w[1]), "{} {}", w[0], w[1]);
        }
        for &x in &xs {
            assert_eq!(value(key(x)).to_bits(), x.to_bits());
        }
        let mut shuffled: Vec<u32> = xs.iter().rev().map(|&x| key(x)).collect();
        shuffled.sort_unstable();
        let back: Vec<u32> = shuffled.iter().map(|&k| value(k).to_bits()).collect();
        assert_eq!(back, xs.map(f32::to_bits));
    }
}

//! Surface area heuristic kd-tree build (MacDonald & Booth 1990; PBRT-v3
//! `KdTreeAccel`; Wald & Havran 2006 for the cost model).
//!
//! Per node, every axis is tried: an exact sweep over the triangle box
//! edges for small nodes, sorted once and kept sorted from node to node
//! (`events.rs`, Wald & Havran 2006: O(n) per node), and a binned sweep
//! for large ones (O(n) per node). Large subtrees are
//! built in parallel with `rayon::join` and appended in a fixed order, and
//! the largest nodes bin and partition their references in parallel
//! chunks (`split_in_chunks`), so the tree is the same for any thread
//! count.
//!
//! References carry the box of their triangle's part in the cell, and
//! are classified and clipped by `clip.rs` (straddlers go to both sides,
//! optionally clipped to each; a triangle lying in the plane goes below).

use super::clip::{
    ClipBuffers, NONE, PrimRef, Sides, side_counts, split_refs_into, split_refs_sided,
};
use super::events::{self, EventBuffers, Events};
use super::ledger::{Account, Ledger};
use super::node::{KdNode, MAX_INDEX};
use super::params::{BuildError, KdBuildParams};
use crate::aabb::Aabb;
use crate::simd::F4;
use glam::Vec3;
use rayon::prelude::*;

/// Subtrees with more triangles than this are built in parallel.
const PARALLEL_ABOVE: usize = 8192;

/// Nodes with more references than this are binned, counted and
/// partitioned in parallel too (the upper levels, where the subtrees are
/// still few), in chunks of [`CHUNK`] references: the chunks' integer
/// counts add up and their slices of the children's arrays follow one
/// another in the chunks' order, so the tree is the same for any thread
/// count.
const PARALLEL_SPLIT_ABOVE: usize = 1 << 15;

/// References per chunk of a parallel split.
const CHUNK: usize = 1 << 13;

/// The flat output of a (sub)tree build.
#[derive(Default)]
pub(crate) struct Built {
    pub nodes: Vec<KdNode>,
    pub leaf_prims: Vec<u32>,
    /// The most bytes the build held at once ([`Ledger`]); set by
    /// [`build`] only.
    pub peak_bytes: usize,
}

struct Ctx<'a> {
    corners: &'a [[Vec3; 3]],
    p: &'a KdBuildParams,
    max_depth: u32,
    /// Every byte the build holds and emits (all threads), against the
    /// memory budget.
    ledger: Ledger,
    /// Test oracle: sort each exact node's edges anew, as the build did
    /// before the events were kept sorted (`tests` below).
    #[cfg(test)]
    resort: bool,
}

/// Buffers reused by every node one task builds.
struct Scratch<'a> {
    /// Where each reference of the node being split went.
    sides: Sides,
    /// The straddlers' events of the split, spare event arrays.
    events: EventBuffers,
    /// Per bin of the binned sweep: box minima, box maxima.
    min_count: Vec<usize>,
    max_count: Vec<usize>,
    /// The clipping's polygon buffers.
    clip: ClipBuffers,
    /// This task's charges on the ledger.
    account: Account<'a>,
    /// The bytes of the buffers above, charged to `account`.
    held: usize,
}

impl<'a> Scratch<'a> {
    fn new(ctx: &'a Ctx) -> Scratch<'a> {
        Scratch {
            sides: Sides::new(),
            events: EventBuffers::default(),
            min_count: Vec::new(),
            max_count: Vec::new(),
            clip: ClipBuffers::new(),
            account: Account::new(&ctx.ledger),
            held: 0,
        }
    }

    /// Charge what the buffers hold now.
    fn account_buffers(&mut self) -> Result<(), BuildError> {
        let counts = self.min_count.capacity() + self.max_count.capacity();
        let bytes = self.sides.capacity() * size_of::<[u32; 2]>()
            + counts * size_of::<usize>()
            + self.events.bytes();
        self.account.resize(&mut self.held, bytes)
    }
}

impl Drop for Scratch<'_> {
    fn drop(&mut self) {
        self.account.release(self.held);
    }
}

#[derive(Clone, Copy)]
struct Split {
    axis: usize,
    pos: f32,
    cost: f32,
    /// The references below and above, where the sweep counted them
    /// exactly (the exact sweep; not the binned one).
    counts: Option<(usize, usize)>,
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
        ledger: Ledger::new(p.memory_budget),
        #[cfg(test)]
        resort: false,
    };
    build_with(&ctx, prims, bounds)
}

fn build_with(ctx: &Ctx, prims: Vec<PrimRef>, bounds: Aabb) -> Result<Built, BuildError> {
    let mut out = Built::default();
    let mut scratch = Scratch::new(ctx);
    let held = refs_bytes(&prims);
    scratch.account.charge(held)?;
    let node = Node {
        prims,
        events: None,
        held,
        cell: bounds,
        depth: 0,
        bad_refines: 0,
    };
    build_node(ctx, node, &mut scratch, &mut out)?;
    drop(scratch);
    out.peak_bytes = ctx.ledger.peak();
    Ok(out)
}

/// Bytes of a reference array (its capacity).
fn refs_bytes(prims: &Vec<PrimRef>) -> usize {
    prims.capacity() * size_of::<PrimRef>()
}

/// Emit a leaf of `refs`, whose array (`held` bytes) is then spent.
fn push_leaf(
    refs: &[PrimRef],
    held: usize,
    account: &mut Account,
    out: &mut Built,
) -> Result<(), BuildError> {
    let n = refs.len();
    account.release(held);
    account.charge(8 + if n > 1 { 4 * n } else { 0 })?;
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

/// A node to build: its references (and their sorted events, when a
/// parent's split made them), its cell and its place on the path.
struct Node {
    prims: Vec<PrimRef>,
    events: Option<Events>,
    /// The bytes of `prims` and `events`, charged to the ledger.
    held: usize,
    cell: Aabb,
    depth: u32,
    bad_refines: u32,
}

impl Node {
    /// Will this node be a leaf whatever the SAH says?
    fn is_leaf_outright(ctx: &Ctx, n: usize, depth: u32) -> bool {
        n <= ctx.p.max_leaf_size as usize || depth >= ctx.max_depth
    }

    /// Does this node take the exact sweep (and so need events)?
    fn is_exact(ctx: &Ctx, n: usize) -> bool {
        n <= ctx.p.exact_below && n < events::MAX_REFS
    }
}

fn build_node<'a>(
    ctx: &'a Ctx,
    node: Node,
    scratch: &mut Scratch<'a>,
    out: &mut Built,
) -> Result<(), BuildError> {
    if out.nodes.len() > MAX_INDEX as usize {
        return Err(BuildError::TooManyNodes(out.nodes.len()));
    }
    let Node {
        prims,
        events,
        mut held,
        cell,
        depth,
        bad_refines,
    } = node;
    let n = prims.len();
    if Node::is_leaf_outright(ctx, n, depth) {
        return push_leaf(&prims, held, &mut scratch.account, out);
    }
    // Sorted once, here, for the first exact node on a path; below it each
    // split hands its children their events still sorted.
    let events = match events {
        Some(ev) => Some(ev),
        None if Node::is_exact(ctx, n) => {
            let ev = Events::of(&prims, &mut scratch.events);
            // Its array may have come from the spares: out of the
            // scratch's bytes first, then into the node's.
            scratch.account_buffers()?;
            scratch
                .account
                .resize(&mut held, refs_bytes(&prims) + ev.bytes())?;
            Some(ev)
        }
        None => None,
    };
    let leaf_cost = ctx.p.intersection_cost * n as f32;
    let Some(best) = find_split(ctx, &prims, events.as_ref(), &cell, scratch) else {
        return push_leaf(&prims, held, &mut scratch.account, out);
    };
    // PBRT's termination: allow a few splits that do not lower the cost
    // below a leaf's ("bad refines"), in the hope that their children pay
    // off. `>=`: a split that only ties the leaf is no refinement either.
    let bad_refines = bad_refines + u32::from(best.cost >= leaf_cost);
    if (best.cost > 4.0 * leaf_cost && n < 16) || bad_refines >= ctx.p.max_bad_refines {
        return push_leaf(&prims, held, &mut scratch.account, out);
    }

    let (axis, s) = (best.axis, best.pos);
    // Reusing spent nodes' reference arrays here (as the events' are) was
    // measured: no faster (within 2 %, either way by preset).
    // The children's arrays at their size: counted by the exact sweep, or
    // here for a binned split (whose bin counts may differ by rounding).
    // A large node counts per chunk, on every thread.
    let chunk_counts: Vec<(usize, usize)> = if n > PARALLEL_SPLIT_ABOVE {
        prims
            .par_chunks(CHUNK)
            .map(|c| side_counts(c, (axis, s)))
            .collect()
    } else {
        Vec::new()
    };
    let (nb, na) = match best.counts {
        _ if !chunk_counts.is_empty() => chunk_counts
            .iter()
            .fold((0, 0), |(nb, na), (b, a)| (nb + b, na + a)),
        Some(counts) => counts,
        None => side_counts(&prims, (axis, s)),
    };
    debug_assert!(best.counts.is_none_or(|c| c == (nb, na)));
    let mut below = Vec::with_capacity(nb);
    let mut above = Vec::with_capacity(na);
    let (mut held_below, mut held_above) = (refs_bytes(&below), refs_bytes(&above));
    scratch.account.charge(held_below + held_above)?;
    scratch.sides.clear();
    let sides = events.is_some().then_some(&mut scratch.sides);
    if chunk_counts.is_empty() {
        split_refs_sided(
            ctx.corners,
            &prims,
            &cell,
            (axis, s),
            ctx.p.split_clipping.then_some(&mut scratch.clip),
            (&mut below, &mut above),
            sides,
        );
    } else {
        below.resize(nb, PrimRef::default());
        above.resize(na, PrimRef::default());
        split_in_chunks(
            ctx,
            (&prims, &chunk_counts),
            &cell,
            (axis, s),
            (&mut below, &mut above),
            sides,
        );
    }
    debug_assert_eq!((below.len(), above.len()), (nb, na));
    drop(prims);
    // The children's events, but not for a child that is a leaf anyway.
    let (events_below, events_above) = match &events {
        Some(ev) => ev.split(
            &scratch.sides,
            (&below, &above),
            (
                !Node::is_leaf_outright(ctx, below.len(), depth + 1),
                !Node::is_leaf_outright(ctx, above.len(), depth + 1),
            ),
            (!ctx.p.split_clipping).then_some((axis, s)),
            &mut scratch.events,
        ),
        None => (None, None),
    };
    if let Some(ev) = events {
        scratch.events.recycle(ev);
    }
    // The parent's arrays are spent (its event array now a spare, and
    // the children's taken from the spares: the scratch's bytes first);
    // the children's and the scratch's are what this node holds now.
    scratch.account.release(held);
    scratch.account_buffers()?;
    let ev_bytes = |ev: &Option<Events>| ev.as_ref().map_or(0, Events::bytes);
    let acc = &mut scratch.account;
    acc.resize(
        &mut held_below,
        refs_bytes(&below) + ev_bytes(&events_below),
    )?;
    acc.resize(
        &mut held_above,
        refs_bytes(&above) + ev_bytes(&events_above),
    )?;
    acc.charge(8)?;
    let (mut cell_below, mut cell_above) = (cell, cell);
    cell_below.max[axis] = s;
    cell_above.min[axis] = s;
    let child = |prims, events, held, cell| Node {
        prims,
        events,
        held,
        cell,
        depth: depth + 1,
        bad_refines,
    };
    let node_below = child(below, events_below, held_below, cell_below);
    let node_above = child(above, events_above, held_above, cell_above);

    let me = out.nodes.len();
    // Placeholder, rewritten once the above child's index is known.
    out.nodes.push(KdNode::EMPTY_LEAF);
    let above_index = if n > PARALLEL_ABOVE {
        let on_its_own = |node| {
            let mut sub = Built::default();
            build_node(ctx, node, &mut Scratch::new(ctx), &mut sub).map(|_| sub)
        };
        let (rb, ra) = rayon::join(|| on_its_own(node_below), || on_its_own(node_above));
        append(out, rb?)?;
        let above_index = out.nodes.len();
        append(out, ra?)?;
        above_index
    } else {
        build_node(ctx, node_below, scratch, out)?;
        let above_index = out.nodes.len();
        build_node(ctx, node_above, scratch, out)?;
        above_index
    };
    let above_index =
        u32::try_from(above_index).map_err(|_| BuildError::TooManyNodes(above_index))?;
    out.nodes[me] = KdNode::interior(axis, s, above_index)
        .map_err(|_| BuildError::TooManyNodes(above_index as usize))?;
    Ok(())
}

/// The parallel partition of a large node: each chunk of `prims` writes
/// its references into its own slices of `below` and `above` (sized by
/// `chunk_counts`, the chunks' [`side_counts`]) and of `sides`, in
/// parallel; the result equals [`split_refs_sided`]'s.
fn split_in_chunks(
    ctx: &Ctx,
    (prims, chunk_counts): (&[PrimRef], &[(usize, usize)]),
    cell: &Aabb,
    split: (usize, f32),
    (below, above): (&mut [PrimRef], &mut [PrimRef]),
    sides: Option<&mut Sides>,
) {
    let mut sides_left = sides.map(|s| {
        s.resize(prims.len(), [NONE; 2]);
        &mut s[..]
    });
    let (mut below_left, mut above_left) = (below, above);
    let mut base = (0, 0);
    let mut jobs = Vec::with_capacity(chunk_counts.len());
    for (chunk, &(nb, na)) in prims.chunks(CHUNK).zip(chunk_counts) {
        let (b, rest) = std::mem::take(&mut below_left).split_at_mut(nb);
        below_left = rest;
        let (a, rest) = std::mem::take(&mut above_left).split_at_mut(na);
        above_left = rest;
        let sides = sides_left.take().map(|s| {
            let (mine, rest) = s.split_at_mut(chunk.len());
            sides_left = Some(rest);
            mine
        });
        jobs.push((chunk, (b, a), sides, base));
        base = (base.0 + nb, base.1 + na);
    }
    jobs.into_par_iter()
        .for_each(|(chunk, children, sides, base)| {
            split_refs_into(
                ctx.corners,
                chunk,
                cell,
                split,
                ctx.p.split_clipping,
                children,
                (sides, base),
            );
        });
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

/// The SAH cost of the splits of one cell on one axis: PBRT-v3's cost,
/// with the empty-space bonus scaled by the share of the cell's extent
/// the empty child spans. PBRT's flat bonus makes any empty sliver,
/// however thin, beat every balanced split, so trees peel slivers one
/// depth level at a time and reach the depth limit with leaves of dozens
/// of triangles (on `gen:scalable:100000`: SAH cost 405 with the flat
/// bonus, 58 scaled; docs/builds.md, "The flat empty-space bonus").
///
/// What depends only on the cell and the axis is computed once per node
/// and axis, not per candidate. Per candidate, the cost used to recompute
/// the cell's extent and index it by a run-time axis (a `match` per index
/// in glam): about 75 instructions per candidate, 8 % of the `dynamic`
/// build's instructions on the bunny (callgrind); the same operations on
/// the same values now, so the same cost bits and the same trees.
#[derive(Clone, Copy)]
struct SahAxis {
    traversal_cost: f32,
    intersection_cost: f32,
    empty_bonus: f32,
    inv_sa: f32,
    /// The cell's bounds and extent on the axis.
    lo: f32,
    hi: f32,
    extent: f32,
    /// The area of the cell's face across the axis, and the perimeter of
    /// that face (the children's areas are `2 (face + d perim)`).
    face: f32,
    perim: f32,
}

impl SahAxis {
    fn new(p: &KdBuildParams, cell: &Aabb, inv_sa: f32, axis: usize) -> SahAxis {
        let e = cell.extent();
        let (o1, o2) = ((axis + 1) % 3, (axis + 2) % 3);
        SahAxis {
            traversal_cost: p.traversal_cost,
            intersection_cost: p.intersection_cost,
            empty_bonus: p.empty_bonus,
            inv_sa,
            lo: cell.min[axis],
            hi: cell.max[axis],
            extent: e[axis],
            face: e[o1] * e[o2],
            perim: e[o1] + e[o2],
        }
    }

    /// The cost of a split at `s` with `nb` / `na` references below /
    /// above.
    #[inline(always)]
    fn cost(&self, s: f32, nb: usize, na: usize) -> f32 {
        let (below, above) = (s - self.lo, self.hi - s);
        let sa_below = 2.0 * (self.face + below * self.perim);
        let sa_above = 2.0 * (self.face + above * self.perim);
        // The empty-space bonus only where a child is empty: elsewhere it
        // is `+0` and `C_i * (1 - 0)` is `C_i` exactly, so skipping its
        // division there gives the same bits (and the same trees).
        let weight = if nb == 0 || na == 0 {
            let empty = if nb == 0 { below } else { above };
            self.intersection_cost * (1.0 - self.empty_bonus * (empty / self.extent))
        } else {
            self.intersection_cost
        };
        // Through `i64` the conversion is one instruction (the unsigned one
        // branches on the top bit); the same value, so the same rounding.
        let (nb, na) = (nb as i64 as f32, na as i64 as f32);
        self.traversal_cost + weight * (sa_below * self.inv_sa * nb + sa_above * self.inv_sa * na)
    }
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

/// The cheapest split of `cell` over all axes: by the exact sweep over
/// `events` when given, else binned.
fn find_split(
    ctx: &Ctx,
    prims: &[PrimRef],
    events: Option<&Events>,
    cell: &Aabb,
    scratch: &mut Scratch,
) -> Option<Split> {
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
    let binned = events.is_none();
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
        let cand = match events {
            None => binned_axis(ctx, prims.len(), &priced, inv_sa, (axis, scale), scratch),
            #[cfg(test)]
            Some(_) if ctx.resort => tests::exact_axis(ctx, prims, &priced, inv_sa, axis),
            Some(ev) => {
                let sah = SahAxis::new(ctx.p, &priced, inv_sa, axis);
                events::sweep(ev.axis(axis), prims.len(), (lo, hi), |s, nb, na| {
                    sah.cost(s, nb, na)
                })
                .map(|(pos, cost, counts)| Split {
                    axis,
                    pos,
                    cost,
                    counts: Some(counts),
                })
            }
        };
        if let Some(c) = cand
            && best.is_none_or(|b| c.cost < b.cost)
        {
            best = Some(c);
        }
    }
    best
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
    let Scratch {
        min_count,
        max_count,
        ..
    } = scratch;
    min_count.clear();
    min_count.resize(3 * bins, 0);
    max_count.clear();
    max_count.resize(3 * bins, 0);
    let binner = Binner::new(lo, scale, bins);
    let bin_into = |refs: &[PrimRef], min_count: &mut [usize], max_count: &mut [usize]| {
        for r in refs {
            let [b0, b1, b2, _] = binner.bins_of(r.lo);
            let [b3, b4, b5, _] = binner.bins_of(r.hi);
            min_count[b0] += 1;
            min_count[b1] += 1;
            min_count[b2] += 1;
            max_count[b3] += 1;
            max_count[b4] += 1;
            max_count[b5] += 1;
        }
    };
    if prims.len() > PARALLEL_SPLIT_ABOVE {
        // A large node: chunks binned on every thread, their counts added.
        let zeros = || (vec![0; 3 * bins], vec![0; 3 * bins]);
        let add = |(mut mins, mut maxs): (Vec<usize>, Vec<usize>),
                   (m, x): (Vec<usize>, Vec<usize>)| {
            mins.iter_mut().zip(m).for_each(|(c, k)| *c += k);
            maxs.iter_mut().zip(x).for_each(|(c, k)| *c += k);
            (mins, maxs)
        };
        let (mins, maxs) = prims
            .par_chunks(CHUNK)
            .fold(zeros, |(mut mins, mut maxs), c| {
                bin_into(c, &mut mins, &mut maxs);
                (mins, maxs)
            })
            .reduce(zeros, add);
        min_count.copy_from_slice(&mins);
        max_count.copy_from_slice(&maxs);
    } else {
        bin_into(prims, min_count, max_count);
    }
    scale
}

/// A reference's six bins (box minima, then maxima, on x, y, z) as
/// indices into the count arrays of [`bin_all_axes`], computed four lanes
/// at a time. The scalar loop's saturating `f32 as usize` per axis cost
/// about 45 instructions per axis and reference (callgrind, bunny
/// `dynamic` build: binning was 22 % of the build's instructions); a
/// plain eight-lane array loop was only partly vectorised by LLVM
/// (scalar conversions with their NaN and overflow fix-ups). Clamping to
/// `[0, last bin]` in f32 first (`minps`, `maxps`) makes the truncation
/// (`cvttps2dq`) exact, and gives the bins the scalar loop gave (`as`
/// saturated negatives to 0). A NaN would need `inf * 0`, an axis of
/// infinite extent, which has scale 0 and is never swept.
struct Binner {
    base: F4,
    scale: F4,
    offset: [i32; 4],
    last_bin: F4,
}

impl Binner {
    fn new(lo: [f32; 3], scale: [f32; 3], bins: usize) -> Binner {
        // `bins` is at most 4096 (`validate`): the offsets fit an i32.
        let axis_offset = |a: usize| (a * bins) as i32;
        Binner {
            base: F4::from([lo[0], lo[1], lo[2], 0.0]),
            scale: F4::from([scale[0], scale[1], scale[2], 0.0]),
            offset: [0, 1, 2, 0].map(axis_offset),
            last_bin: F4::splat((bins - 1) as f32),
        }
    }

    /// The bins of `x` (a box's minima or maxima) on x, y, z; the fourth
    /// lane is 0.
    #[inline(always)]
    fn bins_of(&self, x: [f32; 3]) -> [usize; 4] {
        let x = F4::from([x[0], x[1], x[2], 0.0]);
        let t = ((x - self.base) * self.scale)
            .fast_min(self.last_bin)
            .fast_max(F4::ZERO);
        let k = t.fast_trunc_int().to_array();
        std::array::from_fn(|i| (k[i] + self.offset[i]) as usize)
    }
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
    let sah = SahAxis::new(ctx.p, cell, inv_sa, axis);
    for k in 1..bins {
        nb += min_count[k - 1];
        na -= max_count[k - 1];
        let s = lo + (hi - lo) * (k as f32 / bins as f32);
        if s <= lo || s >= hi || separates_nothing(n, nb, na) {
            continue;
        }
        let cost = sah.cost(s, nb, na);
        if best.is_none_or(|bs| cost < bs.cost) {
            best = Some(Split {
                axis,
                pos: s,
                cost,
                counts: None,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mesh;
    use crate::protocol::generate;

    /// The exact sweep as it was before the events were kept sorted: each
    /// node sorts its box minima, maxima and flat boxes anew and merges
    /// the two edge lists. The oracle the event sweep must equal.
    pub(super) fn exact_axis(
        ctx: &Ctx,
        prims: &[PrimRef],
        cell: &Aabb,
        inv_sa: f32,
        axis: usize,
    ) -> Option<Split> {
        let n = prims.len();
        let sorted = |v: Vec<f32>| {
            let mut v = v;
            v.sort_unstable_by(f32::total_cmp);
            v
        };
        let mins = sorted(prims.iter().map(|r| r.lo[axis]).collect());
        let maxs = sorted(prims.iter().map(|r| r.hi[axis]).collect());
        let planar = sorted(
            prims
                .iter()
                .filter(|r| r.lo[axis] == r.hi[axis])
                .map(|r| r.lo[axis])
                .collect(),
        );
        let (lo, hi) = (cell.min[axis], cell.max[axis]);
        let (mut i_min, mut i_max, mut p_lo, mut p_hi) = (0, 0, 0, 0);
        let (mut a, mut b) = (0, 0);
        let mut best: Option<Split> = None;
        let mut last = f32::NEG_INFINITY;
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
            let cost = SahAxis::new(ctx.p, cell, inv_sa, axis).cost(s, nb, na);
            if best.is_none_or(|bs| cost < bs.cost) {
                best = Some(Split {
                    axis,
                    pos: s,
                    cost,
                    counts: None,
                });
            }
        }
        best
    }

    fn built(mesh: &Mesh, p: &KdBuildParams, resort: bool) -> Built {
        let prims: Vec<PrimRef> = (0..mesh.triangle_count())
            .filter(|&i| !mesh.is_degenerate(i))
            .map(|i| PrimRef::new(i as u32, mesh.triangle_bounds(i)))
            .collect();
        let ctx = Ctx {
            corners: mesh.corner_slice(),
            p,
            max_depth: p.depth_for(mesh.triangle_count()).unwrap(),
            ledger: Ledger::new(p.memory_budget),
            resort,
        };
        build_with(&ctx, prims, mesh.bounds()).unwrap()
    }

    /// The same tree, a zero split position compared as a float (the
    /// events make every zero `+0.0`; the old sweep kept the sign of the
    /// edge it met first).
    fn assert_same_tree(a: &Built, b: &Built, what: &str) {
        assert_eq!(a.nodes.len(), b.nodes.len(), "{what}");
        for (i, (x, y)) in a.nodes.iter().zip(&b.nodes).enumerate() {
            if x.is_leaf() || y.is_leaf() || x.split() != 0.0 {
                assert!(x == y, "{what}: node {i}");
            } else {
                assert_eq!(
                    (x.axis(), x.child()),
                    (y.axis(), y.child()),
                    "{what}: node {i}"
                );
                assert_eq!(y.split(), 0.0, "{what}: node {i}");
            }
        }
        assert_eq!(a.leaf_prims, b.leaf_prims, "{what}");
    }

    #[test]
    fn sorted_once_events_build_the_trees_of_the_per_node_sort() {
        let scenes = [
            ("jittered sphere", generate::jittered_sphere(4000, 3, 0.3)),
            ("scalable", generate::scalable(3000)),
            ("cornell box", generate::cornell_box()),
            ("sphere", generate::sphere(2000)),
        ];
        for (scene, mesh) in &scenes {
            for (preset, p) in KdBuildParams::presets() {
                for clip in [false, true] {
                    // Exact everywhere, and exact only below a few levels
                    // of binning (events first sorted mid-tree).
                    for exact_below in [usize::MAX, 200] {
                        let p = KdBuildParams {
                            split_clipping: clip,
                            exact_below,
                            threads: Some(1),
                            ..p
                        };
                        let what =
                            format!("{scene}, {preset}, clip {clip}, exact below {exact_below}");
                        let new = built(mesh, &p, false);
                        assert!(new.nodes.len() > 10, "{what}");
                        assert_same_tree(&new, &built(mesh, &p, true), &what);
                    }
                }
            }
        }
    }

    /// The references of a mesh large enough for the parallel split.
    fn large_refs() -> (Mesh, Vec<PrimRef>) {
        let mesh = generate::jittered_sphere(50_000, 5, 0.3);
        let prims: Vec<PrimRef> = (0..mesh.triangle_count())
            .filter(|&i| !mesh.is_degenerate(i))
            .map(|i| PrimRef::new(i as u32, mesh.triangle_bounds(i)))
            .collect();
        assert!(prims.len() > PARALLEL_SPLIT_ABOVE + CHUNK);
        (mesh, prims)
    }

    /// A build context over `mesh` for calling the split's parts alone.
    fn ctx_of<'a>(mesh: &'a Mesh, p: &'a KdBuildParams) -> Ctx<'a> {
        Ctx {
            corners: mesh.corner_slice(),
            p,
            max_depth: 20,
            ledger: Ledger::new(None),
            resort: false,
        }
    }

    /// The chunked partition of a large node writes the same children and
    /// the same sides as the sequential one, with and without clipping,
    /// for splits through the middle and off it on every axis.
    #[test]
    fn the_parallel_split_equals_the_sequential_one() {
        let (mesh, prims) = large_refs();
        let cell = mesh.bounds();
        for clip in [false, true] {
            let p = KdBuildParams {
                split_clipping: clip,
                ..KdBuildParams::default()
            };
            let ctx = ctx_of(&mesh, &p);
            for axis in 0..3 {
                for f in [0.5, 0.3] {
                    let s = cell.min[axis] + f * (cell.max[axis] - cell.min[axis]);
                    let (mut below, mut above, mut sides) = (vec![], vec![], Sides::new());
                    split_refs_sided(
                        ctx.corners,
                        &prims,
                        &cell,
                        (axis, s),
                        clip.then_some(&mut ClipBuffers::new()),
                        (&mut below, &mut above),
                        Some(&mut sides),
                    );
                    let counts: Vec<_> = prims
                        .chunks(CHUNK)
                        .map(|c| side_counts(c, (axis, s)))
                        .collect();
                    let mut b = vec![PrimRef::default(); below.len()];
                    let mut a = vec![PrimRef::default(); above.len()];
                    let mut sd = vec![[7, 7]; 5];
                    split_in_chunks(
                        &ctx,
                        (&prims, &counts),
                        &cell,
                        (axis, s),
                        (&mut b, &mut a),
                        Some(&mut sd),
                    );
                    let what = format!("clip {clip}, axis {axis}, at {f}");
                    assert!(below.len() > CHUNK && above.len() > CHUNK, "{what}");
                    assert_eq!((b, a, sd), (below, above, sides), "{what}");
                }
            }
        }
    }

    /// The chunked binning of a large node counts as a plain loop does.
    #[test]
    fn the_parallel_binning_counts_every_box_once() {
        let (mesh, prims) = large_refs();
        let p = KdBuildParams::default();
        let ctx = ctx_of(&mesh, &p);
        let cell = mesh.bounds();
        let mut scratch = Scratch::new(&ctx);
        let scale = bin_all_axes(&p, &prims, &cell, &mut scratch);
        let bins = p.bins as usize;
        let (mut mins, mut maxs) = (vec![0; 3 * bins], vec![0; 3 * bins]);
        for r in &prims {
            for a in 0..3 {
                let bin = |x: f32| {
                    let k = ((x - cell.min[a]) * scale[a]).floor().max(0.0) as usize;
                    a * bins + k.min(bins - 1)
                };
                mins[bin(r.lo[a])] += 1;
                maxs[bin(r.hi[a])] += 1;
            }
        }
        assert_eq!(scratch.min_count, mins);
        assert_eq!(scratch.max_count, maxs);
        assert_eq!(mins.iter().sum::<usize>(), 3 * prims.len());
    }

    /// The four-lane binning gives the bins of the scalar formula it
    /// replaced, at bin boundaries, at the cell's bounds, outside them and
    /// for scales of 0 (an axis that cannot be binned).
    #[test]
    fn the_lane_binning_equals_the_scalar_bins() {
        for bins in [2usize, 7, 32, 128, 4096] {
            let lo = [-3.5f32, 0.0, 1e-3];
            let hi = [2.25f32, 1e6, 1e-3];
            let scale: [f32; 3] = std::array::from_fn(|a| {
                let s = bins as f32 / (hi[a] - lo[a]);
                if s.is_finite() && s > 0.0 { s } else { 0.0 }
            });
            let binner = Binner::new(lo, scale, bins);
            let last_bin = (bins - 1) as f32;
            let scalar =
                |a: usize, x: f32| a * bins + ((x - lo[a]) * scale[a]).min(last_bin) as usize;
            let mut xs: Vec<[f32; 3]> = Vec::new();
            for k in 0..=bins {
                let t = k as f32 / bins as f32;
                let at: [f32; 3] = std::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * t);
                xs.push(at);
                xs.push(at.map(f32::next_up));
                xs.push(at.map(f32::next_down));
            }
            xs.push(lo.map(|x| x - 1.0));
            xs.push(hi.map(|x| x * 4.0 + 1.0));
            xs.push([f32::MAX, -f32::MAX, 0.0]);
            for x in xs {
                let got = binner.bins_of(x);
                for a in 0..3 {
                    assert_eq!(got[a], scalar(a, x[a]), "{bins} bins, axis {a}, x {}", x[a]);
                }
            }
        }
    }

    /// Every charge is released: after a build, sequential or with
    /// subtrees on other threads, the ledger holds exactly the emitted
    /// tree, and its peak covered the root's references and the tree.
    #[test]
    fn the_ledger_ends_holding_exactly_the_tree() {
        // Above `PARALLEL_SPLIT_ABOVE` references, so the root's split is
        // chunked and subtrees go to other threads.
        let (mesh, _) = large_refs();
        for (preset, p) in KdBuildParams::presets() {
            for threads in [1, 2] {
                let prims: Vec<PrimRef> = (0..mesh.triangle_count())
                    .filter(|&i| !mesh.is_degenerate(i))
                    .map(|i| PrimRef::new(i as u32, mesh.triangle_bounds(i)))
                    .collect();
                let root = refs_bytes(&prims);
                let ctx = Ctx {
                    corners: mesh.corner_slice(),
                    p: &p,
                    max_depth: p.depth_for(mesh.triangle_count()).unwrap(),
                    ledger: Ledger::new(None),
                    resort: false,
                };
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let b = pool
                    .install(|| build_with(&ctx, prims, mesh.bounds()))
                    .unwrap();
                let tree = 8 * b.nodes.len() + 4 * b.leaf_prims.len();
                let what = format!("{preset}, {threads} threads");
                assert_eq!(ctx.ledger.live(), tree, "{what}");
                assert_eq!(b.peak_bytes, ctx.ledger.peak(), "{what}");
                assert!(b.peak_bytes >= root.max(tree), "{what}: {}", b.peak_bytes);
            }
        }
    }

    #[test]
    fn flat_and_shared_edges_build_the_same_trees() {
        // Many boxes sharing edge positions and flat on every axis in turn:
        // the grouping of equal positions and the flat-box rule at work.
        let mut positions = Vec::new();
        let mut tris = Vec::new();
        for i in 0..400u32 {
            let (x, y) = ((i % 20) as f32 * 0.5, (i / 20) as f32 * 0.5);
            let base = positions.len() as u32;
            match i % 3 {
                0 => positions.extend([
                    glam::Vec3::new(x, y, 0.0),
                    glam::Vec3::new(x + 0.5, y, 0.0),
                    glam::Vec3::new(x, y + 0.5, 0.0),
                ]),
                1 => positions.extend([
                    glam::Vec3::new(x, y, -0.0),
                    glam::Vec3::new(x, y + 0.5, 1.0),
                    glam::Vec3::new(x, y, 1.0),
                ]),
                _ => positions.extend([
                    glam::Vec3::new(x, y, 0.0),
                    glam::Vec3::new(x + 1.0, y + 0.5, 0.5),
                    glam::Vec3::new(x + 0.5, y + 1.0, 1.0),
                ]),
            }
            tris.push([base, base + 1, base + 2]);
        }
        let mesh = Mesh::new(positions, tris).unwrap();
        for (preset, p) in KdBuildParams::presets() {
            for clip in [false, true] {
                let p = KdBuildParams {
                    split_clipping: clip,
                    threads: Some(1),
                    ..p
                };
                let what = format!("{preset}, clip {clip}");
                assert_same_tree(&built(&mesh, &p, false), &built(&mesh, &p, true), &what);
            }
        }
    }
}

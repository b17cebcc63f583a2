//! The binary build: binned SAH (Wald 2007, "On fast construction of
//! SAH-based bounding volume hierarchies") or median splits (Bridson's
//! lecture notes), top-down over triangle references, in parallel with
//! rayon and the same tree for any thread count.
//!
//! Both BVHs start here: [`Bvh2`](super::Bvh2) keeps the binary tree,
//! [`Bvh8`](super::Bvh8) collapses it into 8-wide nodes (`collapse.rs`).
//!
//! Determinism: a node's split depends only on its references (binning
//! unites boxes with `min`/`max` and sums integer counts, exact in any
//! order, so the parallel binning of large nodes equals the serial one),
//! and subtrees built on other threads are appended in a fixed order
//! (left, then right).

use super::node::Node2;
use super::params::{BVH_MAX_DEPTH, BvhBuildParams, Split};
use crate::aabb::Aabb;
use crate::mesh::Mesh;
use glam::Vec3A;
use rayon::prelude::*;

/// Subtrees of more references than this are built with `rayon::join`.
const PARALLEL_SUBTREE: usize = 4096;

/// Nodes of more references than this bin in parallel chunks of this size.
const PARALLEL_BINNING: usize = 32768;

/// A triangle reference: its box and its index (32 bytes). The centroid is
/// taken as `lo + hi` (twice the centre: the factor cancels in binning).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct PrimRef {
    lo: [f32; 3],
    prim: u32,
    hi: [f32; 3],
    _pad: u32,
}

impl PrimRef {
    #[inline(always)]
    fn lo(&self) -> Vec3A {
        Vec3A::from_array(self.lo)
    }
    #[inline(always)]
    fn hi(&self) -> Vec3A {
        Vec3A::from_array(self.hi)
    }
    /// Twice the box centre.
    #[inline(always)]
    fn centroid2(&self) -> Vec3A {
        self.lo() + self.hi()
    }
}

/// A box and the box of its references' centroids (doubled), grown
/// together.
#[derive(Clone, Copy, Debug)]
struct Bounds {
    geom: Aabb,
    cent: Aabb,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        geom: Aabb::EMPTY,
        cent: Aabb::EMPTY,
    };
    #[inline(always)]
    fn grow(&mut self, r: &PrimRef) {
        self.geom.min = self.geom.min.min(r.lo());
        self.geom.max = self.geom.max.max(r.hi());
        self.cent.grow(r.centroid2());
    }
    #[inline(always)]
    fn union(&self, o: &Bounds) -> Bounds {
        Bounds {
            geom: self.geom.union(&o.geom),
            cent: self.cent.union(&o.cent),
        }
    }
    fn of(refs: &[PrimRef]) -> Bounds {
        let mut b = Bounds::EMPTY;
        for r in refs {
            b.grow(r);
        }
        b
    }
}

/// The binary tree a build made: nodes in depth-first order (right child
/// indices absolute) and the triangle order its leaves index.
pub(crate) struct Binary {
    pub nodes: Vec<Node2>,
    pub prims: Vec<u32>,
}

/// Builds the binary tree over the non-degenerate triangles of `mesh`.
/// An empty (or all-degenerate) mesh gives no node at all.
pub(crate) fn build(mesh: &Mesh, params: &BvhBuildParams) -> Binary {
    let mut refs: Vec<PrimRef> = (0..mesh.triangle_count())
        .filter(|&i| !mesh.is_degenerate(i))
        .map(|i| {
            let b = mesh.triangle_bounds(i);
            PrimRef {
                lo: b.min.to_array(),
                prim: i as u32,
                hi: b.max.to_array(),
                _pad: 0,
            }
        })
        .collect();
    if refs.is_empty() {
        return Binary {
            nodes: Vec::new(),
            prims: Vec::new(),
        };
    }
    let bounds = bounds_of(&refs);
    let b = Builder { params };
    let sub = b.node(&mut refs, 0, bounds, 0);
    let mut nodes = Vec::with_capacity(sub.len());
    sub.flatten(&mut nodes);
    Binary {
        nodes,
        prims: refs.iter().map(|r| r.prim).collect(),
    }
}

/// The bounds of many references, in parallel chunks when they are many.
fn bounds_of(refs: &[PrimRef]) -> Bounds {
    if refs.len() <= PARALLEL_BINNING {
        return Bounds::of(refs);
    }
    refs.par_chunks(PARALLEL_BINNING)
        .map(Bounds::of)
        .reduce(|| Bounds::EMPTY, |a, b| a.union(&b))
}

/// A subtree built by one task: its nodes in depth-first order with the
/// right children relative to their parents, or a node whose two subtrees
/// were built by two tasks (flattened once at the end, so nodes are copied
/// once however many levels ran in parallel).
enum Subtree {
    Flat(Vec<Node2>),
    Join {
        node: Node2,
        left: Box<Subtree>,
        right: Box<Subtree>,
        len: usize,
    },
}

impl Subtree {
    fn len(&self) -> usize {
        match self {
            Subtree::Flat(v) => v.len(),
            Subtree::Join { len, .. } => *len,
        }
    }

    /// Appends the nodes to `out`, right children made absolute.
    fn flatten(self, out: &mut Vec<Node2>) {
        match self {
            Subtree::Flat(v) => {
                let base = out.len() as u32;
                out.extend(v.into_iter().enumerate().map(|(i, mut n)| {
                    if !n.is_leaf() {
                        n.index += base + i as u32;
                    }
                    n
                }));
            }
            Subtree::Join {
                mut node,
                left,
                right,
                ..
            } => {
                node.index = out.len() as u32 + 1 + left.len() as u32;
                out.push(node);
                left.flatten(out);
                right.flatten(out);
            }
        }
    }
}

/// One bin: the box of its references and their count.
#[derive(Clone, Copy, Debug)]
struct Bin {
    lo: Vec3A,
    hi: Vec3A,
    count: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
        count: 0,
    };
    #[inline(always)]
    fn add(&mut self, r: &PrimRef) {
        self.lo = self.lo.min(r.lo());
        self.hi = self.hi.max(r.hi());
        self.count += 1;
    }
    #[inline(always)]
    fn merge(&mut self, o: &Bin) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
        self.count += o.count;
    }
}

/// A build thread's scratch: the bins of the three axes (`nb` each:
/// `bins[axis * nb + i]`) and the sweep's right-hand sums.
#[derive(Default)]
struct Scratch {
    bins: Vec<Bin>,
    right: Vec<(f32, u32)>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::default();
}

/// Surface area of the box `lo..hi` (0 for an empty one).
#[inline(always)]
fn area(lo: Vec3A, hi: Vec3A) -> f32 {
    let e = (hi - lo).max(Vec3A::ZERO);
    2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
}

/// Where to split a node: a bin boundary on an axis, or the middle of its
/// references in their current order.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Cut {
    /// References with bin `<= bin` on `axis` go left.
    Bin { axis: usize, bin: usize },
    /// The first half goes left (no usable bin boundary, the median
    /// preset, or the depth bound).
    Half,
}

struct Builder<'a> {
    params: &'a BvhBuildParams,
}

/// `ceil(log2 n)` for `n >= 1`.
fn ceil_log2(n: usize) -> u32 {
    usize::BITS - (n.max(1) - 1).leading_zeros()
}

impl Builder<'_> {
    /// The SAH cost of a leaf of `n` references: `C_i` per block.
    #[inline(always)]
    fn leaf_cost(&self, n: u32) -> f32 {
        let block = self.params.block;
        self.params.intersection_cost * n.div_ceil(block) as f32
    }

    /// The split of a node of `refs`: `None` for a leaf.
    fn cut(&self, refs: &[PrimRef], b: &Bounds, depth: u32) -> Option<(Cut, bool)> {
        let n = refs.len();
        let max_leaf = self.params.max_leaf_size as usize;
        // The depth bound: from where the SAH could pass it, balanced
        // splits (each level halves the references, so the leaves end at
        // depth `depth + ceil(log2 n)` at most: below `BVH_MAX_DEPTH`).
        let forced = depth + ceil_log2(n) >= BVH_MAX_DEPTH - 1;
        if n <= 1 {
            None
        } else if forced || self.params.split == Split::Median {
            (n > max_leaf).then_some((Cut::Half, forced))
        } else {
            self.sah_cut(refs, b).map(|c| (c, false))
        }
    }

    /// Splits `refs` by `cut`: the left count and both sides' bounds.
    fn split(
        &self,
        refs: &mut [PrimRef],
        b: &Bounds,
        cut: Cut,
        forced: bool,
    ) -> (usize, Bounds, Bounds) {
        match cut {
            Cut::Bin { axis, bin } => self.partition(refs, b, axis, bin),
            Cut::Half if self.params.split == Split::Median && !forced => median(refs, b),
            Cut::Half => {
                let mid = refs.len() / 2;
                let lb = bounds_of(&refs[..mid]);
                let rb = bounds_of(&refs[mid..]);
                (mid, lb, rb)
            }
        }
    }

    /// Builds the subtree of `refs` (the triangle slots from `offset`):
    /// large subtrees as two parallel tasks, small ones on this thread.
    fn node(&self, refs: &mut [PrimRef], offset: usize, b: Bounds, depth: u32) -> Subtree {
        let n = refs.len();
        if n <= PARALLEL_SUBTREE {
            let max_leaf = self.params.max_leaf_size as usize;
            let mut out = Vec::with_capacity(2 * n.div_ceil(max_leaf.clamp(1, 4)));
            self.serial(refs, offset, b, depth, &mut out);
            return Subtree::Flat(out);
        }
        let Some((cut, forced)) = self.cut(refs, &b, depth) else {
            return Subtree::Flat(vec![leaf(&b.geom, offset, n)]);
        };
        let (mid, lb, rb) = self.split(refs, &b, cut, forced);
        let (lr, rr) = refs.split_at_mut(mid);
        let (l, r) = rayon::join(
            || self.node(lr, offset, lb, depth + 1),
            || self.node(rr, offset + mid, rb, depth + 1),
        );
        let len = 1 + l.len() + r.len();
        Subtree::Join {
            node: interior(&b.geom),
            left: Box::new(l),
            right: Box::new(r),
            len,
        }
    }

    /// A subtree on this thread, appended to `out` (right children
    /// relative to their parents).
    fn serial(
        &self,
        refs: &mut [PrimRef],
        offset: usize,
        b: Bounds,
        depth: u32,
        out: &mut Vec<Node2>,
    ) {
        let Some((cut, forced)) = self.cut(refs, &b, depth) else {
            out.push(leaf(&b.geom, offset, refs.len()));
            return;
        };
        let (mid, lb, rb) = self.split(refs, &b, cut, forced);
        let (lr, rr) = refs.split_at_mut(mid);
        let me = out.len();
        out.push(interior(&b.geom));
        self.serial(lr, offset, lb, depth + 1, out);
        out[me].index = (out.len() - me) as u32;
        self.serial(rr, offset + mid, rb, depth + 1, out);
    }

    /// The binned SAH's choice for a node of more than one reference:
    /// the cheapest bin boundary over the three axes, or `None` for a leaf
    /// (when the node may be one and no split is cheaper). A node with no
    /// usable boundary (every centroid in one bin) is halved when it is too
    /// large for a leaf.
    fn sah_cut(&self, refs: &[PrimRef], b: &Bounds) -> Option<Cut> {
        let n = refs.len();
        let p = self.params;
        let nb = (p.bins as usize).min(4 + n / 20).max(2);
        let mapping = Mapping::new(&b.cent, nb);
        let inv_area = 1.0 / b.geom.surface_area().max(f32::MIN_POSITIVE);
        // The bins and the sweep in this thread's scratch (a fresh vector
        // per node was one allocation per node of the tree). Taken out of
        // the cell, not borrowed: `bin` runs rayon tasks for large nodes,
        // and a task this thread steals meanwhile builds another node.
        let mut taken = SCRATCH.with(std::cell::RefCell::take);
        let cut = {
            let Scratch { bins, right } = &mut taken;
            bin(refs, &mapping, bins);
            right.clear();
            right.resize(nb, (0.0, 0));
            let mut best: Option<(f32, Cut)> = None;
            for axis in (0..3).filter(|&a| mapping.used[a]) {
                let bins = &bins[axis * nb..(axis + 1) * nb];
                // Right-to-left sweep: areas and counts of bins i.. .
                let mut acc = Bin::EMPTY;
                for i in (1..nb).rev() {
                    acc.merge(&bins[i]);
                    right[i] = (area(acc.lo, acc.hi), acc.count);
                }
                let mut acc = Bin::EMPTY;
                for i in 0..nb - 1 {
                    acc.merge(&bins[i]);
                    let (ra, rn) = right[i + 1];
                    if acc.count == 0 || rn == 0 {
                        continue;
                    }
                    let cost = p.traversal_cost
                        + (area(acc.lo, acc.hi) * self.leaf_cost(acc.count)
                            + ra * self.leaf_cost(rn))
                            * inv_area;
                    // Strictly cheaper: ties keep the lower axis and bin.
                    if best.is_none_or(|(c, _)| cost < c) {
                        best = Some((cost, Cut::Bin { axis, bin: i }));
                    }
                }
            }
            self.decide(n, best)
        };
        SCRATCH.with(|scratch| scratch.replace(taken));
        cut
    }

    /// A leaf, or the best split (or halving, when nothing separates the
    /// references and they are too many for a leaf).
    fn decide(&self, n: usize, best: Option<(f32, Cut)>) -> Option<Cut> {
        let p = self.params;
        let may_be_leaf = n <= p.max_leaf_size as usize;
        match best {
            Some((cost, cut)) if !(may_be_leaf && self.leaf_cost(n as u32) <= cost) => Some(cut),
            Some(_) => None,
            None => (!may_be_leaf).then_some(Cut::Half),
        }
    }

    /// Moves the references with bin `<= bin` on `axis` to the front;
    /// returns their count and both sides' bounds.
    fn partition(
        &self,
        refs: &mut [PrimRef],
        b: &Bounds,
        axis: usize,
        bin: usize,
    ) -> (usize, Bounds, Bounds) {
        let nb = (self.params.bins as usize).min(4 + refs.len() / 20).max(2);
        let mapping = Mapping::new(&b.cent, nb);
        let (mut lb, mut rb) = (Bounds::EMPTY, Bounds::EMPTY);
        let (mut i, mut j) = (0, refs.len());
        while i < j {
            if mapping.bin(&refs[i], axis) <= bin {
                lb.grow(&refs[i]);
                i += 1;
            } else {
                j -= 1;
                rb.grow(&refs[i]);
                refs.swap(i, j);
            }
        }
        (i, lb, rb)
    }
}

/// Bins the references' centroids on the three axes into `out` (axes with
/// no centroid extent fill bin 0), in parallel chunks for many references.
fn bin(refs: &[PrimRef], mapping: &Mapping, out: &mut Vec<Bin>) {
    let nb = mapping.last + 1;
    let one = |chunk: &[PrimRef], b: &mut [Bin]| {
        for r in chunk {
            let ids = mapping.bins(r);
            b[ids[0]].add(r);
            b[nb + ids[1]].add(r);
            b[2 * nb + ids[2]].add(r);
        }
    };
    out.clear();
    out.resize(3 * nb, Bin::EMPTY);
    if refs.len() <= PARALLEL_BINNING {
        one(refs, out);
        return;
    }
    let merged = refs
        .par_chunks(PARALLEL_BINNING)
        .map(|c| {
            let mut b = vec![Bin::EMPTY; 3 * nb];
            one(c, &mut b);
            b
        })
        .reduce(
            || vec![Bin::EMPTY; 3 * nb],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(&b) {
                    x.merge(y);
                }
                a
            },
        );
    out.copy_from_slice(&merged);
}

/// The median split: references ordered by centroid along the longest axis
/// of the centroids' box (ties by triangle index), halved.
fn median(refs: &mut [PrimRef], b: &Bounds) -> (usize, Bounds, Bounds) {
    let axis = b.cent.extent().max_position();
    let mid = refs.len() / 2;
    refs.select_nth_unstable_by(mid, |x, y| {
        x.centroid2()[axis]
            .total_cmp(&y.centroid2()[axis])
            .then(x.prim.cmp(&y.prim))
    });
    let lb = bounds_of(&refs[..mid]);
    let rb = bounds_of(&refs[mid..]);
    (mid, lb, rb)
}

/// An interior node over `b` (its right child set later).
fn interior(b: &Aabb) -> Node2 {
    Node2 {
        lo: b.min.to_array(),
        count: 0,
        hi: b.max.to_array(),
        index: 0,
    }
}

/// A leaf over the triangle slots `offset..offset + n`.
fn leaf(b: &Aabb, offset: usize, n: usize) -> Node2 {
    Node2 {
        lo: b.min.to_array(),
        count: n as u32,
        hi: b.max.to_array(),
        index: offset as u32,
    }
}

/// Centroid to bin, per axis: `(c - lo) * scale`, clamped.
struct Mapping {
    lo: Vec3A,
    scale: Vec3A,
    last: usize,
    used: [bool; 3],
}

impl Mapping {
    fn new(cent: &Aabb, nb: usize) -> Mapping {
        let extent = cent.extent();
        // Slightly under `nb / extent`, so the largest centroid lands in
        // the last bin (clamped anyway).
        let scale = Vec3A::splat(nb as f32 * (1.0 - 1.0 / 65536.0)) / extent;
        let used = [0, 1, 2].map(|a| extent[a] > 0.0 && scale[a].is_finite());
        Mapping {
            lo: cent.min,
            scale: Vec3A::select(glam::BVec3A::from(used), scale, Vec3A::ZERO),
            last: nb - 1,
            used,
        }
    }

    /// The bins of `r` on the three axes.
    #[inline(always)]
    fn bins(&self, r: &PrimRef) -> [usize; 3] {
        let f = (r.centroid2() - self.lo) * self.scale;
        // `as usize` saturates: negatives (none here) and NaN go to 0.
        let a = f.to_array();
        [0, 1, 2].map(|k| (a[k] as usize).min(self.last))
    }

    #[inline(always)]
    fn bin(&self, r: &PrimRef, axis: usize) -> usize {
        let f = (r.centroid2()[axis] - self.lo[axis]) * self.scale[axis];
        (f as usize).min(self.last)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::generate;

    /// Every triangle slot in exactly one leaf, every child box inside its
    /// parent's, and leaves no larger than allowed.
    fn check(mesh: &Mesh, p: &BvhBuildParams) -> Binary {
        let t = build(mesh, p);
        let mut seen = vec![0u32; mesh.triangle_count()];
        for &i in &t.prims {
            seen[i as usize] += 1;
        }
        for (i, s) in seen.iter().enumerate() {
            assert_eq!(*s, u32::from(!mesh.is_degenerate(i)), "triangle {i}");
        }
        let mut stack = vec![(0usize, 0u32)];
        let mut covered = 0;
        while let Some((i, d)) = stack.pop() {
            assert!(d < BVH_MAX_DEPTH);
            let n = t.nodes[i];
            if n.is_leaf() {
                assert!(n.count <= p.max_leaf_size || n.count == 1);
                covered += n.count as usize;
                for &prim in &t.prims[n.index as usize..(n.index + n.count) as usize] {
                    let tb = mesh.triangle_bounds(prim as usize);
                    assert!(n.bounds().union(tb) == n.bounds());
                }
                continue;
            }
            for c in [i + 1, n.index as usize] {
                assert!(n.bounds().union(&t.nodes[c].bounds()) == n.bounds());
                stack.push((c, d + 1));
            }
        }
        assert_eq!(covered, t.prims.len());
        t
    }

    #[test]
    fn every_preset_covers_every_triangle_once() {
        let mesh = generate::jittered_sphere(5000, 3, 0.3);
        for (_, p) in BvhBuildParams::presets() {
            check(&mesh, &p);
        }
    }

    #[test]
    fn identical_centroids_and_long_chains_stay_within_the_depth_bound() {
        // 3,000 copies of one triangle: no bin boundary separates them.
        let pos = vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y];
        let mesh = Mesh::new(pos, vec![[0, 1, 2]; 3000]).unwrap();
        for (_, p) in BvhBuildParams::presets() {
            check(&mesh, &p);
        }
        // Triangles at 2^-k: the SAH peels one at a time.
        let mut pos = Vec::new();
        let mut tris = Vec::new();
        for k in 0..120u32 {
            let x = 2f32.powi(-(k as i32));
            let i = pos.len() as u32;
            pos.extend([
                glam::Vec3::new(x, 0.0, 0.0),
                glam::Vec3::new(x, 1.0, 0.0),
                glam::Vec3::new(x, 0.0, 1.0),
            ]);
            tris.push([i, i + 1, i + 2]);
        }
        let mesh = Mesh::new(pos, tris).unwrap();
        let p = BvhBuildParams {
            max_leaf_size: 1,
            ..BvhBuildParams::sah()
        };
        check(&mesh, &p);
    }

    #[test]
    fn the_tree_is_the_same_for_any_thread_count() {
        let mesh = generate::jittered_sphere(60_000, 5, 0.2);
        for (name, p) in BvhBuildParams::presets() {
            let with = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| build(&mesh, &p))
            };
            let one = with(1);
            for threads in [2, 3] {
                let many = with(threads);
                assert_eq!(one.nodes, many.nodes, "{name}, {threads} threads");
                assert_eq!(one.prims, many.prims, "{name}, {threads} threads");
            }
        }
    }
}

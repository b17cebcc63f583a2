//! A chunk of a stream as per-ray arrays: every value the traversal needs
//! of a ray, computed once, indexed by the ray's id in the chunk (`0..n`),
//! grouped into records by who reads them. The node steps read one axis
//! of `plane` (entry, exit and reciprocal direction: one record, read by
//! id), the leaves `leaf` (the shear, the permuted origin and the ray's
//! own `t_min`) and the closest hit so far, the single-ray finish all of
//! it (`scalar::RayConsts`). The values are the scalar traversal's, from the
//! same functions (`margin::shifted`, `aabb::slab`, `triangle::shear`), so
//! every decision made from them is the scalar one.

use crate::aabb::slab;
use crate::kdtree::kernel::partition::{BoxRec, LeafRec, PlaneRec, Subsets};
use crate::kdtree::kernel::prefetch::prefetch;
use crate::kdtree::layout::Layout;
use crate::kdtree::margin;
use crate::kdtree::scalar::{RayConsts, by_axis};
use crate::ray::{Hit, NO_PRIM, Ray};
use crate::simd::Lane;
use crate::triangle::{self, Shear};

/// The per-ray arrays of one chunk (all rays of one direction octant).
#[derive(Clone, Debug, Default)]
pub(crate) struct StreamRays {
    /// Rays in the chunk.
    pub n: usize,
    /// Each ray's index in the caller's slice.
    pub src: Vec<u32>,
    /// Per axis, what a node step reads (`PlaneRec`): the origin moved
    /// forwards by the margin (far-side entries), moved backwards (near-side
    /// exits), and the reciprocal direction.
    pub plane: [Vec<PlaneRec>; 3],
    /// What a leaf reads (`LeafRec`): the triangle test's permuted origin,
    /// its shear `(d_x / d_z, d_y / d_z, 1 / d_z)`, and the ray's own
    /// `t_min` (triangles are tested over the whole ray).
    pub leaf: Vec<LeafRec>,
    /// With cell boxes only (`cells.rs`): what a node step reads of a
    /// ray, all three axes and `t_min` on one line. Empty otherwise.
    pub boxes: Vec<BoxRec>,
    /// The rays come sorted by the dominant axis of their direction (the
    /// triangle test's `kz`): the rays of axis `a` are the ids
    /// `class_end[a - 1]..class_end[a]` (from 0 for `a = 0`). Within one
    /// octant that axis decides the whole permutation ([`StreamRays::perm`]),
    /// so the leaves test groups of one axis with one permutation.
    pub class_end: [u32; 3],
    /// The closest hit so far: `t` (the ray's `t_max` before any;
    /// `-inf` once an occlusion ray is found occluded, which retires it
    /// from every cell), triangle, barycentrics.
    pub best_t: Vec<f32>,
    pub best_prim: Vec<u32>,
    pub best_u: Vec<f32>,
    pub best_v: Vec<f32>,
}

/// How many rays ahead [`StreamRays::load`] prefetches.
const AHEAD: usize = 16;

/// The permutation `[kx, ky, kz]` of the rays of dominant axis `kz` in
/// the octant `neg` (`triangle::permutation`: within one octant the sign
/// of `d[kz]` is the octant's, as `d[kz]` is never zero).
#[inline(always)]
pub(crate) fn perm(kz: usize, neg: [bool; 3]) -> [usize; 3] {
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if neg[kz] { [ky, kx, kz] } else { [kx, ky, kz] }
}

impl StreamRays {
    /// Loads the rays `rays[src[i]]` (one direction octant: `neg`; sorted
    /// by their dominant axis), and writes the ones that cross the tree's
    /// box into the segment `0..m` of `subsets` with their interval in
    /// it. Returns `m`. Inlined into the kernels.
    ///
    /// # Panics
    /// If an index of `src` is out of `rays`' bounds, or `src` is not
    /// sorted by dominant axis.
    #[inline(always)]
    pub(crate) fn load<T: Layout>(
        &mut self,
        tree: &T,
        rays: &[Ray],
        src: &[u32],
        neg: [bool; 3],
        subsets: &mut Subsets,
    ) -> usize {
        let n = src.len();
        self.resize(n);
        subsets.reserve_to(n);
        let bounds = tree.bounds();
        let mut class_count = [0u32; 3];
        let mut prev_kz = 0;
        let mut m = 0;
        let (ids, s_t_min, s_t_max) = (
            &mut subsets.ids[..n],
            &mut subsets.t_min[..n],
            &mut subsets.t_max[..n],
        );
        let [px, py, pz] = &mut self.plane;
        let (px, py, pz) = (&mut px[..n], &mut py[..n], &mut pz[..n]);
        let (out_src, leaf, best_t) = (
            &mut self.src[..n],
            &mut self.leaf[..n],
            &mut self.best_t[..n],
        );
        let (best_prim, best_u, best_v) = (
            &mut self.best_prim[..n],
            &mut self.best_u[..n],
            &mut self.best_v[..n],
        );
        for i in 0..n {
            // The rays come in octant order, scattered over the caller's
            // slice: ask for the line of a ray `AHEAD` ahead, so that the
            // loads overlap instead of each waiting on memory.
            if let Some(&ahead) = src.get(i + AHEAD) {
                prefetch(&rays[ahead as usize]);
            }
            let s = src[i];
            let ray = &rays[s as usize];
            debug_assert_eq!(ray.dir_neg(), neg);
            let org = ray.origin.to_array();
            let inv_dir = ray.inv_dir.to_array();
            // The scalar traversal's set-up (`scalar.rs`), value for value.
            let org_m = margin::shifted(bounds, &org, &neg);
            let (_, t0, t1) = slab(
                bounds,
                &org_m.entry,
                &org_m.exit,
                &inv_dir,
                &neg,
                ray.t_min,
                ray.t_max,
            );
            let (sh, k) = triangle::shear(ray);
            assert!(
                k[2] >= prev_kz,
                "a chunk's rays come sorted by dominant axis"
            );
            prev_kz = k[2];
            class_count[k[2]] += 1;
            out_src[i] = s;
            let rec = |a: usize| [org_m.entry[a], org_m.exit[a], inv_dir[a], 0.0];
            (px[i], py[i], pz[i]) = (rec(0), rec(1), rec(2));
            let (o, sh_s) = (sh.org, sh.s);
            leaf[i] = [o[0], o[1], o[2], sh_s[0], sh_s[1], sh_s[2], ray.t_min, 0.0];
            best_t[i] = ray.t_max;
            best_prim[i] = NO_PRIM;
            best_u[i] = 0.0;
            best_v[i] = 0.0;
            // A ray that misses the box enters no subset.
            ids[m] = i as u32;
            s_t_min[m] = t0;
            s_t_max[m] = t1;
            m += usize::from(Lane::le(t0, t1));
        }
        self.class_end = [class_count[0], class_count[0] + class_count[1], n as u32];
        m
    }

    /// Fills [`StreamRays::boxes`] from the loaded records, for the
    /// cell-box form (`cells.rs`). A pass of its own, so that the load of
    /// the default form does not carry it (inside the load it cost 1 % of
    /// the stream's instructions, callgrind).
    #[inline(always)]
    pub(crate) fn fill_boxes(&mut self) {
        let n = self.n;
        if self.boxes.len() < n {
            self.boxes.resize(n, BoxRec::default());
        }
        let [px, py, pz] = &self.plane;
        for (i, b) in self.boxes[..n].iter_mut().enumerate() {
            let (x, y, z) = (px[i], py[i], pz[i]);
            *b = BoxRec([
                x[0],
                y[0],
                z[0],
                x[1],
                y[1],
                z[1],
                x[2],
                y[2],
                z[2],
                self.leaf[i][6],
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            ]);
        }
    }

    /// The dominant axis of ray `i` (its class).
    #[inline(always)]
    pub(crate) fn class_of(&self, i: u32) -> usize {
        usize::from(i >= self.class_end[0]) + usize::from(i >= self.class_end[1])
    }

    /// Room for `n` rays (arrays grow, never shrink).
    fn resize(&mut self, n: usize) {
        self.n = n;
        if self.src.len() >= n {
            return;
        }
        self.src.resize(n, 0);
        for a in 0..3 {
            self.plane[a].resize(n, [0.0; 4]);
        }
        self.leaf.resize(n, [0.0; 8]);
        for v in [&mut self.best_t, &mut self.best_u, &mut self.best_v] {
            v.resize(n, 0.0);
        }
        self.best_prim.resize(n, NO_PRIM);
    }

    /// The scalar walk's constants of ray `i` (`neg`: the chunk's octant).
    #[inline(always)]
    pub(crate) fn consts(&self, i: usize, neg: [bool; 3]) -> RayConsts {
        let l = &self.leaf[i];
        let r = [&self.plane[0][i], &self.plane[1][i], &self.plane[2][i]];
        let p = |k: usize| [r[0][k], r[1][k], r[2][k]];
        RayConsts {
            entry_org: by_axis(p(0)),
            exit_org: by_axis(p(1)),
            inv_dir: by_axis(p(2)),
            neg: by_axis(neg),
            shear: Shear {
                org: [l[0], l[1], l[2]],
                s: [l[3], l[4], l[5]],
            },
            k: perm(self.class_of(i as u32), neg),
            t_min: l[6],
        }
    }

    /// Ray `i`'s closest hit so far.
    #[inline(always)]
    pub(crate) fn best(&self, i: usize) -> Hit {
        Hit {
            t: self.best_t[i],
            prim: self.best_prim[i],
            u: self.best_u[i],
            v: self.best_v[i],
        }
    }

    /// Sets ray `i`'s closest hit; for occlusion (`ANY`) a hit retires the
    /// ray (`best_t = -inf`: it fails every later cell and triangle).
    #[inline(always)]
    pub(crate) fn set_best<const ANY: bool>(&mut self, i: usize, h: Hit) {
        self.best_t[i] = if ANY && h.prim != NO_PRIM {
            f32::NEG_INFINITY
        } else {
            h.t
        };
        self.best_prim[i] = h.prim;
        self.best_u[i] = h.u;
        self.best_v[i] = h.v;
    }

    /// Ray `i`'s answer: its closest hit, if any.
    #[inline]
    pub(crate) fn hit(&self, i: usize) -> Option<Hit> {
        (self.best_prim[i] != NO_PRIM).then(|| self.best(i))
    }

    /// Is ray `i` occluded?
    #[inline]
    pub(crate) fn occluded(&self, i: usize) -> bool {
        self.best_prim[i] != NO_PRIM
    }
}

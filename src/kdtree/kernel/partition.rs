//! The stream traversal's vector partition (`kdtree/stream/`): a subset of
//! a ray stream is split at a node's plane into the rays that go on into
//! the near child and those deferred to the far one, with no branch per
//! ray (Wald, Gribble, Boulos and Kensler 2007; Barringer and
//! Akenine-Möller 2014). Three forms, one result bit for bit:
//!
//! - [`Portable`]: a plain loop that writes every ray to both outputs and
//!   advances each output by the ray's decision (the SSE kernel's, and
//!   the reference the others are tested against);
//! - [`Avx2`]: eight rays per step, the plane distances computed from
//!   the rays' [`PlaneRec`]s (eight 16-byte loads and a transpose, not
//!   gathers) and each output left-packed with one `vpermps` from a
//!   256-entry table of lane orders;
//! - [`Avx512`]: sixteen rays per step, the records gathered, each
//!   output packed with `vcompressps` into a register and stored whole
//!   (the memory form of `vcompressps` is microcoded and slow on AMD
//!   Zen 4).
//!
//! Part of the crate's one `unsafe` module, as a leaf that imports nothing
//! from the traversals, so that the stream traversal uses it without an
//! import cycle through the kernels that inline it.
//!
//! A subset is a *segment* of [`Subsets`]: parallel arrays of ray ids and
//! the rays' intervals in the subset's cell. Every writer may write up to
//! [`SLACK`] entries past the end of what it keeps (whole vectors), so
//! segments are laid out with that gap between them; the ids index the
//! stream's per-ray arrays, and every gather clamps them to those arrays'
//! length, so no id, however wrong, reads out of bounds.

#[cfg(target_arch = "x86_64")]
use super::lanes::{A8, A8Index};
use crate::simd::{F8, Lane, U8};

/// Entries a writer may write past the end of what it keeps: the widest
/// vector (16 lanes).
pub(crate) const SLACK: usize = 16;

/// The subsets of a stream traversal: ray ids and the rays' intervals
/// (`t_min`, `t_max`) in the subset's cell, as one stack of segments.
/// Grown on demand and kept across calls (`StreamScratch`), never shrunk.
#[derive(Clone, Debug, Default)]
pub(crate) struct Subsets {
    pub(crate) ids: Vec<u32>,
    pub(crate) t_min: Vec<f32>,
    pub(crate) t_max: Vec<f32>,
}

impl Subsets {
    /// Makes room for entries `0..end` (plus the writers' slack).
    #[inline(always)]
    pub(crate) fn reserve_to(&mut self, end: usize) {
        if self.ids.len() < end + SLACK {
            self.grow(end + SLACK);
        }
    }

    /// Grows to at least `want` entries, geometrically: the stack's depth
    /// is not known up front.
    #[cold]
    #[inline(never)]
    fn grow(&mut self, want: usize) {
        let n = want.max(2 * self.ids.len());
        self.ids.resize(n, 0);
        self.t_min.resize(n, 0.0);
        self.t_max.resize(n, 0.0);
    }

    /// Entries in use (allocated).
    pub(crate) fn capacity(&self) -> usize {
        self.ids.len()
    }
}

/// What a node step reads of one ray for one axis, in one 16-byte record:
/// `[entry, exit, inv_dir, 0]`, the origin moved by the margin (`entry`:
/// forwards, `exit`: backwards; `kdtree/margin.rs`) and the reciprocal
/// direction. One record per ray and axis, so that the three values a step
/// reads by id share a cache line: as three separate arrays they cost
/// three lines per ray and node, and the three gathers were two thirds of
/// the split's time on the bunny's random rays (`docs/streams.md`, "Per-ray
/// records").
pub(crate) type PlaneRec = [f32; 4];

/// What a leaf reads of one ray, in one 32-byte record: the triangle
/// test's permuted origin (0..3) and shear (3..6), the ray's own `t_min`
/// (6), and 0. A leaf group loads eight records and transposes them
/// ([`StreamIsa::gather_leaf`]) where it gathered seven separate arrays.
pub(crate) type LeafRec = [f32; 8];

/// What the cell-box form's node step reads of one ray
/// (`kdtree/stream/cells.rs`), on one 64-byte line: `[entry x, y, z,
/// exit x, y, z, inv_dir x, y, z, t_min, 0, ...]` (the origins moved by
/// the margin, as in [`PlaneRec`], and the ray's own `t_min`).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(crate) struct BoxRec(pub(crate) [f32; 16]);

/// A cell as the cell-box form sees it: per axis the coordinate of the
/// face every ray of the octant enters by and of the one it leaves by, and
/// every ray's [`BoxRec`] and closest hit so far, indexed by ray id.
#[derive(Clone, Copy)]
pub(crate) struct BoxCell<'a> {
    pub(crate) entry_face: [f32; 3],
    pub(crate) exit_face: [f32; 3],
    pub(crate) rec: &'a [BoxRec],
    pub(crate) best_t: &'a [f32],
}

impl BoxCell<'_> {
    /// Ray `i`'s interval in the cell: the root's slab test
    /// (`aabb::slab`, the same operations in the same order) with the
    /// closest hit so far as `t_max`.
    #[inline(always)]
    pub(crate) fn interval(&self, i: usize) -> (f32, f32) {
        let r = &self.rec[i].0;
        let (mut t0, mut t1) = (r[9], self.best_t[i]);
        for a in 0..3 {
            t0 = t0.max_keep((self.entry_face[a] - r[a]) * r[6 + a]);
            t1 = t1.min_keep((self.exit_face[a] - r[3 + a]) * r[6 + a]);
        }
        (t0, t1)
    }
}

/// A node's plane as the partition sees it: the split and, for the node's
/// axis, every ray's [`PlaneRec`], indexed by ray id.
#[derive(Clone, Copy)]
pub(crate) struct Plane<'a> {
    pub(crate) split: f32,
    pub(crate) rec: &'a [PlaneRec],
}

/// Eight ray ids, clamped into `0..n` of the arrays they index, for
/// [`StreamIsa::gather8`]; lanes past the group's rays repeat its first.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Ids8 {
    ids: [u32; 8],
    /// Every id is below this.
    bound: usize,
}

impl Ids8 {
    /// The group `ids` (1 to 8 rays), for arrays of `n >= 1` entries.
    ///
    /// # Panics
    /// If `ids` is empty or longer than 8, or `n == 0`.
    #[inline(always)]
    pub(crate) fn new(ids: &[u32], n: usize) -> Ids8 {
        assert!(!ids.is_empty() && ids.len() <= 8 && n > 0);
        let n = n.min(u32::MAX as usize);
        let last = (n - 1) as u32;
        let first = ids[0].min(last);
        let mut lanes = [first; 8];
        for (l, &id) in lanes.iter_mut().zip(ids) {
            *l = id.min(last);
        }
        Ids8 {
            ids: lanes,
            bound: n,
        }
    }

    /// The id of lane `i`.
    #[inline(always)]
    pub(crate) fn lane(&self, i: usize) -> usize {
        self.ids[i] as usize
    }
}

/// One instruction set's partition, cull and gather. The traversal is
/// generic over it and compiled once per kernel (`kernel/stream.rs`).
pub(crate) trait StreamIsa: Copy {
    /// The leaves' lanes: `F8` for the portable form, the explicit AVX
    /// register type [`A8`](super::lanes::A8) for the AVX2 and AVX-512
    /// forms (`lanes.rs` says why).
    type Lanes: Lane;

    /// Splits the segment `cur..cur + len` of `s` at `plane`: a ray goes
    /// near when `t_min <= near_t_max` and far when `far_t_min <= t_max`,
    /// where `near_t_max = t_max.min_keep((split - exit) * inv_dir)` and
    /// `far_t_min = t_min.max_keep((split - entry) * inv_dir)` (the scalar
    /// node step's arithmetic, `scalar.rs`). The near rays, with
    /// `(t_min, near_t_max)`, are written in place from `cur` on and the
    /// far ones, with `(far_t_min, t_max)`, from `top` on, each in the
    /// segment's order. Returns `(near, far)`, their counts.
    ///
    /// # Panics
    /// Unless `cur + len + SLACK <= top`, `top + len + SLACK <=
    /// s.capacity()`, and the plane's arrays have one common length, at
    /// least 1 when `len > 0`.
    fn split(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        plane: &Plane,
    ) -> (usize, usize);

    /// The pop's cull of the segment `cur..cur + len`: each ray's
    /// `t_max` becomes `t_max.min_keep(best_t[id])` and the rays whose
    /// `t_min <= t_max` still holds are kept, in order, in place. Returns
    /// how many.
    ///
    /// # Panics
    /// Unless `cur + len + SLACK <= s.capacity()` and `best_t` is
    /// non-empty when `len > 0`.
    fn cull(self, s: &mut Subsets, cur: usize, len: usize, best_t: &[f32]) -> usize;

    /// [`StreamIsa::split`] for subsets of ids alone (the cell-box form):
    /// each ray's interval is [`BoxCell::interval`], then the node step's
    /// decision at `split` on `axis`; only ids are written.
    ///
    /// # Panics
    /// Unless `cur + len + SLACK <= top`, `top + len + SLACK <=
    /// s.capacity()`, `axis < 3`, and the cell's arrays have one common
    /// length, at least 1 when `len > 0`.
    #[allow(clippy::too_many_arguments)]
    fn split_boxes(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        cell: &BoxCell,
        axis: usize,
        split: f32,
    ) -> (usize, usize);

    /// [`StreamIsa::cull`] for the cell-box form: the rays whose
    /// [`BoxCell::interval`] is not empty, kept in order, in place.
    ///
    /// # Panics
    /// Unless `cur + len + SLACK <= s.capacity()` and the cell's arrays
    /// have one common length, at least 1 when `len > 0`.
    fn cull_boxes(self, s: &mut Subsets, cur: usize, len: usize, cell: &BoxCell) -> usize;

    /// `a[ids.lane(i)]` in lane `i`.
    ///
    /// # Panics
    /// If `a` is shorter than the arrays `ids` was made for.
    fn gather(self, ids: &Ids8, a: &[f32]) -> Self::Lanes;

    /// Field `f` of the records `a[ids.lane(i)]` in lane `i` of entry `f`.
    ///
    /// # Panics
    /// If `a` is shorter than the arrays `ids` was made for.
    fn gather_leaf(self, ids: &Ids8, a: &[LeafRec]) -> [Self::Lanes; 8];

    /// [`StreamIsa::gather`] of `u32` entries (triangle indices).
    ///
    /// # Panics
    /// As [`StreamIsa::gather`].
    fn gather_index(self, ids: &Ids8, a: &[u32]) -> <Self::Lanes as Lane>::Index;
}

/// The checks every form of [`StreamIsa::split`] makes before it writes.
#[inline(always)]
fn check_split(s: &Subsets, cur: usize, len: usize, top: usize, p: &Plane) {
    assert!(cur + len + SLACK <= top && top + len + SLACK <= s.capacity());
    assert!(s.t_min.len() == s.ids.len() && s.t_max.len() == s.ids.len());
    let n = p.rec.len();
    // The AVX-512 gathers index the records as floats with `i32` offsets
    // (`4 * id`).
    assert!((n > 0 || len == 0) && n <= i32::MAX as usize / 4);
}

/// The checks of [`StreamIsa::cull_boxes`] (and of the cell for
/// [`check_split_boxes`]).
#[inline(always)]
fn check_boxes(s: &Subsets, cur: usize, len: usize, c: &BoxCell) {
    assert!(cur + len + SLACK <= s.capacity());
    let n = c.rec.len();
    assert!(c.best_t.len() == n && (n > 0 || len == 0) && n <= i32::MAX as usize);
}

/// The checks of [`StreamIsa::split_boxes`]: the segments as
/// [`check_split`] checks them, the cell as [`check_boxes`].
#[inline(always)]
fn check_split_boxes(s: &Subsets, cur: usize, len: usize, top: usize, c: &BoxCell, axis: usize) {
    check_boxes(s, cur, len, c);
    assert!(cur + len + SLACK <= top && top + len + SLACK <= s.capacity() && axis < 3);
}

/// The checks of [`StreamIsa::cull`].
#[inline(always)]
fn check_cull(s: &Subsets, cur: usize, len: usize, best_t: &[f32]) {
    assert!(cur + len + SLACK <= s.capacity());
    assert!(s.t_min.len() == s.ids.len() && s.t_max.len() == s.ids.len());
    assert!(!best_t.is_empty() || len == 0);
}

/// The plain loop: the SSE kernel's partition and the reference.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Portable;

impl StreamIsa for Portable {
    type Lanes = F8;

    #[inline(always)]
    fn split(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        p: &Plane,
    ) -> (usize, usize) {
        check_split(s, cur, len, top, p);
        let last = p.rec.len().saturating_sub(1);
        let (mut near, mut far) = (0, 0);
        for j in cur..cur + len {
            let id = s.ids[j];
            let i = (id as usize).min(last);
            let (t_min, t_max) = (s.t_min[j], s.t_max[j]);
            let [entry, exit, inv_dir, _] = p.rec[i];
            let d_exit = (p.split - exit) * inv_dir;
            let d_entry = (p.split - entry) * inv_dir;
            let near_t_max = if d_exit < t_max { d_exit } else { t_max };
            let far_t_min = if d_entry > t_min { d_entry } else { t_min };
            // Both outputs written, each advanced by the decision: no
            // branch per ray. The far output lies beyond the segment, and
            // the near one never passes the ray being read.
            let f = top + far;
            s.ids[f] = id;
            s.t_min[f] = far_t_min;
            s.t_max[f] = t_max;
            far += usize::from(far_t_min <= t_max);
            let n = cur + near;
            s.ids[n] = id;
            s.t_min[n] = t_min;
            s.t_max[n] = near_t_max;
            near += usize::from(t_min <= near_t_max);
        }
        (near, far)
    }

    #[inline(always)]
    fn cull(self, s: &mut Subsets, cur: usize, len: usize, best_t: &[f32]) -> usize {
        check_cull(s, cur, len, best_t);
        let last = best_t.len().saturating_sub(1);
        let mut kept = 0;
        for j in cur..cur + len {
            let id = s.ids[j];
            let b = best_t[(id as usize).min(last)];
            let (t_min, t_max) = (s.t_min[j], s.t_max[j]);
            let t_max = if b < t_max { b } else { t_max };
            let k = cur + kept;
            s.ids[k] = id;
            s.t_min[k] = t_min;
            s.t_max[k] = t_max;
            kept += usize::from(t_min <= t_max);
        }
        kept
    }

    #[inline(always)]
    fn split_boxes(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        c: &BoxCell,
        axis: usize,
        split: f32,
    ) -> (usize, usize) {
        check_split_boxes(s, cur, len, top, c, axis);
        let last = c.rec.len().saturating_sub(1);
        let (mut near, mut far) = (0, 0);
        for j in cur..cur + len {
            let id = s.ids[j];
            let i = (id as usize).min(last);
            // The ray's interval in the cell, then the scalar step.
            let (t_min, t_max) = c.interval(i);
            let r = &c.rec[i].0;
            let d_exit = (split - r[3 + axis]) * r[6 + axis];
            let d_entry = (split - r[axis]) * r[6 + axis];
            let near_t_max = if d_exit < t_max { d_exit } else { t_max };
            let far_t_min = if d_entry > t_min { d_entry } else { t_min };
            // Both outputs written, each advanced by the decision.
            s.ids[top + far] = id;
            far += usize::from(far_t_min <= t_max);
            s.ids[cur + near] = id;
            near += usize::from(t_min <= near_t_max);
        }
        (near, far)
    }

    #[inline(always)]
    fn cull_boxes(self, s: &mut Subsets, cur: usize, len: usize, c: &BoxCell) -> usize {
        check_boxes(s, cur, len, c);
        let last = c.rec.len().saturating_sub(1);
        let mut kept = 0;
        for j in cur..cur + len {
            let id = s.ids[j];
            let (t_min, t_max) = c.interval((id as usize).min(last));
            s.ids[cur + kept] = id;
            kept += usize::from(t_min <= t_max);
        }
        kept
    }

    #[inline(always)]
    fn gather(self, ids: &Ids8, a: &[f32]) -> F8 {
        let mut out = [0.0; 8];
        for (o, &i) in out.iter_mut().zip(&ids.ids) {
            *o = a[i as usize];
        }
        F8::from(out)
    }

    #[inline(always)]
    fn gather_leaf(self, ids: &Ids8, a: &[LeafRec]) -> [F8; 8] {
        let mut out = [[0.0; 8]; 8];
        for (l, &i) in ids.ids.iter().enumerate() {
            let r = &a[i as usize];
            for (o, &v) in out.iter_mut().zip(r) {
                o[l] = v;
            }
        }
        out.map(F8::from)
    }

    #[inline(always)]
    fn gather_index(self, ids: &Ids8, a: &[u32]) -> U8 {
        let mut out = [0; 8];
        for (o, &i) in out.iter_mut().zip(&ids.ids) {
            *o = a[i as usize];
        }
        U8::from(out)
    }
}

/// The AVX2 forms. A value exists only where the CPU has AVX2 and POPCNT
/// ([`Avx2::detect`]), so its methods may run their instructions.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2 {
    _private: (),
}

impl Avx2 {
    /// The AVX2 forms, if this CPU runs them.
    #[inline]
    pub(crate) fn detect() -> Option<Avx2> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("popcnt")
        {
            return Some(Avx2 { _private: () });
        }
        None
    }
}

/// The AVX-512 forms (F: compress, mask registers, 16 lanes). A value
/// exists only where the CPU has AVX-512F, AVX2 and POPCNT
/// ([`Avx512::detect`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx512 {
    avx2: Avx2,
}

impl Avx512 {
    /// The AVX-512 forms, if this CPU runs them.
    #[inline]
    pub(crate) fn detect() -> Option<Avx512> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Avx2::detect().map(|avx2| Avx512 { avx2 });
        }
        None
    }
}

/// Lane orders for the AVX2 left-pack: entry `m` lists, one byte per
/// lane, the lanes whose bit is set in `m`, lowest first (the rest 0).
#[cfg(target_arch = "x86_64")]
static LEFT_PACK: [u64; 256] = {
    let mut t = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let (mut packed, mut k, mut lane) = (0u64, 0, 0);
        while lane < 8 {
            if m >> lane & 1 == 1 {
                packed |= (lane as u64) << (8 * k);
                k += 1;
            }
            lane += 1;
        }
        t[m] = packed;
        m += 1;
    }
    t
};

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The intrinsics. Every function here needs the features it is
    //! compiled with; the callers hold a token ([`super::Avx2`],
    //! [`super::Avx512`]) that proves them, and have checked the bounds
    //! the `// SAFETY:` comments rely on ([`super::check_split`],
    //! [`super::check_cull`]).
    use super::super::lanes::{A8, A8Index};
    use super::{BoxCell, Ids8, LEFT_PACK, LeafRec, Plane, PlaneRec, SLACK, Subsets};
    use std::arch::x86_64::*;

    /// The lane order that left-packs the lanes of `m` (8 bits).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn pack_order(m: u32) -> __m256i {
        _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(LEFT_PACK[(m & 0xFF) as usize] as i64))
    }

    /// The segment's arrays and the far output's start, as raw pointers
    /// (the loops below index them with checked bounds).
    #[derive(Clone, Copy)]
    struct Out {
        ids: *mut u32,
        t_min: *mut f32,
        t_max: *mut f32,
    }

    impl Out {
        #[inline(always)]
        fn of(s: &mut Subsets) -> Out {
            Out {
                ids: s.ids.as_mut_ptr(),
                t_min: s.t_min.as_mut_ptr(),
                t_max: s.t_max.as_mut_ptr(),
            }
        }
    }

    /// The records of the eight rays `ids[0..8]` (each id clamped to
    /// `last`), as entry, exit and reciprocal-direction lanes: eight
    /// 16-byte loads and a 4 x 4 transpose in each half, in place of three
    /// `vgatherdps` (microcoded on AMD Zen 3). Measured: the same records
    /// gathered were no faster than the separate arrays; loaded and
    /// transposed, faster on most rows of two noisy interleaved runs
    /// (`docs/streams.md`, "Per-ray records").
    ///
    /// # Safety
    /// AVX; `ids[0..8]` readable; `rec[0..=last]` readable.
    #[inline(always)]
    unsafe fn records8(
        rec: *const PlaneRec,
        ids: *const u32,
        last: u32,
    ) -> (__m256, __m256, __m256) {
        // SAFETY: the caller's promise; every id is clamped to `last`.
        unsafe {
            let r =
                |k: usize| _mm_loadu_ps(rec.add((*ids.add(k)).min(last) as usize).cast::<f32>());
            let pair = |lo: usize, hi: usize| {
                _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(r(lo)), r(hi))
            };
            let (r04, r15, r26, r37) = (pair(0, 4), pair(1, 5), pair(2, 6), pair(3, 7));
            // [e0 e1 x0 x1 | e4 e5 x4 x5], [i0 i1 _ _ | i4 i5 _ _], and the
            // same for rays 2, 3, 6, 7.
            let (t0, t1) = (_mm256_unpacklo_ps(r04, r15), _mm256_unpackhi_ps(r04, r15));
            let (t2, t3) = (_mm256_unpacklo_ps(r26, r37), _mm256_unpackhi_ps(r26, r37));
            (
                _mm256_shuffle_ps::<0x44>(t0, t2),
                _mm256_shuffle_ps::<0xEE>(t0, t2),
                _mm256_shuffle_ps::<0x44>(t1, t3),
            )
        }
    }

    /// One step of [`split_avx2`]: entries `cur + j ..` (`live` lanes of
    /// eight), far ones written at `top + far`, near ones at `cur + near`.
    ///
    /// # Safety
    /// AVX2 and POPCNT; `check_split` passed; `j < len`, `near <= j`,
    /// `far <= j`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    unsafe fn split_step8(
        o: Out,
        p: &Plane,
        split: __m256,
        last: __m256i,
        at: usize,
        top: usize,
        live: u32,
        near: &mut usize,
        far: &mut usize,
        cur: usize,
    ) {
        // SAFETY: (all blocks) AVX2 and POPCNT run here (the caller's
        // promise). Loads: `at + 8 <= cur + len + SLACK <= capacity`
        // (check_split), initialised entries (lanes past `len` are read
        // and ignored). Record loads: `records8` clamps every id to `n -
        // 1`, `n` the records' count (`n > 0` when `len > 0`, check_split).
        // Stores: `top + far + 8 <= top + len + SLACK <=
        // capacity`; `cur + near + 8 <= at + 8`, never past the entries
        // still to be read (from `at + 8` on), and `top` lies beyond `cur
        // + len + SLACK` (check_split).
        unsafe {
            let id = _mm256_min_epu32(_mm256_loadu_si256(o.ids.add(at).cast()), last);
            let t_min = _mm256_loadu_ps(o.t_min.add(at));
            let t_max = _mm256_loadu_ps(o.t_max.add(at));
            let (entry, exit, inv) =
                records8(p.rec.as_ptr(), o.ids.add(at), p.rec.len() as u32 - 1);
            // The scalar step's arithmetic: `minps(d, t)` is `d < t ? d :
            // t`, `min_keep`; `maxps` likewise `max_keep`. No FMA.
            let near_t_max = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(split, exit), inv), t_max);
            let far_t_min = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(split, entry), inv), t_min);
            let go_near =
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_min, near_t_max)) as u32 & live;
            let go_far =
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(far_t_min, t_max)) as u32 & live;
            // Far rays at `top + far`, then near ones in place; whole
            // vectors, each advanced by its count.
            let (of, on) = (pack_order(go_far), pack_order(go_near));
            let f = top + *far;
            _mm256_storeu_si256(o.ids.add(f).cast(), _mm256_permutevar8x32_epi32(id, of));
            _mm256_storeu_ps(o.t_min.add(f), _mm256_permutevar8x32_ps(far_t_min, of));
            _mm256_storeu_ps(o.t_max.add(f), _mm256_permutevar8x32_ps(t_max, of));
            let n = cur + *near;
            _mm256_storeu_si256(o.ids.add(n).cast(), _mm256_permutevar8x32_epi32(id, on));
            _mm256_storeu_ps(o.t_min.add(n), _mm256_permutevar8x32_ps(t_min, on));
            _mm256_storeu_ps(o.t_max.add(n), _mm256_permutevar8x32_ps(near_t_max, on));
            *far += go_far.count_ones() as usize;
            *near += go_near.count_ones() as usize;
        }
    }

    /// [`super::StreamIsa::split`], eight rays per step: whole steps, then
    /// one step with the tail's lanes.
    ///
    /// # Safety
    /// AVX2 and POPCNT must be available, and `check_split` must have
    /// passed.
    #[target_feature(enable = "avx2,popcnt")]
    pub(super) unsafe fn split_avx2(
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        p: &Plane,
    ) -> (usize, usize) {
        if len == 0 {
            return (0, 0);
        }
        let o = Out::of(s);
        let last = _mm256_set1_epi32((p.rec.len() - 1) as i32);
        let split = _mm256_set1_ps(p.split);
        let (mut near, mut far, mut j) = (0usize, 0usize, 0usize);
        while j + 8 <= len {
            // SAFETY: AVX2 and POPCNT (this function's features); `j <
            // len`; `near` and `far` count rays of `0..j`.
            unsafe {
                split_step8(
                    o,
                    p,
                    split,
                    last,
                    cur + j,
                    top,
                    0xFF,
                    &mut near,
                    &mut far,
                    cur,
                )
            };
            j += 8;
        }
        if j < len {
            let live = (1u32 << (len - j)) - 1;
            // SAFETY: as above.
            unsafe {
                split_step8(
                    o,
                    p,
                    split,
                    last,
                    cur + j,
                    top,
                    live,
                    &mut near,
                    &mut far,
                    cur,
                )
            };
        }
        (near, far)
    }

    /// One step of [`cull_avx2`] (as [`split_step8`]).
    ///
    /// # Safety
    /// AVX2 and POPCNT; `check_cull` passed; `kept <= j < len`.
    #[inline(always)]
    unsafe fn cull_step8(
        o: Out,
        best_t: &[f32],
        last: __m256i,
        at: usize,
        live: u32,
        kept: &mut usize,
        cur: usize,
    ) {
        // SAFETY: AVX2 and POPCNT (the caller's promise); loads and stores
        // within `cur + len + SLACK <= capacity` (check_cull), stores never
        // past the entries still to be read; the gather's ids clamped to
        // `best_t.len() - 1`.
        unsafe {
            let id = _mm256_min_epu32(_mm256_loadu_si256(o.ids.add(at).cast()), last);
            let t_min = _mm256_loadu_ps(o.t_min.add(at));
            let best = _mm256_i32gather_ps::<4>(best_t.as_ptr(), id);
            let t_max = _mm256_min_ps(best, _mm256_loadu_ps(o.t_max.add(at)));
            let keep = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_min, t_max)) as u32 & live;
            let order = pack_order(keep);
            let k = cur + *kept;
            _mm256_storeu_si256(o.ids.add(k).cast(), _mm256_permutevar8x32_epi32(id, order));
            _mm256_storeu_ps(o.t_min.add(k), _mm256_permutevar8x32_ps(t_min, order));
            _mm256_storeu_ps(o.t_max.add(k), _mm256_permutevar8x32_ps(t_max, order));
            *kept += keep.count_ones() as usize;
        }
    }

    /// [`super::StreamIsa::cull`], eight rays per step.
    ///
    /// # Safety
    /// AVX2 and POPCNT must be available, and `check_cull` must have
    /// passed.
    #[target_feature(enable = "avx2,popcnt")]
    pub(super) unsafe fn cull_avx2(
        s: &mut Subsets,
        cur: usize,
        len: usize,
        best_t: &[f32],
    ) -> usize {
        if len == 0 {
            return 0;
        }
        let o = Out::of(s);
        let last = _mm256_set1_epi32((best_t.len() - 1) as i32);
        let (mut kept, mut j) = (0usize, 0usize);
        while j + 8 <= len {
            // SAFETY: AVX2 and POPCNT (this function's features); `kept <=
            // j < len`.
            unsafe { cull_step8(o, best_t, last, cur + j, 0xFF, &mut kept, cur) };
            j += 8;
        }
        if j < len {
            // SAFETY: as above.
            unsafe {
                cull_step8(
                    o,
                    best_t,
                    last,
                    cur + j,
                    (1u32 << (len - j)) - 1,
                    &mut kept,
                    cur,
                )
            };
        }
        kept
    }

    /// [`super::StreamIsa::gather_leaf`]: eight 32-byte loads and an 8 x 8
    /// transpose (24 shuffles) in place of seven `vgatherdps`. Inlined as
    /// [`gather_avx2`].
    ///
    /// # Safety
    /// AVX2 must be available and every id of `ids` below `a.len()`.
    #[inline(always)]
    pub(super) unsafe fn gather_leaf_avx2(ids: &Ids8, a: &[LeafRec]) -> [A8; 8] {
        // SAFETY: AVX2 is available and every id indexes `a` (the caller's
        // promise); a record is 32 bytes, read unaligned.
        unsafe {
            let r = |k: usize| _mm256_loadu_ps(a.as_ptr().add(ids.ids[k] as usize).cast::<f32>());
            transpose8([r(0), r(1), r(2), r(3), r(4), r(5), r(6), r(7)]).map(A8::from_raw)
        }
    }

    /// Eight rays' 8-field records (`r[k]`: ray `k`) as eight lanes of
    /// each field: 24 shuffles.
    ///
    /// # Safety
    /// AVX must be available.
    #[inline(always)]
    unsafe fn transpose8(r: [__m256; 8]) -> [__m256; 8] {
        // SAFETY: register operations only; AVX (the caller's promise).
        unsafe {
            let [r0, r1, r2, r3, r4, r5, r6, r7] = r;
            // Pairs of rays interleaved, then fours: field f of rays 0..4
            // in the low half of `s[f]`, field f + 4 in its high half (and
            // the same in `u` for rays 4..8).
            let (t0, t1) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpackhi_ps(r0, r1));
            let (t2, t3) = (_mm256_unpacklo_ps(r2, r3), _mm256_unpackhi_ps(r2, r3));
            let (t4, t5) = (_mm256_unpacklo_ps(r4, r5), _mm256_unpackhi_ps(r4, r5));
            let (t6, t7) = (_mm256_unpacklo_ps(r6, r7), _mm256_unpackhi_ps(r6, r7));
            let s = [
                _mm256_shuffle_ps::<0x44>(t0, t2),
                _mm256_shuffle_ps::<0xEE>(t0, t2),
                _mm256_shuffle_ps::<0x44>(t1, t3),
                _mm256_shuffle_ps::<0xEE>(t1, t3),
            ];
            let u = [
                _mm256_shuffle_ps::<0x44>(t4, t6),
                _mm256_shuffle_ps::<0xEE>(t4, t6),
                _mm256_shuffle_ps::<0x44>(t5, t7),
                _mm256_shuffle_ps::<0xEE>(t5, t7),
            ];
            [
                _mm256_permute2f128_ps::<0x20>(s[0], u[0]),
                _mm256_permute2f128_ps::<0x20>(s[1], u[1]),
                _mm256_permute2f128_ps::<0x20>(s[2], u[2]),
                _mm256_permute2f128_ps::<0x20>(s[3], u[3]),
                _mm256_permute2f128_ps::<0x31>(s[0], u[0]),
                _mm256_permute2f128_ps::<0x31>(s[1], u[1]),
                _mm256_permute2f128_ps::<0x31>(s[2], u[2]),
                _mm256_permute2f128_ps::<0x31>(s[3], u[3]),
            ]
        }
    }

    /// The intervals of the eight rays `ids[0..8]` (each id clamped to
    /// `last`) in the cell `c` ([`BoxCell::interval`], lane by lane), and
    /// their records' lanes: each ray's 64-byte record read as one 32-byte
    /// and one 16-byte load, transposed 8 x 8 and 4 x 4.
    ///
    /// # Safety
    /// AVX2; every lane of `ids` at most `last` (the gather of the
    /// closest hits reads by them unclamped); `c.rec[0..=last]` and
    /// `c.best_t[0..=last]` readable.
    #[inline(always)]
    unsafe fn boxes8(c: &BoxCell, ids: __m256i, last: u32) -> ([__m256; 9], __m256, __m256) {
        // SAFETY: the caller's promise: AVX2, and every lane of `ids` at
        // most `last`, so every record load (clamped again) and the gather
        // of the closest hits stay inside both arrays.
        unsafe {
            let mut id = [0u32; 8];
            _mm256_storeu_si256(id.as_mut_ptr().cast(), ids);
            let p = |k: usize| c.rec.as_ptr().add(id[k].min(last) as usize).cast::<f32>();
            let lo = transpose8(std::array::from_fn(|k| _mm256_loadu_ps(p(k))));
            let hi = |k: usize| _mm_loadu_ps(p(k).add(8));
            let pair = |a: usize, b: usize| {
                _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(hi(a)), hi(b))
            };
            let (t0, t2) = (
                _mm256_unpacklo_ps(pair(0, 4), pair(1, 5)),
                _mm256_unpacklo_ps(pair(2, 6), pair(3, 7)),
            );
            let f = [
                lo[0],
                lo[1],
                lo[2],
                lo[3],
                lo[4],
                lo[5],
                lo[6],
                lo[7],
                _mm256_shuffle_ps::<0x44>(t0, t2),
            ];
            let t_min = _mm256_shuffle_ps::<0xEE>(t0, t2);
            let best = _mm256_i32gather_ps::<4>(c.best_t.as_ptr(), ids);
            // The slab test, in `aabb::slab`'s order: `maxps(d, t)` is
            // `max_keep`, `minps(d, t)` `min_keep`. No FMA.
            let (mut t0, mut t1) = (t_min, best);
            for a in 0..3 {
                let entry = _mm256_set1_ps(c.entry_face[a]);
                let exit = _mm256_set1_ps(c.exit_face[a]);
                t0 = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(entry, f[a]), f[6 + a]), t0);
                t1 = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(exit, f[3 + a]), f[6 + a]), t1);
            }
            (f, t0, t1)
        }
    }

    /// [`super::StreamIsa::split_boxes`], eight rays per step.
    ///
    /// # Safety
    /// AVX2 and POPCNT must be available, and the checks of
    /// `split_boxes` must have passed.
    #[target_feature(enable = "avx2,popcnt")]
    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe fn split_boxes_avx2(
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        c: &BoxCell,
        axis: usize,
        split: f32,
    ) -> (usize, usize) {
        if len == 0 {
            return (0, 0);
        }
        let ids = s.ids.as_mut_ptr();
        let n = c.rec.len() as u32 - 1;
        let last = _mm256_set1_epi32(n as i32);
        let split = _mm256_set1_ps(split);
        let (mut near, mut far, mut j) = (0usize, 0usize, 0usize);
        while j < len {
            let live = if j + 8 <= len {
                0xFF
            } else {
                (1u32 << (len - j)) - 1
            };
            let at = cur + j;
            // SAFETY: AVX2 and POPCNT (this function's features). Loads:
            // `at + 8 <= cur + len + SLACK <= capacity` (checked), lanes
            // past `len` read and ignored; `boxes8` clamps every id to
            // `n`, below both arrays' common length (checked). Stores:
            // `top + far + 8 <= top + len + SLACK <= capacity`; `cur +
            // near + 8 <= at + 8`, never past the entries still to be
            // read, and `top` lies beyond `cur + len + SLACK` (checked).
            unsafe {
                let id = _mm256_min_epu32(_mm256_loadu_si256(ids.add(at).cast()), last);
                let (f, t_min, t_max) = boxes8(c, id, n);
                let (entry, exit, inv) = (f[axis], f[3 + axis], f[6 + axis]);
                let near_t_max =
                    _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(split, exit), inv), t_max);
                let far_t_min =
                    _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(split, entry), inv), t_min);
                let go_near = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_min, near_t_max))
                    as u32
                    & live;
                let go_far =
                    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(far_t_min, t_max)) as u32 & live;
                let (of, on) = (pack_order(go_far), pack_order(go_near));
                _mm256_storeu_si256(
                    ids.add(top + far).cast(),
                    _mm256_permutevar8x32_epi32(id, of),
                );
                _mm256_storeu_si256(
                    ids.add(cur + near).cast(),
                    _mm256_permutevar8x32_epi32(id, on),
                );
                far += go_far.count_ones() as usize;
                near += go_near.count_ones() as usize;
            }
            j += 8;
        }
        (near, far)
    }

    /// [`super::StreamIsa::cull_boxes`], eight rays per step.
    ///
    /// # Safety
    /// AVX2 and POPCNT must be available, and `check_boxes` must have
    /// passed.
    #[target_feature(enable = "avx2,popcnt")]
    pub(super) unsafe fn cull_boxes_avx2(
        s: &mut Subsets,
        cur: usize,
        len: usize,
        c: &BoxCell,
    ) -> usize {
        if len == 0 {
            return 0;
        }
        let ids = s.ids.as_mut_ptr();
        let n = c.rec.len() as u32 - 1;
        let last = _mm256_set1_epi32(n as i32);
        let (mut kept, mut j) = (0usize, 0usize);
        while j < len {
            let live = if j + 8 <= len {
                0xFF
            } else {
                (1u32 << (len - j)) - 1
            };
            let at = cur + j;
            // SAFETY: as in `split_boxes_avx2`: loads and stores within
            // `cur + len + SLACK <= capacity` (checked), stores never past
            // the entries still to be read, ids clamped to `n`.
            unsafe {
                let id = _mm256_min_epu32(_mm256_loadu_si256(ids.add(at).cast()), last);
                let (_, t_min, t_max) = boxes8(c, id, n);
                let keep =
                    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_min, t_max)) as u32 & live;
                let order = pack_order(keep);
                _mm256_storeu_si256(
                    ids.add(cur + kept).cast(),
                    _mm256_permutevar8x32_epi32(id, order),
                );
                kept += keep.count_ones() as usize;
            }
            j += 8;
        }
        kept
    }

    /// [`super::StreamIsa::gather`] with `vgatherdps`. Not a
    /// `#[target_feature]` function, so that it is always inlined (into
    /// the AVX2 and AVX-512 kernels, the only callers).
    ///
    /// # Safety
    /// AVX2 must be available and every id of `ids` below `a.len()`.
    #[inline(always)]
    pub(super) unsafe fn gather_avx2(ids: &Ids8, a: &[f32]) -> A8 {
        // SAFETY: AVX2 is available (the caller's promise); `Ids8`'s ids
        // are its first 32 bytes, aligned to 32; every id indexes `a` (the
        // caller's promise, checked by `gather`).
        A8::from_raw(unsafe {
            let id = _mm256_load_si256(ids.ids.as_ptr().cast());
            _mm256_i32gather_ps::<4>(a.as_ptr(), id)
        })
    }

    /// [`gather_avx2`] of `u32` entries (`vpgatherdd`).
    ///
    /// # Safety
    /// As [`gather_avx2`].
    #[inline(always)]
    pub(super) unsafe fn gather_index_avx2(ids: &Ids8, a: &[u32]) -> A8Index {
        // SAFETY: as in `gather_avx2`.
        A8Index::from_raw(unsafe {
            let id = _mm256_load_si256(ids.ids.as_ptr().cast());
            _mm256_i32gather_epi32::<4>(a.as_ptr().cast(), id)
        })
    }

    /// One step of [`split_avx512`] (as [`split_step8`], sixteen lanes).
    ///
    /// # Safety
    /// AVX-512F and POPCNT; `check_split` passed; `j < len`, `near <=
    /// j`, `far <= j`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    unsafe fn split_step16(
        o: Out,
        p: &Plane,
        split: __m512,
        last: __m512i,
        at: usize,
        top: usize,
        live: __mmask16,
        near: &mut usize,
        far: &mut usize,
        cur: usize,
    ) {
        // SAFETY: as in `split_step8`, with 16 for 8 (`SLACK >= 16`), but
        // the records gathered: ids clamped to `n - 1`, so `4 * id + 2 < 4
        // * n` floats, and `4 * n` fits an `i32` (check_split).
        // Compress into registers, store whole vectors (the module
        // comment says why not the memory form).
        unsafe {
            let id = _mm512_min_epu32(_mm512_loadu_si512(o.ids.add(at).cast()), last);
            let t_min = _mm512_loadu_ps(o.t_min.add(at));
            let t_max = _mm512_loadu_ps(o.t_max.add(at));
            let rec = p.rec.as_ptr().cast::<f32>();
            let at4 = _mm512_slli_epi32::<2>(id);
            let entry = _mm512_i32gather_ps::<4>(at4, rec);
            let exit = _mm512_i32gather_ps::<4>(at4, rec.add(1));
            let inv = _mm512_i32gather_ps::<4>(at4, rec.add(2));
            let near_t_max = _mm512_min_ps(_mm512_mul_ps(_mm512_sub_ps(split, exit), inv), t_max);
            let far_t_min = _mm512_max_ps(_mm512_mul_ps(_mm512_sub_ps(split, entry), inv), t_min);
            let go_near = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(live, t_min, near_t_max);
            let go_far = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(live, far_t_min, t_max);
            let f = top + *far;
            _mm512_storeu_si512(o.ids.add(f).cast(), _mm512_maskz_compress_epi32(go_far, id));
            _mm512_storeu_ps(o.t_min.add(f), _mm512_maskz_compress_ps(go_far, far_t_min));
            _mm512_storeu_ps(o.t_max.add(f), _mm512_maskz_compress_ps(go_far, t_max));
            let n = cur + *near;
            _mm512_storeu_si512(
                o.ids.add(n).cast(),
                _mm512_maskz_compress_epi32(go_near, id),
            );
            _mm512_storeu_ps(o.t_min.add(n), _mm512_maskz_compress_ps(go_near, t_min));
            _mm512_storeu_ps(
                o.t_max.add(n),
                _mm512_maskz_compress_ps(go_near, near_t_max),
            );
            *far += go_far.count_ones() as usize;
            *near += go_near.count_ones() as usize;
        }
    }

    /// [`super::StreamIsa::split`], sixteen rays per step.
    ///
    /// # Safety
    /// AVX-512F and POPCNT must be available, and `check_split` must have
    /// passed.
    #[target_feature(enable = "avx512f,popcnt")]
    pub(super) unsafe fn split_avx512(
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        p: &Plane,
    ) -> (usize, usize) {
        const _: () = assert!(SLACK >= 16);
        if len == 0 {
            return (0, 0);
        }
        let o = Out::of(s);
        let last = _mm512_set1_epi32((p.rec.len() - 1) as i32);
        let split = _mm512_set1_ps(p.split);
        let (mut near, mut far, mut j) = (0usize, 0usize, 0usize);
        while j + 16 <= len {
            // SAFETY: AVX-512F and POPCNT (this function's features); `j <
            // len`; `near` and `far` count rays of `0..j`.
            unsafe {
                split_step16(
                    o,
                    p,
                    split,
                    last,
                    cur + j,
                    top,
                    0xFFFF,
                    &mut near,
                    &mut far,
                    cur,
                )
            };
            j += 16;
        }
        if j < len {
            let live = ((1u32 << (len - j)) - 1) as __mmask16;
            // SAFETY: as above.
            unsafe {
                split_step16(
                    o,
                    p,
                    split,
                    last,
                    cur + j,
                    top,
                    live,
                    &mut near,
                    &mut far,
                    cur,
                )
            };
        }
        (near, far)
    }

    /// One step of [`cull_avx512`] (as [`cull_step8`], sixteen lanes).
    ///
    /// # Safety
    /// AVX-512F and POPCNT; `check_cull` passed; `kept <= j < len`.
    #[inline(always)]
    unsafe fn cull_step16(
        o: Out,
        best_t: &[f32],
        last: __m512i,
        at: usize,
        live: __mmask16,
        kept: &mut usize,
        cur: usize,
    ) {
        // SAFETY: as in `cull_step8`, with 16 for 8.
        unsafe {
            let id = _mm512_min_epu32(_mm512_loadu_si512(o.ids.add(at).cast()), last);
            let t_min = _mm512_loadu_ps(o.t_min.add(at));
            let best = _mm512_i32gather_ps::<4>(id, best_t.as_ptr());
            let t_max = _mm512_min_ps(best, _mm512_loadu_ps(o.t_max.add(at)));
            let keep = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(live, t_min, t_max);
            let k = cur + *kept;
            _mm512_storeu_si512(o.ids.add(k).cast(), _mm512_maskz_compress_epi32(keep, id));
            _mm512_storeu_ps(o.t_min.add(k), _mm512_maskz_compress_ps(keep, t_min));
            _mm512_storeu_ps(o.t_max.add(k), _mm512_maskz_compress_ps(keep, t_max));
            *kept += keep.count_ones() as usize;
        }
    }

    /// [`super::StreamIsa::cull`], sixteen rays per step.
    ///
    /// # Safety
    /// AVX-512F and POPCNT must be available, and `check_cull` must have
    /// passed.
    #[target_feature(enable = "avx512f,popcnt")]
    pub(super) unsafe fn cull_avx512(
        s: &mut Subsets,
        cur: usize,
        len: usize,
        best_t: &[f32],
    ) -> usize {
        if len == 0 {
            return 0;
        }
        let o = Out::of(s);
        let last = _mm512_set1_epi32((best_t.len() - 1) as i32);
        let (mut kept, mut j) = (0usize, 0usize);
        while j + 16 <= len {
            // SAFETY: AVX-512F and POPCNT (this function's features);
            // `kept <= j < len`.
            unsafe { cull_step16(o, best_t, last, cur + j, 0xFFFF, &mut kept, cur) };
            j += 16;
        }
        if j < len {
            let live = ((1u32 << (len - j)) - 1) as __mmask16;
            // SAFETY: as above.
            unsafe { cull_step16(o, best_t, last, cur + j, live, &mut kept, cur) };
        }
        kept
    }
}

#[cfg(target_arch = "x86_64")]
impl StreamIsa for Avx2 {
    type Lanes = A8;

    #[inline(always)]
    fn split(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        p: &Plane,
    ) -> (usize, usize) {
        check_split(s, cur, len, top, p);
        // SAFETY: `self` exists only where the CPU has AVX2 and POPCNT
        // (`Avx2::detect`); `check_split` passed.
        unsafe { x86::split_avx2(s, cur, len, top, p) }
    }

    #[inline(always)]
    fn cull(self, s: &mut Subsets, cur: usize, len: usize, best_t: &[f32]) -> usize {
        check_cull(s, cur, len, best_t);
        // SAFETY: AVX2 and POPCNT are available (the token); `check_cull`
        // passed.
        unsafe { x86::cull_avx2(s, cur, len, best_t) }
    }

    #[inline(always)]
    fn split_boxes(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        c: &BoxCell,
        axis: usize,
        split: f32,
    ) -> (usize, usize) {
        check_split_boxes(s, cur, len, top, c, axis);
        // SAFETY: AVX2 and POPCNT are available (the token); the checks
        // passed.
        unsafe { x86::split_boxes_avx2(s, cur, len, top, c, axis, split) }
    }

    #[inline(always)]
    fn cull_boxes(self, s: &mut Subsets, cur: usize, len: usize, c: &BoxCell) -> usize {
        check_boxes(s, cur, len, c);
        // SAFETY: AVX2 and POPCNT are available (the token); `check_boxes`
        // passed.
        unsafe { x86::cull_boxes_avx2(s, cur, len, c) }
    }

    #[inline(always)]
    fn gather(self, ids: &Ids8, a: &[f32]) -> A8 {
        assert!(ids.bound <= a.len());
        // SAFETY: AVX2 is available (the token); every id indexes `a`
        // (checked above).
        unsafe { x86::gather_avx2(ids, a) }
    }

    #[inline(always)]
    fn gather_leaf(self, ids: &Ids8, a: &[LeafRec]) -> [A8; 8] {
        assert!(ids.bound <= a.len());
        // SAFETY: AVX2 is available (the token); every id indexes `a`
        // (checked above).
        unsafe { x86::gather_leaf_avx2(ids, a) }
    }

    #[inline(always)]
    fn gather_index(self, ids: &Ids8, a: &[u32]) -> A8Index {
        assert!(ids.bound <= a.len());
        // SAFETY: AVX2 is available (the token); every id indexes `a`.
        unsafe { x86::gather_index_avx2(ids, a) }
    }
}

#[cfg(target_arch = "x86_64")]
impl StreamIsa for Avx512 {
    type Lanes = A8;

    #[inline(always)]
    fn split(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        p: &Plane,
    ) -> (usize, usize) {
        check_split(s, cur, len, top, p);
        // SAFETY: `self` exists only where the CPU has AVX-512F and POPCNT
        // (`Avx512::detect`); `check_split` passed.
        unsafe { x86::split_avx512(s, cur, len, top, p) }
    }

    #[inline(always)]
    fn cull(self, s: &mut Subsets, cur: usize, len: usize, best_t: &[f32]) -> usize {
        check_cull(s, cur, len, best_t);
        // SAFETY: AVX-512F and POPCNT are available (the token);
        // `check_cull` passed.
        unsafe { x86::cull_avx512(s, cur, len, best_t) }
    }

    /// The AVX2 form: the cell-box form was measured with it alone.
    #[inline(always)]
    fn split_boxes(
        self,
        s: &mut Subsets,
        cur: usize,
        len: usize,
        top: usize,
        c: &BoxCell,
        axis: usize,
        split: f32,
    ) -> (usize, usize) {
        self.avx2.split_boxes(s, cur, len, top, c, axis, split)
    }

    #[inline(always)]
    fn cull_boxes(self, s: &mut Subsets, cur: usize, len: usize, c: &BoxCell) -> usize {
        self.avx2.cull_boxes(s, cur, len, c)
    }

    #[inline(always)]
    fn gather(self, ids: &Ids8, a: &[f32]) -> A8 {
        self.avx2.gather(ids, a)
    }

    #[inline(always)]
    fn gather_leaf(self, ids: &Ids8, a: &[LeafRec]) -> [A8; 8] {
        self.avx2.gather_leaf(ids, a)
    }

    #[inline(always)]
    fn gather_index(self, ids: &Ids8, a: &[u32]) -> A8Index {
        self.avx2.gather_index(ids, a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (no dependency in unit tests).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> u32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) as u32
        }
        fn f(&mut self, special: &[f32]) -> f32 {
            let r = self.next();
            if r.is_multiple_of(7) {
                special[(r as usize / 7) % special.len()]
            } else {
                (r % 2001) as f32 / 100.0 - 10.0
            }
        }
    }

    const SPECIAL: [f32; 7] = [
        0.0,
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1.0,
        -1.0,
    ];

    /// One split form: subsets, current, length, top, plane.
    type SplitFn = Box<dyn Fn(&mut Subsets, usize, usize, usize, &Plane) -> (usize, usize)>;

    /// One cull form, by name.
    type CullForm<'a> = (&'static str, Box<dyn Fn(&mut Subsets) -> usize + 'a>);

    /// The forms this CPU runs, by name.
    fn forms() -> Vec<(&'static str, SplitFn)> {
        let mut v: Vec<(&'static str, SplitFn)> = vec![(
            "portable",
            Box::new(|s, c, l, t, p| Portable.split(s, c, l, t, p)),
        )];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(i) = Avx2::detect() {
                v.push((
                    "avx2",
                    Box::new(move |s, c, l, t, p| i.split(s, c, l, t, p)),
                ));
            }
            if let Some(i) = Avx512::detect() {
                v.push((
                    "avx512",
                    Box::new(move |s, c, l, t, p| i.split(s, c, l, t, p)),
                ));
            }
        }
        v
    }

    fn bits(s: &Subsets, from: usize, n: usize) -> Vec<(u32, u32, u32)> {
        (from..from + n)
            .map(|j| (s.ids[j], s.t_min[j].to_bits(), s.t_max[j].to_bits()))
            .collect()
    }

    /// Every form splits a segment exactly as the scalar node step
    /// decides ray by ray (NaN distances, signed zeros and infinities
    /// included), in order, bit for bit, for every length up to 40 (all
    /// tails of 8 and 16 lanes), leaving everything below the segment and
    /// past the far output's slack untouched. Small enough for Miri.
    #[test]
    fn every_form_splits_as_the_scalar_step_decides() {
        let mut g = Lcg(7);
        let n = 23;
        let entry: Vec<f32> = (0..n).map(|_| g.f(&SPECIAL)).collect();
        let exit: Vec<f32> = entry.iter().map(|e| e - 0.125).collect();
        let inv: Vec<f32> = (0..n).map(|_| g.f(&SPECIAL)).collect();
        let rec: Vec<PlaneRec> = (0..n).map(|i| [entry[i], exit[i], inv[i], 0.0]).collect();
        let plane = Plane {
            split: 0.5,
            rec: &rec,
        };
        let lens: Vec<usize> = if cfg!(miri) {
            vec![0, 1, 9, 17]
        } else {
            (0..=40).collect()
        };
        for len in lens {
            let cur = 3;
            let top = cur + len + SLACK + 2;
            let mut base = Subsets::default();
            base.reserve_to(top + len);
            for j in 0..base.capacity() {
                base.ids[j] = g.next() % n as u32;
                base.t_min[j] = g.f(&SPECIAL[..4]);
                base.t_max[j] = base.t_min[j] + (g.next() % 50) as f32 / 10.0;
            }
            // The scalar step, ray by ray.
            let (mut want_near, mut want_far) = (Vec::new(), Vec::new());
            for j in cur..cur + len {
                let i = base.ids[j] as usize;
                let (t0, t1) = (base.t_min[j], base.t_max[j]);
                let near_t_max = crate::simd::Lane::min_keep(t1, (plane.split - exit[i]) * inv[i]);
                let far_t_min = crate::simd::Lane::max_keep(t0, (plane.split - entry[i]) * inv[i]);
                if t0 <= near_t_max {
                    want_near.push((base.ids[j], t0.to_bits(), near_t_max.to_bits()));
                }
                if far_t_min <= t1 {
                    want_far.push((base.ids[j], far_t_min.to_bits(), t1.to_bits()));
                }
            }
            for (name, split) in forms() {
                let mut s = base.clone();
                let (near, far) = split(&mut s, cur, len, top, &plane);
                assert_eq!(bits(&s, cur, near), want_near, "{name} len {len} near");
                assert_eq!(bits(&s, top, far), want_far, "{name} len {len} far");
                assert_eq!(bits(&s, 0, cur), bits(&base, 0, cur), "{name}: below");
                let end = top + len + SLACK;
                let rest = s.capacity() - end;
                assert_eq!(
                    bits(&s, end, rest),
                    bits(&base, end, rest),
                    "{name}: past the slack"
                );
            }
        }
    }

    /// Every form culls as the scalar pop decides, in place, in order.
    #[test]
    fn every_form_culls_as_the_scalar_pop_decides() {
        let mut g = Lcg(11);
        let n = 19;
        let best: Vec<f32> = (0..n).map(|_| g.f(&SPECIAL)).collect();
        let best = best.as_slice();
        let lens: Vec<usize> = if cfg!(miri) {
            vec![0, 3, 17]
        } else {
            (0..=40).collect()
        };
        for len in lens {
            let cur = 5;
            let mut base = Subsets::default();
            base.reserve_to(cur + len);
            for j in 0..base.capacity() {
                base.ids[j] = g.next() % n as u32;
                base.t_min[j] = g.f(&SPECIAL[..4]);
                base.t_max[j] = base.t_min[j] + (g.next() % 50) as f32 / 10.0;
            }
            let want: Vec<(u32, u32, u32)> = (cur..cur + len)
                .filter_map(|j| {
                    let t_max =
                        crate::simd::Lane::min_keep(base.t_max[j], best[base.ids[j] as usize]);
                    (base.t_min[j] <= t_max)
                        .then(|| (base.ids[j], base.t_min[j].to_bits(), t_max.to_bits()))
                })
                .collect();
            let mut culls: Vec<CullForm<'_>> =
                vec![("portable", Box::new(|s| Portable.cull(s, cur, len, best)))];
            #[cfg(target_arch = "x86_64")]
            {
                if let Some(i) = Avx2::detect() {
                    culls.push(("avx2", Box::new(move |s| i.cull(s, cur, len, best))));
                }
                if let Some(i) = Avx512::detect() {
                    culls.push(("avx512", Box::new(move |s| i.cull(s, cur, len, best))));
                }
            }
            for (name, cull) in culls {
                let mut s = base.clone();
                let kept = cull(&mut s);
                assert_eq!(bits(&s, cur, kept), want, "{name} len {len}");
                assert_eq!(bits(&s, 0, cur), bits(&base, 0, cur), "{name}: below");
            }
        }
    }

    /// Every form of the cell-box split and cull decides as the scalar
    /// slab test and node step do, ray by ray (NaN distances, signed zeros
    /// and infinities included), in order, for every length up to 40 and
    /// every axis; nothing below the segment or past the slack is written.
    #[test]
    fn every_box_form_decides_as_the_slab_test() {
        let mut g = Lcg(13);
        let n = 21;
        // Rays of the positive octant (entry faces low) around the cell,
        // the special values (NaN, infinities, signed zeros) one time in
        // seven in every field, and in some `t_min` and closest hits.
        let rec: Vec<BoxRec> = (0..n)
            .map(|_| {
                let mut r = [0.0; 16];
                for a in 0..3 {
                    r[a] = g.f(&SPECIAL) * 0.5 + 2.0;
                    r[3 + a] = r[a] - 0.125; // the exit origin behind, as the margin's
                    r[6 + a] = g.f(&SPECIAL).abs() + 0.01;
                }
                r[9] = if g.next().is_multiple_of(4) {
                    g.f(&SPECIAL)
                } else {
                    0.0
                };
                BoxRec(r)
            })
            .collect();
        let best: Vec<f32> = (0..n)
            .map(|_| {
                if g.next().is_multiple_of(4) {
                    g.f(&SPECIAL)
                } else {
                    100.0
                }
            })
            .collect();
        let cell = BoxCell {
            entry_face: [-2.0, -1.0, 1.5],
            exit_face: [3.0, 4.0, 7.0],
            rec: &rec,
            best_t: &best,
        };
        let lens: Vec<usize> = if cfg!(miri) {
            vec![0, 1, 9]
        } else {
            (0..=40).collect()
        };
        type Forms<'a> = Vec<(
            &'static str,
            Box<dyn Fn(&mut Subsets, usize, usize, usize, usize) -> (usize, usize) + 'a>,
        )>;
        type Culls<'a> = Vec<(
            &'static str,
            Box<dyn Fn(&mut Subsets, usize, usize) -> usize + 'a>,
        )>;
        let cell = &cell;
        let mut splits: Forms = vec![(
            "portable",
            Box::new(|s, c, l, t, a| Portable.split_boxes(s, c, l, t, cell, a, 2.0)),
        )];
        let mut culls: Culls = vec![(
            "portable",
            Box::new(|s, c, l| Portable.cull_boxes(s, c, l, cell)),
        )];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(i) = Avx2::detect() {
                splits.push((
                    "avx2",
                    Box::new(move |s, c, l, t, a| i.split_boxes(s, c, l, t, cell, a, 2.0)),
                ));
                culls.push(("avx2", Box::new(move |s, c, l| i.cull_boxes(s, c, l, cell))));
            }
            if let Some(i) = Avx512::detect() {
                splits.push((
                    "avx512",
                    Box::new(move |s, c, l, t, a| i.split_boxes(s, c, l, t, cell, a, 2.0)),
                ));
                culls.push((
                    "avx512",
                    Box::new(move |s, c, l| i.cull_boxes(s, c, l, cell)),
                ));
            }
        }
        let ids = |s: &Subsets, from: usize, k: usize| s.ids[from..from + k].to_vec();
        let mut decided = [0usize; 3];
        for len in lens {
            for axis in 0..3 {
                let cur = 3;
                let top = cur + len + SLACK + 2;
                let mut base = Subsets::default();
                base.reserve_to(top + len);
                for j in 0..base.capacity() {
                    base.ids[j] = g.next() % n as u32;
                }
                // The scalar slab test and node step, ray by ray.
                let (mut near, mut far, mut kept) = (Vec::new(), Vec::new(), Vec::new());
                for j in cur..cur + len {
                    let id = base.ids[j];
                    let (t0, t1) = cell.interval(id as usize);
                    let r = &rec[id as usize].0;
                    let near_t_max = t1.min_keep((2.0 - r[3 + axis]) * r[6 + axis]);
                    let far_t_min = t0.max_keep((2.0 - r[axis]) * r[6 + axis]);
                    if t0 <= near_t_max {
                        near.push(id);
                    }
                    if far_t_min <= t1 {
                        far.push(id);
                    }
                    if t0 <= t1 {
                        kept.push(id);
                    }
                }
                decided[0] += near.len();
                decided[1] += far.len();
                decided[2] += len - kept.len();
                for (name, split) in &splits {
                    let mut s = base.clone();
                    let (n_near, n_far) = split(&mut s, cur, len, top, axis);
                    assert_eq!(
                        ids(&s, cur, n_near),
                        near,
                        "{name} len {len} axis {axis} near"
                    );
                    assert_eq!(ids(&s, top, n_far), far, "{name} len {len} axis {axis} far");
                    assert_eq!(ids(&s, 0, cur), ids(&base, 0, cur), "{name}: below");
                    let end = top + len + SLACK;
                    let rest = s.capacity() - end;
                    assert_eq!(ids(&s, end, rest), ids(&base, end, rest), "{name}: past");
                }
                for (name, cull) in &culls {
                    let mut s = base.clone();
                    let k = cull(&mut s, cur, len);
                    assert_eq!(ids(&s, cur, k), kept, "{name} len {len} cull");
                    assert_eq!(ids(&s, 0, cur), ids(&base, 0, cur), "{name}: below");
                }
            }
        }
        // The rays went near, far, and were culled, each many times.
        assert!(decided.iter().all(|&d| d > 20), "{decided:?}");
    }

    /// Gathers read the ids' entries; short groups repeat their first
    /// ray; ids are clamped into the arrays.
    #[test]
    fn gathers_read_the_ids_entries() {
        let a: Vec<f32> = (0..10).map(|i| i as f32 * 1.5).collect();
        let ids = Ids8::new(&[3, 9, 0], a.len());
        let want = [4.5, 13.5, 0.0, 4.5, 4.5, 4.5, 4.5, 4.5];
        assert_eq!(Portable.gather(&ids, &a).to_array(), want);
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(i) = Avx2::detect() {
                assert_eq!(i.gather(&ids, &a).to_array(), want);
            }
            if let Some(i) = Avx512::detect() {
                assert_eq!(i.gather(&ids, &a).to_array(), want);
            }
        }
        let prims: Vec<u32> = (0..10).map(|i| 100 + i).collect();
        let want_p = [103, 109, 100, 103, 103, 103, 103, 103];
        assert_eq!(Portable.gather_index(&ids, &prims).to_array(), want_p);
        #[cfg(target_arch = "x86_64")]
        if let Some(i) = Avx2::detect() {
            let g = i.gather_index(&ids, &prims);
            assert_eq!(std::array::from_fn(|l| A8::index_lane(g, l)), want_p);
        }
        // Leaf records: field f of record id in lane l, every form, for
        // groups of 1 to 8 rays.
        let recs: Vec<LeafRec> = (0..10)
            .map(|i| std::array::from_fn(|f| (i * 8 + f) as f32 - 0.5))
            .collect();
        for len in 1..=8 {
            let group: Vec<u32> = (0..len as u32).map(|k| (k * 7 + 3) % 10).collect();
            let ids = Ids8::new(&group, recs.len());
            let want: [[f32; 8]; 8] =
                std::array::from_fn(|f| std::array::from_fn(|l| recs[ids.lane(l)][f]));
            assert_eq!(
                Portable.gather_leaf(&ids, &recs).map(|v| v.to_array()),
                want
            );
            #[cfg(target_arch = "x86_64")]
            {
                if let Some(i) = Avx2::detect() {
                    assert_eq!(i.gather_leaf(&ids, &recs).map(|v| v.to_array()), want);
                }
                if let Some(i) = Avx512::detect() {
                    assert_eq!(i.gather_leaf(&ids, &recs).map(|v| v.to_array()), want);
                }
            }
        }
        let clamped = Ids8::new(&[99, 2], a.len());
        assert_eq!(
            (clamped.lane(0), clamped.lane(1), clamped.lane(7)),
            (9, 2, 9)
        );
    }

    /// The left-pack table lists each mask's lanes, lowest first.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_left_pack_table_lists_each_masks_lanes() {
        for (m, &packed) in LEFT_PACK.iter().enumerate() {
            let lanes: Vec<u64> = (0..8).filter(|l| m >> l & 1 == 1).collect();
            for (k, &l) in lanes.iter().enumerate() {
                assert_eq!(packed >> (8 * k) & 0xFF, l, "mask {m:#x}");
            }
            if lanes.len() < 8 {
                assert_eq!(packed >> (8 * lanes.len()), 0, "mask {m:#x}");
            }
        }
    }
}

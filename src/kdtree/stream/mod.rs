//! Ray streams: any number of rays traced breadth first, for rays the
//! host has not grouped (ambient occlusion, diffuse bounces, random
//! rays). The rays are split by direction octant; each octant's rays go
//! through the tree in chunks of up to [`StreamOptions::stream_size`],
//! each chunk as one stream: depth first over nodes, breadth first over
//! rays (`traverse.rs`), with vector partitions (`kernel/partition.rs`),
//! leaves tested eight rays at a time (`leaf.rs`) and sparse subsets
//! finished by the scalar walk. Every ray's answer equals the scalar
//! query's, bit for bit.
//!
//! The traversal's memory (the chunk's per-ray arrays, the subsets'
//! stack) lives in a [`StreamScratch`] that a host keeps per thread and
//! passes to [`KdTree::intersect_stream`] / [`KdTree::occluded_stream`];
//! the one-shot [`KdTree::intersect_rays`] / [`KdTree::occluded_rays`]
//! use one kept per thread by the library (`docs/streams.md`).

mod cells;
mod leaf;
pub(crate) mod rays;
mod sort;
pub(crate) mod traverse;

pub(crate) use sort::order;

use super::KdTree;
use super::kernel::Kernel;
use super::kernel::partition::Subsets;
use super::kernel::stream::chunk_in;
use super::layout::Layout;
use super::stats::{Counters, NoCount, TraversalStats};
use crate::ray::{Hit, Ray};
use crate::triangle;
use rays::StreamRays;
use std::cell::RefCell;
use std::fmt;

/// The largest [`StreamOptions::stream_size`]: ray ids are 32-bit, and
/// a chunk's per-ray arrays take about 100 bytes a ray.
pub const MAX_STREAM_SIZE: usize = 1 << 24;

/// How streams are cut into chunks and when a subset finishes ray by
/// ray. The defaults were measured (`docs/streams.md`).
///
/// ```
/// use packtrace::kdtree::StreamOptions;
/// let o = StreamOptions::new(4096, 8).unwrap();
/// assert_eq!((o.stream_size(), o.single_ray_below()), (4096, 8));
/// assert!(StreamOptions::new(0, 8).is_err());
/// assert_eq!(StreamOptions::default(), StreamOptions::DEFAULT);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamOptions {
    stream_size: usize,
    single_ray_below: usize,
    cell_boxes: bool,
}

impl StreamOptions {
    /// The measured defaults (`docs/streams.md`, "Sweeps"). Chunks of
    /// 65,536 rays: callgrind counts 6-8 % fewer instructions per ao ray
    /// than 16,384 (bunny, Sponza) and 6-7 % fewer per random ray once an
    /// octant holds more rays (512 x 512), since more rays share each node
    /// visit; 1,024 and 4,096 cost 4-31 % more than 16,384. A chunk's
    /// arrays then take about 6 MB. Single rays below 4: 2 is 2-6 % better
    /// on ao and 3-8 % worse on random, 8 and above worse on three of the
    /// four rows, 0 (never) 2 % better on bunny ao and 3-29 % worse on the
    /// other three.
    pub const DEFAULT: StreamOptions = StreamOptions {
        stream_size: 65536,
        single_ray_below: 4,
        cell_boxes: false,
    };

    /// Chunks of at most `stream_size` rays of one octant; a subset of
    /// fewer than `single_ray_below` rays finishes its subtree ray by ray
    /// (0 or 1: never; above the stream size: always, which is the
    /// scalar traversal with the stream's set-up).
    ///
    /// # Errors
    /// [`StreamOptionsError`] if `stream_size` is 0 or above
    /// [`MAX_STREAM_SIZE`].
    pub fn new(
        stream_size: usize,
        single_ray_below: usize,
    ) -> Result<StreamOptions, StreamOptionsError> {
        if stream_size == 0 || stream_size > MAX_STREAM_SIZE {
            return Err(StreamOptionsError { stream_size });
        }
        Ok(StreamOptions {
            stream_size,
            single_ray_below,
            cell_boxes: false,
        })
    }

    /// The same options, with subsets that carry their cell's box instead
    /// of each ray's interval in it (`true`), recomputing the interval at
    /// every node. Same answers, bit for bit; measured slower on every
    /// row tried, so off by default (`docs/streams.md`, "Intervals against
    /// cell boxes"). It is here so that the comparison can be rerun
    /// (`bench --stream-cell-boxes`).
    ///
    /// ```
    /// use packtrace::kdtree::StreamOptions;
    /// let o = StreamOptions::DEFAULT.with_cell_boxes(true);
    /// assert!(o.cell_boxes() && !StreamOptions::DEFAULT.cell_boxes());
    /// ```
    #[must_use]
    pub fn with_cell_boxes(self, cell_boxes: bool) -> StreamOptions {
        StreamOptions { cell_boxes, ..self }
    }

    /// Do subsets carry cell boxes ([`StreamOptions::with_cell_boxes`])?
    #[must_use]
    pub fn cell_boxes(&self) -> bool {
        self.cell_boxes
    }

    /// Rays per chunk, at most.
    #[must_use]
    pub fn stream_size(&self) -> usize {
        self.stream_size
    }

    /// Subsets smaller than this finish ray by ray.
    #[must_use]
    pub fn single_ray_below(&self) -> usize {
        self.single_ray_below
    }
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions::DEFAULT
    }
}

/// A stream size [`StreamOptions::new`] refuses.
///
/// ```
/// let e = packtrace::kdtree::StreamOptions::new(0, 4).unwrap_err();
/// assert_eq!(e.to_string(), "stream size 0 is not in 1..=16777216");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamOptionsError {
    /// The size asked for.
    pub stream_size: usize,
}

impl fmt::Display for StreamOptionsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "stream size {} is not in 1..={MAX_STREAM_SIZE}",
            self.stream_size
        )
    }
}

impl std::error::Error for StreamOptionsError {}

/// The memory of the stream traversal, kept between calls so that a call
/// allocates nothing once the scratch has grown to the largest chunk and
/// deepest subset stack it has seen (it never shrinks). Keep one per
/// thread; it holds no reference to any tree or ray.
///
/// ```
/// use glam::Vec3;
/// use packtrace::kdtree::StreamScratch;
/// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
/// let mut scratch = StreamScratch::new();
/// let rays = vec![Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap(); 100];
/// let mut hits = vec![None; 100];
/// for _ in 0..3 {
///     t.intersect_stream(&rays, &mut hits, &mut scratch);
/// }
/// assert!(hits.iter().all(|h| h.unwrap().prim == 0));
/// assert!(scratch.bytes() > 0);
/// ```
#[derive(Clone, Debug, Default)]
pub struct StreamScratch {
    options: StreamOptions,
    /// The caller's ray indices, by octant.
    order: Vec<u32>,
    rays: StreamRays,
    subsets: Subsets,
}

impl StreamScratch {
    /// An empty scratch with the default options (nothing allocated yet).
    #[must_use]
    pub fn new() -> StreamScratch {
        StreamScratch::default()
    }

    /// An empty scratch with `options`.
    ///
    /// ```
    /// use packtrace::kdtree::{StreamOptions, StreamScratch};
    /// let s = StreamScratch::with_options(StreamOptions::new(1024, 2).unwrap());
    /// assert_eq!(s.options().stream_size(), 1024);
    /// ```
    #[must_use]
    pub fn with_options(options: StreamOptions) -> StreamScratch {
        StreamScratch {
            options,
            ..StreamScratch::default()
        }
    }

    /// The options the scratch traces with.
    #[must_use]
    pub fn options(&self) -> StreamOptions {
        self.options
    }

    /// Bytes the scratch holds (its arrays' lengths).
    #[must_use]
    pub fn bytes(&self) -> usize {
        let r = &self.rays;
        4 * (self.order.len() + 3 * self.subsets.capacity() + r.src.len() * 23 + r.boxes.len() * 16)
    }
}

thread_local! {
    /// The one-shot calls' scratch, one per thread.
    static SCRATCH: RefCell<StreamScratch> = RefCell::new(StreamScratch::new());
}

/// `f` with this thread's scratch (a fresh one if it is in use: a
/// nested call, which the library itself never makes).
fn with_thread_scratch<R>(f: impl FnOnce(&mut StreamScratch) -> R) -> R {
    SCRATCH.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => f(&mut s),
        Err(_) => f(&mut StreamScratch::new()),
    })
}

impl KdTree {
    /// Closest hits of a stream of rays, `hits[i]` for `rays[i]`, traced
    /// breadth first (`kdtree::stream`) with a scratch the library keeps
    /// per thread. Use it for rays the host has not grouped (secondary
    /// rays from many surfaces); [`KdTree::intersect_stream`] with the
    /// host's own [`StreamScratch`] does the same; screen tiles of
    /// coherent rays trace fastest as packets, and a lone ray with
    /// [`KdTree::intersect`].
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let rays: Vec<Ray> = (0..7)
    ///     .map(|i| Ray::new(Vec3::new(0.1 * i as f32, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap())
    ///     .collect();
    /// let mut hits = vec![None; 7];
    /// t.intersect_rays(&rays, &mut hits);
    /// assert!(hits.iter().zip(&rays).all(|(h, r)| *h == t.intersect(r)));
    /// ```
    pub fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        intersect_rays(self, rays, hits);
    }

    /// Occlusion of a stream of rays, `occluded[i]` for `rays[i]`, traced
    /// as [`KdTree::intersect_rays`] does.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.1, 0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// let mut occ = vec![false; 5];
    /// t.occluded_rays(&[r; 5], &mut occ);
    /// assert!(occ.iter().all(|&o| o));
    /// ```
    pub fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        occluded_rays(self, rays, occluded);
    }

    /// Closest hits of a stream of rays with the caller's scratch: no
    /// allocation once `scratch` has grown to the stream's needs.
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::kdtree::StreamScratch;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.3, 0.3, -1.0), Vec3::Z, 0.0, 9.0).unwrap();
    /// let mut hits = [None; 3];
    /// t.intersect_stream(&[r; 3], &mut hits, &mut StreamScratch::new());
    /// assert_eq!(hits[2], t.intersect(&r));
    /// ```
    pub fn intersect_stream(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        scratch: &mut StreamScratch,
    ) {
        intersect_with::<_, _>(Kernel::active(), self, rays, hits, scratch, &mut NoCount);
    }

    /// Occlusion of a stream of rays with the caller's scratch.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::kdtree::StreamScratch;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.3, 0.3, -1.0), Vec3::Z, 0.0, 0.5).unwrap();
    /// let mut occ = [true; 2];
    /// t.occluded_stream(&[r; 2], &mut occ, &mut StreamScratch::new());
    /// assert_eq!(occ, [false; 2]);
    /// ```
    pub fn occluded_stream(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        scratch: &mut StreamScratch,
    ) {
        occluded_with::<_, _>(
            Kernel::active(),
            self,
            rays,
            occluded,
            scratch,
            &mut NoCount,
        );
    }

    /// [`KdTree::intersect_stream`], adding its work to `stats`.
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::kdtree::StreamScratch;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// t.intersect_stream_counted(&[r; 4], &mut [None; 4], &mut StreamScratch::new(), &mut s);
    /// assert_eq!(s.rays, 4);
    /// ```
    pub fn intersect_stream_counted(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        scratch: &mut StreamScratch,
        stats: &mut TraversalStats,
    ) {
        stats.rays += rays.len() as u64;
        intersect_with::<_, _>(Kernel::active(), self, rays, hits, scratch, stats);
    }

    /// [`KdTree::occluded_stream`], adding its work to `stats`.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::kdtree::StreamScratch;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, TraversalStats};
    /// let t = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    /// let mut s = TraversalStats::default();
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// t.occluded_stream_counted(&[r; 2], &mut [false; 2], &mut StreamScratch::new(), &mut s);
    /// assert_eq!(s.rays, 2);
    /// ```
    pub fn occluded_stream_counted(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        scratch: &mut StreamScratch,
        stats: &mut TraversalStats,
    ) {
        stats.rays += rays.len() as u64;
        occluded_with::<_, _>(Kernel::active(), self, rays, occluded, scratch, stats);
    }
}

/// Closest hits of a stream through any layout, with this thread's
/// scratch (the one-shot calls and the measured layouts' queries).
pub(crate) fn intersect_rays<T: Layout>(tree: &T, rays: &[Ray], hits: &mut [Option<Hit>]) {
    with_thread_scratch(|s| intersect_with(Kernel::active(), tree, rays, hits, s, &mut NoCount));
}

/// Occlusion of a stream through any layout, with this thread's scratch.
pub(crate) fn occluded_rays<T: Layout>(tree: &T, rays: &[Ray], occluded: &mut [bool]) {
    with_thread_scratch(|s| occluded_with(Kernel::active(), tree, rays, occluded, s, &mut NoCount));
}

/// Closest hits in kernel `k`.
pub(crate) fn intersect_with<T: Layout, C: Counters>(
    k: Kernel,
    tree: &T,
    rays: &[Ray],
    hits: &mut [Option<Hit>],
    scratch: &mut StreamScratch,
    c: &mut C,
) {
    assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
    trace::<T, false, C>(k, tree, rays, scratch, c, |src, r, i| {
        hits[src] = r.hit(i);
    });
}

/// Occlusion in kernel `k`.
pub(crate) fn occluded_with<T: Layout, C: Counters>(
    k: Kernel,
    tree: &T,
    rays: &[Ray],
    occluded: &mut [bool],
    scratch: &mut StreamScratch,
    c: &mut C,
) {
    assert_eq!(rays.len(), occluded.len(), "one slot per ray");
    trace::<T, true, C>(k, tree, rays, scratch, c, |src, r, i| {
        occluded[src] = r.occluded(i);
    });
}

/// The octant split and the chunks: every ray of `rays` traced, its
/// answer handed to `out(index in rays, chunk, id in chunk)`.
fn trace<T: Layout, const ANY: bool, C: Counters>(
    k: Kernel,
    tree: &T,
    rays: &[Ray],
    scratch: &mut StreamScratch,
    c: &mut C,
    mut out: impl FnMut(usize, &StreamRays, usize),
) {
    let StreamScratch {
        options,
        order,
        rays: chunk,
        subsets,
    } = scratch;
    // The caller's indices by direction octant, then by the dominant axis
    // of the direction (`rays.rs`: one triangle-test permutation per axis
    // within an octant); a counting sort, stable.
    let class = |r: &Ray| {
        let [x, y, z] = r.dir_neg();
        let octant = usize::from(x) | usize::from(y) << 1 | usize::from(z) << 2;
        3 * octant + triangle::permutation(r.dir)[2]
    };
    let mut start = [0usize; 25];
    for r in rays {
        start[class(r) + 1] += 1;
    }
    for o in 0..24 {
        start[o + 1] += start[o];
    }
    order.resize(rays.len(), 0);
    let mut fill = start;
    for (i, r) in rays.iter().enumerate() {
        let o = class(r);
        order[fill[o]] = i as u32;
        fill[o] += 1;
    }
    for o in 0..8 {
        let neg = [o & 1 != 0, o & 2 != 0, o & 4 != 0];
        for src in order[start[3 * o]..start[3 * o + 3]].chunks(options.stream_size) {
            chunk_in::<T, ANY, C>(
                k,
                tree,
                rays,
                src,
                neg,
                chunk,
                subsets,
                options.single_ray_below,
                options.cell_boxes,
                c,
            );
            for (i, &s) in src.iter().enumerate() {
                out(s as usize, chunk, i);
            }
        }
    }
}

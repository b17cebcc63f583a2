//! The engines under test and the one tracing routine that both the timed
//! repetitions and `--check` run, plus the untimed counted pass.
//!
//! Timed work is exactly: trace every ray (or packet) and store its result
//! in a buffer allocated beforehand. Scalar and stream modes store one
//! result per ray (a stream splits its rays by octant and traces them
//! breadth first, or for a scene sorts them into packets, inside the
//! timed region); packet modes store one result per packet, and the lanes
//! are written back to ray order only afterwards, outside the timed region.
//!
//! Scenes of instances (`packtrace::scene`, accels `instance` and `scene`)
//! are traced through the scene's own API: `intersect`/`occluded` per ray,
//! `intersect_packet`/`occluded_packet` per 4- or 8-wide packet, and the
//! stream API (`SceneQuery::intersect_rays_with`), all with the default
//! query (every instance, no filter). Their hits carry the instance and
//! geometry too; compared with a mesh's hits, only `t`, `prim`, `u` and `v`
//! count.

use packtrace::bvh::{Bvh2, Bvh8};
use packtrace::glam::Vec3;
use packtrace::grid::{Grid, HGrid};
use packtrace::group::{Apex, RayGroup};
use packtrace::kdtree::{StreamOptions, StreamScratch};
use packtrace::protocol::workload::{NO_RAY, RaySet};
use packtrace::scene::{Query, Scene, SceneHit, SceneHits4, SceneHits8, SceneQuery};
use packtrace::{
    BlockedKdTree, BruteForce, Hit, HitPacket4, HitPacket8, InlineKdTree, KdTree, NaiveKdTree,
    PacketQuery, Ray, RayPacket4, RayPacket8, RayQuery, TraversalStats,
};
use rayon::ThreadPool;
use rayon::prelude::*;
use std::cell::RefCell;
use std::sync::OnceLock;
use std::time::Instant;

/// Rays (scalar mode) or packets (packet mode) per parallel work item.
const CHUNK: usize = 1024;

/// Rays per stream when a stream run is split across threads.
const STREAM_CHUNK: usize = 65536;

pub use packtrace::Mode;

/// Which structure answers the queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Accel {
    /// The kd-tree of 8-byte nodes (depth-first order, PBRT's).
    Kd8,
    /// The same tree with sibling pairs in cache-line blocks, to measure
    /// what that order buys.
    #[value(name = "kd8-blocked")]
    Kd8Blocked,
    /// The same tree with each leaf's triangles copied into one run of
    /// corner records (no index array), to measure what that buys.
    #[value(name = "kd8-inline")]
    Kd8Inline,
    /// The same tree converted to 40-byte nodes with per-leaf vectors.
    Naive,
    /// Every triangle for every ray (scalar only).
    Brute,
    /// The kd8 tree (shared, not rebuilt) placed as one instance with the
    /// identity transform in a `packtrace::scene::Scene`, traced through
    /// the scene's API: the cost of the top level and the instance
    /// transform over the bare tree (no group modes).
    Instance,
    /// A scene file's whole scene (`--scene PATH.scene`; no group modes).
    Scene,
    /// The binary BVH, binned SAH build, leaves tested one triangle at a
    /// time (`packtrace::bvh::Bvh2`, preset `sah_binary`; no group modes).
    Bvh2,
    /// The binary BVH with the lectures' median split (preset `median`).
    #[value(name = "bvh2-median")]
    Bvh2Median,
    /// The 8-wide BVH collapsed from the binary SAH tree, leaves of
    /// 4-triangle blocks (`packtrace::bvh::Bvh8`, preset `sah`; no group
    /// modes).
    Bvh8,
    /// The uniform grid with 3D-DDA traversal and mailboxes
    /// (`packtrace::grid::Grid`, `GridParams::default()`, density
    /// `--grid-density`; no group modes).
    Grid,
    /// The two-level grid: a coarse top grid whose crowded cells hold
    /// sub-grids (`packtrace::grid::HGrid`, `HGridParams::default()`, the
    /// sub-grids' density `--grid-density`; no group modes).
    #[value(name = "hgrid")]
    HGrid,
    /// Peer: Embree 3 through its C API (`--features embree`), Embree's
    /// default context flags: rtcIntersect1/4/8 (modes scalar, packet4,
    /// packet8). `peers::embree`.
    Embree,
    /// Peer: the same Embree scene traced with the coherent context flag
    /// (real packet traversal; modes packet4 and packet8).
    #[value(name = "embree-coherent")]
    EmbreeCoherent,
    /// Peer: obvhs 0.4.0's compressed wide BVH (CWBVH), single rays.
    /// `peers::obvhs`.
    Obvhs,
    /// Peer: tinybvh's BVH8_CPU through tinybvh-rs (`--features
    /// tinybvh`), single rays. `peers::tinybvh`.
    Tinybvh,
}

impl Accel {
    /// The JSON name.
    pub fn name(self) -> &'static str {
        match self {
            Accel::Kd8 => "kd8",
            Accel::Kd8Blocked => "kd8-blocked",
            Accel::Kd8Inline => "kd8-inline",
            Accel::Naive => "naive",
            Accel::Brute => "brute",
            Accel::Instance => "instance",
            Accel::Scene => "scene",
            Accel::Bvh2 => "bvh2",
            Accel::Bvh2Median => "bvh2-median",
            Accel::Bvh8 => "bvh8",
            Accel::Grid => "grid",
            Accel::HGrid => "hgrid",
            Accel::Embree => "embree",
            Accel::EmbreeCoherent => "embree-coherent",
            Accel::Obvhs => "obvhs",
            Accel::Tinybvh => "tinybvh",
        }
    }

    /// Is the accelerator a BVH (with its own statistics and counters)?
    pub fn is_bvh(self) -> bool {
        matches!(self, Accel::Bvh2 | Accel::Bvh2Median | Accel::Bvh8)
    }

    /// Is the accelerator a grid (with its own statistics and counters)?
    pub fn is_grid(self) -> bool {
        matches!(self, Accel::Grid | Accel::HGrid)
    }

    /// Does the accelerator run its own counted pass
    /// ([`counted_bvh`]: the BVHs and the grids)?
    pub fn counts_itself(self) -> bool {
        self.is_bvh() || self.is_grid()
    }

    /// Is the accelerator another engine (a peer in `peers`), not
    /// packtrace's?
    pub fn is_peer(self) -> bool {
        matches!(
            self,
            Accel::Embree | Accel::EmbreeCoherent | Accel::Obvhs | Accel::Tinybvh
        )
    }

    /// The cargo feature of `packtrace-cli` the accelerator needs, if any.
    pub fn feature(self) -> Option<&'static str> {
        match self {
            Accel::Embree | Accel::EmbreeCoherent => Some("embree"),
            Accel::Tinybvh => Some("tinybvh"),
            _ => None,
        }
    }

    /// Was the accelerator compiled into this binary (its feature on)?
    pub fn compiled_in(self) -> bool {
        self.feature().is_none_or(|f| {
            (f == "embree" && cfg!(feature = "embree"))
                || (f == "tinybvh" && cfg!(feature = "tinybvh"))
        })
    }

    /// Does the accelerator trace a scene of instances (and not one mesh)?
    pub fn is_scene(self) -> bool {
        matches!(self, Accel::Instance | Accel::Scene)
    }

    /// Can the accelerator trace a scene of this kind: a scene file
    /// (`scene_file`) or one mesh (an OBJ file or a `gen:` spec)? A scene
    /// file is traced by `scene` alone; a mesh by all the others.
    pub fn traces(self, scene_file: bool) -> bool {
        (self == Accel::Scene) == scene_file
    }

    /// Does the accelerator have a packet traversal? (Embree's packets are
    /// its own `rtcIntersect4/8`, without a stream mode.)
    pub fn has_packets(self) -> bool {
        !matches!(self, Accel::Brute | Accel::Obvhs | Accel::Tinybvh)
    }

    /// Does the accelerator trace ray groups (the group modes)?
    pub fn has_groups(self) -> bool {
        matches!(self, Accel::Kd8)
    }

    /// Can the accelerator trace in `mode`?
    pub fn runs(self, mode: Mode) -> bool {
        if matches!(self, Accel::Embree | Accel::EmbreeCoherent) {
            // The coherent flag is a packet traversal's: no single rays.
            return matches!(mode, Mode::Packet4 | Mode::Packet8)
                || (mode == Mode::Scalar && self == Accel::Embree);
        }
        match mode {
            Mode::Scalar => true,
            Mode::Group8x8 | Mode::Group16x16 => self.has_groups(),
            _ => self.has_packets(),
        }
    }

    /// Is the accelerator one kd-tree (with its tree statistics)? The
    /// instance accel is the kd8 tree under a one-instance top level.
    pub fn has_tree(self) -> bool {
        matches!(
            self,
            Accel::Kd8 | Accel::Kd8Blocked | Accel::Kd8Inline | Accel::Naive | Accel::Instance
        )
    }

    /// Are the counted pass's per-ray counters (the kd8 traversal's)
    /// this accelerator's? Not for scenes: their top level is not counted.
    pub fn has_counts(self) -> bool {
        matches!(
            self,
            Accel::Kd8 | Accel::Kd8Blocked | Accel::Kd8Inline | Accel::Naive
        )
    }
}

/// One accelerator, borrowed.
#[derive(Clone, Copy)]
pub enum Engine<'a> {
    /// 8-byte nodes.
    Kd8(&'a KdTree),
    /// 8-byte nodes in blocked order.
    Blocked(&'a BlockedKdTree),
    /// 8-byte nodes, leaves' triangles inline.
    Inline(&'a InlineKdTree),
    /// Fat nodes.
    Naive(&'a NaiveKdTree),
    /// No structure.
    Brute(BruteForce<'a>),
    /// A scene of instances (the instance and scene accels).
    Scene(&'a Scene),
    /// A binary BVH.
    Bvh2(&'a Bvh2),
    /// An 8-wide BVH.
    Bvh8(&'a Bvh8),
    /// A uniform grid.
    Grid(&'a Grid),
    /// A two-level grid.
    HGrid(&'a HGrid),
}

/// The rays of one workload in both forms the modes trace.
pub struct Input<'a> {
    /// Rays in ray order.
    pub rays: &'a [Ray],
    /// Packets as lane -> ray index ([`NO_RAY`]: inactive).
    pub lanes: &'a [[u32; 4]],
    /// The same packets in SoA form, made before timing.
    pub packets: &'a [RayPacket4],
    /// 8-wide packets as lane -> ray index.
    pub lanes8: &'a [[u32; 8]],
    /// The same in SoA form, made before timing.
    pub packets8: &'a [RayPacket8],
    /// The group modes' packets in tile order, made before timing.
    pub groups: &'a [Groups],
    /// Any-hit query (shadow, ao) instead of closest hit.
    pub occlusion: bool,
}

impl<'a> Input<'a> {
    /// `set`'s rays for the scalar mode alone (no SoA packets, no tiles).
    pub fn scalar(set: &'a RaySet, occlusion: bool) -> Input<'a> {
        Input {
            rays: &set.rays,
            lanes: &set.packets,
            packets: &[],
            lanes8: &set.packets8,
            packets8: &[],
            groups: &[],
            occlusion,
        }
    }

    /// The tiles of group mode `mode`.
    ///
    /// # Panics
    /// If they were not made (the caller makes them for every group mode
    /// it runs).
    pub fn groups_of(&self, mode: Mode) -> &Groups {
        self.groups
            .iter()
            .find(|g| g.mode == mode)
            .expect("tiles made for every group mode that runs")
    }
}

/// One group mode's 8-wide packets in tile order: the SoA copies and the
/// lane -> ray map of each, the packet range of each tile, and the apex.
pub struct Groups {
    /// The group mode.
    pub mode: Mode,
    /// Packets, tile after tile.
    pub packets: Vec<RayPacket8>,
    /// Lane -> ray index of each packet.
    pub lanes: Vec<[u32; 8]>,
    /// `packets[a..b]` of each tile.
    pub ranges: Vec<(usize, usize)>,
    /// The workload's apex (primary: the eye; shadow: the light).
    pub apex: Option<(Vec3, Apex)>,
}

impl Groups {
    /// The tiles of `mode` over `set` (`RaySet::tiles`).
    pub fn new(set: &RaySet, mode: Mode) -> Groups {
        let (w, h) = mode.tile().expect("a group mode");
        let mut g = Groups {
            mode,
            packets: Vec::with_capacity(set.packets8.len()),
            lanes: Vec::with_capacity(set.packets8.len()),
            ranges: Vec::new(),
            apex: set.apex,
        };
        for tile in set.tiles(w, h) {
            let a = g.packets.len();
            for i in tile {
                g.packets.push(set.packet8(i as usize));
                g.lanes.push(set.packets8[i as usize]);
            }
            g.ranges.push((a, g.packets.len()));
        }
        g
    }

    /// Tile `r` as a ray group: from the workload's apex, or, for rays
    /// without one (ao, random), from the first ray's origin, which gives
    /// an incoherent group traced packet by packet.
    fn group(&self, (a, b): (usize, usize)) -> RayGroup<'_> {
        let ps = &self.packets[a..b];
        let (apex, kind) = self.apex.unwrap_or_else(|| {
            let first = ps.iter().find_map(|p| (0..8).find_map(|i| p.ray(i)));
            (first.map_or(Vec3::ZERO, |r| r.origin()), Apex::Origin)
        });
        RayGroup::new(ps, apex, kind).expect("tiles of at most 32 packets, finite apex")
    }
}

/// Where one run stores its results.
pub enum Output {
    /// Scalar closest hits, per ray.
    Hits(Vec<Option<Hit>>),
    /// Scalar occlusion, per ray.
    Occluded(Vec<bool>),
    /// Packet closest hits, per packet.
    Hits4(Vec<HitPacket4>),
    /// Packet occlusion masks, per packet.
    Masks4(Vec<u32>),
    /// 8-wide packet closest hits, per packet.
    Hits8(Vec<HitPacket8>),
    /// 8-wide packet occlusion masks, per packet.
    Masks8(Vec<u32>),
    /// Group closest hits, per packet in tile order.
    GroupHits(Mode, Vec<HitPacket8>),
    /// Group occlusion masks, per packet in tile order.
    GroupMasks(Mode, Vec<u32>),
    /// A scene's scalar or stream closest hits, per ray (its occlusion
    /// goes to `Occluded`, `Masks4` and `Masks8`).
    SceneHits(Vec<Option<SceneHit>>),
    /// A scene's 4-wide packet closest hits, per packet.
    SceneHits4(Vec<SceneHits4>),
    /// A scene's 8-wide packet closest hits, per packet.
    SceneHits8(Vec<SceneHits8>),
}

/// Results in ray order.
#[derive(Debug, PartialEq)]
pub enum Results {
    /// Closest hit per ray.
    Closest(Vec<Option<Hit>>),
    /// Occlusion per ray.
    Occluded(Vec<bool>),
    /// A scene's closest hit per ray (with instance and geometry).
    SceneClosest(Vec<Option<SceneHit>>),
}

/// A scene hit as a mesh hit: `t`, `prim`, `u`, `v` (the instance and
/// geometry dropped).
pub fn mesh_hit(h: &SceneHit) -> Hit {
    Hit {
        t: h.t,
        prim: h.prim,
        u: h.u,
        v: h.v,
    }
}

impl Results {
    /// Number of rays.
    pub fn len(&self) -> usize {
        match self {
            Results::Closest(h) => h.len(),
            Results::Occluded(o) => o.len(),
            Results::SceneClosest(h) => h.len(),
        }
    }

    /// Rays with a hit (closest hit) or found occluded.
    pub fn hits(&self) -> u64 {
        match self {
            Results::Closest(h) => h.iter().flatten().count() as u64,
            Results::Occluded(o) => o.iter().filter(|&&b| b).count() as u64,
            Results::SceneClosest(h) => h.iter().flatten().count() as u64,
        }
    }

    /// Sum of `t` over hits in `f64`, in ray order; `None` for occlusion.
    pub fn sum_t(&self) -> Option<f64> {
        match self {
            Results::Closest(h) => Some(h.iter().flatten().map(|h| h.t as f64).sum()),
            Results::Occluded(_) => None,
            Results::SceneClosest(h) => Some(h.iter().flatten().map(|h| h.t as f64).sum()),
        }
    }

    /// The closest hits as mesh hits (a scene's without instance and
    /// geometry); `None` for occlusion.
    pub fn mesh_hits(&self) -> Option<Vec<Option<Hit>>> {
        match self {
            Results::Closest(h) => Some(h.clone()),
            Results::Occluded(_) => None,
            Results::SceneClosest(h) => Some(h.iter().map(|h| h.as_ref().map(mesh_hit)).collect()),
        }
    }

    /// Ray `i`'s result, printable.
    pub fn describe(&self, i: usize) -> String {
        match self {
            Results::Closest(h) => match h[i] {
                Some(h) => format!(
                    "Some(Hit {{ t: {:?} [0x{:08x}], prim: {}, u: {:?}, v: {:?} }})",
                    h.t,
                    h.t.to_bits(),
                    h.prim,
                    h.u,
                    h.v
                ),
                None => "None".into(),
            },
            Results::Occluded(o) => format!("occluded: {}", o[i]),
            Results::SceneClosest(h) => match h[i] {
                Some(h) => format!(
                    "Some(SceneHit {{ t: {:?} [0x{:08x}], prim: {}, u: {:?}, v: {:?}, instance: {}, \
                     geometry: {} }})",
                    h.t,
                    h.t.to_bits(),
                    h.prim,
                    h.u,
                    h.v,
                    h.instance.0,
                    h.geometry.0
                ),
                None => "None".into(),
            },
        }
    }

    /// First ray whose results differ. A mesh's hits and a scene's agree
    /// when `t`, `prim`, `u` and `v` are equal; two scenes' hits must also
    /// name the same instance and geometry.
    pub fn first_difference(&self, other: &Results) -> Option<usize> {
        let mesh_vs_scene = |a: &[Option<Hit>], b: &[Option<SceneHit>]| {
            a.iter()
                .zip(b)
                .position(|(x, y)| *x != y.as_ref().map(mesh_hit))
        };
        match (self, other) {
            (Results::Closest(a), Results::Closest(b)) => a.iter().zip(b).position(|(x, y)| x != y),
            (Results::Occluded(a), Results::Occluded(b)) => {
                a.iter().zip(b).position(|(x, y)| x != y)
            }
            (Results::SceneClosest(a), Results::SceneClosest(b)) => {
                a.iter().zip(b).position(|(x, y)| x != y)
            }
            (Results::Closest(a), Results::SceneClosest(b))
            | (Results::SceneClosest(b), Results::Closest(a)) => mesh_vs_scene(a, b),
            _ => Some(0),
        }
        .or((self.len() != other.len()).then(|| self.len().min(other.len())))
    }
}

impl Output {
    /// An empty buffer for `engine` in `mode` over `input`.
    pub fn new(engine: &Engine, mode: Mode, input: &Input) -> Output {
        if let Engine::Scene(_) = engine {
            match (mode, input.occlusion) {
                (Mode::Scalar | Mode::Stream, false) => {
                    return Output::SceneHits(vec![None; input.rays.len()]);
                }
                (Mode::Packet4, false) => {
                    return Output::SceneHits4(vec![SceneHits4::default(); input.packets.len()]);
                }
                (Mode::Packet8, false) => {
                    return Output::SceneHits8(vec![SceneHits8::default(); input.packets8.len()]);
                }
                // Occlusion: the same buffers as a mesh's.
                _ => {}
            }
        }
        match (mode, input.occlusion) {
            (Mode::Scalar | Mode::Stream, false) => Output::Hits(vec![None; input.rays.len()]),
            (Mode::Scalar | Mode::Stream, true) => Output::Occluded(vec![false; input.rays.len()]),
            (Mode::Packet4, false) => {
                Output::Hits4(vec![HitPacket4::default(); input.packets.len()])
            }
            (Mode::Packet4, true) => Output::Masks4(vec![0; input.packets.len()]),
            (Mode::Packet8, false) => {
                Output::Hits8(vec![HitPacket8::default(); input.packets8.len()])
            }
            (Mode::Packet8, true) => Output::Masks8(vec![0; input.packets8.len()]),
            (Mode::Group8x8 | Mode::Group16x16, false) => Output::GroupHits(
                mode,
                vec![HitPacket8::default(); input.groups_of(mode).packets.len()],
            ),
            (Mode::Group8x8 | Mode::Group16x16, true) => {
                Output::GroupMasks(mode, vec![0; input.groups_of(mode).packets.len()])
            }
        }
    }

    /// The results in ray order: packet lanes written back to their rays.
    pub fn per_ray(&self, input: &Input) -> Results {
        let n = input.rays.len();
        match self {
            Output::Hits(h) => Results::Closest(h.clone()),
            Output::Occluded(o) => Results::Occluded(o.clone()),
            Output::Hits4(p) => Results::Closest(scatter(n, p, input.lanes, |h, l| h.hit(l))),
            Output::Masks4(m) => {
                Results::Occluded(scatter(n, m, input.lanes, |m, l| m >> l & 1 == 1))
            }
            Output::Hits8(p) => Results::Closest(scatter(n, p, input.lanes8, |h, l| h.hit(l))),
            Output::Masks8(m) => {
                Results::Occluded(scatter(n, m, input.lanes8, |m, l| m >> l & 1 == 1))
            }
            Output::GroupHits(mode, p) => {
                let lanes = &input.groups_of(*mode).lanes;
                Results::Closest(scatter(n, p, lanes, |h, l| h.hit(l)))
            }
            Output::GroupMasks(mode, m) => {
                let lanes = &input.groups_of(*mode).lanes;
                Results::Occluded(scatter(n, m, lanes, |m, l| m >> l & 1 == 1))
            }
            Output::SceneHits(h) => Results::SceneClosest(h.clone()),
            Output::SceneHits4(p) => {
                Results::SceneClosest(scatter(n, p, input.lanes, |h, l| h.hit(l)))
            }
            Output::SceneHits8(p) => {
                Results::SceneClosest(scatter(n, p, input.lanes8, |h, l| h.hit(l)))
            }
        }
    }
}

/// Per-packet results written back to their rays (`n` rays).
fn scatter<P, T: Clone + Default, const W: usize>(
    n: usize,
    packets: &[P],
    lanes: &[[u32; W]],
    lane: impl Fn(&P, usize) -> T,
) -> Vec<T> {
    let mut out = vec![T::default(); n];
    for (p, lanes) in packets.iter().zip(lanes) {
        for (l, &ray) in lanes.iter().enumerate() {
            if ray != NO_RAY {
                out[ray as usize] = lane(p, l);
            }
        }
    }
    out
}

/// `output[i] = f(&input[i])` for all `i`: on this thread, or in chunks of
/// [`CHUNK`] across `pool`.
#[inline]
pub fn map_into<I: Sync, O: Send>(
    pool: Option<&ThreadPool>,
    input: &[I],
    output: &mut [O],
    f: impl Fn(&I) -> O + Sync,
) {
    fill_into(pool, input, output, |i, o| *o = f(i));
}

/// `f(input[k], &mut output[k])` for every `k`, on this thread or in
/// chunks across `pool`: for queries that write their result in place.
#[inline]
fn fill_into<I: Sync, O: Send>(
    pool: Option<&ThreadPool>,
    input: &[I],
    output: &mut [O],
    f: impl Fn(&I, &mut O) + Sync,
) {
    match pool {
        None => {
            for (o, i) in output.iter_mut().zip(input) {
                f(i, o);
            }
        }
        Some(pool) => pool.install(|| {
            input
                .par_chunks(CHUNK)
                .zip(output.par_chunks_mut(CHUNK))
                .for_each(|(is, os)| {
                    for (o, i) in os.iter_mut().zip(is) {
                        f(i, o);
                    }
                });
        }),
    }
}

/// Scalar tracing into a per-ray buffer.
fn trace_scalar<T: RayQuery + Sync>(
    t: &T,
    input: &Input,
    out: &mut Output,
    pool: Option<&ThreadPool>,
) {
    match out {
        Output::Hits(o) => map_into(pool, input.rays, o, |r| t.intersect(r)),
        Output::Occluded(o) => map_into(pool, input.rays, o, |r| t.occluded(r)),
        _ => unreachable!("scalar mode with a packet buffer"),
    }
}

/// kd8's stream options (`--stream-size`, `--stream-single`), set once
/// before any run.
static STREAM_OPTIONS: OnceLock<StreamOptions> = OnceLock::new();

/// Sets kd8's stream options (the first call wins).
pub fn set_stream_options(o: StreamOptions) {
    let _ = STREAM_OPTIONS.set(o);
}

thread_local! {
    /// kd8's stream scratch, one per thread and kept across repetitions,
    /// as a host keeps it.
    static SCRATCH: RefCell<Option<StreamScratch>> = const { RefCell::new(None) };
}

/// `f` with this thread's stream scratch (made with the options).
fn with_scratch<R>(f: impl FnOnce(&mut StreamScratch) -> R) -> R {
    SCRATCH.with(|s| {
        let mut s = s.borrow_mut();
        let o = STREAM_OPTIONS.get().copied().unwrap_or_default();
        let s = s.get_or_insert_with(|| StreamScratch::with_options(o));
        f(s)
    })
}

/// kd8's stream tracing: the breadth-first traversal with a scratch kept
/// per thread (`KdTree::intersect_stream`), chunked as [`trace_stream`].
fn trace_kd_stream(t: &KdTree, input: &Input, out: &mut Output, pool: Option<&ThreadPool>) {
    match out {
        Output::Hits(o) => stream_into(pool, input.rays, o, |r, h| {
            with_scratch(|s| t.intersect_stream(r, h, s));
        }),
        Output::Occluded(o) => stream_into(pool, input.rays, o, |r, m| {
            with_scratch(|s| t.occluded_stream(r, m, s));
        }),
        _ => unreachable!("stream mode with a packet buffer"),
    }
}

/// Stream tracing into a per-ray buffer: the whole workload is one stream
/// on one thread, or one stream per chunk of [`STREAM_CHUNK`] rays.
fn trace_stream<T: PacketQuery + Sync>(
    t: &T,
    input: &Input,
    out: &mut Output,
    pool: Option<&ThreadPool>,
) {
    match out {
        Output::Hits(o) => stream_into(pool, input.rays, o, |r, h| t.intersect_rays(r, h)),
        Output::Occluded(o) => stream_into(pool, input.rays, o, |r, m| t.occluded_rays(r, m)),
        _ => unreachable!("stream mode with a packet buffer"),
    }
}

/// `f(rays, out)` as one stream on this thread, or one stream per chunk of
/// [`STREAM_CHUNK`] rays across `pool`, each writing its own slice of `out`.
fn stream_into<O: Send>(
    pool: Option<&ThreadPool>,
    rays: &[Ray],
    out: &mut [O],
    f: impl Fn(&[Ray], &mut [O]) + Sync,
) {
    match pool {
        None => f(rays, out),
        Some(pool) => pool.install(|| {
            rays.par_chunks(STREAM_CHUNK)
                .zip(out.par_chunks_mut(STREAM_CHUNK))
                .for_each(|(r, o)| f(r, o));
        }),
    }
}

/// Packet tracing into a per-packet buffer.
fn trace_packets<T: PacketQuery + Sync>(
    t: &T,
    input: &Input,
    out: &mut Output,
    pool: Option<&ThreadPool>,
) {
    match out {
        Output::Hits4(o) => map_into(pool, input.packets, o, |p| t.intersect4(p)),
        Output::Masks4(o) => map_into(pool, input.packets, o, |p| t.occluded4(p)),
        Output::Hits8(o) => map_into(pool, input.packets8, o, |p| t.intersect8(p)),
        Output::Masks8(o) => map_into(pool, input.packets8, o, |p| t.occluded8(p)),
        _ => unreachable!("packet mode with another mode's buffer"),
    }
}

/// A scene's scalar tracing into a per-ray buffer.
fn trace_scene_scalar(s: &Scene, input: &Input, out: &mut Output, pool: Option<&ThreadPool>) {
    match out {
        Output::SceneHits(o) => map_into(pool, input.rays, o, |r| s.intersect(r)),
        Output::Occluded(o) => map_into(pool, input.rays, o, |r| s.occluded(r)),
        _ => unreachable!("scene scalar mode with another buffer"),
    }
}

/// A scene's packet tracing into a per-packet buffer (the default query:
/// every instance, no filter).
fn trace_scene_packets(s: &Scene, input: &Input, out: &mut Output, pool: Option<&ThreadPool>) {
    let q = Query::new();
    match out {
        Output::SceneHits4(o) => {
            fill_into(pool, input.packets, o, |p, h| {
                s.intersect_packet_into(p, &q, h)
            });
        }
        Output::Masks4(o) => map_into(pool, input.packets, o, |p| s.occluded_packet(p, &q)),
        Output::SceneHits8(o) => {
            fill_into(pool, input.packets8, o, |p, h| {
                s.intersect_packet_into(p, &q, h)
            });
        }
        Output::Masks8(o) => map_into(pool, input.packets8, o, |p| s.occluded_packet(p, &q)),
        _ => unreachable!("scene packet mode with another buffer"),
    }
}

/// A scene's stream tracing (`SceneQuery`'s stream API, which sorts the
/// rays into coherent packets) into a per-ray buffer.
fn trace_scene_stream(s: &Scene, input: &Input, out: &mut Output, pool: Option<&ThreadPool>) {
    let q = Query::new();
    match out {
        Output::SceneHits(o) => stream_into(pool, input.rays, o, |r, h| {
            s.intersect_rays_with(r, h, &q);
        }),
        Output::Occluded(o) => stream_into(pool, input.rays, o, |r, m| {
            s.occluded_rays_with(r, m, &q);
        }),
        _ => unreachable!("scene stream mode with another buffer"),
    }
}

/// Group tracing into a per-packet buffer in tile order: one tile per
/// work item, on this thread or across `pool`.
fn trace_groups(t: &KdTree, input: &Input, out: &mut Output, pool: Option<&ThreadPool>) {
    match out {
        Output::GroupHits(mode, o) => {
            let g = input.groups_of(*mode);
            for_tiles(pool, g, o, |gr, o| t.intersect_group_into(gr, o));
        }
        Output::GroupMasks(mode, o) => {
            let g = input.groups_of(*mode);
            for_tiles(pool, g, o, |gr, o| t.occluded_group_into(gr, o));
        }
        _ => unreachable!("group mode with another mode's buffer"),
    }
}

/// `f(tile, its slice of out)` for every tile of `g`.
fn for_tiles<O: Send>(
    pool: Option<&ThreadPool>,
    g: &Groups,
    out: &mut [O],
    f: impl Fn(&RayGroup, &mut [O]) + Sync,
) {
    match pool {
        None => {
            for &r in &g.ranges {
                f(&g.group(r), &mut out[r.0..r.1]);
            }
        }
        Some(pool) => {
            let mut slices = Vec::with_capacity(g.ranges.len());
            let mut rest = out;
            for &(a, b) in &g.ranges {
                let (head, tail) = rest.split_at_mut(b - a);
                slices.push(head);
                rest = tail;
            }
            pool.install(|| {
                slices
                    .into_par_iter()
                    .zip(g.ranges.par_iter())
                    .with_min_len(16)
                    .for_each(|(o, &r)| f(&g.group(r), o));
            });
        }
    }
}

/// Trace every ray of `input` once into `out` (made by [`Output::new`] for
/// the same engine and mode): the timed work, and what `--check` verifies.
///
/// # Panics
/// For a mode the engine lacks (brute force in packet mode, a scene or
/// the naive layout in group mode; callers skip them) or a buffer of
/// another mode.
pub fn trace(
    engine: Engine,
    mode: Mode,
    input: &Input,
    out: &mut Output,
    pool: Option<&ThreadPool>,
) {
    match (engine, mode) {
        (Engine::Kd8(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::Kd8(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::Kd8(t), Mode::Stream) => trace_kd_stream(t, input, out, pool),
        (Engine::Kd8(t), Mode::Group8x8 | Mode::Group16x16) => trace_groups(t, input, out, pool),
        (Engine::Blocked(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::Blocked(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::Blocked(t), Mode::Stream) => trace_stream(t, input, out, pool),
        (Engine::Inline(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::Inline(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::Inline(t), Mode::Stream) => trace_stream(t, input, out, pool),
        (Engine::Naive(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::Naive(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::Naive(t), Mode::Stream) => trace_stream(t, input, out, pool),
        (Engine::Brute(b), Mode::Scalar) => trace_scalar(&b, input, out, pool),
        (Engine::Scene(s), Mode::Scalar) => trace_scene_scalar(s, input, out, pool),
        (Engine::Scene(s), Mode::Packet4 | Mode::Packet8) => {
            trace_scene_packets(s, input, out, pool);
        }
        (Engine::Scene(s), Mode::Stream) => trace_scene_stream(s, input, out, pool),
        (Engine::Bvh2(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::Bvh2(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::Bvh2(t), Mode::Stream) => trace_stream(t, input, out, pool),
        (Engine::Bvh8(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::Bvh8(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::Bvh8(t), Mode::Stream) => trace_stream(t, input, out, pool),
        (Engine::Grid(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::Grid(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::Grid(t), Mode::Stream) => trace_stream(t, input, out, pool),
        (Engine::HGrid(t), Mode::Scalar) => trace_scalar(t, input, out, pool),
        (Engine::HGrid(t), Mode::Packet4 | Mode::Packet8) => trace_packets(t, input, out, pool),
        (Engine::HGrid(t), Mode::Stream) => trace_stream(t, input, out, pool),
        (Engine::Bvh2(_) | Engine::Bvh8(_), _) => unreachable!("the BVHs have no group mode"),
        (Engine::Grid(_) | Engine::HGrid(_), _) => unreachable!("the grids have no group mode"),
        (Engine::Brute(_), _) => unreachable!("brute force has no packet or stream mode"),
        (Engine::Blocked(_) | Engine::Inline(_) | Engine::Naive(_), _) => {
            unreachable!("only the kd8 tree has group modes")
        }
        (Engine::Scene(_), _) => unreachable!("scenes have no group mode"),
    }
}

/// Trace once untimed (warm-up), then `reps` timed times. Returns the
/// seconds of each timed run and the buffer of the last one.
pub fn time_runs(
    engine: Engine,
    mode: Mode,
    input: &Input,
    pool: Option<&ThreadPool>,
    reps: u32,
) -> (Vec<f64>, Output) {
    let mut out = Output::new(&engine, mode, input);
    trace(engine, mode, input, &mut out, pool);
    let mut seconds = Vec::with_capacity(reps as usize);
    for _ in 0..reps {
        let start = Instant::now();
        trace(engine, mode, input, &mut out, pool);
        seconds.push(start.elapsed().as_secs_f64());
    }
    (seconds, out)
}

/// Median (mean of the middle two for an even count); NaN when empty.
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Sum of `f(item, stats)` counters over `items`, in chunks across `pool`.
fn count_over<I: Sync>(
    pool: Option<&ThreadPool>,
    items: &[I],
    f: impl Fn(&I, &mut TraversalStats) + Sync,
) -> TraversalStats {
    let chunk = |c: &[I]| {
        let mut s = TraversalStats::default();
        for i in c {
            f(i, &mut s);
        }
        s
    };
    match pool {
        None => chunk(items),
        Some(pool) => pool.install(|| {
            items
                .par_chunks(CHUNK)
                .map(chunk)
                .reduce(TraversalStats::default, |mut a, b| {
                    a += b;
                    a
                })
        }),
    }
}

/// The untimed counted pass of the kd-tree in `mode` (the naive layout runs
/// the same traversal over the same nodes, so its counts are these too).
pub fn counted(
    tree: &KdTree,
    mode: Mode,
    input: &Input,
    pool: Option<&ThreadPool>,
) -> TraversalStats {
    match (mode, input.occlusion) {
        (Mode::Scalar, false) => count_over(pool, input.rays, |r, s| {
            tree.intersect_counted(r, s);
        }),
        (Mode::Scalar, true) => count_over(pool, input.rays, |r, s| {
            tree.occluded_counted(r, s);
        }),
        (Mode::Packet4, false) => count_over(pool, input.packets, |p, s| {
            tree.intersect4_counted(p, s);
        }),
        (Mode::Packet4, true) => count_over(pool, input.packets, |p, s| {
            tree.occluded4_counted(p, s);
        }),
        (Mode::Packet8, false) => count_over(pool, input.packets8, |p, s| {
            tree.intersect_packet_counted(p, s);
        }),
        (Mode::Packet8, true) => count_over(pool, input.packets8, |p, s| {
            tree.occluded_packet_counted(p, s);
        }),
        // The stream in the timed run's chunks, with its scratch.
        (Mode::Stream, occlusion) => {
            let chunk = if pool.is_some() {
                STREAM_CHUNK
            } else {
                input.rays.len().max(1)
            };
            count_over(
                pool,
                &input.rays.chunks(chunk).collect::<Vec<_>>(),
                |r, s| {
                    with_scratch(|scratch| {
                        if occlusion {
                            tree.occluded_stream_counted(r, &mut vec![false; r.len()], scratch, s);
                        } else {
                            tree.intersect_stream_counted(r, &mut vec![None; r.len()], scratch, s);
                        }
                    });
                },
            )
        }
        (Mode::Group8x8 | Mode::Group16x16, occlusion) => {
            let g = input.groups_of(mode);
            count_over(pool, &g.ranges, |&r, s| {
                let group = g.group(r);
                if occlusion {
                    let mut o = vec![0; r.1 - r.0];
                    tree.occluded_group_counted(&group, &mut o, s);
                } else {
                    let mut o = vec![HitPacket8::default(); r.1 - r.0];
                    tree.intersect_group_counted(&group, &mut o, s);
                }
            })
        }
    }
}

/// The counted pass of a BVH or a grid in `mode` (packet modes count the
/// workload's 8-wide or 4-wide packets; a stream's are those of the
/// 8-wide packets). A grid's `nodes` are the cells walked, its `leaves`
/// the non-empty cells tested, and it counts `mailbox_hits`.
pub fn counted_bvh(
    engine: Engine,
    mode: Mode,
    input: &Input,
    pool: Option<&ThreadPool>,
) -> TraversalStats {
    // The 8-wide tree's stream is its single rays (`Bvh8::intersect_rays`).
    let mode = match (engine, mode) {
        (Engine::Bvh8(_), Mode::Stream) => Mode::Scalar,
        _ => mode,
    };
    macro_rules! count {
        ($t:expr) => {
            match (mode, input.occlusion) {
                (Mode::Scalar, false) => count_over(pool, input.rays, |r, s| {
                    $t.intersect_counted(r, s);
                }),
                (Mode::Scalar, true) => count_over(pool, input.rays, |r, s| {
                    $t.occluded_counted(r, s);
                }),
                (Mode::Packet4, false) => count_over(pool, input.packets, |p, s| {
                    $t.intersect_packet_counted(p, s);
                }),
                (Mode::Packet4, true) => count_over(pool, input.packets, |p, s| {
                    $t.occluded_packet_counted(p, s);
                }),
                (_, false) => count_over(pool, input.packets8, |p, s| {
                    $t.intersect_packet_counted(p, s);
                }),
                (_, true) => count_over(pool, input.packets8, |p, s| {
                    $t.occluded_packet_counted(p, s);
                }),
            }
        };
    }
    match engine {
        Engine::Bvh2(t) => count!(t),
        Engine::Bvh8(t) => count!(t),
        Engine::Grid(t) => count!(t),
        Engine::HGrid(t) => count!(t),
        _ => TraversalStats::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use packtrace::protocol::camera::Camera;
    use packtrace::protocol::{SceneFrame, default_light, generate, workload};
    use std::sync::Arc;

    /// Every mode of `engine` that `accel` runs, on `set`, against
    /// `reference` (on this thread and on a pool of two).
    fn agree(accel: Accel, engine: Engine, reference: &Results, set: &RaySet, occlusion: bool) {
        let packets: Vec<RayPacket4> = (0..set.packets.len()).map(|i| set.packet(i)).collect();
        let packets8: Vec<RayPacket8> = (0..set.packets8.len()).map(|i| set.packet8(i)).collect();
        let input = Input {
            rays: &set.rays,
            lanes: &set.packets,
            packets: &packets,
            lanes8: &set.packets8,
            packets8: &packets8,
            groups: &[],
            occlusion,
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let mut modes = 0;
        for mode in Mode::ALL.into_iter().filter(|&m| accel.runs(m)) {
            for pool in [None, Some(&pool)] {
                let mut out = Output::new(&engine, mode, &input);
                trace(engine, mode, &input, &mut out, pool);
                let got = out.per_ray(&input);
                assert_eq!(
                    reference.first_difference(&got),
                    None,
                    "{}/{}",
                    accel.name(),
                    mode.name()
                );
                // t, prim, u and v bit for bit.
                if let (Some(a), Some(b)) = (reference.mesh_hits(), got.mesh_hits()) {
                    let bits = |h: &[Option<Hit>]| -> Vec<_> {
                        h.iter()
                            .map(|h| {
                                h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
                            })
                            .collect()
                    };
                    assert_eq!(bits(&a), bits(&b), "{}/{}", accel.name(), mode.name());
                }
            }
            modes += 1;
        }
        assert_eq!(modes, 4, "scalar, packet4, packet8, stream");
    }

    /// The four workloads over `tree`'s mesh at 32 x 32, each with
    /// whether it asks for occlusion.
    fn four_workloads(tree: &KdTree) -> [(RaySet, bool); 4] {
        let frame = SceneFrame::of(tree.mesh());
        let camera = Camera::auto(&frame.bounds);
        let primary = workload::primary(&camera, 32, 32).unwrap();
        let hits: Vec<Option<Hit>> = primary.rays.iter().map(|r| tree.intersect(r)).collect();
        assert!(hits.iter().flatten().count() > 100);
        let light = default_light(&frame);
        [
            (primary.clone(), false),
            (
                workload::shadow(&primary, &hits, tree.mesh(), &frame, light),
                true,
            ),
            (workload::ao(&primary, &hits, tree.mesh(), &frame), true),
            (workload::random(&frame, 1024), false),
        ]
    }

    #[test]
    fn one_instance_traces_exactly_as_the_bare_tree() {
        let tree = Arc::new(KdTree::build(generate::sphere(2000), &Default::default()).unwrap());
        let one = crate::scene::one_instance("sphere", Arc::clone(&tree)).unwrap();
        assert!(std::ptr::eq(
            one.geometry(packtrace::scene::GeometryId(0))
                .unwrap()
                .tree(),
            &*tree
        ));
        let sets = four_workloads(&tree);
        for (set, occlusion) in &sets {
            let reference = if *occlusion {
                Results::Occluded(set.rays.iter().map(|r| tree.occluded(r)).collect())
            } else {
                Results::Closest(set.rays.iter().map(|r| tree.intersect(r)).collect())
            };
            agree(
                Accel::Instance,
                Engine::Scene(&one),
                &reference,
                set,
                *occlusion,
            );
        }
    }

    #[test]
    fn bvh2_and_the_grids_trace_exactly_as_kd8() {
        use packtrace::bvh::BvhBuildParams;
        use packtrace::grid::{GridParams, HGridParams};
        let mesh = generate::sphere(3000);
        let tree = KdTree::build(mesh.clone(), &Default::default()).unwrap();
        let bvh2 = Bvh2::build(mesh.clone(), &BvhBuildParams::sah_binary()).unwrap();
        let grid = Grid::build(mesh.clone(), &GridParams::default()).unwrap();
        // Few triangles per sub-grid: the top level refines.
        let hparams = HGridParams {
            refine_above: 4,
            ..HGridParams::default()
        };
        let hgrid = HGrid::build(mesh, &hparams).unwrap();
        assert!(hgrid.stats().subgrids > 0);
        let sets = four_workloads(&tree);
        let engines = [
            (Accel::Bvh2, Engine::Bvh2(&bvh2)),
            (Accel::Grid, Engine::Grid(&grid)),
            (Accel::HGrid, Engine::HGrid(&hgrid)),
        ];
        for (set, occlusion) in &sets {
            let reference = if *occlusion {
                Results::Occluded(set.rays.iter().map(|r| tree.occluded(r)).collect())
            } else {
                Results::Closest(set.rays.iter().map(|r| tree.intersect(r)).collect())
            };
            for (accel, engine) in engines {
                agree(accel, engine, &reference, set, *occlusion);
            }
        }
        // The counted pass: cells walked and tested, triangle tests and
        // mailbox hits, for every mode the grids run.
        let primary = &sets[0].0;
        let packets: Vec<RayPacket4> = (0..primary.packets.len())
            .map(|i| primary.packet(i))
            .collect();
        let packets8: Vec<RayPacket8> = (0..primary.packets8.len())
            .map(|i| primary.packet8(i))
            .collect();
        let input = Input {
            rays: &primary.rays,
            lanes: &primary.packets,
            packets: &packets,
            lanes8: &primary.packets8,
            packets8: &packets8,
            groups: &[],
            occlusion: false,
        };
        for (accel, engine) in engines {
            for mode in Mode::ALL.into_iter().filter(|&m| accel.runs(m)) {
                let c = counted_bvh(engine, mode, &input, None);
                let what = format!("{}/{}", accel.name(), mode.name());
                assert_eq!(c.rays, primary.rays.len() as u64, "{what}");
                assert!(c.nodes > 0 && c.leaves > 0, "{what}: {c:?}");
                assert!(c.triangle_tests > 0, "{what}: {c:?}");
                if !accel.is_grid() {
                    assert_eq!(c.mailbox_hits, 0, "{what}");
                }
            }
        }
        // Random rays cross many cells: a triangle in several of them is
        // met again, and the mailbox skips it.
        let random = &sets[3].0;
        let input = Input::scalar(random, false);
        for (accel, engine) in &engines[1..] {
            let c = counted_bvh(*engine, Mode::Scalar, &input, None);
            assert!(c.mailbox_hits > 0, "{}: {c:?}", accel.name());
        }
        assert!(Accel::Grid.counts_itself() && Accel::Bvh2.counts_itself());
        assert!(!Accel::Kd8.counts_itself() && !Accel::Grid.has_counts());
    }

    #[test]
    fn scene_hits_compare_with_mesh_hits_by_t_prim_u_v() {
        use packtrace::scene::{GeometryId, InstanceId, SceneHit};
        let h = Hit {
            t: 2.0,
            prim: 7,
            u: 0.25,
            v: 0.5,
        };
        let sh = |instance| SceneHit {
            t: 2.0,
            u: 0.25,
            v: 0.5,
            prim: 7,
            geometry: GeometryId(0),
            instance: InstanceId(instance),
        };
        let mesh = Results::Closest(vec![None, Some(h)]);
        let scene = Results::SceneClosest(vec![None, Some(sh(3))]);
        assert_eq!(mesh.first_difference(&scene), None);
        assert_eq!(scene.first_difference(&mesh), None);
        assert_eq!(mesh_hit(&sh(3)), h);
        // Two scenes' hits must name the same instance.
        let other = Results::SceneClosest(vec![None, Some(sh(4))]);
        assert_eq!(scene.first_difference(&other), Some(1));
        let moved = Results::Closest(vec![None, Some(Hit { prim: 8, ..h })]);
        assert_eq!(moved.first_difference(&scene), Some(1));
        assert_eq!(
            scene.first_difference(&Results::Occluded(vec![false, true])),
            Some(0)
        );
        assert_eq!(
            (scene.hits(), scene.sum_t(), scene.len()),
            (1, Some(2.0), 2)
        );
        assert!(
            scene.describe(1).contains("instance: 3"),
            "{}",
            scene.describe(1)
        );
        assert_eq!(scene.mesh_hits(), Some(vec![None, Some(h)]));
    }

    #[test]
    fn accels_say_what_they_trace() {
        assert!(Accel::Instance.traces(false) && !Accel::Instance.traces(true));
        assert!(Accel::Scene.traces(true) && !Accel::Scene.traces(false));
        for a in [Accel::Instance, Accel::Scene] {
            assert!(a.is_scene() && !a.has_counts() && a.has_packets());
            assert!(!a.runs(Mode::Group8x8) && !a.runs(Mode::Group16x16) && a.runs(Mode::Stream));
        }
        assert!(Accel::Instance.has_tree() && !Accel::Scene.has_tree());
        assert_eq!(
            (Accel::Instance.name(), Accel::Scene.name()),
            ("instance", "scene")
        );
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn packet_lanes_go_back_to_their_rays() {
        let r = Ray::new_unchecked(glam::Vec3::ZERO, glam::Vec3::X, 0.0, 1.0);
        let rays = [r; 3];
        let lanes = [[2, NO_RAY, 0, 1]];
        let input = Input {
            rays: &rays,
            lanes: &lanes,
            packets: &[],
            lanes8: &[],
            packets8: &[],
            groups: &[],
            occlusion: true,
        };
        let out = Output::Masks4(vec![0b0101]);
        assert_eq!(
            out.per_ray(&input),
            Results::Occluded(vec![true, false, true])
        );
        let hit = Ray::new_unchecked(glam::Vec3::new(0.2, 0.2, 1.0), glam::Vec3::NEG_Z, 0.0, 9.0);
        let tri = packtrace::Mesh::new(
            vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let tree = KdTree::build(tri, &packtrace::KdBuildParams::default()).unwrap();
        let h = tree.intersect4(&RayPacket4::from_lanes([None, None, None, Some(hit)]));
        let out = Output::Hits4(vec![h]);
        let res = out.per_ray(&Input {
            occlusion: false,
            ..input
        });
        assert_eq!(res.hits(), 1);
        assert_eq!(res.sum_t(), Some(1.0));
        let Results::Closest(v) = res else { panic!() };
        assert_eq!(v[1].map(|h| h.prim), Some(0));
        // 8-wide: lane 6 holds ray 0.
        let lanes8 = [[NO_RAY, NO_RAY, NO_RAY, NO_RAY, NO_RAY, NO_RAY, 0, NO_RAY]];
        let input8 = Input {
            lanes8: &lanes8,
            ..input
        };
        let out = Output::Masks8(vec![0b0100_0000]);
        assert_eq!(
            out.per_ray(&input8),
            Results::Occluded(vec![true, false, false])
        );
    }
}

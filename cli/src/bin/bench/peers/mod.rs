//! Peer engines inside the bench: Embree 3 (`embree`, `embree-coherent`;
//! `--features embree`), obvhs (`obvhs`) and tinybvh (`tinybvh`;
//! `--features tinybvh`), traced on the protocol's rays beside packtrace.
//!
//! Each peer builds its own structure over the scene's triangles (file
//! order, so its primitive ids are packtrace's triangle indices), takes
//! the same primary and random rays as packtrace, and derives its shadow
//! and ao rays from its *own* primary hits (the protocol's rule: an engine
//! is measured on the rays a renderer built on it would cast). It writes
//! the same JSON lines as packtrace's modes, and `--check` compares its
//! hit count and summed `t` with scalar kd8's within the protocol's
//! tolerance (`check_peer`).
//!
//! Timing: rays are converted into the engine's own ray records before
//! timing; engines that write into their rays (Embree, tinybvh) get a
//! fresh copy before every repetition, outside the timed region. Only the
//! engine's trace calls and the store of each result are timed, as for
//! packtrace's modes.

#[cfg(feature = "embree")]
pub mod embree;
#[cfg(any(feature = "embree", feature = "tinybvh"))]
#[allow(unsafe_code)]
mod ffi;
pub mod obvhs;
#[cfg(feature = "tinybvh")]
pub mod tinybvh;

use crate::check::{self, Tally};
use crate::cli::Config;
use crate::fingerprint::Fingerprint;
use crate::report::Sink;
use crate::trace::{self, Accel, Input, Mode, Results};
use crate::{Failure, JsonFields, Row, json_line, progress};
use packtrace::glam::Vec3;
use packtrace::protocol::SceneFrame;
use packtrace::protocol::workload::{self, RaySet, Workload};
use packtrace::{Hit, KdTree, Mesh};
use rayon::ThreadPool;
#[cfg(any(feature = "embree", feature = "tinybvh"))]
use rayon::prelude::*;
use std::time::Instant;

/// Rays or packets per parallel work item (as packtrace's modes).
#[cfg(any(feature = "embree", feature = "tinybvh"))]
const CHUNK: usize = 1024;

/// One built peer engine.
pub trait Peer: Sync {
    /// Its accel name.
    fn accel(&self) -> Accel;
    /// Seconds its build took (the structure and any layout step needed
    /// before tracing), on the run's thread count.
    fn build_seconds(&self) -> f64;
    /// Bytes of its structure, where the engine tells.
    fn bytes(&self) -> Option<usize>;
    /// The engine and its version, e.g. `embree 3.13.5`.
    fn version(&self) -> String;
    /// `set`'s rays in the engine's own form for `mode` (untimed).
    fn prepare<'a>(&'a self, mode: Mode, set: &'a RaySet, occlusion: bool) -> Box<dyn Traced + 'a>;
}

/// One workload's rays, prepared for one peer and mode.
pub trait Traced {
    /// Put the rays back as prepared (untimed; for engines that write into
    /// their rays).
    fn reset(&mut self);
    /// Trace every ray once: the timed work.
    fn trace(&mut self, pool: Option<&ThreadPool>);
    /// The results of the last trace in ray order.
    fn results(&self) -> Results;
}

/// Build the peers among `accels` over `mesh`, on `threads` threads.
///
/// # Errors
/// [`Failure::Input`] when an engine refuses the scene or its device.
pub fn build(accels: &[Accel], mesh: &Mesh, threads: usize) -> Result<Vec<Box<dyn Peer>>, Failure> {
    let mut peers: Vec<Box<dyn Peer>> = Vec::new();
    #[cfg(feature = "embree")]
    {
        let flags: Vec<bool> = accels
            .iter()
            .filter_map(|a| match a {
                Accel::Embree => Some(false),
                Accel::EmbreeCoherent => Some(true),
                _ => None,
            })
            .collect();
        if !flags.is_empty() {
            // One Embree scene, traced with either context flag.
            let scene = std::sync::Arc::new(embree::Built::new(mesh, threads)?);
            for coherent in flags {
                peers.push(Box::new(embree::Embree::new(&scene, coherent)));
            }
        }
    }
    for &a in accels {
        match a {
            Accel::Obvhs => peers.push(Box::new(obvhs::Obvhs::new(mesh))),
            #[cfg(feature = "tinybvh")]
            Accel::Tinybvh => peers.push(Box::new(tinybvh::TinyBvh::new(mesh)?)),
            _ => {}
        }
    }
    let _ = threads;
    // In --accel order.
    peers.sort_by_key(|p| accels.iter().position(|&a| a == p.accel()));
    Ok(peers)
}

/// What the peers of one mesh scene share: the scene, its primary rays,
/// and packtrace's reference for `--check`.
pub struct Scene<'a> {
    /// The JSON `scene`.
    pub name: &'a str,
    /// The scene's triangles (the peers' primitive ids index them).
    pub mesh: &'a Mesh,
    /// Its frame (box, diagonal).
    pub frame: SceneFrame,
    /// Its light.
    pub light: Vec3,
    /// Its primary rays.
    pub primary: &'a RaySet,
    /// Scalar kd8's primary hits, which packtrace's shadow and ao rays
    /// derive from.
    pub kd8_hits: &'a [Option<Hit>],
    /// The kd8 tree: `--check`'s reference.
    pub tree: &'a KdTree,
    /// The rays' fingerprint before the workload.
    pub fingerprint: Fingerprint,
}

/// A workload's rays from `primary` and an engine's own primary `hits`.
fn rays_of(scene: &Scene, w: Workload, hits: &[Option<Hit>]) -> RaySet {
    match w {
        Workload::Primary => scene.primary.clone(),
        Workload::Shadow => {
            workload::shadow(scene.primary, hits, scene.mesh, &scene.frame, scene.light)
        }
        Workload::Ao => workload::ao(scene.primary, hits, scene.mesh, &scene.frame),
        Workload::Random => workload::random(&scene.frame, scene.primary.len()),
    }
}

/// Scalar kd8's tally of workload `w`: `--check`'s reference.
fn reference(scene: &Scene, w: Workload) -> Tally {
    let set = rays_of(scene, w, scene.kd8_hits);
    let input = Input::scalar(&set, w.is_occlusion());
    let results = check::reference(scene.tree, &input);
    Tally::of(
        &results,
        scene.fingerprint.workload(w),
        scene.primary.len() as u64,
    )
}

/// Trace once untimed (warm-up), then `reps` timed times, each after a
/// reset; the seconds of each.
fn time_runs(traced: &mut dyn Traced, pool: Option<&ThreadPool>, reps: u32) -> Vec<f64> {
    traced.reset();
    traced.trace(pool);
    (0..reps)
        .map(|_| {
            traced.reset();
            let start = Instant::now();
            traced.trace(pool);
            start.elapsed().as_secs_f64()
        })
        .collect()
}

/// Check and time every workload and mode of every peer; one JSON line
/// per (peer, workload, mode), its rates added to the scene's rows.
///
/// # Errors
/// [`Failure::Mismatch`] when `--check` finds a peer outside the
/// protocol's tolerance; [`Failure::Io`] when a line cannot be written.
pub fn run(
    cfg: &Config,
    sink: &mut Sink,
    scene: &Scene,
    peers: &[Box<dyn Peer>],
    pool: Option<&ThreadPool>,
    rows: &mut [Row],
) -> Result<(), Failure> {
    let mut references: Vec<(Workload, Tally)> = Vec::new();
    for peer in peers {
        let accel = peer.accel();
        // The peer's own primary hits, in the first mode it has.
        let first = Mode::ALL
            .into_iter()
            .find(|&m| accel.runs(m))
            .expect("every peer has a mode");
        let hits = {
            let mut t = peer.prepare(first, scene.primary, false);
            t.reset();
            t.trace(pool);
            t.results().mesh_hits().expect("closest hits")
        };
        for &w in &cfg.workloads {
            let set = rays_of(scene, w, &hits);
            let fingerprint = scene.fingerprint.workload(w);
            let modes: Vec<Mode> = if cfg.check {
                Mode::ALL.into_iter().filter(|&m| accel.runs(m)).collect()
            } else {
                cfg.modes
                    .iter()
                    .copied()
                    .filter(|&m| accel.runs(m))
                    .collect()
            };
            for mode in modes {
                let mut traced = peer.prepare(mode, &set, w.is_occlusion());
                if cfg.check {
                    let reference = match references.iter().find(|(x, _)| *x == w) {
                        Some((_, t)) => t.clone(),
                        None => {
                            let t = reference(scene, w);
                            references.push((w, t.clone()));
                            t
                        }
                    };
                    traced.reset();
                    traced.trace(pool);
                    let pixels = scene.primary.len() as u64;
                    let got = Tally::of(&traced.results(), fingerprint, pixels);
                    check::check_peer(
                        &format!("{} {w}", scene.name),
                        &format!("{}/{}", accel.name(), mode.name()),
                        &reference,
                        &got,
                    )?;
                }
                if cfg.check_only || !cfg.modes.contains(&mode) {
                    continue;
                }
                let secs = time_runs(traced.as_mut(), pool, cfg.reps);
                let results = traced.results();
                drop(traced);
                let seconds = trace::median(&secs);
                let rays = set.rays.len();
                let mrays = rays as f64 / seconds / 1e6;
                let hits = results.hits();
                let line = json_line(&JsonFields {
                    cfg,
                    scene: scene.name,
                    triangles: scene.mesh.triangle_count(),
                    workload: w,
                    mode,
                    accel,
                    rays,
                    hits,
                    sum_t: results.sum_t(),
                    build_seconds: peer.build_seconds(),
                    build_peak_bytes: None,
                    build_peak_rss_bytes: None,
                    seconds,
                    mrays,
                    tree: None,
                    bytes: peer.bytes(),
                    bvh: None,
                    grid: None,
                    counts: None,
                    instances: None,
                    engine: peer.version(),
                    fingerprint,
                });
                sink.line(&line)?;
                eprintln!("{}", progress(w, mode, accel, rays, hits, (mrays, seconds)));
                if let Some(row) = rows
                    .iter_mut()
                    .find(|r| r.scene == scene.name && r.workload == w)
                {
                    row.rates
                        .push((format!("{}/{}", mode.name(), accel.name()), mrays));
                }
            }
        }
    }
    Ok(())
}

/// `f(chunk)` over `items` in chunks of [`CHUNK`]: on this thread, or
/// across `pool`. For engines that trace their ray records in place.
#[cfg(any(feature = "embree", feature = "tinybvh"))]
pub fn for_chunks<T: Send>(
    pool: Option<&ThreadPool>,
    items: &mut [T],
    f: impl Fn(&mut [T]) + Sync,
) {
    match pool {
        None => f(items),
        Some(pool) => pool.install(|| items.par_chunks_mut(CHUNK).for_each(&f)),
    }
}

//! `--tlas-update`: what moving instances costs (issue 16's second target,
//! "updating the transforms of 1,000 instances and rebuilding the top
//! level takes under 1 ms per 100 instances on one thread"), and what each
//! top level costs to trace.
//!
//! For each instance count N and each top level (`TopLevel::Sah`,
//! `TopLevel::Median`), N instances of one mesh (built once, shared) are
//! placed on a jittered grid with random rotations and uniform scales.
//! Then every instance is moved (`SceneEdit::set_transform` to a new
//! jittered placement) and the edit committed, which rebuilds the top
//! level; the time of that, on this thread (the scene's edits use no
//! thread pool), is taken over [`update_reps`] updates after one untimed
//! warm-up, and its median reported. The new transforms are made before
//! the clock starts, so only the scene's work is timed. Both top levels
//! see the same placements, update after update, and end in the same
//! place; the protocol's primary rays (auto camera of the scene's world
//! box unless `--camera`) and random rays are then traced through each in
//! the chosen modes, as the main run traces them.

use crate::Failure;
use crate::check;
use crate::cli::Config;
use crate::report::{JsonLine, RUSTFLAGS, Sink, target_features};
use crate::scene;
use crate::trace::{self, Accel, Engine, Input, Mode};
use crate::{packets_of, packets8_of};
use packtrace::glam::{Affine3A, Quat, Vec3};
use packtrace::protocol::SceneFrame;
use packtrace::protocol::sampling::{hash, unit};
use packtrace::protocol::workload::{self, Workload};
use packtrace::scene::{GeometryId, InstanceId, Scene, TopLevel};
use packtrace::{KdTree, Mesh};
use rayon::ThreadPool;
use std::f32::consts::PI;
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

/// Fewest timed updates (they are short: a median of few is noisy).
pub const MIN_UPDATE_REPS: u32 = 11;

/// The top levels compared, with their JSON names.
pub const TOP_LEVELS: [(TopLevel, &str); 2] =
    [(TopLevel::Sah, "sah"), (TopLevel::Median, "median")];

/// Timed updates for `--reps reps`: at least [`MIN_UPDATE_REPS`].
pub fn update_reps(reps: u32) -> u32 {
    reps.max(MIN_UPDATE_REPS)
}

/// One row of the table: one instance count, top level and mode.
pub struct Row {
    /// Instances.
    pub instances: usize,
    /// The top level's name.
    pub top: &'static str,
    /// The trace mode.
    pub mode: Mode,
    /// Median milliseconds of one update (move all, commit).
    pub update_ms: f64,
    /// Mrays/s of each workload traced, in `--workloads` order.
    pub rates: Vec<(Workload, f64)>,
}

/// A uniform hash in `[0, 1)` of (update `rep`, instance `i`, draw `j`).
fn draw(rep: u32, i: u32, j: u32) -> f32 {
    unit(hash(
        hash(rep.wrapping_add(0x9e37_79b9)) ^ i.wrapping_mul(16).wrapping_add(j),
    ))
}

/// Instance `i`'s placement in update `rep` (rep 0: the first placement):
/// the mesh centred on the origin, scaled by 0.5..1, rotated about a
/// random axis by a random angle, and moved to its cell of a `k x k x k`
/// grid of cells `cell` wide, jittered by up to a quarter cell.
pub fn placement(bounds_center: Vec3, cell: f32, k: u32, i: u32, rep: u32) -> Affine3A {
    let d = |j| draw(rep, i, j);
    let scale = 0.5 + 0.5 * d(0);
    let z = 1.0 - 2.0 * d(1);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * d(2);
    let axis = Vec3::new(r * phi.cos(), r * phi.sin(), z);
    let angle = 2.0 * PI * d(3);
    let gridpos = Vec3::new((i % k) as f32, (i / k % k) as f32, (i / (k * k)) as f32);
    let jitter = Vec3::new(d(4), d(5), d(6)) - 0.5;
    let at = (gridpos + 0.5 + 0.5 * jitter) * cell;
    Affine3A::from_scale_rotation_translation(
        Vec3::splat(scale),
        Quat::from_axis_angle(axis.normalize_or(Vec3::Z), angle),
        at,
    ) * Affine3A::from_translation(-bounds_center)
}

/// Every instance's placement in update `rep`, for `n` instances of a mesh
/// with `frame` (grid cells 1.5 mesh diagonals wide).
pub fn placements(frame: &SceneFrame, n: usize, rep: u32) -> Vec<Affine3A> {
    let k = (n as f64).cbrt().ceil().max(1.0) as u32;
    let cell = 1.5 * frame.diagonal.max(f32::MIN_POSITIVE);
    (0..n as u32)
        .map(|i| placement(frame.center, cell, k, i, rep))
        .collect()
}

/// A scene of `tree` placed at `at`, with top level `top`, and its ids.
///
/// # Errors
/// [`Failure::Input`] if the scene refuses a placement.
pub fn instanced(
    tree: &Arc<KdTree>,
    top: TopLevel,
    at: &[Affine3A],
) -> Result<(Scene, Vec<InstanceId>), Failure> {
    let mut scene = Scene::with_top_level(top);
    let g: GeometryId = scene.add_shared_geometry("mesh", Arc::clone(tree));
    let mut edit = scene.edit();
    let ids = at
        .iter()
        .map(|&m| edit.add_instance(g, m))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| Failure::Input(format!("--tlas-update: {e}")))?;
    edit.commit();
    Ok((scene, ids))
}

/// Move every instance to `to` and commit (the top level is rebuilt).
///
/// # Errors
/// [`Failure::Input`] if the scene refuses a placement.
pub fn update(scene: &mut Scene, ids: &[InstanceId], to: &[Affine3A]) -> Result<(), Failure> {
    let mut edit = scene.edit();
    for (&id, &m) in ids.iter().zip(to) {
        edit.set_transform(id, m)
            .map_err(|e| Failure::Input(format!("--tlas-update: {e}")))?;
    }
    edit.commit();
    Ok(())
}

/// The whole `--tlas-update` run of `cfg` (its mesh is `cfg.scenes[0]`):
/// JSON lines to `sink`, table rows into `rows`.
///
/// # Errors
/// [`Failure::Input`] for a bad mesh or camera, [`Failure::Io`] when the
/// JSON cannot be written, [`Failure::Mismatch`] when `--check` fails.
pub fn run(
    cfg: &Config,
    pool: &ThreadPool,
    sink: &mut Sink,
    sizes: &[usize],
    rows: &mut Vec<Row>,
) -> Result<(), Failure> {
    let spec = cfg
        .scenes
        .first()
        .map_or(crate::cli::DEFAULT_TLAS_MESH, |s| s);
    let mesh: Mesh = scene::load(spec)?.mesh;
    let triangles = mesh.triangle_count();
    let mesh_frame = SceneFrame::of(&mesh);
    let tree = pool
        .install(|| KdTree::build(mesh, &cfg.preset.params))
        .map_err(|e| Failure::Input(format!("{spec}: {e}")))?;
    let tree = Arc::new(tree);
    let reps = update_reps(cfg.reps);
    let trace_pool = (cfg.threads > 1).then_some(pool);
    eprintln!(
        "tlas-update: {spec} ({triangles} triangles) instanced {sizes:?} times; {reps} timed \
         updates (median) on one thread; tracing {}x{} on {} thread(s)",
        cfg.width, cfg.height, cfg.threads
    );
    if cfg.modes.iter().any(|m| m.tile().is_some()) {
        eprintln!("bench: note: scenes of instances have no group mode; group modes are skipped");
    }
    for &n in sizes {
        // Placements of the first build, the warm-up and the timed updates.
        let at: Vec<Vec<Affine3A>> = (0..=reps + 1)
            .map(|rep| placements(&mesh_frame, n, rep))
            .collect();
        for (top, top_name) in TOP_LEVELS {
            let start = Instant::now();
            let (mut world, ids) = instanced(&tree, top, &at[0])?;
            let build_ms = start.elapsed().as_secs_f64() * 1e3;
            update(&mut world, &ids, &at[1])?; // warm-up
            let mut ms = Vec::with_capacity(reps as usize);
            for to in &at[2..] {
                let start = Instant::now();
                update(&mut world, &ids, to)?;
                ms.push(start.elapsed().as_secs_f64() * 1e3);
            }
            let update_ms = trace::median(&ms);
            eprintln!(
                "  {n:>8} instances {top_name:<6}: build {build_ms:.3} ms, update {update_ms:.3} \
                 ms median ({:.3} ms per 100 instances)",
                update_ms * 100.0 / n as f64
            );
            let frame = SceneFrame::of_scene(&world);
            let camera = cfg
                .camera
                .unwrap_or_else(|| packtrace::protocol::camera::Camera::auto(&frame.bounds));
            let primary = workload::primary(&camera, cfg.width, cfg.height)
                .map_err(|e| Failure::Input(format!("--tlas-update: {e}")))?;
            // Per mode: (workload, hits, median seconds, Mrays/s).
            let mut traced: Vec<(Mode, Vec<Traced>)> = cfg
                .modes
                .iter()
                .filter(|m| Accel::Scene.runs(**m))
                .map(|&m| (m, Vec::new()))
                .collect();
            for &w in &cfg.workloads {
                let owned;
                let set = match w {
                    Workload::Random => {
                        owned = workload::random(&frame, primary.len());
                        &owned
                    }
                    _ => &primary,
                };
                let needs = |m: Mode| cfg.check || cfg.modes.contains(&m);
                let packets = if needs(Mode::Packet4) {
                    packets_of(set)
                } else {
                    Vec::new()
                };
                let packets8 = if needs(Mode::Packet8) {
                    packets8_of(set)
                } else {
                    Vec::new()
                };
                let input = Input {
                    rays: &set.rays,
                    lanes: &set.packets,
                    packets: &packets,
                    lanes8: &set.packets8,
                    packets8: &packets8,
                    groups: &[],
                    occlusion: false,
                };
                let engine = Engine::Scene(&world);
                if cfg.check {
                    let label = format!("{n} instances {top_name} {w}");
                    let world_tris = triangles * n;
                    let reference = check::scene_reference(&world, &input);
                    let sampled =
                        check::check_scene_oracle(&label, &world, &reference, &input, world_tris)?;
                    check::check_workload(
                        &label,
                        &format!("scene/scalar (itself = brute scene on {sampled} sampled rays)"),
                        &reference,
                        &[(Accel::Scene, engine)],
                        &input,
                        world_tris,
                        trace_pool,
                    )?;
                }
                if cfg.check_only {
                    continue;
                }
                for (mode, t) in &mut traced {
                    let (secs, out) = trace::time_runs(engine, *mode, &input, trace_pool, cfg.reps);
                    let seconds = trace::median(&secs);
                    t.push(Traced {
                        workload: w,
                        hits: out.per_ray(&input).hits(),
                        seconds,
                        mrays: input.rays.len() as f64 / seconds / 1e6,
                    });
                }
            }
            if cfg.check_only {
                continue;
            }
            for (mode, t) in traced {
                let line = json_line(&TlasLine {
                    cfg,
                    spec,
                    triangles,
                    instances: n,
                    top: top_name,
                    mode,
                    build_ms,
                    update_ms,
                    update_reps: reps,
                    traced: &t,
                });
                sink.line(&line)?;
                rows.push(Row {
                    instances: n,
                    top: top_name,
                    mode,
                    update_ms,
                    rates: t.iter().map(|t| (t.workload, t.mrays)).collect(),
                });
            }
        }
    }
    Ok(())
}

/// One workload traced through one scene in one mode.
struct Traced {
    workload: Workload,
    hits: u64,
    /// Median seconds of the timed runs.
    seconds: f64,
    mrays: f64,
}

/// What one `--tlas-update` JSON line reports.
struct TlasLine<'a> {
    cfg: &'a Config,
    spec: &'a str,
    triangles: usize,
    instances: usize,
    top: &'static str,
    mode: Mode,
    build_ms: f64,
    update_ms: f64,
    update_reps: u32,
    traced: &'a [Traced],
}

/// One JSON line: `"bench":"tlas_update"`, the mesh, the instances and
/// top level, the update's median and per-100 milliseconds, then per
/// workload traced its rays' hits, seconds and Mrays/s.
fn json_line(f: &TlasLine) -> String {
    let mut j = JsonLine::default();
    j.push("bench", "tlas_update");
    j.push("scene", f.spec);
    j.push("triangles", f.triangles);
    j.push("instances", f.instances);
    j.push("top_level", f.top);
    j.push("build_ms", f.build_ms);
    j.push("update_ms", f.update_ms);
    j.push(
        "update_ms_per_100",
        f.update_ms * 100.0 / f.instances as f64,
    );
    j.push("update_reps", f.update_reps);
    j.push("update_threads", 1);
    j.push("mode", f.mode.name());
    j.push("threads", f.cfg.threads);
    j.push("width", f.cfg.width);
    j.push("height", f.cfg.height);
    j.push("reps", f.cfg.reps);
    j.push("preset", f.cfg.preset.name);
    for t in f.traced {
        let (hits, seconds, mrays) = match t.workload {
            Workload::Primary => ("primary_hits", "primary_seconds", "primary_mrays_per_s"),
            _ => ("random_hits", "random_seconds", "random_mrays_per_s"),
        };
        j.push(hits, t.hits);
        j.push(seconds, t.seconds);
        j.push(mrays, t.mrays);
    }
    j.push("rustflags", RUSTFLAGS);
    j.push("target_features", target_features());
    j.render()
}

/// The table: instances, top level, mode, update ms (median), ms per 100
/// instances, then Mrays/s of each workload traced.
///
/// # Errors
/// When `out` cannot be written.
pub fn print_table(rows: &[Row], out: &mut dyn Write) -> std::io::Result<()> {
    let Some(first) = rows.first() else {
        return Ok(());
    };
    let mut head = format!(
        "{:>9} {:<6} {:<7} {:>10} {:>10}",
        "instances", "top", "mode", "update ms", "ms/100"
    );
    for (w, _) in &first.rates {
        head.push_str(&format!(" {:>15}", format!("{w} Mrays/s")));
    }
    writeln!(out, "\nTop-level update (one thread) and trace\n{head}")?;
    for r in rows {
        let mut line = format!(
            "{:>9} {:<6} {:<7} {:>10.3} {:>10.4}",
            r.instances,
            r.top,
            r.mode.name(),
            r.update_ms,
            r.update_ms * 100.0 / r.instances as f64
        );
        for (_, rate) in &r.rates {
            line.push_str(&format!(" {rate:>15.3}"));
        }
        writeln!(out, "{line}")?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use packtrace::Ray;
    use packtrace::protocol::generate;
    use packtrace::scene::{BruteScene, Query, SceneQuery};

    fn sphere_tree() -> Arc<KdTree> {
        Arc::new(KdTree::build(generate::sphere(200), &Default::default()).unwrap())
    }

    #[test]
    fn placements_are_deterministic_and_differ_per_update() {
        let frame = SceneFrame::of(&generate::sphere(200));
        let a = placements(&frame, 30, 0);
        assert_eq!(a, placements(&frame, 30, 0));
        let b = placements(&frame, 30, 1);
        assert!(
            a.iter().zip(&b).all(|(x, y)| x != y),
            "every instance moves"
        );
        // Scales in 0.5..1, each instance in its own cell.
        for m in &a {
            let s = m.matrix3.x_axis.length();
            assert!((0.499..=1.001).contains(&s), "{s}");
        }
    }

    #[test]
    fn updates_move_every_instance_and_both_top_levels_agree() {
        let tree = sphere_tree();
        let frame = SceneFrame::of(tree.mesh());
        let n = 27;
        let (a0, a1) = (placements(&frame, n, 0), placements(&frame, n, 1));
        let (mut sah, ids) = instanced(&tree, TopLevel::Sah, &a0).unwrap();
        let (mut median, ids2) = instanced(&tree, TopLevel::Median, &a0).unwrap();
        update(&mut sah, &ids, &a1).unwrap();
        update(&mut median, &ids2, &a1).unwrap();
        assert_eq!(sah.instance_count(), n);
        assert_eq!(sah.bounds(), median.bounds());
        for (id, m) in ids.iter().zip(&a1) {
            assert_eq!(sah.instance(*id).unwrap().transform().to_world(), *m);
        }
        // Random rays: both top levels and the oracle give the same hits.
        let f = SceneFrame::of_scene(&sah);
        let rays: Vec<Ray> = workload::random(&f, 256).rays;
        let brute = BruteScene::new(&sah);
        let q = Query::new();
        let mut hits = 0;
        for r in &rays {
            let h = sah.intersect(r);
            assert_eq!(h, median.intersect(r));
            assert_eq!(h, brute.intersect_with(r, &q));
            hits += h.is_some() as u32;
        }
        assert!(hits > 0);
    }

    #[test]
    fn update_reps_have_a_floor() {
        assert_eq!(update_reps(1), MIN_UPDATE_REPS);
        assert_eq!(update_reps(50), 50);
    }

    #[test]
    fn the_table_lists_every_row() {
        let rows = [Row {
            instances: 100,
            top: "sah",
            mode: Mode::Scalar,
            update_ms: 0.05,
            rates: vec![(Workload::Primary, 3.0), (Workload::Random, 1.5)],
        }];
        let mut out = Vec::new();
        print_table(&rows, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.contains("primary Mrays/s") && text.contains("random Mrays/s"),
            "{text}"
        );
        let last = text.lines().last().unwrap();
        assert!(
            last.contains("100") && last.contains("sah") && last.contains("0.0500"),
            "{last}"
        );
    }
}

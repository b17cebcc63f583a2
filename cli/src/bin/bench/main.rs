//! `bench`: packtrace on the benchmark protocol (`docs/PROTOCOL.md`, v1).
//!
//! For each scene it builds the kd-tree once, makes the protocol's rays
//! (`primary`, `shadow`, `ao`, `random`; shadow and ao rays derived from the
//! scalar kd8 primary hits), and for each (workload, mode, accelerator)
//! traces them once untimed and `--reps` times timed. Each result is one
//! JSON object with the protocol's fields plus tree statistics and per-ray
//! traversal counters (from a separate untimed counted pass), and a closing
//! table sums them up. Where they go ([`report::output_plan`]): piped or
//! redirected, or with `--json`/`--json -`, the JSON lines on stdout and
//! the table on stderr; on a terminal, the table alone on stdout.
//! `--json PATH` also writes the JSON lines to PATH. Progress and warnings
//! always go to stderr.
//!
//! Every run is 1024x1024 (the protocol's size) unless `--size` says
//! otherwise, on one thread unless `--threads` says otherwise.
//!
//! Scenes of instances (issue 16): `--accel instance` traces the kd8 tree
//! (shared, not rebuilt) as one instance with the identity transform in a
//! `packtrace::scene::Scene`, through the scene's API, beside the bare
//! tree; `--scene PATH.scene` loads a scene file and traces the whole scene
//! (accel `scene`; camera and light from `NAME.view` beside it, else from
//! the scene's world box; shadow and ao rays start from the primary hits'
//! world triangles); `--tlas-update` times moving every instance of N
//! instances and rebuilding the top level, for both top levels
//! (`tlas.rs`). Scenes have no group modes.
//!
//! ```text
//! cargo run --release --bin bench                         # data/*.obj, kd8: a table
//! cargo run --release --bin bench -- --scene bunny.obj --check --json bunny.jsonl
//! cargo run --release --bin bench -- --scaling --scaling-sizes 1e3,1e4,1e5
//! cargo run --release --bin bench -- --scene bunny.obj --accel kd8,instance
//! cargo run --release --bin bench -- --scene data/cornell_spheres.scene --check
//! cargo run --release --bin bench -- --tlas-update --size 256x256
//! ```
//!
//! `--check` compares every ray of every mode and accelerator with scalar
//! kd8 before timing (a scene file: every mode with the scene's scalar
//! query, and that with the brute-force scene oracle on a sample of rays).
//! Exit status: 0 success, 1 check mismatch, 2 bad input. See
//! `docs/measurements.md` for every option and field, and
//! `docs/benchmarking.md` for the peer engines (`peers`: Embree, obvhs,
//! tinybvh on the same rays, `--check` within the protocol's tolerance)
//! and `bench report` (`results`).

#![deny(unsafe_code)]

mod check;
mod cli;
mod fingerprint;
mod memory;
mod peers;
mod report;
mod results;
mod scene;
mod stamp;
mod tlas;
mod trace;

use clap::Parser;
use clap::error::ErrorKind;
use cli::{Cli, Config, PROTOCOL_MIN_REPS};
use fingerprint::Fingerprint;
use packtrace::bvh::{Bvh2, Bvh8, BvhStats};
use packtrace::glam::Vec3;
use packtrace::grid::{Grid, GridStats, HGrid};
use packtrace::protocol::workload::{self, RaySet, Workload};
use packtrace::protocol::{SceneFrame, load_scene, load_view};
use packtrace::scene::Scene as InstScene;
use packtrace::{
    BlockedKdTree, BruteForce, Hit, InlineKdTree, KdTree, Kernel, Mesh, NaiveKdTree, RayPacket4,
    RayPacket8, TraversalStats, TreeStats,
};
use packtrace_cli::chain;
use rayon::{ThreadPool, ThreadPoolBuilder};
use report::{JsonLine, RUSTFLAGS, Sink, output_plan, target_features};
use std::io::{IsTerminal, Write};
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;
use trace::{Accel, Engine, Input, Mode};

/// Largest triangles x rays per pass for `--accel brute` without `--force`
/// (the timed brute run makes `reps + 1` such passes).
const BRUTE_TIME_LIMIT: f64 = 5e8;

/// Why a run stopped.
#[derive(Debug)]
pub enum Failure {
    /// Bad input: option value, scene file, view file, build parameters.
    /// Exit status 2.
    Input(String),
    /// Output could not be written. Exit status 2.
    Io(String),
    /// `--check` found a mismatch (already printed). Exit status 1.
    Mismatch,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            // clap's message: "error: ..." and maybe "[possible values: ...]",
            // then a blank line and usage hints. Keep the message, one line.
            let text = e.to_string();
            let message: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|l| !l.is_empty())
                .collect();
            let message = message.join(" ");
            let message = message.strip_prefix("error: ").unwrap_or(&message);
            eprintln!("bench: error: {message} (see bench --help)");
            return ExitCode::from(2);
        }
    };
    let outcome = match &cli.command {
        Some(cli::Command::Report(args)) => results::run(args),
        None => Config::from_cli(cli).and_then(|cfg| run(&cfg)),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(m) | Failure::Io(m)) => {
            eprintln!("bench: error: {m}");
            ExitCode::from(2)
        }
        Err(Failure::Mismatch) => ExitCode::from(1),
    }
}

/// One row of the closing summary table.
struct Row {
    scene: String,
    workload: Workload,
    triangles: usize,
    build_seconds: f64,
    /// Tree facts (none for a scene file).
    bytes_per_triangle: Option<f64>,
    /// The build's counted peak bytes per triangle (none for a scene file).
    peak_per_triangle: Option<f64>,
    nodes: Option<usize>,
    max_depth: Option<u32>,
    /// (mode/accel, Mrays/s)
    rates: Vec<(String, f64)>,
}

/// The whole run.
fn run(cfg: &Config) -> Result<(), Failure> {
    if cfg.reps < PROTOCOL_MIN_REPS && !cfg.check_only {
        eprintln!(
            "bench: warning: --reps {} is below the protocol's minimum of {PROTOCOL_MIN_REPS}; \
             the timings are not protocol figures",
            cfg.reps
        );
    }
    for spec in &cfg.scenes {
        scene::precheck(spec)?;
    }
    trace::set_stream_options(cfg.stream);
    if cfg.modes.iter().any(|&m| m != Mode::Scalar) && cfg.accels.contains(&Accel::Brute) {
        eprintln!(
            "bench: note: brute force has no packet or stream mode; those runs of brute are skipped"
        );
    }
    if cfg.tlas_update.is_none() {
        if cfg.modes.iter().any(|m| m.tile().is_some()) && cfg.accels.iter().any(|a| a.is_scene()) {
            eprintln!(
                "bench: note: scenes of instances have no group mode; the group runs of instance \
                 and scene are skipped"
            );
        }
        for a in &cfg.accels {
            if !cfg.scenes.iter().any(|s| a.traces(scene::is_scene_file(s))) {
                eprintln!(
                    "bench: note: accel {} traces none of the scenes (a scene file is traced by \
                     accel scene alone, a mesh by the others)",
                    a.name()
                );
            }
        }
    }
    let plan = output_plan(std::io::stdout().is_terminal(), cfg.json.as_ref());
    let mut sink = Sink::open(plan, cfg.json.as_ref().and_then(|j| j.file()))?;
    if !plan.json_stdout && !cfg.check_only {
        eprintln!(
            "bench: stdout is a terminal: summary table only; JSON lines with --json [PATH] \
             or when piped"
        );
    }
    let mut rows = Vec::new();
    let mut tlas_rows = Vec::new();
    let combos = cfg.presets.len() * cfg.thread_counts.len();
    // Every scene once per (preset, thread count): a build scaling run.
    for &preset in &cfg.presets {
        for &threads in &cfg.thread_counts {
            let run = Config {
                preset,
                threads,
                ..cfg.clone()
            };
            let pool = ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| Failure::Input(format!("--threads {threads}: {e}")))?;
            eprintln!(
                "bench: {} scene(s), {}x{}, threads {}, reps {}, preset {}, rustflags \"{RUSTFLAGS}\", \
                 target features {}, packet kernel {}",
                run.scenes.len(),
                run.width,
                run.height,
                run.threads,
                run.reps,
                run.preset.name,
                target_features(),
                Kernel::active().name()
            );
            let first = rows.len();
            if let Some(sizes) = &run.tlas_update {
                tlas::run(&run, &pool, &mut sink, sizes, &mut tlas_rows)?;
            } else {
                for spec in &run.scenes {
                    run_scene(&run, &pool, &mut sink, spec, &mut rows)?;
                }
            }
            if combos > 1 {
                for row in &mut rows[first..] {
                    row.scene = format!("{} [{}, {threads}t]", row.scene, preset.name);
                }
            }
        }
    }
    sink.finish()?;
    if !cfg.check_only {
        // With peers: every engine beside Embree's best (`results`).
        let comparison = results::comparison(sink.lines());
        let print = |out: &mut dyn Write| {
            print_summary(&rows, out)?;
            if let Some(c) = &comparison {
                write!(out, "{c}")?;
            }
            tlas::print_table(&tlas_rows, out)
        };
        let written = if plan.table_stdout {
            print(&mut std::io::stdout().lock()).map_err(|e| ("stdout", e))
        } else {
            print(&mut std::io::stderr().lock()).map_err(|e| ("stderr", e))
        };
        written.map_err(|(to, e)| Failure::Io(format!("{to}: {e}")))?;
    }
    Ok(())
}

/// Packets of a ray set in SoA form (ray generation, never timed).
fn packets_of(set: &RaySet) -> Vec<RayPacket4> {
    (0..set.packets.len()).map(|i| set.packet(i)).collect()
}

/// 8-wide packets of a ray set in SoA form (never timed).
fn packets8_of(set: &RaySet) -> Vec<RayPacket8> {
    (0..set.packets8.len()).map(|i| set.packet8(i)).collect()
}

/// The rays each workload at most has, for the brute-force limit.
fn max_rays(cfg: &Config) -> u64 {
    let pixels = cfg.width as u64 * cfg.height as u64;
    cfg.workloads
        .iter()
        .map(|w| match w {
            Workload::Ao => workload::AO_SAMPLES as u64 * pixels,
            _ => pixels,
        })
        .max()
        .unwrap_or(0)
}

/// A timed accelerator of one scene: its engine, what its build took and
/// its bytes (tree accels).
struct Timed<'a> {
    accel: Accel,
    engine: Engine<'a>,
    build_seconds: f64,
    bytes: Option<usize>,
    /// A BVH's statistics.
    bvh: Option<BvhStats>,
    /// A grid's statistics.
    grid: Option<GridStats>,
}

/// A built BVH of either width.
enum BvhAny {
    Wide(Bvh8),
    Binary(Bvh2),
}

/// What `--check` compares the engines with.
#[derive(Clone, Copy)]
enum Reference<'a> {
    /// Scalar kd8 (a mesh scene).
    Kd8(&'a KdTree),
    /// The scene's scalar query, itself checked on a sample of rays
    /// against the brute-force scene oracle (a scene file).
    Scene(&'a InstScene),
}

/// One loaded and built scene, ready for its workloads.
struct Subject<'a> {
    /// The JSON `scene`.
    name: String,
    /// Triangles (a scene file's: world triangles, over every instance).
    triangles: usize,
    /// The triangles the primary hits of `trace_workloads` are in; shadow
    /// and ao rays start from their normals (a scene file's: flattened).
    mesh: &'a Mesh,
    frame: SceneFrame,
    light: Vec3,
    build_seconds: f64,
    /// The build's peak bytes by its own ledger
    /// (`KdTree::build_peak_bytes`; none for a scene file).
    build_peak_bytes: Option<usize>,
    /// Peak resident memory the build added (Linux).
    build_peak_rss_bytes: Option<usize>,
    /// The kd8 tree's statistics (none for a scene file).
    stats: Option<TreeStats>,
    /// The tree of the counted pass (none for a scene file).
    counted: Option<&'a KdTree>,
    /// Live instances of a scene file (none for a mesh).
    instances: Option<usize>,
    reference: Reference<'a>,
    /// Engines `--check` compares with the reference.
    checked: Vec<(Accel, Engine<'a>)>,
    /// Accelerators timed, in `--accel` order.
    timed: Vec<Timed<'a>>,
    /// The rays' fingerprint before the workload.
    fingerprint: Fingerprint,
}

/// Build, trace and report one scene: a mesh (OBJ file or `gen:` spec)
/// or a scene file.
fn run_scene(
    cfg: &Config,
    pool: &ThreadPool,
    sink: &mut Sink,
    spec: &str,
    rows: &mut Vec<Row>,
) -> Result<(), Failure> {
    if scene::is_scene_file(spec) {
        return run_scene_file(cfg, pool, sink, spec, rows);
    }
    let scene = scene::load(spec)?;
    let name = scene.name.clone();
    let triangles = scene.mesh.triangle_count();
    let frame = SceneFrame::of(&scene.mesh);
    let camera = cfg
        .camera
        .unwrap_or_else(|| scene.view.camera_or_auto(&frame.bounds));
    let light = cfg
        .light
        .unwrap_or_else(|| scene.view.light_or_default(&frame));

    // Brute-force size limit, before any long work
    let brute_tests = triangles as f64 * max_rays(cfg) as f64;
    if cfg.accels.contains(&Accel::Brute)
        && !cfg.check_only
        && !cfg.force
        && brute_tests > BRUTE_TIME_LIMIT
    {
        return Err(Failure::Input(format!(
            "--accel brute on {name}: {triangles} triangles x up to {} rays = {brute_tests:.2e} \
             triangle tests per pass, over the limit of {BRUTE_TIME_LIMIT:e}; use a smaller \
             --size or scene, drop brute, or pass --force",
            max_rays(cfg)
        )));
    }

    // Build
    eprintln!(
        "{name}: {triangles} triangles; building kd8 (preset {})",
        cfg.preset.name
    );
    let rss_before = memory::reset_peak();
    let start = Instant::now();
    let tree = pool
        .install(|| KdTree::build(scene.mesh, &cfg.preset.params))
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    let build_seconds = start.elapsed().as_secs_f64();
    let build_peak_rss_bytes =
        rss_before.and_then(|before| Some(memory::peak()?.saturating_sub(before)));
    let build_peak_bytes = Some(tree.build_peak_bytes());
    // Shared with the one-instance scene: one build for both.
    let tree = Arc::new(if cfg.copy_tree { tree.clone() } else { tree });
    let stats = tree.stats();
    eprintln!(
        "{name}: built in {build_seconds:.3} s ({:.2} Mtris/s, peak {:.1} MB counted, {} MB \
         resident added): {} nodes, {} leaves, depth {}, {:.2} refs/tri, {} bytes ({:.1} B/tri), \
         SAH cost {:.2}",
        triangles as f64 / build_seconds.max(1e-9) / 1e6,
        tree.build_peak_bytes() as f64 / 1e6,
        build_peak_rss_bytes.map_or("?".to_string(), |b| format!("{:.1}", b as f64 / 1e6)),
        stats.nodes,
        stats.leaves,
        stats.max_depth,
        stats.refs_per_triangle,
        stats.bytes,
        stats.bytes as f64 / triangles.max(1) as f64,
        stats.sah_cost
    );
    let blocked = if cfg.accels.contains(&Accel::Kd8Blocked) || cfg.check {
        let start = Instant::now();
        let blocked =
            BlockedKdTree::from_kd(&tree).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
        Some((blocked, start.elapsed().as_secs_f64()))
    } else {
        None
    };
    let inline = if cfg.accels.contains(&Accel::Kd8Inline) || cfg.check {
        let start = Instant::now();
        let inline =
            InlineKdTree::from_kd(&tree).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
        Some((inline, start.elapsed().as_secs_f64()))
    } else {
        None
    };
    let naive = if cfg.accels.contains(&Accel::Naive) || cfg.check {
        let start = Instant::now();
        let naive = NaiveKdTree::from_kd(&tree);
        Some((naive, start.elapsed().as_secs_f64()))
    } else {
        None
    };
    // The instance accel: the same tree as one instance, identity transform.
    let instance = if cfg.accels.contains(&Accel::Instance) || cfg.check {
        let start = Instant::now();
        let one = scene::one_instance(&name, Arc::clone(&tree))?;
        Some((one, start.elapsed().as_secs_f64()))
    } else {
        None
    };
    // The BVHs: each built from the mesh (not from the kd-tree), timed.
    let bvh = |accel: Accel| -> Result<Option<(BvhAny, f64, BvhStats)>, Failure> {
        if !(cfg.accels.contains(&accel) || cfg.check) {
            return Ok(None);
        }
        let mesh = tree.mesh().clone();
        let err = |e: packtrace::bvh::BvhBuildError| Failure::Input(format!("{name}: {e}"));
        let start = Instant::now();
        let params = cfg.bvh_params_of(accel).expect("a BVH accel");
        let built = if accel == Accel::Bvh8 {
            BvhAny::Wide(pool.install(|| Bvh8::build(mesh, &params)).map_err(err)?)
        } else {
            BvhAny::Binary(pool.install(|| Bvh2::build(mesh, &params)).map_err(err)?)
        };
        let secs = start.elapsed().as_secs_f64();
        let st = match &built {
            BvhAny::Wide(b) => b.stats(),
            BvhAny::Binary(b) => b.stats(),
        };
        eprintln!(
            "{name}: {} built in {secs:.3} s ({:.2} Mtris/s): {} nodes ({:.2} children), {} leaves \
             ({:.2} tris, sizes {:?}), {} blocks, depth {}, {} bytes ({:.1} B/tri), SAH cost {:.2}",
            accel.name(),
            triangles as f64 / secs.max(1e-9) / 1e6,
            st.nodes,
            st.mean_children,
            st.leaves,
            st.mean_leaf_triangles,
            st.leaf_sizes,
            st.blocks,
            st.max_depth,
            st.bytes,
            st.bytes_per_triangle(),
            st.sah_cost
        );
        Ok(Some((built, secs, st)))
    };
    let bvh8 = bvh(Accel::Bvh8)?;
    let bvh2 = bvh(Accel::Bvh2)?;
    let bvh2_median = bvh(Accel::Bvh2Median)?;
    fn bvh_engine(b: &Option<(BvhAny, f64, BvhStats)>) -> Option<Engine<'_>> {
        b.as_ref().map(|(x, _, _)| match x {
            BvhAny::Wide(b) => Engine::Bvh8(b),
            BvhAny::Binary(b) => Engine::Bvh2(b),
        })
    }
    // The grids: each built from the mesh (not from the kd-tree), timed,
    // like the BVHs.
    let grid_err = |e: packtrace::grid::GridBuildError| Failure::Input(format!("{name}: {e}"));
    let grid = if cfg.accels.contains(&Accel::Grid) || cfg.check {
        let mesh = tree.mesh().clone();
        let start = Instant::now();
        let params = cfg.grid_params();
        let g = pool
            .install(|| Grid::build(mesh, &params))
            .map_err(grid_err)?;
        let secs = start.elapsed().as_secs_f64();
        let st = g.stats();
        eprintln!("{}", grid_built(&name, Accel::Grid, secs, &st));
        Some((g, secs, st))
    } else {
        None
    };
    let hgrid = if cfg.accels.contains(&Accel::HGrid) || cfg.check {
        let mesh = tree.mesh().clone();
        let start = Instant::now();
        let params = cfg.hgrid_params();
        let g = pool
            .install(|| HGrid::build(mesh, &params))
            .map_err(grid_err)?;
        let secs = start.elapsed().as_secs_f64();
        let st = g.stats();
        eprintln!("{}", grid_built(&name, Accel::HGrid, secs, &st));
        Some((g, secs, st))
    } else {
        None
    };
    let mut checked: Vec<(Accel, Engine)> = vec![(Accel::Kd8, Engine::Kd8(&tree))];
    for (accel, b) in [
        (Accel::Bvh8, &bvh8),
        (Accel::Bvh2, &bvh2),
        (Accel::Bvh2Median, &bvh2_median),
    ] {
        if let Some(e) = bvh_engine(b) {
            checked.push((accel, e));
        }
    }
    if let Some((b, _)) = &blocked {
        checked.push((Accel::Kd8Blocked, Engine::Blocked(b)));
    }
    if let Some((t, _)) = &inline {
        checked.push((Accel::Kd8Inline, Engine::Inline(t)));
    }
    if let Some((n, _)) = &naive {
        checked.push((Accel::Naive, Engine::Naive(n)));
    }
    checked.push((Accel::Brute, Engine::Brute(BruteForce::new(tree.mesh()))));
    if let Some((g, _, _)) = &grid {
        checked.push((Accel::Grid, Engine::Grid(g)));
    }
    if let Some((g, _, _)) = &hgrid {
        checked.push((Accel::HGrid, Engine::HGrid(g)));
    }
    if let Some((one, _)) = &instance {
        checked.push((Accel::Instance, Engine::Scene(one)));
    }
    // Peers: other engines over the same triangles (`peers`).
    let peers = peers::build(&cfg.accels, tree.mesh(), cfg.threads)?;
    for p in &peers {
        eprintln!(
            "{name}: {} built in {:.3} s: {}",
            p.version(),
            p.build_seconds(),
            p.bytes().map_or("? bytes".into(), |b| format!(
                "{b} bytes ({:.1} B/tri)",
                b as f64 / triangles.max(1) as f64
            ))
        );
    }
    let timed: Vec<Timed> = cfg
        .accels
        .iter()
        .filter(|a| a.traces(false) && !a.is_peer())
        .map(|&accel| match accel {
            Accel::Kd8 => Timed {
                accel,
                engine: Engine::Kd8(&tree),
                build_seconds,
                bytes: Some(stats.bytes),
                bvh: None,
                grid: None,
            },
            Accel::Bvh8 | Accel::Bvh2 | Accel::Bvh2Median => {
                let b = match accel {
                    Accel::Bvh8 => &bvh8,
                    Accel::Bvh2 => &bvh2,
                    _ => &bvh2_median,
                };
                let (_, secs, st) = b.as_ref().expect("built when selected");
                Timed {
                    accel,
                    engine: bvh_engine(b).expect("built when selected"),
                    build_seconds: *secs,
                    bytes: Some(st.bytes),
                    bvh: Some(st.clone()),
                    grid: None,
                }
            }
            Accel::Grid => {
                let (g, secs, st) = grid.as_ref().expect("built when selected");
                Timed {
                    accel,
                    engine: Engine::Grid(g),
                    build_seconds: *secs,
                    bytes: Some(st.bytes),
                    bvh: None,
                    grid: Some(*st),
                }
            }
            Accel::HGrid => {
                let (g, secs, st) = hgrid.as_ref().expect("built when selected");
                Timed {
                    accel,
                    engine: Engine::HGrid(g),
                    build_seconds: *secs,
                    bytes: Some(st.bytes),
                    bvh: None,
                    grid: Some(*st),
                }
            }
            Accel::Kd8Blocked => {
                let (b, conv) = blocked.as_ref().expect("made when kd8-blocked is selected");
                Timed {
                    accel,
                    engine: Engine::Blocked(b),
                    build_seconds: build_seconds + conv,
                    bvh: None,
                    grid: None,
                    bytes: Some(b.bytes()),
                }
            }
            Accel::Kd8Inline => {
                let (t, conv) = inline.as_ref().expect("made when kd8-inline is selected");
                Timed {
                    accel,
                    engine: Engine::Inline(t),
                    build_seconds: build_seconds + conv,
                    bvh: None,
                    grid: None,
                    bytes: Some(t.bytes()),
                }
            }
            Accel::Naive => {
                let (n, conv) = naive.as_ref().expect("built when naive is selected");
                Timed {
                    accel,
                    engine: Engine::Naive(n),
                    build_seconds: build_seconds + conv,
                    bvh: None,
                    grid: None,
                    bytes: Some(n.bytes()),
                }
            }
            Accel::Instance => {
                let (one, secs) = instance.as_ref().expect("made when instance is selected");
                Timed {
                    accel,
                    engine: Engine::Scene(one),
                    build_seconds: build_seconds + secs,
                    bvh: None,
                    grid: None,
                    bytes: Some(stats.bytes),
                }
            }
            Accel::Brute => Timed {
                accel,
                engine: Engine::Brute(BruteForce::new(tree.mesh())),
                build_seconds: 0.0,
                bytes: None,
                bvh: None,
                grid: None,
            },
            Accel::Scene => unreachable!("a scene file's accel"),
            _ => unreachable!("peers are traced by `peers`"),
        })
        .collect();
    let trace_pool = (cfg.threads > 1).then_some(pool);

    // Primary rays, and the scalar kd8 hits that shadow and ao derive from
    let primary = workload::primary(&camera, cfg.width, cfg.height)
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    let oracle = primary_hits(cfg, Engine::Kd8(&tree), &primary, trace_pool)
        .map(|r| r.mesh_hits().expect("closest hits"))
        .unwrap_or_default();
    let fingerprint = Fingerprint::of_scene(tree.mesh(), &primary, light);
    let subject = Subject {
        name,
        triangles,
        mesh: tree.mesh(),
        frame,
        light,
        build_seconds,
        build_peak_bytes,
        build_peak_rss_bytes,
        stats: Some(stats),
        counted: Some(&tree),
        instances: None,
        reference: Reference::Kd8(&tree),
        checked,
        timed,
        fingerprint,
    };
    let first = rows.len();
    trace_workloads(cfg, sink, &subject, &primary, &oracle, trace_pool, rows)?;
    if peers.is_empty() {
        return Ok(());
    }
    // The scalar kd8 primary hits (made above only when a workload derives
    // from them): `--check`'s reference for the peers' shadow and ao rays.
    let kd8_hits = if oracle.is_empty() {
        primary.rays.iter().map(|r| tree.intersect(r)).collect()
    } else {
        oracle
    };
    let scene = peers::Scene {
        name: &subject.name,
        mesh: tree.mesh(),
        frame,
        light,
        primary: &primary,
        kd8_hits: &kd8_hits,
        tree: &tree,
        fingerprint,
    };
    peers::run(cfg, sink, &scene, &peers, trace_pool, &mut rows[first..])
}

/// The stderr line of a built grid: its build time and statistics (as
/// the BVHs' line beside it).
fn grid_built(name: &str, accel: Accel, secs: f64, st: &GridStats) -> String {
    format!(
        "{name}: {} built in {secs:.3} s ({:.2} Mtris/s): dims {:?}, {} cells ({} empty), {} \
         subgrids, {:.2} refs/tri, max {} per cell, {} bytes ({:.1} B/tri)",
        accel.name(),
        st.triangles as f64 / secs.max(1e-9) / 1e6,
        st.dims,
        st.cells,
        st.empty_cells,
        st.subgrids,
        st.references_per_triangle(),
        st.max_per_cell,
        st.bytes,
        st.bytes as f64 / st.triangles.max(1) as f64
    )
}

/// The scalar hits of the primary rays in `engine`, when a workload
/// derives from them (shadow, ao); `None` otherwise.
fn primary_hits(
    cfg: &Config,
    engine: Engine,
    primary: &RaySet,
    pool: Option<&ThreadPool>,
) -> Option<trace::Results> {
    let derived = cfg
        .workloads
        .iter()
        .any(|w| matches!(w, Workload::Shadow | Workload::Ao));
    if !derived {
        return None;
    }
    let input = Input::scalar(primary, false);
    let mut out = trace::Output::new(&engine, Mode::Scalar, &input);
    trace::trace(engine, Mode::Scalar, &input, &mut out, pool);
    Some(out.per_ray(&input))
}

/// Load, trace and report a scene file (accel `scene`): its view file
/// `NAME.view` beside it, else the auto camera and default light of the
/// scene's world box.
fn run_scene_file(
    cfg: &Config,
    pool: &ThreadPool,
    sink: &mut Sink,
    spec: &str,
    rows: &mut Vec<Row>,
) -> Result<(), Failure> {
    let path = Path::new(spec);
    let name = path
        .file_stem()
        .map_or_else(|| spec.to_string(), |s| s.to_string_lossy().into_owned());
    eprintln!(
        "{name}: loading the scene file, building its meshes (preset {})",
        cfg.preset.name
    );
    let rss_before = memory::reset_peak();
    let start = Instant::now();
    let world = pool
        .install(|| load_scene(path, &cfg.preset.params))
        .map_err(|e| Failure::Input(chain(&e)))?;
    let build_seconds = start.elapsed().as_secs_f64();
    let build_peak_rss_bytes =
        rss_before.and_then(|before| Some(memory::peak()?.saturating_sub(before)));
    let view = load_view(path).map_err(|e| Failure::Input(chain(&e)))?;
    let (flat, first) = scene::flatten(&world)?;
    let triangles = flat.triangle_count();
    if world.instance_count() == 0 {
        return Err(Failure::Input(format!("{spec}: the scene has no instance")));
    }
    let frame = SceneFrame::of_scene(&world);
    let camera = cfg
        .camera
        .unwrap_or_else(|| view.camera_or_auto(&frame.bounds));
    let light = cfg.light.unwrap_or_else(|| view.light_or_default(&frame));
    eprintln!(
        "{name}: {} geometries, {} instances, {triangles} world triangles; loaded and built in \
         {build_seconds:.3} s (top level {:?})",
        world.geometry_count(),
        world.instance_count(),
        world.top_level()
    );
    let trace_pool = (cfg.threads > 1).then_some(pool);
    let primary = workload::primary(&camera, cfg.width, cfg.height)
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    // The scene's primary hits as hits in the flattened world mesh.
    let oracle = match primary_hits(cfg, Engine::Scene(&world), &primary, trace_pool) {
        Some(trace::Results::SceneClosest(h)) => h
            .iter()
            .map(|h| h.map(|h| scene::flat_hit(&h, &first)))
            .collect(),
        _ => Vec::new(),
    };
    let engine = Engine::Scene(&world);
    let fingerprint = Fingerprint::of_scene(&flat, &primary, light);
    let subject = Subject {
        name,
        triangles,
        mesh: &flat,
        frame,
        light,
        build_seconds,
        build_peak_bytes: None,
        build_peak_rss_bytes,
        stats: None,
        counted: None,
        instances: Some(world.instance_count()),
        reference: Reference::Scene(&world),
        checked: vec![(Accel::Scene, engine)],
        timed: vec![Timed {
            accel: Accel::Scene,
            engine,
            build_seconds,
            bytes: None,
            bvh: None,
            grid: None,
        }],
        fingerprint,
    };
    trace_workloads(cfg, sink, &subject, &primary, &oracle, trace_pool, rows)
}

/// Make, check and time every workload of a loaded scene; one JSON line
/// per (workload, mode, accel), one row per workload.
fn trace_workloads(
    cfg: &Config,
    sink: &mut Sink,
    subject: &Subject,
    primary: &RaySet,
    oracle: &[Option<Hit>],
    trace_pool: Option<&ThreadPool>,
    rows: &mut Vec<Row>,
) -> Result<(), Failure> {
    let Subject {
        name,
        triangles,
        frame,
        ..
    } = subject;
    let (triangles, frame) = (*triangles, *frame);
    for &w in &cfg.workloads {
        let owned;
        let set: &RaySet = match w {
            Workload::Primary => primary,
            Workload::Shadow => {
                owned = workload::shadow(primary, oracle, subject.mesh, &frame, subject.light);
                &owned
            }
            Workload::Ao => {
                owned = workload::ao(primary, oracle, subject.mesh, &frame);
                &owned
            }
            Workload::Random => {
                owned = workload::random(&frame, primary.len());
                &owned
            }
        };
        let timed = |m: Mode| {
            !cfg.check_only
                && cfg.modes.contains(&m)
                && subject.timed.iter().any(|t| t.accel.runs(m))
        };
        let needed =
            |m: Mode| timed(m) || (cfg.check && subject.checked.iter().any(|(a, _)| a.runs(m)));
        let has_counts = subject.counted.is_some()
            && cfg.stats
            && subject.timed.iter().any(|t| t.accel.has_counts());
        let packets = if needed(Mode::Packet4) {
            packets_of(set)
        } else {
            Vec::new()
        };
        let bvh_counts = cfg.stats && subject.timed.iter().any(|t| t.accel.counts_itself());
        let counted8 = (has_counts || bvh_counts) && (timed(Mode::Packet8) || timed(Mode::Stream));
        let packets8 = if needed(Mode::Packet8) || counted8 {
            packets8_of(set)
        } else {
            Vec::new()
        };
        let groups: Vec<trace::Groups> = [Mode::Group8x8, Mode::Group16x16]
            .into_iter()
            .filter(|&m| needed(m))
            .map(|m| trace::Groups::new(set, m))
            .collect();
        let input = Input {
            rays: &set.rays,
            lanes: &set.packets,
            packets: &packets,
            lanes8: &set.packets8,
            packets8: &packets8,
            groups: &groups,
            occlusion: w.is_occlusion(),
        };
        if cfg.check {
            let label = format!("{name} {w}");
            match subject.reference {
                Reference::Kd8(tree) => {
                    let reference = check::reference(tree, &input);
                    check::check_workload(
                        &label,
                        "kd8/scalar",
                        &reference,
                        &subject.checked,
                        &input,
                        triangles,
                        trace_pool,
                    )?;
                }
                Reference::Scene(world) => {
                    let reference = check::scene_reference(world, &input);
                    let sampled =
                        check::check_scene_oracle(&label, world, &reference, &input, triangles)?;
                    check::check_workload(
                        &label,
                        &format!("scene/scalar (itself = brute scene on {sampled} sampled rays)"),
                        &reference,
                        &subject.checked,
                        &input,
                        triangles,
                        trace_pool,
                    )?;
                }
            }
        }
        if cfg.check_only {
            continue;
        }
        let stats = subject.stats.as_ref();
        let mut row = Row {
            scene: name.clone(),
            workload: w,
            triangles,
            build_seconds: subject.build_seconds,
            bytes_per_triangle: stats.map(|s| s.bytes as f64 / triangles.max(1) as f64),
            peak_per_triangle: subject
                .build_peak_bytes
                .map(|b| b as f64 / triangles.max(1) as f64),
            nodes: stats.map(|s| s.nodes),
            max_depth: stats.map(|s| s.max_depth),
            rates: Vec::new(),
        };
        for &mode in &cfg.modes {
            let counts = match subject.counted {
                Some(tree) if has_counts => Some(trace::counted(tree, mode, &input, trace_pool)),
                _ => None,
            };
            for t in &subject.timed {
                let accel = t.accel;
                if !accel.runs(mode) {
                    continue;
                }
                let (secs, out) = trace::time_runs(t.engine, mode, &input, trace_pool, cfg.reps);
                let results = out.per_ray(&input);
                drop(out);
                let seconds = trace::median(&secs);
                let rays = input.rays.len();
                let mrays = rays as f64 / seconds / 1e6;
                let tree_stats = stats.filter(|_| accel.has_tree());
                let counts = if accel.counts_itself() && cfg.stats {
                    Some(trace::counted_bvh(t.engine, mode, &input, trace_pool))
                } else {
                    counts.filter(|_| accel.has_counts())
                };
                let line = json_line(&JsonFields {
                    cfg,
                    scene: name,
                    triangles,
                    workload: w,
                    mode,
                    accel,
                    rays,
                    hits: results.hits(),
                    sum_t: results.sum_t(),
                    build_seconds: t.build_seconds,
                    build_peak_bytes: subject.build_peak_bytes,
                    build_peak_rss_bytes: subject.build_peak_rss_bytes,
                    seconds,
                    mrays,
                    tree: tree_stats,
                    bytes: t
                        .bytes
                        .filter(|_| tree_stats.is_some() || t.bvh.is_some() || t.grid.is_some()),
                    bvh: t.bvh.as_ref(),
                    grid: t.grid.as_ref(),
                    counts,
                    instances: match accel {
                        Accel::Instance => Some(1),
                        _ => subject.instances,
                    },
                    engine: format!("packtrace {}", env!("CARGO_PKG_VERSION")),
                    fingerprint: subject.fingerprint.workload(w),
                });
                sink.line(&line)?;
                eprintln!(
                    "{}{}",
                    progress(w, mode, accel, rays, results.hits(), (mrays, seconds)),
                    match counts {
                        Some(c) if rays > 0 => format!(
                            "  {:.1} nodes/ray {:.1} tris/ray{}",
                            c.nodes as f64 / rays as f64,
                            c.triangle_tests as f64 / rays as f64,
                            if accel.is_grid() {
                                format!(
                                    " {:.2} mailbox hits/ray",
                                    c.mailbox_hits as f64 / rays as f64
                                )
                            } else if mode.tile().is_some() {
                                format!(
                                    " {} groups, entry depth {:.1}, {:.2} cell tests/ray, {:.2} culled/ray",
                                    c.groups,
                                    c.entry_depth as f64 / c.groups.max(1) as f64,
                                    c.cell_tests as f64 / rays as f64,
                                    c.culled_triangles as f64 / rays as f64
                                )
                            } else {
                                String::new()
                            }
                        ),
                        _ => String::new(),
                    }
                );
                row.rates
                    .push((format!("{}/{}", mode.name(), accel.name()), mrays));
            }
        }
        rows.push(row);
    }
    Ok(())
}

/// The progress line (stderr) of one timed run, before any counters.
fn progress(
    w: Workload,
    mode: Mode,
    accel: Accel,
    rays: usize,
    hits: u64,
    (mrays, seconds): (f64, f64),
) -> String {
    format!(
        "  {:<8} {:<7} {:<8} {rays:>9} rays {hits:>9} hits {mrays:>9.3} Mrays/s  median {seconds:.5} s",
        w.name(),
        mode.name(),
        accel.name(),
    )
}

/// What one JSON line reports.
struct JsonFields<'a> {
    cfg: &'a Config,
    scene: &'a str,
    triangles: usize,
    workload: Workload,
    mode: Mode,
    /// The kd-tree build's peak bytes, counted by its ledger.
    build_peak_bytes: Option<usize>,
    /// Peak resident memory the build added (Linux), bytes.
    build_peak_rss_bytes: Option<usize>,
    accel: Accel,
    rays: usize,
    hits: u64,
    sum_t: Option<f64>,
    build_seconds: f64,
    seconds: f64,
    mrays: f64,
    /// Tree statistics (packtrace's trees only).
    tree: Option<&'a TreeStats>,
    /// The accelerator's bytes, where known (none for brute force).
    bytes: Option<usize>,
    /// A BVH's statistics (the BVH accels).
    bvh: Option<&'a BvhStats>,
    /// A grid's statistics (the grid accels).
    grid: Option<&'a GridStats>,
    /// Counted-pass totals (none for brute force, scenes or `--no-stats`).
    counts: Option<TraversalStats>,
    /// Instances traced (the instance accel: 1; a scene file: its live
    /// instances; none for a mesh's other accels).
    instances: Option<usize>,
    /// The engine that traced and its version (`packtrace 0.1.0`,
    /// `embree 3.13.5 ...`).
    engine: String,
    /// The rays' fingerprint.
    fingerprint: Fingerprint,
}

/// The protocol's fields in its order, then the extras.
fn json_line(f: &JsonFields) -> String {
    let mut j = JsonLine::default();
    j.push("scene", f.scene);
    j.push("triangles", f.triangles);
    j.push("workload", f.workload.name());
    j.push("mode", f.mode.name());
    j.push("accel", f.accel.name());
    j.push("threads", f.cfg.threads);
    j.push("width", f.cfg.width);
    j.push("height", f.cfg.height);
    j.push("rays", f.rays);
    j.push("hits", f.hits);
    j.push("sum_t", f.sum_t);
    j.push("build_seconds", f.build_seconds);
    j.push("seconds", f.seconds);
    j.push("mrays_per_s", f.mrays);
    // Extras: build and tree
    j.push("preset", f.cfg.preset.name);
    j.push("params", format!("{:?}", f.cfg.preset.params));
    // A BVH row's own build parameters (`params` is the kd8 reference's).
    let bvh_params = f.cfg.bvh_params_of(f.accel).map(|p| format!("{p:?}"));
    j.push("bvh_params", bvh_params.as_deref());
    // Brute force builds nothing: no rate.
    j.push(
        "build_mtris_per_s",
        (f.build_seconds > 0.0).then(|| f.triangles as f64 / f.build_seconds / 1e6),
    );
    j.push("build_peak_bytes", f.build_peak_bytes);
    j.push("build_peak_rss_bytes", f.build_peak_rss_bytes);
    j.push("reps", f.cfg.reps);
    let (t, b) = (f.tree, f.bvh);
    j.push("nodes", t.map(|s| s.nodes).or(b.map(|b| b.nodes)));
    j.push("leaves", t.map(|s| s.leaves).or(b.map(|b| b.leaves)));
    j.push(
        "max_depth",
        t.map(|s| s.max_depth).or(b.map(|b| b.max_depth)),
    );
    let g = f.grid;
    j.push(
        "refs_per_tri",
        t.map(|s| s.refs_per_triangle)
            .or(g.map(GridStats::references_per_triangle)),
    );
    j.push("tree_bytes", f.bytes);
    j.push(
        "bytes_per_triangle",
        f.bytes.map(|b| b as f64 / f.triangles.max(1) as f64),
    );
    j.push("sah_cost", t.map(|s| s.sah_cost).or(b.map(|b| b.sah_cost)));
    j.push("bvh_blocks", b.map(|b| b.blocks));
    j.push("bvh_mean_children", b.map(|b| b.mean_children));
    j.push("bvh_mean_leaf_tris", b.map(|b| b.mean_leaf_triangles));
    // A grid row's own build parameters and statistics (`GridStats`).
    j.push("grid_params", f.cfg.grid_params_of(f.accel));
    j.push("grid_dims", g.map(|g| g.dims.to_vec()));
    j.push("grid_cells", g.map(|g| g.cells));
    j.push("grid_empty_cells", g.map(|g| g.empty_cells));
    j.push("grid_max_per_cell", g.map(|g| g.max_per_cell));
    j.push("grid_subgrids", g.map(|g| g.subgrids));
    // Extras: per-ray counters (packet node visits count once per packet)
    let per_ray = |x: fn(&TraversalStats) -> u64| {
        f.counts
            .map(|c| x(&c) as f64 / f.rays as f64)
            .filter(|v| v.is_finite())
    };
    // Streams: breadth-first ray steps count too (`stream_node_rays`).
    j.push("nodes_per_ray", per_ray(|c| c.nodes + c.stream_node_rays));
    j.push("leaves_per_ray", per_ray(|c| c.leaves));
    j.push("tris_per_ray", per_ray(|c| c.triangle_tests));
    // Grids: triangles their mailbox skipped (tested in an earlier cell).
    j.push(
        "mailbox_hits_per_ray",
        per_ray(|c| c.mailbox_hits).filter(|_| f.accel.is_grid()),
    );
    let packet = f.counts.filter(|_| f.mode != Mode::Scalar && f.rays > 0);
    j.push(
        "lane_utilisation",
        packet.map(|c| c.lane_utilisation(f.mode.width())),
    );
    j.push(
        "octant_split_share",
        packet.map(|c| c.octant_splits as f64 / c.packets.max(1) as f64),
    );
    j.push(
        "single_ray_share",
        packet.map(|c| c.single_rays as f64 / c.rays.max(1) as f64),
    );
    // Stream mode: how the breadth-first traversal went
    // (`packtrace::kdtree::StreamScratch`): rays per node visit of a
    // subset, and the share of those visits that split it in two.
    let stream = f
        .counts
        .filter(|c| f.mode == Mode::Stream && c.stream_nodes > 0);
    j.push(
        "rays_per_node_visit",
        stream.map(|c| c.stream_node_rays as f64 / c.stream_nodes as f64),
    );
    j.push(
        "partition_share",
        stream.map(|c| c.partitions as f64 / c.stream_nodes as f64),
    );
    // Group modes: how the tiles went (`packtrace::group`).
    let group = f.counts.filter(|_| f.mode.tile().is_some() && f.rays > 0);
    j.push("groups", group.map(|c| c.groups));
    j.push(
        "entry_depth",
        group.map(|c| c.entry_depth as f64 / c.groups.max(1) as f64),
    );
    j.push(
        "cell_tests_per_ray",
        group.map(|c| c.cell_tests as f64 / f.rays as f64),
    );
    j.push(
        "culled_tris_per_ray",
        group.map(|c| c.culled_triangles as f64 / f.rays as f64),
    );
    // Scenes of instances: how many were traced.
    j.push("instances", f.instances);
    j.push("rustflags", RUSTFLAGS);
    j.push("target_features", target_features());
    // The packet kernel chosen at run time (`packtrace::Kernel`); scalar
    // traversal is the same code in every kernel.
    // The 8-wide BVH's single rays run in the kernels too.
    j.push(
        "kernel",
        ((f.mode != Mode::Scalar || f.accel == Accel::Bvh8) && !f.accel.is_peer())
            .then(|| Kernel::active().name()),
    );
    // Who traced, on which rays, where, from which commit, by which command.
    j.push("engine", f.engine.as_str());
    j.push("fingerprint", f.fingerprint.hex());
    let s = stamp::get();
    j.push("host", s.host.as_str());
    j.push("cpu", s.cpu.as_str());
    j.push("cores", s.cores);
    j.push("cpu_flags", s.cpu_flags.as_str());
    j.push("commit", s.commit);
    j.push("command", s.command.as_str());
    j.push("label", f.cfg.label.as_deref());
    j.render()
}

/// The closing table: one row per scene and workload, Mrays/s per
/// mode/accel.
///
/// # Errors
/// When `out` cannot be written.
fn print_summary(rows: &[Row], out: &mut dyn Write) -> std::io::Result<()> {
    if rows.is_empty() {
        return Ok(());
    }
    // Every mode/accel of any row, in first-seen order (a scene file's
    // rows have `scene` where a mesh's have the others).
    let mut cols: Vec<&str> = Vec::new();
    for (k, _) in rows.iter().flat_map(|r| &r.rates) {
        if !cols.contains(&k.as_str()) {
            cols.push(k);
        }
    }
    // As wide as the longest scene name (with a preset and thread suffix
    // in runs over several presets or thread counts), at least 22.
    let w = rows
        .iter()
        .map(|r| r.scene.len())
        .max()
        .unwrap_or(0)
        .max(22);
    let mut head = format!(
        "{:<w$} {:<8} {:>9} {:>8} {:>8} {:>6} {:>9} {:>5}",
        "scene", "workload", "tris", "build s", "peak B/t", "B/tri", "nodes", "depth"
    );
    // Each column as wide as its name, at least 13.
    let widths: Vec<usize> = cols.iter().map(|c| c.len().max(13)).collect();
    for (c, cw) in cols.iter().zip(&widths) {
        head.push_str(&format!(" {c:>cw$}"));
    }
    writeln!(out, "\nMrays/s\n{head}")?;
    let or_dash = |v: Option<String>| v.unwrap_or_else(|| "-".into());
    for r in rows {
        let mut line = format!(
            "{:<w$} {:<8} {:>9} {:>8.3} {:>8} {:>6} {:>9} {:>5}",
            r.scene,
            r.workload.name(),
            r.triangles,
            r.build_seconds,
            or_dash(r.peak_per_triangle.map(|b| format!("{b:.0}"))),
            or_dash(r.bytes_per_triangle.map(|b| format!("{b:.1}"))),
            or_dash(r.nodes.map(|n| n.to_string())),
            or_dash(r.max_depth.map(|d| d.to_string())),
        );
        for (c, cw) in cols.iter().zip(&widths) {
            match r.rates.iter().find(|(k, _)| k == c) {
                Some((_, rate)) => line.push_str(&format!(" {rate:>cw$.3}")),
                None => line.push_str(&format!(" {:>cw$}", "-")),
            }
        }
        writeln!(out, "{line}")?;
    }
    out.flush()
}

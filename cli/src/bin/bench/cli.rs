//! Command-line options, their parsers, and the resolved run configuration.

use crate::Failure;
use crate::scene::is_scene_file;
use crate::trace::{Accel, Mode};
use clap::Parser;
use glam::Vec3;
use packtrace::bvh::BvhBuildParams;
use packtrace::grid::{GridParams, HGridParams};
use packtrace::kdtree::StreamOptions;
use packtrace::protocol::camera::{Camera, parse_light};
use packtrace::protocol::generate::MAX_SPEC_TRIANGLES;
use packtrace::protocol::workload::{Workload, check_image_size};
use packtrace::{DepthLimit, KdBuildParams};
use std::path::{Path, PathBuf};

/// Scene sizes of `--scaling` without `--scaling-sizes`.
const DEFAULT_SCALING_SIZES: [usize; 5] = [1_000, 10_000, 100_000, 1_000_000, 4_000_000];

/// Instance counts of `--tlas-update` without `--tlas-sizes`.
const DEFAULT_TLAS_SIZES: [usize; 3] = [100, 1_000, 10_000];

/// The mesh `--tlas-update` instances without `--scene`.
pub const DEFAULT_TLAS_MESH: &str = "gen:sphere:1k";

/// Most instances `--tlas-sizes` takes.
const MAX_INSTANCES: usize = 10_000_000;

/// Fewest timed repetitions the protocol allows.
pub const PROTOCOL_MIN_REPS: u32 = 5;

/// Benchmark packtrace on the protocol's rays (docs/PROTOCOL.md): one JSON
/// object per (scene, workload, mode, accel) when stdout is piped or with
/// --json, a summary table when stdout is a terminal; progress on stderr.
#[derive(Parser, Debug)]
#[command(
    name = "bench",
    version,
    after_help = AFTER_HELP,
    args_conflicts_with_subcommands = true
)]
pub struct Cli {
    /// `bench report`: tables and charts from recorded runs.
    #[command(subcommand)]
    pub command: Option<Command>,

    /// Scene: an OBJ file (its NAME.view beside it supplies camera and
    /// light), a generated scene gen:sphere:N, gen:scalable:N,
    /// `gen:jittered:N[:SEED[:JITTER]]`, gen:cornell (N may end in k or M),
    /// or a scene file of instances PATH.scene (traced by accel `scene`
    /// alone; its NAME.view beside it, else the auto camera of the
    /// scene's world box). Repeatable. Default: every data/*.obj of the
    /// crate (the Cornell box), kd8 only unless --accel is given (a run of
    /// about a minute).
    #[arg(long = "scene", value_name = "PATH.obj|gen:KIND:N|PATH.scene")]
    pub scenes: Vec<String>,

    /// Camera for every scene (default: the view file's, else the
    /// protocol's auto camera).
    #[arg(
        long,
        value_name = "ex,ey,ez,tx,ty,tz,ux,uy,uz,fov",
        value_parser = parse_camera,
        allow_hyphen_values = true
    )]
    pub camera: Option<Camera>,

    /// Point light for every scene (default: the view file's, else the
    /// protocol's default light C + D (0.25, 0.8, 0.35)).
    #[arg(long, value_name = "x,y,z", value_parser = parse_light_arg, allow_hyphen_values = true)]
    pub light: Option<Vec3>,

    /// Image size, both sides even (the default is the protocol's, for
    /// every run).
    #[arg(long, value_name = "WxH", default_value = "1024x1024", value_parser = parse_size)]
    pub size: (u32, u32),

    /// Workloads to run, comma-separated [default: primary,shadow,ao,random;
    /// primary with --scaling; primary,random with --tlas-update, which
    /// traces no others].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = parse_workload)]
    pub workloads: Option<Vec<Workload>>,

    /// Traversal modes, comma-separated [default: all of them: scalar,packet4,packet8,stream,group8x8,group16x16;
    /// scalar with --tlas-update]. Scenes of instances (accels instance
    /// and scene) have no group modes.
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = mode_parser())]
    pub modes: Option<Vec<Mode>>,

    /// Accelerators, comma-separated: kd8 (8-byte nodes, depth first),
    /// kd8-blocked (the same nodes, sibling pairs in cache-line blocks),
    /// kd8-inline (the same nodes, each leaf's triangle corners copied
    /// into one run: no index array),
    /// naive (40-byte nodes, same tree), brute (every triangle; small runs only, scalar
    /// mode only), instance (the kd8 tree as one instance with the
    /// identity transform in a scene, traced through the scene API; no
    /// group modes), scene (a PATH.scene file's scene; no group modes),
    /// bvh8, bvh2, bvh2-median (the BVHs; no group modes), grid (uniform
    /// grid, 3D-DDA with mailboxes; no group modes), hgrid (two-level
    /// grid; no group modes);
    /// peers: embree (Embree 3, modes scalar, packet4, packet8; needs
    /// --features embree), embree-coherent (the same with the coherent
    /// flag; packet4, packet8), obvhs (obvhs's CWBVH, scalar), tinybvh
    /// (tinybvh's BVH8_CPU, scalar; needs --features tinybvh)
    /// [default: kd8,naive (meshes), scene (scene files); kd8 with
    /// --scaling or without --scene].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_enum)]
    pub accel: Option<Vec<Accel>>,

    /// Worker threads for tree build and tracing (a rayon pool of this
    /// size; rays or packets are split into chunks of 1024). One by default:
    /// the protocol's figures are single-core (`render`, by contrast, uses
    /// every core).
    /// A comma-separated list runs every scene once per count (a build
    /// scaling run: `--threads 1,2`).
    #[arg(long, value_name = "N[,N...]", default_value = "1", value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub threads: Vec<u32>,

    /// Timed repetitions after one untimed warm-up; `seconds` is their
    /// median. The protocol asks for at least 5 (fewer: a warning).
    #[arg(long, value_name = "N", default_value_t = PROTOCOL_MIN_REPS, value_parser = clap::value_parser!(u32).range(1..))]
    pub reps: u32,

    /// Build preset: packtrace, dynamic, pbrt, mitsuba or fast_build; a
    /// comma-separated list (or `all`) runs every scene once per preset.
    #[arg(long, value_name = "NAME[,NAME...]", default_value = "packtrace", value_delimiter = ',', value_parser = parse_preset)]
    pub preset: Vec<Preset>,

    /// Override one build parameter of the preset (repeatable):
    /// traversal_cost, intersection_cost, empty_bonus, max_bad_refines,
    /// max_leaf_size, exact_below, bins, split_clipping (true/false), and
    /// max_depth as a depth, `pbrt`, `compact` or `log2:BASE:SLOPE`. The
    /// JSON's `params` field records what was built with.
    #[arg(long = "set", value_name = "KEY=VALUE", value_parser = parse_setting)]
    pub set: Vec<Setting>,

    /// Override one build parameter of the BVHs (repeatable; every BVH
    /// accel starts from its preset: bvh8 `sah`, bvh2 `sah_binary`,
    /// bvh2-median `median`): bins, traversal_cost, intersection_cost,
    /// block, max_leaf_size, merge_below (`packtrace::bvh::BvhBuildParams`).
    #[arg(long = "bvh-set", value_name = "KEY=VALUE", value_parser = parse_bvh_setting)]
    pub bvh_set: Vec<Setting>,

    /// Grid density (cells per triangle, `GridParams::density`) of accel
    /// grid and of accel hgrid's sub-grids (its top level keeps
    /// `HGridParams::default()`'s) [default: `GridParams::default()`'s, 4].
    #[arg(long, value_name = "LAMBDA")]
    pub grid_density: Option<f32>,

    /// Trace accels grid and hgrid without their mailboxes
    /// (`GridParams::mailbox = false`): the same answers, more tests.
    #[arg(long)]
    pub grid_no_mailbox: bool,

    /// Before timing, compare every ray's result of every mode and
    /// accelerator (instance included) with scalar kd8 (and brute force
    /// when triangles x rays <= 2e9); a scene file's modes with its scalar
    /// query, itself compared with the brute-force scene oracle on a sample
    /// of rays (at most 5e7 triangle tests). Print the first mismatch and
    /// exit 1.
    #[arg(long)]
    pub check: bool,

    /// As --check, without timing (no JSON output).
    #[arg(long)]
    pub check_only: bool,

    /// JSON lines: `--json` or `--json -` prints them on stdout even on a
    /// terminal (the table then goes to stderr); `--json PATH` also writes
    /// them to PATH. Without it they go to stdout only when stdout is not a
    /// terminal.
    #[arg(
        long,
        value_name = "PATH|-",
        num_args = 0..=1,
        default_missing_value = "-",
        value_parser = parse_json_target
    )]
    pub json: Option<JsonTarget>,

    /// Per-ray traversal counters from a separate untimed counted pass
    /// (on by default).
    #[arg(long, overrides_with = "no_stats")]
    pub stats: bool,

    /// Skip the counted pass; the per-ray counter fields are null.
    #[arg(long, overrides_with = "stats")]
    pub no_stats: bool,

    /// Trace kd8 through a copy of the built tree (`KdTree::clone`), made
    /// after the build like the other layouts' conversions, so that
    /// layout comparisons put every tree in an equally fresh allocation
    /// (on a million-triangle scene the build's own arrays traced random
    /// rays a few per cent slower than a copy of them).
    #[arg(long)]
    pub copy_tree: bool,

    /// Allow --accel brute on runs over its size limit.
    #[arg(long)]
    pub force: bool,

    /// Stream mode (kd8): rays per chunk of one direction octant
    /// [default: the library's, `StreamOptions::DEFAULT`].
    #[arg(long, value_name = "N")]
    pub stream_size: Option<usize>,

    /// Stream mode (kd8): subsets of fewer rays finish ray by ray
    /// [default: the library's, `StreamOptions::DEFAULT`].
    #[arg(long, value_name = "N")]
    pub stream_single: Option<usize>,

    /// Stream mode (kd8): subsets carry their cell's box instead of the
    /// rays' intervals (the measured alternative, docs/streams.md).
    #[arg(long)]
    pub stream_cell_boxes: bool,

    /// Scaling run: build and trace gen:scalable:N for each N of
    /// --scaling-sizes (primary rays, kd8, auto camera unless given).
    #[arg(long)]
    pub scaling: bool,

    /// Triangle counts for --scaling, comma-separated (1e3, 10000, 10k, 4M
    /// all work) [default: 1e3,1e4,1e5,1e6,4e6].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = parse_count)]
    pub scaling_sizes: Option<Vec<usize>>,

    /// Top-level update run: for each N of --tlas-sizes, N instances of one
    /// mesh (the --scene given, an OBJ file or gen: spec; default
    /// gen:sphere:1k) on a jittered grid with random rotations and scales,
    /// for each top level (sah, median): the median time of moving every
    /// instance (set_transform) and committing (the top level's rebuild),
    /// on this thread, over max(--reps, 11) updates; then primary and
    /// random rays traced through the scene (--size, --modes [default
    /// scalar], --threads). A table, and JSON lines as usual.
    #[arg(long)]
    pub tlas_update: bool,

    /// Instance counts for --tlas-update, comma-separated (100, 1e3, 10k
    /// all work) [default: 100,1000,10000].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = parse_instances)]
    pub tlas_sizes: Option<Vec<usize>>,

    /// A free note stamped on every JSON line (e.g. `idle machine`,
    /// `loaded: 6 builds running`), printed by `bench report` beside the
    /// run's machine, commit and command.
    #[arg(long, value_name = "TEXT")]
    pub label: Option<String>,
}

/// Subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum Command {
    /// Markdown tables and SVG charts from recorded JSON lines:
    /// `bench report RUN.jsonl... --out DIR`.
    Report(crate::results::ReportArgs),
}

const AFTER_HELP: &str = "\
Output: on a terminal, stdout gets a summary table (Mrays/s per scene,
workload, mode and accel); piped or redirected, or with --json [-], it gets
one JSON object per line and the table goes to stderr. Progress, warnings
and errors always go to stderr.

Threads: bench measures on 1 thread by default, as the protocol's figures
are single-core; --threads N uses a pool of N (render uses every core
unless told otherwise).

Protocol: docs/PROTOCOL.md. Every option and output field: docs/measurements.md;
peers, their fields and bench report: docs/benchmarking.md. Figures: BENCHMARKS.md.

Peers: --accel embree,embree-coherent,obvhs,tinybvh trace the same rays
with other engines (Embree and tinybvh need `--features embree` /
`--features tinybvh` at build time); --check holds them to the protocol's
agreement rule, and the closing table gives ratios to Embree's best.

Report: `bench report RUN.jsonl... --out DIR` writes markdown tables and
SVG charts of recorded runs (see bench report --help).

Exit status: 0 on success, 1 when --check finds a mismatch, 2 for bad input
(missing or malformed scene, bad option value).

Examples:
  bench                                          # data/*.obj, kd8, 1024x1024: a table
  bench --scene gen:sphere:100k > sphere.jsonl   # JSON lines into a file
  bench --scene bunny.obj --check --json out.jsonl
  bench --scene gen:scalable:1M --workloads primary --threads 2
  bench --scaling --scaling-sizes 1e3,1e4,1e5
  bench --scene bunny.obj --accel kd8,instance   # one instance vs the bare tree
  bench --scene data/cornell_spheres.scene --check
  bench --tlas-update --size 256x256             # top-level update ms, sah vs median
  bench --scene bunny.obj --accel kd8,embree,embree-coherent --check   # --features embree
  bench report runs/*.jsonl --out report/        # tables and SVG charts";

/// A build preset chosen by name.
#[derive(Clone, Copy, Debug)]
pub struct Preset {
    /// Its name in [`KdBuildParams::presets`].
    pub name: &'static str,
    /// Its parameters.
    pub params: KdBuildParams,
}

fn parse_camera(s: &str) -> Result<Camera, String> {
    Camera::parse(s).map_err(|e| e.to_string())
}

fn parse_light_arg(s: &str) -> Result<Vec3, String> {
    parse_light(s).map_err(|e| e.to_string())
}

fn parse_workload(s: &str) -> Result<Workload, String> {
    s.trim().parse::<Workload>().map_err(|e| e.to_string())
}

/// `WxH` with both sides even and non-zero and at most `MAX_PIXELS` pixels.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WxH (e.g. 1024x1024)"))?;
    let side = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{v}` in `{s}` is not a whole number of pixels"))
    };
    let (w, h) = (side(w)?, side(h)?);
    check_image_size(w, h).map_err(|e| e.to_string())?;
    Ok((w, h))
}

/// Where `--json` sends the JSON lines (besides the rule for stdout, see
/// [`crate::report::output_plan`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum JsonTarget {
    /// `--json` alone or `--json -`: stdout, even when it is a terminal.
    Stdout,
    /// `--json PATH`: this file too (created or truncated).
    File(PathBuf),
}

impl JsonTarget {
    /// The file, for `--json PATH`.
    pub fn file(&self) -> Option<&Path> {
        match self {
            JsonTarget::Stdout => None,
            JsonTarget::File(p) => Some(p),
        }
    }
}

/// `-` (also what a bare `--json` means) or a file path.
fn parse_json_target(s: &str) -> Result<JsonTarget, String> {
    match s {
        "-" => Ok(JsonTarget::Stdout),
        "" => Err("an empty path (use `-` or no value for stdout)".into()),
        p => Ok(JsonTarget::File(PathBuf::from(p))),
    }
}

/// One `--set KEY=VALUE` build parameter override.
#[derive(Clone, Debug)]
pub struct Setting {
    key: String,
    value: String,
}

fn parse_setting(s: &str) -> Result<Setting, String> {
    let (key, value) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}` is not KEY=VALUE"))?;
    let setting = Setting {
        key: key.trim().to_string(),
        value: value.trim().to_string(),
    };
    // Checked here so that a typo fails before any scene is loaded.
    apply(&mut KdBuildParams::default(), &setting)?;
    Ok(setting)
}

/// Apply one override to `p` (its range is checked later, by
/// `KdBuildParams::validate`).
fn apply(p: &mut KdBuildParams, s: &Setting) -> Result<(), String> {
    fn num<T: std::str::FromStr>(s: &Setting) -> Result<T, String> {
        s.value
            .parse()
            .map_err(|_| format!("--set {}: `{}` is not a valid value", s.key, s.value))
    }
    match s.key.as_str() {
        "traversal_cost" => p.traversal_cost = num(s)?,
        "intersection_cost" => p.intersection_cost = num(s)?,
        "empty_bonus" => p.empty_bonus = num(s)?,
        "max_bad_refines" => p.max_bad_refines = num(s)?,
        "max_leaf_size" => p.max_leaf_size = num(s)?,
        "exact_below" => p.exact_below = num(s)?,
        "bins" => p.bins = num(s)?,
        "split_clipping" => p.split_clipping = num(s)?,
        "max_depth" => {
            p.max_depth = match s.value.as_str() {
                "pbrt" => DepthLimit::PBRT,
                "compact" => DepthLimit::COMPACT,
                v => match v.strip_prefix("log2:").and_then(|r| r.split_once(':')) {
                    Some((base, slope)) => DepthLimit::Log2 {
                        base: base
                            .parse()
                            .map_err(|_| format!("--set max_depth: bad base `{base}`"))?,
                        slope: slope
                            .parse()
                            .map_err(|_| format!("--set max_depth: bad slope `{slope}`"))?,
                    },
                    None => DepthLimit::Fixed(num(s)?),
                },
            }
        }
        k => {
            return Err(format!(
                "--set: unknown build parameter `{k}` (traversal_cost, intersection_cost, \
                 empty_bonus, max_depth, max_bad_refines, max_leaf_size, exact_below, bins, \
                 split_clipping)"
            ));
        }
    }
    Ok(())
}

fn parse_bvh_setting(s: &str) -> Result<Setting, String> {
    let setting = parse_key_value(s)?;
    apply_bvh(&mut BvhBuildParams::default(), &setting)?;
    Ok(setting)
}

fn parse_key_value(s: &str) -> Result<Setting, String> {
    let (key, value) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}` is not KEY=VALUE"))?;
    Ok(Setting {
        key: key.trim().to_string(),
        value: value.trim().to_string(),
    })
}

/// Apply one `--bvh-set` override to `p` (its range is checked later, by
/// `BvhBuildParams::validate`).
pub fn apply_bvh(p: &mut BvhBuildParams, s: &Setting) -> Result<(), String> {
    let num = |s: &Setting| {
        s.value
            .parse::<f64>()
            .map_err(|_| format!("--bvh-set {}: `{}` is not a number", s.key, s.value))
    };
    let int = |s: &Setting| {
        s.value
            .parse::<u32>()
            .map_err(|_| format!("--bvh-set {}: `{}` is not a whole number", s.key, s.value))
    };
    match s.key.as_str() {
        "traversal_cost" => p.traversal_cost = num(s)? as f32,
        "intersection_cost" => p.intersection_cost = num(s)? as f32,
        "bins" => p.bins = int(s)?,
        "block" => p.block = int(s)?,
        "max_leaf_size" => p.max_leaf_size = int(s)?,
        "merge_below" => p.merge_below = int(s)?,
        k => {
            return Err(format!(
                "--bvh-set: unknown BVH build parameter `{k}` (bins, traversal_cost, \
                 intersection_cost, block, max_leaf_size, merge_below)"
            ));
        }
    }
    Ok(())
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    let presets = KdBuildParams::presets();
    if s == "all" {
        // Expanded into every preset when the configuration is made.
        return Ok(Preset {
            name: "all",
            params: KdBuildParams::default(),
        });
    }
    presets
        .iter()
        .find(|(name, _)| *name == s)
        .map(|&(name, params)| Preset { name, params })
        .ok_or_else(|| {
            let names: Vec<&str> = presets.iter().map(|(n, _)| *n).collect();
            format!(
                "unknown preset `{s}` (expected {} or all)",
                names.join(", ")
            )
        })
}

/// A triangle count: `1000`, `1e3`, `4e6`, `10k` or `4M`.
fn parse_count(s: &str) -> Result<usize, String> {
    count_of(s, "triangle", MAX_SPEC_TRIANGLES)
}

/// An instance count, written as [`parse_count`] takes them.
fn parse_instances(s: &str) -> Result<usize, String> {
    count_of(s, "instance", MAX_INSTANCES)
}

/// A whole count of `what`s in `1..=max`: `1000`, `1e3`, `10k` or `4M`.
fn count_of(s: &str, what: &str, max: usize) -> Result<usize, String> {
    let t = s.trim();
    let bad = || format!("`{s}` is not a {what} count (e.g. 1000, 1e3, 10k, 4M)");
    let n: f64 = if let Some(d) = t.strip_suffix(['k', 'K']) {
        d.parse::<f64>().map_err(|_| bad())? * 1e3
    } else if let Some(d) = t.strip_suffix(['m', 'M']) {
        d.parse::<f64>().map_err(|_| bad())? * 1e6
    } else {
        t.parse::<f64>().map_err(|_| bad())?
    };
    if !(n.is_finite() && n >= 1.0 && n.fract() == 0.0 && n <= max as f64) {
        return Err(format!("`{s}` is not a whole {what} count in 1..={max}"));
    }
    Ok(n as usize)
}

/// `items` without repeats, first occurrence kept.
fn dedup<T: PartialEq + Copy>(items: Vec<T>) -> Vec<T> {
    let mut out = Vec::with_capacity(items.len());
    for i in items {
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

/// Everything a run needs, defaults filled in.
#[derive(Clone, Debug)]
pub struct Config {
    /// Scene specs: OBJ paths or `gen:` specs, in run order.
    pub scenes: Vec<String>,
    /// Camera override for every scene.
    pub camera: Option<Camera>,
    /// Light override for every scene.
    pub light: Option<Vec3>,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Workloads in run order.
    pub workloads: Vec<Workload>,
    /// Modes in run order.
    pub modes: Vec<Mode>,
    /// Accelerators in run order.
    pub accels: Vec<Accel>,
    /// Worker threads of this run.
    pub threads: usize,
    /// Every thread count to run (`threads` is one of them).
    pub thread_counts: Vec<usize>,
    /// Timed repetitions.
    pub reps: u32,
    /// Build preset of this run.
    pub preset: Preset,
    /// Every preset to run (`preset` is one of them), `--set` applied.
    pub presets: Vec<Preset>,
    /// Compare all engines ray by ray before timing.
    pub check: bool,
    /// Do not time.
    pub check_only: bool,
    /// `--json`: JSON lines on stdout even on a terminal, or also to a file.
    pub json: Option<JsonTarget>,
    /// Run the counted pass.
    pub stats: bool,
    /// Lift the brute-force size limit.
    pub force: bool,
    /// `--copy-tree`: trace a fresh copy of the built tree.
    pub copy_tree: bool,
    /// `--tlas-update`: the instance counts of the top-level update run
    /// (its mesh is `scenes[0]`).
    pub tlas_update: Option<Vec<usize>>,
    /// `--stream-size`, `--stream-single`: kd8's stream options.
    pub stream: StreamOptions,
    /// `--label`: a note on every JSON line.
    pub label: Option<String>,
    /// `--bvh-set` overrides, applied to each BVH accel's preset.
    pub bvh_set: Vec<Setting>,
    /// `--grid-density`: accel grid's density and accel hgrid's
    /// sub-grids'.
    pub grid_density: f32,
    /// `--grid-no-mailbox`: both grids without mailboxes.
    pub grid_mailbox: bool,
}

/// `--modes` values: the library's mode names, listed in clap's errors.
fn mode_parser() -> impl clap::builder::TypedValueParser<Value = Mode> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(Mode::ALL.map(Mode::name))
        .map(|s| s.parse::<Mode>().expect("a listed mode name"))
}

/// The repository's `data/` directory (as the crate was built: beside
/// `cli/`) and its `*.obj` scenes, sorted.
fn data_scenes() -> (PathBuf, Vec<String>) {
    let cli = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = cli.parent().unwrap_or(cli).join("data");
    let mut found: Vec<String> = std::fs::read_dir(&dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "obj"))
        .map(|p| p.display().to_string())
        .collect();
    found.sort();
    (dir, found)
}

impl Config {
    /// The BVH preset `base` with the `--bvh-set` overrides (checked when
    /// the configuration was made).
    pub fn bvh_params(&self, base: BvhBuildParams) -> BvhBuildParams {
        let mut p = base;
        for s in &self.bvh_set {
            apply_bvh(&mut p, s).expect("checked by Config::from_cli");
        }
        p
    }

    /// The build parameters of a BVH accel (its preset, `--bvh-set`
    /// applied); `None` for the others.
    pub fn bvh_params_of(&self, accel: Accel) -> Option<BvhBuildParams> {
        let base = match accel {
            Accel::Bvh8 => BvhBuildParams::sah(),
            Accel::Bvh2 => BvhBuildParams::sah_binary(),
            Accel::Bvh2Median => BvhBuildParams::median(),
            _ => return None,
        };
        Some(self.bvh_params(base))
    }

    /// Accel grid's build parameters: the defaults with `--grid-density`.
    pub fn grid_params(&self) -> GridParams {
        GridParams {
            density: self.grid_density,
            mailbox: self.grid_mailbox,
            ..GridParams::default()
        }
    }

    /// Accel hgrid's build parameters: the defaults, the sub-grids'
    /// density `--grid-density`.
    pub fn hgrid_params(&self) -> HGridParams {
        let d = HGridParams::default();
        HGridParams {
            top: GridParams {
                mailbox: self.grid_mailbox,
                ..d.top
            },
            cell: GridParams {
                density: self.grid_density,
                mailbox: self.grid_mailbox,
                ..d.cell
            },
            ..d
        }
    }

    /// The build parameters of a grid accel in Rust's debug form; `None`
    /// for the others.
    pub fn grid_params_of(&self, accel: Accel) -> Option<String> {
        match accel {
            Accel::Grid => Some(format!("{:?}", self.grid_params())),
            Accel::HGrid => Some(format!("{:?}", self.hgrid_params())),
            _ => None,
        }
    }

    /// Fill in defaults and check combinations clap cannot.
    ///
    /// # Errors
    /// [`Failure::Input`] for contradictory options.
    pub fn from_cli(cli: Cli) -> Result<Config, Failure> {
        if cli.scaling && !cli.scenes.is_empty() {
            return Err(Failure::Input(
                "--scaling builds its own gen:scalable:N scenes; drop --scene".into(),
            ));
        }
        if cli.scaling_sizes.is_some() && !cli.scaling {
            return Err(Failure::Input("--scaling-sizes needs --scaling".into()));
        }
        if cli.tlas_sizes.is_some() && !cli.tlas_update {
            return Err(Failure::Input("--tlas-sizes needs --tlas-update".into()));
        }
        if cli.tlas_update {
            if cli.scaling {
                return Err(Failure::Input(
                    "--tlas-update and --scaling are separate runs; pick one".into(),
                ));
            }
            if cli.scenes.len() > 1 || cli.scenes.iter().any(|s| is_scene_file(s)) {
                return Err(Failure::Input(
                    "--tlas-update instances one mesh: at most one --scene, an OBJ file or a \
                     gen: spec"
                        .into(),
                ));
            }
            if cli.accel.is_some() {
                return Err(Failure::Input(
                    "--tlas-update traces its own scenes of instances; drop --accel".into(),
                ));
            }
            if let Some(w) = cli
                .workloads
                .iter()
                .flatten()
                .find(|w| !matches!(w, Workload::Primary | Workload::Random))
            {
                return Err(Failure::Input(format!(
                    "--tlas-update traces primary and random rays, not {w}"
                )));
            }
        }
        let tlas_update = cli.tlas_update.then(|| {
            dedup(
                cli.tlas_sizes
                    .clone()
                    .unwrap_or_else(|| DEFAULT_TLAS_SIZES.to_vec()),
            )
        });
        // The default run (no --scene): the crate's own scenes, kd8 only,
        // so that it stays about a minute at the protocol's size.
        let default_run = !cli.scaling && !cli.tlas_update && cli.scenes.is_empty();
        let scenes = if cli.tlas_update {
            if cli.scenes.is_empty() {
                vec![DEFAULT_TLAS_MESH.to_string()]
            } else {
                cli.scenes
            }
        } else if cli.scaling {
            let sizes = cli
                .scaling_sizes
                .unwrap_or_else(|| DEFAULT_SCALING_SIZES.to_vec());
            dedup(sizes)
                .into_iter()
                .map(|n| format!("gen:scalable:{n}"))
                .collect()
        } else if default_run {
            let (dir, found) = data_scenes();
            if found.is_empty() {
                return Err(Failure::Input(format!(
                    "no --scene given and no *.obj in {}; name a scene with --scene",
                    dir.display()
                )));
            }
            found
        } else {
            cli.scenes
        };
        let (width, height) = cli.size;
        let workloads = dedup(cli.workloads.unwrap_or_else(|| {
            if cli.tlas_update {
                vec![Workload::Primary, Workload::Random]
            } else if cli.scaling {
                vec![Workload::Primary]
            } else {
                Workload::ALL.to_vec()
            }
        }));
        let modes = dedup(cli.modes.unwrap_or_else(|| {
            if cli.tlas_update {
                vec![Mode::Scalar]
            } else {
                Mode::ALL.to_vec()
            }
        }));
        let files = scenes.iter().filter(|s| is_scene_file(s)).count();
        let accels = dedup(cli.accel.unwrap_or_else(|| {
            if cli.tlas_update || (files > 0 && files == scenes.len()) {
                vec![Accel::Scene]
            } else if cli.scaling || default_run {
                vec![Accel::Kd8]
            } else if files > 0 {
                vec![Accel::Kd8, Accel::Naive, Accel::Scene]
            } else {
                vec![Accel::Kd8, Accel::Naive]
            }
        }));
        // An engine this binary was built without: say which feature.
        if let Some(a) = accels.iter().find(|a| !a.compiled_in()) {
            let feature = a.feature().unwrap_or_default();
            return Err(Failure::Input(format!(
                "accel {} is not compiled into this bench: rebuild with the cargo feature \
                 `{feature}`, e.g. `cargo run --release -p packtrace-cli --features {feature} \
                 --bin bench -- ...`{}",
                a.name(),
                if feature == "embree" {
                    " (needs Embree 3: `apt-get install libembree-dev`)"
                } else {
                    " (compiles tinybvh's C++20: needs g++)"
                }
            )));
        }
        if !cli.tlas_update {
            // Every scene needs an accel that traces it.
            for spec in &scenes {
                let file = is_scene_file(spec);
                if !accels.iter().any(|a| a.traces(file)) {
                    return Err(Failure::Input(if file {
                        format!(
                            "{spec} is a scene file, traced by accel scene alone: add it to --accel"
                        )
                    } else {
                        format!(
                            "{spec} is one mesh, which accel scene does not trace (it traces \
                             PATH.scene files): add kd8, naive, brute or instance to --accel"
                        )
                    }));
                }
            }
        }
        let mut presets = Vec::new();
        for preset in &cli.preset {
            if preset.name == "all" {
                presets.extend(
                    KdBuildParams::presets()
                        .iter()
                        .map(|&(name, params)| Preset { name, params }),
                );
            } else {
                presets.push(*preset);
            }
        }
        for preset in &mut presets {
            for setting in &cli.set {
                apply(&mut preset.params, setting).map_err(Failure::Input)?;
            }
            preset
                .params
                .validate()
                .map_err(|e| Failure::Input(format!("preset {}: {e}", preset.name)))?;
        }
        for (name, mut p) in BvhBuildParams::presets() {
            for setting in &cli.bvh_set {
                apply_bvh(&mut p, setting).map_err(Failure::Input)?;
            }
            p.validate()
                .map_err(|e| Failure::Input(format!("--bvh-set on preset {name}: {e}")))?;
        }
        let grid_density = cli.grid_density.unwrap_or(GridParams::default().density);
        GridParams {
            density: grid_density,
            ..GridParams::default()
        }
        .validate()
        .map_err(|e| Failure::Input(format!("--grid-density: {e}")))?;
        Ok(Config {
            scenes,
            camera: cli.camera,
            light: cli.light,
            width,
            height,
            workloads,
            modes,
            accels,
            threads: cli.threads[0] as usize,
            thread_counts: cli.threads.iter().map(|&t| t as usize).collect(),
            reps: cli.reps,
            preset: presets[0],
            presets,
            check: cli.check || cli.check_only,
            check_only: cli.check_only,
            json: cli.json,
            stats: !cli.no_stats,
            force: cli.force,
            copy_tree: cli.copy_tree,
            tlas_update,
            stream: StreamOptions::new(
                cli.stream_size
                    .unwrap_or(StreamOptions::DEFAULT.stream_size()),
                cli.stream_single
                    .unwrap_or(StreamOptions::DEFAULT.single_ray_below()),
            )
            .map_err(|e| Failure::Input(format!("--stream-size: {e}")))?
            .with_cell_boxes(cli.stream_cell_boxes),
            label: cli.label,
            bvh_set: cli.bvh_set,
            grid_density,
            grid_mailbox: !cli.grid_no_mailbox,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_must_be_even_and_non_zero() {
        assert_eq!(parse_size("64x32"), Ok((64, 32)));
        assert_eq!(parse_size("64X32"), Ok((64, 32)));
        for bad in ["63x64", "64x0", "0x0", "64", "ax64", "64x-2", "65536x65536"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn counts_accept_exponents_and_suffixes() {
        assert_eq!(parse_count("1e3"), Ok(1000));
        assert_eq!(parse_count("4e6"), Ok(4_000_000));
        assert_eq!(parse_count("10k"), Ok(10_000));
        assert_eq!(parse_count("4M"), Ok(4_000_000));
        assert_eq!(parse_count("1500"), Ok(1500));
        for bad in ["0", "1.5", "-3", "1e9", "x", "nan", "inf"] {
            assert!(parse_count(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn build_parameter_overrides() {
        let mut p = KdBuildParams::default();
        for kv in [
            "max_depth=pbrt",
            "max_bad_refines=3",
            "bins=16",
            "split_clipping=false",
        ] {
            apply(&mut p, &parse_setting(kv).unwrap()).unwrap();
        }
        assert_eq!(p.max_depth, DepthLimit::PBRT);
        assert_eq!(
            (p.max_bad_refines, p.bins, p.split_clipping),
            (3, 16, false)
        );
        apply(&mut p, &parse_setting("max_depth=log2:5:1.5").unwrap()).unwrap();
        assert_eq!(
            p.max_depth,
            DepthLimit::Log2 {
                base: 5.0,
                slope: 1.5
            }
        );
        apply(&mut p, &parse_setting("max_depth=20").unwrap()).unwrap();
        assert_eq!(p.max_depth, DepthLimit::Fixed(20));
        assert!(
            parse_setting("depth=3")
                .unwrap_err()
                .contains("unknown build parameter")
        );
        assert!(
            parse_setting("bins=many")
                .unwrap_err()
                .contains("not a valid value")
        );
        assert!(parse_setting("bins").unwrap_err().contains("KEY=VALUE"));
    }

    #[test]
    fn presets_by_name() {
        assert_eq!(parse_preset("pbrt").unwrap().params, KdBuildParams::pbrt());
        assert!(parse_preset("fast").unwrap_err().contains("fast_build"));
    }

    fn parse(args: &[&str]) -> Cli {
        Cli::try_parse_from(std::iter::once("bench").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{args:?}: {e}"))
    }

    #[test]
    fn json_takes_an_optional_value() {
        let file = |p: &str| Some(JsonTarget::File(PathBuf::from(p)));
        assert_eq!(parse(&[]).json, None);
        assert_eq!(parse(&["--json"]).json, Some(JsonTarget::Stdout));
        assert_eq!(parse(&["--json", "-"]).json, Some(JsonTarget::Stdout));
        assert_eq!(parse(&["--json=-"]).json, Some(JsonTarget::Stdout));
        assert_eq!(parse(&["--json", "out.jsonl"]).json, file("out.jsonl"));
        assert_eq!(parse(&["--json=out.jsonl"]).json, file("out.jsonl"));
        // a bare --json before another option leaves that option alone
        let c = parse(&["--json", "--reps", "3", "--check"]);
        assert_eq!(
            (c.json, c.reps, c.check),
            (Some(JsonTarget::Stdout), 3, true)
        );
        let c = parse(&["--scene", "a.obj", "--json", "--scene", "b.obj"]);
        assert_eq!(c.json, Some(JsonTarget::Stdout));
        assert_eq!(c.scenes, ["a.obj", "b.obj"]);
        assert!(Cli::try_parse_from(["bench", "--json", ""]).is_err());
        assert_eq!(JsonTarget::Stdout.file(), None);
        assert_eq!(
            JsonTarget::File("x.jsonl".into()).file(),
            Some(Path::new("x.jsonl"))
        );
    }

    #[test]
    fn one_default_size_for_every_run() {
        for args in [
            &[][..],
            &["--scene", "gen:sphere:1k"][..],
            &["--scaling"][..],
        ] {
            let cfg = Config::from_cli(parse(args)).expect("a valid run");
            assert_eq!((cfg.width, cfg.height), (1024, 1024), "{args:?}");
        }
        let cfg = Config::from_cli(parse(&["--size", "64x32"])).unwrap();
        assert_eq!((cfg.width, cfg.height), (64, 32));
    }

    #[test]
    fn the_default_run_is_the_data_scenes_on_kd8() {
        let cfg = Config::from_cli(parse(&[])).unwrap();
        assert!(!cfg.scenes.is_empty());
        assert!(
            cfg.scenes.iter().all(|s| s.ends_with(".obj")),
            "{:?}",
            cfg.scenes
        );
        assert_eq!(cfg.accels, [Accel::Kd8]);
        assert_eq!(cfg.workloads, Workload::ALL);
        assert_eq!(cfg.modes, Mode::ALL);
        assert_eq!(cfg.threads, 1);
        // --accel still applies; a named scene gets both layouts
        let cfg = Config::from_cli(parse(&["--accel", "naive"])).unwrap();
        assert_eq!(cfg.accels, [Accel::Naive]);
        let cfg = Config::from_cli(parse(&["--scene", "gen:sphere:1k"])).unwrap();
        assert_eq!(cfg.accels, [Accel::Kd8, Accel::Naive]);
    }

    /// The message of a configuration `args` refuses.
    fn refused(args: &[&str]) -> String {
        match Config::from_cli(parse(args)) {
            Err(Failure::Input(m)) => m,
            other => panic!("{args:?} accepted: {other:?}"),
        }
    }

    #[test]
    fn instance_and_scene_accels_by_name() {
        let cfg =
            Config::from_cli(parse(&["--scene", "a.obj", "--accel", "kd8,instance"])).unwrap();
        assert_eq!(cfg.accels, [Accel::Kd8, Accel::Instance]);
        assert_eq!(cfg.modes, Mode::ALL);
        assert_eq!(cfg.tlas_update, None);
        assert!(Cli::try_parse_from(["bench", "--accel", "instances"]).is_err());
        // A scene file alone: accel scene; beside a mesh: both kinds.
        let cfg = Config::from_cli(parse(&["--scene", "data/x.scene"])).unwrap();
        assert_eq!(cfg.accels, [Accel::Scene]);
        assert_eq!(cfg.workloads, Workload::ALL);
        let cfg =
            Config::from_cli(parse(&["--scene", "x.scene", "--scene", "gen:sphere:1k"])).unwrap();
        assert_eq!(cfg.accels, [Accel::Kd8, Accel::Naive, Accel::Scene]);
        assert!(is_scene_file("dir/x.scene") && !is_scene_file("x.obj"));
        assert!(!is_scene_file("gen:sphere:1k") && !is_scene_file("scene"));
    }

    #[test]
    fn every_scene_needs_an_accel_that_traces_it() {
        let e = refused(&["--scene", "x.scene", "--accel", "kd8,instance"]);
        assert!(
            e.contains("x.scene is a scene file") && e.contains("add it"),
            "{e}"
        );
        let e = refused(&["--scene", "gen:sphere:1k", "--accel", "scene"]);
        assert!(e.contains("one mesh") && e.contains("instance"), "{e}");
        // Mixed: each kind finds its accel.
        Config::from_cli(parse(&[
            "--scene",
            "x.scene",
            "--scene",
            "a.obj",
            "--accel",
            "scene,kd8",
        ]))
        .unwrap();
    }

    #[test]
    fn tlas_update_defaults() {
        let cfg = Config::from_cli(parse(&["--tlas-update"])).unwrap();
        assert_eq!(cfg.tlas_update, Some(vec![100, 1000, 10_000]));
        assert_eq!(cfg.scenes, [DEFAULT_TLAS_MESH]);
        assert_eq!(cfg.workloads, [Workload::Primary, Workload::Random]);
        assert_eq!(cfg.modes, [Mode::Scalar]);
        assert_eq!(cfg.accels, [Accel::Scene]);
        assert_eq!((cfg.width, cfg.height, cfg.threads), (1024, 1024, 1));
        let cfg = Config::from_cli(parse(&[
            "--tlas-update",
            "--tlas-sizes",
            "1e2,5k,100",
            "--scene",
            "gen:sphere:200",
            "--modes",
            "scalar,packet8",
            "--workloads",
            "random",
            "--size",
            "256x256",
        ]))
        .unwrap();
        assert_eq!(cfg.tlas_update, Some(vec![100, 5000]));
        assert_eq!(cfg.scenes, ["gen:sphere:200"]);
        assert_eq!(cfg.modes, [Mode::Scalar, Mode::Packet8]);
        assert_eq!(cfg.workloads, [Workload::Random]);
        assert_eq!((cfg.width, cfg.height), (256, 256));
    }

    #[test]
    fn tlas_update_refuses_what_it_cannot_do() {
        assert!(refused(&["--tlas-sizes", "100"]).contains("needs --tlas-update"));
        assert!(refused(&["--tlas-update", "--scaling"]).contains("pick one"));
        assert!(refused(&["--tlas-update", "--accel", "kd8"]).contains("drop --accel"));
        let e = refused(&["--tlas-update", "--workloads", "primary,shadow"]);
        assert!(e.contains("not shadow"), "{e}");
        let e = refused(&["--tlas-update", "--scene", "a.scene"]);
        assert!(e.contains("one mesh"), "{e}");
        let e = refused(&["--tlas-update", "--scene", "a.obj", "--scene", "b.obj"]);
        assert!(e.contains("at most one --scene"), "{e}");
        assert_eq!(parse_instances("10k"), Ok(10_000));
        for bad in ["0", "2.5", "1e8", "many"] {
            let e = parse_instances(bad).unwrap_err();
            assert!(e.contains("instance count"), "{bad}: {e}");
        }
        assert!(Cli::try_parse_from(["bench", "--tlas-update", "--tlas-sizes", "0"]).is_err());
    }

    #[test]
    fn grid_accels_by_name_and_density() {
        let cfg = Config::from_cli(parse(&[
            "--scene",
            "a.obj",
            "--accel",
            "kd8,bvh2,grid,hgrid",
        ]))
        .unwrap();
        assert_eq!(
            cfg.accels,
            [Accel::Kd8, Accel::Bvh2, Accel::Grid, Accel::HGrid]
        );
        assert_eq!(cfg.grid_params(), GridParams::default());
        assert_eq!(cfg.hgrid_params(), HGridParams::default());
        assert_eq!(cfg.grid_params_of(Accel::Bvh2), None);
        assert!(
            cfg.grid_params_of(Accel::Grid)
                .unwrap()
                .contains("density: 4.0")
        );
        assert_eq!(cfg.bvh_params_of(Accel::Grid), None);
        let cfg = Config::from_cli(parse(&[
            "--scene",
            "a.obj",
            "--accel",
            "grid,hgrid",
            "--grid-density",
            "2.5",
            "--grid-no-mailbox",
        ]))
        .unwrap();
        assert_eq!(cfg.grid_params().density, 2.5);
        assert!(!cfg.grid_params().mailbox);
        let h = cfg.hgrid_params();
        assert!(!h.top.mailbox && !h.cell.mailbox);
        assert_eq!(h.cell.density, 2.5);
        assert_eq!(h.top.density, HGridParams::default().top.density);
        for bad in ["0", "-1", "1000", "nan"] {
            let arg = format!("--grid-density={bad}");
            let e = refused(&["--scene", "a.obj", "--accel", "grid", &arg]);
            assert!(e.contains("--grid-density"), "{bad}: {e}");
        }
        assert!(Cli::try_parse_from(["bench", "--grid-density", "dense"]).is_err());
        assert!(Cli::try_parse_from(["bench", "--accel", "h-grid"]).is_err());
        for (a, name) in [(Accel::Grid, "grid"), (Accel::HGrid, "hgrid")] {
            assert_eq!(a.name(), name);
            assert!(a.is_grid() && a.counts_itself() && !a.is_bvh() && !a.has_tree());
            assert!(!a.is_peer() && !a.is_scene() && a.traces(false) && a.compiled_in());
            assert!(Mode::ALL.iter().all(|&m| a.runs(m) == Accel::Bvh2.runs(m)));
        }
    }

    #[test]
    fn dedup_keeps_first() {
        assert_eq!(dedup(vec![3, 1, 3, 2, 1]), vec![3, 1, 2]);
    }
}

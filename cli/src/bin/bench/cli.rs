//! Command-line options, their parsers, and the resolved run configuration.

use crate::Failure;
use crate::trace::{Accel, Mode};
use clap::Parser;
use glam::Vec3;
use packtrace::KdBuildParams;
use packtrace::protocol::camera::{Camera, parse_light};
use packtrace::protocol::generate::MAX_SPEC_TRIANGLES;
use packtrace::protocol::workload::{Workload, check_image_size};
use std::path::{Path, PathBuf};

/// Generated scene added to the data scenes when no `--scene` is given.
const DEFAULT_GENERATED: &str = "gen:sphere:100k";

/// Image size of the default run (no `--scene`): finishes in seconds.
const DEFAULT_RUN_SIZE: (u32, u32) = (512, 512);

/// The protocol's image size, used whenever a scene is named.
const PROTOCOL_SIZE: (u32, u32) = (1024, 1024);

/// Scene sizes of `--scaling` without `--scaling-sizes`.
const DEFAULT_SCALING_SIZES: [usize; 5] = [1_000, 10_000, 100_000, 1_000_000, 4_000_000];

/// Fewest timed repetitions the protocol allows.
pub const PROTOCOL_MIN_REPS: u32 = 5;

/// Benchmark packtrace on the protocol's rays (BENCH_PROTOCOL.md): one JSON
/// object per (scene, workload, mode, accel) on stdout, progress on stderr.
#[derive(Parser, Debug)]
#[command(name = "bench", version, after_help = AFTER_HELP)]
pub struct Cli {
    /// Scene: an OBJ file (its NAME.view beside it supplies camera and
    /// light) or a generated scene gen:sphere:N, gen:scalable:N,
    /// `gen:jittered:N[:SEED[:JITTER]]`, gen:cornell (N may end in k or M).
    /// Repeatable. Default: every data/*.obj of the crate plus
    /// gen:sphere:100k, at 512x512.
    #[arg(long = "scene", value_name = "PATH.obj|gen:KIND:N")]
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

    /// Image size, both sides even [default: 1024x1024; 512x512 for the
    /// default scenes].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,

    /// Workloads to run, comma-separated [default: primary,shadow,ao,random;
    /// primary with --scaling].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = parse_workload)]
    pub workloads: Option<Vec<Workload>>,

    /// Traversal modes, comma-separated [default: scalar,packet4].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = mode_parser())]
    pub modes: Option<Vec<Mode>>,

    /// Accelerators, comma-separated: kd8 (8-byte nodes), naive (40-byte
    /// nodes, same tree), brute (every triangle; small runs only, scalar
    /// mode only) [default: kd8,naive; kd8 with --scaling].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_enum)]
    pub accel: Option<Vec<Accel>>,

    /// Worker threads for tree build and tracing (a rayon pool of this
    /// size; rays or packets are split into chunks of 1024).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub threads: u32,

    /// Timed repetitions after one untimed warm-up; `seconds` is their
    /// median. The protocol asks for at least 5 (fewer: a warning).
    #[arg(long, value_name = "N", default_value_t = PROTOCOL_MIN_REPS, value_parser = clap::value_parser!(u32).range(1..))]
    pub reps: u32,

    /// Build preset: packtrace, pbrt, mitsuba or fast_build.
    #[arg(long, value_name = "NAME", default_value = "packtrace", value_parser = parse_preset)]
    pub preset: Preset,

    /// Before timing, compare every ray's result of every mode and
    /// accelerator with scalar kd8 (and brute force when triangles x rays
    /// <= 2e9); print the first mismatch and exit 1.
    #[arg(long)]
    pub check: bool,

    /// As --check, without timing (no JSON output).
    #[arg(long)]
    pub check_only: bool,

    /// Also write the JSON lines to this file.
    #[arg(long, value_name = "PATH")]
    pub json: Option<PathBuf>,

    /// Per-ray traversal counters from a separate untimed counted pass
    /// (on by default).
    #[arg(long, overrides_with = "no_stats")]
    pub stats: bool,

    /// Skip the counted pass; the per-ray counter fields are null.
    #[arg(long, overrides_with = "stats")]
    pub no_stats: bool,

    /// Allow --accel brute on runs over its size limit.
    #[arg(long)]
    pub force: bool,

    /// Scaling run: build and trace gen:scalable:N for each N of
    /// --scaling-sizes (primary rays, kd8, auto camera unless given).
    #[arg(long)]
    pub scaling: bool,

    /// Triangle counts for --scaling, comma-separated (1e3, 10000, 10k, 4M
    /// all work) [default: 1e3,1e4,1e5,1e6,4e6].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = parse_count)]
    pub scaling_sizes: Option<Vec<usize>>,
}

const AFTER_HELP: &str = "\
Exit status: 0 on success, 1 when --check finds a mismatch, 2 for bad input
(missing or malformed scene, bad option value).

Examples:
  bench                                          # data/ scenes + gen:sphere:100k, 512x512
  bench --scene bunny.obj --check --json out.jsonl
  bench --scene gen:scalable:1M --workloads primary --threads 2
  bench --scaling --scaling-sizes 1e3,1e4,1e5";

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

fn parse_preset(s: &str) -> Result<Preset, String> {
    let presets = KdBuildParams::presets();
    presets
        .iter()
        .find(|(name, _)| *name == s)
        .map(|&(name, params)| Preset { name, params })
        .ok_or_else(|| {
            let names: Vec<&str> = presets.iter().map(|(n, _)| *n).collect();
            format!("unknown preset `{s}` (expected {})", names.join(", "))
        })
}

/// A triangle count: `1000`, `1e3`, `4e6`, `10k` or `4M`.
fn parse_count(s: &str) -> Result<usize, String> {
    let t = s.trim();
    let bad = || format!("`{s}` is not a triangle count (e.g. 1000, 1e3, 10k, 4M)");
    let n: f64 = if let Some(d) = t.strip_suffix(['k', 'K']) {
        d.parse::<f64>().map_err(|_| bad())? * 1e3
    } else if let Some(d) = t.strip_suffix(['m', 'M']) {
        d.parse::<f64>().map_err(|_| bad())? * 1e6
    } else {
        t.parse::<f64>().map_err(|_| bad())?
    };
    if !(n.is_finite() && n >= 1.0 && n.fract() == 0.0 && n <= MAX_SPEC_TRIANGLES as f64) {
        return Err(format!(
            "`{s}` is not a whole triangle count in 1..={MAX_SPEC_TRIANGLES}"
        ));
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
#[derive(Debug)]
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
    /// Worker threads.
    pub threads: usize,
    /// Timed repetitions.
    pub reps: u32,
    /// Build preset.
    pub preset: Preset,
    /// Compare all engines ray by ray before timing.
    pub check: bool,
    /// Do not time.
    pub check_only: bool,
    /// Also write JSON lines here.
    pub json: Option<PathBuf>,
    /// Run the counted pass.
    pub stats: bool,
    /// Lift the brute-force size limit.
    pub force: bool,
}

/// `--modes` values: the library's mode names, listed in clap's errors.
fn mode_parser() -> impl clap::builder::TypedValueParser<Value = Mode> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(Mode::ALL.map(Mode::name))
        .map(|s| s.parse::<Mode>().expect("a listed mode name"))
}

/// The repository's `data/*.obj` scenes, sorted (paths as the crate was
/// built: the parent of `cli/`).
fn data_scenes() -> Vec<String> {
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
    found
}

impl Config {
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
        let (scenes, default_size) = if cli.scaling {
            let sizes = cli
                .scaling_sizes
                .unwrap_or_else(|| DEFAULT_SCALING_SIZES.to_vec());
            let specs = dedup(sizes)
                .into_iter()
                .map(|n| format!("gen:scalable:{n}"))
                .collect();
            (specs, PROTOCOL_SIZE)
        } else if cli.scenes.is_empty() {
            let mut s = data_scenes();
            s.push(DEFAULT_GENERATED.to_string());
            (s, DEFAULT_RUN_SIZE)
        } else {
            (cli.scenes, PROTOCOL_SIZE)
        };
        let (width, height) = cli.size.unwrap_or(default_size);
        let workloads = dedup(cli.workloads.unwrap_or_else(|| {
            if cli.scaling {
                vec![Workload::Primary]
            } else {
                Workload::ALL.to_vec()
            }
        }));
        let modes = dedup(
            cli.modes
                .unwrap_or_else(|| vec![Mode::Scalar, Mode::Packet4, Mode::Packet8, Mode::Stream]),
        );
        let accels = dedup(cli.accel.unwrap_or_else(|| {
            if cli.scaling {
                vec![Accel::Kd8]
            } else {
                vec![Accel::Kd8, Accel::Naive]
            }
        }));
        Ok(Config {
            scenes,
            camera: cli.camera,
            light: cli.light,
            width,
            height,
            workloads,
            modes,
            accels,
            threads: cli.threads as usize,
            reps: cli.reps,
            preset: cli.preset,
            check: cli.check || cli.check_only,
            check_only: cli.check_only,
            json: cli.json,
            stats: !cli.no_stats,
            force: cli.force,
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
    fn presets_by_name() {
        assert_eq!(parse_preset("pbrt").unwrap().params, KdBuildParams::pbrt());
        assert!(parse_preset("fast").unwrap_err().contains("fast_build"));
    }

    #[test]
    fn dedup_keeps_first() {
        assert_eq!(dedup(vec![3, 1, 3, 2, 1]), vec![3, 1, 2]);
    }
}

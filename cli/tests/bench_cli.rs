//! The `bench` binary as a user runs it: its JSON lines, its agreement with
//! a direct library computation, `--check` on the crate's scenes (and the
//! shared bunny in a scene test, run with `PACKTRACE_SCENES` and
//! `-- --include-ignored`), and its exit status on bad
//! input. Also the protocol's secondary-ray formulas recomputed here in
//! `f64` (the primary-ray and hash references live in the unit tests of
//! `camera.rs` and `workload.rs`).

use glam::{DVec3, Vec3, Vec3A};
use packtrace::protocol::camera::load_view;
use packtrace::protocol::workload::{self, NO_RAY, RaySet};
use packtrace::protocol::{SceneFrame, sampling};
use packtrace::{Aabb, Hit, KdBuildParams, KdTree, Mesh, Ray, load_obj};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

// ---------------------------------------------------------------------------
// Running the binary
// ---------------------------------------------------------------------------

/// The repository's root (the parent of `cli/`), where `data/` is.
fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("cli/ has a parent")
}

/// Run `bench` from the repository's root.
fn bench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bench"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("bench runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Run and require success; the parsed JSON lines of stdout.
fn bench_json(args: &[&str]) -> Vec<Value> {
    let o = bench(args);
    assert!(
        o.status.success(),
        "bench {args:?} failed ({}):\n{}",
        o.status,
        stderr(&o)
    );
    String::from_utf8(o.stdout)
        .expect("stdout is UTF-8")
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect()
}

/// The crate's `data/*.obj` files.
fn data_scenes() -> Vec<PathBuf> {
    let dir = root().join("data");
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("data/ exists")
        .map(|e| e.expect("readable").path())
        .filter(|p| p.extension().is_some_and(|x| x == "obj"))
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no data/*.obj");
    v
}

/// A fresh path in the temp directory.
fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("packtrace-bench-cli-{}-{name}", std::process::id()))
}

// ---------------------------------------------------------------------------
// JSON lines
// ---------------------------------------------------------------------------

const PROTOCOL_FIELDS: [&str; 14] = [
    "scene",
    "triangles",
    "workload",
    "mode",
    "accel",
    "threads",
    "width",
    "height",
    "rays",
    "hits",
    "sum_t",
    "build_seconds",
    "seconds",
    "mrays_per_s",
];

const EXTRA_FIELDS: [&str; 18] = [
    "preset",
    "reps",
    "nodes",
    "leaves",
    "max_depth",
    "refs_per_tri",
    "tree_bytes",
    "bytes_per_triangle",
    "sah_cost",
    "nodes_per_ray",
    "leaves_per_ray",
    "tris_per_ray",
    "lane_utilisation",
    "octant_split_share",
    "single_ray_share",
    "rustflags",
    "target_features",
    "kernel",
];

fn u(v: &Value, k: &str) -> u64 {
    v[k].as_u64()
        .unwrap_or_else(|| panic!("`{k}` is not an unsigned integer: {v}"))
}

fn f(v: &Value, k: &str) -> f64 {
    v[k].as_f64()
        .unwrap_or_else(|| panic!("`{k}` is not a number: {v}"))
}

fn s<'a>(v: &'a Value, k: &str) -> &'a str {
    v[k].as_str()
        .unwrap_or_else(|| panic!("`{k}` is not a string: {v}"))
}

#[test]
fn json_lines_carry_every_protocol_field_with_its_type() {
    let json = temp_path("lines.jsonl");
    let json_arg = json.to_str().unwrap();
    let lines = bench_json(&[
        "--scene",
        "data/cornell.obj",
        "--scene",
        "gen:sphere:500",
        "--size",
        "16x16",
        "--reps",
        "1",
        "--accel",
        "kd8,naive,brute",
        "--json",
        json_arg,
    ]);
    // 2 scenes x 4 workloads x (4 modes x 2 trees + 2 group modes on kd8
    // + scalar brute)
    assert_eq!(lines.len(), 2 * 4 * 11);
    let file = std::fs::read_to_string(&json).unwrap();
    std::fs::remove_file(&json).unwrap();
    assert_eq!(file.lines().count(), lines.len());
    for (l, v) in file.lines().zip(&lines) {
        assert_eq!(&serde_json::from_str::<Value>(l).unwrap(), v);
    }

    for v in &lines {
        let obj = v.as_object().expect("an object per line");
        for k in PROTOCOL_FIELDS.iter().chain(&EXTRA_FIELDS) {
            assert!(obj.contains_key(*k), "missing `{k}`: {v}");
        }
        assert!(
            ["cornell", "gen:sphere:500"].contains(&s(v, "scene")),
            "{v}"
        );
        let workload = s(v, "workload");
        assert!(
            ["primary", "shadow", "ao", "random"].contains(&workload),
            "{v}"
        );
        let mode = s(v, "mode");
        assert!(
            [
                "scalar",
                "packet4",
                "packet8",
                "stream",
                "group8x8",
                "group16x16"
            ]
            .contains(&mode),
            "{v}"
        );
        let accel = s(v, "accel");
        assert!(["kd8", "naive", "brute"].contains(&accel), "{v}");
        assert!(!(accel == "brute" && mode != "scalar"), "{v}");
        let group = mode.starts_with("group");
        assert!(!(group && accel != "kd8"), "{v}");
        // Group statistics, for group modes only.
        for k in [
            "groups",
            "entry_depth",
            "cell_tests_per_ray",
            "culled_tris_per_ray",
        ] {
            assert_eq!(v[k].is_null(), !(group && rays_of(v) > 0), "`{k}`: {v}");
        }
        if group && workload == "primary" {
            // At most one group per tile; the Cornell box's 8 x 8 primary
            // tiles are narrow enough to be traced as groups, all 4 of them
            // (a 16 x 16 tile of this 16 x 16 image spreads too wide).
            let tile: u64 = if mode == "group8x8" { 64 } else { 256 };
            assert!(u(v, "groups") <= 256 / tile, "{v}");
            if s(v, "scene") == "cornell" && mode == "group8x8" {
                assert_eq!(u(v, "groups"), 4, "{v}");
            }
        }
        assert!(u(v, "triangles") > 0);
        assert_eq!(
            (u(v, "threads"), u(v, "width"), u(v, "height")),
            (1, 16, 16)
        );
        let (rays, hits) = (u(v, "rays"), u(v, "hits"));
        assert!(hits <= rays, "{v}");
        if matches!(workload, "primary" | "random") {
            assert_eq!(rays, 256, "{v}");
        }
        let occlusion = matches!(workload, "shadow" | "ao");
        assert_eq!(v["sum_t"].is_null(), occlusion, "{v}");
        if !occlusion {
            assert!(f(v, "sum_t") >= 0.0 && (hits == 0) == (f(v, "sum_t") == 0.0));
        }
        assert!(f(v, "build_seconds") >= 0.0);
        let seconds = f(v, "seconds");
        assert!(seconds > 0.0, "{v}");
        let expect = rays as f64 / seconds / 1e6;
        let got = f(v, "mrays_per_s");
        assert!(
            (got - expect).abs() <= 1e-9 * expect.max(1e-300),
            "mrays_per_s {got} vs rays/seconds/1e6 = {expect}"
        );
        // extras
        assert_eq!(s(v, "preset"), "packtrace");
        assert_eq!(u(v, "reps"), 1);
        let _ = s(v, "rustflags");
        let features = s(v, "target_features");
        if cfg!(target_arch = "x86_64") {
            assert!(features.contains("sse2"), "{v}");
        }
        let tree_fields = [
            "nodes",
            "leaves",
            "max_depth",
            "refs_per_tri",
            "tree_bytes",
            "bytes_per_triangle",
            "sah_cost",
            "nodes_per_ray",
            "leaves_per_ray",
            "tris_per_ray",
        ];
        for k in tree_fields {
            assert_eq!(v[k].is_null(), accel == "brute", "`{k}`: {v}");
        }
        if accel != "brute" {
            assert!(u(v, "nodes") >= u(v, "leaves") && u(v, "leaves") >= 1);
            assert!(f(v, "refs_per_tri") > 0.0 && f(v, "sah_cost") > 0.0);
            let bpt = u(v, "tree_bytes") as f64 / u(v, "triangles") as f64;
            assert!((f(v, "bytes_per_triangle") - bpt).abs() < 1e-9 * bpt);
            if rays > 0 {
                assert!(f(v, "nodes_per_ray") >= 0.0 && f(v, "tris_per_ray") >= 0.0);
            }
        }
        let packet_tree = mode != "scalar" && accel != "brute" && rays > 0;
        for k in ["lane_utilisation", "octant_split_share", "single_ray_share"] {
            assert_eq!(v[k].is_null(), !packet_tree, "`{k}`: {v}");
            // A stream's `single_ray_share` counts single-ray finishes per
            // ray: a ray can finish several subtrees alone (docs/streams.md).
            let top = if mode == "stream" && k == "single_ray_share" {
                f64::INFINITY
            } else {
                1.0
            };
            if packet_tree {
                assert!((0.0..=top).contains(&f(v, k)), "`{k}`: {v}");
            }
        }
        // The packet kernel that ran, for packet and stream modes only.
        assert_eq!(v["kernel"].is_null(), mode == "scalar", "{v}");
        if mode != "scalar" {
            assert!(["sse", "avx2", "avx512"].contains(&s(v, "kernel")), "{v}");
        }
    }

    // every mode and accelerator reports the same answer
    for scene in ["cornell", "gen:sphere:500"] {
        for w in ["primary", "shadow", "ao", "random"] {
            let same: Vec<&Value> = lines
                .iter()
                .filter(|v| v["scene"] == scene && v["workload"] == w)
                .collect();
            assert_eq!(same.len(), 11);
            for v in &same {
                assert_eq!(v["rays"], same[0]["rays"], "{scene} {w}");
                assert_eq!(v["hits"], same[0]["hits"], "{scene} {w}");
                assert_eq!(v["sum_t"], same[0]["sum_t"], "{scene} {w}");
            }
        }
    }
}

#[test]
fn protocol_fields_come_first_in_protocol_order() {
    let o = bench(&[
        "--scene",
        "data/cornell.obj",
        "--size",
        "8x8",
        "--reps",
        "1",
        "--workloads",
        "shadow",
        "--modes",
        "packet4",
        "--accel",
        "kd8",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    let line = text.lines().next().expect("one line");
    let mut at = 0;
    for k in PROTOCOL_FIELDS {
        let pos = line[at..]
            .find(&format!("\"{k}\":"))
            .unwrap_or_else(|| panic!("`{k}` out of order in {line}"));
        at += pos + 1;
    }
    assert!(line.starts_with("{\"scene\":\"cornell\""), "{line}");
    assert!(line.contains("\"sum_t\":null"), "{line}");
    assert_eq!(text.lines().count(), 1);
}

/// A line's `rays`.
fn rays_of(v: &Value) -> u64 {
    v["rays"].as_u64().expect("rays")
}

// ---------------------------------------------------------------------------
// Agreement with a direct library computation
// ---------------------------------------------------------------------------

/// Hits and `sum_t` (ray order, f64) of closest-hit results.
fn tally(hits: &[Option<Hit>]) -> (u64, f64) {
    let n = hits.iter().flatten().count() as u64;
    (n, hits.iter().flatten().map(|h| h.t as f64).sum())
}

#[test]
fn bench_counts_equal_a_direct_library_computation_on_cornell() {
    let (w, h) = (64, 64);
    let lines = bench_json(&[
        "--scene",
        "data/cornell.obj",
        "--size",
        "64x64",
        "--reps",
        "1",
        "--accel",
        "kd8",
        "--no-stats",
    ]);
    assert_eq!(lines.len(), 4 * 6);

    // The same run by hand, through the library
    let path = root().join("data/cornell.obj");
    let mesh = load_obj(&path).unwrap();
    let triangles = mesh.triangle_count() as u64;
    let view = load_view(&path).unwrap();
    let frame = SceneFrame::of(&mesh);
    let camera = view.camera_or_auto(&frame.bounds);
    let light = view.light_or_default(&frame);
    let tree = KdTree::build(mesh, &KdBuildParams::packtrace()).unwrap();
    let primary = workload::primary(&camera, w, h).unwrap();
    let primary_hits: Vec<Option<Hit>> = primary.rays.iter().map(|r| tree.intersect(r)).collect();
    let occluded = |set: &RaySet| set.rays.iter().filter(|r| tree.occluded(r)).count() as u64;
    let shadow = workload::shadow(&primary, &primary_hits, tree.mesh(), &frame, light);
    let ao = workload::ao(&primary, &primary_hits, tree.mesh(), &frame);
    let random = workload::random(&frame, (w * h) as usize);
    let random_hits: Vec<Option<Hit>> = random.rays.iter().map(|r| tree.intersect(r)).collect();
    let expect = [
        (
            "primary",
            primary.len(),
            tally(&primary_hits).0,
            Some(tally(&primary_hits).1),
        ),
        ("shadow", shadow.len(), occluded(&shadow), None),
        ("ao", ao.len(), occluded(&ao), None),
        (
            "random",
            random.len(),
            tally(&random_hits).0,
            Some(tally(&random_hits).1),
        ),
    ];
    // Sanity: the Cornell box seen from its camera is mostly hit
    assert!(expect[0].2 > (w * h) as u64 * 8 / 10);
    for v in &lines {
        let (_, rays, hits, sum_t) = expect.iter().find(|e| e.0 == s(v, "workload")).unwrap();
        assert_eq!(u(v, "triangles"), triangles);
        assert_eq!(u(v, "rays"), *rays as u64, "{v}");
        assert_eq!(u(v, "hits"), *hits, "{v}");
        match sum_t {
            // serde_json parses floats to within an ulp
            Some(t) => assert!((f(v, "sum_t") - t).abs() <= 1e-12 * t, "{v} vs {t}"),
            None => assert!(v["sum_t"].is_null()),
        }
        // --no-stats: counters null, tree statistics still there
        assert!(v["nodes_per_ray"].is_null() && v["lane_utilisation"].is_null());
        assert_eq!(u(v, "nodes"), tree.node_count() as u64);
        assert_eq!(u(v, "tree_bytes"), tree.stats().bytes as u64);
    }
}

#[test]
fn threads_change_timings_not_answers() {
    let run = |threads: &str| {
        let mut v = bench_json(&[
            "--scene",
            "gen:sphere:3000",
            "--size",
            "32x32",
            "--reps",
            "1",
            "--threads",
            threads,
        ]);
        for line in &mut v {
            let o = line.as_object_mut().unwrap();
            for k in [
                "threads",
                "build_seconds",
                "build_mtris_per_s",
                "build_peak_bytes",
                "build_peak_rss_bytes",
                "seconds",
                "mrays_per_s",
                // the run's stamp: its command line names the thread count
                "command",
            ] {
                o.remove(k);
            }
        }
        v
    };
    assert_eq!(run("1"), run("2"));
}

// ---------------------------------------------------------------------------
// --check
// ---------------------------------------------------------------------------

#[test]
fn check_passes_on_every_data_scene() {
    for scene in data_scenes() {
        let scene = scene.to_str().unwrap();
        for threads in ["1", "2"] {
            let o = bench(&[
                "--scene",
                scene,
                "--size",
                "64x64",
                "--reps",
                "1",
                "--check",
                "--threads",
                threads,
            ]);
            let err = stderr(&o);
            assert!(o.status.success(), "{scene}: {err}");
            for w in ["primary", "shadow", "ao", "random"] {
                let ok = err
                    .lines()
                    .find(|l| l.starts_with("check ok:") && l.contains(&format!(" {w}: ")))
                    .unwrap_or_else(|| panic!("no check line for {w}:\n{err}"));
                // cornell is small enough for brute force at 64x64
                assert!(
                    ok.contains(
                        "kd8/packet4 kd8/packet8 kd8/stream kd8/group8x8 kd8/group16x16 \
                         bvh8/scalar bvh8/packet4 bvh8/packet8 bvh8/stream bvh2/scalar \
                         bvh2/packet4 bvh2/packet8 bvh2/stream bvh2-median/scalar \
                         bvh2-median/packet4 bvh2-median/packet8 bvh2-median/stream \
                         kd8-blocked/scalar kd8-blocked/packet4 kd8-blocked/packet8 \
                         kd8-blocked/stream kd8-inline/scalar kd8-inline/packet4 \
                         kd8-inline/packet8 kd8-inline/stream naive/scalar naive/packet4 \
                         naive/packet8 naive/stream brute/scalar"
                    ),
                    "{ok}"
                );
            }
            assert!(err.contains("--reps 1 is below"), "{err}");
        }
    }
}

#[test]
fn check_only_prints_no_json() {
    let o = bench(&[
        "--scene",
        "gen:jittered:800",
        "--size",
        "32x32",
        "--check-only",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
    assert_eq!(stderr(&o).matches("check ok:").count(), 4);
}

/// A scene test (`tests/common/scenes.rs` of the library): listed as
/// ignored by a plain `cargo test`, fails when run without its scene.
#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn check_passes_on_the_shared_bunny() {
    let dir = std::env::var_os("PACKTRACE_SCENES")
        .expect("this scene test needs PACKTRACE_SCENES, the shared scenes' directory");
    let bunny = Path::new(&dir).join("bunny.obj");
    assert!(
        bunny.is_file(),
        "PACKTRACE_SCENES is set but {} is missing",
        bunny.display()
    );
    let o = bench(&[
        "--scene",
        bunny.to_str().unwrap(),
        "--size",
        "256x256",
        "--check-only",
        "--threads",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o).matches("check ok:").count(), 4);
}

// ---------------------------------------------------------------------------
// Where the output goes: JSON lines when piped or asked for, else a table
// ---------------------------------------------------------------------------

/// A small run: one generated scene, two workloads, two modes, kd8 (4
/// results).
const SMALL: [&str; 14] = [
    "--scene",
    "gen:sphere:1k",
    "--size",
    "16x16",
    "--reps",
    "1",
    "--workloads",
    "primary,shadow",
    "--modes",
    "scalar,packet4",
    "--accel",
    "kd8",
    "--threads",
    "1",
];

/// `SMALL` followed by `extra`.
fn small<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    SMALL.iter().chain(extra).copied().collect()
}

/// The summary table: its title, its header and one row per workload of
/// `SMALL`.
fn assert_table(text: &str, what: &str) {
    let lines: Vec<&str> = text.lines().map(|l| l.trim_end_matches('\r')).collect();
    let title = lines
        .iter()
        .position(|l| *l == "Mrays/s")
        .unwrap_or_else(|| panic!("{what}: no table:\n{text}"));
    let head = lines[title + 1];
    assert!(
        head.starts_with("scene") && head.contains("scalar/kd8") && head.contains("packet4/kd8"),
        "{what}: {head}"
    );
    for w in ["primary", "shadow"] {
        assert!(
            lines[title + 2..]
                .iter()
                .any(|l| l.starts_with("gen:sphere:1k") && l.contains(w)),
            "{what}: no {w} row:\n{text}"
        );
    }
}

/// The JSON lines of `text` (every line must be one).
fn json_lines(text: &str, what: &str) -> Vec<Value> {
    text.lines()
        .map(|l| l.trim_end_matches('\r'))
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{what}: not JSON ({e}): {l}")))
        .collect()
}

#[test]
fn piped_stdout_gets_json_lines_and_stderr_the_table() {
    // `Command::output` pipes stdout, as `bench ... > file.jsonl` or the
    // shared harness's `bench ... 2>>err >> file.jsonl` does.
    let o = bench(&SMALL);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let out = String::from_utf8(o.stdout).unwrap();
    let lines = json_lines(&out, "piped");
    assert_eq!(lines.len(), 4, "{out}");
    for v in &lines {
        assert_eq!((s(v, "scene"), s(v, "accel")), ("gen:sphere:1k", "kd8"));
        assert_eq!((u(v, "width"), u(v, "height")), (16, 16));
    }
    assert_table(&err, "stderr");
    assert!(!err.contains("stdout is a terminal"), "{err}");
}

#[test]
fn json_dash_or_bare_json_prints_json_lines() {
    for extra in [
        &["--json", "-"][..],
        &["--json"][..],
        &["--json=-"][..],
        // a bare --json before another option takes no value from it
        &["--json", "--no-stats"][..],
    ] {
        let args: Vec<&str> = extra.iter().chain(&SMALL).copied().collect();
        let o = bench(&args);
        let err = stderr(&o);
        assert!(o.status.success(), "{extra:?}: {err}");
        let out = String::from_utf8(o.stdout).unwrap();
        assert_eq!(json_lines(&out, "--json -").len(), 4, "{extra:?}: {out}");
        assert_table(&err, "stderr");
    }
    assert!(
        !root().join("-").exists(),
        "--json - wrote a file named `-`"
    );
}

#[test]
fn json_path_writes_the_lines_to_the_file_too() {
    let json = temp_path("piped.jsonl");
    let o = bench(&small(&["--json", json.to_str().unwrap()]));
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let file = std::fs::read_to_string(&json).unwrap();
    std::fs::remove_file(&json).unwrap();
    let out = String::from_utf8(o.stdout).unwrap();
    assert_eq!(json_lines(&file, "file").len(), 4, "{file}");
    assert_eq!(out, file, "stdout and the --json file differ");
    assert_table(&err, "stderr");
}

#[test]
fn check_only_prints_no_table_and_no_json_anywhere() {
    let json = temp_path("check_only.jsonl");
    let o = bench(&[
        "--scene",
        "gen:sphere:1k",
        "--size",
        "16x16",
        "--check-only",
        "--json",
        json.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(o.stdout.is_empty());
    assert!(!err.contains("Mrays/s"), "{err}");
    assert_eq!(std::fs::read_to_string(&json).unwrap(), "");
    std::fs::remove_file(&json).unwrap();
}

/// Run `bench` with stdout on a pseudo-terminal (util-linux `script`),
/// stderr to a file; `None` when no pseudo-terminal can be had here.
/// Returns (status ok, stdout as the terminal saw it, stderr).
#[cfg(target_os = "linux")]
fn bench_on_a_terminal(args: &[&str], tag: &str) -> Option<(bool, String, String)> {
    let quote = |a: &str| format!("'{}'", a.replace('\'', r"'\''"));
    let probe = Command::new("script")
        .args(["-qec", "test -t 1", "/dev/null"])
        .output();
    if !probe.is_ok_and(|o| o.status.success()) {
        eprintln!("no pseudo-terminal (util-linux `script`): skipping the terminal checks");
        return None;
    }
    let err_path = temp_path(&format!("{tag}.err"));
    let mut cmd = quote(env!("CARGO_BIN_EXE_bench"));
    for a in args {
        cmd.push(' ');
        cmd.push_str(&quote(a));
    }
    cmd.push_str(&format!(" 2>{}", quote(err_path.to_str().unwrap())));
    let o = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .current_dir(root())
        .output()
        .expect("script runs");
    let err = std::fs::read_to_string(&err_path).unwrap_or_default();
    let _ = std::fs::remove_file(&err_path);
    Some((
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        err,
    ))
}

#[cfg(target_os = "linux")]
#[test]
fn a_terminal_gets_the_table_and_json_only_when_asked() {
    // Nothing asked: the table on stdout, no JSON; a note on stderr.
    let Some((ok, out, err)) = bench_on_a_terminal(&SMALL, "tty") else {
        return;
    };
    assert!(ok, "{err}");
    assert_table(&out, "terminal stdout");
    assert!(!out.contains('{'), "JSON on the terminal:\n{out}");
    assert!(!err.contains("Mrays/s\n"), "table on stderr too:\n{err}");
    assert!(err.contains("stdout is a terminal"), "{err}");

    // --json -: JSON lines on stdout, the table on stderr.
    let (ok, out, err) = bench_on_a_terminal(&small(&["--json", "-"]), "tty_dash").unwrap();
    assert!(ok, "{err}");
    assert_eq!(json_lines(&out, "--json - on a terminal").len(), 4, "{out}");
    assert_table(&err, "stderr with --json -");

    // --json PATH: the file gets the JSON lines, the terminal the table.
    let json = temp_path("tty.jsonl");
    let (ok, out, err) =
        bench_on_a_terminal(&small(&["--json", json.to_str().unwrap()]), "tty_path").unwrap();
    let file = std::fs::read_to_string(&json).unwrap_or_default();
    let _ = std::fs::remove_file(&json);
    assert!(ok, "{err}");
    assert_eq!(
        json_lines(&file, "--json PATH on a terminal").len(),
        4,
        "{file}"
    );
    assert_table(&out, "terminal stdout with --json PATH");
    assert!(!out.contains('{'), "JSON on the terminal:\n{out}");
}

// ---------------------------------------------------------------------------
// Bad input: one line on stderr, exit status 2
// ---------------------------------------------------------------------------

/// Run, expect exit status 2 with one `bench: error:` line containing
/// `needle`, nothing on stdout, and no panic.
fn expect_input_error(args: &[&str], needle: &str) {
    let o = bench(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(o.stdout.is_empty(), "{args:?}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.contains("error")).collect();
    assert_eq!(errors.len(), 1, "{args:?}: {err}");
    assert!(errors[0].starts_with("bench: error: "), "{err}");
    assert!(
        errors[0].contains(needle),
        "{args:?}: `{needle}` not in {err}"
    );
}

#[test]
fn missing_scene_names_the_file() {
    expect_input_error(
        &["--scene", "data/no_such_scene.obj", "--size", "8x8"],
        "data/no_such_scene.obj",
    );
    // An unreadable file (a directory where the view file should be):
    // the OS's reason once, as the error's source, not repeated by it.
    let obj = temp_path("unreadable_view.obj");
    let view = obj.with_extension("view");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::create_dir_all(&view).unwrap();
    let reason = std::fs::read(&view).unwrap_err().to_string();
    let o = bench(&["--scene", obj.to_str().unwrap(), "--size", "8x8"]);
    let err = stderr(&o);
    let _ = (std::fs::remove_file(&obj), std::fs::remove_dir(&view));
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.matches(&reason).count(), 1, "{err}");
    assert!(err.contains("cannot read the view file: "), "{err}");
    // checked before any other scene is run
    expect_input_error(
        &["--scene", "data/cornell.obj", "--scene", "nowhere/x.obj"],
        "nowhere/x.obj",
    );
}

#[test]
fn malformed_obj_names_the_file() {
    let bad = temp_path("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    let name = bad.to_str().unwrap();
    expect_input_error(&["--scene", name, "--size", "8x8"], name);
    std::fs::write(&bad, "v 0 0 0\n").unwrap();
    expect_input_error(&["--scene", name, "--size", "8x8"], name);
    std::fs::remove_file(&bad).unwrap();
}

#[test]
fn preset_and_thread_lists_run_every_combination() {
    // One tiny primary-ray run of kd8 scalar; `extra` picks presets etc.
    let tiny = |scene: &str, size: &str, extra: &[&str]| {
        let mut args = vec![
            "--scene",
            scene,
            "--size",
            size,
            "--reps",
            "1",
            "--workloads",
            "primary",
            "--modes",
            "scalar",
            "--accel",
            "kd8",
            "--json",
        ];
        args.extend_from_slice(extra);
        bench_json(&args)
    };
    let lines = tiny(
        "gen:sphere:2000",
        "16x16",
        &[
            "--preset",
            "packtrace,dynamic",
            "--threads",
            "1,2",
            "--set",
            "bins=16",
        ],
    );
    let got: Vec<(String, u64)> = lines
        .iter()
        .map(|l| (s(l, "preset").to_string(), u(l, "threads")))
        .collect();
    let want: Vec<(String, u64)> = [
        ("packtrace", 1),
        ("packtrace", 2),
        ("dynamic", 1),
        ("dynamic", 2),
    ]
    .iter()
    .map(|&(p, t)| (p.to_string(), t))
    .collect();
    assert_eq!(got, want);
    for l in &lines {
        assert!(s(l, "params").contains("bins: 16"), "{l}");
        let rate = f(l, "build_mtris_per_s");
        assert!(rate > 0.0 && rate.is_finite(), "{l}");
        assert!(
            l["build_peak_bytes"].is_null() || l["build_peak_bytes"].is_u64(),
            "{l}"
        );
    }
    // The same tree for either thread count, per preset.
    assert_eq!(u(&lines[0], "nodes"), u(&lines[1], "nodes"));
    assert_eq!(u(&lines[2], "nodes"), u(&lines[3], "nodes"));
    assert_ne!(u(&lines[0], "nodes"), u(&lines[2], "nodes"));
    // `all` is every preset.
    let all = tiny("gen:sphere:500", "8x8", &["--preset", "all", "--no-stats"]);
    let names: Vec<&str> = all.iter().map(|l| s(l, "preset")).collect();
    assert_eq!(
        names,
        ["packtrace", "dynamic", "pbrt", "mitsuba", "fast_build"]
    );
}

#[test]
fn bad_option_values_exit_2() {
    let c = ["--scene", "data/cornell.obj"];
    let with =
        |extra: &[&'static str]| -> Vec<&'static str> { c.iter().chain(extra).copied().collect() };
    expect_input_error(&with(&["--size", "63x64"]), "63x64");
    expect_input_error(&with(&["--size", "64x0"]), "even");
    expect_input_error(&with(&["--size", "64"]), "WxH");
    expect_input_error(
        &with(&["--workloads", "primary,shade"]),
        "unknown workload `shade`",
    );
    expect_input_error(&with(&["--modes", "packet16"]), "packet16");
    expect_input_error(&with(&["--accel", "bvh"]), "bvh");
    expect_input_error(&with(&["--preset", "fastest"]), "unknown preset `fastest`");
    expect_input_error(
        &with(&["--set", "depth=3"]),
        "unknown build parameter `depth`",
    );
    expect_input_error(
        &with(&["--set", "bins=1"]),
        "bins = 1 (must be in 2..=4096)",
    );
    expect_input_error(&with(&["--reps", "0"]), "--reps");
    expect_input_error(&with(&["--threads", "0"]), "--threads");
    expect_input_error(&with(&["--camera", "0,0,1,0,0,0,0,1,0"]), "camera");
    expect_input_error(&with(&["--light", "1,2"]), "light");
    expect_input_error(&with(&["--bogus"]), "--bogus");
    expect_input_error(&["--scene", "gen:cube:10"], "gen:cube:10");
    expect_input_error(&["--scaling", "--scene", "data/cornell.obj"], "--scaling");
    expect_input_error(&["--scaling", "--scaling-sizes", "1e3,x"], "`x`");
    expect_input_error(
        &[
            "--scene",
            "gen:sphere:100k",
            "--size",
            "512x512",
            "--accel",
            "brute",
        ],
        "--force",
    );
}

#[test]
fn negative_camera_and_light_values_parse() {
    let lines = bench_json(&[
        "--scene",
        "gen:sphere:200",
        "--camera",
        "-0.5,0.2,-3,0,0,0,0,1,0,40",
        "--light",
        "-2,3,-4",
        "--size",
        "8x8",
        "--reps",
        "1",
        "--workloads",
        "primary,shadow",
        "--modes",
        "scalar",
        "--accel",
        "kd8",
    ]);
    assert_eq!(lines.len(), 2);
    assert!(u(&lines[0], "hits") > 0);
}

#[test]
fn help_exits_0() {
    let o = bench(&["--help"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for opt in ["--scene", "--check", "--scaling", "--threads", "--json"] {
        assert!(text.contains(opt), "{opt}");
    }
    // the protocol it follows, and the one-thread default against render's
    assert!(text.contains("docs/PROTOCOL.md"), "{text}");
    assert!(!text.contains("BENCH_PROTOCOL"), "{text}");
    assert!(text.contains("1 thread by default"), "{text}");
    assert!(text.contains("render uses every core"), "{text}");
    assert!(text.contains("[default: 1024x1024]"), "{text}");
}

#[test]
fn scaling_reports_each_size() {
    let lines = bench_json(&[
        "--scaling",
        "--scaling-sizes",
        "1e3,3k",
        "--size",
        "16x16",
        "--reps",
        "1",
    ]);
    let scenes: Vec<&str> = lines.iter().map(|v| s(v, "scene")).collect();
    assert_eq!(
        scenes,
        [["gen:scalable:1000"; 6], ["gen:scalable:3000"; 6]].concat()
    );
    for v in &lines {
        assert_eq!((s(v, "workload"), s(v, "accel")), ("primary", "kd8"));
        assert!(f(v, "bytes_per_triangle") > 0.0 && u(v, "max_depth") > 0);
    }
    let modes: Vec<&str> = lines[..6].iter().map(|v| s(v, "mode")).collect();
    assert_eq!(
        modes,
        [
            "scalar",
            "packet4",
            "packet8",
            "stream",
            "group8x8",
            "group16x16"
        ]
    );
}

// ---------------------------------------------------------------------------
// Secondary rays against the protocol's formulas in f64
// ---------------------------------------------------------------------------

/// The protocol's hash in `u64` with explicit masking (an independent
/// implementation of the `u32` wrapping version).
fn hash64(v: u64) -> u64 {
    const M: u64 = 0xffff_ffff;
    let s = (v.wrapping_mul(747796405).wrapping_add(2891336453)) & M;
    let w = (((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277803737)) & M;
    (w >> 22) ^ w
}

fn unit64(h: u64) -> f64 {
    (h >> 8) as f64 / 16777216.0
}

fn d(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

fn assert_close(got: Vec3, want: DVec3, tol: f64, what: &str) {
    assert!(
        (d(got) - want).abs().max_element() <= tol,
        "{what}: {got} vs {want}"
    );
}

/// The protocol's cosine-weighted direction of sample `k` of pixel `p`
/// around `n`, with the Duff et al. basis, all in f64.
fn ao_dir64(p: u64, k: u64, n: DVec3) -> DVec3 {
    let s = hash64((p * 16 + k) & 0xffff_ffff);
    let (u1, u2) = (unit64(s), unit64(hash64(s)));
    let rr = u1.sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let (lx, ly, lz) = (rr * phi.cos(), rr * phi.sin(), (1.0 - u1).max(0.0).sqrt());
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let b1 = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let b2 = DVec3::new(b, sign + n.y * n.y * a, -n.y);
    (b1 * lx + b2 * ly + n * lz).normalize()
}

#[test]
fn random_rays_match_the_protocol_in_f64() {
    let bounds = Aabb::new(Vec3A::new(-1.0, 0.0, 2.0), Vec3A::new(3.0, 1.0, 4.0));
    let frame = SceneFrame::from_bounds(bounds);
    let set = workload::random(&frame, 4096);
    let (min, max) = (DVec3::new(-1.0, 0.0, 2.0), DVec3::new(3.0, 1.0, 4.0));
    for i in (0..4096u64).step_by(37) {
        let s: Vec<f64> = (0..5).map(|j| unit64(hash64(i * 8 + j))).collect();
        let z = 1.0 - 2.0 * s[0];
        let rr = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * s[1];
        let dir = DVec3::new(rr * phi.cos(), rr * phi.sin(), z);
        let origin = min + DVec3::new(s[2], s[3], s[4]) * (max - min);
        let r = set.rays[i as usize];
        // f32 rounding of 1 - z^2 near the poles costs a few ulps of rr
        assert_close(r.dir(), dir, 2e-6, &format!("ray {i} dir"));
        assert_close(r.origin(), origin, 1e-6, &format!("ray {i} origin"));
        assert_eq!((r.t_min(), r.t_max()), (0.0, f32::INFINITY));
    }
    assert_eq!(set.packets[5], [20, 21, 22, 23]);
}

#[test]
fn ao_directions_match_the_protocol_in_f64() {
    let normals = [
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::X,
        Vec3::NEG_Y,
        Vec3::new(0.3, -0.5, 0.8).normalize(),
        Vec3::new(0.6, 0.8, -0.0),
        Vec3::new(-0.2, 0.1, -0.97).normalize(),
    ];
    for n in normals {
        for p in [0u32, 1, 77, 4095, 1 << 20, (1 << 28) + 5] {
            for k in 0..4 {
                let got = sampling::ao_direction(p, k, n);
                let want = ao_dir64(p as u64, k as u64, d(n));
                assert_close(got, want, 2e-6, &format!("p {p} k {k} n {n}"));
            }
        }
    }
}

#[test]
fn shadow_and_ao_rays_match_the_protocol_in_f64() {
    // One tilted triangle; pixel 0 misses, pixel 1 hits it from below
    // (so the normal is flipped toward the ray).
    let corners = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(2.0, 0.5, 0.3),
        Vec3::new(0.2, 1.5, -0.4),
    ];
    let mesh = Mesh::new(corners.to_vec(), vec![[0, 1, 2]]).unwrap();
    let frame = SceneFrame::of(&mesh);
    let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
    let miss = Ray::new(Vec3::new(9.0, 9.0, 9.0), Vec3::X, 0.0, f32::INFINITY).unwrap();
    let hit_ray = Ray::new(
        Vec3::new(0.6, 0.5, -3.0),
        Vec3::new(0.05, 0.1, 1.0).normalize(),
        0.0,
        f32::INFINITY,
    )
    .unwrap();
    let primary = RaySet {
        rays: vec![miss, hit_ray],
        packets: vec![[0, 1, NO_RAY, NO_RAY]],
        packets8: vec![[0, 1, NO_RAY, NO_RAY, NO_RAY, NO_RAY, NO_RAY, NO_RAY]],
        ..RaySet::default()
    };
    let hits: Vec<Option<Hit>> = primary.rays.iter().map(|r| tree.intersect(r)).collect();
    assert!(hits[0].is_none());
    let t = hits[1].expect("the tilted triangle is hit").t as f64;

    // Q = P + n * 1e-4 D in f64, n facing the ray
    let c: Vec<DVec3> = corners.iter().map(|&v| d(v)).collect();
    let diagonal = (c[1].max(c[2]).max(c[0]) - c[1].min(c[2]).min(c[0])).length();
    let mut n = (c[1] - c[0]).cross(c[2] - c[0]).normalize();
    if n.dot(d(hit_ray.dir())) > 0.0 {
        n = -n;
    }
    assert!(n.z < 0.0, "the ray comes from -z");
    let q = d(hit_ray.origin()) + t * d(hit_ray.dir()) + n * (1e-4 * diagonal);

    let light = Vec3::new(1.0, 0.5, -2.0);
    let sh = workload::shadow(&primary, &hits, &mesh, &frame, light);
    assert_eq!(sh.len(), 1);
    assert_eq!(sh.packets, vec![[NO_RAY, 0, NO_RAY, NO_RAY]]);
    let to_light = d(light) - q;
    let r = sh.rays[0];
    assert_close(r.origin(), q, 1e-6, "shadow origin");
    assert_close(r.dir(), to_light.normalize(), 1e-6, "shadow dir");
    assert_eq!(r.t_min(), 0.0);
    let t_max = to_light.length() * (1.0 - 1e-4);
    assert!(
        ((r.t_max() as f64) - t_max).abs() <= 1e-6 * t_max,
        "{} vs {t_max}",
        r.t_max()
    );

    let ao = workload::ao(&primary, &hits, &mesh, &frame);
    assert_eq!(ao.len(), 4);
    for k in 0..4u32 {
        let r = ao.rays[k as usize];
        assert_close(r.origin(), q, 1e-6, "ao origin");
        // pixel index p = 1
        assert_close(
            r.dir(),
            ao_dir64(1, k as u64, n),
            2e-6,
            &format!("ao dir {k}"),
        );
        assert_eq!(r.t_min(), 0.0);
        assert!((r.t_max() as f64 - 0.25 * diagonal).abs() <= 1e-6 * diagonal);
        assert_eq!(ao.packets[k as usize], [NO_RAY, k, NO_RAY, NO_RAY]);
    }
}

#[test]
fn blocked_order_inline_leaves_and_a_copied_tree_give_kd8_answers() {
    // kd8 through a copy of the built tree, beside the blocked order and
    // the inline leaves: the same hits and the same sum of distances on
    // every workload.
    let rows = bench_json(&[
        "--scene",
        "gen:cornell",
        "--size",
        "32x32",
        "--reps",
        "1",
        "--accel",
        "kd8,kd8-blocked,kd8-inline",
        "--modes",
        "scalar,packet8",
        "--copy-tree",
        "--check",
    ]);
    for w in ["primary", "shadow", "ao", "random"] {
        let of = |accel: &str| -> Vec<(u64, Option<f64>)> {
            rows.iter()
                .filter(|r| r["workload"] == w && r["accel"] == accel)
                .map(|r| (r["hits"].as_u64().unwrap(), r["sum_t"].as_f64()))
                .collect()
        };
        let (kd8, blocked, inline) = (of("kd8"), of("kd8-blocked"), of("kd8-inline"));
        assert_eq!(kd8.len(), 2, "{w}: one row per mode");
        assert_eq!(kd8, blocked, "{w}");
        assert_eq!(kd8, inline, "{w}");
        assert!(kd8[0].0 > 0, "{w}: some rays hit");
    }
}

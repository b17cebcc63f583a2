//! Peer engines through `bench`: `--check` holds each to the protocol's
//! agreement with scalar kd8 (hit counts and summed `t`), in every mode
//! it has, and their JSON lines carry the protocol's fields. obvhs is
//! always compiled in; Embree and tinybvh are tested when their features
//! are on (`.ci/run` runs this file with `--features embree,tinybvh`).
//! Also the errors of asking for an engine wrongly.

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn bench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bench"))
        .args(args)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap())
        .output()
        .expect("bench runs")
}

/// The one `bench: error:` line of a refused run (exit status 2).
fn refused(args: &[&str]) -> String {
    let o = bench(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err.lines()
        .find(|l| l.starts_with("bench: error: "))
        .unwrap_or_else(|| panic!("no error line: {err}"))
        .to_string()
}

/// `bench --check` with `accels` beside kd8 on a small Cornell box;
/// requires success and returns (stderr, JSON lines of the peers).
fn checked_run(accels: &str) -> (String, Vec<Value>) {
    let accel = format!("kd8,{accels}");
    let o = bench(&[
        "--scene",
        "data/cornell.obj",
        "--size",
        "128x128",
        "--reps",
        "1",
        "--modes",
        "scalar,packet4,packet8",
        "--accel",
        &accel,
        "--check",
        "--json",
        "-",
    ]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{accel}: {err}");
    let lines = String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter(|v| v["accel"] != "kd8")
        .collect();
    (err, lines)
}

/// Every (workload, mode) of `accel` was checked and timed, and its lines
/// carry the protocol's fields and the fingerprint of kd8's lines.
fn assert_checked(err: &str, lines: &[Value], accel: &str, modes: &[&str]) {
    for w in ["primary", "shadow", "ao", "random"] {
        for m in modes {
            let ok = format!("cornell {w}: {accel}/{m} agrees with kd8/scalar");
            assert!(err.contains(&ok), "`{ok}` not in:\n{err}");
            let line = lines
                .iter()
                .find(|v| v["accel"] == accel && v["workload"] == w && v["mode"] == *m)
                .unwrap_or_else(|| panic!("no line {accel} {w} {m}"));
            for k in ["rays", "hits", "seconds", "mrays_per_s", "build_seconds"] {
                assert!(line[k].is_number(), "{k}: {line}");
            }
            assert_eq!(
                line["sum_t"].is_null(),
                w == "shadow" || w == "ao",
                "{line}"
            );
            assert!(line["fingerprint"].as_str().is_some_and(|f| f.len() == 16));
            assert!(line["engine"].as_str().is_some(), "{line}");
        }
    }
}

#[test]
fn obvhs_agrees_with_kd8_under_check() {
    let (err, lines) = checked_run("obvhs");
    assert_checked(&err, &lines, "obvhs", &["scalar"]);
    // The closing table compares every engine.
    assert!(err.contains("obvhs scalar"), "{err}");
}

#[cfg(feature = "embree")]
#[test]
fn embree_agrees_with_kd8_in_every_mode() {
    let (err, lines) = checked_run("embree,embree-coherent");
    assert_checked(&err, &lines, "embree", &["scalar", "packet4", "packet8"]);
    assert_checked(&err, &lines, "embree-coherent", &["packet4", "packet8"]);
    // The closing table gives ratios to Embree's best.
    assert!(err.contains("ratio to Embree's best"), "{err}");
    assert!(err.contains("best embree"), "{err}");
}

/// tinybvh-rs has BVH8_CPU's traversal only in builds with AVX2
/// (`RUSTFLAGS="-C target-cpu=native"`).
#[cfg(all(feature = "tinybvh", target_feature = "avx2"))]
#[test]
fn tinybvh_agrees_with_kd8_under_check() {
    let (err, lines) = checked_run("tinybvh");
    assert_checked(&err, &lines, "tinybvh", &["scalar"]);
}

#[cfg(all(feature = "tinybvh", not(target_feature = "avx2")))]
#[test]
fn tinybvh_without_avx2_says_how_to_build_it() {
    let e = refused(&["--scene", "data/cornell.obj", "--accel", "kd8,tinybvh"]);
    assert!(e.contains("target-cpu=native"), "{e}");
}

#[test]
fn an_unknown_engine_lists_the_engines() {
    let e = refused(&["--scene", "data/cornell.obj", "--accel", "kd8,optix"]);
    assert!(e.contains("optix"), "{e}");
    for known in ["kd8", "embree", "embree-coherent", "obvhs", "tinybvh"] {
        assert!(e.contains(known), "{known} not listed: {e}");
    }
}

#[test]
fn an_engine_not_compiled_in_names_its_feature() {
    let mut missing = Vec::new();
    if !cfg!(feature = "embree") {
        missing.extend(["embree", "embree-coherent"]);
    }
    if !cfg!(feature = "tinybvh") {
        missing.push("tinybvh");
    }
    for accel in missing {
        let e = refused(&["--scene", "data/cornell.obj", "--accel", accel]);
        let feature = if accel == "tinybvh" {
            "tinybvh"
        } else {
            "embree"
        };
        assert!(e.contains(&format!("accel {accel} is not compiled")), "{e}");
        assert!(e.contains(&format!("--features {feature}")), "{e}");
    }
}

#[test]
fn a_missing_scene_says_what_to_give() {
    let e = refused(&["--scene", "data/nowhere.obj", "--accel", "kd8,obvhs"]);
    assert!(e.contains("data/nowhere.obj"), "{e}");
    assert!(e.contains("--scene takes"), "{e}");
}

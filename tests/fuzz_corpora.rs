//! The fuzz targets' corpora replayed as ordinary tests: every input in
//! `fuzz/seeds/<target>/` (committed: the seeds every campaign starts
//! from) and, where a campaign left them, `fuzz/corpus/<target>/` and
//! the minimised crashes in `fuzz/artifacts/<target>/` (ignored by git),
//! through the target's own checks (`fuzz/checks/<target>.rs`, the body
//! of `fuzz/fuzz_targets/<target>.rs`). So `cargo test` (and CI) runs
//! what the fuzzers assert on what they found, without nightly or
//! libFuzzer. The inputs of the fuzzers' findings are also literal cases
//! of `tests/regressions.rs`.

#[path = "../fuzz/checks/obj.rs"]
#[allow(dead_code)]
mod obj;
#[path = "../fuzz/checks/trace.rs"]
#[allow(dead_code)]
mod trace;

use std::path::{Path, PathBuf};

/// The inputs of one target: the committed seeds (there must be some)
/// and any local corpus and artifacts, sorted by path.
fn inputs(target: &str) -> Vec<PathBuf> {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut files = Vec::new();
    let mut seeds = 0;
    for dir in ["seeds", "corpus", "artifacts"] {
        let Ok(entries) = std::fs::read_dir(fuzz.join(dir).join(target)) else {
            assert!(dir != "seeds", "fuzz/seeds/{target} is missing");
            continue;
        };
        for e in entries {
            let p = e.unwrap().path();
            if p.is_file() {
                seeds += usize::from(dir == "seeds");
                files.push(p);
            }
        }
    }
    assert!(seeds > 0, "fuzz/seeds/{target} holds no input");
    files.sort();
    files
}

/// Every input through `check`; the failures are collected and reported
/// together, each with its file.
fn replay(target: &str, check: fn(&[u8])) {
    let files = inputs(target);
    let mut failures = Vec::new();
    for path in &files {
        let data = std::fs::read(path).unwrap();
        if let Err(p) = std::panic::catch_unwind(|| check(&data)) {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            failures.push(format!("{}: {msg}", path.display()));
        }
    }
    println!("{target}: {} inputs replayed", files.len());
    assert!(
        failures.is_empty(),
        "{} of {} {target} inputs fail the target's checks:\n{}",
        failures.len(),
        files.len(),
        failures.join("\n")
    );
}

#[test]
fn obj_corpus_passes_the_obj_target() {
    replay("obj", obj::check);
}

#[test]
fn trace_corpus_passes_the_trace_target() {
    replay("trace", trace::check);
}

/// The replay reaches both sides of the targets' checks: the OBJ seeds
/// hold files that load and files that are refused.
#[test]
fn the_obj_seeds_hold_valid_and_invalid_files() {
    let (mut ok, mut err) = (0, 0);
    for p in inputs("obj")
        .iter()
        .filter(|p| p.starts_with(Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds")))
    {
        match packtrace::parse_obj_bytes(&std::fs::read(p).unwrap()) {
            Ok(_) => ok += 1,
            Err(_) => err += 1,
        }
    }
    assert!(ok > 0 && err > 0, "{ok} seeds load, {err} are refused");
}

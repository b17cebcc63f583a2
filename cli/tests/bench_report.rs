//! `bench report` on a recorded fixture (`fixtures/report/run.jsonl`):
//! the markdown it writes, to the letter (`fixtures/report/report.md`,
//! `fixtures/report/index.md`), and its SVG charts, parsed as XML with
//! their bars counted.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/report")
}

/// `bench report run.jsonl --out OUT --index OUT/index.md`, from the
/// fixture folder (so the file name in the tables is `run.jsonl`).
fn report(out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bench"))
        .arg("report")
        .arg("run.jsonl")
        .arg("--out")
        .arg(out)
        .arg("--index")
        .arg(out.join("index.md"))
        .args(extra)
        .current_dir(fixtures())
        .output()
        .expect("bench runs")
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("packtrace-report-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The bars of a chart: `<rect>`s filled with a colour other than the
/// white background and legend box (legend swatches are circles).
fn bars(svg: &str) -> usize {
    let doc = roxmltree::Document::parse(svg).expect("well-formed SVG");
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    doc.descendants()
        .filter(|n| n.has_tag_name("rect"))
        .filter(|n| {
            let fill = n.attribute("fill").unwrap_or("none").to_ascii_uppercase();
            fill != "NONE" && fill != "#FFFFFF" && fill != "WHITE"
        })
        .count()
}

#[test]
fn the_report_of_the_fixture_is_the_recorded_text() {
    let out = temp_dir("text");
    let o = report(&out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The out folder appears in the report's first line: name it as the
    // recorded text does.
    let normalise = |s: String| s.replace(&out.display().to_string(), "OUT");
    for (got, want) in [("report.md", "report.md"), ("index.md", "index.md")] {
        let got = normalise(std::fs::read_to_string(out.join(got)).unwrap());
        let want = std::fs::read_to_string(fixtures().join(want)).unwrap();
        assert_eq!(got, want, "{}", out.join("report.md").display());
    }
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn the_charts_are_svg_with_one_bar_per_line() {
    let out = temp_dir("svg");
    let o = report(&out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = |f: &str| std::fs::read_to_string(out.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    // box, 1 thread: 5 engines x 2 workloads.
    assert_eq!(bars(&svg("box-1t-mrays.svg")), 10);
    // kd8 packet8 over kd8 scalar and embree packet8 over embree scalar,
    // on 2 workloads; embree-coherent has no scalar line.
    assert_eq!(bars(&svg("box-1t-speedup.svg")), 4);
    // ball: 2 engines x 1 workload; no packet line, no speed-up chart.
    assert_eq!(bars(&svg("ball-1t-mrays.svg")), 2);
    assert!(!out.join("ball-1t-speedup.svg").exists());
    // box at 1 and 2 threads: a scaling chart; build and scaling charts
    // are lines, no bars.
    assert_eq!(bars(&svg("box-threads.svg")), 0);
    assert_eq!(bars(&svg("build.svg")), 0);
    assert!(!out.join("ball-threads.svg").exists());
    // Engines' names are in the legend.
    assert!(svg("box-1t-mrays.svg").contains("embree-coherent packet8"));
    // The summary: kd8's best over embree's best (embree-coherent is
    // embree's) on box primary and box shadow; none on ball, where the
    // two engines traced different rays (fingerprints cccc, dddd).
    assert_eq!(bars(&svg("summary.svg")), 2);
    assert!(svg("summary.svg").contains("kd8 best"));
    assert!(!svg("summary.svg").contains("embree-coherent best"));
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn report_errors_name_the_file_and_line() {
    let out = temp_dir("bad");
    let bad = out.with_extension("jsonl");
    std::fs::write(&bad, "{\"scene\":\"s\",\"workload\":\"primary\"}\n").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_bench"))
        .args([
            "report",
            bad.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("{}:1: no `mode`", bad.display())),
        "{err}"
    );
    let o = Command::new(env!("CARGO_BIN_EXE_bench"))
        .args(["report", "no/such.jsonl", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.starts_with("bench: error: no/such.jsonl: "), "{err}");
    // No file: clap says what is missing.
    let o = Command::new(env!("CARGO_BIN_EXE_bench"))
        .args(["report", "--out", "x"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let _ = std::fs::remove_file(&bad);
}

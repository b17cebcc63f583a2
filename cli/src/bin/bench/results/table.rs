//! Tables of recorded runs, as markdown (the report) or aligned text (the
//! bench's closing comparison): Mrays/s per engine and workload with the
//! ratio to the baseline's best, build seconds with their ratio, bytes per
//! triangle, and the runs' stamps.

use super::record::{Record, Stamp};

/// Rows of cells under a header; columns of figures are right-aligned,
/// the others left-aligned.
pub struct Table {
    /// Column names.
    pub head: Vec<String>,
    /// Rows, each as long as `head`.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// Is column `i` figures (every cell but `-` opens with a number)?
    fn figures(&self, i: usize) -> bool {
        let mut cells = self
            .rows
            .iter()
            .map(|r| r[i].as_str())
            .filter(|c| *c != "-");
        let number = |c: &str| {
            c.split(' ')
                .next()
                .is_some_and(|n| n.parse::<f64>().is_ok())
        };
        i > 0 && cells.all(number)
    }

    /// As a markdown table.
    pub fn markdown(&self) -> String {
        let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
        let mut out = line(&self.head);
        let rule: Vec<String> = (0..self.head.len())
            .map(|i| if self.figures(i) { "---:" } else { "---" }.to_string())
            .collect();
        out += &line(&rule);
        for r in &self.rows {
            out += &line(r);
        }
        out
    }

    /// As text in aligned columns.
    pub fn text(&self) -> String {
        let width = |i: usize| {
            std::iter::once(&self.head)
                .chain(&self.rows)
                .map(|r| r[i].chars().count())
                .max()
                .unwrap_or(0)
        };
        let widths: Vec<usize> = (0..self.head.len()).map(width).collect();
        let line = |cells: &[String]| {
            let parts: Vec<String> = cells
                .iter()
                .zip(&widths)
                .enumerate()
                .map(|(i, (c, &w))| {
                    let pad = " ".repeat(w - c.chars().count());
                    if i == 0 {
                        format!("{c}{pad}")
                    } else {
                        format!("{pad}{c}")
                    }
                })
                .collect();
            parts.join("  ").trim_end().to_string() + "\n"
        };
        let mut out = line(&self.head);
        for r in &self.rows {
            out += &line(r);
        }
        out
    }
}

/// Records of one scene at one thread count and image size: what one
/// speed table and one chart show.
pub struct Group<'a> {
    /// Scene name.
    pub scene: &'a str,
    /// Its triangles.
    pub triangles: u64,
    /// Threads.
    pub threads: u64,
    /// Image size.
    pub size: (u64, u64),
    /// The lines, in recorded order (a later line of the same engine and
    /// workload replaces an earlier one).
    pub records: Vec<&'a Record>,
}

impl Group<'_> {
    /// `scene (N triangles, WxH, T thread(s))`.
    pub fn title(&self) -> String {
        format!(
            "{} ({} triangles, {}x{}, {} thread{})",
            self.scene,
            self.triangles,
            self.size.0,
            self.size.1,
            self.threads,
            if self.threads == 1 { "" } else { "s" }
        )
    }

    /// Workloads in first-seen order.
    pub fn workloads(&self) -> Vec<&str> {
        first_seen(self.records.iter().map(|r| r.workload.as_str()))
    }

    /// Engines (`accel mode`) in first-seen order.
    pub fn engines(&self) -> Vec<String> {
        first_seen(self.records.iter().map(|r| r.engine()))
    }

    /// The line of `engine` on `workload`, the last recorded.
    pub fn line(&self, engine: &str, workload: &str) -> Option<&Record> {
        self.records
            .iter()
            .rev()
            .find(|r| r.workload == workload && r.engine() == engine)
            .copied()
    }

    /// The baseline's fastest line on `workload`.
    pub fn best_of(&self, baseline: &str, workload: &str) -> Option<&Record> {
        self.records
            .iter()
            .filter(|r| r.workload == workload && r.is_of(baseline))
            .max_by(|a, b| a.mrays.total_cmp(&b.mrays))
            .copied()
    }
}

/// `items` without repeats, in first-seen order.
pub fn first_seen<T: PartialEq>(items: impl Iterator<Item = T>) -> Vec<T> {
    let mut out = Vec::new();
    for i in items {
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

/// Records grouped by (scene, threads, size), in first-seen order.
pub fn groups(records: &[Record]) -> Vec<Group<'_>> {
    let mut out: Vec<Group> = Vec::new();
    for r in records {
        match out
            .iter_mut()
            .find(|g| g.scene == r.scene && g.threads == r.threads && g.size == r.size)
        {
            Some(g) => g.records.push(r),
            None => out.push(Group {
                scene: &r.scene,
                triangles: r.triangles,
                threads: r.threads,
                size: r.size,
                records: vec![r],
            }),
        }
    }
    // Each scene's thread counts together, fewest first.
    let scenes = first_seen(records.iter().map(|r| r.scene.as_str()));
    out.sort_by_key(|g| (scenes.iter().position(|s| *s == g.scene), g.threads));
    out
}

/// The runs' labels (`--label`), each once.
pub fn labels(records: &[Record]) -> Vec<&str> {
    first_seen(records.iter().map(|r| r.stamp.label.as_str()))
        .into_iter()
        .filter(|l| !l.is_empty())
        .collect()
}

/// Did two lines trace the same rays? Lines without a fingerprint (other
/// harnesses) are taken at their word.
fn comparable(a: &Record, b: &Record) -> bool {
    match (&a.fingerprint, &b.fingerprint) {
        (Some(x), Some(y)) => x == y,
        _ => true,
    }
}

/// `value (ratio×)`, or `value (n/c)` when the lines traced other rays.
fn with_ratio(value: String, ratio: Option<Option<f64>>) -> String {
    match ratio {
        None => value,
        Some(Some(r)) => format!("{value} ({r:.2}×)"),
        Some(None) => format!("{value} (n/c)"),
    }
}

/// One group's speed table: a row per engine, Mrays/s per workload with
/// the ratio to the baseline's best on that workload (when the baseline
/// ran), build seconds with their ratio to the baseline's, bytes per
/// triangle; a last row with the baseline's best of each workload.
pub fn speed(group: &Group, baseline: Option<&str>) -> Table {
    let workloads = group.workloads();
    let baseline = baseline.filter(|b| group.records.iter().any(|r| r.is_of(b)));
    let mut head = vec!["engine".to_string()];
    head.extend(workloads.iter().map(|w| format!("{w} Mrays/s")));
    head.extend(["build s".into(), "B/tri".into()]);
    let base_build = baseline.and_then(|b| {
        group
            .records
            .iter()
            .filter(|r| r.is_of(b))
            .filter_map(|r| r.build_seconds)
            .reduce(f64::min)
    });
    let mut rows = Vec::new();
    for engine in group.engines() {
        let mut row = vec![engine.clone()];
        let mut any = None;
        for w in &workloads {
            row.push(match group.line(&engine, w) {
                None => "-".into(),
                Some(r) => {
                    any = Some(r);
                    let best = baseline.and_then(|b| group.best_of(b, w));
                    let ratio = best.map(|b| comparable(r, b).then(|| r.mrays / b.mrays));
                    with_ratio(format!("{:.2}", r.mrays), ratio)
                }
            });
        }
        let r = any.expect("an engine has a line");
        row.push(match r.build_seconds {
            None => "-".into(),
            Some(s) => with_ratio(
                format!("{s:.3}"),
                base_build.map(|b| (b > 0.0).then(|| s / b)),
            ),
        });
        row.push(
            r.bytes_per_triangle
                .map_or("-".into(), |b| format!("{b:.1}")),
        );
        rows.push(row);
    }
    if let Some(b) = baseline {
        let mut row = vec![format!("best {b}")];
        for w in &workloads {
            row.push(
                group
                    .best_of(b, w)
                    .map_or("-".into(), |r| format!("{:.2} ({})", r.mrays, r.engine())),
            );
        }
        row.extend(["-".into(), "-".into()]);
        rows.push(row);
    }
    Table { head, rows }
}

/// Is the line packtrace's (not a peer's)?
pub fn is_packtrace(r: &Record) -> bool {
    !["embree", "obvhs", "tinybvh", "bvh"]
        .iter()
        .any(|p| r.is_of(p))
}

/// The headline: per group and workload, packtrace's best line beside the
/// baseline's best, and their ratio.
pub fn headline(groups: &[Group], baseline: &str) -> Table {
    let head = [
        "scene",
        "workload",
        "packtrace best",
        "Mrays/s",
        &format!("{baseline} best"),
        "Mrays/s",
        "ratio",
    ]
    .map(String::from)
    .to_vec();
    let mut rows = Vec::new();
    for g in groups {
        for w in g.workloads() {
            let ours = g
                .records
                .iter()
                .filter(|r| r.workload == w && is_packtrace(r))
                .max_by(|a, b| a.mrays.total_cmp(&b.mrays));
            let theirs = g.best_of(baseline, w);
            let cell = |r: Option<&&Record>| {
                r.map_or(["-".into(), "-".into()], |r| {
                    [r.engine(), format!("{:.2}", r.mrays)]
                })
            };
            let [oe, om] = cell(ours);
            let [te, tm] = cell(theirs.as_ref());
            let ratio = match (ours, theirs) {
                (Some(a), Some(b)) if comparable(a, b) => format!("{:.2}×", a.mrays / b.mrays),
                (Some(_), Some(_)) => "n/c".into(),
                _ => "-".into(),
            };
            let scene = format!("{} ({}t)", g.scene, g.threads);
            rows.push(vec![scene, w.to_string(), oe, om, te, tm, ratio]);
        }
    }
    Table { head, rows }
}

/// The runs behind the records: one row per file and stamp.
pub fn runs(records: &[Record]) -> Table {
    let head = [
        "file",
        "host",
        "CPU",
        "cores",
        "CPU flags",
        "packet kernel",
        "commit",
        "label",
        "command",
    ]
    .map(String::from)
    .to_vec();
    let stamps: Vec<(&str, &Stamp)> =
        first_seen(records.iter().map(|r| (r.file.as_str(), &r.stamp)));
    let or_dash = |s: &str| {
        if s.is_empty() {
            "-".into()
        } else {
            s.to_string()
        }
    };
    let rows = stamps
        .into_iter()
        .map(|(f, s)| {
            let kernels = first_seen(
                records
                    .iter()
                    .filter(|r| r.file == f && r.stamp == *s)
                    .filter_map(|r| r.kernel.as_deref()),
            );
            vec![
                f.to_string(),
                or_dash(&s.host),
                or_dash(&s.cpu),
                or_dash(&s.cores),
                or_dash(&s.cpu_flags),
                or_dash(&kernels.join(",")),
                or_dash(&s.commit),
                or_dash(&s.label),
                if s.command.is_empty() {
                    "-".into()
                } else {
                    format!("`{}`", s.command)
                },
            ]
        })
        .collect();
    Table { head, rows }
}

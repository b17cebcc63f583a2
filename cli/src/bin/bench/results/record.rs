//! Recorded JSON lines read back: one [`Record`] per traced (scene,
//! workload, mode, accel), each with the stamp of the run that made it.

use serde_json::Value;

/// Where and how a line was measured (its run's stamp; lines of older runs
/// or other harnesses may lack any of it).
#[derive(Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct Stamp {
    /// Host name.
    pub host: String,
    /// CPU model.
    pub cpu: String,
    /// Logical cores.
    pub cores: String,
    /// SIMD features of the CPU.
    pub cpu_flags: String,
    /// Commit the bench was built from.
    pub commit: String,
    /// The command.
    pub command: String,
    /// `--label`.
    pub label: String,
}

/// One traced line.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// The file it came from.
    pub file: String,
    /// Scene name.
    pub scene: String,
    /// Triangles of the scene.
    pub triangles: u64,
    /// Workload name.
    pub workload: String,
    /// Mode (`single`, as Embree harnesses call it, read as `scalar`).
    pub mode: String,
    /// Accel name.
    pub accel: String,
    /// Threads.
    pub threads: u64,
    /// Image size.
    pub size: (u64, u64),
    /// Rays traced.
    pub rays: u64,
    /// Seconds of the build, where reported.
    pub build_seconds: Option<f64>,
    /// Mrays/s.
    pub mrays: f64,
    /// Bytes of the structure per triangle, where known.
    pub bytes_per_triangle: Option<f64>,
    /// The rays' fingerprint, where recorded.
    pub fingerprint: Option<String>,
    /// The packet kernel that ran (packtrace's packet modes).
    pub kernel: Option<String>,
    /// The run's stamp.
    pub stamp: Stamp,
}

impl Record {
    /// `accel mode`, as tables and legends name an engine's line.
    pub fn engine(&self) -> String {
        format!("{} {}", self.accel, self.mode)
    }

    /// Is this line the baseline's (its accel named `baseline` or
    /// `baseline-...`)?
    pub fn is_of(&self, baseline: &str) -> bool {
        self.accel == baseline
            || self
                .accel
                .strip_prefix(baseline)
                .is_some_and(|r| r.starts_with('-'))
    }
}

/// A field as text (strings bare, numbers as written), `""` when absent
/// or null.
fn text(o: &Value, key: &str) -> String {
    match o.get(key) {
        None | Some(Value::Null) => String::new(),
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
    }
}

/// Parse the JSON lines of `file` (its `contents`). Blank lines and lines
/// of other bench runs (`"bench":"tlas_update"`) are passed over.
///
/// # Errors
/// `file:line: why` for a line that is not a JSON object of a traced run.
pub fn parse(file: &str, contents: &str) -> Result<Vec<Record>, String> {
    let mut out = Vec::new();
    for (n, line) in contents.lines().enumerate() {
        let at = || format!("{file}:{}", n + 1);
        if line.trim().is_empty() {
            continue;
        }
        let o: Value =
            serde_json::from_str(line).map_err(|e| format!("{}: not a JSON line: {e}", at()))?;
        if !o.is_object() {
            return Err(format!("{}: not a JSON object", at()));
        }
        if o.get("bench").is_some() {
            continue;
        }
        let string = |k: &str| match o.get(k) {
            Some(Value::String(s)) => Ok(s.clone()),
            _ => Err(format!("{}: no `{k}` (not a bench result line)", at())),
        };
        let number = |k: &str| o.get(k).and_then(Value::as_f64);
        let count = |k: &str| o.get(k).and_then(Value::as_u64).unwrap_or(0);
        let mode = string("mode")?;
        out.push(Record {
            file: file.to_string(),
            scene: string("scene")?,
            triangles: count("triangles"),
            workload: string("workload")?,
            mode: if mode == "single" {
                "scalar".into()
            } else {
                mode
            },
            accel: string("accel")?,
            threads: count("threads").max(1),
            size: (count("width"), count("height")),
            rays: count("rays"),
            build_seconds: number("build_seconds"),
            mrays: number("mrays_per_s")
                .ok_or_else(|| format!("{}: no `mrays_per_s` (not a bench result line)", at()))?,
            bytes_per_triangle: number("bytes_per_triangle"),
            fingerprint: o
                .get("fingerprint")
                .and_then(Value::as_str)
                .map(String::from),
            kernel: o.get("kernel").and_then(Value::as_str).map(String::from),
            stamp: Stamp {
                host: text(&o, "host"),
                cpu: text(&o, "cpu"),
                cores: text(&o, "cores"),
                cpu_flags: text(&o, "cpu_flags"),
                commit: text(&o, "commit"),
                command: text(&o, "command"),
                label: text(&o, "label"),
            },
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_parse_and_bad_lines_are_named() {
        let ok = r#"{"scene":"s","triangles":12,"workload":"primary","mode":"single","accel":"embree","threads":1,"width":8,"height":8,"rays":64,"mrays_per_s":2.5}

{"bench":"tlas_update","scene":"x"}"#;
        let r = parse("a.jsonl", ok).unwrap();
        assert_eq!(r.len(), 1);
        assert_eq!((r[0].mode.as_str(), r[0].mrays), ("scalar", 2.5));
        assert_eq!(r[0].engine(), "embree scalar");
        assert!(r[0].is_of("embree") && !r[0].is_of("emb"));
        let e = parse("b.jsonl", "{\"scene\":\"s\"}").unwrap_err();
        assert!(e.starts_with("b.jsonl:1: no `mode`"), "{e}");
        assert!(
            parse("c.jsonl", "nope")
                .unwrap_err()
                .starts_with("c.jsonl:1: not a JSON")
        );
    }
}

//! JSON lines (fields in a fixed order), where they and the summary table
//! go, and the build facts each line carries.

use crate::Failure;
use crate::cli::JsonTarget;
use serde_json::Value;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// `RUSTFLAGS` of the build (empty when unset, e.g. flags from a cargo
/// config file do not show here; `target_features` does).
pub const RUSTFLAGS: &str = match option_env!("RUSTFLAGS") {
    Some(f) => f,
    None => "",
};

/// x86 and ARM SIMD features enabled at compile time, comma-separated
/// (what `wide` picks its code paths from).
pub fn target_features() -> String {
    let features: [(&str, bool); 12] = [
        ("sse2", cfg!(target_feature = "sse2")),
        ("sse3", cfg!(target_feature = "sse3")),
        ("ssse3", cfg!(target_feature = "ssse3")),
        ("sse4.1", cfg!(target_feature = "sse4.1")),
        ("sse4.2", cfg!(target_feature = "sse4.2")),
        ("popcnt", cfg!(target_feature = "popcnt")),
        ("avx", cfg!(target_feature = "avx")),
        ("avx2", cfg!(target_feature = "avx2")),
        ("fma", cfg!(target_feature = "fma")),
        ("bmi2", cfg!(target_feature = "bmi2")),
        ("avx512f", cfg!(target_feature = "avx512f")),
        ("neon", cfg!(target_feature = "neon")),
    ];
    names_on(&features)
}

/// The names whose flag is on, comma-separated (CPU and compile-time
/// feature lists).
pub fn names_on(flags: &[(&'static str, bool)]) -> String {
    flags
        .iter()
        .filter(|(_, on)| *on)
        .map(|(name, _)| *name)
        .collect::<Vec<_>>()
        .join(",")
}

/// One JSON object with its keys in insertion order.
#[derive(Default)]
pub struct JsonLine {
    fields: Vec<(&'static str, Value)>,
}

impl JsonLine {
    /// Append a field.
    pub fn push(&mut self, key: &'static str, value: impl Into<Value>) {
        self.fields.push((key, value.into()));
    }

    /// The object on one line.
    pub fn render(&self) -> String {
        let body: Vec<String> = self
            .fields
            .iter()
            .map(|(k, v)| format!("{}:{v}", Value::from(*k)))
            .collect();
        format!("{{{}}}", body.join(","))
    }
}

/// Where a run's output goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    /// JSON lines on stdout.
    pub json_stdout: bool,
    /// The summary table on stdout (else on stderr).
    pub table_stdout: bool,
}

/// The output rules: JSON lines on stdout when stdout is not a terminal
/// (piped or redirected, as harnesses run `bench ... > file.jsonl`) or
/// when `--json`/`--json -` asks for them; otherwise the summary table
/// there instead, for a person reading a terminal. The table goes to stdout
/// exactly when JSON does not, so the two never interleave on one stream.
/// `--json PATH` adds the file and changes nothing on stdout. Progress,
/// warnings and errors always go to stderr; `--check-only` prints neither
/// JSON nor table, whatever the plan.
pub fn output_plan(stdout_is_terminal: bool, json: Option<&JsonTarget>) -> Plan {
    let json_stdout = !stdout_is_terminal || json == Some(&JsonTarget::Stdout);
    Plan {
        json_stdout,
        table_stdout: !json_stdout,
    }
}

/// Stdout when the plan says so, plus the `--json` file when given.
pub struct Sink {
    stdout: bool,
    file: Option<(BufWriter<File>, String)>,
    /// Every line written, for the closing comparison table.
    lines: Vec<String>,
}

impl Sink {
    /// Open (create or truncate) the `--json` file.
    ///
    /// # Errors
    /// [`Failure::Input`] naming the file.
    pub fn open(plan: Plan, json: Option<&Path>) -> Result<Sink, Failure> {
        let file = match json {
            None => None,
            Some(p) => {
                let f = File::create(p)
                    .map_err(|e| Failure::Input(format!("--json {}: {e}", p.display())))?;
                Some((BufWriter::new(f), p.display().to_string()))
            }
        };
        Ok(Sink {
            stdout: plan.json_stdout,
            file,
            lines: Vec::new(),
        })
    }

    /// Write one line to stdout when planned (flushed, so a pipe sees it at
    /// once) and to the file.
    ///
    /// # Errors
    /// [`Failure::Io`] when either cannot be written.
    pub fn line(&mut self, line: &str) -> Result<(), Failure> {
        if self.stdout {
            let mut out = std::io::stdout().lock();
            writeln!(out, "{line}")
                .and_then(|()| out.flush())
                .map_err(|e| Failure::Io(format!("stdout: {e}")))?;
        }
        if let Some((f, name)) = &mut self.file {
            writeln!(f, "{line}").map_err(|e| Failure::Io(format!("{name}: {e}")))?;
        }
        self.lines.push(line.to_string());
        Ok(())
    }

    /// Every line written so far.
    pub fn lines(&self) -> &[String] {
        &self.lines
    }

    /// Flush the file.
    ///
    /// # Errors
    /// [`Failure::Io`] naming the file.
    pub fn finish(&mut self) -> Result<(), Failure> {
        if let Some((f, name)) = &mut self.file {
            f.flush().map_err(|e| Failure::Io(format!("{name}: {e}")))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_keep_their_order_and_nan_is_null() {
        let mut j = JsonLine::default();
        j.push("scene", "a\"b");
        j.push("rays", 3u64);
        j.push("sum_t", Option::<f64>::None);
        j.push("x", f64::NAN);
        j.push("y", 0.5);
        assert_eq!(
            j.render(),
            r#"{"scene":"a\"b","rays":3,"sum_t":null,"x":null,"y":0.5}"#
        );
    }

    #[test]
    fn a_terminal_gets_the_table_unless_json_is_asked_for() {
        let table = Plan {
            json_stdout: false,
            table_stdout: true,
        };
        let json = Plan {
            json_stdout: true,
            table_stdout: false,
        };
        let file = JsonTarget::File("out.jsonl".into());
        assert_eq!(output_plan(true, None), table);
        assert_eq!(output_plan(true, Some(&file)), table);
        assert_eq!(output_plan(true, Some(&JsonTarget::Stdout)), json);
    }

    #[test]
    fn a_pipe_gets_json_whatever_is_asked() {
        let json = Plan {
            json_stdout: true,
            table_stdout: false,
        };
        let file = JsonTarget::File("out.jsonl".into());
        assert_eq!(output_plan(false, None), json);
        assert_eq!(output_plan(false, Some(&file)), json);
        assert_eq!(output_plan(false, Some(&JsonTarget::Stdout)), json);
    }

    #[test]
    fn json_and_table_never_share_stdout() {
        let file = JsonTarget::File("x".into());
        for terminal in [false, true] {
            for json in [None, Some(&JsonTarget::Stdout), Some(&file)] {
                let p = output_plan(terminal, json);
                assert_ne!(p.json_stdout, p.table_stdout, "{terminal} {json:?}");
            }
        }
    }

    #[test]
    fn target_features_are_listed() {
        let f = target_features();
        if cfg!(target_arch = "x86_64") {
            assert!(f.starts_with("sse2"), "{f}");
        }
    }
}

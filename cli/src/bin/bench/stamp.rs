//! What every JSON line says about where and how it was measured: the
//! machine, its CPU model and SIMD flags, the commit the bench was built
//! from, the command, and a free label (`--label`). `bench report` prints
//! them beside the figures, so that a kept run says what it is.

use std::sync::OnceLock;

/// The run's stamp.
#[derive(Clone, Debug)]
pub struct Stamp {
    /// The host name (`/proc/sys/kernel/hostname`), else `unknown`.
    pub host: String,
    /// The CPU model (`model name` of `/proc/cpuinfo`), else the target
    /// architecture.
    pub cpu: String,
    /// Logical cores the process may use.
    pub cores: usize,
    /// SIMD features the CPU has (detected at run time), comma-separated.
    pub cpu_flags: String,
    /// The commit the bench was built from (`-dirty`: with uncommitted
    /// changes), from `build.rs`.
    pub commit: &'static str,
    /// The command line, the program as `bench`.
    pub command: String,
}

/// The stamp of this process, made once.
pub fn get() -> &'static Stamp {
    static STAMP: OnceLock<Stamp> = OnceLock::new();
    STAMP.get_or_init(|| Stamp {
        host: std::fs::read_to_string("/proc/sys/kernel/hostname")
            .map(|s| s.trim().to_string())
            .ok()
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| "unknown".into()),
        cpu: cpu_model().unwrap_or_else(|| std::env::consts::ARCH.to_string()),
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        cpu_flags: cpu_flags(),
        commit: env!("PACKTRACE_COMMIT"),
        command: command(std::env::args()),
    })
}

/// `model name` of the first processor in `/proc/cpuinfo`.
fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
}

/// The SIMD features a packet kernel or a peer may pick, as the CPU has
/// them (not as the binary was compiled: that is `target_features`).
fn cpu_flags() -> String {
    #[cfg(target_arch = "x86_64")]
    {
        let flags = [
            ("sse4.2", std::arch::is_x86_feature_detected!("sse4.2")),
            ("avx", std::arch::is_x86_feature_detected!("avx")),
            ("avx2", std::arch::is_x86_feature_detected!("avx2")),
            ("fma", std::arch::is_x86_feature_detected!("fma")),
            ("bmi2", std::arch::is_x86_feature_detected!("bmi2")),
            ("avx512f", std::arch::is_x86_feature_detected!("avx512f")),
            ("avx512vl", std::arch::is_x86_feature_detected!("avx512vl")),
            ("avx512dq", std::arch::is_x86_feature_detected!("avx512dq")),
            ("avx512bw", std::arch::is_x86_feature_detected!("avx512bw")),
        ];
        crate::report::names_on(&flags)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        String::new()
    }
}

/// The command line as typed, the program's path shortened to `bench`;
/// arguments with spaces or quotes are single-quoted.
pub fn command(args: impl Iterator<Item = String>) -> String {
    args.enumerate()
        .map(|(i, a)| {
            if i == 0 {
                "bench".to_string()
            } else if a.is_empty() || a.contains([' ', '\'', '"', '$', '*']) {
                format!("'{}'", a.replace('\'', r"'\''"))
            } else {
                a
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_names_bench_and_quotes_what_needs_it() {
        let args = ["/x/target/release/bench", "--scene", "a b.obj", "--check"];
        assert_eq!(
            command(args.iter().map(|s| s.to_string())),
            "bench --scene 'a b.obj' --check"
        );
    }

    #[test]
    fn the_stamp_has_a_commit_and_a_cpu() {
        let s = get();
        assert!(!s.commit.is_empty() && !s.cpu.is_empty() && s.cores >= 1);
    }
}

//! Peak build memory from the kernel's own accounting (Linux): the peak
//! resident set size is reset before a build (`/proc/self/clear_refs`,
//! value 5) and read after it (`VmHWM` in `/proc/self/status`). Elsewhere,
//! or where `/proc` refuses, the figures are `None` (`null` in the JSON).
//! Resident memory counts pages touched, so it includes the allocator's
//! reuse of freed memory: it is what the build costs the machine (and a
//! later build of the same run, reusing pages an earlier one freed, may
//! report less than it needs).

use std::fs;

/// Reset the peak and return the resident size now, in bytes.
pub fn reset_peak() -> Option<usize> {
    fs::write("/proc/self/clear_refs", "5").ok()?;
    status_kib("VmRSS:")?.checked_mul(1024)
}

/// The peak resident size since the last [`reset_peak`], in bytes.
pub fn peak() -> Option<usize> {
    status_kib("VmHWM:")?.checked_mul(1024)
}

/// A `kB` field of `/proc/self/status`.
fn status_kib(field: &str) -> Option<usize> {
    let status = fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line[field.len()..]
        .trim()
        .strip_suffix("kB")?
        .trim()
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peak_grows_with_a_large_allocation() {
        let Some(before) = reset_peak() else {
            eprintln!("note: /proc/self/clear_refs not available; skipped");
            return;
        };
        let block = vec![1u8; 64 << 20];
        std::hint::black_box(&block);
        let after = peak().unwrap();
        assert!(after >= before + (60 << 20), "{before} -> {after}");
    }
}

//! The `trace` fuzz target: libFuzzer's input through the checks of
//! `checks/trace.rs` (also replayed over the committed corpora by the
//! main crate's `tests/fuzz_corpora.rs`).

#![no_main]

#[path = "../checks/trace.rs"]
mod checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| checks::check(data));

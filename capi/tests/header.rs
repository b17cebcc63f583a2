//! `include/packtrace.h` is what cbindgen makes of the crate today: CI
//! fails when an exported function or struct changed and the header was
//! not regenerated. To regenerate: `PACKTRACE_BLESS=1 cargo test -p
//! packtrace-c --test header`.

use std::path::Path;

#[test]
fn the_checked_in_header_is_current() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut fresh = Vec::new();
    cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .expect("cbindgen parses the crate")
        .write(&mut fresh);
    let fresh = String::from_utf8(fresh).expect("UTF-8");
    let path = dir.join("include/packtrace.h");
    if std::env::var_os("PACKTRACE_BLESS").is_some() {
        std::fs::write(&path, &fresh).expect("write the header");
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    if checked_in != fresh {
        let line = checked_in
            .lines()
            .zip(fresh.lines())
            .position(|(a, b)| a != b)
            .map_or(checked_in.lines().count().min(fresh.lines().count()), |i| i);
        panic!(
            "include/packtrace.h differs from cbindgen's output from line {} on: regenerate \
             it with `PACKTRACE_BLESS=1 cargo test -p packtrace-c --test header`",
            line + 1
        );
    }
}

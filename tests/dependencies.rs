//! What a host gets: the library's own dependencies are exactly glam, wide,
//! rayon and tobj (issue 15); the binaries' (`clap`, `png`, `serde_json`,
//! `indicatif`) live in `cli/Cargo.toml`. `.ci/run` also checks the
//! resolved tree with `cargo tree -p packtrace -e normal`.

use std::path::Path;

/// The package names of one `[section]` of a manifest.
fn section(manifest: &str, name: &str) -> Vec<String> {
    let header = format!("[{name}]");
    let Some(start) = manifest.lines().position(|l| l.trim() == header) else {
        return Vec::new();
    };
    let mut names: Vec<String> = manifest
        .lines()
        .skip(start + 1)
        .take_while(|l| !l.trim_start().starts_with('['))
        .filter_map(|l| l.split_once('=').map(|(k, _)| k.trim().to_string()))
        .filter(|k| !k.is_empty() && !k.starts_with('#'))
        .collect();
    names.sort();
    names
}

#[test]
fn the_library_depends_on_glam_wide_rayon_and_tobj_only() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    assert_eq!(
        section(&lib, "dependencies"),
        ["glam", "rayon", "tobj", "wide"]
    );
    assert!(section(&lib, "features").is_empty(), "no features needed");
    let cli = std::fs::read_to_string(root.join("cli/Cargo.toml")).unwrap();
    let bins = section(&cli, "dependencies");
    for name in ["clap", "png", "serde_json", "indicatif", "packtrace"] {
        assert!(bins.iter().any(|b| b == name), "cli lacks {name}: {bins:?}");
    }
}

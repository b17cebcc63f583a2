//! The shared scenes (bunny, Sponza, teapot, Cornell box: `.obj` and
//! `.view` files) for the scene tests. Every scene test is
//! `#[ignore = "needs PACKTRACE_SCENES..."]`, so that a plain `cargo test`
//! lists it as ignored, with the reason, instead of passing it unrun:
//!
//! ```sh
//! PACKTRACE_SCENES=/path/to/scenes cargo test -- --include-ignored
//! ```
//!
//! runs them (`.ci/run` does, and fails if one did not run). A scene test
//! that runs without the variable, or without one of its files, fails.

use std::path::{Path, PathBuf};

/// `PACKTRACE_SCENES`, the directory of the shared scenes.
///
/// # Panics
/// When the variable is unset or names no directory: a scene test that
/// runs needs its scenes.
pub fn scenes_dir() -> PathBuf {
    let Some(dir) = std::env::var_os("PACKTRACE_SCENES") else {
        panic!(
            "this scene test needs PACKTRACE_SCENES, the directory of the shared scenes \
             (bunny.obj, sponza.obj, ...): PACKTRACE_SCENES=/path/to/scenes cargo test -- --include-ignored"
        );
    };
    let dir = PathBuf::from(dir);
    assert!(
        dir.is_dir(),
        "PACKTRACE_SCENES={} is not a directory",
        dir.display()
    );
    dir
}

/// The scene file `name` in `dir`: fails the test when it is missing.
pub fn scene_file(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    assert!(
        p.is_file(),
        "PACKTRACE_SCENES={} but {} is missing (or not a file)",
        dir.display(),
        p.display()
    );
    p
}

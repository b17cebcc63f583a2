//! Build facts for the binaries: the commit they were built from (stamped
//! on every JSON line of `bench`), and, with the `embree` feature, where
//! the linker finds Embree 3.

use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    commit();
    if std::env::var_os("CARGO_FEATURE_EMBREE").is_some() {
        link_embree();
    }
}

/// `git` with `args` in this package's folder; its trimmed stdout on success.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// `PACKTRACE_COMMIT`: the short commit, `-dirty` when tracked files had
/// uncommitted changes at build time; `unknown` outside a git checkout.
/// Rebuilt when HEAD, the branch or the index moves.
fn commit() {
    let hash = git(&["rev-parse", "--short=12", "HEAD"]);
    let dirty =
        git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    let stamp = match hash {
        Some(h) if dirty => format!("{h}-dirty"),
        Some(h) => h,
        None => "unknown".into(),
    };
    println!("cargo:rustc-env=PACKTRACE_COMMIT={stamp}");
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        let dir = PathBuf::from(dir);
        println!("cargo:rerun-if-changed={}", dir.join("HEAD").display());
        println!("cargo:rerun-if-changed={}", dir.join("index").display());
    }
    if let (Some(common), Some(branch)) = (
        git(&["rev-parse", "--git-common-dir"]),
        git(&["symbolic-ref", "-q", "HEAD"]),
    ) {
        println!(
            "cargo:rerun-if-changed={}",
            Path::new(&common).join(branch).display()
        );
    }
}

/// Link `libembree3`: pkg-config's answer when it knows `embree3` (Embree's
/// own builds install a .pc file), else `EMBREE_DIR/lib`, else the
/// linker's default search path (Debian's `libembree-dev` ships no .pc
/// file and puts the library there). Fails with the fix when none has it.
fn link_embree() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");
    let pkg = Command::new("pkg-config")
        .args(["--libs", "embree3"])
        .output()
        .ok()
        .filter(|o| o.status.success());
    if let Some(out) = pkg {
        for flag in String::from_utf8_lossy(&out.stdout).split_whitespace() {
            if let Some(dir) = flag.strip_prefix("-L") {
                println!("cargo:rustc-link-search=native={dir}");
            } else if let Some(lib) = flag.strip_prefix("-l") {
                println!("cargo:rustc-link-lib=dylib={lib}");
            }
        }
        return;
    }
    let mut dirs: Vec<PathBuf> = Vec::new();
    if let Some(root) = std::env::var_os("EMBREE_DIR") {
        let lib = Path::new(&root).join("lib");
        println!("cargo:rustc-link-search=native={}", lib.display());
        dirs.push(lib);
    }
    dirs.extend(
        [
            "/usr/lib/x86_64-linux-gnu",
            "/usr/lib/aarch64-linux-gnu",
            "/usr/lib64",
            "/usr/lib",
            "/usr/local/lib",
        ]
        .map(PathBuf::from),
    );
    if let Some(paths) = std::env::var_os("LIBRARY_PATH") {
        dirs.extend(std::env::split_paths(&paths));
    }
    if !dirs.iter().any(|d| d.join("libembree3.so").exists()) {
        eprintln!(
            "error: the `embree` feature needs Embree 3 (libembree3.so): install it \
             (`apt-get install libembree-dev` on Debian or Ubuntu), or set EMBREE_DIR to an \
             Embree 3 install, or build without `--features embree`"
        );
        std::process::exit(1);
    }
    println!("cargo:rustc-link-lib=dylib=embree3");
}

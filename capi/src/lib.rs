//! # packtrace-c
//!
//! The C API of packtrace, for C and C++ hosts: `libpacktrace_c.a` and
//! `libpacktrace_c.so` with the header `include/packtrace.h` (generated
//! from this crate by cbindgen; `tests/header.rs` keeps the checked-in
//! copy current). The guide for hosts is `docs/c-api.md`.
//!
//! Every exported function returns a [`PacktraceStatus`] and never
//! unwinds: a library error becomes its status and the thread's
//! [`packtrace_last_error`] message (the Rust error's `Display` text), a
//! panic is caught at the boundary (`status::guard`). Raw pointers are
//! turned into references in one module, `ptr.rs`, after the checks the
//! library can make (null, alignment, sizes that overflow); it holds all
//! of the crate's `unsafe` blocks (`.ci/run` checks that).
//!
//! Modules: `status` (codes, last error, the guard), `ptr` (the unsafe
//! boundary, handles), `types` (the C structs), `params` (build
//! parameters and the structure kind), `packet` (the host's rays to the
//! library's and answers back), `library` (version, status names, the
//! last error, build parameters, the origin offset), `tree`, `scene`,
//! `obj` (the exported functions by handle).

#![deny(missing_docs)]
// `unsafe` is allowed in `ptr.rs` (raw pointers) and for the
// `#[unsafe(no_mangle)]` attributes of the exported functions.
#![deny(unsafe_code)]

mod library;
mod obj;
mod packet;
mod params;
mod ptr;
mod scene;
mod status;
mod tree;
mod types;

pub use library::*;
pub use obj::*;
pub use scene::*;
pub use status::PacktraceStatus;
pub use tree::*;
pub use types::*;

//! Calls about the library itself: version, status names, the thread's
//! last error, build parameters, and the secondary-ray origin offset.
// `#[unsafe(no_mangle)]` on the exported functions is all the unsafe
// code here; raw pointers are turned into references in `ptr.rs` only.
#![allow(unsafe_code)]

use crate::status::{STATUSES, guard};
use crate::types::{PacktraceBuildParams, PacktracePreset};
use crate::{params, ptr, tree};
use std::ffi::{CStr, c_char};

/// The message of the calling thread's last failed packtrace call (the
/// Rust error's `Display` text, then its sources after `: `), or "" if
/// none has failed. Never NULL; valid until the thread's next failing
/// call. A successful call leaves it as it was.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_last_error() -> *const c_char {
    crate::status::last_error()
}

/// The name of a status code (`"PACKTRACE_STATUS_OK"`, ...), or
/// `"PACKTRACE_STATUS_UNKNOWN"` for a value that is not one. Never NULL;
/// static.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_status_name(status: u32) -> *const c_char {
    STATUSES
        .get(status as usize)
        .map_or(c"PACKTRACE_STATUS_UNKNOWN", |(_, name)| *name)
        .as_ptr()
}

/// The library's version, `"MAJOR.MINOR.PATCH"`. Never NULL; static.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_version() -> *const c_char {
    const VERSION: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => c"unknown",
        };
    VERSION.as_ptr()
}

/// Fills `*out_params` with the default build parameters (the kd-tree,
/// the Rust `KdBuildParams::default()`).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_build_params_default(
    out_params: *mut PacktraceBuildParams,
) -> crate::PacktraceStatus {
    packtrace_build_params_preset(PacktracePreset::Default as u32, out_params)
}

/// Fills `*out_params` with preset `preset` (a `PacktracePreset`;
/// `INVALID_ARGUMENT` otherwise).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_build_params_preset(
    preset: u32,
    out_params: *mut PacktraceBuildParams,
) -> crate::PacktraceStatus {
    guard(|| {
        let out = ptr::write(out_params, "out_params")?;
        *out = params::preset(preset)?;
        Ok(())
    })
}

/// `point` (three floats) moved off a surface along its unit normal
/// `normal` (towards the side it points to) far enough that no f32
/// rounding puts it back on the other side: 256 `normal_i` ulps of each
/// coordinate, or `normal_i / 65536` for a coordinate below 1/32 in
/// magnitude (Wächter and Binder, Ray Tracing Gems, 2019, chapter 6).
/// Written to `out_point`. `INVALID_ARGUMENT` for a non-finite input.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_offset_origin(
    point: *const f32,
    normal: *const f32,
    out_point: *mut f32,
) -> crate::PacktraceStatus {
    guard(|| {
        let p = tree::vec3(point, "point")?;
        let n = tree::vec3(normal, "normal")?;
        tree::put3(out_point, packtrace::spawn::offset_origin(p, n))
    })
}

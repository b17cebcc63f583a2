//! Status codes, the thread's last error message, and the guard every
//! exported function runs its body in (no panic crosses the boundary).

use std::any::Any;
use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char};
use std::fmt;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// What a call returns: `PACKTRACE_STATUS_OK`, or why it failed (the
/// message is then in `packtrace_last_error()`). A failed call writes
/// none of its outputs.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacktraceStatus {
    /// Success.
    Ok = 0,
    /// A required pointer argument is NULL.
    NullPointer = 1,
    /// A pointer argument is not aligned as its type requires (vertex and
    /// index buffers: 4 bytes; `PacktraceRayHit`: 16; `PacktraceRayHit4`:
    /// 16; `PacktraceRayHit8`: 32).
    Misaligned = 2,
    /// A count, stride, size, mask value or enum value out of range: a
    /// stride too small for its element or not a multiple of 4, a byte
    /// size that overflows, a `valid` entry other than 0 or -1, a NaN or
    /// infinite input to a helper.
    InvalidArgument = 3,
    /// An active ray is refused by the ray policy: NaN or infinite
    /// origin or direction, zero direction, NaN `tnear` or `tfar`.
    InvalidRay = 4,
    /// The vertex and index arrays do not make a mesh: an index past the
    /// vertices, a non-finite vertex used by a triangle, too many
    /// triangles.
    InvalidMesh = 5,
    /// A field of `PacktraceBuildParams` is out of range.
    InvalidParams = 6,
    /// The build failed (a tree larger than the node encoding can
    /// address, the memory budget, the thread pool).
    Build = 7,
    /// A scene refused an edit (unknown geometry or instance, a singular
    /// or non-finite transform, too many instances).
    Scene = 8,
    /// An OBJ file could not be read or parsed.
    Load = 9,
    /// The handle was released (detected for recently released handles;
    /// using a released handle is a host bug the library cannot always
    /// see).
    ReleasedHandle = 10,
    /// The pointer is not a live handle of the kind the function takes
    /// (e.g. a scene passed where a tree is expected).
    InvalidHandle = 11,
    /// The scene has edits that `packtrace_scene_commit` has not applied.
    Uncommitted = 12,
    /// The request is valid but not available in this build (e.g. an
    /// acceleration structure kind reserved for a later version).
    Unsupported = 13,
    /// The library panicked: a bug in packtrace, caught at the boundary.
    Panic = 14,
}

/// Every status with its name, for `packtrace_status_name` and tests.
pub(crate) const STATUSES: [(PacktraceStatus, &CStr); 15] = [
    (PacktraceStatus::Ok, c"PACKTRACE_STATUS_OK"),
    (
        PacktraceStatus::NullPointer,
        c"PACKTRACE_STATUS_NULL_POINTER",
    ),
    (PacktraceStatus::Misaligned, c"PACKTRACE_STATUS_MISALIGNED"),
    (
        PacktraceStatus::InvalidArgument,
        c"PACKTRACE_STATUS_INVALID_ARGUMENT",
    ),
    (PacktraceStatus::InvalidRay, c"PACKTRACE_STATUS_INVALID_RAY"),
    (
        PacktraceStatus::InvalidMesh,
        c"PACKTRACE_STATUS_INVALID_MESH",
    ),
    (
        PacktraceStatus::InvalidParams,
        c"PACKTRACE_STATUS_INVALID_PARAMS",
    ),
    (PacktraceStatus::Build, c"PACKTRACE_STATUS_BUILD"),
    (PacktraceStatus::Scene, c"PACKTRACE_STATUS_SCENE"),
    (PacktraceStatus::Load, c"PACKTRACE_STATUS_LOAD"),
    (
        PacktraceStatus::ReleasedHandle,
        c"PACKTRACE_STATUS_RELEASED_HANDLE",
    ),
    (
        PacktraceStatus::InvalidHandle,
        c"PACKTRACE_STATUS_INVALID_HANDLE",
    ),
    (
        PacktraceStatus::Uncommitted,
        c"PACKTRACE_STATUS_UNCOMMITTED",
    ),
    (
        PacktraceStatus::Unsupported,
        c"PACKTRACE_STATUS_UNSUPPORTED",
    ),
    (PacktraceStatus::Panic, c"PACKTRACE_STATUS_PANIC"),
];

/// A failed call: its status and the message `packtrace_last_error()`
/// gives.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Error {
    pub(crate) status: PacktraceStatus,
    pub(crate) message: String,
}

impl Error {
    pub(crate) fn new(status: PacktraceStatus, message: impl Into<String>) -> Error {
        Error {
            status,
            message: message.into(),
        }
    }

    /// A library error: its `Display` text, then each source's (`: `).
    pub(crate) fn from_rust(status: PacktraceStatus, e: &dyn std::error::Error) -> Error {
        let mut message = e.to_string();
        let mut source = e.source();
        while let Some(s) = source {
            message.push_str(": ");
            message.push_str(&s.to_string());
            source = s.source();
        }
        Error { status, message }
    }

    pub(crate) fn null(name: &str) -> Error {
        Error::new(
            PacktraceStatus::NullPointer,
            format!("argument `{name}` is a null pointer"),
        )
    }

    pub(crate) fn invalid(message: impl Into<String>) -> Error {
        Error::new(PacktraceStatus::InvalidArgument, message)
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// The library's errors, each with its status.
macro_rules! from_rust {
    ($($t:ty => $s:expr),* $(,)?) => {$(
        impl From<$t> for Error {
            fn from(e: $t) -> Error {
                Error::from_rust($s, &e)
            }
        }
    )*};
}

from_rust! {
    packtrace::MeshError => PacktraceStatus::InvalidMesh,
    packtrace::RayError => PacktraceStatus::InvalidRay,
    packtrace::PacketError => PacktraceStatus::InvalidRay,
    packtrace::scene::SceneError => PacktraceStatus::Scene,
    packtrace::LoadError => PacktraceStatus::Load,
}

impl From<packtrace::BuildError> for Error {
    fn from(e: packtrace::BuildError) -> Error {
        use packtrace::BuildError::{DepthLimit, InvalidParams};
        let status = match e {
            InvalidParams(_) | DepthLimit(_) => PacktraceStatus::InvalidParams,
            _ => PacktraceStatus::Build,
        };
        Error::from_rust(status, &e)
    }
}

thread_local! {
    /// The message of this thread's last failed call.
    static LAST: RefCell<CString> = RefCell::new(CString::default());
}

fn set_last(message: &str) {
    // A message never holds a NUL byte (an OBJ path might).
    let c = CString::new(message.replace('\0', "\\0")).unwrap_or_default();
    LAST.with(|l| *l.borrow_mut() = c);
}

/// The message of this thread's last failed call ("" before any).
pub(crate) fn last_error() -> *const c_char {
    LAST.with(|l| l.borrow().as_ptr())
}

/// The text of a panic's payload.
fn panic_text(p: &(dyn Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".to_string())
}

/// Runs an exported function's body: its error becomes the status and
/// the thread's last error; a panic is caught here and becomes
/// [`PacktraceStatus::Panic`], so none unwinds into the host's frames
/// (undefined behaviour for an `extern "C"` function).
#[inline(always)]
pub(crate) fn guard(body: impl FnOnce() -> Result<(), Error>) -> PacktraceStatus {
    // The body only reads its arguments and writes its outputs after every
    // check passed, so a caught panic leaves no broken state behind that
    // the host could see (outputs may be partly written; the status says
    // not to read them).
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => PacktraceStatus::Ok,
        Ok(Err(e)) => fail(&e),
        Err(p) => fail(&Error::new(
            PacktraceStatus::Panic,
            format!(
                "packtrace panicked (a bug; please report it): {}",
                panic_text(&*p)
            ),
        )),
    }
}

#[cold]
fn fail(e: &Error) -> PacktraceStatus {
    set_last(&e.message);
    e.status
}

#[cfg(test)]
mod tests {
    use super::*;

    fn last() -> String {
        LAST.with(|l| l.borrow().to_string_lossy().into_owned())
    }

    #[test]
    fn a_panic_becomes_a_status_and_a_message() {
        let s = guard(|| panic!("boom {}", 7));
        assert_eq!(s, PacktraceStatus::Panic);
        assert!(last().ends_with("boom 7"), "{}", last());
        let s = guard(|| std::panic::panic_any(5u8));
        assert_eq!(s, PacktraceStatus::Panic);
        assert!(last().ends_with("(no message)"));
    }

    #[test]
    fn errors_keep_their_display_text_and_sources() {
        let e: Error =
            packtrace::scene::SceneError::Transform(packtrace::scene::TransformError::NonFinite)
                .into();
        assert_eq!(e.status, PacktraceStatus::Scene);
        assert_eq!(
            e.message,
            "bad instance transform: transform has a NaN or infinite entry"
        );
        assert_eq!(guard(|| Err(e.clone())), PacktraceStatus::Scene);
        assert_eq!(last(), e.message);
        // Success leaves the last message alone.
        assert_eq!(guard(|| Ok(())), PacktraceStatus::Ok);
        assert_eq!(last(), e.message);
        set_last("a\0b");
        assert_eq!(last(), "a\\0b");
    }

    #[test]
    fn status_names_are_in_code_order() {
        for (i, (s, _)) in STATUSES.iter().enumerate() {
            assert_eq!(*s as u32, i as u32);
        }
    }
}

//! What the `render` and `bench` binaries share.

/// An error and its sources, `a: b: c` (packtrace's errors never repeat
/// their source in their own message, so each part appears once).
///
/// ```
/// let e = packtrace::load_obj("no/such/file.obj").unwrap_err();
/// let text = packtrace_cli::chain(&e);
/// assert!(text.starts_with("no/such/file.obj: cannot read the file: "), "{text}");
/// ```
#[must_use]
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text += &format!(": {c}");
        cause = c.source();
    }
    text
}

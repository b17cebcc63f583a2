//! The crate's only unsafe code: raw pointers from the host turned into
//! references and slices after the checks the library can make (null,
//! alignment, sizes that overflow), and the handles' allocation, lookup
//! and release. Everything else in the crate is safe Rust over what this
//! module hands out.
//!
//! What the library cannot check is the host's contract (stated in the
//! header): a non-null pointer points at live memory of the size the
//! arguments say, and no other thread writes it during the call; a handle
//! is not used after its release (detected for the last
//! [`QUARANTINE`] released handles, see [`release`]).
#![allow(unsafe_code)]

use crate::status::{Error, PacktraceStatus};
use std::collections::VecDeque;
use std::marker::PhantomData;
use std::mem::{align_of, size_of};
use std::sync::Mutex;

/// `p` null or misaligned for `T`: the error naming argument `name`.
fn check<T>(p: *const T, name: &str) -> Result<(), Error> {
    if p.is_null() {
        return Err(Error::null(name));
    }
    if !(p as usize).is_multiple_of(align_of::<T>()) {
        return Err(Error::new(
            PacktraceStatus::Misaligned,
            format!(
                "argument `{name}` ({p:p}) is not aligned to {} bytes",
                align_of::<T>()
            ),
        ));
    }
    Ok(())
}

/// The `T` at `p`, read-only.
pub(crate) fn read<'a, T>(p: *const T, name: &str) -> Result<&'a T, Error> {
    check(p, name)?;
    // SAFETY: `p` is non-null and aligned (checked above); that it points
    // at a live `T` nobody writes during the call is the host's contract.
    Ok(unsafe { &*p })
}

/// The `T` at `p`, read and written.
pub(crate) fn write<'a, T>(p: *mut T, name: &str) -> Result<&'a mut T, Error> {
    check(p, name)?;
    // SAFETY: as `read`; the host also promises no other reference to it
    // during the call (it is this call's in/out argument).
    Ok(unsafe { &mut *p })
}

/// Bytes of `count` elements `stride` bytes apart, the last one `size`
/// bytes long, if that fits in `isize`.
fn span(count: usize, stride: usize, size: usize) -> Option<usize> {
    let n = count
        .checked_sub(1)
        .map_or(Some(0), |last| last.checked_mul(stride)?.checked_add(size))?;
    (n <= isize::MAX as usize).then_some(n)
}

/// The checks of an array argument of `count` elements of `size` bytes
/// placed `stride` bytes apart at `p` (aligned for `T`): a null pointer is
/// accepted when `count` is zero.
fn check_array<T>(p: *const T, count: usize, stride: usize, name: &str) -> Result<bool, Error> {
    if count == 0 {
        return Ok(false);
    }
    check(p, name)?;
    if stride < size_of::<T>() || !stride.is_multiple_of(align_of::<T>()) {
        return Err(Error::invalid(format!(
            "stride of `{name}` is {stride} bytes: at least {} and a multiple of {} required",
            size_of::<T>(),
            align_of::<T>()
        )));
    }
    if span(count, stride, size_of::<T>()).is_none() {
        return Err(Error::invalid(format!(
            "`{name}`: {count} elements {stride} bytes apart overflow the address space"
        )));
    }
    Ok(true)
}

/// The NUL-terminated string at `p` (a file path), as bytes.
pub(crate) fn c_str<'a>(p: *const std::ffi::c_char, name: &str) -> Result<&'a [u8], Error> {
    check(p, name)?;
    // SAFETY: non-null (checked); that it points at a NUL-terminated
    // string that lives through the call is the host's contract.
    Ok(unsafe { std::ffi::CStr::from_ptr(p) }.to_bytes())
}

/// `count` `T`s at `p`, contiguous, read-only (null allowed for zero).
pub(crate) fn slice<'a, T>(p: *const T, count: usize, name: &str) -> Result<&'a [T], Error> {
    if !check_array(p, count, size_of::<T>().max(1), name)? {
        return Ok(&[]);
    }
    // SAFETY: non-null, aligned, and `count * size_of::<T>()` fits in
    // `isize` (checked); the host promises `count` live `T`s there.
    Ok(unsafe { std::slice::from_raw_parts(p, count) })
}

/// `count` `T`s at `p`, contiguous, written (null allowed for zero).
pub(crate) fn slice_mut<'a, T>(p: *mut T, count: usize, name: &str) -> Result<&'a mut [T], Error> {
    if !check_array(p, count, size_of::<T>().max(1), name)? {
        return Ok(&mut []);
    }
    // SAFETY: as `slice`, and the host promises no other access during
    // the call.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, count) })
}

/// Reads `count` records of three `T`s (a vertex's `float x, y, z`, a
/// triangle's `uint32_t` indices) starting every `stride` bytes at `p`,
/// in place: the host's own buffers, whatever else each record holds.
pub(crate) fn strided3<T: Copy>(
    p: *const T,
    count: usize,
    stride: usize,
    name: &str,
) -> Result<Vec<[T; 3]>, Error> {
    // The element is `[T; 3]`, aligned as `T`.
    if !check_array(p.cast::<[T; 3]>(), count, stride, name)? {
        return Ok(Vec::new());
    }
    let base = p.cast::<u8>();
    Ok((0..count)
        .map(|i| {
            // SAFETY: record `i` starts `i * stride` bytes in, inside the
            // span checked above (`(count - 1) * stride + 3 size_of T`
            // fits in `isize`), aligned for `T` (base and stride are); the
            // host promises the span is live.
            unsafe { base.add(i * stride).cast::<[T; 3]>().read() }
        })
        .collect())
}

/// `count` elements of `T` placed `stride` bytes apart (a host's array of
/// ray structs), each read and written in place.
pub(crate) struct StridedMut<'a, T> {
    base: *mut u8,
    count: usize,
    stride: usize,
    _t: PhantomData<&'a mut T>,
}

impl<'a, T> StridedMut<'a, T> {
    /// The elements, after the checks of [`slice`] with a stride of at
    /// least `size_of::<T>()` (so that no two overlap).
    pub(crate) fn new(p: *mut T, count: usize, stride: usize, name: &str) -> Result<Self, Error> {
        check_array(p, count, stride, name)?;
        Ok(StridedMut {
            base: p.cast(),
            count,
            stride,
            _t: PhantomData,
        })
    }

    pub(crate) fn len(&self) -> usize {
        self.count
    }

    /// Element `i`.
    ///
    /// # Panics
    /// If `i >= len()` (caught at the boundary like any panic).
    pub(crate) fn get(&self, i: usize) -> &T {
        assert!(i < self.count, "element {i} of {}", self.count);
        // SAFETY: `i < count`, inside the checked span, aligned; elements
        // do not overlap (stride >= size).
        unsafe { &*self.base.add(i * self.stride).cast::<T>() }
    }

    /// Element `i`, written.
    ///
    /// # Panics
    /// If `i >= len()`.
    pub(crate) fn get_mut(&mut self, i: usize) -> &mut T {
        assert!(i < self.count, "element {i} of {}", self.count);
        // SAFETY: as `get`; `&mut self` makes the reference unique.
        unsafe { &mut *self.base.add(i * self.stride).cast::<T>() }
    }
}

/// A handle as the host holds it: a pointer to this (the C side sees an
/// opaque struct). `magic` says the kind, or that it was released.
#[repr(C)]
pub(crate) struct Handle<T> {
    magic: u32,
    inner: Option<T>,
}

/// The `magic` of a released handle (of any kind).
const RELEASED: u32 = 0x5045_4144; // "DEAP": dead packtrace handle

/// The kinds of handle: a magic number and a name for messages.
pub(crate) trait Kind: Sized + Send + 'static {
    /// The opaque type the host sees.
    type Opaque;
    const MAGIC: u32;
    const NAME: &'static str;
}

/// How many released handles stay allocated, marked released, so that a
/// later use of one is reported ([`PacktraceStatus::ReleasedHandle`])
/// rather than reading freed memory: the last 1024 (a few tens of bytes
/// each; their contents are freed at once).
pub(crate) const QUARANTINE: usize = 1024;

static RELEASED_HANDLES: Mutex<VecDeque<Box<dyn Send>>> = Mutex::new(VecDeque::new());

/// A new handle owning `inner`.
pub(crate) fn new_handle<T: Kind>(inner: T) -> *mut T::Opaque {
    Box::into_raw(Box::new(Handle {
        magic: T::MAGIC,
        inner: Some(inner),
    }))
    .cast()
}

/// The handle's header, if `p` is one of a live handle of kind `T`.
fn header<'a, T: Kind>(p: *const T::Opaque, name: &str) -> Result<&'a Handle<T>, Error> {
    // The magic first, through a `u32` (every handle starts with it), so
    // that no `Handle<T>` reference is made to a handle of another kind.
    let magic = *read(p.cast::<u32>(), name)?;
    match magic {
        m if m == T::MAGIC => read(p.cast::<Handle<T>>(), name),
        RELEASED => Err(Error::new(
            PacktraceStatus::ReleasedHandle,
            format!("argument `{name}` is a released handle"),
        )),
        _ => Err(Error::new(
            PacktraceStatus::InvalidHandle,
            format!("argument `{name}` is not a packtrace {} handle", T::NAME),
        )),
    }
}

/// The object behind handle `p`.
pub(crate) fn handle<'a, T: Kind>(p: *const T::Opaque, name: &str) -> Result<&'a T, Error> {
    let h = header::<T>(p, name)?;
    h.inner
        .as_ref()
        .ok_or_else(|| Error::new(PacktraceStatus::ReleasedHandle, "released handle"))
}

/// The object behind handle `p`, to change it (the host promises that no
/// other thread uses the handle meanwhile).
pub(crate) fn handle_mut<'a, T: Kind>(p: *mut T::Opaque, name: &str) -> Result<&'a mut T, Error> {
    header::<T>(p, name)?;
    let h = write(p.cast::<Handle<T>>(), name)?;
    h.inner
        .as_mut()
        .ok_or_else(|| Error::new(PacktraceStatus::ReleasedHandle, "released handle"))
}

/// Releases handle `p` (NULL: nothing to do): its object is dropped now
/// (a tree shared with a scene lives on in the scene), its header is kept
/// among the last [`QUARANTINE`] released ones, marked released.
pub(crate) fn release<T: Kind>(p: *mut T::Opaque, name: &str) -> Result<(), Error> {
    if p.is_null() {
        return Ok(());
    }
    header::<T>(p, name)?;
    // SAFETY: `p` came from `new_handle::<T>` (its magic says so, checked
    // above, and a released one is refused there), so it is a live
    // `Box<Handle<T>>` that nobody else owns; the host promises no other
    // thread uses it now.
    let mut h = unsafe { Box::from_raw(p.cast::<Handle<T>>()) };
    h.magic = RELEASED;
    let inner = h.inner.take();
    let evicted = {
        let mut q = RELEASED_HANDLES
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        q.push_back(h);
        (q.len() > QUARANTINE).then(|| q.pop_front())
    };
    // Dropped outside the lock.
    drop((inner, evicted));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Thing(Vec<u8>);
    struct OpaqueThing;
    impl Kind for Thing {
        type Opaque = OpaqueThing;
        const MAGIC: u32 = 7;
        const NAME: &'static str = "thing";
    }

    #[test]
    fn spans_that_overflow_are_refused() {
        assert_eq!(span(0, 12, 12), Some(0));
        assert_eq!(span(1, 16, 12), Some(12));
        assert_eq!(span(3, 16, 12), Some(44));
        assert_eq!(span(usize::MAX, 16, 12), None);
        assert_eq!(span(usize::MAX / 8, 16, 12), None);
        let p = std::ptr::dangling::<f32>();
        let e = check_array(p, usize::MAX / 4, 12, "v").unwrap_err();
        assert_eq!(e.status, PacktraceStatus::InvalidArgument);
        assert!(e.message.contains("overflow"), "{}", e.message);
        let e = check_array(p.cast::<[f32; 3]>(), 2, 8, "v").unwrap_err();
        assert!(e.message.contains("at least 12"), "{}", e.message);
        let e = check_array(p.cast::<[f32; 3]>(), 2, 14, "v").unwrap_err();
        assert!(e.message.contains("multiple of 4"), "{}", e.message);
    }

    #[test]
    fn strided_records_are_read_in_place() {
        // Interleaved position + one extra float.
        let v: Vec<f32> = (0..12).map(|i| i as f32).collect();
        let r = strided3(v.as_ptr(), 3, 16, "v").unwrap();
        assert_eq!(r, [[0.0, 1.0, 2.0], [4.0, 5.0, 6.0], [8.0, 9.0, 10.0]]);
        assert!(
            strided3::<f32>(std::ptr::null(), 0, 0, "v")
                .unwrap()
                .is_empty()
        );
        let e = strided3(v.as_ptr().wrapping_byte_add(2), 1, 12, "v").unwrap_err();
        assert_eq!(e.status, PacktraceStatus::Misaligned);
    }

    #[test]
    fn released_handles_are_reported_until_evicted() {
        let p = new_handle(Thing(vec![1, 2, 3]));
        assert_eq!(handle::<Thing>(p, "h").unwrap().0, [1, 2, 3]);
        handle_mut::<Thing>(p, "h").unwrap().0.push(4);
        release::<Thing>(p, "h").unwrap();
        let e = handle::<Thing>(p, "h").err().unwrap();
        assert_eq!(e.status, PacktraceStatus::ReleasedHandle);
        assert_eq!(
            release::<Thing>(p, "h").unwrap_err().status,
            PacktraceStatus::ReleasedHandle
        );
        assert!(release::<Thing>(std::ptr::null_mut(), "h").is_ok());
    }
}

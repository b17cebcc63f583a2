//! The traversals' stack of deferred cells, uninitialised: part of the
//! crate's one `unsafe` module (`kernel`), as a leaf that imports nothing,
//! so that the traversals it serves (`scalar.rs`, `packet.rs`, `group.rs`)
//! depend on it without depending on the kernels that inline them.

/// A stack of deferred cells, left uninitialised: the scalar,
/// packet and group traversals had filled their whole array with a
/// placeholder on every call (a `memset` per ray: 2.5 % of a scalar primary
/// ray's instructions on the teapot, callgrind; about 5 % of the packet
/// kernel's samples, perf), for slots that are written before they are
/// read.
///
/// Invariant: slots `0..len` were written by [`Stack::push`].
pub(crate) struct Stack<T: Copy, const N: usize> {
    items: [std::mem::MaybeUninit<T>; N],
    len: usize,
}

impl<T: Copy, const N: usize> Stack<T, N> {
    /// An empty stack (no slot written).
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Stack {
            items: [const { std::mem::MaybeUninit::uninit() }; N],
            len: 0,
        }
    }

    /// Pushes `t`. Panics when full: a traversal sizes its stack by the
    /// tree's depth limit, which bounds the deferred cells (a leaf at depth
    /// d has at most d far children deferred above it).
    #[inline(always)]
    pub(crate) fn push(&mut self, t: T) {
        self.items[self.len] = std::mem::MaybeUninit::new(t);
        self.len += 1;
    }

    /// Pops the last pushed entry, or `None` when empty.
    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: `len` was at least 1 and slot `len - 1` (now `len`) was
        // written by `push` (the invariant: slots `0..len` are written,
        // and `pop` only ever shrinks `len` over written slots).
        Some(unsafe { self.items.get_unchecked(self.len).assume_init() })
    }
}

#[cfg(test)]
mod tests {
    use super::Stack;

    /// The uninitialised stack returns what was pushed, last in first out,
    /// then `None`; refilled slots read their new values (Miri checks that
    /// no uninitialised slot is ever read).
    #[test]
    fn the_stack_pops_what_was_pushed_and_never_an_unwritten_slot() {
        let mut s = Stack::<(u32, f32), 4>::new();
        assert_eq!(s.pop(), None);
        s.push((1, 1.5));
        s.push((2, 2.5));
        assert_eq!(s.pop(), Some((2, 2.5)));
        s.push((3, 3.5));
        s.push((4, 4.5));
        s.push((5, 5.5));
        assert_eq!(s.pop(), Some((5, 5.5)));
        assert_eq!(s.pop(), Some((4, 4.5)));
        assert_eq!(s.pop(), Some((3, 3.5)));
        assert_eq!(s.pop(), Some((1, 1.5)));
        assert_eq!(s.pop(), None);
        assert_eq!(s.pop(), None);
    }

    /// A push beyond the capacity panics (the traversals size the stack so
    /// that it never happens) rather than writing out of bounds.
    #[test]
    #[should_panic(expected = "index out of bounds")]
    fn a_full_stack_refuses_a_push() {
        let mut s = Stack::<u32, 2>::new();
        for i in 0..3 {
            s.push(i);
        }
    }
}

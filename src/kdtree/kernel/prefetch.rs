//! Cache prefetch hints for the traversals: part of the crate's one
//! `unsafe` module (`kernel`), as a leaf that imports nothing, like
//! `stack.rs`.

/// Ask the CPU to bring the line holding `r` into L1 (`prefetcht0`). A
/// hint only: it never faults and changes no result.
#[inline(always)]
pub(crate) fn prefetch<T>(r: &T) {
    prefetch_at((r as *const T).cast::<i8>());
}

/// [`prefetch`] every cache line of `*r`, first to last: the requests go
/// out together, before the first load that waits for one of them.
#[inline(always)]
pub(crate) fn prefetch_all<T>(r: &T) {
    let base = (r as *const T).cast::<i8>();
    let size = std::mem::size_of::<T>();
    let mut off = 0;
    while off < size {
        prefetch_at(base.wrapping_add(off));
        off += 64;
    }
    if size > 0 {
        prefetch_at(base.wrapping_add(size - 1));
    }
}

/// `prefetcht0` of the line holding byte `p` (inside one object).
#[inline(always)]
fn prefetch_at(p: *const i8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `_mm_prefetch` needs SSE, which every x86-64 CPU has (it is
    // in the baseline target); a prefetch never faults and reads nothing
    // the program sees, whatever the address (here always inside an
    // object a reference was given for).
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(p);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

#[cfg(test)]
mod tests {
    use super::{prefetch, prefetch_all};

    #[test]
    fn prefetching_every_line_changes_nothing_for_any_size() {
        let big = [3.0f32; 97]; // 388 bytes: seven lines at most
        let byte = 5u8;
        prefetch_all(&big);
        prefetch_all(&byte);
        prefetch_all(&());
        prefetch_all(&big[96]);
        assert!(big.iter().all(|&x| x == 3.0));
        assert_eq!(byte, 5);
    }

    #[test]
    fn a_prefetch_changes_nothing_and_accepts_any_reference() {
        let corners = [[1.0f32, 2.0, 3.0]; 3];
        let words = vec![7u32; 100];
        prefetch(&corners);
        prefetch(&words[99]);
        prefetch(&());
        assert_eq!(corners, [[1.0, 2.0, 3.0]; 3]);
        assert!(words.iter().all(|&w| w == 7));
    }
}

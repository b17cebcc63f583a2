//! A cache prefetch hint for the traversals: part of the crate's one
//! `unsafe` module (`kernel`), as a leaf that imports nothing, like
//! `stack.rs`.

/// Ask the CPU to bring the line holding `r` into L1 (`prefetcht0`). A
/// hint only: it never faults and changes no result.
#[inline(always)]
pub(crate) fn prefetch<T>(r: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `_mm_prefetch` needs SSE, which every x86-64 CPU has (it is
    // in the baseline target); a prefetch reads nothing the program sees
    // and never faults, and `r` is a valid reference anyway.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>((r as *const T).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = r;
}

#[cfg(test)]
mod tests {
    use super::prefetch;

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

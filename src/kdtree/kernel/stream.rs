//! The stream traversal (`kdtree/stream/traverse.rs`) in the run-time
//! kernels: compiled once for the baseline target with the plain-loop
//! partition, once with AVX2 (gathers, left-pack through a permutation
//! table) and once with AVX-512 (gathers and compress over 16 lanes),
//! and the one [`Kernel::active`] names picked per call. The leaves'
//! 8-wide triangle tests and the single-ray walk are inlined into each.

use super::Kernel;
use super::partition::{Avx2, Avx512, Portable, Subsets};
use crate::kdtree::layout::Layout;
use crate::kdtree::stats::Counters;
use crate::kdtree::stream::rays::StreamRays;
use crate::kdtree::stream::traverse::trace_chunk;
use crate::ray::Ray;

/// One chunk's traversal (see `trace_chunk`) in kernel `k`, or in the
/// SSE one if the CPU lacks what `k` needs.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn chunk_in<T: Layout, const ANY: bool, C: Counters>(
    k: Kernel,
    tree: &T,
    input: &[Ray],
    src: &[u32],
    neg: [bool; 3],
    rays: &mut StreamRays,
    subsets: &mut Subsets,
    single_below: usize,
    boxes: bool,
    c: &mut C,
) {
    #[cfg(target_arch = "x86_64")]
    if k == Kernel::Avx512
        && Kernel::avx512_supported()
        && let Some(isa) = Avx512::detect()
    {
        // SAFETY: `avx512_supported` and `Avx512::detect` checked every
        // feature `chunk_avx512` is compiled with (AVX-512 F, VL, BW, DQ,
        // AVX2, POPCNT; `is_x86_feature_detected!`), so all its
        // instructions run on this CPU; the arguments are references.
        return unsafe {
            chunk_avx512::<T, ANY, C>(
                isa,
                tree,
                input,
                src,
                neg,
                rays,
                subsets,
                single_below,
                boxes,
                c,
            )
        };
    }
    #[cfg(target_arch = "x86_64")]
    if k != Kernel::Sse
        && let Some(isa) = Avx2::detect()
    {
        // SAFETY: `Avx2::detect` checked AVX2 and POPCNT
        // (`is_x86_feature_detected!`), the features `chunk_avx2` is
        // compiled with, so every instruction of it runs on this CPU.
        return unsafe {
            chunk_avx2::<T, ANY, C>(
                isa,
                tree,
                input,
                src,
                neg,
                rays,
                subsets,
                single_below,
                boxes,
                c,
            )
        };
    }
    let _ = k;
    chunk_sse::<T, ANY, C>(
        Portable,
        tree,
        input,
        src,
        neg,
        rays,
        subsets,
        single_below,
        boxes,
        c,
    );
}

/// The traversal compiled for the baseline target.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn chunk_sse<T: Layout, const ANY: bool, C: Counters>(
    isa: Portable,
    tree: &T,
    input: &[Ray],
    src: &[u32],
    neg: [bool; 3],
    rays: &mut StreamRays,
    subsets: &mut Subsets,
    single_below: usize,
    boxes: bool,
    c: &mut C,
) {
    trace_chunk::<_, T, ANY, C>(
        isa,
        tree,
        input,
        src,
        neg,
        rays,
        subsets,
        single_below,
        boxes,
        c,
    );
}

/// The traversal compiled with AVX2 and POPCNT (no FMA: every value as
/// the scalar path rounds it).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn chunk_avx2<T: Layout, const ANY: bool, C: Counters>(
    isa: Avx2,
    tree: &T,
    input: &[Ray],
    src: &[u32],
    neg: [bool; 3],
    rays: &mut StreamRays,
    subsets: &mut Subsets,
    single_below: usize,
    boxes: bool,
    c: &mut C,
) {
    trace_chunk::<_, T, ANY, C>(
        isa,
        tree,
        input,
        src,
        neg,
        rays,
        subsets,
        single_below,
        boxes,
        c,
    );
}

/// The traversal compiled with AVX-512 (no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512bw,avx512dq,popcnt")]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn chunk_avx512<T: Layout, const ANY: bool, C: Counters>(
    isa: Avx512,
    tree: &T,
    input: &[Ray],
    src: &[u32],
    neg: [bool; 3],
    rays: &mut StreamRays,
    subsets: &mut Subsets,
    single_below: usize,
    boxes: bool,
    c: &mut C,
) {
    trace_chunk::<_, T, ANY, C>(
        isa,
        tree,
        input,
        src,
        neg,
        rays,
        subsets,
        single_below,
        boxes,
        c,
    );
}

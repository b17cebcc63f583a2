//! Run-time kernel choice: the packet traversal compiled twice, for AVX2
//! and for the baseline x86-64 (SSE2), and the one picked once per process
//! from what the CPU reports. This is the crate's only `unsafe`: calling a
//! `#[target_feature]` function is unsafe because running AVX2
//! instructions on a CPU without them is undefined behaviour.
//!
//! The default build targets baseline x86-64, so the only way to use AVX2
//! without `RUSTFLAGS` is a function compiled with
//! `#[target_feature(enable = "avx2")]` into which the whole traversal is
//! inlined (`traverse_packet` is `#[inline(always)]`, and so is everything
//! it calls on the hot path). Inside it, `F8`'s array lanes become single
//! AVX instructions (`simd/f8.rs`). FMA is not enabled: a fused
//! multiply-add rounds once where the scalar path rounds twice, and every
//! lane must equal the scalar result bit for bit.
//!
//! `PACKTRACE_KERNEL=sse` forces the baseline kernel on a machine with
//! AVX2 (tests run both; `.ci/run`), read once, at the first packet query.
//! Asking for `avx2` on a CPU without it falls back to SSE: the variable
//! can never make the crate run instructions the CPU lacks.

use super::layout::Layout;
use super::packet::traverse_packet;
use super::stats::Counters;
use crate::packet::{HitPacket, RayPacket};
use crate::simd::Lane;
use std::sync::atomic::{AtomicU8, Ordering};

/// An instruction set the packet traversal is compiled for.
///
/// ```
/// use packtrace::kdtree::Kernel;
/// let k = Kernel::active();
/// assert!(k == Kernel::Sse || k == Kernel::Avx2);
/// assert_eq!(Kernel::Avx2.name(), "avx2");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Baseline x86-64 (SSE2), or the portable build on other targets.
    Sse,
    /// AVX2: 8-wide lanes in one register, VEX encoding for 4-wide ones.
    Avx2,
}

/// 0: not chosen yet; otherwise `Kernel as u8 + 1`.
static ACTIVE: AtomicU8 = AtomicU8::new(0);

impl Kernel {
    /// The kernel packet queries use in this process: AVX2 when the CPU
    /// has it and `PACKTRACE_KERNEL` does not say `sse`.
    #[must_use]
    pub fn active() -> Kernel {
        match ACTIVE.load(Ordering::Relaxed) {
            1 => Kernel::Sse,
            2 => Kernel::Avx2,
            _ => {
                let k = Kernel::choose(std::env::var("PACKTRACE_KERNEL").ok().as_deref());
                ACTIVE.store(k as u8 + 1, Ordering::Relaxed);
                k
            }
        }
    }

    /// The kernel for a `PACKTRACE_KERNEL` value on this CPU.
    fn choose(var: Option<&str>) -> Kernel {
        if var.is_some_and(|v| v.eq_ignore_ascii_case("sse")) {
            return Kernel::Sse;
        }
        if Kernel::avx2_supported() {
            Kernel::Avx2
        } else {
            Kernel::Sse
        }
    }

    /// Does this CPU run AVX2?
    ///
    /// ```
    /// let _ = packtrace::kdtree::Kernel::avx2_supported();
    /// ```
    #[must_use]
    pub fn avx2_supported() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx2")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }

    /// The kernel's name in the bench's JSON (`"sse"`, `"avx2"`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Sse => "sse",
            Kernel::Avx2 => "avx2",
        }
    }
}

/// The packet traversal in the active kernel.
#[inline]
pub(crate) fn packet<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    #[cfg(target_arch = "x86_64")]
    if Kernel::active() == Kernel::Avx2 {
        // SAFETY: `Kernel::active` is `Avx2` only when
        // `is_x86_feature_detected!("avx2")` returned true on this CPU
        // (`Kernel::choose`), so every instruction `avx2` may contain is
        // supported; its arguments are plain references, valid for the call.
        return unsafe { avx2::<L, T, ANY, C>(tree, p, c) };
    }
    sse::<L, T, ANY, C>(tree, p, c)
}

/// The traversal compiled for the baseline target.
#[inline(never)]
fn sse<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    traverse_packet::<L, T, ANY, C>(tree, p, c)
}

/// The traversal compiled with AVX2 enabled (and no FMA: bit-exact lanes).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn avx2<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    traverse_packet::<L, T, ANY, C>(tree, p, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_variable_can_only_downgrade() {
        assert_eq!(Kernel::choose(Some("sse")), Kernel::Sse);
        assert_eq!(Kernel::choose(Some("SSE")), Kernel::Sse);
        let best = if Kernel::avx2_supported() {
            Kernel::Avx2
        } else {
            Kernel::Sse
        };
        assert_eq!(Kernel::choose(None), best);
        assert_eq!(Kernel::choose(Some("avx2")), best);
        assert_eq!(Kernel::choose(Some("avx512")), best);
    }
}

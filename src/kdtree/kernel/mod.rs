//! Run-time kernel choice: the packet traversal compiled twice, for AVX2
//! and for the baseline x86-64 (SSE2), and the one picked once per process
//! from what the CPU reports. This module is the crate's only `unsafe`:
//! calling a `#[target_feature]` function is unsafe because running AVX2
//! instructions on a CPU without them is undefined behaviour; the AVX
//! intrinsics of an instance's packet build; the traversals'
//! uninitialised stack (`stack.rs`); and the scalar leaves' prefetch hint
//! (`prefetch.rs`).
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
//! A third kernel enables AVX-512 (F, VL, BW, DQ) for the same 256-bit
//! lanes: 32 vector registers and mask registers instead of 16 and blends,
//! which the triangle test's register pressure needs.
//!
//! `PACKTRACE_KERNEL=sse` (or `avx2`) forces a lesser kernel on a machine
//! that has a better one (tests run them all; `.ci/run`), read once, at
//! the first packet query. The variable can only choose among the kernels
//! the CPU runs: it can never make the crate run instructions the CPU
//! lacks. The unit tests below run every kernel the CPU has, name on
//! standard error the ones it lacks, and fail instead when
//! `PACKTRACE_EXPECT_KERNELS` lists one (`.ci/run` sets it from the CPU's
//! flags).

// The BVHs' kernels (`src/bvh/`'s traversals, dispatched here).
pub(crate) mod bvh;
// A leaf (imports nothing): the traversals use it without importing the
// kernels that inline them.
#[cfg(target_arch = "x86_64")]
mod lanes;
pub(crate) mod partition;
pub(crate) mod prefetch;
pub(crate) mod stack;
pub(crate) mod stream;

use super::group::traverse_group;
use super::layout::Layout;
use super::packet::{traverse_packet, traverse_packet_from};
use super::stats::Counters;
use crate::aabb::Aabb;
use crate::frustum::Frustum;
use crate::packet::{HitPacket, RayPacket};
use crate::simd::{F8, Lane};
use glam::Vec3A;
use std::sync::atomic::{AtomicU8, Ordering};

/// An instruction set the packet traversal is compiled for.
///
/// ```
/// use packtrace::kdtree::Kernel;
/// let k = Kernel::active();
/// assert!([Kernel::Sse, Kernel::Avx2, Kernel::Avx512].contains(&k));
/// assert_eq!(Kernel::Avx2.name(), "avx2");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Baseline x86-64 (SSE2), or the portable build on other targets.
    Sse,
    /// AVX2: 8-wide lanes in one register, VEX encoding for 4-wide ones.
    Avx2,
    /// AVX-512 (F, VL, BW, DQ) at 256 bits: the AVX2 kernel with 32 vector
    /// registers and mask registers, which the triangle test's register
    /// pressure needs (measured: docs/packets-and-kernels.md).
    Avx512,
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
            3 => Kernel::Avx512,
            _ => {
                let k = Kernel::choose(std::env::var("PACKTRACE_KERNEL").ok().as_deref());
                ACTIVE.store(k as u8 + 1, Ordering::Relaxed);
                k
            }
        }
    }

    /// The kernel for a `PACKTRACE_KERNEL` value on this CPU: the best
    /// one it supports, or a lesser one the variable names.
    fn choose(var: Option<&str>) -> Kernel {
        let best = Kernel::best_supported();
        match var.map(str::to_ascii_lowercase).as_deref() {
            Some("sse") => Kernel::Sse,
            Some("avx2") if best != Kernel::Sse => Kernel::Avx2,
            _ => best,
        }
    }

    /// The fastest kernel this CPU runs.
    ///
    /// ```
    /// let _ = packtrace::kdtree::Kernel::best_supported();
    /// ```
    #[must_use]
    pub fn best_supported() -> Kernel {
        if Kernel::avx512_supported() {
            Kernel::Avx512
        } else if Kernel::avx2_supported() {
            Kernel::Avx2
        } else {
            Kernel::Sse
        }
    }

    /// Does this CPU run the AVX-512 kernel (F, VL, BW, DQ)?
    ///
    /// ```
    /// let _ = packtrace::kdtree::Kernel::avx512_supported();
    /// ```
    #[must_use]
    pub fn avx512_supported() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl")
                && std::arch::is_x86_feature_detected!("avx512bw")
                && std::arch::is_x86_feature_detected!("avx512dq")
                && Kernel::avx2_supported()
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
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

    /// The kernel's name in the bench's JSON (`"sse"`, `"avx2"`,
    /// `"avx512"`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Sse => "sse",
            Kernel::Avx2 => "avx2",
            Kernel::Avx512 => "avx512",
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
    packet_in::<L, T, ANY, C>(Kernel::active(), tree, p, c)
}

/// The packet traversal in kernel `k`, or in the SSE one if the CPU lacks
/// what `k` needs (tests run both kernels in one process this way).
#[inline]
pub(crate) fn packet_in<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    k: Kernel,
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    #[cfg(target_arch = "x86_64")]
    if k == Kernel::Avx512 && Kernel::avx512_supported() {
        // SAFETY: `avx512_supported` checked every feature `avx512` is
        // compiled with (`is_x86_feature_detected!`, true here), so all its
        // instructions run on this CPU; the arguments are plain references.
        return unsafe { avx512::<L, T, ANY, C>(tree, p, c) };
    }
    #[cfg(target_arch = "x86_64")]
    if k != Kernel::Sse && Kernel::avx2_supported() {
        // SAFETY: `avx2_supported` is `is_x86_feature_detected!("avx2")`,
        // true here, so every instruction `avx2` may contain runs on this
        // CPU; its arguments are plain references, valid for the call.
        return unsafe { avx2::<L, T, ANY, C>(tree, p, c) };
    }
    let _ = k;
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

/// The traversal compiled with AVX-512 enabled (256-bit lanes with 32
/// registers and mask registers; no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512bw,avx512dq")]
#[inline(never)]
fn avx512<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    p: &RayPacket<L>,
    c: &mut C,
) -> HitPacket<L> {
    traverse_packet::<L, T, ANY, C>(tree, p, c)
}

/// What a kernel builds before it traces: a packet computed from other
/// lanes (a scene's world rays in an instance's space), so that the
/// arithmetic runs with the kernel's instructions rather than the
/// baseline's. Implementations are `#[inline(always)]`.
pub(crate) trait BuildPacket<L: Lane> {
    /// The caller already knows the packet's active lanes share one
    /// octant and are more than [`super::single_ray_lanes`] (`hybrid.rs`
    /// checked them): the kernel skips its own check.
    const CHECKED: bool = false;
    /// What the kernel returns for a traced packet.
    type Out;
    /// The packet to trace.
    fn build(&self) -> RayPacket<L>;
    /// The traced packet's hits made [`BuildPacket::Out`], in the kernel
    /// that traced them (a scene merges them into each lane's best hit so
    /// far with the kernel's instructions; callers that trace a handed-back
    /// packet themselves call it too).
    fn finish(&mut self, h: HitPacket<L>) -> Self::Out;
    /// [`BuildPacket::build`] in a kernel with AVX2 (`isa` proves it),
    /// equal to it bit for bit: a builder may use AVX instructions here
    /// ([`affine_packet8`]). By default `build` itself.
    #[inline(always)]
    fn build_avx2(&self, isa: Avx2) -> RayPacket<L> {
        let _ = isa;
        self.build()
    }
}

/// Proof that the running kernel has AVX2: made only in `built_avx2` and
/// `built_avx512`, which run only after the CPU reported their features
/// (`built_in`), so a function given one may run AVX2 instructions.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2 {
    _private: (),
}

/// Eight rays moved by the affine map `x -> A x + b` (`a`: the columns of
/// `A`) and made a packet, in AVX registers: what
/// `Transform::lanes_to_object` and then [`RayPacket::from_lanes_unchecked`]
/// compute, with the same IEEE operations in the same order, so equal bit
/// for bit (tested below). `None` unless `L` is [`F8`].
///
/// Why intrinsics here and nowhere else: written generically, this build
/// reached LLVM as eight scalar chains per component, and its SLP
/// vectoriser packed them across rows and components (2- and 4-lane
/// pieces, lane-by-lane flush branches, about 460 instructions per packet
/// in the AVX2 kernel; outlining it into its own AVX2 function did not
/// help). The traversal's lanes, which come from loads, vectorise cleanly.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn affine_packet8<L: Lane>(
    isa: Avx2,
    a: &[Vec3A; 3],
    b: Vec3A,
    org: &[L; 3],
    dir: &[L; 3],
    t_min: L,
    t_max: L,
    active: u32,
) -> Option<RayPacket<L>> {
    use std::any::Any;
    let _ = isa;
    // `L` is `F8` exactly when these succeed (compiled away either way).
    let org = (org as &dyn Any).downcast_ref::<[F8; 3]>()?;
    let dir = (dir as &dyn Any).downcast_ref::<[F8; 3]>()?;
    let t_min = *(&t_min as &dyn Any).downcast_ref::<F8>()?;
    let t_max = *(&t_max as &dyn Any).downcast_ref::<F8>()?;
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: `isa` exists only inside `built_avx2` and
        // `built_avx512`, which run only on a CPU that reported AVX2
        // (`built_in`): every instruction of `avx2_affine` runs here. Its
        // arguments are plain values and references.
        let p = unsafe { avx2_affine(a, b, org, dir, t_min, t_max, active) };
        (&p as &dyn Any).downcast_ref::<RayPacket<L>>().copied()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (a, b, org, dir, t_min, t_max, active);
        None
    }
}

/// [`affine_packet8`]'s arithmetic, one AVX instruction per step. Read it
/// beside `Transform::lanes_to_object` and
/// [`RayPacket::from_lanes_unchecked`]: the same operations in the same
/// order (no FMA), so every lane equals the scalar ray bit for bit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn avx2_affine(
    a: &[Vec3A; 3],
    b: Vec3A,
    org: &[F8; 3],
    dir: &[F8; 3],
    t_min: F8,
    t_max: F8,
    active: u32,
) -> RayPacket<F8> {
    use std::arch::x86_64::{
        __m256, _CMP_LT_OQ, _mm256_add_ps, _mm256_and_ps, _mm256_and_si256, _mm256_blendv_ps,
        _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_div_ps, _mm256_loadu_ps,
        _mm256_max_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_set_epi32, _mm256_set1_epi32,
        _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps,
    };
    let load = |x: F8| {
        let x = x.to_array();
        // SAFETY: `x` is eight initialised `f32` (an unaligned load).
        unsafe { _mm256_loadu_ps(x.as_ptr()) }
    };
    let store = |v: __m256| {
        let mut x = [0.0f32; 8];
        // SAFETY: `x` has room for eight `f32` (an unaligned store).
        unsafe { _mm256_storeu_ps(x.as_mut_ptr(), v) };
        F8::from(x)
    };
    // Row r of `A` times v: `(a[0][r] v.x + a[1][r] v.y) + a[2][r] v.z`.
    let row = |r: usize, v: &[__m256; 3]| {
        let x = _mm256_mul_ps(_mm256_set1_ps(a[0][r]), v[0]);
        let y = _mm256_mul_ps(_mm256_set1_ps(a[1][r]), v[1]);
        let z = _mm256_mul_ps(_mm256_set1_ps(a[2][r]), v[2]);
        _mm256_add_ps(_mm256_add_ps(x, y), z)
    };
    let o = [load(org[0]), load(org[1]), load(org[2])];
    let d = [load(dir[0]), load(dir[1]), load(dir[2])];
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    // Object-space origin `A o + b` and direction `A d`.
    let o = [
        _mm256_add_ps(row(0, &o), _mm256_set1_ps(b.x)),
        _mm256_add_ps(row(1, &o), _mm256_set1_ps(b.y)),
        _mm256_add_ps(row(2, &o), _mm256_set1_ps(b.z)),
    ];
    let d = [row(0, &d), row(1, &d), row(2, &d)];
    // Active lanes: bit i of `active` AND-ed with lane i's bit, compared.
    let bit = _mm256_set_epi32(128, 64, 32, 16, 8, 4, 2, 1);
    let on = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
        _mm256_and_si256(_mm256_set1_epi32(active as i32), bit),
        bit,
    ));
    // Flush tiny components (`flush_tiny`, ray.rs): `|d| < MIN_POSITIVE`
    // or `|d| / max < MIN_POSITIVE` becomes `d * 0`; `max` as `max_keep`
    // takes it (`maxps(o, s)` is `o > s ? o : s`).
    let abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX));
    let abs = [
        _mm256_and_ps(d[0], abs_mask),
        _mm256_and_ps(d[1], abs_mask),
        _mm256_and_ps(d[2], abs_mask),
    ];
    let max = _mm256_max_ps(abs[2], _mm256_max_ps(abs[1], abs[0]));
    let tiny = _mm256_set1_ps(f32::MIN_POSITIVE);
    let flushed = |d: __m256, a: __m256| {
        let flush = _mm256_or_ps(
            _mm256_cmp_ps::<_CMP_LT_OQ>(a, tiny),
            _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_div_ps(a, max), tiny),
        );
        let d = _mm256_blendv_ps(d, _mm256_mul_ps(d, zero), flush);
        _mm256_blendv_ps(one, d, on)
    };
    let d = [
        flushed(d[0], abs[0]),
        flushed(d[1], abs[1]),
        flushed(d[2], abs[2]),
    ];
    // Inactive lanes: zero origin, empty interval.
    let t_min = _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), load(t_min), on);
    let t_max = _mm256_blendv_ps(_mm256_set1_ps(f32::NEG_INFINITY), load(t_max), on);
    RayPacket::from_parts_unchecked(
        [
            store(_mm256_blendv_ps(zero, o[0], on)),
            store(_mm256_blendv_ps(zero, o[1], on)),
            store(_mm256_blendv_ps(zero, o[2], on)),
        ],
        [store(d[0]), store(d[1]), store(d[2])],
        [
            store(_mm256_div_ps(one, d[0])),
            store(_mm256_div_ps(one, d[1])),
            store(_mm256_div_ps(one, d[2])),
        ],
        store(t_min),
        store(t_max),
        active & 0xFF,
    )
}

/// A built packet: traced here when its active lanes share one octant and
/// are more than [`super::single_ray_lanes`], else handed back.
pub(crate) enum Built<L: Lane, O> {
    /// The kernel's hits, through [`BuildPacket::finish`].
    Traced(O),
    /// The packet, for the octant split or the single-ray switch.
    Divergent(RayPacket<L>),
}

/// An 8-wide packet as it is (the bare tree's packets and octant
/// sub-packets), copied into the kernel: `hybrid.rs` sends those through
/// [`built`] instead of [`packet`]. The same traversal inlined after a
/// packet built in the kernel compiles to full-width `ymm` operations,
/// where [`packet`]'s, which traces the caller's packet through a
/// reference, leaves most of its multiplications and subtractions as
/// pairs of 128-bit ones (callgrind by instruction, avx2 kernel, kd8
/// packet8 primary rays: bunny 946 -> 758, Sponza 1,013 -> 879, teapot
/// 483 -> 433 instructions per ray; the cause inside LLVM was not found).
/// 4-wide packets lose by it (bunny 717 -> 763) and keep [`packet`].
pub(crate) struct Given<'a, L: Lane>(pub &'a RayPacket<L>);

impl<L: Lane> BuildPacket<L> for Given<'_, L> {
    const CHECKED: bool = true;
    type Out = HitPacket<L>;
    #[inline(always)]
    fn build(&self) -> RayPacket<L> {
        *self.0
    }
    #[inline(always)]
    fn finish(&mut self, h: HitPacket<L>) -> HitPacket<L> {
        h
    }
}

/// Where a built packet's traversal starts: at the root ([`Root`], no
/// data), or at a node and its cell ([`At`]: a group's entry point,
/// `group.rs`). A type, not a value, so that each start is its own
/// kernel: an `Option` argument to the one kernel took packet8 primary
/// rays from 848 to 1,413 instructions per ray on Sponza (callgrind).
pub(crate) trait Start<T: Layout>: Copy {
    /// The packet traversal from this start.
    fn trace<L: Lane, const ANY: bool, C: Counters>(
        self,
        tree: &T,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L>;
}

/// The root of the tree.
#[derive(Clone, Copy)]
pub(crate) struct Root;

impl<T: Layout> Start<T> for Root {
    #[inline(always)]
    fn trace<L: Lane, const ANY: bool, C: Counters>(
        self,
        tree: &T,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L> {
        traverse_packet::<L, T, ANY, C>(tree, p, c)
    }
}

/// A node and its cell.
#[derive(Clone, Copy)]
pub(crate) struct At<'a, R>(pub R, pub &'a Aabb);

impl<T: Layout> Start<T> for At<'_, T::Ref> {
    #[inline(always)]
    fn trace<L: Lane, const ANY: bool, C: Counters>(
        self,
        tree: &T,
        p: &RayPacket<L>,
        c: &mut C,
    ) -> HitPacket<L> {
        traverse_packet_from::<L, T, ANY, C>(tree, p, self.0, self.1, c)
    }
}

/// Build and trace in one kernel (see [`BuildPacket`]).
#[inline(always)]
fn build_and_trace<
    L: Lane,
    T: Layout,
    B: BuildPacket<L>,
    S: Start<T>,
    const ANY: bool,
    C: Counters,
>(
    tree: &T,
    b: &mut B,
    start: S,
    isa: Option<Avx2>,
    c: &mut C,
) -> Built<L, B::Out> {
    let p = match isa {
        Some(isa) => b.build_avx2(isa),
        None => b.build(),
    };
    // The hits pass through memory before `finish`: handed on in
    // registers, they left LLVM's SLP vectoriser without the stores it
    // starts from, and it scalarised the traversal's `F8` arithmetic
    // (callgrind, avx2, instance packet8 primary: teapot 460 -> 750
    // instructions per ray without this `black_box`).
    let trace =
        |p: &RayPacket<L>, c: &mut C| std::hint::black_box(start.trace::<L, ANY, C>(tree, p, c));
    if B::CHECKED {
        return Built::Traced(b.finish(trace(&p, c)));
    }
    let active = p.active();
    let [nx, ny, nz] = p.neg_bits();
    let one_octant =
        (nx == 0 || nx == active) && (ny == 0 || ny == active) && (nz == 0 || nz == active);
    if !one_octant || active.count_ones() <= super::single_ray_lanes(L::WIDTH) {
        return Built::Divergent(p);
    }
    Built::Traced(b.finish(trace(&p, c)))
}

/// [`build_and_trace`] in the active kernel.
#[inline]
pub(crate) fn built<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &mut B,
    c: &mut C,
) -> Built<L, B::Out> {
    built_in::<L, T, B, Root, ANY, C>(Kernel::active(), tree, b, Root, c)
}

/// [`built`] with the traversal started at node `start`, whose cell is
/// `cell`, instead of the root (a group's entry point, `group.rs`).
#[inline]
pub(crate) fn built_from<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &mut B,
    start: T::Ref,
    cell: &Aabb,
    c: &mut C,
) -> Built<L, B::Out> {
    built_in::<L, T, B, At<'_, T::Ref>, ANY, C>(Kernel::active(), tree, b, At(start, cell), c)
}

/// [`build_and_trace`] in kernel `k`, or in the SSE one if the CPU lacks
/// what `k` needs (as [`packet_in`]).
#[inline]
pub(crate) fn built_in<
    L: Lane,
    T: Layout,
    B: BuildPacket<L>,
    S: Start<T>,
    const ANY: bool,
    C: Counters,
>(
    k: Kernel,
    tree: &T,
    b: &mut B,
    start: S,
    c: &mut C,
) -> Built<L, B::Out> {
    #[cfg(target_arch = "x86_64")]
    if k == Kernel::Avx512 && Kernel::avx512_supported() {
        // SAFETY: as in `packet_in`: every feature `built_avx512` is
        // compiled with was detected on this CPU; plain references.
        return unsafe { built_avx512::<L, T, B, S, ANY, C>(tree, b, start, c) };
    }
    #[cfg(target_arch = "x86_64")]
    if k != Kernel::Sse && Kernel::avx2_supported() {
        // SAFETY: as in `packet_in`: AVX2 was detected on this CPU; the
        // arguments are plain references, valid for the call.
        return unsafe { built_avx2::<L, T, B, S, ANY, C>(tree, b, start, c) };
    }
    let _ = k;
    built_sse::<L, T, B, S, ANY, C>(tree, b, start, c)
}

/// The build and the traversal compiled for the baseline target.
#[inline(never)]
fn built_sse<L: Lane, T: Layout, B: BuildPacket<L>, S: Start<T>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &mut B,
    start: S,
    c: &mut C,
) -> Built<L, B::Out> {
    build_and_trace::<L, T, B, S, ANY, C>(tree, b, start, None, c)
}

/// The build and the traversal compiled with AVX2 (no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn built_avx2<L: Lane, T: Layout, B: BuildPacket<L>, S: Start<T>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &mut B,
    start: S,
    c: &mut C,
) -> Built<L, B::Out> {
    // This kernel runs only after the CPU reported AVX2 (`built_in`).
    build_and_trace::<L, T, B, S, ANY, C>(tree, b, start, Some(Avx2 { _private: () }), c)
}

/// The build and the traversal compiled with AVX-512 at 256 bits (no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512bw,avx512dq")]
#[inline(never)]
fn built_avx512<
    L: Lane,
    T: Layout,
    B: BuildPacket<L>,
    S: Start<T>,
    const ANY: bool,
    C: Counters,
>(
    tree: &T,
    b: &mut B,
    start: S,
    c: &mut C,
) -> Built<L, B::Out> {
    // This kernel runs only after the CPU reported AVX2 and AVX-512.
    build_and_trace::<L, T, B, S, ANY, C>(tree, b, start, Some(Avx2 { _private: () }), c)
}

/// The group traversal (`group.rs`) in the active kernel.
#[inline]
pub(crate) fn group<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    ps: &[RayPacket<L>],
    fr: &Frustum,
    cull: bool,
    out: &mut [HitPacket<L>],
    c: &mut C,
) {
    group_in::<L, T, ANY, C>(Kernel::active(), tree, ps, fr, cull, out, c);
}

/// The group traversal in kernel `k`, or in the SSE one if the CPU lacks
/// what `k` needs (as [`packet_in`]).
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn group_in<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    k: Kernel,
    tree: &T,
    ps: &[RayPacket<L>],
    fr: &Frustum,
    cull: bool,
    out: &mut [HitPacket<L>],
    c: &mut C,
) {
    #[cfg(target_arch = "x86_64")]
    if k == Kernel::Avx512 && Kernel::avx512_supported() {
        // SAFETY: as in `packet_in`: every feature `group_avx512` is
        // compiled with was detected on this CPU; plain references.
        return unsafe { group_avx512::<L, T, ANY, C>(tree, ps, fr, cull, out, c) };
    }
    #[cfg(target_arch = "x86_64")]
    if k != Kernel::Sse && Kernel::avx2_supported() {
        // SAFETY: as in `packet_in`: AVX2 was detected on this CPU; the
        // arguments are plain references, valid for the call.
        return unsafe { group_avx2::<L, T, ANY, C>(tree, ps, fr, cull, out, c) };
    }
    let _ = k;
    group_sse::<L, T, ANY, C>(tree, ps, fr, cull, out, c);
}

/// The group traversal compiled for the baseline target.
#[inline(never)]
fn group_sse<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    ps: &[RayPacket<L>],
    fr: &Frustum,
    cull: bool,
    out: &mut [HitPacket<L>],
    c: &mut C,
) {
    traverse_group::<L, T, ANY, C>(tree, ps, fr, cull, out, c);
}

/// The group traversal compiled with AVX2 (no FMA: bit-exact lanes).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn group_avx2<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    ps: &[RayPacket<L>],
    fr: &Frustum,
    cull: bool,
    out: &mut [HitPacket<L>],
    c: &mut C,
) {
    traverse_group::<L, T, ANY, C>(tree, ps, fr, cull, out, c);
}

/// The group traversal compiled with AVX-512 at 256 bits (no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512bw,avx512dq")]
#[inline(never)]
fn group_avx512<L: Lane, T: Layout, const ANY: bool, C: Counters>(
    tree: &T,
    ps: &[RayPacket<L>],
    fr: &Frustum,
    cull: bool,
    out: &mut [HitPacket<L>],
    c: &mut C,
) {
    traverse_group::<L, T, ANY, C>(tree, ps, fr, cull, out, c);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::stats::NoCount;
    use crate::packet::{HitPacket8, RayPacket8};
    use crate::simd::F4;
    use crate::{KdBuildParams, KdTree, Mesh, Ray, RayPacket4};
    use glam::Vec3;

    /// The kernels a test runs: those this CPU runs. The dispatch falls
    /// back to a lesser kernel when the CPU lacks one, so a kernel the CPU
    /// lacks is not run, and is named on standard error (written past the
    /// test harness's output capture, so a plain `cargo test` shows it).
    /// `PACKTRACE_EXPECT_KERNELS` (a comma list of `sse`, `avx2`,
    /// `avx512`; `.ci/run` sets it from the CPU flags in `/proc/cpuinfo`)
    /// turns that into a failure: CI never passes a kernel it did not run.
    fn kernels_to_test(test: &str) -> Vec<Kernel> {
        use std::io::Write;
        let supported = |k: Kernel| match k {
            Kernel::Sse => true,
            Kernel::Avx2 => Kernel::avx2_supported(),
            Kernel::Avx512 => Kernel::avx512_supported(),
        };
        let all = [Kernel::Sse, Kernel::Avx2, Kernel::Avx512];
        let expected: Vec<Kernel> = match std::env::var("PACKTRACE_EXPECT_KERNELS") {
            Ok(list) => list
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(|s| {
                    all.into_iter()
                        .find(|k| k.name() == s)
                        .unwrap_or_else(|| panic!("PACKTRACE_EXPECT_KERNELS: unknown kernel `{s}`"))
                })
                .collect(),
            Err(_) => Vec::new(),
        };
        for k in all.into_iter().filter(|&k| !supported(k)) {
            assert!(
                !expected.contains(&k),
                "{test}: PACKTRACE_EXPECT_KERNELS names the {} kernel, which this CPU does \
                 not run: the test would fall back to a lesser kernel",
                k.name()
            );
            let _ = writeln!(
                std::io::stderr(),
                "note: {test}: the {} kernel is not tested (this CPU lacks it)",
                k.name()
            );
        }
        all.into_iter().filter(|&k| supported(k)).collect()
    }

    /// Both kernels (AVX2 where the CPU has it), both widths, closest hit
    /// and occlusion: every lane equals the scalar query. Small enough for
    /// Miri, which runs the dispatch (and its `unsafe` block, when the
    /// interpreter reports AVX2).
    #[test]
    fn every_kernel_equals_scalar_lane_by_lane() {
        let mesh = Mesh::new(
            vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.5),
                Vec3::new(1.0, 1.0, -0.5),
            ],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap();
        let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
        let rays: Vec<Ray> = (0..8)
            .map(|i| {
                let x = -0.9 + 0.25 * i as f32;
                Ray::new(
                    Vec3::new(x, 0.1 * x, 2.0),
                    Vec3::new(0.01, 0.0, -1.0),
                    0.0,
                    9.0,
                )
                .unwrap()
            })
            .collect();
        for k in kernels_to_test("every_kernel_equals_scalar_lane_by_lane") {
            let p8 = RayPacket8::from_slice(&rays);
            let h8 = packet_in::<_, _, false, _>(k, &tree, &p8, &mut NoCount);
            let o8 = packet_in::<_, _, true, _>(k, &tree, &p8, &mut NoCount).mask();
            let p4 = RayPacket4::from_slice(&rays[3..]);
            let h4 = packet_in::<F4, _, false, _>(k, &tree, &p4, &mut NoCount);
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(h8.hit(i), tree.intersect(r), "{k:?} lane {i}");
                assert_eq!(o8 >> i & 1 == 1, tree.occluded(r), "{k:?} lane {i}");
            }
            for i in 0..4 {
                assert_eq!(h4.hit(i), tree.intersect(&rays[3 + i]), "{k:?} lane {i}");
            }
            assert!(h8.mask() != 0, "the rays hit");
        }
    }

    /// A packet a kernel builds itself: traced there, every lane equal to
    /// the scalar query, when its lanes share an octant; handed back
    /// unchanged when they do not. Small enough for Miri (the `unsafe`
    /// blocks of `built_in`).
    #[test]
    fn every_kernel_traces_a_built_packet_equal_to_scalar() {
        let mesh = Mesh::new(
            vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.5),
            ],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
        let ray = |x: f32, dz: f32| {
            Ray::new(
                Vec3::new(x, 0.0, 2.0 * -dz.signum()),
                Vec3::new(0.01, 0.0, dz),
                0.0,
                9.0,
            )
            .unwrap()
        };
        let coherent: Vec<Ray> = (0..8).map(|i| ray(-0.9 + 0.25 * i as f32, -1.0)).collect();
        let mixed: Vec<Ray> = (0..8)
            .map(|i| ray(0.1 * i as f32, [-1.0, 1.0][i % 2]))
            .collect();
        for k in kernels_to_test("every_kernel_traces_a_built_packet_equal_to_scalar") {
            let p = RayPacket8::from_slice(&coherent);
            let mut b = Given(&p);
            let Built::Traced(h) =
                built_in::<_, _, _, _, false, _>(k, &tree, &mut b, Root, &mut NoCount)
            else {
                panic!("{k:?}: one octant, eight lanes: traced in the kernel");
            };
            for (i, r) in coherent.iter().enumerate() {
                assert_eq!(h.hit(i), tree.intersect(r), "{k:?} lane {i}");
            }
            assert!(h.mask() != 0, "the rays hit");
            // A builder the caller has not checked (as a scene's).
            struct Unchecked(RayPacket8);
            impl BuildPacket<crate::simd::F8> for Unchecked {
                type Out = HitPacket8;
                fn build(&self) -> RayPacket8 {
                    self.0
                }
                fn finish(&mut self, h: HitPacket8) -> HitPacket8 {
                    h
                }
            }
            let mut b = Unchecked(RayPacket8::from_slice(&mixed));
            let Built::Divergent(p) =
                built_in::<_, _, _, _, true, _>(k, &tree, &mut b, Root, &mut NoCount)
            else {
                panic!("{k:?}: two octants: handed back");
            };
            assert_eq!(p.active(), 0xFF);
        }
    }

    /// The AVX form of an instance's packet equals the generic one bit for
    /// bit (origin, direction, reciprocal, interval, active lanes) on
    /// directions with tiny, subnormal and signed-zero components, a
    /// mirrored and a badly scaled map, and inactive lanes. Small enough
    /// for Miri where it reports AVX2.
    #[test]
    fn the_avx_instance_packet_equals_the_generic_one_bit_for_bit() {
        if !kernels_to_test("the_avx_instance_packet_equals_the_generic_one_bit_for_bit")
            .contains(&Kernel::Avx2)
        {
            return;
        }
        let isa = Avx2 { _private: () };
        let maps = [
            [
                Vec3A::new(0.3, -1.0, 2.0),
                Vec3A::new(1e-3, 0.7, 0.0),
                Vec3A::new(-4.0, 0.0, 1e5),
            ],
            [Vec3A::NEG_X, Vec3A::Y, Vec3A::new(0.0, 0.0, -2.5)],
        ];
        let b = Vec3A::new(0.5, -7.0, 1e-30);
        let lanes = |v: [f32; 8]| F8::from(v);
        let org = [
            lanes([0.0, 1.0, -2.0, 3.5, 1e6, -1e-6, 7.0, 0.25]),
            lanes([-0.0, 2.0, 9.0, -3.0, 0.5, 1e4, -7.0, 0.125]),
            lanes([1.0, -1.0, 0.0, 2.0, -5.0, 3.0, 1e-20, 6.0]),
        ];
        let dir = [
            lanes([1e-39, 1.0, -0.0, 3e-38, 1.0, -0.5, 2.0, 1e10]),
            lanes([0.0, -1e-38, 1.0, 1.0, 1e-45, 0.1, -3.0, 1e-30]),
            lanes([-1.0, 0.0, 1e-40, -1.0, 0.0, 0.2, 1e30, -1e-30]),
        ];
        let t_min = lanes([0.0, 0.5, 1.0, 0.0, 2.0, 0.0, 0.0, 0.25]);
        let t_max = lanes([9.0, f32::INFINITY, 3.0, 1e9, 4.0, 5.0, 6.0, 7.0]);
        let bits = |x: F8| x.to_array().map(f32::to_bits);
        for a in &maps {
            for active in [0xFF, 0x5A, 0x01, 0x80, 0x00] {
                let row = |r: usize, v: &[F8; 3]| {
                    F8::splat(a[0][r]) * v[0]
                        + F8::splat(a[1][r]) * v[1]
                        + F8::splat(a[2][r]) * v[2]
                };
                let o = [
                    row(0, &org) + F8::splat(b.x),
                    row(1, &org) + F8::splat(b.y),
                    row(2, &org) + F8::splat(b.z),
                ];
                let d = [row(0, &dir), row(1, &dir), row(2, &dir)];
                let want = RayPacket::from_lanes_unchecked(o, d, t_min, t_max, active);
                let got = affine_packet8(isa, a, b, &org, &dir, t_min, t_max, active).unwrap();
                assert_eq!(got.active(), want.active());
                for k in 0..3 {
                    assert_eq!(
                        bits(got.org()[k]),
                        bits(want.org()[k]),
                        "org {k} {active:#x}"
                    );
                    assert_eq!(
                        bits(got.dir()[k]),
                        bits(want.dir()[k]),
                        "dir {k} {active:#x}"
                    );
                    assert_eq!(
                        bits(got.inv_dir()[k]),
                        bits(want.inv_dir()[k]),
                        "inv_dir {k} {active:#x}"
                    );
                }
                assert_eq!(bits(got.t_min()), bits(want.t_min()));
                assert_eq!(bits(got.t_max()), bits(want.t_max()));
            }
        }
        // Other widths are not this form's.
        let f4 = [F4::splat(1.0); 3];
        let one = F4::splat(1.0);
        assert!(affine_packet8(isa, &maps[0], b, &f4, &f4, one, one, 0xF).is_none());
    }

    /// Every kernel traces a small group (closest hit and occlusion, leaf
    /// culling off and on) with every lane equal to the scalar query.
    /// Small enough for Miri, which runs the group dispatch's `unsafe`
    /// blocks where the interpreter reports the features.
    #[test]
    fn every_kernel_traces_a_group_equal_to_scalar() {
        use crate::frustum::{Apex, Frustum};
        let mesh = Mesh::new(
            vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.5),
                Vec3::new(1.0, 1.0, -0.5),
            ],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap();
        let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
        let eye = Vec3::new(0.1, 0.2, 3.0);
        let packets: Vec<RayPacket8> = (0..2)
            .map(|p| {
                RayPacket8::from_fn(|i| {
                    let (x, y) = ((i % 4) as f32, (i / 4 + 2 * p) as f32);
                    let d = Vec3::new(0.1 * x - 0.2, 0.1 * y - 0.2, -1.0);
                    Ray::new(eye, d, 0.0, 9.0).ok()
                })
            })
            .collect();
        let fr = Frustum::of_packets(&packets, eye, Apex::Origin).unwrap();
        for k in kernels_to_test("every_kernel_traces_a_group_equal_to_scalar") {
            for cull in [false, true] {
                let mut hits = [HitPacket8::default(); 2];
                let mut occ = [HitPacket8::default(); 2];
                group_in::<_, _, false, _>(k, &tree, &packets, &fr, cull, &mut hits, &mut NoCount);
                group_in::<_, _, true, _>(k, &tree, &packets, &fr, cull, &mut occ, &mut NoCount);
                for (j, p) in packets.iter().enumerate() {
                    for i in 0..8 {
                        let r = p.ray(i).unwrap();
                        assert_eq!(hits[j].hit(i), tree.intersect(&r), "{k:?} {j} {i}");
                        assert_eq!(
                            occ[j].mask() >> i & 1 == 1,
                            tree.occluded(&r),
                            "{k:?} {j} {i}"
                        );
                    }
                }
                assert!(hits[0].mask() != 0, "the rays hit");
            }
        }
    }

    #[test]
    fn the_variable_can_only_downgrade() {
        assert_eq!(Kernel::choose(Some("sse")), Kernel::Sse);
        assert_eq!(Kernel::choose(Some("SSE")), Kernel::Sse);
        let best = Kernel::best_supported();
        assert_eq!(Kernel::choose(None), best);
        assert_eq!(Kernel::choose(Some("avx512")), best);
        assert_eq!(Kernel::choose(Some("avx1024")), best);
        let avx2 = if best == Kernel::Sse {
            Kernel::Sse
        } else {
            Kernel::Avx2
        };
        assert_eq!(Kernel::choose(Some("avx2")), avx2);
        if Kernel::avx512_supported() {
            assert!(Kernel::avx2_supported());
        }
    }
}

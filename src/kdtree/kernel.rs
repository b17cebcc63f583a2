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
//! A third kernel enables AVX-512 (F, VL, BW, DQ) for the same 256-bit
//! lanes: 32 vector registers and mask registers instead of 16 and blends,
//! which the triangle test's register pressure needs.
//!
//! `PACKTRACE_KERNEL=sse` (or `avx2`) forces a lesser kernel on a machine
//! that has a better one (tests run them all; `.ci/run`), read once, at
//! the first packet query. The variable can only choose among the kernels
//! the CPU runs: it can never make the crate run instructions the CPU
//! lacks.

use super::group::traverse_group;
use super::layout::Layout;
use super::packet::traverse_packet;
use super::stats::Counters;
use crate::frustum::Frustum;
use crate::packet::{HitPacket, RayPacket};
use crate::simd::Lane;
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
    /// pressure needs (measured: README, packet section).
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
    /// The packet to trace.
    fn build(&self) -> RayPacket<L>;
}

/// A built packet: traced here when its active lanes share one octant and
/// are more than [`super::single_ray_lanes`], else handed back.
pub(crate) enum Built<L: Lane> {
    /// The kernel's hits.
    Traced(HitPacket<L>),
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
    #[inline(always)]
    fn build(&self) -> RayPacket<L> {
        *self.0
    }
}

/// Build and trace in one kernel (see [`BuildPacket`]).
#[inline(always)]
fn build_and_trace<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &B,
    c: &mut C,
) -> Built<L> {
    let p = b.build();
    if B::CHECKED {
        return Built::Traced(traverse_packet::<L, T, ANY, C>(tree, &p, c));
    }
    let active = p.active();
    let [nx, ny, nz] = p.neg_bits();
    let one_octant =
        (nx == 0 || nx == active) && (ny == 0 || ny == active) && (nz == 0 || nz == active);
    if !one_octant || active.count_ones() <= super::single_ray_lanes(L::WIDTH) {
        return Built::Divergent(p);
    }
    Built::Traced(traverse_packet::<L, T, ANY, C>(tree, &p, c))
}

/// [`build_and_trace`] in the active kernel.
#[inline]
pub(crate) fn built<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &B,
    c: &mut C,
) -> Built<L> {
    built_in::<L, T, B, ANY, C>(Kernel::active(), tree, b, c)
}

/// [`build_and_trace`] in kernel `k`, or in the SSE one if the CPU lacks
/// what `k` needs (as [`packet_in`]).
#[inline]
pub(crate) fn built_in<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    k: Kernel,
    tree: &T,
    b: &B,
    c: &mut C,
) -> Built<L> {
    #[cfg(target_arch = "x86_64")]
    if k == Kernel::Avx512 && Kernel::avx512_supported() {
        // SAFETY: as in `packet_in`: every feature `built_avx512` is
        // compiled with was detected on this CPU; plain references.
        return unsafe { built_avx512::<L, T, B, ANY, C>(tree, b, c) };
    }
    #[cfg(target_arch = "x86_64")]
    if k != Kernel::Sse && Kernel::avx2_supported() {
        // SAFETY: as in `packet_in`: AVX2 was detected on this CPU; the
        // arguments are plain references, valid for the call.
        return unsafe { built_avx2::<L, T, B, ANY, C>(tree, b, c) };
    }
    let _ = k;
    built_sse::<L, T, B, ANY, C>(tree, b, c)
}

/// The build and the traversal compiled for the baseline target.
#[inline(never)]
fn built_sse<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &B,
    c: &mut C,
) -> Built<L> {
    build_and_trace::<L, T, B, ANY, C>(tree, b, c)
}

/// The build and the traversal compiled with AVX2 (no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn built_avx2<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &B,
    c: &mut C,
) -> Built<L> {
    build_and_trace::<L, T, B, ANY, C>(tree, b, c)
}

/// The build and the traversal compiled with AVX-512 at 256 bits (no FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512bw,avx512dq")]
#[inline(never)]
fn built_avx512<L: Lane, T: Layout, B: BuildPacket<L>, const ANY: bool, C: Counters>(
    tree: &T,
    b: &B,
    c: &mut C,
) -> Built<L> {
    build_and_trace::<L, T, B, ANY, C>(tree, b, c)
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
        for k in [Kernel::Sse, Kernel::Avx2, Kernel::Avx512] {
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
        for k in [Kernel::Sse, Kernel::Avx2, Kernel::Avx512] {
            let p = RayPacket8::from_slice(&coherent);
            let b = Given(&p);
            let Built::Traced(h) = built_in::<_, _, _, false, _>(k, &tree, &b, &mut NoCount) else {
                panic!("{k:?}: one octant, eight lanes: traced in the kernel");
            };
            for (i, r) in coherent.iter().enumerate() {
                assert_eq!(h.hit(i), tree.intersect(r), "{k:?} lane {i}");
            }
            assert!(h.mask() != 0, "the rays hit");
            // A builder the caller has not checked (as a scene's).
            struct Unchecked(RayPacket8);
            impl BuildPacket<crate::simd::F8> for Unchecked {
                fn build(&self) -> RayPacket8 {
                    self.0
                }
            }
            let b = Unchecked(RayPacket8::from_slice(&mixed));
            let Built::Divergent(p) = built_in::<_, _, _, true, _>(k, &tree, &b, &mut NoCount)
            else {
                panic!("{k:?}: two octants: handed back");
            };
            assert_eq!(p.active(), 0xFF);
        }
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
        for k in [Kernel::Sse, Kernel::Avx2, Kernel::Avx512] {
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

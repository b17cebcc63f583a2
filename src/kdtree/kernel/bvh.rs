//! The BVHs' run-time kernels: the 8-wide tree's single-ray traversal and
//! both trees' packet traversals, each compiled for AVX-512, for AVX2 with
//! FMA, and for the baseline target, and picked once per process as the
//! kd-tree's packet kernels are (`PACKTRACE_KERNEL` forces a lesser one).
//! Only the dispatch lives here (the `unsafe` calls after detection); the
//! traversals are the generic code of `src/bvh/`, inlined into each.
//!
//! Unlike the kd kernels these enable FMA: the 8-wide node test computes
//! its plane distances with one fused multiply-subtract each
//! (`bvh/slab.rs`, `Fused`), which the margin covers as it covers two
//! roundings. Rust never contracts `a * b + c` by itself, so the triangle
//! routine inlined beside it still rounds every operation as the scalar
//! path does, and every answer stays bit-equal to brute force.

use super::Kernel;
use crate::bvh::Bvh8;
use crate::bvh::bvh2::{Bvh2, traverse_packet as bvh2_traverse_packet};
use crate::bvh::packet::traverse as bvh8_traverse_packet;
use crate::bvh::single::traverse as bvh8_traverse;
use crate::bvh::slab::{Fast8, Fms, Plain, RayBoxes, Robust8};
use crate::grid::Grid;
use crate::grid::packet::traverse as grid_traverse_packet;
use crate::kdtree::stats::Counters;
use crate::packet::{HitPacket, RayPacket};
use crate::ray::{Hit, Ray};
use crate::simd::Lane;
use std::sync::atomic::{AtomicU8, Ordering};

/// 0: not chosen yet; otherwise `Kernel as u8 + 1`, as resolved for the
/// BVHs (AVX2 needs FMA too).
static CHOICE: AtomicU8 = AtomicU8::new(0);

/// Does the CPU run the AVX2 kernel of the BVHs (AVX2 and FMA)?
fn avx2_fma_supported() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        Kernel::avx2_supported() && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Is kernel `k` runnable here (falling back to the baseline otherwise)?
fn resolve(k: Kernel) -> Kernel {
    match k {
        Kernel::Avx512 if Kernel::avx512_supported() && avx2_fma_supported() => Kernel::Avx512,
        Kernel::Avx512 | Kernel::Avx2 if avx2_fma_supported() => Kernel::Avx2,
        _ => Kernel::Sse,
    }
}

/// The BVH kernel of this process: [`Kernel::active`], resolved.
#[inline]
pub(crate) fn active() -> Kernel {
    match CHOICE.load(Ordering::Relaxed) {
        1 => Kernel::Sse,
        2 => Kernel::Avx2,
        3 => Kernel::Avx512,
        _ => {
            let k = resolve(Kernel::active());
            CHOICE.store(k as u8 + 1, Ordering::Relaxed);
            k
        }
    }
}

/// The 8-wide tree's single-ray traversal in the active kernel: the fast
/// box test where the ray allows it, else the robust one (`bvh/slab.rs`).
#[inline]
pub(crate) fn bvh8_ray<const ANY: bool, C: Counters>(
    bvh: &Bvh8,
    ray: &Ray,
    c: &mut C,
) -> Option<Hit> {
    // `active()` is resolved already: no second check of the CPU.
    #[cfg(target_arch = "x86_64")]
    match active() {
        // SAFETY: `active` returns `Avx512` only when `resolve` saw every
        // feature `ray_avx512` is compiled with detected on this CPU
        // (AVX-512 F/VL/BW/DQ, AVX2, FMA); the arguments are references.
        Kernel::Avx512 => return unsafe { ray_avx512::<ANY, C>(bvh, ray, c) },
        // SAFETY: `active` returns `Avx2` only when AVX2 and FMA were
        // detected, the features `ray_avx2` is compiled with.
        Kernel::Avx2 => return unsafe { ray_avx2::<ANY, C>(bvh, ray, c) },
        Kernel::Sse => {}
    }
    ray_sse::<ANY, C>(bvh, ray, c)
}

/// [`bvh8_ray`] in kernel `k`, or a lesser one the CPU runs (tests run
/// every kernel in one process this way).
#[cfg(test)]
#[inline]
pub(crate) fn bvh8_ray_in<const ANY: bool, C: Counters>(
    k: Kernel,
    bvh: &Bvh8,
    ray: &Ray,
    c: &mut C,
) -> Option<Hit> {
    #[cfg(target_arch = "x86_64")]
    match resolve(k) {
        // SAFETY: `resolve` returns `Avx512` only when
        // `is_x86_feature_detected!` reported every feature `ray_avx512`
        // is compiled with (AVX-512 F/VL/BW/DQ, AVX2, FMA), so each of its
        // instructions runs on this CPU; the arguments are references.
        Kernel::Avx512 => return unsafe { ray_avx512::<ANY, C>(bvh, ray, c) },
        // SAFETY: `resolve` returns `Avx2` only when AVX2 and FMA were
        // detected, the features `ray_avx2` is compiled with.
        Kernel::Avx2 => return unsafe { ray_avx2::<ANY, C>(bvh, ray, c) },
        Kernel::Sse => {}
    }
    let _ = k;
    ray_sse::<ANY, C>(bvh, ray, c)
}

/// The per-ray set-up and the traversal, inlined into the baseline kernel:
/// the fast test, or the robust one for the rare ray that needs it.
#[inline(always)]
fn bvh8_ray_body<M: Fms, const ANY: bool, C: Counters>(
    bvh: &Bvh8,
    ray: &Ray,
    c: &mut C,
) -> Option<Hit> {
    let r = RayBoxes::new(bvh, ray);
    if r.fast {
        bvh8_traverse::<_, ANY, C>(bvh, ray, &Fast8::<M>::new(&r), c)
    } else {
        robust::<ANY, C>(bvh, ray, &r, c)
    }
}

/// The AVX kernels' set-up and traversal: the node test in AVX registers
/// ([`avx::Node8Test`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn bvh8_ray_avx<const ANY: bool, C: Counters>(
    isa: avx::Isa,
    bvh: &Bvh8,
    ray: &Ray,
    c: &mut C,
) -> Option<Hit> {
    let r = RayBoxes::new(bvh, ray);
    if r.fast {
        bvh8_traverse::<_, ANY, C>(bvh, ray, &avx::Node8Test::new(isa, &r), c)
    } else {
        robust::<ANY, C>(bvh, ray, &r, c)
    }
}

/// The 8-wide node test written with AVX2 and FMA intrinsics: LLVM split
/// the generic one (`bvh/slab.rs`, `Fast8<Fused>`) into 128-bit halves for
/// its compare and move-mask and reloaded its constants from the stack
/// (callgrind, bunny random rays: about 55 instructions per node step
/// against about 20 here).
#[cfg(target_arch = "x86_64")]
mod avx {
    use crate::bvh::node::Node8;
    use crate::bvh::slab::{NodeTest, RayBoxes};
    use crate::simd::F8;
    use std::arch::x86_64::{
        __m256, _CMP_LE_OQ, _mm256_cmp_ps, _mm256_fmsub_ps, _mm256_load_ps, _mm256_max_ps,
        _mm256_min_ps, _mm256_movemask_ps, _mm256_set1_ps, _mm256_storeu_ps,
    };

    /// Proof that the running kernel has AVX2 and FMA: made only in
    /// `ray_avx2` and `ray_avx512`, which run only after the CPU reported
    /// those features (`resolve`).
    #[derive(Clone, Copy, Debug)]
    pub(super) struct Isa {
        _private: (),
    }

    impl Isa {
        /// # Safety
        /// The CPU must run AVX2 and FMA.
        #[inline(always)]
        pub(super) unsafe fn new() -> Isa {
            Isa { _private: () }
        }
    }

    /// The fast test's per-ray constants in AVX registers.
    #[derive(Clone, Copy)]
    pub(super) struct Node8Test {
        near: [bool; 3],
        inv: [__m256; 3],
        entry_inv: [__m256; 3],
        exit_inv: [__m256; 3],
        _isa: Isa,
    }

    impl Node8Test {
        #[inline(always)]
        pub(super) fn new(isa: Isa, r: &RayBoxes) -> Node8Test {
            // SAFETY: `isa` proves AVX2 and FMA (see `Isa`).
            unsafe { setup(isa, r) }
        }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn setup(isa: Isa, r: &RayBoxes) -> Node8Test {
        Node8Test {
            near: r.neg,
            inv: r.inv.map(|x| _mm256_set1_ps(x)),
            entry_inv: [0, 1, 2].map(|a| _mm256_set1_ps(r.entry[a] * r.inv[a])),
            exit_inv: [0, 1, 2].map(|a| _mm256_set1_ps(r.exit[a] * r.inv[a])),
            _isa: isa,
        }
    }

    impl NodeTest for Node8Test {
        #[inline(always)]
        fn test(&self, node: &Node8, t_min: f32, t_max: f32) -> (u32, F8) {
            // SAFETY: a `Node8Test` holds an `Isa`, which proves AVX2 and
            // FMA; the planes are 32-byte aligned (`F8`), as the aligned
            // loads need.
            unsafe { test(self, node, t_min, t_max) }
        }
    }

    /// Six fused multiply-subtracts (the near planes against the entry
    /// origin, the far ones against the exit origin), two `max`/`min`
    /// chains with the interval, one compare and one move-mask.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn test(t: &Node8Test, node: &Node8, t_min: f32, t_max: f32) -> (u32, F8) {
        let p = &node.planes;
        let n = t.near;
        let plane = |f: &F8| -> *const f32 { (f as *const F8).cast() };
        // SAFETY: every pointer is a whole, 32-byte aligned `F8`.
        let (nx, ny, nz, fx, fy, fz) = unsafe {
            (
                _mm256_load_ps(plane(&p[0][n[0] as usize])),
                _mm256_load_ps(plane(&p[1][n[1] as usize])),
                _mm256_load_ps(plane(&p[2][n[2] as usize])),
                _mm256_load_ps(plane(&p[0][!n[0] as usize])),
                _mm256_load_ps(plane(&p[1][!n[1] as usize])),
                _mm256_load_ps(plane(&p[2][!n[2] as usize])),
            )
        };
        let t0x = _mm256_fmsub_ps(nx, t.inv[0], t.entry_inv[0]);
        let t0y = _mm256_fmsub_ps(ny, t.inv[1], t.entry_inv[1]);
        let t0z = _mm256_fmsub_ps(nz, t.inv[2], t.entry_inv[2]);
        let t1x = _mm256_fmsub_ps(fx, t.inv[0], t.exit_inv[0]);
        let t1y = _mm256_fmsub_ps(fy, t.inv[1], t.exit_inv[1]);
        let t1z = _mm256_fmsub_ps(fz, t.inv[2], t.exit_inv[2]);
        let t0 = _mm256_max_ps(
            _mm256_max_ps(t0x, t0y),
            _mm256_max_ps(t0z, _mm256_set1_ps(t_min)),
        );
        let t1 = _mm256_min_ps(
            _mm256_min_ps(t1x, t1y),
            _mm256_min_ps(t1z, _mm256_set1_ps(t_max)),
        );
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
        let mut dist = [0.0f32; 8];
        // SAFETY: `dist` has room for eight floats (an unaligned store).
        unsafe { _mm256_storeu_ps(dist.as_mut_ptr(), t0) };
        (mask, F8::from(dist))
    }
}

/// The robust test's traversal, out of the kernels' hot code.
#[cold]
#[inline(never)]
fn robust<const ANY: bool, C: Counters>(
    bvh: &Bvh8,
    ray: &Ray,
    r: &RayBoxes,
    c: &mut C,
) -> Option<Hit> {
    bvh8_traverse::<_, ANY, C>(bvh, ray, &Robust8::new(r, ray), c)
}

#[inline(never)]
fn ray_sse<const ANY: bool, C: Counters>(bvh: &Bvh8, ray: &Ray, c: &mut C) -> Option<Hit> {
    bvh8_ray_body::<Plain, ANY, C>(bvh, ray, c)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
fn ray_avx2<const ANY: bool, C: Counters>(bvh: &Bvh8, ray: &Ray, c: &mut C) -> Option<Hit> {
    // SAFETY: this kernel runs only after the CPU reported AVX2 and FMA.
    let isa = unsafe { avx::Isa::new() };
    bvh8_ray_avx::<ANY, C>(isa, bvh, ray, c)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512bw,avx512dq")]
#[inline(never)]
fn ray_avx512<const ANY: bool, C: Counters>(bvh: &Bvh8, ray: &Ray, c: &mut C) -> Option<Hit> {
    // SAFETY: this kernel runs only after the CPU reported AVX-512, AVX2
    // and FMA.
    let isa = unsafe { avx::Isa::new() };
    bvh8_ray_avx::<ANY, C>(isa, bvh, ray, c)
}

/// Generates a packet traversal's dispatch and its three kernels.
macro_rules! packet_kernels {
    ($tree:ty, $body:ident, $name:ident, $name_in:ident, $sse:ident, $avx2:ident, $avx512:ident) => {
        /// The packet traversal (one octant, fast lanes) in the active
        /// kernel.
        #[inline]
        pub(crate) fn $name<L: Lane, const ANY: bool, C: Counters>(
            t: &$tree,
            p: &RayPacket<L>,
            c: &mut C,
        ) -> HitPacket<L> {
            $name_in::<L, ANY, C>(active(), t, p, c)
        }

        /// The packet traversal in kernel `k`, or a lesser one the CPU
        /// runs.
        #[inline]
        pub(crate) fn $name_in<L: Lane, const ANY: bool, C: Counters>(
            k: Kernel,
            t: &$tree,
            p: &RayPacket<L>,
            c: &mut C,
        ) -> HitPacket<L> {
            #[cfg(target_arch = "x86_64")]
            match resolve(k) {
                // SAFETY: as in `bvh8_ray_in`: every feature of the
                // kernel was detected on this CPU; plain references.
                Kernel::Avx512 => return unsafe { $avx512::<L, ANY, C>(t, p, c) },
                // SAFETY: as above (AVX2 and FMA detected).
                Kernel::Avx2 => return unsafe { $avx2::<L, ANY, C>(t, p, c) },
                Kernel::Sse => {}
            }
            let _ = k;
            $sse::<L, ANY, C>(t, p, c)
        }

        #[inline(never)]
        fn $sse<L: Lane, const ANY: bool, C: Counters>(
            t: &$tree,
            p: &RayPacket<L>,
            c: &mut C,
        ) -> HitPacket<L> {
            $body::<L, ANY, C>(t, p, c)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        #[inline(never)]
        fn $avx2<L: Lane, const ANY: bool, C: Counters>(
            t: &$tree,
            p: &RayPacket<L>,
            c: &mut C,
        ) -> HitPacket<L> {
            $body::<L, ANY, C>(t, p, c)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma,avx512f,avx512vl,avx512bw,avx512dq")]
        #[inline(never)]
        fn $avx512<L: Lane, const ANY: bool, C: Counters>(
            t: &$tree,
            p: &RayPacket<L>,
            c: &mut C,
        ) -> HitPacket<L> {
            $body::<L, ANY, C>(t, p, c)
        }
    };
}

packet_kernels!(
    Bvh8,
    bvh8_traverse_packet,
    bvh8_packet,
    bvh8_packet_in,
    bvh8_packet_sse,
    bvh8_packet_avx2,
    bvh8_packet_avx512
);
packet_kernels!(
    Bvh2,
    bvh2_traverse_packet,
    bvh2_packet,
    bvh2_packet_in,
    bvh2_packet_sse,
    bvh2_packet_avx2,
    bvh2_packet_avx512
);
packet_kernels!(
    Grid,
    grid_traverse_packet,
    grid_packet,
    grid_packet_in,
    grid_packet_sse,
    grid_packet_avx2,
    grid_packet_avx512
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BvhBuildParams;
    use crate::kdtree::stats::NoCount;
    use crate::packet::RayPacket8;
    use crate::simd::F4;
    use crate::{Mesh, RayPacket4};
    use glam::Vec3;

    /// Every kernel, closest hit and occlusion, single rays and packets of
    /// both widths, both trees and the grid: every answer equals the scalar query.
    /// Small enough for Miri (the dispatch's `unsafe` blocks).
    #[test]
    fn every_bvh_kernel_equals_the_scalar_query() {
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
        let p = BvhBuildParams {
            max_leaf_size: 1,
            ..BvhBuildParams::sah()
        };
        let b8 = Bvh8::build(mesh.clone(), &p).unwrap();
        let b2 = Bvh2::build(mesh.clone(), &p).unwrap();
        let grid = Grid::build(
            mesh,
            &crate::grid::GridParams {
                density: 8.0,
                ..Default::default()
            },
        )
        .unwrap();
        let rays: Vec<Ray> = (0..8)
            .map(|i| {
                let x = -0.9 + 0.25 * i as f32;
                Ray::new(
                    Vec3::new(x, 0.1 * x, 2.0),
                    Vec3::new(0.01, 0.02, -1.0),
                    0.0,
                    9.0,
                )
                .unwrap()
            })
            .collect();
        let brute = crate::BruteForce::new(b8.mesh());
        use crate::query::RayQuery;
        for k in [Kernel::Sse, Kernel::Avx2, Kernel::Avx512] {
            for r in &rays {
                assert!(RayBoxes::new(&b8, r).fast);
                let h = bvh8_ray_in::<false, _>(k, &b8, r, &mut NoCount);
                let o = bvh8_ray_in::<true, _>(k, &b8, r, &mut NoCount);
                assert_eq!(h, brute.intersect(r), "{k:?}");
                assert_eq!(o.is_some(), brute.occluded(r), "{k:?}");
            }
            let p8 = RayPacket8::from_slice(&rays);
            let p4 = RayPacket4::from_slice(&rays[3..]);
            let h8 = bvh8_packet_in::<_, false, _>(k, &b8, &p8, &mut NoCount);
            let o8 = bvh8_packet_in::<_, true, _>(k, &b8, &p8, &mut NoCount).mask();
            let g8 = bvh2_packet_in::<_, false, _>(k, &b2, &p8, &mut NoCount);
            let h4 = bvh8_packet_in::<F4, false, _>(k, &b8, &p4, &mut NoCount);
            let g4 = bvh2_packet_in::<F4, true, _>(k, &b2, &p4, &mut NoCount).mask();
            let c8 = grid_packet_in::<_, false, _>(k, &grid, &p8, &mut NoCount);
            let c4 = grid_packet_in::<F4, true, _>(k, &grid, &p4, &mut NoCount).mask();
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(h8.hit(i), brute.intersect(r), "{k:?} lane {i}");
                assert_eq!(g8.hit(i), brute.intersect(r), "{k:?} lane {i}");
                assert_eq!(c8.hit(i), brute.intersect(r), "{k:?} grid lane {i}");
                assert_eq!(o8 >> i & 1 == 1, brute.occluded(r), "{k:?} lane {i}");
            }
            for i in 0..4 {
                assert_eq!(h4.hit(i), brute.intersect(&rays[3 + i]), "{k:?} lane {i}");
                assert_eq!(g4 >> i & 1 == 1, brute.occluded(&rays[3 + i]), "{k:?}");
                assert_eq!(c4 >> i & 1 == 1, brute.occluded(&rays[3 + i]), "{k:?} grid");
            }
            assert!(h8.mask() != 0, "the rays hit");
        }
    }
}

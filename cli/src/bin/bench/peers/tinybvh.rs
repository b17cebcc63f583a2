//! `--accel tinybvh` (`--features tinybvh`): tinybvh 1.6.8's BVH8_CPU
//! (Wald et al.'s 8-wide BVH for wide vector units, tinybvh's fastest CPU
//! layout) through tinybvh-rs 0.1.0-beta.3, single rays.
//!
//! - Build: `BVH::build` (binned SAH), `split_leaves(4)`, MBVH8, then
//!   BVH8_CPU, all in `build_seconds` (BVH8_CPU keeps its own copy of the
//!   triangles).
//! - Trace: `Intersect` on rays in 128-byte slots (`ffi::tinybvh`: the
//!   binding's 64-byte `Ray` is smaller than the C++ one). The reciprocal
//!   direction is tinybvh's own (`1/x`, +-1e30 under 1e-12 in magnitude);
//!   the direction is not renormalised.
//! - Interval: tinybvh starts every ray at `t > 0` (the protocol's
//!   `t_min` is 0 for every workload) and keeps a hit when `t < hit.t`, so
//!   `hit.t` starts at the next float above `t_max` (the protocol's
//!   `t <= t_max`), clamped to tinybvh's "far" of 1e30.
//! - Occlusion: the binding has no `IsOccluded`, so occlusion rays are
//!   closest-hit queries within `t_max` (no early exit: a handicap on
//!   shadow and ao rays).
//! - BVH8_CPU's traversal is compiled only with AVX2 enabled in the Rust
//!   build as well (`RUSTFLAGS="-C target-cpu=native"`); without it the
//!   peer refuses to run and says so.

#[cfg(target_feature = "avx2")]
use super::ffi::tinybvh::{Bvh8, Slot};
use super::{Peer, Traced};
use crate::Failure;
use crate::trace::{Accel, Mode};
use packtrace::Mesh;
use packtrace::protocol::workload::RaySet;
#[cfg(target_feature = "avx2")]
use tinybvh_rs::{INFINITE, Intersection, Ray, bvh, bvh8_cpu, mbvh};
#[cfg(target_feature = "avx2")]
use {crate::trace::Results, packtrace::Hit, rayon::ThreadPool};

/// tinybvh's BVH8_CPU over a mesh.
pub struct TinyBvh {
    #[cfg(target_feature = "avx2")]
    bvh: Bvh8,
    build_seconds: f64,
}

impl TinyBvh {
    /// Build over `mesh`'s triangles.
    ///
    /// # Errors
    /// [`Failure::Input`] when the bench was built without AVX2 (BVH8_CPU's
    /// traversal needs it), or tinybvh refuses the mesh.
    #[cfg(target_feature = "avx2")]
    pub fn new(mesh: &Mesh) -> Result<TinyBvh, Failure> {
        let p = mesh.positions();
        let corners: Vec<[f32; 4]> = mesh
            .triangles()
            .iter()
            .flatten()
            .map(|&i| {
                let v = p[i as usize];
                [v.x, v.y, v.z, 0.0]
            })
            .collect();
        let fail = |e: tinybvh_rs::Error| Failure::Input(format!("tinybvh: {e}"));
        let start = std::time::Instant::now();
        let mut wald = bvh::BVH::new(corners.as_slice().into()).map_err(fail)?;
        wald.split_leaves(4);
        let wide = mbvh::BVH::new(&wald);
        let bvh = bvh8_cpu::BVH::new(&wide).map_err(fail)?;
        Ok(TinyBvh {
            bvh: Bvh8(bvh),
            build_seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// Without AVX2 in the Rust build, BVH8_CPU cannot trace: say how to
    /// build it.
    ///
    /// # Errors
    /// Always [`Failure::Input`].
    #[cfg(not(target_feature = "avx2"))]
    pub fn new(_mesh: &Mesh) -> Result<TinyBvh, Failure> {
        Err(Failure::Input(
            "accel tinybvh: tinybvh-rs compiles BVH8_CPU's traversal only with AVX2 enabled: \
             build the bench with RUSTFLAGS=\"-C target-cpu=native\" (on a CPU with AVX2)"
                .into(),
        ))
    }
}

/// The next float above `x` (`x` itself for infinities).
#[cfg(target_feature = "avx2")]
fn next_up(x: f32) -> f32 {
    if x.is_finite() && x >= 0.0 {
        f32::from_bits(x.to_bits() + 1)
    } else {
        x
    }
}

/// tinybvh's reciprocal: `1/x`, or +-1e30 for `|x| <= 1e-12`.
#[cfg(target_feature = "avx2")]
fn safe_rcp(x: f32) -> f32 {
    if x > 1e-12 || x < -1e-12 {
        1.0 / x
    } else if x >= 0.0 {
        INFINITE
    } else {
        -INFINITE
    }
}

impl Peer for TinyBvh {
    fn accel(&self) -> Accel {
        Accel::Tinybvh
    }

    fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    fn bytes(&self) -> Option<usize> {
        None
    }

    fn version(&self) -> String {
        "tinybvh-rs 0.1.0-beta.3 (tinybvh 1.6.8) BVH8_CPU".into()
    }

    #[cfg(target_feature = "avx2")]
    fn prepare<'a>(&'a self, mode: Mode, set: &'a RaySet, occlusion: bool) -> Box<dyn Traced + 'a> {
        assert_eq!(mode, Mode::Scalar, "tinybvh traces single rays");
        let slots: Vec<Slot> = set
            .rays
            .iter()
            .map(|r| {
                let (o, d) = (r.origin(), r.dir());
                Slot::new(Ray {
                    origin: o.to_array(),
                    padding_0: 0xFFFF, // the C++ ray's mask: every instance
                    dir: d.to_array(),
                    padding_1: 0,
                    r_d: [safe_rcp(d.x), safe_rcp(d.y), safe_rcp(d.z)],
                    padding_2: 0,
                    hit: Intersection {
                        t: next_up(r.t_max()).min(INFINITE),
                        ..Default::default()
                    },
                })
            })
            .collect();
        Box::new(Prepared {
            bvh: &self.bvh,
            work: slots.clone(),
            pristine: slots,
            occlusion,
        })
    }

    #[cfg(not(target_feature = "avx2"))]
    fn prepare<'a>(&'a self, _: Mode, _: &'a RaySet, _: bool) -> Box<dyn Traced + 'a> {
        unreachable!("TinyBvh::new refuses without AVX2")
    }
}

#[cfg(target_feature = "avx2")]
struct Prepared<'a> {
    bvh: &'a Bvh8,
    pristine: Vec<Slot>,
    work: Vec<Slot>,
    occlusion: bool,
}

#[cfg(target_feature = "avx2")]
impl Traced for Prepared<'_> {
    fn reset(&mut self) {
        self.work.copy_from_slice(&self.pristine);
    }

    fn trace(&mut self, pool: Option<&ThreadPool>) {
        let bvh = self.bvh;
        super::for_chunks(pool, &mut self.work, |c| {
            c.iter_mut().for_each(|s| bvh.intersect(s));
        });
    }

    fn results(&self) -> Results {
        // A hit moved `t` below where it started.
        let hit = |(w, p): (&Slot, &Slot)| (w.ray.hit.t < p.ray.hit.t).then_some(w.ray.hit);
        let pairs = self.work.iter().zip(&self.pristine);
        if self.occlusion {
            Results::Occluded(pairs.map(|x| hit(x).is_some()).collect())
        } else {
            Results::Closest(
                pairs
                    .map(|x| {
                        hit(x).map(|h| Hit {
                            t: h.t,
                            prim: h.prim,
                            u: h.u,
                            v: h.v,
                        })
                    })
                    .collect(),
            )
        }
    }
}

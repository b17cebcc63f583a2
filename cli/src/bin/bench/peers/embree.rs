//! `--accel embree` and `--accel embree-coherent`: Embree 3 (Debian's
//! `libembree-dev`, 3.13.5) through its C API (`ffi::embree`).
//!
//! - Device `threads=N` (`--threads`, 1 for the protocol's figures): its
//!   build runs on that many threads. One scene, one triangle geometry in
//!   file order (Embree's `primID` is packtrace's triangle index), Embree's
//!   default build quality (medium); `build_seconds` is `rtcCommitScene`,
//!   bytes are what Embree's memory monitor saw it allocate for the scene.
//! - Modes: `scalar` is `rtcIntersect1` / `rtcOccluded1` (Embree calls it
//!   single-ray), `packet4` and `packet8` are `rtcIntersect4/8` /
//!   `rtcOccluded4/8` on the protocol's packets (2 x 2 pixel quads, 4 x 2
//!   blocks, ao sample k of a quad's pixels, random rays 4i..4i+3), a lane
//!   without a ray switched off in `valid`.
//! - Context flags: `embree` runs with Embree's default (incoherent),
//!   under which `rtcIntersect4/8` trace each lane on its own (hybrid
//!   traversal); `embree-coherent` sets `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`,
//!   under which they run real packet traversal (faster on primary and
//!   shadow rays, slower on ao and random). Embree's fair best for a
//!   workload is the faster of the two.
//! - Flush-to-zero and denormals-are-zero are on around the build and
//!   every traced chunk, on each thread, as Embree asks.
//! - Embree writes into its rays: each repetition starts from a fresh copy
//!   of the prepared records, made outside the timed region.

use super::ffi::embree::{
    Context, Device, FLAG_COHERENT, FLAG_INCOHERENT, FlushToZero, Hit1, HitN, INVALID_ID, Ray1,
    RayHit1, RayHitN, RayN, Scene,
};
use super::{Peer, Traced, for_chunks};
use crate::Failure;
use crate::trace::{Accel, Mode, Results};
use packtrace::protocol::workload::{NO_RAY, RaySet};
use packtrace::{Hit, Mesh, Ray};
use rayon::ThreadPool;
use std::sync::Arc;
use std::time::Instant;

/// The committed Embree scene of a mesh, shared by both context flags.
pub struct Built {
    scene: Scene,
    build_seconds: f64,
    bytes: usize,
    version: String,
}

impl Built {
    /// Build `mesh` on a device of `threads` threads.
    ///
    /// # Errors
    /// [`Failure::Input`] when Embree refuses the device or the scene.
    pub fn new(mesh: &Mesh, threads: usize) -> Result<Built, Failure> {
        let fail = |e: String| Failure::Input(format!("embree: {e}"));
        let device = Device::new(threads).map_err(fail)?;
        let version = device.version();
        if !device.native_ray8() {
            return Err(fail(format!(
                "Embree {version} has no native 8-wide packets on this CPU (no AVX)"
            )));
        }
        let before = device.allocated();
        let positions: Vec<[f32; 3]> = mesh.positions().iter().map(|p| p.to_array()).collect();
        let scene = Scene::new(device, &positions, mesh.triangles()).map_err(fail)?;
        let start = Instant::now();
        scene.commit().map_err(fail)?;
        let build_seconds = start.elapsed().as_secs_f64();
        let bytes = scene.device().allocated().saturating_sub(before);
        Ok(Built {
            scene,
            build_seconds,
            bytes,
            version,
        })
    }
}

/// One context flag on a built scene.
pub struct Embree {
    built: Arc<Built>,
    coherent: bool,
}

impl Embree {
    /// `built` traced with the coherent flag or Embree's default.
    pub fn new(built: &Arc<Built>, coherent: bool) -> Embree {
        Embree {
            built: Arc::clone(built),
            coherent,
        }
    }

    fn flags(&self) -> u32 {
        if self.coherent {
            FLAG_COHERENT
        } else {
            FLAG_INCOHERENT
        }
    }
}

/// An Embree ray record of `r`.
fn ray1(r: &Ray) -> Ray1 {
    Ray1 {
        org: r.origin().to_array(),
        tnear: r.t_min(),
        dir: r.dir().to_array(),
        time: 0.0,
        tfar: r.t_max(),
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// A packet of the rays `lanes` names ([`NO_RAY`]: an inactive lane, with
/// an empty interval) and its `valid` mask.
fn packet<const N: usize>(rays: &[Ray], lanes: &[u32; N]) -> ([i32; N], RayN<N>) {
    let mut p = RayN {
        org_x: [0.0; N],
        org_y: [0.0; N],
        org_z: [0.0; N],
        tnear: [0.0; N],
        dir_x: [0.0; N],
        dir_y: [0.0; N],
        dir_z: [1.0; N],
        time: [0.0; N],
        tfar: [f32::NEG_INFINITY; N],
        mask: [u32::MAX; N],
        id: [0; N],
        flags: [0; N],
    };
    let mut valid = [0; N];
    for (l, &i) in lanes.iter().enumerate() {
        if i == NO_RAY {
            continue;
        }
        let r = ray1(&rays[i as usize]);
        valid[l] = -1;
        [p.org_x[l], p.org_y[l], p.org_z[l]] = r.org;
        [p.dir_x[l], p.dir_y[l], p.dir_z[l]] = r.dir;
        p.tnear[l] = r.tnear;
        p.tfar[l] = r.tfar;
    }
    (valid, p)
}

/// A packet's empty hit record (every lane missed).
fn no_hits<const N: usize>() -> HitN<N> {
    HitN {
        ng_x: [0.0; N],
        ng_y: [0.0; N],
        ng_z: [0.0; N],
        u: [0.0; N],
        v: [0.0; N],
        prim_id: [0; N],
        geom_id: [INVALID_ID; N],
        inst_id: [[INVALID_ID; N]; 1],
    }
}

/// The prepared records of one workload and mode; `valid` masks with each
/// packet.
#[derive(Clone)]
enum Records {
    Closest1(Vec<RayHit1>),
    Occluded1(Vec<Ray1>),
    Closest4(Vec<([i32; 4], RayHitN<4>)>),
    Occluded4(Vec<([i32; 4], RayN<4>)>),
    Closest8(Vec<([i32; 8], RayHitN<8>)>),
    Occluded8(Vec<([i32; 8], RayN<8>)>),
}

fn closest_packets<const N: usize>(
    rays: &[Ray],
    lanes: &[[u32; N]],
) -> Vec<([i32; N], RayHitN<N>)> {
    lanes
        .iter()
        .map(|l| {
            let (valid, ray) = packet(rays, l);
            let hit = no_hits();
            (valid, RayHitN { ray, hit })
        })
        .collect()
}

fn occluded_packets<const N: usize>(rays: &[Ray], lanes: &[[u32; N]]) -> Vec<([i32; N], RayN<N>)> {
    lanes.iter().map(|l| packet(rays, l)).collect()
}

impl Peer for Embree {
    fn accel(&self) -> Accel {
        if self.coherent {
            Accel::EmbreeCoherent
        } else {
            Accel::Embree
        }
    }

    fn build_seconds(&self) -> f64 {
        self.built.build_seconds
    }

    fn bytes(&self) -> Option<usize> {
        Some(self.built.bytes)
    }

    fn version(&self) -> String {
        format!(
            "embree {} ({} flag, build quality medium)",
            self.built.version,
            if self.coherent { "coherent" } else { "default" }
        )
    }

    fn prepare<'a>(&'a self, mode: Mode, set: &'a RaySet, occlusion: bool) -> Box<dyn Traced + 'a> {
        let rays = &set.rays;
        let pristine = match (mode, occlusion) {
            (Mode::Scalar, false) => Records::Closest1(
                rays.iter()
                    .map(|r| RayHit1 {
                        ray: ray1(r),
                        hit: Hit1 {
                            geom_id: INVALID_ID,
                            inst_id: [INVALID_ID],
                            ..Default::default()
                        },
                    })
                    .collect(),
            ),
            (Mode::Scalar, true) => Records::Occluded1(rays.iter().map(ray1).collect()),
            (Mode::Packet4, false) => Records::Closest4(closest_packets(rays, &set.packets)),
            (Mode::Packet4, true) => Records::Occluded4(occluded_packets(rays, &set.packets)),
            (Mode::Packet8, false) => Records::Closest8(closest_packets(rays, &set.packets8)),
            (Mode::Packet8, true) => Records::Occluded8(occluded_packets(rays, &set.packets8)),
            _ => panic!("Embree has no {} mode here", mode.name()),
        };
        Box::new(Prepared {
            engine: self,
            set,
            work: pristine.clone(),
            pristine,
        })
    }
}

struct Prepared<'a> {
    engine: &'a Embree,
    set: &'a RaySet,
    pristine: Records,
    work: Records,
}

/// Per-packet results written back to their rays.
fn scatter<P, T: Clone + Default, const N: usize>(
    n: usize,
    packets: &[([i32; N], P)],
    lanes: &[[u32; N]],
    lane: impl Fn(&P, usize) -> T,
) -> Vec<T> {
    let mut out = vec![T::default(); n];
    for ((_, p), l) in packets.iter().zip(lanes) {
        for (k, &i) in l.iter().enumerate() {
            if i != NO_RAY {
                out[i as usize] = lane(p, k);
            }
        }
    }
    out
}

fn lane_hit<const N: usize>(p: &RayHitN<N>, k: usize) -> Option<Hit> {
    (p.hit.geom_id[k] != INVALID_ID).then(|| Hit {
        t: p.ray.tfar[k],
        prim: p.hit.prim_id[k],
        u: p.hit.u[k],
        v: p.hit.v[k],
    })
}

impl Traced for Prepared<'_> {
    fn reset(&mut self) {
        // A copy into the buffers already there: no allocation.
        match (&mut self.work, &self.pristine) {
            (Records::Closest1(w), Records::Closest1(p)) => w.copy_from_slice(p),
            (Records::Occluded1(w), Records::Occluded1(p)) => w.copy_from_slice(p),
            (Records::Closest4(w), Records::Closest4(p)) => w.copy_from_slice(p),
            (Records::Occluded4(w), Records::Occluded4(p)) => w.copy_from_slice(p),
            (Records::Closest8(w), Records::Closest8(p)) => w.copy_from_slice(p),
            (Records::Occluded8(w), Records::Occluded8(p)) => w.copy_from_slice(p),
            _ => unreachable!("work and pristine records of one kind"),
        }
    }

    fn trace(&mut self, pool: Option<&ThreadPool>) {
        let scene = &self.engine.built.scene;
        let flags = self.engine.flags();
        // Each chunk on its thread: flush-to-zero on, a fresh context.
        match &mut self.work {
            Records::Closest1(r) => for_chunks(pool, r, |c| {
                let (_ftz, mut ctx) = (FlushToZero::on(), Context::new(flags));
                c.iter_mut().for_each(|r| scene.intersect1(&mut ctx, r));
            }),
            Records::Occluded1(r) => for_chunks(pool, r, |c| {
                let (_ftz, mut ctx) = (FlushToZero::on(), Context::new(flags));
                c.iter_mut().for_each(|r| scene.occluded1(&mut ctx, r));
            }),
            Records::Closest4(p) => for_chunks(pool, p, |c| {
                let (_ftz, mut ctx) = (FlushToZero::on(), Context::new(flags));
                c.iter_mut()
                    .for_each(|(v, p)| scene.intersect_n(&mut ctx, v, p));
            }),
            Records::Occluded4(p) => for_chunks(pool, p, |c| {
                let (_ftz, mut ctx) = (FlushToZero::on(), Context::new(flags));
                c.iter_mut()
                    .for_each(|(v, p)| scene.occluded_n(&mut ctx, v, p));
            }),
            Records::Closest8(p) => for_chunks(pool, p, |c| {
                let (_ftz, mut ctx) = (FlushToZero::on(), Context::new(flags));
                c.iter_mut()
                    .for_each(|(v, p)| scene.intersect_n(&mut ctx, v, p));
            }),
            Records::Occluded8(p) => for_chunks(pool, p, |c| {
                let (_ftz, mut ctx) = (FlushToZero::on(), Context::new(flags));
                c.iter_mut()
                    .for_each(|(v, p)| scene.occluded_n(&mut ctx, v, p));
            }),
        }
    }

    fn results(&self) -> Results {
        let (n, set) = (self.set.rays.len(), self.set);
        match &self.work {
            Records::Closest1(r) => Results::Closest(
                r.iter()
                    .map(|r| {
                        (r.hit.geom_id != INVALID_ID).then_some(Hit {
                            t: r.ray.tfar,
                            prim: r.hit.prim_id,
                            u: r.hit.u,
                            v: r.hit.v,
                        })
                    })
                    .collect(),
            ),
            Records::Occluded1(r) => {
                Results::Occluded(r.iter().map(|r| r.tfar == f32::NEG_INFINITY).collect())
            }
            Records::Closest4(p) => Results::Closest(scatter(n, p, &set.packets, lane_hit)),
            Records::Occluded4(p) => Results::Occluded(scatter(n, p, &set.packets, |p, k| {
                p.tfar[k] == f32::NEG_INFINITY
            })),
            Records::Closest8(p) => Results::Closest(scatter(n, p, &set.packets8, lane_hit)),
            Records::Occluded8(p) => Results::Occluded(scatter(n, p, &set.packets8, |p, k| {
                p.tfar[k] == f32::NEG_INFINITY
            })),
        }
    }
}

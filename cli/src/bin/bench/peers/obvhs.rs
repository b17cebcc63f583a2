//! `--accel obvhs`: obvhs 0.4.0's compressed wide BVH (CWBVH, Ylitie et
//! al. 2017), single rays (obvhs has no packet traversal).
//!
//! Build: `build_cwbvh_from_tris` with `BvhBuildParams::medium_build()`
//! (obvhs's preset of about Embree's build time) on one thread (no
//! `parallel` feature), then the triangles copied into the BVH's leaf
//! order as `RtTriangle`s, as obvhs's own examples trace them; both count
//! in `build_seconds`. Trace: `ray_traverse` (closest hit) and
//! `ray_traverse_miss` (occlusion) with `RtTriangle::intersect`.
//!
//! Interval: obvhs accepts a hit with `tmin <= t <= tmax` in the triangle
//! test and keeps it when `t < tmax` in the traversal; the protocol wants
//! `t_min < t <= t_max`. So the ray gets `tmin` = the next float above
//! `t_min` and `tmax` = the next float above `t_max` (infinity stays):
//! exactly the protocol's interval. (With `tmin = 0`, shadow and ao rays
//! that start on an edge of the Cornell box's floor and wall were found
//! occluded at `t = 0`.)

use super::{Peer, Traced};
use crate::trace::{Accel, Mode, Results, map_into};
use ::obvhs::BvhBuildParams;
use ::obvhs::cwbvh::CwBvh;
use ::obvhs::cwbvh::builder::build_cwbvh_from_tris;
use ::obvhs::ray::{Ray, RayHit};
use ::obvhs::rt_triangle::RtTriangle;
use ::obvhs::triangle::Triangle;
use packtrace::glam::Vec3A;
use packtrace::protocol::workload::RaySet;
use packtrace::{Hit, Mesh};
use rayon::ThreadPool;
use std::time::{Duration, Instant};

/// obvhs's CWBVH over a mesh.
pub struct Obvhs {
    bvh: CwBvh,
    /// Triangles in leaf order: `tris[i]` is mesh triangle
    /// `bvh.primitive_indices[i]`.
    tris: Vec<RtTriangle>,
    build_seconds: f64,
}

/// The next float above `x` (`x` itself for infinities and NaN).
fn next_up(x: f32) -> f32 {
    if !x.is_finite() {
        x
    } else if x == 0.0 {
        f32::from_bits(1)
    } else if x > 0.0 {
        f32::from_bits(x.to_bits() + 1)
    } else {
        f32::from_bits(x.to_bits() - 1)
    }
}

impl Obvhs {
    /// Build over `mesh`'s triangles.
    pub fn new(mesh: &Mesh) -> Obvhs {
        let p = mesh.positions();
        let triangles: Vec<Triangle> = mesh
            .triangles()
            .iter()
            .map(|t| {
                let [v0, v1, v2] = t.map(|i| Vec3A::from(p[i as usize]));
                Triangle { v0, v1, v2 }
            })
            .collect();
        let start = Instant::now();
        let mut core = Duration::ZERO;
        let bvh = build_cwbvh_from_tris(&triangles, BvhBuildParams::medium_build(), &mut core);
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| RtTriangle::from(&triangles[i as usize]))
            .collect();
        Obvhs {
            bvh,
            tris,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    fn closest(&self, ray: &Ray) -> Option<Hit> {
        let mut hit = RayHit::none();
        self.bvh
            .ray_traverse(*ray, &mut hit, |r, i| self.tris[i].intersect(r))
            .then(|| Hit {
                t: hit.t,
                prim: self.bvh.primitive_indices[hit.primitive_id as usize],
                u: 0.0,
                v: 0.0,
            })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        !self
            .bvh
            .ray_traverse_miss(*ray, |r, i| self.tris[i].intersect(r))
    }
}

impl Peer for Obvhs {
    fn accel(&self) -> Accel {
        Accel::Obvhs
    }

    fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    fn bytes(&self) -> Option<usize> {
        Some(
            std::mem::size_of_val(self.bvh.nodes.as_slice())
                + std::mem::size_of_val(self.bvh.primitive_indices.as_slice())
                + std::mem::size_of_val(self.tris.as_slice()),
        )
    }

    fn version(&self) -> String {
        "obvhs 0.4.0 CWBVH (medium_build)".into()
    }

    fn prepare<'a>(&'a self, mode: Mode, set: &'a RaySet, occlusion: bool) -> Box<dyn Traced + 'a> {
        assert_eq!(mode, Mode::Scalar, "obvhs traces single rays");
        let rays = set
            .rays
            .iter()
            .map(|r| {
                Ray::new(
                    r.origin().into(),
                    r.dir().into(),
                    next_up(r.t_min()),
                    next_up(r.t_max()),
                )
            })
            .collect();
        Box::new(Prepared {
            engine: self,
            rays,
            out: if occlusion {
                Out::Occluded(vec![false; set.rays.len()])
            } else {
                Out::Closest(vec![None; set.rays.len()])
            },
        })
    }
}

enum Out {
    Closest(Vec<Option<Hit>>),
    Occluded(Vec<bool>),
}

struct Prepared<'a> {
    engine: &'a Obvhs,
    rays: Vec<Ray>,
    out: Out,
}

impl Traced for Prepared<'_> {
    fn reset(&mut self) {
        // obvhs reads its rays and never writes them.
    }

    fn trace(&mut self, pool: Option<&ThreadPool>) {
        let e = self.engine;
        match &mut self.out {
            Out::Closest(o) => map_into(pool, &self.rays, o, |r| e.closest(r)),
            Out::Occluded(o) => map_into(pool, &self.rays, o, |r| e.occluded(r)),
        }
    }

    fn results(&self) -> Results {
        match &self.out {
            Out::Closest(o) => Results::Closest(o.clone()),
            Out::Occluded(o) => Results::Occluded(o.clone()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_up_is_the_next_float() {
        assert_eq!(next_up(0.0), f32::from_bits(1));
        assert_eq!(next_up(1.0), 1.0 + f32::EPSILON);
        assert!(next_up(-1.0) > -1.0 && next_up(-1.0) < -0.99999);
        assert_eq!(next_up(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn obvhs_agrees_with_scalar_kd8_on_a_sphere() {
        use packtrace::KdTree;
        use packtrace::protocol::camera::Camera;
        use packtrace::protocol::{SceneFrame, workload};
        let mesh = packtrace::protocol::generate::sphere(2000);
        let tree = KdTree::build(mesh.clone(), &Default::default()).unwrap();
        let peer = Obvhs::new(&mesh);
        let frame = SceneFrame::of(&mesh);
        let primary = workload::primary(&Camera::auto(&frame.bounds), 32, 32).unwrap();
        let mut t = peer.prepare(Mode::Scalar, &primary, false);
        t.trace(None);
        let Results::Closest(got) = t.results() else {
            panic!()
        };
        let mut hits = 0;
        for (r, g) in primary.rays.iter().zip(&got) {
            let want = tree.intersect(r);
            assert_eq!(want.is_some(), g.is_some());
            if let (Some(a), Some(b)) = (want, g) {
                assert!((a.t - b.t).abs() <= 1e-4 * a.t, "{a:?} {b:?}");
                hits += 1;
            }
        }
        assert!(hits > 100);
    }
}

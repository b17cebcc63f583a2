//! Issue 17: exact at the edges. Rays whose interval ends at a hit or
//! starts just below it, at every coordinate scale, on every path; the
//! reported hit always lies inside the ray's interval with finite `t`,
//! `u`, `v`. Every comparison runs through the harness
//! (`tests/common/harness.rs`). The independent check's reproducers (A1,
//! A2, A3, B) are cases of `tests/regressions.rs`.

mod common;

use common::*;
use glam::Vec3;
use packtrace::{BruteForce, Hit, Mesh, Ray, RayQuery};

/// Every preset's tree, every path (scalar, packet lanes in every
/// position and neighbourhood, stream, naive layout) against brute force,
/// and brute force's answer is `expected`.
fn assert_every_path(mesh: &Mesh, ray: &Ray, expected: Option<Hit>) {
    let report = agree(mesh, &[*ray]);
    report.assert_ok("every path");
    assert_eq!(
        hit_bits(report.hit(0)),
        hit_bits(expected),
        "brute force\nray: {}",
        ray_literal(ray)
    );
}

/// Hits on meshes far beyond the f32 range of the fast route, and far
/// below it: every path reports the same finite hit (before, 1e30-scale
/// meshes were missed by every path and tiny ones too).
#[test]
fn huge_and_tiny_triangles_are_hit_with_finite_t() {
    for scale in [1e-30f32, 1e-20, 1e-13, 1e13, 1e18, 1e30, 1e36] {
        let mesh = Mesh::new(
            vec![Vec3::ZERO, Vec3::X * scale, Vec3::Y * scale],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let ray = Ray::new(
            Vec3::new(0.25, 0.25, 1.0) * scale,
            Vec3::NEG_Z,
            0.0,
            f32::INFINITY,
        )
        .unwrap();
        let h = BruteForce::new(&mesh).intersect(&ray);
        let h = h.unwrap_or_else(|| panic!("scale {scale:e}: no hit"));
        assert_eq!(h.t, scale, "scale {scale:e}");
        assert_eq!((h.u, h.v), (0.25, 0.25), "scale {scale:e}");
        assert_every_path(&mesh, &ray, Some(h));
    }
}

/// A long sliver (6,781 units long, under one unit wide) seen from 5,000
/// units away: the f32 triangle test's `t` was off by 0.2 (its error grows
/// with the triangle's length squared over its width), beyond the
/// traversal's margin, and three presets returned the other triangle
/// (found by the harness's companion rays). Fixed by taking vague
/// distances from f64 against a `2^-12` margin (docs/testing.md, finding 12).
#[test]
fn a_long_sliver_far_away_agrees_with_brute_force() {
    let mesh = Mesh::new(
        vec![
            Vec3::new(0.25, 0.25, -0.5),
            Vec3::new(-1.0, -0.0, -0.0),
            Vec3::new(6781.3574, -0.0, 3.9871304),
            Vec3::new(-1.0, -2.0, -0.0),
            Vec3::new(-1.0, -0.0, -1.0),
        ],
        vec![[0, 1, 2], [3, 4, 2]],
    )
    .unwrap();
    let ray = Ray::new(
        Vec3::new(-3392.1812, -5087.02, -3389.6863),
        Vec3::new(1.0, 0.75, 0.5),
        0.0,
        f32::INFINITY,
    )
    .unwrap();
    let brute = BruteForce::new(&mesh).intersect(&ray);
    assert!(brute.is_some());
    assert_every_path(&mesh, &ray, brute);
}

// ---------------------------------------------------------------------------
// Properties: intervals around a found hit, at every scale
// ---------------------------------------------------------------------------

use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// A triangle in the unit cube: tilted (three free corners) or lying in a
/// plane `axis = c` (the architectural case: walls, floors, steps).
#[derive(Clone, Debug)]
enum Tri {
    Tilted([[f32; 3]; 3]),
    AxisAligned {
        axis: usize,
        c: f32,
        uv: [[f32; 2]; 3],
    },
}

fn unit() -> impl Strategy<Value = f32> {
    prop_oneof![
        2 => prop::sample::select(&[0.0f32, 0.125, 0.25, 0.5, 0.75, 1.0][..]),
        3 => 0.0f32..=1.0,
    ]
}

fn tri() -> impl Strategy<Value = Tri> {
    prop_oneof![
        1 => prop::array::uniform3(prop::array::uniform3(unit())).prop_map(Tri::Tilted),
        2 => (0usize..3, unit(), prop::array::uniform3(prop::array::uniform2(unit())))
            .prop_map(|(axis, c, uv)| Tri::AxisAligned { axis, c, uv }),
    ]
}

/// `10^e` for a uniform exponent: scales 1e-4 to 1e6, offsets up to 1e6.
fn pow10(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    (lo..=hi).prop_map(|e| 10f32.powf(e))
}

fn offset() -> impl Strategy<Value = Vec3> {
    let c = prop_oneof![1 => Just(0.0f32), 3 => (pow10(-2.0, 6.0), any::<bool>()).prop_map(|(m, n)| if n { -m } else { m })];
    [c.clone(), c.clone(), c].prop_map(Vec3::from)
}

#[derive(Clone, Debug)]
struct Scene {
    tris: Vec<Tri>,
    scale: f32,
    offset: Vec3,
}

fn scene() -> impl Strategy<Value = Scene> {
    (
        prop::collection::vec(tri(), 1..40),
        pow10(-4.0, 6.0),
        offset(),
    )
        .prop_map(|(tris, scale, offset)| Scene {
            tris,
            scale,
            offset,
        })
}

impl Scene {
    fn place(&self, p: [f32; 3]) -> Vec3 {
        Vec3::from(p) * self.scale + self.offset
    }

    fn mesh(&self) -> Mesh {
        let mut positions = Vec::new();
        for t in &self.tris {
            let corners: [[f32; 3]; 3] = match t {
                Tri::Tilted(c) => *c,
                Tri::AxisAligned { axis, c, uv } => uv.map(|[a, b]| {
                    let mut p = [0.0; 3];
                    p[*axis] = *c;
                    p[(axis + 1) % 3] = a;
                    p[(axis + 2) % 3] = b;
                    p
                }),
            };
            positions.extend(corners.map(|c| self.place(c)));
        }
        let triangles = (0..self.tris.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        Mesh::new(positions, triangles).unwrap()
    }
}

/// Where a first ray starts: anywhere in (or around) the unit cube, or
/// just off a triangle's surface (the renderer's case: a secondary ray
/// from a hit point, offset by `10^-e` of the scene's size).
#[derive(Clone, Debug)]
enum From {
    Free([f32; 3]),
    NearSurface {
        tri: prop::sample::Index,
        bary: [f32; 2],
        off: [f32; 3],
        e: f32,
    },
}

/// A first ray: from `from`, aimed at a point or along an axis.
#[derive(Clone, Debug)]
struct Probe {
    from: From,
    to: [f32; 3],
    axis_parallel: Option<(usize, bool)>,
    /// Re-trace from the hit point in this direction too (a secondary ray).
    bounce: [f32; 3],
}

fn probe() -> impl Strategy<Value = Probe> {
    let p = || prop::array::uniform3(prop_oneof![3 => unit(), 1 => -1.0f32..2.0]);
    let from = prop_oneof![
        1 => p().prop_map(From::Free),
        2 => (any::<prop::sample::Index>(), prop::array::uniform2(0.0f32..=1.0),
              prop::array::uniform3(-1.0f32..1.0), 1.0f32..7.0)
            .prop_map(|(tri, bary, off, e)| From::NearSurface { tri, bary, off, e }),
    ];
    (
        from,
        p(),
        prop::option::weighted(0.2, (0usize..3, any::<bool>())),
        prop::array::uniform3(-1.0f32..1.0),
    )
        .prop_map(|(from, to, axis_parallel, bounce)| Probe {
            from,
            to,
            axis_parallel,
            bounce,
        })
}

/// The recipe around a found hit at `t`: `t_max = t`,
/// `t_max = next_up(t)`, `t_min = next_down(t)`, `t_min = t`, and the
/// one-ulp interval `(next_down(t), t]`.
fn around(ray: &Ray, t: f32) -> [Ray; 5] {
    let (o, d) = (ray.origin(), ray.dir());
    [
        Ray::new(o, d, ray.t_min(), t).unwrap(),
        Ray::new(o, d, ray.t_min(), t.next_up()).unwrap(),
        Ray::new(o, d, t.next_down(), f32::INFINITY).unwrap(),
        Ray::new(o, d, t, f32::INFINITY).unwrap(),
        Ray::new(o, d, t.next_down(), t).unwrap(),
    ]
}

/// The rays of the probes: each first ray; where it hits, the intervals
/// around its hit, a secondary ray from the hit point and the intervals
/// around that one's hit. Every ray also gets a listed packet `[the ray
/// reversed, the ray, the ray with the empty interval (1, 0], the ray]`
/// (the reversed and empty rays are traced as rays too).
fn check_scene(scene: &Scene, probes: &[Probe], tally: &Tally) -> Result<(), TestCaseError> {
    let mesh = scene.mesh();
    let mut engines = Engines::try_new(&mesh).map_err(TestCaseError::fail)?;
    engines.options.placements = Placements::Cycle;
    let brute = engines.brute;
    let mut rays: Vec<Ray> = Vec::new();
    let mut packets: Vec<Vec<Option<usize>>> = Vec::new();
    let mut push = |ray: Ray| {
        let k = rays.len();
        rays.push(ray);
        rays.push(Ray::new(ray.origin(), -ray.dir(), ray.t_min(), ray.t_max()).unwrap());
        rays.push(Ray::new_unchecked(ray.origin(), ray.dir(), 1.0, 0.0));
        packets.push(vec![Some(k + 1), Some(k), Some(k + 2), Some(k)]);
        brute.intersect(&ray)
    };
    for pr in probes {
        let from = match &pr.from {
            From::Free(p) => scene.place(*p),
            From::NearSurface { tri, bary, off, e } => {
                let c = mesh.corners(tri.index(mesh.triangle_count()));
                let (a, b) = (bary[0], bary[1] * (1.0 - bary[0]));
                let on = c[0] + (c[1] - c[0]) * a + (c[2] - c[0]) * b;
                on + Vec3::from(*off) * (scene.scale * 10f32.powf(-e))
            }
        };
        let dir = match pr.axis_parallel {
            Some((axis, neg)) => {
                let mut d = Vec3::ZERO;
                d[axis] = if neg { -1.0 } else { 1.0 };
                d
            }
            None => scene.place(pr.to) - from,
        };
        tally.probes.set(tally.probes.get() + 1);
        let Ok(ray) = Ray::new(from, dir, 0.0, f32::INFINITY) else {
            continue;
        };
        let Some(h) = push(ray) else {
            continue;
        };
        tally.hits.set(tally.hits.get() + 1);
        for r in around(&ray, h.t) {
            push(r);
        }
        // A secondary ray from the hit point, and the same recipe on it.
        if let Ok(sec) = Ray::new(ray.at(h.t), Vec3::from(pr.bounce), 0.0, f32::INFINITY)
            && let Some(h2) = push(sec)
        {
            for r in around(&sec, h2.t) {
                push(r);
            }
        }
    }
    engines
        .agree_packets(&rays, &packets)
        .check("intervals around a hit")
}

/// Probes drawn and probes that hit (their intervals are the test).
#[derive(Default)]
struct Tally {
    probes: std::cell::Cell<usize>,
    hits: std::cell::Cell<usize>,
}

/// Intervals that end at, or start just below, a found hit, on meshes
/// of axis-aligned and tilted triangles at scales 1e-4 to 1e6 and
/// offsets up to 1e6: every preset, scalar and packet, equals brute
/// force, and no path reports a hit outside its interval. A probe that
/// misses traces no interval around a hit, so at least a third of the
/// probes must hit (about half do: 375 of 708 with CI's seed and 64
/// cases), or the property checked too little.
#[test]
fn intervals_around_a_hit_at_every_scale() {
    let tally = Tally::default();
    let mut runner = proptest::test_runner::TestRunner::new(config(64));
    let cases = (scene(), prop::collection::vec(probe(), 1..24));
    if let Err(e) = runner.run(&cases, |(s, probes)| check_scene(&s, &probes, &tally)) {
        panic!("{e}");
    }
    let (probes, hits) = (tally.probes.get(), tally.hits.get());
    println!("{hits} of {probes} probes hit");
    assert!(
        3 * hits >= probes && hits > 0,
        "only {hits} of {probes} probes hit: the intervals around hits went mostly untested"
    );
}

//! PBRT's watertightness test: rays from inside a closed mesh must all hit
//! it. The mesh is a UV sphere with shared vertices (poles, rings,
//! segments) whose vertices are pushed radially by up to ±10%, so no two
//! triangles are coplanar and every edge is shared by exactly two
//! triangles. Rays start well inside the smallest radius and go in random
//! directions, or exactly at a vertex or an edge midpoint (the cases where
//! a non-watertight test leaks). No reference answer is needed; the hits
//! are also compared with brute force, bit for bit.

mod common;

use common::{Rng, hit_bits, ray_literal};
use glam::Vec3;
use packtrace::{
    BruteForce, KdBuildParams, KdTree, Mesh, Ray, RayPacket4, RayQuery, TraversalStats,
};

/// Radial jitter of every vertex, as a fraction of the unit radius.
const JITTER: f32 = 0.10;
/// Origins lie in a ball this large, far inside the smallest radius
/// (`1 - JITTER`).
const ORIGIN_RADIUS: f32 = 0.45;

/// A closed UV sphere: a north pole, `rings - 1` rings of `segments`
/// vertices, a south pole; `2 * segments * (rings - 1)` triangles, every
/// edge shared by two of them. Each vertex's radius is `1 ± JITTER`,
/// deterministic in `seed` and the vertex index.
fn jittered_sphere(rings: usize, segments: usize, seed: u64) -> Mesh {
    let mut rng = Rng(seed);
    let mut radius = || 1.0 + JITTER * (2.0 * rng.f32() - 1.0);
    let mut positions = vec![Vec3::Z * radius()];
    for k in 1..rings {
        let theta = std::f32::consts::PI * k as f32 / rings as f32;
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let dir = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            positions.push(dir * radius());
        }
    }
    positions.push(Vec3::NEG_Z * radius());
    let south = (positions.len() - 1) as u32;
    let ring = |k: usize, j: usize| (1 + (k - 1) * segments + j % segments) as u32;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
    }
    for k in 1..rings - 1 {
        for j in 0..segments {
            let (a, b) = (ring(k, j), ring(k, j + 1));
            let (c, d) = (ring(k + 1, j), ring(k + 1, j + 1));
            triangles.push([a, c, b]);
            triangles.push([b, c, d]);
        }
    }
    for j in 0..segments {
        triangles.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    let mesh = Mesh::new(positions, triangles).unwrap();
    assert_eq!(mesh.triangle_count(), 2 * segments * (rings - 1));
    mesh
}

/// A uniformly distributed point in the ball of radius `ORIGIN_RADIUS`.
fn inside(rng: &mut Rng) -> Vec3 {
    loop {
        let p = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if p.length_squared() <= 1.0 {
            return p * ORIGIN_RADIUS;
        }
    }
}

/// Rays of the test: random, at every vertex, at every edge midpoint, in
/// groups of four sharing one origin (so packets are meaningful). The
/// random groups point into one octant, so they take the packet path.
fn rays(mesh: &Mesh, random_groups: usize, aimed_limit: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng(seed);
    let mut rays = Vec::new();
    let ray = |o: Vec3, d: Vec3| Ray::new(o, d, 0.0, f32::INFINITY).unwrap();
    for g in 0..random_groups {
        let o = if g == 0 { Vec3::ZERO } else { inside(&mut rng) };
        let signs = rng.unit().signum();
        for _ in 0..4 {
            rays.push(ray(o, rng.unit().abs() * signs));
        }
    }
    // Targets: every used vertex and every edge midpoint (each edge once
    // per triangle side is fine), thinned to `aimed_limit` of each.
    let mut vertices: Vec<Vec3> = Vec::new();
    let mut midpoints: Vec<Vec3> = Vec::new();
    for t in 0..mesh.triangle_count() {
        let c = mesh.corners(t);
        vertices.push(c[0]);
        for k in 0..3 {
            midpoints.push((c[k] + c[(k + 1) % 3]) * 0.5);
        }
    }
    for targets in [vertices, midpoints] {
        let step = targets.len().div_ceil(aimed_limit).max(1);
        let mut o = Vec3::ZERO;
        for (i, p) in targets.iter().step_by(step).enumerate() {
            if i % 4 == 0 {
                // A new origin every four rays; the first group from the
                // centre, where `p - o` is the vertex itself.
                o = if i == 0 { Vec3::ZERO } else { inside(&mut rng) };
            }
            rays.push(ray(o, *p - o));
        }
    }
    while rays.len() % 4 != 0 {
        rays.push(ray(Vec3::ZERO, Vec3::X));
    }
    rays
}

/// Every ray hits: brute force (checked on every `brute_every`-th ray), the
/// scalar traversal and the packet traversal of every preset, with the
/// same hit as brute force.
fn check_watertight(mesh: &Mesh, rays: &[Ray], brute_every: usize) {
    let brute = BruteForce::new(mesh);
    let mut failures: Vec<String> = Vec::new();
    let mut fail = |what: String| {
        if failures.len() < 8 {
            failures.push(what);
        }
    };
    let mut reference: Vec<Option<packtrace::Hit>> = vec![None; rays.len()];
    for (i, r) in rays.iter().enumerate().step_by(brute_every) {
        reference[i] = brute.intersect(r);
        if reference[i].is_none() {
            fail(format!("brute force leaks: {}", ray_literal(r)));
        }
    }
    let mut leaks = 0usize;
    for (name, params) in KdBuildParams::presets() {
        let tree = KdTree::build(mesh.clone(), &params).unwrap();
        assert_eq!(tree.validate(), Ok(()), "{name}");
        let mut stats = TraversalStats::default();
        for (g, group) in rays.chunks_exact(4).enumerate() {
            let packet = tree.intersect4_counted(
                &RayPacket4::from_rays(&[group[0], group[1], group[2], group[3]]),
                &mut stats,
            );
            let occluded = tree.occluded4(&RayPacket4::from_rays(&[
                group[0], group[1], group[2], group[3],
            ]));
            for (l, r) in group.iter().enumerate() {
                let i = 4 * g + l;
                let scalar = tree.intersect(r);
                if scalar.is_none() {
                    leaks += 1;
                    fail(format!("{name}: scalar leaks: {}", ray_literal(r)));
                }
                if packet.hit(l).is_none() {
                    leaks += 1;
                    fail(format!("{name}: packet lane {l} leaks: {}", ray_literal(r)));
                }
                if occluded >> l & 1 == 0 || !tree.occluded(r) {
                    leaks += 1;
                    fail(format!("{name}: not occluded: {}", ray_literal(r)));
                }
                if i % brute_every == 0 && hit_bits(scalar) != hit_bits(reference[i]) {
                    fail(format!(
                        "{name}: kd {scalar:?} != brute {:?}: {}",
                        reference[i],
                        ray_literal(r)
                    ));
                }
                if hit_bits(packet.hit(l)) != hit_bits(scalar) {
                    fail(format!(
                        "{name}: packet {:?} != scalar {scalar:?}: {}",
                        packet.hit(l),
                        ray_literal(r)
                    ));
                }
            }
        }
        // The random groups share an octant: most packets must not fall
        // back to single rays, or the packet path went untested.
        assert!(
            stats.fallback_packets * 2 < stats.packets,
            "{name}: {} of {} packets fell back",
            stats.fallback_packets,
            stats.packets
        );
    }
    assert!(
        failures.is_empty(),
        "{} leaks; first failures:\n{}",
        leaks,
        failures.join("\n")
    );
}

#[test]
fn jittered_sphere_2k_is_watertight() {
    let mesh = jittered_sphere(32, 32, 1);
    assert_eq!(mesh.triangle_count(), 1984);
    let rays = rays(&mesh, 4000, 2000, 11);
    check_watertight(&mesh, &rays, 1);
}

#[test]
fn jittered_sphere_20k_is_watertight() {
    let mesh = jittered_sphere(100, 100, 2);
    assert_eq!(mesh.triangle_count(), 19_800);
    let rays = rays(&mesh, 2000, 3000, 12);
    check_watertight(&mesh, &rays, 8);
}

/// Thin slivers: many segments, few rings, so triangles near the poles are
/// long and thin and edges nearly parallel to many rays.
#[test]
fn jittered_sliver_sphere_is_watertight() {
    let mesh = jittered_sphere(6, 400, 3);
    let rays = rays(&mesh, 1000, 2000, 13);
    check_watertight(&mesh, &rays, 2);
}

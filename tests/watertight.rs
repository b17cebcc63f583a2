//! PBRT's watertightness test: rays from inside a closed mesh must all hit
//! it. The mesh is a UV sphere with shared vertices (poles, rings,
//! segments) whose vertices are pushed radially by up to ±10%, so no two
//! triangles are coplanar and every edge is shared by exactly two
//! triangles. Rays start well inside the smallest radius and go in random
//! directions, or exactly at a vertex or an edge midpoint (the cases where
//! a non-watertight test leaks). No reference answer is needed; the hits
//! are also compared with brute force, bit for bit, through the harness
//! (`tests/common/harness.rs`).

mod common;

use common::{Engines, Placements, Reference, Rng, ray_literal};
use glam::Vec3;
use packtrace::{Mesh, Ray, RayPacket4, TraversalStats};

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

/// Every ray hits. Every `brute_every`-th ray goes through the harness
/// against brute force (every preset's tree, validated; scalar, packet
/// placements in turn, stream, naive layout), and brute force must hit it;
/// every ray, traced in its group of four as one packet, goes through the
/// harness against the first preset's scalar traversal, which must hit
/// and be occluded. The first `random_groups` groups (one octant each)
/// must all take the packet path.
fn check_watertight(mesh: &Mesh, rays: &[Ray], random_groups: usize, brute_every: usize) {
    let mut failures: Vec<String> = Vec::new();
    let mut engines = Engines::new(mesh);
    // Packets beside zero-direction lanes visit every cell: too slow here.
    engines.options.placements = Placements::Cycle;
    engines.options.zero_neighbours = false;
    let sampled: Vec<Ray> = rays.iter().step_by(brute_every).copied().collect();
    let report = engines.agree(&sampled);
    if !report.is_ok() {
        failures.push(report.message("against brute force"));
    }
    for (r, a) in sampled.iter().zip(&report.expected) {
        if a.hit.is_none() {
            failures.push(format!("brute force leaks: {}", ray_literal(r)));
        }
    }
    engines.options.reference = Reference::Scalar;
    engines.options.placements = Placements::None;
    let groups: Vec<Vec<Option<usize>>> = (0..rays.len() / 4)
        .map(|g| (4 * g..4 * g + 4).map(Some).collect())
        .collect();
    let report = engines.agree_packets(rays, &groups);
    if !report.is_ok() {
        failures.push(report.message("in groups of four"));
    }
    let mut leaks = 0usize;
    for (r, a) in rays.iter().zip(&report.expected) {
        if a.hit.is_none() || !a.occluded {
            leaks += 1;
            failures.push(format!(
                "{}: scalar leaks: {}",
                engines.trees[0].name,
                ray_literal(r)
            ));
        }
    }
    // The random groups share an octant (`rays`): every one of them must
    // take the packet path, as one packet, neither split by octant nor
    // traced lane by lane, or the packet path went untested. A packet that
    // falls back lane by lane counts in `single_rays`, one split by octant
    // in `octant_splits` (`src/kdtree/hybrid.rs`).
    let coherent = &rays[..4 * random_groups];
    for t in &engines.trees {
        let mut stats = TraversalStats::default();
        for group in coherent.chunks_exact(4) {
            t.kd.intersect4_counted(
                &RayPacket4::from_rays(&[group[0], group[1], group[2], group[3]]),
                &mut stats,
            );
        }
        assert_eq!(
            (stats.packets, stats.rays),
            (random_groups as u64, coherent.len() as u64),
            "{}: packets and rays counted",
            t.name
        );
        assert_eq!(
            (stats.single_rays, stats.octant_splits),
            (0, 0),
            "{}: of {} same-octant packets, {} lanes fell back to single rays and {} packets \
             were split by octant",
            t.name,
            stats.packets,
            stats.single_rays,
            stats.octant_splits
        );
    }
    assert!(
        failures.is_empty(),
        "{} leaks; {} failures, the first:\n{}",
        leaks,
        failures.len(),
        failures[..failures.len().min(8)].join("\n")
    );
}

#[test]
fn jittered_sphere_2k_is_watertight() {
    let mesh = jittered_sphere(32, 32, 1);
    assert_eq!(mesh.triangle_count(), 1984);
    let rays = rays(&mesh, 4000, 2000, 11);
    check_watertight(&mesh, &rays, 4000, 1);
}

#[test]
fn jittered_sphere_20k_is_watertight() {
    let mesh = jittered_sphere(100, 100, 2);
    assert_eq!(mesh.triangle_count(), 19_800);
    let rays = rays(&mesh, 2000, 3000, 12);
    check_watertight(&mesh, &rays, 2000, 8);
}

/// Thin slivers: many segments, few rings, so triangles near the poles are
/// long and thin and edges nearly parallel to many rays.
#[test]
fn jittered_sliver_sphere_is_watertight() {
    let mesh = jittered_sphere(6, 400, 3);
    let rays = rays(&mesh, 1000, 2000, 13);
    check_watertight(&mesh, &rays, 1000, 2);
}

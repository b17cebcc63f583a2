//! Trees deeper than the small traversal stack: the traversals must pick
//! the 64-entry stack for them (a 32-entry one overflows), and still equal
//! brute force. A mutation test finding: flipping the stack choice in
//! `traverse` / `traverse4` survived every other suite.

mod common;

use common::box_triangles;
use glam::Vec3;
use packtrace::{BruteForce, DepthLimit, KdBuildParams, KdTree, Mesh, Ray, RayPacket4, RayQuery};

/// Cubes shrinking geometrically toward the origin along the diagonal:
/// cube `k` spans `[2^-k / 2, 2^-k * 3/4]` on every axis. Each split that
/// peels the largest cube off leaves a cell a quarter of the size, so the
/// tree is a chain about as deep as the cubes are many.
fn shrinking_cubes(n: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for k in 0..n {
        let s = (-(k as f32)).exp2();
        let (lo, hi) = (Vec3::splat(0.5 * s), Vec3::splat(0.75 * s));
        box_triangles(lo, hi, &mut positions, &mut triangles);
    }
    Mesh::new(positions, triangles).unwrap()
}

#[test]
fn trees_deeper_than_32_are_traced_with_the_deep_stack() {
    let mesh = shrinking_cubes(48);
    let params = KdBuildParams {
        max_depth: DepthLimit::Fixed(64),
        ..KdBuildParams::default()
    };
    let tree = KdTree::build(mesh.clone(), &params).unwrap();
    tree.validate().unwrap();
    let depth = tree.stats().max_depth;
    assert!(
        depth > 40,
        "the scene must build a deep tree, got depth {depth}"
    );
    let brute = BruteForce::new(&mesh);
    let mut rays = Vec::new();
    // Along the diagonal both ways, and slightly off it: the rays from
    // beyond the largest cube descend the whole chain with a far child
    // deferred at every level.
    for o in [
        Vec3::splat(-1.0),
        Vec3::splat(2.0),
        Vec3::new(2.0, 1.9, 2.1),
    ] {
        for t_max in [f32::INFINITY, 1.0] {
            rays.push(Ray::new(o, -o.signum(), 0.0, t_max).unwrap());
            rays.push(Ray::new(o, Vec3::splat(0.0) - o, 0.0, t_max).unwrap());
        }
    }
    for r in &rays {
        assert_eq!(tree.intersect(r), brute.intersect(r), "{r:?}");
        assert_eq!(tree.occluded(r), brute.occluded(r), "{r:?}");
    }
    for chunk in rays.chunks(4) {
        let p = RayPacket4::from_slice(chunk);
        let h = tree.intersect4(&p);
        for (i, r) in chunk.iter().enumerate() {
            assert_eq!(h.hit(i), brute.intersect(r), "{r:?}");
        }
    }
}

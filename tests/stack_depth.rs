//! Trees deeper than the small traversal stack: every traversal must pick
//! the 64-entry stack for them (a 32-entry one overflows), and still equal
//! brute force. A mutation test finding: flipping the stack choice in
//! `traverse` / `traverse4` survived every other suite. Each traversal
//! chooses its stack by itself (`scalar.rs`, `packet.rs`, `group.rs`), so
//! each is driven down the deep chain here: scalar, 4- and 8-wide packets
//! (closest hit and occlusion, every lane placement, the stream API, every
//! node layout, through the harness) and ray groups (steered to the leaves
//! and handed off, leaf culling on and off).

mod common;

use common::{Engines, box_triangles, hit_bits};
use glam::Vec3;
use packtrace::group::{Apex, RayGroup};
use packtrace::{DepthLimit, KdBuildParams, KdTree, Mesh, Ray, RayPacket8};

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

/// The deep tree: 48 cubes, a chain over 40 levels deep (validated).
fn deep_tree() -> (Mesh, KdTree) {
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
    (mesh, tree)
}

/// Rays along the chain: from beyond its small end (they descend the
/// whole chain with a far child deferred at every level) and from beyond
/// its large end, along the diagonal and slightly off it, with open and
/// closed intervals.
fn chain_rays() -> Vec<Ray> {
    let mut rays = Vec::new();
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
    rays
}

#[test]
fn trees_deeper_than_32_are_traced_with_the_deep_stack() {
    let (mesh, tree) = deep_tree();
    let engines = Engines::from_trees(&mesh, vec![("depth 64".to_string(), tree)]);
    let rays = chain_rays();
    let report = engines.agree(&rays);
    report.assert_ok("the deep chain");
    let hits = report.expected.iter().filter(|a| a.hit.is_some()).count();
    assert!(hits >= rays.len() / 2, "{hits} of {} rays hit", rays.len());
}

/// A group of 8 x 8 rays from an apex just below the chain's small end,
/// their directions a few ulps apart around the diagonal: every ray runs
/// down the whole chain (its offset from the diagonal stays far below
/// the smallest cube's size until it has passed it), as one coherent
/// group. Steered to the leaves (`traverse_group`'s stack) and handed off
/// at the entry point (the packet traversal's), with and without leaf
/// culling, closest hit and occlusion: every lane equals the scalar
/// query, which equals brute force.
#[test]
fn groups_on_a_tree_deeper_than_32_use_the_deep_stack() {
    let (mesh, tree) = deep_tree();
    let apex = Vec3::splat(-(2f32.powi(-60)));
    let step = f32::EPSILON;
    let packets: Vec<RayPacket8> = (0..8)
        .map(|p| {
            RayPacket8::from_fn(|l| {
                let d = Vec3::new(1.0, 1.0 + step * l as f32, 1.0 + step * p as f32);
                Ray::new(apex, d, 0.0, f32::INFINITY).ok()
            })
        })
        .collect();
    let brute = packtrace::BruteForce::new(&mesh);
    let mut want = Vec::new();
    for p in &packets {
        for l in 0..8 {
            let r = p.ray(l).unwrap();
            let h = tree.intersect(&r);
            assert_eq!(
                hit_bits(h),
                hit_bits(packtrace::RayQuery::intersect(&brute, &r))
            );
            // The smallest cube, at the chain's far end from the root.
            assert_eq!(h.map(|h| h.prim / 12), Some(47), "ray {r:?}");
            want.push((h, tree.occluded(&r)));
        }
    }
    for handoff in [false, true] {
        for cull in [false, true] {
            let g = RayGroup::new(&packets, apex, Apex::Origin)
                .unwrap()
                .with_entry_handoff(handoff)
                .with_leaf_culling(cull);
            assert!(g.is_coherent(), "the group has a frustum");
            let hits = tree.intersect_group(&g);
            let occluded = tree.occluded_group(&g);
            for (j, (h, &o)) in hits.iter().zip(&occluded).enumerate() {
                for l in 0..8 {
                    let (wh, wo) = want[8 * j + l];
                    let what = format!("hand-off {handoff}, culling {cull}, packet {j} lane {l}");
                    assert_eq!(hit_bits(h.hit(l)), hit_bits(wh), "{what}");
                    assert_eq!(o >> l & 1 == 1, wo, "{what}: occlusion");
                }
            }
        }
    }
}

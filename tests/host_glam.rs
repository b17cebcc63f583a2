//! A host as issue 15 describes it: its only math types come from
//! `packtrace::glam`, so they are the very types the API takes (no second
//! `glam` version in play). This file must not name the `glam` crate
//! directly; `tests/layers.rs` does not check that, review does.

use packtrace::glam::{Vec3, Vec3A};
use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket4};

#[test]
fn a_host_builds_and_traces_with_the_reexported_glam() {
    let mesh = Mesh::new(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
        vec![[0, 1, 2], [1, 3, 2]],
    )
    .unwrap();
    let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
    let ray = Ray::new(Vec3::new(0.75, 0.75, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
    let hit = tree.intersect(&ray).unwrap();
    assert_eq!((hit.t, hit.prim), (1.0, 1));
    // The scene box is in the re-exported `Vec3A`.
    let bounds = tree.bounds();
    assert_eq!(bounds.min, Vec3A::ZERO);
    assert_eq!(bounds.max, Vec3A::new(1.0, 1.0, 0.0));
    // Packets take the same rays.
    let hits = tree.intersect4(&RayPacket4::from_rays(&[ray; 4]));
    assert_eq!(hits.hit(3), Some(hit));
}

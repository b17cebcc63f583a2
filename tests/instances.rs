//! Scenes of instances (issue 16): the scene's scalar traversal equals the
//! brute-force scene oracle (every instance, every triangle, the ray
//! transformed naively), and every packet width and the stream API equal
//! the scalar traversal, bit for bit, on random scenes of random
//! instances: translated, rotated, scaled, mirrored (negative
//! determinant) and nearly singular transforms, overlapping instances,
//! instances of the same geometry in the same place (ties between
//! instances), with ray masks and an any-hit filter; rays from far away,
//! from inside instances, axis-parallel, and aimed at instance vertices
//! (grazing shared vertices and edges).

use glam::{Affine3A, Quat, Vec3};
use packtrace::scene::{
    BruteScene, GeometryId, InstanceId, Query, Scene, SceneError, SceneHit, SceneQuery, TopLevel,
    TransformError,
};
use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket4, RayPacket8};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Coordinates on a coarse grid, so that triangles share vertices and
/// edges and some are degenerate.
const GRID: [f32; 7] = [-1.0, -0.5, 0.0, 0.25, 0.5, 1.0, 2.0];

fn mesh_strategy() -> impl Strategy<Value = Mesh> {
    let corner = (0..GRID.len(), 0..GRID.len(), 0..GRID.len())
        .prop_map(|(x, y, z)| Vec3::new(GRID[x], GRID[y], GRID[z]));
    prop::collection::vec(corner, 3..24).prop_map(|p| {
        let n = p.len() as u32;
        let tris = (0..n - 2)
            .map(|i| [i, (i + 1) % n, (i * 7 + 2) % n])
            .collect();
        Mesh::new(p, tris).expect("grid mesh")
    })
}

/// An object-to-world transform of one of the kinds the issue names.
fn transform_strategy() -> impl Strategy<Value = Affine3A> {
    let v = (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0).prop_map(|(x, y, z)| Vec3::new(x, y, z));
    let axis = v.clone().prop_filter("axis", |a| a.length() > 0.1);
    prop_oneof![
        Just(Affine3A::IDENTITY),
        v.clone().prop_map(Affine3A::from_translation),
        (axis.clone(), -7.0f32..7.0, v.clone()).prop_map(|(a, ang, t)| {
            Affine3A::from_rotation_translation(Quat::from_axis_angle(a.normalize(), ang), t)
        }),
        // Non-uniform scales, mirrored ones among them.
        (
            prop::sample::select(vec![-2.0f32, -1.0, -0.5, 0.3, 1.0, 1.7]),
            prop::sample::select(vec![-1.0f32, 0.5, 1.0, 2.5]),
            prop::sample::select(vec![-0.7f32, 1.0, 3.0]),
            axis.clone(),
            -3.0f32..3.0,
            v.clone()
        )
            .prop_map(|(x, y, z, a, ang, t)| {
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(x, y, z),
                    Quat::from_axis_angle(a.normalize(), ang),
                    t,
                )
            }),
        // Nearly singular: one axis squashed by up to 10^4.
        (
            prop::sample::select(vec![1e-2f32, 1e-3, 1e-4, 3e-4]),
            axis,
            -3.0f32..3.0,
            v
        )
            .prop_map(|(s, a, ang, t)| {
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(1.0, s, 1.0),
                    Quat::from_axis_angle(a.normalize(), ang),
                    t,
                )
            }),
        // Shears.
        (-2.0f32..2.0, -2.0f32..2.0).prop_map(|(a, b)| {
            Affine3A::from_cols_array(&[1.0, 0.0, 0.0, a, 1.0, 0.0, b, 0.0, 1.0, 0.0, 0.0, 0.0])
        }),
    ]
}

/// One instance: geometry index (modulo the geometry count), transform,
/// mask, and whether it repeats the previous instance exactly (a tie).
type InstanceSpec = (usize, Affine3A, u32, bool);

fn instance_strategy() -> impl Strategy<Value = InstanceSpec> {
    (
        0usize..3,
        transform_strategy(),
        prop::sample::select(vec![u32::MAX, 1, 2, 3]),
        prop::bool::weighted(0.15),
    )
}

fn scene_of(meshes: &[Mesh], instances: &[InstanceSpec], top: TopLevel) -> Scene {
    let mut scene = Scene::with_top_level(top);
    let ids: Vec<GeometryId> = meshes
        .iter()
        .enumerate()
        .map(|(i, m)| {
            scene.add_geometry(
                &format!("m{i}"),
                KdTree::build(m.clone(), &KdBuildParams::default()).unwrap(),
            )
        })
        .collect();
    let mut e = scene.edit();
    let mut prev: Option<(GeometryId, Affine3A)> = None;
    for &(g, m, mask, repeat) in instances {
        let (g, m) = match (repeat, prev) {
            (true, Some(p)) => p,
            _ => (ids[g % ids.len()], m),
        };
        // Transforms past the condition limit are refused: skip them.
        let Ok(id) = e.add_instance(g, m) else {
            continue;
        };
        e.set_mask(id, mask).unwrap();
        prev = Some((g, m));
    }
    e.commit();
    scene
}

/// Rays of every kind for a scene: between grid points scaled to the
/// scene's box, axis-parallel ones, from far away, and aimed exactly at
/// instance vertices.
fn rays_for(scene: &Scene, seeds: &[(usize, usize, usize, u8, f32)]) -> Vec<Ray> {
    let b = scene.bounds();
    let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
    let size = (hi - lo).max(Vec3::splat(1.0));
    let point = |i: usize, j: usize, k: usize| {
        lo + size
            * Vec3::new(
                (GRID[i % 7] + 1.0) / 3.0,
                (GRID[j % 7] + 1.0) / 3.0,
                (GRID[k % 7] + 1.0) / 3.0,
            )
    };
    let vertices: Vec<Vec3> = scene
        .instances()
        .flat_map(|(_, inst)| {
            let m = inst.transform().to_world();
            let mesh = scene.geometry(inst.geometry()).unwrap().tree().mesh();
            mesh.positions()
                .iter()
                .map(move |&p| m.transform_point3(p))
                .collect::<Vec<_>>()
        })
        .collect();
    let mut rays = Vec::new();
    for &(i, j, k, kind, t) in seeds {
        let o = point(i, j, k);
        let (o, d) = match kind % 6 {
            0 => (o, point(k + 3, i + 1, j + 5) - o),
            // Axis-parallel, both signs.
            1 => (o, [Vec3::X, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_X][i % 4]),
            // From far away toward the scene.
            2 => {
                let far = o + Vec3::new(1e3, -7e2, 3e3) * (1.0 + t);
                (far, o - far)
            }
            // Aimed at an instance vertex (grazing shared vertices/edges).
            3 | 4 if !vertices.is_empty() => {
                let v = vertices[(i * 31 + j * 7 + k) % vertices.len()];
                (o, v - o)
            }
            _ => (o, Vec3::new(t - 0.5, 0.3, -1.0)),
        };
        let Ok(r) = Ray::new(o, d, 0.0, f32::INFINITY) else {
            continue;
        };
        rays.push(r);
        // The same ray with an interval ending at its scene hit (exact
        // ends) and starting just past it.
        if let Some(h) = scene.intersect(&r) {
            rays.push(Ray::new(o, d, 0.0, h.t).unwrap());
            rays.push(Ray::new(o, d, h.t, f32::INFINITY).unwrap());
        }
    }
    rays
}

fn same(a: Option<SceneHit>, b: Option<SceneHit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            a.t.to_bits() == b.t.to_bits()
                && a.u.to_bits() == b.u.to_bits()
                && a.v.to_bits() == b.v.to_bits()
                && (a.prim, a.geometry, a.instance) == (b.prim, b.geometry, b.instance)
        }
        _ => false,
    }
}

/// Scalar equals the oracle; packets of 4 and 8 (lane masks rotated) and
/// streams equal scalar.
fn check(scene: &Scene, rays: &[Ray], q: &Query<'_>, label: &str) -> Result<(), TestCaseError> {
    let brute = BruteScene::new(scene);
    for (k, r) in rays.iter().enumerate() {
        let got = scene.intersect_with(r, q);
        let want = brute.intersect_with(r, q);
        prop_assert!(
            same(got, want),
            "{label}: ray {k} {r:?}: scene {got:?}, brute force {want:?}"
        );
        let occ = scene.occluded_with(r, q);
        prop_assert_eq!(
            occ,
            want.is_some(),
            "{}: occlusion of ray {} {:?}",
            label,
            k,
            r
        );
        prop_assert_eq!(brute.occluded_with(r, q), want.is_some());
    }
    // Packets: lane i of packet j is ray 8 j + i (some lanes empty), each
    // lane with its own mask drawn from the query's.
    for (j, chunk) in rays.chunks(8).enumerate() {
        let lanes = |w: usize| -> Vec<Option<Ray>> {
            (0..w)
                .map(|i| chunk.get(i).copied().filter(|_| (i + j) % 5 != 4))
                .collect()
        };
        let masks: [u32; 8] = std::array::from_fn(|i| q.mask((i + j) % 8));
        let qp = q.with_lane_masks(masks);
        let l8 = lanes(8);
        let p8 = RayPacket8::from_fn(|i| l8[i]);
        let h8 = scene.intersect_packet(&p8, &qp);
        let o8 = scene.occluded_packet(&p8, &qp);
        // In place, into a buffer that holds another packet's hits.
        let mut into = scene.intersect_packet(&RayPacket8::from_fn(|i| l8[(i + 3) % 8]), &qp);
        scene.intersect_packet_into(&p8, &qp, &mut into);
        for i in 0..8 {
            prop_assert!(
                same(into.hit(i), h8.hit(i)),
                "{label}: packet8 in place {j} lane {i}"
            );
        }
        let l4 = lanes(4);
        let p4 = RayPacket4::from_fn(|i| l4[i]);
        let h4 = scene.intersect4_with(&p4, &qp);
        let o4 = scene.occluded4_with(&p4, &qp);
        for i in 0..8 {
            let qi = q.with_mask(masks[i]);
            let want = l8[i].and_then(|r| scene.intersect_with(&r, &qi));
            prop_assert!(
                same(h8.hit(i), want),
                "{label}: packet8 {j} lane {i}: {:?} vs scalar {want:?}",
                h8.hit(i)
            );
            prop_assert_eq!(
                o8 >> i & 1 == 1,
                want.is_some(),
                "{}: occluded8 lane {}",
                label,
                i
            );
            if i < 4 {
                prop_assert!(same(h4.hit(i), want), "{label}: packet4 {j} lane {i}");
                prop_assert_eq!(o4 >> i & 1 == 1, want.is_some(), "{}: occluded4", label);
            }
        }
    }
    // Streams: the caller's order, lane 0's mask for every ray.
    let mut hits = vec![None; rays.len()];
    scene.intersect_rays_with(rays, &mut hits, q);
    let mut occ = vec![false; rays.len()];
    scene.occluded_rays_with(rays, &mut occ, q);
    for (k, r) in rays.iter().enumerate() {
        let want = scene.intersect_with(r, q);
        prop_assert!(same(hits[k], want), "{label}: stream ray {k}");
        prop_assert_eq!(occ[k], want.is_some(), "{}: stream occlusion {}", label, k);
    }
    Ok(())
}

/// A pure filter: rejects a third of the hits, by instance and triangle
/// and by where on the triangle they are.
fn alpha(h: &SceneHit) -> bool {
    !(h.prim + 2 * h.instance.0).is_multiple_of(3) || h.u < 0.3
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn scenes_equal_the_oracle_on_every_path(
        meshes in prop::collection::vec(mesh_strategy(), 1..4),
        instances in prop::collection::vec(instance_strategy(), 1..7),
        seeds in prop::collection::vec((0usize..7, 0usize..7, 0usize..7, 0u8..6, 0.0f32..1.0), 4..16),
        median in any::<bool>(),
    ) {
        let top = if median { TopLevel::Median } else { TopLevel::Sah };
        let scene = scene_of(&meshes, &instances, top);
        let rays = rays_for(&scene, &seeds);
        check(&scene, &rays, &Query::new(), "plain")?;
        check(&scene, &rays, &Query::new().with_mask(1), "mask 1")?;
        check(&scene, &rays, &Query::new().with_lane_masks([1, 2, 3, u32::MAX, 0, 2, 1, 3]), "lane masks")?;
        check(&scene, &rays, &Query::new().with_filter(&alpha), "filter")?;
        check(&scene, &rays, &Query::new().with_mask(2).with_filter(&alpha), "mask 2 and filter")?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// A top level of one instance takes its own path in the scalar query
    /// (no walk, no merge): the same checks on scenes of exactly one.
    #[test]
    fn one_instance_scenes_equal_the_oracle_on_every_path(
        mesh in mesh_strategy(),
        instance in instance_strategy(),
        seeds in prop::collection::vec((0usize..7, 0usize..7, 0usize..7, 0u8..6, 0.0f32..1.0), 4..16),
    ) {
        let scene = scene_of(&[mesh], &[instance], TopLevel::Sah);
        let rays = rays_for(&scene, &seeds);
        check(&scene, &rays, &Query::new(), "plain")?;
        check(&scene, &rays, &Query::new().with_mask(1), "mask 1")?;
        check(&scene, &rays, &Query::new().with_mask(0), "mask 0")?;
        check(&scene, &rays, &Query::new().with_filter(&alpha), "filter")?;
        check(&scene, &rays, &Query::new().with_mask(2).with_filter(&alpha), "mask 2 and filter")?;
    }
}

fn triangle() -> Mesh {
    Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap()
}

fn one_geometry() -> (Scene, GeometryId) {
    let mut s = Scene::new();
    let g = s.add_geometry(
        "tri",
        KdTree::build(triangle(), &KdBuildParams::default()).unwrap(),
    );
    (s, g)
}

#[test]
fn a_filter_that_rejects_everything_and_a_mask_that_matches_nothing_give_no_hit() {
    let (mut s, g) = one_geometry();
    {
        let mut e = s.edit();
        for z in 0..10 {
            let id = e
                .add_instance(g, Affine3A::from_translation(Vec3::Z * z as f32))
                .unwrap();
            e.set_mask(id, 0b1).unwrap();
        }
    }
    let r = Ray::new(Vec3::new(0.2, 0.2, 20.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
    assert_eq!(s.intersect(&r).unwrap().instance, InstanceId(9));
    let none = |_: &SceneHit| false;
    let q = Query::new().with_filter(&none);
    let p = RayPacket8::from_rays(&[r; 8]);
    assert_eq!(s.intersect_with(&r, &q), None);
    assert!(!s.occluded_with(&r, &q));
    assert_eq!(s.intersect_packet(&p, &q).mask(), 0);
    assert_eq!(s.occluded_packet(&p, &q), 0);
    let q = Query::new().with_mask(0b10);
    assert_eq!(s.intersect_with(&r, &q), None);
    assert!(!s.occluded_with(&r, &q));
    assert_eq!(s.intersect_packet(&p, &q).mask(), 0);
    assert_eq!(s.occluded_packet(&p, &q), 0);
    // A filter that keeps only instance 3 finds it behind the others.
    let only3 = |h: &SceneHit| h.instance == InstanceId(3);
    let h = s
        .intersect_with(&r, &Query::new().with_filter(&only3))
        .unwrap();
    assert_eq!((h.instance, h.t), (InstanceId(3), 17.0));
}

#[test]
fn ties_between_instances_go_to_the_smaller_id_on_every_path() {
    let (mut s, g) = one_geometry();
    let ids: Vec<InstanceId> = {
        let mut e = s.edit();
        (0..5)
            .map(|_| e.add_instance(g, Affine3A::IDENTITY).unwrap())
            .collect()
    };
    s.edit().remove_instance(ids[0]).unwrap();
    let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    assert_eq!(s.intersect(&r).unwrap().instance, ids[1]);
    let h = s.intersect_packet(&RayPacket4::from_rays(&[r; 4]), &Query::new());
    assert!((0..4).all(|i| h.hit(i).unwrap().instance == ids[1]));
    assert_eq!(
        BruteScene::new(&s)
            .intersect_with(&r, &Query::new())
            .unwrap()
            .instance,
        ids[1]
    );
}

#[test]
fn moving_instances_rebuilds_only_the_top_level() {
    let mut s = Scene::new();
    let tree = std::sync::Arc::new(
        KdTree::build(
            packtrace::protocol::generate::sphere(500),
            &KdBuildParams::default(),
        )
        .unwrap(),
    );
    let g = s.add_shared_geometry("ball", tree.clone());
    let id = s
        .edit()
        .add_instance(g, Affine3A::from_translation(Vec3::X * 10.0))
        .unwrap();
    let r = Ray::new(Vec3::new(10.0, 0.0, 5.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
    assert!(s.intersect(&r).is_some());
    s.edit()
        .set_transform(id, Affine3A::from_translation(Vec3::Y * 10.0))
        .unwrap();
    assert!(s.intersect(&r).is_none());
    // The scene still shares the one tree, never rebuilt or copied.
    assert!(std::ptr::eq(s.geometry(g).unwrap().tree(), &*tree));
    assert_eq!(std::sync::Arc::strong_count(&tree), 2);
}

#[test]
fn bad_edits_are_clear_errors() {
    let (mut s, g) = one_geometry();
    let mut e = s.edit();
    assert_eq!(
        e.add_instance(GeometryId(7), Affine3A::IDENTITY),
        Err(SceneError::UnknownGeometry(GeometryId(7)))
    );
    let flat = Affine3A::from_scale(Vec3::new(1.0, 1.0, 0.0));
    assert!(matches!(
        e.add_instance(g, flat),
        Err(SceneError::Transform(TransformError::Singular { .. }))
    ));
    let inf = Affine3A::from_translation(Vec3::new(0.0, f32::INFINITY, 0.0));
    assert_eq!(
        e.add_instance(g, inf),
        Err(SceneError::Transform(TransformError::NonFinite))
    );
    assert_eq!(
        e.set_transform(InstanceId(0), Affine3A::IDENTITY),
        Err(SceneError::UnknownInstance(InstanceId(0)))
    );
    let id = e.add_instance(g, Affine3A::IDENTITY).unwrap();
    assert!(e.set_transform(id, flat).is_err());
    e.remove_instance(id).unwrap();
    assert_eq!(e.remove_instance(id), Err(SceneError::UnknownInstance(id)));
    assert_eq!(e.set_mask(id, 1), Err(SceneError::UnknownInstance(id)));
    e.commit();
    assert_eq!(s.instance_count(), 0);
    // Its own part in Display, the cause through source(), never both.
    let e = SceneError::Transform(TransformError::NonFinite);
    assert_eq!(e.to_string(), "bad instance transform");
    let cause = std::error::Error::source(&e).unwrap().to_string();
    assert!(cause.contains("NaN or infinite"), "{cause}");
}

/// A nearly singular instance seen from far away: the pad keeps the top
/// level from culling it (every path still equals the oracle).
#[test]
fn nearly_singular_instances_far_from_the_ray_origin_are_not_culled() {
    let mut s = Scene::new();
    let g = s.add_geometry(
        "ball",
        KdTree::build(
            packtrace::protocol::generate::sphere(200),
            &KdBuildParams::default(),
        )
        .unwrap(),
    );
    let m = Affine3A::from_scale_rotation_translation(
        Vec3::new(1.0, 2e-5, 1.0),
        Quat::from_rotation_x(0.7),
        Vec3::new(1e4, -3e3, 2e3),
    );
    s.edit().add_instance(g, m).unwrap();
    let centre = m.transform_point3(Vec3::ZERO);
    let brute = BruteScene::new(&s);
    let mut hits = 0;
    for i in 0..400 {
        let a = i as f32 * 0.61;
        let o = centre + Vec3::new(a.cos(), a.sin(), 0.3) * 1e5;
        let target = m.transform_point3(Vec3::new((a * 3.1).sin(), 0.0, (a * 1.7).cos()) * 0.9);
        let r = Ray::new(o, target - o, 0.0, f32::INFINITY).unwrap();
        let want = brute.intersect_with(&r, &Query::new());
        assert!(same(s.intersect(&r), want), "ray {i}");
        hits += want.is_some() as u32;
    }
    assert!(hits > 100, "only {hits} rays hit the instance");
}

/// An instance of an empty mesh is never hit and leaves the others'
/// culling alone (its box is empty, not infinite).
#[test]
fn instances_of_empty_meshes_are_never_hit() {
    let (mut s, g) = one_geometry();
    let empty = s.add_geometry(
        "empty",
        KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap(),
    );
    {
        let mut e = s.edit();
        e.add_instance(empty, Affine3A::from_scale(Vec3::splat(3.0)))
            .unwrap();
        for i in 0..20 {
            e.add_instance(g, Affine3A::from_translation(Vec3::X * (2 * i) as f32))
                .unwrap();
        }
    }
    assert!(s.bounds().max.is_finite() && s.bounds().min.is_finite());
    let brute = BruteScene::new(&s);
    for i in 0..40 {
        let r = Ray::new(
            Vec3::new(i as f32 * 0.55, 0.2, 1.0),
            Vec3::new(0.01, 0.0, -1.0),
            0.0,
            f32::INFINITY,
        )
        .unwrap();
        let q = Query::new();
        assert!(
            same(s.intersect(&r), brute.intersect_with(&r, &q)),
            "ray {i}"
        );
        assert_ne!(s.intersect(&r).map(|h| h.geometry), Some(empty));
    }
}

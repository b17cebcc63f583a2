//! Group tracing equals the scalar traversal on every ray, bit for bit,
//! for every build preset: primary-like tiles (8 x 8 and 16 x 16, as
//! 8-wide packets) from cameras inside and outside the scene, on split
//! planes and at triangle corners, with spreads from zero (every lane
//! parallel, axis-parallel tiles among them) to wider than the frustum
//! allows (the packet fallback), intervals ending exactly at hits,
//! inactive lanes; shadow groups toward lights inside and outside the
//! scene; and tiles whose only hit lies in a far corner of the scene (the
//! entry point must not skip it).

mod common;

use common::*;
use glam::Vec3;
use packtrace::group::{Apex, RayGroup};
use packtrace::protocol::workload::shadow_ray;
use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8, TraversalStats};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// A tile of `w x h` rays around `base`, `spread` apart, as 4 x 2 packets
/// (row-major blocks); lane `i` of packet `j` is inactive when bit
/// `(8 j + i) % 64` of `holes` is set.
fn tile(
    base: &Ray,
    w: usize,
    h: usize,
    spread: f32,
    holes: u64,
    interval: &Interval,
    mesh: &Mesh,
) -> Vec<RayPacket8> {
    let d = base.dir();
    let side = if d.x.abs() < 0.5 * d.length() {
        Vec3::X
    } else {
        Vec3::Y
    };
    let u = d.cross(side).normalize_or_zero() * d.length();
    let v = d.cross(u).normalize_or_zero() * d.length();
    let mut packets = Vec::new();
    for by in 0..h / 2 {
        for bx in 0..w / 4 {
            let j = packets.len();
            packets.push(RayPacket8::from_fn(|i| {
                if holes >> ((8 * j + i) % 64) & 1 == 1 {
                    return None;
                }
                let (x, y) = ((4 * bx + i % 4) as f32, (2 * by + i / 4) as f32);
                let dir =
                    d + u * (spread * (x - 0.5 * w as f32)) + v * (spread * (y - 0.5 * h as f32));
                let dir = if dir == Vec3::ZERO || !dir.is_finite() {
                    d
                } else {
                    dir
                };
                Some(with_interval(base.origin(), dir, interval, mesh))
            }));
        }
    }
    packets
}

/// Every lane of the group's results equals the scalar query of its ray,
/// with leaf culling and the entry hand-off each off and on.
fn check(
    tree: &KdTree,
    packets: &[RayPacket8],
    apex: Vec3,
    kind: Apex,
    label: &str,
) -> Result<(), TestCaseError> {
    for (cull, handoff) in [(false, true), (true, true), (false, false), (true, false)] {
        let label = format!("{label} (leaf culling {cull}, entry hand-off {handoff})");
        check_one(tree, packets, apex, kind, cull, handoff, &label)?;
    }
    Ok(())
}

fn check_one(
    tree: &KdTree,
    packets: &[RayPacket8],
    apex: Vec3,
    kind: Apex,
    cull: bool,
    handoff: bool,
    label: &str,
) -> Result<(), TestCaseError> {
    let g = RayGroup::new(packets, apex, kind)
        .map_err(|e| TestCaseError::fail(e.to_string()))?
        .with_leaf_culling(cull)
        .with_entry_handoff(handoff);
    let hits = tree.intersect_group(&g);
    let occ = tree.occluded_group(&g);
    let mut stats = TraversalStats::default();
    let mut counted = vec![Default::default(); packets.len()];
    tree.intersect_group_counted(&g, &mut counted, &mut stats);
    prop_assert_eq!(&counted, &hits, "{}: counted differs", label);
    for (j, p) in packets.iter().enumerate() {
        for i in 0..8 {
            let Some(r) = p.ray(i) else {
                prop_assert_eq!(hits[j].hit(i), None);
                prop_assert_eq!(occ[j] >> i & 1, 0);
                continue;
            };
            let want = tree.intersect(&r);
            prop_assert_eq!(
                hit_bits(hits[j].hit(i)),
                hit_bits(want),
                "{}: packet {} lane {} ray {} (coherent {})",
                label,
                j,
                i,
                ray_literal(&r),
                g.is_coherent()
            );
            prop_assert_eq!(
                occ[j] >> i & 1 == 1,
                tree.occluded(&r),
                "{}: occlusion, packet {} lane {}",
                label,
                j,
                i
            );
        }
    }
    Ok(())
}

fn trees(mesh: &Mesh) -> Vec<(String, KdTree)> {
    KdBuildParams::presets()
        .into_iter()
        .map(|(name, p)| {
            (
                name.to_string(),
                KdTree::build(mesh.clone(), &p).expect("builds"),
            )
        })
        .collect()
}

/// The trees' split planes, for origins on them (`Origin::OnSplitPlane`).
fn planes(trees: &[(String, KdTree)]) -> Vec<(usize, f32)> {
    trees.iter().flat_map(|(_, t)| t.split_planes()).collect()
}

fn spread() -> impl Strategy<Value = f32> {
    prop_oneof![
        2 => Just(0.0f32),
        4 => prop::sample::select(&[1e-4f32, 1e-3, 4e-3, 0.02][..]),
        1 => Just(0.3f32),
    ]
}

fn size() -> impl Strategy<Value = (usize, usize)> {
    prop_oneof![4 => Just((8, 8)), 1 => Just((16, 16)), 1 => Just((4, 2))]
}

fn holes() -> impl Strategy<Value = u64> {
    prop_oneof![3 => Just(0u64), 1 => any::<u64>()]
}

proptest! {
    #![proptest_config(config(48))]

    /// Primary-like tiles: one origin, small direction offsets.
    #[test]
    fn origin_groups_equal_scalar(
        spec in any_mesh(),
        base in ray_spec_with(plain_interval()),
        interval in interval(),
        spread in spread(),
        (w, h) in size(),
        holes in holes(),
    ) {
        let mesh = spec.mesh();
        let trees = trees(&mesh);
        let base = make_ray_on(&base, &mesh, &planes(&trees));
        let packets = tile(&base, w, h, spread, holes, &interval, &mesh);
        for (name, tree) in trees {
            check(&tree, &packets, base.origin(), Apex::Origin, &name)?;
        }
    }

    /// Shadow groups: from the tile's primary hits (or points along
    /// missing rays) toward one light, inside or outside the scene.
    #[test]
    fn target_groups_equal_scalar(
        spec in any_mesh(),
        base in ray_spec_with(plain_interval()),
        light in origin(),
        spread in spread(),
        (w, h) in size(),
        holes in holes(),
    ) {
        let mesh = spec.mesh();
        let trees = trees(&mesh);
        let base = make_ray_on(&base, &mesh, &planes(&trees));
        let light = origin_point_on(&light, &mesh, &planes(&trees));
        let primary = tile(&base, w, h, spread, holes, &Interval::Full, &mesh);
        let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).expect("builds");
        let shadow: Vec<RayPacket8> = primary
            .iter()
            .map(|p| {
                RayPacket8::from_fn(|i| {
                    let r = p.ray(i)?;
                    let t = tree.intersect(&r).map_or(3.0, |h| h.t);
                    let q = r.origin() + r.dir() * t;
                    let s = shadow_ray(q, light);
                    Ray::new(s.origin(), s.dir(), s.t_min(), s.t_max()).ok()
                })
            })
            .collect();
        for (name, tree) in trees {
            check(&tree, &shadow, light, Apex::Target, &name)?;
        }
    }
}

/// A wall of triangles in front and one small triangle far off in a
/// corner of the scene box: a tile aimed past the wall's edge at that
/// triangle hits only it. The entry point must not skip it.
#[test]
fn a_tile_whose_only_hit_is_in_a_far_corner_finds_it() {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    // A 16 x 16 wall at z = 0 over [0, 16]^2.
    for y in 0..16u32 {
        for x in 0..16u32 {
            let b = positions.len() as u32;
            let (fx, fy) = (x as f32, y as f32);
            positions.extend([
                Vec3::new(fx, fy, 0.0),
                Vec3::new(fx + 1.0, fy, 0.0),
                Vec3::new(fx, fy + 1.0, 0.0),
            ]);
            triangles.push([b, b + 1, b + 2]);
        }
    }
    // The lone triangle in the far corner at (40, 40, -30).
    let b = positions.len() as u32;
    positions.extend([
        Vec3::new(39.5, 39.5, -30.0),
        Vec3::new(40.5, 39.5, -30.0),
        Vec3::new(39.5, 40.5, -30.0),
    ]);
    triangles.push([b, b + 1, b + 2]);
    let mesh = Mesh::new(positions, triangles).unwrap();
    let eye = Vec3::new(8.0, 8.0, 10.0);
    let aim = Vec3::new(39.8, 39.8, -30.0) - eye;
    for (name, tree) in trees(&mesh) {
        let base = Ray::new(eye, aim, 0.0, f32::INFINITY).unwrap();
        let packets = tile(&base, 16, 16, 1e-4, 0, &Interval::Full, &mesh);
        let g = RayGroup::new(&packets, eye, Apex::Origin).unwrap();
        assert!(g.is_coherent());
        let hits = tree.intersect_group(&g);
        let found = hits.iter().map(|h| h.mask().count_ones()).sum::<u32>();
        assert!(found > 0, "{name}: the far triangle is hit");
        assert!(
            hits.iter()
                .all(|h| (0..8).all(|i| h.hit(i).is_none_or(|h| h.prim == 256))),
            "{name}"
        );
        check(&tree, &packets, eye, Apex::Origin, &name).unwrap();
        // And from the other side, with the wall between: the corner
        // triangle is hidden from no ray of a tile aimed beside the wall.
        let eye2 = Vec3::new(60.0, 60.0, -50.0);
        let base = Ray::new(
            eye2,
            Vec3::new(40.0, 40.0, -30.0) - eye2,
            0.0,
            f32::INFINITY,
        )
        .unwrap();
        let packets = tile(&base, 8, 8, 2e-3, 0, &Interval::Full, &mesh);
        check(&tree, &packets, eye2, Apex::Origin, &name).unwrap();
    }
}

/// Statistics: a coherent group is counted as one group with its entry
/// depth (and its cell tests when steered to the leaves); a diverging one
/// as packets.
#[test]
fn counted_groups_report_entry_depth_and_cell_tests() {
    let mesh = packtrace::protocol::generate::sphere(2000);
    let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
    let eye = Vec3::new(0.0, 0.0, 5.0);
    let base = Ray::new(eye, Vec3::new(0.0, 0.0, -1.0), 0.0, f32::INFINITY).unwrap();
    let packets = tile(&base, 8, 8, 1e-3, 0, &Interval::Full, &mesh);
    let g = RayGroup::new(&packets, eye, Apex::Origin).unwrap();
    let mut s = TraversalStats::default();
    let mut out = vec![Default::default(); 8];
    tree.intersect_group_counted(&g, &mut out, &mut s);
    assert_eq!((s.groups, s.packets, s.rays), (1, 8, 64));
    // Handed off at the entry point: the packets' own node steps, no
    // clipping to cells.
    assert!(
        s.entry_depth > 0 && s.nodes > s.entry_depth && s.cell_tests == 0,
        "{s:?}"
    );
    // Steered to the leaves: each packet clips itself there.
    let mut s = TraversalStats::default();
    tree.intersect_group_counted(&g.clone().with_entry_handoff(false), &mut out, &mut s);
    assert_eq!((s.groups, s.packets, s.rays), (1, 8, 64));
    assert!(s.entry_depth > 0 && s.cell_tests > 0, "{s:?}");
    let wide = tile(&base, 8, 8, 0.5, 0, &Interval::Full, &mesh);
    let g = RayGroup::new(&wide, eye, Apex::Origin).unwrap();
    assert!(!g.is_coherent());
    let mut s = TraversalStats::default();
    tree.intersect_group_counted(&g, &mut out, &mut s);
    assert_eq!((s.groups, s.packets), (0, 8));
}

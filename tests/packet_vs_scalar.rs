//! The packet traversal equals the scalar traversal lane by lane, bit for
//! bit, for every build preset: coherent and incoherent packets, mixed
//! direction signs (the octant split), inactive lanes, exact-zero
//! direction components, origins on split planes and inside the scene.
//! Every lane is compared through the harness (`tests/common/harness.rs`),
//! against brute force (so packet == scalar == brute force); beside it,
//! what only packets have: the lane round trip, inactive lanes' fields,
//! `from_soa`, the naive layout's whole result, and the counted entry
//! points' octant-split and single-ray accounting, for 4- and 8-wide
//! packets through one generic body. Also the stream API with every tail length.

mod common;

use common::*;
use glam::Vec3;
use packtrace::simd::{F4, F8, Lane};
use packtrace::{KdTree, NaiveKdTree, Ray, RayPacket, RayPacket4, TraversalStats};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// How the four lanes are made.
#[derive(Clone, Debug)]
enum PacketSpec {
    /// Camera-like: one origin, a base aim and four small offsets.
    Coherent {
        origin: Origin,
        aim: Aim,
        offsets: [Vec3; 4],
        interval: Interval,
        zero: u8,
        neg_zero: u8,
    },
    /// Four independent rays (mixed signs are common).
    Independent([RaySpec; 4]),
    /// One ray repeated with the sign of its zero components varied per
    /// lane: identical geometry, different sign bits.
    SignedZeros { ray: RaySpec, neg_zero: [u8; 4] },
}

fn offset() -> impl Strategy<Value = Vec3> {
    let c = prop_oneof![
        Just(0.0f32),
        Just(-0.0f32),
        prop::sample::select(&[1.0e-3f32, -1.0e-3, 0.01, -0.01, 0.05][..]),
        -0.02f32..0.02,
    ];
    [c.clone(), c.clone(), c].prop_map(Vec3::from)
}

fn packet_spec() -> impl Strategy<Value = PacketSpec> {
    prop_oneof![
        3 => (origin(), aim(), prop::array::uniform4(offset()), interval(), zero_mask(), 0u8..8).prop_map(
            |(origin, aim, offsets, interval, zero, neg_zero)| PacketSpec::Coherent {
                origin, aim, offsets, interval, zero, neg_zero,
            }
        ),
        3 => prop::array::uniform4(ray_spec()).prop_map(PacketSpec::Independent),
        1 => (ray_spec(), prop::array::uniform4(0u8..8)).prop_map(|(ray, neg_zero)| PacketSpec::SignedZeros { ray, neg_zero }),
    ]
}

/// Active-lane masks: all active most often; every pattern, including one
/// to three inactive lanes and none active, is drawn.
fn active_mask() -> impl Strategy<Value = u32> {
    prop_oneof![2 => Just(0b1111u32), 3 => 0u32..16]
}

fn make_rays(spec: &PacketSpec, mesh: &packtrace::Mesh, planes: &[(usize, f32)]) -> [Ray; 4] {
    match spec {
        PacketSpec::Coherent {
            origin,
            aim,
            offsets,
            interval,
            zero,
            neg_zero,
        } => {
            let base = make_ray_on(
                &RaySpec {
                    origin: origin.clone(),
                    aim: aim.clone(),
                    interval: Interval::Full,
                    zero: *zero,
                    neg_zero: *neg_zero,
                },
                mesh,
                planes,
            );
            offsets.map(|o| {
                let mut d = apply_zero_masks(base.dir() + o, *zero, *neg_zero);
                if d == Vec3::ZERO {
                    d = base.dir();
                }
                with_interval(base.origin(), d, interval, mesh)
            })
        }
        PacketSpec::Independent(specs) => specs.each_ref().map(|s| make_ray_on(s, mesh, planes)),
        PacketSpec::SignedZeros { ray, neg_zero } => {
            let r = make_ray_on(ray, mesh, planes);
            neg_zero.map(|n| {
                let d = apply_zero_masks(r.dir(), 0, n);
                Ray::new(r.origin(), d, r.t_min(), r.t_max()).unwrap()
            })
        }
    }
}

/// The octant (three sign bits) of a ray's direction, `-0.0` negative.
fn octant(r: &Ray) -> u32 {
    (0..3).fold(0, |o, a| o | (r.dir()[a].is_sign_negative() as u32) << a)
}

/// The spread of the active lanes' directions, as `RayPacket::dir_spread`
/// documents it: the largest per-axis range over the largest magnitude.
fn spread(rays: &[Ray], active: u32) -> f32 {
    let dirs: Vec<_> = (0..rays.len())
        .filter(|&i| active >> i & 1 == 1)
        .map(|i| rays[i].dir())
        .collect();
    let scale = dirs
        .iter()
        .fold(0.0f32, |m, d| m.max(d.abs().max_element()));
    let range = (0..3).fold(0.0f32, |m, a| {
        let lo = dirs.iter().fold(f32::INFINITY, |x, d| x.min(d[a]));
        let hi = dirs.iter().fold(f32::NEG_INFINITY, |x, d| x.max(d[a]));
        m.max(hi - lo)
    });
    if scale > 0.0 { range / scale } else { 0.0 }
}

/// What the counted entry points must report for these lanes: with the
/// active lanes in several octants and spread wider than `MAX_DIR_SPREAD`,
/// no split and every lane a single ray; in several octants otherwise,
/// one octant split; and one single ray per active lane whose octant holds
/// at most `single_ray_lanes(width)` active lanes.
fn expected_counts(rays: &[Ray], active: u32) -> (u64, u64) {
    let th = packtrace::kdtree::single_ray_lanes(rays.len()) as usize;
    let lanes: Vec<u32> = (0..rays.len())
        .filter(|&i| active >> i & 1 == 1)
        .map(|i| octant(&rays[i]))
        .collect();
    let split = lanes.iter().any(|&o| o != lanes[0]);
    if split && spread(rays, active) > packtrace::kdtree::MAX_DIR_SPREAD {
        return (0, lanes.len() as u64);
    }
    let single = lanes
        .iter()
        .filter(|&&o| lanes.iter().filter(|&&q| q == o).count() <= th)
        .count();
    (u64::from(split), single as u64)
}

/// What only packets have, for one preset's tree and any width: the
/// packet's lanes and mask, inactive lanes' fields, the naive layout's
/// whole result, and the counted twins' octant-split and single-ray
/// accounting. (Every lane's answer is compared with brute force by the
/// harness in `check`.)
fn check_packet<L: Lane>(
    tree: &KdTree,
    naive: &NaiveKdTree,
    name: &str,
    rays: &[Ray],
    active: u32,
) -> Result<(), TestCaseError> {
    let lane = |i: usize| (active >> i & 1 == 1).then_some(rays[i]);
    let p = RayPacket::<L>::from_fn(lane);
    prop_assert_eq!(p.active(), active);
    let hits = tree.intersect_packet(&p);
    let occ = tree.occluded_packet(&p);
    for i in 0..L::WIDTH {
        prop_assert_eq!(p.ray(i), lane(i), "lane {} round trip", i);
        if lane(i).is_none() {
            prop_assert_eq!(hits.hit(i), None, "{}: inactive lane {} hit", name, i);
            prop_assert_eq!(occ >> i & 1, 0, "{}: inactive lane {} occluded", name, i);
        }
    }
    prop_assert_eq!(hits.mask() & !active, 0);

    // The fat-node layout runs the same packet traversal: same answers,
    // inactive lanes' fields included.
    prop_assert_eq!(naive.intersect_packet(&p), hits, "{}: naive layout", name);
    prop_assert_eq!(naive.occluded_packet(&p), occ, "{}: naive occluded", name);

    // Counted twins: same answers, exact octant and single-ray accounting.
    let (split, single) = expected_counts(rays, active);
    let mut st = TraversalStats::default();
    let counted = tree.intersect_packet_counted(&p, &mut st);
    prop_assert_eq!(counted, hits, "{}: intersect_packet_counted", name);
    prop_assert_eq!(st.packets, 1);
    prop_assert_eq!(st.rays, u64::from(active.count_ones()));
    prop_assert_eq!(
        (st.octant_splits, st.single_rays),
        (split, single),
        "{}: counts for {:#b}, dirs {:?}",
        name,
        active,
        rays.iter().map(|r| r.dir()).collect::<Vec<_>>()
    );
    let mut st = TraversalStats::default();
    prop_assert_eq!(
        tree.occluded_packet_counted(&p, &mut st),
        occ,
        "{}: occluded_packet_counted",
        name
    );
    prop_assert_eq!(st.octant_splits, split, "{}: occluded split", name);
    prop_assert_eq!((st.packets, st.rays), (1, u64::from(active.count_ones())));
    Ok(())
}

/// The SoA constructor builds the same 4-wide packet as the lanes.
fn check_soa(tree: &KdTree, name: &str, rays: &[Ray; 4], active: u32) -> Result<(), TestCaseError> {
    let p = RayPacket4::from_fn(|i| (active >> i & 1 == 1).then_some(rays[i]));
    let soa = RayPacket4::from_soa(
        [0, 1, 2].map(|a| std::array::from_fn(|i| rays[i].origin()[a])),
        [0, 1, 2].map(|a| std::array::from_fn(|i| rays[i].dir()[a])),
        std::array::from_fn(|i| rays[i].t_min()),
        std::array::from_fn(|i| rays[i].t_max()),
        active,
    )
    .expect("valid rays");
    prop_assert_eq!(
        tree.intersect4(&soa),
        tree.intersect4(&p),
        "{}: from_soa",
        name
    );
    Ok(())
}

/// The packets' rays (the inactive lanes' rays too) through the harness,
/// with each packet listed as generated (its inactive lanes `None`), lane
/// placements taken in turn by the rays; then each packet's own checks.
fn check(spec: &MeshSpec, packets: &[(PacketSpec, u32)]) -> Result<(), TestCaseError> {
    let mesh = spec.mesh();
    let mut engines = Engines::try_new(&mesh).map_err(TestCaseError::fail)?;
    engines.options.placements = Placements::Cycle;
    let planes = split_planes(&engines.trees);
    let made: Vec<([Ray; 4], u32)> = packets
        .iter()
        .map(|(ps, active)| (make_rays(ps, &mesh, &planes), *active))
        .collect();
    let rays: Vec<Ray> = made.iter().flat_map(|(four, _)| *four).collect();
    // Each generated packet as a 4-wide one, and each two consecutive
    // ones side by side as an 8-wide one (mixed octants, 0 to 8 active).
    let mut listed: Vec<Vec<Option<usize>>> = made
        .iter()
        .enumerate()
        .map(|(q, (_, active))| {
            (0..4)
                .map(|i| (active >> i & 1 == 1).then_some(4 * q + i))
                .collect()
        })
        .collect();
    let wide: Vec<Vec<Option<usize>>> = listed.chunks_exact(2).map(|c| c.concat()).collect();
    listed.extend(wide);
    engines
        .agree_packets(&rays, &listed)
        .check("packet == scalar == brute")?;
    for (four, active) in &made {
        for t in &engines.trees {
            check_packet::<F4>(&t.kd, &t.naive, &t.name, four, *active)?;
            check_soa(&t.kd, &t.name, four, *active)?;
        }
    }
    for pair in made.chunks_exact(2) {
        let eight: Vec<Ray> = pair.iter().flat_map(|(four, _)| *four).collect();
        let active = pair[0].1 | pair[1].1 << 4;
        for t in &engines.trees {
            check_packet::<F8>(&t.kd, &t.naive, &t.name, &eight, active)?;
        }
    }
    Ok(())
}

fn packets() -> impl Strategy<Value = Vec<(PacketSpec, u32)>> {
    prop::collection::vec((packet_spec(), active_mask()), 1..16)
}

proptest! {
    // Split clipping makes builds over flat meshes the slowest part of the
    // suite: fewer cases here.
    #![proptest_config(config(150))]

    #[test]
    fn coplanar_packet_equals_scalar(spec in coplanar(), ps in packets()) {
        check(&spec, &ps)?;
    }
}

proptest! {
    #![proptest_config(config(300))]

    #[test]
    fn soup_packet_equals_scalar(spec in soup(), ps in packets()) {
        check(&spec, &ps)?;
    }

    #[test]
    fn heightfield_packet_equals_scalar(spec in heightfield(), ps in packets()) {
        check(&spec, &ps)?;
    }

    #[test]
    fn degenerate_packet_equals_scalar(spec in with_degenerates(), ps in packets()) {
        check(&spec, &ps)?;
    }

    #[test]
    fn duplicate_packet_equals_scalar(spec in with_duplicates(), ps in packets()) {
        check(&spec, &ps)?;
    }

    /// `intersect_rays` / `occluded_rays` over streams of 0..13 rays (every
    /// tail length, from every offset) equal brute force ray by ray, and so
    /// the scalar queries.
    #[test]
    fn stream_equals_scalar(spec in any_mesh(), specs in prop::collection::vec(ray_spec(), 0..13)) {
        let mesh = spec.mesh();
        let mut engines = Engines::try_new(&mesh).map_err(TestCaseError::fail)?;
        engines.options.placements = Placements::Cycle;
        let planes = split_planes(&engines.trees);
        let rays: Vec<Ray> = specs.iter().map(|s| make_ray_on(s, &mesh, &planes)).collect();
        engines.agree(&rays).check("stream")?;
    }
}

#[test]
fn stream_slots_untouched_past_a_miss_stay_none() {
    // A stale value in the output slot must be overwritten by a miss.
    let mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    let tree = KdTree::build(mesh, &packtrace::KdBuildParams::default()).unwrap();
    let hit = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    let miss = Ray::new(Vec3::new(5.0, 5.0, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    for n in 0..13 {
        let rays: Vec<Ray> = (0..n)
            .map(|i| if i % 3 == 1 { miss } else { hit })
            .collect();
        let stale = tree.intersect(&hit);
        let mut hits = vec![stale; n];
        tree.intersect_rays(&rays, &mut hits);
        let mut occ = vec![true; n];
        tree.occluded_rays(&rays, &mut occ);
        for i in 0..n {
            assert_eq!(hits[i], tree.intersect(&rays[i]), "n = {n}, ray {i}");
            assert_eq!(occ[i], tree.occluded(&rays[i]), "n = {n}, ray {i}");
        }
    }
}

#[test]
fn octant_splits_are_counted_exactly_when_signs_disagree() {
    let mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    let tree = KdTree::build(mesh, &packtrace::KdBuildParams::default()).unwrap();
    let o = Vec3::new(0.2, 0.2, 1.0);
    let r = |d: Vec3| Ray::new(o, d, 0.0, 9.0).unwrap();
    let down = r(Vec3::new(0.0, 0.0, -1.0));
    let down_neg_zero = r(Vec3::new(-0.0, 0.0, -1.0));
    let up = r(Vec3::Z);
    let (left, right) = (
        r(Vec3::new(-0.001, 0.0, -1.0)),
        r(Vec3::new(0.001, 0.0, -1.0)),
    );
    // (lanes, octant splits, lanes traced as single rays)
    let cases: [([Option<Ray>; 4], u64, u64); 9] = [
        ([Some(down); 4], 0, 0),
        // -0.0 is its own octant: one lane alone there.
        (
            [Some(down), Some(down_neg_zero), Some(down), Some(down)],
            1,
            1,
        ),
        // Two coherent octants (x crosses zero): split, two sub-packets.
        ([Some(left), Some(right), Some(right), Some(left)], 1, 0),
        ([Some(left), Some(right), Some(right), Some(right)], 1, 1),
        // Divergent (up and down): every lane alone, no split.
        ([Some(down), None, Some(up), None], 0, 2),
        ([Some(down), Some(up), Some(up), Some(down)], 0, 4),
        // One active lane: single ray, no split.
        ([Some(down), None, None, None], 0, 1),
        ([None, Some(down_neg_zero), None, Some(down_neg_zero)], 0, 0),
        ([None; 4], 0, 0),
    ];
    for (lanes, splits, singles) in cases {
        let p = RayPacket4::from_lanes(lanes);
        let mut st = TraversalStats::default();
        let h = tree.intersect4_counted(&p, &mut st);
        assert_eq!(
            (st.octant_splits, st.single_rays),
            (splits, singles),
            "{lanes:?}"
        );
        assert_eq!(h, tree.intersect4(&p));
        for (i, lane) in lanes.iter().enumerate() {
            assert_eq!(h.hit(i), lane.and_then(|r| tree.intersect(&r)), "lane {i}");
        }
    }
}

/// The simplest packet: four copies of one ray hitting one triangle (the
/// non-fallback path, all lanes agree on every sign): every lane of every
/// preset hits like brute force (the harness's "copies" packet).
#[test]
fn four_identical_rays_hit_like_scalar() {
    let mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    let report = agree(&mesh, &[r]);
    report.assert_ok("four identical rays");
    assert!(report.hit(0).is_some());
}

/// Lanes switched off with `with_active` (valid rays still stored in
/// them): only the active lanes may report hits, in closest-hit and
/// occlusion queries, on both layouts.
#[test]
fn lanes_switched_off_never_hit() {
    let mesh = packtrace::Mesh::new(
        vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(3.0, -1.0, 0.0),
            Vec3::new(-1.0, 3.0, 0.0),
        ],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let r = |x: f32| Ray::new(Vec3::new(x, 0.1, 1.0), Vec3::NEG_Z, 0.0, 10.0).unwrap();
    let rays = [r(0.1), r(0.2), r(0.3), r(0.4)];
    for active in 0..16u32 {
        let p = RayPacket4::from_rays(&rays).with_active(active);
        for (name, params) in packtrace::KdBuildParams::presets() {
            let kd = KdTree::build(mesh.clone(), &params).unwrap();
            let naive = NaiveKdTree::from_kd(&kd);
            assert_eq!(kd.intersect4(&p).mask(), active, "{name} kd8 intersect4");
            assert_eq!(
                naive.intersect4(&p).mask(),
                active,
                "{name} naive intersect4"
            );
            assert_eq!(kd.occluded4(&p), active, "{name} kd8 occluded4");
            assert_eq!(naive.occluded4(&p), active, "{name} naive occluded4");
            for (i, ray) in rays.iter().enumerate() {
                let want = (active >> i & 1 == 1).then(|| kd.intersect(ray)).flatten();
                assert_eq!(kd.intersect4(&p).hit(i), want, "{name} lane {i}");
            }
        }
    }
}

//! The packet traversal equals the scalar traversal lane by lane, bit for
//! bit, for every build preset: coherent and incoherent packets, mixed
//! direction signs (the per-lane fallback), inactive lanes, exact-zero
//! direction components, origins on split planes and inside the scene.
//! Every lane is compared through the harness (`tests/common/harness.rs`),
//! against brute force (so packet == scalar == brute force); beside it,
//! what only packets have: the lane round trip, inactive lanes' fields,
//! `from_soa`, the naive layout's whole result, and the counted entry
//! points' fallback accounting. Also the stream API with every tail length.

mod common;

use common::*;
use glam::Vec3;
use packtrace::{KdTree, NaiveKdTree, Ray, RayPacket4, TraversalStats};
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

fn make_rays(spec: &PacketSpec, mesh: &packtrace::Mesh) -> [Ray; 4] {
    match spec {
        PacketSpec::Coherent {
            origin,
            aim,
            offsets,
            interval,
            zero,
            neg_zero,
        } => {
            let base = make_ray(
                &RaySpec {
                    origin: origin.clone(),
                    aim: aim.clone(),
                    interval: Interval::Full,
                    zero: *zero,
                    neg_zero: *neg_zero,
                },
                mesh,
            );
            offsets.map(|o| {
                let mut d = apply_zero_masks(base.dir() + o, *zero, *neg_zero);
                if d == Vec3::ZERO {
                    d = base.dir();
                }
                with_interval(base.origin(), d, interval, mesh)
            })
        }
        PacketSpec::Independent(specs) => specs.each_ref().map(|s| make_ray(s, mesh)),
        PacketSpec::SignedZeros { ray, neg_zero } => {
            let r = make_ray(ray, mesh);
            neg_zero.map(|n| {
                let d = apply_zero_masks(r.dir(), 0, n);
                Ray::new(r.origin(), d, r.t_min(), r.t_max()).unwrap()
            })
        }
    }
}

/// Do the active lanes disagree on the sign bit of some direction axis?
fn signs_disagree(rays: &[Ray; 4], active: u32) -> bool {
    (0..3).any(|a| {
        let mut neg = (0..4)
            .filter(|i| active >> i & 1 == 1)
            .map(|i| rays[i].dir()[a].is_sign_negative());
        match neg.next() {
            Some(first) => neg.any(|n| n != first),
            None => false,
        }
    })
}

/// What only packets have, for one preset's tree: the packet's lanes and
/// mask, inactive lanes' fields, `from_soa`, the naive layout's whole
/// result, and the counted twins. (Every lane's answer is compared with
/// brute force by the harness in `check`.)
fn check_packet(
    tree: &KdTree,
    naive: &NaiveKdTree,
    name: &str,
    rays: &[Ray; 4],
    active: u32,
) -> Result<(), TestCaseError> {
    let lanes: [Option<Ray>; 4] =
        std::array::from_fn(|i| (active >> i & 1 == 1).then_some(rays[i]));
    let p = RayPacket4::from_lanes(lanes);
    prop_assert_eq!(p.active, active);
    let hits = tree.intersect4(&p);
    let occ = tree.occluded4(&p);
    for (i, lane) in lanes.iter().enumerate() {
        prop_assert_eq!(p.ray(i), *lane, "lane {} round trip", i);
        if lane.is_none() {
            prop_assert_eq!(hits.hit(i), None, "{}: inactive lane {} hit", name, i);
            prop_assert_eq!(hits.prim[i], u32::MAX);
            prop_assert_eq!(occ >> i & 1, 0, "{}: inactive lane {} occluded", name, i);
        }
    }
    prop_assert_eq!(hits.mask() & !active, 0);

    // The SoA constructor builds the same packet.
    let soa = RayPacket4::from_soa(
        [0, 1, 2].map(|a| std::array::from_fn(|i| rays[i].origin()[a])),
        [0, 1, 2].map(|a| std::array::from_fn(|i| rays[i].dir()[a])),
        std::array::from_fn(|i| rays[i].t_min()),
        std::array::from_fn(|i| rays[i].t_max()),
        active,
    )
    .expect("valid rays");
    prop_assert_eq!(tree.intersect4(&soa), hits, "{}: from_soa", name);

    // The fat-node layout runs the same packet traversal: same answers,
    // inactive lanes' fields included.
    prop_assert_eq!(naive.intersect4(&p), hits, "{}: naive layout", name);
    prop_assert_eq!(naive.occluded4(&p), occ, "{}: naive layout occluded", name);

    // Counted twins: same answers, exact fallback accounting.
    let mut st = TraversalStats::default();
    let counted = tree.intersect4_counted(&p, &mut st);
    prop_assert_eq!(counted, hits, "{}: intersect4_counted", name);
    let fallback = u64::from(signs_disagree(rays, active));
    prop_assert_eq!(st.packets, 1);
    prop_assert_eq!(st.rays, u64::from(active.count_ones()));
    prop_assert_eq!(
        st.fallback_packets,
        fallback,
        "{}: fallback for {:#06b}, dirs {:?}",
        name,
        active,
        rays.map(|r| r.dir())
    );
    let mut st = TraversalStats::default();
    prop_assert_eq!(
        tree.occluded4_counted(&p, &mut st),
        occ,
        "{}: occluded4_counted",
        name
    );
    prop_assert_eq!(st.fallback_packets, fallback, "{}: occluded fallback", name);
    prop_assert_eq!((st.packets, st.rays), (1, u64::from(active.count_ones())));
    Ok(())
}

/// The packets' rays (the inactive lanes' rays too) through the harness,
/// with each packet listed as generated (its inactive lanes `None`), lane
/// placements taken in turn by the rays; then each packet's own checks.
fn check(spec: &MeshSpec, packets: &[(PacketSpec, u32)]) -> Result<(), TestCaseError> {
    let mesh = spec.mesh();
    let mut engines = Engines::try_new(&mesh).map_err(TestCaseError::fail)?;
    engines.options.placements = Placements::Cycle;
    let made: Vec<([Ray; 4], u32)> = packets
        .iter()
        .map(|(ps, active)| (make_rays(ps, &mesh), *active))
        .collect();
    let rays: Vec<Ray> = made.iter().flat_map(|(four, _)| *four).collect();
    let listed: Vec<Vec<Option<usize>>> = made
        .iter()
        .enumerate()
        .map(|(q, (_, active))| {
            (0..4)
                .map(|i| (active >> i & 1 == 1).then_some(4 * q + i))
                .collect()
        })
        .collect();
    engines
        .agree_packets(&rays, &listed)
        .check("packet == scalar == brute")?;
    for (four, active) in &made {
        for t in &engines.trees {
            check_packet(&t.kd, &t.naive, &t.name, four, *active)?;
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
        let rays: Vec<Ray> = specs.iter().map(|s| make_ray(s, &mesh)).collect();
        let mut engines = Engines::try_new(&mesh).map_err(TestCaseError::fail)?;
        engines.options.placements = Placements::Cycle;
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
fn fallback_is_counted_exactly_when_signs_disagree() {
    let mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    let tree = KdTree::build(mesh, &packtrace::KdBuildParams::default()).unwrap();
    let o = Vec3::new(0.2, 0.2, 1.0);
    let r = |d: Vec3| Ray::new(o, d, 0.0, 9.0).unwrap();
    let down = r(Vec3::new(0.0, 0.0, -1.0));
    let down_neg_zero = r(Vec3::new(-0.0, 0.0, -1.0));
    let up = r(Vec3::Z);
    let cases: [([Option<Ray>; 4], u64); 6] = [
        ([Some(down); 4], 0),
        ([Some(down), Some(down_neg_zero), Some(down), Some(down)], 1),
        ([Some(down), None, Some(up), None], 1),
        // The disagreeing lane is inactive: no fallback.
        ([Some(down), None, None, None], 0),
        ([None, Some(down_neg_zero), None, Some(down_neg_zero)], 0),
        ([None; 4], 0),
    ];
    for (lanes, expect) in cases {
        let p = RayPacket4::from_lanes(lanes);
        let mut st = TraversalStats::default();
        let h = tree.intersect4_counted(&p, &mut st);
        assert_eq!(st.fallback_packets, expect, "{lanes:?}");
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

/// A packet built by hand (its fields are public) with valid rays in lanes
/// that `active` leaves out: only the active lanes may report hits, in
/// closest-hit and occlusion queries, on both layouts, whatever the
/// inactive lanes' intervals say.
#[test]
fn inactive_lanes_of_a_hand_built_packet_never_hit() {
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
        let mut p = RayPacket4::from_rays(&rays);
        p.active = active;
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

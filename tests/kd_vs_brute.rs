//! The kd traversal equals the brute-force oracle exactly (same `t`,
//! triangle, `u`, `v` bits; same occlusion) for every build preset, on
//! meshes and rays chosen to break kd-trees; every build validates. Every
//! comparison goes through the harness (`tests/common/harness.rs`), so the
//! scalar, packet, stream and naive-layout paths are all held to it. Also
//! the typed errors of the build parameters and of `Ray::new`.

mod common;

use common::*;
use glam::Vec3;
use packtrace::{
    BuildError, DepthLimit, Hit, KdBuildParams, KdTree, MAX_DEPTH_LIMIT, Mesh, Ray, RayError,
    RayQuery,
};
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::TestCaseError;

/// `make_ray`, except that a recipe aimed at a point only a subnormal
/// distance away on every axis (extreme coordinates), whose direction is
/// zero after the ray policy's flush of subnormal components, gets
/// `make_ray`'s fallback direction, as a zero direction does (`Ray::new`
/// refuses it with `ZeroDirection`).
fn make_valid_ray(s: &RaySpec, mesh: &Mesh, planes: &[(usize, f32)]) -> Ray {
    let origin = origin_point_on(&s.origin, mesh, planes);
    let corner = |tri: &Index, k: usize| {
        (!mesh.is_empty()).then(|| mesh.corners(tri.index(mesh.triangle_count()))[k % 3])
    };
    let aim = match &s.aim {
        Aim::Dir(d) => Some(*d),
        Aim::AtCorner { tri, corner: k } => corner(tri, *k).map(|c| c - origin),
        Aim::AtEdgeMidpoint { tri, edge } => corner(tri, *edge)
            .zip(corner(tri, *edge + 1))
            .map(|(a, b)| (a + b) * 0.5 - origin),
        Aim::AtCentroid { tri } => corner(tri, 0)
            .zip(corner(tri, 1))
            .zip(corner(tri, 2))
            .map(|((a, b), c)| (a + b + c) / 3.0 - origin),
    };
    let flushed_to_zero = aim.is_some_and(|d| {
        let d = apply_zero_masks(d, s.zero, s.neg_zero);
        d != Vec3::ZERO && Ray::new(Vec3::ZERO, d, 0.0, 1.0) == Err(RayError::ZeroDirection)
    });
    if flushed_to_zero {
        let fallback = RaySpec {
            aim: Aim::Dir(Vec3::new(0.5, -0.25, 1.0)),
            zero: s.zero & 0b011,
            ..s.clone()
        };
        return make_ray_on(&fallback, mesh, planes);
    }
    make_ray_on(s, mesh, planes)
}

/// Every ray through every engine of the harness (every preset's tree,
/// validated; scalar, packet lanes, stream and naive layout, against brute
/// force, bit for bit; the harness also holds the oracle to its own
/// contract: occlusion agrees with the closest hit, the hit lies in
/// `(t_min, t_max]` and is never on a degenerate triangle). Each ray gets
/// one of the lane placements in turn (thousands of cases). Then the
/// interval semantics
/// of the `*Hit` recipes, on the oracle.
fn check(spec: &MeshSpec, recipes: &[RaySpec]) -> Result<(), TestCaseError> {
    let mesh = spec.mesh();
    let mut engines = Engines::try_new(&mesh).map_err(TestCaseError::fail)?;
    // Origins on split planes: those of the trees just built.
    let planes = split_planes(&engines.trees);
    let rays: Vec<Ray> = recipes
        .iter()
        .map(|s| make_valid_ray(s, &mesh, &planes))
        .collect();
    engines.options.placements = Placements::Cycle;
    let report = engines.agree(&rays);
    report.check("kd == brute")?;
    let brute = engines.brute;
    for ((s, r), h) in recipes.iter().zip(&rays).zip(&report.expected) {
        let h = &h.hit;
        let full = Ray::new(r.origin(), r.dir(), 0.0, f32::INFINITY).unwrap();
        let full_hit = brute.intersect(&full);
        match (&s.interval, full_hit) {
            (Interval::TMaxAtHit, Some(f)) => {
                prop_assert_eq!(
                    hit_bits(*h),
                    hit_bits(Some(f)),
                    "t_max = hit.t must keep the hit: {}",
                    ray_literal(r)
                );
            }
            (Interval::TMaxBelowHit, Some(_)) => {
                prop_assert_eq!(*h, None, "t_max below the closest hit: {}", ray_literal(r));
            }
            (Interval::TMinAtHit, Some(f)) => {
                prop_assert!(
                    h.is_none_or(|h| h.t > f.t),
                    "t_min = hit.t must exclude it: {}",
                    ray_literal(r)
                );
            }
            _ => {}
        }
    }
    Ok(())
}

fn rays() -> impl Strategy<Value = Vec<RaySpec>> {
    prop::collection::vec(plain_ray_spec(), 1..40)
}

proptest! {
    // Split clipping makes builds over flat meshes the slowest part of the
    // suite: fewer cases here.
    #![proptest_config(config(150))]

    #[test]
    fn coplanar_kd_equals_brute(spec in coplanar(), rs in rays()) {
        check(&spec, &rs)?;
    }
}

proptest! {
    #![proptest_config(config(400))]

    #[test]
    fn soup_kd_equals_brute(spec in soup(), rs in rays()) {
        check(&spec, &rs)?;
    }

    #[test]
    fn heightfield_kd_equals_brute(spec in heightfield(), rs in rays()) {
        check(&spec, &rs)?;
    }

    #[test]
    fn degenerate_kd_equals_brute(spec in with_degenerates(), rs in rays()) {
        check(&spec, &rs)?;
    }

    #[test]
    fn duplicate_kd_equals_brute(spec in with_duplicates(), rs in rays()) {
        check(&spec, &rs)?;
    }

    /// Intervals that end exactly at the closest hit (`t_max = hit.t`, the
    /// bound is inclusive, so the hit stays) or just before it (no hit).
    #[test]
    fn interval_ends_at_hit_kd_equals_brute(
        spec in any_mesh(),
        rs in prop::collection::vec(ends_at_hit_ray_spec(), 1..40),
    ) {
        check(&spec, &rs)?;
    }

    /// Intervals that start at the closest hit (`t_min = hit.t`, exclusive):
    /// the next hit or none.
    #[test]
    fn interval_starts_at_hit_kd_equals_brute(
        spec in any_mesh(),
        rs in prop::collection::vec(starts_at_hit_ray_spec(), 1..40),
    ) {
        check(&spec, &rs)?;
    }
}

/// Any finite `f32` (normal, subnormal, zero), the whole range.
fn any_finite() -> impl Strategy<Value = f32> {
    prop::num::f32::NORMAL | prop::num::f32::SUBNORMAL | prop::num::f32::ZERO
}

proptest! {
    #![proptest_config(config(200))]

    /// Coordinates from the whole finite range mixed with grid values: the
    /// equality is claimed for every valid (finite) mesh.
    #[test]
    fn extreme_coordinates_kd_equals_brute(
        pts in prop::collection::vec(
            [prop_oneof![2 => grid_coord(), 1 => any_finite()],
             prop_oneof![2 => grid_coord(), 1 => any_finite()],
             prop_oneof![2 => grid_coord(), 1 => any_finite()]],
            3..24),
        idx in prop::collection::vec(prop::array::uniform3(any::<proptest::sample::Index>()), 1..60),
        rs in rays(),
    ) {
        let positions: Vec<Vec3> = pts.iter().map(|c| Vec3::from(*c)).collect();
        let triangles = idx.iter().map(|t| t.map(|i| i.index(positions.len()) as u32)).collect();
        check(&MeshSpec { positions, triangles }, &rs)?;
    }

    /// Any valid parameter set (not only the presets) builds a valid tree
    /// that agrees with brute force, including depth 0 (one leaf), depth
    /// 64 (the stack bound) and leaves of any size. (A zero traversal cost
    /// is accepted by the build but makes trees grow exponentially up to
    /// the depth limit on flat cells, so it is left out here.)
    #[test]
    fn any_valid_params_kd_equals_brute(spec in any_mesh(), p in valid_params(), rs in rays()) {
        let mesh = spec.mesh();
        let tree = KdTree::build(mesh.clone(), &p).map_err(|e| TestCaseError::fail(format!("{p:?}: {e}")))?;
        prop_assert_eq!(tree.validate(), Ok(()), "{:?}", p);
        prop_assert!(tree.stats().max_depth <= tree.depth_limit());
        let planes = tree.split_planes();
        let rays: Vec<Ray> = rs.iter().map(|s| make_valid_ray(s, &mesh, &planes)).collect();
        let mut engines = Engines::from_trees(&mesh, vec![("params".to_string(), tree)]);
        engines.options.placements = Placements::Cycle;
        engines.agree(&rays).check(&format!("{p:?}"))?;
    }
}

/// Build parameters that `KdTree::build` accepts, with split clipping on
/// and off, every sweep, every depth up to the stack bound.
fn valid_params() -> impl Strategy<Value = KdBuildParams> {
    (
        prop_oneof![Just(0.01f32), 0.01f32..20.0],
        prop_oneof![Just(f32::MIN_POSITIVE), 0.01f32..100.0],
        prop_oneof![Just(0.0f32), Just(0.999f32), 0.0f32..1.0],
        prop_oneof![
            Just(DepthLimit::PBRT),
            Just(DepthLimit::COMPACT),
            Just(DepthLimit::Fixed(0)),
            Just(DepthLimit::Fixed(MAX_DEPTH_LIMIT)),
            (0u32..=MAX_DEPTH_LIMIT).prop_map(DepthLimit::Fixed),
            (0.0f32..10.0, 0.0f32..2.0).prop_map(|(base, slope)| DepthLimit::Log2 { base, slope })
        ],
        1u32..5,
        0u32..6,
        prop_oneof![Just(0usize), 0usize..300, Just(usize::MAX)],
        prop_oneof![Just(2u32), Just(128u32), 2u32..300],
        any::<bool>(),
    )
        .prop_map(
            |(
                traversal_cost,
                intersection_cost,
                empty_bonus,
                max_depth,
                max_bad_refines,
                max_leaf_size,
                exact_below,
                bins,
                split_clipping,
            )| KdBuildParams {
                traversal_cost,
                intersection_cost,
                empty_bonus,
                max_depth,
                max_bad_refines,
                max_leaf_size,
                exact_below,
                bins,
                split_clipping,
                memory_budget: None,
                threads: None,
            },
        )
}

/// Rays of every kind against a mesh that can never be hit: every
/// preset's tree validates and references no triangle, and no engine hits.
fn assert_never_hit(mesh: &Mesh) {
    let engines = Engines::new(mesh);
    for t in &engines.trees {
        let stats = t.kd.stats();
        assert_eq!(
            stats.leaves - stats.empty_leaves,
            0,
            "{}: no triangle may be referenced",
            t.name
        );
    }
    let mut rng = Rng(7);
    let rays: Vec<Ray> = (0..2000)
        .map(|i| {
            let o = Vec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            );
            let d = apply_zero_masks(
                rng.unit(),
                (i % 8) as u8 * u8::from(i % 3 == 0),
                (i / 8 % 8) as u8,
            );
            Ray::new(
                o,
                if d == Vec3::ZERO { Vec3::X } else { d },
                0.0,
                f32::INFINITY,
            )
            .unwrap()
        })
        .collect();
    let report = engines.agree(&rays);
    report.assert_ok("never hit");
    for (r, a) in rays.iter().zip(&report.expected) {
        assert_eq!(*a, Answer::NONE, "brute force: {}", ray_literal(r));
    }
}

#[test]
fn empty_mesh_builds_valid_trees_that_never_hit() {
    assert_never_hit(&Mesh::default());
    assert_never_hit(&Mesh::new(vec![], vec![]).unwrap());
    // Unused vertices only: still empty.
    assert_never_hit(&Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![]).unwrap());
}

#[test]
fn all_degenerate_mesh_builds_valid_trees_that_never_hit() {
    let p = vec![
        Vec3::ZERO,
        Vec3::X,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(0.5, 0.5, 0.5),
    ];
    // Repeated vertices, a point, collinear corners (on an axis and on the
    // diagonal), in every order.
    let t = vec![
        [0, 0, 1],
        [1, 0, 0],
        [3, 3, 3],
        [0, 1, 2],
        [2, 0, 1],
        [4, 5, 6],
        [6, 4, 5],
        [4, 0, 5],
        [5, 5, 4],
    ];
    let mesh = Mesh::new(p, t).unwrap();
    assert!((0..mesh.triangle_count()).all(|i| mesh.is_degenerate(i)));
    assert_never_hit(&mesh);
}

#[test]
fn depth_over_the_stack_bound_is_a_typed_error() {
    let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    for d in [MAX_DEPTH_LIMIT + 1, 100, u32::MAX] {
        let p = KdBuildParams {
            max_depth: DepthLimit::Fixed(d),
            ..KdBuildParams::default()
        };
        assert_eq!(
            KdTree::build(mesh.clone(), &p).unwrap_err(),
            BuildError::DepthLimit(d)
        );
        assert_eq!(
            KdTree::build(Mesh::default(), &p).unwrap_err(),
            BuildError::DepthLimit(d)
        );
    }
    let p = KdBuildParams {
        max_depth: DepthLimit::Fixed(MAX_DEPTH_LIMIT),
        ..KdBuildParams::default()
    };
    let tree = KdTree::build(mesh, &p).unwrap();
    assert_eq!(tree.depth_limit(), MAX_DEPTH_LIMIT);
    assert_eq!(tree.validate(), Ok(()));
}

#[test]
fn memory_budget_is_a_typed_error() {
    let spec = MeshSpec {
        positions: (0..64)
            .map(|i| Vec3::new((i % 4) as f32, (i / 4 % 4) as f32, (i / 16) as f32))
            .collect(),
        triangles: (0..60).map(|i| [i, i + 1, i + 4]).collect(),
    };
    let mesh = spec.mesh();
    for (name, p) in KdBuildParams::presets() {
        for budget in [0, 1, 100] {
            let small = KdBuildParams {
                memory_budget: Some(budget),
                ..p
            };
            match KdTree::build(mesh.clone(), &small) {
                Err(BuildError::MemoryBudget { budget: b, needed }) => {
                    assert_eq!(b, budget, "{name}");
                    assert!(
                        needed > budget,
                        "{name}: needed {needed} <= budget {budget}"
                    );
                }
                other => panic!("{name}: budget {budget}: expected MemoryBudget, got {other:?}"),
            }
        }
        // A generous budget builds the same tree as no budget.
        let big = KdBuildParams {
            memory_budget: Some(1 << 30),
            ..p
        };
        let a = KdTree::build(mesh.clone(), &big).unwrap();
        let b = KdTree::build(mesh.clone(), &p).unwrap();
        assert_eq!(a.validate(), Ok(()));
        assert_eq!(
            (a.node_count(), a.stats()),
            (b.node_count(), b.stats()),
            "{name}"
        );
    }
}

#[test]
fn invalid_costs_are_typed_errors() {
    let base = KdBuildParams::default();
    let bad = [
        KdBuildParams {
            traversal_cost: f32::NAN,
            ..base
        },
        // A zero traversal cost lets splits that separate nothing recurse.
        KdBuildParams {
            traversal_cost: 0.0,
            ..base
        },
        KdBuildParams {
            traversal_cost: -0.0,
            ..base
        },
        KdBuildParams {
            traversal_cost: -1.0,
            ..base
        },
        KdBuildParams {
            traversal_cost: f32::INFINITY,
            ..base
        },
        KdBuildParams {
            intersection_cost: f32::NAN,
            ..base
        },
        KdBuildParams {
            intersection_cost: -80.0,
            ..base
        },
        KdBuildParams {
            intersection_cost: 0.0,
            ..base
        },
        KdBuildParams {
            intersection_cost: f32::INFINITY,
            ..base
        },
        KdBuildParams {
            empty_bonus: f32::NAN,
            ..base
        },
        KdBuildParams {
            empty_bonus: -0.5,
            ..base
        },
        KdBuildParams {
            empty_bonus: 1.0,
            ..base
        },
        KdBuildParams {
            max_bad_refines: 0,
            ..base
        },
    ];
    let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    for p in bad {
        match KdTree::build(mesh.clone(), &p) {
            // The message names the bad field: "field = value (rule)".
            Err(BuildError::InvalidParams(text)) => assert!(text.contains(" = "), "{p:?}: {text}"),
            other => panic!("{p:?}: expected InvalidParams, got {other:?}"),
        }
        assert!(
            matches!(
                KdTree::build(Mesh::default(), &p),
                Err(BuildError::InvalidParams(_))
            ),
            "{p:?}"
        );
    }
    // The smallest positive traversal cost is valid.
    let p = KdBuildParams {
        traversal_cost: f32::MIN_POSITIVE,
        ..base
    };
    assert_eq!(KdTree::build(mesh, &p).map(|t| t.validate()), Ok(Ok(())));
}

#[test]
fn ray_new_rejects_zero_nan_and_inf() {
    let o = Vec3::new(0.5, 0.25, 1.0);
    assert_eq!(
        Ray::new(o, Vec3::ZERO, 0.0, 1.0),
        Err(RayError::ZeroDirection)
    );
    assert_eq!(
        Ray::new(o, Vec3::splat(-0.0), 0.0, 1.0),
        Err(RayError::ZeroDirection)
    );
    assert_eq!(
        Ray::new(o, Vec3::new(0.0, -0.0, 0.0), 0.0, f32::INFINITY),
        Err(RayError::ZeroDirection)
    );
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for axis in 0..3 {
            let mut v = Vec3::ONE;
            v[axis] = bad;
            assert!(
                matches!(
                    Ray::new(v, Vec3::Z, 0.0, 1.0),
                    Err(RayError::NonFiniteOrigin(_))
                ),
                "{v}"
            );
            assert!(
                matches!(
                    Ray::new(o, v, 0.0, 1.0),
                    Err(RayError::NonFiniteDirection(_))
                ),
                "{v}"
            );
        }
    }
    assert!(matches!(
        Ray::new(o, Vec3::Z, f32::NAN, 1.0),
        Err(RayError::NanBound { .. })
    ));
    assert!(matches!(
        Ray::new(o, Vec3::Z, 0.0, f32::NAN),
        Err(RayError::NanBound { .. })
    ));
    // Infinite bounds and an empty interval are valid.
    assert!(Ray::new(o, Vec3::Z, f32::NEG_INFINITY, f32::INFINITY).is_ok());
    assert!(Ray::new(o, Vec3::Z, 2.0, 1.0).is_ok());
    // Every error has a message.
    assert!(!RayError::ZeroDirection.to_string().is_empty());
}

/// The ray policy: an invalid ray built with `new_unchecked` never panics,
/// never loops and never hits, on every path; an empty interval never hits.
#[test]
fn unchecked_invalid_rays_never_hit() {
    // A closed box around the origin, so every valid ray from inside hits.
    let mesh = box_mesh(Vec3::splat(-1.0), Vec3::ONE);
    let o = Vec3::new(0.1, 0.2, 0.3);
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let bad = [
        Ray::new_unchecked(o, Vec3::ZERO, 0.0, inf),
        Ray::new_unchecked(o, Vec3::splat(-0.0), 0.0, inf),
        Ray::new_unchecked(Vec3::new(nan, 0.0, 0.0), Vec3::Z, 0.0, inf),
        Ray::new_unchecked(Vec3::new(inf, 0.0, 0.0), Vec3::Z, 0.0, inf),
        Ray::new_unchecked(o, Vec3::new(0.0, nan, 1.0), 0.0, inf),
        Ray::new_unchecked(o, Vec3::new(inf, 0.0, 1.0), 0.0, inf),
        Ray::new_unchecked(o, Vec3::splat(nan), 0.0, inf),
        Ray::new_unchecked(o, Vec3::Z, nan, inf),
        Ray::new_unchecked(o, Vec3::Z, 0.0, nan),
        Ray::new_unchecked(o, Vec3::Z, 0.5, 0.5),
        Ray::new_unchecked(o, Vec3::Z, 2.0, 1.0),
        Ray::new_unchecked(o, Vec3::Z, inf, inf),
    ];
    let good = Ray::new(o, Vec3::Z, 0.0, inf).unwrap();
    // Each bad ray also next to a valid lane, in a packet: only the valid
    // lane hits.
    let rays: Vec<Ray> = std::iter::once(good).chain(bad).collect();
    let packets: Vec<Vec<Option<usize>>> = (1..rays.len())
        .map(|k| vec![Some(0), Some(k), None, Some(k)])
        .collect();
    let report = Engines::new(&mesh).agree_packets(&rays, &packets);
    report.assert_ok("invalid rays");
    assert!(report.hit(0).is_some(), "the valid ray hits the box");
    for (r, a) in rays.iter().zip(&report.expected).skip(1) {
        assert_eq!(*a, Answer::NONE, "brute: {}", ray_literal(r));
    }
}

// ---------------------------------------------------------------------------
// Minimal cases found by the properties above, kept as plain tests.
// ---------------------------------------------------------------------------

fn unit_triangle() -> Mesh {
    Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap()
}

/// Asserts every engine == brute (bits), and that brute hits.
fn assert_kd_matches_brute_hit(mesh: &Mesh, r: &Ray) {
    assert!(
        assert_kd_matches_brute(mesh, r).is_some(),
        "brute force must hit: {}",
        ray_literal(r)
    );
}

/// Asserts every engine == brute (bits, closest hit and occlusion) for
/// every preset; returns brute force's answer.
fn assert_kd_matches_brute(mesh: &Mesh, r: &Ray) -> Option<Hit> {
    let report = agree(mesh, &[*r]);
    report.assert_ok("kd == brute");
    report.hit(0)
}

/// `t_max` = the hit distance on a flat mesh: the triangle test gives
/// `t = 0.99999994` (`0x3f7fffff`), the root slab test of the zero-thickness
/// box gives entry `1.0` and rejects the interval before any slack.
#[test]
fn t_max_equal_to_hit_t_on_a_flat_mesh() {
    let o = Vec3::new(0.5, 0.75, 0.4);
    let d = Vec3::new(-0.25, -0.5, -0.4);
    let r = Ray::new(o, d, 0.0, f32::from_bits(0x3f7f_ffff)).unwrap();
    assert_kd_matches_brute_hit(&unit_triangle(), &r);
}

/// A ray through the corner of a flat mesh's box (aimed at vertex 0), full
/// interval: brute force hits at `t = 0.99999994`, the root slab misses.
#[test]
fn ray_through_a_vertex_on_the_corner_of_a_flat_box() {
    let r = Ray::new(
        Vec3::new(-1.0, -1.0, f32::from_bits(0x3dcd_013b)), // z = 0.1001
        Vec3::new(1.0, 1.0, f32::from_bits(0xbdcd_013b)),
        0.0,
        f32::INFINITY,
    )
    .unwrap();
    assert_kd_matches_brute_hit(&unit_triangle(), &r);
}

/// An origin on the triangle (a secondary ray) with a tiny positive
/// `t_min`: the watertight test's rounding gives `t = 3.4930032e-8` for the
/// triangle the ray starts on. Before the conservative t bound, brute force
/// reported it and the kd-tree (whose box is left at `t = 0`) did not; now
/// the hit lies within the rounding bound of the origin, so neither reports
/// it (the ray policy, docs/exactness.md).
#[test]
fn tiny_t_min_from_a_point_on_the_surface() {
    let r = Ray::new(
        Vec3::new(0.48689753, 0.17796215, 0.0),
        Vec3::new(0.437378, 0.33619034, 0.37317115),
        1.7465016e-8,
        f32::INFINITY,
    )
    .unwrap();
    assert_eq!(assert_kd_matches_brute(&unit_triangle(), &r), None);
}

/// Long, thin triangles reaching far from the origin (z = -3921) and a ray
/// starting among them near their far end: the watertight test returned
/// `t = 0.63391286` for triangle 1 (exact distance `1.50603`), before the
/// ray even enters its box at `t = 0.9616`, so the kd-tree (which culled
/// that cell after finding triangle 2 at `t = 0.9570889`) disagreed with
/// brute force. Both hits lie within their triangles' conservative t error
/// bounds (the rounding error of `t` grows with the vertices' distance from
/// the origin), so now neither path reports them.
#[test]
fn long_thin_triangle_with_inaccurate_t() {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let far = p(-0.0, -1.0, -3921.7134);
    let positions = vec![
        p(-2.0, -2.0, -2.0),
        far,
        p(0.25, 1.5, 1.5),
        p(-2.0, -2.0, -2.0),
        far,
        p(0.25, -0.0, 1.0),
        p(0.5, -0.5, 3.0),
        p(0.25, 1.5, 1.5),
        far,
        p(0.0006657784, -1.0, -2.0),
        p(0.25, 0.5, -2.0),
        p(3.0, -2.0, -1.0),
    ];
    let mesh = Mesh::new(
        positions,
        vec![[0, 1, 2], [3, 4, 5], [6, 7, 8], [9, 10, 11]],
    )
    .unwrap();
    let r = Ray::new(
        p(1.1760186, 0.3046193, -3161.5618), // bits 0x3f9687c7 0x3e9bf710 0xc54598fd
        p(-0.9630093, -0.9278303, 1.0),
        0.0,
        f32::INFINITY,
    )
    .unwrap();
    assert_eq!(assert_kd_matches_brute(&mesh, &r), None);
}

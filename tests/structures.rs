//! One property suite for every structure: the kd-tree (default preset),
//! the 8-wide BVH (SAH and median builds), the binary BVH (median and
//! SAH), the uniform grid (default, box overlap without mailbox, coarse
//! and fine) and the two-level grid (default, and one refining every
//! cell of more than one triangle), each validated, each traced through the one harness
//! (`tests/common/harness.rs`) ray by ray, as packets of 4 and 8 in every
//! lane placement and as streams, against brute force bit for bit (`t`,
//! triangle, `u`, `v`, ties to the smaller index; occlusion). The meshes
//! and rays are the kd-tree suite's (`tests/kd_vs_brute.rs`): triangle
//! soups, heightfields, coplanar sets, degenerate and duplicate triangles,
//! axis-parallel rays (zero direction components of both signs), origins
//! on box faces, on corner and bin planes and on the surface, rays aimed
//! at corners and edge midpoints (grazing edges and shared vertices),
//! intervals that end or start exactly at the closest hit, and
//! coordinates from the whole finite `f32` range. The kernel the packets
//! run in follows `PACKTRACE_KERNEL` (CI runs this suite again with the
//! baseline kernel forced); `kdtree/kernel/bvh.rs` runs every kernel in
//! one process.

mod common;

use common::harness::{Engines, Placements};
use common::*;
use glam::Vec3;
use packtrace::bvh::{Bvh2, Bvh8, BvhBuildParams};
use packtrace::grid::{Grid, GridParams, HGrid, HGridParams, Overlap};
use packtrace::{KdBuildParams, Mesh, Ray, RayError};
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::TestCaseError;

/// Every structure over `mesh`, validated, in one harness.
fn engines(mesh: &Mesh) -> Result<Engines<'_>, String> {
    let mut e = Engines::with_params(mesh, &[("kd", KdBuildParams::default())])?;
    e.options.naive = false;
    for (name, p) in [
        ("sah", BvhBuildParams::sah()),
        ("median", BvhBuildParams::median()),
        (
            "leaf1",
            BvhBuildParams {
                max_leaf_size: 1,
                ..BvhBuildParams::sah()
            },
        ),
    ] {
        let b = Bvh8::build(mesh.clone(), &p).map_err(|e| format!("bvh8/{name}: {e}"))?;
        b.validate().map_err(|e| format!("bvh8/{name}: {e}"))?;
        e = e.with_structure(format!("bvh8/{name}"), b);
    }
    for (name, p) in [
        ("median", BvhBuildParams::median()),
        ("sah_binary", BvhBuildParams::sah_binary()),
    ] {
        let b = Bvh2::build(mesh.clone(), &p).map_err(|e| format!("bvh2/{name}: {e}"))?;
        b.validate().map_err(|e| format!("bvh2/{name}: {e}"))?;
        e = e.with_structure(format!("bvh2/{name}"), b);
    }
    for (name, p) in [
        ("default", GridParams::default()),
        (
            "boxes",
            GridParams {
                overlap: Overlap::Boxes,
                mailbox: false,
                ..GridParams::default()
            },
        ),
        (
            "coarse",
            GridParams {
                density: 0.05,
                ..GridParams::default()
            },
        ),
        (
            "fine",
            GridParams {
                density: 40.0,
                ..GridParams::default()
            },
        ),
    ] {
        let g = Grid::build(mesh.clone(), &p).map_err(|e| format!("grid/{name}: {e}"))?;
        g.validate().map_err(|e| format!("grid/{name}: {e}"))?;
        e = e.with_structure(format!("grid/{name}"), g);
    }
    for (name, p) in [
        ("default", HGridParams::default()),
        (
            "deep",
            HGridParams {
                top: GridParams {
                    density: 0.2,
                    ..GridParams::default()
                },
                refine_above: 1,
                ..HGridParams::default()
            },
        ),
    ] {
        let g = HGrid::build(mesh.clone(), &p).map_err(|e| format!("hgrid/{name}: {e}"))?;
        g.validate().map_err(|e| format!("hgrid/{name}: {e}"))?;
        e = e.with_structure(format!("hgrid/{name}"), g);
    }
    Ok(e)
}

/// `make_ray`, with `make_ray`'s fallback direction for a recipe whose
/// direction is zero only after the ray policy's flush of subnormal
/// components (as `kd_vs_brute.rs` does).
fn make_valid_ray(s: &RaySpec, mesh: &Mesh) -> Ray {
    let origin = origin_point(&s.origin, mesh);
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
        return make_ray(&fallback, mesh);
    }
    make_ray(s, mesh)
}

fn check(spec: &MeshSpec, recipes: &[RaySpec]) -> Result<(), TestCaseError> {
    let mesh = spec.mesh();
    let rays: Vec<Ray> = recipes.iter().map(|s| make_valid_ray(s, &mesh)).collect();
    let mut e = engines(&mesh).map_err(TestCaseError::fail)?;
    e.options.placements = Placements::Cycle;
    e.agree(&rays).check("every structure == brute")
}

fn rays() -> impl Strategy<Value = Vec<RaySpec>> {
    prop::collection::vec(ray_spec(), 1..40)
}

proptest! {
    #![proptest_config(config(120))]

    #[test]
    fn soup_every_structure_equals_brute(spec in soup(), rs in rays()) {
        check(&spec, &rs)?;
    }

    #[test]
    fn heightfield_every_structure_equals_brute(spec in heightfield(), rs in rays()) {
        check(&spec, &rs)?;
    }

    #[test]
    fn degenerate_every_structure_equals_brute(spec in with_degenerates(), rs in rays()) {
        check(&spec, &rs)?;
    }

    #[test]
    fn duplicate_every_structure_equals_brute(spec in with_duplicates(), rs in rays()) {
        check(&spec, &rs)?;
    }

    #[test]
    fn coplanar_every_structure_equals_brute(spec in coplanar(), rs in rays()) {
        check(&spec, &rs)?;
    }

    /// Intervals that end or start exactly at the closest hit.
    #[test]
    fn at_hit_intervals_every_structure_equals_brute(
        spec in any_mesh(),
        rs in prop::collection::vec(at_hit_ray_spec(), 1..40),
    ) {
        check(&spec, &rs)?;
    }

    /// Coordinates from the whole finite range mixed with grid values.
    #[test]
    fn extreme_coordinates_every_structure_equals_brute(
        pts in prop::collection::vec(
            [prop_oneof![2 => grid_coord(), 1 => any_finite()],
             prop_oneof![2 => grid_coord(), 1 => any_finite()],
             prop_oneof![2 => grid_coord(), 1 => any_finite()]],
            3..24),
        idx in prop::collection::vec(prop::array::uniform3(any::<Index>()), 1..60),
        rs in rays(),
    ) {
        let positions: Vec<Vec3> = pts.iter().map(|c| Vec3::from(*c)).collect();
        let triangles = idx.iter().map(|t| t.map(|i| i.index(positions.len()) as u32)).collect();
        check(&MeshSpec { positions, triangles }, &rs)?;
    }

    /// One scene at scales from `1e-30` to `1e30`, offset far from the
    /// origin: the fast box test at moderate scales, the robust one at the
    /// extremes.
    #[test]
    fn scaled_and_offset_scenes_every_structure_equals_brute(
        spec in soup(),
        scale_exp in -30i32..=30,
        offset in prop_oneof![Just(0.0f32), -1e6f32..1e6],
        rs in rays(),
    ) {
        let s = 10f32.powi(scale_exp);
        let positions = spec.positions.iter().map(|p| *p * s + Vec3::splat(offset)).collect();
        check(&MeshSpec { positions, triangles: spec.triangles.clone() }, &rs)?;
    }
}

/// Any finite `f32` (normal, subnormal, zero), the whole range.
fn any_finite() -> impl Strategy<Value = f32> {
    prop::num::f32::NORMAL | prop::num::f32::SUBNORMAL | prop::num::f32::ZERO
}

/// A closed, jittered sphere seen from inside: every ray hits
/// (watertightness needs no reference), and every structure agrees with
/// brute force on the triangle.
#[test]
fn rays_from_inside_a_closed_sphere_always_hit_every_structure() {
    let mesh = packtrace::protocol::generate::jittered_sphere(3000, 7, 0.3);
    let mut e = engines(&mesh).unwrap();
    e.options.placements = Placements::Cycle;
    let rays: Vec<Ray> = (0..300)
        .map(|i| {
            let f = i as f32;
            let d = Vec3::new((f * 0.37).sin(), (f * 0.91).cos(), (f * 0.13).sin() - 0.2);
            Ray::new(Vec3::new(0.01, -0.02, 0.03), d, 0.0, f32::INFINITY).unwrap()
        })
        .collect();
    let report = e.agree(&rays);
    report.assert_ok("inside the sphere");
    // (`expected` also holds the harness's companion rays, after these.)
    for (k, a) in report.expected.iter().take(rays.len()).enumerate() {
        assert!(a.hit.is_some(), "ray {k} escaped the closed sphere");
    }
}

/// The same trees for 1, 2 and 3 threads (builds big enough to run in
/// parallel: subtrees of 4096 references and more, chunked binning).
#[test]
fn bvh_builds_are_the_same_for_any_thread_count() {
    let mesh = packtrace::protocol::generate::jittered_sphere(80_000, 11, 0.2);
    for (name, p) in BvhBuildParams::presets() {
        let with = |threads| BvhBuildParams {
            threads: Some(threads),
            ..p
        };
        let one = Bvh8::build(mesh.clone(), &with(1)).unwrap();
        let one2 = Bvh2::build(mesh.clone(), &with(1)).unwrap();
        for threads in [2, 3] {
            let many = Bvh8::build(mesh.clone(), &with(threads)).unwrap();
            assert_eq!(one.nodes(), many.nodes(), "{name}, {threads} threads");
            assert_eq!(one.blocks(), many.blocks(), "{name}, {threads} threads");
            let many2 = Bvh2::build(mesh.clone(), &with(threads)).unwrap();
            assert_eq!(one2.nodes(), many2.nodes(), "{name}, {threads} threads");
            assert_eq!(one2.prims(), many2.prims(), "{name}, {threads} threads");
        }
        assert_eq!(one.validate(), Ok(()));
    }
}

//! Found failures as a table: every input the fuzzers (docs/testing.md,
//! "Findings") and the independent check of issue 17 found, reduced to
//! literals, run by one loop through the comparison harness
//! (`tests/common/harness.rs`: every preset built and validated, brute
//! force, scalar, packet lanes in every position and neighbourhood, the
//! stream API, the naive layout, bit for bit, and every hit finite and
//! inside its interval).
//!
//! A case either pins the answers (`Expect::Hits`: brute force, and so
//! every engine, returns exactly these bits) or asks only that all engines
//! agree (`Expect::Agree`). Cases that need a check beyond that (the ray
//! policy's flushes, a distance against f64) have their own test below,
//! on the table's data. The OBJ finding is a parser input, not a mesh, and
//! has its own test at the end.

mod common;

use common::{Engines, hit_bits};
use glam::Vec3;
use packtrace::{Hit, Mesh, Ray};

const INF: f32 = f32::INFINITY;

/// What a case must give.
enum Expect {
    /// Every engine agrees with brute force (whatever it answers).
    Agree,
    /// Brute force's closest hit of each ray, bit for bit (and every engine
    /// agrees with it).
    Hits(Vec<Option<Hit>>),
}

/// One found failure.
struct Case {
    /// The test's name before the table (docs/testing.md cites them).
    name: &'static str,
    /// Where it was found.
    source: &'static str,
    mesh: Mesh,
    rays: Vec<Ray>,
    expect: Expect,
}

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// A vector from `f32` bit patterns.
fn vb(b: [u32; 3]) -> Vec3 {
    Vec3::from(b.map(f32::from_bits))
}

/// An `f32` from its bit pattern.
fn f32_bits(b: u32) -> f32 {
    f32::from_bits(b)
}

/// A mesh of positions and index triples.
fn mesh(positions: &[Vec3], triangles: &[[u32; 3]]) -> Mesh {
    Mesh::new(positions.to_vec(), triangles.to_vec()).expect("a case's mesh is valid")
}

/// A soup: triangle `i` is corners `3i..3i+3`.
fn soup(tris: &[[Vec3; 3]]) -> Mesh {
    let triangles: Vec<[u32; 3]> = (0..tris.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    mesh(&tris.concat(), &triangles)
}

/// A soup given as bit patterns.
fn soup_bits(tris: &[[[u32; 3]; 3]]) -> Mesh {
    soup(&tris.iter().map(|t| t.map(vb)).collect::<Vec<_>>())
}

fn ray(o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Ray {
    Ray::new(o, d, t_min, t_max).expect("a case's ray is valid")
}

fn hit(t: u32, prim: u32, u: u32, v: u32) -> Hit {
    Hit {
        t: f32_bits(t),
        prim,
        u: f32_bits(u),
        v: f32_bits(v),
    }
}

/// The issue 17 reproducer A1: a triangle in the plane z = -3.68 and a ray
/// towards it.
fn a1_mesh() -> Mesh {
    soup_bits(&[[
        [0x41c49168, 0x41446a80, 0xc06bc9ef],
        [0x41bd9ba5, 0x41222d0f, 0xc06bc9ef],
        [0x41ca1687, 0x41222d0f, 0xc06bc9ef],
    ]])
}
const A1_RAY: ([u32; 3], [u32; 3]) = (
    [0x41bfa26f, 0x412bac04, 0xc06bca8d],
    [0x3f5a0866, 0xbecc4e8f, 0x3eadec7e],
);

/// A2: a triangle in the plane x = 21.531.
fn a2_mesh() -> Mesh {
    soup_bits(&[[
        [0x41ac3f7c, 0x41505de7, 0xc07efd22],
        [0x41ac3f7c, 0x4156cc30, 0xc07efd22],
        [0x41ac3f7c, 0x4156cc30, 0xc0816a16],
    ]])
}
const A2_RAY: ([u32; 3], [u32; 3]) = (
    [0x41ac3f7d, 0x415629d0, 0xc07fbe6e],
    [0xbeb2d2fb, 0x3c579b62, 0x3f6fdaba],
);

/// Class B: coordinates around 1e14, a ray along -y through a vertex.
const B_RAY: ([u32; 3], [u32; 3]) = (
    [0xd6c9212e, 0x570c3fdc, 0x5736841e],
    [0x0, 0xbf72654c, 0x80000000],
);

/// The ray `(o, d)` with the intervals around its first hit at `t`:
/// closed at it, one ulp beyond, one ulp short, starting one ulp below it,
/// starting at it, and the one-ulp interval `(next_down(t), t]`.
fn around((o, d): ([u32; 3], [u32; 3]), t: u32) -> Vec<Ray> {
    let t = f32_bits(t);
    [
        (0.0, t),
        (0.0, t.next_up()),
        (0.0, t.next_down()),
        (t.next_down(), INF),
        (t, INF),
        (t.next_down(), t),
    ]
    .into_iter()
    .map(|(a, b)| ray(vb(o), vb(d), a, b))
    .collect()
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "subnormal_direction_component_is_traced_like_brute_force",
            source: "docs/testing.md finding 2 (`trace` fuzz target, reduced by hand)",
            mesh: mesh(
                &[v(0.0, -1.0, 1.0), v(0.0, 1.5, 1.0), v(-1.0, -1.0, 0.0)],
                &[[0, 1, 2]],
            ),
            rays: vec![ray(
                v(8.28442e-40, 0.0, 0.0),
                v(-8.28442e-40, 1.5, 1.0),
                0.0,
                INF,
            )],
            expect: Expect::Agree,
        },
        Case {
            name: "tiny_coordinates_underflowing_edge_function_agrees_with_brute_force",
            source: "docs/testing.md finding 3 (`trace` fuzz target, reduced by removing triangles)",
            mesh: mesh(
                &[
                    v(0.0, 0.0, -27.5),
                    v(1.25, 1.0, -1.0),
                    v(9.919097e-38, 9.405685e-38, 1.5751635e-36),
                    v(9.706944e-35, 4e-45, 2.38801e-38),
                ],
                &[[0, 1, 2], [3, 2, 1]],
            ),
            rays: vec![ray(v(0.0, 0.0, 1.0), v(0.0, 0.0, -28.5), 0.0, INF)],
            expect: Expect::Agree,
        },
        Case {
            // The harness checks that no path (brute force included)
            // reports a hit with non-finite t, u or v.
            name: "overflowing_triangle_test_reports_no_nan_hit",
            source: "docs/testing.md finding 3 (`trace` fuzz target, reduced)",
            mesh: mesh(
                &[
                    v(0.0, 2.0, 4.0),
                    v(0.0, 3.0, 1.0),
                    v(1.0, 0.0, 0.0),
                    v(4.305e-42, 1.5046328e-36, 1.5516525e-36),
                    v(1.8189903e-12, 1.1e-44, 1.7e-44),
                    v(7.37918e-40, 1.6011173e-33, 6.396345e-36),
                ],
                &[[0, 1, 2], [3, 4, 5]],
            ),
            rays: vec![ray(
                v(0.0, 2.3440831e-38, -2.6793063e36),
                v(0.0, -2.3440831e-38, 2.6793063e36),
                0.0,
                INF,
            )],
            expect: Expect::Agree,
        },
        Case {
            name: "hit_at_t_zero_from_a_negative_t_min_agrees_with_brute_force",
            source: "docs/testing.md finding 3 (`trace` fuzz target, reduced)",
            mesh: mesh(
                &[
                    v(0.0, 0.0, 0.0),
                    v(0.0, 0.0, -0.25),
                    v(9.8607613e-32, 0.0, 1.44e-42),
                    v(0.0, 1.0, 1.0),
                    v(0.0, 0.0, 1.25),
                ],
                &[[0, 1, 2], [3, 4, 2]],
            ),
            rays: vec![ray(
                v(2.887e-42, 1.616535e-36, 2.314398e-38),
                v(0.0, 1.0, 0.0),
                -2.6793063e36,
                6.508296e-30,
            )],
            expect: Expect::Agree,
        },
        Case {
            // The finding is about the build: every preset's tree must
            // validate (the harness validates every tree it builds). The
            // fuzzer's input had no ray that failed.
            name: "split_clipping_with_subnormal_coordinates_validates",
            source: "docs/testing.md finding 4 (`trace` fuzz target, reduced by removing triangles)",
            mesh: soup(&[
                [
                    v(2.0, 0.0, 0.0),
                    v(3.0, 0.0, 0.0),
                    v(1.6457021e-36, 0.0, 2.3509886e-38),
                ],
                [
                    v(0.0, 0.0, -10.75),
                    v(3.0, 0.0, 0.0),
                    v(14.25, 14.25, 14.25),
                ],
                [
                    v(0.25, 0.0, 0.0),
                    v(0.0, 0.0, -10.75),
                    v(3.71647e-40, 1.5046342e-36, 4.235169e-22),
                ],
                [
                    v(14.25, 14.25, 14.25),
                    v(3.71647e-40, 1.5046342e-36, 4.235169e-22),
                    v(3.0, 0.0, 0.0),
                ],
            ]),
            rays: vec![],
            expect: Expect::Agree,
        },
        Case {
            // The ray starts on the triangle (in the flat scene box y = 0)
            // with a tiny t_min; the harness traces it alone, beside
            // inactive lanes and beside three zero-direction lanes, the
            // fuzzer's packet `[ray, zero, zero, zero]`.
            name: "a_lane_does_not_depend_on_invalid_neighbours",
            source: "docs/testing.md finding 5 (`trace` fuzz target, reduced to one triangle)",
            mesh: mesh(
                &[v(9.75, 0.0, -0.25), v(0.0, 0.0, 0.0), v(2.0, 0.0, 1.0)],
                &[[0, 1, 2]],
            ),
            rays: vec![ray(v(1.0, 0.0, 0.0), v(3.0, 1.0, 0.0), 2.87e-42, INF)],
            expect: Expect::Agree,
        },
        Case {
            name: "direction_components_beyond_f32_range_of_each_other_agree",
            source: "docs/testing.md finding 9 (`trace` fuzz target, second campaign: its whole 8-triangle soup)",
            mesh: soup(&[
                [
                    v(1.0889068e-28, 2.3519957e-38, -8.825641e18),
                    v(1.0889068e-28, 2.3519957e-38, -8.825641e18),
                    v(1.0889068e-28, 2.3519957e-38, -8.825641e18),
                ],
                [v(0.0, -9.75, -9.75), v(0.0, -9.75, -9.75), v(0.0, 0.0, 0.0)],
                [v(0.0, -9.75, -9.75), v(1.0, 0.0, 0.0), v(0.0, 0.0, 0.0)],
                [v(0.0, 0.0, 0.0), v(0.0, -9.75, -9.75), v(0.0, -9.75, -9.75)],
                [
                    v(3.0, 0.0, 0.0),
                    v(0.0, -9.75, -9.75),
                    v(2.0006452e-38, 0.0, 1.561203e-39),
                ],
                [v(2.25, 3.25, 2.0), v(1.0, 10.5, 0.0), v(2.25, 3.25, 2.0)],
                [v(1.5, 2.75, 2.5), v(1.0, 0.0, 0.0), v(0.0, 0.0, 0.0)],
                [
                    v(2.25, 3.25, 2.0),
                    v(1.0889068e-28, 2.3519957e-38, -8.825641e18),
                    v(0.0, -9.75, -9.75),
                ],
            ]),
            rays: vec![ray(
                v(0.0, 0.0, 0.25),
                v(1.0889068e-28, 2.3519957e-38, -8.825641e18),
                0.0,
                INF,
            )],
            expect: Expect::Agree,
        },
        Case {
            name: "grazing_an_edge_with_a_negligible_component_agrees",
            source: "docs/testing.md finding 9 (`trace` fuzz target, second campaign)",
            mesh: mesh(
                &[
                    v(-1.0, 0.0, 1.0),
                    v(0.5, -1.0, -1.0),
                    v(-1.0, 0.0, -1.0),
                    v(2.0, 2.0, 3.0),
                    v(-1.713457e35, 1.0, 0.5),
                    v(0.0, 2.0, 0.0),
                ],
                &[[0, 1, 2], [3, 4, 5]],
            ),
            rays: [1.0, 3.0]
                .map(|x| {
                    ray(
                        v(x, 0.0, 0.0),
                        v(-1.713457e35, 3.7765102e-34, 0.0),
                        0.0,
                        INF,
                    )
                })
                .to_vec(),
            expect: Expect::Agree,
        },
        Case {
            name: "a1_t_min_just_below_the_hit",
            source: "issue 17, class A, reproducer A1 (independent check)",
            mesh: a1_mesh(),
            rays: vec![ray(vb(A1_RAY.0), vb(A1_RAY.1), f32_bits(0x38e89475), INF)],
            expect: Expect::Hits(vec![Some(hit(0x38e89476, 0, 0x3f3703b4, 0x3bff22e6))]),
        },
        Case {
            name: "a2_t_max_equal_to_the_hit",
            source: "issue 17, class A, reproducer A2 (independent check)",
            mesh: a2_mesh(),
            rays: vec![ray(vb(A2_RAY.0), vb(A2_RAY.1), 0.0, f32_bits(0x36b72e08))],
            expect: Expect::Hits(vec![Some(hit(0x36b72e08, 0, 0x3f346f3d, 0x3e494388))]),
        },
        Case {
            name: "a3_coordinates_around_1e5",
            source: "issue 17, class A, reproducer A3 (independent check): three triangles, t_max equal to the hit",
            mesh: soup_bits(&[
                [
                    [0x47e76301, 0x47bc3401, 0x470fd600],
                    [0x47eac901, 0x47be2800, 0x470fd600],
                    [0x47eac901, 0x47ac3000, 0x470fd600],
                ],
                [
                    [0x47c28d01, 0x47a1a400, 0x470b2600],
                    [0x47e9de00, 0x47a1a400, 0x470b2600],
                    [0x47e8ff82, 0x479fb001, 0x47073e00],
                ],
                [
                    [0x47c28d01, 0x47a1a400, 0x470b2600],
                    [0x47c28d01, 0x47a6ea01, 0x470b2600],
                    [0x47e98400, 0x47a6ea01, 0x470b2600],
                ],
            ]),
            rays: vec![ray(
                vb([0x47c9fa9b, 0x47a2adf9, 0x470b2799]),
                vb([0x3dcc5efb, 0xbf48b6cc, 0xbf1cd5c9]),
                0.0,
                f32_bits(0x4026e60f),
            )],
            expect: Expect::Hits(vec![Some(hit(0x4026e60f, 2, 0x3bb7cc5b, 0x3e4339b7))]),
        },
        Case {
            name: "reproducers_with_every_interval_around_the_hit (A1)",
            source: "issue 17, class A: A1 with the interval moved around its hit",
            mesh: a1_mesh(),
            rays: around(A1_RAY, 0x38e89476),
            expect: Expect::Hits({
                let h = Some(hit(0x38e89476, 0, 0x3f3703b4, 0x3bff22e6));
                vec![h, h, None, h, None, h]
            }),
        },
        Case {
            name: "reproducers_with_every_interval_around_the_hit (A2)",
            source: "issue 17, class A: A2 with the interval moved around its hit",
            mesh: a2_mesh(),
            rays: around(A2_RAY, 0x36b72e08),
            expect: Expect::Hits({
                let h = Some(hit(0x36b72e08, 0, 0x3f346f3d, 0x3e494388));
                vec![h, h, None, h, None, h]
            }),
        },
        Case {
            // The f32 products overflowed and every path reported t = inf;
            // the f64 route gives the finite distance (checked against f64
            // in `b_no_hit_at_infinity_has_the_f64_distance`), and an
            // interval beyond f32::MAX holds no hit.
            name: "b_no_hit_at_infinity",
            source: "issue 17, class B (independent check): coordinates around 1e14",
            mesh: soup_bits(&[[
                [0xd6901e30, 0xd602352e, 0x57479906],
                [0xd72412a3, 0x5592bd62, 0x571050c0],
                [0xd6c9212e, 0xd585e8bb, 0x5736841e],
            ]]),
            rays: vec![
                ray(vb(B_RAY.0), vb(B_RAY.1), 0.0, INF),
                ray(vb(B_RAY.0), vb(B_RAY.1), f32::MAX, INF),
            ],
            expect: Expect::Hits(vec![Some(hit(0x5725cc87, 0, 0x00000000, 0x3f800000)), None]),
        },
        Case {
            // The f32 inside decision accepts the vertex the ray is aimed
            // at, the exact ray passes just outside, and the grazing
            // ray's exact plane crossing lay 1.1e-4 before the vertex,
            // outside the triangle's box: brute force reported it there
            // and every tree missed it when the interval ended at it.
            name: "vertex_aimed_grazing_ray_ending_at_its_hit",
            source: "docs/testing.md finding 13, first case (`kd_vs_brute.rs`, random seed; triangle 53 of 109)",
            mesh: soup(&[[v(0.25, -0.5, 0.0), v(-1.0, -1.0, 1.0), v(-0.5, -0.5, 0.25)]]),
            rays: ending_near_one(
                v(0.0006852072, 0.0, -0.5),
                v(-0.5006852, -0.5, 0.75),
                0.9998908,
            ),
            expect: Expect::Agree,
        },
        Case {
            name: "vertex_aimed_ray_at_the_mesh_box_corner",
            source: "docs/testing.md finding 13, second case (`instances.rs`, 20,000 cases)",
            mesh: soup(&[[v(0.25, -0.5, 0.5), v(0.5, 2.0, 2.0), v(-1.0, -1.0, -1.0)]]),
            rays: ending_near_one(
                v(-3.9505444, 4.8862586, -1.0000001),
                v(4.4505444, -2.8862586, 3.0),
                0.99996734,
            ),
            expect: Expect::Agree,
        },
        Case {
            name: "vertex_aimed_ray_at_a_shared_vertex_on_the_box_face",
            source: "docs/testing.md finding 13, third case (`instances.rs` seed cc abed7a39)",
            mesh: mesh(
                &[
                    v(-1.0, 0.0, 2.0),
                    v(-0.5, 1.0, 1.0),
                    v(-0.5, 2.0, 0.25),
                    v(-1.0, -1.0, -1.0),
                    v(2.0, -1.0, -1.0),
                ],
                &[[0, 1, 2], [1, 2, 3], [3, 4, 3]],
            ),
            rays: ending_near_one(
                v(-5.6082554, 4.822051, 0.68914294),
                v(5.1082554, -2.822051, -0.43914294),
                0.9999665,
            ),
            expect: Expect::Agree,
        },
    ]
}

/// A ray aimed at a vertex it reaches at `t = 1`, with intervals ending at
/// the `t` brute force once reported (`old_t`), at 1 and one ulp either
/// side, and open; and each closed interval again starting at its end's
/// `next_down`.
fn ending_near_one(o: Vec3, d: Vec3, old_t: f32) -> Vec<Ray> {
    let ends = [old_t, 1.0f32.next_down(), 1.0, 1.0f32.next_up(), INF];
    let mut rays: Vec<Ray> = ends.iter().map(|&t| ray(o, d, 0.0, t)).collect();
    rays.extend(ends[..4].iter().map(|&t| ray(o, d, t.next_down(), t)));
    rays
}

/// The case of that name.
fn case(name: &str) -> Case {
    cases()
        .into_iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no case {name}"))
}

/// Every case through every engine; all failing cases are reported
/// together, each with its source.
#[test]
fn every_case_agrees_on_every_engine() {
    let cases = cases();
    let mut names: Vec<&str> = cases.iter().map(|c| c.name).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), cases.len(), "case names are unique");
    let mut failures = Vec::new();
    for c in &cases {
        let label = format!("{} [{}]", c.name, c.source);
        let engines = match Engines::try_new(&c.mesh) {
            Ok(e) => e,
            Err(e) => {
                failures.push(format!("{label}: {e}"));
                continue;
            }
        };
        let report = engines.agree(&c.rays);
        if !report.is_ok() {
            failures.push(report.message(&label));
        }
        if let Expect::Hits(want) = &c.expect {
            assert_eq!(want.len(), c.rays.len(), "{}: one answer per ray", c.name);
            for (k, w) in want.iter().enumerate() {
                if hit_bits(report.hit(k)) != hit_bits(*w) {
                    failures.push(format!(
                        "{label}: ray {k}: brute force {:?}, want {w:?}",
                        report.hit(k)
                    ));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases fail:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// Finding 2, the ray policy: the subnormal component is flushed to
/// `-0.0`, the sign (and so near/far) kept.
#[test]
fn subnormal_direction_component_is_flushed_with_its_sign() {
    let c = case("subnormal_direction_component_is_traced_like_brute_force");
    let ray = c.rays[0];
    assert_eq!(ray.dir().x.to_bits(), (-0.0f32).to_bits());
    assert_eq!(ray.inv_dir().x, f32::NEG_INFINITY);
}

/// Finding 9, the ray policy: a component negligible against the dominant
/// one is flushed.
#[test]
fn negligible_direction_component_is_flushed() {
    let c = case("direction_components_beyond_f32_range_of_each_other_agree");
    assert_eq!(c.rays[0].dir().y, 0.0, "negligible component flushed");
}

/// Class B: the hit is finite and within 1e-6 of the f64 distance to the
/// vertex (1.54e14 away along -y, `|d| = 0.946`, so `t` is about 1.6e14).
#[test]
fn b_no_hit_at_infinity_has_the_f64_distance() {
    let c = case("b_no_hit_at_infinity");
    let report = Engines::new(&c.mesh).agree(&c.rays[..1]);
    report.assert_ok(c.name);
    let h = report
        .hit(0)
        .expect("the ray passes through a vertex: edges are inclusive");
    assert!(
        h.t.is_finite() && h.u.is_finite() && h.v.is_finite(),
        "{h:?}"
    );
    let exact = (f64::from(f32_bits(0x570c3fdc)) - f64::from(f32_bits(0xd585e8bb)))
        / f64::from(f32_bits(0x3f72654c));
    assert!(
        (f64::from(h.t) - exact).abs() <= exact * 1e-6,
        "{} vs {exact}",
        h.t
    );
}

/// Finding 6, found by the `obj` fuzz target (minimised with `cargo fuzz
/// tmin`): in tobj 4.0.5 a relative (negative) texcoord or normal index
/// that points before the first one wraps to a huge `usize`, and tobj
/// computes `vt * 2 + 1` / `vn * 3 + 2` unchecked: "attempt to multiply
/// with overflow" in every build with overflow checks. The loader no
/// longer reads faces through tobj, and the answers are known: the
/// positions-only loader reads attribute indices as integers only (the
/// first two load as the triangle), the shading loader refuses them with
/// a typed error; the fuzzer's input names vertex 3 of 2 (its `r` line is
/// an unknown keyword, skipped).
#[test]
fn obj_relative_texcoord_or_normal_index_before_the_first_is_not_a_panic() {
    use packtrace::LoadError;
    use packtrace::obj::Attribute;
    let no_panic = |src: &[u8]| {
        let text = String::from_utf8_lossy(src).into_owned();
        let plain = std::panic::catch_unwind(|| packtrace::parse_obj_bytes(src))
            .unwrap_or_else(|_| panic!("parse_obj_bytes panicked on {text:?}"));
        let shaded = std::panic::catch_unwind(|| packtrace::parse_obj_bytes_with_shading(src))
            .unwrap_or_else(|_| panic!("parse_obj_bytes_with_shading panicked on {text:?}"));
        (plain, shaded.err())
    };
    let triangle = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
    for (src, attribute) in [
        (
            &b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-3 2 3\n"[..],
            Attribute::TextureCoordinate,
        ),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-3 2 3\n",
            Attribute::Normal,
        ),
    ] {
        let (plain, shaded) = no_panic(src);
        let mesh = plain.unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mesh.triangle_count(), 1);
        assert_eq!(*mesh.corners(0), triangle);
        match shaded {
            Some(LoadError::AttributeIndexOutOfRange {
                line: 5,
                attribute: a,
                index: -3,
                count: 1,
                ..
            }) => assert_eq!(a, attribute),
            other => panic!("{attribute:?}: expected AttributeIndexOutOfRange, got {other:?}"),
        }
    }
    // The fuzzer's minimised input, byte for byte. Corners are checked
    // left to right: the positions-only loader first fails on the third
    // corner's vertex, the shading loader already on the second corner's
    // texture coordinate.
    let (plain, shaded) = no_panic(b"r\nv 1 0 0\nv 0 1  0\nvt 0  1\nf 1 2/-6 3");
    match plain {
        Err(LoadError::IndexOutOfRange {
            line: 5,
            index: 3,
            vertex_count: 2,
            ..
        }) => {}
        other => panic!("expected IndexOutOfRange, got {other:?}"),
    }
    match shaded {
        Some(LoadError::AttributeIndexOutOfRange {
            line: 5,
            attribute: Attribute::TextureCoordinate,
            index: -6,
            count: 1,
            ..
        }) => {}
        other => panic!("expected AttributeIndexOutOfRange, got {other:?}"),
    }
}

/// Where `o + t d` meets the triangle `(p0, p1, p2)`, in f64.
struct F64Hit {
    t: f64,
    u: f64,
    v: f64,
    /// Bounds on the f32 triangle test's rounding error in `t` and in
    /// `u`, `v`: `16 eps` (eps = `f32::EPSILON`) times the size of what
    /// it computes with, the corners relative to the origin (`m`), over
    /// `|d|` for `t`, and its edge functions (`m^2 |d|`) over their sum
    /// (`|det|`) for the barycentrics: a few roundings of each term, as
    /// in PBRT's error analysis of the watertight test.
    t_tol: f64,
    uv_tol: f64,
}

/// Cramer's rule for `[-d, p1 - p0, p2 - p0] (t, u, v) = o - p0` in f64
/// (the f32 inputs are exact in f64; `None` for a ray parallel to the
/// plane).
fn f64_hit(o: Vec3, d: Vec3, [p0, p1, p2]: [Vec3; 3]) -> Option<F64Hit> {
    let f = |p: Vec3| glam::DVec3::new(p.x.into(), p.y.into(), p.z.into());
    let (o, d) = (f(o), f(d));
    let (q0, q1, q2) = (f(p0) - o, f(p1) - o, f(p2) - o);
    let (e1, e2) = (q1 - q0, q2 - q0);
    let s = -q0;
    let det = (-d).dot(e1.cross(e2));
    if det == 0.0 {
        return None;
    }
    let m = q0.abs().max(q1.abs()).max(q2.abs()).max_element();
    let eps = 16.0 * f64::from(f32::EPSILON);
    Some(F64Hit {
        t: s.dot(e1.cross(e2)) / det,
        u: (-d).dot(s.cross(e2)) / det,
        v: (-d).dot(e1.cross(s)) / det,
        t_tol: eps * m / d.abs().max_element(),
        uv_tol: eps * m * m * d.length() / det.abs(),
    })
}

/// The pinned hits of the table (`Expect::Hits`) have an independent
/// source: the closest triangle in f64 is the pinned `prim`, and the
/// pinned `t`, `u`, `v` lie within the f32 test's rounding bound of the
/// f64 values (`F64Hit`). The bits themselves are the f32 test's (pinned so that any
/// change is seen); `t` is also the independent check's, and class B's
/// `u = 0, v = 1` is exact for a geometric reason: the ray runs along
/// `-y` through the triangle's third vertex (same `x` and `z`, zero `x`
/// and `z` direction), where `v = 1`.
#[test]
fn pinned_hits_match_an_f64_reference() {
    let mut checked = 0;
    for c in cases() {
        let Expect::Hits(want) = &c.expect else {
            continue;
        };
        for (r, w) in c.rays.iter().zip(want) {
            let Some(w) = w else { continue };
            // The closest f64 crossing inside its triangle, whatever the
            // interval (the pinned intervals end or start at the hit).
            let mut best: Option<(usize, F64Hit)> = None;
            for prim in 0..c.mesh.triangle_count() {
                let Some(h) = f64_hit(r.origin(), r.dir(), *c.mesh.corners(prim)) else {
                    continue;
                };
                let inside = h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0 && h.t > 0.0;
                if inside && best.as_ref().is_none_or(|(_, b)| h.t < b.t) {
                    best = Some((prim, h));
                }
            }
            let (prim, h) = best.unwrap_or_else(|| panic!("{}: no f64 hit", c.name));
            assert_eq!(
                w.prim as usize, prim,
                "{}: the closest triangle in f64",
                c.name
            );
            let close = |got: f32, want: f64, tol: f64, what: &str| {
                let off = (f64::from(got) - want).abs();
                println!("{}: {what} off by {off:.3e} (bound {tol:.3e})", c.name);
                assert!(
                    off <= tol,
                    "{}: {what} {got:e} vs f64 {want:e} (off by {off:e}, bound {tol:e})",
                    c.name
                );
            };
            close(w.t, h.t, h.t_tol, "t");
            close(w.u, h.u, h.uv_tol, "u");
            close(w.v, h.v, h.uv_tol, "v");
            checked += 1;
        }
    }
    assert!(checked >= 10, "{checked} pinned hits checked");
    // Class B, the geometric reason above.
    let b = case("b_no_hit_at_infinity");
    let third = b.mesh.corners(0)[2];
    let o = b.rays[0].origin();
    assert_eq!((o.x, o.z), (third.x, third.z));
    assert_eq!((b.rays[0].dir().x, b.rays[0].dir().z), (0.0, 0.0));
}

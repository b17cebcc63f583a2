//! Issue 17: exact at the edges. Rays whose interval ends at a hit or
//! starts just below it, at every coordinate scale, on every path; the
//! reported hit always lies inside the ray's interval with finite `t`,
//! `u`, `v`; the independent check's reproducers as literal bit patterns.

mod common;

use common::*;
use glam::Vec3;
use packtrace::{BruteForce, Hit, KdBuildParams, KdTree, Mesh, Ray, RayPacket4, RayQuery};

fn v(b: [u32; 3]) -> Vec3 {
    Vec3::new(
        f32::from_bits(b[0]),
        f32::from_bits(b[1]),
        f32::from_bits(b[2]),
    )
}

fn mesh_of(tris: &[[[u32; 3]; 3]]) -> Mesh {
    let positions: Vec<Vec3> = tris.iter().flatten().map(|&c| v(c)).collect();
    let triangles = (0..tris.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    Mesh::new(positions, triangles).unwrap()
}

fn ray_of(o: [u32; 3], d: [u32; 3], t_min: f32, t_max: f32) -> Ray {
    Ray::new(v(o), v(d), t_min, t_max).unwrap()
}

/// Every preset's tree, scalar and packet (the ray in each lane, the
/// other lanes inactive, and four copies) against brute force; the
/// expected hit is given literally where the report gave it.
fn assert_every_path(mesh: &Mesh, ray: &Ray, expected: Option<Hit>) {
    let brute = BruteForce::new(mesh);
    assert_eq!(
        hit_bits(brute.intersect(ray)),
        hit_bits(expected),
        "brute force"
    );
    assert_eq!(
        brute.occluded(ray),
        expected.is_some(),
        "brute force occlusion"
    );
    for (name, p) in KdBuildParams::presets() {
        let tree = KdTree::build(mesh.clone(), &p).unwrap();
        let ctx = format!("{name}\nray: {}", ray_literal(ray));
        assert_eq!(
            hit_bits(tree.intersect(ray)),
            hit_bits(expected),
            "scalar {ctx}"
        );
        assert_eq!(tree.occluded(ray), expected.is_some(), "occluded {ctx}");
        for lane in 0..4 {
            let mut lanes = [None; 4];
            lanes[lane] = Some(*ray);
            let pk = RayPacket4::from_lanes(lanes);
            let h = tree.intersect4(&pk);
            assert_eq!(
                hit_bits(h.hit(lane)),
                hit_bits(expected),
                "packet lane {lane} {ctx}"
            );
            assert_eq!(
                tree.occluded4(&pk) >> lane & 1 == 1,
                expected.is_some(),
                "{ctx}"
            );
        }
        let h = tree.intersect4(&RayPacket4::from_rays(&[*ray; 4]));
        for lane in 0..4 {
            assert_eq!(
                hit_bits(h.hit(lane)),
                hit_bits(expected),
                "full packet {ctx}"
            );
        }
    }
}

#[allow(dead_code)]
fn hit(t: u32, prim: u32, u: u32, v: u32) -> Hit {
    Hit {
        t: f32::from_bits(t),
        prim,
        u: f32::from_bits(u),
        v: f32::from_bits(v),
    }
}

/// A1: `t_min` just below the hit, on a triangle in the plane z = -3.68.
#[test]
fn a1_t_min_just_below_the_hit() {
    let mesh = mesh_of(&[[
        [0x41c49168, 0x41446a80, 0xc06bc9ef],
        [0x41bd9ba5, 0x41222d0f, 0xc06bc9ef],
        [0x41ca1687, 0x41222d0f, 0xc06bc9ef],
    ]]);
    let ray = ray_of(
        [0x41bfa26f, 0x412bac04, 0xc06bca8d],
        [0x3f5a0866, 0xbecc4e8f, 0x3eadec7e],
        f32::from_bits(0x38e89475),
        f32::INFINITY,
    );
    let expected = BruteForce::new(&mesh).intersect(&ray).unwrap();
    assert_eq!((expected.t.to_bits(), expected.prim), (0x38e89476, 0));
    assert_eq!(
        (expected.u.to_bits(), expected.v.to_bits()),
        (0x3f3703b4, 0x3bff22e6)
    );
    assert_every_path(&mesh, &ray, Some(expected));
}

/// A2: `t_max` equal to the hit, on a triangle in the plane x = 21.531.
#[test]
fn a2_t_max_equal_to_the_hit() {
    let mesh = mesh_of(&[[
        [0x41ac3f7c, 0x41505de7, 0xc07efd22],
        [0x41ac3f7c, 0x4156cc30, 0xc07efd22],
        [0x41ac3f7c, 0x4156cc30, 0xc0816a16],
    ]]);
    let ray = ray_of(
        [0x41ac3f7d, 0x415629d0, 0xc07fbe6e],
        [0xbeb2d2fb, 0x3c579b62, 0x3f6fdaba],
        0.0,
        f32::from_bits(0x36b72e08),
    );
    let expected = BruteForce::new(&mesh).intersect(&ray).unwrap();
    assert_eq!((expected.t.to_bits(), expected.prim), (0x36b72e08, 0));
    assert_every_path(&mesh, &ray, Some(expected));
}

/// A3: coordinates around 1e5, three triangles, `t_max` equal to the hit.
#[test]
fn a3_coordinates_around_1e5() {
    let mesh = mesh_of(&[
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
    ]);
    let ray = ray_of(
        [0x47c9fa9b, 0x47a2adf9, 0x470b2799],
        [0x3dcc5efb, 0xbf48b6cc, 0xbf1cd5c9],
        0.0,
        f32::from_bits(0x4026e60f),
    );
    let expected = BruteForce::new(&mesh).intersect(&ray).unwrap();
    assert_eq!((expected.t.to_bits(), expected.prim), (0x4026e60f, 2));
    assert_every_path(&mesh, &ray, Some(expected));
}

/// The same three rays with the interval moved around the hit: closed
/// at the hit, one ulp beyond, starting at it, one ulp below it.
#[test]
fn reproducers_with_every_interval_around_the_hit() {
    let cases = [
        (
            mesh_of(&[[
                [0x41c49168, 0x41446a80, 0xc06bc9ef],
                [0x41bd9ba5, 0x41222d0f, 0xc06bc9ef],
                [0x41ca1687, 0x41222d0f, 0xc06bc9ef],
            ]]),
            (
                [0x41bfa26f, 0x412bac04, 0xc06bca8d],
                [0x3f5a0866, 0xbecc4e8f, 0x3eadec7e],
            ),
        ),
        (
            mesh_of(&[[
                [0x41ac3f7c, 0x41505de7, 0xc07efd22],
                [0x41ac3f7c, 0x4156cc30, 0xc07efd22],
                [0x41ac3f7c, 0x4156cc30, 0xc0816a16],
            ]]),
            (
                [0x41ac3f7d, 0x415629d0, 0xc07fbe6e],
                [0xbeb2d2fb, 0x3c579b62, 0x3f6fdaba],
            ),
        ),
    ];
    for (mesh, (o, d)) in &cases {
        let brute = BruteForce::new(mesh);
        let first = brute
            .intersect(&ray_of(*o, *d, 0.0, f32::INFINITY))
            .unwrap();
        for (t_min, t_max) in [
            (0.0, first.t),
            (0.0, first.t.next_up()),
            (0.0, first.t.next_down()),
            (first.t.next_down(), f32::INFINITY),
            (first.t, f32::INFINITY),
            (first.t.next_down(), first.t),
        ] {
            let ray = ray_of(*o, *d, t_min, t_max);
            assert_every_path(mesh, &ray, brute.intersect(&ray));
        }
    }
}

/// Class B: coordinates around 1e14, a ray along an axis through a
/// vertex. The f32 products overflowed and every path reported
/// `t = inf`; now the f64 route gives the finite distance, and an interval
/// beyond `f32::MAX` holds no hit on any path.
#[test]
fn b_no_hit_at_infinity() {
    let mesh = mesh_of(&[[
        [0xd6901e30, 0xd602352e, 0x57479906],
        [0xd72412a3, 0x5592bd62, 0x571050c0],
        [0xd6c9212e, 0xd585e8bb, 0x5736841e],
    ]]);
    let (o, d) = (
        [0xd6c9212e, 0x570c3fdc, 0x5736841e],
        [0x0, 0xbf72654c, 0x80000000],
    );
    let ray = ray_of(o, d, 0.0, f32::INFINITY);
    let found = BruteForce::new(&mesh).intersect(&ray);
    let h = found.expect("the ray passes through a vertex: edges are inclusive");
    assert!(
        h.t.is_finite() && h.u.is_finite() && h.v.is_finite(),
        "{h:?}"
    );
    // The vertex is 1.54e14 away along -y (|d| = 0.946): t is about 1.6e14.
    let exact = (f64::from(f32::from_bits(0x570c3fdc)) - f64::from(f32::from_bits(0xd585e8bb)))
        / f64::from(f32::from_bits(0x3f72654c));
    assert!(
        (f64::from(h.t) - exact).abs() <= exact * 1e-6,
        "{} vs {exact}",
        h.t
    );
    assert_every_path(&mesh, &ray, found);
    assert_every_path(&mesh, &ray_of(o, d, f32::MAX, f32::INFINITY), None);
}

/// Hits on meshes far beyond the f32 range of the fast route, and far
/// below it: every path reports the same finite hit (before, 1e30-scale
/// meshes were missed by every path and tiny ones too).
#[test]
fn huge_and_tiny_triangles_are_hit_with_finite_t() {
    for scale in [1e-30f32, 1e-20, 1e-13, 1e13, 1e18, 1e30, 1e36] {
        let mesh = Mesh::new(
            vec![Vec3::ZERO, Vec3::X * scale, Vec3::Y * scale],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let ray = Ray::new(
            Vec3::new(0.25, 0.25, 1.0) * scale,
            Vec3::NEG_Z,
            0.0,
            f32::INFINITY,
        )
        .unwrap();
        let h = BruteForce::new(&mesh).intersect(&ray);
        let h = h.unwrap_or_else(|| panic!("scale {scale:e}: no hit"));
        assert_eq!(h.t, scale, "scale {scale:e}");
        assert_eq!((h.u, h.v), (0.25, 0.25), "scale {scale:e}");
        assert_every_path(&mesh, &ray, Some(h));
    }
}

// ---------------------------------------------------------------------------
// Properties: intervals around a found hit, at every scale
// ---------------------------------------------------------------------------

use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// A triangle in the unit cube: tilted (three free corners) or lying in a
/// plane `axis = c` (the architectural case: walls, floors, steps).
#[derive(Clone, Debug)]
enum Tri {
    Tilted([[f32; 3]; 3]),
    AxisAligned {
        axis: usize,
        c: f32,
        uv: [[f32; 2]; 3],
    },
}

fn unit() -> impl Strategy<Value = f32> {
    prop_oneof![
        2 => prop::sample::select(&[0.0f32, 0.125, 0.25, 0.5, 0.75, 1.0][..]),
        3 => 0.0f32..=1.0,
    ]
}

fn tri() -> impl Strategy<Value = Tri> {
    prop_oneof![
        1 => prop::array::uniform3(prop::array::uniform3(unit())).prop_map(Tri::Tilted),
        2 => (0usize..3, unit(), prop::array::uniform3(prop::array::uniform2(unit())))
            .prop_map(|(axis, c, uv)| Tri::AxisAligned { axis, c, uv }),
    ]
}

/// `10^e` for a uniform exponent: scales 1e-4 to 1e6, offsets up to 1e6.
fn pow10(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    (lo..=hi).prop_map(|e| 10f32.powf(e))
}

fn offset() -> impl Strategy<Value = Vec3> {
    let c = prop_oneof![1 => Just(0.0f32), 3 => (pow10(-2.0, 6.0), any::<bool>()).prop_map(|(m, n)| if n { -m } else { m })];
    [c.clone(), c.clone(), c].prop_map(Vec3::from)
}

#[derive(Clone, Debug)]
struct Scene {
    tris: Vec<Tri>,
    scale: f32,
    offset: Vec3,
}

fn scene() -> impl Strategy<Value = Scene> {
    (
        prop::collection::vec(tri(), 1..40),
        pow10(-4.0, 6.0),
        offset(),
    )
        .prop_map(|(tris, scale, offset)| Scene {
            tris,
            scale,
            offset,
        })
}

impl Scene {
    fn place(&self, p: [f32; 3]) -> Vec3 {
        Vec3::from(p) * self.scale + self.offset
    }

    fn mesh(&self) -> Mesh {
        let mut positions = Vec::new();
        for t in &self.tris {
            let corners: [[f32; 3]; 3] = match t {
                Tri::Tilted(c) => *c,
                Tri::AxisAligned { axis, c, uv } => uv.map(|[a, b]| {
                    let mut p = [0.0; 3];
                    p[*axis] = *c;
                    p[(axis + 1) % 3] = a;
                    p[(axis + 2) % 3] = b;
                    p
                }),
            };
            positions.extend(corners.map(|c| self.place(c)));
        }
        let triangles = (0..self.tris.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        Mesh::new(positions, triangles).unwrap()
    }
}

/// Where a first ray starts: anywhere in (or around) the unit cube, or
/// just off a triangle's surface (the renderer's case: a secondary ray
/// from a hit point, offset by `10^-e` of the scene's size).
#[derive(Clone, Debug)]
enum From {
    Free([f32; 3]),
    NearSurface {
        tri: prop::sample::Index,
        bary: [f32; 2],
        off: [f32; 3],
        e: f32,
    },
}

/// A first ray: from `from`, aimed at a point or along an axis.
#[derive(Clone, Debug)]
struct Probe {
    from: From,
    to: [f32; 3],
    axis_parallel: Option<(usize, bool)>,
    /// Re-trace from the hit point in this direction too (a secondary ray).
    bounce: [f32; 3],
}

fn probe() -> impl Strategy<Value = Probe> {
    let p = || prop::array::uniform3(prop_oneof![3 => unit(), 1 => -1.0f32..2.0]);
    let from = prop_oneof![
        1 => p().prop_map(From::Free),
        2 => (any::<prop::sample::Index>(), prop::array::uniform2(0.0f32..=1.0),
              prop::array::uniform3(-1.0f32..1.0), 1.0f32..7.0)
            .prop_map(|(tri, bary, off, e)| From::NearSurface { tri, bary, off, e }),
    ];
    (
        from,
        p(),
        prop::option::weighted(0.2, (0usize..3, any::<bool>())),
        prop::array::uniform3(-1.0f32..1.0),
    )
        .prop_map(|(from, to, axis_parallel, bounce)| Probe {
            from,
            to,
            axis_parallel,
            bounce,
        })
}

/// Every kd path on `ray` equals brute force, and every path's hit (brute
/// force included) lies in the interval with finite `t`, `u`, `v`.
fn agree(mesh: &Mesh, trees: &[(&str, KdTree)], ray: &Ray) -> Result<Option<Hit>, TestCaseError> {
    let brute = BruteForce::new(mesh);
    let expected = brute.intersect(ray);
    let sane = |h: Option<Hit>, path: &str| -> Result<(), TestCaseError> {
        if let Some(h) = h {
            prop_assert!(
                h.t.is_finite()
                    && h.u.is_finite()
                    && h.v.is_finite()
                    && ray.t_min < h.t
                    && h.t <= ray.t_max,
                "{path}: hit {h:?} outside ({}, {}] or not finite\nray: {}",
                ray.t_min,
                ray.t_max,
                ray_literal(ray)
            );
        }
        Ok(())
    };
    sane(expected, "brute force")?;
    prop_assert_eq!(brute.occluded(ray), expected.is_some());
    for (name, tree) in trees {
        let ctx = || {
            format!(
                "{name}\nray: {}\n{}",
                ray_literal(ray),
                diagnose(
                    mesh,
                    ray,
                    &[("brute", expected), ("kd", tree.intersect(ray))]
                )
            )
        };
        let s = tree.intersect(ray);
        sane(s, name)?;
        prop_assert_eq!(hit_bits(s), hit_bits(expected), "scalar {}", ctx());
        prop_assert_eq!(tree.occluded(ray), expected.is_some(), "occluded {}", ctx());
        // Packet: the ray in lane 1 beside three different rays.
        let other = Ray::new(ray.origin, -ray.dir, ray.t_min, ray.t_max).unwrap();
        let lanes = [
            other,
            *ray,
            Ray::new_unchecked(ray.origin, ray.dir, 1.0, 0.0),
            *ray,
        ];
        let pk = RayPacket4::from_rays(&lanes);
        let h = tree.intersect4(&pk);
        for lane in [1, 3] {
            sane(h.hit(lane), name)?;
            prop_assert_eq!(
                hit_bits(h.hit(lane)),
                hit_bits(expected),
                "packet lane {} {}",
                lane,
                ctx()
            );
        }
        prop_assert_eq!(
            tree.occluded4(&pk) >> 1 & 1 == 1,
            expected.is_some(),
            "occluded4 {}",
            ctx()
        );
    }
    Ok(expected)
}

/// The recipe around a found hit at `t`: `t_max = t`,
/// `t_max = next_up(t)`, `t_min = next_down(t)`, `t_min = t`, and the
/// one-ulp interval `(next_down(t), t]`.
fn around(ray: &Ray, t: f32) -> [Ray; 5] {
    let (o, d) = (ray.origin, ray.dir);
    [
        Ray::new(o, d, ray.t_min, t).unwrap(),
        Ray::new(o, d, ray.t_min, t.next_up()).unwrap(),
        Ray::new(o, d, t.next_down(), f32::INFINITY).unwrap(),
        Ray::new(o, d, t, f32::INFINITY).unwrap(),
        Ray::new(o, d, t.next_down(), t).unwrap(),
    ]
}

fn check_scene(scene: &Scene, probes: &[Probe]) -> Result<(), TestCaseError> {
    let mesh = scene.mesh();
    let trees = trees(&mesh).map_err(TestCaseError::fail)?;
    for pr in probes {
        let from = match &pr.from {
            From::Free(p) => scene.place(*p),
            From::NearSurface { tri, bary, off, e } => {
                let c = mesh.corners(tri.index(mesh.triangle_count()));
                let (a, b) = (bary[0], bary[1] * (1.0 - bary[0]));
                let on = c[0] + (c[1] - c[0]) * a + (c[2] - c[0]) * b;
                on + Vec3::from(*off) * (scene.scale * 10f32.powf(-e))
            }
        };
        let dir = match pr.axis_parallel {
            Some((axis, neg)) => {
                let mut d = Vec3::ZERO;
                d[axis] = if neg { -1.0 } else { 1.0 };
                d
            }
            None => scene.place(pr.to) - from,
        };
        let Ok(ray) = Ray::new(from, dir, 0.0, f32::INFINITY) else {
            continue;
        };
        let Some(h) = agree(&mesh, &trees, &ray)? else {
            continue;
        };
        for r in around(&ray, h.t) {
            agree(&mesh, &trees, &r)?;
        }
        // A secondary ray from the hit point, and the same recipe on it.
        if let Ok(sec) = Ray::new(ray.at(h.t), Vec3::from(pr.bounce), 0.0, f32::INFINITY)
            && let Some(h2) = agree(&mesh, &trees, &sec)?
        {
            for r in around(&sec, h2.t) {
                agree(&mesh, &trees, &r)?;
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(config(64))]

    /// Intervals that end at, or start just below, a found hit, on meshes
    /// of axis-aligned and tilted triangles at scales 1e-4 to 1e6 and
    /// offsets up to 1e6: every preset, scalar and packet, equals brute
    /// force, and no path reports a hit outside its interval.
    #[test]
    fn intervals_around_a_hit_at_every_scale(s in scene(), probes in prop::collection::vec(probe(), 1..24)) {
        check_scene(&s, &probes)?;
    }
}

//! Rays that break naive code, against a sphere, a box, one triangle, the
//! empty mesh and an axis-aligned grid mesh whose kd splits fall on vertex
//! coordinates: zero and non-finite directions, non-finite origins, empty
//! and inverted intervals, NaN bounds, negative zeros, tiny and huge
//! components, origins exactly on split planes and on scene-box faces and
//! edges.
//!
//! The ray policy (module docs of `packtrace::ray`) must hold:
//! - `Ray::new` returns the documented `RayError` for an invalid ray, with
//!   the offending value in it, and accepts every other ray unchanged;
//! - a ray built with `Ray::new_unchecked` that `Ray::new` would refuse,
//!   or whose interval is empty, never hits, on every path;
//! - no path panics or loops (the test finishing is the check; all counts
//!   are bounded);
//! - brute force, the scalar kd traversal of every preset, the naive
//!   layout (`NaiveKdTree::from_kd`), the packet traversal (the ray in
//!   every lane position, beside valid lanes of the same and of other
//!   direction signs, beside inactive lanes, beside zero-direction lanes,
//!   and four of it) and the stream API (`intersect_rays`,
//!   `occluded_rays`, at every offset) give exactly the same answer: the
//!   harness (`tests/common/harness.rs`) checks all of it, on the rays and
//!   on the companion rays of every direction octant placed beside them.

mod common;

use common::harness::{Placements, centre_radius, companion, invalid, octant};
use common::{Answer, Engines, Report, agree, box_mesh, hit_bits};
use glam::Vec3;
use packtrace::protocol::generate;
use packtrace::query::PacketQuery;
use packtrace::{BruteForce, Hit, Mesh, Ray, RayError, RayPacket4, RayQuery};

const INF: f32 = f32::INFINITY;
const NAN: f32 = f32::NAN;

// ---------------------------------------------------------------------------
// Meshes
// ---------------------------------------------------------------------------

/// The 12 triangles of the box `[-1, 1]^3`.
fn unit_box() -> Mesh {
    box_mesh(Vec3::splat(-1.0), Vec3::ONE)
}

fn one_triangle() -> Mesh {
    Mesh::new(
        vec![
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(2.0, -0.5, 0.0),
            Vec3::new(0.0, 1.5, -0.5),
        ],
        vec![[0, 1, 2]],
    )
    .unwrap()
}

/// Axis-aligned unit squares on the integer grid of `[0, 8]^3`, in the
/// planes `axis = k` for k in {0, 2, 3, 5, 8}: every vertex coordinate is
/// an integer, so the exact sweep's splits are integers and the binned
/// sweep's root splits are multiples of 8/128 = 1/16.
fn grid_mesh() -> Mesh {
    let mut p = Vec::new();
    let mut t = Vec::new();
    for axis in 0..3 {
        for k in [0u32, 2, 3, 5, 8] {
            for i in 0..8u32 {
                for j in 0..8u32 {
                    if !(i * 7 + j * 3 + k + axis as u32).is_multiple_of(4) {
                        continue;
                    }
                    let b = p.len() as u32;
                    for (di, dj) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
                        let mut v = [0.0f32; 3];
                        v[axis] = k as f32;
                        v[(axis + 1) % 3] = (i + di) as f32;
                        v[(axis + 2) % 3] = (j + dj) as f32;
                        p.push(Vec3::from(v));
                    }
                    t.push([b, b + 1, b + 2]);
                    t.push([b, b + 2, b + 3]);
                }
            }
        }
    }
    Mesh::new(p, t).unwrap()
}

fn meshes() -> Vec<(&'static str, Mesh)> {
    vec![
        ("sphere", generate::sphere(500)),
        ("box", unit_box()),
        ("triangle", one_triangle()),
        ("empty", Mesh::default()),
        ("grid", grid_mesh()),
    ]
}

/// Companion rays per octant (as many as a packet has other lanes).
const COMPANIONS: usize = 3;

/// Every mesh's problems: the constructor's and the harness's.
#[derive(Default)]
struct Problems {
    constructor: Vec<String>,
    report: Report,
}

impl Problems {
    /// Panic with everything found, if anything.
    #[track_caller]
    fn finish(self) {
        let mut text = String::new();
        if !self.constructor.is_empty() {
            text += &format!(
                "{} constructor check(s) failed; the first:\n  {}\n",
                self.constructor.len(),
                self.constructor[..self.constructor.len().min(8)].join("\n  ")
            );
        }
        if !self.report.is_ok() {
            text += &self.report.message("engines");
        }
        assert!(text.is_empty(), "{text}");
    }
}

// ---------------------------------------------------------------------------
// The policy
// ---------------------------------------------------------------------------

fn vbits(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// A ray's fields as bits (NaN-safe, `-0.0 != 0.0`).
fn ray_bits(r: &Ray) -> ([u32; 3], [u32; 3], [u32; 3], u32, u32) {
    (
        vbits(r.origin()),
        vbits(r.dir()),
        vbits(r.inv_dir()),
        r.t_min().to_bits(),
        r.t_max().to_bits(),
    )
}

/// `Ray::new` on the ray's fields returns exactly the documented result:
/// the unchanged ray when valid, else one of the errors that apply, with
/// the offending values in it and in its message.
fn check_constructor(label: &str, r: &Ray, problems: &mut Vec<String>) {
    let got = Ray::new(r.origin(), r.dir(), r.t_min(), r.t_max());
    let unchecked = Ray::new_unchecked(r.origin(), r.dir(), r.t_min(), r.t_max());
    match got {
        Ok(ok) => {
            if invalid(r) {
                problems.push(format!("{label}: Ray::new accepted {r:?}"));
            }
            if ray_bits(&ok) != ray_bits(&unchecked) {
                problems.push(format!(
                    "{label}: Ray::new changed the ray\n      got {ok:?}\n     want {unchecked:?}"
                ));
            }
        }
        Err(e) => {
            let text = e.to_string();
            let applies = match e {
                RayError::NonFiniteOrigin(o) => {
                    vbits(o) == vbits(r.origin())
                        && !r.origin().is_finite()
                        && text.contains("origin")
                }
                RayError::NonFiniteDirection(d) => {
                    vbits(d) == vbits(r.dir()) && !r.dir().is_finite() && text.contains("direction")
                }
                RayError::ZeroDirection => r.dir() == Vec3::ZERO && text.contains("zero"),
                RayError::NanBound { t_min, t_max } => {
                    t_min.to_bits() == r.t_min().to_bits()
                        && t_max.to_bits() == r.t_max().to_bits()
                        && (t_min.is_nan() || t_max.is_nan())
                        && text.contains("NaN")
                }
            };
            if !applies {
                problems.push(format!(
                    "{label}: Ray::new gave {e:?} (\"{text}\") for {r:?}"
                ));
            }
        }
    }
}

/// Check one list of rays against one mesh: the constructor on each ray;
/// the harness on the rays and on the companions of every octant (the
/// valid rays placed beside them in packets, held to brute force too),
/// with every lane placement; and each ray in every lane of a packet given
/// as SoA arrays, beside companions of its signs, with garbage in the
/// active mask's upper bits.
fn check_rays(
    mesh_name: &str,
    mesh: &Mesh,
    engines: &Engines,
    rays: &[(String, Ray)],
    out: &mut Problems,
) {
    for (label, r) in rays {
        check_constructor(&format!("{mesh_name}: {label}"), r, &mut out.constructor);
    }
    let (c, radius) = centre_radius(mesh);
    let mut all: Vec<Ray> = rays.iter().map(|(_, r)| *r).collect();
    for oct in 0..8 {
        for k in 0..COMPANIONS {
            all.push(companion(oct, c, radius, 0.05 * k as f32));
        }
    }
    assert_eq!(engines.options.placements, Placements::Every);
    let report = engines.agree(&all).name_rays(|k| match rays.get(k) {
        Some((label, _)) => label.clone(),
        None => "companion".to_string(),
    });
    for (k, (label, r)) in rays.iter().enumerate() {
        let want = report.expected[k];
        let oct = octant(r);
        for lane in 0..4 {
            let mut org = [[0.0f32; 4]; 3];
            let mut dir = [[0.0f32; 4]; 3];
            let (mut t_min, mut t_max) = ([0.0f32; 4], [0.0f32; 4]);
            let mut k = 0;
            for i in 0..4 {
                let ri = if i == lane {
                    *r
                } else {
                    k += 1;
                    companion(oct, c, radius, 0.05 * (k - 1) as f32)
                };
                for a in 0..3 {
                    org[a][i] = ri.origin()[a];
                    dir[a][i] = ri.dir()[a];
                }
                t_min[i] = ri.t_min();
                t_max[i] = ri.t_max();
            }
            // Bad rays on purpose: the unchecked constructor (the checked
            // one refuses them, `tests/packet_vs_scalar.rs` and the unit
            // tests of `packet`).
            let soa = RayPacket4::from_soa_unchecked(org, dir, t_min, t_max, u32::MAX);
            if soa.active() != 0b1111 {
                out.constructor.push(format!(
                    "{mesh_name}: {label}: from_soa active {:#b}",
                    soa.active()
                ));
            }
            for t in &engines.trees {
                let h = t.kd.intersect4(&soa);
                if hit_bits(h.hit(lane)) != hit_bits(want.hit) {
                    out.constructor.push(format!(
                        "{mesh_name}: {label}/{}: from_soa lane {lane}\n      got {:?}\n     want {:?}",
                        t.name,
                        h.hit(lane),
                        want.hit
                    ));
                }
            }
        }
    }
    out.report.merge(mesh_name, report);
}

// ---------------------------------------------------------------------------
// The rays
// ---------------------------------------------------------------------------

/// Invalid rays (`Ray::new` refuses them): zero, NaN and infinite
/// directions, NaN and infinite origins, NaN bounds, and combinations.
fn invalid_rays(c: Vec3, radius: f32) -> Vec<(String, Ray)> {
    let mut v = Vec::new();
    let o = c - Vec3::new(0.3, 0.2, 2.0) * radius;
    let towards = c - o;
    // Zero direction with every sign combination of zeros.
    for s in 0..8 {
        let z = |k: u32| if s >> k & 1 == 1 { -0.0f32 } else { 0.0 };
        let d = Vec3::new(z(0), z(1), z(2));
        v.push((
            format!("zero direction {d:?}"),
            Ray::new_unchecked(o, d, 0.0, INF),
        ));
    }
    let nans = [
        NAN,
        -NAN,
        f32::from_bits(0x7f80_0001),
        f32::from_bits(0xffc0_1234),
    ];
    let non_finite = [NAN, -NAN, f32::from_bits(0x7f80_0001), INF, -INF];
    for axis in 0..3 {
        for &x in &non_finite {
            let mut bad_o = o;
            bad_o[axis] = x;
            v.push((
                format!("origin[{axis}] = {x:?}"),
                Ray::new_unchecked(bad_o, towards, 0.0, INF),
            ));
            let mut bad_d = towards;
            bad_d[axis] = x;
            v.push((
                format!("dir[{axis}] = {x:?}"),
                Ray::new_unchecked(o, bad_d, 0.0, INF),
            ));
            // Non-finite component, the others zero.
            let mut lone = Vec3::ZERO;
            lone[axis] = x;
            v.push((
                format!("dir = {lone:?}"),
                Ray::new_unchecked(o, lone, 0.0, INF),
            ));
        }
    }
    for &x in &nans {
        v.push((
            format!("t_min = {x:?}"),
            Ray::new_unchecked(o, towards, x, INF),
        ));
        v.push((
            format!("t_max = {x:?}"),
            Ray::new_unchecked(o, towards, 0.0, x),
        ));
        v.push((
            format!("both bounds {x:?}"),
            Ray::new_unchecked(o, towards, x, x),
        ));
    }
    v.push((
        "all NaN".into(),
        Ray::new_unchecked(Vec3::splat(NAN), Vec3::splat(NAN), NAN, NAN),
    ));
    v.push((
        "all inf".into(),
        Ray::new_unchecked(Vec3::splat(INF), Vec3::splat(-INF), -INF, INF),
    ));
    v.push((
        "NaN origin, zero direction".into(),
        Ray::new_unchecked(Vec3::new(NAN, 0.0, 0.0), Vec3::ZERO, 0.0, INF),
    ));
    v.push((
        "inf origin, NaN direction, NaN bounds".into(),
        Ray::new_unchecked(Vec3::new(0.0, INF, 0.0), Vec3::new(0.0, 0.0, NAN), NAN, NAN),
    ));
    v
}

/// Valid rays with empty, inverted, degenerate or unusual intervals, aimed
/// at the scene (several exactly at the brute-force hit distance).
fn interval_rays(mesh: &Mesh, c: Vec3, radius: f32) -> Vec<(String, Ray)> {
    let o = c - Vec3::new(0.3, 0.2, 2.0) * radius;
    let d = c - o;
    let t_hit = BruteForce::new(mesh)
        .intersect(&Ray::new(o, d, 0.0, INF).unwrap())
        .map_or(0.5, |h| h.t);
    let intervals = [
        (2.0, 1.0),
        (0.0, 0.0),
        (0.0, -0.0),
        (-0.0, 0.0),
        (-0.0, INF),
        (t_hit, t_hit),
        (0.0, t_hit),
        (0.0, t_hit.next_down()),
        (t_hit, INF),
        (t_hit.next_down(), t_hit),
        (INF, INF),
        (-INF, -INF),
        (INF, -INF),
        (-INF, INF),
        (-1e30, 0.0),
        (-f32::MAX, f32::MAX),
        (f32::from_bits(1), INF),
        (0.0, f32::from_bits(1)),
        (1.0, f32::MAX),
    ];
    intervals
        .iter()
        .map(|&(a, b)| {
            (
                format!("interval ({a:?}, {b:?}]"),
                Ray::new_unchecked(o, d, a, b),
            )
        })
        .collect()
}

/// Rays with negative zeros, tiny (subnormal, flushed to zero: two of
/// them end up zero directions) and huge components, far origins.
fn extreme_rays(c: Vec3, radius: f32) -> Vec<(String, Ray)> {
    let mut v = Vec::new();
    let mut push = |label: &str, o: Vec3, d: Vec3| {
        v.push((label.to_string(), Ray::new_unchecked(o, d, 0.0, INF)));
    };
    let r = radius;
    // Negative zeros in the direction: axis-parallel rays through the
    // centre, from outside, with each sign pattern of the zero components.
    for axis in 0..3 {
        for s in 0..4 {
            for sign in [1.0f32, -1.0] {
                let mut d = Vec3::ZERO;
                d[(axis + 1) % 3] = if s & 1 == 1 { -0.0 } else { 0.0 };
                d[(axis + 2) % 3] = if s & 2 != 0 { -0.0 } else { 0.0 };
                d[axis] = sign;
                let o = c - 2.0 * r * d;
                push(&format!("axis {axis} dir {d:?}"), o, d);
                // The same from the centre (inside).
                push(&format!("axis {axis} dir {d:?} from the centre"), c, d);
            }
        }
    }
    // Negative zeros in the origin.
    push(
        "origin -0.0",
        Vec3::new(-0.0, -0.0, -0.0),
        Vec3::new(0.25, 0.5, 1.0),
    );
    push(
        "origin -0.0, dir -0.0",
        Vec3::new(-0.0, c.y, -0.0),
        Vec3::new(-0.0, 1.0, -0.0),
    );
    // Tiny directions: subnormal components (their reciprocals would
    // overflow to inf) are flushed to zero with their sign by the ray
    // policy, so the first two become zero directions (invalid, never hit)
    // and the third the axis-parallel `(1, 0, -0)`.
    let tiny = f32::from_bits(1);
    push(
        "dir (min subnormal, 0, 0)",
        c - Vec3::X * 2.0 * r,
        Vec3::new(tiny, 0.0, 0.0),
    );
    push(
        "dir subnormal diagonal",
        c - Vec3::splat(2.0 * r),
        Vec3::splat(1e-40),
    );
    push(
        "dir (1, subnormal, -subnormal)",
        c - Vec3::X * 2.0 * r,
        Vec3::new(1.0, tiny, -tiny),
    );
    push("dir 1e-38", c - Vec3::splat(2.0 * r), Vec3::splat(1e-38));
    // Huge directions: products overflow.
    push("dir 1e38", c - Vec3::splat(2.0 * r), Vec3::splat(1e38));
    push(
        "dir f32::MAX",
        c - Vec3::splat(2.0 * r),
        Vec3::splat(f32::MAX),
    );
    push(
        "dir (MAX, -MAX, 1)",
        c + Vec3::new(-2.0, 2.0, 0.0) * r,
        Vec3::new(f32::MAX, -f32::MAX, 1.0),
    );
    push(
        "dir (1e38, 1e-38, 0)",
        c - Vec3::X * 2.0 * r,
        Vec3::new(1e38, 1e-38, 0.0),
    );
    // Far origins aimed at the centre.
    for far in [1e30f32, 1e38, f32::MAX] {
        push(
            &format!("origin x = {far:e}"),
            c + Vec3::X * far,
            Vec3::NEG_X,
        );
        push(&format!("origin x = -{far:e}"), c - Vec3::X * far, Vec3::X);
        let o = c + Vec3::new(far, -far, far);
        push(&format!("origin diagonal {far:e}"), o, c - o);
    }
    v
}

/// Origins exactly on the scene box's faces, edges and corners, with
/// directions lying in the face, pointing in and pointing out.
fn box_face_rays(mesh: &Mesh, rng: &mut u64) -> Vec<(String, Ray)> {
    let mut v = Vec::new();
    if mesh.is_empty() {
        return v;
    }
    let (lo, hi): (Vec3, Vec3) = (mesh.bounds().min.into(), mesh.bounds().max.into());
    let mut f = || {
        *rng = rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*rng >> 40) as f32 / (1u64 << 24) as f32
    };
    for axis in 0..3 {
        for (face_name, face) in [("min", lo[axis]), ("max", hi[axis])] {
            for k in 0..6 {
                let mut o = lo + Vec3::new(f(), f(), f()) * (hi - lo);
                o[axis] = face;
                let mut d = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5);
                let inward = if face_name == "min" { 1.0 } else { -1.0 };
                d[axis] = match k % 3 {
                    0 => {
                        if k < 3 {
                            0.0
                        } else {
                            -0.0
                        }
                    }
                    1 => inward,
                    _ => -inward,
                };
                v.push((
                    format!("on {face_name} face of axis {axis}, kind {k}"),
                    Ray::new_unchecked(o, d, 0.0, INF),
                ));
            }
            // Along an edge of the box: on two faces, moving along the third axis.
            let other = (axis + 1) % 3;
            let third = (axis + 2) % 3;
            for other_face in [lo[other], hi[other]] {
                let mut o = lo - (hi - lo);
                o[axis] = face;
                o[other] = other_face;
                let mut d = Vec3::ZERO;
                d[third] = 1.0;
                v.push((
                    format!("along a box edge, axes {axis}/{other}"),
                    Ray::new_unchecked(o, d, 0.0, INF),
                ));
            }
        }
    }
    // From each corner towards the centre and along the box diagonal.
    for i in 0..8 {
        let o = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let c = 0.5 * (lo + hi);
        v.push((
            format!("from corner {i}"),
            Ray::new_unchecked(o, c - o, 0.0, INF),
        ));
        v.push((
            format!("away from corner {i}"),
            Ray::new_unchecked(o, o - c, 0.0, INF),
        ));
    }
    v
}

/// Origins exactly on kd split planes: every split of every preset's tree
/// (`KdTree::split_planes`) plus the grid values (integers and multiples
/// of 1/16), with directions in the plane (`±0.0` on its axis), crossing
/// it, and along the line where two planes meet.
fn split_plane_rays(mesh: &Mesh, engines: &Engines, rng: &mut u64) -> Vec<(String, Ray)> {
    let mut planes: Vec<(usize, f32)> = engines
        .trees
        .iter()
        .flat_map(|t| t.kd.split_planes())
        .collect();
    for axis in 0..3 {
        for k in 0..=16 {
            planes.push((axis, k as f32 * 0.5));
        }
        planes.push((axis, 1.0 / 16.0));
        planes.push((axis, 7.0 / 16.0));
    }
    planes.sort_by_key(|a| (a.0, a.1.to_bits()));
    planes.dedup();
    let (lo, hi): (Vec3, Vec3) = (mesh.bounds().min.into(), mesh.bounds().max.into());
    let mut f = || {
        *rng = rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*rng >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut v = Vec::new();
    for (n, &(axis, s)) in planes.iter().enumerate() {
        let mut o = lo + Vec3::new(f(), f(), f()) * (hi - lo);
        o[axis] = s;
        // In the plane, with either zero.
        let mut d = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5);
        d[axis] = if n % 2 == 0 { 0.0 } else { -0.0 };
        v.push((
            format!("in split plane {axis} = {s}"),
            Ray::new_unchecked(o, d, 0.0, INF),
        ));
        // Crossing it, from the plane, both ways.
        let mut d = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5);
        d[axis] = 0.5;
        v.push((
            format!("from split plane {axis} = {s}, up"),
            Ray::new_unchecked(o, d, 0.0, INF),
        ));
        d[axis] = -0.5;
        v.push((
            format!("from split plane {axis} = {s}, down"),
            Ray::new_unchecked(o, d, 0.0, INF),
        ));
        // Along the line where it meets an integer plane of the next axis.
        let other = (axis + 1) % 3;
        let mut o2 = o;
        o2[other] = (o[other]).round();
        let mut d = Vec3::ZERO;
        d[(axis + 2) % 3] = if n % 2 == 0 { 1.0 } else { -1.0 };
        d[other] = -0.0;
        v.push((
            format!("along split line {axis} = {s}, {other} = {}", o2[other]),
            Ray::new_unchecked(o2, d, 0.0, INF),
        ));
    }
    v
}

// ---------------------------------------------------------------------------
// Tests
// ---------------------------------------------------------------------------

#[test]
fn invalid_rays_are_refused_and_never_hit() {
    let mut out = Problems::default();
    for (name, mesh) in meshes() {
        let e = Engines::new(&mesh);
        let (c, r) = centre_radius(&mesh);
        let rays = invalid_rays(c, r);
        for (label, ray) in &rays {
            assert!(invalid(ray), "{label}: test ray is meant to be invalid");
        }
        check_rays(name, &mesh, &e, &rays, &mut out);
    }
    out.finish();
}

#[test]
fn empty_inverted_and_odd_intervals() {
    let mut out = Problems::default();
    for (name, mesh) in meshes() {
        let e = Engines::new(&mesh);
        let (c, r) = centre_radius(&mesh);
        check_rays(name, &mesh, &e, &interval_rays(&mesh, c, r), &mut out);
    }
    out.finish();
}

#[test]
fn negative_zeros_tiny_and_huge_components() {
    let mut out = Problems::default();
    for (name, mesh) in meshes() {
        let e = Engines::new(&mesh);
        let (c, r) = centre_radius(&mesh);
        check_rays(name, &mesh, &e, &extreme_rays(c, r), &mut out);
    }
    out.finish();
}

#[test]
fn origins_on_box_faces_edges_and_corners() {
    let mut out = Problems::default();
    let mut rng = 11u64;
    for (name, mesh) in meshes() {
        let e = Engines::new(&mesh);
        check_rays(name, &mesh, &e, &box_face_rays(&mesh, &mut rng), &mut out);
    }
    out.finish();
}

#[test]
fn origins_on_split_planes() {
    let mesh = grid_mesh();
    let e = Engines::new(&mesh);
    let splits: Vec<(usize, f32)> = e.trees.iter().flat_map(|t| t.kd.split_planes()).collect();
    eprintln!("{} split planes read from the trees", splits.len());
    assert!(!splits.is_empty(), "the grid mesh's trees split");
    // The exact sweep splits at vertex coordinates (integers here).
    for t in &e.trees {
        if t.kd.params().exact_below == usize::MAX {
            for (axis, s) in t.kd.split_planes() {
                assert_eq!(
                    s.fract(),
                    0.0,
                    "{}: split {axis} = {s} not on the grid",
                    t.name
                );
            }
        }
    }
    let mut rng = 12u64;
    let mut out = Problems::default();
    check_rays(
        "grid",
        &mesh,
        &e,
        &split_plane_rays(&mesh, &e, &mut rng),
        &mut out,
    );
    out.finish();
}

/// The stream API with no rays, and with every tail length of a run of
/// invalid rays, into slots pre-filled with hits that must be overwritten;
/// both layouts.
#[test]
fn stream_api_empty_and_all_invalid() {
    let mesh = unit_box();
    let engines = Engines::new(&mesh);
    for t in &engines.trees {
        let paths: [(&str, &dyn PacketQuery); 2] = [("kd", &t.kd), ("naive", &t.naive)];
        for (layout, e) in paths {
            let mut none: Vec<Option<Hit>> = vec![];
            e.intersect_rays(&[], &mut none);
            e.occluded_rays(&[], &mut []);
            let bad: Vec<Ray> = invalid_rays(Vec3::ZERO, 1.0)
                .into_iter()
                .map(|(_, r)| r)
                .collect();
            for n in 0..9 {
                let mut hits = vec![
                    Some(Hit {
                        t: 1.0,
                        prim: 7,
                        u: 0.0,
                        v: 0.0
                    });
                    n
                ];
                let mut occ = vec![true; n];
                e.intersect_rays(&bad[..n], &mut hits);
                e.occluded_rays(&bad[..n], &mut occ);
                assert!(hits.iter().all(|h| h.is_none()), "{}/{layout}: {n}", t.name);
                assert!(occ.iter().all(|o| !o), "{}/{layout}: {n}", t.name);
            }
        }
    }
}

/// The ray policy's flush of subnormal direction components is applied
/// identically by every constructor (`Ray::new`, `Ray::new_unchecked`,
/// `RayPacket4::from_soa` and `from_soa_unchecked`, `from_lanes`/`from_rays` of such rays), with the
/// sign kept, so the traversal (`1 / d = ±inf`) and the triangle test
/// (`d = ±0`) see the same ray; normal components are untouched.
#[test]
fn subnormal_direction_components_are_flushed_on_every_path() {
    let tiny = f32::from_bits(1);
    let below_normal = f32::MIN_POSITIVE.next_down();
    let cases = [
        (Vec3::new(1.0, tiny, -tiny), Vec3::new(1.0, 0.0, -0.0)),
        (
            Vec3::new(-1e-40, -2.0, below_normal),
            Vec3::new(-0.0, -2.0, 0.0),
        ),
        (
            Vec3::new(f32::MIN_POSITIVE, -f32::MIN_POSITIVE, 1.0),
            Vec3::new(f32::MIN_POSITIVE, -f32::MIN_POSITIVE, 1.0),
        ),
    ];
    let o = Vec3::new(0.5, -0.25, 3.0);
    for (d, want) in cases {
        let checked = Ray::new(o, d, 0.0, INF).unwrap();
        let unchecked = Ray::new_unchecked(o, d, 0.0, INF);
        let arrays = (
            [[o.x; 4], [o.y; 4], [o.z; 4]],
            [[d.x; 4], [d.y; 4], [d.z; 4]],
            [0.0; 4],
            [INF; 4],
        );
        let soa = RayPacket4::from_soa(arrays.0, arrays.1, arrays.2, arrays.3, 0b1111).unwrap();
        let soa_unchecked =
            RayPacket4::from_soa_unchecked(arrays.0, arrays.1, arrays.2, arrays.3, 0b1111);
        assert_eq!(vbits(checked.dir()), vbits(want), "{d:?}");
        assert_eq!(ray_bits(&checked), ray_bits(&unchecked), "{d:?}");
        for i in 0..4 {
            let lane = soa.ray(i).unwrap();
            assert_eq!(ray_bits(&lane), ray_bits(&checked), "{d:?} lane {i}");
            let lane = soa_unchecked.ray(i).unwrap();
            assert_eq!(ray_bits(&lane), ray_bits(&checked), "{d:?} lane {i}");
            let p = RayPacket4::from_rays(&[checked; 4]).ray(i).unwrap();
            assert_eq!(ray_bits(&p), ray_bits(&checked), "{d:?} lane {i}");
        }
        for a in 0..3 {
            assert_eq!(
                checked.inv_dir()[a].to_bits(),
                (1.0 / want[a]).to_bits(),
                "{d:?}"
            );
        }
    }
    // Zero after the flush: refused by `Ray::new`, never hits unchecked.
    let d = Vec3::new(1e-40, -tiny, 0.0);
    assert_eq!(Ray::new(o, d, 0.0, INF), Err(RayError::ZeroDirection));
    let mesh = unit_box();
    let r = Ray::new_unchecked(Vec3::ZERO, d, 0.0, INF);
    let report = agree(&mesh, &[r]);
    report.assert_ok("zero after the flush");
    assert_eq!(report.expected[0], Answer::NONE);
}

// ---------------------------------------------------------------------------
// Regression tests: minimal reproductions of what the checks above found
// ---------------------------------------------------------------------------

/// `t_max` set exactly to the distance of a hit on the scene box's
/// boundary (here the flat box of one triangle in `z = 0`; found on the
/// grid mesh's `z = 0` face). `t_max` is inclusive, so brute force hits;
/// the kd root slab clips the interval to `t_max` and rejects it when the
/// entry distance rounds one ulp above, before any slack is applied. 22 of
/// 163 such rays at this triangle were lost, on every path and preset.
#[test]
fn t_max_at_a_hit_on_the_scene_box_keeps_the_hit() {
    let mesh = Mesh::new(
        vec![
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let (o, d) = (Vec3::new(0.1, 0.1, -0.4), Vec3::new(0.1, 0.1, 0.3));
    let full = Ray::new(o, d, 0.0, INF).unwrap();
    let hit = BruteForce::new(&mesh).intersect(&full).unwrap();
    assert_eq!(hit.t, 1.333_333_3);
    let ray = Ray::new(o, d, 0.0, hit.t).unwrap();
    let report = agree(&mesh, &[ray]);
    report.assert_ok("t_max at the hit");
    assert_eq!(report.hit(0), Some(hit));
}

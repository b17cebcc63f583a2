//! Shared generators for the integration tests: meshes that stress the
//! kd-tree (shared vertices and edges, axis-aligned and coplanar triangles,
//! degenerate and duplicate triangles) and rays that stress the traversal
//! (exact-zero direction components, origins on split planes and box faces,
//! aims at vertices and edge midpoints, intervals ending exactly at a hit).
//!
//! Meshes and rays are generated as *recipes* (plain data with proptest
//! shrinking) and materialised against the mesh in the test body. Every
//! `Debug` print is a Rust literal that reproduces the case exactly: `f32`
//! values print with `{:?}`, which round-trips bit for bit.
//!
//! Every suite compares engines through one harness, [`harness`]
//! ([`Engines`], [`agree`], [`Report`]).

#![allow(dead_code)] // each test crate uses a different part of this module

pub mod harness;
pub mod scenes;

#[allow(unused_imports)] // as dead_code above
pub use harness::{Answer, Engines, Placements, Reference, Report, agree};

use glam::Vec3;
use packtrace::{BruteForce, Hit, Mesh, Ray, RayQuery};
use proptest::prelude::*;
use proptest::sample::Index;
use std::fmt;

// ---------------------------------------------------------------------------
// Meshes
// ---------------------------------------------------------------------------

/// Coordinates of the vertex grid. Splits sit at triangle box edges, so
/// these values are also the split planes rays are started on. `-0.0` is
/// included on purpose (equal to `0.0`, different sign bit).
pub const GRID: [f32; 10] = [-2.0, -1.0, -0.5, -0.0, 0.0, 0.25, 0.5, 1.0, 1.5, 3.0];

/// A mesh as positions and index triples, printed as a Rust literal.
#[derive(Clone, PartialEq)]
pub struct MeshSpec {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl MeshSpec {
    /// The validated mesh (every generator produces finite, in-range data).
    pub fn mesh(&self) -> Mesh {
        Mesh::new(self.positions.clone(), self.triangles.clone()).expect("generated mesh is valid")
    }
}

impl fmt::Debug for MeshSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "MeshSpec {{ // {} triangles", self.triangles.len())?;
        writeln!(f, "    positions: vec![")?;
        for p in &self.positions {
            writeln!(f, "        {},", vec3_literal(*p))?;
        }
        writeln!(f, "    ],")?;
        writeln!(f, "    triangles: vec!{:?},", self.triangles)?;
        write!(f, "}}")
    }
}

/// `Vec3::new(..)` with exact `f32` literals.
pub fn vec3_literal(p: Vec3) -> String {
    format!("Vec3::new({:?}f32, {:?}f32, {:?}f32)", p.x, p.y, p.z)
}

/// A ray as a Rust literal, with the bit patterns of every field.
pub fn ray_literal(r: &Ray) -> String {
    let bits = |v: Vec3| {
        format!(
            "[{:#010x}, {:#010x}, {:#010x}]",
            v.x.to_bits(),
            v.y.to_bits(),
            v.z.to_bits()
        )
    };
    format!(
        "Ray::new_unchecked({}, {}, {:?}f32, {:?}f32) /* origin bits {}, dir bits {}, t_min {:#010x}, t_max {:#010x} */",
        vec3_literal(r.origin()),
        vec3_literal(r.dir()),
        r.t_min(),
        r.t_max(),
        bits(r.origin()),
        bits(r.dir()),
        r.t_min().to_bits(),
        r.t_max().to_bits()
    )
}

/// One coordinate: mostly grid values (so coincident vertices, shared
/// edges and axis-aligned triangles are common), some arbitrary floats.
pub fn coord() -> BoxedStrategy<f32> {
    prop_oneof![
        8 => prop::sample::select(&GRID[..]),
        2 => -4.0f32..4.0,
        1 => -1.0e-3f32..1.0e-3,
        1 => -1.0e4f32..1.0e4,
    ]
    .boxed()
}

pub fn grid_coord() -> impl Strategy<Value = f32> {
    prop::sample::select(&GRID[..])
}

pub fn point() -> BoxedStrategy<Vec3> {
    [coord(), coord(), coord()]
        .prop_map(|[x, y, z]| Vec3::new(x, y, z))
        .boxed()
}

pub fn grid_point() -> BoxedStrategy<Vec3> {
    [grid_coord(), grid_coord(), grid_coord()]
        .prop_map(|[x, y, z]| Vec3::new(x, y, z))
        .boxed()
}

fn tri_indices(n_pos: usize, idx: Vec<[Index; 3]>) -> Vec<[u32; 3]> {
    idx.iter()
        .map(|t| t.map(|i| i.index(n_pos) as u32))
        .collect()
}

/// Triangle soup over a shared pool of points: 1..200 triangles.
pub fn soup() -> BoxedStrategy<MeshSpec> {
    (
        prop::collection::vec(prop_oneof![3 => grid_point(), 1 => point()], 3..48),
        prop::collection::vec(prop::array::uniform3(any::<Index>()), 1..200),
    )
        .prop_map(|(positions, idx)| MeshSpec {
            triangles: tri_indices(positions.len(), idx),
            positions,
        })
        .boxed()
}

/// Heightfield on a regular grid with shared vertices, its height axis any
/// of x, y, z; heights are grid values, so flat (axis-aligned, coplanar)
/// patches are common. Each cell's diagonal is chosen at random.
pub fn heightfield() -> BoxedStrategy<MeshSpec> {
    (1usize..8, 1usize..8)
        .prop_flat_map(|(nx, ny)| {
            (
                Just((nx, ny)),
                prop::collection::vec(grid_coord(), (nx + 1) * (ny + 1)),
                prop::collection::vec(any::<bool>(), nx * ny),
                0usize..3,
                prop::sample::select(&[0.25f32, 0.5, 1.0][..]),
            )
        })
        .prop_map(|((nx, ny), heights, diag, axis, step)| {
            let mut positions = Vec::new();
            for j in 0..=ny {
                for i in 0..=nx {
                    let (a, b, h) = (
                        i as f32 * step - 1.0,
                        j as f32 * step - 1.0,
                        heights[j * (nx + 1) + i],
                    );
                    positions.push(match axis {
                        0 => Vec3::new(h, a, b),
                        1 => Vec3::new(a, h, b),
                        _ => Vec3::new(a, b, h),
                    });
                }
            }
            let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
            let mut triangles = Vec::new();
            for j in 0..ny {
                for i in 0..nx {
                    let (p00, p10, p01, p11) =
                        (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
                    if diag[j * nx + i] {
                        triangles.push([p00, p10, p11]);
                        triangles.push([p00, p11, p01]);
                    } else {
                        triangles.push([p00, p10, p01]);
                        triangles.push([p10, p11, p01]);
                    }
                }
            }
            MeshSpec {
                positions,
                triangles,
            }
        })
        .boxed()
}

/// Triangles of which many are degenerate: repeated vertices, all three
/// equal, exactly collinear corners (`p, p + d, p + 2d` on the grid), mixed
/// with ordinary triangles (the index of a degenerate triangle must never be
/// reported, and the others must still be found).
pub fn with_degenerates() -> BoxedStrategy<MeshSpec> {
    let kind = prop_oneof![
        (grid_point(), grid_point(), grid_point()).prop_map(|(a, b, c)| [a, b, c]),
        (grid_point(), grid_point()).prop_map(|(a, b)| [a, a, b]),
        (grid_point(), grid_point()).prop_map(|(a, b)| [a, b, b]),
        grid_point().prop_map(|a| [a, a, a]),
        (grid_point(), grid_point()).prop_map(|(p, d)| [p, p + d, p + 2.0 * d]),
        (grid_point(), grid_point()).prop_map(|(p, d)| [p + 2.0 * d, p, p + d]),
        (point(), point()).prop_map(|(p, d)| [p, p + d, p + 0.5 * d]),
    ];
    prop::collection::vec(kind, 1..120)
        .prop_map(|tris| {
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            for t in tris {
                let base = positions.len() as u32;
                positions.extend_from_slice(&t);
                triangles.push([base, base + 1, base + 2]);
            }
            MeshSpec {
                positions,
                triangles,
            }
        })
        .boxed()
}

/// A soup plus coincident duplicates: same indices, rotated or reversed
/// corners, or the same positions under new vertex indices.
pub fn with_duplicates() -> BoxedStrategy<MeshSpec> {
    (
        soup(),
        prop::collection::vec((any::<Index>(), 0u8..4), 1..60),
    )
        .prop_map(|(mut m, dups)| {
            for (i, how) in dups {
                let t = m.triangles[i.index(m.triangles.len())];
                let new = match how {
                    0 => t,
                    1 => [t[1], t[2], t[0]],
                    2 => [t[2], t[1], t[0]],
                    _ => {
                        let base = m.positions.len() as u32;
                        for k in t {
                            m.positions.push(m.positions[k as usize]);
                        }
                        [base, base + 1, base + 2]
                    }
                };
                // Interleave: a duplicate may come before its original.
                let at = (i.index(m.triangles.len() + 1) * 7) % (m.triangles.len() + 1);
                m.triangles.insert(at, new);
            }
            m
        })
        .boxed()
}

/// All triangles in one plane: an axis-aligned plane at a grid value, or a
/// general plane spanned by two grid vectors from a grid point.
pub fn coplanar() -> BoxedStrategy<MeshSpec> {
    let axis_aligned = (
        0usize..3,
        grid_coord(),
        prop::collection::vec([grid_coord(), grid_coord()], 3..40),
        prop::collection::vec(prop::array::uniform3(any::<Index>()), 1..150),
    )
        .prop_map(|(axis, c, uv, idx)| {
            let positions: Vec<Vec3> = uv
                .iter()
                .map(|[a, b]| match axis {
                    0 => Vec3::new(c, *a, *b),
                    1 => Vec3::new(*a, c, *b),
                    _ => Vec3::new(*a, *b, c),
                })
                .collect();
            MeshSpec {
                triangles: tri_indices(positions.len(), idx),
                positions,
            }
        });
    let general = (
        grid_point(),
        grid_point(),
        grid_point(),
        prop::collection::vec([grid_coord(), grid_coord()], 3..40),
        prop::collection::vec(prop::array::uniform3(any::<Index>()), 1..150),
    )
        .prop_map(|(o, e1, e2, st, idx)| {
            let positions: Vec<Vec3> = st.iter().map(|[s, t]| o + *s * e1 + *t * e2).collect();
            MeshSpec {
                triangles: tri_indices(positions.len(), idx),
                positions,
            }
        });
    prop_oneof![axis_aligned, general].boxed()
}

/// Any of the generators above.
pub fn any_mesh() -> BoxedStrategy<MeshSpec> {
    prop_oneof![
        3 => soup(),
        2 => heightfield(),
        2 => with_degenerates(),
        2 => with_duplicates(),
        2 => coplanar(),
    ]
    .boxed()
}

// ---------------------------------------------------------------------------
// Rays
// ---------------------------------------------------------------------------

/// Where a ray starts.
#[derive(Clone, Debug)]
pub enum Origin {
    /// Anywhere around the scene.
    Free(Vec3),
    /// On the plane `axis = c` of a triangle corner coordinate `c` (box
    /// edges, hence exact-sweep split candidates).
    OnCornerPlane {
        base: Vec3,
        tri: Index,
        corner: usize,
        axis: usize,
    },
    /// On a root bin boundary of the binned sweep (`lo + (hi - lo) * k/128`).
    OnBinPlane { base: Vec3, axis: usize, k: u32 },
    /// On the split plane of an interior node of the built trees
    /// (`KdTree::split_planes`, node order: mostly deep nodes, and the
    /// clipped cells' planes of the presets that clip), at `min + f *
    /// (max - min)` of the scene box on the other axes. Materialised by
    /// [`origin_point_on`] against the trees' planes; without planes (a
    /// suite that builds no tree first) it is [`Origin::Inside`].
    OnSplitPlane { frac: [f32; 3], plane: Index },
    /// On a face of the scene box.
    OnBoxFace { base: Vec3, axis: usize, max: bool },
    /// Inside the scene box: `min + f * (max - min)` per axis.
    Inside([f32; 3]),
    /// Exactly at a triangle corner (on the surface).
    AtCorner { tri: Index, corner: usize },
}

/// Where a ray points.
#[derive(Clone, Debug)]
pub enum Aim {
    Dir(Vec3),
    AtCorner { tri: Index, corner: usize },
    AtEdgeMidpoint { tri: Index, edge: usize },
    AtCentroid { tri: Index },
}

/// The ray's `(t_min, t_max]`.
#[derive(Clone, Debug)]
pub enum Interval {
    Full,
    /// `t_max` = the distance of the closest hit (inclusive end).
    TMaxAtHit,
    /// `t_min` = the distance of the closest hit (exclusive start).
    TMinAtHit,
    /// `t_max` just below the closest hit.
    TMaxBelowHit,
    Finite(f32),
    NegativeTMin,
    Empty,
}

#[derive(Clone, Debug)]
pub struct RaySpec {
    pub origin: Origin,
    pub aim: Aim,
    pub interval: Interval,
    /// Direction components forced to zero (bit per axis).
    pub zero: u8,
    /// Zero direction components made `-0.0` (bit per axis).
    pub neg_zero: u8,
}

pub fn dir_component() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => prop::sample::select(&[-1.0f32, -0.5, -0.0, 0.0, 0.25, 0.5, 1.0, 2.0][..]),
        4 => -1.0f32..1.0,
        1 => -1.0e-6f32..1.0e-6,
        1 => -1.0e5f32..1.0e5,
    ]
}

pub fn direction() -> BoxedStrategy<Vec3> {
    [dir_component(), dir_component(), dir_component()]
        .prop_map(|[x, y, z]| Vec3::new(x, y, z))
        .boxed()
}

fn free_origin() -> impl Strategy<Value = Vec3> {
    let c = prop_oneof![
        3 => prop::sample::select(&GRID[..]),
        3 => -6.0f32..6.0,
        1 => -1.0e3f32..1.0e3,
    ];
    [c.clone(), c.clone(), c].prop_map(|[x, y, z]| Vec3::new(x, y, z))
}

pub fn origin() -> BoxedStrategy<Origin> {
    let frac = prop_oneof![
        prop::sample::select(&[0.0f32, 0.25, 0.5, 0.75, 1.0][..]),
        0.0f32..=1.0,
    ];
    prop_oneof![
        3 => free_origin().prop_map(Origin::Free),
        3 => (free_origin(), any::<Index>(), 0usize..3, 0usize..3)
            .prop_map(|(base, tri, corner, axis)| Origin::OnCornerPlane { base, tri, corner, axis }),
        1 => (free_origin(), 0usize..3, 1u32..128).prop_map(|(base, axis, k)| Origin::OnBinPlane { base, axis, k }),
        3 => ([frac.clone(), frac.clone(), frac.clone()], any::<Index>())
            .prop_map(|(frac, plane)| Origin::OnSplitPlane { frac, plane }),
        2 => (free_origin(), 0usize..3, any::<bool>()).prop_map(|(base, axis, max)| Origin::OnBoxFace { base, axis, max }),
        2 => [frac.clone(), frac.clone(), frac].prop_map(Origin::Inside),
        1 => (any::<Index>(), 0usize..3).prop_map(|(tri, corner)| Origin::AtCorner { tri, corner }),
    ]
    .boxed()
}

pub fn aim() -> BoxedStrategy<Aim> {
    prop_oneof![
        4 => direction().prop_map(Aim::Dir),
        2 => (any::<Index>(), 0usize..3).prop_map(|(tri, corner)| Aim::AtCorner { tri, corner }),
        2 => (any::<Index>(), 0usize..3).prop_map(|(tri, edge)| Aim::AtEdgeMidpoint { tri, edge }),
        1 => any::<Index>().prop_map(|tri| Aim::AtCentroid { tri }),
    ]
    .boxed()
}

/// Intervals that do not depend on a hit distance.
pub fn plain_interval() -> BoxedStrategy<Interval> {
    prop_oneof![
        6 => Just(Interval::Full),
        1 => (0.0f32..8.0).prop_map(Interval::Finite),
        1 => Just(Interval::NegativeTMin),
        1 => Just(Interval::Empty),
    ]
    .boxed()
}

/// Intervals that end exactly at the closest hit, or just before it.
pub fn ends_at_hit_interval() -> BoxedStrategy<Interval> {
    prop_oneof![2 => Just(Interval::TMaxAtHit), 1 => Just(Interval::TMaxBelowHit)].boxed()
}

/// Intervals that start or end exactly at (or just before) the closest hit.
pub fn at_hit_interval() -> BoxedStrategy<Interval> {
    prop_oneof![
        2 => Just(Interval::TMaxAtHit),
        2 => Just(Interval::TMinAtHit),
        1 => Just(Interval::TMaxBelowHit),
    ]
    .boxed()
}

pub fn interval() -> BoxedStrategy<Interval> {
    prop_oneof![3 => plain_interval(), 1 => at_hit_interval()].boxed()
}

/// Zero-component masks: usually none, often one or two axes (axis-parallel
/// rays when two are zero).
pub fn zero_mask() -> impl Strategy<Value = u8> {
    prop_oneof![4 => Just(0u8), 3 => 0u8..8]
}

pub fn ray_spec_with(
    interval: impl Strategy<Value = Interval> + 'static,
) -> BoxedStrategy<RaySpec> {
    (origin(), aim(), interval, zero_mask(), 0u8..8)
        .prop_map(|(origin, aim, interval, zero, neg_zero)| RaySpec {
            origin,
            aim,
            interval,
            zero,
            neg_zero,
        })
        .boxed()
}

/// Rays with intervals of every kind.
pub fn ray_spec() -> BoxedStrategy<RaySpec> {
    ray_spec_with(interval()).boxed()
}

/// Rays whose interval does not depend on a hit distance.
pub fn plain_ray_spec() -> BoxedStrategy<RaySpec> {
    ray_spec_with(plain_interval()).boxed()
}

/// Rays whose interval ends at (or just before) the closest hit.
pub fn ends_at_hit_ray_spec() -> BoxedStrategy<RaySpec> {
    ray_spec_with(ends_at_hit_interval())
}

/// Rays whose interval starts at the closest hit.
pub fn starts_at_hit_ray_spec() -> BoxedStrategy<RaySpec> {
    ray_spec_with(Just(Interval::TMinAtHit))
}

/// Rays whose interval starts or ends at the closest hit.
pub fn at_hit_ray_spec() -> BoxedStrategy<RaySpec> {
    ray_spec_with(at_hit_interval()).boxed()
}

/// Corner `k` of triangle `tri` (an `Index`), if the mesh has triangles.
fn corner(mesh: &Mesh, tri: &Index, k: usize) -> Option<Vec3> {
    (!mesh.is_empty()).then(|| mesh.corners(tri.index(mesh.triangle_count()))[k % 3])
}

/// The scene box as `(lo, hi)`; a unit box around the origin when empty.
pub fn scene_box(mesh: &Mesh) -> (Vec3, Vec3) {
    if mesh.is_empty() {
        (Vec3::splat(-1.0), Vec3::splat(1.0))
    } else {
        (mesh.bounds().min.into(), mesh.bounds().max.into())
    }
}

/// The split planes `(axis, position)` of every tree, for
/// [`Origin::OnSplitPlane`].
pub fn split_planes(trees: &[harness::Tree]) -> Vec<(usize, f32)> {
    trees.iter().flat_map(|t| t.kd.split_planes()).collect()
}

/// Where the recipe starts, without the trees' split planes.
pub fn origin_point(o: &Origin, mesh: &Mesh) -> Vec3 {
    origin_point_on(o, mesh, &[])
}

/// Where the recipe starts; [`Origin::OnSplitPlane`] picks one of
/// `planes`.
pub fn origin_point_on(o: &Origin, mesh: &Mesh, planes: &[(usize, f32)]) -> Vec3 {
    let (lo, hi) = scene_box(mesh);
    match o {
        Origin::Free(p) => *p,
        Origin::OnCornerPlane {
            base,
            tri,
            corner: k,
            axis,
        } => {
            let mut p = *base;
            if let Some(c) = corner(mesh, tri, *k) {
                p[*axis] = c[*axis];
            }
            p
        }
        Origin::OnBinPlane { base, axis, k } => {
            let mut p = *base;
            p[*axis] = lo[*axis] + (hi[*axis] - lo[*axis]) * (*k as f32 / 128.0);
            p
        }
        Origin::OnBoxFace { base, axis, max } => {
            let mut p = *base;
            p[*axis] = if *max { hi[*axis] } else { lo[*axis] };
            p
        }
        Origin::Inside(f) => lo + Vec3::from(*f) * (hi - lo),
        Origin::OnSplitPlane { frac, plane } => {
            let mut p = lo + Vec3::from(*frac) * (hi - lo);
            if !planes.is_empty() {
                let (axis, split) = planes[plane.index(planes.len())];
                p[axis] = split;
            }
            p
        }
        Origin::AtCorner { tri, corner: k } => corner(mesh, tri, *k).unwrap_or(Vec3::ZERO),
    }
}

fn target(a: &Aim, mesh: &Mesh, origin: Vec3) -> Vec3 {
    match a {
        Aim::Dir(d) => *d,
        Aim::AtCorner { tri, corner: k } => corner(mesh, tri, *k).map_or(Vec3::X, |c| c - origin),
        Aim::AtEdgeMidpoint { tri, edge } => {
            match (corner(mesh, tri, *edge), corner(mesh, tri, *edge + 1)) {
                (Some(a), Some(b)) => (a + b) * 0.5 - origin,
                _ => Vec3::Y,
            }
        }
        Aim::AtCentroid { tri } => match (
            corner(mesh, tri, 0),
            corner(mesh, tri, 1),
            corner(mesh, tri, 2),
        ) {
            (Some(a), Some(b), Some(c)) => (a + b + c) / 3.0 - origin,
            _ => Vec3::Z,
        },
    }
}

/// Apply the zero masks: forced zeros, then the sign of every zero.
pub fn apply_zero_masks(mut d: Vec3, zero: u8, neg_zero: u8) -> Vec3 {
    for a in 0..3 {
        if zero >> a & 1 == 1 {
            d[a] = 0.0;
        }
        if d[a] == 0.0 {
            d[a] = if neg_zero >> a & 1 == 1 { -0.0 } else { 0.0 };
        }
    }
    d
}

/// A valid ray for the recipe (a fallback direction replaces a zero or
/// non-finite one, so every recipe yields a ray).
pub fn make_ray(s: &RaySpec, mesh: &Mesh) -> Ray {
    make_ray_on(s, mesh, &[])
}

/// [`make_ray`], with [`Origin::OnSplitPlane`] on one of `planes`.
pub fn make_ray_on(s: &RaySpec, mesh: &Mesh, planes: &[(usize, f32)]) -> Ray {
    let origin = origin_point_on(&s.origin, mesh, planes);
    let mut dir = apply_zero_masks(target(&s.aim, mesh, origin), s.zero, s.neg_zero);
    if dir == Vec3::ZERO || !dir.is_finite() {
        dir = apply_zero_masks(Vec3::new(0.5, -0.25, 1.0), s.zero & 0b011, s.neg_zero);
    }
    let origin = if origin.is_finite() {
        origin
    } else {
        Vec3::ZERO
    };
    with_interval(origin, dir, &s.interval, mesh)
}

/// The ray `origin + t dir` with the recipe's interval; the `*Hit`
/// intervals are placed at the brute-force closest hit of the full ray.
pub fn with_interval(origin: Vec3, dir: Vec3, interval: &Interval, mesh: &Mesh) -> Ray {
    let full = Ray::new(origin, dir, 0.0, f32::INFINITY).expect("valid ray");
    let hit = || BruteForce::new(mesh).intersect(&full).map(|h| h.t);
    let (t_min, t_max) = match interval {
        Interval::Full => (0.0, f32::INFINITY),
        Interval::TMaxAtHit => (0.0, hit().unwrap_or(f32::INFINITY)),
        Interval::TMinAtHit => (hit().unwrap_or(0.0), f32::INFINITY),
        Interval::TMaxBelowHit => (0.0, hit().map_or(1.0, |t| t.next_down())),
        Interval::Finite(t) => (0.0, *t),
        Interval::NegativeTMin => (-1.0e3, f32::INFINITY),
        Interval::Empty => (1.0, 1.0),
    };
    Ray::new(origin, dir, t_min, t_max).expect("valid ray")
}

// ---------------------------------------------------------------------------
// Comparison helpers (the comparison itself: `harness`)
// ---------------------------------------------------------------------------

/// A hit as bit patterns, so that `-0.0 != 0.0` and NaN compares equal to
/// itself: "exactly equal" means equal bits. The one hit-as-bits helper of
/// the tests.
pub fn hit_bits(h: Option<Hit>) -> Option<(u32, u32, u32, u32)> {
    h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
}

/// Proptest case count: `PROPTEST_CASES` if set, else `default`.
pub fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// Proptest configuration with `cases(default)` cases; failures are not
/// persisted (the minimal cases found are kept as explicit tests instead).
pub fn config(default: u32) -> ProptestConfig {
    ProptestConfig {
        cases: cases(default),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Append the 12 triangles of the box `[lo, hi]` (outward winding).
pub fn box_triangles(lo: Vec3, hi: Vec3, positions: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>) {
    let base = positions.len() as u32;
    for i in 0..8 {
        positions.push(Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        ));
    }
    let quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    for q in quads {
        triangles.push([base + q[0], base + q[1], base + q[2]]);
        triangles.push([base + q[0], base + q[2], base + q[3]]);
    }
}

/// The closed box `[lo, hi]` as a mesh of 12 triangles.
pub fn box_mesh(lo: Vec3, hi: Vec3) -> Mesh {
    let (mut p, mut t) = (Vec::new(), Vec::new());
    box_triangles(lo, hi, &mut p, &mut t);
    Mesh::new(p, t).expect("a box is a valid mesh")
}

/// Tiny deterministic generator (SplitMix64) for the non-proptest tests.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[0, 1)`.
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    pub fn coin(&mut self) -> bool {
        self.next_u64() & 1 == 1
    }
    /// A uniformly distributed unit vector.
    pub fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            if l > 1.0e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// Triage text for a mismatch: for each hit, where its `t` lies relative to
/// the span of its triangle's box along the ray. A `t` outside that span
/// means the triangle test's rounding put the hit where no cell of the
/// triangle is (the known limit of exact kd == brute agreement); a `t`
/// inside it points at the traversal.
pub fn diagnose(mesh: &Mesh, ray: &Ray, hits: &[(&str, Option<Hit>)]) -> String {
    let line = Ray::new_unchecked(ray.origin(), ray.dir(), f32::NEG_INFINITY, f32::INFINITY);
    let mut out = String::new();
    for (name, h) in hits {
        let Some(h) = h else { continue };
        let span = mesh.triangle_bounds(h.prim as usize).intersect(&line);
        let verdict = match span {
            Some((a, b)) if h.t >= a && h.t <= b => "inside its triangle's box span".to_string(),
            Some((a, b)) => {
                format!("OUTSIDE its triangle's box span [{a:?}, {b:?}] (triangle-test rounding)")
            }
            None => {
                "its triangle's box is not on the ray's line (triangle-test rounding)".to_string()
            }
        };
        out += &format!("\n  {name}: prim {} at t = {:?}: {verdict}", h.prim, h.t);
    }
    out
}

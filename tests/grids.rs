//! The grids where a grid is fragile: rays along cell boundaries (in cell
//! faces and along cell edges), origins on cell faces, edges and corners,
//! inside and outside the grid, rays through cell corners, and a scene
//! far from the origin whose pad spans cells; each through the uniform and
//! the two-level grid on every path of the harness (scalar, packets of 4
//! and 8 in every lane placement, streams) against brute force bit for
//! bit. The generic property suite over random scenes is
//! `tests/structures.rs`, which runs the grids too.

mod common;

use common::{Engines, Placements};
use glam::Vec3;
use packtrace::grid::{Grid, GridParams, HGrid, HGridParams, Overlap};
use packtrace::{Mesh, Ray};

/// A deterministic hash in `0..1`.
fn unit(i: u32) -> f32 {
    let mut x = i.wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
    x ^= x >> 15;
    x = x.wrapping_mul(0x2C1B_3C6D);
    x ^= x >> 12;
    (x >> 8) as f32 / (1u32 << 24) as f32
}

/// 128 triangles with corners on the half-unit lattice of `[0, 8]^3`
/// (many of them lying in cell faces and along cell edges), whose box is
/// exactly `[0, 8]^3`: with density 4 the grid is 8 x 8 x 8 unit cells.
fn lattice_mesh() -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let snap = |x: f32| (x * 16.0).floor() * 0.5;
    for t in 0..128u32 {
        let base = positions.len() as u32;
        let c = Vec3::new(
            snap(unit(6 * t)),
            snap(unit(6 * t + 1)),
            snap(unit(6 * t + 2)),
        );
        for k in 0..3u32 {
            let d = Vec3::new(
                snap(unit(9 * t + 3 * k + 100)) * 0.25,
                snap(unit(9 * t + 3 * k + 101)) * 0.25,
                snap(unit(9 * t + 3 * k + 102)) * 0.25,
            );
            // Flatten some triangles into the cell faces x, y or z = const.
            let mut p = (c + d).min(Vec3::splat(8.0));
            if t % 4 < 3 {
                p[(t % 4) as usize] = c[(t % 4) as usize];
            }
            positions.push(p);
        }
        triangles.push([base, base + 1, base + 2]);
    }
    // Pin the box to [0, 8]^3.
    let base = positions.len() as u32;
    positions.extend([
        Vec3::ZERO,
        Vec3::X,
        Vec3::Y,
        Vec3::splat(8.0),
        Vec3::new(7.0, 8.0, 8.0),
        Vec3::new(8.0, 7.0, 8.0),
    ]);
    triangles.push([base, base + 1, base + 2]);
    triangles.push([base + 3, base + 4, base + 5]);
    Mesh::new(positions, triangles).unwrap()
}

/// The rays the grid finds hardest, over the lattice `[0, 8]^3`.
fn boundary_rays() -> Vec<Ray> {
    let mut rays = Vec::new();
    let mut push = |o: Vec3, d: Vec3| {
        if let Ok(r) = Ray::new(o, d, 0.0, f32::INFINITY) {
            rays.push(r);
        }
    };
    let axes = [Vec3::X, Vec3::Y, Vec3::Z];
    for i in 0..=8 {
        for j in 0..=8 {
            let (a, b) = (i as f32, j as f32);
            for (k, &ax) in axes.iter().enumerate() {
                // Along a cell edge, from outside, both ways.
                let mut o = [a, b, -1.0];
                o.rotate_right(k);
                let o = Vec3::from(o);
                let o = o - ax * (o.dot(ax) + 1.0);
                push(o, ax);
                push(o + ax * 10.0, -ax);
                // In a cell face, half-way between edges.
                let mut f = [a, b + 0.5, 0.0];
                f.rotate_right(k);
                let f = Vec3::from(f) - ax;
                push(f, ax);
                // From a cell corner inside the grid, diagonally.
                let mut c = [a, b, 4.0];
                c.rotate_right(k);
                push(Vec3::from(c), Vec3::new(1.0, 1.0, 1.0));
                push(Vec3::from(c), Vec3::new(-1.0, 0.5, -0.25));
            }
        }
    }
    // Origins on cell faces with hashed directions, and outside the grid.
    for n in 0..400u32 {
        let face = Vec3::new(
            (unit(3 * n + 7) * 8.0).floor(),
            unit(3 * n + 8) * 8.0,
            unit(3 * n + 9) * 8.0,
        );
        let d = Vec3::new(
            unit(n + 900) - 0.5,
            unit(n + 901) - 0.5,
            unit(n + 902) - 0.5,
        );
        push(face, d);
        push(face + Vec3::new(0.0, -20.0, 0.0), d + Vec3::Y);
        push(Vec3::new(-3.0, 4.0, 4.0), Vec3::new(1.0, d.y, d.z));
    }
    // Through the grid's corners and along its outer faces.
    push(Vec3::splat(-1.0), Vec3::ONE);
    push(Vec3::splat(9.0), -Vec3::ONE);
    push(Vec3::new(-1.0, 0.0, 0.0), Vec3::X);
    push(Vec3::new(-1.0, 8.0, 8.0), Vec3::X);
    push(Vec3::new(4.0, 8.0, -1.0), Vec3::Z);
    rays
}

/// A two-level grid that refines nearly every top cell of the lattice.
fn lattice_hgrid_params() -> HGridParams {
    HGridParams {
        top: GridParams {
            density: 0.1,
            ..GridParams::default()
        },
        refine_above: 2,
        ..HGridParams::default()
    }
}

fn grids(mesh: &Mesh) -> Engines<'_> {
    let mut e = Engines::from_trees(mesh, Vec::new());
    for (name, p) in [
        ("default", GridParams::default()),
        (
            "boxes",
            GridParams {
                overlap: Overlap::Boxes,
                ..GridParams::default()
            },
        ),
        (
            "no-mailbox",
            GridParams {
                mailbox: false,
                ..GridParams::default()
            },
        ),
    ] {
        let g = Grid::build(mesh.clone(), &p).unwrap();
        assert_eq!(g.validate(), Ok(()), "{name}");
        e = e.with_structure(format!("grid/{name}"), g);
    }
    let h = HGrid::build(mesh.clone(), &lattice_hgrid_params()).unwrap();
    assert_eq!(h.validate(), Ok(()));
    e.with_structure("hgrid", h)
}

#[test]
fn the_lattice_grid_has_unit_cells() {
    let g = Grid::build(lattice_mesh(), &GridParams::default()).unwrap();
    assert_eq!(g.dims(), [8, 8, 8]);
    let h = HGrid::build(lattice_mesh(), &lattice_hgrid_params()).unwrap();
    assert!(h.stats().subgrids > 0);
}

#[test]
fn rays_along_cell_boundaries_and_from_cell_faces_equal_brute() {
    let mesh = lattice_mesh();
    let mut e = grids(&mesh);
    e.options.placements = Placements::Cycle;
    let rays = boundary_rays();
    assert!(rays.len() > 2000);
    let report = e.agree(&rays);
    report.assert_ok("grids on cell boundaries");
    let hits = report.expected.iter().filter(|a| a.hit.is_some()).count();
    assert!(hits > 200, "only {hits} of {} rays hit", rays.len());
}

/// Origins 2,000 and 1,000,000 units away: their margin outgrows the
/// build's pad, so the walk also searches one cell, or every cell, around
/// its own.
#[test]
fn far_origins_search_around_their_walk_and_equal_brute() {
    let mesh = lattice_mesh();
    let mut e = grids(&mesh);
    e.options.placements = Placements::Cycle;
    let mut rays = Vec::new();
    for scale in [2.0e3f32, 1.0e6] {
        for n in 0..300u32 {
            let o =
                Vec3::new(unit(n) - 0.5, unit(n + 1) - 0.5, unit(n + 2) - 0.5).normalize() * scale;
            let target = Vec3::new(unit(n + 3), unit(n + 4), unit(n + 5)) * 8.0;
            rays.push(Ray::new(o, target - o, 0.0, f32::INFINITY).unwrap());
        }
    }
    let report = e.agree(&rays);
    report.assert_ok("far origins");
    assert!(report.expected.iter().filter(|a| a.hit.is_some()).count() > 50);
}

/// The same lattice moved far from the origin and scaled down, so the
/// pad (a share of the coordinates' magnitude) is a large part of a cell,
/// and rays from far away must search the cells around their walk.
#[test]
fn a_scene_far_from_the_origin_and_far_origins_equal_brute() {
    let lattice = lattice_mesh();
    let offset = Vec3::new(3.0e4, -2.0e4, 1.0e4);
    let positions = lattice
        .positions()
        .iter()
        .map(|p| *p * 0.01 + offset)
        .collect();
    let mesh = Mesh::new(positions, lattice.triangles().to_vec()).unwrap();
    let mut e = grids(&mesh);
    e.options.placements = Placements::Cycle;
    let near: Vec<Ray> = boundary_rays()
        .iter()
        .map(|r| Ray::new(r.origin() * 0.01 + offset, r.dir(), 0.0, f32::INFINITY).unwrap())
        .collect();
    let far: Vec<Ray> = (0..300u32)
        .map(|n| {
            let o = Vec3::new(unit(n) - 0.5, unit(n + 1) - 0.5, unit(n + 2) - 0.5) * 4.0e6;
            let target = offset + Vec3::new(unit(n + 3), unit(n + 4), unit(n + 5)) * 0.08;
            Ray::new(o, target - o, 0.0, f32::INFINITY).unwrap()
        })
        .collect();
    e.agree(&near).assert_ok("far scene, near rays");
    e.agree(&far).assert_ok("far scene, far origins");
}

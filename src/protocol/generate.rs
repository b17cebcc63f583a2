//! Generated meshes for tests and benchmarks: closed spheres (plain and
//! radially jittered), a scalable field of spheres, the teapot in a
//! stadium, and the Cornell box
//! from its published measurements. All deterministic.
//!
//! ```
//! use packtrace::protocol::generate;
//! let m = generate::from_spec("gen:sphere:1000")?;
//! assert_eq!(m.triangle_count(), generate::sphere(1000).triangle_count());
//! # Ok::<(), packtrace::protocol::generate::SpecError>(())
//! ```

use super::sampling::{hash, unit};
use crate::mesh::Mesh;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use std::io::{self, Write};
use std::path::Path;

/// Why a generated-scene spec (`gen:KIND:N`) cannot be built.
///
/// ```
/// let e = packtrace::protocol::generate::from_spec("gen:cube:10").unwrap_err();
/// assert!(e.to_string().contains("`gen:cube:10`"));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SpecError {
    /// The spec as given.
    pub spec: String,
    /// What is wrong with it.
    pub reason: String,
}

impl std::fmt::Display for SpecError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "scene spec `{}`: {}", self.spec, self.reason)
    }
}

impl std::error::Error for SpecError {}

/// Largest triangle count [`from_spec`] accepts.
///
/// ```
/// assert_eq!(packtrace::protocol::generate::MAX_SPEC_TRIANGLES, 50_000_000);
/// ```
pub const MAX_SPEC_TRIANGLES: usize = 50_000_000;

/// A mesh the generator made: indices in range and vertices finite by
/// construction, so it skips `Mesh::new`'s error path (debug builds check).
fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    Mesh::from_valid(positions, triangles)
}

/// UV-sphere resolution `(stacks, segments)` for about `target` triangles:
/// `2 * segments * (stacks - 1)` triangles, `segments` about `2 * stacks`.
fn uv_dims(target: usize) -> (u32, u32) {
    let stacks = ((1.0 + (1.0 + target as f64).sqrt()) / 2.0)
        .round()
        .max(2.0) as u32;
    let segments = (target as f64 / (2.0 * (stacks - 1) as f64))
        .round()
        .max(3.0) as u32;
    (stacks, segments)
}

/// Unit UV sphere (poles on the y axis) in `f64`: positions and outward
/// (counter-clockwise seen from outside) triangles with shared vertices.
fn uv_sphere(target: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let (stacks, segs) = uv_dims(target);
    let mut pos = Vec::with_capacity(((stacks - 1) * segs + 2) as usize);
    // North pole, rings from north to south, south pole
    pos.push(DVec3::Y);
    for i in 1..stacks {
        let theta = PI * i as f64 / stacks as f64;
        for j in 0..segs {
            let phi = 2.0 * PI * j as f64 / segs as f64;
            let (st, ct) = theta.sin_cos();
            pos.push(DVec3::new(st * phi.cos(), ct, st * phi.sin()));
        }
    }
    let south = pos.len() as u32;
    pos.push(DVec3::NEG_Y);
    let ring = |i: u32, j: u32| 1 + (i - 1) * segs + j % segs;
    let mut tris = Vec::with_capacity((2 * segs * (stacks - 1)) as usize);
    // Caps and bands
    for j in 0..segs {
        tris.push([0, ring(1, j + 1), ring(1, j)]);
        tris.push([south, ring(stacks - 1, j), ring(stacks - 1, j + 1)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..segs {
            let (a, b) = (ring(i, j), ring(i, j + 1));
            let (c, d) = (ring(i + 1, j), ring(i + 1, j + 1));
            tris.push([a, b, c]);
            tris.push([b, d, c]);
        }
    }
    (pos, tris)
}

/// A closed, watertight UV sphere of radius 1 at the origin (poles on the
/// y axis, vertices shared, triangles counter-clockwise seen from outside).
///
/// It has `2 * segments * (stacks - 1)` triangles, within `stacks - 1`
/// (about `sqrt(target) / 2`) of `target_triangles` for targets of 12 or
/// more, and never fewer than 6 (a triangular bipyramid).
///
/// ```
/// let m = packtrace::protocol::generate::sphere(1000);
/// assert!((m.triangle_count() as i64 - 1000).abs() <= 16);
/// assert!(m.positions().iter().all(|p| (p.length() - 1.0).abs() < 1e-6));
/// ```
#[must_use]
pub fn sphere(target_triangles: usize) -> Mesh {
    let (pos, tris) = uv_sphere(target_triangles);
    mesh(pos.iter().map(|p| p.as_vec3()).collect(), tris)
}

/// SplitMix64 (Steele et al. 2014): the generator's deterministic noise.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// [`sphere`]'s topology with every vertex moved radially: vertex `k` lies
/// at radius `1 + jitter * (2 u_k - 1)`, `u_k` in `[0, 1)` from `seed` and
/// `k`. Still closed and watertight (vertices stay shared) and star-shaped
/// around the origin, so every ray from a point within radius
/// `1 - jitter` of the origin must hit it (PBRT's watertightness test).
///
/// # Panics
/// If `jitter` is not in `[0, 1)`.
///
/// ```
/// use packtrace::protocol::generate::{jittered_sphere, sphere};
/// let m = jittered_sphere(500, 7, 0.2);
/// assert_eq!(m.triangles(), sphere(500).triangles());
/// assert!(m.positions().iter().all(|p| (0.8..=1.2).contains(&p.length())));
/// assert_eq!(m.positions(), jittered_sphere(500, 7, 0.2).positions());
/// ```
#[must_use]
pub fn jittered_sphere(target_triangles: usize, seed: u64, jitter: f32) -> Mesh {
    assert!(
        (0.0..1.0).contains(&jitter),
        "jitter {jitter} is not in [0, 1)"
    );
    let (pos, tris) = uv_sphere(target_triangles);
    let key = splitmix64(seed);
    let pos = pos
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let u = (splitmix64(key ^ k as u64) >> 11) as f64 / (1u64 << 53) as f64;
            (*p * (1.0 + jitter as f64 * (2.0 * u - 1.0))).as_vec3()
        })
        .collect();
    mesh(pos, tris)
}

/// Triangles per sphere of [`scalable`] for a target: `sqrt(target)`
/// clamped to `32..=2048`, and the whole target below 32.
fn per_sphere(target: usize) -> usize {
    ((target as f64).sqrt() as usize)
        .clamp(32, 2048)
        .min(target)
}

/// A scene of any size for scaling benchmarks: a square grid (3 units
/// apart, in the `xz` plane) of closed spheres with hashed radii
/// `0.6..1.2`, heights `0..2` and offsets, each of about
/// `clamp(sqrt(target), 32, 2048)` triangles (so both the number of
/// objects and their detail grow with the size); below 32 triangles, one
/// [`sphere`]`(target)`.
///
/// The count is a whole number of spheres, within half a sphere's
/// triangles of the target (within 2 % from 1,000 triangles, 0.05 % from
/// 1,000,000). Generating 4 million triangles takes well under a second
/// in release builds (plus [`Mesh::new`]'s per-triangle data).
///
/// ```
/// let m = packtrace::protocol::generate::scalable(10_000);
/// assert!((m.triangle_count() as f64 / 10_000.0 - 1.0).abs() < 0.02);
/// ```
#[must_use]
pub fn scalable(target_triangles: usize) -> Mesh {
    let (unit_pos, unit_tris) = uv_sphere(per_sphere(target_triangles));
    let per = unit_tris.len();
    let n = ((target_triangles as f64 / per as f64).round() as usize).max(1);
    let grid = (n as f64).sqrt().ceil() as usize;
    let mut positions = Vec::with_capacity(n * unit_pos.len());
    let mut triangles = Vec::with_capacity(n * per);
    for i in 0..n {
        let h = |j: u32| unit(hash((i as u32).wrapping_mul(4).wrapping_add(j))) as f64;
        let radius = 0.6 + 0.6 * h(0);
        let center = DVec3::new(
            3.0 * (i % grid) as f64 + 0.3 * (2.0 * h(1) - 1.0),
            2.0 * h(2),
            3.0 * (i / grid) as f64 + 0.3 * (2.0 * h(3) - 1.0),
        );
        let base = positions.len() as u32;
        positions.extend(unit_pos.iter().map(|p| (center + radius * *p).as_vec3()));
        triangles.extend(unit_tris.iter().map(|t| t.map(|k| base + k)));
    }
    mesh(positions, triangles)
}

/// Segments of [`stadium`]'s floor and stands.
const STADIUM_SEGMENTS: usize = 64;

/// Triangles of [`stadium`]'s bowl: the floor's fan and two per stand
/// segment.
pub const STADIUM_BOWL_TRIANGLES: usize = 3 * STADIUM_SEGMENTS;

/// "The teapot in a stadium", the case the lectures give for hierarchical
/// grids: a wide, open bowl of few large triangles (a floor disk of radius
/// 100 and sloped stands from radius 100 to 130, rising to 30) with a
/// dense object at its centre, a closed jittered sphere of radius 2.5
/// resting on the floor, that holds all the other triangles. A uniform
/// grid sized for the whole bowl puts the object into a few crowded
/// cells.
///
/// `target_triangles` counts both; the object gets at least 32.
///
/// ```
/// use packtrace::protocol::generate::{stadium, STADIUM_BOWL_TRIANGLES};
/// let m = stadium(10_000);
/// assert!(m.triangle_count() > 9_000);
/// let object = (STADIUM_BOWL_TRIANGLES..m.triangle_count()).map(|i| m.corners(i)[0].length());
/// assert!(object.fold(0.0f32, f32::max) < 6.0);
/// ```
#[must_use]
pub fn stadium(target_triangles: usize) -> Mesh {
    let n = STADIUM_SEGMENTS;
    let (r_floor, r_top, h_top) = (100.0f64, 130.0f64, 30.0f64);
    let mut positions = vec![DVec3::ZERO];
    for ring in [(r_floor, 0.0), (r_top, h_top)] {
        for i in 0..n {
            let a = 2.0 * PI * i as f64 / n as f64;
            positions.push(DVec3::new(ring.0 * a.cos(), ring.1, ring.0 * a.sin()));
        }
    }
    let inner = |i: usize| 1 + (i % n) as u32;
    let outer = |i: usize| 1 + (n + i % n) as u32;
    let mut triangles = Vec::with_capacity(target_triangles.max(STADIUM_BOWL_TRIANGLES + 32));
    for i in 0..n {
        triangles.push([0, inner(i + 1), inner(i)]);
        triangles.push([inner(i), inner(i + 1), outer(i + 1)]);
        triangles.push([inner(i), outer(i + 1), outer(i)]);
    }
    let object = jittered_sphere(
        target_triangles
            .saturating_sub(STADIUM_BOWL_TRIANGLES)
            .max(32),
        7,
        0.1,
    );
    let base = positions.len() as u32;
    let radius = 2.5 / 1.1;
    positions.extend(
        object
            .positions()
            .iter()
            .map(|p| p.as_dvec3() * radius + DVec3::new(0.0, 2.5, 0.0)),
    );
    triangles.extend(object.triangles().iter().map(|t| t.map(|k| base + k)));
    mesh(positions.iter().map(|p| p.as_vec3()).collect(), triangles)
}

/// Parse a triangle count: digits, optionally with a `k` (thousand) or `M`
/// (million) suffix.
fn parse_count(spec: &str, s: &str) -> Result<usize, SpecError> {
    let fail = |reason: String| SpecError {
        spec: spec.to_string(),
        reason,
    };
    let (digits, scale) = match s.strip_suffix('M').or_else(|| s.strip_suffix('m')) {
        Some(d) => (d, 1_000_000),
        None => match s.strip_suffix('k').or_else(|| s.strip_suffix('K')) {
            Some(d) => (d, 1_000),
            None => (s, 1),
        },
    };
    let n = digits
        .parse::<usize>()
        .ok()
        .and_then(|n| n.checked_mul(scale))
        .ok_or_else(|| fail(format!("`{s}` is not a triangle count")))?;
    if n == 0 || n > MAX_SPEC_TRIANGLES {
        return Err(fail(format!(
            "triangle count {n} is not in 1..={MAX_SPEC_TRIANGLES}"
        )));
    }
    Ok(n)
}

/// Build a generated scene from its spec:
///
/// - `gen:sphere:N`: [`sphere`]`(N)`;
/// - `gen:jittered:N[:SEED[:JITTER]]`: [`jittered_sphere`] (defaults:
///   seed 1, jitter 0.1);
/// - `gen:scalable:N`: [`scalable`]`(N)`;
/// - `gen:stadium:N`: [`stadium`]`(N)`, the teapot in a stadium;
/// - `gen:cornell`: [`cornell_box`].
///
/// `N` is a count with an optional `k` or `M` suffix (`gen:scalable:4M`),
/// in `1..=MAX_SPEC_TRIANGLES`.
///
/// # Errors
/// [`SpecError`] naming the spec and the part at fault.
///
/// ```
/// use packtrace::protocol::generate::from_spec;
/// assert_eq!(from_spec("gen:cornell")?.triangle_count(), 32);
/// assert!(from_spec("gen:scalable:2k")?.triangle_count() > 1900);
/// assert!(from_spec("gen:jittered:500:3:0.25").is_ok());
/// let e = from_spec("gen:cube:10").unwrap_err().to_string();
/// assert!(e.contains("`cube`"), "{e}");
/// # Ok::<(), packtrace::protocol::generate::SpecError>(())
/// ```
pub fn from_spec(spec: &str) -> Result<Mesh, SpecError> {
    let fail = |reason: String| SpecError {
        spec: spec.to_string(),
        reason,
    };
    let rest = spec
        .strip_prefix("gen:")
        .ok_or_else(|| fail("a generated scene starts with `gen:`".into()))?;
    let parts: Vec<&str> = rest.split(':').collect();
    let arity = |lo: usize, hi: usize| {
        if (lo..=hi).contains(&parts.len()) {
            Ok(())
        } else {
            Err(fail(format!(
                "`{}` takes {} argument(s), found {}",
                parts[0],
                if lo == hi {
                    format!("{}", lo - 1)
                } else {
                    format!("{} to {}", lo - 1, hi - 1)
                },
                parts.len() - 1
            )))
        }
    };
    match parts[0] {
        "sphere" => {
            arity(2, 2)?;
            Ok(sphere(parse_count(spec, parts[1])?))
        }
        "jittered" => {
            arity(2, 4)?;
            let n = parse_count(spec, parts[1])?;
            let seed = match parts.get(2) {
                Some(s) => s
                    .parse::<u64>()
                    .map_err(|_| fail(format!("seed `{s}` is not an unsigned integer")))?,
                None => 1,
            };
            let jitter = match parts.get(3) {
                Some(s) => s
                    .parse::<f32>()
                    .ok()
                    .filter(|j| (0.0..1.0).contains(j))
                    .ok_or_else(|| fail(format!("jitter `{s}` is not a number in [0, 1)")))?,
                None => 0.1,
            };
            Ok(jittered_sphere(n, seed, jitter))
        }
        "scalable" => {
            arity(2, 2)?;
            Ok(scalable(parse_count(spec, parts[1])?))
        }
        "stadium" => {
            arity(2, 2)?;
            Ok(stadium(parse_count(spec, parts[1])?))
        }
        "cornell" => {
            arity(1, 1)?;
            Ok(cornell_box())
        }
        other => Err(fail(format!(
            "unknown generator `{other}` (expected sphere, jittered, scalable, stadium or cornell)"
        ))),
    }
}

/// The Cornell box quads, in mm, as published ("Cornell University
/// Program of Computer Graphics, Cornell box data"): name and corners.
#[rustfmt::skip]
const CORNELL_QUADS: [(&str, [[f32; 3]; 4]); 16] = [
    ("floor", [[552.8, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 559.2], [549.6, 0.0, 559.2]]),
    ("ceiling", [[556.0, 548.8, 0.0], [556.0, 548.8, 559.2], [0.0, 548.8, 559.2], [0.0, 548.8, 0.0]]),
    ("light", [[343.0, 548.8, 227.0], [343.0, 548.8, 332.0], [213.0, 548.8, 332.0], [213.0, 548.8, 227.0]]),
    ("back wall", [[549.6, 0.0, 559.2], [0.0, 0.0, 559.2], [0.0, 548.8, 559.2], [556.0, 548.8, 559.2]]),
    ("right wall", [[0.0, 0.0, 559.2], [0.0, 0.0, 0.0], [0.0, 548.8, 0.0], [0.0, 548.8, 559.2]]),
    ("left wall", [[552.8, 0.0, 0.0], [549.6, 0.0, 559.2], [556.0, 548.8, 559.2], [556.0, 548.8, 0.0]]),
    ("short block", [[130.0, 165.0, 65.0], [82.0, 165.0, 225.0], [240.0, 165.0, 272.0], [290.0, 165.0, 114.0]]),
    ("short block", [[290.0, 0.0, 114.0], [290.0, 165.0, 114.0], [240.0, 165.0, 272.0], [240.0, 0.0, 272.0]]),
    ("short block", [[130.0, 0.0, 65.0], [130.0, 165.0, 65.0], [290.0, 165.0, 114.0], [290.0, 0.0, 114.0]]),
    ("short block", [[82.0, 0.0, 225.0], [82.0, 165.0, 225.0], [130.0, 165.0, 65.0], [130.0, 0.0, 65.0]]),
    ("short block", [[240.0, 0.0, 272.0], [240.0, 165.0, 272.0], [82.0, 165.0, 225.0], [82.0, 0.0, 225.0]]),
    ("tall block", [[423.0, 330.0, 247.0], [265.0, 330.0, 296.0], [314.0, 330.0, 456.0], [472.0, 330.0, 406.0]]),
    ("tall block", [[423.0, 0.0, 247.0], [423.0, 330.0, 247.0], [472.0, 330.0, 406.0], [472.0, 0.0, 406.0]]),
    ("tall block", [[472.0, 0.0, 406.0], [472.0, 330.0, 406.0], [314.0, 330.0, 456.0], [314.0, 0.0, 456.0]]),
    ("tall block", [[314.0, 0.0, 456.0], [314.0, 330.0, 456.0], [265.0, 330.0, 296.0], [265.0, 0.0, 296.0]]),
    ("tall block", [[265.0, 0.0, 296.0], [265.0, 330.0, 296.0], [423.0, 330.0, 247.0], [423.0, 0.0, 247.0]]),
];

/// The Cornell box's materials and their diffuse colour (linear RGB): the
/// usual reduction of the published reflectance spectra (Cornell box
/// data, "Materials") to RGB, as in the Cornell box scenes of PBRT-v3 and
/// Mitsuba; the light's surface reflects 0.78 (ibid.).
pub const CORNELL_MATERIALS: [(&str, [f32; 3]); 4] = [
    ("white", [0.725, 0.71, 0.68]),
    ("red", [0.63, 0.065, 0.05]),
    ("green", [0.14, 0.45, 0.091]),
    ("light", [0.78, 0.78, 0.78]),
];

/// The material of each part of the box: red on the left (seen from the
/// camera), green on the right, the light, and white elsewhere.
fn cornell_material(part: &str) -> &'static str {
    match part {
        "left wall" => "red",
        "right wall" => "green",
        "light" => "light",
        _ => "white",
    }
}

/// The diffuse colour of each triangle of [`cornell_box`]
/// ([`CORNELL_MATERIALS`]), for the renderer.
///
/// ```
/// use packtrace::protocol::generate::{cornell_albedo, cornell_box};
/// let albedo = cornell_albedo();
/// assert_eq!(albedo.len(), cornell_box().triangle_count());
/// assert!(albedo.iter().any(|c| c.x > 0.6 && c.y < 0.1)); // the red wall
/// ```
#[must_use]
pub fn cornell_albedo() -> Vec<Vec3> {
    CORNELL_QUADS
        .iter()
        .flat_map(|(part, _)| {
            let name = cornell_material(part);
            let kd = CORNELL_MATERIALS
                .iter()
                .find(|(m, _)| *m == name)
                .map_or(Vec3::ONE, |(_, kd)| Vec3::from_array(*kd));
            [kd, kd]
        })
        .collect()
}

/// The text of `data/cornell.mtl`: [`CORNELL_MATERIALS`] as `newmtl` /
/// `Kd` pairs.
///
/// ```
/// let text = packtrace::protocol::generate::cornell_mtl();
/// assert!(text.contains("newmtl red\nKd 0.63 0.065 0.05\n"));
/// ```
#[must_use]
pub fn cornell_mtl() -> String {
    let mut s = String::from(
        "# Cornell box materials, written by packtrace (generate::CORNELL_MATERIALS):\n\
         # the published reflectance spectra reduced to linear RGB.\n",
    );
    for (name, kd) in CORNELL_MATERIALS {
        s.push_str(&format!(
            "newmtl {name}\nKd {} {} {}\n",
            kd[0], kd[1], kd[2]
        ));
    }
    s
}

/// The view file of [`cornell_box`], as `data/cornell.view` holds it: the
/// published camera and a point light 10 mm below the centre of the
/// ceiling light.
///
/// ```
/// use packtrace::protocol::camera::View;
/// let v = View::parse(packtrace::protocol::generate::CORNELL_VIEW).unwrap();
/// assert_eq!(v.camera.unwrap().eye, glam::Vec3::new(278.0, 273.0, -800.0));
/// ```
pub const CORNELL_VIEW: &str = "\
# Cornell box view, written by packtrace (generate::CORNELL_VIEW).
# Published camera: eye (278, 273, -800) looking along +z, up +y, focal
# length 35 mm, film 25 x 25 mm: vertical fov = 2 atan(12.5 / 35) = 39.3077 deg.
camera 278,273,-800,278,273,0,0,1,0,39.3077
# Point light 10 mm below the centre (278, 548.8, 279.5) of the ceiling light.
light 278,538.8,279.5
";

/// The Cornell box from Cornell's published measurements ("Cornell
/// University Program of Computer Graphics, Cornell box data",
/// <https://www.graphics.cornell.edu/online/box/data.html>), in mm: floor,
/// ceiling, light, back wall, right wall (x = 0), left wall (x = 552.8 to
/// 556), then the short and the tall block (5 quads each, no bottom), 16
/// quads fan-triangulated (`v0 v1 v2`, `v0 v2 v3`) into 32 triangles,
/// 4 unshared vertices per quad.
///
/// As published, the light quad lies in the ceiling's plane (y = 548.8),
/// so over the light the ceiling (smaller triangle index) wins ties.
/// The box is open toward `-z`, where the camera ([`CORNELL_VIEW`]) is.
///
/// ```
/// let m = packtrace::protocol::generate::cornell_box();
/// assert_eq!(m.triangle_count(), 32);
/// assert_eq!(m.bounds().max, glam::Vec3A::new(556.0, 548.8, 559.2));
/// ```
#[must_use]
pub fn cornell_box() -> Mesh {
    let mut positions = Vec::with_capacity(64);
    let mut triangles = Vec::with_capacity(32);
    for (_, quad) in &CORNELL_QUADS {
        let b = positions.len() as u32;
        positions.extend(quad.iter().map(|c| Vec3::from_array(*c)));
        triangles.push([b, b + 1, b + 2]);
        triangles.push([b, b + 2, b + 3]);
    }
    mesh(positions, triangles)
}

/// How far the light quad of [`cornell_box_lit`] hangs below the ceiling,
/// in mm.
///
/// ```
/// assert_eq!(packtrace::protocol::generate::CORNELL_LIGHT_DROP, 1.0);
/// ```
pub const CORNELL_LIGHT_DROP: f32 = 1.0;

/// The emitted radiance of the Cornell box's light, linear RGB: the usual
/// reduction of the published emission spectrum to RGB, as in the Cornell
/// box scenes of McGuire's Computer Graphics Archive (`Ke 17 12 4`) and of
/// Bitterli's rendering resources used by PBRT-v4.
///
/// ```
/// assert_eq!(packtrace::protocol::generate::CORNELL_LIGHT_RADIANCE, [17.0, 12.0, 4.0]);
/// ```
pub const CORNELL_LIGHT_RADIANCE: [f32; 3] = [17.0, 12.0, 4.0];

/// [`cornell_box`] for light transport: the same 32 triangles in the same
/// order, with the light quad (triangles 4 and 5) moved
/// [`CORNELL_LIGHT_DROP`] below the ceiling. As published, the light lies
/// in the ceiling's plane, where the ceiling (the smaller triangle index)
/// hides it from every ray; renderers of the published data lower it the
/// same way (McGuire's archive, Mitsuba's `cbox`). Its emission is
/// [`cornell_emission`].
///
/// ```
/// use packtrace::protocol::generate::{cornell_box, cornell_box_lit};
/// let (lit, published) = (cornell_box_lit(), cornell_box());
/// assert_eq!(lit.triangle_count(), 32);
/// assert_eq!(lit.corners(4)[0].y, 547.8);
/// assert_eq!(lit.corners(2), published.corners(2)); // the ceiling stays
/// ```
#[must_use]
pub fn cornell_box_lit() -> Mesh {
    let mut positions = Vec::with_capacity(64);
    let mut triangles = Vec::with_capacity(32);
    for (part, quad) in &CORNELL_QUADS {
        let drop = if *part == "light" {
            CORNELL_LIGHT_DROP
        } else {
            0.0
        };
        let b = positions.len() as u32;
        positions.extend(quad.iter().map(|c| Vec3::from_array(*c) - Vec3::Y * drop));
        triangles.push([b, b + 1, b + 2]);
        triangles.push([b, b + 2, b + 3]);
    }
    mesh(positions, triangles)
}

/// The emitted radiance of each triangle of [`cornell_box_lit`]:
/// [`CORNELL_LIGHT_RADIANCE`] for the light's two triangles (emitting
/// downwards, the side their winding faces), zero elsewhere.
///
/// ```
/// use packtrace::protocol::generate::{cornell_box_lit, cornell_emission};
/// let e = cornell_emission();
/// assert_eq!(e.iter().filter(|c| c.x > 0.0).count(), 2);
/// assert!(cornell_box_lit().normal(4).y < 0.0); // facing the floor
/// ```
#[must_use]
pub fn cornell_emission() -> Vec<Vec3> {
    cornell_parts()
        .into_iter()
        .map(|part| {
            if part == "light" {
                Vec3::from_array(CORNELL_LIGHT_RADIANCE)
            } else {
                Vec3::ZERO
            }
        })
        .collect()
}

/// The part of the box each triangle of [`cornell_box`] belongs to, by
/// triangle: `floor`, `ceiling`, `light`, `back wall`, `right wall`
/// (green, at `x = 0`, on the right of the image), `left wall` (red),
/// `short block`, `tall block`.
///
/// ```
/// let parts = packtrace::protocol::generate::cornell_parts();
/// assert_eq!((parts.len(), parts[0], parts[11]), (32, "floor", "left wall"));
/// ```
#[must_use]
pub fn cornell_parts() -> Vec<&'static str> {
    CORNELL_QUADS
        .iter()
        .flat_map(|(part, _)| [*part, *part])
        .collect()
}

/// Write a mesh as a Wavefront OBJ file: `header` lines as `#` comments,
/// then `v x y z` for every position (shortest round-trip decimals, so
/// the file loads back bit for bit) and `f a b c` (1-based) for every
/// triangle. Nothing else (no normals, groups or materials), so other
/// engines can load generated scenes too.
///
/// # Errors
/// Any error of `out`.
///
/// ```
/// let m = packtrace::protocol::generate::sphere(50);
/// let mut text = Vec::new();
/// packtrace::protocol::generate::write_obj(&m, "a sphere", &mut text).unwrap();
/// let back = packtrace::parse_obj_bytes(&text).unwrap();
/// assert_eq!(back.triangle_count(), m.triangle_count());
/// assert!((0..m.triangle_count()).all(|i| back.corners(i) == m.corners(i)));
/// ```
pub fn write_obj(mesh: &Mesh, header: &str, mut out: impl Write) -> io::Result<()> {
    for line in header.lines() {
        writeln!(out, "# {line}")?;
    }
    for p in mesh.positions() {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for t in mesh.triangles() {
        writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    Ok(())
}

/// The text of `data/cornell.obj`: [`cornell_box`] with a header naming
/// the source and a comment before each part.
///
/// ```
/// let text = packtrace::protocol::generate::cornell_obj();
/// assert!(text.contains("# tall block"));
/// let m = packtrace::parse_obj_bytes(text.as_bytes()).unwrap();
/// assert_eq!(m.triangle_count(), 32);
/// ```
#[must_use]
pub fn cornell_obj() -> String {
    let mut s = String::from(
        "# Cornell box, written by packtrace (generate::cornell_box) from the published\n\
         # measurements: Cornell University Program of Computer Graphics, Cornell box data\n\
         # (https://www.graphics.cornell.edu/online/box/data.html). Units: mm.\n\
         # 16 quads, each as 2 triangles (v0 v1 v2, v0 v2 v3); colours in cornell.mtl.\n\
         mtllib cornell.mtl\n",
    );
    let mut last = "";
    for (q, (name, quad)) in CORNELL_QUADS.iter().enumerate() {
        if *name != last {
            s.push_str(&format!("# {name}\nusemtl {}\n", cornell_material(name)));
            last = name;
        }
        for c in quad {
            s.push_str(&format!("v {} {} {}\n", c[0], c[1], c[2]));
        }
        let b = 4 * q + 1;
        s.push_str(&format!(
            "f {} {} {}\nf {} {} {}\n",
            b,
            b + 1,
            b + 2,
            b,
            b + 2,
            b + 3
        ));
    }
    s
}

/// Write `cornell.obj`, `cornell.mtl` and `cornell.view` ([`cornell_obj`],
/// [`cornell_mtl`], [`CORNELL_VIEW`]) into `dir` (the crate's `data/`
/// directory).
///
/// # Errors
/// Any I/O error.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("packtrace-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// packtrace::protocol::generate::write_cornell_data(&dir).unwrap();
/// assert_eq!(packtrace::load_obj(dir.join("cornell.obj")).unwrap().triangle_count(), 32);
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn write_cornell_data(dir: &Path) -> io::Result<()> {
    std::fs::write(dir.join("cornell.obj"), cornell_obj())?;
    std::fs::write(dir.join("cornell.mtl"), cornell_mtl())?;
    std::fs::write(dir.join("cornell.view"), CORNELL_VIEW)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::{KdBuildParams, KdTree};
    use crate::packet::RayPacket4;
    use crate::ray::Ray;
    use std::collections::HashMap;

    /// Every directed edge appears once and its reverse once: a closed,
    /// consistently oriented 2-manifold.
    fn assert_closed(m: &Mesh) {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in m.triangles() {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &c) in &edges {
            assert_eq!(c, 1, "edge {a}-{b} used {c} times in one direction");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} has no twin");
        }
    }

    #[test]
    fn sphere_counts_are_close_to_the_target() {
        for target in (0..200).chain([500, 1000, 4321, 10_000, 99_999, 1_000_000]) {
            let (s, m) = uv_dims(target);
            let n = 2 * m as i64 * (s as i64 - 1);
            assert!(n >= 6, "{target}");
            if target >= 12 {
                assert!((n - target as i64).abs() < s as i64, "{target}: {n}");
            }
        }
        assert_eq!(sphere(0).triangle_count(), 6);
        assert_eq!(sphere(1000).triangle_count(), 990);
    }

    #[test]
    fn spheres_are_closed_outward_and_round() {
        for target in [0, 6, 12, 100, 2000] {
            let m = sphere(target);
            assert_closed(&m);
            for i in 0..m.triangle_count() {
                assert!(!m.is_degenerate(i), "{target}: {i}");
                let c = m.corners(i);
                let centroid = (c[0] + c[1] + c[2]) / 3.0;
                assert!(
                    m.normal(i).dot(centroid) > 0.0,
                    "{target}: triangle {i} faces inward"
                );
            }
            assert!(
                m.positions()
                    .iter()
                    .all(|p| (p.length() - 1.0).abs() < 1e-6)
            );
            // Euler characteristic of a sphere
            let (v, f) = (m.positions().len() as i64, m.triangle_count() as i64);
            assert_eq!(v - 3 * f / 2 + f, 2);
        }
    }

    #[test]
    fn jittered_sphere_is_deterministic_closed_and_bounded() {
        let a = jittered_sphere(3000, 42, 0.3);
        assert_closed(&a);
        assert_eq!(a.positions(), jittered_sphere(3000, 42, 0.3).positions());
        assert_ne!(a.positions(), jittered_sphere(3000, 43, 0.3).positions());
        let r: Vec<f32> = a.positions().iter().map(|p| p.length()).collect();
        assert!(r.iter().all(|&r| (0.7..=1.3).contains(&r)));
        // the jitter is actually used
        assert!(r.iter().any(|&r| r < 0.8) && r.iter().any(|&r| r > 1.2));
        assert_eq!(
            jittered_sphere(300, 1, 0.0).positions(),
            sphere(300).positions()
        );
    }

    #[test]
    #[should_panic(expected = "jitter")]
    fn jitter_of_one_is_refused() {
        let _ = jittered_sphere(100, 1, 1.0);
    }

    /// PBRT's watertightness test: every ray from inside a closed jittered
    /// sphere hits it, in scalar and packet traversal alike.
    #[test]
    fn rays_from_inside_a_jittered_sphere_all_hit() {
        let mesh = jittered_sphere(20_000, 9, 0.25);
        for (name, params) in KdBuildParams::presets() {
            let tree = KdTree::build(mesh.clone(), &params).unwrap();
            let mut rays = Vec::new();
            for i in 0..8000u32 {
                let u = |j: u32| unit(hash(i * 8 + j));
                let z = 1.0 - 2.0 * u(0);
                let rr = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * std::f32::consts::PI * u(1);
                let dir = Vec3::new(rr * phi.cos(), rr * phi.sin(), z);
                // origins at the centre, on the axes and in a ball of 0.5
                let origin = match i % 4 {
                    0 => Vec3::ZERO,
                    1 => Vec3::new(0.0, 0.5 * (u(2) - 0.5), 0.0),
                    _ => (Vec3::new(u(2), u(3), u(4)) - 0.5) * 0.5,
                };
                rays.push(Ray::new(origin, dir, 0.0, f32::INFINITY).unwrap());
            }
            for (k, r) in rays.iter().enumerate() {
                assert!(tree.intersect(r).is_some(), "{name}: ray {k} {r:?} escapes");
                assert!(tree.occluded(r), "{name}: ray {k} {r:?} not occluded");
            }
            for c in rays.chunks_exact(4) {
                let p = RayPacket4::from_rays(&[c[0], c[1], c[2], c[3]]);
                let h = tree.intersect4(&p);
                assert_eq!(h.mask(), 0b1111, "{name}: {c:?}");
                assert_eq!(tree.occluded4(&p), 0b1111, "{name}: {c:?}");
                for (i, r) in c.iter().enumerate() {
                    assert_eq!(h.hit(i), tree.intersect(r), "{name}: {r:?}");
                }
            }
        }
    }

    #[test]
    fn the_stadium_is_a_wide_bowl_with_a_dense_object_at_its_centre() {
        let m = from_spec("gen:stadium:20k").unwrap();
        assert!((m.triangle_count() as f64 / 20_000.0 - 1.0).abs() < 0.02);
        let b = m.bounds();
        assert!(b.max.x > 129.0 && b.min.x < -129.0 && b.max.y > 29.0);
        // Nearly every triangle lies within 2.5 of the object's centre.
        let centre = Vec3::new(0.0, 2.5, 0.0);
        let near = (0..m.triangle_count())
            .filter(|&i| {
                m.corners(i)
                    .iter()
                    .all(|c| (*c - centre).length() <= 2.5 + 1e-4)
            })
            .count();
        assert_eq!(near, m.triangle_count() - STADIUM_BOWL_TRIANGLES);
        assert_eq!(
            stadium(10).triangle_count(),
            STADIUM_BOWL_TRIANGLES + jittered_sphere(32, 7, 0.1).triangle_count()
        );
    }

    #[test]
    fn scalable_counts_and_layout() {
        for target in [1, 31, 1000, 4567, 50_000, 300_000] {
            let m = scalable(target);
            let n = m.triangle_count();
            let per = uv_sphere(per_sphere(target)).1.len();
            assert_eq!(n % per, 0, "{target}");
            assert!(
                (n as i64 - target as i64).unsigned_abs() as usize <= per.div_ceil(2).max(6),
                "{target}: {n}"
            );
            if target >= 1000 {
                assert!(
                    (n as f64 / target as f64 - 1.0).abs() < 0.02,
                    "{target}: {n}"
                );
            }
        }
        let m = scalable(50_000);
        assert_closed(&m);
        assert!(m.bounds().extent().x > 10.0 && m.bounds().extent().z > 10.0);
        assert_eq!(m.positions(), scalable(50_000).positions());
    }

    #[test]
    fn from_spec_accepts_each_kind_and_names_errors() {
        assert_eq!(from_spec("gen:sphere:1000").unwrap().triangle_count(), 990);
        assert_eq!(
            from_spec("gen:jittered:1k").unwrap().positions(),
            jittered_sphere(1000, 1, 0.1).positions()
        );
        assert_eq!(
            from_spec("gen:jittered:1000:5:0.5").unwrap().positions(),
            jittered_sphere(1000, 5, 0.5).positions()
        );
        assert_eq!(
            from_spec("gen:scalable:2k").unwrap().positions(),
            scalable(2000).positions()
        );
        assert_eq!(from_spec("gen:cornell").unwrap().triangle_count(), 32);
        let bad = [
            ("sphere:10", "starts with `gen:`"),
            ("gen:sphere", "takes 1 argument"),
            ("gen:sphere:10:3", "takes 1 argument"),
            ("gen:sphere:ten", "`ten`"),
            ("gen:sphere:0", "not in 1..="),
            ("gen:scalable:60M", "not in 1..="),
            ("gen:jittered:10:x", "seed `x`"),
            ("gen:jittered:10:1:1.5", "jitter `1.5`"),
            ("gen:cornell:3", "takes 0 argument"),
            ("gen:torus:10", "unknown generator `torus`"),
        ];
        for (spec, why) in bad {
            let e = from_spec(spec).unwrap_err().to_string();
            assert!(e.contains(why) && e.contains(spec), "{spec}: {e}");
        }
    }

    fn data_dir() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
    }

    /// `data/cornell.obj` and `data/cornell.view` are exactly what the
    /// code writes, so they cannot drift.
    #[test]
    fn cornell_data_files_match_the_code() {
        let m = cornell_box();
        let loaded = crate::obj::load_obj(data_dir().join("cornell.obj")).unwrap();
        assert_eq!(loaded.triangle_count(), m.triangle_count());
        for i in 0..m.triangle_count() {
            assert_eq!(loaded.corners(i), m.corners(i), "triangle {i}");
        }
        assert_eq!(loaded.bounds(), m.bounds());
        let text = std::fs::read_to_string(data_dir().join("cornell.obj")).unwrap();
        assert_eq!(
            text,
            cornell_obj(),
            "rewrite the files: cargo run --example write_cornell_data"
        );
        let mtl = std::fs::read_to_string(data_dir().join("cornell.mtl")).unwrap();
        assert_eq!(
            mtl,
            cornell_mtl(),
            "rewrite the files: cargo run --example write_cornell_data"
        );
        // The OBJ's materials give the colours the renderer uses.
        let shaded = crate::obj::load_obj_with_shading(data_dir().join("cornell.obj")).unwrap();
        let albedo = cornell_albedo();
        for (i, want) in albedo.iter().enumerate() {
            let got = shaded.material(i as u32).and_then(|m| m.diffuse);
            assert_eq!(got, Some(*want), "triangle {i}");
        }
        let view = crate::protocol::camera::load_view(&data_dir().join("cornell.obj")).unwrap();
        assert_eq!(
            view,
            crate::protocol::camera::View::parse(CORNELL_VIEW).unwrap()
        );
    }

    #[test]
    fn cornell_box_matches_the_published_measurements() {
        let m = cornell_box();
        let b = m.bounds();
        assert_eq!(b.min, glam::Vec3A::ZERO);
        assert_eq!(b.max, glam::Vec3A::new(556.0, 548.8, 559.2));
        assert!((0..32).all(|i| !m.is_degenerate(i)));
        // the published camera sees the inside: most primary rays hit
        let v = crate::protocol::camera::View::parse(CORNELL_VIEW).unwrap();
        let cam = v.camera.unwrap();
        assert!((cam.fov_deg - 2.0 * (12.5f32 / 35.0).atan().to_degrees()).abs() < 1e-3);
        let tree = KdTree::build(m, &KdBuildParams::default()).unwrap();
        let set = crate::protocol::workload::primary(&cam, 64, 64).unwrap();
        let hits = set
            .rays
            .iter()
            .filter(|r| tree.intersect(r).is_some())
            .count();
        assert!(hits > 64 * 64 * 9 / 10, "{hits}");
        // the light sits inside the box, below the ceiling
        let light = v.light.unwrap();
        assert!(tree.bounds().contains(light.into()) && light.y < 548.8);
    }
}

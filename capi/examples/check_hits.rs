//! The Rust side of the C and C++ examples' check: compares every ray and
//! answer the examples dumped with the Rust API's own answers, bit for
//! bit. It links the `packtrace` crate only, never the C API it checks.
//!
//! ```text
//! check_hits generate SCENE.obj          write the generated test scene
//! check_hits tree SCENE.obj OUT.hits     check trace.c's dump
//! check_hits scene SCENE.obj OUT.hits    check scene.cpp's dump
//! ```
//!
//! Dump lines (every float as its 8 hex digits of IEEE bits):
//! - `P ray.. miss` / `P ray.. hit T PRIM U V NX NY NZ GEOM INST`: a tree's
//!   closest hit of `ray` (`ox oy oz dx dy dz tnear tfar`), checked
//!   against `KdTree::intersect` and `Mesh::normal`;
//! - `S ray.. OCC`: the shadow ray the C API spawned from the last hit
//!   (checked against `spawn::spawn_ray`) and its occlusion
//!   (`KdTree::occluded`);
//! - `N NX NY NZ`: the shading normal at the last hit
//!   (`ObjMesh::shading_normal`);
//! - `I GEOM M0..M11 MASK`: an instance of the scene (row-major 3 x 4);
//! - `Q ray.. MASK miss|hit ..`, `O ray.. MASK OCC`: a scene's closest hit
//!   and occlusion under the ray mask (`Scene::intersect_with`,
//!   `occluded_with`, `Scene::normal`).

use packtrace::glam::{Affine3A, Mat3, Vec3};
use packtrace::scene::{GeometryId, InstanceId, Query, Scene, SceneHit};
use packtrace::{Hit, KdBuildParams, KdTree, ObjMesh, Ray, load_obj_with_shading, spawn};
use std::fmt::Write as _;
use std::process::ExitCode;

/// Tallies and the first few failures.
#[derive(Default)]
struct Tally {
    passed: usize,
    failed: usize,
}

impl Tally {
    fn check(&mut self, ok: bool, line: usize, what: impl FnOnce() -> String) {
        if ok {
            self.passed += 1;
        } else {
            self.failed += 1;
            if self.failed <= 10 {
                eprintln!("line {line}: {}", what());
            }
        }
    }
}

fn f(word: &str) -> f32 {
    f32::from_bits(u32::from_str_radix(word, 16).expect("8 hex digits"))
}

fn u(word: &str) -> u32 {
    word.parse().expect("an unsigned integer")
}

fn ray(w: &[&str]) -> Ray {
    let v = |i: usize| Vec3::new(f(w[i]), f(w[i + 1]), f(w[i + 2]));
    Ray::new(v(0), v(3), f(w[6]), f(w[7])).expect("the examples dump valid rays")
}

fn bits(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// The hit a dump line claims: `T PRIM U V NX NY NZ GEOM INST`.
struct Claimed {
    hit: Hit,
    ng: Vec3,
    geom: u32,
    inst: u32,
}

fn claimed(w: &[&str]) -> Claimed {
    Claimed {
        hit: Hit {
            t: f(w[0]),
            prim: u(w[1]),
            u: f(w[2]),
            v: f(w[3]),
        },
        ng: Vec3::new(f(w[4]), f(w[5]), f(w[6])),
        geom: u(w[7]),
        inst: u(w[8]),
    }
}

fn same(a: &Hit, b: &Hit) -> bool {
    (a.t.to_bits(), a.prim, a.u.to_bits(), a.v.to_bits())
        == (b.t.to_bits(), b.prim, b.u.to_bits(), b.v.to_bits())
}

fn check(mode: &str, obj: &ObjMesh, dump: &str) -> Tally {
    let tree = KdTree::build(obj.mesh().clone(), &KdBuildParams::default()).expect("builds");
    let mesh = tree.mesh();
    let mut scene = Scene::new();
    let g = scene.add_geometry("mesh", tree.clone());
    let mut t = Tally::default();
    let mut last: Option<Hit> = None;
    for (n, line) in dump.lines().enumerate() {
        let n = n + 1;
        let w: Vec<&str> = line.split_whitespace().collect();
        match (mode, w.first().copied()) {
            ("tree", Some("P")) => {
                let r = ray(&w[1..9]);
                let want = tree.intersect(&r);
                last = None;
                if w[9] == "miss" {
                    t.check(want.is_none(), n, || format!("C missed, Rust hit {want:?}"));
                    continue;
                }
                let c = claimed(&w[10..19]);
                let ok = want.is_some_and(|h| {
                    same(&h, &c.hit)
                        && bits(mesh.normal(h.prim as usize)) == bits(c.ng)
                        && (c.geom, c.inst) == (0, u32::MAX)
                });
                t.check(ok, n, || format!("C hit {:?}, Rust {want:?}", c.hit));
                last = Some(c.hit);
            }
            ("tree", Some("S")) => {
                let c = ray(&w[1..9]);
                let hit = last.expect("an S line follows a hit");
                let want = spawn::spawn_ray(mesh, &hit, c.dir(), c.t_max()).expect("valid");
                let ok = bits(want.origin()) == bits(c.origin())
                    && bits(want.dir()) == bits(c.dir())
                    && (want.t_min().to_bits(), want.t_max().to_bits())
                        == (c.t_min().to_bits(), c.t_max().to_bits());
                t.check(ok, n, || format!("spawned ray {c:?}, Rust {want:?}"));
                let occluded = w[9] == "1";
                t.check(tree.occluded(&c) == occluded, n, || {
                    format!("C occluded = {occluded}, Rust the opposite")
                });
            }
            ("tree", Some("N")) => {
                let hit = last.expect("an N line follows a hit");
                let c = Vec3::new(f(w[1]), f(w[2]), f(w[3]));
                let want = obj.shading_normal(&hit);
                t.check(bits(want) == bits(c), n, || {
                    format!("shading normal {c}, Rust {want}")
                });
            }
            ("scene", Some("I")) => {
                assert_eq!(u(w[1]), 0, "one geometry");
                let m: Vec<f32> = w[2..14].iter().map(|x| f(x)).collect();
                let rows =
                    Mat3::from_cols_array(&[m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10]]);
                let xf = Affine3A::from_mat3_translation(rows, Vec3::new(m[3], m[7], m[11]));
                let mut e = scene.edit();
                let id = e.add_instance(g, xf).expect("a valid transform");
                e.set_mask(id, u(w[14])).expect("live");
            }
            ("scene", Some("Q")) => {
                let r = ray(&w[1..9]);
                let q = Query::new().with_mask(u(w[9]));
                let want = scene.intersect_with(&r, &q);
                if w[10] == "miss" {
                    t.check(want.is_none(), n, || format!("C missed, Rust hit {want:?}"));
                    continue;
                }
                let c = claimed(&w[11..20]);
                let ok = want.is_some_and(|h: SceneHit| {
                    let as_hit = Hit {
                        t: h.t,
                        prim: h.prim,
                        u: h.u,
                        v: h.v,
                    };
                    same(&as_hit, &c.hit)
                        && (h.geometry, h.instance) == (GeometryId(c.geom), InstanceId(c.inst))
                        && scene.normal(&h).map(bits) == Some(bits(c.ng))
                });
                t.check(ok, n, || {
                    format!(
                        "C hit {:?} geometry {} instance {}, Rust {want:?}",
                        c.hit, c.geom, c.inst
                    )
                });
            }
            ("scene", Some("O")) => {
                let r = ray(&w[1..9]);
                let q = Query::new().with_mask(u(w[9]));
                let occluded = w[10] == "1";
                t.check(scene.occluded_with(&r, &q) == occluded, n, || {
                    format!("C occluded = {occluded}, Rust the opposite")
                });
            }
            (_, Some(tag)) => panic!("line {n}: unexpected `{tag}` in a {mode} dump"),
            (_, None) => {}
        }
    }
    t
}

/// The generated test scene: a jittered sphere with per-vertex normals
/// (`vn`, so shading normals are interpolated) over a ground quad
/// without them (geometric normals).
fn generate() -> String {
    let sphere = packtrace::protocol::generate::jittered_sphere(3000, 7, 0.15);
    let mut s = String::from("# packtrace-c test scene: jittered sphere over a ground quad\n");
    for p in sphere.positions() {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for p in sphere.positions() {
        let n = p.normalize();
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for t in sphere.triangles() {
        let [a, b, c] = t.map(|i| i + 1);
        let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
    }
    let k = sphere.positions().len();
    for (x, z) in [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)] {
        let _ = writeln!(s, "v {x} -1.3 {z}");
    }
    let _ = writeln!(s, "f {} {} {} {}", k + 1, k + 4, k + 3, k + 2);
    s
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["generate", path] => {
            std::fs::write(path, generate()).expect("write the scene");
            ExitCode::SUCCESS
        }
        [mode @ ("tree" | "scene"), obj, dump] => {
            let obj = load_obj_with_shading(obj).expect("the OBJ loads");
            let dump = std::fs::read_to_string(dump).expect("the dump reads");
            let t = check(mode, &obj, &dump);
            println!("{} passed, {} failed", t.passed, t.failed);
            if t.failed == 0 && t.passed > 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        _ => {
            eprintln!(
                "usage: check_hits generate SCENE.obj | check_hits tree|scene SCENE.obj DUMP"
            );
            ExitCode::from(2)
        }
    }
}

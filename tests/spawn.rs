//! Secondary rays made with `spawn::spawn_ray` never re-hit the triangle
//! they leave, and never tunnel out of a closed mesh (issue 15, item 1):
//! from every primary hit, a shadow ray to the light, a ray back to the
//! eye, a ray on through the surface and two rays grazing it (5 and 0.5
//! degrees above the surface). On a closed sphere always; on the bunny and
//! Sponza in a scene test (`tests/common/scenes.rs`; the protocol's
//! primary rays, 256x256).

#[path = "common/scenes.rs"]
mod scenes;

use packtrace::glam::Vec3;
use packtrace::protocol::workload;
use packtrace::{Hit, KdBuildParams, KdTree, Ray, load_obj, load_view, spawn};

/// Traces the spawned rays of every primary hit; returns how many were
/// traced. `closed`: a ray on through the surface must hit the mesh again.
fn check(name: &str, tree: &KdTree, primary: &[Ray], light: Vec3, closed: bool) -> usize {
    let mesh = tree.mesh();
    let mut traced = 0;
    let mut rehits = Vec::new();
    for r in primary {
        let Some(h) = tree.intersect(r) else {
            continue;
        };
        let p = spawn::hit_point(mesh, &h);
        let n = mesh.normal(h.prim as usize);
        let n = if n.dot(r.dir()) > 0.0 { -n } else { n };
        // A tangent, and directions just above the surface.
        let tangent = n.any_orthonormal_vector();
        let graze = |deg: f32| tangent * deg.to_radians().cos() + n * deg.to_radians().sin();
        let rays = [
            ("shadow", light - p, 1.0 - 1e-4),
            ("back", -r.dir(), f32::INFINITY),
            ("on", r.dir(), f32::INFINITY),
            ("graze 5", graze(5.0), f32::INFINITY),
            ("graze 0.5", graze(0.5), f32::INFINITY),
        ];
        for (what, dir, t_max) in rays {
            if dir.length_squared() == 0.0 {
                continue;
            }
            let s = spawn::spawn_ray(mesh, &h, dir, t_max).expect("a valid ray");
            traced += 1;
            let got: Option<Hit> = tree.intersect(&s);
            if got.is_some_and(|g| g.prim == h.prim) {
                rehits.push(format!("{what}: {s:?} re-hits {}", h.prim));
            }
            if closed && what == "on" && got.is_none() {
                rehits.push(format!("{what}: {s:?} tunnels out through {}", h.prim));
            }
        }
    }
    assert!(
        rehits.is_empty(),
        "{name}: {} of {traced} spawned rays fail, the first: {}",
        rehits.len(),
        rehits[0]
    );
    traced
}

#[test]
fn spawned_rays_leave_a_closed_sphere_cleanly() {
    let mesh = packtrace::protocol::generate::sphere(20_000);
    let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
    // Rays at the sphere from all around, at scales where ulps matter.
    let mut primary = Vec::new();
    for i in 0..4000 {
        let a = i as f32 * 2.399_963;
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / 4000.0;
        let eye = Vec3::new(
            a.cos() * (1.0 - z * z).sqrt(),
            a.sin() * (1.0 - z * z).sqrt(),
            z,
        ) * 4.0;
        let target = Vec3::new(0.3 * a.sin(), 0.2 * z, 0.1 * a.cos());
        primary.push(Ray::new(eye, target - eye, 0.0, f32::INFINITY).unwrap());
    }
    let traced = check("sphere", &tree, &primary, Vec3::new(3.0, 5.0, 4.0), true);
    assert!(traced > 15_000);
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn spawned_rays_on_bunny_and_sponza_never_rehit() {
    let dir = scenes::scenes_dir();
    for name in ["bunny", "sponza"] {
        let obj = scenes::scene_file(&dir, &format!("{name}.obj"));
        let mesh = load_obj(&obj).unwrap_or_else(|e| panic!("{e}"));
        let view = load_view(&obj).unwrap_or_else(|e| panic!("{e}"));
        let frame = packtrace::SceneFrame::of(&mesh);
        let camera = view.camera.expect("the view lists a camera");
        let light = view.light_or_default(&frame);
        let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
        let primary = workload::primary(&camera, 256, 256).unwrap();
        let traced = check(name, &tree, &primary.rays, light, false);
        println!("{name}: {traced} spawned rays, none re-hits its triangle");
        assert!(traced > 20_000);
    }
}

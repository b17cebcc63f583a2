//! Agreement on the shared scenes: kd-tree == brute force, packet ==
//! scalar, ray by ray (never by checksum), on the protocol's workloads,
//! through the harness (`tests/common/harness.rs`).
//!
//! The scenes directory comes from `PACKTRACE_SCENES`. Every test here is
//! a scene test (`tests/common/scenes.rs`): ignored by a plain `cargo
//! test`, which lists it with the reason; run with
//! `PACKTRACE_SCENES=/path/to/scenes cargo test --test scenes --
//! --include-ignored`. A missing variable or file fails the test.

mod common;

use common::scenes::{scene_file, scenes_dir};
use common::{Engines, Placements, Reference, hit_bits};
use glam::Vec3;
use packtrace::group::RayGroup;
use packtrace::protocol::SceneFrame;
use packtrace::protocol::workload::{self, NO_RAY, RaySet};
use packtrace::{Camera, Hit, KdBuildParams, KdTree, Mesh, Ray, load_obj, load_view};
use std::path::Path;
use std::time::Instant;

/// Protocol image size.
const SIZE: u32 = 1024;

/// A loaded scene: its mesh, frame, listed camera and light (or defaults).
struct Scene {
    name: String,
    mesh: Mesh,
    frame: SceneFrame,
    camera: Camera,
    light: Vec3,
}

fn load_scene(dir: &Path, name: &str) -> Scene {
    let obj = scene_file(dir, &format!("{name}.obj"));
    scene_file(dir, &format!("{name}.view"));
    let mesh = load_obj(&obj).unwrap_or_else(|e| panic!("{e}"));
    let view = load_view(&obj).unwrap_or_else(|e| panic!("{e}"));
    let frame = SceneFrame::of(&mesh);
    let camera = view
        .camera
        .unwrap_or_else(|| panic!("{name}.view lists no camera"));
    let light = view.light_or_default(&frame);
    Scene {
        name: name.to_string(),
        mesh,
        frame,
        camera,
        light,
    }
}

/// The default preset's tree over the scene (validated), in the harness.
fn engines(s: &Scene) -> Engines<'_> {
    let t = Instant::now();
    let e = Engines::with_params(&s.mesh, &[("default", KdBuildParams::default())])
        .unwrap_or_else(|e| panic!("{e}"));
    println!(
        "{}: {} triangles, {} nodes, built and validated in {:.2} s",
        s.name,
        s.mesh.triangle_count(),
        e.trees[0].kd.node_count(),
        t.elapsed().as_secs_f64()
    );
    e
}

/// Every ray of the set sits in exactly one lane of the 4-wide packets and
/// in exactly one of the 8-wide ones, and no packet is empty.
fn assert_packets_cover(set: &RaySet, name: &str) {
    let lists: [Vec<&[u32]>; 2] = [
        set.packets.iter().map(|l| &l[..]).collect(),
        set.packets8.iter().map(|l| &l[..]).collect(),
    ];
    for (width, list) in [4, 8].into_iter().zip(lists) {
        let mut seen = vec![0u8; set.len()];
        for lanes in list {
            assert!(lanes.iter().any(|&l| l != NO_RAY), "{name}: empty packet");
            for &l in lanes.iter().filter(|&&l| l != NO_RAY) {
                seen[l as usize] += 1;
            }
        }
        assert!(
            seen.iter().all(|&c| c == 1),
            "{name}: a ray is not in exactly one lane of the {width}-wide packets"
        );
    }
}

/// Trace `set` both ways, compare lane by lane: the harness with the
/// scalar traversal as reference (brute force over a whole image is too
/// slow) and the set's 4- and 8-wide packets listed: `intersect4` and
/// `intersect8` against `intersect`, `occluded4` and `occluded8` against
/// `occluded`, inactive lanes report no hit, and the (sorting) stream API
/// from offset 0. Prints the protocol counters; returns the
/// mismatch count and the scalar closest hits.
fn packet_vs_scalar(
    engines: &mut Engines,
    scene: &str,
    workload: &str,
    set: &RaySet,
) -> (usize, Vec<Option<Hit>>) {
    assert_packets_cover(set, workload);
    // A whole image per workload: the kd layout, the set's own packets,
    // the stream from one offset (the naive layout, every lane placement
    // and every stream offset are checked on the bunny sample below).
    engines.options.reference = Reference::Scalar;
    engines.options.placements = Placements::None;
    engines.options.naive = false;
    engines.options.stream_offsets = 1;
    let lanes = |lanes: &[u32]| -> Vec<Option<usize>> {
        lanes
            .iter()
            .map(|&k| (k != NO_RAY).then_some(k as usize))
            .collect()
    };
    // Each list is traced by the packet width of its length.
    let packets: Vec<Vec<Option<usize>>> = set
        .packets
        .iter()
        .map(|l| lanes(l))
        .chain(set.packets8.iter().map(|l| lanes(l)))
        .collect();
    let t = Instant::now();
    let report = engines.agree_packets(&set.rays, &packets);
    let elapsed = t.elapsed().as_secs_f64();
    // The protocol's counters, sum_t in f64 in ray order
    let hits: Vec<Option<Hit>> = report.expected.iter().map(|a| a.hit).collect();
    let n_hits = hits.iter().flatten().count();
    let n_occ = report.expected.iter().filter(|a| a.occluded).count();
    let sum_t: f64 = hits.iter().flatten().map(|h| h.t as f64).sum();
    println!(
        "{scene}/{workload}: {} rays in {} + {} packets, hits {n_hits}, occluded {n_occ}, \
         sum_t {sum_t:.6}; traced and compared in {elapsed:.2} s, mismatches {}",
        set.len(),
        set.packets.len(),
        set.packets8.len(),
        report.total
    );
    if !report.is_ok() {
        eprintln!("{}", report.message(&format!("{scene}/{workload}")));
    }
    (report.total, hits)
}

/// All protocol workloads of a scene at 1024 x 1024, secondary rays derived
/// from the scalar primary hits: packet == scalar on every lane.
fn packet_equals_scalar(scene: &str) {
    let dir = scenes_dir();
    let start = Instant::now();
    let s = load_scene(&dir, scene);
    let mut e = engines(&s);
    let primary = workload::primary(&s.camera, SIZE, SIZE).unwrap();
    let (mut total, hits) = packet_vs_scalar(&mut e, scene, "primary", &primary);
    let shadow = workload::shadow(&primary, &hits, &s.mesh, &s.frame, s.light);
    total += packet_vs_scalar(&mut e, scene, "shadow", &shadow).0;
    drop(shadow);
    let ao = workload::ao(&primary, &hits, &s.mesh, &s.frame);
    total += packet_vs_scalar(&mut e, scene, "ao", &ao).0;
    drop(ao);
    let random = workload::random(&s.frame, (SIZE * SIZE) as usize);
    total += packet_vs_scalar(&mut e, scene, "random", &random).0;
    println!(
        "{scene}: all workloads in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    assert_eq!(
        total, 0,
        "{scene}: packet and scalar traversal disagree (see stderr)"
    );
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn packet_equals_scalar_full_image_bunny() {
    packet_equals_scalar("bunny");
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn packet_equals_scalar_full_image_sponza() {
    packet_equals_scalar("sponza");
}

/// 20,000 protocol primary rays of the bunny (every 52nd pixel of the
/// 1024 x 1024 image, in ray order): kd-tree == brute force exactly, for
/// closest hit and occlusion, on every path of the harness (scalar, naive
/// layout, lane placements in turn, stream); and on every 4th of them with
/// the interval cut to half the hit distance and to exactly the hit
/// distance. Brute force costs about 60,000 scans of 69,451 triangles.
#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn kd_equals_brute_on_bunny_primary() {
    let dir = scenes_dir();
    let start = Instant::now();
    let s = load_scene(&dir, "bunny");
    let mut e = engines(&s);
    // Packets beside zero-direction lanes visit every cell: too slow here.
    e.options.placements = Placements::Cycle;
    e.options.zero_neighbours = false;
    let primary = workload::primary(&s.camera, SIZE, SIZE).unwrap();
    let pixels: Vec<usize> = (0..20_000).map(|i| i * 52).collect();
    let sample: Vec<Ray> = pixels.iter().map(|&p| primary.rays[p]).collect();
    let report = e
        .agree(&sample)
        .name_rays(|k| format!("pixel {}", pixels[k]));
    // every 4th ray: up to half and exactly the (brute-force) hit distance
    let mut cut = Vec::new();
    let mut cut_pixels = Vec::new();
    for (k, r) in sample.iter().enumerate().step_by(4) {
        if let Some(h) = report.hit(k) {
            cut.push(r.with_interval(r.t_min(), h.t * 0.5).unwrap());
            cut.push(r.with_interval(r.t_min(), h.t).unwrap());
            cut_pixels.extend([pixels[k]; 2]);
        }
    }
    let cut_report = e
        .agree(&cut)
        .name_rays(|k| format!("pixel {}, interval cut", cut_pixels[k]));
    let hits = report.expected.iter().filter(|a| a.hit.is_some()).count();
    let mismatches = report.total + cut_report.total;
    println!(
        "bunny kd vs brute: {} rays and {} cut intervals, {hits} hits, {mismatches} mismatches, {:.1} s",
        sample.len(),
        cut.len(),
        start.elapsed().as_secs_f64()
    );
    for (r, what) in [
        (&report, "bunny kd vs brute"),
        (&cut_report, "bunny kd vs brute, cut"),
    ] {
        if !r.is_ok() {
            eprintln!("{}", r.message(what));
        }
    }
    assert!(hits > 2000, "only {hits} of the sampled rays hit the bunny");
    assert_eq!(
        mismatches, 0,
        "kd-tree and brute force disagree (see stderr)"
    );
}

/// The protocol's primary rays (from the eye) and shadow rays (toward the
/// light) of a scene at 1024 x 1024, traced as 8 x 8 and 16 x 16 tile
/// groups: every lane equals the scalar query, closest hit and occlusion.
fn group_equals_scalar(scene: &str) {
    let dir = scenes_dir();
    let s = load_scene(&dir, scene);
    let tree = KdTree::build(s.mesh.clone(), &KdBuildParams::default()).unwrap();
    let primary = workload::primary(&s.camera, SIZE, SIZE).unwrap();
    let hits: Vec<_> = primary.rays.iter().map(|r| tree.intersect(r)).collect();
    let shadow = workload::shadow(&primary, &hits, &s.mesh, &s.frame, s.light);
    let mut bad = Vec::new();
    for (name, set) in [("primary", &primary), ("shadow", &shadow)] {
        let (apex, kind) = set.apex.expect("image workloads have an apex");
        let want: Vec<(Option<Hit>, bool)> = set
            .rays
            .iter()
            .map(|r| (tree.intersect(r), tree.occluded(r)))
            .collect();
        for tile in [8, 16] {
            let mut coherent = 0;
            for t in set.tiles(tile, tile) {
                let packets: Vec<_> = t.iter().map(|&i| set.packet8(i as usize)).collect();
                let g = RayGroup::new(&packets, apex, kind).unwrap();
                coherent += usize::from(g.is_coherent());
                let got = tree.intersect_group(&g);
                let occ = tree.occluded_group(&g);
                for (j, &i) in t.iter().enumerate() {
                    for (l, &ray) in set.packets8[i as usize].iter().enumerate() {
                        if ray == NO_RAY {
                            continue;
                        }
                        let (h, o) = want[ray as usize];
                        if hit_bits(got[j].hit(l)) != hit_bits(h) || (occ[j] >> l & 1 == 1) != o {
                            bad.push(format!("{name} {tile}x{tile} ray {ray}"));
                        }
                    }
                }
            }
            println!("{scene} {name} {tile}x{tile}: {coherent} coherent tiles");
            assert!(coherent > 0, "{scene} {name}: no tile had a frustum");
        }
    }
    assert!(
        bad.is_empty(),
        "{scene}: {} rays differ, first {:?}",
        bad.len(),
        &bad[..bad.len().min(5)]
    );
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn group_equals_scalar_full_image_bunny() {
    group_equals_scalar("bunny");
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn group_equals_scalar_full_image_sponza() {
    group_equals_scalar("sponza");
}

/// Issue 16 on real meshes: the mesh as one identity instance of a scene
/// traces every primary and shadow ray of the image exactly as the bare
/// kd-tree does (scalar, 4- and 8-wide packets, streams); the mesh as two
/// instances (rotated and scaled; mirrored) traces the same rays moved
/// into the first instance's place equal to the scene's scalar path on
/// every packet width and stream, and equal to the brute-force scene
/// oracle on a sample of them.
fn instance_equals_kd(scene: &str) {
    use glam::{Affine3A, Quat};
    use packtrace::scene::{BruteScene, Query, Scene as World, SceneHit, SceneQuery};
    let dir = scenes_dir();
    let s = load_scene(&dir, scene);
    let tree =
        std::sync::Arc::new(KdTree::build(s.mesh.clone(), &KdBuildParams::default()).unwrap());
    let primary = workload::primary(&s.camera, SIZE, SIZE).unwrap();
    let hits: Vec<_> = primary.rays.iter().map(|r| tree.intersect(r)).collect();
    let shadow = workload::shadow(&primary, &hits, &s.mesh, &s.frame, s.light);
    let q = Query::new();
    // Answers compared bit for bit (`-0.0` is not `0.0`), as everywhere
    // else in the suite.
    let as_hit = |h: Option<SceneHit>| {
        hit_bits(h.map(|h| Hit {
            t: h.t,
            prim: h.prim,
            u: h.u,
            v: h.v,
        }))
    };
    let scene_bits = |h: Option<SceneHit>| h.map(|h| (as_hit(Some(h)), h.geometry, h.instance));

    // One identity instance: exactly the bare tree.
    let mut one = World::new();
    let g = one.add_shared_geometry(scene, tree.clone());
    one.edit().add_instance(g, Affine3A::IDENTITY).unwrap();
    let mut bad = Vec::new();
    for (name, set) in [("primary", &primary), ("shadow", &shadow)] {
        let mut stream = vec![None; set.len()];
        one.intersect_rays_with(&set.rays, &mut stream, &q);
        let mut stream_occ = vec![false; set.len()];
        one.occluded_rays_with(&set.rays, &mut stream_occ, &q);
        for (k, r) in set.rays.iter().enumerate() {
            let (h, o) = (hit_bits(tree.intersect(r)), tree.occluded(r));
            if as_hit(one.intersect(r)) != h || one.occluded(r) != o {
                bad.push(format!("{name} scalar ray {k}"));
            }
            if as_hit(stream[k]) != h || stream_occ[k] != o {
                bad.push(format!("{name} stream ray {k}"));
            }
        }
        for (i, lanes) in set.packets8.iter().enumerate() {
            let p = set.packet8(i);
            let (h, o) = (one.intersect_packet(&p, &q), one.occluded_packet(&p, &q));
            for (l, &ray) in lanes.iter().enumerate() {
                if ray == NO_RAY {
                    continue;
                }
                let r = &set.rays[ray as usize];
                if as_hit(h.hit(l)) != hit_bits(tree.intersect(r))
                    || (o >> l & 1 == 1) != tree.occluded(r)
                {
                    bad.push(format!("{name} packet8 ray {ray}"));
                }
            }
        }
        for (i, lanes) in set.packets.iter().enumerate() {
            let p = set.packet(i);
            let (h, o) = (one.intersect_packet(&p, &q), one.occluded_packet(&p, &q));
            for (l, &ray) in lanes.iter().enumerate() {
                if ray == NO_RAY {
                    continue;
                }
                let r = &set.rays[ray as usize];
                if as_hit(h.hit(l)) != hit_bits(tree.intersect(r))
                    || (o >> l & 1 == 1) != tree.occluded(r)
                {
                    bad.push(format!("{name} packet4 ray {ray}"));
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{scene} identity instance: {} rays differ, first {:?}",
        bad.len(),
        &bad[..bad.len().min(5)]
    );

    // Two instances, rotated and scaled, and mirrored beside it.
    let m = Affine3A::from_scale_rotation_translation(
        glam::Vec3::splat(1.7),
        Quat::from_euler(glam::EulerRot::YXZ, 0.6, -0.2, 0.1),
        glam::Vec3::new(3.0, -1.0, 2.0) * s.frame.diagonal,
    );
    let mirror = m * Affine3A::from_scale(glam::Vec3::new(-1.0, 1.0, 1.0));
    let mut two = World::new();
    let g = two.add_shared_geometry(scene, tree.clone());
    two.edit().add_instance(g, m).unwrap();
    two.edit().add_instance(g, mirror).unwrap();
    let brute = BruteScene::new(&two);
    let moved = |r: &Ray| {
        Ray::new(
            m.transform_point3(r.origin()),
            m.transform_vector3(r.dir()),
            r.t_min(),
            r.t_max(),
        )
        .ok()
    };
    let mut hit_count = 0;
    for (name, set) in [("primary", &primary), ("shadow", &shadow)] {
        let rays: Vec<Option<Ray>> = set.rays.iter().map(moved).collect();
        let want: Vec<_> = rays
            .iter()
            .map(|r| r.map(|r| (two.intersect(&r), two.occluded(&r))))
            .collect();
        hit_count += want.iter().flatten().filter(|w| w.0.is_some()).count();
        let lane_ray = |lanes: &[u32], l: usize| {
            lanes
                .get(l)
                .filter(|&&r| r != NO_RAY)
                .and_then(|&r| rays[r as usize])
        };
        let mut check = |lanes: &[u32], h: &dyn Fn(usize) -> Option<SceneHit>, o: u32, w| {
            for (l, &ray) in lanes.iter().enumerate() {
                let Some(Some((wh, wo))) = (ray != NO_RAY).then(|| want[ray as usize]) else {
                    continue;
                };
                if scene_bits(h(l)) != scene_bits(wh) || (o >> l & 1 == 1) != wo {
                    bad.push(format!("{name} moved packet{w} ray {ray}"));
                }
            }
        };
        for lanes in &set.packets8 {
            let p = packtrace::RayPacket8::from_fn(|l| lane_ray(lanes, l));
            let (h, o) = (two.intersect_packet(&p, &q), two.occluded_packet(&p, &q));
            check(lanes, &|l| h.hit(l), o, 8);
        }
        for lanes in &set.packets {
            let p = packtrace::RayPacket4::from_fn(|l| lane_ray(lanes, l));
            let (h, o) = (two.intersect_packet(&p, &q), two.occluded_packet(&p, &q));
            check(lanes, &|l| h.hit(l), o, 4);
        }
        let (mut stream, mut stream_occ) = (vec![None; set.len()], vec![false; set.len()]);
        let valid: Vec<Ray> = rays.iter().flatten().copied().collect();
        two.intersect_rays_with(&valid, &mut stream[..valid.len()], &q);
        two.occluded_rays_with(&valid, &mut stream_occ[..valid.len()], &q);
        let wanted = want.iter().flatten();
        for (k, (w, (h, o))) in wanted.zip(stream.iter().zip(&stream_occ)).enumerate() {
            if scene_bits(*h) != scene_bits(w.0) || *o != w.1 {
                bad.push(format!("{name} moved stream, valid ray {k}"));
            }
        }
        // The oracle on every 509th ray (brute force over a whole image
        // is too slow).
        for k in (0..set.len()).step_by(509) {
            if let Some(r) = rays[k] {
                let w = want[k].unwrap();
                if scene_bits(brute.intersect_with(&r, &q)) != scene_bits(w.0)
                    || brute.occluded_with(&r, &q) != w.1
                {
                    bad.push(format!("{name} moved ray {k} vs brute force"));
                }
            }
        }
    }
    println!("{scene}: two instances, {hit_count} of the moved rays hit");
    assert!(
        hit_count > SIZE as usize * SIZE as usize / 10,
        "{scene}: few moved rays hit"
    );
    assert!(
        bad.is_empty(),
        "{scene} two instances: {} rays differ, first {:?}",
        bad.len(),
        &bad[..bad.len().min(5)]
    );
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn instance_equals_kd_full_image_bunny() {
    instance_equals_kd("bunny");
}

#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn instance_equals_kd_full_image_sponza() {
    instance_equals_kd("sponza");
}

//! Agreement on the shared scenes: kd-tree == brute force, packet ==
//! scalar, ray by ray (never by checksum), on the protocol's workloads.
//!
//! The scenes directory comes from `PACKTRACE_SCENES` (e.g.
//! `PACKTRACE_SCENES=/work/shared/scenes cargo test --test scenes`). Unset:
//! every test prints a note and passes. Set: a missing file fails the test.

use glam::Vec3;
use packtrace::protocol::SceneFrame;
use packtrace::protocol::workload::{self, NO_RAY, RaySet};
use packtrace::{
    BruteForce, Camera, Hit, KdBuildParams, KdTree, Ray, RayQuery, load_obj, load_view,
};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Protocol image size.
const SIZE: u32 = 1024;
/// Mismatches printed per test.
const SHOW: usize = 8;

/// The scenes directory, or `None` (with a note) when the variable is unset.
fn scenes_dir(test: &str) -> Option<PathBuf> {
    match std::env::var_os("PACKTRACE_SCENES") {
        Some(d) => Some(PathBuf::from(d)),
        None => {
            eprintln!("note: {test} skipped: set PACKTRACE_SCENES to the shared scenes directory");
            None
        }
    }
}

/// A file the test needs: fails the test when it is missing.
fn need(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    assert!(
        p.is_file(),
        "PACKTRACE_SCENES={} but {} is missing (or not a file)",
        dir.display(),
        p.display()
    );
    p
}

/// A loaded scene: its tree, frame, listed camera and light (or defaults).
struct Scene {
    tree: KdTree,
    frame: SceneFrame,
    camera: Camera,
    light: Vec3,
}

fn load_scene(dir: &Path, name: &str) -> Scene {
    let obj = need(dir, &format!("{name}.obj"));
    need(dir, &format!("{name}.view"));
    let mesh = load_obj(&obj).unwrap_or_else(|e| panic!("{e}"));
    let view = load_view(&obj).unwrap_or_else(|e| panic!("{e}"));
    let frame = SceneFrame::of(&mesh);
    let camera = view
        .camera
        .unwrap_or_else(|| panic!("{name}.view lists no camera"));
    let light = view.light_or_default(&frame);
    let t = Instant::now();
    let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "{name}: {} triangles, {} nodes, built in {:.2} s",
        tree.mesh().triangle_count(),
        tree.node_count(),
        t.elapsed().as_secs_f64()
    );
    Scene {
        tree,
        frame,
        camera,
        light,
    }
}

/// A ray as Rust source, exact (Debug prints round-trip `f32`s).
fn show_ray(r: &Ray) -> String {
    format!(
        "Ray::new_unchecked(Vec3::new({:?}, {:?}, {:?}), Vec3::new({:?}, {:?}, {:?}), {:?}, {:?})",
        r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.t_min, r.t_max
    )
}

/// Mismatch count and the first few (ordered by where they occur).
#[derive(Default)]
struct Mismatches {
    count: usize,
    first: Vec<(usize, String)>,
}

impl Mismatches {
    fn add(mut self, at: usize, what: String) -> Mismatches {
        self.count += 1;
        self.first.push((at, what));
        self.first.sort_by_key(|m| m.0);
        self.first.truncate(SHOW);
        self
    }

    fn merge(mut self, o: Mismatches) -> Mismatches {
        self.count += o.count;
        self.first.extend(o.first);
        self.first.sort_by_key(|m| m.0);
        self.first.truncate(SHOW);
        self
    }

    fn report(&self, what: &str) {
        if self.count > 0 {
            eprintln!("{what}: {} mismatches; first ones:", self.count);
            for (_, m) in &self.first {
                eprintln!("  {m}");
            }
        }
    }
}

/// Every ray of the set sits in exactly one lane, and no packet is empty.
fn assert_packets_cover(set: &RaySet, name: &str) {
    let mut seen = vec![0u8; set.len()];
    for lanes in &set.packets {
        assert!(lanes.iter().any(|&l| l != NO_RAY), "{name}: empty packet");
        for &l in lanes.iter().filter(|&&l| l != NO_RAY) {
            seen[l as usize] += 1;
        }
    }
    assert!(
        seen.iter().all(|&c| c == 1),
        "{name}: a ray is not in exactly one lane"
    );
}

/// Trace `set` both ways, compare lane by lane: `intersect4` against
/// `intersect` and `occluded4` against `occluded`. Inactive lanes must
/// report no hit. Prints the protocol counters; returns the mismatches and
/// the scalar closest hits.
fn packet_vs_scalar(
    tree: &KdTree,
    scene: &str,
    workload: &str,
    set: &RaySet,
) -> (Mismatches, Vec<Option<Hit>>) {
    assert_packets_cover(set, workload);
    let t = Instant::now();
    let hits: Vec<Option<Hit>> = set.rays.par_iter().map(|r| tree.intersect(r)).collect();
    let occluded: Vec<bool> = set.rays.par_iter().map(|r| tree.occluded(r)).collect();
    let scalar_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let found = (0..set.packets.len())
        .into_par_iter()
        .fold(Mismatches::default, |mut acc, i| {
            let packet = set.packet(i);
            let h4 = tree.intersect4(&packet);
            let o4 = tree.occluded4(&packet);
            for (lane, &k) in set.packets[i].iter().enumerate() {
                let (hit, occ) = (h4.hit(lane), o4 >> lane & 1 == 1);
                if k == NO_RAY {
                    if hit.is_some() || occ {
                        let what = format!(
                            "{scene}/{workload} packet {i} lane {lane}: inactive lane reports \
                             hit {hit:?} occluded {occ}"
                        );
                        acc = acc.add(i * 4 + lane, what);
                    }
                    continue;
                }
                let r = &set.rays[k as usize];
                if hit != hits[k as usize] {
                    let what = format!(
                        "{scene}/{workload} ray {k} (packet {i} lane {lane}) {}: \
                         intersect {:?} != intersect4 {hit:?}",
                        show_ray(r),
                        hits[k as usize]
                    );
                    acc = acc.add(i * 4 + lane, what);
                }
                if occ != occluded[k as usize] {
                    let what = format!(
                        "{scene}/{workload} ray {k} (packet {i} lane {lane}) {}: \
                         occluded {} != occluded4 {occ}",
                        show_ray(r),
                        occluded[k as usize]
                    );
                    acc = acc.add(i * 4 + lane, what);
                }
            }
            acc
        })
        .reduce(Mismatches::default, Mismatches::merge);
    let packet_s = t.elapsed().as_secs_f64();
    // The protocol's counters, sum_t in f64 in ray order
    let n_hits = hits.iter().flatten().count();
    let n_occ = occluded.iter().filter(|&&o| o).count();
    let sum_t: f64 = hits.iter().flatten().map(|h| h.t as f64).sum();
    println!(
        "{scene}/{workload}: {} rays in {} packets, hits {n_hits}, occluded {n_occ}, \
         sum_t {sum_t:.6}; scalar {scalar_s:.2} s, packet {packet_s:.2} s, mismatches {}",
        set.len(),
        set.packets.len(),
        found.count
    );
    found.report(&format!("{scene}/{workload}"));
    (found, hits)
}

/// All protocol workloads of a scene at 1024 x 1024, secondary rays derived
/// from the scalar primary hits: packet == scalar on every lane.
fn packet_equals_scalar(scene: &str) {
    let Some(dir) = scenes_dir(&format!("packet_equals_scalar_full_image_{scene}")) else {
        return;
    };
    let start = Instant::now();
    let s = load_scene(&dir, scene);
    let tree = &s.tree;
    let primary = workload::primary(&s.camera, SIZE, SIZE).unwrap();
    let (found, hits) = packet_vs_scalar(tree, scene, "primary", &primary);
    let mut total = found.count;
    let shadow = workload::shadow(&primary, &hits, tree.mesh(), &s.frame, s.light);
    total += packet_vs_scalar(tree, scene, "shadow", &shadow).0.count;
    drop(shadow);
    let ao = workload::ao(&primary, &hits, tree.mesh(), &s.frame);
    total += packet_vs_scalar(tree, scene, "ao", &ao).0.count;
    drop(ao);
    let random = workload::random(&s.frame, (SIZE * SIZE) as usize);
    total += packet_vs_scalar(tree, scene, "random", &random).0.count;
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
fn packet_equals_scalar_full_image_bunny() {
    packet_equals_scalar("bunny");
}

#[test]
fn packet_equals_scalar_full_image_sponza() {
    packet_equals_scalar("sponza");
}

/// 20,000 protocol primary rays of the bunny (every 52nd pixel of the
/// 1024 x 1024 image, in ray order): kd-tree == brute force exactly, for
/// closest hit; and for occlusion on every 4th of them (full interval, half
/// the hit distance, exactly the hit distance). Brute force costs about
/// 26,000 full scans of 69,451 triangles.
#[test]
fn kd_equals_brute_on_bunny_primary() {
    let Some(dir) = scenes_dir("kd_equals_brute_on_bunny_primary") else {
        return;
    };
    let start = Instant::now();
    let s = load_scene(&dir, "bunny");
    let tree = &s.tree;
    let brute = BruteForce::new(tree.mesh());
    let primary = workload::primary(&s.camera, SIZE, SIZE).unwrap();
    let sample: Vec<(usize, Ray)> = (0..20_000)
        .map(|i| (i * 52, primary.rays[i * 52]))
        .collect();
    let found = sample
        .par_iter()
        .fold(Mismatches::default, |mut acc, &(p, r)| {
            let kd = tree.intersect(&r);
            let bf = brute.intersect(&r);
            if kd != bf {
                let what = format!("pixel {p} {}: kd {kd:?} != brute {bf:?}", show_ray(&r));
                acc = acc.add(p, what);
            }
            // every 4th ray: occlusion over the full interval, then up to
            // half and exactly the (brute-force) hit distance
            if p % (4 * 52) != 0 {
                return acc;
            }
            let mut tests = vec![r];
            if let Some(h) = bf {
                tests.push(Ray {
                    t_max: h.t * 0.5,
                    ..r
                });
                tests.push(Ray { t_max: h.t, ..r });
            }
            for q in tests {
                let (kd, bf) = (tree.occluded(&q), brute.occluded(&q));
                if kd != bf {
                    let what =
                        format!("pixel {p} {}: kd occluded {kd} != brute {bf}", show_ray(&q));
                    acc = acc.add(p, what);
                }
            }
            acc
        })
        .reduce(Mismatches::default, Mismatches::merge);
    let hits = sample
        .iter()
        .filter(|(_, r)| tree.intersect(r).is_some())
        .count();
    println!(
        "bunny kd vs brute: {} rays, {hits} hits, {} mismatches, {:.1} s",
        sample.len(),
        found.count,
        start.elapsed().as_secs_f64()
    );
    found.report("bunny kd vs brute");
    assert!(hits > 2000, "only {hits} of the sampled rays hit the bunny");
    assert_eq!(
        found.count, 0,
        "kd-tree and brute force disagree (see stderr)"
    );
}

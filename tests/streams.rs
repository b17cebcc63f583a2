//! The breadth-first stream traversal (`KdTree::intersect_stream`,
//! `occluded_stream`, and the one-shot `intersect_rays` /
//! `occluded_rays`) equals the scalar traversal and brute force ray by
//! ray, bit for bit (`t`, triangle, `u`, `v`; occlusion): on random scenes
//! with streams of 1 to several thousand rays of mixed direction octants,
//! rays with empty intervals and axis-parallel directions, origins on
//! split planes, intervals that end or start exactly at a hit, huge and
//! tiny coordinates, every build preset, every stream size and
//! single-ray threshold (down to one ray per chunk, and every subset
//! finished alone or none), and a scratch reused across calls of
//! different sizes. The kernel is the process's (`PACKTRACE_KERNEL=sse`
//! or `avx2` forces a lesser one; CI runs this file with each); the
//! library's unit tests run all three kernels in one process
//! (`kdtree::stream`).

mod common;

use common::*;
use glam::Vec3;
use packtrace::kdtree::{StreamOptions, StreamScratch};
use packtrace::{BruteForce, Hit, KdBuildParams, KdTree, Mesh, Ray, RayQuery, TraversalStats};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Every ray of `rays` through the stream with `scratch`: closest hits
/// and occlusion equal the scalar queries' bit for bit, and brute
/// force's when `brute` is given.
fn check(
    tree: &KdTree,
    brute: Option<&BruteForce>,
    rays: &[Ray],
    scratch: &mut StreamScratch,
) -> Result<(), String> {
    let mut hits = vec![
        Some(Hit {
            t: -1.0,
            prim: 7,
            u: 0.5,
            v: 0.5
        });
        rays.len()
    ];
    let mut occ = vec![true; rays.len()];
    tree.intersect_stream(rays, &mut hits, scratch);
    tree.occluded_stream(rays, &mut occ, scratch);
    for (i, r) in rays.iter().enumerate() {
        let want = tree.intersect(r);
        let want_occ = tree.occluded(r);
        if hit_bits(hits[i]) != hit_bits(want) || occ[i] != want_occ {
            return Err(format!(
                "ray {i} of {} ({:?}): stream {:?} / occluded {}, scalar {:?} / occluded {}\n{}",
                rays.len(),
                scratch.options(),
                hits[i],
                occ[i],
                want,
                want_occ,
                ray_literal(r)
            ));
        }
        if let Some(b) = brute {
            let (bh, bo) = (b.intersect(r), b.occluded(r));
            if hit_bits(bh) != hit_bits(want) || bo != want_occ {
                return Err(format!(
                    "ray {i}: scalar {want:?} / {want_occ}, brute {bh:?} / {bo}\n{}",
                    ray_literal(r)
                ));
            }
        }
    }
    Ok(())
}

/// The options the properties try: chunks of one ray, a few, the default;
/// no single-ray finish, some, every subset alone; intervals or cell
/// boxes.
fn options() -> impl Strategy<Value = StreamOptions> {
    (
        prop::sample::select(&[1usize, 2, 7, 64, 1000][..]),
        prop::sample::select(&[0usize, 1, 3, 8, 64, usize::MAX][..]),
        any::<bool>(),
    )
        .prop_map(|(n, t, b)| StreamOptions::new(n, t).unwrap().with_cell_boxes(b))
}

/// `count` random rays around the mesh: origins in the box grown by half
/// its size, uniform directions (every octant), intervals full or finite.
fn random_rays(mesh: &Mesh, count: usize, seed: u64) -> Vec<Ray> {
    let (lo, hi) = scene_box(mesh);
    let (c, h) = ((lo + hi) * 0.5, (hi - lo).max(Vec3::splat(1e-3)));
    let mut g = Rng(seed);
    (0..count)
        .map(|_| {
            let o = c + Vec3::new(g.range(-1.0, 1.0), g.range(-1.0, 1.0), g.range(-1.0, 1.0)) * h;
            let t_max = if g.coin() {
                f32::INFINITY
            } else {
                g.range(0.0, 2.0) * h.length()
            };
            Ray::new(o, g.unit(), 0.0, t_max).unwrap()
        })
        .collect()
}

proptest! {
    #![proptest_config(config(48))]

    /// Streams of the generators' hostile rays (split planes, box faces,
    /// corners, edge midpoints, axis-parallel and signed-zero directions,
    /// empty intervals, intervals at a hit), each repeated, beside up to
    /// 3,000 random rays: stream == scalar == brute force for every option.
    #[test]
    fn stream_equals_scalar_and_brute(
        spec in any_mesh(),
        specs in prop::collection::vec(ray_spec(), 1..48),
        copies in 1usize..40,
        random in prop_oneof![Just(0usize), 1usize..3000],
        seed in any::<u64>(),
        opts in options(),
    ) {
        let mesh = spec.mesh();
        let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
        let brute = BruteForce::new(&mesh);
        let mut rays: Vec<Ray> = specs.iter().map(|s| make_ray(s, &mesh)).collect();
        let hostile = rays.clone();
        for _ in 1..copies {
            rays.extend_from_slice(&hostile);
        }
        rays.extend(random_rays(&mesh, random, seed));
        // Interleaved, so that each octant's rays are scattered.
        let mut g = Rng(seed ^ 1);
        for i in (1..rays.len()).rev() {
            rays.swap(i, g.below(i + 1));
        }
        check(&tree, Some(&brute), &rays, &mut StreamScratch::with_options(opts))
            .map_err(TestCaseError::fail)?;
    }

    /// Intervals that end or start exactly at each ray's closest hit, or
    /// one ulp either side, in streams.
    #[test]
    fn intervals_at_hits(spec in any_mesh(), seed in any::<u64>(), opts in options()) {
        let mesh = spec.mesh();
        let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
        let brute = BruteForce::new(&mesh);
        let mut rays = Vec::new();
        for r in random_rays(&mesh, 400, seed) {
            if let Some(h) = tree.intersect(&r) {
                let (o, d) = (r.origin(), r.dir());
                for (t0, t1) in [
                    (0.0, h.t),
                    (0.0, h.t.next_up()),
                    (0.0, h.t.next_down()),
                    (h.t, f32::INFINITY),
                    (h.t.next_down(), h.t),
                    (h.t.next_down(), f32::INFINITY),
                ] {
                    rays.push(Ray::new(o, d, t0, t1).unwrap());
                }
            }
        }
        check(&tree, Some(&brute), &rays, &mut StreamScratch::with_options(opts))
            .map_err(TestCaseError::fail)?;
    }
}

/// Rays started exactly on every split plane of the tree (and on the
/// planes one ulp either side), in all eight octants and along the axes.
#[test]
fn origins_on_split_planes() {
    let mut g = Rng(17);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..300u32 {
        let c = Vec3::new(g.range(-4.0, 4.0), g.range(-4.0, 4.0), g.range(-4.0, 4.0));
        for _ in 0..3 {
            positions
                .push(c + Vec3::new(g.range(-0.5, 0.5), g.range(-0.5, 0.5), g.range(-0.5, 0.5)));
        }
        triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let mesh = Mesh::new(positions, triangles).unwrap();
    let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
    let brute = BruteForce::new(&mesh);
    let mut rays = Vec::new();
    for (axis, split) in tree.split_planes() {
        for s in [split.next_down(), split, split.next_up()] {
            let mut o = Vec3::new(g.range(-5.0, 5.0), g.range(-5.0, 5.0), g.range(-5.0, 5.0));
            o[axis] = s;
            let mut d = g.unit();
            if g.below(4) == 0 {
                d[axis] = 0.0; // in the plane
            }
            if g.below(8) == 0 {
                d = Vec3::ZERO;
                d[(axis + 1) % 3] = if g.coin() { 1.0 } else { -1.0 };
            }
            rays.push(Ray::new(o, d, 0.0, f32::INFINITY).unwrap());
        }
    }
    assert!(rays.len() > 300, "{} rays", rays.len());
    for opts in [
        StreamOptions::DEFAULT,
        StreamOptions::new(5, 2).unwrap(),
        StreamOptions::DEFAULT.with_cell_boxes(true),
        StreamOptions::new(5, 2).unwrap().with_cell_boxes(true),
    ] {
        check(
            &tree,
            Some(&brute),
            &rays,
            &mut StreamScratch::with_options(opts),
        )
        .unwrap();
    }
}

/// Huge and tiny scenes (coordinates from 1e-20 to 1e20, offsets up to
/// 1e6 of their size): the margin and the f64 route hold for streams.
#[test]
fn huge_and_tiny_coordinates() {
    let mut g = Rng(5);
    for scale in [1e-20f32, 1e-6, 1e-2, 1.0, 1e3, 1e12, 1e20] {
        for offset in [0.0f32, 1e6] {
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            for i in 0..200u32 {
                let c = Vec3::new(g.range(-1.0, 1.0), g.range(-1.0, 1.0), g.range(-1.0, 1.0));
                for _ in 0..3 {
                    let p =
                        c + Vec3::new(g.range(-0.2, 0.2), g.range(-0.2, 0.2), g.range(-0.2, 0.2));
                    positions.push((p + Vec3::splat(offset)) * scale);
                }
                triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
            }
            let mesh = Mesh::new(positions, triangles).unwrap();
            let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
            let brute = BruteForce::new(&mesh);
            let rays = random_rays(&mesh, 1500, scale.to_bits() as u64);
            for boxes in [false, true] {
                let opts = StreamOptions::DEFAULT.with_cell_boxes(boxes);
                check(
                    &tree,
                    Some(&brute),
                    &rays,
                    &mut StreamScratch::with_options(opts),
                )
                .unwrap_or_else(|e| panic!("scale {scale}, offset {offset}: {e}"));
            }
        }
    }
}

/// Every build preset, on a closed jittered sphere (rays from inside: all
/// hit) and rays of the four workload kinds: from a pinhole, toward a
/// light (occlusion), short ambient-occlusion rays off the surface, and
/// random rays.
#[test]
fn every_preset_every_workload_kind() {
    let mesh = packtrace::protocol::generate::jittered_sphere(3000, 9, 0.3);
    let (lo, hi) = scene_box(&mesh);
    let (c, size) = ((lo + hi) * 0.5, (hi - lo).length());
    let mut g = Rng(23);
    let mut rays = Vec::new();
    let eye = c + Vec3::new(0.3, 0.4, 1.0) * size;
    for _ in 0..1500 {
        let target =
            c + Vec3::new(g.range(-0.5, 0.5), g.range(-0.5, 0.5), g.range(-0.5, 0.5)) * size;
        rays.push(Ray::new(eye, target - eye, 0.0, f32::INFINITY).unwrap());
    }
    for t in 0..mesh.triangle_count().min(1500) {
        let [a, b, cc] = *mesh.corners(t);
        let p = (a + b + cc) / 3.0;
        let n = (b - a).cross(cc - a).normalize_or_zero();
        let q = p + n * (1e-4 * size);
        rays.push(Ray::new(q, g.unit(), 0.0, 0.25 * size).unwrap());
        let light = c + Vec3::new(0.25, 0.8, 0.35) * size;
        rays.push(Ray::new(q, light - q, 0.0, (light - q).length() * (1.0 - 1e-4)).unwrap());
        rays.push(Ray::new(c, g.unit(), 0.0, f32::INFINITY).unwrap());
    }
    rays.extend(random_rays(&mesh, 1500, 3));
    let brute = BruteForce::new(&mesh);
    for (name, params) in KdBuildParams::presets() {
        let tree = KdTree::build(mesh.clone(), &params).unwrap();
        for opts in [
            StreamOptions::DEFAULT,
            StreamOptions::new(97, 1).unwrap(),
            StreamOptions::new(4096, 64).unwrap(),
            StreamOptions::DEFAULT.with_cell_boxes(true),
            StreamOptions::new(97, 1).unwrap().with_cell_boxes(true),
        ] {
            check(
                &tree,
                Some(&brute),
                &rays,
                &mut StreamScratch::with_options(opts),
            )
            .unwrap_or_else(|e| panic!("preset {name}: {e}"));
        }
        // Rays from the centre of the closed sphere all hit.
        let inside: Vec<Ray> = (0..500)
            .map(|_| Ray::new(c, g.unit(), 0.0, f32::INFINITY).unwrap())
            .collect();
        let mut occ = vec![false; inside.len()];
        tree.occluded_rays(&inside, &mut occ);
        assert!(
            occ.iter().all(|&o| o),
            "preset {name}: a ray escaped the closed sphere"
        );
    }
}

/// One scratch reused across streams of different sizes and options
/// answers as a fresh one does, and the one-shot calls as well.
#[test]
fn scratch_reuse_across_sizes_equals_fresh_scratch() {
    let mesh = packtrace::protocol::generate::sphere(2000);
    let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
    let all = random_rays(&mesh, 6000, 11);
    let mut kept = StreamScratch::with_options(StreamOptions::new(512, 4).unwrap());
    for &n in &[3000usize, 1, 0, 500, 17, 5999, 2, 6000] {
        let rays = &all[all.len() - n..];
        let (mut a, mut b, mut c) = (vec![None; n], vec![None; n], vec![None; n]);
        tree.intersect_stream(rays, &mut a, &mut kept);
        tree.intersect_stream(
            rays,
            &mut b,
            &mut StreamScratch::with_options(kept.options()),
        );
        tree.intersect_rays(rays, &mut c);
        let (mut oa, mut ob) = (vec![false; n], vec![false; n]);
        tree.occluded_stream(rays, &mut oa, &mut kept);
        tree.occluded_rays(rays, &mut ob);
        for i in 0..n {
            assert_eq!(hit_bits(a[i]), hit_bits(b[i]), "n {n} ray {i}");
            assert_eq!(hit_bits(a[i]), hit_bits(c[i]), "n {n} ray {i}");
            assert_eq!(oa[i], ob[i], "n {n} ray {i}");
        }
    }
    assert!(kept.bytes() > 6000 * 4, "the scratch kept its arrays");
}

/// The counted calls: every ray is counted, subsets never visit a node
/// with fewer rays than the threshold, partitions are node visits that
/// split, and a threshold above the stream size finishes every ray alone
/// (the scalar traversal's node count exactly).
#[test]
fn counters_add_up() {
    let mesh = packtrace::protocol::generate::sphere(2000);
    let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
    let rays = random_rays(&mesh, 3000, 2);
    let mut s = TraversalStats::default();
    let mut scratch = StreamScratch::with_options(StreamOptions::new(4096, 8).unwrap());
    tree.intersect_stream_counted(&rays, &mut vec![None; rays.len()], &mut scratch, &mut s);
    assert_eq!(s.rays, 3000);
    assert!(s.stream_nodes > 0 && s.stream_node_rays >= 8 * s.stream_nodes);
    assert!(s.partitions <= s.stream_nodes && s.partitions > 0);
    assert!(s.single_rays > 0);
    let mut alone = TraversalStats::default();
    let mut all_single = StreamScratch::with_options(StreamOptions::new(4096, usize::MAX).unwrap());
    tree.intersect_stream_counted(
        &rays,
        &mut vec![None; rays.len()],
        &mut all_single,
        &mut alone,
    );
    let mut scalar = TraversalStats::default();
    for r in &rays {
        tree.intersect_counted(r, &mut scalar);
    }
    assert_eq!(alone.stream_nodes, 0);
    let in_box = rays
        .iter()
        .filter(|r| tree.bounds().intersect(r).is_some())
        .count() as u64;
    assert!(alone.single_rays <= in_box);
    assert_eq!(
        (alone.nodes, alone.leaves, alone.triangle_tests),
        (scalar.nodes, scalar.leaves, scalar.triangle_tests)
    );
}

/// Bad sizes are refused with a clear error; an empty stream is fine.
#[test]
fn options_refuse_bad_sizes() {
    assert!(StreamOptions::new(0, 1).is_err());
    assert!(StreamOptions::new(packtrace::kdtree::MAX_STREAM_SIZE + 1, 1).is_err());
    assert!(StreamOptions::new(packtrace::kdtree::MAX_STREAM_SIZE, 1).is_ok());
    let tree = KdTree::build(Mesh::default(), &KdBuildParams::default()).unwrap();
    tree.intersect_stream(&[], &mut [], &mut StreamScratch::new());
    tree.occluded_rays(&[], &mut []);
}

//! Traversal: scalar against 4-wide packets on the protocol's primary
//! (closest hit) and shadow (occlusion) rays.
//!
//! Scenes: `data/cornell.obj` at 256 x 256, and, when `PACKTRACE_SCENES`
//! names the shared scene directory, `bunny.obj` and `sponza.obj` from it
//! at 512 x 512 (each with its `.view` file). Rays and packets are made
//! once, outside the measurement; each iteration traces all of them and
//! stores every result, as the `bench` binary's timed runs do.
//!
//! ```text
//! cargo bench --bench traverse
//! PACKTRACE_SCENES=/path/to/scenes cargo bench --bench traverse
//! ```

use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use packtrace::camera::load_view;
use packtrace::workload::{self, RaySet, SceneFrame};
use packtrace::{Hit, HitPacket4, KdBuildParams, KdTree, RayPacket4, load_obj};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A scene's tree and its protocol rays.
struct Bench {
    name: String,
    tree: KdTree,
    primary: RaySet,
    primary_packets: Vec<RayPacket4>,
    shadow: RaySet,
    shadow_packets: Vec<RayPacket4>,
}

fn packets_of(set: &RaySet) -> Vec<RayPacket4> {
    (0..set.packets.len()).map(|i| set.packet(i)).collect()
}

/// Load `path`, build its tree, make primary and shadow rays at `size`.
fn load(path: &Path, size: u32) -> Bench {
    let mesh = load_obj(path).unwrap_or_else(|e| panic!("{e}"));
    let view = load_view(path).unwrap_or_else(|e| panic!("{e}"));
    let frame = SceneFrame::of(&mesh);
    let camera = view.camera_or_auto(&frame.bounds);
    let light = view.light_or_default(&frame);
    let tree = KdTree::build(mesh, &KdBuildParams::default()).expect("tree builds");
    let primary = workload::primary(&camera, size, size).expect("valid camera");
    let hits: Vec<Option<Hit>> = primary.rays.iter().map(|r| tree.intersect(r)).collect();
    let shadow = workload::shadow(&primary, &hits, tree.mesh(), &frame, light);
    Bench {
        name: path
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
        primary_packets: packets_of(&primary),
        shadow_packets: packets_of(&shadow),
        tree,
        primary,
        shadow,
    }
}

/// The crate's scene, plus the shared ones when `PACKTRACE_SCENES` is set.
fn scenes() -> Vec<(PathBuf, u32)> {
    let mut v = vec![(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/cornell.obj"),
        256,
    )];
    if let Some(dir) = std::env::var_os("PACKTRACE_SCENES") {
        for name in ["bunny.obj", "sponza.obj"] {
            let p = Path::new(&dir).join(name);
            if p.is_file() {
                v.push((p, 512));
            } else {
                eprintln!("traverse: {} not found, skipped", p.display());
            }
        }
    }
    v
}

fn traverse(c: &mut Criterion) {
    let mut group = c.benchmark_group("traverse");
    group.sampling_mode(SamplingMode::Flat);
    for (path, size) in scenes() {
        let s = load(&path, size);
        let tree = &s.tree;
        let mut hits = vec![None; s.primary.len()];
        let mut hits4 = vec![HitPacket4::default(); s.primary_packets.len()];
        let mut occluded = vec![false; s.shadow.len()];
        let mut masks = vec![0u32; s.shadow_packets.len()];

        group.throughput(Throughput::Elements(s.primary.len() as u64));
        group.bench_function(BenchmarkId::new("scalar/closest", &s.name), |b| {
            b.iter(|| {
                for (h, r) in hits.iter_mut().zip(&s.primary.rays) {
                    *h = tree.intersect(black_box(r));
                }
            });
        });
        group.bench_function(BenchmarkId::new("packet4/closest", &s.name), |b| {
            b.iter(|| {
                for (h, p) in hits4.iter_mut().zip(&s.primary_packets) {
                    *h = tree.intersect4(black_box(p));
                }
            });
        });
        group.throughput(Throughput::Elements(s.shadow.len() as u64));
        group.bench_function(BenchmarkId::new("scalar/occluded", &s.name), |b| {
            b.iter(|| {
                for (o, r) in occluded.iter_mut().zip(&s.shadow.rays) {
                    *o = tree.occluded(black_box(r));
                }
            });
        });
        group.bench_function(BenchmarkId::new("packet4/occluded", &s.name), |b| {
            b.iter(|| {
                for (m, p) in masks.iter_mut().zip(&s.shadow_packets) {
                    *m = tree.occluded4(black_box(p));
                }
            });
        });
        black_box((&hits, &hits4, &occluded, &masks));
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1))
        .sample_size(10);
    targets = traverse
}
criterion_main!(benches);

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

mod common;

use common::{packets_of, shared};
use criterion::{
    BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use packtrace::protocol::workload::{self, RaySet};
use packtrace::{Hit, HitPacket4, KdTree, RayPacket4};
use std::hint::black_box;

/// A scene's tree and its protocol primary and shadow rays.
struct Bench {
    name: String,
    tree: KdTree,
    primary: RaySet,
    primary_packets: Vec<RayPacket4>,
    shadow: RaySet,
    shadow_packets: Vec<RayPacket4>,
}

/// The shared loader, plus shadow rays from the scalar primary hits.
fn load(path: &std::path::Path, size: u32) -> Bench {
    let s = common::load(path, size);
    let hits: Vec<Option<Hit>> = s.primary.rays.iter().map(|r| s.tree.intersect(r)).collect();
    let shadow = workload::shadow(&s.primary, &hits, s.tree.mesh(), &s.frame, s.light);
    Bench {
        name: s.name,
        shadow_packets: packets_of(&shadow),
        tree: s.tree,
        primary: s.primary,
        primary_packets: s.primary_packets,
        shadow,
    }
}

fn traverse(c: &mut Criterion) {
    let mut group = c.benchmark_group("traverse");
    group.sampling_mode(SamplingMode::Flat);
    let scenes = std::iter::once(common::cornell()).chain(
        ["bunny.obj", "sponza.obj"]
            .into_iter()
            .filter_map(|n| shared("traverse", n)),
    );
    for (path, size) in scenes {
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
    config = common::config();
    targets = traverse
}
criterion_main!(benches);

//! Node layout: the 8-byte kd-tree against the same tree in 40-byte
//! nodes with per-leaf vectors (`NaiveKdTree::from_kd`: same splits, same
//! node order, same traversal code), scalar and 4-wide, over the same
//! protocol primary rays.
//!
//! Scene: `sponza.obj` at 512 x 512 from `PACKTRACE_SCENES` when set,
//! else `data/cornell.obj` at 256 x 256 (each with its `.view` file).
//!
//! ```text
//! cargo bench --bench layout
//! PACKTRACE_SCENES=/path/to/scenes cargo bench --bench layout
//! ```

mod common;

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use packtrace::{HitPacket4, NaiveKdTree, Ray, RayPacket4};
use std::hint::black_box;

/// Scalar closest hits of every ray, stored.
fn scalar<F: Fn(&Ray) -> Option<packtrace::Hit>>(
    rays: &[Ray],
    out: &mut [Option<packtrace::Hit>],
    f: F,
) {
    for (h, r) in out.iter_mut().zip(rays) {
        *h = f(black_box(r));
    }
}

/// Packet closest hits of every packet, stored.
fn packet4<F: Fn(&RayPacket4) -> HitPacket4>(packets: &[RayPacket4], out: &mut [HitPacket4], f: F) {
    for (h, p) in out.iter_mut().zip(packets) {
        *h = f(black_box(p));
    }
}

fn layout(c: &mut Criterion) {
    let (path, size) = common::shared("layout", "sponza.obj").unwrap_or_else(common::cornell);
    let scene = common::load(&path, size);
    let (kd, primary, packets, name) = (
        &scene.tree,
        &scene.primary,
        &scene.primary_packets,
        &scene.name,
    );
    let naive = NaiveKdTree::from_kd(kd);
    let id = format!("primary/{name}");
    eprintln!(
        "layout: {name} {size}x{size}: kd8 {} bytes, naive {} bytes, {} nodes",
        kd.stats().bytes,
        naive.bytes(),
        kd.node_count()
    );

    // Same answers from both layouts before they are timed
    for r in &primary.rays {
        assert_eq!(kd.intersect(r), naive.intersect(r));
    }

    let mut hits = vec![None; primary.len()];
    let mut hits4 = vec![HitPacket4::default(); packets.len()];
    let rays = Throughput::Elements(primary.len() as u64);
    let config = |g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>| {
        g.throughput(rays.clone());
        g.sampling_mode(SamplingMode::Flat);
    };

    let mut g = c.benchmark_group("layout/kd8/scalar");
    config(&mut g);
    g.bench_function(&id, |b| {
        b.iter(|| scalar(&primary.rays, &mut hits, |r| kd.intersect(r)))
    });
    g.finish();

    let mut g = c.benchmark_group("layout/kd8/packet4");
    config(&mut g);
    g.bench_function(&id, |b| {
        b.iter(|| packet4(packets, &mut hits4, |p| kd.intersect4(p)))
    });
    g.finish();

    let mut g = c.benchmark_group("layout/naive/scalar");
    config(&mut g);
    g.bench_function(&id, |b| {
        b.iter(|| scalar(&primary.rays, &mut hits, |r| naive.intersect(r)))
    });
    g.finish();

    let mut g = c.benchmark_group("layout/naive/packet4");
    config(&mut g);
    g.bench_function(&id, |b| {
        b.iter(|| packet4(packets, &mut hits4, |p| naive.intersect4(p)))
    });
    g.finish();
    black_box((&hits, &hits4));
}

criterion_group! {
    name = benches;
    config = common::config();
    targets = layout
}
criterion_main!(benches);

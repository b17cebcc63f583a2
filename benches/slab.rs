//! Slab test: four scalar `Aabb::intersect` calls against one
//! `RayPacket4::slab` on the same four rays.
//!
//! The rays are the protocol's `random` rays of a scene box twice the size
//! of the tested box, so about half of them hit it; rays and packets are
//! made once, outside the measurement.
//!
//! ```text
//! cargo bench --bench slab
//! ```

mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3A;
use packtrace::protocol::SceneFrame;
use packtrace::protocol::workload;
use packtrace::{Aabb, RayPacket4};
use std::hint::black_box;

/// Rays per iteration (a multiple of 4).
const RAYS: usize = 4096;

fn slab(c: &mut Criterion) {
    // Rays from a box around the tested one, in all directions
    let tested = Aabb::new(Vec3A::new(-1.0, -0.5, -2.0), Vec3A::new(1.0, 0.5, 2.0));
    let around = SceneFrame::from_bounds(Aabb::new(
        Vec3A::new(-2.0, -1.0, -4.0),
        Vec3A::new(2.0, 1.0, 4.0),
    ));
    let set = workload::random(&around, RAYS);
    let packets: Vec<RayPacket4> = common::packets_of(&set);
    assert_eq!(packets.len() * 4, set.rays.len());

    // Both forms must agree before they are timed
    let scalar_hits = set
        .rays
        .iter()
        .filter(|r| tested.intersect(r).is_some())
        .count();
    let packet_hits: u32 = packets.iter().map(|p| p.slab(&tested).0.count_ones()).sum();
    assert_eq!(scalar_hits, packet_hits as usize);

    let mut group = c.benchmark_group("slab");
    group.throughput(Throughput::Elements(RAYS as u64));
    group.bench_function("scalar", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for quad in set.rays.chunks_exact(4) {
                for r in quad {
                    hits += tested.intersect(black_box(r)).is_some() as u32;
                }
            }
            hits
        });
    });
    group.bench_function("packet4", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for p in &packets {
                hits += black_box(p).slab(&tested).0.count_ones();
            }
            hits
        });
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = common::config();
    targets = slab
}
criterion_main!(benches);

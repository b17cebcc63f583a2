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

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use packtrace::camera::load_view;
use packtrace::workload::{self, SceneFrame};
use packtrace::{HitPacket4, KdBuildParams, KdTree, NaiveKdTree, Ray, RayPacket4, load_obj};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Sponza from the shared scenes, else the crate's Cornell box.
fn scene() -> (PathBuf, u32) {
    if let Some(dir) = std::env::var_os("PACKTRACE_SCENES") {
        let p = Path::new(&dir).join("sponza.obj");
        if p.is_file() {
            return (p, 512);
        }
        eprintln!("layout: {} not found, using data/cornell.obj", p.display());
    }
    (
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/cornell.obj"),
        256,
    )
}

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
    let (path, size) = scene();
    let mesh = load_obj(&path).unwrap_or_else(|e| panic!("{e}"));
    let view = load_view(&path).unwrap_or_else(|e| panic!("{e}"));
    let frame = SceneFrame::of(&mesh);
    let camera = view.camera_or_auto(&frame.bounds);
    let kd = KdTree::build(mesh, &KdBuildParams::default()).expect("tree builds");
    let naive = NaiveKdTree::from_kd(&kd);
    let primary = workload::primary(&camera, size, size).expect("valid camera");
    let packets: Vec<RayPacket4> = (0..primary.packets.len())
        .map(|i| primary.packet(i))
        .collect();
    let name = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
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
        b.iter(|| packet4(&packets, &mut hits4, |p| kd.intersect4(p)))
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
        b.iter(|| packet4(&packets, &mut hits4, |p| naive.intersect4(p)))
    });
    g.finish();
    black_box((&hits, &hits4));
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1))
        .sample_size(10);
    targets = layout
}
criterion_main!(benches);

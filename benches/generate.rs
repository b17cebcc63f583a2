//! Scene generation: `generate::scalable` at the largest benchmark size
//! (4 million triangles), the scene `bench --scene gen:scalable:4M`
//! builds before it traces. A timing, so a benchmark (it was an ignored
//! test asserting under 10 s, which a loaded machine could fail and an
//! idle one could never measure).
//!
//! ```text
//! cargo bench --bench generate
//! ```

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use packtrace::protocol::generate;
use std::hint::black_box;

fn scalable(c: &mut Criterion) {
    let mut g = c.benchmark_group("generate");
    // Seconds per iteration: the fewest samples criterion takes.
    g.sample_size(10);
    for target in [40_000usize, 4_000_000] {
        let n = generate::scalable(target).triangle_count();
        g.throughput(Throughput::Elements(n as u64));
        g.bench_function(format!("scalable/{target}"), |b| {
            b.iter(|| generate::scalable(black_box(target)))
        });
    }
    g.finish();
}

criterion_group!(benches, scalable);
criterion_main!(benches);

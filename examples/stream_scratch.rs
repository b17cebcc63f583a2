//! The cost of the one-shot stream calls' thread-local scratch
//! (`KdTree::intersect_rays`) against a scratch the host keeps
//! (`KdTree::intersect_stream` with its own `StreamScratch`): the same
//! protocol random rays of a mesh, traced in batches of each size both
//! ways, each way in its own function so that callgrind counts them apart
//! (docs/streams.md, "Scratch cost"):
//!
//! ```text
//! cargo build --release --example stream_scratch
//! PACKTRACE_KERNEL=avx2 valgrind --tool=callgrind --dump-after='stream_scratch::one_shot' \
//!   --dump-after='stream_scratch::host_kept' target/release/examples/stream_scratch [MESH.obj|gen:SPEC]
//! ```
//!
//! Each call of the two functions ends one dump (the first also holds the
//! build); the example prints which dump is which and the rays each
//! traced. Without valgrind it prints wall-clock times (loaded-machine
//! figures; read only the ratio).

use packtrace::kdtree::StreamScratch;
use packtrace::protocol::{SceneFrame, generate, workload};
use packtrace::{Hit, KdBuildParams, KdTree, Ray, load_obj};
use std::time::Instant;

/// Rays in all (traced once per batch size and way).
const RAYS: usize = 65536;

/// Every batch of `batch` rays through the one-shot call (the library's
/// thread-local scratch).
#[inline(never)]
fn one_shot(tree: &KdTree, rays: &[Ray], hits: &mut [Option<Hit>], batch: usize) {
    for (r, h) in rays.chunks(batch).zip(hits.chunks_mut(batch)) {
        tree.intersect_rays(r, h);
    }
}

/// Every batch of `batch` rays through the host's own scratch.
#[inline(never)]
fn host_kept(
    tree: &KdTree,
    rays: &[Ray],
    hits: &mut [Option<Hit>],
    batch: usize,
    scratch: &mut StreamScratch,
) {
    for (r, h) in rays.chunks(batch).zip(hits.chunks_mut(batch)) {
        tree.intersect_stream(r, h, scratch);
    }
}

fn main() {
    let spec = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "gen:sphere:100k".to_string());
    let mesh = if spec.starts_with("gen:") {
        generate::from_spec(&spec).map_err(|e| e.to_string())
    } else {
        load_obj(&spec).map_err(|e| e.to_string())
    };
    let mesh = mesh.unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2);
    });
    let frame = SceneFrame::of(&mesh);
    let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2);
    });
    let rays = workload::random(&frame, RAYS).rays;
    let batches = [64, 1024, 16384];
    // Every buffer made before anything is counted, and the two ways
    // compared after, so that a dump holds its call and a clock reads only
    // the tracing.
    let mut a = vec![vec![None; RAYS]; batches.len() + 1];
    let mut b = a.clone();
    let mut scratch = StreamScratch::new();
    let mut seconds = Vec::new();
    // Both scratches grown to the largest batch first (dumps 1 and 2)
    one_shot(&tree, &rays, &mut a[0], RAYS);
    host_kept(&tree, &rays, &mut b[0], RAYS, &mut scratch);
    for (i, &batch) in batches.iter().enumerate() {
        let t = Instant::now();
        one_shot(&tree, &rays, &mut a[i + 1], batch);
        let one = t.elapsed().as_secs_f64();
        let t = Instant::now();
        host_kept(&tree, &rays, &mut b[i + 1], batch, &mut scratch);
        seconds.push((one, t.elapsed().as_secs_f64()));
    }
    assert!(a == b, "the two ways disagree");
    println!("dump 1: one_shot warm-up, dump 2: host_kept warm-up ({RAYS} rays each)");
    for (i, (&batch, (one, kept))) in batches.iter().zip(seconds).enumerate() {
        println!(
            "dump {}: one_shot, dump {}: host_kept; batches of {batch}: {RAYS} rays, \
             {one:.4} s one-shot, {kept:.4} s host-kept",
            2 * i + 3,
            2 * i + 4
        );
    }
}

//! Build one scene's tree repeatedly with one preset and print the median
//! build time and triangles per second (for profiling the build alone:
//! no OBJ parsing or tracing in the samples).
//!
//! ```text
//! cargo run --release --example build_loop -- SCENE.obj PRESET [RUNS] [THREADS]
//! ```

use packtrace::{KdBuildParams, KdTree, load_obj};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: build_loop SCENE.obj PRESET [RUNS] [THREADS]";
    let (Some(path), Some(preset)) = (args.first(), args.get(1)) else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let runs: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(9);
    let threads: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let Some((_, params)) = KdBuildParams::presets()
        .into_iter()
        .find(|(n, _)| n == preset)
    else {
        eprintln!("unknown preset {preset}; {usage}");
        std::process::exit(2);
    };
    let params = KdBuildParams {
        threads: Some(threads),
        ..params
    };
    let mesh = match load_obj(path) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let tris = mesh.triangle_count();
    let mut secs = Vec::with_capacity(runs);
    let mut nodes = 0;
    for _ in 0..runs {
        let m = mesh.clone();
        let t0 = Instant::now();
        let tree = KdTree::build(m, &params).unwrap_or_else(|e| {
            eprintln!("error: {e}");
            std::process::exit(1);
        });
        secs.push(t0.elapsed().as_secs_f64());
        nodes = tree.node_count();
    }
    secs.sort_by(f64::total_cmp);
    let median = secs[runs / 2];
    println!(
        "{preset} {tris} tris, {nodes} nodes: median {median:.4} s over {runs} runs, {:.3} Mtris/s",
        tris as f64 / median / 1e6
    );
}

//! Build statistics of the kd-tree for the `data/` scenes and, with
//! `PACKTRACE_SCENES` set, the shared scenes, for every build preset, as a
//! Markdown table (docs/measurements.md, "Tree statistics of every preset").
//!
//! ```text
//! PACKTRACE_SCENES=../shared/scenes cargo run --release --example tree_stats [SCENE.obj ...]
//! ```

use packtrace::{KdBuildParams, KdTree, load_obj};
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let mut scenes: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if scenes.is_empty() {
        scenes.push(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/cornell.obj"
        )));
        if let Ok(dir) = std::env::var("PACKTRACE_SCENES") {
            for name in ["cornell_box", "teapot", "bunny", "sponza"] {
                scenes.push(PathBuf::from(&dir).join(format!("{name}.obj")));
            }
        }
    }
    println!(
        "| scene | triangles | preset | build s | nodes | leaves | empty | max depth | mean depth | refs/tri | tris/leaf | SAH cost | bytes | nodes/tri | bytes/tri |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for path in &scenes {
        let mesh = match load_obj(path) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(2);
            }
        };
        let name = path.file_stem().map_or("?".into(), |s| s.to_string_lossy());
        for (preset, params) in KdBuildParams::presets() {
            let t0 = Instant::now();
            let tree = match KdTree::build(mesh.clone(), &params) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("error: {name}: {e}");
                    std::process::exit(2);
                }
            };
            let secs = t0.elapsed().as_secs_f64();
            if let Err(e) = tree.validate() {
                eprintln!("error: {name} ({preset}): {e}");
                std::process::exit(1);
            }
            let s = tree.stats();
            println!(
                "| {name} | {} | {preset} | {secs:.3} | {} | {} | {} | {} | {:.1} | {:.2} | {:.2} | {:.1} | {} | {:.2} | {:.1} |",
                s.triangles,
                s.nodes,
                s.leaves,
                s.empty_leaves,
                s.max_depth,
                s.mean_depth,
                s.refs_per_triangle,
                s.mean_leaf_triangles,
                s.sah_cost,
                s.bytes,
                s.nodes as f64 / s.triangles.max(1) as f64,
                s.bytes as f64 / s.triangles.max(1) as f64,
            );
        }
    }
}

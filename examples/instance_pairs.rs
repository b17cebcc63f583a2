//! What one instance of a mesh costs over the bare kd-tree, measured in
//! pairs: the protocol's primary rays of a scene (its `.view` camera, else
//! the auto camera), traced in alternating passes through the kd-tree and
//! through a scene holding the same tree as one instance at the identity,
//! for `rounds` rounds (the order flips every round, the first is a
//! warm-up). Prints the median and quartiles of the per-round speed ratio
//! instance / kd8. Pairs a few tens of milliseconds apart share the
//! machine's state, so the ratio moves less than that of two `bench` rows
//! taken seconds apart (docs/instances.md).
//!
//! ```text
//! taskset -c 1 cargo run --release --example instance_pairs -- ../shared/scenes/teapot.obj scalar 80
//! ```
//!
//! An optional fourth argument sets the rays per side (default 512).
//!
//! Modes: `scalar` (`KdTree::intersect` / `Scene::intersect`) and `packet8`
//! (`KdTree::intersect_packet` / `Scene::intersect_packet` on the
//! protocol's 4 x 2 blocks).

use packtrace::glam::Affine3A;
use packtrace::protocol::{SceneFrame, load_view, workload};
use packtrace::scene::{Query, Scene};
use packtrace::{KdBuildParams, KdTree, load_obj};
use std::path::Path;
use std::process::exit;
use std::sync::Arc;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: instance_pairs SCENE.obj [scalar|packet8] [ROUNDS >= 5] [SIZE >= 8]";
    let Some(path) = args.first().map(Path::new) else {
        eprintln!("{usage}");
        exit(2);
    };
    let mode = args.get(1).map_or("scalar", String::as_str);
    let rounds = match args.get(2).map_or(Ok(40), |s| s.parse::<usize>()) {
        Ok(r) if r >= 5 && (mode == "scalar" || mode == "packet8") => r,
        _ => {
            eprintln!("{usage}");
            exit(2);
        }
    };
    // Rays per side (512: the protocol's bench size; 128 or 256 keep the
    // packets in L2, docs/instances.md).
    let size = match args.get(3).map_or(Ok(512), |s| s.parse::<u32>()) {
        Ok(n) if n >= 8 => n,
        _ => {
            eprintln!("{usage}");
            exit(2);
        }
    };
    let fail = |e: &dyn std::fmt::Display| -> ! {
        eprintln!("error: {e}");
        exit(1);
    };
    let mesh = load_obj(path).unwrap_or_else(|e| fail(&e));
    let frame = SceneFrame::of(&mesh);
    let view = load_view(path).unwrap_or_else(|e| fail(&e));
    let camera = view.camera_or_auto(&frame.bounds);
    let set = workload::primary(&camera, size, size).unwrap_or_else(|e| fail(&e));
    let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap_or_else(|e| fail(&e));
    let tree = Arc::new(tree);
    let mut scene = Scene::new();
    let g = scene.add_shared_geometry("mesh", Arc::clone(&tree));
    scene
        .edit()
        .add_instance(g, Affine3A::IDENTITY)
        .unwrap_or_else(|e| fail(&e));
    let packets: Vec<_> = (0..set.packets8.len()).map(|i| set.packet8(i)).collect();
    let q = Query::new();
    // One pass of `kd8` (false) or the instance (true); its hit count keeps
    // the work from being optimised away and checks that both agree.
    let pass = |instance: bool| -> (f64, u64) {
        let t0 = Instant::now();
        let mut hits = 0u64;
        if mode == "scalar" {
            for ray in &set.rays {
                hits += u64::from(if instance {
                    scene.intersect(ray).is_some()
                } else {
                    tree.intersect(ray).is_some()
                });
            }
        } else {
            for p in &packets {
                hits += u64::from(if instance {
                    scene.intersect_packet(p, &q).mask().count_ones()
                } else {
                    tree.intersect_packet(p).mask().count_ones()
                });
            }
        }
        (t0.elapsed().as_secs_f64(), hits)
    };
    let mut ratios = Vec::with_capacity(rounds);
    for r in 0..rounds {
        let ((kd8, h0), (inst, h1)) = if r % 2 == 0 {
            let a = pass(false);
            (a, pass(true))
        } else {
            let b = pass(true);
            (pass(false), b)
        };
        if h0 != h1 {
            fail(&format!("kd8 found {h0} hits, the instance {h1}"));
        }
        if r > 0 {
            ratios.push(kd8 / inst);
        }
    }
    ratios.sort_by(f64::total_cmp);
    let n = ratios.len();
    println!(
        "{} {mode}: instance / kd8 speed, median {:.3}, quartiles {:.3} {:.3} ({n} pairs, kernel {})",
        path.file_stem().map_or("?".into(), |s| s.to_string_lossy()),
        ratios[n / 2],
        ratios[n / 4],
        ratios[3 * n / 4],
        packtrace::kdtree::Kernel::active().name(),
    );
}

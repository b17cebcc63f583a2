//! What the criterion benches share: one configuration, and loading a
//! scene with its view file, tree and protocol primary rays (made once,
//! outside the measurement).

// Each bench is its own crate and uses only part of this module.
#![allow(dead_code)]

use criterion::Criterion;
use packtrace::protocol::SceneFrame;
use packtrace::protocol::camera::load_view;
use packtrace::protocol::workload::{self, RaySet};
use packtrace::{KdBuildParams, KdTree, RayPacket4, load_obj};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// 10 samples, 3 s of measurement after 1 s of warm-up (docs/measurements.md).
pub fn config() -> Criterion {
    Criterion::default()
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1))
        .sample_size(10)
}

/// The crate's own scene and the image side it is benched at.
pub fn cornell() -> (PathBuf, u32) {
    (
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data/cornell.obj"),
        256,
    )
}

/// `name` from `PACKTRACE_SCENES` at 512 x 512, when the variable is set and
/// the file exists (a note on stderr, naming `bench`, when it is missing).
pub fn shared(bench: &str, name: &str) -> Option<(PathBuf, u32)> {
    let dir = std::env::var_os("PACKTRACE_SCENES")?;
    let p = Path::new(&dir).join(name);
    if p.is_file() {
        Some((p, 512))
    } else {
        eprintln!("{bench}: {} not found, skipped", p.display());
        None
    }
}

/// The packets of a ray set, in packet order.
pub fn packets_of(set: &RaySet) -> Vec<RayPacket4> {
    (0..set.packets.len()).map(|i| set.packet(i)).collect()
}

/// A scene's tree, frame, light and protocol primary rays.
pub struct Scene {
    pub name: String,
    pub tree: KdTree,
    pub frame: SceneFrame,
    pub light: glam::Vec3,
    pub primary: RaySet,
    pub primary_packets: Vec<RayPacket4>,
}

/// Load `path` and its view file, build the default tree, make the primary
/// rays of a `size` x `size` image.
pub fn load(path: &Path, size: u32) -> Scene {
    let mesh = load_obj(path).unwrap_or_else(|e| panic!("{e}"));
    let view = load_view(path).unwrap_or_else(|e| panic!("{e}"));
    let frame = SceneFrame::of(&mesh);
    let camera = view.camera_or_auto(&frame.bounds);
    let light = view.light_or_default(&frame);
    let tree = KdTree::build(mesh, &KdBuildParams::default()).expect("tree builds");
    let primary = workload::primary(&camera, size, size).expect("valid camera");
    Scene {
        name: path
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
        primary_packets: packets_of(&primary),
        tree,
        frame,
        light,
        primary,
    }
}

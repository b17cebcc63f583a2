//! The benchmark protocol (the layer above the tracing core): the pinhole
//! camera and view files, the scene frame, the four workloads (primary,
//! shadow, ambient occlusion, random) with their packets, the protocol's
//! hash-based sampling, and generated scenes. `docs/PROTOCOL.md` describes
//! the rays (the shared protocol, `../shared/BENCH_PROTOCOL.md` beside a
//! checkout, is the authority); ARCHITECTURE.md shows the layers.
//!
//! Depends on the core (rays, meshes, packets), never the other way round.

pub mod camera;
pub mod frame;
pub mod generate;
pub mod sampling;
pub mod scene_file;
pub mod workload;

pub use camera::{Camera, View, ViewError, load_view};
pub use frame::{SceneFrame, default_light};
pub use scene_file::{
    MeshSource, SceneFileError, SceneMesh, load_scene, load_scene_with_sources, parse_scene,
    parse_scene_with_sources,
};
pub use workload::{RaySet, Workload, WorkloadError};

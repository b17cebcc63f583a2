//! # packtrace
//!
//! Ray tracing against triangle meshes on the CPU with 4-wide SIMD ray
//! packets through an SAH kd-tree of 8-byte nodes, with a scalar path and a
//! brute-force loop as correctness oracles.
//!
//! ```
//! use glam::Vec3;
//! use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket4};
//!
//! // One triangle in the z = 0 plane.
//! let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;
//! let tree = KdTree::build(mesh, &KdBuildParams::default())?;
//!
//! // One ray at a time...
//! let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;
//! let hit = tree.intersect(&ray).expect("hits");
//! assert_eq!((hit.t, hit.prim, hit.u, hit.v), (1.0, 0, 0.25, 0.25));
//!
//! // ...or four at once, with exactly the same answers.
//! let hits = tree.intersect4(&RayPacket4::from_rays(&[ray; 4]));
//! assert_eq!(hits.hit(3), Some(hit));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Module map (one concept each). The tracing core: [`aabb`], [`ray`],
//! [`packet`], [`simd`] (the only module naming `wide`), `triangle`,
//! [`mesh`], [`obj`], [`kdtree`] (node, build, scalar and packet
//! traversal, validate, stats), [`brute`], [`query`]. Above it the
//! benchmark protocol, [`protocol`] (camera, frame, workload, sampling,
//! generate), and above that the renderer's core, [`render`]. The layers,
//! the invariants and where they are tested: ARCHITECTURE.md.

#![deny(missing_docs)]
// Library code returns typed errors; a panic is only a documented contract
// (`# Panics`, with a scoped allow). Unit tests may still unwrap.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::unwrap_in_result,
        clippy::missing_panics_doc
    )
)]
#![forbid(unsafe_code)]

pub mod aabb;
pub mod brute;
pub mod kdtree;
pub mod mesh;
pub mod obj;
pub mod packet;
pub mod protocol;
pub mod query;
pub mod ray;
pub mod render;
pub mod simd;
mod triangle;

pub use aabb::Aabb;
pub use brute::BruteForce;
pub use kdtree::{
    BuildError, KdBuildParams, KdTree, MAX_DEPTH_LIMIT, NaiveKdTree, TraversalStats, TreeStats,
    ValidationError,
};
pub use mesh::{Mesh, MeshError};
pub use obj::{LoadError, load_obj, parse_obj_bytes};
pub use packet::{HitPacket4, RayPacket4};
pub use protocol::{
    Camera, RaySet, SceneFrame, View, ViewError, Workload, WorkloadError, load_view,
};
pub use query::{Mode, PacketQuery, RayQuery};
pub use ray::{Hit, Ray, RayError};

/// The README's Rust examples, compiled and run as doc tests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

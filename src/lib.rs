//! # packtrace
//!
//! Ray tracing against triangle meshes on the CPU, one ray at a time or in
//! 4- and 8-wide SIMD packets (AVX-512, AVX2 or SSE kernels, chosen at run
//! time) through an SAH kd-tree of 8-byte nodes, with a scalar path and a
//! brute-force loop as correctness oracles.
//!
//! ```
//! use glam::Vec3;
//! use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket4, RayPacket8};
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
//! // ...or four or eight at once, with exactly the same answers.
//! let hits = tree.intersect4(&RayPacket4::from_rays(&[ray; 4]));
//! assert_eq!(hits.hit(3), Some(hit));
//! let hits = tree.intersect8(&RayPacket8::from_rays(&[ray; 8]));
//! assert_eq!(hits.hit(7), Some(hit));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Layers
//!
//! ```text
//!  application   render (tiles, shading, heat-map counts,      cli/src/bin/{render,bench}
//!                        the path tracer)
//!       |
//!  protocol      protocol::{camera, frame, workload, sampling, generate,
//!                          scene_file}
//!       |
//!  tracing core  simd  aabb  ray  triangle  mesh  obj  packet  group
//!                frustum  query  brute  scene::{transform, tlas, brute}
//!                kdtree::{node, params, build, clip, layout, margin,
//!                         scalar, packet, kernel, hybrid, stream, group,
//!                         group_query, naive, validate, stats}
//!                bvh::{..}  grid::{params, cells, walk, single, packet,
//!                                  query, validate}
//! ```
//!
//! Each layer uses only the layers below it, and no modules import each
//! other in a circle (`tests/layers.rs` checks both from the source).
//!
//! - **Tracing core**, one concept per module: [`simd`] (the [`simd::Lane`]
//!   trait and the NaN rule; the only module naming `wide`), [`aabb`] (boxes
//!   and the slab test), [`ray`] (rays, hits, the ray policy), `triangle`
//!   (the one watertight ray/triangle routine), [`mesh`] and [`obj`],
//!   [`packet`] (SoA packets), [`group`] (ray groups with a frustum,
//!   `frustum` their cone), [`kdtree`] (node encoding, SAH build,
//!   scalar and packet traversal with the cell margin, validation,
//!   statistics), [`bvh`] and [`grid`] (the BVHs and the grids beside the
//!   kd-tree, same traits, same answers), [`scene`] (geometries, instances with transforms, the
//!   top-level BVH, masks and filters, and its oracle), [`brute`] (the
//!   oracle) and [`query`] (the [`RayQuery`] and
//!   [`PacketQuery`] traits every engine implements, and [`Mode`]).
//! - **Protocol** ([`protocol`]): the benchmark protocol's camera and view
//!   files, scene frame, workloads, sampling and generated scenes.
//! - **Application** ([`render`]): the renderers' library side (the path
//!   tracer, [`render::path`], traces through any [`PacketQuery`]); the
//!   binaries add the command lines, PNG output and the heat-map picture.
//!
//! The invariants and where each is enforced and tested: `ARCHITECTURE.md`.

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
// `unsafe` only in `kdtree::kernel` (run-time AVX2 dispatch), allowed there.
#![deny(unsafe_code)]

pub mod aabb;
pub mod brute;
pub mod bvh;
mod frustum;
pub mod grid;
pub mod group;
pub mod kdtree;
pub mod mesh;
pub mod obj;
pub mod packet;
pub mod protocol;
pub mod query;
pub mod ray;
pub mod render;
pub mod scene;
pub mod simd;
pub mod spawn;
mod triangle;

/// The `glam` this crate's API is written in (`Vec3`, `Vec3A`), re-exported
/// so a host names the same version: with another `glam` in the host's
/// `Cargo.toml`, `Ray::new(glam::Vec3::ZERO, ..)` fails to type-check
/// ("multiple different versions of crate `glam`").
///
/// ```
/// use packtrace::glam::Vec3;
/// let ray = packtrace::Ray::new(Vec3::ZERO, Vec3::Z, 0.0, 1.0)?;
/// assert_eq!(ray.dir(), Vec3::Z);
/// # Ok::<(), packtrace::RayError>(())
/// ```
pub use glam;

pub use aabb::Aabb;
pub use brute::BruteForce;
pub use kdtree::{
    BlockedKdTree, BuildError, DepthLimit, InlineKdTree, KdBuildParams, KdTree, Kernel, MAX_BINS,
    MAX_DEPTH_LIMIT, NaiveKdTree, TraversalStats, TreeStats, ValidationError,
};
pub use mesh::{Mesh, MeshError};
pub use obj::{
    LoadError, ObjMesh, load_obj, load_obj_with_shading, parse_obj_bytes,
    parse_obj_bytes_with_shading,
};
pub use packet::{
    HitPacket, HitPacket4, HitPacket8, PacketError, RayPacket, RayPacket4, RayPacket8,
};
pub use protocol::{
    Camera, RaySet, SceneFrame, View, ViewError, Workload, WorkloadError, load_view,
};
pub use query::{Mode, PacketQuery, RayQuery};
pub use ray::{Hit, Ray, RayError};

/// The README's Rust examples, compiled and run as doc tests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;

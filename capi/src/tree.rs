//! Trees: one mesh's acceleration structure, built from the host's vertex
//! and index arrays, queried with single rays, 4- and 8-wide packets and
//! streams, and the hit-point, normal and secondary-ray helpers.
// `#[unsafe(no_mangle)]` on the exported functions is all the unsafe
// code here; raw pointers are turned into references in `ptr.rs` only.
#![allow(unsafe_code)]

use crate::packet::{self, Found, Width};
use crate::params::{self, Accel};
use crate::ptr::{self, Kind, StridedMut};
use crate::status::{Error, PacktraceStatus, guard};
use crate::types::{
    PACKTRACE_INVALID_ID, PacktraceBuildParams, PacktraceRay, PacktraceRay4, PacktraceRay8,
    PacktraceRayHit, PacktraceRayHit4, PacktraceRayHit8,
};
use packtrace::glam::Vec3;
use packtrace::{Hit, KdTree, Mesh, MeshError, PacketQuery, RayPacket4, RayPacket8, spawn};
use std::ffi::c_int;
use std::sync::Arc;

/// A built acceleration structure over one mesh (opaque). Immutable once
/// built: any number of threads may query it at once.
pub struct PacktraceTree {
    _opaque: [u8; 0],
}

/// A tree handle's object: the structure and its triangles' unit normals.
pub(crate) struct Tree {
    structure: Structure,
    /// `Mesh::normal` of every triangle, computed once: the `Ng` of every
    /// hit is then one load, not a cross product and a square root per
    /// hit (36 instructions per ray of the C API's packet8 query on
    /// Sponza, callgrind; docs/c-api-design.md). 12 bytes per triangle.
    normals: Vec<Vec3>,
}

/// The structure behind a tree handle: one variant per `PacktraceAccel`.
pub(crate) enum Structure {
    KdTree(Arc<KdTree>),
}

impl Kind for Tree {
    type Opaque = PacktraceTree;
    const MAGIC: u32 = 0x5054_5452; // "PTTR"
    const NAME: &'static str = "tree";
}

impl Tree {
    /// Builds structure `accel` over `mesh`.
    fn build(accel: Accel, mesh: Mesh, p: &PacktraceBuildParams) -> Result<Tree, Error> {
        let normals = (0..mesh.triangle_count()).map(|i| mesh.normal(i)).collect();
        let structure = match accel {
            Accel::KdTree => Structure::KdTree(Arc::new(KdTree::build(mesh, &params::kd(p)?)?)),
        };
        Ok(Tree { structure, normals })
    }

    /// The structure's queries.
    #[inline(always)]
    pub(crate) fn query(&self) -> &(dyn PacketQuery + Sync) {
        match &self.structure {
            Structure::KdTree(t) => &**t,
        }
    }

    /// The mesh it was built over.
    pub(crate) fn mesh(&self) -> &Mesh {
        match &self.structure {
            Structure::KdTree(t) => t.mesh(),
        }
    }

    /// The kd-tree a scene's geometry shares.
    pub(crate) fn kd(&self) -> Option<&Arc<KdTree>> {
        match &self.structure {
            Structure::KdTree(t) => Some(t),
        }
    }

    /// What the host reads of hit `h`.
    #[inline]
    fn found(&self, h: Hit) -> Found {
        Found {
            t: h.t,
            u: h.u,
            v: h.v,
            prim: h.prim,
            geom: 0,
            inst: PACKTRACE_INVALID_ID,
            ng: self.normals[h.prim as usize],
        }
    }

    /// `Hit` of `prim_id`, `u`, `v`, checked against the mesh.
    fn hit(&self, prim_id: u32, u: f32, v: f32) -> Result<Hit, Error> {
        let n = self.mesh().triangle_count();
        if prim_id as usize >= n {
            return Err(Error::invalid(format!(
                "prim_id {prim_id} is not a triangle of the tree (it has {n})"
            )));
        }
        if !(u.is_finite() && v.is_finite()) {
            return Err(Error::invalid(format!(
                "barycentrics ({u}, {v}) are not finite"
            )));
        }
        Ok(Hit {
            t: 0.0,
            prim: prim_id,
            u,
            v,
        })
    }
}

fn tree_ref<'a>(p: *const PacktraceTree) -> Result<&'a Tree, Error> {
    ptr::handle::<Tree>(p, "tree")
}

/// Three floats at `p`, finite.
pub(crate) fn vec3(p: *const f32, name: &str) -> Result<Vec3, Error> {
    let s = ptr::slice(p, 3, name)?;
    let v = Vec3::new(s[0], s[1], s[2]);
    if !v.is_finite() {
        return Err(Error::invalid(format!("`{name}` {v} is not finite")));
    }
    Ok(v)
}

/// Writes `v` to the three floats at `p`.
pub(crate) fn put3(p: *mut f32, v: Vec3) -> Result<(), Error> {
    ptr::slice_mut(p, 3, "out")?.copy_from_slice(&v.to_array());
    Ok(())
}

/// Builds a tree over a triangle mesh given as the host's own arrays,
/// read in place (the library keeps its own copy; the arrays may be
/// freed after the call).
///
/// - `vertices`: `vertex_count` positions, each three `float`s (x, y,
///   z) at the start of a record `vertex_stride` bytes long (12 for
///   packed positions, more for interleaved vertex data; a multiple of
///   4); 4-byte aligned.
/// - `indices`: `triangle_count` triangles, each three `uint32_t` vertex
///   indices at the start of a record `index_stride` bytes long (12 when
///   packed); 4-byte aligned.
/// - `params`: the build parameters, or NULL for the defaults.
///
/// Vertices no triangle uses are ignored (they need not be finite).
/// Zero-area triangles are kept (indices stay stable) and never hit. Zero
/// counts make an empty tree (that never hits); a NULL array is accepted
/// with a zero count.
///
/// On success `*out_tree` is a new handle; release it with
/// `packtrace_tree_release`.
///
/// Errors: `NULL_POINTER` (`out_tree`, or an array with a non-zero
/// count), `MISALIGNED`, `INVALID_ARGUMENT` (a stride below 12 or not a
/// multiple of 4, a byte size that overflows, more than 2^32 vertices),
/// `INVALID_MESH` (an index past the vertices, a used vertex not finite,
/// 2^32 - 1 triangles or more), `INVALID_PARAMS`, `UNSUPPORTED`
/// (`PACKTRACE_ACCEL_RESERVED_BVH8`), `BUILD`.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_tree_new(
    vertices: *const f32,
    vertex_count: usize,
    vertex_stride: usize,
    indices: *const u32,
    triangle_count: usize,
    index_stride: usize,
    params: *const PacktraceBuildParams,
    out_tree: *mut *mut PacktraceTree,
) -> PacktraceStatus {
    guard(|| {
        let out = ptr::write(out_tree, "out_tree")?;
        let p = if params.is_null() {
            params::preset(0)?
        } else {
            *ptr::read(params, "params")?
        };
        let accel = Accel::from_raw(p.accel)?;
        if triangle_count >= u32::MAX as usize {
            return Err(MeshError::TooManyTriangles(triangle_count).into());
        }
        if vertex_count > 1 << 32 {
            return Err(Error::invalid(format!(
                "vertex_count {vertex_count} exceeds 2^32, the most 32-bit indices can name"
            )));
        }
        let positions = ptr::strided3(vertices, vertex_count, vertex_stride, "vertices")?;
        let triangles = ptr::strided3(indices, triangle_count, index_stride, "indices")?;
        let positions = positions.into_iter().map(Vec3::from_array).collect();
        let tree = Tree::build(accel, Mesh::new(positions, triangles)?, &p)?;
        *out = ptr::new_handle(tree);
        Ok(())
    })
}

/// Releases a tree (NULL: nothing to do). Scenes that hold it as a
/// geometry keep it alive. Releasing a handle twice, or using it after,
/// is reported as `RELEASED_HANDLE` for recently released handles (the
/// library keeps the last 1024 released handles' headers), undefined
/// behaviour otherwise.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_tree_release(tree: *mut PacktraceTree) -> PacktraceStatus {
    guard(|| ptr::release::<Tree>(tree, "tree"))
}

/// The tree's triangle count and its box (`lower`, `upper`: three floats
/// each; an empty tree's box is `+inf` below `-inf`). Any output may be
/// NULL.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_tree_info(
    tree: *const PacktraceTree,
    out_triangle_count: *mut usize,
    out_lower: *mut f32,
    out_upper: *mut f32,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let b = t.mesh().bounds();
        if !out_triangle_count.is_null() {
            *ptr::write(out_triangle_count, "out_triangle_count")? = t.mesh().triangle_count();
        }
        if !out_lower.is_null() {
            put3(out_lower, b.min.into())?;
        }
        if !out_upper.is_null() {
            put3(out_upper, b.max.into())?;
        }
        Ok(())
    })
}

/// The closest hit of one ray (Embree's `rtcIntersect1`): on a hit,
/// `rayhit->ray.tfar` becomes its `t` and `rayhit->hit` is filled
/// (`geom_id` 0, `inst_id` `PACKTRACE_INVALID_ID`); on a miss, the hit's
/// ids are `PACKTRACE_INVALID_ID` and the rest is unchanged. The ray is
/// checked (`INVALID_RAY`: NaN or infinite origin or direction, a zero
/// direction, a NaN bound). `rayhit` must be 16-byte aligned.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_intersect1(
    tree: *const PacktraceTree,
    rayhit: *mut PacktraceRayHit,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let rh = ptr::write(rayhit, "rayhit")?;
        let r = packet::ray(&rh.ray)?;
        let f = t.query().intersect(&r).map(|h| t.found(h));
        packet::write_hit(&mut rh.ray, &mut rh.hit, f);
        Ok(())
    })
}

/// Whether one ray hits anything (Embree's `rtcOccluded1`): `ray->tfar`
/// becomes `-inf` if it does, and is unchanged otherwise.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_occluded1(
    tree: *const PacktraceTree,
    ray: *mut PacktraceRay,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let r = ptr::write(ray, "ray")?;
        let occluded = t.query().occluded(&packet::ray(r)?);
        packet::write_occluded(r, occluded);
        Ok(())
    })
}

/// A packet query of any width: the checked packet of the active lanes,
/// traced by `trace`, each active lane's answer written.
#[inline(always)]
fn packet_query<R: Width>(
    valid: *const c_int,
    tree: *const PacktraceTree,
    rays: &mut R,
    trace: impl FnOnce(&Tree, &R::Packet, &mut R) -> Result<(), Error>,
) -> Result<(), Error> {
    let t = tree_ref(tree)?;
    let active = packet::active(ptr::slice(valid, R::W, "valid")?)?;
    let p = rays.packet(active)?;
    trace(t, &p, rays)
}

/// The closest hits of a 4-wide packet (Embree's `rtcIntersect4`):
/// lanes whose `valid` entry is -1 are traced, those with 0 left alone
/// (any other value: `INVALID_ARGUMENT`); each traced lane is written as
/// `packtrace_intersect1` writes its ray. `valid` points at 4 `int`s;
/// `rayhit` must be 16-byte aligned. An invalid active lane fails the
/// whole call (`INVALID_RAY`, the message names the lane), writing
/// nothing.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_intersect4(
    valid: *const c_int,
    tree: *const PacktraceTree,
    rayhit: *mut PacktraceRayHit4,
) -> PacktraceStatus {
    guard(|| {
        let rh = ptr::write(rayhit, "rayhit")?;
        let hits = &mut rh.hit;
        packet_query(valid, tree, &mut rh.ray, |t, p: &RayPacket4, r| {
            let h = t.query().intersect4(p);
            for i in lanes(p.active()) {
                r.write_hit(hits, i, h.hit(i).map(|h| t.found(h)));
            }
            Ok(())
        })
    })
}

/// The occlusion of a 4-wide packet (Embree's `rtcOccluded4`): each
/// traced lane's `tfar` becomes `-inf` if it hits anything.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_occluded4(
    valid: *const c_int,
    tree: *const PacktraceTree,
    ray: *mut PacktraceRay4,
) -> PacktraceStatus {
    guard(|| {
        let r = ptr::write(ray, "ray")?;
        packet_query(valid, tree, r, |t, p: &RayPacket4, r| {
            let m = t.query().occluded4(p);
            for i in lanes(p.active()) {
                r.write_occluded(i, m >> i & 1 == 1);
            }
            Ok(())
        })
    })
}

/// The closest hits of an 8-wide packet (Embree's `rtcIntersect8`), as
/// `packtrace_intersect4` with 8 lanes; `rayhit` must be 32-byte aligned.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_intersect8(
    valid: *const c_int,
    tree: *const PacktraceTree,
    rayhit: *mut PacktraceRayHit8,
) -> PacktraceStatus {
    guard(|| {
        let rh = ptr::write(rayhit, "rayhit")?;
        let hits = &mut rh.hit;
        packet_query(valid, tree, &mut rh.ray, |t, p: &RayPacket8, r| {
            let h = t.query().intersect8(p);
            for i in lanes(p.active()) {
                r.write_hit(hits, i, h.hit(i).map(|h| t.found(h)));
            }
            Ok(())
        })
    })
}

/// The occlusion of an 8-wide packet (Embree's `rtcOccluded8`); `ray`
/// must be 32-byte aligned.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_occluded8(
    valid: *const c_int,
    tree: *const PacktraceTree,
    ray: *mut PacktraceRay8,
) -> PacktraceStatus {
    guard(|| {
        let r = ptr::write(ray, "ray")?;
        packet_query(valid, tree, r, |t, p: &RayPacket8, r| {
            let m = t.query().occluded8(p);
            for i in lanes(p.active()) {
                r.write_occluded(i, m >> i & 1 == 1);
            }
            Ok(())
        })
    })
}

/// The set bits of `mask`, lowest first.
#[inline]
pub(crate) fn lanes(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let i = (mask != 0).then(|| mask.trailing_zeros())?;
        mask &= mask - 1;
        Some(i as usize)
    })
}

/// The closest hits of a stream of `count` rays of any length (Embree 3's
/// `rtcIntersect1M`): `rayhits` holds `count` `PacktraceRayHit`s
/// `byte_stride` bytes apart (`sizeof(PacktraceRayHit)` when packed; a
/// multiple of 16). The library groups the rays into coherent packets
/// itself; each ray is written as `packtrace_intersect1` writes it. Every
/// ray is checked before any is traced: one invalid ray fails the call
/// (`INVALID_RAY`, the message names it) and nothing is written. A zero
/// count does nothing (`rayhits` may then be NULL).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_intersect_stream(
    tree: *const PacktraceTree,
    rayhits: *mut PacktraceRayHit,
    count: usize,
    byte_stride: usize,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let mut rh = StridedMut::new(rayhits, count, byte_stride, "rayhits")?;
        let rays = (0..rh.len())
            .map(|i| packet::stream_ray(&rh.get(i).ray, i))
            .collect::<Result<Vec<_>, _>>()?;
        let mut hits = vec![None; rays.len()];
        t.query().intersect_rays(&rays, &mut hits);
        for (i, h) in hits.into_iter().enumerate() {
            let r = rh.get_mut(i);
            packet::write_hit(&mut r.ray, &mut r.hit, h.map(|h| t.found(h)));
        }
        Ok(())
    })
}

/// The occlusion of a stream of `count` rays `byte_stride` bytes apart
/// (`sizeof(PacktraceRay)` when packed; a multiple of 16): each occluded
/// ray's `tfar` becomes `-inf`. Checked as `packtrace_intersect_stream`.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_occluded_stream(
    tree: *const PacktraceTree,
    rays: *mut PacktraceRay,
    count: usize,
    byte_stride: usize,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let mut rs = StridedMut::new(rays, count, byte_stride, "rays")?;
        let checked = (0..rs.len())
            .map(|i| packet::stream_ray(rs.get(i), i))
            .collect::<Result<Vec<_>, _>>()?;
        let mut occluded = vec![false; checked.len()];
        t.query().occluded_rays(&checked, &mut occluded);
        for (i, o) in occluded.into_iter().enumerate() {
            packet::write_occluded(rs.get_mut(i), o);
        }
        Ok(())
    })
}

/// The point of a hit on its triangle, from the barycentrics (`(1 - u -
/// v) p0 + u p1 + v p2`; more accurate than `org + t dir` far from the
/// origin), written to `out_point` (three floats). `INVALID_ARGUMENT` if
/// `prim_id` is not a triangle of the tree or `u`, `v` are not finite.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_hit_point(
    tree: *const PacktraceTree,
    prim_id: u32,
    u: f32,
    v: f32,
    out_point: *mut f32,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let h = t.hit(prim_id, u, v)?;
        put3(out_point, spawn::hit_point(t.mesh(), &h))
    })
}

/// The unit geometric normal of triangle `prim_id` (`(p1 - p0) x (p2 -
/// p0)`, normalised; zero for a zero-area triangle), written to
/// `out_normal` (three floats).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_geometric_normal(
    tree: *const PacktraceTree,
    prim_id: u32,
    out_normal: *mut f32,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let h = t.hit(prim_id, 0.0, 0.0)?;
        put3(out_normal, t.normals[h.prim as usize])
    })
}

/// A secondary ray leaving the surface of a hit (triangle `prim_id` at
/// barycentrics `u`, `v`) in direction `dir` (three floats) over `(0,
/// tfar]`: it starts at the hit point moved off the surface, to the side
/// `dir` goes to, by Wächter and Binder's offset (Ray Tracing Gems,
/// chapter 6), so that it does not hit the triangle it leaves again. For
/// a shadow ray to a light at `l`, pass `dir = l - hit point` and `tfar`
/// just below 1. Written to `out_ray` (`mask` all ones; `time`, `id`,
/// `flags` zero).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_spawn_ray(
    tree: *const PacktraceTree,
    prim_id: u32,
    u: f32,
    v: f32,
    dir: *const f32,
    tfar: f32,
    out_ray: *mut PacktraceRay,
) -> PacktraceStatus {
    guard(|| {
        let t = tree_ref(tree)?;
        let h = t.hit(prim_id, u, v)?;
        let out = ptr::write(out_ray, "out_ray")?;
        let d = ptr::slice(dir, 3, "dir")?;
        let r = spawn::spawn_ray(t.mesh(), &h, Vec3::new(d[0], d[1], d[2]), tfar)?;
        *out = PacktraceRay {
            org_x: r.origin().x,
            org_y: r.origin().y,
            org_z: r.origin().z,
            tnear: r.t_min(),
            dir_x: r.dir().x,
            dir_y: r.dir().y,
            dir_z: r.dir().z,
            time: 0.0,
            tfar: r.t_max(),
            mask: u32::MAX,
            id: 0,
            flags: 0,
        };
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_are_the_set_bits() {
        assert_eq!(lanes(0b1010_0101).collect::<Vec<_>>(), [0, 2, 5, 7]);
        assert_eq!(lanes(0).count(), 0);
    }
}

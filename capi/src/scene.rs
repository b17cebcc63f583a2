//! Scenes of instances: geometries (trees shared with the host's tree
//! handles), instances placing them with affine transforms and masks, one
//! commit per batch of edits (Embree's `rtcCommitScene`), and the same
//! queries as a tree's, with ray masks and geometry and instance ids.
// `#[unsafe(no_mangle)]` on the exported functions is all the unsafe
// code here; raw pointers are turned into references in `ptr.rs` only.
#![allow(unsafe_code)]

use crate::packet::{self, Found, Width};
use crate::ptr::{self, Kind, StridedMut};
use crate::status::{Error, PacktraceStatus, guard};
use crate::tree::{PacktraceTree, Tree, lanes, put3};
use crate::types::{
    PacktraceRay, PacktraceRay4, PacktraceRay8, PacktraceRayHit, PacktraceRayHit4, PacktraceRayHit8,
};
use packtrace::glam::{Affine3A, Mat3A, Vec3A};
use packtrace::scene::{GeometryId, InstanceId, Query, Scene, SceneHit, SceneQuery};
use packtrace::{Ray, RayPacket4, RayPacket8};
use std::ffi::c_int;

/// A scene of instances (opaque). Queries may run from any number of
/// threads at once; an edit or commit needs the scene to itself.
pub struct PacktraceScene {
    _opaque: [u8; 0],
}

/// The scene and whether it has edits not yet committed.
pub(crate) struct SceneState {
    scene: Scene,
    dirty: bool,
}

impl Kind for SceneState {
    type Opaque = PacktraceScene;
    const MAGIC: u32 = 0x5054_5343; // "PTSC"
    const NAME: &'static str = "scene";
}

impl SceneState {
    /// The scene, if every edit is committed.
    fn committed(&self) -> Result<&Scene, Error> {
        if self.dirty {
            return Err(Error::new(
                PacktraceStatus::Uncommitted,
                "the scene has edits not committed: call packtrace_scene_commit before \
                 querying it",
            ));
        }
        Ok(&self.scene)
    }

    /// Runs one edit without rebuilding the top level: that waits for
    /// `packtrace_scene_commit`, once for a whole batch of edits, as
    /// Embree's `rtcCommitScene` does. (A `SceneEdit` rebuilds the top
    /// level when dropped; forgetting it skips that rebuild and nothing
    /// else: it only borrows the scene.)
    fn edit<T>(
        &mut self,
        f: impl FnOnce(&mut packtrace::scene::SceneEdit<'_>) -> Result<T, Error>,
    ) -> Result<T, Error> {
        let mut e = self.scene.edit();
        let r = f(&mut e);
        std::mem::forget(e);
        self.dirty = true;
        r
    }
}

/// What the host reads of scene hit `h`.
#[inline]
fn found(s: &Scene, h: SceneHit) -> Found {
    Found {
        t: h.t,
        u: h.u,
        v: h.v,
        prim: h.prim,
        geom: h.geometry.0,
        inst: h.instance.0,
        ng: s.normal(&h).unwrap_or_default(),
    }
}

fn scene_ref<'a>(p: *const PacktraceScene) -> Result<&'a Scene, Error> {
    ptr::handle::<SceneState>(p, "scene")?.committed()
}

fn scene_mut<'a>(p: *mut PacktraceScene) -> Result<&'a mut SceneState, Error> {
    ptr::handle_mut::<SceneState>(p, "scene")
}

/// A 3 x 4 row-major affine map (Embree's
/// `RTC_FORMAT_FLOAT3X4_ROW_MAJOR`): row `i` is `m[4i..4i + 3]` and the
/// translation `m[4i + 3]`.
fn affine(p: *const f32) -> Result<Affine3A, Error> {
    let m = ptr::slice(p, 12, "transform")?;
    let col = |j: usize| Vec3A::new(m[j], m[4 + j], m[8 + j]);
    Ok(Affine3A::from_mat3_translation(
        Mat3A::from_cols(col(0), col(1), col(2)).into(),
        col(3).into(),
    ))
}

/// A new, empty scene (committed: it may be queried at once).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_new(out_scene: *mut *mut PacktraceScene) -> PacktraceStatus {
    guard(|| {
        let out = ptr::write(out_scene, "out_scene")?;
        *out = ptr::new_handle(SceneState {
            scene: Scene::new(),
            dirty: false,
        });
        Ok(())
    })
}

/// Releases a scene (NULL: nothing to do); the trees it holds stay alive
/// while their own handles do. Use after release: as
/// `packtrace_tree_release`.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_release(scene: *mut PacktraceScene) -> PacktraceStatus {
    guard(|| ptr::release::<SceneState>(scene, "scene"))
}

/// Adds a tree as a geometry of the scene (shared, not copied: the scene
/// keeps it alive after `packtrace_tree_release`) and writes its id
/// (0, 1, ... in order of addition) to `out_geom_id`.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_add_geometry(
    scene: *mut PacktraceScene,
    tree: *const PacktraceTree,
    out_geom_id: *mut u32,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_mut(scene)?;
        let t = ptr::handle::<Tree>(tree, "tree")?;
        let out = ptr::write(out_geom_id, "out_geom_id")?;
        let kd = t.kd().ok_or_else(|| {
            Error::new(
                PacktraceStatus::Unsupported,
                "scenes hold kd-trees only in this version",
            )
        })?;
        if s.scene.geometry_count() >= u32::MAX as usize - 1 {
            return Err(packtrace::scene::SceneError::TooMany.into());
        }
        *out = s.scene.add_shared_geometry("", kd.clone()).0;
        Ok(())
    })
}

/// Places geometry `geom_id` with the object-to-world map `transform`
/// (12 floats, 3 x 4 row-major: `x' = m[0] x + m[1] y + m[2] z + m[3]`,
/// ...) and ray mask `mask` (an instance is traced for rays whose mask
/// shares a bit with it), and writes the instance's id (never reused) to
/// `out_inst_id`. Takes effect at the next `packtrace_scene_commit`;
/// queries fail with `UNCOMMITTED` until then. `SCENE` for an unknown
/// geometry or a singular, ill-conditioned or non-finite transform.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_add_instance(
    scene: *mut PacktraceScene,
    geom_id: u32,
    transform: *const f32,
    mask: u32,
    out_inst_id: *mut u32,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_mut(scene)?;
        let m = affine(transform)?;
        let out = ptr::write(out_inst_id, "out_inst_id")?;
        let id = s.edit(|e| {
            let id = e.add_instance(GeometryId(geom_id), m)?;
            e.set_mask(id, mask)?;
            Ok(id)
        })?;
        *out = id.0;
        Ok(())
    })
}

/// Moves instance `inst_id` (`transform` as in
/// `packtrace_scene_add_instance`); unchanged on error. Takes effect at
/// the next commit.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_set_transform(
    scene: *mut PacktraceScene,
    inst_id: u32,
    transform: *const f32,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_mut(scene)?;
        let m = affine(transform)?;
        s.edit(|e| Ok(e.set_transform(InstanceId(inst_id), m)?))
    })
}

/// Sets instance `inst_id`'s mask. Takes effect at the next commit.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_set_mask(
    scene: *mut PacktraceScene,
    inst_id: u32,
    mask: u32,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_mut(scene)?;
        s.edit(|e| Ok(e.set_mask(InstanceId(inst_id), mask)?))
    })
}

/// Removes instance `inst_id` (its id is not reused). Takes effect at the
/// next commit.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_remove_instance(
    scene: *mut PacktraceScene,
    inst_id: u32,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_mut(scene)?;
        s.edit(|e| Ok(e.remove_instance(InstanceId(inst_id))?))
    })
}

/// Applies the edits since the last commit: rebuilds the top level over
/// the instances (never the geometries' trees). No other thread may use
/// the scene meanwhile.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_commit(scene: *mut PacktraceScene) -> PacktraceStatus {
    guard(|| {
        let s = scene_mut(scene)?;
        s.scene.edit().commit();
        s.dirty = false;
        Ok(())
    })
}

/// The unit world-space geometric normal of triangle `prim_id` of
/// instance `inst_id` (a hit's ids), written to `out_normal`.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_normal(
    scene: *const PacktraceScene,
    inst_id: u32,
    prim_id: u32,
    out_normal: *mut f32,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_ref(scene)?;
        let h = SceneHit {
            t: 0.0,
            u: 0.0,
            v: 0.0,
            prim: prim_id,
            geometry: GeometryId(0),
            instance: InstanceId(inst_id),
        };
        let n = s.normal(&h).ok_or_else(|| {
            Error::invalid(format!(
                "instance {inst_id} has no triangle {prim_id} (or is not in the scene)"
            ))
        })?;
        put3(out_normal, n)
    })
}

/// The closest hit of one ray over the instances whose mask shares a bit
/// with `rayhit->ray.mask`, written as `packtrace_intersect1` writes it,
/// with the geometry's and the instance's ids.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_intersect1(
    scene: *const PacktraceScene,
    rayhit: *mut PacktraceRayHit,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_ref(scene)?;
        let rh = ptr::write(rayhit, "rayhit")?;
        let r = packet::ray(&rh.ray)?;
        let q = Query::new().with_mask(rh.ray.mask);
        let f = s.intersect_with(&r, &q).map(|h| found(s, h));
        packet::write_hit(&mut rh.ray, &mut rh.hit, f);
        Ok(())
    })
}

/// Whether one ray hits any instance its mask selects (`tfar = -inf` if
/// so).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_occluded1(
    scene: *const PacktraceScene,
    ray: *mut PacktraceRay,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_ref(scene)?;
        let r = ptr::write(ray, "ray")?;
        let q = Query::new().with_mask(r.mask);
        let occluded = s.occluded_with(&packet::ray(r)?, &q);
        packet::write_occluded(r, occluded);
        Ok(())
    })
}

/// The query of a packet's lanes' masks.
fn lane_masks<R: Width>(r: &R) -> Query<'static> {
    let mut m = [u32::MAX; 8];
    for (i, slot) in m.iter_mut().enumerate().take(R::W) {
        *slot = r.mask(i);
    }
    Query::new().with_lane_masks(m)
}

/// The closest hits of a packet of either width, each lane under its
/// own mask.
#[inline(always)]
fn intersect_packet<R: Width>(
    valid: *const c_int,
    scene: *const PacktraceScene,
    rays: &mut R,
    hits: &mut R::Hits,
) -> Result<(), Error>
where
    R::Packet: ScenePacket,
{
    let s = scene_ref(scene)?;
    let active = packet::active(ptr::slice(valid, R::W, "valid")?)?;
    let p = rays.packet(active)?;
    let q = lane_masks(rays);
    let h = p.intersect(s, &q);
    for i in lanes(active) {
        rays.write_hit(hits, i, h(i).map(|h| found(s, h)));
    }
    Ok(())
}

/// The occlusion of a packet of either width.
#[inline(always)]
fn occluded_packet<R: Width>(
    valid: *const c_int,
    scene: *const PacktraceScene,
    rays: &mut R,
) -> Result<(), Error>
where
    R::Packet: ScenePacket,
{
    let s = scene_ref(scene)?;
    let active = packet::active(ptr::slice(valid, R::W, "valid")?)?;
    let p = rays.packet(active)?;
    let m = p.occluded(s, &lane_masks(rays));
    for i in lanes(active) {
        rays.write_occluded(i, m >> i & 1 == 1);
    }
    Ok(())
}

/// The scene's packet queries for one width.
trait ScenePacket {
    fn intersect(&self, s: &Scene, q: &Query<'_>) -> impl Fn(usize) -> Option<SceneHit>;
    fn occluded(&self, s: &Scene, q: &Query<'_>) -> u32;
}

impl ScenePacket for RayPacket4 {
    fn intersect(&self, s: &Scene, q: &Query<'_>) -> impl Fn(usize) -> Option<SceneHit> {
        let h = s.intersect_packet(self, q);
        move |i| h.hit(i)
    }
    fn occluded(&self, s: &Scene, q: &Query<'_>) -> u32 {
        s.occluded_packet(self, q)
    }
}

impl ScenePacket for RayPacket8 {
    fn intersect(&self, s: &Scene, q: &Query<'_>) -> impl Fn(usize) -> Option<SceneHit> {
        let h = s.intersect_packet(self, q);
        move |i| h.hit(i)
    }
    fn occluded(&self, s: &Scene, q: &Query<'_>) -> u32 {
        s.occluded_packet(self, q)
    }
}

/// The closest hits of a 4-wide packet over the instances each lane's
/// mask selects: lanes written as `packtrace_scene_intersect1` writes a
/// ray, `valid` as in `packtrace_intersect4`; `rayhit` 16-byte aligned.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_intersect4(
    valid: *const c_int,
    scene: *const PacktraceScene,
    rayhit: *mut PacktraceRayHit4,
) -> PacktraceStatus {
    guard(|| {
        let rh = ptr::write(rayhit, "rayhit")?;
        intersect_packet(valid, scene, &mut rh.ray, &mut rh.hit)
    })
}

/// The occlusion of a 4-wide packet over the instances each lane's mask
/// selects (`tfar = -inf` for occluded lanes).
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_occluded4(
    valid: *const c_int,
    scene: *const PacktraceScene,
    ray: *mut PacktraceRay4,
) -> PacktraceStatus {
    guard(|| occluded_packet(valid, scene, ptr::write(ray, "ray")?))
}

/// The closest hits of an 8-wide packet over the instances each lane's
/// mask selects, as `packtrace_scene_intersect4`; `rayhit` 32-byte
/// aligned.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_intersect8(
    valid: *const c_int,
    scene: *const PacktraceScene,
    rayhit: *mut PacktraceRayHit8,
) -> PacktraceStatus {
    guard(|| {
        let rh = ptr::write(rayhit, "rayhit")?;
        intersect_packet(valid, scene, &mut rh.ray, &mut rh.hit)
    })
}

/// The occlusion of an 8-wide packet over the instances each lane's mask
/// selects.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_occluded8(
    valid: *const c_int,
    scene: *const PacktraceScene,
    ray: *mut PacktraceRay8,
) -> PacktraceStatus {
    guard(|| occluded_packet(valid, scene, ptr::write(ray, "ray")?))
}

/// Runs a scene stream query once per distinct ray mask (the library's
/// streams take one mask): `trace(rays, query, out)` over the rays of
/// each mask, answers scattered back to ray order.
fn by_mask<T: Clone + Default>(
    rays: &[Ray],
    masks: &[u32],
    trace: impl Fn(&[Ray], &Query<'_>, &mut [T]),
) -> Vec<T> {
    let mut out = vec![T::default(); rays.len()];
    if masks.iter().all(|&m| Some(&m) == masks.first()) {
        let q = Query::new().with_mask(masks.first().copied().unwrap_or(u32::MAX));
        trace(rays, &q, &mut out);
        return out;
    }
    let mut order: Vec<u32> = (0..rays.len() as u32).collect();
    order.sort_by_key(|&i| masks[i as usize]);
    for group in order.chunk_by(|&a, &b| masks[a as usize] == masks[b as usize]) {
        let sub: Vec<Ray> = group.iter().map(|&i| rays[i as usize]).collect();
        let mut answers = vec![T::default(); sub.len()];
        trace(
            &sub,
            &Query::new().with_mask(masks[group[0] as usize]),
            &mut answers,
        );
        for (&i, a) in group.iter().zip(answers) {
            out[i as usize] = a;
        }
    }
    out
}

/// The closest hits of a stream of rays (`rayhits` as in
/// `packtrace_intersect_stream`) over the instances each ray's mask
/// selects.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_intersect_stream(
    scene: *const PacktraceScene,
    rayhits: *mut PacktraceRayHit,
    count: usize,
    byte_stride: usize,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_ref(scene)?;
        let mut rh = StridedMut::new(rayhits, count, byte_stride, "rayhits")?;
        let rays = (0..rh.len())
            .map(|i| packet::stream_ray(&rh.get(i).ray, i))
            .collect::<Result<Vec<_>, _>>()?;
        let masks: Vec<u32> = (0..rh.len()).map(|i| rh.get(i).ray.mask).collect();
        let hits = by_mask(&rays, &masks, |r, q, out| s.intersect_rays_with(r, out, q));
        for (i, h) in hits.into_iter().enumerate() {
            let r = rh.get_mut(i);
            packet::write_hit(&mut r.ray, &mut r.hit, h.map(|h| found(s, h)));
        }
        Ok(())
    })
}

/// The occlusion of a stream of rays (`rays` as in
/// `packtrace_occluded_stream`) over the instances each ray's mask
/// selects.
#[unsafe(no_mangle)]
pub extern "C" fn packtrace_scene_occluded_stream(
    scene: *const PacktraceScene,
    rays: *mut PacktraceRay,
    count: usize,
    byte_stride: usize,
) -> PacktraceStatus {
    guard(|| {
        let s = scene_ref(scene)?;
        let mut rs = StridedMut::new(rays, count, byte_stride, "rays")?;
        let checked = (0..rs.len())
            .map(|i| packet::stream_ray(rs.get(i), i))
            .collect::<Result<Vec<_>, _>>()?;
        let masks: Vec<u32> = (0..rs.len()).map(|i| rs.get(i).mask).collect();
        let occluded = by_mask(&checked, &masks, |r, q, out| {
            s.occluded_rays_with(r, out, q)
        });
        for (i, o) in occluded.into_iter().enumerate() {
            packet::write_occluded(rs.get_mut(i), o);
        }
        Ok(())
    })
}

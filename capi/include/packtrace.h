/*
 * packtrace: SIMD ray-packet tracing through an SAH kd-tree, for C and C++.
 *
 * Generated from capi/src by cbindgen (capi/tests/header.rs checks that
 * this copy is current): do not edit by hand. The guide is docs/c-api.md.
 *
 * Errors: every function returns a PacktraceStatus; PACKTRACE_STATUS_OK
 * is success. On failure packtrace_last_error() gives the reason (the
 * library's own message, per thread) and no output was written. No call
 * ever unwinds or aborts: a panic inside the library is caught and
 * returned as PACKTRACE_STATUS_PANIC.
 *
 * Ownership: a handle made by a *_new or *_load call belongs to the
 * host, who releases it with the matching *_release call. Arrays passed
 * in are read during the call only (a tree keeps its own copy). A scene
 * holds its geometries' trees itself: a tree may be released while a
 * scene still uses it.
 *
 * Threads: built trees, committed scenes and loaded OBJs are immutable;
 * any number of threads may query them at once, with no locking.
 * Editing a scene (add, move, mask, remove, commit) or releasing any
 * handle needs it to itself: no other thread may use that handle
 * meanwhile. packtrace_last_error() is per thread.
 *
 * Checks: NULL and misaligned pointers, counts whose byte size overflows,
 * strides too small for their element, NaN or infinite rays and vertices
 * are refused with a status. What the library cannot see (a pointer to
 * too little memory, a handle used after release once 1024 others were
 * released since) is the host's contract.
 */
#ifndef PACKTRACE_ALIGNED
#if defined(_MSC_VER)
#define PACKTRACE_ALIGNED(n) __declspec(align(n))
#else
#define PACKTRACE_ALIGNED(n) __attribute__((aligned(n)))
#endif
#endif


#ifndef PACKTRACE_H
#define PACKTRACE_H

#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

// The id of no triangle, geometry or instance: a miss's `prim_id`,
// `geom_id` and `inst_id`, and the `inst_id` of a tree's hit (as
// Embree's `RTC_INVALID_GEOMETRY_ID`).
#define PACKTRACE_INVALID_ID UINT32_MAX

// The value of `PacktraceBuildParams::accel` reserved for the 8-wide
// BVH: refused with `PACKTRACE_STATUS_UNSUPPORTED` until the library
// has that structure.
#define PACKTRACE_ACCEL_RESERVED_BVH8 1

// What a call returns: `PACKTRACE_STATUS_OK`, or why it failed (the
// message is then in `packtrace_last_error()`). A failed call writes
// none of its outputs.
enum PacktraceStatus
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  // Success.
  PACKTRACE_STATUS_OK = 0,
  // A required pointer argument is NULL.
  PACKTRACE_STATUS_NULL_POINTER = 1,
  // A pointer argument is not aligned as its type requires (vertex and
  // index buffers: 4 bytes; `PacktraceRayHit`: 16; `PacktraceRayHit4`:
  // 16; `PacktraceRayHit8`: 32).
  PACKTRACE_STATUS_MISALIGNED = 2,
  // A count, stride, size, mask value or enum value out of range: a
  // stride too small for its element or not a multiple of 4, a byte
  // size that overflows, a `valid` entry other than 0 or -1, a NaN or
  // infinite input to a helper.
  PACKTRACE_STATUS_INVALID_ARGUMENT = 3,
  // An active ray is refused by the ray policy: NaN or infinite
  // origin or direction, zero direction, NaN `tnear` or `tfar`.
  PACKTRACE_STATUS_INVALID_RAY = 4,
  // The vertex and index arrays do not make a mesh: an index past the
  // vertices, a non-finite vertex used by a triangle, too many
  // triangles.
  PACKTRACE_STATUS_INVALID_MESH = 5,
  // A field of `PacktraceBuildParams` is out of range.
  PACKTRACE_STATUS_INVALID_PARAMS = 6,
  // The build failed (a tree larger than the node encoding can
  // address, the memory budget, the thread pool).
  PACKTRACE_STATUS_BUILD = 7,
  // A scene refused an edit (unknown geometry or instance, a singular
  // or non-finite transform, too many instances).
  PACKTRACE_STATUS_SCENE = 8,
  // An OBJ file could not be read or parsed.
  PACKTRACE_STATUS_LOAD = 9,
  // The handle was released (detected for recently released handles;
  // using a released handle is a host bug the library cannot always
  // see).
  PACKTRACE_STATUS_RELEASED_HANDLE = 10,
  // The pointer is not a live handle of the kind the function takes
  // (e.g. a scene passed where a tree is expected).
  PACKTRACE_STATUS_INVALID_HANDLE = 11,
  // The scene has edits that `packtrace_scene_commit` has not applied.
  PACKTRACE_STATUS_UNCOMMITTED = 12,
  // The request is valid but not available in this build (e.g. an
  // acceleration structure kind reserved for a later version).
  PACKTRACE_STATUS_UNSUPPORTED = 13,
  // The library panicked: a bug in packtrace, caught at the boundary.
  PACKTRACE_STATUS_PANIC = 14,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum PacktraceStatus PacktraceStatus;
#else
typedef uint32_t PacktraceStatus;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

// Which acceleration structure `packtrace_tree_new` builds
// (`PacktraceBuildParams::accel`).
enum PacktraceAccel
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  // The SAH kd-tree of 8-byte nodes (PBRT's layout).
  PACKTRACE_ACCEL_KD_TREE = 0,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum PacktraceAccel PacktraceAccel;
#else
typedef uint32_t PacktraceAccel;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

// The build presets of `packtrace_build_params_preset` (the Rust
// `KdBuildParams` presets).
enum PacktracePreset
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  // The default, chosen by measurement on the protocol's rays.
  PACKTRACE_PRESET_DEFAULT = 0,
  // For scenes rebuilt every frame: binned sweep, no clipping.
  PACKTRACE_PRESET_DYNAMIC = 1,
  // PBRT-v3's constants.
  PACKTRACE_PRESET_PBRT = 2,
  // Mitsuba 0.6's constants.
  PACKTRACE_PRESET_MITSUBA = 3,
  // Binned sweep above 64 triangles, shallower trees.
  PACKTRACE_PRESET_FAST_BUILD = 4,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum PacktracePreset PacktracePreset;
#else
typedef uint32_t PacktracePreset;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

// How `PacktraceBuildParams` gives the depth limit.
enum PacktraceDepthRule
#if defined(__cplusplus) || __STDC_VERSION__ >= 202311L
  : uint32_t
#endif // defined(__cplusplus) || __STDC_VERSION__ >= 202311L
 {
  // `round(depth_base + depth_slope * log2 N)` for `N` triangles, at
  // most 64.
  PACKTRACE_DEPTH_RULE_LOG2 = 0,
  // `depth_fixed` for every mesh, at most 64.
  PACKTRACE_DEPTH_RULE_FIXED = 1,
};
#ifndef __cplusplus
#if __STDC_VERSION__ >= 202311L
typedef enum PacktraceDepthRule PacktraceDepthRule;
#else
typedef uint32_t PacktraceDepthRule;
#endif // __STDC_VERSION__ >= 202311L
#endif // __cplusplus

// A loaded OBJ file (opaque): its mesh, normals, texture coordinates and
// materials. Immutable: any number of threads may read it at once.
typedef struct PacktraceObj PacktraceObj;

// A scene of instances (opaque). Queries may run from any number of
// threads at once; an edit or commit needs the scene to itself.
typedef struct PacktraceScene PacktraceScene;

// A built acceleration structure over one mesh (opaque). Immutable once
// built: any number of threads may query it at once.
typedef struct PacktraceTree PacktraceTree;

// Build parameters: fill them with `packtrace_build_params_default` (or
// `_preset`) and change fields. The kd-tree's fields are those of the
// Rust `KdBuildParams`, checked the same way
// (`PACKTRACE_STATUS_INVALID_PARAMS` names the first bad field).
typedef struct PacktraceBuildParams {
  // The structure: a `PacktraceAccel` value.
  uint32_t accel;
  // SAH cost of one traversal step, finite and > 0.
  float traversal_cost;
  // SAH cost of one ray/triangle test, finite and > 0.
  float intersection_cost;
  // Fraction of the cost waived when one side of a split is empty, in
  // [0, 1).
  float empty_bonus;
  // A `PacktraceDepthRule` value.
  uint32_t depth_rule;
  // `PACKTRACE_DEPTH_RULE_LOG2`: depth of a one-triangle mesh (finite,
  // >= 0).
  float depth_base;
  // `PACKTRACE_DEPTH_RULE_LOG2`: levels per doubling of the triangle
  // count (finite, >= 0).
  float depth_slope;
  // `PACKTRACE_DEPTH_RULE_FIXED`: the depth, at most 64.
  uint32_t depth_fixed;
  // Splits costlier than a leaf allowed on one path, >= 1.
  uint32_t max_bad_refines;
  // Nodes with at most this many triangles become leaves.
  uint32_t max_leaf_size;
  // Nodes with more triangles than this use the binned sweep
  // (`SIZE_MAX`: never).
  size_t exact_below;
  // Bins per axis of the binned sweep, in 2..=4096.
  uint32_t bins;
  // Clip straddling triangles to the child cells: 0 or 1.
  uint32_t split_clipping;
  // Fail rather than hold more bytes than this during the build (0: no
  // budget).
  size_t memory_budget;
  // Build threads (0: the library's global pool, one per core).
  uint32_t threads;
} PacktraceBuildParams;

// One ray, `org + t dir` for `tnear < t <= tfar` (the ray policy: a
// zero direction component is allowed, a zero direction is not; NaN or
// infinite coordinates and NaN bounds are refused). Layout of Embree 3's
// `RTCRay`; `time`, `id` and `flags` are the host's and never read.
// `mask` is read by scene queries only (an instance is traced when its
// mask and the ray's share a bit).
typedef struct PACKTRACE_ALIGNED(16) PacktraceRay {
  // Origin, x.
  float org_x;
  // Origin, y.
  float org_y;
  // Origin, z.
  float org_z;
  // Exclusive lower bound of the hit distance.
  float tnear;
  // Direction, x (need not be normalised; `t` is in units of it).
  float dir_x;
  // Direction, y.
  float dir_y;
  // Direction, z.
  float dir_z;
  // Not read (motion blur is not supported).
  float time;
  // Inclusive upper bound of the hit distance; an intersect query sets
  // it to the hit's `t`, an occluded query to `-inf` when the ray is
  // occluded (as Embree).
  float tfar;
  // The ray's mask (scene queries).
  uint32_t mask;
  // Not read: the host's.
  uint32_t id;
  // Not read: the host's.
  uint32_t flags;
} PacktraceRay;

// A hit, as an intersect query writes it. Layout of Embree 3's `RTCHit`
// with one instance level. On a miss `prim_id`, `geom_id` and `inst_id`
// are `PACKTRACE_INVALID_ID` and the rest is unchanged.
typedef struct PACKTRACE_ALIGNED(16) PacktraceHit {
  // Geometric normal, x: unit length (Embree's is not normalised), in
  // world space for a scene's hit.
  float ng_x;
  // Geometric normal, y.
  float ng_y;
  // Geometric normal, z.
  float ng_z;
  // Barycentric weight of the triangle's second vertex.
  float u;
  // Barycentric weight of the triangle's third vertex.
  float v;
  // The triangle's index in its mesh.
  uint32_t prim_id;
  // The geometry's id in its scene (0 for a tree's hit).
  uint32_t geom_id;
  // The instance's id in its scene (`PACKTRACE_INVALID_ID` for a
  // tree's hit).
  uint32_t inst_id;
} PacktraceHit;

// A ray and the hit an intersect query writes (`RTCRayHit`).
typedef struct PACKTRACE_ALIGNED(16) PacktraceRayHit {
  // The ray (its `tfar` becomes the hit's `t`).
  struct PacktraceRay ray;
  // The hit.
  struct PacktraceHit hit;
} PacktraceRayHit;

// 4 rays in SoA form, field for field like Embree 3's `RTCRayHit4` ray
// part (see `PacktraceRay`).
typedef struct PACKTRACE_ALIGNED(16) PacktraceRay4 {
  // Origins, x.
  float org_x[4];
  // Origins, y.
  float org_y[4];
  // Origins, z.
  float org_z[4];
  // Exclusive lower bounds.
  float tnear[4];
  // Directions, x.
  float dir_x[4];
  // Directions, y.
  float dir_y[4];
  // Directions, z.
  float dir_z[4];
  // Not read.
  float time[4];
  // Inclusive upper bounds; set to the hit's `t` (intersect) or `-inf`
  // (occluded lanes).
  float tfar[4];
  // Ray masks (scene queries).
  uint32_t mask[4];
  // Not read.
  uint32_t id[4];
  // Not read.
  uint32_t flags[4];
} PacktraceRay4;

// The hits of 4 rays in SoA form (see `PacktraceHit`).
typedef struct PACKTRACE_ALIGNED(16) PacktraceHit4 {
  // Geometric normals, x (unit length).
  float ng_x[4];
  // Geometric normals, y.
  float ng_y[4];
  // Geometric normals, z.
  float ng_z[4];
  // Barycentric weights of the second vertex.
  float u[4];
  // Barycentric weights of the third vertex.
  float v[4];
  // Triangle indices (`PACKTRACE_INVALID_ID`: no hit).
  uint32_t prim_id[4];
  // Geometry ids.
  uint32_t geom_id[4];
  // Instance ids.
  uint32_t inst_id[4];
} PacktraceHit4;

// A packet of 4 rays and their hits (`RTCRayHit4`), 16-byte aligned.
typedef struct PACKTRACE_ALIGNED(16) PacktraceRayHit4 {
  // The rays.
  struct PacktraceRay4 ray;
  // The hits.
  struct PacktraceHit4 hit;
} PacktraceRayHit4;

// 8 rays in SoA form, field for field like Embree 3's `RTCRayHit8` ray
// part (see `PacktraceRay`).
typedef struct PACKTRACE_ALIGNED(32) PacktraceRay8 {
  // Origins, x.
  float org_x[8];
  // Origins, y.
  float org_y[8];
  // Origins, z.
  float org_z[8];
  // Exclusive lower bounds.
  float tnear[8];
  // Directions, x.
  float dir_x[8];
  // Directions, y.
  float dir_y[8];
  // Directions, z.
  float dir_z[8];
  // Not read.
  float time[8];
  // Inclusive upper bounds; set to the hit's `t` (intersect) or `-inf`
  // (occluded lanes).
  float tfar[8];
  // Ray masks (scene queries).
  uint32_t mask[8];
  // Not read.
  uint32_t id[8];
  // Not read.
  uint32_t flags[8];
} PacktraceRay8;

// The hits of 8 rays in SoA form (see `PacktraceHit`).
typedef struct PACKTRACE_ALIGNED(32) PacktraceHit8 {
  // Geometric normals, x (unit length).
  float ng_x[8];
  // Geometric normals, y.
  float ng_y[8];
  // Geometric normals, z.
  float ng_z[8];
  // Barycentric weights of the second vertex.
  float u[8];
  // Barycentric weights of the third vertex.
  float v[8];
  // Triangle indices (`PACKTRACE_INVALID_ID`: no hit).
  uint32_t prim_id[8];
  // Geometry ids.
  uint32_t geom_id[8];
  // Instance ids.
  uint32_t inst_id[8];
} PacktraceHit8;

// A packet of 8 rays and their hits (`RTCRayHit8`), 32-byte aligned.
typedef struct PACKTRACE_ALIGNED(32) PacktraceRayHit8 {
  // The rays.
  struct PacktraceRay8 ray;
  // The hits.
  struct PacktraceHit8 hit;
} PacktraceRayHit8;

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

// The message of the calling thread's last failed packtrace call (the
// Rust error's `Display` text, then its sources after `: `), or "" if
// none has failed. Never NULL; valid until the thread's next failing
// call. A successful call leaves it as it was.
const char *packtrace_last_error(void);

// The name of a status code (`"PACKTRACE_STATUS_OK"`, ...), or
// `"PACKTRACE_STATUS_UNKNOWN"` for a value that is not one. Never NULL;
// static.
const char *packtrace_status_name(uint32_t status);

// The library's version, `"MAJOR.MINOR.PATCH"`. Never NULL; static.
const char *packtrace_version(void);

// Fills `*out_params` with the default build parameters (the kd-tree,
// the Rust `KdBuildParams::default()`).
PacktraceStatus packtrace_build_params_default(struct PacktraceBuildParams *out_params);

// Fills `*out_params` with preset `preset` (a `PacktracePreset`;
// `INVALID_ARGUMENT` otherwise).
PacktraceStatus packtrace_build_params_preset(uint32_t preset,
                                              struct PacktraceBuildParams *out_params);

// `point` (three floats) moved off a surface along its unit normal
// `normal` (towards the side it points to) far enough that no f32
// rounding puts it back on the other side: 256 `normal_i` ulps of each
// coordinate, or `normal_i / 65536` for a coordinate below 1/32 in
// magnitude (Wächter and Binder, Ray Tracing Gems, 2019, chapter 6).
// Written to `out_point`. `INVALID_ARGUMENT` for a non-finite input.
PacktraceStatus packtrace_offset_origin(const float *point, const float *normal, float *out_point);

// Loads the OBJ file at `path` (a NUL-terminated string) with its
// shading data (`vn`, `vt`, `usemtl` and the `mtllib` files' diffuse
// colours): polygons fan-triangulated in file order. `LOAD` with the
// file, line and reason when it cannot be read or parsed.
PacktraceStatus packtrace_obj_load(const char *path, struct PacktraceObj **out_obj);

// Releases an OBJ (NULL: nothing to do); the arrays of
// `packtrace_obj_mesh` die with it.
PacktraceStatus packtrace_obj_release(struct PacktraceObj *obj);

// The OBJ's mesh as arrays to pass to `packtrace_tree_new`: positions
// (three floats per vertex, stride 12) and triangles (three `uint32_t`
// per triangle, stride 12), owned by the OBJ and valid until its
// release. Any output may be NULL.
PacktraceStatus packtrace_obj_mesh(const struct PacktraceObj *obj,
                                   const float **out_positions,
                                   size_t *out_vertex_count,
                                   const uint32_t **out_indices,
                                   size_t *out_triangle_count);

// The unit shading normal at a hit (triangle `prim_id`, barycentrics
// `u`, `v`): the corners' `vn` normals interpolated and normalised, or
// the geometric normal where the triangle has none (or they cancel
// out); written to `out_normal` (three floats).
PacktraceStatus packtrace_obj_shading_normal(const struct PacktraceObj *obj,
                                             uint32_t prim_id,
                                             float u,
                                             float v,
                                             float *out_normal);

// The texture coordinate at a hit, interpolated from the corners' `vt`:
// `*out_found` is 1 and `out_uv` (two floats) set, or 0 and `out_uv`
// untouched when the triangle has none.
PacktraceStatus packtrace_obj_texcoord(const struct PacktraceObj *obj,
                                       uint32_t prim_id,
                                       float u,
                                       float v,
                                       float *out_uv,
                                       uint32_t *out_found);

// A new, empty scene (committed: it may be queried at once).
PacktraceStatus packtrace_scene_new(struct PacktraceScene **out_scene);

// Releases a scene (NULL: nothing to do); the trees it holds stay alive
// while their own handles do. Use after release: as
// `packtrace_tree_release`.
PacktraceStatus packtrace_scene_release(struct PacktraceScene *scene);

// Adds a tree as a geometry of the scene (shared, not copied: the scene
// keeps it alive after `packtrace_tree_release`) and writes its id
// (0, 1, ... in order of addition) to `out_geom_id`.
PacktraceStatus packtrace_scene_add_geometry(struct PacktraceScene *scene,
                                             const struct PacktraceTree *tree,
                                             uint32_t *out_geom_id);

// Places geometry `geom_id` with the object-to-world map `transform`
// (12 floats, 3 x 4 row-major: `x' = m[0] x + m[1] y + m[2] z + m[3]`,
// ...) and ray mask `mask` (an instance is traced for rays whose mask
// shares a bit with it), and writes the instance's id (never reused) to
// `out_inst_id`. Takes effect at the next `packtrace_scene_commit`;
// queries fail with `UNCOMMITTED` until then. `SCENE` for an unknown
// geometry or a singular, ill-conditioned or non-finite transform.
PacktraceStatus packtrace_scene_add_instance(struct PacktraceScene *scene,
                                             uint32_t geom_id,
                                             const float *transform,
                                             uint32_t mask,
                                             uint32_t *out_inst_id);

// Moves instance `inst_id` (`transform` as in
// `packtrace_scene_add_instance`); unchanged on error. Takes effect at
// the next commit.
PacktraceStatus packtrace_scene_set_transform(struct PacktraceScene *scene,
                                              uint32_t inst_id,
                                              const float *transform);

// Sets instance `inst_id`'s mask. Takes effect at the next commit.
PacktraceStatus packtrace_scene_set_mask(struct PacktraceScene *scene,
                                         uint32_t inst_id,
                                         uint32_t mask);

// Removes instance `inst_id` (its id is not reused). Takes effect at the
// next commit.
PacktraceStatus packtrace_scene_remove_instance(struct PacktraceScene *scene, uint32_t inst_id);

// Applies the edits since the last commit: rebuilds the top level over
// the instances (never the geometries' trees). No other thread may use
// the scene meanwhile.
PacktraceStatus packtrace_scene_commit(struct PacktraceScene *scene);

// The unit world-space geometric normal of triangle `prim_id` of
// instance `inst_id` (a hit's ids), written to `out_normal`.
PacktraceStatus packtrace_scene_normal(const struct PacktraceScene *scene,
                                       uint32_t inst_id,
                                       uint32_t prim_id,
                                       float *out_normal);

// The closest hit of one ray over the instances whose mask shares a bit
// with `rayhit->ray.mask`, written as `packtrace_intersect1` writes it,
// with the geometry's and the instance's ids.
PacktraceStatus packtrace_scene_intersect1(const struct PacktraceScene *scene,
                                           struct PacktraceRayHit *rayhit);

// Whether one ray hits any instance its mask selects (`tfar = -inf` if
// so).
PacktraceStatus packtrace_scene_occluded1(const struct PacktraceScene *scene,
                                          struct PacktraceRay *ray);

// The closest hits of a 4-wide packet over the instances each lane's
// mask selects: lanes written as `packtrace_scene_intersect1` writes a
// ray, `valid` as in `packtrace_intersect4`; `rayhit` 16-byte aligned.
PacktraceStatus packtrace_scene_intersect4(const int *valid,
                                           const struct PacktraceScene *scene,
                                           struct PacktraceRayHit4 *rayhit);

// The occlusion of a 4-wide packet over the instances each lane's mask
// selects (`tfar = -inf` for occluded lanes).
PacktraceStatus packtrace_scene_occluded4(const int *valid,
                                          const struct PacktraceScene *scene,
                                          struct PacktraceRay4 *ray);

// The closest hits of an 8-wide packet over the instances each lane's
// mask selects, as `packtrace_scene_intersect4`; `rayhit` 32-byte
// aligned.
PacktraceStatus packtrace_scene_intersect8(const int *valid,
                                           const struct PacktraceScene *scene,
                                           struct PacktraceRayHit8 *rayhit);

// The occlusion of an 8-wide packet over the instances each lane's mask
// selects.
PacktraceStatus packtrace_scene_occluded8(const int *valid,
                                          const struct PacktraceScene *scene,
                                          struct PacktraceRay8 *ray);

// The closest hits of a stream of rays (`rayhits` as in
// `packtrace_intersect_stream`) over the instances each ray's mask
// selects.
PacktraceStatus packtrace_scene_intersect_stream(const struct PacktraceScene *scene,
                                                 struct PacktraceRayHit *rayhits,
                                                 size_t count,
                                                 size_t byte_stride);

// The occlusion of a stream of rays (`rays` as in
// `packtrace_occluded_stream`) over the instances each ray's mask
// selects.
PacktraceStatus packtrace_scene_occluded_stream(const struct PacktraceScene *scene,
                                                struct PacktraceRay *rays,
                                                size_t count,
                                                size_t byte_stride);

// Builds a tree over a triangle mesh given as the host's own arrays,
// read in place (the library keeps its own copy; the arrays may be
// freed after the call).
//
// - `vertices`: `vertex_count` positions, each three `float`s (x, y,
//   z) at the start of a record `vertex_stride` bytes long (12 for
//   packed positions, more for interleaved vertex data; a multiple of
//   4); 4-byte aligned.
// - `indices`: `triangle_count` triangles, each three `uint32_t` vertex
//   indices at the start of a record `index_stride` bytes long (12 when
//   packed); 4-byte aligned.
// - `params`: the build parameters, or NULL for the defaults.
//
// Vertices no triangle uses are ignored (they need not be finite).
// Zero-area triangles are kept (indices stay stable) and never hit. Zero
// counts make an empty tree (that never hits); a NULL array is accepted
// with a zero count.
//
// On success `*out_tree` is a new handle; release it with
// `packtrace_tree_release`.
//
// Errors: `NULL_POINTER` (`out_tree`, or an array with a non-zero
// count), `MISALIGNED`, `INVALID_ARGUMENT` (a stride below 12 or not a
// multiple of 4, a byte size that overflows, more than 2^32 vertices),
// `INVALID_MESH` (an index past the vertices, a used vertex not finite,
// 2^32 - 1 triangles or more), `INVALID_PARAMS`, `UNSUPPORTED`
// (`PACKTRACE_ACCEL_RESERVED_BVH8`), `BUILD`.
PacktraceStatus packtrace_tree_new(const float *vertices,
                                   size_t vertex_count,
                                   size_t vertex_stride,
                                   const uint32_t *indices,
                                   size_t triangle_count,
                                   size_t index_stride,
                                   const struct PacktraceBuildParams *params,
                                   struct PacktraceTree **out_tree);

// Releases a tree (NULL: nothing to do). Scenes that hold it as a
// geometry keep it alive. Releasing a handle twice, or using it after,
// is reported as `RELEASED_HANDLE` for recently released handles (the
// library keeps the last 1024 released handles' headers), undefined
// behaviour otherwise.
PacktraceStatus packtrace_tree_release(struct PacktraceTree *tree);

// The tree's triangle count and its box (`lower`, `upper`: three floats
// each; an empty tree's box is `+inf` below `-inf`). Any output may be
// NULL.
PacktraceStatus packtrace_tree_info(const struct PacktraceTree *tree,
                                    size_t *out_triangle_count,
                                    float *out_lower,
                                    float *out_upper);

// The closest hit of one ray (Embree's `rtcIntersect1`): on a hit,
// `rayhit->ray.tfar` becomes its `t` and `rayhit->hit` is filled
// (`geom_id` 0, `inst_id` `PACKTRACE_INVALID_ID`); on a miss, the hit's
// ids are `PACKTRACE_INVALID_ID` and the rest is unchanged. The ray is
// checked (`INVALID_RAY`: NaN or infinite origin or direction, a zero
// direction, a NaN bound). `rayhit` must be 16-byte aligned.
PacktraceStatus packtrace_intersect1(const struct PacktraceTree *tree,
                                     struct PacktraceRayHit *rayhit);

// Whether one ray hits anything (Embree's `rtcOccluded1`): `ray->tfar`
// becomes `-inf` if it does, and is unchanged otherwise.
PacktraceStatus packtrace_occluded1(const struct PacktraceTree *tree, struct PacktraceRay *ray);

// The closest hits of a 4-wide packet (Embree's `rtcIntersect4`):
// lanes whose `valid` entry is -1 are traced, those with 0 left alone
// (any other value: `INVALID_ARGUMENT`); each traced lane is written as
// `packtrace_intersect1` writes its ray. `valid` points at 4 `int`s;
// `rayhit` must be 16-byte aligned. An invalid active lane fails the
// whole call (`INVALID_RAY`, the message names the lane), writing
// nothing.
PacktraceStatus packtrace_intersect4(const int *valid,
                                     const struct PacktraceTree *tree,
                                     struct PacktraceRayHit4 *rayhit);

// The occlusion of a 4-wide packet (Embree's `rtcOccluded4`): each
// traced lane's `tfar` becomes `-inf` if it hits anything.
PacktraceStatus packtrace_occluded4(const int *valid,
                                    const struct PacktraceTree *tree,
                                    struct PacktraceRay4 *ray);

// The closest hits of an 8-wide packet (Embree's `rtcIntersect8`), as
// `packtrace_intersect4` with 8 lanes; `rayhit` must be 32-byte aligned.
PacktraceStatus packtrace_intersect8(const int *valid,
                                     const struct PacktraceTree *tree,
                                     struct PacktraceRayHit8 *rayhit);

// The occlusion of an 8-wide packet (Embree's `rtcOccluded8`); `ray`
// must be 32-byte aligned.
PacktraceStatus packtrace_occluded8(const int *valid,
                                    const struct PacktraceTree *tree,
                                    struct PacktraceRay8 *ray);

// The closest hits of a stream of `count` rays of any length (Embree 3's
// `rtcIntersect1M`): `rayhits` holds `count` `PacktraceRayHit`s
// `byte_stride` bytes apart (`sizeof(PacktraceRayHit)` when packed; a
// multiple of 16). The library groups the rays into coherent packets
// itself; each ray is written as `packtrace_intersect1` writes it. Every
// ray is checked before any is traced: one invalid ray fails the call
// (`INVALID_RAY`, the message names it) and nothing is written. A zero
// count does nothing (`rayhits` may then be NULL).
PacktraceStatus packtrace_intersect_stream(const struct PacktraceTree *tree,
                                           struct PacktraceRayHit *rayhits,
                                           size_t count,
                                           size_t byte_stride);

// The occlusion of a stream of `count` rays `byte_stride` bytes apart
// (`sizeof(PacktraceRay)` when packed; a multiple of 16): each occluded
// ray's `tfar` becomes `-inf`. Checked as `packtrace_intersect_stream`.
PacktraceStatus packtrace_occluded_stream(const struct PacktraceTree *tree,
                                          struct PacktraceRay *rays,
                                          size_t count,
                                          size_t byte_stride);

// The point of a hit on its triangle, from the barycentrics (`(1 - u -
// v) p0 + u p1 + v p2`; more accurate than `org + t dir` far from the
// origin), written to `out_point` (three floats). `INVALID_ARGUMENT` if
// `prim_id` is not a triangle of the tree or `u`, `v` are not finite.
PacktraceStatus packtrace_hit_point(const struct PacktraceTree *tree,
                                    uint32_t prim_id,
                                    float u,
                                    float v,
                                    float *out_point);

// The unit geometric normal of triangle `prim_id` (`(p1 - p0) x (p2 -
// p0)`, normalised; zero for a zero-area triangle), written to
// `out_normal` (three floats).
PacktraceStatus packtrace_geometric_normal(const struct PacktraceTree *tree,
                                           uint32_t prim_id,
                                           float *out_normal);

// A secondary ray leaving the surface of a hit (triangle `prim_id` at
// barycentrics `u`, `v`) in direction `dir` (three floats) over `(0,
// tfar]`: it starts at the hit point moved off the surface, to the side
// `dir` goes to, by Wächter and Binder's offset (Ray Tracing Gems,
// chapter 6), so that it does not hit the triangle it leaves again. For
// a shadow ray to a light at `l`, pass `dir = l - hit point` and `tfar`
// just below 1. Written to `out_ray` (`mask` all ones; `time`, `id`,
// `flags` zero).
PacktraceStatus packtrace_spawn_ray(const struct PacktraceTree *tree,
                                    uint32_t prim_id,
                                    float u,
                                    float v,
                                    const float *dir,
                                    float tfar,
                                    struct PacktraceRay *out_ray);

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* PACKTRACE_H */

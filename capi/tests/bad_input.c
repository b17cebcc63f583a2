/*
 * bad_input.c: every function of the C API given bad input (NULL and
 * misaligned pointers, released and wrong handles, zero and overflowing
 * counts, bad strides, NaN rays and values) returns its documented status
 * and message, and writes no output. Built and run by .ci/run (also
 * under Valgrind): prints "N passed, M failed" and exits non-zero on a
 * failure.
 *
 *   cc -std=c11 -I capi/include capi/tests/bad_input.c \
 *      target/debug/libpacktrace_c.a -lm -lpthread -ldl -o bad_input
 */
#include <math.h>
#include <stdalign.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "packtrace.h"

static int passed, failed;

/* `call` returns `want` and the thread's last error contains `text`. */
#define EXPECT(call, want, text) expect((call), (want), (text), #call, __LINE__)

static void expect(PacktraceStatus got, PacktraceStatus want, const char *text, const char *call,
                   int line) {
    const char *msg = packtrace_last_error();
    int ok = got == want && (want == PACKTRACE_STATUS_OK || strstr(msg, text) != NULL);
    if (ok) {
        passed++;
        return;
    }
    failed++;
    fprintf(stderr, "line %d: %s\n  returned %s, expected %s\n  message \"%s\", expected to contain \"%s\"\n",
            line, call, packtrace_status_name(got), packtrace_status_name(want), msg, text);
}

/* A plain truth. */
#define TRUE(cond) expect((cond) ? PACKTRACE_STATUS_OK : PACKTRACE_STATUS_PANIC, PACKTRACE_STATUS_OK, "", #cond, __LINE__)

static const PacktraceStatus OK = PACKTRACE_STATUS_OK;
static const PacktraceStatus NUL = PACKTRACE_STATUS_NULL_POINTER;
static const PacktraceStatus MIS = PACKTRACE_STATUS_MISALIGNED;
static const PacktraceStatus ARG = PACKTRACE_STATUS_INVALID_ARGUMENT;
static const PacktraceStatus RAY = PACKTRACE_STATUS_INVALID_RAY;
static const PacktraceStatus REL = PACKTRACE_STATUS_RELEASED_HANDLE;
static const PacktraceStatus HANDLE = PACKTRACE_STATUS_INVALID_HANDLE;

/* A unit quad in z = 0 as two triangles. */
static const float QUAD[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
static const uint32_t TRIS[2][3] = {{0, 1, 2}, {0, 2, 3}};

static PacktraceTree *quad_tree(void) {
    PacktraceTree *t = NULL;
    packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, NULL, &t);
    return t;
}

/* A ray down onto the quad. */
static PacktraceRay down(void) {
    PacktraceRay r;
    memset(&r, 0, sizeof r);
    r.org_x = 0.25f, r.org_y = 0.5f, r.org_z = 1.0f;
    r.dir_z = -1.0f;
    r.tfar = INFINITY;
    r.mask = 0xffffffffu;
    return r;
}

static void library_calls(void) {
    TRUE(strlen(packtrace_version()) >= 5);
    TRUE(strcmp(packtrace_status_name(PACKTRACE_STATUS_OK), "PACKTRACE_STATUS_OK") == 0);
    TRUE(strcmp(packtrace_status_name(14), "PACKTRACE_STATUS_PANIC") == 0);
    TRUE(strcmp(packtrace_status_name(99), "PACKTRACE_STATUS_UNKNOWN") == 0);

    PacktraceBuildParams p;
    EXPECT(packtrace_build_params_default(NULL), NUL, "argument `out_params` is a null pointer");
    EXPECT(packtrace_build_params_preset(5, &p), ARG, "preset 5 is not a PacktracePreset (0 to 4)");
    EXPECT(packtrace_build_params_preset(PACKTRACE_PRESET_PBRT, &p), OK, "");
    TRUE(p.intersection_cost == 80.0f && p.depth_rule == PACKTRACE_DEPTH_RULE_LOG2);

    float point[3] = {1, 2, 3}, normal[3] = {0, 1, 0}, out[3] = {7, 7, 7};
    float nan_point[3] = {NAN, 0, 0};
    EXPECT(packtrace_offset_origin(NULL, normal, out), NUL, "`point` is a null pointer");
    EXPECT(packtrace_offset_origin(point, NULL, out), NUL, "`normal` is a null pointer");
    EXPECT(packtrace_offset_origin(point, normal, NULL), NUL, "`out` is a null pointer");
    EXPECT(packtrace_offset_origin(nan_point, normal, out), ARG, "`point` [NaN, 0, 0] is not finite");
    TRUE(out[0] == 7.0f); /* nothing written on failure */
    EXPECT(packtrace_offset_origin(point, normal, out), OK, "");
    TRUE(out[0] == 1.0f && out[1] > 2.0f);
}

static void tree_new(void) {
    PacktraceTree *t = NULL;
    alignas(16) float buf[16] = {0};
    PacktraceBuildParams p;
    packtrace_build_params_default(&p);

    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, NULL, NULL), NUL,
           "argument `out_tree` is a null pointer");
    EXPECT(packtrace_tree_new(NULL, 4, 12, &TRIS[0][0], 2, 12, NULL, &t), NUL,
           "argument `vertices` is a null pointer");
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, NULL, 2, 12, NULL, &t), NUL,
           "argument `indices` is a null pointer");
    EXPECT(packtrace_tree_new((const float *)((const char *)buf + 2), 1, 12, NULL, 0, 12, NULL, &t),
           MIS, "argument `vertices`");
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 8, &TRIS[0][0], 2, 12, NULL, &t), ARG,
           "stride of `vertices` is 8 bytes: at least 12 and a multiple of 4 required");
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 14, &TRIS[0][0], 2, 12, NULL, &t), ARG,
           "stride of `vertices` is 14 bytes");
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 0, NULL, &t), ARG,
           "stride of `indices` is 0 bytes");
    EXPECT(packtrace_tree_new(&QUAD[0][0], SIZE_MAX / 8, 16, &TRIS[0][0], 2, 12, NULL, &t), ARG,
           "vertex_count");
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, (SIZE_MAX / 2) & ~(size_t)3, &TRIS[0][0], 2, 12, NULL, &t), ARG,
           "overflow the address space");
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], (size_t)UINT32_MAX, 12, NULL, &t),
           PACKTRACE_STATUS_INVALID_MESH, "4294967295 triangles exceed the limit of 4294967294");
    /* An index past the vertices; a used vertex that is NaN. */
    EXPECT(packtrace_tree_new(&QUAD[0][0], 3, 12, &TRIS[0][0], 2, 12, NULL, &t),
           PACKTRACE_STATUS_INVALID_MESH, "triangle 1 uses vertex 3, but there are only 3 vertices");
    float nan_quad[4][3];
    memcpy(nan_quad, QUAD, sizeof nan_quad);
    nan_quad[2][1] = NAN;
    EXPECT(packtrace_tree_new(&nan_quad[0][0], 4, 12, &TRIS[0][0], 2, 12, NULL, &t),
           PACKTRACE_STATUS_INVALID_MESH, "vertex 2 is not finite: [1, NaN, 0]");
    /* Bad parameters. */
    PacktraceBuildParams bad = p;
    bad.traversal_cost = NAN;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_INVALID_PARAMS,
           "invalid kd-tree build parameters: traversal_cost = NaN (must be finite and > 0)");
    bad = p, bad.accel = PACKTRACE_ACCEL_RESERVED_BVH8;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_UNSUPPORTED, "reserved for the 8-wide BVH");
    bad = p, bad.accel = 7;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_INVALID_PARAMS, "accel = 7 (must be a PacktraceAccel value)");
    bad = p, bad.depth_rule = 5;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_INVALID_PARAMS, "depth_rule = 5");
    bad = p, bad.split_clipping = 2;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_INVALID_PARAMS, "split_clipping = 2 (must be 0 or 1)");
    bad = p, bad.depth_rule = PACKTRACE_DEPTH_RULE_FIXED, bad.depth_fixed = 65;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_INVALID_PARAMS, "max_depth 65 exceeds the limit of 64");
    bad = p, bad.bins = 1;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_INVALID_PARAMS, "bins = 1 (must be in 2..=4096)");
    bad = p, bad.memory_budget = 1;
    EXPECT(packtrace_tree_new(&QUAD[0][0], 4, 12, &TRIS[0][0], 2, 12, &bad, &t),
           PACKTRACE_STATUS_BUILD, "over its memory budget of 1");
    TRUE(t == NULL); /* no failed call wrote it */

    /* Zero counts: an empty tree (NULL arrays accepted), which never hits. */
    EXPECT(packtrace_tree_new(NULL, 0, 0, NULL, 0, 0, NULL, &t), OK, "");
    PacktraceRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray = down();
    EXPECT(packtrace_intersect1(t, &rh), OK, "");
    TRUE(rh.hit.prim_id == PACKTRACE_INVALID_ID && rh.ray.tfar == INFINITY);
    size_t n = 9;
    EXPECT(packtrace_tree_info(t, &n, NULL, NULL), OK, "");
    TRUE(n == 0);
    EXPECT(packtrace_tree_release(t), OK, "");
    /* Interleaved vertices, stride 16, read in place. */
    float inter[4][4];
    for (int i = 0; i < 4; i++) memcpy(inter[i], QUAD[i], 12), inter[i][3] = NAN;
    t = NULL;
    EXPECT(packtrace_tree_new(&inter[0][0], 4, 16, &TRIS[0][0], 2, 12, &p, &t), OK, "");
    EXPECT(packtrace_tree_info(t, &n, NULL, NULL), OK, "");
    TRUE(n == 2);
    EXPECT(packtrace_tree_release(t), OK, "");
}

static void handles(void) {
    PacktraceTree *t = quad_tree();
    PacktraceScene *s = NULL;
    packtrace_scene_new(&s);
    PacktraceRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray = down();

    EXPECT(packtrace_tree_release(NULL), OK, "");
    EXPECT(packtrace_scene_release(NULL), OK, "");
    EXPECT(packtrace_obj_release(NULL), OK, "");
    EXPECT(packtrace_intersect1(NULL, &rh), NUL, "argument `tree` is a null pointer");
    EXPECT(packtrace_tree_info(NULL, NULL, NULL, NULL), NUL, "argument `tree` is a null pointer");
    /* A scene where a tree is expected, and the other way round. */
    EXPECT(packtrace_intersect1((const PacktraceTree *)s, &rh), HANDLE,
           "argument `tree` is not a packtrace tree handle");
    EXPECT(packtrace_scene_intersect1((const PacktraceScene *)t, &rh), HANDLE,
           "argument `scene` is not a packtrace scene handle");
    EXPECT(packtrace_tree_release((PacktraceTree *)s), HANDLE, "not a packtrace tree handle");

    /* Released handles, used again. */
    EXPECT(packtrace_tree_release(t), OK, "");
    EXPECT(packtrace_intersect1(t, &rh), REL, "argument `tree` is a released handle");
    EXPECT(packtrace_tree_info(t, NULL, NULL, NULL), REL, "released handle");
    EXPECT(packtrace_tree_release(t), REL, "argument `tree` is a released handle");
    EXPECT(packtrace_scene_release(s), OK, "");
    EXPECT(packtrace_scene_commit(s), REL, "argument `scene` is a released handle");
    EXPECT(packtrace_scene_intersect1(s, &rh), REL, "argument `scene` is a released handle");
    EXPECT(packtrace_scene_release(s), REL, "argument `scene` is a released handle");
}

static void single_rays(void) {
    PacktraceTree *t = quad_tree();
    alignas(16) unsigned char buf[2 * sizeof(PacktraceRayHit)];
    PacktraceRayHit rh;
    memset(&rh, 0, sizeof rh);

    EXPECT(packtrace_intersect1(t, NULL), NUL, "argument `rayhit` is a null pointer");
    EXPECT(packtrace_intersect1(t, (PacktraceRayHit *)(buf + 4)), MIS,
           "is not aligned to 16 bytes");
    EXPECT(packtrace_occluded1(t, NULL), NUL, "argument `ray` is a null pointer");
    EXPECT(packtrace_occluded1(t, (PacktraceRay *)(buf + 8)), MIS, "is not aligned to 16 bytes");
    rh.ray = down(), rh.ray.org_x = NAN;
    EXPECT(packtrace_intersect1(t, &rh), RAY, "ray origin [NaN, 0.5, 1] is not finite");
    TRUE(rh.ray.tfar == INFINITY);
    rh.ray = down(), rh.ray.dir_z = 0.0f;
    EXPECT(packtrace_intersect1(t, &rh), RAY, "ray direction is the zero vector");
    rh.ray = down(), rh.ray.dir_y = INFINITY;
    EXPECT(packtrace_occluded1(t, &rh.ray), RAY, "ray direction [0, inf, -1] is not finite");
    rh.ray = down(), rh.ray.tnear = NAN;
    EXPECT(packtrace_occluded1(t, &rh.ray), RAY, "ray interval (NaN, inf] contains NaN");
    rh.ray = down(), rh.ray.tfar = NAN;
    EXPECT(packtrace_intersect1(t, &rh), RAY, "ray interval (0, NaN] contains NaN");
    /* And the good ray. */
    rh.ray = down();
    EXPECT(packtrace_intersect1(t, &rh), OK, "");
    TRUE(rh.ray.tfar == 1.0f && rh.hit.prim_id == 1 && rh.hit.geom_id == 0 &&
         rh.hit.inst_id == PACKTRACE_INVALID_ID && rh.hit.ng_z == 1.0f);
    rh.ray = down();
    EXPECT(packtrace_occluded1(t, &rh.ray), OK, "");
    TRUE(rh.ray.tfar == -INFINITY);
    packtrace_tree_release(t);
}

static void packets(void) {
    PacktraceTree *t = quad_tree();
    alignas(32) static unsigned char buf[2 * sizeof(PacktraceRayHit8)];
    static PacktraceRayHit8 p8;
    static PacktraceRayHit4 p4;
    const int all8[8] = {-1, -1, -1, -1, -1, -1, -1, -1}, all4[4] = {-1, -1, -1, -1};
    int bad_valid[8] = {-1, -1, 1, -1, 0, 0, 0, 0};
    PacktraceRay r = down();
    for (int i = 0; i < 8; i++) {
        p8.ray.org_x[i] = r.org_x, p8.ray.org_y[i] = r.org_y, p8.ray.org_z[i] = r.org_z;
        p8.ray.dir_z[i] = -1.0f, p8.ray.tfar[i] = INFINITY;
        if (i < 4) {
            p4.ray.org_x[i] = r.org_x, p4.ray.org_y[i] = r.org_y, p4.ray.org_z[i] = r.org_z;
            p4.ray.dir_z[i] = -1.0f, p4.ray.tfar[i] = INFINITY;
        }
    }
    EXPECT(packtrace_intersect8(NULL, t, &p8), NUL, "argument `valid` is a null pointer");
    EXPECT(packtrace_intersect8(all8, NULL, &p8), NUL, "argument `tree` is a null pointer");
    EXPECT(packtrace_intersect8(all8, t, NULL), NUL, "argument `rayhit` is a null pointer");
    EXPECT(packtrace_intersect8(all8, t, (PacktraceRayHit8 *)(buf + 16)), MIS,
           "is not aligned to 32 bytes");
    EXPECT(packtrace_occluded8(all8, t, (PacktraceRay8 *)(buf + 4)), MIS, "aligned to 32 bytes");
    EXPECT(packtrace_intersect4(all4, t, (PacktraceRayHit4 *)(buf + 8)), MIS, "aligned to 16 bytes");
    EXPECT(packtrace_occluded4(NULL, t, &p4.ray), NUL, "argument `valid` is a null pointer");
    EXPECT(packtrace_intersect8(bad_valid, t, &p8), ARG,
           "valid[2] is 1: a lane is active with -1 and inactive with 0 (as in Embree)");
    EXPECT(packtrace_occluded4(bad_valid, t, &p4.ray), ARG, "valid[2] is 1");
    /* A NaN in an active lane fails the call and writes nothing; in an
     * inactive lane it is never read. */
    p8.ray.dir_x[5] = NAN;
    EXPECT(packtrace_intersect8(all8, t, &p8), RAY, "lane 5: ray direction [NaN, 0, -1] is not finite");
    TRUE(p8.ray.tfar[0] == INFINITY);
    EXPECT(packtrace_occluded8(all8, t, &p8.ray), RAY, "lane 5: ray direction");
    int five_off[8] = {-1, -1, -1, -1, -1, 0, -1, -1};
    EXPECT(packtrace_intersect8(five_off, t, &p8), OK, "");
    TRUE(p8.ray.tfar[0] == 1.0f && p8.ray.tfar[5] == INFINITY && p8.hit.prim_id[7] == 1);
    p4.ray.tnear[3] = NAN;
    EXPECT(packtrace_intersect4(all4, t, &p4), RAY, "lane 3: ray interval (NaN, inf] contains NaN");
    int three_off[4] = {-1, -1, -1, 0};
    EXPECT(packtrace_occluded4(three_off, t, &p4.ray), OK, "");
    TRUE(p4.ray.tfar[0] == -INFINITY && p4.ray.tfar[3] == INFINITY);
    packtrace_tree_release(t);
    EXPECT(packtrace_intersect4(all4, t, &p4), REL, "released handle");
    EXPECT(packtrace_occluded8(all8, t, &p8.ray), REL, "released handle");
}

static void streams(void) {
    PacktraceTree *t = quad_tree();
    static PacktraceRayHit rh[5];
    static PacktraceRay rays[5];
    for (int i = 0; i < 5; i++) rh[i].ray = down(), rays[i] = down();

    /* Zero rays: nothing to do, NULL accepted. */
    EXPECT(packtrace_intersect_stream(t, NULL, 0, 0), OK, "");
    EXPECT(packtrace_occluded_stream(t, NULL, 0, 0), OK, "");
    EXPECT(packtrace_intersect_stream(t, NULL, 5, sizeof(PacktraceRayHit)), NUL,
           "argument `rayhits` is a null pointer");
    EXPECT(packtrace_occluded_stream(t, NULL, 1, sizeof(PacktraceRay)), NUL,
           "argument `rays` is a null pointer");
    EXPECT(packtrace_intersect_stream(NULL, rh, 5, sizeof(PacktraceRayHit)), NUL,
           "argument `tree` is a null pointer");
    EXPECT(packtrace_intersect_stream(t, rh, 5, 16), ARG,
           "stride of `rayhits` is 16 bytes: at least 80 and a multiple of 16 required");
    EXPECT(packtrace_occluded_stream(t, rays, 5, 56), ARG,
           "stride of `rays` is 56 bytes: at least 48 and a multiple of 16 required");
    EXPECT(packtrace_intersect_stream(t, rh, SIZE_MAX / 40, sizeof(PacktraceRayHit)), ARG,
           "overflow the address space");
    EXPECT(packtrace_occluded_stream(t, (PacktraceRay *)((char *)rays + 4), 2, sizeof(PacktraceRay)),
           MIS, "aligned to 16 bytes");
    rh[3].ray.org_z = NAN;
    EXPECT(packtrace_intersect_stream(t, rh, 5, sizeof(PacktraceRayHit)), RAY,
           "ray 3: ray origin [0.25, 0.5, NaN] is not finite");
    TRUE(rh[0].ray.tfar == INFINITY); /* nothing written */
    rays[4].dir_z = 0.0f;
    EXPECT(packtrace_occluded_stream(t, rays, 5, sizeof(PacktraceRay)), RAY,
           "ray 4: ray direction is the zero vector");
    rh[3].ray = down(), rays[4] = down();
    EXPECT(packtrace_intersect_stream(t, rh, 5, sizeof(PacktraceRayHit)), OK, "");
    TRUE(rh[4].ray.tfar == 1.0f && rh[4].hit.prim_id == 1);
    /* Every other ray: a stride of two structs. */
    EXPECT(packtrace_occluded_stream(t, rays, 2, 2 * sizeof(PacktraceRay)), OK, "");
    TRUE(rays[0].tfar == -INFINITY && rays[1].tfar == INFINITY && rays[2].tfar == -INFINITY);
    packtrace_tree_release(t);
    EXPECT(packtrace_occluded_stream(t, rays, 5, sizeof(PacktraceRay)), REL, "released handle");
}

static void helpers(void) {
    PacktraceTree *t = quad_tree();
    float out[3] = {7, 7, 7}, dir[3] = {0, 0, 1}, zero[3] = {0, 0, 0};
    PacktraceRay r;
    EXPECT(packtrace_hit_point(t, 2, 0.25f, 0.25f, out), ARG,
           "prim_id 2 is not a triangle of the tree (it has 2)");
    EXPECT(packtrace_hit_point(t, 0, NAN, 0.25f, out), ARG, "barycentrics (NaN, 0.25) are not finite");
    EXPECT(packtrace_hit_point(t, 0, 0.25f, 0.25f, NULL), NUL, "`out` is a null pointer");
    EXPECT(packtrace_hit_point(NULL, 0, 0.25f, 0.25f, out), NUL, "`tree` is a null pointer");
    TRUE(out[0] == 7.0f);
    EXPECT(packtrace_hit_point(t, 0, 0.25f, 0.5f, out), OK, "");
    TRUE(out[0] == 0.75f && out[1] == 0.5f && out[2] == 0.0f);
    EXPECT(packtrace_geometric_normal(t, 9, out), ARG, "prim_id 9 is not a triangle");
    EXPECT(packtrace_geometric_normal(t, 0, NULL), NUL, "`out` is a null pointer");
    EXPECT(packtrace_geometric_normal(t, 0, out), OK, "");
    TRUE(out[2] == 1.0f);
    EXPECT(packtrace_spawn_ray(t, 0, 0.25f, 0.25f, NULL, 1.0f, &r), NUL, "`dir` is a null pointer");
    EXPECT(packtrace_spawn_ray(t, 0, 0.25f, 0.25f, dir, 1.0f, NULL), NUL, "`out_ray` is a null pointer");
    EXPECT(packtrace_spawn_ray(t, 0, 0.25f, 0.25f, zero, 1.0f, &r), RAY, "ray direction is the zero vector");
    EXPECT(packtrace_spawn_ray(t, 0, 0.25f, 0.25f, dir, NAN, &r), RAY, "ray interval (0, NaN] contains NaN");
    EXPECT(packtrace_spawn_ray(t, 5, 0.25f, 0.25f, dir, 1.0f, &r), ARG, "prim_id 5 is not a triangle");
    EXPECT(packtrace_spawn_ray(t, 0, 0.25f, 0.25f, dir, 1.0f, &r), OK, "");
    TRUE(r.org_z > 0.0f && r.tfar == 1.0f && r.mask == 0xffffffffu);
    packtrace_tree_release(t);
    EXPECT(packtrace_geometric_normal(t, 0, out), REL, "released handle");
    EXPECT(packtrace_spawn_ray(t, 0, 0.25f, 0.25f, dir, 1.0f, &r), REL, "released handle");
    EXPECT(packtrace_hit_point(t, 0, 0.25f, 0.25f, out), REL, "released handle");
}

static void scenes(void) {
    PacktraceTree *t = quad_tree();
    PacktraceScene *s = NULL;
    uint32_t g = 99, inst = 99;
    const float identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    const float flat[12] = {1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0};
    const float nan[12] = {1, 0, 0, NAN, 0, 1, 0, 0, 0, 0, 1, 0};
    const int all4[4] = {-1, -1, -1, -1}, all8[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
    static PacktraceRayHit4 p4;
    static PacktraceRayHit8 p8;
    PacktraceRayHit rh;
    memset(&rh, 0, sizeof rh);

    EXPECT(packtrace_scene_new(NULL), NUL, "argument `out_scene` is a null pointer");
    EXPECT(packtrace_scene_new(&s), OK, "");
    EXPECT(packtrace_scene_add_geometry(NULL, t, &g), NUL, "`scene` is a null pointer");
    EXPECT(packtrace_scene_add_geometry(s, NULL, &g), NUL, "`tree` is a null pointer");
    EXPECT(packtrace_scene_add_geometry(s, t, NULL), NUL, "`out_geom_id` is a null pointer");
    EXPECT(packtrace_scene_add_geometry(s, t, &g), OK, "");
    TRUE(g == 0);
    EXPECT(packtrace_scene_add_instance(s, 5, identity, 1, &inst), PACKTRACE_STATUS_SCENE,
           "no geometry 5 in the scene");
    EXPECT(packtrace_scene_add_instance(s, 0, flat, 1, &inst), PACKTRACE_STATUS_SCENE,
           "bad instance transform: transform is singular or nearly so");
    EXPECT(packtrace_scene_add_instance(s, 0, nan, 1, &inst), PACKTRACE_STATUS_SCENE,
           "bad instance transform: transform has a NaN or infinite entry");
    EXPECT(packtrace_scene_add_instance(s, 0, NULL, 1, &inst), NUL, "`transform` is a null pointer");
    EXPECT(packtrace_scene_add_instance(s, 0, identity, 1, NULL), NUL, "`out_inst_id` is a null pointer");
    TRUE(inst == 99);
    EXPECT(packtrace_scene_add_instance(s, 0, identity, 1, &inst), OK, "");
    TRUE(inst == 0);
    /* Queries before the commit. */
    rh.ray = down();
    EXPECT(packtrace_scene_intersect1(s, &rh), PACKTRACE_STATUS_UNCOMMITTED,
           "the scene has edits not committed: call packtrace_scene_commit");
    EXPECT(packtrace_scene_occluded_stream(s, &rh.ray, 1, sizeof(PacktraceRay)),
           PACKTRACE_STATUS_UNCOMMITTED, "not committed");
    EXPECT(packtrace_scene_normal(s, 0, 0, (float[3]){0}), PACKTRACE_STATUS_UNCOMMITTED, "not committed");
    EXPECT(packtrace_scene_commit(NULL), NUL, "`scene` is a null pointer");
    EXPECT(packtrace_scene_commit(s), OK, "");
    EXPECT(packtrace_scene_set_transform(s, 3, identity), PACKTRACE_STATUS_SCENE, "no instance 3 in the scene");
    EXPECT(packtrace_scene_set_transform(s, 0, nan), PACKTRACE_STATUS_SCENE, "NaN or infinite entry");
    EXPECT(packtrace_scene_set_mask(s, 3, 1), PACKTRACE_STATUS_SCENE, "no instance 3 in the scene");
    EXPECT(packtrace_scene_set_mask(NULL, 0, 1), NUL, "`scene` is a null pointer");
    EXPECT(packtrace_scene_remove_instance(s, 3), PACKTRACE_STATUS_SCENE, "no instance 3 in the scene");
    EXPECT(packtrace_scene_commit(s), OK, "");
    /* The tree released: the scene keeps it. */
    packtrace_tree_release(t);
    rh.ray = down();
    EXPECT(packtrace_scene_intersect1(s, &rh), OK, "");
    TRUE(rh.ray.tfar == 1.0f && rh.hit.geom_id == 0 && rh.hit.inst_id == 0);
    rh.ray = down(), rh.ray.mask = 2;
    EXPECT(packtrace_scene_intersect1(s, &rh), OK, "");
    TRUE(rh.hit.prim_id == PACKTRACE_INVALID_ID && rh.ray.tfar == INFINITY); /* masked off */
    rh.ray = down(), rh.ray.dir_x = NAN;
    EXPECT(packtrace_scene_intersect1(s, &rh), RAY, "ray direction [NaN, 0, -1] is not finite");
    EXPECT(packtrace_scene_occluded1(s, &rh.ray), RAY, "ray direction [NaN, 0, -1] is not finite");
    EXPECT(packtrace_scene_occluded1(s, NULL), NUL, "`ray` is a null pointer");
    float n[3];
    EXPECT(packtrace_scene_normal(s, 4, 0, n), ARG, "instance 4 has no triangle 0");
    EXPECT(packtrace_scene_normal(s, 0, 2, n), ARG, "instance 0 has no triangle 2");
    EXPECT(packtrace_scene_normal(s, 0, 0, NULL), NUL, "`out` is a null pointer");
    EXPECT(packtrace_scene_normal(s, 0, 0, n), OK, "");
    /* Packets and streams. */
    for (int i = 0; i < 8; i++) {
        p8.ray.org_x[i] = 0.25f, p8.ray.org_y[i] = 0.5f, p8.ray.org_z[i] = 1.0f;
        p8.ray.dir_z[i] = -1.0f, p8.ray.tfar[i] = INFINITY, p8.ray.mask[i] = i % 2 ? 1 : 2;
        if (i < 4) {
            p4.ray.org_x[i] = 0.25f, p4.ray.org_y[i] = 0.5f, p4.ray.org_z[i] = 1.0f;
            p4.ray.dir_z[i] = -1.0f, p4.ray.tfar[i] = INFINITY, p4.ray.mask[i] = 1;
        }
    }
    EXPECT(packtrace_scene_intersect8(NULL, s, &p8), NUL, "`valid` is a null pointer");
    EXPECT(packtrace_scene_intersect4(all4, s, NULL), NUL, "`rayhit` is a null pointer");
    p8.ray.tfar[6] = NAN;
    EXPECT(packtrace_scene_intersect8(all8, s, &p8), RAY, "lane 6: ray interval (0, NaN] contains NaN");
    EXPECT(packtrace_scene_occluded8(all8, s, &p8.ray), RAY, "lane 6");
    p8.ray.tfar[6] = INFINITY;
    EXPECT(packtrace_scene_intersect8(all8, s, &p8), OK, "");
    TRUE(p8.hit.inst_id[1] == 0 && p8.hit.prim_id[0] == PACKTRACE_INVALID_ID);
    EXPECT(packtrace_scene_occluded4((int[4]){-1, 2, 0, 0}, s, &p4.ray), ARG, "valid[1] is 2");
    EXPECT(packtrace_scene_occluded4(all4, s, &p4.ray), OK, "");
    TRUE(p4.ray.tfar[3] == -INFINITY);
    static PacktraceRayHit stream[3];
    for (int i = 0; i < 3; i++) stream[i].ray = down(), stream[i].ray.mask = (uint32_t)i;
    EXPECT(packtrace_scene_intersect_stream(s, stream, 3, 8), ARG, "stride of `rayhits` is 8 bytes");
    EXPECT(packtrace_scene_intersect_stream(s, stream, SIZE_MAX / 64, 80), ARG, "overflow");
    EXPECT(packtrace_scene_intersect_stream(s, NULL, 0, 0), OK, "");
    stream[2].ray.dir_y = NAN;
    EXPECT(packtrace_scene_intersect_stream(s, stream, 3, sizeof(PacktraceRayHit)), RAY, "ray 2:");
    stream[2].ray = down(), stream[2].ray.mask = 3;
    EXPECT(packtrace_scene_intersect_stream(s, stream, 3, sizeof(PacktraceRayHit)), OK, "");
    /* Masks 0 and 2 miss instance 0 (mask 1); 1 and 3 hit it. */
    TRUE(stream[0].hit.prim_id == PACKTRACE_INVALID_ID && stream[1].hit.inst_id == 0 &&
         stream[2].hit.inst_id == 0);
    EXPECT(packtrace_scene_occluded_stream(s, &stream[0].ray, 3, 4), ARG, "stride of `rays` is 4 bytes");
    EXPECT(packtrace_scene_remove_instance(s, 0), OK, "");
    EXPECT(packtrace_scene_remove_instance(s, 0), PACKTRACE_STATUS_SCENE, "no instance 0 in the scene");
    EXPECT(packtrace_scene_commit(s), OK, "");
    rh.ray = down();
    EXPECT(packtrace_scene_occluded1(s, &rh.ray), OK, "");
    TRUE(rh.ray.tfar == INFINITY);
    EXPECT(packtrace_scene_release(s), OK, "");
    EXPECT(packtrace_scene_add_instance(s, 0, identity, 1, &inst), REL, "released handle");
    EXPECT(packtrace_scene_set_mask(s, 0, 1), REL, "released handle");
    EXPECT(packtrace_scene_intersect8(all8, s, &p8), REL, "released handle");
}

static void objs(void) {
    PacktraceObj *o = NULL;
    EXPECT(packtrace_obj_load(NULL, &o), NUL, "argument `path` is a null pointer");
    EXPECT(packtrace_obj_load("x.obj", NULL), NUL, "argument `out_obj` is a null pointer");
    EXPECT(packtrace_obj_load("no/such/file.obj", &o), PACKTRACE_STATUS_LOAD,
           "no/such/file.obj: cannot read the file");
    TRUE(o == NULL);
    /* A small file with normals on one triangle and texture coordinates. */
    const char *path = "bad_input_test.obj";
    FILE *f = fopen(path, "w");
    if (!f) return;
    fputs("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n"
          "f 1/1/1 2/2/1 3/3/1\nf 1 3 2\n",
          f);
    fclose(f);
    EXPECT(packtrace_obj_load(path, &o), OK, "");
    remove(path);
    const float *pos = NULL;
    size_t nv = 0, nt = 0;
    EXPECT(packtrace_obj_mesh(NULL, &pos, &nv, NULL, &nt), NUL, "`obj` is a null pointer");
    EXPECT(packtrace_obj_mesh(o, &pos, &nv, NULL, &nt), OK, "");
    TRUE(nv == 3 && nt == 2 && pos[3] == 1.0f);
    float out[3], uv[2] = {7, 7};
    uint32_t found = 9;
    EXPECT(packtrace_obj_shading_normal(o, 2, 0.1f, 0.1f, out), ARG,
           "prim_id 2 is not a triangle of the OBJ (it has 2)");
    EXPECT(packtrace_obj_shading_normal(o, 0, INFINITY, 0.1f, out), ARG, "are not finite");
    EXPECT(packtrace_obj_shading_normal(o, 0, 0.1f, 0.1f, NULL), NUL, "`out` is a null pointer");
    EXPECT(packtrace_obj_shading_normal(o, 1, 0.1f, 0.1f, out), OK, "");
    TRUE(out[2] == -1.0f); /* no normals: the geometric one */
    EXPECT(packtrace_obj_texcoord(o, 0, 0.5f, 0.25f, uv, NULL), NUL, "`out_found` is a null pointer");
    EXPECT(packtrace_obj_texcoord(o, 0, 0.5f, 0.25f, NULL, &found), NUL, "`out_uv` is a null pointer");
    EXPECT(packtrace_obj_texcoord(o, 1, 0.5f, 0.25f, uv, &found), OK, "");
    TRUE(found == 0 && uv[0] == 7.0f);
    EXPECT(packtrace_obj_texcoord(o, 0, 0.5f, 0.25f, uv, &found), OK, "");
    TRUE(found == 1 && uv[0] == 0.5f && uv[1] == 0.25f);
    EXPECT(packtrace_obj_release(o), OK, "");
    EXPECT(packtrace_obj_mesh(o, &pos, &nv, NULL, &nt), REL, "argument `obj` is a released handle");
    EXPECT(packtrace_obj_texcoord(o, 0, 0.5f, 0.25f, uv, &found), REL, "released handle");
    EXPECT(packtrace_obj_release(o), REL, "released handle");
}

int main(void) {
    library_calls();
    tree_new();
    handles();
    single_rays();
    packets();
    streams();
    helpers();
    scenes();
    objs();
    printf("%d passed, %d failed\n", passed, failed);
    return failed != 0;
}

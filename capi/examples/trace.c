/*
 * trace.c: a C host's first image with packtrace.
 *
 * Loads an OBJ, builds a tree from the host's own (interleaved) vertex
 * buffer, traces a W x H image with 8-wide packets (4 x 2 pixel blocks),
 * checks every pixel against the single-ray and the stream queries,
 * shoots a shadow ray from every hit (spawned off the surface by the
 * library) and writes:
 *   - OUT.hits: every ray and answer as exact bit patterns, which
 *     `cargo run -p packtrace-c --example check_hits -- tree SCENE.obj
 *     OUT.hits` compares with the Rust API's own answers;
 *   - IMAGE.ppm (optional): the image, shaded with the OBJ's normals.
 *
 * Build (after `cargo build --release -p packtrace-c`):
 *   cc -std=c11 -O2 -I capi/include capi/examples/trace.c \
 *      target/release/libpacktrace_c.a -lm -lpthread -ldl -o trace
 * Run: ./trace scene.obj out.hits [WIDTH HEIGHT [image.ppm]]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "packtrace.h"

/* Stop with the library's message when a call fails. */
#define CHECK(call)                                                                   \
    do {                                                                              \
        PacktraceStatus s_ = (call);                                                  \
        if (s_ != PACKTRACE_STATUS_OK) {                                              \
            fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__,                    \
                    packtrace_status_name(s_), packtrace_last_error());               \
            exit(1);                                                                  \
        }                                                                             \
    } while (0)

/* A host's vertex: position and one more attribute, 16 bytes. */
typedef struct Vertex {
    float position[3];
    float attribute;
} Vertex;

typedef struct V3 { float x, y, z; } V3;
static V3 v3(float x, float y, float z) { V3 v = {x, y, z}; return v; }
static V3 add(V3 a, V3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static V3 sub(V3 a, V3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static V3 scale(V3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static V3 cross(V3 a, V3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static V3 normalize(V3 a) { return scale(a, 1.0f / sqrtf(dot(a, a))); }

/* The bits of a float, for the exact dump. */
static unsigned bits(float f) {
    unsigned u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static void dump_ray(FILE *out, const PacktraceRay *r) {
    fprintf(out, "%08x %08x %08x %08x %08x %08x %08x %08x", bits(r->org_x), bits(r->org_y),
            bits(r->org_z), bits(r->dir_x), bits(r->dir_y), bits(r->dir_z), bits(r->tnear),
            bits(r->tfar));
}

static int same_hit(const PacktraceRayHit *a, const PacktraceRayHit *b) {
    return bits(a->ray.tfar) == bits(b->ray.tfar) && a->hit.prim_id == b->hit.prim_id &&
           bits(a->hit.u) == bits(b->hit.u) && bits(a->hit.v) == bits(b->hit.v);
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s SCENE.obj OUT.hits [WIDTH HEIGHT [IMAGE.ppm]]\n", argv[0]);
        return 2;
    }
    int width = argc > 4 ? atoi(argv[3]) : 64, height = argc > 4 ? atoi(argv[4]) : 48;
    if (width <= 0 || height <= 0 || width % 4 || height % 2) {
        fprintf(stderr, "WIDTH must be a multiple of 4 and HEIGHT of 2\n");
        return 2;
    }

    /* The mesh: the library's OBJ reader, copied into the host's own
     * interleaved vertex buffer, which the tree reads in place. */
    PacktraceObj *obj = NULL;
    CHECK(packtrace_obj_load(argv[1], &obj));
    const float *positions;
    const uint32_t *indices;
    size_t vertex_count, triangle_count;
    CHECK(packtrace_obj_mesh(obj, &positions, &vertex_count, &indices, &triangle_count));
    Vertex *vertices = malloc((vertex_count ? vertex_count : 1) * sizeof(Vertex));
    for (size_t i = 0; i < vertex_count; i++) {
        memcpy(vertices[i].position, positions + 3 * i, 3 * sizeof(float));
        vertices[i].attribute = 1.0f;
    }
    PacktraceBuildParams params;
    CHECK(packtrace_build_params_default(&params));
    PacktraceTree *tree = NULL;
    CHECK(packtrace_tree_new(&vertices[0].position[0], vertex_count, sizeof(Vertex), indices,
                             triangle_count, 3 * sizeof(uint32_t), &params, &tree));
    free(vertices); /* the tree keeps its own copy */

    /* The benchmark protocol's auto camera and light. */
    float lo[3], hi[3];
    CHECK(packtrace_tree_info(tree, NULL, lo, hi));
    V3 lower = v3(lo[0], lo[1], lo[2]), upper = v3(hi[0], hi[1], hi[2]);
    V3 centre = scale(add(lower, upper), 0.5f);
    float diag = sqrtf(dot(sub(upper, lower), sub(upper, lower)));
    V3 eye = add(centre, scale(normalize(v3(0.3f, 0.4f, 1.0f)), 0.9f * diag));
    V3 light = add(centre, scale(v3(0.25f, 0.8f, 0.35f), diag));
    V3 f = normalize(sub(centre, eye));
    V3 r = normalize(cross(f, v3(0.0f, 1.0f, 0.0f)));
    V3 u = cross(r, f);
    float h = tanf(45.0f * 3.14159265358979f / 360.0f), aspect = (float)width / (float)height;

    size_t n = (size_t)width * height;
    PacktraceRayHit *pixels = calloc(n, sizeof(PacktraceRayHit));
    PacktraceRayHit *stream = calloc(n, sizeof(PacktraceRayHit));
    PacktraceRay *shadow = calloc(n, sizeof(PacktraceRay));
    PacktraceRay *primary = calloc(n, sizeof(PacktraceRay)); /* as generated */
    if (!pixels || !stream || !shadow || !primary) return 1;

    /* Primary rays, 4 x 2 pixel blocks as 8-wide packets. */
    const int valid[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
    for (int by = 0; by < height; by += 2) {
        for (int bx = 0; bx < width; bx += 4) {
            PacktraceRayHit8 packet;
            memset(&packet, 0, sizeof packet);
            for (int lane = 0; lane < 8; lane++) {
                int x = bx + lane % 4, y = by + lane / 4;
                float sx = (2.0f * (x + 0.5f) / width - 1.0f) * h * aspect;
                float sy = (1.0f - 2.0f * (y + 0.5f) / height) * h;
                V3 d = normalize(add(f, add(scale(r, sx), scale(u, sy))));
                packet.ray.org_x[lane] = eye.x;
                packet.ray.org_y[lane] = eye.y;
                packet.ray.org_z[lane] = eye.z;
                packet.ray.dir_x[lane] = d.x;
                packet.ray.dir_y[lane] = d.y;
                packet.ray.dir_z[lane] = d.z;
                packet.ray.tnear[lane] = 0.0f;
                packet.ray.tfar[lane] = INFINITY;
                packet.ray.mask[lane] = 0xffffffffu;
                /* The same ray for the single-ray and the stream queries. */
                PacktraceRayHit *p = &pixels[(size_t)y * width + x];
                p->ray.org_x = eye.x, p->ray.org_y = eye.y, p->ray.org_z = eye.z;
                p->ray.dir_x = d.x, p->ray.dir_y = d.y, p->ray.dir_z = d.z;
                p->ray.tnear = 0.0f, p->ray.tfar = INFINITY, p->ray.mask = 0xffffffffu;
                stream[(size_t)y * width + x] = *p;
                primary[(size_t)y * width + x] = p->ray;
            }
            CHECK(packtrace_intersect8(valid, tree, &packet));
            for (int lane = 0; lane < 8; lane++) {
                int x = bx + lane % 4, y = by + lane / 4;
                PacktraceRayHit *p = &pixels[(size_t)y * width + x];
                PacktraceRayHit single = *p;
                CHECK(packtrace_intersect1(tree, &single));
                /* The packet's lane, as one struct. */
                p->ray.tfar = packet.ray.tfar[lane];
                p->hit.ng_x = packet.hit.ng_x[lane];
                p->hit.ng_y = packet.hit.ng_y[lane];
                p->hit.ng_z = packet.hit.ng_z[lane];
                p->hit.u = packet.hit.u[lane];
                p->hit.v = packet.hit.v[lane];
                p->hit.prim_id = packet.hit.prim_id[lane];
                p->hit.geom_id = packet.hit.geom_id[lane];
                p->hit.inst_id = packet.hit.inst_id[lane];
                if (!same_hit(p, &single)) {
                    fprintf(stderr, "pixel (%d, %d): packet and single ray differ\n", x, y);
                    return 1;
                }
            }
        }
    }
    CHECK(packtrace_intersect_stream(tree, stream, n, sizeof(PacktraceRayHit)));
    for (size_t i = 0; i < n; i++) {
        if (!same_hit(&pixels[i], &stream[i])) {
            fprintf(stderr, "ray %zu: packet and stream differ\n", i);
            return 1;
        }
    }

    /* Shadow rays from every hit, spawned off the surface towards the
     * light, traced as one stream. */
    size_t shadows = 0;
    for (size_t i = 0; i < n; i++) {
        const PacktraceHit *hit = &pixels[i].hit;
        if (hit->prim_id == PACKTRACE_INVALID_ID) continue;
        float p[3];
        CHECK(packtrace_hit_point(tree, hit->prim_id, hit->u, hit->v, p));
        float to_light[3] = {light.x - p[0], light.y - p[1], light.z - p[2]};
        CHECK(packtrace_spawn_ray(tree, hit->prim_id, hit->u, hit->v, to_light, 0.9999f,
                                  &shadow[shadows++]));
    }
    PacktraceRay *shadow_in = malloc((shadows ? shadows : 1) * sizeof(PacktraceRay));
    memcpy(shadow_in, shadow, shadows * sizeof(PacktraceRay));
    CHECK(packtrace_occluded_stream(tree, shadow, shadows, sizeof(PacktraceRay)));

    /* The dump: rays and answers as bit patterns. */
    FILE *out = fopen(argv[2], "w");
    if (!out) {
        perror(argv[2]);
        return 1;
    }
    unsigned char *image = calloc(n, 3);
    size_t k = 0, hits = 0, lit = 0;
    for (size_t i = 0; i < n; i++) {
        const PacktraceRayHit *p = &pixels[i];
        fprintf(out, "P ");
        dump_ray(out, &primary[i]);
        const PacktraceHit *hit = &p->hit;
        if (hit->prim_id == PACKTRACE_INVALID_ID) {
            fprintf(out, " miss\n");
            continue;
        }
        hits++;
        fprintf(out, " hit %08x %u %08x %08x %08x %08x %08x %u %u\n", bits(p->ray.tfar),
                hit->prim_id, bits(hit->u), bits(hit->v), bits(hit->ng_x), bits(hit->ng_y),
                bits(hit->ng_z), hit->geom_id, hit->inst_id);
        /* The shadow ray spawned from it, and its answer. */
        int occluded = shadow[k].tfar == -INFINITY;
        fprintf(out, "S ");
        dump_ray(out, &shadow_in[k]);
        fprintf(out, " %d\n", occluded);
        k++;
        lit += !occluded;
        /* The shading normal at the hit. */
        float sn[3];
        CHECK(packtrace_obj_shading_normal(obj, hit->prim_id, hit->u, hit->v, sn));
        fprintf(out, "N %08x %08x %08x\n", bits(sn[0]), bits(sn[1]), bits(sn[2]));
        V3 d = v3(p->ray.dir_x, p->ray.dir_y, p->ray.dir_z);
        float shade = fabsf(dot(v3(sn[0], sn[1], sn[2]), d)) * (occluded ? 0.35f : 1.0f);
        image[3 * i] = image[3 * i + 1] = image[3 * i + 2] = (unsigned char)(255.0f * shade);
    }
    fclose(out);
    if (argc > 5) {
        FILE *ppm = fopen(argv[5], "wb");
        if (!ppm) {
            perror(argv[5]);
            return 1;
        }
        fprintf(ppm, "P6\n%d %d\n255\n", width, height);
        fwrite(image, 3, n, ppm);
        fclose(ppm);
    }
    printf("%d x %d pixels: %zu hits, %zu lit; packet8 == single ray == stream on every pixel\n",
           width, height, hits, lit);

    free(image);
    free(shadow_in);
    free(shadow);
    free(stream);
    free(primary);
    free(pixels);
    CHECK(packtrace_tree_release(tree));
    CHECK(packtrace_obj_release(obj));
    return 0;
}

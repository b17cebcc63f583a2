// scene.cpp: a C++ host tracing a scene of instances with packtrace.
//
// Loads an OBJ, builds one tree, places it three times in a scene (the
// identity, a rotated and moved copy, a mirrored and scaled copy) with
// ray masks, and traces a W x H image through the scene with 8-wide
// packets whose lanes carry different masks, checking every pixel
// against the scene's single-ray and stream queries; then shadow rays as
// 4-wide packets. It writes OUT.hits, which `cargo run -p packtrace-c
// --example check_hits -- scene SCENE.obj OUT.hits` compares with the
// Rust API's own answers bit for bit.
//
// Build (after `cargo build --release -p packtrace-c`):
//   c++ -std=c++17 -O2 -I capi/include capi/examples/scene.cpp
//       target/release/libpacktrace_c.a -lpthread -ldl -o scene
// Run: ./scene scene.obj out.hits [WIDTH HEIGHT]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "packtrace.h"

namespace {

// A failed call as an exception carrying the library's message.
void check(PacktraceStatus s, const char *what) {
    if (s != PACKTRACE_STATUS_OK)
        throw std::runtime_error(std::string(what) + ": " + packtrace_status_name(s) + ": " +
                                 packtrace_last_error());
}

// Handles owned by unique_ptr: released however the scope ends.
struct ReleaseTree {
    void operator()(PacktraceTree *t) const { packtrace_tree_release(t); }
};
struct ReleaseScene {
    void operator()(PacktraceScene *s) const { packtrace_scene_release(s); }
};
struct ReleaseObj {
    void operator()(PacktraceObj *o) const { packtrace_obj_release(o); }
};
using Tree = std::unique_ptr<PacktraceTree, ReleaseTree>;
using Scene = std::unique_ptr<PacktraceScene, ReleaseScene>;
using Obj = std::unique_ptr<PacktraceObj, ReleaseObj>;

struct V3 {
    float x, y, z;
};
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator*(V3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
V3 normalize(V3 a) { return a * (1.0f / std::sqrt(dot(a, a))); }

unsigned bits(float f) {
    unsigned u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

void dump_ray(FILE *out, const PacktraceRay &r) {
    std::fprintf(out, "%08x %08x %08x %08x %08x %08x %08x %08x %u", bits(r.org_x), bits(r.org_y),
                 bits(r.org_z), bits(r.dir_x), bits(r.dir_y), bits(r.dir_z), bits(r.tnear),
                 bits(r.tfar), r.mask);
}

bool same(const PacktraceRayHit &a, const PacktraceRayHit &b) {
    return bits(a.ray.tfar) == bits(b.ray.tfar) && a.hit.prim_id == b.hit.prim_id &&
           a.hit.geom_id == b.hit.geom_id && a.hit.inst_id == b.hit.inst_id &&
           bits(a.hit.u) == bits(b.hit.u) && bits(a.hit.v) == bits(b.hit.v) &&
           bits(a.hit.ng_x) == bits(b.hit.ng_x) && bits(a.hit.ng_y) == bits(b.hit.ng_y) &&
           bits(a.hit.ng_z) == bits(b.hit.ng_z);
}

// Three rays' masks: every instance, the first two, the third only.
const uint32_t MASKS[3] = {0xffffffffu, 0x3u, 0x4u};

int run(int argc, char **argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s SCENE.obj OUT.hits [WIDTH HEIGHT]\n", argv[0]);
        return 2;
    }
    const int width = argc > 4 ? std::atoi(argv[3]) : 64, height = argc > 4 ? std::atoi(argv[4]) : 48;
    if (width <= 0 || height <= 0 || width % 4 || height % 2) {
        std::fprintf(stderr, "WIDTH must be a multiple of 4 and HEIGHT of 2\n");
        return 2;
    }

    PacktraceObj *o = nullptr;
    check(packtrace_obj_load(argv[1], &o), "load");
    Obj obj(o);
    const float *positions;
    const uint32_t *indices;
    size_t vertex_count, triangle_count;
    check(packtrace_obj_mesh(obj.get(), &positions, &vertex_count, &indices, &triangle_count), "mesh");
    PacktraceTree *t = nullptr;
    check(packtrace_tree_new(positions, vertex_count, 3 * sizeof(float), indices, triangle_count,
                             3 * sizeof(uint32_t), nullptr, &t),
          "build");
    Tree tree(t);
    float lo[3], hi[3];
    check(packtrace_tree_info(tree.get(), nullptr, lo, hi), "info");
    const V3 lower{lo[0], lo[1], lo[2]}, upper{hi[0], hi[1], hi[2]};
    const V3 centre = (lower + upper) * 0.5f;
    const float diag = std::sqrt(dot(upper - lower, upper - lower));

    // The scene: three instances of the one geometry.
    PacktraceScene *s = nullptr;
    check(packtrace_scene_new(&s), "scene");
    Scene scene(s);
    uint32_t geom;
    check(packtrace_scene_add_geometry(scene.get(), tree.get(), &geom), "geometry");
    tree.reset();  // the scene keeps the tree alive
    const float c = std::cos(0.6f), sn = std::sin(0.6f), d = 0.7f * diag;
    const float transforms[3][12] = {
        {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0},                       // identity
        {c, 0, sn, d, 0, 1, 0, 0.1f * d, -sn, 0, c, -0.5f * d},     // rotated about y, moved
        {-0.6f, 0, 0, -d, 0, 0.6f, 0, 0, 0, 0, 0.6f, 0.3f * d},     // mirrored in x, scaled
    };
    const uint32_t instance_masks[3] = {0x1u, 0x2u, 0x4u};
    FILE *out = std::fopen(argv[2], "w");
    if (!out) {
        std::perror(argv[2]);
        return 1;
    }
    for (int i = 0; i < 3; i++) {
        uint32_t id;
        check(packtrace_scene_add_instance(scene.get(), geom, transforms[i], instance_masks[i], &id),
              "instance");
        std::fprintf(out, "I %u", geom);
        for (float m : transforms[i]) std::fprintf(out, " %08x", bits(m));
        std::fprintf(out, " %u\n", instance_masks[i]);
    }
    check(packtrace_scene_commit(scene.get()), "commit");

    // Camera: the protocol's auto camera, pulled back to see all three.
    const V3 eye = centre + normalize(V3{0.3f, 0.4f, 1.0f}) * (1.6f * diag);
    const V3 f = normalize(centre - eye), r = normalize(cross(f, V3{0, 1, 0})), u = cross(r, f);
    const float h = std::tan(50.0f * 3.14159265f / 360.0f), aspect = float(width) / float(height);
    const size_t n = size_t(width) * height;
    std::vector<PacktraceRayHit> pixels(n), stream(n);
    const int valid8[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
    for (int by = 0; by < height; by += 2) {
        for (int bx = 0; bx < width; bx += 4) {
            PacktraceRayHit8 packet{};
            for (int lane = 0; lane < 8; lane++) {
                const int x = bx + lane % 4, y = by + lane / 4;
                const float sx = (2.0f * (x + 0.5f) / width - 1.0f) * h * aspect;
                const float sy = (1.0f - 2.0f * (y + 0.5f) / height) * h;
                const V3 dir = normalize(f + r * sx + u * sy);
                PacktraceRayHit &p = pixels[size_t(y) * width + x];
                p = PacktraceRayHit{};
                p.ray = PacktraceRay{eye.x, eye.y, eye.z, 0.0f, dir.x, dir.y, dir.z, 0.0f, INFINITY,
                                     MASKS[(x + y) % 3], 0, 0};
                stream[size_t(y) * width + x] = p;
                packet.ray.org_x[lane] = eye.x, packet.ray.org_y[lane] = eye.y;
                packet.ray.org_z[lane] = eye.z, packet.ray.tnear[lane] = 0.0f;
                packet.ray.dir_x[lane] = dir.x, packet.ray.dir_y[lane] = dir.y;
                packet.ray.dir_z[lane] = dir.z, packet.ray.tfar[lane] = INFINITY;
                packet.ray.mask[lane] = p.ray.mask;
            }
            check(packtrace_scene_intersect8(valid8, scene.get(), &packet), "intersect8");
            for (int lane = 0; lane < 8; lane++) {
                const int x = bx + lane % 4, y = by + lane / 4;
                PacktraceRayHit &p = pixels[size_t(y) * width + x];
                PacktraceRayHit single = p;
                check(packtrace_scene_intersect1(scene.get(), &single), "intersect1");
                // The lane as one struct: a miss leaves u, v and Ng as given (zero).
                p.ray.tfar = packet.ray.tfar[lane];
                p.hit = PacktraceHit{packet.hit.ng_x[lane], packet.hit.ng_y[lane], packet.hit.ng_z[lane],
                                     packet.hit.u[lane],    packet.hit.v[lane],    packet.hit.prim_id[lane],
                                     packet.hit.geom_id[lane], packet.hit.inst_id[lane]};
                if (!same(p, single)) throw std::runtime_error("packet and single ray differ");
            }
        }
    }
    check(packtrace_scene_intersect_stream(scene.get(), stream.data(), n, sizeof(PacktraceRayHit)),
          "stream");
    for (size_t i = 0; i < n; i++)
        if (!same(pixels[i], stream[i])) throw std::runtime_error("packet and stream differ");

    size_t hits = 0;
    for (size_t i = 0; i < n; i++) {
        PacktraceRay in = pixels[i].ray;
        in.tfar = INFINITY;  // the ray as traced
        std::fprintf(out, "Q ");
        dump_ray(out, in);
        const PacktraceHit &hit = pixels[i].hit;
        if (hit.prim_id == PACKTRACE_INVALID_ID) {
            std::fprintf(out, " miss\n");
            continue;
        }
        hits++;
        std::fprintf(out, " hit %08x %u %08x %08x %08x %08x %08x %u %u\n", bits(pixels[i].ray.tfar),
                     hit.prim_id, bits(hit.u), bits(hit.v), bits(hit.ng_x), bits(hit.ng_y),
                     bits(hit.ng_z), hit.geom_id, hit.inst_id);
    }

    // Shadow rays towards a light above, from the world hit points
    // (org + t dir, moved off the surface along the world normal), as
    // 4-wide packets, checked against the single-ray occlusion.
    const V3 light = centre + V3{0.25f, 0.8f, 0.35f} * (2.0f * diag);
    std::vector<PacktraceRay> shadow;
    for (size_t i = 0; i < n; i++) {
        const PacktraceRayHit &p = pixels[i];
        if (p.hit.prim_id == PACKTRACE_INVALID_ID) continue;
        const V3 d{p.ray.dir_x, p.ray.dir_y, p.ray.dir_z};
        const V3 at = V3{p.ray.org_x, p.ray.org_y, p.ray.org_z} + d * p.ray.tfar;
        V3 ng{p.hit.ng_x, p.hit.ng_y, p.hit.ng_z};
        const V3 to_light = light - at;
        if (dot(ng, to_light) < 0) ng = ng * -1.0f;
        const float point[3] = {at.x, at.y, at.z}, normal[3] = {ng.x, ng.y, ng.z};
        float start[3];
        check(packtrace_offset_origin(point, normal, start), "offset");
        const V3 dir = light - V3{start[0], start[1], start[2]};
        shadow.push_back(PacktraceRay{start[0], start[1], start[2], 0.0f, dir.x, dir.y, dir.z, 0.0f,
                                      0.9999f, MASKS[i % 3], 0, 0});
    }
    size_t occluded = 0;
    for (size_t i = 0; i < shadow.size(); i += 4) {
        PacktraceRay4 packet{};
        int valid4[4] = {0, 0, 0, 0};
        for (size_t lane = 0; lane < 4 && i + lane < shadow.size(); lane++) {
            const PacktraceRay &s4 = shadow[i + lane];
            valid4[lane] = -1;
            packet.org_x[lane] = s4.org_x, packet.org_y[lane] = s4.org_y, packet.org_z[lane] = s4.org_z;
            packet.dir_x[lane] = s4.dir_x, packet.dir_y[lane] = s4.dir_y, packet.dir_z[lane] = s4.dir_z;
            packet.tnear[lane] = s4.tnear, packet.tfar[lane] = s4.tfar, packet.mask[lane] = s4.mask;
        }
        check(packtrace_scene_occluded4(valid4, scene.get(), &packet), "occluded4");
        for (size_t lane = 0; lane < 4 && i + lane < shadow.size(); lane++) {
            PacktraceRay single = shadow[i + lane];
            check(packtrace_scene_occluded1(scene.get(), &single), "occluded1");
            const bool occ = packet.tfar[lane] == -INFINITY;
            if (occ != (single.tfar == -INFINITY))
                throw std::runtime_error("packet and single shadow ray differ");
            occluded += occ;
            std::fprintf(out, "O ");
            dump_ray(out, shadow[i + lane]);
            std::fprintf(out, " %d\n", occ ? 1 : 0);
        }
    }
    std::fclose(out);
    std::printf("%d x %d pixels through 3 instances: %zu hits, %zu shadowed; packet == single ray == "
                "stream on every pixel\n",
                width, height, hits, occluded);
    return 0;
}

}  // namespace

int main(int argc, char **argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "scene: %s\n", e.what());
        return 1;
    }
}

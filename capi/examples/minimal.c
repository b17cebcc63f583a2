/* minimal.c: one quad, one 8-wide packet, the hits printed (docs/c-api.md). */
#include <math.h>
#include <stdio.h>
#include "packtrace.h"

int main(void) {
    const float vertices[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}; /* x y z per vertex */
    const uint32_t indices[] = {0, 1, 2, 0, 2, 3};                  /* two triangles */
    PacktraceTree *tree = NULL;
    if (packtrace_tree_new(vertices, 4, 3 * sizeof(float), indices, 2, 3 * sizeof(uint32_t),
                           NULL /* default build */, &tree) != PACKTRACE_STATUS_OK) {
        fprintf(stderr, "build: %s\n", packtrace_last_error());
        return 1;
    }
    PacktraceRayHit8 rh = {0}; /* 32-byte aligned by its type */
    const int valid[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
    for (int i = 0; i < 8; i++) { /* rays straight down, x from 0.1 to 1.5 */
        rh.ray.org_x[i] = 0.1f + 0.2f * i, rh.ray.org_y[i] = 0.5f, rh.ray.org_z[i] = 1.0f;
        rh.ray.dir_z[i] = -1.0f, rh.ray.tnear[i] = 0.0f, rh.ray.tfar[i] = INFINITY;
    }
    if (packtrace_intersect8(valid, tree, &rh) != PACKTRACE_STATUS_OK) {
        fprintf(stderr, "trace: %s\n", packtrace_last_error());
        return 1;
    }
    for (int i = 0; i < 8; i++)
        if (rh.hit.prim_id[i] != PACKTRACE_INVALID_ID)
            printf("ray %d: t = %g, triangle %u, u = %g, v = %g\n", i, rh.ray.tfar[i],
                   rh.hit.prim_id[i], rh.hit.u[i], rh.hit.v[i]);
        else printf("ray %d: miss\n", i);
    packtrace_tree_release(tree);
    return 0;
}

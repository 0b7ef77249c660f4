/*
 * kdbeam from C: a ground mesh and a row of instanced triangles, traced by single rays and a
 * stream; bad input answered with error codes. Built and run by .ci/run:
 *
 *   cargo build --release -p kdbeam-capi
 *   cc -std=c99 -Wall -Wextra -Werror -Icapi/include examples/c/trace.c \
 *      target/release/libkdbeam_capi.a -lpthread -ldl -lm -o target/trace-c
 *   target/trace-c
 *
 * Exits 0 when every check holds, 1 (saying which) otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "kdbeam.h"

static int failures = 0;

static void check(int ok, const char *what) {
    if (!ok) {
        fprintf(stderr, "FAILED: %s (last error: \"%s\")\n", what, kdbeam_last_error());
        failures++;
    }
}

/* A ray straight down (-y) from height 10 at (x, z). */
static KdbeamRay down(float x, float z) {
    KdbeamRay r = {x, 10.0f, z, 0.0f, 0.0f, -1.0f, 0.0f, INFINITY};
    return r;
}

int main(void) {
    KdbeamScene *scene = kdbeam_scene_new();
    check(scene != NULL, "kdbeam_scene_new");

    /* Ground: a 20 x 20 quad at y = 0, traced as it is. */
    const float ground[] = {-10, 0, -10, 10, 0, -10, 10, 0, 10, -10, 0, 10};
    const uint32_t quad[] = {0, 2, 1, 0, 3, 2};
    uint32_t ground_id = kdbeam_scene_add_mesh(scene, ground, 4, quad, 2);
    check(ground_id == 0, "the first geometry id is 0");

    /* A unit triangle in the xz plane, instanced at heights 1, 2, 3 along x. */
    const float tri[] = {0, 0, 0, 1, 0, 0, 0, 0, 1};
    const uint32_t one[] = {0, 1, 2};
    uint32_t proto = kdbeam_scene_add_prototype(scene, tri, 3, one, 1);
    check(proto == 1, "the second geometry id is 1");
    uint32_t inst[3];
    for (int i = 0; i < 3; i++) {
        /* Column-major 3x4: the x, y and z axes, then the translation. */
        float m[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, (float)(2 * i), (float)(i + 1), 0};
        inst[i] = kdbeam_scene_add_instance(scene, proto, m, 0xFFFFFFFFu);
        check(inst[i] == (uint32_t)i, "instance ids count from 0");
    }

    /* A new scene sizes each mesh's tree by its own triangles. This example traces rays one
       by one, so it sets trees for single incoherent rays on every mesh instead; a value out of
       its range is refused and leaves the scene as it was. */
    KdbeamBuildParams params;
    check(kdbeam_scene_get_build_params(scene, &params) == KDBEAM_BUILD_PARAMS_PER_MESH,
          "each mesh its own tree");
    check(kdbeam_scene_get_geometry_build_params(scene, ground_id, &params) == 0,
          "the ground's own build params");
    printf("the ground's own tree: ci_over_ct %g\n", params.ci_over_ct);
    check(kdbeam_build_params_for_incoherent_rays(scene, &params) == 0, "incoherent-ray params");
    check(kdbeam_scene_set_build_params(scene, &params) == 0, "set_build_params");
    KdbeamBuildParams refused = params;
    refused.ci_over_ct = -1.0f;
    check(kdbeam_scene_set_build_params(scene, &refused) == KDBEAM_ERROR_INVALID_ARGUMENT,
          "a negative ci_over_ct is refused");
    printf("negative ci_over_ct: %s\n", kdbeam_last_error());

    /* Tracing before the first commit: a miss, with the error set. */
    KdbeamRay r = down(0.25f, 0.25f);
    KdbeamHit hit;
    kdbeam_intersect1(scene, &r, &hit);
    check(hit.geometry == KDBEAM_INVALID_ID && strlen(kdbeam_last_error()) > 0,
          "an uncommitted scene misses and says why");

    check(kdbeam_scene_commit(scene) == 0, "commit");
    kdbeam_intersect1(scene, &r, &hit);
    check(hit.t == 9.0f && hit.geometry == proto && hit.instance == inst[0] && hit.triangle == 0,
          "the ray from above hits instance 0 at t = 9");
    check(strcmp(kdbeam_last_error(), "") == 0, "no error after a success");

    r = down(-5.0f, -5.0f);
    kdbeam_intersect1(scene, &r, &hit);
    check(hit.t == 10.0f && hit.geometry == ground_id && hit.instance == KDBEAM_INVALID_ID,
          "the ground is hit as it is, with no instance");
    check(kdbeam_occluded1(scene, &r), "occluded by the ground");

    /* Move instance 2 down below the ground: the ray through it now stops at the ground. */
    float low[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 4, -1, 0};
    check(kdbeam_scene_set_transform(scene, inst[2], low) == 0, "set_transform");
    check(kdbeam_scene_commit(scene) == 0, "commit after the move");

    /* A stream of rays, one per instance column and one NaN ray. */
    KdbeamRay rays[4] = {down(0.25f, 0.25f), down(2.25f, 0.25f), down(4.25f, 0.25f),
                         down(NAN, 0.0f)};
    KdbeamHit hits[4];
    check(kdbeam_intersect_stream(scene, rays, hits, 4) == 0, "kdbeam_intersect_stream");
    check(hits[0].instance == inst[0] && hits[0].t == 9.0f, "stream ray 0 hits instance 0");
    check(hits[1].instance == inst[1] && hits[1].t == 8.0f, "stream ray 1 hits instance 1");
    check(hits[2].geometry == ground_id && hits[2].t == 10.0f, "stream ray 2 hits the ground");
    check(hits[3].geometry == KDBEAM_INVALID_ID && isinf(hits[3].t), "a NaN ray misses");
    for (int i = 0; i < 3; i++) {
        printf("ray %d: t = %g, geometry %u, instance %d, triangle %u\n", i, hits[i].t,
               hits[i].geometry, hits[i].instance == KDBEAM_INVALID_ID ? -1 : (int)hits[i].instance,
               hits[i].triangle);
    }

    /* Bad input: error codes and messages, never a crash. */
    check(kdbeam_scene_add_mesh(scene, NULL, 3, one, 1) == KDBEAM_INVALID_ID, "NULL positions");
    printf("NULL positions: %s\n", kdbeam_last_error());
    const uint32_t bad[] = {0, 1, 9};
    check(kdbeam_scene_add_mesh(scene, tri, 3, bad, 1) == KDBEAM_INVALID_ID, "index out of range");
    printf("index out of range: %s\n", kdbeam_last_error());
    check(kdbeam_scene_commit(NULL) == KDBEAM_ERROR_NULL_POINTER, "NULL scene");
    check(kdbeam_scene_remove_instance(scene, inst[1]) == 0, "remove_instance");
    check(kdbeam_scene_remove_instance(scene, inst[1]) == KDBEAM_ERROR_UNKNOWN_ID, "stale id");
    printf("stale id: %s\n", kdbeam_last_error());
    uint32_t again = kdbeam_scene_add_instance(scene, proto, low, 1);
    check(again == 3, "ids are never reused");

    kdbeam_scene_free(scene);
    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("every check of the C example holds\n");
    return 0;
}

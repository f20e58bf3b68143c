/* Shared by the scene fuzz targets (a header: scripts/fuzz.sh builds every
 * tests/fuzz/<name>.c as a target). The invariants every loaded scene must keep,
 * whatever the input: no consumer may ever read a NaN, an out-of-range
 * index or an unusable camera. */
#ifndef SPHERECULL_FUZZ_SCENE_CHECK_H
#define SPHERECULL_FUZZ_SCENE_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "spherecull/sc_scene.h"

static void fz_require_at(int ok, const char *what, int line)
{
    if (!ok) {
        fprintf(stderr, "fuzz: requirement '%s' at line %d failed\n", what, line);
        abort();
    }
}
#define fz_require(ok) fz_require_at((ok), #ok, __LINE__)

/* A warning is one non-empty printable line. */
static int fz_printable(const char *s)
{
    for (const unsigned char *p = (const unsigned char *)s; *p; p++)
        if (*p < 0x20 || *p == 0x7f)
            return 0;
    return 1;
}

static void fz_on_warn(void *ctx, const char *msg)
{
    fz_require(msg && msg[0] && fz_printable(msg));
    (*(size_t *)ctx)++;
}

/* An error is one non-empty printable line that fits the buffer. */
static void fz_check_error(const char *err, size_t errlen)
{
    fz_require(strlen(err) > 0 && strlen(err) < errlen);
    fz_require(fz_printable(err));
}

static void fz_check_scene(const sc_scene *s, uint64_t max_triangles)
{
    sc_scene_view v;
    sc_scene_stats st;
    fz_require(sc_scene_get_view(s, &v) == SC_OK);
    fz_require(sc_scene_get_stats(s, &st) == SC_OK);
    fz_require(v.mesh.triangle_count <= max_triangles);
    fz_require(st.triangles == v.mesh.triangle_count && st.vertices == v.mesh.vertex_count);
    fz_require(st.degenerate_triangles <= st.triangles);
    for (size_t i = 0; i < 3 * v.mesh.vertex_count; i++)
        fz_require(isfinite(v.mesh.positions[i]));
    for (size_t i = 0; i < 3 * v.mesh.triangle_count; i++)
        fz_require(v.mesh.indices[i] < v.mesh.vertex_count);
    for (size_t i = 0; i < v.mesh.triangle_count; i++)
        fz_require(v.mesh_ids[i] < v.num_meshes);
    for (size_t i = 0; i < 3 * v.num_meshes; i++)
        fz_require(v.mesh_colors[i] >= 0 && v.mesh_colors[i] <= 1);
    for (size_t i = 0; i < v.num_lights; i++) {
        const sc_light *l = &v.lights[i];
        fz_require(l->type == SC_LIGHT_DIRECTIONAL || l->type == SC_LIGHT_POINT);
        for (int k = 0; k < 3; k++)
            fz_require(isfinite(l->vec[k]) && isfinite(l->color[k]) && l->color[k] >= 0);
    }
    for (int k = 0; k < 3; k++)
        fz_require(v.background[k] >= 0 && v.background[k] <= 1);
    fz_require(v.ambient >= 0 && v.ambient <= 1);
    sc_camera_frame f;
    fz_require(sc_camera_frame_make(&v.camera, &f) == SC_OK);
    fz_require(v.camera.width >= 1 && v.camera.height >= 1 &&
               v.camera.width <= SC_SCENE_MAX_IMAGE_SIDE && v.camera.height <= SC_SCENE_MAX_IMAGE_SIDE);
    for (int k = 0; k < 3; k++)
        fz_require(isfinite(st.bounds_min[k]) && isfinite(st.bounds_max[k]) &&
                   st.bounds_min[k] <= st.bounds_max[k]);
}

#endif

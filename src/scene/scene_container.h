/* Private to src/scene: the scene container every loader fills, and the
 * helpers the loaders share. Loaders depend on this header only; the spec
 * dispatcher (scene_load.c) is the one file that knows every loader. */
#ifndef SPHERECULL_SCENE_CONTAINER_H
#define SPHERECULL_SCENE_CONTAINER_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_scene.h"

struct sc_scene {
    float *positions;
    uint32_t *indices;
    uint32_t *mesh_ids;
    float *mesh_colors;
    float *mesh_emission;           /* 3 per mesh, like mesh_colors */
    sc_light *lights;
    size_t num_vertices, num_triangles, num_meshes, num_lights;
    size_t cap_vertices, cap_triangles, cap_mesh_ids, cap_meshes, cap_emission, cap_lights;
    sc_camera camera;
    float background[3];
    float ambient;
    sc_mesh_view *objects;          /* instanced meshes; each owns one block (positions, then indices) */
    sc_scene_instance *instances;
    size_t num_objects, num_instances, cap_objects, cap_instances;

    /* Policy and bookkeeping copied from the options. */
    uint64_t max_triangles, max_pixels;
    uint64_t seed;
    char *cache_dir;                /* NULL: resolved on demand */
    sc_scene_warn_fn warn;
    void *warn_ctx;
    size_t warnings, degenerate, dropped_nonfinite, skipped_primitives;
    int depth;                      /* nesting of proc:grid loads */
    uint32_t import_timeout_ms;     /* resolved: never 0 */
    int import_in_process;
    uint64_t max_import_bytes;      /* 0: derived from the caps when importing */
};

#define SC_DEFAULT_GREY 0.75f

/* Appends the geometry a spec names (mesh file, "cache:NAME", "proc:...")
 * with a transform (row-major 4x4, NULL = identity) and an optional colour
 * override; relative paths resolve against base_dir (NULL: as given). The
 * JSON loader and proc:grid receive it from the dispatcher, so that no
 * loader depends on another through it. */
typedef sc_status (*sc_scene_append_fn)(sc_scene *s, const char *spec, const char *base_dir,
                                        const double xform[16], const float *color, char *err,
                                        size_t errlen);

/* An empty scene with the policy (caps, seed, warnings, import settings) of
 * parent, one nesting level deeper; the caller frees it. */
sc_status sc_scene_create_nested(const sc_scene *parent, sc_scene **out);

/* One formatted warning: counted always, forwarded up to the limit. */
void sc_scene_warnf(sc_scene *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Formats err (if any room) and returns status, for one-line error exits. */
sc_status sc_scene_errf(char *err, size_t errlen, sc_status st, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Reserves room for more triangles and vertices, checking the caps first.
 * On SC_ERR_LIMIT / SC_ERR_OUT_OF_MEMORY err is filled and nothing changes. */
sc_status sc_scene_reserve(sc_scene *s, size_t more_vertices, size_t more_triangles,
                           char *err, size_t errlen);

/* Adds a mesh colour entry; returns its id through *id. */
sc_status sc_scene_new_mesh(sc_scene *s, const float color[3], uint32_t *id);

/* Appends triangles of an existing mesh id (the body of sc_scene_add_mesh). */
sc_status sc_scene_append_triangles(sc_scene *s, const float *positions, size_t num_vertices,
                                   const uint32_t *indices, size_t num_triangles, uint32_t mesh,
                                   char *err, size_t errlen);

/* Adds sub's geometry as one object placed by each of the count transforms
 * (row-major 3x4, object to world): the object kept in object space for
 * sc_accel, and each instance's triangles appended to s (the transform
 * applied in double, rounded once), with meshes of sub's colours (or
 * color) and emission. what names the source in error messages. */
sc_status sc_scene_add_instances(sc_scene *s, const sc_scene *sub, const float (*xfm)[12], size_t count,
                                 const float *color, const float *emission, const char *what, char *err,
                                 size_t errlen);

/* Bounds of all vertices referenced by triangles (or a unit box when empty). */
void sc_scene_bounds(const sc_scene *s, double lo[3], double hi[3]);

#endif

/* Private to src/scene: the scene container and the helpers the loaders share. */
#ifndef SPHERECULL_SCENE_INTERNAL_H
#define SPHERECULL_SCENE_INTERNAL_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_scene.h"

struct sc_scene {
    float *positions;
    uint32_t *indices;
    uint32_t *mesh_ids;
    float *mesh_colors;
    sc_light *lights;
    size_t num_vertices, num_triangles, num_meshes, num_lights;
    size_t cap_vertices, cap_triangles, cap_mesh_ids, cap_meshes, cap_lights;
    sc_camera camera;
    float background[3];
    float ambient;

    /* Policy and bookkeeping copied from the options. */
    uint64_t max_triangles, max_pixels;
    uint64_t seed;
    char *cache_dir;                /* NULL: resolved on demand */
    sc_scene_warn_fn warn;
    void *warn_ctx;
    size_t warnings, degenerate, dropped_nonfinite, skipped_primitives;
    int depth;                      /* nesting of proc:grid / json loads */
    uint32_t import_timeout_ms;     /* resolved: never 0 */
    int import_in_process;
    uint64_t max_import_bytes;      /* 0: derived from the caps when importing */
};

#define SC_DEFAULT_GREY 0.75f

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

/* Bounds of all vertices referenced by triangles (or a unit box when empty). */
void sc_scene_bounds(const sc_scene *s, size_t first_triangle, double lo[3], double hi[3]);

/* Loaders: each appends to s. base_dir resolves relative paths in JSON. */
sc_status sc_scene_load_assimp(sc_scene *s, const char *path, const double xform[16],
                               const float *color, char *err, size_t errlen);
sc_status sc_scene_load_json(sc_scene *s, const char *path, char *err, size_t errlen);
/* The body of sc_scene_load_json on text already in memory (NUL at text[len]). */
sc_status sc_scene_load_json_buffer(sc_scene *s, const char *path, const char *base_dir,
                                    const char *text, size_t len, char *err, size_t errlen);

/* The two halves of sc_scene_load_assimp (which picks one by the options):
 * the import itself, in this process (take_lock: serialise against other
 * threads; a forked child, single-threaded, must not wait on a lock some
 * parent thread held at fork time), and the same import in a child process
 * with a time limit (import_isolated.c). */
sc_status sc_scene_import_assimp(sc_scene *s, const char *path, const double xform[16],
                                 const float *color, int take_lock, char *err, size_t errlen);
sc_status sc_scene_import_isolated(sc_scene *s, const char *path, const double xform[16],
                                   const float *color, char *err, size_t errlen);
/* Cheap checks before any import: missing, directory, empty, PLY headers
 * that hang assimp. */
sc_status sc_scene_check_mesh_file(const char *path, char *err, size_t errlen);
sc_status sc_scene_load_procedural(sc_scene *s, const char *spec, const double xform[16],
                                   const float *color, char *err, size_t errlen);

/* Appends the geometry of spec (mesh file, cache:, proc:) with a transform
 * (row-major 4x4, NULL = identity) and an optional colour override. JSON
 * scenes are not accepted here. */
sc_status sc_scene_append_spec(sc_scene *s, const char *spec, const double xform[16],
                               const float *color, char *err, size_t errlen);

/* Expands "cache:NAME" and "${SPHERECULL_MESHES}" into a malloc'd path. */
sc_status sc_scene_expand_path(sc_scene *s, const char *spec, const char *base_dir,
                               char **out, char *err, size_t errlen);

/* Parses a size "123", "20k", "1M"; 0 on failure. */
int sc_scene_parse_count(const char *text, uint64_t *out);

#endif

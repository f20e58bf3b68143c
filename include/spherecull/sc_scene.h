/* spherecull — scenes: only what a ray tracer needs.
 *
 * A scene is one flat triangle soup (float positions, uint32 indices, one
 * mesh id per triangle), one RGB colour and one emitted radiance per mesh, a
 * pinhole camera, lights and a background. Node transforms are flattened at load time; textures,
 * normals, animation and bones are not kept.
 *
 * Sources (sc_scene_load's spec):
 *   - a mesh file in any format assimp reads (OBJ, OFF, PLY, STL, glTF, 3DS,
 *     ...): the camera frames the model and a default light is added;
 *   - a scene description "*.json" (see scenes/README.md for the format);
 *   - "proc:KIND:N" procedural scenes of about N triangles (N may end in k or
 *     M): sphere, soup, slivers, terrain, and "proc:grid:MESH:N", a grid of
 *     copies of MESH (any other spec) with at least N triangles;
 *   - "cache:NAME", a mesh in the mesh cache (scripts/fetch-meshes.sh fills it
 *     from Debian's libcgal-demo): $SPHERECULL_MESHES, else
 *     ${XDG_CACHE_HOME:-$HOME/.cache}/spherecull/meshes.
 *
 * Bad input policy (every case returns a status and a one-line message):
 *   - unreadable, empty, truncated or malformed files, unknown formats, scenes
 *     without triangles: SC_ERR_IO or SC_ERR_PARSE;
 *   - more triangles than options->max_triangles (vertices: 3x that), or more
 *     pixels than options->max_pixels: SC_ERR_LIMIT, before the big allocation;
 *   - a triangle with a NaN or infinite vertex is dropped and counted, with a
 *     warning: one bad vertex should not make a whole model unusable, and a
 *     dropped triangle cannot feed NaN to the BVH or the prefilter. The bad
 *     vertex itself is stored as (0,0,0) so no consumer ever reads a NaN;
 *   - degenerate (zero-area) and duplicate triangles are kept and counted:
 *     they are legal geometry a tracer must survive;
 *   - out-of-range indices are an error (SC_ERR_INVALID_ARGUMENT for raw
 *     buffers, SC_ERR_PARSE in files);
 *   - a missing material gives the default colour and a warning;
 *   - a mesh file that crashes assimp (SIGSEGV, an uncatchable exception)
 *     is SC_ERR_PARSE; one that needs more than the import time limit or
 *     memory cap is SC_ERR_LIMIT: the import runs in a child process (see
 *     sc_scene_options), so neither takes the caller down.
 *
 * Warnings go to options->warn (the library never prints); at most
 * SC_SCENE_MAX_WARNINGS are forwarded per load, then one summary line.
 *
 * Threads: sc_scene_load, sc_scene_load_json_text, sc_scene_create and
 * sc_scene_free are reentrant: distinct scenes may be loaded in several
 * threads at once (assimp imports in this process are serialised by a lock
 * inside). One scene may be read by many threads at once (sc_scene_get_view,
 * sc_scene_get_stats and the arrays of a view); a call that changes it
 * (sc_scene_add_*, sc_scene_set_*, sc_scene_frame_camera) must not overlap
 * any other call on the same scene.
 */
#ifndef SPHERECULL_SC_SCENE_H
#define SPHERECULL_SC_SCENE_H

#include "sc_api.h"
#include <stddef.h>
#include <stdint.h>

#include "sc_camera.h"
#include "sc_mesh.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SC_SCENE_DEFAULT_MAX_TRIANGLES 50000000ull
#define SC_SCENE_DEFAULT_MAX_PIXELS (1ull << 26)   /* 8192 x 8192 */
#define SC_SCENE_MAX_IMAGE_SIDE 32768
#define SC_SCENE_DEFAULT_WIDTH 800
#define SC_SCENE_DEFAULT_HEIGHT 600
#define SC_SCENE_MAX_WARNINGS 16
#define SC_SCENE_DEFAULT_IMPORT_TIMEOUT_MS 120000u
#define SC_SCENE_MAX_EMISSION 1e6f   /* per RGB component */

typedef struct sc_scene sc_scene;   /* opaque */

typedef enum sc_light_type {
    SC_LIGHT_DIRECTIONAL = 0,   /* vec = direction the light travels (unit) */
    SC_LIGHT_POINT = 1          /* vec = position; falls off as 1/d^2 */
} sc_light_type;

typedef struct sc_light {
    sc_light_type type;
    float vec[3];
    float color[3];             /* linear RGB, already scaled by intensity */
} sc_light;

typedef void (*sc_scene_warn_fn)(void *ctx, const char *message);

typedef struct sc_scene_options {
    uint64_t max_triangles;     /* 0: SC_SCENE_DEFAULT_MAX_TRIANGLES */
    uint64_t max_pixels;        /* 0: SC_SCENE_DEFAULT_MAX_PIXELS */
    const char *mesh_cache_dir; /* NULL: $SPHERECULL_MESHES or the XDG default */
    uint64_t seed;              /* procedural scenes */
    sc_scene_warn_fn warn;      /* NULL: warnings are only counted */
    void *warn_ctx;
    /* Mesh files are imported by assimp in a child process by default: a
     * damaged file can crash assimp (SIGSEGV, an exception thrown where it
     * cannot be caught) or make it loop forever, and neither may take the
     * caller down. The child streams the triangles back through a pipe; a
     * crash or an import slower than the time limit becomes one error line
     * (SC_ERR_PARSE for a crash, SC_ERR_LIMIT for the time limit).
     * import_timeout_ms 0: $SPHERECULL_IMPORT_TIMEOUT (seconds) if set, else
     * SC_SCENE_DEFAULT_IMPORT_TIMEOUT_MS. import_in_process 1 (or
     * $SPHERECULL_IMPORT=in-process) imports in the calling process: no
     * fork, but a hostile file can then crash or hang the caller. */
    uint32_t import_timeout_ms;
    int import_in_process;
    /* Data memory (RLIMIT_DATA: heap and private mappings, reserved rather
     * than touched) the import child may allocate beyond what it inherits,
     * so a file claiming billions of elements is refused instead of
     * exhausting the machine: SC_ERR_LIMIT. 0: $SPHERECULL_IMPORT_MEMORY
     * (MiB) if set, else 1 GiB + 2 KiB per triangle of the cap (assimp's OBJ
     * reader reserves ~1.2 KiB and touches ~0.6 KiB per triangle), at most
     * half the physical memory. Not enforced in-process. */
    uint64_t max_import_bytes;
} sc_scene_options;

/* Read-only view of a scene; valid until the scene is freed or modified. */
/* A rigid instance from a scene file's "instances" (scenes/README.md): an
 * object (a mesh loaded once, in object space) placed by a transform. The
 * scene view holds both forms: every instance's triangles in view.mesh
 * (the transform applied in double, rounded once: what the tools that take
 * one mesh see), and the objects and transforms, from which sc_accel.h
 * builds one tree per object and a top level over the instances. */
typedef struct sc_scene_instance {
    uint32_t object;            /* index into sc_scene_view.objects */
    float xfm[12];              /* object to world, row-major 3x4 (as sc_accel_attach_instance) */
    size_t first_triangle;      /* its triangles in view.mesh: [first_triangle, first_triangle +
                                   objects[object].triangle_count), in the object's order */
} sc_scene_instance;

typedef struct sc_scene_view {
    sc_mesh_view mesh;          /* every triangle of the scene, packed (strides 0) */
    const uint32_t *mesh_ids;   /* 1 per triangle, each < num_meshes */
    const float *mesh_colors;   /* 3 per mesh, linear RGB in [0, 1] */
    const sc_light *lights;
    size_t num_meshes, num_lights;
    sc_camera camera;           /* always valid for sc_camera_frame_make */
    float background[3];
    float ambient;              /* constant ambient term in [0, 1] */
    /* 3 per mesh: linear radiance the front side of the mesh's triangles
     * emits (the side (V1 - V0) x (V2 - V0) points to; 0: none), for the
     * path tracer; from a scene file's "emission" or a mesh file's emissive
     * material colour. */
    const float *mesh_emission;
    const sc_mesh_view *objects;             /* the instanced meshes, object space, packed */
    const sc_scene_instance *instances;      /* in file order */
    size_t num_objects, num_instances;
} sc_scene_view;

typedef struct sc_scene_stats {
    size_t triangles, vertices, meshes;
    size_t degenerate_triangles;    /* zero area, kept */
    size_t dropped_nonfinite;       /* triangles dropped for a NaN/Inf vertex */
    size_t skipped_primitives;      /* points and lines found in mesh files */
    size_t warnings;                /* all of them, also those not forwarded */
    size_t bytes;                   /* positions + indices + mesh ids */
    double bytes_per_triangle;
    double bounds_min[3], bounds_max[3];
} sc_scene_stats;

/* Defaults: every field zero/NULL except seed = 1. */
SC_API void sc_scene_options_init(sc_scene_options *options);

/* Loads a scene (see the top of this file for spec). options may be NULL.
 * On failure *out is NULL and err (if errlen > 0) holds one line without a
 * trailing newline. */
SC_API sc_status sc_scene_load(const char *spec, const sc_scene_options *options,
                               sc_scene **out, char *err, size_t errlen);

/* A scene description from memory: text (len bytes, need not be
 * NUL-terminated) in the "*.json" format. Relative mesh paths resolve
 * against base_dir (NULL: the current directory); name labels messages
 * (NULL: "<memory>"). Same contract as sc_scene_load. */
SC_API sc_status sc_scene_load_json_text(const char *text, size_t len, const char *name,
                                         const char *base_dir, const sc_scene_options *options,
                                         sc_scene **out, char *err, size_t errlen);

/* An empty scene for raw buffers: no triangles, default camera, no lights.
 * The options (cap, warning callback) are copied and apply to later calls. */
SC_API sc_status sc_scene_create(const sc_scene_options *options, sc_scene **out);

/* Appends one mesh; color may be NULL (default grey). Indices must be
 * < num_vertices. Triangles touching a non-finite vertex are dropped with a
 * warning. Returns SC_ERR_LIMIT, leaving the scene unchanged, when the
 * counts would exceed the cap: checked on num_vertices and num_triangles
 * before either buffer is read. */
SC_API sc_status sc_scene_add_mesh(sc_scene *scene, const float *positions, size_t num_vertices,
                                   const uint32_t *indices, size_t num_triangles,
                                   const float color[3], char *err, size_t errlen);

/* Sets the radiance mesh (an index < num_meshes, in the order meshes were
 * added) emits from its front side; components in [0, SC_SCENE_MAX_EMISSION]. */
SC_API sc_status sc_scene_set_mesh_emission(sc_scene *scene, size_t mesh, const float rgb[3]);

SC_API sc_status sc_scene_add_light(sc_scene *scene, const sc_light *light);
SC_API sc_status sc_scene_set_camera(sc_scene *scene, const sc_camera *camera);
SC_API sc_status sc_scene_set_background(sc_scene *scene, const float rgb[3]);

/* Points the camera at the scene's bounding box from the given azimuth and
 * elevation (degrees, y up), with vertical fov fov_y_deg and the given image
 * size, far enough that the whole box is in view. */
SC_API sc_status sc_scene_frame_camera(sc_scene *scene, double azimuth_deg, double elevation_deg,
                                       double fov_y_deg, int width, int height);

/* Adds a white directional key light from above-left of the current camera. */
SC_API sc_status sc_scene_add_default_light(sc_scene *scene);

SC_API sc_status sc_scene_get_view(const sc_scene *scene, sc_scene_view *view);
SC_API sc_status sc_scene_get_stats(const sc_scene *scene, sc_scene_stats *stats);

/* Where "cache:NAME" points: writes the directory into buf. */
SC_API sc_status sc_scene_mesh_cache_dir(const sc_scene_options *options, char *buf, size_t buflen);

SC_API void sc_scene_free(sc_scene *scene);

#ifdef __cplusplus
}
#endif
#endif

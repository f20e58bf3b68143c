/* Private to src/scene (and the tests): procedural meshes, so scale tests
 * and comparisons need no files.
 *
 * Scene specs (sc_scene_load and scene files), N a count with an optional
 * k (1e3) or M (1e6) suffix that the generators round up to their natural
 * resolution; random ones use the scene seed:
 *   proc:sphere:N    UV sphere of radius 1 at the origin, vertices exactly on it
 *   proc:soup:N      N random triangles in [-1,1]^3, edges ~ 2/cbrt(N)
 *   proc:slivers:N   N needles and caps (huge circumspheres) in [-1,1]^3
 *   proc:terrain:N   height field over [-1,1]^2 (x, z), y up
 *   proc:grid:MESH:N copies of MESH (any other spec) on a square grid in x, z,
 *                    at least N triangles
 * The tests also build on three fixed meshes with shared (welded) vertices:
 * an icosphere, a small height field over [0,1]^2 and a cube. */
#ifndef SPHERECULL_SCENE_PROCEDURAL_H
#define SPHERECULL_SCENE_PROCEDURAL_H

#include <stdint.h>

#include "scene_container.h"
#include "spherecull/sc_rays.h"

typedef struct sc_proc_mesh {
    float *positions;
    uint32_t *indices;
    uint32_t vertex_count, triangle_count;
} sc_proc_mesh;

/* Appends the mesh a "proc:..." spec names to s (transform and colour
 * override as sc_scene_append_fn); proc:grid loads its MESH through
 * append_mesh. */
sc_status sc_scene_load_procedural(sc_scene *s, const char *spec, const double xform[16],
                                   const float *color, sc_scene_append_fn append_mesh, char *err,
                                   size_t errlen);

/* The generators behind the specs: n >= 1 triangles (rounded up). */
sc_status sc_proc_sphere(uint64_t n, sc_proc_mesh *out);
sc_status sc_proc_soup(uint64_t n, uint64_t seed, sc_proc_mesh *out);
sc_status sc_proc_slivers(uint64_t n, uint64_t seed, sc_proc_mesh *out);
sc_status sc_proc_terrain(uint64_t n, uint64_t seed, sc_proc_mesh *out);

/* Closed unit icosphere, 20 * 4^level triangles (level 0..8). */
sc_status sc_proc_icosphere(int level, sc_proc_mesh *out);
/* Open height field over [0,1]^2 (x, z), 2 n^2 triangles (n 1..4096). */
sc_status sc_proc_heightfield(int n, sc_proc_mesh *out);
/* Closed cube [-1,1]^3, 12 triangles. */
sc_status sc_proc_cube(sc_proc_mesh *out);

void sc_proc_free(sc_proc_mesh *m);
sc_mesh_view sc_proc_view(const sc_proc_mesh *m);

#endif

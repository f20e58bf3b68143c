/* Procedural meshes for tests and for 'compare' runs without scene files:
 * "proc:sphere[:LEVEL]" (closed icosphere, 20*4^LEVEL triangles, default 5),
 * "proc:grid[:N]" (open height field, 2 N^2 triangles, default 128),
 * "proc:soup[:N]" (N random small triangles in the unit cube, default 20000),
 * "proc:cube" (closed, 12 triangles). Vertices are shared (welded). */
#ifndef SPHERECULL_COMPARE_PROCEDURAL_H
#define SPHERECULL_COMPARE_PROCEDURAL_H

#include <stdint.h>

#include "spherecull/sc_rays.h"

typedef struct sc_proc_mesh {
    float *positions;
    uint32_t *indices;
    uint32_t vertex_count, triangle_count;
} sc_proc_mesh;

sc_status sc_proc_icosphere(int level, sc_proc_mesh *out);
sc_status sc_proc_grid(int n, sc_proc_mesh *out);
sc_status sc_proc_soup(uint32_t n, uint64_t seed, sc_proc_mesh *out);
sc_status sc_proc_cube(sc_proc_mesh *out);

/* Parses a "proc:..." name; SC_ERR_INVALID_ARGUMENT if it is not one. */
sc_status sc_proc_by_name(const char *name, sc_proc_mesh *out);
int sc_proc_is_name(const char *name);

void sc_proc_free(sc_proc_mesh *m);
sc_mesh_view sc_proc_view(const sc_proc_mesh *m);

#endif

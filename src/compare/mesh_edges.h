/* Welded edge table of a mesh view, shared by sc_mesh_is_closed, the
 * adversarial ray generator and the icosphere's welding in
 * src/scene/procedural.c. Private to the library. */
#ifndef SPHERECULL_COMPARE_MESH_EDGES_H
#define SPHERECULL_COMPARE_MESH_EDGES_H

#include <stdint.h>

#include "spherecull/sc_rays.h"

typedef struct sc_edge {
    uint32_t a, b;      /* welded vertex ids, a < b */
    uint32_t tri;       /* triangle using this edge */
} sc_edge;

typedef struct sc_edge_table {
    uint32_t *canon;    /* vertex -> welded id (lowest index with the same position) */
    sc_edge *edges;     /* sorted by (a, b); degenerate triangles contribute none */
    size_t count;
} sc_edge_table;

/* mesh must be valid (sc_mesh_check, or built valid): it is not checked
 * again here. */
sc_status sc_edge_table_build(const sc_mesh_view *mesh, sc_edge_table *out);
void sc_edge_table_free(sc_edge_table *t);

/* 1 iff triangle tri has three distinct welded vertices. */
int sc_edge_table_tri_ok(const sc_edge_table *t, const sc_mesh_view *mesh, uint32_t tri);

#endif

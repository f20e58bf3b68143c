/* spherecull — a triangle mesh as every part of the library takes it.
 *
 * A view of the caller's arrays, not a copy: vertex i is three floats (x, y,
 * z) at byte offset i * vertex_stride from positions, triangle j three
 * uint32_t vertex indices at byte offset j * index_stride from indices. A
 * stride of 0 means tightly packed (12 bytes); 16 reads float4 vertices or
 * index quads, as in Embree's buffers. Strides are multiples of 4, at least
 * 12; both arrays are 4-byte aligned. The BVH build (sc_bvh.h), the Embree
 * back end (sc_embree.h), the raster reference (sc_raster.h), the ray-set
 * generators (sc_rays.h) and scenes (sc_scene.h) all take this view.
 *
 *   sc_mesh_view m = { positions, nverts, indices, ntris, 0, 0 };   // packed
 *   sc_mesh_view m4 = { &verts[0].x, nverts, &tris[0].v0, ntris, sizeof verts[0], sizeof tris[0] };
 *
 * sc_mesh_check validates a view once and returns it with its bounds as an
 * sc_checked_mesh, which the ray sets, the oracle and the Embree back end
 * trust (they do not check again).
 *
 * Threads: views are plain data; the functions here only read the arrays
 * and write their outputs, so any number of threads may use one mesh.
 */
#ifndef SPHERECULL_SC_MESH_H
#define SPHERECULL_SC_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "sc_api.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sc_mesh_view {
    const float *positions;
    size_t vertex_count;
    const uint32_t *indices;
    size_t triangle_count;
    size_t vertex_stride;        /* bytes between vertices; 0 = 12 */
    size_t index_stride;         /* bytes between triangles; 0 = 12 */
} sc_mesh_view;

/* Vertex i (x, y, z) and triangle t (three indices) of a view. */
static inline const float *sc_mesh_vertex(const sc_mesh_view *m, size_t i)
{
    size_t s = m->vertex_stride ? m->vertex_stride : 3 * sizeof(float);
    return (const float *)(const void *)((const char *)m->positions + i * s);
}
static inline const uint32_t *sc_mesh_triangle(const sc_mesh_view *m, size_t t)
{
    size_t s = m->index_stride ? m->index_stride : 3 * sizeof(uint32_t);
    return (const uint32_t *)(const void *)((const char *)m->indices + t * s);
}

/* 1 if the strides and alignments are as stated above (the arrays and the
 * counts are not looked at); every function taking a view checks this. */
SC_API int sc_mesh_layout_ok(const sc_mesh_view *m);

/* A mesh view that passed sc_mesh_check, with the bounds of the vertices its
 * triangles reference. Make it with sc_mesh_check only, and check again if
 * the arrays change. */
typedef struct sc_checked_mesh {
    sc_mesh_view view;
    float lo[3], hi[3];
} sc_checked_mesh;

/* Checks a mesh view (layout, non-NULL arrays, at least one vertex and
 * triangle, fewer than 2^32 vertices, indices in range, finite positions)
 * and fills *out with it and its bounds. SC_ERR_INVALID_ARGUMENT /
 * SC_ERR_NONFINITE otherwise, *out zeroed. */
SC_API sc_status sc_mesh_check(const sc_mesh_view *view, sc_checked_mesh *out);

/* Axis-aligned bounds of the referenced vertices of an unchecked view (a
 * checked mesh carries them). */
SC_API sc_status sc_mesh_bounds(const sc_mesh_view *mesh, float lo[3], float hi[3]);

/* *closed = 1 iff, after welding identical positions, every edge is used by
 * exactly two triangles (degenerate triangles ignored). */
SC_API sc_status sc_mesh_is_closed(const sc_checked_mesh *mesh, int *closed);

#ifdef __cplusplus
}
#endif
#endif

/* The mesh check, bounds, welding and the edge table. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "mesh_edges.h"

/* Bounds of the vertices the triangles reference; SC_ERR_INVALID_ARGUMENT
 * for an index out of range, SC_ERR_NONFINITE for a non-finite vertex. */
static sc_status referenced_bounds(const sc_mesh_view *mesh, float lo[3], float hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *ix = sc_mesh_triangle(mesh, t);
        for (int c = 0; c < 3; c++) {
            if (ix[c] >= mesh->vertex_count)
                return SC_ERR_INVALID_ARGUMENT;
            const float *p = sc_mesh_vertex(mesh, ix[c]);
            for (int k = 0; k < 3; k++) {
                float x = p[k];
                if (!isfinite(x))
                    return SC_ERR_NONFINITE;
                if (x < lo[k]) lo[k] = x;
                if (x > hi[k]) hi[k] = x;
            }
        }
    }
    return SC_OK;
}

static int stride_ok(size_t s)
{
    return s == 0 || (s >= 12 && s % 4 == 0);
}

int sc_mesh_layout_ok(const sc_mesh_view *m)
{
    return m && stride_ok(m->vertex_stride) && stride_ok(m->index_stride) &&
           (uintptr_t)m->positions % 4 == 0 && (uintptr_t)m->indices % 4 == 0;
}

sc_status sc_mesh_check(const sc_mesh_view *view, sc_checked_mesh *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    if (!sc_mesh_layout_ok(view) || !view->positions || !view->indices || view->vertex_count == 0 ||
        view->triangle_count == 0 || view->vertex_count > UINT32_MAX || view->triangle_count > UINT32_MAX)
        return SC_ERR_INVALID_ARGUMENT;
    for (size_t i = 0; i < view->vertex_count; i++) {
        const float *p = sc_mesh_vertex(view, i);
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return SC_ERR_NONFINITE;
    }
    sc_status st = referenced_bounds(view, out->lo, out->hi);
    if (st != SC_OK)
        return st;
    out->view = *view;
    return SC_OK;
}

sc_status sc_mesh_bounds(const sc_mesh_view *mesh, float lo[3], float hi[3])
{
    if (!sc_mesh_layout_ok(mesh) || !mesh->positions || !mesh->indices || !lo || !hi || mesh->triangle_count == 0)
        return SC_ERR_INVALID_ARGUMENT;
    return referenced_bounds(mesh, lo, hi);
}

typedef struct weld_key {
    float p[3];
    uint32_t index;
} weld_key;

static int cmp_pos(const void *pa, const void *pb)
{
    const weld_key *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a->p[k] != b->p[k])
            return a->p[k] < b->p[k] ? -1 : 1;
    return (a->index > b->index) - (a->index < b->index);
}

static int cmp_edge(const void *pa, const void *pb)
{
    const sc_edge *a = pa, *b = pb;
    if (a->a != b->a) return a->a < b->a ? -1 : 1;
    if (a->b != b->b) return a->b < b->b ? -1 : 1;
    return (a->tri > b->tri) - (a->tri < b->tri);
}

int sc_edge_table_tri_ok(const sc_edge_table *t, const sc_mesh_view *mesh, uint32_t tri)
{
    const uint32_t *ix = sc_mesh_triangle(mesh, tri);
    uint32_t a = t->canon[ix[0]], b = t->canon[ix[1]], c = t->canon[ix[2]];
    return a != b && b != c && a != c;
}

sc_status sc_edge_table_build(const sc_mesh_view *mesh, sc_edge_table *out)
{
    if (!out || !mesh)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    size_t nv = mesh->vertex_count, nt = mesh->triangle_count;
    weld_key *order = malloc(nv * sizeof *order);
    out->canon = malloc(nv * sizeof *out->canon);
    out->edges = malloc(3 * nt * sizeof *out->edges);
    if (!order || !out->canon || !out->edges) {
        free(order);
        sc_edge_table_free(out);
        return SC_ERR_OUT_OF_MEMORY;
    }
    for (size_t i = 0; i < nv; i++) {
        memcpy(order[i].p, sc_mesh_vertex(mesh, i), sizeof order[i].p);
        order[i].index = (uint32_t)i;
    }
    qsort(order, nv, sizeof *order, cmp_pos);
    for (size_t i = 0; i < nv;) {
        size_t j = i + 1;
        while (j < nv && order[j].p[0] == order[i].p[0] && order[j].p[1] == order[i].p[1] &&
               order[j].p[2] == order[i].p[2])
            j++;
        for (size_t k = i; k < j; k++)
            out->canon[order[k].index] = order[i].index;
        i = j;
    }
    free(order);
    size_t ne = 0;
    for (size_t t = 0; t < nt; t++) {
        if (!sc_edge_table_tri_ok(out, mesh, (uint32_t)t))
            continue;
        const uint32_t *ix = sc_mesh_triangle(mesh, t);
        for (int e = 0; e < 3; e++) {
            uint32_t a = out->canon[ix[e]], b = out->canon[ix[(e + 1) % 3]];
            out->edges[ne].a = a < b ? a : b;
            out->edges[ne].b = a < b ? b : a;
            out->edges[ne].tri = (uint32_t)t;
            ne++;
        }
    }
    qsort(out->edges, ne, sizeof *out->edges, cmp_edge);
    out->count = ne;
    return SC_OK;
}

void sc_edge_table_free(sc_edge_table *t)
{
    if (!t)
        return;
    free(t->canon);
    free(t->edges);
    memset(t, 0, sizeof *t);
}

sc_status sc_mesh_is_closed(const sc_checked_mesh *mesh, int *closed)
{
    if (!closed)
        return SC_ERR_INVALID_ARGUMENT;
    *closed = 0;
    if (!mesh)
        return SC_ERR_INVALID_ARGUMENT;
    sc_edge_table t;
    sc_status st = sc_edge_table_build(&mesh->view, &t);
    if (st != SC_OK)
        return st;
    int ok = t.count > 0;
    for (size_t i = 0; i < t.count && ok;) {
        size_t j = i + 1;
        while (j < t.count && t.edges[j].a == t.edges[i].a && t.edges[j].b == t.edges[i].b)
            j++;
        if (j - i != 2)
            ok = 0;
        i = j;
    }
    *closed = ok;
    sc_edge_table_free(&t);
    return SC_OK;
}

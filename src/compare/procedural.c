/* Procedural meshes (see procedural.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_rng.h"
#include "mesh_edges.h"
#include "procedural.h"

void sc_proc_free(sc_proc_mesh *m)
{
    if (!m)
        return;
    free(m->positions);
    free(m->indices);
    memset(m, 0, sizeof *m);
}

sc_mesh_view sc_proc_view(const sc_proc_mesh *m)
{
    sc_mesh_view v = { m->positions, m->vertex_count, m->indices, m->triangle_count };
    return v;
}

static sc_status alloc_mesh(sc_proc_mesh *m, size_t nv, size_t nt)
{
    memset(m, 0, sizeof *m);
    m->positions = malloc(3 * nv * sizeof *m->positions);
    m->indices = malloc(3 * nt * sizeof *m->indices);
    if (!m->positions || !m->indices) {
        sc_proc_free(m);
        return SC_ERR_OUT_OF_MEMORY;
    }
    m->vertex_count = (uint32_t)nv;
    m->triangle_count = (uint32_t)nt;
    return SC_OK;
}

/* Replaces indices by the welded ids: independently subdivided faces then
 * share their vertices, because equal inputs give equal float midpoints. */
static sc_status weld(sc_proc_mesh *m)
{
    sc_mesh_view v = sc_proc_view(m);
    sc_edge_table t;
    sc_status st = sc_edge_table_build(&v, &t);
    if (st != SC_OK)
        return st;
    for (size_t i = 0; i < 3 * (size_t)m->triangle_count; i++)
        m->indices[i] = t.canon[m->indices[i]];
    sc_edge_table_free(&t);
    return SC_OK;
}

static void sphere_point(const double p[3], float *out)
{
    double l = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    for (int k = 0; k < 3; k++)
        out[k] = (float)(p[k] / l);
}

static void subdivide(sc_proc_mesh *m, size_t *nv, size_t *nt, const double a[3], const double b[3],
                      const double c[3], int level)
{
    if (level == 0) {
        const double *p[3] = { a, b, c };
        for (int j = 0; j < 3; j++) {
            sphere_point(p[j], &m->positions[3 * *nv]);
            m->indices[3 * *nt + (size_t)j] = (uint32_t)(*nv)++;
        }
        (*nt)++;
        return;
    }
    double ab[3], bc[3], ca[3];
    for (int k = 0; k < 3; k++) {
        ab[k] = 0.5 * (a[k] + b[k]);
        bc[k] = 0.5 * (b[k] + c[k]);
        ca[k] = 0.5 * (c[k] + a[k]);
    }
    subdivide(m, nv, nt, a, ab, ca, level - 1);
    subdivide(m, nv, nt, ab, b, bc, level - 1);
    subdivide(m, nv, nt, ca, bc, c, level - 1);
    subdivide(m, nv, nt, ab, bc, ca, level - 1);
}

sc_status sc_proc_icosphere(int level, sc_proc_mesh *out)
{
    if (!out || level < 0 || level > 8)
        return SC_ERR_INVALID_ARGUMENT;
    const double g = (1 + sqrt(5.0)) / 2;
    const double V[12][3] = { { -1, g, 0 }, { 1, g, 0 }, { -1, -g, 0 }, { 1, -g, 0 },
                              { 0, -1, g }, { 0, 1, g }, { 0, -1, -g }, { 0, 1, -g },
                              { g, 0, -1 }, { g, 0, 1 }, { -g, 0, -1 }, { -g, 0, 1 } };
    static const int F[20][3] = { { 0, 11, 5 }, { 0, 5, 1 }, { 0, 1, 7 }, { 0, 7, 10 }, { 0, 10, 11 },
                                  { 1, 5, 9 }, { 5, 11, 4 }, { 11, 10, 2 }, { 10, 7, 6 }, { 7, 1, 8 },
                                  { 3, 9, 4 }, { 3, 4, 2 }, { 3, 2, 6 }, { 3, 6, 8 }, { 3, 8, 9 },
                                  { 4, 9, 5 }, { 2, 4, 11 }, { 6, 2, 10 }, { 8, 6, 7 }, { 9, 8, 1 } };
    size_t nt = 20;
    for (int i = 0; i < level; i++)
        nt *= 4;
    sc_status st = alloc_mesh(out, 3 * nt, nt);
    if (st != SC_OK)
        return st;
    size_t cv = 0, ct = 0;
    for (int f = 0; f < 20; f++)
        subdivide(out, &cv, &ct, V[F[f][0]], V[F[f][1]], V[F[f][2]], level);
    if ((st = weld(out)) != SC_OK)
        sc_proc_free(out);
    return st;
}

sc_status sc_proc_grid(int n, sc_proc_mesh *out)
{
    if (!out || n < 1 || n > 4096)
        return SC_ERR_INVALID_ARGUMENT;
    size_t w = (size_t)n + 1;
    sc_status st = alloc_mesh(out, w * w, 2 * (size_t)n * n);
    if (st != SC_OK)
        return st;
    for (size_t y = 0; y < w; y++)
        for (size_t x = 0; x < w; x++) {
            double u = (double)x / n, v = (double)y / n;
            float *p = &out->positions[3 * (y * w + x)];
            p[0] = (float)u;
            p[1] = (float)(0.08 * sin(7 * u) * cos(5 * v) + 0.03 * sin(23 * u + 17 * v));
            p[2] = (float)v;
        }
    size_t t = 0;
    for (size_t y = 0; y < (size_t)n; y++)
        for (size_t x = 0; x < (size_t)n; x++) {
            uint32_t a = (uint32_t)(y * w + x), b = a + 1, c = a + (uint32_t)w, d = c + 1;
            uint32_t *ix = &out->indices[6 * t++];
            ix[0] = a, ix[1] = c, ix[2] = b;
            ix[3] = b, ix[4] = c, ix[5] = d;
        }
    return SC_OK;
}

sc_status sc_proc_soup(uint32_t n, uint64_t seed, sc_proc_mesh *out)
{
    if (!out || n < 1 || n > 50000000u)
        return SC_ERR_INVALID_ARGUMENT;
    sc_status st = alloc_mesh(out, 3 * (size_t)n, n);
    if (st != SC_OK)
        return st;
    sc_rng r;
    sc_rng_seed(&r, seed);
    double size = 0.5 / cbrt((double)n);
    for (size_t t = 0; t < n; t++) {
        double c[3];
        for (int k = 0; k < 3; k++)
            c[k] = sc_rng_uniform(&r);
        for (int j = 0; j < 3; j++) {
            for (int k = 0; k < 3; k++)
                out->positions[9 * t + 3 * (size_t)j + (size_t)k] =
                    (float)(c[k] + size * (sc_rng_uniform(&r) - 0.5));
            out->indices[3 * t + (size_t)j] = (uint32_t)(3 * t + (size_t)j);
        }
    }
    return SC_OK;
}

sc_status sc_proc_cube(sc_proc_mesh *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    sc_status st = alloc_mesh(out, 8, 12);
    if (st != SC_OK)
        return st;
    for (int i = 0; i < 8; i++) {
        out->positions[3 * i + 0] = (i & 1) ? 1.0f : -1.0f;
        out->positions[3 * i + 1] = (i & 2) ? 1.0f : -1.0f;
        out->positions[3 * i + 2] = (i & 4) ? 1.0f : -1.0f;
    }
    static const uint32_t F[12][3] = { { 0, 2, 1 }, { 1, 2, 3 }, { 4, 5, 6 }, { 5, 7, 6 },
                                       { 0, 1, 4 }, { 1, 5, 4 }, { 2, 6, 3 }, { 3, 6, 7 },
                                       { 0, 4, 2 }, { 2, 4, 6 }, { 1, 3, 5 }, { 3, 7, 5 } };
    memcpy(out->indices, F, sizeof F);
    return SC_OK;
}

int sc_proc_is_name(const char *name)
{
    return name && strncmp(name, "proc:", 5) == 0;
}

sc_status sc_proc_by_name(const char *name, sc_proc_mesh *out)
{
    if (!out || !sc_proc_is_name(name))
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    const char *kind = name + 5, *colon = strchr(kind, ':');
    size_t klen = colon ? (size_t)(colon - kind) : strlen(kind);
    long arg = -1;
    if (colon) {
        char *end;
        arg = strtol(colon + 1, &end, 10);
        if (*end || end == colon + 1 || arg < 0)
            return SC_ERR_INVALID_ARGUMENT;
    }
    if (klen == 6 && strncmp(kind, "sphere", 6) == 0)
        return sc_proc_icosphere(arg < 0 ? 5 : (int)(arg > 8 ? 99 : arg), out);
    if (klen == 4 && strncmp(kind, "grid", 4) == 0)
        return sc_proc_grid(arg < 0 ? 128 : (int)(arg > 4096 ? 0 : arg), out);
    if (klen == 4 && strncmp(kind, "soup", 4) == 0)
        return sc_proc_soup(arg < 0 ? 20000u : (uint32_t)(arg > 50000000 ? 0 : arg), 1, out);
    if (klen == 4 && strncmp(kind, "cube", 4) == 0 && arg < 0)
        return sc_proc_cube(out);
    return SC_ERR_INVALID_ARGUMENT;
}

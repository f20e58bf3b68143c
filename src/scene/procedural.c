/* Procedural meshes (see procedural.h): the generators, the "proc:" spec
 * parser that puts them into a scene, and the fixed test meshes. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_rng.h"
#include "compare/mesh_edges.h"
#include "procedural.h"

#define PI 3.14159265358979323846

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
    sc_mesh_view v = { m->positions, m->vertex_count, m->indices, m->triangle_count, 0, 0 };
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

/* uint32 indices bound the vertex count: at most 3 vertices per triangle. */
static int count_ok(uint64_t n)
{
    return n >= 1 && n <= UINT32_MAX / 4;
}

static void put_v(sc_proc_mesh *g, size_t v, double x, double y, double z)
{
    g->positions[3 * v] = (float)x;
    g->positions[3 * v + 1] = (float)y;
    g->positions[3 * v + 2] = (float)z;
}

static void put_t(sc_proc_mesh *g, size_t t, size_t a, size_t b, size_t c)
{
    g->indices[3 * t] = (uint32_t)a;
    g->indices[3 * t + 1] = (uint32_t)b;
    g->indices[3 * t + 2] = (uint32_t)c;
}

static void transform_point(const double m[16], const float in[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = m[4 * i] * in[0] + m[4 * i + 1] * in[1] + m[4 * i + 2] * in[2] + m[4 * i + 3];
}

/* ---- the scene generators ------------------------------------------------ */

/* 4 s^2 - 4 s triangles with s stacks and 2 s slices. */
sc_status sc_proc_sphere(uint64_t n, sc_proc_mesh *g)
{
    if (!g || !count_ok(n))
        return SC_ERR_INVALID_ARGUMENT;
    uint64_t s = 3;
    while (4 * s * s - 4 * s < n)
        s++;
    uint64_t slices = 2 * s;
    if (alloc_mesh(g, 2 + (s - 1) * slices, 4 * s * s - 4 * s) != SC_OK)
        return SC_ERR_OUT_OF_MEMORY;
    put_v(g, 0, 0, 1, 0);
    put_v(g, 1, 0, -1, 0);
    for (uint64_t i = 1; i < s; i++) {
        double th = PI * (double)i / (double)s;
        for (uint64_t j = 0; j < slices; j++) {
            double ph = 2 * PI * (double)j / (double)slices;
            put_v(g, 2 + (i - 1) * slices + j, sin(th) * cos(ph), cos(th), -sin(th) * sin(ph));
        }
    }
    size_t t = 0;
#define RING(i, j) (2 + ((i) - 1) * slices + ((j) % slices))
    for (uint64_t j = 0; j < slices; j++) {
        put_t(g, t++, 0, RING(1, j), RING(1, j + 1));
        put_t(g, t++, 1, RING(s - 1, j + 1), RING(s - 1, j));
    }
    for (uint64_t i = 1; i + 1 < s; i++)
        for (uint64_t j = 0; j < slices; j++) {
            put_t(g, t++, RING(i, j), RING(i + 1, j), RING(i + 1, j + 1));
            put_t(g, t++, RING(i, j), RING(i + 1, j + 1), RING(i, j + 1));
        }
#undef RING
    return SC_OK;
}

static void random_in_cube(sc_rng *r, double c[3])
{
    for (int i = 0; i < 3; i++)
        c[i] = sc_rng_range(r, -1, 1);
}

/* n unconnected triangles (vertices 3t, 3t+1, 3t+2) and the random stream
 * of one kind of scene (salt), for the generators to place the vertices. */
static sc_status alloc_unconnected(sc_proc_mesh *g, uint64_t n, uint64_t seed, uint64_t salt,
                                   sc_rng *r)
{
    if (!g || !count_ok(n))
        return SC_ERR_INVALID_ARGUMENT;
    if (alloc_mesh(g, 3 * n, n) != SC_OK)
        return SC_ERR_OUT_OF_MEMORY;
    for (uint64_t t = 0; t < n; t++)
        put_t(g, t, 3 * t, 3 * t + 1, 3 * t + 2);
    sc_rng_seed(r, seed ^ salt);
    return SC_OK;
}

sc_status sc_proc_soup(uint64_t n, uint64_t seed, sc_proc_mesh *g)
{
    sc_rng r;
    sc_status st = alloc_unconnected(g, n, seed, 0x736f7570u, &r);
    if (st != SC_OK)
        return st;
    double h = 1.0 / cbrt((double)n);
    for (uint64_t t = 0; t < n; t++) {
        double c[3];
        random_in_cube(&r, c);
        for (int k = 0; k < 3; k++)
            put_v(g, 3 * t + k, c[0] + sc_rng_range(&r, -h, h), c[1] + sc_rng_range(&r, -h, h),
                  c[2] + sc_rng_range(&r, -h, h));
    }
    return SC_OK;
}

static void random_unit(sc_rng *r, double v[3])
{
    double z = sc_rng_range(r, -1, 1), ph = sc_rng_range(r, 0, 2 * PI), s = sqrt(1 - z * z);
    v[0] = s * cos(ph);
    v[1] = s * sin(ph);
    v[2] = z;
}

/* Half needles (one edge 1e-4 of the others), half caps (an apex 1e-4 off
 * the long edge): the shapes whose circumspheres are worst. */
sc_status sc_proc_slivers(uint64_t n, uint64_t seed, sc_proc_mesh *g)
{
    sc_rng r;
    sc_status st = alloc_unconnected(g, n, seed, 0x736c6976u, &r);
    if (st != SC_OK)
        return st;
    double len = 4.0 / cbrt((double)n);
    for (uint64_t t = 0; t < n; t++) {
        double c[3];
        random_in_cube(&r, c);
        double d[3], e[3], tmp[3];
        random_unit(&r, d);
        random_unit(&r, tmp);
        e[0] = d[1] * tmp[2] - d[2] * tmp[1];
        e[1] = d[2] * tmp[0] - d[0] * tmp[2];
        e[2] = d[0] * tmp[1] - d[1] * tmp[0];
        double el = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        if (!(el > 1e-9)) {
            e[0] = d[1]; e[1] = -d[0]; e[2] = 0;   /* any perpendicular */
            el = sqrt(e[0] * e[0] + e[1] * e[1]);
            if (!(el > 1e-9)) {
                e[0] = 1; e[1] = 0; e[2] = 0; el = 1;
            }
        }
        double l = len * sc_rng_range(&r, 0.5, 1.0), w = 1e-4 * l;
        double a[3], b[3], p[3];
        for (int i = 0; i < 3; i++) {
            a[i] = c[i] - 0.5 * l * d[i];
            b[i] = c[i] + 0.5 * l * d[i];
            p[i] = ((t & 1) ? c[i] : a[i]) + w * e[i] / el;
        }
        put_v(g, 3 * t, a[0], a[1], a[2]);
        put_v(g, 3 * t + 1, b[0], b[1], b[2]);
        put_v(g, 3 * t + 2, p[0], p[1], p[2]);
    }
    return SC_OK;
}

/* Sum of octaves of randomly oriented waves: smooth hills with detail. */
sc_status sc_proc_terrain(uint64_t n, uint64_t seed, sc_proc_mesh *g)
{
    if (!g || !count_ok(n))
        return SC_ERR_INVALID_ARGUMENT;
    uint64_t k = 1;
    while (2 * k * k < n)
        k++;
    if (alloc_mesh(g, (k + 1) * (k + 1), 2 * k * k) != SC_OK)
        return SC_ERR_OUT_OF_MEMORY;
    sc_rng r;
    sc_rng_seed(&r, seed ^ 0x7465727275ull);
    enum { OCT = 8 };
    double amp[OCT], freq[OCT], cs[OCT], sn[OCT], ph[OCT];
    for (int o = 0; o < OCT; o++) {
        double th = sc_rng_range(&r, 0, 2 * PI);
        amp[o] = 0.18 * pow(0.55, o);
        freq[o] = 1.6 * pow(1.9, o);
        cs[o] = cos(th);
        sn[o] = sin(th);
        ph[o] = sc_rng_range(&r, 0, 2 * PI);
    }
    for (uint64_t i = 0; i <= k; i++)
        for (uint64_t j = 0; j <= k; j++) {
            double x = -1 + 2.0 * (double)j / (double)k, z = -1 + 2.0 * (double)i / (double)k, y = 0;
            for (int o = 0; o < OCT; o++)
                y += amp[o] * sin(freq[o] * (x * cs[o] + z * sn[o]) + ph[o]);
            put_v(g, i * (k + 1) + j, x, y, z);
        }
    size_t t = 0;
    for (uint64_t i = 0; i < k; i++)
        for (uint64_t j = 0; j < k; j++) {
            size_t v = i * (k + 1) + j;
            put_t(g, t++, v, v + k + 1, v + 1);
            put_t(g, t++, v + 1, v + k + 1, v + k + 2);
        }
    return SC_OK;
}

/* ---- proc: specs in a scene ---------------------------------------------- */

/* Parses a count "123", "20k", "1M"; 0 on failure. */
static int parse_count(const char *text, uint64_t *out)
{
    if (!text || *text < '0' || *text > '9')
        return 0;
    errno = 0;
    char *end;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno)
        return 0;
    uint64_t mul = 1;
    if (*end == 'k' || *end == 'K')
        mul = 1000, end++;
    else if (*end == 'M')
        mul = 1000000, end++;
    if (*end != '\0' || v == 0 || v > UINT64_MAX / mul)
        return 0;
    *out = v * mul;
    return 1;
}

static sc_status add_generated(sc_scene *s, sc_proc_mesh *g, const double xform[16],
                               const float *color, const float def[3], char *err, size_t errlen)
{
    if (xform)
        for (size_t v = 0; v < g->vertex_count; v++) {
            double p[3];
            transform_point(xform, g->positions + 3 * v, p);
            for (int i = 0; i < 3; i++)
                g->positions[3 * v + i] = (float)p[i];
        }
    return sc_scene_add_mesh(s, g->positions, g->vertex_count, g->indices, g->triangle_count,
                             color ? color : def, err, errlen);
}

static sc_status make_grid(sc_scene *s, const char *spec, const char *mesh, uint64_t n,
                           const double xform[16], const float *color,
                           sc_scene_append_fn append_mesh, char *err, size_t errlen)
{
    if (s->depth >= 2)
        return sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: grids nested too deeply", spec);
    sc_scene *sub;
    sc_status st = sc_scene_create_nested(s, &sub);
    if (st != SC_OK)
        return sc_scene_errf(err, errlen, st, "%s", sc_strerror(st));
    st = append_mesh(sub, mesh, NULL, NULL, NULL, err, errlen);
    s->warnings += sub->warnings;
    if (st == SC_OK && sub->num_triangles == 0)
        st = sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: '%s' has no triangles", spec, mesh);
    if (st != SC_OK) {
        sc_scene_free(sub);
        return st;
    }
    uint64_t nt = sub->num_triangles, nv = sub->num_vertices;
    uint64_t copies = (n + nt - 1) / nt;
    if (copies > s->max_triangles / nt + 1 || copies * nt > s->max_triangles) {
        sc_scene_free(sub);
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "%s: %llu copies of %llu triangles exceed the cap of %llu triangles",
                             spec, (unsigned long long)copies, (unsigned long long)nt,
                             (unsigned long long)s->max_triangles);
    }
    st = sc_scene_reserve(s, (size_t)(copies * nv), (size_t)(copies * nt), err, errlen);
    if (st != SC_OK) {
        sc_scene_free(sub);
        return st;
    }
    uint32_t first_mesh = (uint32_t)s->num_meshes;
    for (size_t m = 0; st == SC_OK && m < sub->num_meshes; m++) {
        uint32_t id;
        st = sc_scene_new_mesh(s, color ? color : sub->mesh_colors + 3 * m, &id);
    }
    if (st != SC_OK) {
        s->num_meshes = first_mesh;
        sc_scene_free(sub);
        return sc_scene_errf(err, errlen, st, "%s: cannot add meshes: %s", spec, sc_strerror(st));
    }
    double lo[3], hi[3];
    sc_scene_bounds(sub, lo, hi);
    double ex = hi[0] - lo[0], ez = hi[2] - lo[2];
    double step = 1.25 * (ex > ez ? ex : ez);
    if (!(step > 0))
        step = 1;
    uint64_t side = 1;
    while (side * side < copies)
        side++;
    static const double identity[16] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 };
    const double *m = xform ? xform : identity;
    size_t v0 = s->num_vertices, t0 = s->num_triangles;
    for (uint64_t c = 0; c < copies; c++) {
        double off[3] = { ((double)(c % side) - 0.5 * (double)(side - 1)) * step, 0,
                          ((double)(c / side) - 0.5 * (double)(side - 1)) * step };
        uint32_t base = (uint32_t)(v0 + c * nv);
        for (size_t v = 0; v < nv; v++) {
            float q[3];
            for (int i = 0; i < 3; i++)
                q[i] = (float)((double)sub->positions[3 * v + i] + off[i]);
            double p[3];
            transform_point(m, q, p);
            for (int i = 0; i < 3; i++) {
                float f = (float)p[i];
                if (!isfinite(f)) {
                    s->num_meshes = first_mesh;
                    sc_scene_free(sub);
                    return sc_scene_errf(err, errlen, SC_ERR_RANGE,
                                         "%s: grid coordinates overflow float", spec);
                }
                s->positions[3 * (base + v) + i] = f;
            }
        }
        for (size_t t = 0; t < nt; t++) {
            size_t dst = t0 + c * nt + t;
            for (int k = 0; k < 3; k++)
                s->indices[3 * dst + k] = base + sub->indices[3 * t + k];
            s->mesh_ids[dst] = first_mesh + sub->mesh_ids[t];
        }
    }
    s->num_vertices = v0 + copies * nv;
    s->num_triangles = t0 + copies * nt;
    s->degenerate += copies * sub->degenerate;
    s->dropped_nonfinite += copies * sub->dropped_nonfinite;
    s->skipped_primitives += copies * sub->skipped_primitives;
    sc_scene_free(sub);
    return SC_OK;
}

sc_status sc_scene_load_procedural(sc_scene *s, const char *spec, const double xform[16],
                                   const float *color, sc_scene_append_fn append_mesh, char *err,
                                   size_t errlen)
{
    const char *kind = spec + 5;   /* after "proc:" */
    const char *last = strrchr(kind, ':');
    uint64_t n;
    if (!last || !parse_count(last + 1, &n))
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: expected proc:KIND:N with N a positive count (e.g. 100k)", spec);
    /* uint32 indices bound the vertex count whatever the configured cap. */
    if (n > s->max_triangles || n > UINT32_MAX / 4)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "%s: %llu triangles exceed the cap of %llu", spec, (unsigned long long)n,
                             (unsigned long long)(s->max_triangles < UINT32_MAX / 4 ? s->max_triangles
                                                                                  : UINT32_MAX / 4));
    size_t klen = (size_t)(last - kind);
    if (klen > 5 && strncmp(kind, "grid:", 5) == 0) {
        char *mesh = strndup(kind + 5, klen - 5);
        if (!mesh)
            return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
        sc_status st = make_grid(s, spec, mesh, n, xform, color, append_mesh, err, errlen);
        free(mesh);
        return st;
    }
    sc_proc_mesh g = { 0 };
    sc_status st;
    static const float red[3] = { 0.85f, 0.35f, 0.25f }, blue[3] = { 0.3f, 0.6f, 0.85f },
                       gold[3] = { 0.9f, 0.75f, 0.3f }, green[3] = { 0.45f, 0.6f, 0.35f };
    const float *def;
    /* The generators' own rounding may add a few triangles past N; the
     * real cap check happens when the mesh is added. */
    if (klen == 6 && strncmp(kind, "sphere", 6) == 0)
        st = sc_proc_sphere(n, &g), def = red;
    else if (klen == 4 && strncmp(kind, "soup", 4) == 0)
        st = sc_proc_soup(n, s->seed, &g), def = blue;
    else if (klen == 7 && strncmp(kind, "slivers", 7) == 0)
        st = sc_proc_slivers(n, s->seed, &g), def = gold;
    else if (klen == 7 && strncmp(kind, "terrain", 7) == 0)
        st = sc_proc_terrain(n, s->seed, &g), def = green;
    else
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: unknown procedural scene (sphere, soup, slivers, terrain, grid:MESH)",
                             spec);
    st = st == SC_OK ? add_generated(s, &g, xform, color, def, err, errlen)
                     : sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", spec);
    sc_proc_free(&g);
    return st;
}

/* ---- fixed test meshes --------------------------------------------------- */

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

sc_status sc_proc_heightfield(int n, sc_proc_mesh *out)
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

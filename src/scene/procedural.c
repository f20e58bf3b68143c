/* Procedural scenes by name, so scale tests need no files:
 *   proc:sphere:N    UV sphere of radius 1 at the origin, vertices exactly on it
 *   proc:soup:N      N random triangles in [-1,1]^3, edges ~ 2/cbrt(N)
 *   proc:slivers:N   N needles and caps (huge circumspheres) in [-1,1]^3
 *   proc:terrain:N   height field over [-1,1]^2 (x, z), y up
 *   proc:grid:MESH:N copies of MESH on a square grid in x, z, >= N triangles
 * N is a count with an optional k (1e3) or M (1e6) suffix; the generators
 * round it up to their natural resolution. Random ones use the scene seed. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_rng.h"
#include "scene_internal.h"

#define PI 3.14159265358979323846

typedef struct gen {
    float *pos;
    uint32_t *idx;
    size_t nv, nt;
} gen;

static int gen_alloc(gen *g, size_t nv, size_t nt)
{
    g->pos = malloc(nv * 3 * sizeof(float));
    g->idx = malloc(nt * 3 * sizeof(uint32_t));
    g->nv = nv;
    g->nt = nt;
    return g->pos && g->idx;
}

static void gen_free(gen *g)
{
    free(g->pos);
    free(g->idx);
}

static void put_v(gen *g, size_t v, double x, double y, double z)
{
    g->pos[3 * v] = (float)x;
    g->pos[3 * v + 1] = (float)y;
    g->pos[3 * v + 2] = (float)z;
}

static void put_t(gen *g, size_t t, size_t a, size_t b, size_t c)
{
    g->idx[3 * t] = (uint32_t)a;
    g->idx[3 * t + 1] = (uint32_t)b;
    g->idx[3 * t + 2] = (uint32_t)c;
}

static void xform_point(const double m[16], const float in[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = m[4 * i] * in[0] + m[4 * i + 1] * in[1] + m[4 * i + 2] * in[2] + m[4 * i + 3];
}

/* 4 s^2 - 4 s triangles with s stacks and 2 s slices. */
static int make_sphere(gen *g, uint64_t n)
{
    uint64_t s = 3;
    while (4 * s * s - 4 * s < n)
        s++;
    uint64_t slices = 2 * s;
    if (!gen_alloc(g, 2 + (s - 1) * slices, 4 * s * s - 4 * s))
        return 0;
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
    return 1;
}

static int make_soup(gen *g, uint64_t n, uint64_t seed)
{
    if (!gen_alloc(g, 3 * n, n))
        return 0;
    sc_rng r;
    sc_rng_seed(&r, seed ^ 0x736f7570u);
    double h = 1.0 / cbrt((double)n);
    for (uint64_t t = 0; t < n; t++) {
        double c[3] = { sc_rng_range(&r, -1, 1), sc_rng_range(&r, -1, 1), sc_rng_range(&r, -1, 1) };
        for (int k = 0; k < 3; k++)
            put_v(g, 3 * t + k, c[0] + sc_rng_range(&r, -h, h), c[1] + sc_rng_range(&r, -h, h),
                  c[2] + sc_rng_range(&r, -h, h));
        put_t(g, t, 3 * t, 3 * t + 1, 3 * t + 2);
    }
    return 1;
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
static int make_slivers(gen *g, uint64_t n, uint64_t seed)
{
    if (!gen_alloc(g, 3 * n, n))
        return 0;
    sc_rng r;
    sc_rng_seed(&r, seed ^ 0x736c6976u);
    double len = 4.0 / cbrt((double)n);
    for (uint64_t t = 0; t < n; t++) {
        double c[3] = { sc_rng_range(&r, -1, 1), sc_rng_range(&r, -1, 1), sc_rng_range(&r, -1, 1) };
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
        put_t(g, t, 3 * t, 3 * t + 1, 3 * t + 2);
    }
    return 1;
}

/* Sum of octaves of randomly oriented waves: smooth hills with detail. */
static int make_terrain(gen *g, uint64_t n, uint64_t seed)
{
    uint64_t k = 1;
    while (2 * k * k < n)
        k++;
    if (!gen_alloc(g, (k + 1) * (k + 1), 2 * k * k))
        return 0;
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
    return 1;
}

static sc_status add_generated(sc_scene *s, gen *g, const double xform[16], const float *color,
                               const float def[3], char *err, size_t errlen)
{
    if (xform)
        for (size_t v = 0; v < g->nv; v++) {
            double p[3];
            xform_point(xform, g->pos + 3 * v, p);
            for (int i = 0; i < 3; i++)
                g->pos[3 * v + i] = (float)p[i];
        }
    return sc_scene_add_mesh(s, g->pos, g->nv, g->idx, g->nt, color ? color : def, err, errlen);
}

static sc_status make_grid(sc_scene *s, const char *spec, const char *mesh, uint64_t n,
                           const double xform[16], const float *color, char *err, size_t errlen)
{
    if (s->depth >= 2)
        return sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: grids nested too deeply", spec);
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.max_triangles = s->max_triangles;
    o.mesh_cache_dir = s->cache_dir;
    o.seed = s->seed;
    o.warn = s->warn;
    o.warn_ctx = s->warn_ctx;
    o.import_timeout_ms = s->import_timeout_ms;
    o.import_in_process = s->import_in_process;
    o.max_import_bytes = s->max_import_bytes;
    sc_scene *sub;
    sc_status st = sc_scene_create(&o, &sub);
    if (st != SC_OK)
        return sc_scene_errf(err, errlen, st, "%s", sc_strerror(st));
    sub->depth = s->depth + 1;
    st = sc_scene_append_spec(sub, mesh, NULL, NULL, err, errlen);
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
    sc_scene_bounds(sub, 0, lo, hi);
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
            xform_point(m, q, p);
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
                                   const float *color, char *err, size_t errlen)
{
    const char *kind = spec + 5;   /* after "proc:" */
    const char *last = strrchr(kind, ':');
    uint64_t n;
    if (!last || !sc_scene_parse_count(last + 1, &n))
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
        sc_status st = make_grid(s, spec, mesh, n, xform, color, err, errlen);
        free(mesh);
        return st;
    }
    gen g = { 0 };
    int ok;
    static const float red[3] = { 0.85f, 0.35f, 0.25f }, blue[3] = { 0.3f, 0.6f, 0.85f },
                       gold[3] = { 0.9f, 0.75f, 0.3f }, green[3] = { 0.45f, 0.6f, 0.35f };
    const float *def;
    /* The generators' own rounding may add a few triangles past N; the
     * real cap check happens when the mesh is added. */
    if (klen == 6 && strncmp(kind, "sphere", 6) == 0)
        ok = make_sphere(&g, n), def = red;
    else if (klen == 4 && strncmp(kind, "soup", 4) == 0)
        ok = make_soup(&g, n, s->seed), def = blue;
    else if (klen == 7 && strncmp(kind, "slivers", 7) == 0)
        ok = make_slivers(&g, n, s->seed), def = gold;
    else if (klen == 7 && strncmp(kind, "terrain", 7) == 0)
        ok = make_terrain(&g, n, s->seed), def = green;
    else
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: unknown procedural scene (sphere, soup, slivers, terrain, grid:MESH)",
                             spec);
    sc_status st = ok ? add_generated(s, &g, xform, color, def, err, errlen)
                      : sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", spec);
    gen_free(&g);
    return st;
}

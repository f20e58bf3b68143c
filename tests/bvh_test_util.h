/* Shared by the BVH tests: procedural scenes, a tiny OBJ reader (tests only;
 * the scene subsystem owns real loading), and a brute-force oracle in double
 * precision that knows how far float rounding may move an edge decision.
 *
 * The oracle works in exact-enough double arithmetic on the same float
 * vertices and rays. For a triangle (V0, V1, V2) and ray O + tD it computes
 * the signed volumes E0 = ((V1-O) x (V2-O)).D, E1 = ((V2-O) x (V0-O)).D,
 * E2 = ((V0-O) x (V1-O)).D (barycentric weights E_i / sum E). A float
 * tracer (the watertight test's edge functions are these volumes up to the
 * factor D_kz, each built from a handful of rounded operations on vectors of
 * length |V-O|) can misjudge E_i only by about m_i = K u |a||b||D|; we use
 * K = 64, u = 2^-24 and bound |a||b| by (|a|^2 + |b|^2)/2 to avoid square
 * roots. Hence two classes per triangle:
 *   robust hit   every E_i clears its margin on the same side: any correct
 *                float tracer must find it (or something at least as near);
 *   relaxed hit  every E_i is within its margin of that side: a float tracer
 *                may report it.
 * Likewise t has a tolerance: 64 u max|V-O|/|D| for the rounding of the
 * vertices plus sum(m_i)/(|sum E| - sum(m_i)) times the depth spread of the
 * vertices (oracle_t).
 */
#ifndef SPHERECULL_BVH_TEST_UTIL_H
#define SPHERECULL_BVH_TEST_UTIL_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_rng.h"
#include "spherecull/sc_prefilter.h"

typedef struct tmesh {
    float *pos;
    uint32_t *idx;
    size_t nv, nt;
    size_t cap_v, cap_t;
} tmesh;

static inline void tmesh_free(tmesh *m)
{
    free(m->pos);
    free(m->idx);
    memset(m, 0, sizeof *m);
}

static inline uint32_t tmesh_vertex(tmesh *m, double x, double y, double z)
{
    if (m->nv == m->cap_v) {
        m->cap_v = m->cap_v ? 2 * m->cap_v : 1024;
        m->pos = realloc(m->pos, m->cap_v * 3 * sizeof(float));
    }
    m->pos[3 * m->nv] = (float)x, m->pos[3 * m->nv + 1] = (float)y, m->pos[3 * m->nv + 2] = (float)z;
    return (uint32_t)m->nv++;
}

static inline void tmesh_tri(tmesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->nt == m->cap_t) {
        m->cap_t = m->cap_t ? 2 * m->cap_t : 1024;
        m->idx = realloc(m->idx, m->cap_t * 3 * sizeof(uint32_t));
    }
    m->idx[3 * m->nt] = a, m->idx[3 * m->nt + 1] = b, m->idx[3 * m->nt + 2] = c;
    m->nt++;
}

/* Random soup: n triangles, vertices around random centres in [-1,1]^3
 * (+offset), sizes log-uniform in [1e-3, 0.3]. */
static inline void scene_soup(tmesh *m, size_t n, double offset, uint64_t seed)
{
    sc_rng r;
    sc_rng_seed(&r, seed);
    for (size_t i = 0; i < n; i++) {
        double c[3], s = exp(sc_rng_range(&r, log(1e-3), log(0.3)));
        for (int k = 0; k < 3; k++)
            c[k] = sc_rng_range(&r, -1, 1) + offset;
        uint32_t v[3];
        for (int j = 0; j < 3; j++)
            v[j] = tmesh_vertex(m, c[0] + s * sc_rng_range(&r, -1, 1), c[1] + s * sc_rng_range(&r, -1, 1),
                                c[2] + s * sc_rng_range(&r, -1, 1));
        tmesh_tri(m, v[0], v[1], v[2]);
    }
}

/* Slivers and needles: nearly collinear triangles and triangles with one
 * edge 1e-2..1e-7 of the others, random orientation. */
static inline void scene_slivers(tmesh *m, size_t n, uint64_t seed)
{
    sc_rng r;
    sc_rng_seed(&r, seed);
    for (size_t i = 0; i < n; i++) {
        double c[3], d[3], e[3], L = sc_rng_range(&r, 0.05, 0.5);
        for (int k = 0; k < 3; k++) {
            c[k] = sc_rng_range(&r, -1, 1);
            d[k] = sc_rng_range(&r, -1, 1);
            e[k] = sc_rng_range(&r, -1, 1);
        }
        double eps = exp(sc_rng_range(&r, log(1e-7), log(1e-2)));
        uint32_t a, b, cc;
        if (i & 1) { /* sliver: third vertex eps off the long edge's middle */
            a = tmesh_vertex(m, c[0], c[1], c[2]);
            b = tmesh_vertex(m, c[0] + L * d[0], c[1] + L * d[1], c[2] + L * d[2]);
            cc = tmesh_vertex(m, c[0] + 0.5 * L * d[0] + eps * L * e[0], c[1] + 0.5 * L * d[1] + eps * L * e[1],
                              c[2] + 0.5 * L * d[2] + eps * L * e[2]);
        } else {     /* needle: two vertices eps apart */
            a = tmesh_vertex(m, c[0], c[1], c[2]);
            b = tmesh_vertex(m, c[0] + L * d[0], c[1] + L * d[1], c[2] + L * d[2]);
            cc = tmesh_vertex(m, c[0] + L * d[0] + eps * L * e[0], c[1] + L * d[1] + eps * L * e[1],
                              c[2] + L * d[2] + eps * L * e[2]);
        }
        tmesh_tri(m, a, b, cc);
    }
}

/* Closed icosphere: the icosahedron subdivided `level` times, midpoints
 * projected to the sphere, vertices shared (welded by edge lookup). */
static inline void scene_icosphere(tmesh *m, int level, double radius, const double centre[3])
{
    const double t = (1 + sqrt(5.0)) / 2;
    double base[12][3] = { { -1, t, 0 }, { 1, t, 0 }, { -1, -t, 0 }, { 1, -t, 0 }, { 0, -1, t }, { 0, 1, t },
                           { 0, -1, -t }, { 0, 1, -t }, { t, 0, -1 }, { t, 0, 1 }, { -t, 0, -1 }, { -t, 0, 1 } };
    static const int f[20][3] = { { 0, 11, 5 }, { 0, 5, 1 }, { 0, 1, 7 }, { 0, 7, 10 }, { 0, 10, 11 },
                                  { 1, 5, 9 }, { 5, 11, 4 }, { 11, 10, 2 }, { 10, 7, 6 }, { 7, 1, 8 },
                                  { 3, 9, 4 }, { 3, 4, 2 }, { 3, 2, 6 }, { 3, 6, 8 }, { 3, 8, 9 },
                                  { 4, 9, 5 }, { 2, 4, 11 }, { 6, 2, 10 }, { 8, 6, 7 }, { 9, 8, 1 } };
    size_t cap = 12 + 30 * ((size_t)1 << (2 * level)) * 2;
    double (*v)[3] = malloc(cap * sizeof *v);
    size_t nv = 12;
    for (int i = 0; i < 12; i++) {
        double l = sqrt(base[i][0] * base[i][0] + base[i][1] * base[i][1] + base[i][2] * base[i][2]);
        for (int k = 0; k < 3; k++)
            v[i][k] = base[i][k] / l;
    }
    size_t nf = 20;
    uint32_t *faces = malloc(20 * 3 * sizeof(uint32_t));
    for (int i = 0; i < 20; i++)
        for (int k = 0; k < 3; k++)
            faces[3 * i + k] = (uint32_t)f[i][k];
    for (int l = 0; l < level; l++) {
        /* Edge midpoint cache: open addressing on (min, max). */
        size_t hcap = 16 * nf;
        uint64_t *hk = malloc(hcap * sizeof *hk);
        uint32_t *hv = malloc(hcap * sizeof *hv);
        for (size_t i = 0; i < hcap; i++)
            hk[i] = UINT64_MAX;
        uint32_t *nfaces = malloc(4 * nf * 3 * sizeof(uint32_t));
        for (size_t i = 0; i < nf; i++) {
            uint32_t a[3] = { faces[3 * i], faces[3 * i + 1], faces[3 * i + 2] }, mid[3];
            for (int e = 0; e < 3; e++) {
                uint32_t p = a[e], q = a[(e + 1) % 3];
                uint64_t key = p < q ? (uint64_t)p << 32 | q : (uint64_t)q << 32 | p;
                size_t h = (size_t)((key * 0x9e3779b97f4a7c15ull) >> 20) % hcap;
                while (hk[h] != UINT64_MAX && hk[h] != key)
                    h = (h + 1) % hcap;
                if (hk[h] == UINT64_MAX) {
                    double x[3], len = 0;
                    for (int k = 0; k < 3; k++) {
                        x[k] = 0.5 * (v[p][k] + v[q][k]);
                        len += x[k] * x[k];
                    }
                    len = sqrt(len);
                    for (int k = 0; k < 3; k++)
                        v[nv][k] = x[k] / len;
                    hk[h] = key;
                    hv[h] = (uint32_t)nv++;
                }
                mid[e] = hv[h];
            }
            uint32_t *o = nfaces + 12 * i;
            uint32_t tri[4][3] = { { a[0], mid[0], mid[2] }, { a[1], mid[1], mid[0] },
                                   { a[2], mid[2], mid[1] }, { mid[0], mid[1], mid[2] } };
            memcpy(o, tri, sizeof tri);
        }
        free(faces);
        free(hk);
        free(hv);
        faces = nfaces;
        nf *= 4;
    }
    size_t v0 = m->nv;
    for (size_t i = 0; i < nv; i++)
        tmesh_vertex(m, centre[0] + radius * v[i][0], centre[1] + radius * v[i][1], centre[2] + radius * v[i][2]);
    for (size_t i = 0; i < nf; i++)
        tmesh_tri(m, (uint32_t)(v0 + faces[3 * i]), (uint32_t)(v0 + faces[3 * i + 1]), (uint32_t)(v0 + faces[3 * i + 2]));
    free(v);
    free(faces);
}

/* Minimal OBJ: "v x y z" and "f i j k ..." (i, i/t, i/t/n, i//n; negative
 * indices), polygons fanned. Returns 0 on success. */
static inline int tmesh_read_obj(tmesh *m, const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[4096];
    while (fgets(line, sizeof line, f)) {
        if (line[0] == 'v' && line[1] == ' ') {
            double x, y, z;
            if (sscanf(line + 2, "%lf %lf %lf", &x, &y, &z) == 3)
                tmesh_vertex(m, x, y, z);
        } else if (line[0] == 'f' && line[1] == ' ') {
            long ids[64];
            int n = 0;
            char *p = line + 2;
            while (*p && n < 64) {
                while (*p == ' ' || *p == '\t')
                    p++;
                if (!*p || *p == '\n' || *p == '\r')
                    break;
                char *end;
                long i = strtol(p, &end, 10);
                if (end == p)
                    break;
                ids[n++] = i < 0 ? (long)m->nv + i : i - 1;
                p = end;
                while (*p && *p != ' ' && *p != '\t' && *p != '\n')
                    p++;
            }
            for (int k = 2; k < n; k++)
                if (ids[0] >= 0 && ids[k - 1] >= 0 && ids[k] >= 0)
                    tmesh_tri(m, (uint32_t)ids[0], (uint32_t)ids[k - 1], (uint32_t)ids[k]);
        }
    }
    fclose(f);
    for (size_t i = 0; i < 3 * m->nt; i++)
        if (m->idx[i] >= m->nv)
            return -1;
    return m->nt ? 0 : -1;
}

/* ---- oracle --------------------------------------------------------------- */

typedef struct oracle {
    size_t n;
    double *cx, *cy, *cz, *r2;      /* padded bounding spheres, only to skip work */
    double (*v)[9];
} oracle;

typedef struct oracle_hit {
    int hit;          /* robust or relaxed hit found */
    double t;         /* nearest relaxed hit */
    uint32_t prim;
    double t_robust;  /* min over robust hits of t + tolerance (INFINITY if none):
                         a correct tracer reports nothing farther */
} oracle_hit;

static inline void oracle_init(oracle *o, const tmesh *m)
{
    o->n = m->nt;
    o->cx = malloc(m->nt * sizeof(double));
    o->cy = malloc(m->nt * sizeof(double));
    o->cz = malloc(m->nt * sizeof(double));
    o->r2 = malloc(m->nt * sizeof(double));
    o->v = malloc(m->nt * sizeof *o->v);
    for (size_t i = 0; i < m->nt; i++) {
        double c[3] = { 0, 0, 0 };
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) {
                double x = m->pos[3 * m->idx[3 * i + j] + k];
                o->v[i][3 * j + k] = x;
                c[k] += x / 3;
            }
        double r2 = 0;
        for (int j = 0; j < 3; j++) {
            double d2 = 0;
            for (int k = 0; k < 3; k++)
                d2 += (o->v[i][3 * j + k] - c[k]) * (o->v[i][3 * j + k] - c[k]);
            r2 = fmax(r2, d2);
        }
        o->cx[i] = c[0], o->cy[i] = c[1], o->cz[i] = c[2];
        /* 1e-3 relative padding dwarfs double rounding; the absolute term
         * covers the tiny margins of relaxed hits next to an edge. */
        o->r2[i] = r2 * 1.002 + 1e-30 + 1e-12 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    }
}

static inline void oracle_free(oracle *o)
{
    free(o->cx), free(o->cy), free(o->cz), free(o->r2), free(o->v);
}

__attribute__((target_clones("avx512f", "avx2", "default")))
static void oracle_cull(const oracle *o, size_t begin, size_t end, const double O[3], const double D[3],
                        double dd, uint8_t *keep)
{
    for (size_t i = begin; i < end; i++) {
        double x = o->cx[i] - O[0], y = o->cy[i] - O[1], z = o->cz[i] - O[2];
        double a = y * D[2] - z * D[1], b = z * D[0] - x * D[2], c = x * D[1] - y * D[0];
        keep[i - begin] = (a * a + b * b + c * c) <= o->r2[i] * dd * 1.000001;
    }
}

/* t of a relaxed hit and its tolerance. When |sum E| is within the summed
 * margins the triangle is degenerate at float precision: a float test may
 * then report any point of it, so t is only known to lie in the depth range
 * of its vertices. */
static inline void oracle_t(const double E[3], const double mg[3], const double z[3], const double n2[3],
                            double Dn, double *t, double *tol)
{
    const double u = 0x1p-24, K = 64;
    double det = E[0] + E[1] + E[2], msum = mg[0] + mg[1] + mg[2];
    double maxlen = sqrt(fmax(n2[0], fmax(n2[1], n2[2])));
    double base = K * u * maxlen / Dn;
    /* A tracer may weigh another depth per vertex than z (e.g. the
     * watertight test's A_kz / D_kz); they differ by at most
     * sqrt(3) |A_perp| / |D|, the vertex's distance from the ray. */
    double off[3], lo = INFINITY, hi = -INFINITY;
    for (int j = 0; j < 3; j++) {
        double perp2 = n2[j] - z[j] * z[j] * Dn * Dn;
        off[j] = 1.7320508075688772 * (perp2 > 0 ? sqrt(perp2) : 0) / Dn;
        lo = fmin(lo, z[j] - off[j]);
        hi = fmax(hi, z[j] + off[j]);
    }
    if (!(fabs(det) > msum)) {
        /* Same-sign weights of those depths: the hull of their ranges. */
        *t = 0.5 * (lo + hi);
        *tol = 0.5 * (hi - lo) + base;
        return;
    }
    *t = (E[0] * z[0] + E[1] * z[1] + E[2] * z[2]) / det;
    double spread = 0;
    for (int j = 0; j < 3; j++)
        spread = fmax(spread, fabs(z[j] - *t) + off[j]);
    /* First order in the margins, with det itself perturbed by up to msum. */
    *tol = base + msum / (fabs(det) - msum) * spread;
}

static inline void oracle_trace(const oracle *o, const sc_ray *ray, oracle_hit *out)
{
    const double u = 0x1p-24, K = 64;
    double O[3] = { ray->org[0], ray->org[1], ray->org[2] }, D[3] = { ray->dir[0], ray->dir[1], ray->dir[2] };
    double dd = D[0] * D[0] + D[1] * D[1] + D[2] * D[2], Dn = sqrt(dd);
    out->hit = 0;
    out->t = INFINITY;
    out->t_robust = INFINITY;
    out->prim = UINT32_MAX;
    enum { CH = 4096 };
    uint8_t keep[CH];
    for (size_t b = 0; b < o->n; b += CH) {
        size_t e = b + CH < o->n ? b + CH : o->n;
        oracle_cull(o, b, e, O, D, dd, keep);
        for (size_t i = b; i < e; i++) {
            if (!keep[i - b])
                continue;
            const double *v = o->v[i];
            double P[3][3], n2[3], z[3];
            for (int j = 0; j < 3; j++) {
                n2[j] = 0;
                z[j] = 0;
                for (int k = 0; k < 3; k++) {
                    P[j][k] = v[3 * j + k] - O[k];
                    n2[j] += P[j][k] * P[j][k];
                    z[j] += P[j][k] * D[k];
                }
                z[j] /= dd;
            }
            double E[3], mg[3];
            for (int j = 0; j < 3; j++) {
                const double *a = P[(j + 1) % 3], *bb = P[(j + 2) % 3];
                double cx = a[1] * bb[2] - a[2] * bb[1], cy = a[2] * bb[0] - a[0] * bb[2], cz = a[0] * bb[1] - a[1] * bb[0];
                E[j] = cx * D[0] + cy * D[1] + cz * D[2];
                mg[j] = K * u * 0.5 * (n2[(j + 1) % 3] + n2[(j + 2) % 3]) * Dn;
            }
            int relaxed = (E[0] >= -mg[0] && E[1] >= -mg[1] && E[2] >= -mg[2]) ||
                          (E[0] <= mg[0] && E[1] <= mg[1] && E[2] <= mg[2]);
            if (!relaxed)
                continue;
            int robust = (E[0] > mg[0] && E[1] > mg[1] && E[2] > mg[2]) ||
                         (E[0] < -mg[0] && E[1] < -mg[1] && E[2] < -mg[2]);
            double t, tol;
            oracle_t(E, mg, z, n2, Dn, &t, &tol);
            if (robust && t - tol >= ray->tmin && t + tol <= ray->tmax && t + tol < out->t_robust)
                out->t_robust = t + tol;
            if (t + tol >= ray->tmin && t - tol <= ray->tmax && t < out->t) {
                out->t = t;
                out->prim = (uint32_t)i;
                out->hit = 1;
            }
        }
    }
}

/* t tolerance of triangle prim for this ray (see the header comment). */
static inline double oracle_tri(const oracle *o, uint32_t prim, const sc_ray *ray, double *t_out)
{
    const double u = 0x1p-24, K = 64;
    double O[3] = { ray->org[0], ray->org[1], ray->org[2] }, D[3] = { ray->dir[0], ray->dir[1], ray->dir[2] };
    double dd = D[0] * D[0] + D[1] * D[1] + D[2] * D[2], Dn = sqrt(dd);
    const double *v = o->v[prim];
    double P[3][3], n2[3], z[3], E[3], mg[3];
    for (int j = 0; j < 3; j++) {
        n2[j] = z[j] = 0;
        for (int k = 0; k < 3; k++) {
            P[j][k] = v[3 * j + k] - O[k];
            n2[j] += P[j][k] * P[j][k];
            z[j] += P[j][k] * D[k];
        }
        z[j] /= dd;
    }
    int relaxed_ok;
    for (int j = 0; j < 3; j++) {
        const double *a = P[(j + 1) % 3], *bb = P[(j + 2) % 3];
        double cx = a[1] * bb[2] - a[2] * bb[1], cy = a[2] * bb[0] - a[0] * bb[2], cz = a[0] * bb[1] - a[1] * bb[0];
        E[j] = cx * D[0] + cy * D[1] + cz * D[2];
        mg[j] = K * u * 0.5 * (n2[(j + 1) % 3] + n2[(j + 2) % 3]) * Dn;
    }
    relaxed_ok = (E[0] >= -mg[0] && E[1] >= -mg[1] && E[2] >= -mg[2]) ||
                 (E[0] <= mg[0] && E[1] <= mg[1] && E[2] <= mg[2]);
    double t, tol;
    oracle_t(E, mg, z, n2, Dn, &t, &tol);
    *t_out = t;
    return relaxed_ok ? tol : -1;
}

#endif

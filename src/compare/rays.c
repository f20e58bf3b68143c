/* Seeded ray sets (see sc_rays.h). */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_names.h"
#include "common/sc_rng.h"
#include "mesh_edges.h"

#define PI 3.14159265358979323846

static const char *const kind_names[SC_RAYS_KIND_COUNT] = {
    "primary", "shadow", "diffuse", "random", "adversarial"
};
static const char *const tag_names[SC_RAY_TAG_COUNT] = {
    "none", "vertex", "edge", "edge-back", "grazing"
};

const char *sc_rayset_kind_name(sc_rayset_kind kind)
{
    return sc_enum_name(kind_names, SC_RAYS_KIND_COUNT, (int)kind, "unknown");
}

sc_status sc_rayset_kind_from_name(const char *name, sc_rayset_kind *out)
{
    int v;
    if (!out || sc_enum_lookup(kind_names, SC_RAYS_KIND_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_rayset_kind)v;
    return SC_OK;
}

const char *sc_ray_tag_name(sc_ray_tag tag)
{
    return (unsigned)tag < SC_RAY_TAG_COUNT ? tag_names[tag] : "unknown";
}

void sc_rayset_free(sc_rayset *set)
{
    if (!set)
        return;
    free(set->rays);
    free(set->tag);
    free(set->exact);
    free(set->target);
    free(set->aim_t);
    memset(set, 0, sizeof *set);
}

static sc_status rayset_alloc(sc_rayset *set, sc_rayset_kind kind, size_t count)
{
    memset(set, 0, sizeof *set);
    size_t n = count ? count : 1;
    set->kind = kind;
    set->rays = aligned_alloc(32, n * sizeof *set->rays);
    set->tag = calloc(n, 1);
    set->exact = calloc(n, 1);
    set->target = calloc(n, sizeof *set->target);
    set->aim_t = calloc(n, sizeof *set->aim_t);
    if (!set->rays || !set->tag || !set->exact || !set->target || !set->aim_t) {
        sc_rayset_free(set);
        return SC_ERR_OUT_OF_MEMORY;
    }
    return SC_OK;
}

/* Per-ray stream: independent of generation order. */
static void ray_rng(sc_rng *r, uint64_t seed, size_t i)
{
    sc_rng_seed(r, seed ^ ((uint64_t)i * 0xd1b54a32d192ed03ull + 0x2545f4914f6cdd1dull));
}

static void set_ray(sc_ray *r, const double o[3], const double d[3], float tmin, float tmax)
{
    for (int k = 0; k < 3; k++) {
        r->org[k] = (float)o[k];
        r->dir[k] = (float)d[k];
    }
    r->tmin = tmin;
    r->tmax = tmax;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(double o[3], const double a[3], const double b[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static int normalize3(double v[3])
{
    double l = sqrt(dot3(v, v));
    if (!(l > 0) || !isfinite(l))
        return 0;
    for (int k = 0; k < 3; k++)
        v[k] /= l;
    return 1;
}

static void vertex(const sc_mesh_view *m, uint32_t tri, int corner, double v[3])
{
    const float *p = sc_mesh_vertex(m, sc_mesh_triangle(m, tri)[corner]);
    v[0] = p[0], v[1] = p[1], v[2] = p[2];
}

/* Unit geometric normal (B-A) x (C-A); 0 for a degenerate triangle. */
static int tri_normal(const sc_mesh_view *m, uint32_t tri, double n[3])
{
    double A[3], B[3], C[3], e1[3], e2[3];
    vertex(m, tri, 0, A), vertex(m, tri, 1, B), vertex(m, tri, 2, C);
    for (int k = 0; k < 3; k++)
        e1[k] = B[k] - A[k], e2[k] = C[k] - A[k];
    cross3(n, e1, e2);
    return normalize3(n);
}

static void unit_sphere(sc_rng *r, double w[3])
{
    double z = 2 * sc_rng_uniform(r) - 1, phi = 2 * PI * sc_rng_uniform(r);
    double s = sqrt(fmax(0.0, 1 - z * z));
    w[0] = s * cos(phi), w[1] = s * sin(phi), w[2] = z;
}

/* Any orthonormal pair completing n. */
static void basis(const double n[3], double t[3], double b[3])
{
    double a[3] = { 1, 0, 0 };
    if (fabs(n[0]) > 0.5)
        a[0] = 0, a[1] = 1;
    cross3(t, n, a);
    normalize3(t);
    cross3(b, n, t);
}

static double mesh_diag(const sc_checked_mesh *mesh)
{
    double d2 = 0;
    for (int k = 0; k < 3; k++)
        d2 += ((double)mesh->hi[k] - mesh->lo[k]) * ((double)mesh->hi[k] - mesh->lo[k]);
    return d2 > 0 ? sqrt(d2) : 1;
}

sc_status sc_rayset_primary(const sc_camera *cam, sc_rayset *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    sc_camera_frame fr;
    sc_status st = sc_camera_frame_make(cam, &fr);
    if (st != SC_OK)
        return st;
    if ((double)cam->width * cam->height > 1e9)
        return SC_ERR_LIMIT;
    size_t w = (size_t)cam->width, h = (size_t)cam->height;
    if ((st = rayset_alloc(out, SC_RAYS_PRIMARY, w * h)) != SC_OK)
        return st;
    size_t n = 0;
    for (size_t ty = 0; ty < h; ty += 4)
        for (size_t tx = 0; tx < w; tx += 4)
            for (size_t y = ty; y < ty + 4 && y < h; y++)
                for (size_t x = tx; x < tx + 4 && x < w; x++) {
                    double d[3];
                    sc_camera_ray_dir(cam, &fr, (double)x + 0.5, (double)y + 0.5, d);
                    set_ray(&out->rays[n], cam->eye, d, 0.0f, INFINITY);
                    out->target[n] = (uint32_t)(y * w + x);
                    n++;
                }
    out->count = n;
    return SC_OK;
}

/* Offset hit point of hits[i] and the unit normal facing the incoming ray. */
static int hit_frame(const sc_mesh_view *mesh, const sc_ray *r, const sc_hitrec *h, double off,
                     double p[3], double n[3])
{
    if (h->prim == SC_HITREC_MISS || h->prim >= mesh->triangle_count || !isfinite(h->t))
        return 0;
    if (!tri_normal(mesh, h->prim, n))
        return 0;
    double d[3] = { r->dir[0], r->dir[1], r->dir[2] };
    if (dot3(n, d) > 0)
        for (int k = 0; k < 3; k++)
            n[k] = -n[k];
    for (int k = 0; k < 3; k++)
        p[k] = (double)r->org[k] + (double)h->t * d[k] + off * n[k];
    return 1;
}

/* The start of a set made from the hits of another: *out cleared, the
 * arguments checked (args_ok: the caller's own), room for one ray per hit. */
static sc_status start_from_hits(const sc_checked_mesh *mesh, const sc_rayset *from,
                                 const sc_hitrec *hits, int args_ok, sc_rayset_kind kind,
                                 sc_rayset *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    if (!mesh || !from || !hits || (!from->rays && from->count) || !args_ok)
        return SC_ERR_INVALID_ARGUMENT;
    return rayset_alloc(out, kind, from->count);
}

sc_status sc_rayset_shadow(const sc_checked_mesh *mesh, const sc_rayset *from,
                           const sc_hitrec *hits, const float light[3], sc_rayset *out)
{
    int light_ok = light && isfinite(light[0]) && isfinite(light[1]) && isfinite(light[2]);
    sc_status st = start_from_hits(mesh, from, hits, light_ok, SC_RAYS_SHADOW, out);
    if (st != SC_OK)
        return st;
    double off = SC_RAYS_OFFSET * mesh_diag(mesh);
    size_t n = 0;
    for (size_t i = 0; i < from->count; i++) {
        double p[3], nrm[3], d[3];
        if (!hit_frame(&mesh->view, &from->rays[i], &hits[i], off, p, nrm))
            continue;
        double o[3] = { (float)p[0], (float)p[1], (float)p[2] };
        for (int k = 0; k < 3; k++)
            d[k] = (double)light[k] - o[k];
        set_ray(&out->rays[n], o, d, 0.0f, 1.0f);
        out->target[n++] = (uint32_t)i;
    }
    out->count = n;
    return SC_OK;
}

sc_status sc_rayset_diffuse(const sc_checked_mesh *mesh, const sc_rayset *from,
                            const sc_hitrec *hits, uint64_t seed, sc_rayset *out)
{
    sc_status st = start_from_hits(mesh, from, hits, 1, SC_RAYS_DIFFUSE, out);
    if (st != SC_OK)
        return st;
    double off = SC_RAYS_OFFSET * mesh_diag(mesh);
    size_t n = 0;
    for (size_t i = 0; i < from->count; i++) {
        double p[3], nrm[3], t[3], b[3], d[3];
        if (!hit_frame(&mesh->view, &from->rays[i], &hits[i], off, p, nrm))
            continue;
        sc_rng r;
        ray_rng(&r, seed, i);
        double r1 = sc_rng_uniform(&r), r2 = sc_rng_uniform(&r);
        double phi = 2 * PI * r1, s = sqrt(r2), c = sqrt(1 - r2);
        basis(nrm, t, b);
        for (int k = 0; k < 3; k++)
            d[k] = s * cos(phi) * t[k] + s * sin(phi) * b[k] + c * nrm[k];
        set_ray(&out->rays[n], p, d, 0.0f, INFINITY);
        out->target[n++] = (uint32_t)i;
    }
    out->count = n;
    return SC_OK;
}

sc_status sc_rayset_random(const float lo[3], const float hi[3], size_t count, uint64_t seed,
                           sc_rayset *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    if (!lo || !hi || count == 0)
        return SC_ERR_INVALID_ARGUMENT;
    for (int k = 0; k < 3; k++)
        if (!isfinite(lo[k]) || !isfinite(hi[k]) || lo[k] > hi[k])
            return SC_ERR_INVALID_ARGUMENT;
    sc_status st = rayset_alloc(out, SC_RAYS_RANDOM, count);
    if (st != SC_OK)
        return st;
    for (size_t i = 0; i < count; i++) {
        sc_rng r;
        ray_rng(&r, seed, i);
        double o[3], d[3];
        for (int k = 0; k < 3; k++)
            o[k] = sc_rng_range(&r, lo[k], hi[k]);
        unit_sphere(&r, d);
        set_ray(&out->rays[i], o, d, 0.0f, INFINITY);
        out->target[i] = (uint32_t)i;
    }
    out->count = count;
    return SC_OK;
}

/* ---- adversarial -------------------------------------------------------- */

/* Lowest set bit of a finite non-zero double, as a power of two. */
static double low_bit(double s)
{
    int e;
    double m = frexp(s, &e);                     /* |m| in [0.5, 1) */
    uint64_t M = (uint64_t)ldexp(fabs(m), 53);
    return ldexp(1.0, e - 53 + __builtin_ctzll(M));
}

/* a + b == s exactly (TwoSum error term zero). */
static int sums_exactly(double a, double b, double s)
{
    double s2 = a + b, bb = s2 - a;
    double err = (a - (s2 - bb)) + (b - bb);
    return s2 == s && err == 0;
}

static int is_float(double x)
{
    volatile float f = (float)x;                 /* force the rounding (numerics.md) */
    return (double)f == x && isfinite(x);
}

/* Float o, d with k*o + d == s exactly (k = 1 or 2), d close to want_d.
 * s must be exactly k * (target coordinate), i.e. a sum of floats that was
 * exact in double. Returns 0 if no such pair was found near want_d. */
static int exact_coord(double s, int k, double want_d, float *o, float *d)
{
    if (s == 0) {
        float oo = (float)(-want_d / k);
        *o = oo;
        *d = (float)(-(double)k * oo);
        return sums_exactly((double)k * *o, *d, s);
    }
    /* Any power of two that divides s works as a grid for d. From the
     * finest useful one (24 bits of want_d) to the coarsest (the lowest set
     * bit of s): a finer grid keeps the direction, a coarser one leaves o
     * fewer bits. A coarse s (CAD coordinates such as 16.0) needs the fine
     * grids, or d would round to 0. */
    const double top = low_bit(s), lim = ldexp(1.0, 24) - 1;
    double q = top;
    if (want_d != 0) {
        double fine = ldexp(1.0, ilogb(want_d) - 23);
        if (fine < q)
            q = fine;
    }
    for (; q <= top; q *= 2) {
        double m = nearbyint(want_d / q);
        if (m > lim) m = lim;
        if (m < -lim) m = -lim;
        /* on the coarsest grid, also shrink d towards 0 */
        int tries = q == top ? 64 : 1;
        for (int t = 0; t < tries && m != 0; t++) {
            double dd = m * q;                     /* exact: |m| < 2^24 */
            double oo = (s - dd) / k;
            if (is_float(dd) && is_float(oo) && sums_exactly(k * oo, dd, s)) {
                *o = (float)oo;
                *d = (float)dd;
                return 1;
            }
            m = (t & 1) ? nearbyint(m / 2) : m - (m > 0 ? 1 : -1);
        }
    }
    return 0;
}

/* Sets r so it passes through the target k*T = S (per coordinate) at t = 1/k,
 * arriving along -w from distance len. Returns 1 if exact. */
static int aim(sc_ray *r, const double S[3], int k, const double w[3], double len)
{
    float o[3], d[3];
    int exact = 1;
    for (int c = 0; c < 3; c++) {
        double want_d = -w[c] * len * k;           /* D = k (T - O), O = T + len w */
        if (!exact_coord(S[c], k, want_d, &o[c], &d[c]))
            exact = 0;
    }
    if (exact && d[0] == 0 && d[1] == 0 && d[2] == 0)
        exact = 0;                                 /* never a zero direction */
    if (!exact)
        for (int c = 0; c < 3; c++) {
            o[c] = (float)(S[c] / k + len * w[c]);
            d[c] = (float)(-w[c] * len * k);
        }
    for (int c = 0; c < 3; c++)
        r->org[c] = o[c], r->dir[c] = d[c];
    r->tmin = 0.0f;
    r->tmax = INFINITY;
    return exact;
}

/* Random direction on the side of n given by sign (+1 front, -1 back, 0 any). */
static void side_dir(sc_rng *r, const double n[3], int sign, double w[3])
{
    unit_sphere(r, w);
    double s = dot3(w, n);
    if ((sign > 0 && s < 0) || (sign < 0 && s > 0))
        for (int k = 0; k < 3; k++)
            w[k] = -w[k];
}

sc_status sc_rayset_adversarial(const sc_checked_mesh *checked, size_t count, uint64_t seed,
                                sc_rayset *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    if (!checked || count == 0)
        return SC_ERR_INVALID_ARGUMENT;
    const sc_mesh_view *mesh = &checked->view;
    sc_edge_table et;
    sc_status st = sc_edge_table_build(mesh, &et);
    if (st != SC_OK)
        return st;
    /* Good triangles, and edges shared by exactly two of them. */
    uint32_t *good = malloc((size_t)mesh->triangle_count * sizeof *good);
    size_t *shared = malloc((et.count + 1) * sizeof *shared);
    if (!good || !shared) {
        free(good), free(shared), sc_edge_table_free(&et);
        return SC_ERR_OUT_OF_MEMORY;
    }
    size_t ngood = 0, nshared = 0;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) {
        double n[3];
        if (sc_edge_table_tri_ok(&et, mesh, t) && tri_normal(mesh, t, n))
            good[ngood++] = t;
    }
    for (size_t i = 0; i < et.count;) {
        size_t j = i + 1;
        while (j < et.count && et.edges[j].a == et.edges[i].a && et.edges[j].b == et.edges[i].b)
            j++;
        if (j - i == 2)
            shared[nshared++] = i;
        i = j;
    }
    if (ngood == 0) {
        free(good), free(shared), sc_edge_table_free(&et);
        return SC_ERR_DEGENERATE;
    }
    if ((st = rayset_alloc(out, SC_RAYS_ADVERSARIAL, count)) != SC_OK) {
        free(good), free(shared), sc_edge_table_free(&et);
        return st;
    }
    double diag = mesh_diag(checked);
    for (size_t i = 0; i < count; i++) {
        sc_rng r;
        ray_rng(&r, seed, i);
        sc_ray *ray = &out->rays[i];
        int kind = (int)(i % 4);
        double len = diag * sc_rng_range(&r, 0.05, 0.6), w[3], n[3];
        if (kind == 0) {                                      /* vertex */
            uint32_t t = good[sc_rng_next(&r) % ngood];
            int corner = (int)(sc_rng_next(&r) % 3);
            double V[3];
            vertex(mesh, t, corner, V);
            unit_sphere(&r, w);
            out->exact[i] = (uint8_t)aim(ray, V, 1, w, len);
            out->tag[i] = SC_RAY_TAG_VERTEX;
            out->target[i] = et.canon[sc_mesh_triangle(mesh, t)[corner]];
            out->aim_t[i] = 1.0f;
        } else if (kind == 1 || kind == 2) {                  /* shared edge midpoint */
            uint32_t t0, va, vb;
            double nsum[3] = { 0, 0, 0 };
            if (nshared) {
                const sc_edge *e = &et.edges[shared[sc_rng_next(&r) % nshared]];
                t0 = e[0].tri;
                va = e[0].a, vb = e[0].b;
                double n1[3];
                tri_normal(mesh, e[0].tri, n), tri_normal(mesh, e[1].tri, n1);
                for (int k = 0; k < 3; k++)
                    nsum[k] = n[k] + n1[k];
                if (!normalize3(nsum))              /* opposite windings: use one side */
                    memcpy(nsum, n, sizeof nsum);
            } else {
                t0 = good[sc_rng_next(&r) % ngood];
                int c = (int)(sc_rng_next(&r) % 3);
                va = sc_mesh_triangle(mesh, t0)[c];
                vb = sc_mesh_triangle(mesh, t0)[(c + 1) % 3];
                tri_normal(mesh, t0, nsum);
            }
            const float *A = sc_mesh_vertex(mesh, va), *B = sc_mesh_vertex(mesh, vb);
            double S[3];
            int sum_exact = 1;
            for (int k = 0; k < 3; k++) {
                S[k] = (double)A[k] + (double)B[k];
                /* two floats sum exactly in double unless their exponents
                 * are more than 29 apart */
                if (S[k] - A[k] != B[k])
                    sum_exact = 0;
            }
            side_dir(&r, nsum, kind == 1 ? 1 : -1, w);
            out->exact[i] = (uint8_t)(aim(ray, S, 2, w, len) && sum_exact);
            out->tag[i] = kind == 1 ? SC_RAY_TAG_EDGE : SC_RAY_TAG_EDGE_BACK;
            out->target[i] = t0;
            out->aim_t[i] = 0.5f;
        } else {                                              /* grazing */
            uint32_t t = good[sc_rng_next(&r) % ngood];
            double A[3], B[3], C[3], P[3], tv[3], bv[3];
            vertex(mesh, t, 0, A), vertex(mesh, t, 1, B), vertex(mesh, t, 2, C);
            tri_normal(mesh, t, n);
            double u = sc_rng_uniform(&r), v = sc_rng_uniform(&r);
            if (u + v > 1)
                u = 1 - u, v = 1 - v;
            for (int k = 0; k < 3; k++)
                P[k] = A[k] + u * (B[k] - A[k]) + v * (C[k] - A[k]);
            basis(n, tv, bv);
            double phi = 2 * PI * sc_rng_uniform(&r);
            double ang = pow(10.0, sc_rng_range(&r, -6, -2)) * (sc_rng_uniform(&r) < 0.5 ? -1 : 1);
            double d[3], o[3];
            for (int k = 0; k < 3; k++) {
                d[k] = cos(ang) * (cos(phi) * tv[k] + sin(phi) * bv[k]) + sin(ang) * n[k];
                o[k] = P[k] - len * d[k];
                d[k] *= len;
            }
            set_ray(ray, o, d, 0.0f, INFINITY);
            out->tag[i] = SC_RAY_TAG_GRAZING;
            out->target[i] = t;
            out->aim_t[i] = 1.0f;
        }
    }
    out->count = count;
    free(good), free(shared), sc_edge_table_free(&et);
    return SC_OK;
}

sc_status sc_camera_for_mesh(const sc_checked_mesh *mesh, int width, int height, sc_camera *cam)
{
    if (!mesh || !cam || width < 1 || height < 1)
        return SC_ERR_INVALID_ARGUMENT;
    double c[3], diag = mesh_diag(mesh);
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * ((double)mesh->lo[k] + mesh->hi[k]);
    double dir[3] = { 0.35, 0.45, 0.82 };
    normalize3(dir);
    double dist = 0.5 * diag / tan(22.5 * PI / 180) * 1.05;
    memset(cam, 0, sizeof *cam);
    for (int k = 0; k < 3; k++) {
        cam->eye[k] = c[k] + dist * dir[k];
        cam->target[k] = c[k];
    }
    cam->up[1] = 1;
    cam->fov_y_deg = 45;
    cam->width = width;
    cam->height = height;
    return SC_OK;
}

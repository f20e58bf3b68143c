/* See sc_bench_spheres.h. */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_median.h"
#include "common/sc_clock.h"
#include "common/sc_rng.h"
#include "sc_bench_spheres.h"
#include "sc_families.h"
#include "sc_reference.h"
#include "isa/isa_dispatch.h"

#define NOTE(...)                                                                                                  \
    do {                                                                                                           \
        char line_[256];                                                                                           \
        snprintf(line_, sizeof line_, __VA_ARGS__);                                                                \
        if (note)                                                                                                  \
            note(ctx, line_);                                                                                      \
    } while (0)

/* One timed batch, for the median-of-repeats helper. */
typedef struct job {
    const sc_kernels *k;
    int dbl, method, kind;
    unsigned flags;
    size_t count;
    sc_tri_source_f sf;
    sc_tri_source_d sd;
    sc_spheres_soaf of;
    sc_spheres_soad od;
    void *copy_src, *copy_dst;
    size_t copy_bytes;
} job;

static void run_job(const job *j)
{
    if (j->copy_bytes)
        memcpy(j->copy_dst, j->copy_src, j->copy_bytes);
    else if (j->dbl)
        j->k->sphere->spheres_d(&j->sd, j->count, j->method, j->kind, j->flags, &j->od);
    else
        j->k->sphere->spheres_f(&j->sf, j->count, j->method, j->kind, j->flags, &j->of);
}

/* Seconds per call: the best of `reps` samples, each at least min_time
 * long (the machine is shared; the fastest sample is the one least
 * disturbed by other work). */
static double time_job(const job *j, int reps, double min_time)
{
    double best = INFINITY;
    run_job(j);                                     /* warm caches and pages */
    for (int r = 0; r < reps; r++) {
        int calls = 0;
        double t0 = sc_now_seconds(), el;
        do {
            run_job(j);
            calls++;
            el = sc_now_seconds() - t0;
        } while (el < min_time);
        best = fmin(best, el / calls);
    }
    return best;
}

/* DRAM rows: the copy and the kernel alternate, so that both see the same
 * memory traffic from the rest of the machine; best of each. */
static void time_pair(const job *kernel, const job *copy, int reps, double *tk, double *tc)
{
    *tk = *tc = INFINITY;
    run_job(kernel);
    for (int r = 0; r < reps; r++) {
        double t0 = sc_now_seconds();
        run_job(copy);
        double t1 = sc_now_seconds();
        run_job(kernel);
        double t2 = sc_now_seconds();
        *tc = fmin(*tc, t1 - t0), *tk = fmin(*tk, t2 - t1);
    }
}

/* The memory ceiling of the indexed input: the same 9 coordinates per
 * triangle copied through the same shuffled index buffer into SoA arrays,
 * with the kernels' prefetch distance. */
static double time_indexed_copy(const float *verts, const uint32_t *idx, float *dst, size_t n, int reps)
{
    double best = INFINITY;
    for (int r = 0; r < reps; r++) {
        double t0 = sc_now_seconds();
        for (size_t t = 0; t < n; t++) {
            if (t + SC_PREFETCH_AHEAD < n)
                for (int k = 0; k < 3; k++)
                    __builtin_prefetch(verts + 3 * (size_t)idx[3 * (t + SC_PREFETCH_AHEAD) + (size_t)k]);
            for (int k = 0; k < 3; k++) {
                const float *p = verts + 3 * (size_t)idx[3 * t + (size_t)k];
                for (int a = 0; a < 3; a++)
                    dst[(size_t)(3 * k + a) * n + t] = p[a];
            }
        }
        best = fmin(best, sc_now_seconds() - t0);
    }
    return best;
}

static void add_row(sc_bsph_report *b, sc_bsph_row r)
{
    if (b->n == b->cap) {
        b->cap = b->cap ? 2 * b->cap : 256;
        b->rows = realloc(b->rows, b->cap * sizeof *b->rows);
    }
    b->rows[b->n++] = r;
}

/* ---- data ---------------------------------------------------------------- */

typedef struct dataset {
    size_t n;
    float *f;          /* 9 SoA arrays of n floats */
    double *d;         /* 9 SoA arrays of n doubles (NULL if not needed) */
    float *vf;         /* vertex buffer, 9n floats, for the indexed source */
    uint32_t *idx;     /* 3n */
    float *outf;
    double *outd;
    void *copy_dst;
} dataset;

static int make_data(dataset *ds, size_t n, int with_double, uint64_t seed)
{
    size_t pad = sc_simd_padded(n);
    memset(ds, 0, sizeof *ds);
    ds->n = n;
    ds->f = aligned_alloc(64, sizeof(float) * 9 * pad);
    ds->vf = aligned_alloc(64, sizeof(float) * 9 * pad);
    ds->idx = aligned_alloc(64, sizeof(uint32_t) * 3 * pad);
    ds->outf = aligned_alloc(64, sizeof(float) * 4 * pad);
    size_t copy = (with_double ? sizeof(double) : sizeof(float)) * 13 * pad;
    ds->copy_dst = aligned_alloc(64, copy);
    if (with_double) {
        ds->d = aligned_alloc(64, sizeof(double) * 9 * pad);
        ds->outd = aligned_alloc(64, sizeof(double) * 4 * pad);
    }
    if (!ds->f || !ds->vf || !ds->idx || !ds->outf || !ds->copy_dst || (with_double && (!ds->d || !ds->outd)))
        return -1;
    sc_rng rng;
    sc_rng_seed(&rng, seed);
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 9; k++) {
            float v = (float)sc_rng_range(&rng, -1, 1);
            ds->f[(size_t)k * n + i] = v;
            ds->vf[9 * i + (size_t)k] = v;
            if (with_double)
                ds->d[(size_t)k * n + i] = v;
        }
    /* Shuffled triangle order in the index buffer, so gathers are not sequential. */
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            ds->idx[3 * i + (size_t)k] = (uint32_t)(3 * i + (size_t)k);
    for (size_t i = n; i-- > 1;) {
        size_t j = (size_t)(sc_rng_next(&rng) % (i + 1));
        for (int k = 0; k < 3; k++) {
            uint32_t t = ds->idx[3 * i + (size_t)k];
            ds->idx[3 * i + (size_t)k] = ds->idx[3 * j + (size_t)k];
            ds->idx[3 * j + (size_t)k] = t;
        }
    }
    return 0;
}

static void free_data(dataset *ds)
{
    free(ds->f), free(ds->d), free(ds->vf), free(ds->idx), free(ds->outf), free(ds->outd), free(ds->copy_dst);
}

static job make_job(const dataset *ds, const sc_kernels *k, int dbl, int method, int kind, int indexed)
{
    job j;
    memset(&j, 0, sizeof j);
    size_t n = ds->n, pad = sc_simd_padded(n);
    j.k = k, j.dbl = dbl, j.method = method, j.kind = kind, j.count = n;
    for (int v = 0; v < 3; v++)
        for (int a = 0; a < 3; a++) {
            j.sf.soa[v][a] = ds->f + (size_t)(3 * v + a) * n;
            if (ds->d)
                j.sd.soa[v][a] = ds->d + (size_t)(3 * v + a) * n;
        }
    if (indexed) {
        j.sf.vertices = ds->vf, j.sf.vertex_count = 3 * n, j.sf.indices = ds->idx;
    }
    j.of = (sc_spheres_soaf){ ds->outf, ds->outf + pad, ds->outf + 2 * pad, ds->outf + 3 * pad };
    if (ds->outd)
        j.od = (sc_spheres_soad){ ds->outd, ds->outd + pad, ds->outd + 2 * pad, ds->outd + 3 * pad };
    return j;
}

/* Bytes a batch moves: 9 coordinates in (indexed: 3 indices + 9 gathered
 * coordinates), 4 values out. */
static double batch_bytes(size_t n, int dbl, int indexed)
{
    double s = dbl ? 8 : 4;
    return (double)n * ((indexed ? 12 + 9 * s : 9 * s) + 4 * s);
}

/* ---- errors against MPFR -------------------------------------------------- */

typedef struct errset {
    size_t n;
    float (*V)[3][3];
    sc_ref_sphere *rc, *rm;
    int *rc_ok, *rm_ok;
} errset;

static void make_errset(errset *e, int per_family)
{
    e->n = (size_t)per_family * SC_FAM_COUNT;
    e->V = malloc(sizeof(float) * 9 * e->n);
    e->rc = malloc(sizeof *e->rc * e->n), e->rm = malloc(sizeof *e->rm * e->n);
    e->rc_ok = malloc(sizeof(int) * e->n), e->rm_ok = malloc(sizeof(int) * e->n);
    sc_rng rng;
    sc_rng_seed(&rng, 12345);
    size_t t = 0;
    for (int f = 0; f < SC_FAM_COUNT; f++)
        for (int i = 0; i < per_family; i++, t++) {
            double Vd[3][3];
            sc_family_triangle((sc_family)f, &rng, 1, Vd);
            for (int k = 0; k < 3; k++)
                for (int a = 0; a < 3; a++)
                    e->V[t][k][a] = (float)Vd[k][a];
            sc_ref_sphere_init(&e->rc[t]), sc_ref_sphere_init(&e->rm[t]);
            e->rc_ok[t] = sc_ref_circumsphere(Vd[0], Vd[1], Vd[2], &e->rc[t]);
            e->rm_ok[t] = sc_ref_minimal_sphere(Vd[0], Vd[1], Vd[2], &e->rm[t]);
        }
}

static void free_errset(errset *e)
{
    for (size_t t = 0; t < e->n; t++)
        sc_ref_sphere_clear(&e->rc[t]), sc_ref_sphere_clear(&e->rm[t]);
    free(e->V), free(e->rc), free(e->rm), free(e->rc_ok), free(e->rm_ok);
}

/* Median and max centre error over the triangles whose reference exists and
 * whose computed sphere is finite (failures are counted by `accuracy`). */
static void measure_error(const errset *e, const sc_kernels *k, int dbl, int method, int kind,
                          double *med, double *mx)
{
    size_t n = e->n, pad = sc_simd_padded(n);
    float *fin = malloc(sizeof(float) * 9 * n);
    double *din = malloc(sizeof(double) * 9 * n);
    for (size_t t = 0; t < n; t++)
        for (int v = 0; v < 3; v++)
            for (int a = 0; a < 3; a++)
                fin[(size_t)(3 * v + a) * n + t] = e->V[t][v][a], din[(size_t)(3 * v + a) * n + t] = e->V[t][v][a];
    float *of = malloc(sizeof(float) * 4 * pad);
    double *od = malloc(sizeof(double) * 4 * pad);
    sc_tri_source_f sf;
    sc_tri_source_d sd;
    memset(&sf, 0, sizeof sf), memset(&sd, 0, sizeof sd);
    for (int v = 0; v < 3; v++)
        for (int a = 0; a < 3; a++)
            sf.soa[v][a] = fin + (size_t)(3 * v + a) * n, sd.soa[v][a] = din + (size_t)(3 * v + a) * n;
    sc_spheres_soaf oF = { of, of + pad, of + 2 * pad, of + 3 * pad };
    sc_spheres_soad oD = { od, od + pad, od + 2 * pad, od + 3 * pad };
    if (dbl)
        k->sphere->spheres_d(&sd, n, method, kind, 0, &oD);
    else
        k->sphere->spheres_f(&sf, n, method, kind, 0, &oF);
    double *errs = malloc(sizeof(double) * n);
    int m = 0;
    for (size_t t = 0; t < n; t++) {
        int circ = kind == SC_BATCH_CIRCUM || kind == SC_BATCH_PREFILTER_CIRCUM;
        const sc_ref_sphere *ref = circ ? &e->rc[t] : &e->rm[t];
        if (!(circ ? e->rc_ok[t] : e->rm_ok[t]))
            continue;
        double c[3], r2;
        if (dbl)
            c[0] = od[t], c[1] = od[pad + t], c[2] = od[2 * pad + t], r2 = od[3 * pad + t];
        else
            c[0] = of[t], c[1] = of[pad + t], c[2] = of[2 * pad + t], r2 = of[3 * pad + t];
        if (!isfinite(r2))
            continue;
        errs[m++] = sc_ref_centre_error(ref, c);
    }
    *med = m ? sc_median(errs, m) : NAN;
    *mx = m ? errs[m - 1] : NAN;
    free(fin), free(din), free(of), free(od), free(errs);
}

/* ---- reject masks --------------------------------------------------------- */

static double time_reject(const sc_kernels *k, int width, int packet, int quick)
{
    enum { NB = 1024 };
    sc_sphere_block16 *blk = aligned_alloc(64, sizeof *blk * NB);
    sc_ray_packet16 *pk = aligned_alloc(64, sizeof *pk * NB);
    sc_rng rng;
    sc_rng_seed(&rng, 9);
    for (int b = 0; b < NB; b++)
        for (int i = 0; i < 16; i++) {
            blk[b].cx[i] = (float)sc_rng_range(&rng, -1, 1), blk[b].cy[i] = (float)sc_rng_range(&rng, -1, 1);
            blk[b].cz[i] = (float)sc_rng_range(&rng, -1, 1), blk[b].r2[i] = (float)sc_rng_range(&rng, 0, 0.1);
            pk[b].ox[i] = (float)sc_rng_range(&rng, -3, 3), pk[b].oy[i] = (float)sc_rng_range(&rng, -3, 3);
            pk[b].oz[i] = (float)sc_rng_range(&rng, -3, 3), pk[b].dx[i] = (float)sc_rng_range(&rng, -1, 1);
            pk[b].dy[i] = (float)sc_rng_range(&rng, -1, 1), pk[b].dz[i] = (float)sc_rng_range(&rng, -1, 1);
            pk[b].tmin[i] = 0, pk[b].tmax[i] = INFINITY;
        }
    sc_ray ray = { { 2.5f, 0.1f, -0.3f }, 0, { -1, 0.05f, 0.1f }, INFINITY };
    const float c[3] = { 0.1f, 0.2f, 0.3f };
    double t[7];
    int reps = quick ? 3 : 7;
    volatile uint32_t sink = 0;
    for (int r = 0; r < reps; r++) {
        uint32_t acc = 0;
        long calls = 0;
        double t0 = sc_now_seconds(), el;
        do {
            for (int b = 0; b < NB; b++) {
                if (packet)
                    acc += width == 8 ? k->sphere->packet8((const sc_ray_packet8 *)&pk[b], c, 0.05f)
                                      : k->sphere->packet16(&pk[b], c, 0.05f);
                else if (width == 4)
                    acc += k->sphere->reject4(&ray, (const sc_sphere_block4 *)&blk[b]);
                else if (width == 8)
                    acc += k->sphere->reject8(&ray, (const sc_sphere_block8 *)&blk[b]);
                else
                    acc += k->sphere->reject16(&ray, &blk[b]);
            }
            calls += NB;
            el = sc_now_seconds() - t0;
        } while (el < (quick ? 0.005 : 0.02));
        sink += acc;
        t[r] = el / (double)calls * 1e9;
    }
    (void)sink;
    free(blk), free(pk);
    return sc_median(t, reps);
}

const sc_bsph_row *sc_bsph_find(const sc_bsph_report *b, int method, int kind, int isa, int dbl, const char *ws, const char *src)
{
    for (size_t i = 0; i < b->n; i++) {
        const sc_bsph_row *r = &b->rows[i];
        if (r->method == method && r->kind == kind && r->isa == isa && r->dbl == dbl && strcmp(r->ws, ws) == 0 &&
            strcmp(r->source, src) == 0)
            return r;
    }
    return NULL;
}

sc_status sc_bsph_run(int quick, int only, sc_bsph_report *b, void (*note)(void *ctx, const char *line), void *ctx)
{
    memset(b, 0, sizeof *b);
    b->quick = quick;
    int *isas = b->isas, nisa = 0;
    for (int i = 0; i < SC_ISA_COUNT; i++)
        if (sc_isa_supported((sc_isa)i) && (only < 0 || i == only || i == SC_ISA_SCALAR))
            isas[nisa++] = i;
    b->nisa = nisa;
    b->best = isas[nisa - 1];
    int reps = quick ? 3 : 5;
    double min_time = quick ? 0.003 : 0.02;

    errset es;
    make_errset(&es, quick ? 60 : 200);

    b->idx_copy_ns = NAN;
    static const struct { const char *name; size_t n; } sets[3] = {
        { "L1", 256 }, { "L2", 8192 }, { "DRAM", 10000000 },
    };
    for (int s = 0; s < 3; s++) {
        size_t n = sets[s].n;
        int dram = s == 2;
        if (dram && quick)
            n = 2000000;
        dataset ds;
        if (make_data(&ds, n, 1, 1 + (uint64_t)s) != 0) {
            free_data(&ds);
            free_errset(&es);
            return SC_ERR_OUT_OF_MEMORY;
        }
        if (dram) {
            double ti = time_indexed_copy(ds.vf, ds.idx, (float *)ds.copy_dst, n, reps);
            b->idx_copy_ns = ti / (double)n * 1e9;
            NOTE("DRAM float copy through the shuffled index buffer: %.2f ns/triangle (%.2f GB/s of 64 B/tri)\n",
                   b->idx_copy_ns, batch_bytes(n, 0, 1) / ti / 1e9);
        }
        for (int dbl = 0; dbl < 2; dbl++) {
            job cj = make_job(&ds, NULL, dbl, 0, 0, 0);
            cj.copy_src = dbl ? (void *)ds.d : (void *)ds.f;
            cj.copy_dst = ds.copy_dst;
            cj.copy_bytes = (size_t)(batch_bytes(n, dbl, 0) / 2);
            double tc = time_job(&cj, reps, min_time);
            double copy_bw = 2.0 * (double)cj.copy_bytes / tc;
            NOTE("%-4s %-6s memcpy of %.3g MB: %.2f GB/s (read + write)%s\n", sets[s].name, dbl ? "double" : "float",
                   (double)cj.copy_bytes / 1e6, copy_bw / 1e9, dram ? "; rows re-measure it paired" : "");
            for (int ii = 0; ii < nisa; ii++) {
                const sc_kernels *k = sc_kernels_for((sc_isa)isas[ii]);
                for (int m = 0; m < SC_METHOD_COUNT; m++)
                    for (int kind = 0; kind < SC_BATCH_KIND_COUNT; kind++) {
                        /* DRAM: the prefilter kinds only (what a tracer builds); double textbook only. */
                        if (dram && (kind < SC_BATCH_PREFILTER_CIRCUM || (dbl && m != SC_METHOD_TEXTBOOK)))
                            continue;
                        static const char *const src_name[5] = { "soa", "indexed", "soa-general",
                                                                 "soa-noprescale", "soa-nostream" };
                        for (int src = 0; src < 5; src++) {
                            int tb = m == SC_METHOD_TEXTBOOK;
                            if (src > 0 && !(tb && (kind == SC_BATCH_PREFILTER_MINIMAL ||
                                                    (src == 2 && kind == SC_BATCH_PREFILTER_CIRCUM))))
                                continue;
                            if (src > 0 && isas[ii] == SC_ISA_SCALAR && src != 1)
                                continue;    /* the scalar level has one path and always prescales */
                            if ((src == 1 && dbl) || (src == 4 && !dram))
                                continue;
                            job j = make_job(&ds, k, dbl, m, kind, src == 1);
                            j.flags = src == 2 ? SC_KFLAG_GENERAL
                                    : src == 3 ? SC_KFLAG_GENERAL | SC_KFLAG_NO_PRESCALE
                                    : src == 4 ? SC_KFLAG_NO_STREAM : 0;
                            double t, bw = copy_bw;
                            if (dram) {
                                double tcp;
                                time_pair(&j, &cj, quick ? 3 : 5, &t, &tcp);
                                bw = 2.0 * (double)cj.copy_bytes / tcp;
                            } else {
                                t = time_job(&j, reps, min_time);
                            }
                            sc_bsph_row r = { m, kind, isas[ii], dbl, sets[s].name, src_name[src],
                                      (double)n / t / 1e6, t / (double)n * 1e9,
                                      batch_bytes(n, dbl, src == 1) / t / bw, 0, 0 };
                            const sc_bsph_row *prev = sc_bsph_find(b, m, kind, isas[ii], dbl, "L1", "soa");
                            if (prev && src == 0) {
                                r.err_med = prev->err_med, r.err_max = prev->err_max;
                            } else {
                                measure_error(&es, k, dbl, m, kind, &r.err_med, &r.err_max);
                            }
                            add_row(b, r);
                        }
                    }
            }
        }
        free_data(&ds);
    }
    free_errset(&es);
    for (int ii = 0; ii < nisa; ii++) {
        const sc_kernels *k = sc_kernels_for((sc_isa)isas[ii]);
        static const int width[SC_BSPH_REJECT_COLS] = { 4, 8, 16, 8, 16 };
        for (int c = 0; c < SC_BSPH_REJECT_COLS; c++)
            b->reject_ns[ii][c] = time_reject(k, width[c], c >= 3, quick);
    }
    return SC_OK;
}

void sc_bsph_free(sc_bsph_report *b)
{
    free(b->rows);
    memset(b, 0, sizeof *b);
}

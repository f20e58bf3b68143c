/* SIMD kernels at one ISA level (argv[1], also in SPHERECULL_ISA) against
 * the scalar specification and the exact references:
 *  - batch spheres: every method x kind, float and double, random and hard
 *    families; bit-identical to the specification without FMA, centre error
 *    within a stated bound of the specification's with FMA (the conservative
 *    kinds included); zero containment failures (sc_ref_contains, exact) and
 *    a stated bound on how far r2 exceeds the reference sphere's for the
 *    conservative kinds;
 *  - the conservative kinds' fast path bit-identical to the general path,
 *    lane by lane, on batches that mix every family, and a lane's result
 *    independent of its neighbours; streaming stores and vertex prefetch
 *    (large batches) bit-identical to plain stores;
 *  - tails and bad indices with guard pages;
 *  - reject masks (blocks 4/8/16, packets 8/16) bit-identical to
 *    sc_ray_sphere_reject, and zero false rejects against the exact
 *    ray-triangle oracle on rays aimed at vertices, edges and grazing the
 *    plane.
 * A level this CPU lacks skips every test and exits 77 (ctest: skipped). */
#include "sc_guard.h"

#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "common/sc_rng.h"
#include "sc_families.h"
#include "sc_ftz.h"
#include "sc_ref_ray.h"
#include "sc_reference.h"
#include "isa/isa_dispatch.h"
#include "spherecull/sc_simd.h"

/* Inputs generated with gradual underflow in both MXCSR modes (sc_ftz.h). */
static void gen_triangle(sc_family f, sc_rng *rng, int as_float, double V[3][3])
{
    unsigned csr = sc_test_ftz_off();
    sc_family_triangle(f, rng, as_float, V);
    sc_test_ftz_restore(csr);
}

static sc_isa g_isa;
static int g_supported;

#define NEED_ISA()                                                                   \
    do {                                                                             \
        if (!g_supported)                                                            \
            skip();                                                                  \
    } while (0)


static const char *const spec_kind_name[SC_BATCH_KIND_COUNT] = { "circum", "minimal", "pf-circum", "pf-minimal" };

static void spec_f(const float V[3][3], int method, int kind, sc_spheref *s)
{
    switch (kind) {
    case SC_BATCH_CIRCUM:
        sc_circumsphere_f(V[0], V[1], V[2], (sc_method)method, SC_ORIGIN_OPPOSITE_LONGEST, s);
        break;
    case SC_BATCH_MINIMAL:
        sc_minimal_sphere_f(V[0], V[1], V[2], (sc_method)method, SC_ORIGIN_OPPOSITE_LONGEST, s);
        break;
    case SC_BATCH_PREFILTER_CIRCUM:
        sc_prefilter_sphere_f(V[0], V[1], V[2], SC_SPHERE_CIRCUM, (sc_method)method, s);
        break;
    default:
        sc_prefilter_sphere_f(V[0], V[1], V[2], SC_SPHERE_MINIMAL, (sc_method)method, s);
        break;
    }
}

static void spec_d(const double V[3][3], int method, int kind, sc_sphered *s)
{
    switch (kind) {
    case SC_BATCH_CIRCUM:
        sc_circumsphere_d(V[0], V[1], V[2], (sc_method)method, SC_ORIGIN_OPPOSITE_LONGEST, s);
        break;
    case SC_BATCH_MINIMAL:
        sc_minimal_sphere_d(V[0], V[1], V[2], (sc_method)method, SC_ORIGIN_OPPOSITE_LONGEST, s);
        break;
    case SC_BATCH_PREFILTER_CIRCUM:
        sc_prefilter_sphere_d(V[0], V[1], V[2], SC_SPHERE_CIRCUM, (sc_method)method, s);
        break;
    default:
        sc_prefilter_sphere_d(V[0], V[1], V[2], SC_SPHERE_MINIMAL, (sc_method)method, s);
        break;
    }
}

/* ---- batch spheres against the specification ---------------------------- */

enum { PER_FAMILY = 1500 };

typedef struct soa_f { float *x[3], *y[3], *z[3], *cx, *cy, *cz, *r2; float *mem; } soa_f;

static void run_batch_f(size_t n, float (*V)[3][3], int method, int kind, float *out /* 4 * pad */)
{
    size_t pad = sc_simd_padded(n);
    float *in = malloc(sizeof(float) * 9 * (n ? n : 1));
    sc_triangles_soaf tri;
    for (int k = 0; k < 3; k++) {
        tri.x[k] = in + (3 * k + 0) * n, tri.y[k] = in + (3 * k + 1) * n, tri.z[k] = in + (3 * k + 2) * n;
        for (size_t i = 0; i < n; i++) {
            ((float *)tri.x[k])[i] = V[i][k][0];
            ((float *)tri.y[k])[i] = V[i][k][1];
            ((float *)tri.z[k])[i] = V[i][k][2];
        }
    }
    sc_spheres_soaf o = { out, out + pad, out + 2 * pad, out + 3 * pad };
    assert_int_equal(sc_spheres_soa_f(&tri, n, (sc_method)method, (sc_batch_kind)kind, &o), SC_OK);
    /* The indexed path must give the same bits. */
    float *out2 = malloc(sizeof(float) * 4 * pad + 1);
    uint32_t *idx = malloc(sizeof(uint32_t) * 3 * (n ? n : 1));
    for (size_t i = 0; i < 3 * n; i++)
        idx[i] = (uint32_t)i;
    sc_spheres_soaf o2 = { out2, out2 + pad, out2 + 2 * pad, out2 + 3 * pad };
    assert_int_equal(sc_spheres_indexed_f(&V[0][0][0], 3 * n, idx, n, (sc_method)method,
                                          (sc_batch_kind)kind, &o2), SC_OK);
    assert_memory_equal(out, out2, sizeof(float) * 4 * pad);
    free(in), free(out2), free(idx);
}

static int same_bits_f(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }
static int same_bits_d(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* Stated centre-error bound, relative to the specification's own error
 * e_spec (both against MPFR, in units of the radius) and the triangle's
 * conditioning k = L_max^2 / |a x b| (sc_ref_condition):
 *   e_simd <= 4 e_spec + 64 u + 16 u k.
 * The u k term is the FMA levels' own rounding on ill-conditioned triangles
 * (caps); the specification meets the same kind of bound, not this one. */
#define FMA_FACTOR 4.0
#define FMA_FLOOR_U 64.0
#define FMA_COND_U 16.0

/* Stated bound on the conservative kinds' r2 (what the padding may cost):
 * with e the centre error above and r_ref the reference radius, every
 * vertex is within r_ref (1 + e) of the computed centre, so
 *   r2 <= r_ref^2 (1 + e)^2 (1 + 32 u) + 32 MIN
 * (MIN the smallest normal number: the pad is 16 MIN, see
 * sc_sphere_make_conservative)
 * (the padding (1 + 8u) and the rounding of |V - c|^2 take about 15u). */
static int r2_within_bound(const sc_ref_sphere *ref, const double c[3], double r2, double u, double min_normal)
{
    double r2_ref = mpfr_get_d(ref->r2, MPFR_RNDU);
    if (!(r2_ref > 0))
        return 1;
    double e = sc_ref_centre_error(ref, c);
    return r2 <= r2_ref * (1 + e) * (1 + e) * (1 + 32 * u) + 32 * min_normal;
}

static void check_family_f(sc_family fam, int method, int kind, float (*V)[3][3], size_t n,
                           sc_ref_sphere *ref_c, int *ref_c_ok, sc_ref_sphere *ref_m, int *ref_m_ok,
                           size_t *identical, size_t *contain_fail, size_t *bound_fail, double *worst_ratio)
{
    size_t pad = sc_simd_padded(n);
    float *out = malloc(sizeof(float) * 4 * pad);
    run_batch_f(n, V, method, kind, out);
    const double u = FLT_EPSILON / 2;
    for (size_t i = 0; i < n; i++) {
        sc_spheref s;
        spec_f((const float(*)[3])V[i], method, kind, &s);
        float c[3] = { out[i], out[pad + i], out[2 * pad + i] }, r2 = out[3 * pad + i];
        int same = same_bits_f(c[0], s.c[0]) && same_bits_f(c[1], s.c[1]) && same_bits_f(c[2], s.c[2]) &&
                   same_bits_f(r2, s.r2);
        *identical += (size_t)same;

        if (kind >= SC_BATCH_PREFILTER_CIRCUM) {
            double cd[3] = { c[0], c[1], c[2] };
            for (int k = 0; k < 3; k++) {
                double v[3] = { V[i][k][0], V[i][k][1], V[i][k][2] };
                int finite = isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
                if (finite && !sc_ref_contains(v, cd, r2))
                    ++*contain_fail;
            }
            const sc_ref_sphere *ref = kind == SC_BATCH_PREFILTER_CIRCUM ? &ref_c[i] : &ref_m[i];
            int ok = kind == SC_BATCH_PREFILTER_CIRCUM ? ref_c_ok[i] : ref_m_ok[i];
            if (ok && isfinite(r2) && !r2_within_bound(ref, cd, r2, u, FLT_MIN) && ++*bound_fail <= 5)
                print_message("r2 bound: %s %s %s tri %zu: r2 %a\n", sc_family_name(fam),
                              sc_method_name((sc_method)method), spec_kind_name[kind], i, r2);
        }
        if (!same) {
            int circ = kind == SC_BATCH_CIRCUM || kind == SC_BATCH_PREFILTER_CIRCUM;
            const sc_ref_sphere *ref = circ ? &ref_c[i] : &ref_m[i];
            int ok = circ ? ref_c_ok[i] : ref_m_ok[i];
            if (!ok || !isfinite(s.r2) || !isfinite(r2))
                continue;          /* failure lanes: compared via the prefilter kinds */
            double cd[3] = { c[0], c[1], c[2] }, sd[3] = { s.c[0], s.c[1], s.c[2] };
            double e = sc_ref_centre_error(ref, cd), es = sc_ref_centre_error(ref, sd);
            double vd[3][3];
            for (int k = 0; k < 3; k++)
                for (int a = 0; a < 3; a++)
                    vd[k][a] = V[i][k][a];
            double bound = FMA_FACTOR * es + FMA_FLOOR_U * u + FMA_COND_U * u * sc_ref_condition(vd[0], vd[1], vd[2]);
            if (e / bound > *worst_ratio)
                *worst_ratio = e / bound;
            if (!(e <= bound) && ++*bound_fail <= 5)
                print_message("bound: %s %s %s tri %zu: e %.3g spec %.3g\n", sc_family_name(fam),
                              sc_method_name((sc_method)method), spec_kind_name[kind], i, e, es);
        }
    }
    free(out);
}

static void test_batch_float(void **state)
{
    (void)state;
    NEED_ISA();
    sc_rng rng;
    sc_rng_seed(&rng, 2024);
    float (*V)[3][3] = malloc(sizeof(float) * 9 * PER_FAMILY);
    sc_ref_sphere *rc = malloc(sizeof *rc * PER_FAMILY), *rm = malloc(sizeof *rm * PER_FAMILY);
    int *rc_ok = malloc(sizeof(int) * PER_FAMILY), *rm_ok = malloc(sizeof(int) * PER_FAMILY);
    for (int i = 0; i < PER_FAMILY; i++)
        sc_ref_sphere_init(&rc[i]), sc_ref_sphere_init(&rm[i]);
    size_t total = 0, identical = 0, contain_fail = 0, bound_fail = 0;
    double worst = 0;
    for (int f = 0; f < SC_FAM_COUNT; f++) {
        for (int i = 0; i < PER_FAMILY; i++) {
            double Vd[3][3];
            gen_triangle((sc_family)f, &rng, 1, Vd);
            unsigned csr = sc_test_ftz_off();     /* subnormal inputs reach the kernels as given */
            for (int k = 0; k < 3; k++)
                for (int a = 0; a < 3; a++)
                    V[i][k][a] = (float)Vd[k][a];
            sc_test_ftz_restore(csr);
            {
                rc_ok[i] = sc_ref_circumsphere(Vd[0], Vd[1], Vd[2], &rc[i]);
                rm_ok[i] = sc_ref_minimal_sphere(Vd[0], Vd[1], Vd[2], &rm[i]);
            }
        }
        for (int m = 0; m < SC_METHOD_COUNT; m++)
            for (int k = 0; k < SC_BATCH_KIND_COUNT; k++) {
                check_family_f((sc_family)f, m, k, V, PER_FAMILY, rc, rc_ok, rm, rm_ok, &identical,
                               &contain_fail, &bound_fail, &worst);
                total += PER_FAMILY;
            }
    }
    print_message("float %s: %zu spheres, %zu bit-identical to the specification, %zu containment "
                  "failures, %zu centre-bound failures (worst error/bound %.3g)\n",
                  sc_isa_name(g_isa), total, identical, contain_fail, bound_fail, worst);
    for (int i = 0; i < PER_FAMILY; i++)
        sc_ref_sphere_clear(&rc[i]), sc_ref_sphere_clear(&rm[i]);
    free(V), free(rc), free(rm), free(rc_ok), free(rm_ok);
    assert_int_equal(contain_fail, 0);
    assert_int_equal(bound_fail, 0);
}

static void test_batch_double(void **state)
{
    (void)state;
    NEED_ISA();
    sc_rng rng;
    sc_rng_seed(&rng, 99);
    enum { N = 700 };
    size_t pad = sc_simd_padded(N);
    double (*V)[3][3] = malloc(sizeof(double) * 9 * N);
    double *out = malloc(sizeof(double) * 4 * pad);
    uint32_t *idx = malloc(sizeof(uint32_t) * 3 * N);
    for (size_t i = 0; i < 3 * N; i++)
        idx[i] = (uint32_t)i;
    size_t total = 0, identical = 0, contain_fail = 0, bound_fail = 0;
    const double u = DBL_EPSILON / 2;
    sc_ref_sphere ref;
    sc_ref_sphere_init(&ref);
    for (int f = 0; f < SC_FAM_COUNT; f++) {
        for (int i = 0; i < N; i++)
            gen_triangle((sc_family)f, &rng, 0, V[i]);
        for (int m = 0; m < SC_METHOD_COUNT; m++)
            for (int k = 0; k < SC_BATCH_KIND_COUNT; k++) {
                sc_spheres_soad o = { out, out + pad, out + 2 * pad, out + 3 * pad };
                assert_int_equal(sc_spheres_indexed_d(&V[0][0][0], 3 * N, idx, N, (sc_method)m,
                                                      (sc_batch_kind)k, &o), SC_OK);
                for (int i = 0; i < N; i++) {
                    sc_sphered s;
                    spec_d((const double(*)[3])V[i], m, k, &s);
                    double c[3] = { o.cx[i], o.cy[i], o.cz[i] }, r2 = o.r2[i];
                    int same = same_bits_d(c[0], s.c[0]) && same_bits_d(c[1], s.c[1]) &&
                               same_bits_d(c[2], s.c[2]) && same_bits_d(r2, s.r2);
                    identical += (size_t)same;
                    total++;
                    int circ = k == SC_BATCH_CIRCUM || k == SC_BATCH_PREFILTER_CIRCUM;
                    if (k >= SC_BATCH_PREFILTER_CIRCUM) {
                        for (int v = 0; v < 3; v++)
                            if (isfinite(V[i][v][0]) && isfinite(V[i][v][1]) && isfinite(V[i][v][2]) &&
                                !sc_ref_contains(V[i][v], c, r2))
                                contain_fail++;
                        int rok = circ ? sc_ref_circumsphere(V[i][0], V[i][1], V[i][2], &ref)
                                       : sc_ref_minimal_sphere(V[i][0], V[i][1], V[i][2], &ref);
                        if (rok && isfinite(r2) && !r2_within_bound(&ref, c, r2, u, DBL_MIN))
                            bound_fail++;
                    }
                    if (!same && isfinite(s.r2) && isfinite(r2) && (circ || k == SC_BATCH_PREFILTER_MINIMAL) &&
                        (circ ? sc_ref_circumsphere(V[i][0], V[i][1], V[i][2], &ref)
                              : sc_ref_minimal_sphere(V[i][0], V[i][1], V[i][2], &ref))) {
                        double e = sc_ref_centre_error(&ref, c), es = sc_ref_centre_error(&ref, s.c);
                        if (!(e <= FMA_FACTOR * es + FMA_FLOOR_U * u +
                                   FMA_COND_U * u * sc_ref_condition(V[i][0], V[i][1], V[i][2])))
                            bound_fail++;
                    }
                }
            }
    }
    sc_ref_sphere_clear(&ref);
    print_message("double %s: %zu spheres, %zu bit-identical, %zu containment failures, %zu bound failures\n",
                  sc_isa_name(g_isa), total, identical, contain_fail, bound_fail);
    free(V), free(out), free(idx);
    assert_int_equal(contain_fail, 0);
    assert_int_equal(bound_fail, 0);
}

/* ---- fast path against the general path --------------------------------- */

/* Runs the active level's kernel on SoA copies of V (float or double). */
static void kernel_f(const sc_sphere_kernels *k, float (*V)[3][3], size_t n, int method, int kind, unsigned flags,
                     float *out, size_t pad)
{
    float *in = malloc(sizeof(float) * 9 * (n ? n : 1));
    sc_tri_source_f src;
    memset(&src, 0, sizeof src);
    for (int v = 0; v < 3; v++)
        for (int a = 0; a < 3; a++) {
            float *col = in + (size_t)(3 * v + a) * n;
            for (size_t i = 0; i < n; i++)
                col[i] = V[i][v][a];
            src.soa[v][a] = col;
        }
    sc_spheres_soaf o = { out, out + pad, out + 2 * pad, out + 3 * pad };
    k->spheres_f(&src, n, method, kind, flags, &o);
    free(in);
}

static void kernel_d(const sc_sphere_kernels *k, double (*V)[3][3], size_t n, int method, int kind, unsigned flags,
                     double *out, size_t pad)
{
    double *in = malloc(sizeof(double) * 9 * (n ? n : 1));
    sc_tri_source_d src;
    memset(&src, 0, sizeof src);
    for (int v = 0; v < 3; v++)
        for (int a = 0; a < 3; a++) {
            double *col = in + (size_t)(3 * v + a) * n;
            for (size_t i = 0; i < n; i++)
                col[i] = V[i][v][a];
            src.soa[v][a] = col;
        }
    sc_spheres_soad o = { out, out + pad, out + 2 * pad, out + 3 * pad };
    k->spheres_d(&src, n, method, kind, flags, &o);
    free(in);
}

/* Every family interleaved, so most vectors hold fast and general lanes
 * together: the fast path must give, lane by lane, the general path's bits
 * (SC_KFLAG_GENERAL), and each lane the bits it gets alone in a batch of
 * one (a lane never depends on its neighbours). */
static void test_fast_path_matches_general(void **state)
{
    (void)state;
    NEED_ISA();
    const sc_sphere_kernels *k = sc_kernels_for(g_isa)->sphere;
    enum { PER = 120, N = PER * SC_FAM_COUNT };
    size_t pad = sc_simd_padded(N);
    sc_rng rng;
    sc_rng_seed(&rng, 31337);
    float (*Vf)[3][3] = malloc(sizeof(float) * 9 * N);
    double (*Vd)[3][3] = malloc(sizeof(double) * 9 * N);
    for (int i = 0; i < N; i++) {
        gen_triangle((sc_family)(i % SC_FAM_COUNT), &rng, 1, Vd[i]);
        for (int v = 0; v < 3; v++)
            for (int a = 0; a < 3; a++)
                Vf[i][v][a] = (float)Vd[i][v][a];
    }
    float *f1 = malloc(sizeof(float) * 4 * pad), *f2 = malloc(sizeof(float) * 4 * pad), f3[64];
    double *d1 = malloc(sizeof(double) * 4 * pad), *d2 = malloc(sizeof(double) * 4 * pad), d3[64];
    size_t lanes = 0, differ = 0, alone_differ = 0;
    for (int m = 0; m < SC_METHOD_COUNT; m++)
        for (int kind = SC_BATCH_PREFILTER_CIRCUM; kind <= SC_BATCH_PREFILTER_MINIMAL; kind++) {
            kernel_f(k, Vf, N, m, kind, 0, f1, pad);
            kernel_f(k, Vf, N, m, kind, SC_KFLAG_GENERAL, f2, pad);
            kernel_d(k, Vd, N, m, kind, 0, d1, pad);
            kernel_d(k, Vd, N, m, kind, SC_KFLAG_GENERAL, d2, pad);
            for (size_t i = 0; i < N; i++) {
                for (int j = 0; j < 4; j++) {
                    differ += !same_bits_f(f1[j * pad + i], f2[j * pad + i]);
                    differ += !same_bits_d(d1[j * pad + i], d2[j * pad + i]);
                }
                lanes += 2;
                if (i % 7 == 0) {
                    kernel_f(k, &Vf[i], 1, m, kind, 0, f3, 16);
                    kernel_d(k, &Vd[i], 1, m, kind, 0, d3, 16);
                    for (int j = 0; j < 4; j++) {
                        alone_differ += !same_bits_f(f1[j * pad + i], f3[j * 16]);
                        alone_differ += !same_bits_d(d1[j * pad + i], d3[j * 16]);
                    }
                }
            }
        }
    print_message("%zu conservative spheres (mixed families): %zu values differ from the general path, "
                  "%zu from the same triangle alone\n", lanes, differ, alone_differ);
    free(Vf), free(Vd), free(f1), free(f2), free(d1), free(d2);
    assert_int_equal(differ, 0);
    assert_int_equal(alone_differ, 0);
}

/* Past SC_STREAM_MIN_COUNT the kernels stream their stores (aligned output)
 * and prefetch vertices (indexed input): same bits as plain stores, as an
 * unaligned output (which cannot stream), and as the SoA input. */
static void test_streaming_large_batch(void **state)
{
    (void)state;
    NEED_ISA();
    const sc_sphere_kernels *k = sc_kernels_for(g_isa)->sphere;
    const size_t n = SC_STREAM_MIN_COUNT + 21, pad = sc_simd_padded(n);
    sc_rng rng;
    sc_rng_seed(&rng, 8);
    float *verts = malloc(sizeof(float) * 9 * n), *soa = malloc(sizeof(float) * 9 * n);
    uint32_t *idx = malloc(sizeof(uint32_t) * 3 * n);
    for (size_t i = 0; i < 3 * n; i++)
        idx[i] = (uint32_t)i;
    for (size_t i = n; i-- > 1;) {            /* shuffled triangle order */
        size_t j = (size_t)(sc_rng_next(&rng) % (i + 1));
        for (int v = 0; v < 3; v++) {
            uint32_t t = idx[3 * i + (size_t)v];
            idx[3 * i + (size_t)v] = idx[3 * j + (size_t)v], idx[3 * j + (size_t)v] = t;
        }
    }
    for (size_t i = 0; i < n; i++) {
        double V[3][3];
        gen_triangle(i % 97 ? SC_FAM_RANDOM : (sc_family)(i % SC_FAM_COUNT), &rng, 1, V);
        for (int v = 0; v < 3; v++)
            for (int a = 0; a < 3; a++)
                verts[9 * i + 3 * (size_t)v + (size_t)a] = (float)V[v][a];
    }
    sc_tri_source_f s_soa, s_idx;
    memset(&s_soa, 0, sizeof s_soa);
    for (int v = 0; v < 3; v++)
        for (int a = 0; a < 3; a++) {
            for (size_t i = 0; i < n; i++)
                soa[(size_t)(3 * v + a) * n + i] = verts[3 * idx[3 * i + (size_t)v] + (size_t)a];
            s_soa.soa[v][a] = soa + (size_t)(3 * v + a) * n;
        }
    s_idx = (sc_tri_source_f){ verts, 3 * n, idx, { { 0 } } };
    float *a = aligned_alloc(64, sizeof(float) * 4 * pad), *b = aligned_alloc(64, sizeof(float) * 4 * pad);
    float *c = aligned_alloc(64, sizeof(float) * (4 * pad + 16)), *d = aligned_alloc(64, sizeof(float) * 4 * pad);
    size_t mismatches = 0;
    for (int kind = 0; kind < SC_BATCH_KIND_COUNT; kind++) {
        sc_spheres_soaf oa = { a, a + pad, a + 2 * pad, a + 3 * pad }, ob = { b, b + pad, b + 2 * pad, b + 3 * pad };
        sc_spheres_soaf oc = { c + 1, c + 1 + pad, c + 1 + 2 * pad, c + 1 + 3 * pad };   /* misaligned */
        sc_spheres_soaf od = { d, d + pad, d + 2 * pad, d + 3 * pad };
        assert_int_equal(k->spheres_f(&s_soa, n, SC_METHOD_TEXTBOOK, kind, 0, &oa), 0);
        assert_int_equal(k->spheres_f(&s_soa, n, SC_METHOD_TEXTBOOK, kind, SC_KFLAG_NO_STREAM, &ob), 0);
        assert_int_equal(k->spheres_f(&s_soa, n, SC_METHOD_TEXTBOOK, kind, 0, &oc), 0);
        assert_int_equal(k->spheres_f(&s_idx, n, SC_METHOD_TEXTBOOK, kind, 0, &od), 0);
        mismatches += memcmp(a, b, sizeof(float) * 4 * pad) != 0;
        mismatches += memcmp(a, c + 1, sizeof(float) * 4 * pad) != 0;
        mismatches += memcmp(a, d, sizeof(float) * 4 * pad) != 0;
        for (size_t i = n; i < pad; i++)
            mismatches += !(a[3 * pad + i] == -1 && a[i] == 0);
    }
    free(verts), free(soa), free(idx), free(a), free(b), free(c), free(d);
    assert_int_equal(mismatches, 0);
}

/* ---- tails, guard pages, bad input -------------------------------------- */

static void test_tails_guard_pages(void **state)
{
    (void)state;
    NEED_ISA();
    sc_rng rng;
    sc_rng_seed(&rng, 5);
    for (size_t n = 0; n <= 70; n += (n < 40 ? 1 : 7)) {
        size_t pad = sc_simd_padded(n);
        sc_guard gv, gi, gs[9], go[4], gd[4];
        float *verts = sc_guard_alloc(&gv, sizeof(float) * 9 * n);
        uint32_t *idx = sc_guard_alloc(&gi, sizeof(uint32_t) * 3 * n);
        assert_non_null(verts);
        assert_non_null(idx);
        sc_triangles_soaf tri;
        float *soa[9];
        for (int j = 0; j < 9; j++) {
            soa[j] = sc_guard_alloc(&gs[j], sizeof(float) * n);
            assert_non_null(soa[j]);
        }
        for (int k = 0; k < 3; k++)
            tri.x[k] = soa[3 * k], tri.y[k] = soa[3 * k + 1], tri.z[k] = soa[3 * k + 2];
        for (size_t i = 0; i < n; i++)
            for (int k = 0; k < 3; k++) {
                idx[3 * i + (size_t)k] = (uint32_t)(3 * (n - 1 - i) + (size_t)k);   /* reversed */
                for (int a = 0; a < 3; a++)
                    verts[9 * i + 3 * (size_t)k + (size_t)a] = (float)sc_rng_range(&rng, -10, 10);
            }
        for (size_t i = 0; i < n; i++)
            for (int k = 0; k < 3; k++)
                for (int a = 0; a < 3; a++)
                    soa[3 * k + a][i] = verts[3 * idx[3 * i + (size_t)k] + (size_t)a];
        float *o1[4], *o2[4];
        for (int j = 0; j < 4; j++) {
            o1[j] = sc_guard_alloc(&go[j], sizeof(float) * pad);
            o2[j] = sc_guard_alloc(&gd[j], sizeof(float) * pad);
            assert_true(o1[j] && o2[j]);
        }
        sc_spheres_soaf out1 = { o1[0], o1[1], o1[2], o1[3] }, out2 = { o2[0], o2[1], o2[2], o2[3] };
        for (int kind = 0; kind < SC_BATCH_KIND_COUNT; kind++) {
            assert_int_equal(sc_spheres_indexed_f(verts, 3 * n, idx, n, SC_METHOD_TEXTBOOK,
                                                  (sc_batch_kind)kind, &out1), SC_OK);
            assert_int_equal(sc_spheres_soa_f(&tri, n, SC_METHOD_TEXTBOOK, (sc_batch_kind)kind, &out2), SC_OK);
            for (int j = 0; j < 4; j++)
                assert_memory_equal(o1[j], o2[j], sizeof(float) * pad);
            for (size_t i = n; i < pad; i++)
                assert_true(o1[3][i] == -1 && o1[0][i] == 0);
            for (size_t i = 0; i < n; i++) {
                float V[3][3];
                for (int k = 0; k < 3; k++)
                    for (int a = 0; a < 3; a++)
                        V[k][a] = soa[3 * k + a][i];
                sc_spheref s;
                spec_f((const float(*)[3])V, SC_METHOD_TEXTBOOK, kind, &s);
                assert_true(fabsf(s.r2 - o1[3][i]) <= 1e-4f * s.r2);
            }
        }
        /* One out-of-range index: that triangle never rejects, the rest are kept. */
        if (n > 0) {
            idx[3 * (n / 2) + 1] = (uint32_t)(3 * n);
            assert_int_equal(sc_spheres_indexed_f(verts, 3 * n, idx, n, SC_METHOD_CRAMER,
                                                  SC_BATCH_PREFILTER_MINIMAL, &out1), SC_ERR_INVALID_ARGUMENT);
            for (size_t i = 0; i < n; i++)
                assert_true(i == n / 2 ? isinf(o1[3][i]) : isfinite(o1[3][i]));
        }
        for (int j = 0; j < 9; j++)
            sc_guard_free(&gs[j]);
        for (int j = 0; j < 4; j++)
            sc_guard_free(&go[j]), sc_guard_free(&gd[j]);
        sc_guard_free(&gv), sc_guard_free(&gi);
    }
}

static void test_bad_arguments(void **state)
{
    (void)state;
    NEED_ISA();
    float buf[64];
    sc_spheres_soaf out = { buf, buf + 16, buf + 32, buf + 48 };
    float v[9] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
    uint32_t idx[3] = { 0, 1, 2 };
    assert_int_equal(sc_spheres_indexed_f(v, 3, idx, 1, SC_METHOD_COUNT, SC_BATCH_CIRCUM, &out), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_spheres_indexed_f(v, 3, idx, 1, SC_METHOD_TEXTBOOK, SC_BATCH_KIND_COUNT, &out), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_spheres_indexed_f(v, 3, NULL, 1, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, &out), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_spheres_indexed_f(v, 3, idx, 1, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_spheres_indexed_f(v, 0, idx, 1, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, &out), SC_ERR_INVALID_ARGUMENT);
    assert_true(isinf(out.r2[0]));
    assert_int_equal(sc_spheres_indexed_f(v, SC_SIMD_MAX_VERTICES + 1, idx, 1, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, &out), SC_ERR_LIMIT);
    assert_int_equal(sc_spheres_soa_f(NULL, 1, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, &out), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_spheres_indexed_f(v, 3, idx, 1, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, &out), SC_OK);
    assert_true(fabsf(out.r2[0] - 0.5f) < 1e-6f);
    assert_int_equal(sc_reject8(NULL, NULL), 0);
    assert_int_equal(sc_reject_packet16(NULL, NULL, 0), 0);
}

/* ---- reject masks ------------------------------------------------------- */

static float rand_float_wild(sc_rng *rng)
{
    switch (sc_rng_next(rng) % 16) {
    case 0: return NAN;
    case 1: return INFINITY;
    case 2: return -1.0f;
    case 3: return 0.0f;
    default: return (float)ldexp(sc_rng_uniform(rng), (int)(sc_rng_next(rng) % 40) - 20);
    }
}

static void random_ray(sc_rng *rng, sc_ray *r)
{
    for (int k = 0; k < 3; k++) {
        r->org[k] = (float)sc_rng_range(rng, -4, 4);
        r->dir[k] = (float)sc_rng_range(rng, -1, 1);
    }
    switch (sc_rng_next(rng) % 6) {
    case 0: r->tmin = 0, r->tmax = INFINITY; break;
    case 1: r->tmin = (float)sc_rng_range(rng, 0, 4), r->tmax = r->tmin + (float)sc_rng_range(rng, 0, 4); break;
    case 2: r->tmin = -INFINITY, r->tmax = INFINITY; break;
    case 3: r->tmin = rand_float_wild(rng), r->tmax = rand_float_wild(rng); break;
    case 4: r->tmin = 0, r->tmax = (float)sc_rng_range(rng, 0, 1); break;
    default: r->tmin = (float)sc_rng_range(rng, -2, 0), r->tmax = (float)sc_rng_range(rng, 0, 2); break;
    }
}

static void test_reject_masks_match_spec(void **state)
{
    (void)state;
    NEED_ISA();
    sc_rng rng;
    sc_rng_seed(&rng, 77);
    size_t rejected = 0, lanes = 0;
    for (int iter = 0; iter < 20000; iter++) {
        sc_ray ray;
        random_ray(&rng, &ray);
        sc_sphere_block16 b16;
        for (int i = 0; i < 16; i++) {
            b16.cx[i] = (float)sc_rng_range(&rng, -4, 4);
            b16.cy[i] = (float)sc_rng_range(&rng, -4, 4);
            b16.cz[i] = (float)sc_rng_range(&rng, -4, 4);
            b16.r2[i] = iter % 5 == 0 ? rand_float_wild(&rng) : (float)sc_rng_range(&rng, 0, 2);
        }
        sc_sphere_block8 b8;
        sc_sphere_block4 b4;
        memcpy(b8.cx, b16.cx, 32), memcpy(b8.cy, b16.cy, 32), memcpy(b8.cz, b16.cz, 32), memcpy(b8.r2, b16.r2, 32);
        memcpy(b4.cx, b16.cx, 16), memcpy(b4.cy, b16.cy, 16), memcpy(b4.cz, b16.cz, 16), memcpy(b4.r2, b16.r2, 16);
        uint32_t want = 0;
        for (int i = 0; i < 16; i++) {
            float c[3] = { b16.cx[i], b16.cy[i], b16.cz[i] };
            want |= (uint32_t)sc_ray_sphere_reject(&ray, c, b16.r2[i]) << i;
        }
        assert_int_equal(sc_reject16(&ray, &b16), want);
        assert_int_equal(sc_reject8(&ray, &b8), want & 0xff);
        assert_int_equal(sc_reject4(&ray, &b4), want & 0xf);
        rejected += (size_t)__builtin_popcount(want);
        lanes += 16;

        /* Packets: 16 rays against sphere 0. */
        sc_ray_packet16 p16;
        sc_ray_packet8 p8;
        sc_ray rays[16];
        for (int i = 0; i < 16; i++) {
            random_ray(&rng, &rays[i]);
            p16.ox[i] = rays[i].org[0], p16.oy[i] = rays[i].org[1], p16.oz[i] = rays[i].org[2];
            p16.dx[i] = rays[i].dir[0], p16.dy[i] = rays[i].dir[1], p16.dz[i] = rays[i].dir[2];
            p16.tmin[i] = rays[i].tmin, p16.tmax[i] = rays[i].tmax;
        }
        memcpy(p8.ox, p16.ox, 32), memcpy(p8.oy, p16.oy, 32), memcpy(p8.oz, p16.oz, 32);
        memcpy(p8.dx, p16.dx, 32), memcpy(p8.dy, p16.dy, 32), memcpy(p8.dz, p16.dz, 32);
        memcpy(p8.tmin, p16.tmin, 32), memcpy(p8.tmax, p16.tmax, 32);
        float c[3] = { b16.cx[0], b16.cy[0], b16.cz[0] };
        uint32_t pw = 0;
        for (int i = 0; i < 16; i++)
            pw |= (uint32_t)sc_ray_sphere_reject(&rays[i], c, b16.r2[0]) << i;
        assert_int_equal(sc_reject_packet16(&p16, c, b16.r2[0]), pw);
        assert_int_equal(sc_reject_packet8(&p8, c, b16.r2[0]), pw & 0xff);
    }
    print_message("%zu of %zu lanes rejected, all bit-identical to the specification\n", rejected, lanes);
    assert_true(rejected > lanes / 10 && rejected < lanes);
}

/* Rays aimed at vertices, edges, the interior, and grazing the plane, from
 * near and far; every ray the exact oracle says hits must survive the SIMD
 * spheres and masks. */
static void test_no_false_rejects(void **state)
{
    (void)state;
    NEED_ISA();
    sc_rng rng;
    sc_rng_seed(&rng, 4242);
    enum { NT = 160 };
    size_t hits = 0, rays_tested = 0, false_rejects = 0, rejected_misses = 0;
    static const sc_family fams[] = {
        SC_FAM_RANDOM, SC_FAM_CAP_1E6, SC_FAM_NEEDLE_1E6, SC_FAM_FAR_1E4, SC_FAM_FAR_1E5,
        SC_FAM_SCALE_1EM20, SC_FAM_SCALE_1EM30, SC_FAM_SCALE_1E18, SC_FAM_RIGHT, SC_FAM_DUPLICATE, SC_FAM_COLLINEAR,
        SC_FAM_SUBNORMAL,
    };
    for (size_t fi = 0; fi < sizeof fams / sizeof fams[0]; fi++) {
        float (*V)[3][3] = malloc(sizeof(float) * 9 * NT);
        for (int i = 0; i < NT; i++) {
            double Vd[3][3];
            unsigned csr = sc_test_ftz_off();
            gen_triangle(fams[fi], &rng, 1, Vd);
            for (int k = 0; k < 3; k++)
                for (int a = 0; a < 3; a++)
                    V[i][k][a] = (float)Vd[k][a];
            sc_test_ftz_restore(csr);
        }
        size_t pad = sc_simd_padded(NT);
        float *out = malloc(sizeof(float) * 4 * pad);
        for (int kind = SC_BATCH_PREFILTER_CIRCUM; kind <= SC_BATCH_PREFILTER_MINIMAL; kind++) {
            int method = (int)(sc_rng_next(&rng) % SC_METHOD_COUNT);
            run_batch_f(NT, V, method, kind, out);
            for (int i = 0; i < NT; i++) {
                const float *A = V[i][0], *B = V[i][1], *C = V[i][2];
                double size = 0;
                for (int a = 0; a < 3; a++)
                    size = fmax(size, fmax(fabs((double)A[a] - C[a]), fabs((double)B[a] - C[a])));
                if (size == 0)
                    size = fmax(fabs((double)A[0]), 1e-30);
                for (int r = 0; r < 14; r++) {
                    /* Rays and the oracle's verdict with gradual underflow;
                     * only the kernels below run in the mode under test. */
                    unsigned csr = sc_test_ftz_off();
                    /* Target: vertex, edge point, interior point, or a plane-grazing origin. */
                    double s = sc_rng_uniform(&rng), t = sc_rng_uniform(&rng);
                    double T[3];
                    int which = r < 12 ? r % 4 : 4;
                    for (int a = 0; a < 3; a++) {
                        if (which == 0)
                            T[a] = V[i][r % 3][a];
                        else if (which == 1)
                            T[a] = A[a] + s * ((double)B[a] - A[a]);
                        else
                            T[a] = C[a] + s * ((double)A[a] - C[a]) + (1 - s) * t * ((double)B[a] - C[a]);
                    }
                    if (which == 4)          /* well beside the triangle: should mostly be rejected */
                        for (int a = 0; a < 3; a++)
                            T[a] += 4 * size * sc_rng_range(&rng, -1, 1);
                    double dist = size * ldexp(1, (int)(sc_rng_next(&rng) % 40) - 4);
                    double dirn[3];
                    for (int a = 0; a < 3; a++)
                        dirn[a] = sc_rng_range(&rng, -1, 1);
                    if (which == 3) {
                        /* Grazing: along an edge plus a tiny normal part. */
                        double ab[3], ac[3], nrm[3];
                        for (int a = 0; a < 3; a++)
                            ab[a] = (double)B[a] - A[a], ac[a] = (double)C[a] - A[a];
                        nrm[0] = ab[1] * ac[2] - ab[2] * ac[1];
                        nrm[1] = ab[2] * ac[0] - ab[0] * ac[2];
                        nrm[2] = ab[0] * ac[1] - ab[1] * ac[0];
                        double nl = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
                        double ablen = sqrt(ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]);
                        double eps = ldexp(1, -(int)(sc_rng_next(&rng) % 24));
                        for (int a = 0; a < 3; a++)
                            dirn[a] = (ablen > 0 ? ab[a] / ablen : dirn[a]) + (nl > 0 ? eps * nrm[a] / nl : 0);
                    }
                    sc_ray ray;
                    double O[3], D[3];
                    for (int a = 0; a < 3; a++) {
                        /* Through volatile: GCC 12 at -O3 was seen to keep the
                         * unrounded double here (docs/numerics.md), handing the
                         * oracle a different ray than the kernel's. */
                        volatile float of = (float)(T[a] - dist * dirn[a]);
                        ray.org[a] = of;
                        volatile float df = (float)(T[a] - (double)ray.org[a]);
                        ray.dir[a] = df;
                        O[a] = of, D[a] = df;
                    }
                    ray.tmin = 0;
                    ray.tmax = INFINITY;
                    if (r % 3 == 1) {
                        ray.tmax = 1;         /* the target itself at t ~ 1 */
                    } else if (r % 3 == 2) {
                        ray.tmin = nextafterf(1, 0);
                        ray.tmax = 2;
                    }
                    if (!isfinite(ray.org[0] + ray.org[1] + ray.org[2] + ray.dir[0] + ray.dir[1] + ray.dir[2])) {
                        sc_test_ftz_restore(csr);
                        continue;
                    }
                    rays_tested++;
                    int hit = sc_ref_ray_triangle(O, D, ray.tmin, ray.tmax, (double[3]){ A[0], A[1], A[2] },
                                                  (double[3]){ B[0], B[1], B[2] },
                                                  (double[3]){ C[0], C[1], C[2] }, NULL);
                    sc_test_ftz_restore(csr);
                    sc_sphere_block16 b;
                    sc_sphere_block16_init(&b);
                    int lane = i % 16;
                    b.cx[lane] = out[i], b.cy[lane] = out[pad + i], b.cz[lane] = out[2 * pad + i];
                    b.r2[lane] = out[3 * pad + i];
                    uint32_t m16 = sc_reject16(&ray, &b);
                    int rej = (int)((m16 >> lane) & 1);
                    sc_sphere_block8 b8;
                    sc_sphere_block8_init(&b8);
                    sc_spheref sp = { { b.cx[lane], b.cy[lane], b.cz[lane] }, b.r2[lane] };
                    sc_sphere_block8_set(&b8, lane % 8, &sp);
                    int rej8 = (int)((sc_reject8(&ray, &b8) >> (lane % 8)) & 1);
                    assert_int_equal(rej, rej8);
                    if (hit) {
                        hits++;
                        if (rej) {
                            false_rejects++;
                            if (false_rejects <= 3)
                                print_message("false reject: %s tri %d ray %d: O %a %a %a D %a %a %a t [%a %a] "
                                              "A %a %a %a B %a %a %a C %a %a %a c %a %a %a r2 %a\n",
                                              sc_family_name(fams[fi]), i, r, ray.org[0], ray.org[1], ray.org[2],
                                              ray.dir[0], ray.dir[1], ray.dir[2], ray.tmin, ray.tmax, A[0], A[1],
                                              A[2], B[0], B[1], B[2], C[0], C[1], C[2], sp.c[0], sp.c[1], sp.c[2],
                                              sp.r2);
                        }
                    } else {
                        rejected_misses += (size_t)rej;
                    }
                }
            }
        }
        free(V);
        free(out);
    }
    print_message("%zu rays, %zu exact hits, %zu false rejects, %zu misses rejected\n", rays_tested, hits,
                  false_rejects, rejected_misses);
    assert_int_equal(false_rejects, 0);
    assert_true(hits > rays_tested / 5);
    assert_true(rejected_misses > 0);
}

int main(int argc, char **argv)
{
    const char *name = argc > 1 ? argv[1] : getenv("SPHERECULL_ISA");
    if (!name || sc_isa_from_name(name, &g_isa) != SC_OK) {
        fprintf(stderr, "usage: test_simd scalar|sse4|avx2|avx512 (and SPHERECULL_ISA to match)\n");
        return 2;
    }
    sc_status st = sc_simd_init();
    g_supported = sc_isa_supported(g_isa);
    if (g_supported && st != SC_OK) {
        fprintf(stderr, "SPHERECULL_ISA=%s refused: %s\n", getenv("SPHERECULL_ISA"), sc_strerror(st));
        return 1;
    }
    if (g_supported && sc_isa_active() != g_isa) {
        /* Run without the environment (e.g. by hand): force the level. */
        if (sc_isa_force(g_isa) != SC_OK)
            return 1;
    }
    if (!g_supported)
        fprintf(stderr, "ISA level %s: not supported by this CPU or build, tests skipped\n", name);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_reject_masks_match_spec),
        cmocka_unit_test(test_tails_guard_pages),
        cmocka_unit_test(test_batch_float),
        cmocka_unit_test(test_batch_double),
        cmocka_unit_test(test_fast_path_matches_general),
        cmocka_unit_test(test_streaming_large_batch),
        cmocka_unit_test(test_no_false_rejects),
    };
    int failed = cmocka_run_group_tests_name(sc_isa_name(g_isa), tests, NULL, NULL);
    if (failed)
        return failed;
    return g_supported ? 0 : 77;
}

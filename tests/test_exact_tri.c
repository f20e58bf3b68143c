/* The exact-decision triangle test (SC_TRI_EXACT) against exact references.
 *
 *   - the fixed-point predicates (vol sign, hit, t order) against MPFR on
 *     configurations with exact zeros (lattice points, rays exactly through
 *     vertices and edges), near misses of a few ulps, grazing rays, scales
 *     from 2^-60 to 2^60 and far origins;
 *   - the whole tracer (float filter with error bounds -> double filter ->
 *     exact fallback) on tiny scenes of 1..3 triangles built to defeat a
 *     float test: every hit/miss, every range decision (tmin / tmax set to
 *     the float neighbours of the exact t) and every choice between two
 *     triangles at nearly or exactly the same t must be MPFR's, for every
 *     ISA, closest and any-hit;
 *   - procedural closed and open meshes with the adversarial, random and
 *     segment ray sets judged by the exact oracle (src/compare/oracle.c):
 *     0 hit/miss and 0 primID disagreements outside the tie sets, for every
 *     ISA, prefilter mode and leaf size; the watertight test on the same
 *     rays shows what is being fixed;
 *   - the shared meshes in $SC_TEST_SCENES (skipped when absent).
 */
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include <mpfr.h>

#include "common/sc_rng.h"
#include "compare/oracle.h"
#include "scene/procedural.h"
#include "sc_ref_ray.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_scene.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_trace.h"
#include "trace/tri_exact.h"

#include "sc_ftz.h"
#include "sc_test_meshes.h"
#include "sc_test_checked.h"

static const int LEAVES[] = { 1, 4, 16 };

/* ---- MPFR references ------------------------------------------------------ */

/* sign of D.((P-O) x (Q-O)): every float is exact at 2000 bits and so is
 * every difference and product of the (bounded-exponent) inputs here */
static int mp_vol_sign_gradual(const sc_ray *r, const float P[3], const float Q[3])
{
    mpfr_t a[3], b[3], d[3], x, y, s;
    mpfr_inits2(2000, x, y, s, (mpfr_ptr)0);
    for (int k = 0; k < 3; k++) {
        mpfr_inits2(2000, a[k], b[k], d[k], (mpfr_ptr)0);
        mpfr_set_flt(a[k], P[k], MPFR_RNDN), mpfr_sub_d(a[k], a[k], r->org[k], MPFR_RNDN);
        mpfr_set_flt(b[k], Q[k], MPFR_RNDN), mpfr_sub_d(b[k], b[k], r->org[k], MPFR_RNDN);
        mpfr_set_flt(d[k], r->dir[k], MPFR_RNDN);
    }
    mpfr_set_zero(s, 1);
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        mpfr_mul(x, a[j], b[k], MPFR_RNDN);
        mpfr_mul(y, a[k], b[j], MPFR_RNDN);
        mpfr_sub(x, x, y, MPFR_RNDN);
        mpfr_mul(x, x, d[i], MPFR_RNDN);
        mpfr_add(s, s, x, MPFR_RNDN);
    }
    int sg = mpfr_sgn(s);
    for (int k = 0; k < 3; k++)
        mpfr_clears(a[k], b[k], d[k], (mpfr_ptr)0);
    mpfr_clears(x, y, s, (mpfr_ptr)0);
    return sg;
}

/* mp_vol_sign_gradual with gradual underflow whatever the mode under test
 * (sc_ftz.h): inputs and references never run flushed. */
static int mp_vol_sign(const sc_ray *r, const float P[3], const float Q[3])
{
    unsigned csr = sc_test_ftz_off();
    int res = mp_vol_sign_gradual(r, P, Q);
    sc_test_ftz_restore(csr);
    return res;
}

static int mp_hit_gradual(const sc_ray *r, const float v[9], mpfr_t t)
{
    const double O[3] = { r->org[0], r->org[1], r->org[2] }, D[3] = { r->dir[0], r->dir[1], r->dir[2] };
    const double A[3] = { v[0], v[1], v[2] }, B[3] = { v[3], v[4], v[5] }, C[3] = { v[6], v[7], v[8] };
    return sc_ref_ray_triangle_mpfr(O, D, r->tmin, r->tmax, A, B, C, t);
}

/* mp_hit_gradual with gradual underflow whatever the mode under test
 * (sc_ftz.h): inputs and references never run flushed. */
static int mp_hit(const sc_ray *r, const float v[9], mpfr_t t)
{
    unsigned csr = sc_test_ftz_off();
    int res = mp_hit_gradual(r, v, t);
    sc_test_ftz_restore(csr);
    return res;
}

/* ---- configurations ------------------------------------------------------- */

static float lattice(sc_rng *g, int span, int e)
{
    return (float)ldexp((double)((int)(sc_rng_next(g) % (2u * (unsigned)span + 1)) - span), e);
}

static float nudge(float x, int ulps)
{
    for (; ulps > 0; ulps--)
        x = nextafterf(x, INFINITY);
    for (; ulps < 0; ulps++)
        x = nextafterf(x, -INFINITY);
    return x;
}

/* The scale family under test: INT_MIN = mixed 2^-60 .. 2^40; else every
 * configuration at 2^g_scale_e (tiny 2^-66 ~ 1e-20 and 2^-100 ~ 1e-30, huge
 * 2^46 ~ 7e13: origins, up to 2^12 scales away, reach ~3e17, just below
 * sc_trace's 1e18 limit). */
static int g_scale_e = INT_MIN;
static size_t scale_from_state(void **state, size_t n)
{
    g_scale_e = *state ? *(const int *)*state : INT_MIN;
    return *state ? n / 4 : n;
}

typedef struct config {
    int n;                   /* triangles */
    float v[3][9];
    sc_ray ray;
} config;

/* One random configuration of kind k; s = the exponent of its scale. */
static void make_config_gradual(sc_rng *g, int k, config *c)
{
    int e = (int)sc_rng_range(g, -60, 40);    /* origins stay below 1e18 (sc_trace's limit) */
    if (g_scale_e != INT_MIN)
        e = g_scale_e;
    double sc = ldexp(1, e);
    memset(c, 0, sizeof *c);
    c->n = 1;
    c->ray.tmin = 0;
    c->ray.tmax = INFINITY;
    float *v = c->v[0];
    switch (k % 6) {
    case 0:   /* lattice: the ray exactly through a vertex or an edge point */
    case 1: {
        for (int j = 0; j < 9; j++)
            v[j] = lattice(g, 8, e - 3);
        float tgt[3];
        int a = (int)(sc_rng_next(g) % 3), b = (a + 1) % 3;
        for (int j = 0; j < 3; j++)
            tgt[j] = k % 6 == 0 ? v[3 * a + j] : (float)(0.5 * ((double)v[3 * a + j] + v[3 * b + j]));
        for (int j = 0; j < 3; j++) {
            c->ray.org[j] = lattice(g, 16, e - 2);
            c->ray.dir[j] = (float)((double)tgt[j] - c->ray.org[j]);
        }
        if (k % 6 == 1 && sc_rng_uniform(g) < 0.5) {     /* a few ulps off */
            int ax = (int)(sc_rng_next(g) % 3);
            c->ray.dir[ax] = nudge(c->ray.dir[ax], (int)sc_rng_range(g, -3, 4));
        }
        break;
    }
    case 2: { /* generic float triangle, ray through a vertex of it (rounded), far origin */
        for (int j = 0; j < 9; j++)
            v[j] = (float)(sc * sc_rng_range(g, -1, 1));
        int a = (int)(sc_rng_next(g) % 3);
        double far = ldexp(1, (int)sc_rng_range(g, 0, 12));
        for (int j = 0; j < 3; j++) {
            c->ray.org[j] = (float)(v[3 * a + j] + far * sc * sc_rng_range(g, -1, 1));
            c->ray.dir[j] = nudge((float)((double)v[3 * a + j] - c->ray.org[j]), (int)sc_rng_range(g, -2, 3));
        }
        break;
    }
    case 3: { /* grazing: direction along an edge, tilted by ~2^-20..2^-40 */
        for (int j = 0; j < 9; j++)
            v[j] = (float)(sc * sc_rng_range(g, -1, 1));
        double n[3], e1[3], e2[3];
        for (int j = 0; j < 3; j++)
            e1[j] = (double)v[3 + j] - v[j], e2[j] = (double)v[6 + j] - v[j];
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), el = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
        double tilt = ldexp(sc_rng_range(g, -1, 1), -(int)sc_rng_range(g, 20, 40));
        double w0 = sc_rng_range(g, 0.1, 0.9), w1 = sc_rng_range(g, 0, 1 - w0);
        for (int j = 0; j < 3; j++) {
            double p = v[j] + w0 * e1[j] + w1 * e2[j];          /* a point inside */
            double dd = e1[j] + tilt * el * n[j] / nl;
            c->ray.dir[j] = (float)dd;
            c->ray.org[j] = (float)(p - sc_rng_range(g, 0.5, 4) * dd);
        }
        break;
    }
    case 4: { /* range: tmin or tmax at a float neighbour of the exact t */
        for (int j = 0; j < 9; j++)
            v[j] = (float)(sc * sc_rng_range(g, -1, 1));
        double w0 = sc_rng_range(g, 0.05, 0.9), w1 = sc_rng_range(g, 0.05, 0.95 - w0);
        for (int j = 0; j < 3; j++) {
            double p = v[j] + w0 * ((double)v[3 + j] - v[j]) + w1 * ((double)v[6 + j] - v[j]);
            c->ray.dir[j] = (float)(sc * sc_rng_range(g, -1, 1));
            c->ray.org[j] = (float)(p - sc_rng_range(g, 0.5, 4) * c->ray.dir[j]);
        }
        double t;
        const double O[3] = { c->ray.org[0], c->ray.org[1], c->ray.org[2] };
        const double D[3] = { c->ray.dir[0], c->ray.dir[1], c->ray.dir[2] };
        const double A[3] = { v[0], v[1], v[2] }, B[3] = { v[3], v[4], v[5] }, C[3] = { v[6], v[7], v[8] };
        if (sc_ref_ray_triangle(O, D, 0, INFINITY, A, B, C, &t)) {
            float ft = nudge((float)t, (int)sc_rng_range(g, -1, 2));
            if (sc_rng_uniform(g) < 0.5)
                c->ray.tmax = ft;
            else
                c->ray.tmin = ft > 0 ? ft : 0;
        }
        break;
    }
    default: { /* order: a second (and third) triangle at nearly the same t */
        for (int j = 0; j < 9; j++)
            v[j] = (float)(sc * sc_rng_range(g, -1, 1));
        c->n = 2 + (int)(sc_rng_next(g) % 2);
        for (int q = 1; q < c->n; q++) {
            int how = (int)(sc_rng_next(g) % 3);
            for (int j = 0; j < 9; j++)
                c->v[q][j] = how == 0 ? v[j] : nudge(v[j], (int)sc_rng_range(g, -2, 3));
            if (how == 2) {           /* a neighbour across edge 0-1 */
                for (int j = 0; j < 3; j++)
                    c->v[q][6 + j] = (float)((double)v[j] + v[3 + j] - v[6 + j]);
                for (int j = 0; j < 6; j++)
                    c->v[q][j] = v[j];
            }
        }
        double w = sc_rng_range(g, 0, 1);
        for (int j = 0; j < 3; j++) {
            double p = sc_rng_uniform(g) < 0.5 ? v[j] + w * ((double)v[3 + j] - v[j])      /* on edge 0-1 */
                                               : (v[j] + v[3 + j] + v[6 + j]) / 3.0;
            c->ray.dir[j] = (float)(sc * sc_rng_range(g, -1, 1));
            c->ray.org[j] = (float)(p - sc_rng_range(g, 0.5, 4) * c->ray.dir[j]);
        }
        break;
    }
    }
    if (c->ray.dir[0] == 0 && c->ray.dir[1] == 0 && c->ray.dir[2] == 0)
        c->ray.dir[2] = 1;
}

/* make_config_gradual with gradual underflow whatever the mode under test
 * (sc_ftz.h): inputs and references never run flushed. */
static void make_config(sc_rng *g, int k, config *c)
{
    unsigned csr = sc_test_ftz_off();
    make_config_gradual(g, k, c);
    sc_test_ftz_restore(csr);
}

/* ---- the predicates ------------------------------------------------------- */

static void test_predicates_vs_mpfr(void **state)
{
    (void)state;
    sc_rng g;
    sc_rng_seed(&g, 101);
    size_t zeros = 0, n = scale_from_state(state, 60000), hits = 0, ties = 0;
    mpfr_t ta, tb;
    mpfr_inits2(64, ta, tb, (mpfr_ptr)0);
    for (size_t i = 0; i < n; i++) {
        config c;
        make_config(&g, (int)i, &c);
        const float *v = c.v[0];
        for (int e = 0; e < 3; e++) {
            const float *P = v + 3 * ((e + 1) % 3), *Q = v + 3 * ((e + 2) % 3);
            int want = mp_vol_sign(&c.ray, P, Q);
            zeros += want == 0;
            assert_int_equal(sc_exact_vol_sign(&c.ray, P, Q), want);
        }
        int ha = mp_hit(&c.ray, v, ta);
        hits += ha;
        assert_int_equal(sc_exact_hit_test(&c.ray, v), ha);
        if (c.n > 1 && ha) {
            int hb = mp_hit(&c.ray, c.v[1], tb);
            assert_int_equal(sc_exact_hit_test(&c.ray, c.v[1]), hb);
            if (hb) {
                int want = mpfr_cmp(ta, tb);
                want = (want > 0) - (want < 0);
                ties += want == 0;
                assert_int_equal(sc_exact_cmp_t(&c.ray, v, c.v[1]), want);
                assert_int_equal(sc_exact_cmp_t(&c.ray, c.v[1], v), -want);
            }
        }
    }
    mpfr_clears(ta, tb, (mpfr_ptr)0);
    print_message("%zu configurations (scale %s2^%d): %zu exact-zero volumes, %zu hits, %zu exact t ties\n", n,
                  g_scale_e == INT_MIN ? "mixed, not " : "", g_scale_e == INT_MIN ? 0 : g_scale_e, zeros, hits, ties);
    assert_true(zeros > n / 10 && hits > n / 10 && ties > 100);
}

/* ---- the tracer on tiny scenes ------------------------------------------- */

/* The closest hit MPFR finds among the configuration's triangles: *best =
 * -1 on a miss; tie[i] = 1 for every triangle at the smallest exact t. */
static void mp_closest_gradual(const config *c, int *best, int tie[3])
{
    mpfr_t t[3];
    int h[3];
    *best = -1;
    for (int i = 0; i < c->n; i++) {
        mpfr_init2(t[i], 64);
        h[i] = mp_hit(&c->ray, c->v[i], t[i]);
        if (h[i] && (*best < 0 || mpfr_cmp(t[i], t[*best]) < 0))
            *best = i;
    }
    for (int i = 0; i < c->n; i++)
        tie[i] = *best >= 0 && h[i] && mpfr_cmp(t[i], t[*best]) == 0;
    for (int i = 0; i < c->n; i++)
        mpfr_clear(t[i]);
}

/* mp_closest_gradual with gradual underflow whatever the mode under test
 * (sc_ftz.h): inputs and references never run flushed. */
static void mp_closest(const config *c, int *best, int tie[3])
{
    unsigned csr = sc_test_ftz_off();
    mp_closest_gradual(c, best, tie);
    sc_test_ftz_restore(csr);
}

static void test_tiny_scenes(void **state)
{
    (void)state;
    sc_rng g;
    sc_rng_seed(&g, 202);
    size_t n = scale_from_state(state, 12000), bad_wt = 0, checked = 0;
    uint32_t idx[9] = { 0, 1, 2, 3, 4, 5, 6, 7, 8 };
    for (size_t i = 0; i < n; i++) {
        config c;
        make_config(&g, (int)i, &c);
        int best, tie[3];
        mp_closest(&c, &best, tie);
        for (int isa = SC_ISA_SCALAR; isa < SC_ISA_COUNT; isa++) {
            if (!sc_isa_supported((sc_isa)isa))
                continue;
            for (int tt = 0; tt < 2; tt++) {
                sc_bvh_config cfg;
                sc_bvh_config_default(&cfg);
                assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
                cfg.tri_test = tt ? SC_TRI_WATERTIGHT : SC_TRI_EXACT;
                sc_bvh *b;
                assert_int_equal(sc_bvh_build(&(sc_mesh_view){ &c.v[0][0], 3 * (size_t)c.n, idx, (size_t)c.n, 0, 0 }, &cfg, &b), SC_OK);
                sc_hitrec h;
                int occ;
                assert_int_equal(sc_trace_closest(b, &c.ray, &h, NULL), SC_OK);
                assert_int_equal(sc_trace_any(b, &c.ray, &occ, NULL), SC_OK);
                sc_bvh_free(b);
                int ok = (h.prim == SC_HITREC_MISS) == (best < 0) && occ == (best >= 0) &&
                         (best < 0 || (h.prim < 3 && tie[h.prim]));
                if (tt) {
                    bad_wt += !ok;
                    continue;
                }
                checked++;
                if (!ok)
                    print_message("config %zu (kind %zu) isa %s: prim %u occ %d, want %d\n", i, i % 6,
                                  sc_isa_name((sc_isa)isa), h.prim, occ, best);
                assert_true(ok);
                if (best >= 0)
                    assert_true(h.t >= c.ray.tmin && h.t <= c.ray.tmax);
            }
        }
    }
    print_message("%zu traced configurations (scale %s2^%d) agree with MPFR (watertight: %zu disagree)\n", checked,
                  g_scale_e == INT_MIN ? "mixed, not " : "", g_scale_e == INT_MIN ? 0 : g_scale_e, bad_wt);
    assert_true(bad_wt > 0);         /* the configurations do defeat a float test */
}

/* ---- meshes against the oracle -------------------------------------------- */

static void from_proc(mesh *m, sc_proc_mesh *pm, const double off[3], double scale)
{
    m->nv = pm->vertex_count, m->nt = pm->triangle_count;
    m->pos = pm->positions, m->idx = pm->indices;     /* taken over */
    for (uint32_t v = 0; v < m->nv; v++) {
        double p[3] = { m->pos[3 * v], m->pos[3 * v + 1], m->pos[3 * v + 2] };
        place(p, off, scale);
        for (int k = 0; k < 3; k++)
            m->pos[3 * v + k] = (float)p[k];
    }
}

/* Rays between lattice points of the box (axis-aligned, face and space
 * diagonals): they run along faces, through edges and vertices exactly. */
static void lattice_rays(int n, size_t count, uint64_t seed, sc_ray *out)
{
    sc_rng g;
    sc_rng_seed(&g, seed);
    for (size_t i = 0; i < count; i++) {
        sc_ray *r = &out[i];
        float a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = (float)((int)(sc_rng_next(&g) % (unsigned)(n + 5)) - 2);
            b[k] = (float)((int)(sc_rng_next(&g) % (unsigned)(n + 5)) - 2);
        }
        if (i % 3 == 0) {                 /* axis or face-diagonal directions */
            int ax = (int)(sc_rng_next(&g) % 3);
            b[ax] = a[ax];
            if (i % 2)
                b[(ax + 1) % 3] = a[(ax + 1) % 3];
        }
        for (int k = 0; k < 3; k++)
            r->org[k] = a[k], r->dir[k] = b[k] - a[k];
        if (r->dir[0] == 0 && r->dir[1] == 0 && r->dir[2] == 0)
            r->dir[2] = 1;
        r->tmin = i % 5 == 1 ? 0.5f : 0;
        r->tmax = i % 5 == 2 ? 1.0f : INFINITY;    /* ending exactly at a lattice point */
    }
}

typedef struct score {
    size_t rays, hits, hit_miss, primid, any_wrong, t_bad;
    double t_err;
} score;

static void judge(const sc_bvh *b, const sc_ray *rays, size_t n, const sc_oracle *o, score *s)
{
    memset(s, 0, sizeof *s);
    for (size_t i = 0; i < n; i++) {
        const sc_oracle_hit *h = &o->hits[i];
        sc_hitrec hr;
        int occ;
        assert_int_equal(sc_trace_closest(b, &rays[i], &hr, NULL), SC_OK);
        assert_int_equal(sc_trace_any(b, &rays[i], &occ, NULL), SC_OK);
        s->rays++;
        s->hits += (size_t)h->hit;
        int hit = hr.prim != SC_HITREC_MISS;
        s->any_wrong += occ != h->hit;
        if (hit != h->hit) {
            s->hit_miss++;
            continue;
        }
        if (!hit)
            continue;
        if (!sc_oracle_accepts(o, i, hr.prim))
            s->primid++;
        if (!(hr.t >= rays[i].tmin && hr.t <= rays[i].tmax))
            s->t_bad++;
        /* relative, absolute near t = 0 (an origin exactly on a face) */
        double e = fabs((double)hr.t - h->t) / fmax(fabs(h->t), 1e-6);
        if (e > s->t_err)
            s->t_err = e;
    }
}

/* Watertight disagreements seen on the mesh sets: the tests are not vacuous. */
static size_t g_wt_disagree;

static void run_rays(const char *name, const sc_mesh_view *m, const sc_ray *rays, size_t n, int all_configs)
{
    sc_oracle o;
    sc_checked_mesh cm = sc_test_checked(m);
    assert_int_equal(sc_oracle_run(&cm, rays, n, 2, 0, &o), SC_OK);
    {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        sc_bvh *b;
        assert_int_equal(sc_bvh_build(m, &cfg, &b),
                         SC_OK);
        score s;
        judge(b, rays, n, &o, &s);
        g_wt_disagree += s.hit_miss + s.primid;
        print_message("%-22s %6zu rays (%zu hit)  watertight: h/m %zu prim %zu any %zu\n", name, s.rays, s.hits,
                      s.hit_miss, s.primid, s.any_wrong);
        sc_bvh_free(b);
    }
    size_t configs = 0;
    for (int isa = SC_ISA_SCALAR; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        for (int pm = 0; pm < SC_PREFILTER_MODE_COUNT; pm++)
            for (size_t li = 0; li < 3; li++) {
                if (!all_configs && (pm != SC_PREFILTER_OFF || li != 1))
                    continue;
                sc_bvh_config cfg;
                sc_bvh_config_default(&cfg);
                assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
                cfg.prefilter = (sc_prefilter_mode)pm;
                cfg.leaf_size = LEAVES[li];
                cfg.tri_test = SC_TRI_EXACT;
                sc_bvh *b;
                assert_int_equal(
                    sc_bvh_build(m, &cfg, &b), SC_OK);
                score s;
                judge(b, rays, n, &o, &s);
                if (configs++ == 0 || s.hit_miss || s.primid || s.any_wrong || s.t_bad)
                    print_message("%-22s exact %s %s leaf %2d: h/m %zu prim %zu any %zu t outside %zu, "
                                  "t rel. err max %.1e\n",
                                  name, sc_isa_name((sc_isa)isa),
                                  sc_prefilter_mode_name((sc_prefilter_mode)pm), LEAVES[li], s.hit_miss, s.primid,
                                  s.any_wrong, s.t_bad, s.t_err);
                assert_true(s.hits > 0);
                assert_int_equal(s.hit_miss, 0);
                assert_int_equal(s.primid, 0);
                assert_int_equal(s.any_wrong, 0);
                assert_int_equal(s.t_bad, 0);
                assert_true(s.t_err < 1e-5);
                sc_bvh_free(b);
            }
    }
    sc_oracle_free(&o);
}

/* Adversarial rays, the same rays as segments ending (or starting) exactly
 * at their target, and random rays. */
static void run_mesh(const char *name, const mesh *mm, size_t nrays, uint64_t seed, int want_closed)
{
    sc_mesh_view m = { mm->pos, mm->nv, mm->idx, mm->nt, 0, 0 };
    sc_checked_mesh cm = sc_test_checked(&m);
    int closed = 0;
    assert_int_equal(sc_mesh_is_closed(&cm, &closed), SC_OK);
    assert_int_equal(closed, want_closed);
    char label[64];
    sc_rayset adv, rnd;
    assert_int_equal(sc_rayset_adversarial(&cm, nrays, seed, &adv), SC_OK);
    snprintf(label, sizeof label, "%s adversarial", name);
    run_rays(label, &m, adv.rays, adv.count, 1);

    sc_ray *seg = malloc(adv.count * sizeof *seg);
    size_t ns = 0;
    for (size_t i = 0; i < adv.count; i++) {
        if (!(adv.aim_t[i] > 0))
            continue;
        seg[ns] = adv.rays[i];
        if (i % 2)
            seg[ns].tmax = adv.aim_t[i];
        else
            seg[ns].tmin = adv.aim_t[i];
        ns++;
    }
    snprintf(label, sizeof label, "%s segments", name);
    run_rays(label, &m, seg, ns, 0);
    free(seg);

    float lo[3], hi[3];
    assert_int_equal(sc_mesh_bounds(&m, lo, hi), SC_OK);
    assert_int_equal(sc_rayset_random(lo, hi, nrays, seed, &rnd), SC_OK);
    snprintf(label, sizeof label, "%s random", name);
    run_rays(label, &m, rnd.rays, rnd.count, 0);
    sc_rayset_free(&adv);
    sc_rayset_free(&rnd);
}

static void test_closed_meshes(void **state)
{
    (void)state;
    mesh m;
    const double off0[3] = { 3.1, -1.7, 0.45 }, off1[3] = { -0.3, 12.25, 5.6 };
    torus(&m, 60, 30, off0, 1.0);
    run_mesh("torus", &m, 4000, 3, 1);
    mesh_free(&m);

    /* far from the origin of the coordinates, small: the translation O - V
     * loses many bits, the float filter leaves more to the fallbacks */
    const double far[3] = { 4096.5, -1031.25, 777.125 };
    torus(&m, 40, 20, far, 0.01);
    run_mesh("far small torus", &m, 3000, 4, 1);
    mesh_free(&m);

    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(3, &pm), SC_OK);
    from_proc(&m, &pm, off1, 2.0);
    run_mesh("icosphere", &m, 3000, 5, 1);
    mesh_free(&m);

    assert_int_equal(sc_proc_cube(&pm), SC_OK);
    from_proc(&m, &pm, off1, 1.0);
    run_mesh("cube", &m, 2000, 6, 1);
    mesh_free(&m);
}

static void test_open_meshes(void **state)
{
    (void)state;
    mesh m;
    sc_proc_mesh pm;
    const double off[3] = { 0.5, -0.25, 1.5 };
    assert_int_equal(sc_proc_heightfield(40, &pm), SC_OK);
    from_proc(&m, &pm, off, 1.0);
    run_mesh("grid", &m, 3000, 7, 0);
    mesh_free(&m);

    assert_int_equal(sc_proc_soup(3000, 9, &pm), SC_OK);
    m.nv = pm.vertex_count, m.nt = pm.triangle_count, m.pos = pm.positions, m.idx = pm.indices;
    run_mesh("soup", &m, 3000, 8, 0);
    mesh_free(&m);
}

static void test_lattice(void **state)
{
    (void)state;
    mesh m;
    grid_box(&m, 6, 1);    /* integer vertices: exactly zero edge functions for lattice rays */
    sc_mesh_view v = { m.pos, m.nv, m.idx, m.nt, 0, 0 };
    size_t n = 6000;
    sc_ray *rays = malloc(n * sizeof *rays);
    lattice_rays(6, n, 11, rays);
    run_rays("lattice box", &v, rays, n, 1);
    free(rays);
    mesh_free(&m);
}

static void test_not_vacuous(void **state)
{
    (void)state;
    print_message("watertight disagreements on the mesh sets above: %zu\n", g_wt_disagree);
    assert_true(g_wt_disagree > 0);
}

/* ---- the float filter's t bound ------------------------------------------- */

/* The float filter's t bound against MPFR where the triangle's own S
 * matters (sc_exact_local_bound): a hit near the origin of a ray set up
 * with a root box 2^6 to 2^12 times the hit's distance, triangles of every
 * tilt down to grazing, scales 2^-60 to 2^40. Every certified lane must
 * have |t - t*| <= te; the local bound must have narrowed some te below
 * SC_EXACT_WIDE |t| where the root box's could not have (the test would
 * pass vacuously otherwise). */
static void test_filter_t_bound(void **state)
{
    (void)state;
    sc_rng g;
    sc_rng_seed(&g, 707);
    size_t n = 40000, certified = 0, narrow_far = 0;
    mpfr_t ts, d;
    mpfr_inits2(128, ts, d, (mpfr_ptr)0);
    for (size_t i = 0; i < n; i++) {
        const double sc = ldexp(1.0, (int)(sc_rng_next(&g) % 101) - 60);
        /* a triangle of size l around the point at distance dist along
         * the ray, its plane at cos 10^[-4, 0] to the ray (grazing) */
        double dir[3], len = 0;
        for (int k = 0; k < 3; k++)
            dir[k] = sc_rng_range(&g, -1, 1), len += dir[k] * dir[k];
        len = sqrt(len);
        if (len < 1e-3)
            continue;
        for (int k = 0; k < 3; k++)
            dir[k] /= len;
        const double dist = sc * sc_rng_range(&g, 0.01, 1), l = dist * pow(10, sc_rng_range(&g, -2.5, 0));
        double a[3], b[3], tmp[3] = { sc_rng_range(&g, -1, 1), sc_rng_range(&g, -1, 1), sc_rng_range(&g, -1, 1) };
        /* the plane's normal: dir tilted towards w, a unit vector normal
         * to dir; a and b span the plane */
        const double cosn = pow(10, sc_rng_range(&g, -4, 0)), sinn = sqrt(1 - cosn * cosn);
        double w[3] = { tmp[1] * dir[2] - tmp[2] * dir[1], tmp[2] * dir[0] - tmp[0] * dir[2],
                        tmp[0] * dir[1] - tmp[1] * dir[0] };
        double wl = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        if (wl < 1e-3)
            continue;
        double nrm[3];
        for (int k = 0; k < 3; k++)
            w[k] /= wl, nrm[k] = cosn * dir[k] + sinn * w[k];
        /* a = w x n, b = n x a: the plane's axes */
        a[0] = w[1] * nrm[2] - w[2] * nrm[1], a[1] = w[2] * nrm[0] - w[0] * nrm[2], a[2] = w[0] * nrm[1] - w[1] * nrm[0];
        b[0] = nrm[1] * a[2] - nrm[2] * a[1], b[1] = nrm[2] * a[0] - nrm[0] * a[2], b[2] = nrm[0] * a[1] - nrm[1] * a[0];
        float rows[9 * 4] = { 0 };   /* lane 0 of a leaf block of width 4 */
        for (int j = 0; j < 3; j++) {
            const double ang = 2.0943951023931953 * j + sc_rng_range(&g, -0.5, 0.5);
            for (int k = 0; k < 3; k++)
                rows[(3 * j + k) * 4] = (float)(dist * dir[k] + l * (cos(ang) * a[k] + sin(ang) * b[k]));
        }
        sc_ray r = { { 0, 0, 0 }, 0, { (float)dir[0], (float)dir[1], (float)dir[2] }, INFINITY };
        const float big = (float)(dist * ldexp(1.0, 6 + (int)(sc_rng_next(&g) % 7)));
        const float lo[3] = { -big, -big, -big }, hi[3] = { big, big, big };
        unsigned csr = sc_test_ftz_off();
        float vv[9];
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                vv[3 * j + k] = rows[(3 * j + k) * 4];
        int want = mp_hit_gradual(&r, vv, ts);
        sc_test_ftz_restore(csr);
        sc_ray_pre p;
        sc_ray_precompute(&r, &p, lo, hi);
        float t = 0, te = -1, un, vn, den;
        int fr = sc_tri_exact_filter(&p, rows, 4, 0, r.tmin, r.tmax, &t, &te, &un, &vn, &den);
        if (!fr || te < 0)
            continue;
        /* a certified lane is inside: the exact test agrees it hits */
        assert_true(want);
        certified++;
        mpfr_set_flt(d, t, MPFR_RNDN);
        mpfr_sub(d, d, ts, MPFR_RNDN);
        mpfr_abs(d, d, MPFR_RNDN);
        if (!(mpfr_cmp_d(d, (double)te) <= 0))
            fail_msg("config %zu: |t - t*| = %.3e > te = %.3e (t %.9e, scale 2^%d)", i, mpfr_get_d(d, MPFR_RNDU),
                     (double)te, (double)t, (int)log2(sc));
        /* narrowed by the local bound (with the root box's S, 2^6 times
         * the hit's distance or more, te of a tilted triangle is far above
         * this) */
        if (te <= SC_EXACT_WIDE * fabsf(t) && cosn < 0.5)
            narrow_far++;
    }
    mpfr_clears(ts, d, (mpfr_ptr)0);
    print_message("%zu configurations: %zu certified, %zu narrowed below 2^-15 |t| with a root box 2^6..2^12x "
                  "the hit's distance\n",
                  n, certified, narrow_far);
    /* grazing triangles (cos < 0.01, half the configurations) mostly stay
     * undecided in float, as they should */
    assert_true(certified > n / 8);
    assert_true(narrow_far > n / 40);
}

/* ---- the shared scenes ----------------------------------------------------- */

/* the adversarial set `spherecull compare` uses (65536 rays, seed 1), an
 * even stride of 2000 of them */
static void shared_scene(const char *name, const sc_mesh_view *m, void *ctx)
{
    (void)ctx;
    sc_rayset set;
    sc_checked_mesh cm = sc_test_checked(m);
    assert_int_equal(sc_rayset_adversarial(&cm, 65536, 1, &set), SC_OK);
    size_t ns = 2000;
    sc_ray *sr = malloc(ns * sizeof *sr);
    for (size_t s = 0; s < ns; s++)
        sr[s] = set.rays[(size_t)((double)s * set.count / ns)];
    char label[64];
    snprintf(label, sizeof label, "%s adversarial", name);
    run_rays(label, m, sr, ns, 0);
    free(sr);
    sc_rayset_free(&set);
}

static void test_shared_scenes(void **state)
{
    (void)state;
    const char *const names[] = { "bunny.obj", "fandisk.obj", "armadillo.obj", "dragon_100k.ply" };
    each_shared_scene(names, sizeof names / sizeof names[0], shared_scene, NULL);
}

int main(void)
{
    static int scale_1em20 = -66, scale_1em30 = -100, scale_huge = 46;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_predicates_vs_mpfr),
        cmocka_unit_test(test_tiny_scenes),
        cmocka_unit_test_prestate(test_predicates_vs_mpfr, (void *)&scale_1em20),
        cmocka_unit_test_prestate(test_tiny_scenes, (void *)&scale_1em20),
        cmocka_unit_test_prestate(test_predicates_vs_mpfr, (void *)&scale_1em30),
        cmocka_unit_test_prestate(test_tiny_scenes, (void *)&scale_1em30),
        cmocka_unit_test_prestate(test_predicates_vs_mpfr, (void *)&scale_huge),
        cmocka_unit_test_prestate(test_tiny_scenes, (void *)&scale_huge),
        cmocka_unit_test(test_closed_meshes),
        cmocka_unit_test(test_open_meshes),
        cmocka_unit_test(test_lattice),
        cmocka_unit_test(test_not_vacuous),
        cmocka_unit_test(test_filter_t_bound),
        cmocka_unit_test(test_shared_scenes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

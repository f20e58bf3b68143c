/* The BVH node (slab) test never culls a box the ray meets: the padding that
 * sc_ray_precompute (src/trace/ray_setup.h) folds into ord_near/ord_far,
 * checked exactly with MPFR. Non-parallel rays only (every |d_k| >= 1e-18);
 * parallel rays take sc_slab_par.
 *
 *   - per plane: for a plane p inside the root box (faces included),
 *     fl(p rd - ord_near) <= (p - o)/d <= fl(p rd - ord_far), exactly, on
 *     seeded random roots 1e-30 .. 1e20 wide (subnormal ones, small boxes
 *     1e7 away from 0, flat ones), planes on, next to and between the faces,
 *     origins inside / on a face / one ulp off / up to 1e6 box sizes out /
 *     anywhere up to 1e18, directions 1e-18 .. 1e18 per component with random
 *     signs, nearly axis-aligned, at exactly 1e-18, and up to 3e38 (1/d
 *     subnormal: valid input too);
 *   - the whole node test (sc_slab, the scalar specification) on 8-box nodes whose
 *     boxes sit on a power-of-two lattice, so that rays can pass exactly
 *     through a corner, an edge point or a face point, graze an edge, or run
 *     along a face (origin on the face, that component tiny): every box the
 *     exact ray meets within [tmin, tmax] (tmin = tmax = the touching t
 *     among them) is a computed hit, and its entry distance is <= the
 *     exact one;
 *   - teeth: the same planes and rays with the unpadded b = fl(o rd) must
 *     show violations of both kinds, else the cases are too easy to mean
 *     anything (half the pad is counted too, as a diagnostic).
 *
 * Failures are counted apart where the pad's relative term g underflowed
 * (|o| + root extent below ~1e-31 on an axis) and asserted last, so that one
 * regime cannot hide the other. SC_SLAB_SEED=n runs other cases.
 *
 * Exactness: a difference of two floats, a product of that and a float,
 * and a difference of two such products all fit in PREC bits; every MPFR
 * result's ternary value is checked, and quotients are only ever compared
 * by cross-multiplication, never rounded.
 */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <cmocka.h>

#include <mpfr.h>

#include "common/sc_rng.h"
#include "sc_ftz.h"
#include "trace/node_bvh8_slab.h"

/* floats span 2^-149 .. 2^128: p - o needs 278 bits, (p - o) * float and
 * float * float products below 560 bits of span */
#define PREC 640

static mpfr_t T1, T2, Q;

/* The MXCSR mode under test (sc_ftz.h). Generators and the MPFR reference
 * (whose float-to-double conversions DAZ would zero) run with gradual
 * underflow; only the statements in UNDER_TEST run in the mode under test. */
static unsigned g_mode;
#define UNDER_TEST(...)                 \
    do {                                \
        sc_test_ftz_restore(g_mode);    \
        __VA_ARGS__;                    \
        (void)sc_test_ftz_off();        \
    } while (0)
static int g_inexact; /* some MPFR result was rounded: no comparison can be trusted */
#define EX(op) (g_inexact |= ((op) != 0))

/* SC_SLAB_SEED=n reruns everything on other cases (default 0). */
static uint64_t seed_mix(void)
{
    const char *e = getenv("SC_SLAB_SEED");
    return e ? strtoull(e, NULL, 0) * 0x9e3779b97f4a7c15ull : 0;
}

static double now(void)
{
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- the arithmetic under test --------------------------------------------- */

/* The set-up the padding replaced: b = fl(o rd), no pad. */
static void unpadded(sc_ray_pre *p)
{
    for (int k = 0; k < 3; k++)
        p->ord_near[k] = p->ord_far[k] = p->org[k] * p->rd[k];
}

/* ---- exact references -------------------------------------------------------- */

/* diff = p - o, exactly */
static void mp_diff(mpfr_t diff, float p, float o)
{
    EX(mpfr_set_flt(diff, p, MPFR_RNDN));
    EX(mpfr_sub_d(diff, diff, (double)o, MPFR_RNDN));
}

/* sign of x - diff/d (x may be infinite, not NaN) */
static int cmp_tau(float x, const mpfr_t diff, float d)
{
    EX(mpfr_set_flt(T1, x, MPFR_RNDN));
    EX(mpfr_mul_d(T1, T1, (double)d, MPFR_RNDN));
    EX(mpfr_sub(T1, T1, diff, MPFR_RNDN));
    int s = mpfr_sgn(T1);
    return d < 0 ? -s : s;
}

/* A non-negative-denominator rational num/den (den a positive float). */
typedef struct rat { mpfr_t num; double den; } rat;

/* sign of a - b */
static int rat_cmp(const rat *a, const rat *b)
{
    EX(mpfr_mul_d(T1, a->num, b->den, MPFR_RNDN));
    EX(mpfr_mul_d(T2, b->num, a->den, MPFR_RNDN));
    EX(mpfr_sub(T1, T1, T2, MPFR_RNDN));
    return mpfr_sgn(T1);
}

static void rat_set(rat *a, const rat *b)
{
    EX(mpfr_set(a->num, b->num, MPFR_RNDN));
    a->den = b->den;
}

static void rat_flt(rat *a, float x)
{
    EX(mpfr_set_flt(a->num, x, MPFR_RNDN));
    a->den = 1;
}

/* The exact ray o + t d meets [lo, hi] for some t in [tmin, tmax]: the
 * closed slabs intersected exactly. *entry = max(tmin, near distances),
 * *exit = min(tmax, far distances); 1 iff entry <= exit. */
static rat R_near, R_far;
static int mp_box(const float o[3], const float d[3], float tmin, float tmax, const float lo[3],
                  const float hi[3], rat *entry, rat *exit)
{
    rat_flt(entry, tmin);
    rat_flt(exit, tmax);
    for (int k = 0; k < 3; k++) {
        /* (lo - o)/d and (hi - o)/d with the sign of d moved to the numerator */
        float pn = d[k] > 0 ? lo[k] : hi[k], pf = d[k] > 0 ? hi[k] : lo[k];
        mp_diff(R_near.num, pn, o[k]);
        mp_diff(R_far.num, pf, o[k]);
        if (d[k] < 0) {
            EX(mpfr_neg(R_near.num, R_near.num, MPFR_RNDN));
            EX(mpfr_neg(R_far.num, R_far.num, MPFR_RNDN));
        }
        R_near.den = R_far.den = fabs((double)d[k]);
        if (rat_cmp(&R_near, entry) > 0)
            rat_set(entry, &R_near);
        if (rat_cmp(&R_far, exit) < 0)
            rat_set(exit, &R_far);
    }
    return rat_cmp(entry, exit) <= 0;
}

/* sign of x - r */
static int flt_rat_cmp(float x, const rat *r)
{
    EX(mpfr_set_flt(T2, x, MPFR_RNDN));
    EX(mpfr_mul_d(T2, T2, r->den, MPFR_RNDN));
    EX(mpfr_sub(T2, T2, r->num, MPFR_RNDN));
    return mpfr_sgn(T2);
}

/* ---- random inputs ------------------------------------------------------------ */

static int pick(sc_rng *g, int n) { return (int)(sc_rng_next(g) % (uint64_t)n); }
static double sgn(sc_rng *g) { return (sc_rng_next(g) >> 63) ? -1.0 : 1.0; }
static double logu(sc_rng *g, double e0, double e1) { return pow(10.0, sc_rng_range(g, e0, e1)); }
static int64_t irange(sc_rng *g, int64_t lo, int64_t hi)
{
    return lo + (int64_t)(sc_rng_next(g) % (uint64_t)(hi - lo + 1));
}

static float f_in(sc_rng *g, float lo, float hi)
{
    float x = (float)sc_rng_range(g, lo, hi);
    return x < lo ? lo : x > hi ? hi : x;
}

static float clamp_org(float o)
{
    return fabsf(o) < SC_MAX_ORIGIN ? o : copysignf(nextafterf(SC_MAX_ORIGIN, 0), o);
}

static float clamp_dir(float d)
{
    return fabsf(d) >= SC_MIN_RCP_INPUT ? d : copysignf(SC_MIN_RCP_INPUT, d);
}

/* The pad's relative term g = fl(|o| c + fl(m c)) of sc_ray_precompute,
 * recomputed to sort failures: g below FLT_MIN has lost its relative
 * precision to underflow before being scaled by |rd|. */
static int g_underflows(float o, float lo, float hi)
{
    float m = sc_fmax(fabsf(lo - o), fabsf(hi - o));
    return fmaf(fabsf(o), 0x1.0cp-23f, m * 0x1.0cp-23f) < FLT_MIN;
}

/* One axis of a root box. |coordinates| <= 2e20, so p rd stays finite for
 * |rd| <= 1e18 (the property is about finite distances). */
static void gen_root_axis(sc_rng *g, float *lo, float *hi)
{
    double h, c;
    switch (pick(g, 6)) {
    case 0: h = logu(g, -3, 3), c = sc_rng_range(g, -4 * h, 4 * h); break;          /* ordinary */
    case 1: h = logu(g, -30, -20), c = pick(g, 2) ? 0 : sgn(g) * logu(g, -30, -20); break; /* tiny */
    case 2: h = logu(g, 15, 20), c = sc_rng_range(g, -h, h); break;                /* large */
    case 3: h = logu(g, -3, 1), c = sgn(g) * logu(g, 6, 7.5); break;               /* small, far from 0 */
    case 4: h = logu(g, -45, -38), c = sgn(g) * logu(g, -45, -38); break;          /* subnormal */
    default: h = logu(g, -30, 20), c = sgn(g) * fmin(h * logu(g, -3, 3), 1e20); break;
    }
    *lo = (float)(c - h), *hi = (float)(c + h);
    if (pick(g, 10) == 0)
        *lo = *hi = (float)c; /* flat: a planar mesh */
}

static float gen_org_axis(sc_rng *g, float lo, float hi)
{
    double s = (double)hi - lo;
    if (s == 0)
        s = fmax(fabs((double)lo) * 0x1p-20, 1e-40);
    float o;
    switch (pick(g, 7)) {
    case 0: o = f_in(g, lo, hi); break;
    case 1: o = pick(g, 2) ? lo : hi; break;
    case 2: o = pick(g, 2) ? (float)(lo - s * logu(g, -3, 6)) : (float)(hi + s * logu(g, -3, 6)); break;
    case 3: o = (float)(sgn(g) * logu(g, 0, 18)); break;
    case 4: o = pick(g, 2) ? nextafterf(lo, -INFINITY) : nextafterf(hi, INFINITY); break;
    case 5: o = pick(g, 4) ? (float)(sgn(g) * logu(g, -45, -38)) : 0.0f; break;
    default: o = (float)(0.5 * ((double)lo + hi) + sgn(g) * 1e7 * sc_rng_range(g, 0.5, 1.5)); break;
    }
    return clamp_org(o);
}

static void gen_dir(sc_rng *g, float d[3])
{
    int mode = pick(g, 5), j = pick(g, 3);
    for (int k = 0; k < 3; k++) {
        double m;
        switch (mode) {
        case 0: m = logu(g, -18, 18); break;
        case 1: m = k == j ? logu(g, -1, 1) : logu(g, -18, -10); break; /* nearly axis-aligned */
        case 2: m = logu(g, -3, 3); break;
        case 3: {
            int w = pick(g, 3);
            m = w == 0 ? SC_MIN_RCP_INPUT : w == 1 ? nextafterf(SC_MIN_RCP_INPUT, 1) : logu(g, -18, 18);
            break;
        }
        default: m = logu(g, -18, 38.5); break; /* 1/d subnormal above 2^126 */
        }
        d[k] = clamp_dir((float)(sgn(g) * m));
    }
}

/* ---- 1. every plane of the root box ------------------------------------------- */

typedef struct plane_stats {
    size_t evals, viol, viol_uf, teeth_near, teeth_far, half_viol, nonfinite;
    double min_slack; /* smallest (exact - near)/pad or (far - exact)/pad: how much pad was left */
    float uf_min_rd;  /* smallest |rd| among violations with g underflowed */
} plane_stats;

static void report_plane(const char *what, float p, float o, float d, float lo, float hi, const sc_ray_pre *pre,
                         int k, float got)
{
    mpfr_t diff, tau;
    mpfr_inits2(PREC, diff, tau, (mpfr_ptr)0);
    mp_diff(diff, p, o);
    mpfr_div_d(tau, diff, (double)d, MPFR_RNDN);
    mpfr_printf("VIOLATION %s: p=%a o=%a d=%a root=[%a,%a] rd=%a ord_near=%a ord_far=%a computed=%a "
                "exact=%.30Rg (%Ra)\n",
                what, (double)p, (double)o, (double)d, (double)lo, (double)hi, (double)pre->rd[k],
                (double)pre->ord_near[k], (double)pre->ord_far[k], (double)got, tau, tau);
    mpfr_clears(diff, tau, (mpfr_ptr)0);
}

static void check_planes(uint64_t seed, size_t cases, plane_stats *st)
{
    sc_rng g;
    sc_rng_seed(&g, seed);
    mpfr_t diff;
    mpfr_init2(diff, PREC);
    for (size_t c = 0; c < cases; c++) {
        float lo[3], hi[3];
        sc_ray r;
        for (int k = 0; k < 3; k++) {
            gen_root_axis(&g, &lo[k], &hi[k]);
            r.org[k] = gen_org_axis(&g, lo[k], hi[k]);
        }
        gen_dir(&g, r.dir);
        r.tmin = 0, r.tmax = INFINITY;
        assert_false(sc_ray_parallel(&r));
        sc_ray_pre pre, bare;
        UNDER_TEST(sc_ray_precompute(&r, &pre, lo, hi));
        bare = pre;
        unpadded(&bare);
        for (int k = 0; k < 3; k++) {
            float planes[6] = {
                lo[k], hi[k], nextafterf(lo[k], hi[k]), nextafterf(hi[k], lo[k]), f_in(&g, lo[k], hi[k]),
                f_in(&g, lo[k], hi[k]),
            };
            const float o = r.org[k], d = r.dir[k], rd = pre.rd[k];
            /* half the padding: does the test come near the bound? */
            float padn = pre.ord_near[k] - bare.ord_near[k], padf = bare.ord_far[k] - pre.ord_far[k];
            float half_n = bare.ord_near[k] + padn * 0.5f, half_f = bare.ord_far[k] - padf * 0.5f;
            const int uf = g_underflows(o, lo[k], hi[k]);
            for (int i = 0; i < 6; i++) {
                const float p = planes[i];
                float tn, tf;
                UNDER_TEST(tn = fmaf(p, rd, -pre.ord_near[k]), tf = fmaf(p, rd, -pre.ord_far[k]));
                float t0 = fmaf(p, rd, -bare.ord_near[k]);
                mp_diff(diff, p, o);
                st->evals += 2;
                if (!isfinite(tn) || !isfinite(tf))
                    st->nonfinite++;
                int bad_n = isnan(tn) || cmp_tau(tn, diff, d) > 0;
                int bad_f = isnan(tf) || cmp_tau(tf, diff, d) < 0;
                if (bad_n || bad_f) {
                    size_t *cnt = uf ? &st->viol_uf : &st->viol;
                    if (uf && fabsf(rd) < st->uf_min_rd)
                        st->uf_min_rd = fabsf(rd);
                    if ((*cnt)++ < 3)
                        report_plane(bad_n ? (uf ? "near > exact (g underflowed)" : "near > exact")
                                           : (uf ? "far < exact (g underflowed)" : "far < exact"),
                                     p, o, d, lo[k], hi[k], &pre, k, bad_n ? tn : tf);
                }
                int s0 = cmp_tau(t0, diff, d);
                st->teeth_near += s0 > 0;
                st->teeth_far += s0 < 0;
                if (!uf) {
                    st->half_viol += cmp_tau(fmaf(p, rd, -half_n), diff, d) > 0;
                    st->half_viol += cmp_tau(fmaf(p, rd, -half_f), diff, d) < 0;
                }
                if (uf)
                    continue;
                /* the pad left over, in units of the pad (diagnostic only) */
                mpfr_div_d(Q, diff, (double)d, MPFR_RNDN);
                double en = mpfr_get_d(Q, MPFR_RNDN) - (double)tn;
                double ef = (double)tf - mpfr_get_d(Q, MPFR_RNDN);
                if (padn > 0 && isfinite(en) && en / padn < st->min_slack)
                    st->min_slack = en / padn;
                if (padf > 0 && isfinite(ef) && ef / padf < st->min_slack)
                    st->min_slack = ef / padf;
            }
        }
    }
    mpfr_clear(diff);
}

static void test_planes(void **state)
{
    (void)state;
    plane_stats st = { .min_slack = INFINITY, .uf_min_rd = INFINITY };
    const size_t cases = 60000;
    double t0 = now();
    check_planes(0x51ab0001ull ^ seed_mix(), cases, &st);
    print_message("planes: %zu cases, %zu evaluations, %zu violations, %zu more where the pad's g underflowed "
                  "(smallest |rd| %g), %zu non-finite, %.2f s\n",
                  cases, st.evals, st.viol, st.viol_uf, (double)st.uf_min_rd, st.nonfinite, now() - t0);
    print_message("planes: smallest pad left %.3f of the pad where g is normal (diagnostic)\n", st.min_slack);
    print_message("planes, teeth: unpadded fl(o rd): %zu near > exact, %zu far < exact; "
                  "half the pad (g normal): %zu\n",
                  st.teeth_near, st.teeth_far, st.half_viol);
    assert_false(g_inexact);
    assert_int_equal(st.viol, 0);
    /* every distance the generator asks for is finite: no vacuous infinities */
    assert_int_equal(st.nonfinite, 0);
    /* without the pad both bounds fail on these cases */
    assert_true(st.teeth_near > 0);
    assert_true(st.teeth_far > 0);
    /* Last, so that everything above is checked first. Roots and origins
     * within ~1e-31 of 0 on an axis: g = |o| c + m c underflows before it
     * is scaled by |rd| (up to 1e18), and the absolute 2^-140 term does not
     * stand in for the lost 2u |o rd| + 2u |rd| M. */
    assert_int_equal(st.viol_uf, 0);
}

/* ---- 2. the node test on constructed boxes -------------------------------------- */

typedef struct node_stats {
    size_t nodes, lanes, hits, touches, culled, dist_bad, culled_uf, dist_bad_uf, extra, teeth_culled;
    size_t exact_through;
} node_stats;

enum { K_CORNER, K_EDGE_GRAZE, K_FACE_POINT, K_ALONG_FACE, K_ANY, K_COUNT };
static const char *KIND[K_COUNT] = { "corner", "edge graze", "face point", "along face", "any point" };

static float lat(int64_t i, int e) { return (float)ldexp((double)i, e); } /* exact: |i| < 2^24, e >= -149 */

static void report_lane(const char *what, int kind, const sc_ray *r, const float lo[3], const float hi[3],
                        const float rlo[3], const float rhi[3], float got, const rat *entry, const rat *exit)
{
    print_message("VIOLATION %s (%s): org=(%a,%a,%a) dir=(%a,%a,%a) tmin=%a tmax=%a box=[%a,%a]x[%a,%a]x[%a,%a] "
                  "root=[%a,%a]x[%a,%a]x[%a,%a] dist=%a\n",
                  what, KIND[kind], (double)r->org[0], (double)r->org[1], (double)r->org[2], (double)r->dir[0],
                  (double)r->dir[1], (double)r->dir[2], (double)r->tmin, (double)r->tmax, (double)lo[0],
                  (double)hi[0], (double)lo[1], (double)hi[1], (double)lo[2], (double)hi[2], (double)rlo[0],
                  (double)rhi[0], (double)rlo[1], (double)rhi[1], (double)rlo[2], (double)rhi[2], (double)got);
    mpfr_t a, b;
    mpfr_inits2(64, a, b, (mpfr_ptr)0);
    mpfr_div_d(a, entry->num, entry->den, MPFR_RNDD);
    mpfr_div_d(b, exit->num, exit->den, MPFR_RNDU);
    mpfr_printf("  exact entry in [%Ra, %Ra] (64-bit enclosure), exit >= entry\n", a, b);
    mpfr_clears(a, b, (mpfr_ptr)0);
}

static void check_nodes(uint64_t seed, size_t nodes, node_stats *st, size_t per_kind_hits[K_COUNT])
{
    sc_rng g;
    sc_rng_seed(&g, seed);
    rat entry, exit;
    mpfr_inits2(PREC, entry.num, exit.num, (mpfr_ptr)0);
    for (size_t n = 0; n < nodes; n++) {
        /* boxes on the lattice 2^e Z, optionally 2^21..2^22 cells from 0 */
        int e = pick(&g, 2) ? (int)irange(&g, -30, 10) : (int)irange(&g, -149, 35);
        int64_t base[3], blo[SC_BVH_N][3], bhi[SC_BVH_N][3];
        for (int k = 0; k < 3; k++)
            base[k] = pick(&g, 4) ? 0 : (int64_t)sgn(&g) * irange(&g, 1 << 21, 1 << 22);
        sc_bvh_node8 node;
        memset(&node, 0, sizeof node);
        float rlo[3] = { INFINITY, INFINITY, INFINITY }, rhi[3] = { -INFINITY, -INFINITY, -INFINITY };
        for (int i = 0; i < SC_BVH_N; i++)
            for (int k = 0; k < 3; k++) {
                blo[i][k] = base[k] + irange(&g, -2048, 2048);
                bhi[i][k] = blo[i][k] + (pick(&g, 6) ? irange(&g, 0, (int64_t)1 << pick(&g, 12)) : 0);
                node.b[2 * k][i] = lat(blo[i][k], e);
                node.b[2 * k + 1][i] = lat(bhi[i][k], e);
                rlo[k] = fminf(rlo[k], node.b[2 * k][i]);
                rhi[k] = fmaxf(rhi[k], node.b[2 * k + 1][i]);
            }
        if (pick(&g, 3) == 0) /* a root larger than this node */
            for (int k = 0; k < 3; k++) {
                double ext = ((double)rhi[k] - rlo[k] + ldexp(1, e)) * logu(&g, 0, 3);
                rlo[k] = (float)(rlo[k] - ext), rhi[k] = (float)(rhi[k] + ext);
            }

        /* the target point X on box ti, and a lattice direction through it */
        int ti = pick(&g, SC_BVH_N), kind = pick(&g, K_COUNT), ax = pick(&g, 3);
        int64_t X[3], dn[3];
        for (int k = 0; k < 3; k++) {
            int face = kind == K_CORNER || (kind == K_EDGE_GRAZE && k != ax) ||
                       ((kind == K_FACE_POINT || kind == K_ALONG_FACE) && k == ax);
            int64_t lo = blo[ti][k], hi = bhi[ti][k];
            X[k] = face            ? (pick(&g, 2) ? lo : hi)
                   : kind == K_ANY ? irange(&g, lo - 2, hi + 2)
                                   : irange(&g, lo, hi);
            dn[k] = (int64_t)sgn(&g) * irange(&g, 1, (int64_t)1 << pick(&g, 21));
        }
        if (kind == K_EDGE_GRAZE) {
            /* into one face's slab, out of the other's: the ray touches the edge only */
            int k1 = (ax + 1) % 3, k2 = (ax + 2) % 3;
            if (pick(&g, 2)) { int t = k1; k1 = k2; k2 = t; }
            int64_t m1 = llabs(dn[k1]), m2 = llabs(dn[k2]);
            dn[k1] = X[k1] == blo[ti][k1] ? m1 : -m1;
            dn[k2] = X[k2] == blo[ti][k2] ? -m2 : m2;
            if (blo[ti][k2] == bhi[ti][k2] || blo[ti][k1] == bhi[ti][k1])
                dn[k1] = -dn[k1]; /* flat box: any sign grazes or crosses */
        }
        sc_ray r;
        int64_t dmax = 0;
        for (int k = 0; k < 3; k++)
            dmax = dn[k] > dmax ? dn[k] : -dn[k] > dmax ? -dn[k] : dmax;
        int ilog = 0;
        while (((int64_t)2 << ilog) <= dmax)
            ilog++;
        /* d = dn 2^(e+s), |d| ~ 2^target; the ray is at X when t = 2^-s */
        int s = (int)irange(&g, -20, 20) - e - ilog;
        float t_hit = (float)ldexp(1, -s);
        int exact_through = 1;
        if (pick(&g, 3)) {
            for (int k = 0; k < 3; k++) {
                r.org[k] = lat(X[k] - dn[k], e);
                double dd = ldexp((double)dn[k], e + s);
                r.dir[k] = (float)dd;
                exact_through &= (double)r.dir[k] == dd;
            }
            exact_through &= (double)t_hit == ldexp(1, -s);
        } else {
            /* far origin (up to 1e6 node sizes): d = fl(X - o) misses X by a rounding */
            double size = 0;
            for (int k = 0; k < 3; k++)
                size = fmax(size, (double)rhi[k] - rlo[k]);
            size = fmax(size, ldexp(1, e)) * logu(&g, 0, 6);
            for (int k = 0; k < 3; k++) {
                float x = lat(X[k], e);
                r.org[k] = clamp_org((float)(x - sgn(&g) * size * sc_rng_range(&g, 0.05, 1)));
                r.dir[k] = (float)ldexp((double)(x - r.org[k]), s);
            }
            exact_through = 0;
        }
        if (kind == K_ALONG_FACE) {
            /* origin on the face, nearly parallel to it, either way */
            r.org[ax] = lat(X[ax], e);
            double dm = fmax(fmax(fabs((double)r.dir[0]), fabs((double)r.dir[1])), fabs((double)r.dir[2]));
            r.dir[ax] = (float)(sgn(&g) * dm * logu(&g, -18, -4));
            exact_through = 0;
        }
        if (pick(&g, 3) == 0) { /* one ulp off: a near miss or a near hit */
            int k = pick(&g, 3);
            if (pick(&g, 2))
                r.dir[k] = nextafterf(r.dir[k], sgn(&g) * INFINITY);
            else
                r.org[k] = nextafterf(r.org[k], sgn(&g) * INFINITY);
            exact_through = 0;
        }
        for (int k = 0; k < 3; k++) {
            r.dir[k] = clamp_dir(r.dir[k]);
            r.org[k] = clamp_org(r.org[k]);
            assert_true(isfinite(r.dir[k])); /* a valid ray, or the generator is broken */
        }
        float tb = t_hit > 0 && isfinite(t_hit) ? t_hit : 1.0f;
        switch (pick(&g, 7)) {
        case 0: r.tmin = 0, r.tmax = INFINITY; break;
        case 1: r.tmin = tb, r.tmax = tb; break;
        case 2: r.tmin = 0, r.tmax = tb; break;
        case 3: r.tmin = tb, r.tmax = INFINITY; break;
        case 4: r.tmin = nextafterf(tb, 0), r.tmax = nextafterf(tb, INFINITY); break;
        case 5: r.tmin = 0, r.tmax = FLT_MAX; break;
        default: r.tmin = tb * (float)sc_rng_uniform(&g), r.tmax = tb * (float)logu(&g, 0, 3); break;
        }
        assert_false(sc_ray_parallel(&r));
        st->exact_through += (size_t)exact_through;

        sc_ray_pre pre, bare;
        UNDER_TEST(sc_ray_precompute(&r, &pre, rlo, rhi));
        bare = pre;
        unpadded(&bare);
        float dist[SC_BVH_N], dist0[SC_BVH_N];
        unsigned mask;
        UNDER_TEST(mask = sc_slab(&pre, &node, r.tmin, r.tmax, dist));
        unsigned mask0 = sc_slab(&bare, &node, r.tmin, r.tmax, dist0);
        st->nodes++;
        for (int i = 0; i < SC_BVH_N; i++) {
            float lo[3], hi[3];
            for (int k = 0; k < 3; k++)
                lo[k] = node.b[2 * k][i], hi[k] = node.b[2 * k + 1][i];
            int hit = mp_box(r.org, r.dir, r.tmin, r.tmax, lo, hi, &entry, &exit);
            int got = (mask >> i) & 1;
            st->lanes++;
            if (!hit) {
                st->extra += (size_t)got;
                continue;
            }
            st->hits++;
            if (i == ti)
                per_kind_hits[kind]++;
            st->touches += rat_cmp(&entry, &exit) == 0;
            st->teeth_culled += !((mask0 >> i) & 1);
            int uf = 0;
            for (int k = 0; k < 3; k++)
                uf |= g_underflows(r.org[k], rlo[k], rhi[k]);
            if (!got) {
                size_t *cnt = uf ? &st->culled_uf : &st->culled;
                if ((*cnt)++ < 3)
                    report_lane(uf ? "exact hit culled (g underflowed)" : "exact hit culled", kind, &r, lo, hi,
                                rlo, rhi, dist[i], &entry, &exit);
            } else if (flt_rat_cmp(dist[i], &entry) > 0) {
                size_t *cnt = uf ? &st->dist_bad_uf : &st->dist_bad;
                if ((*cnt)++ < 3)
                    report_lane(uf ? "dist > exact entry (g underflowed)" : "dist > exact entry", kind, &r, lo,
                                hi, rlo, rhi, dist[i], &entry, &exit);
            }
        }
    }
    mpfr_clears(entry.num, exit.num, (mpfr_ptr)0);
}

static void test_nodes(void **state)
{
    (void)state;
    node_stats st = { 0 };
    size_t per_kind[K_COUNT] = { 0 };
    const size_t nodes = 150000;
    double t0 = now();
    check_nodes(0x51ab0002ull ^ seed_mix(), nodes, &st, per_kind);
    print_message("nodes: %zu nodes, %zu lanes, %zu exact hits (%zu touching at one t only), %zu rays exactly "
                  "through their point, %.2f s\n",
                  st.nodes, st.lanes, st.hits, st.touches, st.exact_through, now() - t0);
    print_message("nodes: target hits by kind: corner %zu, edge graze %zu, face point %zu, along face %zu, "
                  "any %zu\n",
                  per_kind[K_CORNER], per_kind[K_EDGE_GRAZE], per_kind[K_FACE_POINT], per_kind[K_ALONG_FACE],
                  per_kind[K_ANY]);
    print_message("nodes: %zu exact hits culled, %zu entry distances above the exact one; where some axis's g "
                  "underflowed: %zu culled, %zu distances above; %zu conservative extra hits; unpadded: %zu exact "
                  "hits culled\n",
                  st.culled, st.dist_bad, st.culled_uf, st.dist_bad_uf, st.extra, st.teeth_culled);
    assert_false(g_inexact);
    assert_int_equal(st.culled, 0);
    assert_int_equal(st.dist_bad, 0);
    /* the constructions do what they claim: exact touches, every kind hits */
    assert_true(st.touches > 0);
    for (int k = 0; k < K_COUNT; k++)
        assert_true(per_kind[k] > 0);
    /* and without the pad a node test does cull some of these hits */
    assert_true(st.teeth_culled > 0);
    /* subnormal lattices, last: the underflow of test_planes */
    assert_int_equal(st.culled_uf, 0);
    assert_int_equal(st.dist_bad_uf, 0);
}

/* sc_ray_valid and sc_ray_valid_sse against their rule, written out here
 * field by field: tmin >= 0, tmax not NaN, every |o_k| < SC_MAX_ORIGIN,
 * every d_k finite, some d_k != 0. Each field runs through the values next
 * to every boundary (signed zeros, subnormals, 1e18 and its neighbours,
 * FLT_MAX, infinities, NaNs) alone, and all fields at once in random
 * combinations. */
static int ray_valid_rule(const sc_ray *r)
{
    int ok = !isnan(r->tmax) && r->tmin >= 0;
    int nonzero = 0;
    for (int k = 0; k < 3; k++) {
        ok = ok && !isnan(r->org[k]) && fabsf(r->org[k]) < SC_MAX_ORIGIN;
        ok = ok && isfinite(r->dir[k]);
        nonzero = nonzero || r->dir[k] != 0;
    }
    return ok && nonzero;
}

static void test_ray_valid(void **state)
{
    (void)state;
    const float M = SC_MAX_ORIGIN;
    const float vals[] = { 0.0f, -0.0f, 1.0f, -1.0f, 0x1p-140f, -0x1p-140f, FLT_MIN, -FLT_MIN, 1e-18f,
                           M, -M, nextafterf(M, 0), -nextafterf(M, 0), nextafterf(M, INFINITY), FLT_MAX,
                           -FLT_MAX, INFINITY, -INFINITY, NAN, -NAN, 3.0f };
    enum { NV = sizeof vals / sizeof vals[0] };
    _Static_assert(sizeof(sc_ray) == 8 * sizeof(float), "a ray is its eight fields");
    const float base[8] = { 1, 2, 3, 0, 0.5f, -0.25f, 1, 10 };   /* org, tmin, dir, tmax */
    size_t n = 0, valid = 0;
    for (int f = 0; f < 8; f++)
        for (int v = 0; v < NV; v++) {
            float fv[8];
            memcpy(fv, base, sizeof fv);
            fv[f] = vals[v];
            sc_ray r;
            memcpy(&r, fv, sizeof r);
            const int got = sc_ray_valid(&r), want = ray_valid_rule(&r), got_sse = sc_ray_valid_sse(&r);
            if (got != want || got_sse != want)
                fail_msg("field %d = %a: sc_ray_valid %d, sc_ray_valid_sse %d, the rule %d", f, (double)vals[v], got,
                         got_sse, want);
            n++, valid += want;
        }
    sc_rng g;
    sc_rng_seed(&g, 99);
    for (int i = 0; i < 200000; i++) {
        float fv[8];
        for (int f = 0; f < 8; f++)
            /* mostly ordinary values, so that both answers are common */
            fv[f] = sc_rng_next(&g) % 4 ? (float)sc_rng_range(&g, f == 3 ? 0 : -5, 5) : vals[sc_rng_next(&g) % NV];
        sc_ray r;
        memcpy(&r, fv, sizeof r);
        const int got = sc_ray_valid(&r), want = ray_valid_rule(&r), got_sse = sc_ray_valid_sse(&r);
        if (got != want || got_sse != want)
            fail_msg("ray (%a %a %a) tmin %a (%a %a %a) tmax %a: sc_ray_valid %d, sc_ray_valid_sse %d, the rule %d",
                     (double)r.org[0], (double)r.org[1], (double)r.org[2], (double)r.tmin, (double)r.dir[0],
                     (double)r.dir[1], (double)r.dir[2], (double)r.tmax, got, got_sse, want);
        n++, valid += want;
    }
    print_message("%zu rays, %zu valid\n", n, valid);
    assert_true(valid > n / 8 && valid < n - n / 8);
}

static int setup(void **state)
{
    (void)state;
    mpfr_inits2(PREC, T1, T2, R_near.num, R_far.num, (mpfr_ptr)0);
    mpfr_init2(Q, 64);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    mpfr_clears(T1, T2, R_near.num, R_far.num, Q, (mpfr_ptr)0);
    mpfr_free_cache();
    return 0;
}

int main(void)
{
    g_mode = sc_test_ftz_off();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_planes),
        cmocka_unit_test(test_nodes),
        cmocka_unit_test(test_ray_valid),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}

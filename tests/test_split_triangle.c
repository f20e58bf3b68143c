/* The triangle cut of the high build quality's spatial splits
 * (sc_split_triangle, src/bvh/split_triangle.h) against exact arithmetic:
 * every vertex and every exact edge crossing that lies in the input box
 * must lie in the box of its side, on triangles at scales from 1e-30 to
 * 1e30 and offsets up to 1e7, slivers, edges in the plane, planes through a
 * vertex or one float beside it, and boxes already cut by earlier planes.
 * The containment of a crossing a + (pos - a_s)(b - a)/(b_s - a_s) is
 * decided without division, in MPFR at a precision where every difference
 * and product of floats is exact. Run in both MXCSR modes. */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <cmocka.h>
#include <mpfr.h>

#include "bvh/split_triangle.h"
#include "common/sc_rng.h"
#include "sc_ftz.h"

/* floats span 2^-149 .. 2^128: a difference needs < 280 bits, a product of two < 560 */
#define PREC 1200
static mpfr_t A, B, C, D;

/* Is lo <= x_k (le = 1) or x_k <= hi (le = 0) for the exact crossing x of
 * edge ab with the plane x_s = pos? Sign of (v - a_k)(b_s - a_s) against
 * (pos - a_s)(b_k - a_k), with b_s - a_s > 0 after ordering the edge. */
static int crossing_side_ok(const float *a, const float *b, int s, float pos, int k, float v, int le)
{
    if (b[s] < a[s]) {
        const float *t = a;
        a = b, b = t;
    }
    mpfr_set_flt(A, v, MPFR_RNDN);
    mpfr_sub_d(A, A, (double)a[k], MPFR_RNDN);           /* v - a_k, exact */
    mpfr_set_flt(B, b[s], MPFR_RNDN);
    mpfr_sub_d(B, B, (double)a[s], MPFR_RNDN);           /* b_s - a_s > 0 */
    mpfr_mul(A, A, B, MPFR_RNDN);
    mpfr_set_flt(C, pos, MPFR_RNDN);
    mpfr_sub_d(C, C, (double)a[s], MPFR_RNDN);
    mpfr_set_flt(D, b[k], MPFR_RNDN);
    mpfr_sub_d(D, D, (double)a[k], MPFR_RNDN);
    mpfr_mul(C, C, D, MPFR_RNDN);
    const int c = mpfr_cmp(A, C);                        /* (v - x_k) * (b_s - a_s) */
    return le ? c <= 0 : c >= 0;
}

static int crossing_in(const float *a, const float *b, int s, float pos, const box3 *bx)
{
    for (int k = 0; k < 3; k++) {
        if (k == s) {
            if (!(bx->lo[k] <= pos && pos <= bx->hi[k]))
                return 0;
            continue;
        }
        if (!crossing_side_ok(a, b, s, pos, k, bx->lo[k], 1) || !crossing_side_ok(a, b, s, pos, k, bx->hi[k], 0))
            return 0;
    }
    return 1;
}

static int point_in(const float *p, const box3 *bx)
{
    for (int k = 0; k < 3; k++)
        if (!(bx->lo[k] <= p[k] && p[k] <= bx->hi[k]))
            return 0;
    return 1;
}

static int inside(const box3 *in, const box3 *out)
{
    for (int k = 0; k < 3; k++)
        if (in->lo[k] <= in->hi[k] && (in->lo[k] < out->lo[k] || in->hi[k] > out->hi[k]))
            return 0;
    return 1;
}

typedef struct tally {
    size_t cases, crossings, crossings_in_box, vertices_in_box, cut_boxes;
} tally;

/* One triangle, plane and box: every exact point that must be in a side is. */
static void check_case(const float v[3][3], const box3 *bx, int s, float pos, tally *t)
{
    const float *vp[3] = { v[0], v[1], v[2] };
    box3 l, r;
    sc_split_triangle(vp, bx, s, pos, &l, &r);      /* in the requested MXCSR mode */
    const unsigned saved = sc_test_ftz_off();        /* the checks with gradual underflow */
    t->cases++;
    /* each side inside the box and on its side of the plane */
    assert_true(inside(&l, bx));
    assert_true(inside(&r, bx));
    assert_true(!(l.lo[s] <= l.hi[s]) || l.hi[s] <= pos);
    assert_true(!(r.lo[s] <= r.hi[s]) || r.lo[s] >= pos);
    for (int i = 0; i < 3; i++) {
        if (!point_in(v[i], bx))
            continue;
        t->vertices_in_box++;
        if (v[i][s] <= pos)
            assert_true(point_in(v[i], &l));
        if (v[i][s] >= pos)
            assert_true(point_in(v[i], &r));
    }
    for (int e = 0; e < 3; e++) {
        const float *a = v[e], *b = v[(e + 1) % 3];
        if (!((a[s] < pos && b[s] > pos) || (a[s] > pos && b[s] < pos)))
            continue;
        t->crossings++;
        if (!crossing_in(a, b, s, pos, bx))
            continue;
        t->crossings_in_box++;
        if (!crossing_in(a, b, s, pos, &l) || !crossing_in(a, b, s, pos, &r)) {
            print_message("crossing of (%a %a %a)-(%a %a %a) at x%d = %a outside a side\n", (double)a[0],
                          (double)a[1], (double)a[2], (double)b[0], (double)b[1], (double)b[2], s, (double)pos);
            fail();
        }
    }
    sc_test_ftz_restore(saved);
}

static float rnd(sc_rng *g, double scale, double off) { return (float)(off + scale * sc_rng_range(g, -1, 1)); }

static void test_random(void **state)
{
    (void)state;
    mpfr_inits2(PREC, A, B, C, D, (mpfr_ptr)0);
    sc_rng g;
    sc_rng_seed(&g, 77);
    tally t = { 0 };
    static const double scales[] = { 1e-30, 1e-12, 1e-3, 1, 1e3, 1e12, 1e30 };
    for (int it = 0; it < 200000; it++) {
        const unsigned saved = sc_test_ftz_off();
        const double scale = scales[sc_rng_next(&g) % 7];
        const double off = (sc_rng_next(&g) % 3 == 0) ? scale * pow(10, (double)(sc_rng_next(&g) % 8)) : 0;
        float v[3][3];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                v[i][k] = rnd(&g, scale, off);
        const int kind = (int)(sc_rng_next(&g) % 6);
        const int s = (int)(sc_rng_next(&g) % 3);
        if (kind == 1)                      /* sliver: two vertices a few ulps apart */
            for (int k = 0; k < 3; k++)
                v[1][k] = nextafterf(v[0][k], (float)INFINITY);
        if (kind == 2)                      /* an edge in an axis plane */
            v[1][s] = v[0][s];
        box3 bx;
        box_empty(&bx);
        for (int i = 0; i < 3; i++)
            box_grow_point(&bx, v[i]);
        float pos;
        const int pk = (int)(sc_rng_next(&g) % 4);
        const int vi = (int)(sc_rng_next(&g) % 3);
        if (pk == 0)
            pos = v[vi][s];                 /* through a vertex */
        else if (pk == 1)
            pos = nextafterf(v[vi][s], sc_rng_next(&g) & 1 ? (float)INFINITY : (float)-INFINITY);
        else
            pos = (float)(bx.lo[s] + (bx.hi[s] - (double)bx.lo[s]) * sc_rng_uniform(&g));
        if (fabsf(pos) < FLT_MIN)
            pos = 0;
        if (kind >= 4) {
            /* a box cut before, on another axis: a random slab of the triangle's box */
            const int c = (s + 1 + (int)(sc_rng_next(&g) % 2)) % 3;
            const float m = (float)(bx.lo[c] + (bx.hi[c] - (double)bx.lo[c]) * sc_rng_uniform(&g));
            if (kind == 4)
                bx.hi[c] = m;
            else
                bx.lo[c] = m;
            t.cut_boxes++;
        }
        sc_test_ftz_restore(saved);
        check_case((const float(*)[3])v, &bx, s, pos, &t);
    }
    print_message("%zu cases (%zu in cut boxes): %zu vertices in the box, %zu crossings, %zu of them in the box\n",
                  t.cases, t.cut_boxes, t.vertices_in_box, t.crossings, t.crossings_in_box);
    /* not vacuous: most crossings are checked, also in boxes cut before */
    assert_true(t.crossings > t.cases / 2);
    assert_true(t.crossings_in_box > t.crossings / 2);
    mpfr_clears(A, B, C, D, (mpfr_ptr)0);
}

/* Edges almost in the plane (b_s - a_s of one ulp) with long extents on the
 * other axes: the crossing's position along the edge is most sensitive. */
static void test_near_parallel(void **state)
{
    (void)state;
    mpfr_inits2(PREC, A, B, C, D, (mpfr_ptr)0);
    sc_rng g;
    sc_rng_seed(&g, 78);
    tally t = { 0 };
    for (int it = 0; it < 50000; it++) {
        const unsigned saved = sc_test_ftz_off();
        const double scale = pow(10, (double)(int)(sc_rng_next(&g) % 40) - 20);
        float v[3][3];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                v[i][k] = rnd(&g, scale, 0);
        const int s = (int)(sc_rng_next(&g) % 3);
        v[1][s] = nextafterf(v[0][s], (float)INFINITY);
        v[2][s] = v[0][s];
        box3 bx;
        box_empty(&bx);
        for (int i = 0; i < 3; i++)
            box_grow_point(&bx, v[i]);
        const float pos = v[0][s];          /* the crossings sit at the ends */
        const float mid = (float)(0.5 * v[0][s] + 0.5 * (double)v[1][s]);
        sc_test_ftz_restore(saved);
        check_case((const float(*)[3])v, &bx, s, pos, &t);
        check_case((const float(*)[3])v, &bx, s, mid, &t);
        /* two ulps apart: the plane strictly between, so two edges cross it */
        float w[3][3];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                w[i][k] = v[i][k];
        w[1][s] = nextafterf(v[1][s], (float)INFINITY);
        box_empty(&bx);
        for (int i = 0; i < 3; i++)
            box_grow_point(&bx, w[i]);
        check_case((const float(*)[3])w, &bx, s, v[1][s], &t);
    }
    print_message("%zu cases: %zu crossings, %zu in the box\n", t.cases, t.crossings, t.crossings_in_box);
    assert_true(t.crossings_in_box > t.cases / 2);
    mpfr_clears(A, B, C, D, (mpfr_ptr)0);
}

/* Cancellation: an edge from -c to c on the other axes that crosses the
 * plane near its midpoint, where the plane sits close to 0 (a_s = -L,
 * b_s = L plus a few ulps): the crossing is tiny against c, so the double
 * arithmetic's absolute error is many of its float ulps. The pad is what
 * holds here. */
static void test_cancellation(void **state)
{
    (void)state;
    mpfr_inits2(PREC, A, B, C, D, (mpfr_ptr)0);
    sc_rng g;
    sc_rng_seed(&g, 79);
    tally t = { 0 };
    for (int it = 0; it < 50000; it++) {
        const unsigned saved = sc_test_ftz_off();
        const int s = (int)(sc_rng_next(&g) % 3);
        const double L = pow(10, sc_rng_range(&g, -6, 6)), c = pow(10, sc_rng_range(&g, -6, 6));
        float v[3][3];
        for (int k = 0; k < 3; k++) {
            v[0][k] = (float)(-c * sc_rng_range(&g, 0.5, 1));
            v[1][k] = -v[0][k];
            v[2][k] = rnd(&g, c, 0);
        }
        v[0][s] = (float)-L;
        v[1][s] = (float)L;
        for (int j = (int)(sc_rng_next(&g) % 5); j > 0; j--)
            v[1][s] = nextafterf(v[1][s], (float)INFINITY);
        float pos = (float)(0.5 * v[0][s] + 0.5 * (double)v[1][s]);
        for (int j = (int)(sc_rng_next(&g) % 7); j > 3; j--)
            pos = nextafterf(pos, (float)INFINITY);
        if (fabsf(pos) < FLT_MIN)
            pos = 0;                        /* the builder never cuts at a subnormal plane */
        box3 bx;
        box_empty(&bx);
        for (int i = 0; i < 3; i++)
            box_grow_point(&bx, v[i]);
        sc_test_ftz_restore(saved);
        check_case((const float(*)[3])v, &bx, s, pos, &t);
    }
    print_message("%zu cases: %zu crossings, %zu in the box\n", t.cases, t.crossings, t.crossings_in_box);
    assert_true(t.crossings_in_box >= t.cases);
    mpfr_clears(A, B, C, D, (mpfr_ptr)0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random),
        cmocka_unit_test(test_near_parallel),
        cmocka_unit_test(test_cancellation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

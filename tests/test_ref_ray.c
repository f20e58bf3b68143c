/* The exact ray-triangle oracle on constructed cases whose answers are known
 * without computing them: rays through vertices and shared edges, parallel
 * rays, the ends of the t range, extreme scales and bad input. */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "common/sc_rng.h"
#include "sc_ref_ray.h"

static const double TA[3] = { 0, 0, 0 }, TB[3] = { 4, 0, 0 }, TC[3] = { 0, 4, 0 };

/* Ray from O towards P: D = P - O, so the hit (if any) is at t = 1 exactly
 * when P - O is exact (dyadic coordinates). */
static int hit_towards(const double O[3], const double P[3], const double A[3],
                       const double B[3], const double C[3], double *t)
{
    double D[3] = { P[0] - O[0], P[1] - O[1], P[2] - O[2] };
    return sc_ref_ray_triangle(O, D, 0, INFINITY, A, B, C, t);
}

static void test_vertices_and_edges(void **state)
{
    (void)state;
    const double O[3] = { 1, 1, 8 };
    const double *V[3] = { TA, TB, TC };
    for (int i = 0; i < 3; i++) {
        double t = -1;
        assert_int_equal(hit_towards(O, V[i], TA, TB, TC, &t), 1);
        assert_true(t == 1.0);
        /* Midpoint of each edge. */
        const double *P = V[i], *Q = V[(i + 1) % 3];
        double M[3] = { (P[0] + Q[0]) / 2, (P[1] + Q[1]) / 2, (P[2] + Q[2]) / 2 };
        assert_int_equal(hit_towards(O, M, TA, TB, TC, &t), 1);
        assert_true(t == 1.0);
        /* Just outside the vertex, away from the triangle. */
        double X[3] = { V[i][0], V[i][1], V[i][2] };
        double cx = 4.0 / 3, cy = 4.0 / 3;
        X[0] += X[0] > cx ? 0x1p-40 : -0x1p-40;
        X[1] += X[1] > cy ? 0x1p-40 : -0x1p-40;
        assert_int_equal(hit_towards(O, X, TA, TB, TC, NULL), 0);
    }
    /* Just inside and just outside the hypotenuse x + y = 4. */
    const double in[3] = { 2 - 0x1p-45, 2, 0 }, out[3] = { 2 + 0x1p-45, 2, 0 };
    assert_int_equal(hit_towards(O, in, TA, TB, TC, NULL), 1);
    assert_int_equal(hit_towards(O, out, TA, TB, TC, NULL), 0);
    /* Both faces count. */
    const double below[3] = { 1, 1, -8 }, P[3] = { 1, 1, 0 };
    assert_int_equal(hit_towards(below, P, TA, TB, TC, NULL), 1);
    assert_int_equal(hit_towards(below, P, TA, TC, TB, NULL), 1);
}

/* Two triangles sharing edge AC: a ray through a point exactly on AC hits
 * both; a ray through the quad anywhere near AC hits at least one. */
static void test_shared_edge(void **state)
{
    (void)state;
    sc_rng rng;
    sc_rng_seed(&rng, 31);
    int both = 0, one = 0;
    for (int iter = 0; iter < 2000; iter++) {
        double A[3], B[3], C[3], D2[3], O[3];
        for (int k = 0; k < 3; k++) {
            /* On a 2^-20 grid, so the edge midpoint and the re-aimed
             * origin below are exact. */
            A[k] = ldexp(round(ldexp(sc_rng_range(&rng, -1, 1), 20)), -20);
            C[k] = ldexp(round(ldexp(sc_rng_range(&rng, -1, 1), 20)), -20);
            O[k] = sc_rng_range(&rng, -10, 10);
        }
        /* B and D2 on opposite sides of AC, roughly in one plane. */
        double e[3] = { C[0] - A[0], C[1] - A[1], C[2] - A[2] };
        double w[3] = { sc_rng_range(&rng, -1, 1), sc_rng_range(&rng, -1, 1), sc_rng_range(&rng, -1, 1) };
        for (int k = 0; k < 3; k++) {
            B[k] = A[k] + 0.5 * e[k] + w[k];
            D2[k] = A[k] + 0.5 * e[k] - w[k] + 0.01 * sc_rng_range(&rng, -1, 1);
        }
        double M[3];
        if (iter % 2 == 0) {
            /* The exact midpoint (A + C)/2 of the edge: dyadic, on the edge. */
            for (int k = 0; k < 3; k++)
                M[k] = (A[k] + C[k]) / 2;
            double Dir[3] = { M[0] - O[0], M[1] - O[1], M[2] - O[2] };
            /* Dir may round; re-aim from O' = M - Dir so that O' + Dir = M exactly. */
            double O2[3];
            for (int k = 0; k < 3; k++) {
                Dir[k] = ldexp(round(ldexp(Dir[k], 20)), -20);
                O2[k] = M[k] - Dir[k];
            }
            int ok = 1;
            for (int k = 0; k < 3; k++)
                if (O2[k] + Dir[k] != M[k])
                    ok = 0;
            if (!ok)
                continue;
            int h1 = sc_ref_ray_triangle(O2, Dir, 0, INFINITY, A, B, C, NULL);
            int h2 = sc_ref_ray_triangle(O2, Dir, 0, INFINITY, A, C, D2, NULL);
            assert_int_equal(h1 + h2, 2);
            both++;
        } else {
            /* A point within 1e-12 of the edge, towards either side. */
            double s = sc_rng_uniform(&rng) * 0.8 + 0.1, j = sc_rng_range(&rng, -1e-12, 1e-12);
            for (int k = 0; k < 3; k++)
                M[k] = A[k] + s * e[k] + j * w[k];
            double Dir[3] = { M[0] - O[0], M[1] - O[1], M[2] - O[2] };
            int h1 = sc_ref_ray_triangle(O, Dir, 0, INFINITY, A, B, C, NULL);
            int h2 = sc_ref_ray_triangle(O, Dir, 0, INFINITY, A, C, D2, NULL);
            assert_true(h1 + h2 >= 1);
            one++;
        }
    }
    print_message("%d through the edge, %d next to it\n", both, one);
    assert_true(both > 500 && one > 500);
}

static void test_parallel(void **state)
{
    (void)state;
    /* In the plane, straight through the triangle. */
    const double O[3] = { -1, 1, 0 }, D[3] = { 1, 0, 0 };
    assert_int_equal(sc_ref_ray_triangle(O, D, -INFINITY, INFINITY, TA, TB, TC, NULL), 0);
    /* Parallel, above. */
    const double O2[3] = { -1, 1, 1 };
    assert_int_equal(sc_ref_ray_triangle(O2, D, -INFINITY, INFINITY, TA, TB, TC, NULL), 0);
    /* Almost parallel but not: hits far away at t = 2^40. */
    const double O3[3] = { 1, 1, 1 }, D3[3] = { 0, 0, -0x1p-40 };
    double t = 0;
    assert_int_equal(sc_ref_ray_triangle(O3, D3, 0, INFINITY, TA, TB, TC, &t), 1);
    assert_true(t == 0x1p40);
    /* Degenerate triangles and a zero direction never hit. */
    const double Z[3] = { 0, 0, 0 }, Ov[3] = { 1, 0, 5 }, Dv[3] = { 0, 0, -1 };
    assert_int_equal(sc_ref_ray_triangle(Ov, Dv, 0, INFINITY, TA, TB, (double[3]){ 2, 0, 0 }, NULL), 0);
    assert_int_equal(sc_ref_ray_triangle(Ov, Dv, 0, INFINITY, TA, TA, TB, NULL), 0);
    assert_int_equal(sc_ref_ray_triangle(Ov, Z, -INFINITY, INFINITY, TA, TB, TC, NULL), 0);
}

static void test_t_range(void **state)
{
    (void)state;
    const double O[3] = { 1, 1, 3 }, D[3] = { 0, 0, -1 };   /* hit at t = 3 */
    double t = 0;
    assert_int_equal(sc_ref_ray_triangle(O, D, 3, 3, TA, TB, TC, &t), 1);
    assert_true(t == 3);
    assert_int_equal(sc_ref_ray_triangle(O, D, nextafter(3, 4), INFINITY, TA, TB, TC, NULL), 0);
    assert_int_equal(sc_ref_ray_triangle(O, D, 0, nextafter(3, 0), TA, TB, TC, NULL), 0);
    assert_int_equal(sc_ref_ray_triangle(O, D, -INFINITY, INFINITY, TA, TB, TC, NULL), 1);
    /* Behind the origin: t = -3. */
    const double Dn[3] = { 0, 0, 1 };
    assert_int_equal(sc_ref_ray_triangle(O, Dn, 0, INFINITY, TA, TB, TC, NULL), 0);
    assert_int_equal(sc_ref_ray_triangle(O, Dn, -3, 0, TA, TB, TC, &t), 1);
    assert_true(t == -3);
    /* Bad ranges and NaN never hit. */
    assert_int_equal(sc_ref_ray_triangle(O, D, 4, 2, TA, TB, TC, NULL), 0);
    assert_int_equal(sc_ref_ray_triangle(O, D, NAN, INFINITY, TA, TB, TC, NULL), 0);
    const double On[3] = { NAN, 1, 3 };
    assert_int_equal(sc_ref_ray_triangle(On, D, 0, INFINITY, TA, TB, TC, NULL), 0);
    const double Di[3] = { 0, INFINITY, -1 };
    assert_int_equal(sc_ref_ray_triangle(O, Di, 0, INFINITY, TA, TB, TC, NULL), 0);
}

static void test_rounding_of_t(void **state)
{
    (void)state;
    const double O[3] = { 1, 1, 0 }, D[3] = { 0, 0, 3 };
    const double A[3] = { 0, 0, 1 }, B[3] = { 4, 0, 1 }, C[3] = { 0, 4, 1 };
    double t = 0;
    assert_int_equal(sc_ref_ray_triangle(O, D, 0, INFINITY, A, B, C, &t), 1);
    assert_true(t == 1.0 / 3.0);
    mpfr_t te, third;
    mpfr_init2(te, 64);
    mpfr_init2(third, 512);
    assert_int_equal(sc_ref_ray_triangle_mpfr(O, D, 0, INFINITY, A, B, C, te), 1);
    assert_true(mpfr_get_prec(te) >= 256);
    mpfr_set_ui(third, 1, MPFR_RNDN);
    mpfr_div_ui(third, third, 3, MPFR_RNDN);
    mpfr_sub(third, third, te, MPFR_RNDN);
    assert_true(mpfr_zero_p(third) || mpfr_get_exp(third) < -250);
    mpfr_clears(te, third, (mpfr_ptr)0);
}

/* Extreme scales: the decision stays exact across the whole double range. */
static void test_scales(void **state)
{
    (void)state;
    static const int exps[] = { -1070, -1000, -500, 0, 500, 1000, 1018 };
    for (size_t i = 0; i < sizeof exps / sizeof exps[0]; i++) {
        int e = exps[i];
        double A[3] = { 0, 0, 0 }, B[3] = { ldexp(1, e), 0, 0 }, C[3] = { 0, ldexp(1, e), 0 };
        double O[3] = { ldexp(0.25, e), ldexp(0.25, e), ldexp(1, e) };
        double Dv[3] = { 0, 0, -1 };
        double t = 0;
        assert_int_equal(sc_ref_ray_triangle(O, Dv, 0, INFINITY, A, B, C, &t), 1);
        assert_true(t == ldexp(1, e));
        /* Aimed exactly at vertex B from far away. */
        double O2[3] = { ldexp(1, e), 0, ldexp(1, e) };
        assert_int_equal(sc_ref_ray_triangle(O2, Dv, 0, INFINITY, A, B, C, NULL), 1);
        /* One ulp beyond vertex B. */
        double O3[3] = { nextafter(ldexp(1, e), INFINITY), 0, ldexp(1, e) };
        assert_int_equal(sc_ref_ray_triangle(O3, Dv, 0, INFINITY, A, B, C, NULL), 0);
    }
    /* Far origin, tiny triangle: a ray from 1e300 away still decides the vertex exactly. */
    const double A[3] = { 0, 0, 0 }, B[3] = { 0x1p-60, 0, 0 }, C[3] = { 0, 0x1p-60, 0 };
    const double O[3] = { 0x1p-60, 0x1p-60, 0x1p1000 }, D[3] = { 0, -0x1p-1000, -1 };
    /* At t = 2^1000 the point is (2^-60, 2^-60 - 1, 0): misses. */
    assert_int_equal(sc_ref_ray_triangle(O, D, 0, INFINITY, A, B, C, NULL), 0);
    const double D2[3] = { 0, -0x1p-1060, -1 };   /* lands on (2^-60, 0): vertex B */
    assert_int_equal(sc_ref_ray_triangle(O, D2, 0, INFINITY, A, B, C, NULL), 1);
}

/* Far from every edge, a plain double Moller-Trumbore agrees. */
static void test_agrees_with_float_math_away_from_edges(void **state)
{
    (void)state;
    sc_rng rng;
    sc_rng_seed(&rng, 7);
    int hits = 0, decided = 0;
    for (int iter = 0; iter < 20000; iter++) {
        double A[3], B[3], C[3], O[3], D[3];
        for (int k = 0; k < 3; k++) {
            A[k] = sc_rng_range(&rng, -1, 1);
            B[k] = sc_rng_range(&rng, -1, 1);
            C[k] = sc_rng_range(&rng, -1, 1);
            O[k] = sc_rng_range(&rng, -4, 4);
        }
        /* Aim near the triangle so that about half the rays hit. */
        double au = sc_rng_range(&rng, -0.3, 1.3), av = sc_rng_range(&rng, -0.3, 1.3);
        for (int k = 0; k < 3; k++)
            D[k] = A[k] + au * (B[k] - A[k]) + av * (C[k] - A[k]) - O[k];
        double e1[3] = { B[0] - A[0], B[1] - A[1], B[2] - A[2] };
        double e2[3] = { C[0] - A[0], C[1] - A[1], C[2] - A[2] };
        double p[3] = { D[1] * e2[2] - D[2] * e2[1], D[2] * e2[0] - D[0] * e2[2], D[0] * e2[1] - D[1] * e2[0] };
        double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
        if (fabs(det) < 1e-3)
            continue;
        double s[3] = { O[0] - A[0], O[1] - A[1], O[2] - A[2] };
        double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
        double q[3] = { s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0] };
        double v = (D[0] * q[0] + D[1] * q[1] + D[2] * q[2]) / det;
        double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
        double margin = 1e-6;
        if (fabs(u) < margin || fabs(v) < margin || fabs(1 - u - v) < margin || fabs(t) < margin)
            continue;
        int expect = u > 0 && v > 0 && u + v < 1 && t > 0;
        double tr = 0;
        int got = sc_ref_ray_triangle(O, D, 0, INFINITY, A, B, C, &tr);
        assert_int_equal(got, expect);
        if (got) {
            assert_true(fabs(tr - t) <= 1e-9 * fabs(t));
            hits++;
        }
        decided++;
    }
    print_message("%d decided, %d hits\n", decided, hits);
    assert_true(hits > 500 && decided > 5000);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vertices_and_edges),
        cmocka_unit_test(test_shared_edge),
        cmocka_unit_test(test_parallel),
        cmocka_unit_test(test_t_range),
        cmocka_unit_test(test_rounding_of_t),
        cmocka_unit_test(test_scales),
        cmocka_unit_test(test_agrees_with_float_math_away_from_edges),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

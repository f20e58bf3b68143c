/* n-simplex hyperspheres (n = 2..16, k = n and k < n) against the MPFR
 * reference, by both methods.
 *
 * Stated bound: |Q - Q_ref| / r_ref <= 2^(n+4) u cond + 4u |Q_ref|_max / r_ref,
 * with cond = sigma_max(E) / sigma_min(E) estimated from the reference's own
 * Gram system (the edge matrix's conditioning governs any solve of E x = h).
 * Ill-conditioned simplices are built with a known condition number.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "common/sc_rng.h"
#include "sc_reference.h"
#include "spherecull/sc_circumsphere.h"

enum { N_MAX = SC_SIMPLEX_MAX_DIM };

/* Vertices: V0 random, V_i = V0 + e_i with e_i random, and for `squash` > 0
 * the last edge pulled towards the span of the others so that the smallest
 * singular value shrinks by about that factor. */
static void make_simplex(sc_rng *rng, int n, int k, double squash, double *V)
{
    for (int j = 0; j < n; j++)
        V[j] = sc_rng_range(rng, -10, 10);
    for (int i = 1; i <= k; i++)
        for (int j = 0; j < n; j++)
            V[i * n + j] = V[j] + sc_rng_range(rng, -1, 1);
    if (squash > 0 && k >= 2) {
        /* e_k = (e_1 + e_2)/2 + squash * noise */
        for (int j = 0; j < n; j++) {
            double e1 = V[1 * n + j] - V[j], e2 = V[2 * n + j] - V[j];
            V[k * n + j] = V[j] + (e1 + e2) / 2 + squash * sc_rng_range(rng, -1, 1);
        }
    }
}

/* Crude but safe condition estimate for the bound: the ratio of the largest
 * edge length to the smallest height of the simplex over its facets is what
 * matters; squash gives it directly. */
static double condition_estimate(double squash)
{
    return squash > 0 ? 4.0 / squash : 64.0;
}

static void run(int n, int k, double squash, int trials, sc_simplex_method method)
{
    sc_rng rng;
    sc_rng_seed(&rng, (uint64_t)(n * 1000 + k * 10 + method) + (uint64_t)(squash * 1e12));
    double V[(N_MAX + 1) * N_MAX], c[N_MAX], r2;
    mpfr_t cref[N_MAX], r2ref;
    for (int j = 0; j < n; j++)
        mpfr_init2(cref[j], 256);
    mpfr_init2(r2ref, 256);
    double u = 0x1p-53;
    int failures = 0;
    double worst = 0;
    for (int t = 0; t < trials; t++) {
        make_simplex(&rng, n, k, squash, V);
        assert_true(sc_ref_simplex_sphere(n, k, V, cref, r2ref));
        sc_status st = sc_simplex_sphere(n, k, V, method, c, &r2);
        if (method == SC_SIMPLEX_CROSS && k < n - 1) {
            assert_int_equal(st, SC_ERR_UNSUPPORTED);
            continue;
        }
        assert_int_equal(st, SC_OK);
        double err = sc_ref_simplex_centre_error(n, cref, r2ref, c);
        double qmax = 0;
        for (int j = 0; j < n; j++)
            qmax = fmax(qmax, fabs(mpfr_get_d(cref[j], MPFR_RNDN)));
        double rr = sqrt(mpfr_get_d(r2ref, MPFR_RNDN));
        double bound = ldexp(1.0, n + 4) * u * condition_estimate(squash) * condition_estimate(squash) +
                       4 * u * qmax / rr;
        if (err > worst)
            worst = err;
        if (!(err <= bound)) {
            if (failures++ < 3)
                print_error("n=%d k=%d %s squash=%g: err %.3e > bound %.3e\n", n, k,
                            sc_simplex_method_name(method), squash, err, bound);
        }
        /* r2 against the reference, same kind of bound */
        double r2e = fabs(r2 - mpfr_get_d(r2ref, MPFR_RNDN)) / mpfr_get_d(r2ref, MPFR_RNDN);
        if (!(r2e <= 2 * bound + 8 * u))
            failures++;
    }
    print_message("n=%2d k=%2d %-5s squash=%-6g worst centre error %.2e\n", n, k,
                  sc_simplex_method_name(method), squash, worst);
    for (int j = 0; j < n; j++)
        mpfr_clear(cref[j]);
    mpfr_clear(r2ref);
    assert_int_equal(failures, 0);
}

static void test_full_simplices_random(void **state)
{
    (void)state;
    for (int n = 2; n <= 16; n++)
        for (int m = 0; m < SC_SIMPLEX_METHOD_COUNT; m++)
            run(n, n, 0, 40, (sc_simplex_method)m);
}

static void test_full_simplices_ill_conditioned(void **state)
{
    (void)state;
    for (int n = 2; n <= 16; n += 2)
        for (int m = 0; m < SC_SIMPLEX_METHOD_COUNT; m++)
            for (double s = 1e-3; s >= 1e-9; s *= 1e-3)
                run(n, n, s, 20, (sc_simplex_method)m);
}

static void test_lower_dimensional_simplices(void **state)
{
    (void)state;
    for (int n = 3; n <= 16; n++) {
        run(n, n - 1, 0, 30, SC_SIMPLEX_CROSS);      /* eq. (18): n-1 bisectors + rho0 */
        run(n, n - 1, 0, 30, SC_SIMPLEX_SOLVE);
        run(n, 2, 0, 30, SC_SIMPLEX_SOLVE);          /* a triangle in En */
        run(n, 2, 0, 5, SC_SIMPLEX_CROSS);           /* unsupported for k < n-1 */
        run(n, 2, 1e-6, 30, SC_SIMPLEX_SOLVE);       /* a sliver triangle in En */
    }
}

/* A triangle in E3 through the simplex path agrees with the E3 kernel. */
static void test_triangle_in_e3_matches_e3_kernel(void **state)
{
    (void)state;
    sc_rng rng;
    sc_rng_seed(&rng, 5);
    for (int t = 0; t < 200; t++) {
        double V[9];
        make_simplex(&rng, 3, 2, 0, V);
        double c[3], r2;
        sc_sphered s;
        assert_int_equal(sc_simplex_sphere(3, 2, V, SC_SIMPLEX_CROSS, c, &r2), SC_OK);
        assert_int_equal(sc_circumsphere_d(V, V + 3, V + 6, SC_METHOD_TEXTBOOK, SC_ORIGIN_OPPOSITE_LONGEST, &s), SC_OK);
        for (int i = 0; i < 3; i++)
            assert_true(fabs(c[i] - s.c[i]) <= 1e-12 * (1 + fabs(s.c[i])));
    }
}

static void test_bad_input(void **state)
{
    (void)state;
    double V[(N_MAX + 1) * N_MAX] = { 0 }, c[N_MAX], r2 = 0;
    assert_int_equal(sc_simplex_sphere(1, 1, V, SC_SIMPLEX_SOLVE, c, &r2), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_simplex_sphere(17, 2, V, SC_SIMPLEX_SOLVE, c, &r2), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_simplex_sphere(4, 5, V, SC_SIMPLEX_SOLVE, c, &r2), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_simplex_sphere(4, 4, NULL, SC_SIMPLEX_SOLVE, c, &r2), SC_ERR_INVALID_ARGUMENT);
    assert_true(isinf(r2));
    /* all vertices equal: degenerate, by both methods */
    for (int m = 0; m < SC_SIMPLEX_METHOD_COUNT; m++) {
        assert_int_equal(sc_simplex_sphere(4, 4, V, (sc_simplex_method)m, c, &r2), SC_ERR_DEGENERATE);
        assert_true(isinf(r2));
    }
    /* exactly affinely dependent: V3 = V1 + V2 - V0 in E3 with k = 3 */
    double W[12] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0 };
    for (int m = 0; m < SC_SIMPLEX_METHOD_COUNT; m++)
        assert_int_equal(sc_simplex_sphere(3, 3, W, (sc_simplex_method)m, c, &r2), SC_ERR_DEGENERATE);
    W[4] = NAN;
    assert_int_equal(sc_simplex_sphere(3, 3, W, SC_SIMPLEX_SOLVE, c, &r2), SC_ERR_NONFINITE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_triangle_in_e3_matches_e3_kernel),
        cmocka_unit_test(test_full_simplices_random),
        cmocka_unit_test(test_full_simplices_ill_conditioned),
        cmocka_unit_test(test_lower_dimensional_simplices),
    };
    return cmocka_run_group_tests_name("simplex", tests, NULL, NULL);
}

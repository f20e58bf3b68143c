/* Triangle spheres against the MPFR reference, float or double (argv[1]).
 *
 * Stated error bound for a circumcentre computed with C opposite the longest
 * edge, per triangle:
 *     |Q - Q_ref| / r_ref  <=  K u kappa  +  2u max_i |Q_ref,i| / r_ref
 * with kappa = L_max^2 / |a x b| (the circumcentre's sensitivity to relative
 * perturbations of the edge vectors), u the unit roundoff, and the second term
 * the unavoidable rounding of the centre itself to the output precision.
 * K = 64: analysis gives about 10 rounding steps along the longest path of
 * the formula; the measured worst case over these families is below 8.
 */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "sc_accuracy.h"
#include "sc_ftz.h"
#include "sc_families.h"

enum { PER_FAMILY = 10000 };
static const double K_BOUND = 64;

static int as_float = 1;

static double unit_roundoff(void)
{
    return as_float ? 0x1p-24 : 0x1p-53;
}

static double centre_bound(const sc_acc_ref *ref, const sc_ref_sphere *rs)
{
    double r = sqrt(mpfr_get_d(rs->r2, MPFR_RNDN));
    double qmax = 0;
    for (int i = 0; i < 3; i++)
        qmax = fmax(qmax, fabs(mpfr_get_d(rs->c[i], MPFR_RNDN)));
    double u = unit_roundoff();
    return K_BOUND * u * ref->condition + 2 * u * qmax / r;
}

static void print_triangle(const char *what, const double V[3][3], double err, double bound)
{
    print_error("%s: err %.3e > bound %.3e for (%a %a %a) (%a %a %a) (%a %a %a)\n", what, err, bound,
                V[0][0], V[0][1], V[0][2], V[1][0], V[1][1], V[1][2], V[2][0], V[2][1], V[2][2]);
}

/* Every method, the minimal sphere and both prefilter kinds on one family:
 * errors within the bound, statuses as the family demands, and not one
 * vertex outside a conservative sphere (decided exactly). */
static void check_family(sc_family fam)
{
    sc_acc_variant variants[32];
    int nv = sc_acc_variants(variants, 32);
    sc_acc_ref ref;
    sc_acc_ref_init(&ref);
    sc_rng rng;
    sc_rng_seed(&rng, 0xC1C1E5u + (unsigned)fam * 2 + (unsigned)as_float);
    int expected = sc_family_expected(fam);
    long out_of_bound = 0, containment = 0, wrong_status = 0, nan_out = 0, degenerate_ok = 0;
    for (int t = 0; t < PER_FAMILY; t++) {
        double V[3][3];
        unsigned csr = sc_test_ftz_off();
        sc_family_triangle(fam, &rng, as_float, V);
        sc_test_ftz_restore(csr);
        sc_acc_ref_compute(&ref, V);
        for (int v = 0; v < nv; v++) {
            const sc_acc_variant *var = &variants[v];
            sc_acc_result res;
            sc_acc_eval(var, as_float, V, &ref, &res);
            /* Never a silent NaN, whatever the input. */
            if (isnan(res.r2) || isnan(res.centre[0]) || isnan(res.centre[1]) || isnan(res.centre[2]))
                nan_out++;
            int prefilter = var->kind == SC_ACC_PREFILTER_CIRCUM || var->kind == SC_ACC_PREFILTER_MINIMAL;
            if (prefilter) {
                containment += res.containment_failures;
                if (res.status != SC_OK)
                    wrong_status++;
                continue;
            }
            if (expected == 2) {
                wrong_status += res.status != SC_ERR_NONFINITE;
                continue;
            }
            if (expected == 1 && var->kind == SC_ACC_CIRCUM) {
                wrong_status += res.status != SC_ERR_DEGENERATE;
                continue;
            }
            if (var->origin != SC_ORIGIN_OPPOSITE_LONGEST)
                continue;     /* as-given is measured by the report, not bounded */
            const sc_ref_sphere *rs = var->kind == SC_ACC_CIRCUM ? &ref.circum : &ref.minimal;
            int ref_ok = var->kind == SC_ACC_CIRCUM ? ref.circum_ok : ref.minimal_ok;
            if (res.status == SC_OK) {
                if (!ref_ok) {
                    wrong_status++;      /* found a circumsphere of an exactly degenerate triangle */
                    continue;
                }
                double bound = var->kind == SC_ACC_CIRCUM ? centre_bound(&ref, rs)
                                                          : centre_bound(&ref, rs) + 4 * unit_roundoff();
                if (var->kind == SC_ACC_MINIMAL && ref.condition > 1 / unit_roundoff())
                    bound = INFINITY;    /* an obtuse-vs-acute decision within rounding */
                if (!(res.centre_err <= bound)) {
                    if (out_of_bound++ < 3)
                        print_triangle(var->name, V, res.centre_err, bound);
                }
            } else if (res.status == SC_ERR_RANGE) {
                /* Allowed only where the true r2 leaves the exponent range. */
                double r2 = ref_ok ? mpfr_get_d(rs->r2, MPFR_RNDN) : 0;
                double hi = as_float ? FLT_MAX : DBL_MAX, lo = as_float ? FLT_MIN : DBL_MIN;
                if (ref_ok && r2 < hi / 4 && r2 > lo * 4)
                    wrong_status++;
                else
                    degenerate_ok++;
            } else if (res.status == SC_ERR_DEGENERATE) {
                /* Allowed only where the input is degenerate to working precision. */
                if (fam != SC_FAM_SUBNORMAL && ref_ok && ref.condition < 0.01 / unit_roundoff())
                    wrong_status++;
                else
                    degenerate_ok++;
            } else {
                wrong_status++;
            }
        }
    }
    sc_acc_ref_clear(&ref);
    print_message("%s %s: %d triangles, %ld out of bound, %ld containment failures, %ld wrong statuses, "
                  "%ld NaN outputs, %ld rightly refused\n", as_float ? "float" : "double",
                  sc_family_name(fam), PER_FAMILY, out_of_bound, containment, wrong_status, nan_out,
                  degenerate_ok);
    assert_int_equal(out_of_bound, 0);
    assert_int_equal(containment, 0);
    assert_int_equal(wrong_status, 0);
    assert_int_equal(nan_out, 0);
}

#define FAMILY_TEST(F) static void test_##F(void **state) { (void)state; check_family(F); }
FAMILY_TEST(SC_FAM_RANDOM)
FAMILY_TEST(SC_FAM_CAP_1E4)
FAMILY_TEST(SC_FAM_CAP_1E5)
FAMILY_TEST(SC_FAM_CAP_1E6)
FAMILY_TEST(SC_FAM_CAP_1E7)
FAMILY_TEST(SC_FAM_NEEDLE_1E4)
FAMILY_TEST(SC_FAM_NEEDLE_1E5)
FAMILY_TEST(SC_FAM_NEEDLE_1E6)
FAMILY_TEST(SC_FAM_NEEDLE_1E7)
FAMILY_TEST(SC_FAM_FAR_1E3)
FAMILY_TEST(SC_FAM_FAR_1E4)
FAMILY_TEST(SC_FAM_FAR_1E5)
FAMILY_TEST(SC_FAM_SCALE_1EM20)
FAMILY_TEST(SC_FAM_SCALE_1EM30)
FAMILY_TEST(SC_FAM_SCALE_1E18)
FAMILY_TEST(SC_FAM_RIGHT)
FAMILY_TEST(SC_FAM_DUPLICATE)
FAMILY_TEST(SC_FAM_COLLINEAR)
FAMILY_TEST(SC_FAM_NONFINITE)
FAMILY_TEST(SC_FAM_SUBNORMAL)

/* The reference itself: its centre is equidistant from the vertices and lies
 * in their plane, to far beyond double precision. */
static void test_reference_equidistant_coplanar(void **state)
{
    (void)state;
    sc_rng rng;
    sc_rng_seed(&rng, 77);
    sc_ref_sphere s;
    sc_ref_sphere_init(&s);
    mpfr_t d[3], tmp, n[3], e1[3], e2[3];
    for (int i = 0; i < 3; i++)
        mpfr_inits2(1024, d[i], n[i], e1[i], e2[i], (mpfr_ptr)0);
    mpfr_init2(tmp, 1024);
    for (int t = 0; t < 500; t++) {
        double V[3][3];
        sc_family_triangle(t % 2 ? SC_FAM_RANDOM : SC_FAM_CAP_1E6, &rng, as_float, V);
        assert_true(sc_ref_circumsphere(V[0], V[1], V[2], &s));
        for (int k = 0; k < 3; k++) {           /* squared distance to vertex k */
            mpfr_set_ui(d[k], 0, MPFR_RNDN);
            for (int i = 0; i < 3; i++) {
                mpfr_sub_d(tmp, s.c[i], V[k][i], MPFR_RNDN);
                mpfr_fma(d[k], tmp, tmp, d[k], MPFR_RNDN);
            }
        }
        for (int k = 1; k < 3; k++) {
            mpfr_sub(tmp, d[k], d[0], MPFR_RNDN);
            mpfr_div(tmp, tmp, s.r2, MPFR_RNDN);
            mpfr_abs(tmp, tmp, MPFR_RNDN);
            assert_true(mpfr_cmp_ui_2exp(tmp, 1, -150) <= 0);
        }
        /* (Q - V0) . ((V1 - V0) x (V2 - V0)) == 0 relative to r |n| */
        for (int i = 0; i < 3; i++) {
            mpfr_set_d(e1[i], V[1][i], MPFR_RNDN); mpfr_sub_d(e1[i], e1[i], V[0][i], MPFR_RNDN);
            mpfr_set_d(e2[i], V[2][i], MPFR_RNDN); mpfr_sub_d(e2[i], e2[i], V[0][i], MPFR_RNDN);
        }
        for (int i = 0; i < 3; i++) {
            int j = (i + 1) % 3, k = (i + 2) % 3;
            mpfr_mul(n[i], e1[j], e2[k], MPFR_RNDN);
            mpfr_mul(tmp, e1[k], e2[j], MPFR_RNDN);
            mpfr_sub(n[i], n[i], tmp, MPFR_RNDN);
        }
        mpfr_set_ui(d[0], 0, MPFR_RNDN);
        mpfr_set_ui(d[1], 0, MPFR_RNDN);
        for (int i = 0; i < 3; i++) {
            mpfr_sub_d(tmp, s.c[i], V[0][i], MPFR_RNDN);
            mpfr_fma(d[0], tmp, n[i], d[0], MPFR_RNDN);
            mpfr_fma(d[1], n[i], n[i], d[1], MPFR_RNDN);
        }
        mpfr_sqr(d[0], d[0], MPFR_RNDN);
        mpfr_mul(d[1], d[1], s.r2, MPFR_RNDN);
        mpfr_div(d[0], d[0], d[1], MPFR_RNDN);
        assert_true(mpfr_cmp_ui_2exp(d[0], 1, -300) <= 0);
    }
    for (int i = 0; i < 3; i++)
        mpfr_clears(d[i], n[i], e1[i], e2[i], (mpfr_ptr)0);
    mpfr_clear(tmp);
    sc_ref_sphere_clear(&s);
}

/* Arguments and the error contract: bad calls fail cleanly and the sphere a
 * failed call leaves behind rejects nothing. */
static void test_arguments_and_contract(void **state)
{
    (void)state;
    float A[3] = { 0, 0, 0 }, B[3] = { 1, 0, 0 }, C[3] = { 0, 1, 0 };
    double Ad[3] = { 0, 0, 0 }, Bd[3] = { 1, 0, 0 }, Cd[3] = { 0, 1, 0 };
    sc_spheref s;
    sc_sphered sd;
    assert_int_equal(sc_circumsphere_f(NULL, B, C, SC_METHOD_TEXTBOOK, SC_ORIGIN_AS_GIVEN, &s), SC_ERR_INVALID_ARGUMENT);
    assert_true(isinf(s.r2) && s.r2 > 0);
    assert_int_equal(sc_circumsphere_f(A, B, C, (sc_method)99, SC_ORIGIN_AS_GIVEN, &s), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_circumsphere_f(A, B, C, SC_METHOD_TEXTBOOK, (sc_origin)7, &s), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_circumsphere_f(A, B, C, SC_METHOD_TEXTBOOK, SC_ORIGIN_AS_GIVEN, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_minimal_sphere_d(Ad, Bd, NULL, SC_METHOD_CRAMER, SC_ORIGIN_AS_GIVEN, &sd), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_prefilter_sphere_d(Ad, Bd, Cd, (sc_sphere_kind)5, SC_METHOD_CRAMER, &sd), SC_ERR_INVALID_ARGUMENT);
    assert_true(isinf(sd.r2));
    /* The right isosceles triangle: all methods land on the hypotenuse midpoint. */
    for (int m = 0; m < SC_METHOD_COUNT; m++) {
        assert_int_equal(sc_circumsphere_f(A, B, C, (sc_method)m, SC_ORIGIN_OPPOSITE_LONGEST, &s), SC_OK);
        assert_float_equal(s.c[0], 0.5f, 1e-6f);
        assert_float_equal(s.c[1], 0.5f, 1e-6f);
        assert_float_equal(s.c[2], 0.0f, 1e-6f);
        assert_float_equal(s.r2, 0.5f, 1e-6f);
    }
    /* Overflow is a range error, not an infinity presented as a centre. */
    float H[3] = { 3e38f, 0, 0 }, G[3] = { -3e38f, 1, 0 }, F[3] = { 0, 3e38f, 0 };
    sc_status st = sc_circumsphere_f(H, G, F, SC_METHOD_TEXTBOOK, SC_ORIGIN_OPPOSITE_LONGEST, &s);
    assert_int_equal(st, SC_ERR_RANGE);
    assert_true(isinf(s.r2));
    assert_int_equal(sc_prefilter_sphere_f(H, G, F, SC_SPHERE_MINIMAL, SC_METHOD_TEXTBOOK, &s), SC_OK);
    assert_true(isinf(s.r2));
    /* The radius on request is rounded up: r*r >= r2 exactly (checked in double). */
    sc_rng rng;
    sc_rng_seed(&rng, 3);
    for (int t = 0; t < 100000; t++) {
        sc_spheref q = { { 0, 0, 0 }, (float)sc_rng_range(&rng, 0, 1e6) };
        float r = sc_sphere_radius_f(&q);
        assert_true((double)r * r >= q.r2);
        assert_true((double)nextafterf(r, 0) * nextafterf(r, 0) < q.r2 || q.r2 == 0);
    }
    sc_spheref inf_sphere = { { 0, 0, 0 }, INFINITY };
    assert_true(isinf(sc_sphere_radius_f(&inf_sphere)));
    /* Names round-trip. */
    for (int m = 0; m < SC_METHOD_COUNT; m++) {
        sc_method back;
        assert_int_equal(sc_method_from_name(sc_method_name((sc_method)m), &back), SC_OK);
        assert_int_equal(back, m);
    }
    sc_method none;
    assert_int_equal(sc_method_from_name("nonsense", &none), SC_ERR_INVALID_ARGUMENT);
    for (int i = 0; i <= SC_STATUS_COUNT; i++)
        assert_non_null(sc_strerror((sc_status)i));
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "double") == 0)
        as_float = 0;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_arguments_and_contract),
        cmocka_unit_test(test_reference_equidistant_coplanar),
        cmocka_unit_test(test_SC_FAM_RANDOM),
        cmocka_unit_test(test_SC_FAM_CAP_1E4),
        cmocka_unit_test(test_SC_FAM_CAP_1E5),
        cmocka_unit_test(test_SC_FAM_CAP_1E6),
        cmocka_unit_test(test_SC_FAM_CAP_1E7),
        cmocka_unit_test(test_SC_FAM_NEEDLE_1E4),
        cmocka_unit_test(test_SC_FAM_NEEDLE_1E5),
        cmocka_unit_test(test_SC_FAM_NEEDLE_1E6),
        cmocka_unit_test(test_SC_FAM_NEEDLE_1E7),
        cmocka_unit_test(test_SC_FAM_FAR_1E3),
        cmocka_unit_test(test_SC_FAM_FAR_1E4),
        cmocka_unit_test(test_SC_FAM_FAR_1E5),
        cmocka_unit_test(test_SC_FAM_SCALE_1EM20),
        cmocka_unit_test(test_SC_FAM_SCALE_1EM30),
        cmocka_unit_test(test_SC_FAM_SCALE_1E18),
        cmocka_unit_test(test_SC_FAM_RIGHT),
        cmocka_unit_test(test_SC_FAM_DUPLICATE),
        cmocka_unit_test(test_SC_FAM_COLLINEAR),
        cmocka_unit_test(test_SC_FAM_NONFINITE),
        cmocka_unit_test(test_SC_FAM_SUBNORMAL),
    };
    return cmocka_run_group_tests_name(as_float ? "circumsphere_float" : "circumsphere_double", tests, NULL, NULL);
}

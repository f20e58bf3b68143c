/* Ray sets: deterministic for a seed, complete, and the adversarial rays
 * really pass through their vertex / edge targets (checked in MPFR). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include <mpfr.h>

#include "scene/procedural.h"
#include "spherecull/sc_rays.h"

static int same_set(const sc_rayset *a, const sc_rayset *b)
{
    return a->count == b->count && memcmp(a->rays, b->rays, a->count * sizeof *a->rays) == 0 &&
           memcmp(a->tag, b->tag, a->count) == 0 && memcmp(a->exact, b->exact, a->count) == 0 &&
           memcmp(a->target, b->target, a->count * sizeof *a->target) == 0;
}

static void test_deterministic(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(3, &pm), SC_OK);
    sc_mesh_view m = sc_proc_view(&pm);
    sc_checked_mesh cm;
    assert_int_equal(sc_mesh_check(&m, &cm), SC_OK);
    float lo[3], hi[3];
    assert_int_equal(sc_mesh_bounds(&m, lo, hi), SC_OK);
    assert_memory_equal(lo, cm.lo, sizeof lo);     /* the check measures the same box */
    assert_memory_equal(hi, cm.hi, sizeof hi);
    sc_rayset a, b, c;
    assert_int_equal(sc_rayset_random(lo, hi, 1000, 7, &a), SC_OK);
    assert_int_equal(sc_rayset_random(lo, hi, 1000, 7, &b), SC_OK);
    assert_int_equal(sc_rayset_random(lo, hi, 1000, 8, &c), SC_OK);
    assert_true(same_set(&a, &b));
    assert_false(same_set(&a, &c));
    /* per-ray streams: a shorter set is a prefix of a longer one */
    sc_rayset d;
    assert_int_equal(sc_rayset_random(lo, hi, 10, 7, &d), SC_OK);
    assert_memory_equal(d.rays, a.rays, 10 * sizeof *d.rays);
    sc_rayset_free(&a), sc_rayset_free(&b), sc_rayset_free(&c), sc_rayset_free(&d);

    assert_int_equal(sc_rayset_adversarial(&cm, 999, 3, &a), SC_OK);
    assert_int_equal(sc_rayset_adversarial(&cm, 999, 3, &b), SC_OK);
    assert_true(same_set(&a, &b));
    sc_rayset_free(&a), sc_rayset_free(&b);

    sc_camera cam;
    assert_int_equal(sc_camera_for_mesh(&cm, 37, 21, &cam), SC_OK);
    assert_int_equal(sc_rayset_primary(&cam, &a), SC_OK);
    assert_int_equal(sc_rayset_primary(&cam, &b), SC_OK);
    assert_true(same_set(&a, &b));
    sc_rayset_free(&a), sc_rayset_free(&b);
    sc_proc_free(&pm);
}

static void test_primary_covers_every_pixel(void **state)
{
    (void)state;
    sc_camera cam = { { 0, 0, 5 }, { 0, 0, 0 }, { 0, 1, 0 }, 45, 37, 21 };
    sc_rayset s;
    assert_int_equal(sc_rayset_primary(&cam, &s), SC_OK);
    assert_int_equal(s.count, 37 * 21);
    unsigned char *seen = calloc(s.count, 1);
    assert_non_null(seen);
    for (size_t i = 0; i < s.count; i++) {
        assert_true(s.target[i] < s.count);
        assert_int_equal(seen[s.target[i]], 0);
        seen[s.target[i]] = 1;
        assert_true(s.rays[i].tmin == 0 && isinf(s.rays[i].tmax));
    }
    /* the first 16 rays are the 4x4 tile at the top-left corner */
    for (int i = 0; i < 16; i++)
        assert_int_equal(s.target[i], (uint32_t)((i / 4) * 37 + i % 4));
    free(seen);
    sc_rayset_free(&s);
    cam.width = 0;
    assert_int_equal(sc_rayset_primary(&cam, &s), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_rayset_primary(NULL, &s), SC_ERR_INVALID_ARGUMENT);
}

/* MPFR: O + t D == P exactly (t a power of two, so 200 bits are exact). */
static int passes_exactly(const sc_ray *r, double t, const double P[3])
{
    mpfr_t x;
    mpfr_init2(x, 200);
    int ok = 1;
    for (int k = 0; k < 3; k++) {
        mpfr_set_d(x, r->dir[k], MPFR_RNDN);
        mpfr_mul_d(x, x, t, MPFR_RNDN);
        mpfr_add_d(x, x, r->org[k], MPFR_RNDN);
        if (mpfr_cmp_d(x, P[k]) != 0)
            ok = 0;
    }
    mpfr_clear(x);
    return ok;
}

static void test_adversarial_targets(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(3, &pm), SC_OK);
    sc_mesh_view m = sc_proc_view(&pm);
    sc_checked_mesh cm;
    assert_int_equal(sc_mesh_check(&m, &cm), SC_OK);
    sc_rayset s;
    assert_int_equal(sc_rayset_adversarial(&cm, 4000, 11, &s), SC_OK);
    size_t per_tag[SC_RAY_TAG_COUNT] = { 0 }, exact[SC_RAY_TAG_COUNT] = { 0 };
    for (size_t i = 0; i < s.count; i++) {
        per_tag[s.tag[i]]++;
        if (!s.exact[i])
            continue;
        exact[s.tag[i]]++;
        if (s.tag[i] == SC_RAY_TAG_VERTEX) {
            const float *V = pm.positions + 3 * (size_t)s.target[i];
            double P[3] = { V[0], V[1], V[2] };
            assert_true(s.aim_t[i] == 1.0f);
            assert_true(passes_exactly(&s.rays[i], 1.0, P));
        } else {
            assert_true(s.tag[i] == SC_RAY_TAG_EDGE || s.tag[i] == SC_RAY_TAG_EDGE_BACK);
            assert_true(s.aim_t[i] == 0.5f);
            /* the point at t = 1/2 lies on an edge of the target triangle:
             * it is the exact midpoint of two of its vertices */
            const uint32_t *ix = pm.indices + 3 * (size_t)s.target[i];
            int on_edge = 0;
            for (int e = 0; e < 3; e++) {
                const float *A = pm.positions + 3 * (size_t)ix[e], *B = pm.positions + 3 * (size_t)ix[(e + 1) % 3];
                double M[3] = { ((double)A[0] + B[0]) / 2, ((double)A[1] + B[1]) / 2, ((double)A[2] + B[2]) / 2 };
                on_edge |= passes_exactly(&s.rays[i], 0.5, M);
            }
            assert_true(on_edge);
        }
    }
    assert_int_equal(per_tag[SC_RAY_TAG_VERTEX], 1000);
    assert_int_equal(per_tag[SC_RAY_TAG_EDGE] + per_tag[SC_RAY_TAG_EDGE_BACK], 2000);
    assert_int_equal(per_tag[SC_RAY_TAG_GRAZING], 1000);
    /* the unit sphere's coordinates allow exact aim for most rays */
    assert_true(exact[SC_RAY_TAG_VERTEX] > 500);
    assert_true(exact[SC_RAY_TAG_EDGE] + exact[SC_RAY_TAG_EDGE_BACK] > 1000);
    sc_rayset_free(&s);
    sc_proc_free(&pm);
}

static void test_shadow_and_diffuse(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_heightfield(8, &pm), SC_OK);
    sc_mesh_view m = sc_proc_view(&pm);
    sc_checked_mesh cm;
    assert_int_equal(sc_mesh_check(&m, &cm), SC_OK);
    /* two hand-made primary rays: one hits triangle 0, one misses */
    sc_rayset from;
    memset(&from, 0, sizeof from);
    sc_ray rays[2] = { { { 0.05f, 1, 0.02f }, 0, { 0, -1, 0 }, INFINITY },
                       { { 5, 5, 5 }, 0, { 1, 0, 0 }, INFINITY } };
    from.rays = rays, from.count = 2;
    const float *A = pm.positions;
    sc_hitrec hits[2] = { { 1 - A[1], 0, 0, 0, { 0, 0, 0 }, 0, SC_INVALID_ID },
                          { INFINITY, 0, 0, SC_HITREC_MISS, { 0, 0, 0 }, SC_INVALID_ID, SC_INVALID_ID } };
    const float light[3] = { 0.5f, 3, 0.5f };
    sc_rayset sh, df;
    assert_int_equal(sc_rayset_shadow(&cm, &from, hits, light, &sh), SC_OK);
    assert_int_equal(sh.count, 1);
    assert_true(sh.rays[0].tmax == 1.0f);
    assert_true(sh.rays[0].org[1] > A[1]);     /* offset towards the incoming side */
    for (int k = 0; k < 3; k++)
        assert_true(fabs(sh.rays[0].org[k] + sh.rays[0].dir[k] - light[k]) < 1e-6);
    assert_int_equal(sc_rayset_diffuse(&cm, &from, hits, 5, &df), SC_OK);
    assert_int_equal(df.count, 1);
    assert_true(df.rays[0].dir[1] > 0);          /* the hemisphere the ray came from */
    sc_rayset_free(&sh), sc_rayset_free(&df);
    assert_int_equal(sc_rayset_shadow(&cm, &from, NULL, light, &sh), SC_ERR_INVALID_ARGUMENT);
    sc_proc_free(&pm);
}

/* sc_mesh_is_closed on a view, checked first. */
static sc_status closed_of(const sc_mesh_view *m, int *closed)
{
    sc_checked_mesh cm;
    sc_status st = sc_mesh_check(m, &cm);
    return st != SC_OK ? st : sc_mesh_is_closed(&cm, closed);
}

static void test_closed(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    int closed = -1;
    sc_mesh_view m;
    assert_int_equal(sc_proc_icosphere(2, &pm), SC_OK);
    m = sc_proc_view(&pm);
    assert_int_equal(closed_of(&m, &closed), SC_OK);
    assert_int_equal(closed, 1);
    sc_proc_free(&pm);
    assert_int_equal(sc_proc_cube(&pm), SC_OK);
    m = sc_proc_view(&pm);
    assert_int_equal(closed_of(&m, &closed), SC_OK);
    assert_int_equal(closed, 1);
    /* removing one triangle opens it */
    m.triangle_count = 11;
    assert_int_equal(closed_of(&m, &closed), SC_OK);
    assert_int_equal(closed, 0);
    sc_proc_free(&pm);
    assert_int_equal(sc_proc_heightfield(4, &pm), SC_OK);
    m = sc_proc_view(&pm);
    assert_int_equal(closed_of(&m, &closed), SC_OK);
    assert_int_equal(closed, 0);
    uint32_t bad[3] = { 0, 1, 999 };
    m.indices = bad, m.triangle_count = 1;
    assert_int_equal(closed_of(&m, &closed), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_mesh_is_closed(NULL, &closed), SC_ERR_INVALID_ARGUMENT);
    sc_proc_free(&pm);
}

/* The one check: what it refuses, and that a refused mesh leaves nothing to trust. */
static void test_mesh_check(void **state)
{
    (void)state;
    const float P[9] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
    const uint32_t I[3] = { 0, 1, 2 }, far[3] = { 0, 1, 3 };
    sc_mesh_view m = { P, 3, I, 1, 0, 0 };
    sc_checked_mesh cm;
    assert_int_equal(sc_mesh_check(&m, &cm), SC_OK);
    assert_ptr_equal(cm.view.positions, P);
    assert_true(cm.lo[0] == 0 && cm.lo[1] == 0 && cm.hi[0] == 1 && cm.hi[1] == 1 && cm.hi[2] == 0);
    float Q[9];
    memcpy(Q, P, sizeof Q);
    Q[4] = NAN;
    m.positions = Q;
    assert_int_equal(sc_mesh_check(&m, &cm), SC_ERR_NONFINITE);
    assert_null(cm.view.positions);
    m.positions = P, m.indices = far;
    assert_int_equal(sc_mesh_check(&m, &cm), SC_ERR_INVALID_ARGUMENT);
    m.indices = I, m.triangle_count = 0;
    assert_int_equal(sc_mesh_check(&m, &cm), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_mesh_check(NULL, &cm), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_mesh_check(&m, NULL), SC_ERR_INVALID_ARGUMENT);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_primary_covers_every_pixel),
        cmocka_unit_test(test_adversarial_targets),
        cmocka_unit_test(test_shadow_and_diffuse),
        cmocka_unit_test(test_closed),
        cmocka_unit_test(test_mesh_check),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

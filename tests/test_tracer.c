/* The comparison harness (src/compare/tracer.h): every tracer of the table
 * agrees with our BVH on one mesh, threaded runs equal single-thread ones,
 * occlusion agrees with closest hits, counters count, and same_hit and the
 * light point decide as documented. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "compare/tracer.h"

/* Two wavy n x n grids, one above the other: shared edges, occlusion and
 * a second layer to hide. */
enum { N = 24 };
static float pos[2 * (N + 1) * (N + 1) * 3];
static uint32_t idx[2 * N * N * 6];

static sc_mesh_view make_mesh(void)
{
    uint32_t nv = 0, nt = 0;
    for (int layer = 0; layer < 2; layer++) {
        uint32_t base = nv;
        for (int y = 0; y <= N; y++)
            for (int x = 0; x <= N; x++, nv++) {
                pos[3 * nv + 0] = (float)x / N;
                pos[3 * nv + 1] = (float)y / N;
                pos[3 * nv + 2] = 0.5f * (float)layer + 0.05f * sinf(7.0f * (float)(x + 2 * y) / N);
            }
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++) {
                uint32_t a = base + (uint32_t)(y * (N + 1) + x), b = a + 1, c = a + N + 1, d = c + 1;
                uint32_t *t = &idx[3 * nt];
                t[0] = a, t[1] = b, t[2] = d, t[3] = a, t[4] = d, t[5] = c;
                nt += 2;
            }
    }
    return (sc_mesh_view){ pos, nv, idx, nt, 0, 0 };
}

static void test_same_hit(void **state)
{
    (void)state;
    sc_hitrec miss = { .prim = SC_HITREC_MISS }, a = { .t = 2.0f, .prim = 5 }, b = { .t = 2.0f, .prim = 6 },
              c = { .t = 2.1f, .prim = 6 }, a2 = { .t = 2.0001f, .prim = 5 };
    assert_true(sc_same_hit(&miss, &miss, 0));
    assert_false(sc_same_hit(&a, &miss, 1e-4f));
    assert_false(sc_same_hit(&miss, &a, 1e-4f));
    assert_true(sc_same_hit(&a, &b, 0));          /* another triangle at the same t: an edge or a tie */
    assert_false(sc_same_hit(&a, &c, 1e-4f));
    assert_true(sc_same_hit(&a, &a2, 1e-4f));
    assert_false(sc_same_hit(&a, &a2, 0));
}

static void test_light_point(void **state)
{
    (void)state;
    const float lo[3] = { 0, 0, 0 }, hi[3] = { 2, 0, 0 };   /* centre (1,0,0), diagonal 2 */
    float out[3];
    sc_light_point(NULL, 0, lo, hi, out);
    assert_float_equal(out[0], 1 + 4 * 0.3f, 1e-6);
    assert_float_equal(out[1], 4.0f, 1e-6);
    assert_float_equal(out[2], 4 * 0.2f, 1e-6);
    sc_light lights[2] = { { SC_LIGHT_DIRECTIONAL, { 0, 0, -1 }, { 1, 1, 1 } },
                           { SC_LIGHT_POINT, { 5, 6, 7 }, { 1, 1, 1 } } };
    sc_light_point(lights, 1, lo, hi, out);        /* two diagonals back along the direction */
    assert_float_equal(out[0], 1.0f, 1e-6);
    assert_float_equal(out[2], 4.0f, 1e-6);
    sc_light_point(lights, 2, lo, hi, out);        /* a point light wins wherever it is */
    assert_float_equal(out[0], 5.0f, 0);
    assert_float_equal(out[1], 6.0f, 0);
    assert_float_equal(out[2], 7.0f, 0);
}

static void test_table(void **state)
{
    (void)state;
    int n;
    const char *const *names = sc_tracer_names(&n);
    assert_true(n >= 5);
    assert_null(names[n]);
    for (int i = 0; i < n; i++)
        assert_ptr_equal(sc_tracer_find(names[i])->name, names[i]);
    assert_null(sc_tracer_find("no-such-tracer"));
    assert_null(sc_tracer_find(NULL));
}

static void test_every_tracer_agrees(void **state)
{
    (void)state;
    sc_mesh_view mv = make_mesh();
    sc_checked_mesh m;
    assert_int_equal(sc_mesh_check(&mv, &m), SC_OK);
    const float lo[3] = { -0.2f, -0.2f, -0.5f }, hi[3] = { 1.2f, 1.2f, 1.0f };
    sc_rayset rs;
    assert_int_equal(sc_rayset_random(lo, hi, 4000, 7, &rs), SC_OK);
    size_t nr = rs.count;
    sc_hitrec *ref = calloc(nr, sizeof *ref), *hits = calloc(nr, sizeof *hits), *hits2 = calloc(nr, sizeof *hits2);
    uint8_t *occ = calloc(nr, 1);
    assert_true(ref && hits && hits2 && occ);

    sc_tracer t;
    assert_int_equal(sc_tracer_build(&t, sc_tracer_find("spherecull-off"), &m), SC_OK);
    assert_non_null(sc_tracer_bvh(&t));
    assert_int_equal(sc_tracer_run(&t, rs.rays, nr, ref, NULL, NULL), SC_OK);
    sc_tracer_free(&t);
    size_t nhit = 0;
    for (size_t i = 0; i < nr; i++)
        nhit += ref[i].prim != SC_HITREC_MISS;
    assert_true(nhit > nr / 10 && nhit < nr);        /* the rays test something */

    int n;
    const char *const *names = sc_tracer_names(&n);
    for (int k = 0; k < n; k++) {
        const sc_tracer_def *def = sc_tracer_find(names[k]);
        assert_int_equal(sc_tracer_build(&t, def, &m), SC_OK);
        assert_true(t.bytes_per_tri > 0);
        sc_tracer_counters ctr;
        memset(&ctr, 0, sizeof ctr);
        assert_int_equal(sc_tracer_run(&t, rs.rays, nr, hits, NULL, &ctr), SC_OK);
        size_t differ = 0;
        for (size_t i = 0; i < nr; i++)
            differ += !sc_same_hit(&hits[i], &ref[i], 1e-4f);
        print_message("%-24s %zu of %zu rays differ from spherecull-off\n", names[k], differ, nr);
        assert_true(differ <= nr / 1000);
        assert_true(ctr.sphere_rejects <= ctr.sphere_tests);
        if (t.fp_exact)                               /* every leaf has spheres (auto may have none) */
            assert_true(ctr.sphere_tests > 0 && ctr.false_positives <= ctr.sphere_tests - ctr.sphere_rejects);
        if (t.counted)
            assert_true(ctr.tri_tests >= ctr.tri_hits && ctr.tri_hits > 0);
        if (def->family == SC_TRACER_OURS)
            assert_int_equal(ctr.rays, nr);

        /* Threads hand out chunks; the answers are the same rays' answers. */
        memset(hits2, 0xff, nr * sizeof *hits2);
        double secs = -1;
        assert_int_equal(sc_tracer_run_threads(&t, rs.rays, nr, hits2, NULL, 3, &secs), SC_OK);
        assert_true(secs >= 0);
        for (size_t i = 0; i < nr; i++) {
            assert_int_equal(hits2[i].prim, hits[i].prim);
            assert_true(hits2[i].prim == SC_HITREC_MISS || hits2[i].t == hits[i].t);
        }
        if (!def->packet) {
            assert_int_equal(sc_tracer_run_threads(&t, rs.rays, nr, NULL, occ, 2, NULL), SC_OK);
            for (size_t i = 0; i < nr; i++)
                assert_int_equal(occ[i], hits[i].prim != SC_HITREC_MISS);
        }
        assert_int_equal(sc_tracer_run_threads(&t, rs.rays, nr, hits2, NULL, 0, NULL), SC_ERR_INVALID_ARGUMENT);
        sc_tracer_free(&t);
        assert_null(t.handle);
    }
    free(ref), free(hits), free(hits2), free(occ);
    sc_rayset_free(&rs);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_hit),
        cmocka_unit_test(test_light_point),
        cmocka_unit_test(test_table),
        cmocka_unit_test(test_every_tracer_agrees),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

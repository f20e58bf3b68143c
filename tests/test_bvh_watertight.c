/* Watertightness: from inside a closed tessellated sphere every ray must hit
 * something. Rays go exactly through mesh vertices (origin at the exact
 * centre, direction = vertex - centre, which is exact in float here), close
 * to edges (direction = fl(P + Q) for a shared edge PQ), and in random
 * directions from random interior points. A miss is a hole; the count must
 * be 0 for the watertight test behind the robust traversal, for every leaf
 * size, prefilter mode and kernel set. Moller-Trumbore's count is printed for
 * comparison only. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include "bvh_test_util.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_trace.h"

typedef struct closed_case {
    const char *name;
    double centre[3], radius;
    int level;
} closed_case;

static size_t make_inside_rays(const tmesh *m, const float c[3], float radius, sc_ray **out)
{
    size_t n = m->nv + 3 * m->nt + 100000, k = 0;
    sc_ray *rays = malloc(n * sizeof *rays);
    for (size_t i = 0; i < m->nv; i++) {
        sc_ray *r = &rays[k++];
        for (int a = 0; a < 3; a++) {
            r->org[a] = c[a];
            r->dir[a] = m->pos[3 * i + a] - c[a];
        }
        r->tmin = 0, r->tmax = INFINITY;
    }
    for (size_t t = 0; t < m->nt; t++)
        for (int e = 0; e < 3; e++) {
            const float *P = m->pos + 3 * m->idx[3 * t + e], *Q = m->pos + 3 * m->idx[3 * t + (e + 1) % 3];
            sc_ray *r = &rays[k++];
            for (int a = 0; a < 3; a++) {
                r->org[a] = c[a];
                r->dir[a] = (float)(((double)P[a] - c[a]) + ((double)Q[a] - c[a]));
            }
            r->tmin = 0, r->tmax = INFINITY;
        }
    sc_rng rng;
    sc_rng_seed(&rng, 99);
    for (size_t i = 0; i < 100000; i++) {
        sc_ray *r = &rays[k++];
        double z = sc_rng_range(&rng, -1, 1), ph = sc_rng_range(&rng, 0, 6.283185307179586), s = sqrt(1 - z * z);
        double d[3] = { s * cos(ph), s * sin(ph), z };
        for (int a = 0; a < 3; a++) {
            r->org[a] = (float)(c[a] + 0.5 * radius * sc_rng_range(&rng, -1, 1));
            r->dir[a] = (float)d[a];
        }
        r->tmin = 0, r->tmax = INFINITY;
    }
    *out = rays;
    return k;
}

static void run_case(const closed_case *cc)
{
    tmesh m = { 0 };
    scene_icosphere(&m, cc->level, cc->radius, cc->centre);
    float c[3] = { (float)cc->centre[0], (float)cc->centre[1], (float)cc->centre[2] };
    assert_true(c[0] == cc->centre[0] && c[1] == cc->centre[1] && c[2] == cc->centre[2]);
    sc_ray *rays;
    size_t n = make_inside_rays(&m, c, (float)cc->radius, &rays);
    const int leaves[] = { 1, 4, 16 };
    const sc_prefilter_mode modes[] = { SC_PREFILTER_OFF, SC_PREFILTER_MINIMAL, SC_PREFILTER_CIRCUM };
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++)
        for (int isa = SC_ISA_SCALAR; isa < SC_ISA_COUNT; isa++) {
            if (!sc_isa_supported((sc_isa)isa))
                continue;
            for (size_t li = 0; li < 3; li++)
                for (size_t mi = 0; mi < 3; mi++) {
                    if (tt == SC_TRI_MOLLER && (li != 1 || mi != 0))
                        continue;
                    sc_bvh_config cfg;
                    sc_bvh_config_default(&cfg);
                    cfg.leaf_size = leaves[li];
                    cfg.prefilter = modes[mi];
                    assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
                    cfg.tri_test = (sc_tri_test)tt;
                    sc_bvh *b;
                    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ m.pos, m.nv, m.idx, m.nt, 0, 0 }, &cfg, &b), SC_OK);
                    size_t holes = 0, any_holes = 0;
                    for (size_t i = 0; i < n; i++) {
                        sc_hitrec h;
                        int occ;
                        assert_int_equal(sc_trace_closest(b, &rays[i], &h, NULL), SC_OK);
                        assert_int_equal(sc_trace_any(b, &rays[i], &occ, NULL), SC_OK);
                        holes += h.prim == SC_HITREC_MISS;
                        any_holes += !occ;
                    }
                    if (tt == SC_TRI_MOLLER || holes || any_holes)
                        print_message("%s (%zu tris): %s %s leaf %d %s: %zu rays, holes %zu (any-hit %zu)\n",
                                      cc->name, m.nt, sc_tri_test_name((sc_tri_test)tt),
                                      sc_isa_name((sc_isa)isa), leaves[li],
                                      sc_prefilter_mode_name(modes[mi]), n, holes, any_holes);
                    if (tt == SC_TRI_WATERTIGHT) {
                        assert_int_equal(holes, 0);
                        assert_int_equal(any_holes, 0);
                    }
                    sc_bvh_free(b);
                }
        }
    print_message("%s: %zu triangles, %zu rays per configuration, watertight holes 0\n", cc->name, m.nt, n);
    free(rays);
    tmesh_free(&m);
}

static void test_unit(void **state)
{
    (void)state;
    closed_case cc = { "unit sphere", { 0, 0, 0 }, 1.0, 4 };
    run_case(&cc);
}

static void test_offset(void **state)
{
    (void)state;
    closed_case cc = { "sphere at 1e4", { 1e4, -1e4, 1e4 }, 1.0, 3 };
    run_case(&cc);
}

static void test_tiny(void **state)
{
    (void)state;
    closed_case cc = { "sphere r=1e-4", { 0.5, 0.25, -0.125 }, 1e-4, 4 };
    run_case(&cc);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_unit),
        cmocka_unit_test(test_offset),
        cmocka_unit_test(test_tiny),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

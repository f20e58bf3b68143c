/* BVH + traversal against a brute-force double-precision oracle
 * (bvh_test_util.h), for every leaf size and prefilter mode, on procedural
 * scenes and (if present) the shared bunny.
 *
 * Per ray, with the oracle's tolerances:
 *   (1) a reported hit on triangle p at t: p is a relaxed hit of the oracle
 *       and |t - t_oracle(p)| <= tol(p);
 *   (2) no robust oracle hit is clearly nearer than the reported t, and a
 *       reported miss means there is no robust hit at all;
 * so a different primitive than the oracle's nearest is accepted only at a
 * tie (same t within tolerance) next to an edge. Every prefilter mode must
 * return bit-identical hits to mode off, and any-hit must agree with
 * closest-hit on hit/miss. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include "bvh/bvh_internal.h"
#include "bvh/node_bvh8.h"
#include "bvh_test_util.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_trace.h"

#define NRAYS 100000

typedef struct scene_case {
    const char *name;
    tmesh m;
    sc_ray *rays;
    size_t nrays;
    oracle orc;
    oracle_hit *ref;
} scene_case;

static void make_rays(scene_case *sc, size_t n, uint64_t seed)
{
    const tmesh *m = &sc->m;
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (size_t i = 0; i < m->nv; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], m->pos[3 * i + k]);
            hi[k] = fmax(hi[k], m->pos[3 * i + k]);
        }
    sc_rng r;
    sc_rng_seed(&r, seed);
    sc->rays = malloc(n * sizeof(sc_ray));
    sc->nrays = n;
    for (size_t i = 0; i < n; i++) {
        sc_ray *ray = &sc->rays[i];
        double o[3], d[3];
        for (int k = 0; k < 3; k++) {
            double e = hi[k] - lo[k];
            o[k] = sc_rng_range(&r, lo[k] - 0.5 * e, hi[k] + 0.5 * e);
        }
        if (i % 2 == 0) {
            /* Aimed at a random point of a random triangle. */
            size_t t = (size_t)(sc_rng_uniform(&r) * (double)m->nt);
            double a = sc_rng_uniform(&r), b = sc_rng_uniform(&r);
            if (a + b > 1) a = 1 - a, b = 1 - b;
            for (int k = 0; k < 3; k++) {
                double p0 = m->pos[3 * m->idx[3 * t] + k], p1 = m->pos[3 * m->idx[3 * t + 1] + k],
                       p2 = m->pos[3 * m->idx[3 * t + 2] + k];
                d[k] = p0 + a * (p1 - p0) + b * (p2 - p0) - o[k];
            }
        } else {
            double z = sc_rng_range(&r, -1, 1), ph = sc_rng_range(&r, 0, 6.283185307179586), s = sqrt(1 - z * z);
            d[0] = s * cos(ph), d[1] = s * sin(ph), d[2] = z;
        }
        for (int k = 0; k < 3; k++) {
            ray->org[k] = (float)o[k];
            ray->dir[k] = (float)d[k];
        }
        if (ray->dir[0] == 0 && ray->dir[1] == 0 && ray->dir[2] == 0)
            ray->dir[0] = 1;
        ray->tmin = 0;
        ray->tmax = INFINITY;
        if (i % 5 == 0)                  /* aimed rays reach their target at t = 1 */
            ray->tmax = (float)sc_rng_range(&r, 0.2, 1.5);
        if (i % 11 == 0)
            ray->tmin = (float)sc_rng_range(&r, 0, 0.8);
    }
    oracle_init(&sc->orc, m);
    sc->ref = malloc(n * sizeof(oracle_hit));
    for (size_t i = 0; i < n; i++)
        oracle_trace(&sc->orc, &sc->rays[i], &sc->ref[i]);
}

static void scene_free(scene_case *sc)
{
    tmesh_free(&sc->m);
    free(sc->rays);
    free(sc->ref);
    oracle_free(&sc->orc);
}

typedef struct check_result {
    size_t hits, bad, prim_diff;
    double max_terr;      /* max |t - t_oracle| / tol */
} check_result;

/* The reported geometric normal against (V1 - V0) x (V2 - V0) in double
 * from the mesh: the float computation rounds e1, e2, the products and the
 * differences, each by at most 2^-24 relative, so every component is within
 * 2^-20 |e1| |e2| of the double one. */
static int normal_ok(const tmesh *m, uint32_t prim, const float ng[3])
{
    const float *v[3];
    for (int j = 0; j < 3; j++)
        v[j] = m->pos + 3 * (size_t)m->idx[3 * (size_t)prim + j];
    double e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++)
        e1[k] = (double)v[1][k] - v[0][k], e2[k] = (double)v[2][k] - v[0][k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const double tol = 0x1p-20 * sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]) *
                       sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
    for (int k = 0; k < 3; k++)
        if (!(fabs(ng[k] - n[k]) <= tol))
            return 0;
    return 1;
}

static void check_against_oracle(const scene_case *sc, const sc_hitrec *h, check_result *res, const char *what)
{
    memset(res, 0, sizeof *res);
    for (size_t i = 0; i < sc->nrays; i++) {
        const oracle_hit *o = &sc->ref[i];
        const sc_ray *ray = &sc->rays[i];
        int ok = 1;
        if (h[i].prim == SC_HITREC_MISS) {
            ok = isinf(o->t_robust) && h[i].geom == SC_INVALID_ID && h[i].inst == SC_INVALID_ID &&
                 h[i].ng[0] == 0 && h[i].ng[1] == 0 && h[i].ng[2] == 0;
        } else {
            res->hits++;
            ok = h[i].geom == 0 && h[i].inst == SC_INVALID_ID && h[i].prim < sc->m.nt &&
                 normal_ok(&sc->m, h[i].prim, h[i].ng);
            double tp, tol = h[i].prim < sc->orc.n ? oracle_tri(&sc->orc, h[i].prim, ray, &tp) : -1;
            if (!ok || tol < 0 || !(fabs(h[i].t - tp) <= tol)) {
                ok = 0;
            } else {
                double e = tol > 0 ? fabs(h[i].t - tp) / tol : 0;
                if (e > res->max_terr)
                    res->max_terr = e;
                ok = h[i].t - tol <= o->t_robust;
            }
            if (h[i].prim != o->prim)
                res->prim_diff++;
        }
        if (!ok) {
            if (res->bad < 5)
                print_message("  %s ray %zu: got prim %u t %.9g, oracle prim %u t %.9g robust<=%.9g\n", what, i,
                              (unsigned)h[i].prim, (double)h[i].t, (unsigned)o->prim, o->t, o->t_robust);
            res->bad++;
        }
    }
}

static const int leaf_sizes[] = { 1, 4, 8, 16 };

/* isa < 0: the level active now; otherwise every kernel is switched to it. */
static sc_bvh *build(const tmesh *m, int leaf, sc_prefilter_mode mode, int isa, sc_tri_test tt)
{
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.leaf_size = leaf;
    cfg.prefilter = mode;
    if (isa >= 0)
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
    cfg.tri_test = tt;
    sc_bvh *bvh = NULL;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ m->pos, m->nv, m->idx, m->nt, 0, 0 }, &cfg, &bvh), SC_OK);
    assert_non_null(bvh);
    return bvh;
}

static void trace_all(const sc_bvh *bvh, const scene_case *sc, sc_hitrec *h)
{
    for (size_t i = 0; i < sc->nrays; i++)
        assert_int_equal(sc_trace_closest(bvh, &sc->rays[i], &h[i], NULL), SC_OK);
}

static int same_hit(const sc_hitrec *a, const sc_hitrec *b)
{
    return a->prim == b->prim && memcmp(&a->t, &b->t, sizeof(float)) == 0 &&
           memcmp(&a->u, &b->u, sizeof(float)) == 0 && memcmp(&a->v, &b->v, sizeof(float)) == 0;
}

static void run_scene(scene_case *sc)
{
    sc_hitrec *h = malloc(sc->nrays * sizeof *h), *off = malloc(sc->nrays * sizeof *off);
    size_t robust = 0;
    for (size_t i = 0; i < sc->nrays; i++)
        robust += !isinf(sc->ref[i].t_robust);
    print_message("%s: %zu triangles, %zu rays, %zu robust oracle hits\n", sc->name, sc->m.nt, sc->nrays, robust);
    for (size_t li = 0; li < sizeof leaf_sizes / sizeof leaf_sizes[0]; li++) {
        for (int mode = 0; mode < SC_PREFILTER_MODE_COUNT; mode++) {
            sc_bvh *bvh = build(&sc->m, leaf_sizes[li], (sc_prefilter_mode)mode, -1, SC_TRI_WATERTIGHT);
            sc_hitrec *cur = mode == 0 ? off : h;
            trace_all(bvh, sc, cur);
            char what[64];
            snprintf(what, sizeof what, "leaf %d %s", leaf_sizes[li], sc_prefilter_mode_name((sc_prefilter_mode)mode));
            check_result res;
            check_against_oracle(sc, cur, &res, what);
            sc_bvh_info info;
            assert_int_equal(sc_bvh_get_info(bvh, &info), SC_OK);
            print_message("  %-18s hits %6zu  bad %zu  prim!=oracle %zu  max|dt|/tol %.3f  %.1f B/tri  sphere leaves %zu/%zu\n",
                          what, res.hits, res.bad, res.prim_diff, res.max_terr,
                          (double)info.total_bytes / (double)(info.triangles ? info.triangles : 1),
                          info.leaves_with_spheres, info.leaves);
            assert_int_equal(res.bad, 0);
            /* The auto rule (sc_bvh.h): blocks of 4 and 8 never get spheres. */
            if (mode == SC_PREFILTER_AUTO && leaf_sizes[li] <= 8)
                assert_int_equal(info.leaves_with_spheres, 0);
            /* A prefilter never changes a hit. */
            if (mode != 0) {
                size_t diff = 0;
                for (size_t i = 0; i < sc->nrays; i++)
                    diff += !same_hit(&h[i], &off[i]);
                assert_int_equal(diff, 0);
            }
            /* any-hit agrees with closest-hit; statistics do not change a hit. */
            sc_trace_stats st = { 0 };
            for (size_t i = 0; i < sc->nrays; i += 7) {
                int occ = -1;
                assert_int_equal(sc_trace_any(bvh, &sc->rays[i], &occ, NULL), SC_OK);
                assert_int_equal(occ, cur[i].prim != SC_HITREC_MISS);
                int occ2 = -1;
                assert_int_equal(sc_trace_any(bvh, &sc->rays[i], &occ2, &st), SC_OK);
                assert_int_equal(occ2, occ);
                sc_hitrec hs;
                assert_int_equal(sc_trace_closest(bvh, &sc->rays[i], &hs, &st), SC_OK);
                assert_true(same_hit(&hs, &cur[i]));
            }
            assert_true(st.sphere_rejects <= st.sphere_tests);
            assert_true(st.tri_hits <= st.tri_tests);
            if (mode == SC_PREFILTER_OFF)
                assert_int_equal(st.sphere_tests, 0);
            else if (mode != SC_PREFILTER_AUTO)
                assert_true(st.sphere_tests > 0);
            assert_true(st.nodes >= st.rays);
            sc_bvh_free(bvh);
        }
    }
    free(h);
    free(off);
}

static void test_soup(void **state)
{
    (void)state;
    scene_case sc = { .name = "soup" };
    scene_soup(&sc.m, 3000, 0, 1);
    make_rays(&sc, NRAYS, 11);
    run_scene(&sc);
    scene_free(&sc);
}

static void test_icosphere(void **state)
{
    (void)state;
    scene_case sc = { .name = "icosphere" };
    double c[3] = { 0.1, -0.2, 0.3 };
    scene_icosphere(&sc.m, 4, 1.0, c);
    make_rays(&sc, NRAYS, 12);
    run_scene(&sc);
    scene_free(&sc);
}

static void test_slivers(void **state)
{
    (void)state;
    scene_case sc = { .name = "slivers" };
    scene_slivers(&sc.m, 3000, 3);
    make_rays(&sc, NRAYS, 13);
    run_scene(&sc);
    scene_free(&sc);
}

static void test_offset(void **state)
{
    (void)state;
    scene_case sc = { .name = "offset 1e5" };
    scene_soup(&sc.m, 2000, 1e5, 4);
    make_rays(&sc, NRAYS, 14);
    run_scene(&sc);
    scene_free(&sc);
}

static void test_bunny(void **state)
{
    (void)state;
    const char *dir = getenv("SC_TEST_SCENES");
    char path[4096];
    snprintf(path, sizeof path, "%s/bunny.obj", dir ? dir : "../shared/scenes");
    scene_case sc = { .name = "bunny" };
    if (tmesh_read_obj(&sc.m, path) != 0) {
        tmesh_free(&sc.m);
        print_message("bunny: %s not readable, skipped\n", path);
        skip();
    }
    make_rays(&sc, NRAYS, 15);
    run_scene(&sc);
    scene_free(&sc);
}

/* Every kernel set returns bit-identical hits (same arithmetic, no FMA). */
static void test_isa_identical(void **state)
{
    (void)state;
    scene_case sc = { .name = "isa" };
    scene_soup(&sc.m, 2000, 0, 5);
    scene_slivers(&sc.m, 1000, 6);
    size_t n = 30000;
    sc.rays = NULL;
    make_rays(&sc, n, 16);
    /* Every 8th ray gets one or two direction components at the parallel
     * test's boundary (1e-18 = SC_MIN_RCP_INPUT takes the octant kernels,
     * anything smaller the parallel node test), signed zeros included:
     * each level's choice of kernel (its own octant and parallel test)
     * must give the scalar answer. */
    const float tiny[] = { 0.0f, -0.0f, 1e-18f, -1e-18f, nextafterf(1e-18f, 0), -nextafterf(1e-18f, 0),
                           1e-30f, -3.0f };
    for (size_t i = 0; i < n; i += 8) {
        sc.rays[i].dir[i / 8 % 3] = tiny[i / 24 % 8];
        if (i % 16 == 0)
            sc.rays[i].dir[(i / 8 + 1) % 3] = tiny[(i / 24 + 3) % 8];
    }
    sc_hitrec *ref = malloc(n * sizeof *ref), *h = malloc(n * sizeof *h);
    const int leaves[] = { 3, 4, 8, 12, 16 };
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++)
        for (size_t li = 0; li < 5; li++)
            for (int mode = 0; mode < SC_PREFILTER_MODE_COUNT; mode += 2) {
                sc_bvh *b = build(&sc.m, leaves[li], (sc_prefilter_mode)mode, SC_ISA_SCALAR, (sc_tri_test)tt);
                trace_all(b, &sc, ref);
                sc_bvh_free(b);
                for (int isa = SC_ISA_SSE4; isa < SC_ISA_COUNT; isa++) {
                    if (!sc_isa_supported((sc_isa)isa))
                        continue;
                    b = build(&sc.m, leaves[li], (sc_prefilter_mode)mode, isa, (sc_tri_test)tt);
                    trace_all(b, &sc, h);
                    size_t diff = 0;
                    for (size_t i = 0; i < n; i++)
                        diff += !same_hit(&h[i], &ref[i]);
                    if (diff)
                        print_message("%s leaf %d %s %s: %zu differ from scalar\n", sc_tri_test_name((sc_tri_test)tt),
                                      leaves[li], sc_prefilter_mode_name((sc_prefilter_mode)mode),
                                      sc_isa_name((sc_isa)isa), diff);
                    assert_int_equal(diff, 0);
                    sc_bvh_free(b);
                }
            }
    free(ref);
    free(h);
    scene_free(&sc);
}

/* Every level visits the same nodes and leaves as the scalar specification,
 * ray by ray, not only returns its hits: the x86 node tests take the entry
 * and exit distances as integer max/min, which matches the float test only
 * with no -0 among the exit distances and tmin >= +0 (ray_setup_x86.h,
 * ctx_set_slab). A tmin or tmax of -0 must change nothing; with tmin = -0
 * taken as is, boxes behind the origin would be entered, which the
 * counters see though the hits do not. Rays from inside the scene, both
 * zeros at both ends, and tmax = 0. */
static void test_isa_same_visits(void **state)
{
    (void)state;
    scene_case sc = { .name = "visits" };
    scene_soup(&sc.m, 1500, 0, 9);
    size_t n = 6000;
    make_rays(&sc, n, 23);
    const float ends[][2] = { { -0.0f, INFINITY }, { 0.0f, INFINITY }, { -0.0f, -0.0f }, { 0.0f, -0.0f },
                              { -0.0f, 0.0f }, { -0.0f, 0.5f } };
    for (size_t i = 0; i < n; i++) {
        sc.rays[i].tmin = ends[i % 6][0];
        sc.rays[i].tmax = ends[i % 6][1];
    }
    sc_trace_stats *ref = calloc(n, sizeof *ref), *st = calloc(n, sizeof *st);
    sc_hitrec *href = malloc(n * sizeof *href), *h = malloc(n * sizeof *h);
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++) {
        sc_bvh *b = build(&sc.m, 8, SC_PREFILTER_OFF, SC_ISA_SCALAR, (sc_tri_test)tt);
        for (size_t i = 0; i < n; i++) {
            ref[i] = (sc_trace_stats){ 0 };   /* the counters add up */
            assert_int_equal(sc_trace_closest(b, &sc.rays[i], &href[i], &ref[i]), SC_OK);
        }
        sc_bvh_free(b);
        for (int isa = SC_ISA_SSE4; isa < SC_ISA_COUNT; isa++) {
            if (!sc_isa_supported((sc_isa)isa))
                continue;
            b = build(&sc.m, 8, SC_PREFILTER_OFF, isa, (sc_tri_test)tt);
            size_t diff = 0, behind = 0;
            for (size_t i = 0; i < n; i++) {
                st[i] = (sc_trace_stats){ 0 };
                assert_int_equal(sc_trace_closest(b, &sc.rays[i], &h[i], &st[i]), SC_OK);
                diff += st[i].nodes != ref[i].nodes || st[i].leaves != ref[i].leaves ||
                        st[i].tri_tests != ref[i].tri_tests || !same_hit(&h[i], &href[i]);
                behind += st[i].nodes > ref[i].nodes;
            }
            if (diff)
                print_message("%s %s: %zu rays visit differently from scalar (%zu visit more)\n",
                              sc_tri_test_name((sc_tri_test)tt), sc_isa_name((sc_isa)isa), diff, behind);
            assert_int_equal(diff, 0);
            sc_bvh_free(b);
        }
    }
    free(ref), free(st), free(href), free(h);
    scene_free(&sc);
}

/* The brute-force entry point uses the same arithmetic as the traversal,
 * so on well-conditioned triangles only exact ties in t may differ. (On
 * triangles that are degenerate at float precision a float test may report
 * any t, also outside the triangle's box, which the traversal never visits;
 * hence a soup without slivers here.) */
static void test_brute_same_arithmetic(void **state)
{
    (void)state;
    scene_case sc = { .name = "brute" };
    scene_soup(&sc.m, 2000, 0, 8);
    size_t n = 20000;
    make_rays(&sc, n, 18);
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++) {
        sc_bvh *b = build(&sc.m, 4, SC_PREFILTER_MINIMAL, -1, (sc_tri_test)tt);
        for (size_t i = 0; i < n; i++) {
            sc_hitrec bh, th;
            assert_int_equal(sc_trace_closest_brute(b, &sc.rays[i], &bh), SC_OK);
            assert_int_equal(sc_trace_closest(b, &sc.rays[i], &th, NULL), SC_OK);
            assert_int_equal(bh.prim == SC_HITREC_MISS, th.prim == SC_HITREC_MISS);
            assert_true(bh.prim == th.prim || bh.t == th.t);
        }
        sc_bvh_free(b);
    }
    scene_free(&sc);
}

/* Moller-Trumbore is not watertight but must agree with the oracle the
 * same way on generic rays. */
static void test_moller(void **state)
{
    (void)state;
    scene_case sc = { .name = "moller" };
    scene_soup(&sc.m, 3000, 0, 7);
    make_rays(&sc, NRAYS, 17);
    sc_hitrec *h = malloc(sc.nrays * sizeof *h);
    sc_bvh *b = build(&sc.m, 4, SC_PREFILTER_OFF, -1, SC_TRI_MOLLER);
    trace_all(b, &sc, h);
    check_result res;
    check_against_oracle(&sc, h, &res, "moller");
    print_message("moller: hits %zu bad %zu prim!=oracle %zu\n", res.hits, res.bad, res.prim_diff);
    assert_int_equal(res.bad, 0);
    sc_bvh_free(b);
    free(h);
    scene_free(&sc);
}

static void test_api(void **state)
{
    (void)state;
    float pos[9] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
    uint32_t idx[3] = { 0, 1, 2 }, bad_idx[3] = { 0, 1, 3 };
    sc_bvh *b = (sc_bvh *)1;
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ pos, 3, idx, 1, 0, 0 }, &cfg, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ NULL, 3, idx, 1, 0, 0 }, &cfg, &b), SC_ERR_INVALID_ARGUMENT);
    assert_null(b);
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ pos, 3, bad_idx, 1, 0, 0 }, &cfg, &b), SC_ERR_INVALID_ARGUMENT);
    cfg.leaf_size = 0;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ pos, 3, idx, 1, 0, 0 }, &cfg, &b), SC_ERR_INVALID_ARGUMENT);
    cfg.leaf_size = 17;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ pos, 3, idx, 1, 0, 0 }, &cfg, &b), SC_ERR_INVALID_ARGUMENT);
    sc_bvh_config_default(&cfg);
    cfg.prefilter = SC_PREFILTER_MODE_COUNT;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ pos, 3, idx, 1, 0, 0 }, &cfg, &b), SC_ERR_INVALID_ARGUMENT);
    sc_bvh_config_default(&cfg);
    cfg.quality = SC_BUILD_QUALITY_COUNT;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ pos, 3, idx, 1, 0, 0 }, &cfg, &b), SC_ERR_INVALID_ARGUMENT);

    /* Empty scene: every ray misses. */
    sc_bvh_config_default(&cfg);
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ NULL, 0, NULL, 0, 0, 0 }, &cfg, &b), SC_OK);
    sc_ray ray = { { 0.25f, 0.25f, -1 }, 0, { 0, 0, 1 }, INFINITY };
    sc_hitrec h;
    int occ = 7;
    assert_int_equal(sc_trace_closest(b, &ray, &h, NULL), SC_OK);
    assert_int_equal(h.prim, SC_HITREC_MISS);
    assert_int_equal(sc_trace_any(b, &ray, &occ, NULL), SC_OK);
    assert_int_equal(occ, 0);
    sc_bvh_free(b);

    /* One triangle, hit in the middle; both faces; bad rays rejected. */
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ pos, 3, idx, 1, 0, 0 }, &cfg, &b), SC_OK);
    assert_int_equal(sc_trace_closest(b, &ray, &h, NULL), SC_OK);
    assert_int_equal(h.prim, 0);
    assert_true(fabsf(h.t - 1) < 1e-6f && fabsf(h.u - 0.25f) < 1e-6f && fabsf(h.v - 0.25f) < 1e-6f);
    sc_ray back = { { 0.25f, 0.25f, 1 }, 0, { 0, 0, -2 }, INFINITY };
    assert_int_equal(sc_trace_closest(b, &back, &h, NULL), SC_OK);
    assert_int_equal(h.prim, 0);
    assert_true(fabsf(h.t - 0.5f) < 1e-6f);
    back.tmax = 0.49f;
    assert_int_equal(sc_trace_closest(b, &back, &h, NULL), SC_OK);
    assert_int_equal(h.prim, SC_HITREC_MISS);
    sc_ray nan_ray = { { NAN, 0, 0 }, 0, { 0, 0, 1 }, INFINITY };
    sc_ray zero_dir = { { 0, 0, 0 }, 0, { 0, 0, 0 }, INFINITY };
    assert_int_equal(sc_trace_closest(b, &nan_ray, &h, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_closest(b, &zero_dir, &h, NULL), SC_ERR_INVALID_ARGUMENT);
    sc_ray neg_tmin = { { 0.25f, 0.25f, -1 }, -1, { 0, 0, 1 }, INFINITY };
    sc_ray far_org = { { 1e19f, 0.25f, -1 }, 0, { -1, 0, 1 }, INFINITY };
    assert_int_equal(sc_trace_closest(b, &neg_tmin, &h, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_any(b, &far_org, &occ, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_closest(NULL, &ray, &h, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_any(b, &ray, NULL, NULL), SC_ERR_INVALID_ARGUMENT);
    sc_bvh_free(b);

    /* A triangle with a non-finite vertex is left out. */
    float posn[12] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, INFINITY, 0, 0 };
    uint32_t idx2[6] = { 0, 1, 2, 0, 1, 3 };
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ posn, 4, idx2, 2, 0, 0 }, &cfg, &b), SC_OK);
    sc_bvh_info info;
    assert_int_equal(sc_bvh_get_info(b, &info), SC_OK);
    assert_int_equal(info.triangles, 1);
    assert_int_equal(info.skipped_triangles, 1);
    sc_bvh_free(b);

    sc_prefilter_mode m;
    assert_int_equal(sc_prefilter_mode_from_name("minimal", &m), SC_OK);
    assert_int_equal(m, SC_PREFILTER_MINIMAL);
    assert_int_equal(sc_prefilter_mode_from_name("bogus", &m), SC_ERR_INVALID_ARGUMENT);
}

/* The same soup given as float4 vertices (w = NaN, which must never be
 * read) and index quads (a fourth index out of range, never read either):
 * the tree built through the strided view answers every ray bit for bit as
 * the packed one, for each triangle test; bad layouts are refused. */
static void test_strided_layout(void **state)
{
    (void)state;
    scene_case sc = { .name = "soup-strided" };
    scene_soup(&sc.m, 2000, 0, 1);
    make_rays(&sc, NRAYS, 23);
    float (*v4)[4] = malloc(sizeof *v4 * sc.m.nv);
    uint32_t (*i4)[4] = malloc(sizeof *i4 * sc.m.nt);
    assert_non_null(v4);
    assert_non_null(i4);
    for (uint32_t i = 0; i < sc.m.nv; i++) {
        memcpy(v4[i], sc.m.pos + 3 * (size_t)i, 3 * sizeof(float));
        v4[i][3] = NAN;
    }
    for (uint32_t t = 0; t < sc.m.nt; t++) {
        memcpy(i4[t], sc.m.idx + 3 * (size_t)t, 3 * sizeof(uint32_t));
        i4[t][3] = UINT32_MAX;
    }
    const sc_mesh_view packed = { sc.m.pos, sc.m.nv, sc.m.idx, sc.m.nt, 0, 0 };
    const sc_mesh_view strided = { &v4[0][0], sc.m.nv, &i4[0][0], sc.m.nt, sizeof v4[0], sizeof i4[0] };
    sc_hitrec *ha = malloc(sizeof *ha * sc.nrays), *hb = malloc(sizeof *hb * sc.nrays);
    assert_non_null(ha);
    assert_non_null(hb);
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.tri_test = (sc_tri_test)tt;
        cfg.prefilter = SC_PREFILTER_MINIMAL;
        sc_bvh *a = NULL, *b = NULL;
        assert_int_equal(sc_bvh_build(&packed, &cfg, &a), SC_OK);
        assert_int_equal(sc_bvh_build(&strided, &cfg, &b), SC_OK);
        trace_all(a, &sc, ha);
        trace_all(b, &sc, hb);
        size_t hits = 0;
        for (size_t i = 0; i < sc.nrays; i++) {
            assert_true(same_hit(&ha[i], &hb[i]));
            hits += ha[i].prim != SC_HITREC_MISS;
        }
        assert_true(hits > sc.nrays / 10);     /* the comparison saw hits */
        sc_bvh_free(a);
        sc_bvh_free(b);
    }
    /* The checked mesh of the strided view has the packed view's bounds. */
    sc_checked_mesh ca, cb;
    assert_int_equal(sc_mesh_check(&packed, &ca), SC_OK);
    assert_int_equal(sc_mesh_check(&strided, &cb), SC_OK);
    assert_memory_equal(ca.lo, cb.lo, sizeof ca.lo);
    assert_memory_equal(ca.hi, cb.hi, sizeof ca.hi);

    sc_bvh *b = (sc_bvh *)1;
    sc_mesh_view bad = strided;
    bad.vertex_stride = 8;                       /* overlapping vertices */
    assert_int_equal(sc_bvh_build(&bad, NULL, &b), SC_ERR_INVALID_ARGUMENT);
    assert_null(b);
    assert_int_equal(sc_mesh_check(&bad, &cb), SC_ERR_INVALID_ARGUMENT);
    bad = strided;
    bad.index_stride = 13;                       /* not a multiple of 4 */
    assert_int_equal(sc_bvh_build(&bad, NULL, &b), SC_ERR_INVALID_ARGUMENT);
    bad = strided;
    bad.positions = (const float *)(const void *)((const char *)strided.positions + 2);   /* misaligned */
    assert_int_equal(sc_bvh_build(&bad, NULL, &b), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_bvh_build(NULL, NULL, &b), SC_ERR_INVALID_ARGUMENT);
    free(ha), free(hb), free(v4), free(i4);
    scene_free(&sc);
}

/* The high build quality (spatial splits, build_spatial_sah.c, then
 * reinsertion, optimize_reinsertion.c) cuts triangles into parts with
 * boxes of their own and rearranges inner nodes: hits bit for bit those of
 * the medium tree (the closest hit and its tie rule do not depend on the
 * tree, nor on which of a triangle's leaves finds it), every hit the
 * oracle's, a lower SAH cost where the medium tree leaves room (leaves of
 * one triangle in a soup and in long slivers, where triangles are cut),
 * and within the traversal's depth on a stack of coincident triangles
 * (median splits, the deepest trees). */
static void test_quality_high(void **state)
{
    (void)state;
    for (int kind = 0; kind < 4; kind++) {
        static const char *const names[] = { "soup", "slivers", "coincident", "nested" };
        scene_case sc = { .name = names[kind] };
        if (kind == 3) {
            /* triangles shrinking by 3 % each around nearly one point: the
             * SAH peels one off per level down to the median depth */
            tmesh *m = &sc.m;
            const size_t n = 3000;
            m->nt = n, m->nv = 3 * n;
            m->pos = malloc(9 * n * sizeof *m->pos);
            m->idx = malloc(3 * n * sizeof *m->idx);
            assert_non_null(m->pos);
            assert_non_null(m->idx);
            double sc_ = 1;
            for (size_t t = 0; t < n; t++, sc_ *= 0.97) {
                const double v[9] = { 0, 0, 0, 1, 0, 0, 0, 1, 0.5 };
                for (int j = 0; j < 9; j++)
                    m->pos[9 * t + (size_t)j] = (float)(v[j] * sc_ + (j % 3 == 0 ? 1e-4 * (double)t : 0));
                for (int j = 0; j < 3; j++)
                    m->idx[3 * t + (size_t)j] = (uint32_t)(3 * t + (size_t)j);
            }
        } else if (kind == 0) {
            scene_soup(&sc.m, 4000, 0, 21);
        } else if (kind == 1) {
            scene_slivers(&sc.m, 3000, 22);
        } else {
            /* 3000 copies of one triangle beside a small soup */
            scene_soup(&sc.m, 500, 0, 23);
            tmesh *m = &sc.m;
            const size_t nt = m->nt + 3000;
            m->idx = realloc(m->idx, 3 * nt * sizeof *m->idx);
            assert_non_null(m->idx);
            for (size_t t = m->nt; t < nt; t++)
                for (int j = 0; j < 3; j++)
                    m->idx[3 * t + j] = m->idx[j];
            m->nt = nt;
        }
        make_rays(&sc, 20000, 30 + (uint64_t)kind);
        for (int leaf = 1; leaf <= 8; leaf += 7) {
            sc_bvh_config cfg;
            sc_bvh_config_default(&cfg);
            assert_int_equal(cfg.quality, SC_BUILD_QUALITY_AUTO);
            cfg.quality = SC_BUILD_QUALITY_MEDIUM;
            cfg.leaf_size = leaf;
            const sc_mesh_view mv = { sc.m.pos, sc.m.nv, sc.m.idx, sc.m.nt, 0, 0 };
            sc_bvh *med = NULL, *high = NULL;
            assert_int_equal(sc_bvh_build(&mv, &cfg, &med), SC_OK);
            cfg.quality = SC_BUILD_QUALITY_HIGH;
            assert_int_equal(sc_bvh_build(&mv, &cfg, &high), SC_OK);
            sc_bvh_info im, ih;
            assert_int_equal(sc_bvh_get_info(med, &im), SC_OK);
            assert_int_equal(sc_bvh_get_info(high, &ih), SC_OK);
            print_message("%s leaf %d: SAH medium %.4f high %.4f, depth %d / %d\n", sc.name, leaf, im.sah_cost,
                          ih.sah_cost, im.depth, ih.depth);
            assert_int_equal(ih.triangles, im.triangles);
            assert_int_equal(med->references, im.triangles);
            assert_true(high->references >= ih.triangles);
            /* at most the budget of cuts; long slivers across a soup's box are cut */
            assert_true(high->references <= ih.triangles + ih.triangles / 5);
            if (kind == 1)
                assert_true(high->references > ih.triangles);
            print_message("%s leaf %d: %zu triangles in %zu leaf slots\n", sc.name, leaf, ih.triangles,
                          high->references);
            assert_true(ih.depth <= SC_BVH_MAX_DEPTH);
            /* Reinsertion lowers the binary tree's cost; the 8-wide tree
             * collapsed from it may give a little of that back. */
            assert_true(ih.sah_cost <= 1.01 * im.sah_cost);
            if ((kind == 0 || kind == 1) && leaf == 1)
                assert_true(ih.sah_cost < im.sah_cost);
            sc_hitrec *hm = malloc(sc.nrays * sizeof *hm), *hh = malloc(sc.nrays * sizeof *hh);
            assert_non_null(hm);
            assert_non_null(hh);
            trace_all(med, &sc, hm);
            trace_all(high, &sc, hh);
            size_t diff = 0;
            for (size_t i = 0; i < sc.nrays; i++)
                diff += !same_hit(&hm[i], &hh[i]);
            assert_int_equal(diff, 0);
            check_result res;
            check_against_oracle(&sc, hh, &res, sc.name);
            assert_int_equal(res.bad, 0);
            for (size_t i = 0; i < sc.nrays; i += 3) {
                int occ = -1;
                assert_int_equal(sc_trace_any(high, &sc.rays[i], &occ, NULL), SC_OK);
                assert_int_equal(occ, hh[i].prim != SC_HITREC_MISS);
            }
            /* A stream interleaves its incoherent rays in a large tree,
             * their stacks sized from the tree's depth: in these, the
             * deepest trees, the same hits bit for bit. */
            high->interleave = 1;
            memset(hm, 0x5a, sc.nrays * sizeof *hm);
            assert_int_equal(sc_trace_closest_n(high, sc.rays, sizeof *sc.rays, hm, sizeof *hm, sc.nrays, 0, NULL),
                             SC_OK);
            diff = 0;
            for (size_t i = 0; i < sc.nrays; i++)
                diff += memcmp(&hm[i], &hh[i], sizeof hh[i]) != 0;
            assert_int_equal(diff, 0);
            free(hm), free(hh);
            sc_bvh_free(med);
            sc_bvh_free(high);
        }
        scene_free(&sc);
    }
}

/* Many small soups with leaves of one and two triangles: the spatial
 * splits cut many triangles and the reinsertion pass makes many moves per
 * round there, and every resulting tree must still find the medium tree's
 * hits. */
static void test_quality_high_soups(void **state)
{
    (void)state;
    for (int seed = 0; seed < 24; seed++) {
        scene_case sc = { .name = "small soup" };
        scene_soup(&sc.m, 100 + 70 * (size_t)seed, 0, 100 + (uint64_t)seed);
        make_rays(&sc, 3000, 200 + (uint64_t)seed);
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.leaf_size = 1 + seed % 2;
        cfg.quality = SC_BUILD_QUALITY_MEDIUM;
        const sc_mesh_view mv = { sc.m.pos, sc.m.nv, sc.m.idx, sc.m.nt, 0, 0 };
        sc_bvh *med = NULL, *high = NULL;
        assert_int_equal(sc_bvh_build(&mv, &cfg, &med), SC_OK);
        cfg.quality = SC_BUILD_QUALITY_HIGH;
        assert_int_equal(sc_bvh_build(&mv, &cfg, &high), SC_OK);
        for (size_t i = 0; i < sc.nrays; i++) {
            sc_hitrec a, b;
            assert_int_equal(sc_trace_closest(med, &sc.rays[i], &a, NULL), SC_OK);
            assert_int_equal(sc_trace_closest(high, &sc.rays[i], &b, NULL), SC_OK);
            assert_true(same_hit(&a, &b));
            int occ = -1;
            assert_int_equal(sc_trace_any(high, &sc.rays[i], &occ, NULL), SC_OK);
            assert_int_equal(occ, a.prim != SC_HITREC_MISS);
        }
        sc_bvh_info ih;
        sc_bvh_get_info(high, &ih);
        assert_true(high->references >= ih.triangles);
        sc_bvh_free(med);
        sc_bvh_free(high);
        scene_free(&sc);
    }
}

/* SC_BUILD_QUALITY_AUTO (sc_bvh.h): medium for a fine mesh, and for one on
 * a two-triangle ground plane; high once the large triangles' boxes add up
 * to 3 or more scene boxes; the same hits as medium either way; and
 * sc_bvh_info.quality says which was built. */
static sc_build_quality built_quality(const tmesh *m, sc_build_quality q)
{
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.quality = q;
    const sc_mesh_view mv = { m->pos, m->nv, m->idx, m->nt, 0, 0 };
    sc_bvh *b = NULL;
    assert_int_equal(sc_bvh_build(&mv, &cfg, &b), SC_OK);
    sc_bvh_info info;
    assert_int_equal(sc_bvh_get_info(b, &info), SC_OK);
    sc_bvh_free(b);
    return info.quality;
}

/* A slanted quad across the scene below ([-1, 2] in x and z): two
 * triangles whose boxes each cover most of its box's area. */
static void add_slab(tmesh *m, double y0, double y1)
{
    uint32_t a = tmesh_vertex(m, -1, y0, -1), b = tmesh_vertex(m, 2, y0, -1);
    uint32_t c = tmesh_vertex(m, 2, y1, 2), d = tmesh_vertex(m, -1, y1, 2);
    tmesh_tri(m, a, b, c);
    tmesh_tri(m, a, c, d);
}

static void test_quality_auto(void **state)
{
    (void)state;
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    assert_int_equal(cfg.quality, SC_BUILD_QUALITY_AUTO);
    const double c[3] = { 0.5, 0.5, 0.5 };
    scene_case sc = { .name = "icosphere" };
    scene_icosphere(&sc.m, 4, 0.5, c);      /* 5,120 triangles, none large */
    assert_int_equal(built_quality(&sc.m, SC_BUILD_QUALITY_AUTO), SC_BUILD_QUALITY_MEDIUM);
    assert_int_equal(built_quality(&sc.m, SC_BUILD_QUALITY_HIGH), SC_BUILD_QUALITY_HIGH);
    /* on a ground plane: one large quad is not enough */
    uint32_t a = tmesh_vertex(&sc.m, -1, 0, -1), b = tmesh_vertex(&sc.m, 2, 0, -1);
    uint32_t d = tmesh_vertex(&sc.m, 2, 0, 2), e = tmesh_vertex(&sc.m, -1, 0, 2);
    tmesh_tri(&sc.m, a, b, d);
    tmesh_tri(&sc.m, a, d, e);
    assert_int_equal(built_quality(&sc.m, SC_BUILD_QUALITY_AUTO), SC_BUILD_QUALITY_MEDIUM);
    /* slanted slabs through the sphere, as an architectural scene's walls
     * and floors: high */
    for (int i = 0; i < 4; i++)
        add_slab(&sc.m, 0.2 * i, 0.2 * i + 0.3);
    assert_int_equal(built_quality(&sc.m, SC_BUILD_QUALITY_AUTO), SC_BUILD_QUALITY_HIGH);
    assert_int_equal(built_quality(&sc.m, SC_BUILD_QUALITY_MEDIUM), SC_BUILD_QUALITY_MEDIUM);
    /* the auto tree's hits are the medium tree's, bit for bit */
    make_rays(&sc, 20000, 77);
    const sc_mesh_view mv = { sc.m.pos, sc.m.nv, sc.m.idx, sc.m.nt, 0, 0 };
    sc_bvh *med = NULL, *au = NULL, *high = NULL;
    cfg.quality = SC_BUILD_QUALITY_MEDIUM;
    assert_int_equal(sc_bvh_build(&mv, &cfg, &med), SC_OK);
    cfg.quality = SC_BUILD_QUALITY_HIGH;
    assert_int_equal(sc_bvh_build(&mv, &cfg, &high), SC_OK);
    cfg.quality = SC_BUILD_QUALITY_AUTO;
    assert_int_equal(sc_bvh_build(&mv, &cfg, &au), SC_OK);
    /* the auto tree is the high one, byte for byte */
    assert_int_equal(au->node_count, high->node_count);
    assert_int_equal(au->leaf_bytes, high->leaf_bytes);
    assert_memory_equal(au->nodes, high->nodes, au->node_count * sizeof(sc_bvh_node8) + au->leaf_bytes);
    assert_true(au->sah_cost < med->sah_cost);
    size_t diff = 0;
    for (size_t i = 0; i < sc.nrays; i++) {
        sc_hitrec x, y;
        assert_int_equal(sc_trace_closest(med, &sc.rays[i], &x, NULL), SC_OK);
        assert_int_equal(sc_trace_closest(au, &sc.rays[i], &y, NULL), SC_OK);
        diff += memcmp(&x, &y, sizeof x) != 0;
    }
    assert_int_equal(diff, 0);
    sc_bvh_free(med);
    sc_bvh_free(au);
    sc_bvh_free(high);
    scene_free(&sc);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_api),
        cmocka_unit_test(test_isa_identical),
        cmocka_unit_test(test_isa_same_visits),
        cmocka_unit_test(test_brute_same_arithmetic),
        cmocka_unit_test(test_soup),
        cmocka_unit_test(test_icosphere),
        cmocka_unit_test(test_slivers),
        cmocka_unit_test(test_offset),
        cmocka_unit_test(test_moller),
        cmocka_unit_test(test_bunny),
        cmocka_unit_test(test_strided_layout),
        cmocka_unit_test(test_quality_high),
        cmocka_unit_test(test_quality_high_soups),
        cmocka_unit_test(test_quality_auto),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/* The Embree back end against the exact oracle: native modes agree away
 * from edges; the user-geometry drop-in (sphere prefilter + watertight test)
 * loses no hit at vertices and edges of a closed mesh, and its prefilter
 * never changes a hit compared with the same clusters without spheres. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "common/sc_rng.h"
#include "compare/compare.h"
#include "compare/oracle.h"
#include "sc_test_checked.h"
#include "scene/procedural.h"
#include <embree3/rtcore.h>

#include "spherecull/sc_embree.h"
#include "spherecull/sc_trace.h"

static sc_embree *make(const sc_checked_mesh *m, sc_embree_mode mode, int cluster, sc_embree_quality q)
{
    sc_embree_config cfg;
    sc_embree_config_default(&cfg);
    cfg.mode = mode;
    cfg.quality = q;
    cfg.cluster_size = cluster;
    sc_embree *e = NULL;
    assert_int_equal(sc_embree_create(m, &cfg, &e), SC_OK);
    assert_non_null(e);
    return e;
}

/* Rays from outside the unit sphere at interior points of random triangles,
 * barycentrics at least 0.1 from every edge. */
static sc_ray *interior_rays(const sc_proc_mesh *pm, size_t n, uint64_t seed, uint32_t *target)
{
    sc_ray *r = malloc(n * sizeof *r);
    assert_non_null(r);
    sc_rng g;
    sc_rng_seed(&g, seed);
    for (size_t i = 0; i < n; i++) {
        uint32_t t = (uint32_t)(sc_rng_next(&g) % pm->triangle_count);
        double a = sc_rng_range(&g, 0.1, 0.8), b = sc_rng_range(&g, 0.1, 0.9 - a), c = 1 - a - b;
        double P[3], N[3];
        for (int k = 0; k < 3; k++) {
            const uint32_t *ix = pm->indices + 3 * (size_t)t;
            P[k] = a * pm->positions[3 * ix[0] + k] + b * pm->positions[3 * ix[1] + k] +
                   c * pm->positions[3 * ix[2] + k];
            N[k] = P[k];
        }
        /* from outside, within 60 degrees of the outward normal */
        double w[3];
        for (int k = 0; k < 3; k++)
            w[k] = N[k] + sc_rng_range(&g, -0.5, 0.5);
        for (int k = 0; k < 3; k++) {
            r[i].org[k] = (float)(P[k] + 2 * w[k]);
            r[i].dir[k] = (float)(-2 * w[k]);
        }
        r[i].tmin = 0, r[i].tmax = INFINITY;
        target[i] = t;
    }
    return r;
}

static void test_native_matches_oracle_away_from_edges(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(4, &pm), SC_OK);
    sc_mesh_view mv = sc_proc_view(&pm);
    sc_checked_mesh m = sc_test_checked(&mv);
    enum { N = 2000 };
    uint32_t *target = malloc(N * sizeof *target);
    sc_ray *rays = interior_rays(&pm, N, 3, target);
    sc_oracle o;
    assert_int_equal(sc_oracle_run(&m, rays, N, 2, 0, &o), SC_OK);
    sc_hitrec *h = malloc(N * sizeof *h), *ours = malloc(N * sizeof *ours);
    uint8_t *occ = malloc(N);
    /* Our tracer's hits on the same rays: the normals must agree with
     * Embree's Ng (the same convention, (V1 - V0) x (V2 - V0)). */
    sc_bvh *bvh = NULL;
    assert_int_equal(sc_bvh_build(&mv, NULL, &bvh), SC_OK);
    for (size_t i = 0; i < N; i++)
        assert_int_equal(sc_trace_closest(bvh, &rays[i], &ours[i], NULL), SC_OK);
    sc_bvh_free(bvh);
    const sc_embree_mode modes[] = { SC_EMBREE_DEFAULT, SC_EMBREE_ROBUST, SC_EMBREE_USER_PREFILTER,
                                     SC_EMBREE_USER_PLAIN, SC_EMBREE_COMPACT };
    for (int mi = 0; mi < 5; mi++)
        for (int q = 0; q < 2; q++) {
            sc_embree *e = make(&m, modes[mi], q ? 16 : 8, (sc_embree_quality)q);
            assert_int_equal(sc_embree_intersect1(e, rays, N, h, NULL), SC_OK);
            for (size_t i = 0; i < N; i++) {
                assert_true(o.hits[i].hit);
                assert_int_equal(o.hits[i].tie_count, 1);
                assert_int_equal(o.hits[i].ties[0], target[i]);   /* the sphere is convex */
                assert_int_equal(h[i].prim, target[i]);
                assert_true(fabs(h[i].t - o.hits[i].t) <= 1e-5 * o.hits[i].t);
                assert_int_equal(ours[i].prim, target[i]);
                const float *a = h[i].ng, *b = ours[i].ng;
                const double nb = sqrt((double)b[0] * b[0] + (double)b[1] * b[1] + (double)b[2] * b[2]);
                assert_true(nb > 0);
                for (int k = 0; k < 3; k++)
                    assert_true(fabs((double)a[k] - b[k]) <= 1e-5 * nb);
                assert_int_equal(h[i].geom, 0);
                assert_int_equal(h[i].inst, SC_INVALID_ID);
            }
            assert_int_equal(sc_embree_occluded1(e, rays, N, occ, NULL), SC_OK);
            for (size_t i = 0; i < N; i++)
                assert_int_equal(occ[i], 1);
            sc_embree_destroy(e);
        }
    sc_oracle_free(&o);
    free(h), free(ours), free(occ), free(rays), free(target);
    sc_proc_free(&pm);
}

static void test_packets_match_single_rays(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(4, &pm), SC_OK);
    sc_mesh_view mv = sc_proc_view(&pm);
    sc_checked_mesh m = sc_test_checked(&mv);
    enum { N = 1003 };                 /* not a multiple of the packet width */
    uint32_t *target = malloc(N * sizeof *target);
    sc_ray *rays = interior_rays(&pm, N, 4, target);
    sc_hitrec *h1 = malloc(N * sizeof *h1), *hp = malloc(N * sizeof *hp);
    for (int mode = 0; mode < 2; mode++) {
        sc_embree *e = make(&m, mode ? SC_EMBREE_USER_PREFILTER : SC_EMBREE_DEFAULT, 8,
                            SC_EMBREE_QUALITY_MEDIUM);
        assert_int_equal(sc_embree_intersect1(e, rays, N, h1, NULL), SC_OK);
        for (int w = 8; w <= 16; w += 8) {
            assert_int_equal(sc_embree_intersect_packets(e, w, rays, N, hp, w == 8, NULL), SC_OK);
            for (size_t i = 0; i < N; i++) {
                assert_int_equal(hp[i].prim, target[i]);
                assert_int_equal(h1[i].prim, target[i]);
                assert_true(fabs(hp[i].t - h1[i].t) <= 1e-6 * h1[i].t);
            }
        }
        assert_int_equal(sc_embree_intersect_packets(e, 4, rays, N, hp, 1, NULL), SC_ERR_INVALID_ARGUMENT);
        sc_embree_destroy(e);
    }
    free(h1), free(hp), free(rays), free(target);
    sc_proc_free(&pm);
}

/* The drop-in on adversarial rays: no lost hit against the oracle on the
 * closed sphere, identical hits with and without the sphere test, and the
 * counters add up. */
static void test_user_prefilter_no_lost_hits(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(4, &pm), SC_OK);
    sc_mesh_view mv = sc_proc_view(&pm);
    sc_checked_mesh m = sc_test_checked(&mv);
    sc_rayset s;
    assert_int_equal(sc_rayset_adversarial(&m, 4000, 21, &s), SC_OK);
    sc_oracle o;
    assert_int_equal(sc_oracle_run(&m, s.rays, s.count, 2, SC_ORACLE_LATER_HIT, &o), SC_OK);
    sc_hitrec *hp = malloc(s.count * sizeof *hp), *hn = malloc(s.count * sizeof *hn);
    uint8_t *occ = malloc(s.count);
    for (int cl = 8; cl <= 16; cl += 8) {
        sc_embree *pre = make(&m, SC_EMBREE_USER_PREFILTER, cl, SC_EMBREE_QUALITY_MEDIUM);
        sc_embree *plain = make(&m, SC_EMBREE_USER_PLAIN, cl, SC_EMBREE_QUALITY_MEDIUM);
        sc_embree_counters cp, cn;
        memset(&cp, 0, sizeof cp), memset(&cn, 0, sizeof cn);
        assert_int_equal(sc_embree_intersect1(pre, s.rays, s.count, hp, &cp), SC_OK);
        assert_int_equal(sc_embree_intersect1(plain, s.rays, s.count, hn, &cn), SC_OK);
        size_t lost = 0, edge_rays = 0;
        for (size_t i = 0; i < s.count; i++) {
            /* the prefilter only skips triangles the ray cannot hit */
            assert_int_equal(hp[i].prim, hn[i].prim);
            assert_true(hp[i].t == hn[i].t || hp[i].prim == SC_HITREC_MISS);
            /* rays that pass through the closed surface at a vertex or edge;
             * rays that only touch it there (tangent) may go either way */
            if (s.tag[i] != SC_RAY_TAG_GRAZING && o.hits[i].crosses) {
                edge_rays++;
                lost += hp[i].prim == SC_HITREC_MISS;
            }
            /* whatever it hits is at the exact first-hit distance (not
             * for grazing rays: there t is ill-conditioned by 1/angle) */
            if (hp[i].prim != SC_HITREC_MISS && o.hits[i].hit && s.tag[i] != SC_RAY_TAG_GRAZING)
                assert_true(fabs(hp[i].t - o.hits[i].t) <= 1e-5 * o.hits[i].t);
        }
        assert_true(edge_rays > 1000);
        assert_int_equal(lost, 0);
        assert_int_equal(sc_embree_occluded1(pre, s.rays, s.count, occ, NULL), SC_OK);
        for (size_t i = 0; i < s.count; i++)
            assert_int_equal(occ[i], hp[i].prim != SC_HITREC_MISS);
        assert_int_equal(cp.rays, s.count);
        assert_true(cp.sphere_tests > 0 && cp.sphere_rejects > 0 && cp.sphere_rejects < cp.sphere_tests);
        assert_int_equal(cp.tri_tests, cp.sphere_tests - cp.sphere_rejects);
        assert_int_equal(cp.false_positives, cp.tri_tests - cp.tri_hits);
        assert_true(cp.tri_tests < cn.tri_tests);
        assert_int_equal(cn.sphere_tests, 0);
        assert_int_equal(cp.cluster_calls, cn.cluster_calls);
        sc_embree_info ip, in;
        assert_int_equal(sc_embree_get_info(pre, &ip), SC_OK);
        assert_int_equal(sc_embree_get_info(plain, &in), SC_OK);
        assert_true(ip.clusters > 0 && ip.mean_cluster_size > cl / 2.0 && ip.mean_cluster_size <= cl);
        assert_true(ip.embree_bytes > 0 && ip.ours_bytes > 0);
        sc_embree_destroy(pre);
        sc_embree_destroy(plain);
    }
    free(hp), free(hn), free(occ);
    sc_oracle_free(&o);
    sc_rayset_free(&s);
    sc_proc_free(&pm);
}

static void test_memory_and_arguments(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(3, &pm), SC_OK);
    sc_mesh_view mv = sc_proc_view(&pm);
    sc_checked_mesh m = sc_test_checked(&mv);
    sc_embree *e = make(&m, SC_EMBREE_DEFAULT, 8, SC_EMBREE_QUALITY_MEDIUM);
    sc_embree_info info;
    assert_int_equal(sc_embree_get_info(e, &info), SC_OK);
    assert_int_equal(info.triangles, m.view.triangle_count);
    /* the monitor saw at least the vertex and index copies */
    assert_true(info.embree_bytes >= 12 * (size_t)m.view.triangle_count);
    assert_true(info.embree_peak_bytes >= info.embree_bytes);
    assert_int_equal(info.ours_bytes, 0);
    assert_int_equal(sc_embree_intersect1(e, NULL, 3, NULL, NULL), SC_ERR_INVALID_ARGUMENT);
    sc_embree_destroy(e);

    sc_embree_config cfg;
    sc_embree_config_default(&cfg);
    cfg.mode = SC_EMBREE_USER_PREFILTER;
    cfg.cluster_size = 17;
    assert_int_equal(sc_embree_create(&m, &cfg, &e), SC_ERR_INVALID_ARGUMENT);
    assert_null(e);
    cfg.cluster_size = 8;
    cfg.mode = (sc_embree_mode)99;
    assert_int_equal(sc_embree_create(&m, &cfg, &e), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_embree_create(NULL, &cfg, &e), SC_ERR_INVALID_ARGUMENT);
    sc_embree_destroy(NULL);
    sc_proc_free(&pm);
}

/* The yardstick names itself: the version a device reports (it must be
 * the major version of the headers we compiled against) and the shared
 * object the symbols came from. */
static void test_version(void **state)
{
    (void)state;
    char v[128], small[4];
    assert_int_equal(sc_embree_version(v, sizeof v), SC_OK);
    int major = -1, minor = -1, patch = -1, used = 0;
    assert_int_equal(sscanf(v, "%d.%d.%d %n", &major, &minor, &patch, &used), 3);
    assert_int_equal(major, RTC_VERSION_MAJOR);
    assert_true(used > 0 && v[used] == '/');
    assert_non_null(strstr(v, "libembree3"));
    assert_int_equal(sc_embree_version(small, sizeof small), SC_OK);   /* truncated, terminated */
    assert_int_equal(strlen(small), 3);
    assert_int_equal(sc_embree_version(NULL, 8), SC_ERR_INVALID_ARGUMENT);
}

/* The median of the rounds' ratios t_ref / t_row: rounds pair the rows'
 * times. */
static double paired(const sc_cmp_row *row, const sc_cmp_row *ref)
{
    double q[SC_CMP_MAX_REPEATS];
    assert_int_equal(row->rounds, ref->rounds);
    const int n = row->rounds;
    for (int i = 0; i < n; i++)
        q[i] = ref->round_s[i] / row->round_s[i];
    for (int i = 1; i < n; i++)   /* insertion sort: n is small */
        for (int j = i; j > 0 && q[j] < q[j - 1]; j--) {
            double t = q[j];
            q[j] = q[j - 1], q[j - 1] = t;
        }
    return n % 2 ? q[n / 2] : 0.5 * (q[n / 2 - 1] + q[n / 2]);
}

/* compare's best Embree: every row's best_embree is its speed over the
 * fastest Embree row (by median) of default flags and the same width in
 * the run (the robust build not), and names it; of the packets' fixed-flag
 * rows only the one whose flag is not the ray set's (camera and shadow
 * rays are coherent), the other repeating embree-p16. Both ratios are the
 * medians of the rounds' paired ratios, and a row's speed is the median
 * round's. */
static void test_best_embree(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(3, &pm), SC_OK);
    sc_mesh_view mv = sc_proc_view(&pm);
    const sc_camera cam = { { 0, 0.5, 3 }, { 0, 0, 0 }, { 0, 1, 0 }, 50, 32, 32 };
    const sc_light light = { SC_LIGHT_POINT, { 2, 3, 4 }, { 1, 1, 1 } };
    sc_cmp_options opt;
    sc_cmp_options_default(&opt);
    static const char *const names[] = { "spherecull-off", "spherecull-p16", "embree", "embree-high",
                                         "embree-robust", "embree-p16", "embree-p16-coherent",
                                         "embree-p16-incoherent", "embree-p8", "spherecull-p8" };
    enum { NT = sizeof names / sizeof names[0] };
    for (int i = 0; i < NT; i++)
        opt.tracers[i] = names[i];
    opt.ntracers = NT;
    opt.threads[0] = 1, opt.nthreads = 1;
    opt.ray_kinds = 1u << SC_RAYS_PRIMARY | 1u << SC_RAYS_SHADOW;
    opt.oracle_rays = 0, opt.repeats = 4, opt.min_seconds = 0;
    opt.width = 32;
    sc_cmp_rows rows = { 0 };
    char err[256] = "";
    assert_int_equal(sc_cmp_scene("ico", &mv, NULL, &cam, &light, 1, &opt, &rows, NULL, err, sizeof err), SC_OK);
    assert_int_equal(rows.count, 2 * NT);
    for (size_t i = 0; i < rows.count; i++) {
        const sc_cmp_row *r = &rows.rows[i];
        const int w = strstr(r->tracer, "-p16") ? 16 : strstr(r->tracer, "-p8") ? 8 : 0;
        const sc_cmp_row *best = NULL;
        for (size_t j = 0; j < rows.count; j++) {
            const sc_cmp_row *o = &rows.rows[j];
            const int ow = strstr(o->tracer, "-p16") ? 16 : strstr(o->tracer, "-p8") ? 8 : 0;
            if (o->rays != r->rays || ow != w || strncmp(o->tracer, "embree", 6) ||
                strcmp(o->tracer, "embree-robust") == 0 || strcmp(o->tracer, "embree-p16-coherent") == 0)
                continue;
            if (!best || o->mrays_per_s > best->mrays_per_s)
                best = o;
        }
        assert_non_null(best);
        assert_string_equal(r->best_embree_tracer, best->tracer);
        assert_true(fabs(r->best_embree - paired(r, best)) <= 1e-12 * r->best_embree);
        assert_int_equal(r->rounds, opt.repeats);
        /* the speed is a round's: the one of time rank repeats / 2 */
        int slower = 0, faster = 0, same = 0;
        for (int k = 0; k < r->rounds; k++) {
            assert_true(r->round_s[k] > 0);
            const double mr = (double)r->nrays / r->round_s[k] / 1e6;
            slower += mr < r->mrays_per_s * (1 - 1e-12);
            faster += mr > r->mrays_per_s * (1 + 1e-12);
            same += fabs(mr - r->mrays_per_s) <= 1e-12 * mr;
        }
        assert_true(same >= 1);
        assert_true(faster <= opt.repeats / 2 && slower <= opt.repeats - 1 - opt.repeats / 2);
        const char *ref = w == 16 ? "embree-p16" : w == 8 ? "embree-p8" : "embree";
        for (size_t j = 0; j < rows.count; j++)
            if (rows.rows[j].rays == r->rays && strcmp(rows.rows[j].tracer, ref) == 0)
                assert_true(fabs(r->speed_vs_embree - paired(r, &rows.rows[j])) <= 1e-12 * r->speed_vs_embree);
    }
    sc_cmp_rows_free(&rows);
    sc_proc_free(&pm);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version),
        cmocka_unit_test(test_native_matches_oracle_away_from_edges),
        cmocka_unit_test(test_packets_match_single_rays),
        cmocka_unit_test(test_user_prefilter_no_lost_hits),
        cmocka_unit_test(test_memory_and_arguments),
        cmocka_unit_test(test_best_embree),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

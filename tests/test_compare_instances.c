/* compare's tracers and oracle through instances (sc_tracer_build_scene,
 * sc_oracle_run_scene, sc_cmp_scene with a view): every tracer with an
 * instanced path reports, on rays aimed at a visible triangle's centroid,
 * the triangle the exact oracle names (as a view->mesh index); the exact
 * test agrees with the oracle on every ray, adversarial ones included; and
 * a comparison run through the instances finds no disagreement, hole or
 * graze for spherecull-exact; bench's brute-force check passes through
 * the instances. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "compare/bench.h"
#include "compare/compare.h"
#include "compare/oracle.h"
#include "compare/tracer.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"

/* Rotated, mirrored and scaled instances of two objects over a ground that
 * belongs to no instance. */
static const char *const SCENE =
    "{ \"width\": 96, \"height\": 64,"
    "  \"camera\": { \"eye\": [0, 3, 6], \"target\": [0, 0, 0], \"fov\": 55 },"
    "  \"meshes\": ["
    "    { \"vertices\": [[-4, 0, -4], [4, 0, -4], [4, 0, 4], [-4, 0, 4]], \"faces\": [[0, 3, 2, 1]] },"
    "    { \"file\": \"proc:sphere:1k\", \"scale\": 0.4, \"translate\": [0, 0.5, 0],"
    "      \"instances\": { \"grid\": [3, 1, 3], \"spacing\": 1.3, \"rotate_jitter\": 180, \"scale_jitter\": 0.3,"
    "                       \"seed\": 7 } },"
    "    { \"vertices\": [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],"
    "                   [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],"
    "      \"faces\": [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [3, 7, 6, 2], [0, 4, 7, 3], [1, 2, 6, 5]],"
    "      \"instances\": [ { \"translate\": [2.5, 1, 0.5], \"rotate\": [30, 45, 10], \"scale\": [0.3, 0.6, 0.2] },"
    "                       { \"translate\": [-2.5, 0.8, -0.5], \"scale\": [-0.4, 0.4, 0.4] } ] }"
    "  ] }";

typedef struct fixture {
    sc_scene *scene;
    sc_scene_view v;
    sc_checked_mesh flat, own, *objects;
    uint32_t *own_idx, *own_prim;
    size_t num_own;
    sc_scene_accel *accel;      /* the object-space rays the oracle decides */
} fixture;

static sc_status object_ray(void *ctx, size_t inst, const sc_ray *w, sc_ray *o)
{
    return sc_accel_instance_ray(sc_scene_accel_world(ctx), (uint32_t)inst, w, o);
}

static void setup(fixture *f)
{
    memset(f, 0, sizeof *f);
    char err[256] = "";
    assert_int_equal(sc_scene_load_json_text(SCENE, strlen(SCENE), "t.json", NULL, NULL, &f->scene, err, sizeof err),
                     SC_OK);
    assert_int_equal(sc_scene_get_view(f->scene, &f->v), SC_OK);
    assert_int_equal(f->v.num_instances, 11);
    assert_int_equal(sc_mesh_check(&f->v.mesh, &f->flat), SC_OK);
    assert_int_equal(sc_scene_view_own_triangles(&f->v, &f->own_idx, &f->own_prim, &f->num_own), SC_OK);
    assert_int_equal(f->num_own, 2);
    const sc_mesh_view own = { f->v.mesh.positions, f->v.mesh.vertex_count, f->own_idx, f->num_own, 0, 0 };
    assert_int_equal(sc_mesh_check(&own, &f->own), SC_OK);
    f->objects = calloc(f->v.num_objects, sizeof *f->objects);
    for (size_t k = 0; k < f->v.num_objects; k++)
        assert_int_equal(sc_mesh_check(&f->v.objects[k], &f->objects[k]), SC_OK);
    assert_int_equal(sc_scene_accel_build(&f->v, NULL, &f->accel), SC_OK);
}

static void teardown(fixture *f)
{
    sc_scene_accel_free(f->accel);
    free(f->objects), free(f->own_idx), free(f->own_prim);
    sc_scene_free(f->scene);
}

static void oracle(const fixture *f, const sc_ray *rays, size_t n, int flags, sc_oracle *o)
{
    const sc_oracle_scene sc = { &f->own, f->own_prim, f->objects, f->v.num_objects, f->v.instances,
                                 f->v.num_instances, object_ray, f->accel };
    assert_int_equal(sc_oracle_run_scene(&sc, rays, n, 2, flags, o), SC_OK);
}

static void test_tracers_through_instances(void **state)
{
    (void)state;
    fixture f;
    setup(&f);
    /* rays from around the scene at every triangle's centroid */
    const size_t nt = f.v.mesh.triangle_count, n = 3000;
    sc_ray *rays = malloc(n * sizeof *rays);
    for (size_t i = 0; i < n; i++) {
        const size_t t = (i * 7919) % nt;
        const uint32_t *ix = sc_mesh_triangle(&f.v.mesh, t);
        const double a = 0.37 * (double)i;
        const float o[3] = { (float)(7 * cos(a)), (float)(1 + 4 * fabs(sin(0.7 * a))), (float)(7 * sin(a)) };
        sc_ray *r = &rays[i];
        memcpy(r->org, o, sizeof o);
        for (int k = 0; k < 3; k++)
            r->dir[k] = (sc_mesh_vertex(&f.v.mesh, ix[0])[k] + sc_mesh_vertex(&f.v.mesh, ix[1])[k] +
                         sc_mesh_vertex(&f.v.mesh, ix[2])[k]) / 3 - o[k];
        r->tmin = 0, r->tmax = INFINITY;
    }
    sc_oracle o;
    oracle(&f, rays, n, 0, &o);
    /* the rays whose aimed triangle is the unique exact first hit */
    size_t visible = 0;
    uint8_t *vis = calloc(n, 1);
    for (size_t i = 0; i < n; i++)
        if (o.hits[i].hit && o.hits[i].tie_count == 1 && o.hits[i].ties[0] == (i * 7919) % nt)
            vis[i] = 1, visible++;
    assert_true(visible > n / 4);
    sc_hitrec *hits = malloc(n * sizeof *hits);
    uint8_t *occ = malloc(n);
    int count, built = 0;
    const char *const *names = sc_tracer_names(&count);
    for (int d = 0; d < count; d++) {
        const sc_tracer_def *def = sc_tracer_find(names[d]);
        sc_tracer t;
        sc_status st = sc_tracer_build_scene(&t, def, &f.v);
        /* Embree's packets and streams through instances are left out
         * (tracer.c says why); ours have packets through instances */
        const int no_path = def->family == SC_TRACER_EMBREE &&
                            (strstr(def->name, "-user-") || def->packet == 8 || def->packet == 16 ||
                             def->packet == SC_TRACER_STREAM);
        if (no_path) {
            assert_int_equal(st, SC_ERR_UNSUPPORTED);
            continue;
        }
        assert_int_equal(st, SC_OK);
        built++;
        assert_int_equal(sc_tracer_run(&t, rays, n, hits, NULL, NULL), SC_OK);
        assert_int_equal(sc_tracer_run_threads(&t, rays, n, NULL, occ, 2, NULL), SC_OK);
        const int exact = def->family == SC_TRACER_OURS && def->quality == SC_TRI_EXACT;
        for (size_t i = 0; i < n; i++) {
            if (vis[i]) {
                if (hits[i].prim != o.hits[i].ties[0])
                    fail_msg("%s: ray %zu hit %u, the oracle %u", def->name, i, hits[i].prim, o.hits[i].ties[0]);
                if (!(fabs(hits[i].t - o.hits[i].t) <= 1e-4 * o.hits[i].t))
                    fail_msg("%s: ray %zu t %.9g, the oracle %.9g", def->name, i, hits[i].t, o.hits[i].t);
                assert_int_equal(hits[i].inst, SC_INVALID_ID);
            }
            if (vis[i] || exact)
                assert_int_equal(occ[i], o.hits[i].hit);
            if (exact) {
                assert_int_equal(hits[i].prim != SC_HITREC_MISS, o.hits[i].hit);
                if (o.hits[i].hit)
                    assert_true(sc_oracle_accepts(&o, i, hits[i].prim));
            }
        }
        sc_tracer_free(&t);
    }
    assert_true(built >= 8);
    /* the exact test on vertex and edge rays, grazing ones included */
    sc_rayset adv;
    assert_int_equal(sc_rayset_adversarial(&f.flat, 3000, 3, &adv), SC_OK);
    sc_oracle oa;
    oracle(&f, adv.rays, adv.count, SC_ORACLE_CROSSING, &oa);
    sc_tracer t;
    assert_int_equal(sc_tracer_build_scene(&t, sc_tracer_find("spherecull-exact"), &f.v), SC_OK);
    sc_hitrec *ah = malloc(adv.count * sizeof *ah);
    assert_int_equal(sc_tracer_run(&t, adv.rays, adv.count, ah, NULL, NULL), SC_OK);
    size_t crossings = 0;
    for (size_t i = 0; i < adv.count; i++) {
        assert_int_equal(ah[i].prim != SC_HITREC_MISS, oa.hits[i].hit);
        if (oa.hits[i].hit)
            assert_true(sc_oracle_accepts(&oa, i, ah[i].prim));
        assert_int_equal(sc_oracle_judge(&oa, i, ah[i].prim, ah[i].t), SC_VERDICT_OK);
        crossings += isfinite(oa.hits[i].cross_t);
    }
    assert_true(crossings > adv.count / 4);
    sc_tracer_free(&t);
    free(ah);
    sc_oracle_free(&oa);
    sc_rayset_free(&adv);
    free(hits), free(occ), free(vis), free(rays);
    sc_oracle_free(&o);
    teardown(&f);
}

static void test_compare_through_instances(void **state)
{
    (void)state;
    fixture f;
    setup(&f);
    sc_cmp_options opt;
    sc_cmp_options_default(&opt);
    opt.tracers[0] = "spherecull-exact", opt.tracers[1] = "spherecull-p16", opt.tracers[2] = "spherecull-off";
    opt.ntracers = 3;
    opt.threads[0] = 1, opt.nthreads = 1;
    opt.oracle_rays = 800, opt.repeats = 1, opt.min_seconds = 0;
    opt.width = 48, opt.random_rays = opt.adversarial_rays = 1500;
    sc_cmp_rows rows = { 0 };
    char err[256] = "";
    assert_int_equal(sc_cmp_scene("t.json", &f.v.mesh, &f.v, &f.v.camera, f.v.lights, f.v.num_lights, &opt, &rows,
                                  NULL, err, sizeof err),
                     SC_OK);
    /* three tracers x five ray sets, p16 through the instances too */
    assert_int_equal(rows.count, 3 * SC_RAYS_KIND_COUNT);
    size_t judged = 0;
    for (size_t i = 0; i < rows.count; i++) {
        const sc_cmp_row *r = &rows.rows[i];
        assert_int_equal(r->instances, 11);
        assert_true(r->oracle_rays > 0);
        if (strcmp(r->tracer, "spherecull-exact") != 0)
            continue;
        assert_int_equal(r->hit_miss_disagree, 0);
        assert_int_equal(r->primid_disagree, 0);
        assert_int_equal(r->holes, 0);
        assert_int_equal(r->grazes_missed, 0);
        judged++;
    }
    assert_int_equal(judged, SC_RAYS_KIND_COUNT);
    /* the packets through the instances answer as the single rays do, so
     * the oracle finds the same disagreements in both rows */
    size_t paired = 0;
    for (size_t i = 0; i < rows.count; i++)
        for (size_t j = 0; j < rows.count; j++) {
            const sc_cmp_row *p = &rows.rows[i], *q = &rows.rows[j];
            if (strcmp(p->tracer, "spherecull-p16") || strcmp(q->tracer, "spherecull-off") || p->rays != q->rays)
                continue;
            assert_int_equal(p->hit_miss_disagree, q->hit_miss_disagree);
            assert_int_equal(p->primid_disagree, q->primid_disagree);
            assert_int_equal(p->holes, q->holes);
            paired++;
        }
    assert_int_equal(paired, SC_RAYS_KIND_COUNT);
    /* flattened on request: the same tracers over view->mesh, p16 included */
    sc_cmp_rows flat = { 0 };
    opt.flatten = 1;
    opt.ray_kinds = 1u << SC_RAYS_PRIMARY;
    assert_int_equal(sc_cmp_scene("t.json", &f.v.mesh, &f.v, &f.v.camera, f.v.lights, f.v.num_lights, &opt, &flat,
                                  NULL, err, sizeof err),
                     SC_OK);
    assert_int_equal(flat.count, 3);
    for (size_t i = 0; i < flat.count; i++)
        assert_int_equal(flat.rows[i].instances, 0);
    sc_cmp_rows_free(&flat);
    sc_cmp_rows_free(&rows);
    teardown(&f);
}

typedef struct bench_seen {
    size_t scenes, rows, instances;
} bench_seen;

static void seen_scene(void *ctx, const sc_bench_scene *s)
{
    bench_seen *b = ctx;
    b->scenes++;
    b->instances = s->instances;
}

static void seen_row(void *ctx, const sc_bench_row *r)
{
    bench_seen *b = ctx;
    b->rows++;
    assert_int_equal(r->diff_brute, 0);
    assert_true(r->mrays > 0);
}

/* bench through instances: each configuration's hits pass the brute-force
 * check through the instances (a difference is an error), every ray kind
 * and prefilter mode is measured, packets are refused with one line, and
 * --instances flat benchmarks the flattened mesh. */
static void test_bench_through_instances(void **state)
{
    (void)state;
    fixture f;
    setup(&f);
    sc_bench_options o;
    sc_bench_options_default(&o);
    o.kinds[0] = SC_RAYS_PRIMARY, o.kinds[1] = SC_RAYS_SHADOW, o.kinds[2] = SC_RAYS_DIFFUSE;
    o.kinds[3] = SC_RAYS_RANDOM, o.nkinds = 4;
    o.threads[0] = 1, o.nthreads = 1;
    o.leaves[0] = 4, o.nleaves = 1;
    o.modes[0] = SC_PREFILTER_OFF, o.modes[1] = SC_PREFILTER_COMPACT, o.nmodes = 2;
    o.width = 64, o.height = 48, o.repeats = 1, o.count = 2000;
    char err[256] = "";
    for (int tri = 0; tri < 2; tri++) {
        o.tri = tri ? SC_TRI_EXACT : SC_TRI_WATERTIGHT;
        bench_seen b = { 0 };
        const sc_bench_sink sink = { seen_scene, seen_row, &b };
        assert_int_equal(sc_bench_run(&f.v.mesh, &f.v, &f.v.camera, f.v.lights, f.v.num_lights, &o, -1, &sink, err,
                                      sizeof err),
                         SC_OK);
        assert_int_equal(b.scenes, 1);
        assert_int_equal(b.instances, 11);
        assert_int_equal(b.rows, 4 * 2);
    }
    o.packet = 16;
    bench_seen b = { 0 };
    const sc_bench_sink sink = { seen_scene, seen_row, &b };
    assert_int_equal(sc_bench_run(&f.v.mesh, &f.v, &f.v.camera, f.v.lights, f.v.num_lights, &o, -1, &sink, err,
                                  sizeof err),
                     SC_ERR_UNSUPPORTED);
    assert_non_null(strstr(err, "instances"));
    o.flatten = 1;
    assert_int_equal(sc_bench_run(&f.v.mesh, &f.v, &f.v.camera, f.v.lights, f.v.num_lights, &o, -1, &sink, err,
                                  sizeof err),
                     SC_OK);
    assert_int_equal(b.instances, 0);
    teardown(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tracers_through_instances),
        cmocka_unit_test(test_compare_through_instances),
        cmocka_unit_test(test_bench_through_instances),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

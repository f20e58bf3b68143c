/* Concurrency as the public headers state it (sc_trace.h, sc_bvh.h,
 * sc_simd.h), meant to run under ThreadSanitizer (`scripts/test.sh --tsan`):
 *   - the first use of the library from 4 threads at once (the lazily
 *     chosen SIMD kernel table);
 *   - per ISA level this CPU supports: 4 threads trace one shared BVH
 *     (closest and any hit, with and without statistics) while 2 threads
 *     build, trace and free BVHs of their own, over and over; and once more
 *     while a seventh thread switches the ISA level back and forth;
 *   - scenes (sc_accel.h): 4 threads trace one scene of instances while 2
 *     threads make scenes of their own that instance the same object
 *     scene (its reference count changed from three threads), commit,
 *     trace, refit and release them, and build, refit and release scenes
 *     of their own meshes.
 * Every answer a thread gets is compared with the one computed before the
 * threads started, so a race that changes a result fails here even without
 * TSan. Threads set the MXCSR mode under test (sc_ftz.h). */
#define _POSIX_C_SOURCE 200809L   /* pthread barriers */
#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "common/sc_rng.h"
#include "sc_ftz.h"
#include "spherecull/sc_accel.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_prefilter.h"
#include "spherecull/sc_simd.h"
#include "spherecull/sc_trace.h"
#include "bvh/bvh_internal.h"

enum { NTRI = 3000, NRAY = 1500, TRACERS = 4, BUILDERS = 2, BUILDS = 6 };

typedef struct soup {
    float *pos;
    uint32_t *idx;
} soup;

/* n triangles with centres in [-1, 1]^3 and vertices within +-size of them. */
static void make_soup(uint64_t seed, int n, double size, soup *s)
{
    sc_rng g;
    sc_rng_seed(&g, seed);
    s->pos = malloc(sizeof(float) * 9 * (size_t)n);
    s->idx = malloc(sizeof(uint32_t) * 3 * (size_t)n);
    assert_non_null(s->pos);
    assert_non_null(s->idx);
    for (int t = 0; t < n; t++) {
        double c[3];
        for (int a = 0; a < 3; a++)
            c[a] = sc_rng_range(&g, -1, 1);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                s->pos[9 * t + 3 * k + a] = (float)(c[a] + sc_rng_range(&g, -size, size));
        for (int k = 0; k < 3; k++)
            s->idx[3 * t + k] = (uint32_t)(3 * t + k);
    }
}

static void free_soup(soup *s)
{
    free(s->pos);
    free(s->idx);
}

static void make_rays(uint64_t seed, sc_ray *rays, int n)
{
    sc_rng g;
    sc_rng_seed(&g, seed);
    for (int i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) {
            rays[i].org[a] = (float)sc_rng_range(&g, -3, 3);
            rays[i].dir[a] = (float)(sc_rng_range(&g, -0.5, 0.5) - rays[i].org[a]);
        }
        rays[i].tmin = 0;
        rays[i].tmax = INFINITY;
    }
}

/* ---- first use from several threads --------------------------------------- */

typedef struct first_use {
    pthread_barrier_t *go;
    sc_isa isa;
    uint32_t mask;
} first_use;

static void *first_use_thread(void *arg)
{
    first_use *f = arg;
    sc_test_ftz_thread_init();
    pthread_barrier_wait(f->go);
    sc_ray r = { { 0, 0, -5 }, 0, { 0, 0, 1 }, INFINITY };
    sc_sphere_block8 blk;
    sc_sphere_block8_init(&blk);
    sc_spheref hit = { { 0, 0, 0 }, 1 }, miss = { { 5, 0, 0 }, 1 };
    sc_sphere_block8_set(&blk, 0, &hit);
    sc_sphere_block8_set(&blk, 1, &miss);
    f->mask = sc_reject8(&r, &blk);
    f->isa = sc_isa_active();
    return NULL;
}

static void test_first_use(void **state)
{
    (void)state;
    pthread_barrier_t go;
    pthread_barrier_init(&go, NULL, TRACERS);
    pthread_t th[TRACERS];
    first_use f[TRACERS];
    for (int i = 0; i < TRACERS; i++) {
        f[i].go = &go;
        assert_int_equal(pthread_create(&th[i], NULL, first_use_thread, &f[i]), 0);
    }
    for (int i = 0; i < TRACERS; i++)
        pthread_join(th[i], NULL);
    pthread_barrier_destroy(&go);
    for (int i = 0; i < TRACERS; i++) {
        assert_int_equal(f[i].mask, 0xfeu);      /* lane 0 kept, 1 rejected, 2..7 empty */
        assert_int_equal(f[i].isa, f[0].isa);
    }
}

/* ---- one shared BVH, tracers and builders ---------------------------------- */

typedef struct shared {
    const sc_bvh *bvh;
    const sc_ray *rays;
    const sc_hitrec *want;
    const int *want_occ;
    sc_bvh_config cfg;
    pthread_barrier_t *go;
} shared;

typedef struct worker {
    const shared *sh;
    int id;
    size_t wrong, errors;
    uint64_t rays_counted;
} worker;

static void *tracer(void *arg)
{
    worker *w = arg;
    const shared *sh = w->sh;
    sc_test_ftz_thread_init();
    pthread_barrier_wait(sh->go);
    sc_trace_stats st;
    memset(&st, 0, sizeof st);
    for (int pass = 0; pass < 2; pass++)
        for (int j = 0; j < NRAY; j++) {
            int i = (j + w->id * NRAY / TRACERS) % NRAY;      /* each thread starts elsewhere */
            sc_hitrec h;
            int occ;
            w->errors += sc_trace_closest(sh->bvh, &sh->rays[i], &h, pass ? &st : NULL) != SC_OK;
            w->errors += sc_trace_any(sh->bvh, &sh->rays[i], &occ, pass ? &st : NULL) != SC_OK;
            w->wrong += h.prim != sh->want[i].prim || memcmp(&h.t, &sh->want[i].t, sizeof h.t) != 0 ||
                        occ != sh->want_occ[i];
        }
    w->rays_counted = st.rays;
    return NULL;
}

static void *builder(void *arg)
{
    worker *w = arg;
    const shared *sh = w->sh;
    sc_test_ftz_thread_init();
    pthread_barrier_wait(sh->go);
    for (int b = 0; b < BUILDS; b++) {
        soup s;
        make_soup(1000 + 100 * (uint64_t)w->id + (uint64_t)b, NTRI, 0.08, &s);
        sc_bvh *own = NULL;
        sc_bvh_config cfg = sh->cfg;
        cfg.prefilter = b % 2 ? SC_PREFILTER_MINIMAL : SC_PREFILTER_AUTO;
        w->errors += sc_bvh_build(&(sc_mesh_view){ s.pos, 3 * NTRI, s.idx, NTRI, 0, 0 }, &cfg, &own) != SC_OK;
        if (own) {
            /* its answers equal brute force over the same triangles */
            for (int i = 0; i < 64; i++) {
                sc_hitrec h, hb;
                w->errors += sc_trace_closest(own, &sh->rays[i], &h, NULL) != SC_OK;
                w->errors += sc_trace_closest_brute(own, &sh->rays[i], &hb) != SC_OK;
                w->wrong += h.prim != hb.prim;
            }
            sc_bvh_free(own);
        }
        free_soup(&s);
    }
    return NULL;
}

/* Switches the ISA level back and forth while the others trace: allowed
 * (sc_isa.h), and every level returns the same hits. */
static void *switcher(void *arg)
{
    worker *w = arg;
    const shared *sh = w->sh;
    pthread_barrier_wait(sh->go);
    for (int k = 0; k < 200; k++)
        for (int isa = SC_ISA_SCALAR; isa < SC_ISA_COUNT; isa++)
            if (sc_isa_supported((sc_isa)isa))
                w->errors += sc_isa_force((sc_isa)isa) != SC_OK;
    return NULL;
}

/* switch_isa: one more thread switches the ISA level all the while. */
static void run_isa(sc_isa isa, int switch_isa)
{
    soup s;
    make_soup(7, NTRI, 0.08, &s);
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    assert_int_equal(sc_isa_force(isa), SC_OK);
    cfg.prefilter = SC_PREFILTER_CIRCUM;
    cfg.tri_test = SC_TRI_EXACT;       /* closest hits are exact: any thread must agree bit for bit */
    sc_bvh *bvh;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ s.pos, 3 * NTRI, s.idx, NTRI, 0, 0 }, &cfg, &bvh), SC_OK);
    sc_ray *rays = malloc(sizeof(sc_ray) * NRAY);
    sc_hitrec *want = malloc(sizeof(sc_hitrec) * NRAY);
    int *want_occ = malloc(sizeof(int) * NRAY);
    assert_non_null(rays);
    assert_non_null(want);
    assert_non_null(want_occ);
    make_rays(11, rays, NRAY);
    size_t hits = 0;
    for (int i = 0; i < NRAY; i++) {
        assert_int_equal(sc_trace_closest(bvh, &rays[i], &want[i], NULL), SC_OK);
        assert_int_equal(sc_trace_any(bvh, &rays[i], &want_occ[i], NULL), SC_OK);
        hits += want[i].prim != SC_HITREC_MISS;
    }
    assert_true(hits > NRAY / 10 && hits < NRAY);

    pthread_barrier_t go;
    const int nth = TRACERS + BUILDERS + (switch_isa != 0);
    pthread_barrier_init(&go, NULL, (unsigned)nth);
    shared sh = { bvh, rays, want, want_occ, cfg, &go };
    pthread_t th[TRACERS + BUILDERS + 1];
    worker w[TRACERS + BUILDERS + 1];
    for (int i = 0; i < nth; i++) {
        w[i] = (worker){ &sh, i, 0, 0, 0 };
        void *(*fn)(void *) = i < TRACERS ? tracer : i < TRACERS + BUILDERS ? builder : switcher;
        assert_int_equal(pthread_create(&th[i], NULL, fn, &w[i]), 0);
    }
    size_t wrong = 0, errors = 0;
    for (int i = 0; i < nth; i++) {
        pthread_join(th[i], NULL);
        wrong += w[i].wrong, errors += w[i].errors;
        if (i < TRACERS)
            assert_int_equal(w[i].rays_counted, 2 * NRAY);
    }
    pthread_barrier_destroy(&go);
    print_message("isa %s%s: %d tracers x %d rays x 2 passes on one BVH (%zu hits) while %d threads built %d BVHs "
                  "each: %zu wrong answers, %zu errors\n",
                  sc_isa_name(isa), switch_isa ? " (switched all the while)" : "", TRACERS, NRAY, hits, BUILDERS,
                  BUILDS, wrong, errors);
    assert_int_equal(wrong, 0);
    assert_int_equal(errors, 0);
    sc_bvh_free(bvh);
    free(rays);
    free(want);
    free(want_occ);
    free_soup(&s);
}

static void test_shared_bvh(void **state)
{
    (void)state;
    int ran = 0;
    for (int isa = SC_ISA_SCALAR; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        run_isa((sc_isa)isa, 0);
        ran++;
    }
    run_isa(SC_ISA_SCALAR, 1);
    assert_true(ran >= 1);
}

/* A build on several threads (POSIX threads for large subtrees, and for
 * the subtrees of the collapse's write pass) is bit for bit the
 * single-threaded one: nodes, leaves, figures, in every leaf layout and
 * with the high quality's spatial splits and reinsertion pass. Under
 * ThreadSanitizer this is also the race check of the parallel builder. */
static void test_parallel_build(void **state)
{
    (void)state;
    enum { BIG = 200000 };
    soup big;
    make_soup(77, BIG, 0.01, &big);
    const sc_mesh_view m = { big.pos, 3 * BIG, big.idx, BIG, 0, 0 };
    /* the soup moved a little, for the refits: parallel below the top levels */
    float *moved = malloc(9 * (size_t)BIG * sizeof *moved);
    for (size_t i = 0; i < 9 * (size_t)BIG; i++)
        moved[i] = big.pos[i] + 0.003f * sinf(0.37f * (float)i);
    const sc_mesh_view mv = { moved, 3 * BIG, big.idx, BIG, 0, 0 };
    const sc_prefilter_mode modes[] = { SC_PREFILTER_OFF, SC_PREFILTER_MINIMAL, SC_PREFILTER_COMPACT,
                                        SC_PREFILTER_OFF };
    for (int md = 0; md < 4; md++) {
        sc_bvh *ref = NULL;
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        assert_int_equal(cfg.threads, 1);
        cfg.prefilter = modes[md];
        cfg.quality = md == 3 ? SC_BUILD_QUALITY_HIGH : SC_BUILD_QUALITY_MEDIUM;
        assert_int_equal(sc_bvh_build(&m, &cfg, &ref), SC_OK);
        if (md == 3)
            assert_true(ref->references > ref->triangles);     /* the spatial splits cut some */
        if (md == 0 || md == 3) {
            /* a tree this large is built as jobs below its top levels
             * (both the binned SAH and the spatial splits): its answers
             * are those of every triangle tested */
            enum { NR = 120 };
            sc_ray rays[NR];
            make_rays(78, rays, NR);
            size_t hits = 0;
            for (int i = 0; i < NR; i++) {
                sc_hitrec h, hb;
                assert_int_equal(sc_trace_closest(ref, &rays[i], &h, NULL), SC_OK);
                assert_int_equal(sc_trace_closest_brute(ref, &rays[i], &hb), SC_OK);
                assert_int_equal(h.prim, hb.prim);
                assert_memory_equal(&h.t, &hb.t, sizeof h.t);
                hits += h.prim != SC_HITREC_MISS;
            }
            assert_true(hits > NR / 4);
        }
        sc_bvh *refit = NULL;
        assert_int_equal(sc_bvh_build(&m, &cfg, &refit), SC_OK);
        assert_int_equal(sc_bvh_refit(refit, &mv), SC_OK);
        assert_true(refit->sah_cost != ref->sah_cost);
        const int counts[] = { 2, 3, 0 };
        for (int c = 0; c < 3; c++) {
            cfg.threads = counts[c];
            sc_bvh *b = NULL;
            assert_int_equal(sc_bvh_build(&m, &cfg, &b), SC_OK);
            assert_int_equal(b->node_count, ref->node_count);
            assert_int_equal(b->leaf_count, ref->leaf_count);
            assert_int_equal(b->leaf_bytes, ref->leaf_bytes);
            assert_int_equal(b->sphere_bytes, ref->sphere_bytes);
            assert_int_equal(b->leaves_with_spheres, ref->leaves_with_spheres);
            assert_int_equal(b->depth, ref->depth);
            assert_true(b->sah_cost == ref->sah_cost);
            assert_memory_equal(b->nodes, ref->nodes, ref->node_count * sizeof *ref->nodes);
            assert_memory_equal(b->leaves, ref->leaves, ref->leaf_bytes);
            /* a refit on these threads writes the bytes of one on a single thread */
            assert_int_equal(sc_bvh_refit(b, &mv), SC_OK);
            assert_true(b->sah_cost == refit->sah_cost);
            assert_memory_equal(b->nodes, refit->nodes, ref->node_count * sizeof *ref->nodes);
            assert_memory_equal(b->leaves, refit->leaves, ref->leaf_bytes);
            sc_bvh_free(b);
        }
        cfg.threads = -1;
        sc_bvh *bad = NULL;
        assert_int_equal(sc_bvh_build(&m, &cfg, &bad), SC_ERR_INVALID_ARGUMENT);
        sc_bvh_free(ref);
        sc_bvh_free(refit);
    }
    free(moved);
    free_soup(&big);
}

/* ---- scenes ------------------------------------------------------------ */

enum { NINST = 12 };

typedef struct scene_shared {
    sc_accel *obj, *world;
    const float (*xfm)[12];
    const sc_ray *rays;
    const sc_hitrec *want;
    const int *want_occ;
    pthread_barrier_t *go;
} scene_shared;

typedef struct scene_worker {
    const scene_shared *sh;
    int id;
    size_t wrong, errors;
} scene_worker;

static void *scene_tracer(void *arg)
{
    scene_worker *w = arg;
    const scene_shared *sh = w->sh;
    sc_test_ftz_thread_init();
    pthread_barrier_wait(sh->go);
    for (int j = 0; j < NRAY; j++) {
        int i = (j + w->id * NRAY / TRACERS) % NRAY;
        sc_hitrec h;
        int occ;
        w->errors += sc_accel_closest(sh->world, &sh->rays[i], &h, NULL) != SC_OK;
        w->errors += sc_accel_any(sh->world, &sh->rays[i], &occ, NULL) != SC_OK;
        w->wrong += h.prim != sh->want[i].prim || h.inst != sh->want[i].inst ||
                    memcmp(&h.t, &sh->want[i].t, sizeof h.t) != 0 || occ != sh->want_occ[i];
    }
    return NULL;
}

static void *scene_builder(void *arg)
{
    scene_worker *w = arg;
    const scene_shared *sh = w->sh;
    sc_test_ftz_thread_init();
    pthread_barrier_wait(sh->go);
    for (int b = 0; b < 3; b++) {
        /* the shared object, instanced as the shared world does: the same answers */
        sc_accel *mine = NULL;
        w->errors += sc_accel_new(NULL, &mine) != SC_OK;
        if (!mine)
            continue;
        for (int i = 0; i < NINST; i++)
            w->errors += sc_accel_attach_instance(mine, sh->obj, sh->xfm[i], NULL) != SC_OK;
        w->errors += sc_accel_commit(mine) != SC_OK;
        w->errors += sc_accel_refit(mine) != SC_OK;
        for (int i = 0; i < 100; i++) {
            sc_hitrec h;
            w->errors += sc_accel_closest(mine, &sh->rays[i], &h, NULL) != SC_OK;
            w->wrong += h.prim != sh->want[i].prim || h.inst != sh->want[i].inst;
        }
        sc_accel_release(mine);
        /* a scene of its own mesh, refitted after the mesh moved */
        soup s;
        make_soup(5000 + 10 * (uint64_t)w->id + (uint64_t)b, NTRI, 0.08, &s);
        sc_accel *own = NULL;
        w->errors += sc_accel_new(NULL, &own) != SC_OK;
        if (own) {
            const sc_mesh_view v = { s.pos, 3 * NTRI, s.idx, NTRI, 0, 0 };
            w->errors += sc_accel_attach_mesh(own, &v, SC_ACCEL_SHARED, NULL) != SC_OK;
            w->errors += sc_accel_commit(own) != SC_OK;
            for (int i = 0; i < 9 * NTRI; i++)
                s.pos[i] *= 1.01f;
            w->errors += sc_accel_refit(own) != SC_OK;
            sc_bvh *fresh = NULL;
            w->errors += sc_bvh_build(&v, NULL, &fresh) != SC_OK;
            for (int i = 0; fresh && i < 64; i++) {
                sc_hitrec h, hf;
                w->errors += sc_accel_closest(own, &sh->rays[i], &h, NULL) != SC_OK;
                w->errors += sc_trace_closest(fresh, &sh->rays[i], &hf, NULL) != SC_OK;
                w->wrong += h.prim != hf.prim || memcmp(&h.t, &hf.t, sizeof h.t) != 0;
            }
            sc_bvh_free(fresh);
            sc_accel_release(own);
        }
        free_soup(&s);
    }
    return NULL;
}

static void test_shared_scene(void **state)
{
    (void)state;
    soup s;
    make_soup(9, NTRI, 0.08, &s);
    sc_accel *obj, *world;
    assert_int_equal(sc_accel_new(NULL, &obj), SC_OK);
    assert_int_equal(sc_accel_attach_mesh(obj, &(sc_mesh_view){ s.pos, 3 * NTRI, s.idx, NTRI, 0, 0 }, SC_ACCEL_COPY,
                                          NULL), SC_OK);
    assert_int_equal(sc_accel_commit(obj), SC_OK);
    assert_int_equal(sc_accel_new(NULL, &world), SC_OK);
    float xfm[NINST][12];
    for (int i = 0; i < NINST; i++) {
        const float c = cosf(0.5f * (float)i), sn = sinf(0.5f * (float)i), sc = 0.3f + 0.05f * (float)i;
        const float x[12] = { sc * c, -sc * sn, 0, 0.4f * (float)(i % 4) - 0.6f, sc * sn, sc * c, 0,
                              0.4f * (float)(i / 4) - 0.4f, 0, 0, sc, 0.1f * (float)i };
        memcpy(xfm[i], x, sizeof x);
        assert_int_equal(sc_accel_attach_instance(world, obj, xfm[i], NULL), SC_OK);
    }
    assert_int_equal(sc_accel_commit(world), SC_OK);
    sc_ray *rays = malloc(sizeof(sc_ray) * NRAY);
    sc_hitrec *want = malloc(sizeof(sc_hitrec) * NRAY);
    int *want_occ = malloc(sizeof(int) * NRAY);
    make_rays(13, rays, NRAY);
    size_t hits = 0;
    for (int i = 0; i < NRAY; i++) {
        assert_int_equal(sc_accel_closest(world, &rays[i], &want[i], NULL), SC_OK);
        assert_int_equal(sc_accel_any(world, &rays[i], &want_occ[i], NULL), SC_OK);
        hits += want[i].prim != SC_HITREC_MISS;
    }
    assert_true(hits > NRAY / 10);
    pthread_barrier_t go;
    pthread_barrier_init(&go, NULL, TRACERS + BUILDERS);
    scene_shared sh = { obj, world, (const float (*)[12])xfm, rays, want, want_occ, &go };
    pthread_t th[TRACERS + BUILDERS];
    scene_worker w[TRACERS + BUILDERS];
    for (int i = 0; i < TRACERS + BUILDERS; i++) {
        w[i] = (scene_worker){ &sh, i, 0, 0 };
        assert_int_equal(pthread_create(&th[i], NULL, i < TRACERS ? scene_tracer : scene_builder, &w[i]), 0);
    }
    size_t wrong = 0, errors = 0;
    for (int i = 0; i < TRACERS + BUILDERS; i++) {
        pthread_join(th[i], NULL);
        wrong += w[i].wrong, errors += w[i].errors;
    }
    pthread_barrier_destroy(&go);
    print_message("scenes: %d tracers x %d rays on one scene of %d instances (%zu hits) while %d threads made, "
                  "refitted and released scenes sharing its object: %zu wrong answers, %zu errors\n",
                  TRACERS, NRAY, NINST, hits, BUILDERS, wrong, errors);
    assert_int_equal(wrong, 0);
    assert_int_equal(errors, 0);
    sc_accel_release(obj);
    sc_accel_release(world);
    free(rays), free(want), free(want_occ);
    free_soup(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_first_use),     /* first: nothing has touched the library yet */
        cmocka_unit_test(test_shared_bvh),
        cmocka_unit_test(test_parallel_build),
        cmocka_unit_test(test_shared_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

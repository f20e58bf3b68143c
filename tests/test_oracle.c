/* The exact oracle: constructed ties whose answers are known by hand, and
 * agreement with a plain brute-force loop over sc_ref_ray_triangle_mpfr
 * (so the double filter and cluster culling never drop a true first hit). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include <mpfr.h>

#include "common/sc_rng.h"
#include "compare/oracle.h"
#include "sc_test_checked.h"
#include "scene/procedural.h"
#include "sc_ref_ray.h"

/* Two triangles sharing the diagonal of the unit square at z = 0, a fan of
 * four around (2,2,0) and one parallel triangle below at z = -1. */
static const float P[] = {
    0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0,                  /* 0..3: square */
    2, 2, 0, 3, 2, 0, 2, 3, 0, 1, 2, 0, 2, 1, 0,         /* 4..8: fan centre + ring */
    -1, -1, -1, 4, -1, -1, -1, 4, -1,                    /* 9..11: floor */
};
static const uint32_t I[] = {
    0, 1, 2, 1, 3, 2,                                    /* tri 0, 1 */
    4, 5, 6, 4, 6, 7, 4, 7, 8, 4, 8, 5,                  /* tri 2..5 */
    9, 10, 11,                                           /* tri 6 */
};

static sc_checked_mesh scene(void)
{
    sc_mesh_view m = { P, 12, I, 7, 0, 0 };
    return sc_test_checked(&m);
}

static void test_constructed_ties(void **state)
{
    (void)state;
    sc_checked_mesh m = scene();
    sc_ray rays[] = {
        { { 0.5f, 0.5f, 1 }, 0, { 0, 0, -1 }, INFINITY },    /* shared edge: {0,1}, t = 1 */
        { { 2, 2, 2 }, 0, { 0, 0, -1 }, INFINITY },          /* fan centre: {2,3,4,5}, t = 2 */
        { { 0.25f, 0.25f, 1 }, 0, { 0, 0, -1 }, INFINITY },  /* inside tri 0 only */
        { { 0.5f, 2, 1 }, 0, { 0, 0, -1 }, INFINITY },       /* only the floor, t = 2 */
        { { -5, 0.5f, 0 }, 0, { 1, 0, 0 }, INFINITY },       /* in the square's plane: parallel, no hit */
        { { 0.5f, 0.5f, 1 }, 0, { 0, 0, -1 }, 0.5f },        /* tmax before the hit: miss */
        { { 0.5f, 0.5f, 1 }, 1.5f, { 0, 0, -1 }, INFINITY }, /* tmin past the square: floor */
        { { 0.5f, 0.5f, 1 }, 0, { 0, 0, 1 }, INFINITY },     /* pointing away */
    };
    size_t n = sizeof rays / sizeof rays[0];
    sc_oracle o;
    assert_int_equal(sc_oracle_run(&m, rays, n, 2, 0, &o), SC_OK);
    assert_int_equal(o.count, n);

    assert_true(o.hits[0].hit);
    assert_true(o.hits[0].t == 1.0);
    assert_int_equal(o.hits[0].tie_count, 2);
    assert_int_equal(o.hits[0].ties[0], 0);
    assert_int_equal(o.hits[0].ties[1], 1);
    assert_true(sc_oracle_accepts(&o, 0, 0) && sc_oracle_accepts(&o, 0, 1));
    assert_false(sc_oracle_accepts(&o, 0, 6));

    assert_true(o.hits[1].hit);
    assert_true(o.hits[1].t == 2.0);
    assert_int_equal(o.hits[1].tie_count, 4);
    for (uint32_t k = 0; k < 4; k++)
        assert_int_equal(o.hits[1].ties[k], 2 + k);

    assert_true(o.hits[2].hit);
    assert_int_equal(o.hits[2].tie_count, 1);
    assert_int_equal(o.hits[2].ties[0], 0);
    assert_false(sc_oracle_accepts(&o, 2, 1));

    assert_true(o.hits[3].hit && o.hits[3].t == 2.0);
    assert_int_equal(o.hits[3].ties[0], 6);

    assert_false(o.hits[4].hit);
    assert_false(o.hits[5].hit);
    assert_true(o.hits[6].hit && o.hits[6].t == 2.0 && o.hits[6].ties[0] == 6);
    assert_false(o.hits[7].hit);
    assert_false(sc_oracle_accepts(&o, 7, 0));
    sc_oracle_free(&o);

    /* with LATER_HIT: rays 0 and 2 also reach the floor; the fan centre
     * lies outside the floor, and ray 3 hits only the floor */
    assert_int_equal(sc_oracle_run(&m, rays, n, 1, SC_ORACLE_LATER_HIT, &o), SC_OK);
    assert_true(o.hits[0].crosses && o.hits[2].crosses);
    assert_false(o.hits[1].crosses || o.hits[3].crosses || o.hits[4].crosses || o.hits[6].crosses);
    assert_int_equal(o.hits[1].tie_count, 4);
    sc_oracle_free(&o);

    assert_int_equal(sc_oracle_run(NULL, rays, n, 1, 0, &o), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_oracle_run(&m, rays, n, 1, 7, &o), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_oracle_run(&m, rays, n, 0, 0, &o), SC_ERR_INVALID_ARGUMENT);
}

/* Plain loop over every triangle with the exact decision. */
static void brute(const sc_mesh_view *m, const sc_ray *r, int *hit, double *t, uint32_t *ties, uint32_t *nties)
{
    mpfr_t best, tt;
    mpfr_init2(best, 256), mpfr_init2(tt, 256);
    *hit = 0, *nties = 0;
    double O[3] = { r->org[0], r->org[1], r->org[2] }, D[3] = { r->dir[0], r->dir[1], r->dir[2] };
    for (uint32_t k = 0; k < m->triangle_count; k++) {
        double V[9];
        for (int j = 0; j < 9; j++)
            V[j] = m->positions[3 * (size_t)m->indices[3 * (size_t)k + j / 3] + j % 3];
        if (!sc_ref_ray_triangle_mpfr(O, D, r->tmin, r->tmax, V, V + 3, V + 6, tt))
            continue;
        int c = *hit ? mpfr_cmp(tt, best) : -1;
        if (c < 0) {
            mpfr_set_prec(best, mpfr_get_prec(tt));
            mpfr_set(best, tt, MPFR_RNDN);
            *hit = 1, *nties = 0;
        }
        if (c <= 0 && *nties < SC_ORACLE_MAX_TIES)
            ties[(*nties)++] = k;
    }
    *t = *hit ? mpfr_get_d(best, MPFR_RNDN) : INFINITY;
    mpfr_clear(best), mpfr_clear(tt);
}

static void check_against_brute(const sc_mesh_view *m, const sc_rayset *s)
{
    sc_oracle o;
    sc_checked_mesh cm = sc_test_checked(m);
    assert_int_equal(sc_oracle_run(&cm, s->rays, s->count, 2, 0, &o), SC_OK);
    size_t nhit = 0, ntie = 0;
    for (size_t i = 0; i < s->count; i++) {
        int hit;
        double t;
        uint32_t ties[SC_ORACLE_MAX_TIES], nt;
        brute(m, &s->rays[i], &hit, &t, ties, &nt);
        assert_int_equal(o.hits[i].hit, hit);
        if (!hit)
            continue;
        nhit++;
        ntie += nt > 1;
        assert_true(o.hits[i].t == t);
        assert_int_equal(o.hits[i].tie_count, nt);
        for (uint32_t k = 0; k < nt; k++)
            assert_int_equal(o.hits[i].ties[k], ties[k]);
    }
    /* the sets must exercise both hits and ties to mean anything */
    print_message("%s: %zu rays, %zu hits, %zu ties\n", sc_rayset_kind_name(s->kind), s->count, nhit, ntie);
    assert_true(nhit > s->count / 10);
    if (s->kind == SC_RAYS_ADVERSARIAL)
        assert_true(ntie > s->count / 10);
    sc_oracle_free(&o);
}

static void test_matches_brute_force(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    sc_rayset s;
    float lo[3], hi[3];
    /* closed sphere: adversarial (ties at vertices/edges) and random rays */
    assert_int_equal(sc_proc_icosphere(2, &pm), SC_OK);
    sc_mesh_view m = sc_proc_view(&pm);
    sc_checked_mesh cm = sc_test_checked(&m);
    assert_int_equal(sc_rayset_adversarial(&cm, 400, 5, &s), SC_OK);
    check_against_brute(&m, &s);
    sc_rayset_free(&s);
    assert_int_equal(sc_mesh_bounds(&m, lo, hi), SC_OK);
    assert_int_equal(sc_rayset_random(lo, hi, 300, 5, &s), SC_OK);
    check_against_brute(&m, &s);
    sc_rayset_free(&s);
    sc_proc_free(&pm);
    /* soup: overlapping triangles, many candidates per ray */
    assert_int_equal(sc_proc_soup(600, 9, &pm), SC_OK);
    m = sc_proc_view(&pm);
    assert_int_equal(sc_mesh_bounds(&m, lo, hi), SC_OK);
    assert_int_equal(sc_rayset_random(lo, hi, 300, 6, &s), SC_OK);
    /* aim every other ray at a triangle's centroid so most of them hit */
    for (size_t i = 0; i < s.count; i += 2) {
        const uint32_t *ix = pm.indices + 3 * (i % pm.triangle_count);
        for (int k = 0; k < 3; k++)
            s.rays[i].dir[k] = (pm.positions[3 * ix[0] + k] + pm.positions[3 * ix[1] + k] +
                                pm.positions[3 * ix[2] + k]) / 3 - s.rays[i].org[k];
    }
    check_against_brute(&m, &s);
    sc_rayset_free(&s);
    sc_proc_free(&pm);
}

/* A ray through a point of a closed surface always hits it, so every exact
 * vertex/edge ray on the closed sphere is an oracle hit with t <= aim_t. */
static void test_closed_mesh_edge_rays_hit(void **state)
{
    (void)state;
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(3, &pm), SC_OK);
    sc_mesh_view m = sc_proc_view(&pm);
    sc_checked_mesh cm = sc_test_checked(&m);
    sc_rayset s;
    assert_int_equal(sc_rayset_adversarial(&cm, 2000, 17, &s), SC_OK);
    sc_oracle o;
    assert_int_equal(sc_oracle_run(&cm, s.rays, s.count, 2, 0, &o), SC_OK);
    size_t checked = 0;
    for (size_t i = 0; i < s.count; i++) {
        if (!s.exact[i] || s.tag[i] == SC_RAY_TAG_GRAZING)
            continue;
        checked++;
        assert_true(o.hits[i].hit);
        assert_true(o.hits[i].t <= (double)s.aim_t[i]);
        if (o.hits[i].t == (double)s.aim_t[i])
            assert_true(o.hits[i].tie_count >= 2);   /* a vertex or shared edge */
    }
    assert_true(checked > 700);
    sc_oracle_free(&o);
    sc_rayset_free(&s);
    sc_proc_free(&pm);
}

/* ---- through instances ------------------------------------------------------ */

typedef struct xlate_ctx {
    const sc_scene_instance *inst;
} xlate_ctx;

/* Translations by integers of points on a 2^-12 grid are exact in float:
 * the object ray is the world ray moved, with the same exact hits. */
static sc_status xlate_ray(void *ctx, size_t i, const sc_ray *w, sc_ray *o)
{
    const xlate_ctx *c = ctx;
    *o = *w;
    for (int k = 0; k < 3; k++)
        o->org[k] = w->org[k] - c->inst[i].xfm[4 * k + 3];
    return SC_OK;
}

static float q12(double x)
{
    return (float)(nearbyint(x * 4096) / 4096);
}

/* The oracle through instances decides each instance's object ray; with
 * exact translations that is the flattened mesh's question, so the two
 * answers (hit, t, ties, and with crossing the first crossing) must be the
 * same. dup: two instances coincide, so ties run across instances. */
static void scene_equals_flat(int dup)
{
    sc_proc_mesh pm;
    assert_int_equal(sc_proc_icosphere(2, &pm), SC_OK);
    const size_t ov = pm.vertex_count, ot = pm.triangle_count;
    float *opos = malloc(3 * ov * sizeof *opos);
    for (size_t k = 0; k < 3 * ov; k++)
        opos[k] = q12(pm.positions[k]);
    const sc_mesh_view obj = { opos, ov, pm.indices, ot, 0, 0 };
    enum { NI = 6 };
    sc_scene_instance inst[NI];
    const size_t own_n = 7, nt = own_n + NI * ot, nv = 12 + NI * ov;
    float *pos = malloc(3 * nv * sizeof *pos);
    uint32_t *idx = malloc(3 * nt * sizeof *idx), own_prim[7];
    memcpy(pos, P, sizeof P);
    memcpy(idx, I, sizeof I);
    for (uint32_t k = 0; k < own_n; k++)
        own_prim[k] = k;
    for (int i = 0; i < NI; i++) {
        const int j = dup && i == NI - 1 ? i - 1 : i;            /* the last one on the one before */
        const float T[3] = { (float)(3 * j - 6), (float)(j % 2 ? 5 : -4), (float)(j % 3) };
        memset(&inst[i], 0, sizeof inst[i]);
        inst[i].object = 0;
        inst[i].first_triangle = own_n + (size_t)i * ot;
        inst[i].xfm[0] = inst[i].xfm[5] = inst[i].xfm[10] = 1;
        for (int k = 0; k < 3; k++)
            inst[i].xfm[4 * k + 3] = T[k];
        for (size_t v = 0; v < ov; v++)
            for (int k = 0; k < 3; k++)
                pos[3 * (12 + i * ov + v) + k] = opos[3 * v + k] + T[k];    /* exact */
        for (size_t t = 0; t < 3 * ot; t++)
            idx[3 * inst[i].first_triangle + t] = (uint32_t)(12 + i * ov) + pm.indices[t];
    }
    const sc_mesh_view flat = { pos, nv, idx, nt, 0, 0 };
    sc_checked_mesh cflat = sc_test_checked(&flat), cobj = sc_test_checked(&obj);
    const sc_mesh_view ownv = { P, 12, I, 7, 0, 0 };
    sc_checked_mesh cown = sc_test_checked(&ownv);
    /* rays on the 2^-8 grid aimed at flat vertices (vertex and edge ties)
     * or at grid points in the box: every difference is exact */
    enum { NR = 1500 };
    sc_ray *rays = malloc(NR * sizeof *rays);
    sc_rng rng;
    sc_rng_seed(&rng, 11 + (uint64_t)dup);
    for (size_t r = 0; r < NR; r++) {
        float o[3], tg[3];
        for (int k = 0; k < 3; k++)
            o[k] = q12(nearbyint(((double)(sc_rng_next(&rng) >> 11) / 9007199254740992.0 * 60 - 30) * 256) / 256);
        if (r % 2) {
            const float *v = pos + 3 * (sc_rng_next(&rng) % nv);
            memcpy(tg, v, sizeof tg);
        } else {
            for (int k = 0; k < 3; k++)
                tg[k] = cflat.lo[k] + q12((double)(sc_rng_next(&rng) >> 11) / 9007199254740992.0 *
                                          (cflat.hi[k] - cflat.lo[k]));
        }
        rays[r] = (sc_ray){ { o[0], o[1], o[2] }, 0, { tg[0] - o[0], tg[1] - o[1], tg[2] - o[2] }, INFINITY };
        if (r % 7 == 0)
            rays[r].tmax = 0.999f;            /* stops short of the target vertex */
    }
    const int flags = dup ? SC_ORACLE_LATER_HIT : SC_ORACLE_CROSSING | SC_ORACLE_LATER_HIT;
    sc_oracle of, os;
    assert_int_equal(sc_oracle_run(&cflat, rays, NR, 2, flags, &of), SC_OK);
    xlate_ctx ctx = { inst };
    const sc_oracle_scene sc = { &cown, own_prim, &cobj, 1, inst, NI, xlate_ray, &ctx };
    assert_int_equal(sc_oracle_run_scene(&sc, rays, NR, 2, flags, &os), SC_OK);
    assert_int_equal(os.count, (size_t)NR);
    size_t hits = 0, ties = 0, cross_inst = 0;
    for (size_t r = 0; r < NR; r++) {
        const sc_oracle_hit *a = &of.hits[r], *b = &os.hits[r];
        assert_int_equal(a->hit, b->hit);
        hits += (size_t)a->hit;
        if (!a->hit)
            continue;
        assert_true(a->t == b->t);
        assert_int_equal(a->crosses, b->crosses);
        assert_int_equal(a->tie_count, b->tie_count);
        ties += a->tie_count > 1;
        for (uint32_t k = 0; k < a->tie_count && k < SC_ORACLE_MAX_TIES; k++)
            assert_int_equal(a->ties[k], b->ties[k]);
        if (dup && a->tie_count > 1 && a->ties[a->tie_count - 1] >= inst[NI - 1].first_triangle &&
            a->ties[0] < inst[NI - 1].first_triangle)
            cross_inst++;
        if (dup)
            continue;
        assert_int_equal(a->first_kind, b->first_kind);
        assert_true(a->cross_t == b->cross_t || (isinf(a->cross_t) && isinf(b->cross_t)));
        assert_int_equal(a->cross_tie_count, b->cross_tie_count);
        for (uint32_t k = 0; k < a->cross_tie_count && k < SC_ORACLE_MAX_TIES; k++)
            assert_int_equal(a->cross_ties[k], b->cross_ties[k]);
    }
    /* the sets are not vacuous: hits, vertex ties, and (dup) ties across the
     * two coincident instances */
    assert_true(hits > NR / 3);
    assert_true(ties > NR / 10);
    if (dup)
        assert_true(cross_inst > 20);
    sc_oracle_free(&of), sc_oracle_free(&os);
    free(rays), free(pos), free(idx), free(opos);
    sc_proc_free(&pm);
}

static void test_scene_translations_equal_flat(void **state)
{
    (void)state;
    scene_equals_flat(0);
}

static void test_scene_coincident_instances_tie(void **state)
{
    (void)state;
    scene_equals_flat(1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constructed_ties),
        cmocka_unit_test(test_matches_brute_force),
        cmocka_unit_test(test_closed_mesh_edge_rays_hit),
        cmocka_unit_test(test_scene_translations_equal_flat),
        cmocka_unit_test(test_scene_coincident_instances_tie),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

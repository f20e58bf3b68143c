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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constructed_ties),
        cmocka_unit_test(test_matches_brute_force),
        cmocka_unit_test(test_closed_mesh_edge_rays_hit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

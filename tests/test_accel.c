/* The scene handle (sc_accel.h): several meshes under one tree report the
 * ids and hits of separate trees; instances report what tracing each
 * instance's rounded object-space ray on its own reports, and that is the
 * exact first hit (MPFR oracle) for that ray; closed meshes seen through
 * instances have no holes; a refit answers as a fresh build over the moved
 * vertices, its spheres still contain their triangles (MPFR), and it
 * rebuilds past the growth limit or on a non-finite vertex; bad arguments
 * are refused. */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>
#include <mpfr.h>

#include "bvh/bvh_internal.h"
#include "compare/oracle.h"
#include "sc_ftz.h"
#include "sc_test_meshes.h"
#include "sc_test_warm.h"
#include "spherecull/sc_accel.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_trace.h"
#include "trace/trace_top.h"

static uint64_t rng_state = 0x1234567ull;
static double rnd(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) * 0x1p-53;
}
static double rnd_in(double a, double b) { return a + (b - a) * rnd(); }

static void random_dir(float d[3])
{
    double z = rnd_in(-1, 1), phi = rnd_in(0, 6.283185307179586), s = sqrt(1 - z * z);
    d[0] = (float)(s * cos(phi)), d[1] = (float)(s * sin(phi)), d[2] = (float)z;
}

/* Rays from a box around the scene towards points in it; every fourth one
 * aimed at a vertex of `aim` (edges and vertices are where trees disagree). */
static void make_rays(sc_ray *rays, size_t n, const float lo[3], const float hi[3], const float *aim, size_t naim)
{
    for (size_t i = 0; i < n; i++) {
        float o[3], p[3];
        for (int k = 0; k < 3; k++) {
            double c = 0.5 * (lo[k] + hi[k]), h = 0.5 * (hi[k] - lo[k]) + 0.1;
            o[k] = (float)(c + rnd_in(-2, 2) * h);
            p[k] = (float)(c + rnd_in(-1, 1) * h);
        }
        if (aim && i % 4 == 0) {
            size_t v = (size_t)(rnd() * (double)naim) % naim;
            memcpy(p, aim + 3 * v, sizeof p);
        }
        sc_ray r = { { o[0], o[1], o[2] }, 0, { p[0] - o[0], p[1] - o[1], p[2] - o[2] }, INFINITY };
        if (r.dir[0] == 0 && r.dir[1] == 0 && r.dir[2] == 0)
            r.dir[2] = 1;
        if (i % 7 == 3)
            r.tmax = 0.9f;   /* some rays end before the surface */
        rays[i] = r;
    }
}

/* rays[0..15] as one packet of 16 and, when p8 is given, as two packets
 * of 8; every lane valid. */
static void pack_rays(const sc_ray *rays, sc_ray_packet16 *p16, sc_ray_packet8 *p8, int32_t valid[16])
{
    for (unsigned i = 0; i < 16; i++) {
        const sc_ray *q = &rays[i];
        const float f[8] = { q->org[0], q->org[1], q->org[2], q->tmin, q->dir[0], q->dir[1], q->dir[2], q->tmax };
        for (unsigned c = 0; c < 8; c++) {
            (&p16->ox[0])[16 * c + i] = f[c];
            if (p8)
                (&p8[i / 8].ox[0])[8 * c + i % 8] = f[c];
        }
        valid[i] = 1;
    }
}

static int same_bits(const sc_hitrec *a, const sc_hitrec *b)
{
    return memcmp(&a->t, &b->t, 4) == 0 && memcmp(&a->u, &b->u, 4) == 0 && memcmp(&a->v, &b->v, 4) == 0 &&
           a->prim == b->prim && a->geom == b->geom && a->inst == b->inst;
}

/* ---- several meshes under one tree --------------------------------------- */

static void test_meshes(void **state)
{
    (void)state;
    mesh m[3];
    const double o0[3] = { 0, 0, 0 }, o1[3] = { 1.5, 0.4, 0.2 };
    torus(&m[0], 24, 12, o0, 1.0);
    grid_box(&m[1], 6, 0);
    torus(&m[2], 16, 10, o1, 0.6);
    /* mesh 1 as float4 vertices, to cover strides */
    float *p4 = malloc(16 * (size_t)m[1].nv);
    for (uint32_t i = 0; i < m[1].nv; i++)
        memcpy(p4 + 4 * i, m[1].pos + 3 * i, 12), p4[4 * i + 3] = 0;
    const sc_mesh_view views[4] = { { m[0].pos, m[0].nv, m[0].idx, m[0].nt, 0, 0 },
                                    { m[0].pos, 0, NULL, 0, 0, 0 },   /* empty */
                                    { p4, m[1].nv, m[1].idx, m[1].nt, 16, 0 },
                                    { m[2].pos, m[2].nv, m[2].idx, m[2].nt, 0, 0 } };
    const size_t N = 4000;
    sc_ray *rays = malloc(N * sizeof *rays);
    const float lo[3] = { -1.5f, -1.5f, -3 }, hi[3] = { 2.5f, 2, 1 };
    make_rays(rays, N, lo, hi, m[0].pos, m[0].nv);
    sc_hitrec *stream = malloc(N * sizeof *stream);
    for (int test = 0; test < 2; test++)
        for (int mode = 0; mode < SC_PREFILTER_MODE_COUNT; mode++) {
            sc_bvh_config cfg;
            sc_bvh_config_default(&cfg);
            cfg.prefilter = (sc_prefilter_mode)mode;
            cfg.tri_test = test ? SC_TRI_MOLLER : SC_TRI_WATERTIGHT;
            cfg.leaf_size = 4 + 4 * (mode % 2);
            sc_accel *a;
            assert_int_equal(sc_accel_new(&cfg, &a), SC_OK);
            uint32_t id;
            for (uint32_t g = 0; g < 4; g++) {
                assert_int_equal(sc_accel_attach_mesh(a, &views[g], g % 2 ? SC_ACCEL_COPY : SC_ACCEL_SHARED, &id),
                                 SC_OK);
                assert_int_equal(id, g);
            }
            sc_bvh *sep[4] = { 0 };
            for (int g = 0; g < 4; g++)
                assert_int_equal(sc_bvh_build(&views[g], &cfg, &sep[g]), SC_OK);
            sc_ray r0 = rays[0];
            sc_hitrec h;
            assert_int_equal(sc_accel_closest(a, &r0, &h, NULL), SC_ERR_INVALID_ARGUMENT);   /* not committed */
            assert_int_equal(sc_accel_commit(a), SC_OK);
            assert_int_equal(sc_accel_closest_n(a, rays, sizeof *rays, stream, sizeof *stream, N, 0, NULL), SC_OK);
            size_t hits = 0, per_geom[4] = { 0 };
            for (size_t i = 0; i < N; i++) {
                sc_hitrec want;
                memset(&want, 0, sizeof want);
                want.prim = SC_HITREC_MISS;
                want.t = rays[i].tmax;
                for (uint32_t g = 0; g < 4; g++) {
                    sc_hitrec s;
                    assert_int_equal(sc_trace_closest(sep[g], &rays[i], &s, NULL), SC_OK);
                    if (s.prim == SC_HITREC_MISS)
                        continue;
                    s.geom = g;
                    if (want.prim == SC_HITREC_MISS || s.t < want.t)
                        want = s;
                }
                if (want.prim == SC_HITREC_MISS)
                    want.geom = want.inst = SC_INVALID_ID;
                assert_int_equal(sc_accel_closest(a, &rays[i], &h, NULL), SC_OK);
                if (!same_bits(&h, &want))
                    fail_msg("mode %d test %d ray %zu: accel (t %a prim %u geom %u) separate (t %a prim %u geom %u)",
                             mode, test, i, h.t, h.prim, h.geom, want.t, want.prim, want.geom);
                assert_memory_equal(h.ng, want.ng, sizeof h.ng);
                assert_true(same_bits(&stream[i], &h));
                int occ;
                assert_int_equal(sc_accel_any(a, &rays[i], &occ, NULL), SC_OK);
                assert_int_equal(occ, h.prim != SC_HITREC_MISS);
                if (h.prim != SC_HITREC_MISS)
                    hits++, per_geom[h.geom]++;
            }
            /* the rays reach every non-empty mesh */
            assert_true(hits > N / 4);
            assert_true(per_geom[0] > 50 && per_geom[2] > 50 && per_geom[3] > 20);
            assert_int_equal(per_geom[1], 0);
            sc_accel_info info;
            assert_int_equal(sc_accel_get_info(a, &info), SC_OK);
            assert_int_equal(info.meshes, 4);
            assert_int_equal(info.triangles, m[0].nt + m[1].nt + m[2].nt);
            assert_int_equal(info.builds, 1);
            for (int g = 0; g < 4; g++)
                sc_bvh_free(sep[g]);
            sc_accel_release(a);
        }
    free(stream);
    free(rays);
    free(p4);
    for (int i = 0; i < 3; i++)
        mesh_free(&m[i]);
}

/* ---- instances -------------------------------------------------------------- */

/* A transform: rotation about a random axis, per-axis scale (a mirror when
 * mirror), translation. */
static void random_xfm(float x[12], double scale, double aniso, int mirror, double tr)
{
    float ax[3];
    random_dir(ax);
    double ang = rnd_in(0, 6.283185307179586), c = cos(ang), s = sin(ang), C = 1 - c;
    double R[3][3] = { { c + ax[0] * ax[0] * C, ax[0] * ax[1] * C - ax[2] * s, ax[0] * ax[2] * C + ax[1] * s },
                       { ax[1] * ax[0] * C + ax[2] * s, c + ax[1] * ax[1] * C, ax[1] * ax[2] * C - ax[0] * s },
                       { ax[2] * ax[0] * C - ax[1] * s, ax[2] * ax[1] * C + ax[0] * s, c + ax[2] * ax[2] * C } };
    double S[3] = { scale, scale * rnd_in(1, aniso), scale * rnd_in(1, aniso) };
    if (mirror)
        S[1] = -S[1];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            x[4 * i + j] = (float)(R[i][j] * S[j]);
        x[4 * i + 3] = (float)rnd_in(-tr, tr);
    }
}

/* An axis-aligned transform: the axes permuted, scaled, some flipped. */
static void aligned_xfm(float x[12], double scale, int mirror, double tr)
{
    static const int perms[6][3] = { { 0, 1, 2 }, { 0, 2, 1 }, { 1, 0, 2 }, { 1, 2, 0 }, { 2, 0, 1 }, { 2, 1, 0 } };
    const int *pm = perms[(int)(rnd() * 6) % 6];
    memset(x, 0, 12 * sizeof(float));
    for (int i = 0; i < 3; i++) {
        x[4 * i + pm[i]] = (float)(scale * rnd_in(1, 1.5) * (mirror && i == 0 ? -1 : 1));
        x[4 * i + 3] = (float)rnd_in(-tr, tr);
    }
}

static void xfm_point(const float x[12], const double p[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = x[4 * i] * p[0] + x[4 * i + 1] * p[1] + x[4 * i + 2] * p[2] + x[4 * i + 3];
}

/* The object-space ray of the library against M^-1 (o - T), M^-1 d in
 * MPFR: each component within 2^-23 relative (one float rounding of the
 * double result, which is within 2^-40 of exact for these transforms). */
/* The world images of m's vertices under n transforms (xfm_point), n * nv
 * points; the caller frees them. */
static float *world_vertices(const mesh *m, const float (*x)[12], int n)
{
    float *aim = malloc(12 * (size_t)m->nv * (size_t)n);
    assert_non_null(aim);
    for (int i = 0; i < n; i++)
        for (uint32_t v = 0; v < m->nv; v++) {
            const double p[3] = { m->pos[3 * v], m->pos[3 * v + 1], m->pos[3 * v + 2] };
            double w[3];
            xfm_point(x[i], p, w);
            for (int k = 0; k < 3; k++)
                aim[3 * ((size_t)i * m->nv + v) + k] = (float)w[k];
        }
    return aim;
}

static void check_instance_ray(const float x[12], const sc_ray *w, const sc_ray *o)
{
    mpfr_t m[3][3], c[3][3], det, acc, tmp, e;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            mpfr_init2(m[i][j], 256), mpfr_init2(c[i][j], 256);
            mpfr_set_flt(m[i][j], x[4 * i + j], MPFR_RNDN);
        }
    mpfr_inits2(256, det, acc, tmp, e, (mpfr_ptr)0);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {   /* cofactor of m[j][i]: inv[i][j] = c[i][j] / det */
            int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
            mpfr_mul(acc, m[r0][c0], m[r1][c1], MPFR_RNDN);
            mpfr_mul(tmp, m[r0][c1], m[r1][c0], MPFR_RNDN);
            mpfr_sub(c[i][j], acc, tmp, MPFR_RNDN);
        }
    mpfr_set_ui(det, 0, MPFR_RNDN);
    for (int j = 0; j < 3; j++) {
        mpfr_mul(tmp, m[0][j], c[j][0], MPFR_RNDN);
        mpfr_add(det, det, tmp, MPFR_RNDN);
    }
    for (int i = 0; i < 3; i++)
        for (int which = 0; which < 2; which++) {
            mpfr_set_ui(acc, 0, MPFR_RNDN);
            for (int j = 0; j < 3; j++) {
                if (which == 0) {
                    mpfr_set_flt(e, w->org[j], MPFR_RNDN);
                    mpfr_set_flt(tmp, x[4 * j + 3], MPFR_RNDN);
                    mpfr_sub(e, e, tmp, MPFR_RNDN);
                } else {
                    mpfr_set_flt(e, w->dir[j], MPFR_RNDN);
                }
                mpfr_mul(e, e, c[i][j], MPFR_RNDN);
                mpfr_add(acc, acc, e, MPFR_RNDN);
            }
            mpfr_div(acc, acc, det, MPFR_RNDN);
            double exact = mpfr_get_d(acc, MPFR_RNDN);
            double got = which == 0 ? o->org[i] : o->dir[i];
            if (!(fabs(got - exact) <= 0x1p-23 * fabs(exact) + 0x1p-126))
                fail_msg("object ray component %d/%d: %a against exact %a", which, i, got, exact);
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            mpfr_clears(m[i][j], c[i][j], (mpfr_ptr)0);
    mpfr_clears(det, acc, tmp, e, (mpfr_ptr)0);
}

#define NINST 24

/* The world: NINST instances of an object of two meshes (one mirrored, one
 * anisotropic, ...) plus a ground mesh of its own. Checked ray by ray
 * against each instance traced on its own through its object scene. */
static void test_instances(void **state)
{
    (void)state;
    for (int test = 0; test < 2; test++) {
        mesh tor, box, ground;
        const double o0[3] = { 0, 0, 0 };
        torus(&tor, 20, 10, o0, 1.0);
        grid_box(&box, 4, 0);
        grid_box(&ground, 8, 0);
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.tri_test = test ? SC_TRI_EXACT : SC_TRI_WATERTIGHT;
        cfg.prefilter = test ? SC_PREFILTER_COMPACT : SC_PREFILTER_OFF;
        sc_accel *obj, *world;
        assert_int_equal(sc_accel_new(&cfg, &obj), SC_OK);
        const sc_mesh_view vt = { tor.pos, tor.nv, tor.idx, tor.nt, 0, 0 }, vb = { box.pos, box.nv, box.idx, box.nt, 0, 0 };
        assert_int_equal(sc_accel_attach_mesh(obj, &vt, SC_ACCEL_COPY, NULL), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(obj, &vb, SC_ACCEL_COPY, NULL), SC_OK);
        assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
        float x[NINST][12];
        /* not committed yet: refused */
        random_xfm(x[0], 1, 1, 0, 1);
        assert_int_equal(sc_accel_attach_instance(world, obj, x[0], NULL), SC_ERR_INVALID_ARGUMENT);
        assert_int_equal(sc_accel_commit(obj), SC_OK);
        for (int i = 0; i < NINST; i++) {
            if (i % 4 == 2)
                aligned_xfm(x[i], rnd_in(0.3, 2), i % 8 == 2, 6);
            else
                random_xfm(x[i], rnd_in(0.3, 2), i % 3 ? 1 : 3, i % 4 == 1, 6);
            uint32_t id;
            assert_int_equal(sc_accel_attach_instance(world, obj, x[i], &id), SC_OK);
            assert_int_equal(id, (uint32_t)i);
        }
        const sc_mesh_view vg = { ground.pos, ground.nv, ground.idx, ground.nt, 0, 0 };
        assert_int_equal(sc_accel_attach_mesh(world, &vg, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(world), SC_OK);
        sc_bvh *gbvh;
        assert_int_equal(sc_bvh_build(&vg, &cfg, &gbvh), SC_OK);

        /* aim at the world images of the torus vertices */
        float *aim = world_vertices(&tor, x, NINST);
        const size_t N = 3000;
        sc_ray *rays = malloc(N * sizeof *rays);
        const float lo[3] = { -8, -8, -8 }, hi[3] = { 8, 8, 8 };
        make_rays(rays, N, lo, hi, aim, (size_t)tor.nv * NINST);
        /* A third of the rays aimed next to the object's vertices that are
         * extreme along a world axis in the axis-aligned instances (i % 4
         * == 2): there the object's box maps onto the instance's world box,
         * so these hits lie on its faces, where the top level could cull
         * them. */
        for (size_t r = 0; r < N / 3; r++) {
            const int i = 2 + 4 * (int)(r % (NINST / 4)), k = (int)(r / NINST) % 3,
                      hi_side = (int)(r / (3 * NINST)) % 2;
            const mesh *ms[2] = { &tor, &box };
            const mesh *bm = &tor;
            uint32_t best = 0;
            double bw[3] = { 0 };
            for (int g = 0; g < 2; g++)
                for (uint32_t v = 0; v < ms[g]->nv; v++) {
                    const double q[3] = { ms[g]->pos[3 * v], ms[g]->pos[3 * v + 1], ms[g]->pos[3 * v + 2] };
                    double w[3];
                    xfm_point(x[i], q, w);
                    if ((g == 0 && v == 0) || (hi_side ? w[k] > bw[k] : w[k] < bw[k]))
                        bm = ms[g], best = v, memcpy(bw, w, sizeof w);
                }
            /* a point on an edge of that vertex, close to it: the hit is
             * within a hair of the box face */
            uint32_t nb = best;
            for (uint32_t t = 0; t < bm->nt && nb == best; t++)
                for (int c = 0; c < 3; c++)
                    if (bm->idx[3 * t + (uint32_t)c] == best)
                        nb = bm->idx[3 * t + (uint32_t)(c + 1) % 3];
            const double qn[3] = { bm->pos[3 * nb], bm->pos[3 * nb + 1], bm->pos[3 * nb + 2] };
            double wn[3];
            xfm_point(x[i], qn, wn);
            const double f = rnd_in(0.001, 0.05);
            float p[3];
            for (int c = 0; c < 3; c++)
                p[c] = (float)(bw[c] + f * (wn[c] - bw[c]));
            float d[3];
            random_dir(d);
            if ((d[k] > 0) == hi_side)
                d[k] = -d[k];   /* from outside the box face */
            if (r % 2)
                d[k] *= 1e-3f;   /* grazing the face: it never goes deep into the box */
            /* from just before the point, so that no other instance is in the way */
            const float back = 0.02f / sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            sc_ray q = { { p[0] - back * d[0], p[1] - back * d[1], p[2] - back * d[2] }, 0, { d[0], d[1], d[2] }, INFINITY };
            if (r % 2)
                q.tmax = 2 * back;   /* and ends just after it: the segment stays within a hair of the face */
            rays[r] = q;
        }
        /* The exact first hit of every instance's object ray (MPFR), over
         * the object's two meshes as one (prim = first[geom] + prim). */
        sc_oracle orc = { 0 };
        sc_ray *orays = malloc(N * NINST * sizeof *orays);
        for (size_t r = 0; r < N; r++)
            for (int i = 0; i < NINST; i++)
                assert_int_equal(sc_accel_instance_ray(world, (uint32_t)i, &rays[r], &orays[r * NINST + i]), SC_OK);
        if (test) {
            mesh both;
            both.nv = tor.nv + box.nv, both.nt = tor.nt + box.nt;
            both.pos = malloc(12 * (size_t)both.nv);
            both.idx = malloc(12 * (size_t)both.nt);
            memcpy(both.pos, tor.pos, 12 * (size_t)tor.nv);
            memcpy(both.pos + 3 * (size_t)tor.nv, box.pos, 12 * (size_t)box.nv);
            memcpy(both.idx, tor.idx, 12 * (size_t)tor.nt);
            for (size_t k = 0; k < 3 * (size_t)box.nt; k++)
                both.idx[3 * (size_t)tor.nt + k] = box.idx[k] + tor.nv;
            const sc_mesh_view bv = { both.pos, both.nv, both.idx, both.nt, 0, 0 };
            sc_checked_mesh cm;
            assert_int_equal(sc_mesh_check(&bv, &cm), SC_OK);
            assert_int_equal(sc_oracle_run(&cm, orays, N * NINST, 2, 0, &orc), SC_OK);
            /* the oracle keeps no pointer to the mesh */
            mesh_free(&both);
        }
        size_t hits = 0, inst_hits = 0, ties = 0;
        for (size_t r = 0; r < N; r++) {
            sc_hitrec h, want;
            memset(&want, 0, sizeof want);
            want.prim = SC_HITREC_MISS;
            want.t = rays[r].tmax;
            want.geom = want.inst = SC_INVALID_ID;
            /* each instance on its own, in id order, then the ground */
            for (int i = 0; i <= NINST; i++) {
                sc_hitrec s;
                sc_ray o = i < NINST ? orays[r * NINST + i] : rays[r];
                if (i < NINST && r % 16 == 0)
                    check_instance_ray(x[i], &rays[r], &o);
                o.tmax = want.t;
                if (i < NINST) {
                    if (o.dir[0] == 0 && o.dir[1] == 0 && o.dir[2] == 0)
                        continue;
                    assert_int_equal(sc_accel_closest(obj, &o, &s, NULL), SC_OK);
                    s.inst = (uint32_t)i;
                } else {
                    assert_int_equal(sc_trace_closest(gbvh, &o, &s, NULL), SC_OK);
                }
                if (s.prim != SC_HITREC_MISS && (want.prim == SC_HITREC_MISS || s.t < want.t))
                    want = s;
            }
            assert_int_equal(sc_accel_closest(world, &rays[r], &h, NULL), SC_OK);
            if (h.prim != want.prim || h.geom != want.geom)
                ties++;
            if (memcmp(&h.t, &want.t, 4) != 0 || h.inst != want.inst || (!test && !same_bits(&h, &want)))
                fail_msg("test %d ray %zu: world (t %a inst %u geom %u prim %u) against each instance (t %a inst %u "
                         "geom %u prim %u)", test, r, h.t, h.inst, h.geom, h.prim, want.t, want.inst, want.geom,
                         want.prim);
            if (test) {
                /* exact: the hit is the exact first hit of its instance's
                 * ray, and no instance's ray has an exact hit before it */
                if (h.inst != SC_INVALID_ID) {
                    uint32_t gp = h.prim + (h.geom ? tor.nt : 0);
                    assert_true(orc.hits[r * NINST + h.inst].hit);
                    assert_true(sc_oracle_accepts(&orc, r * NINST + h.inst, gp));
                }
                for (int i = 0; i < NINST; i++) {
                    const sc_oracle_hit *oh = &orc.hits[r * NINST + i];
                    if (oh->hit && !(oh->t >= h.t * (1 - 1e-6)))
                        fail_msg("ray %zu: instance %d has an exact hit at %.17g before the reported %.9g", r, i,
                                 oh->t, (double)h.t);
                }
            }
            if (h.prim != SC_HITREC_MISS) {
                hits++;
                inst_hits += h.inst != SC_INVALID_ID;
                /* the world normal is the cross product of the transformed edges */
                if (h.inst != SC_INVALID_ID) {
                    const mesh *mm = h.geom == 0 ? &tor : &box;
                    double P[3][3];
                    for (int c = 0; c < 3; c++) {
                        const float *v = mm->pos + 3 * mm->idx[3 * h.prim + (uint32_t)c];
                        const double p[3] = { v[0], v[1], v[2] };
                        xfm_point(x[h.inst], p, P[c]);
                    }
                    double e1[3], e2[3], n[3];
                    for (int k = 0; k < 3; k++)
                        e1[k] = P[1][k] - P[0][k], e2[k] = P[2][k] - P[0][k];
                    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
                    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
                    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
                    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                    for (int k = 0; k < 3; k++)
                        assert_true(fabs(h.ng[k] - n[k]) <= 1e-4 * len);
                }
            }
            int occ;
            assert_int_equal(sc_accel_any(world, &rays[r], &occ, NULL), SC_OK);
            assert_int_equal(occ, h.prim != SC_HITREC_MISS);
            /* the counting kernels give the same answers, one ray counted once */
            sc_trace_stats ts;
            memset(&ts, 0, sizeof ts);
            sc_hitrec hs;
            int occ_s;
            assert_int_equal(sc_accel_closest(world, &rays[r], &hs, &ts), SC_OK);
            assert_int_equal(sc_accel_any(world, &rays[r], &occ_s, &ts), SC_OK);
            assert_true(same_bits(&hs, &h));
            assert_int_equal(occ_s, occ);
            assert_int_equal(ts.rays, 2);
            assert_true(ts.nodes >= 1);
        }
        print_message("test %d: %zu of %zu rays hit, %zu through instances; %zu exact ties\n", test, hits, N,
                      inst_hits, ties);
        sc_oracle_free(&orc);
        free(orays);
        sc_bvh_free(gbvh);
        assert_true(hits > N / 4);
        assert_true(inst_hits > N / 8);
        sc_accel_info info;
        assert_int_equal(sc_accel_get_info(world, &info), SC_OK);
        assert_int_equal(info.instances, NINST);
        assert_int_equal(info.instanced_triangles, (size_t)NINST * (tor.nt + box.nt));
        free(aim);
        free(rays);
        /* either order: the world holds its own reference to obj */
        if (test) {
            sc_accel_release(obj);
            sc_accel_release(world);
        } else {
            sc_accel_release(world);
            sc_accel_release(obj);
        }
        mesh_free(&tor), mesh_free(&box), mesh_free(&ground);
    }
}


/* ---- no holes through instances ------------------------------------------ */

/* Rays from inside a closed torus seen through instances (rotated, mirrored,
 * anisotropic, tiny, huge, far off) in every direction, some aimed at its
 * vertices: every one hits the instance it starts in (or one nearer). */
static void test_no_holes(void **state)
{
    (void)state;
    mesh tor;
    const double o0[3] = { 0, 0, 0 };
    torus(&tor, 36, 18, o0, 1.0);
    for (int test = 0; test < 2; test++) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.tri_test = test ? SC_TRI_EXACT : SC_TRI_WATERTIGHT;
        sc_accel *obj, *world;
        assert_int_equal(sc_accel_new(&cfg, &obj), SC_OK);
        const sc_mesh_view vt = { tor.pos, tor.nv, tor.idx, tor.nt, 0, 0 };
        assert_int_equal(sc_accel_attach_mesh(obj, &vt, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(obj), SC_OK);
        assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
        enum { K = 8 };
        float x[K][12];
        const double scales[K] = { 1, 0.37, 2.9, 1e-3, 1e3, 1, 0.8, 5 };
        const double shifts[K] = { 0, 3, 10, 1, 4e3, 1e4, 20, 50 };
        for (int i = 0; i < K; i++) {
            if (i % 3 == 2)
                aligned_xfm(x[i], scales[i], i == 5, 0);
            else
                random_xfm(x[i], scales[i], i % 2 ? 2.5 : 1, i == 1 || i == 6, 0);
            /* instances far apart, so a ray from inside one meets it first */
            x[i][3] = (float)(shifts[i] + 3e3 * i);
            x[i][7] = (float)(-shifts[i]);
            x[i][11] = (float)(0.5 * shifts[i]);
            if (scales[i] < 0.01)   /* near the origin: world floats resolve its tube */
                x[i][3] = x[i][7] = x[i][11] = -5;
            assert_int_equal(sc_accel_attach_instance(world, obj, x[i], NULL), SC_OK);
        }
        assert_int_equal(sc_accel_commit(world), SC_OK);
        size_t rays = 0, missed = 0;
        for (int i = 0; i < K; i++)
            for (int r = 0; r < 4000; r++) {
                /* a point on the tube's centre circle, in world space */
                double u = rnd_in(0, 6.283185307179586), q[3] = { cos(u), sin(u), 0 }, w[3];
                double rr = rnd_in(0, 0.2);   /* within the tube of radius 0.35 */
                q[0] += rr * cos(u), q[1] += rr * sin(u);
                place(q, o0, 1.0);   /* as torus() placed its vertices */
                xfm_point(x[i], q, w);
                sc_ray ray = { { (float)w[0], (float)w[1], (float)w[2] }, 0, { 0, 0, 0 }, INFINITY };
                if (r % 2) {
                    random_dir(ray.dir);
                } else {
                    uint32_t v = (uint32_t)(rnd() * tor.nv) % tor.nv;
                    const double p[3] = { tor.pos[3 * v], tor.pos[3 * v + 1], tor.pos[3 * v + 2] };
                    double pw[3];
                    xfm_point(x[i], p, pw);
                    for (int k = 0; k < 3; k++)
                        ray.dir[k] = (float)(pw[k] - w[k]);
                }
                sc_hitrec h;
                assert_int_equal(sc_accel_closest(world, &ray, &h, NULL), SC_OK);
                int occ;
                assert_int_equal(sc_accel_any(world, &ray, &occ, NULL), SC_OK);
                rays++;
                if (h.prim == SC_HITREC_MISS || h.inst != (uint32_t)i || !occ) {
                    missed++;
                    print_message("test %d instance %d: ray from inside missed (inst %u, occluded %d)\n", test, i,
                                  h.inst, occ);
                }
            }
        print_message("%s: %zu rays from inside 8 instances, %zu missed\n", test ? "exact" : "watertight", rays,
                      missed);
        assert_int_equal(missed, 0);
        sc_accel_release(world);
        sc_accel_release(obj);
    }
    mesh_free(&tor);
}

/* ---- refit -------------------------------------------------------------------- */

/* A height field z = f(x, y) on an n x n grid, with a wave of amplitude amp. */
static void wave(float *pos, int n, double amp, double phase)
{
    for (int i = 0; i <= n; i++)
        for (int j = 0; j <= n; j++) {
            double x = (double)i / n, y = (double)j / n;
            float *p = pos + 3 * ((size_t)i * (n + 1) + j);
            p[0] = (float)x, p[1] = (float)y;
            p[2] = (float)(amp * sin(6.283185307179586 * (x + phase)) * cos(9.42 * y + phase));
        }
}

/* Every sphere and summary of the tree contains its triangle (MPFR). */
static void check_spheres(const sc_bvh *bvh, const float *pos, const uint32_t *idx)
{
    mpfr_t d, s, r2;
    mpfr_inits2(1024, d, s, r2, (mpfr_ptr)0);
    size_t checked = 0;
    for (size_t ni = 0; ni < bvh->node_count; ni++)
        for (int c = 0; c < SC_BVH_N; c++) {
            const uint64_t ref = bvh->nodes[ni].child[c];
            if (!ref || !sc_ref_is_leaf(ref) || !(sc_ref_has_spheres(ref) || sc_ref_has_summary(ref)))
                continue;
            const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
            const float *head = sc_leaf_block(bvh->leaves, ref);
            _Alignas(64) float blk[64];
            if (sc_ref_has_summary(ref))
                sc_leaf_summary_decode(head, W, blk);
            else
                memcpy(blk, head, 16 * W);
            const uint32_t *prims = sc_leaf_prims(sc_leaf_rows(head, W, ref), W);
            for (unsigned i = 0; i < n; i++) {
                mpfr_set_flt(r2, blk[3 * W + i], MPFR_RNDN);
                for (int j = 0; j < 3; j++) {
                    const float *V = pos + 3 * idx[3 * prims[i] + (uint32_t)j];
                    mpfr_set_ui(s, 0, MPFR_RNDN);
                    for (int k = 0; k < 3; k++) {
                        mpfr_set_flt(d, V[k], MPFR_RNDN);
                        mpfr_sub_d(d, d, blk[k * W + i], MPFR_RNDN);
                        mpfr_fma(s, d, d, s, MPFR_RNDN);
                    }
                    assert_true(mpfr_cmp(s, r2) <= 0);
                }
                checked++;
            }
        }
    assert_true(checked > 0);
    mpfr_clears(d, s, r2, (mpfr_ptr)0);
}

/* Refits of a moving wave answer as fresh builds over the moved vertices,
 * bit for bit, in every prefilter mode; a large change rebuilds; a
 * non-finite vertex rebuilds (sc_accel) or is refused with the tree
 * unchanged (sc_bvh_refit). */
static void test_refit(void **state)
{
    (void)state;
    const int n = 40;
    const size_t nv = (size_t)(n + 1) * (n + 1), nt = 2 * (size_t)n * n;
    float *pos = malloc(12 * nv), *moved = malloc(12 * nv);
    uint32_t *idx = malloc(12 * nt);
    for (int i = 0, t = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            uint32_t a = (uint32_t)(i * (n + 1) + j), b = a + 1, c = a + (uint32_t)n + 1, d = c + 1;
            const uint32_t q[6] = { a, b, d, a, d, c };
            memcpy(idx + 3 * t, q, sizeof q);
            t += 2;
        }
    const size_t N = 3000;
    sc_ray *rays = malloc(N * sizeof *rays);
    const float lo[3] = { 0, 0, -0.3f }, hi[3] = { 1, 1, 0.3f };
    for (int mode = 0; mode < SC_PREFILTER_MODE_COUNT; mode++) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.prefilter = (sc_prefilter_mode)mode;
        cfg.leaf_size = mode == SC_PREFILTER_AUTO ? 16 : 8;
        wave(pos, n, 0.05, 0);
        sc_accel *a;
        assert_int_equal(sc_accel_new(&cfg, &a), SC_OK);
        const sc_mesh_view v = { pos, nv, idx, nt, 0, 0 };
        assert_int_equal(sc_accel_attach_mesh(a, &v, SC_ACCEL_COPY, NULL), SC_OK);
        assert_int_equal(sc_accel_refit(a), SC_OK);   /* never committed: builds */
        sc_accel_info info;
        assert_int_equal(sc_accel_get_info(a, &info), SC_OK);
        assert_int_equal(info.builds, 1);
        assert_int_equal(info.refits, 0);
        for (int step = 1; step <= 6; step++) {
            wave(moved, n, 0.05 + 0.01 * step, 0.01 * step);
            assert_int_equal(sc_accel_update_vertices(a, 0, moved, 0), SC_OK);
            assert_int_equal(sc_accel_refit(a), SC_OK);
            assert_int_equal(sc_accel_get_info(a, &info), SC_OK);
            assert_int_equal(info.builds, 1);
            assert_int_equal(info.refits, (unsigned)step);
            assert_true(info.sah_growth >= 0.5 && info.sah_growth <= SC_ACCEL_REBUILD_GROWTH);
            const sc_mesh_view mv = { moved, nv, idx, nt, 0, 0 };
            sc_bvh *fresh;
            assert_int_equal(sc_bvh_build(&mv, &cfg, &fresh), SC_OK);
            make_rays(rays, N, lo, hi, moved, nv);
            for (size_t r = 0; r < N; r++) {
                sc_hitrec h, w;
                assert_int_equal(sc_accel_closest(a, &rays[r], &h, NULL), SC_OK);
                assert_int_equal(sc_trace_closest(fresh, &rays[r], &w, NULL), SC_OK);
                if (!same_bits(&h, &w))
                    fail_msg("mode %d step %d ray %zu: refit (t %a prim %u) fresh (t %a prim %u)", mode, step, r, h.t,
                             h.prim, w.t, w.prim);
            }
            sc_bvh_free(fresh);
        }
        /* the refitted tree's spheres contain their moved triangles */
        if (mode != SC_PREFILTER_OFF)
            for (int step = 0; step < 1; step++) {
                sc_bvh *b;
                const sc_mesh_view v0 = { pos, nv, idx, nt, 0, 0 }, mv = { moved, nv, idx, nt, 0, 0 };
                assert_int_equal(sc_bvh_build(&v0, &cfg, &b), SC_OK);
                assert_int_equal(sc_bvh_refit(b, &mv), SC_OK);
                if (mode != SC_PREFILTER_AUTO)
                    check_spheres(b, moved, idx);
                /* refused: a non-finite vertex, another triangle count; the tree unchanged */
                sc_bvh_info before, after;
                assert_int_equal(sc_bvh_get_info(b, &before), SC_OK);
                float keep = moved[3 * 7 + 2];
                moved[3 * 7 + 2] = NAN;
                assert_int_equal(sc_bvh_refit(b, &mv), SC_ERR_NONFINITE);
                moved[3 * 7 + 2] = keep;
                const sc_mesh_view fewer = { moved, nv, idx, nt - 1, 0, 0 };
                assert_int_equal(sc_bvh_refit(b, &fewer), SC_ERR_INVALID_ARGUMENT);
                assert_int_equal(sc_bvh_refit(NULL, &mv), SC_ERR_INVALID_ARGUMENT);
                assert_int_equal(sc_bvh_get_info(b, &after), SC_OK);
                assert_true(before.sah_cost == after.sah_cost);
                if (mode != SC_PREFILTER_AUTO)
                    check_spheres(b, moved, idx);
                sc_bvh_free(b);
            }
        /* scrambled vertices: the refitted tree would be far worse, so it rebuilds */
        for (size_t i = 0; i < nv; i++)
            moved[3 * i + 2] = (float)((i * 7919 % 101) / 101.0 - 0.5);
        assert_int_equal(sc_accel_update_vertices(a, 0, moved, 0), SC_OK);
        assert_int_equal(sc_accel_refit(a), SC_OK);
        assert_int_equal(sc_accel_get_info(a, &info), SC_OK);
        assert_int_equal(info.builds, 2);
        assert_true(info.sah_growth == 1);
        /* a non-finite vertex: rebuilt, that triangle never hit */
        moved[2] = INFINITY;
        assert_int_equal(sc_accel_update_vertices(a, 0, moved, 0), SC_OK);
        assert_int_equal(sc_accel_refit(a), SC_OK);
        assert_int_equal(sc_accel_get_info(a, &info), SC_OK);
        assert_int_equal(info.builds, 3);
        sc_ray down = { { 0.001f, 0.004f, 5 }, 0, { 0, 0, -1 }, INFINITY };
        sc_hitrec h;
        assert_int_equal(sc_accel_closest(a, &down, &h, NULL), SC_OK);
        assert_true(h.prim != 0);
        sc_accel_release(a);
    }
    free(rays);
    free(pos), free(moved), free(idx);
}

/* ---- bad arguments --------------------------------------------------------- */

/* The top level's growth (trace_top.h): an instance whose transform has a
 * condition number of 10^3 (a scale after the rotation), and rays from
 * 10^4 of its sizes away that pass just outside its world box beside the
 * vertex that bounds it, half of them exactly parallel to that face (the
 * grown boxes of sc_top_slab). The rounded object ray lands up to about
 * u kappa D from the world ray, far beyond the slab test's own padding
 * (2u D), so an instance whose object ray hits is kept only through the
 * growth. Every answer, single rays and packets of 16, must be the object
 * scene's for the object ray (sc_accel_instance_ray); enough object rays
 * hit for that to mean something. With the growth set to 0 in the FMA
 * test's padding, in the packets' set-up alone, or in the grown boxes,
 * this test fails. */
static void test_growth(void **state)
{
    (void)state;
    mesh box;
    grid_box(&box, 2, 0);
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    sc_accel *obj, *world;
    const sc_mesh_view v = { box.pos, box.nv, box.idx, box.nt, 0, 0 };
    assert_int_equal(sc_accel_new(&cfg, &obj), SC_OK);
    assert_int_equal(sc_accel_attach_mesh(obj, &v, SC_ACCEL_COPY, NULL), SC_OK);
    assert_int_equal(sc_accel_commit(obj), SC_OK);
    /* M = S R, the scale after the rotation: the object ray's rounding in
     * the object's axes comes back scaled by S, up to kappa u D in world */
    float x[12];
    const double S[3] = { 1, 1e3, rnd_in(30, 1e3) };
    random_xfm(x, 1.0, 1.0, 0, 10.0);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            x[4 * i + j] = (float)(x[4 * i + j] * S[i]);
    assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
    assert_int_equal(sc_accel_attach_instance(world, obj, x, NULL), SC_OK);
    assert_int_equal(sc_accel_commit(world), SC_OK);
    /* the world vertices, the box's extent and the vertices that bound it */
    double (*wv)[3] = malloc(box.nv * sizeof *wv), lo[3], hi[3];
    size_t arg[3][2] = { { 0, 0 }, { 0, 0 }, { 0, 0 } };
    for (uint32_t i = 0; i < box.nv; i++) {
        const double p[3] = { box.pos[3 * i], box.pos[3 * i + 1], box.pos[3 * i + 2] };
        xfm_point(x, p, wv[i]);
        for (int k = 0; k < 3; k++) {
            if (i == 0 || wv[i][k] < lo[k])
                lo[k] = wv[i][k], arg[k][0] = i;
            if (i == 0 || wv[i][k] > hi[k])
                hi[k] = wv[i][k], arg[k][1] = i;
        }
    }
    double ext = 0;
    for (int k = 0; k < 3; k++)
        ext = fmax(ext, hi[k] - lo[k]);
    const double D = 1e4 * ext;
    double reach[3];
    for (int k = 0; k < 3; k++)
        reach[k] = 0x1p-23 * D * S[k];
    enum { N = 4096 };
    sc_ray *rays = malloc(N * sizeof *rays);
    sc_hitrec *want = malloc(N * sizeof *want);
    int32_t *want_occ = malloc(N * sizeof *want_occ);
    size_t hits = 0;
    double d[3] = { 0, 0, 1 }, dl = 1, P0[3] = { 0, 0, 0 };
    size_t par_hits = 0;
    for (size_t r = 0; r < N; r++) {
        /* 16 rays from one origin (a packet narrow enough to walk the top
         * tree together) past one bounding vertex */
        const size_t grp = r / 16;
        const int k = (int)(grp % 3), side = (int)(grp / 3 % 2);
        const double *V = wv[arg[k][side]];
        if (r % 16 == 0) {
            /* a direction nearly along the face, or in every other packet
             * exactly along it (rays parallel to an axis: the grown boxes) */
            dl = 0;
            for (int a = 0; a < 3; a++)
                d[a] = a == k ? (grp / 6 % 2 ? 0 : rnd_in(-1e-4, 1e-4)) : rnd_in(-1, 1), dl += d[a] * d[a];
            dl = sqrt(dl);
        }
        /* a point beside V, outside the box's face by up to `reach`; the
         * rays of one packet within a thousandth of that of each other */
        double P[3] = { V[0], V[1], V[2] };
        if (r % 16 == 0) {
            P0[k] = (side ? 1 : -1) * rnd() * reach[k];
            P0[(k + 1) % 3] = rnd_in(-1, 1) * reach[(k + 1) % 3], P0[(k + 2) % 3] = rnd_in(-1, 1) * reach[(k + 2) % 3];
        }
        for (int a = 0; a < 3; a++)
            P[a] += P0[a] + rnd_in(-1e-3, 1e-3) * reach[a];
        sc_ray q = { { 0, 0, 0 }, 0, { 0, 0, 0 }, INFINITY };
        for (int a = 0; a < 3; a++)
            q.org[a] = (float)(V[a] - D * d[a] / dl);
        for (int a = 0; a < 3; a++)
            q.dir[a] = (float)(2 * (P[a] - q.org[a]));
        if (d[k] == 0)
            q.org[k] = (float)P[k], q.dir[k] = 0;
        rays[r] = q;
        sc_ray o;
        assert_int_equal(sc_accel_instance_ray(world, 0, &q, &o), SC_OK);
        int occ;
        assert_int_equal(sc_accel_closest(obj, &o, &want[r], NULL), SC_OK);
        assert_int_equal(sc_accel_any(obj, &o, &occ, NULL), SC_OK);
        want_occ[r] = occ;
        hits += want[r].prim != SC_HITREC_MISS;
        par_hits += want[r].prim != SC_HITREC_MISS && q.dir[k] == 0;
        sc_hitrec g;
        assert_int_equal(sc_accel_closest(world, &q, &g, NULL), SC_OK);
        assert_int_equal(sc_accel_any(world, &q, &occ, NULL), SC_OK);
        if (g.prim != want[r].prim || memcmp(&g.t, &want[r].t, sizeof g.t) || occ != want_occ[r])
            fail_msg("ray %zu: through the instance prim %u t %a occluded %d, its object ray prim %u t %a "
                     "occluded %d", r, g.prim, g.t, occ, want[r].prim, want[r].t, want_occ[r]);
    }
    print_message("%zu of %d object rays hit beside the world box, %zu of them parallel to its face\n", hits, N,
                  par_hits);
    assert_true(hits >= N / 64);
    /* the same rays as packets of 16, on every ISA level */
    const sc_isa start = sc_isa_active();
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        for (size_t base = 0; base < N; base += 16) {
            sc_ray_packet16 p;
            int32_t valid[16], o16[16];
            pack_rays(rays + base, &p, NULL, valid);
            sc_hit_packet16 h;
            assert_int_equal(sc_accel_closest16(world, valid, &p, &h, NULL), SC_OK);
            assert_int_equal(sc_accel_any16(world, valid, &p, o16, NULL), SC_OK);
            for (unsigned i = 0; i < 16; i++)
                if (h.prim[i] != want[base + i].prim || memcmp(&h.t[i], &want[base + i].t, sizeof h.t[i]) ||
                    o16[i] != want_occ[base + i])
                    fail_msg("%s packet ray %zu: prim %u t %a occluded %d, its object ray prim %u t %a occluded %d",
                             sc_isa_name((sc_isa)isa), base + i, h.prim[i], h.t[i], o16[i], want[base + i].prim,
                             want[base + i].t, want_occ[base + i]);
        }
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    sc_accel_release(world);
    sc_accel_release(obj);
    free(rays), free(want), free(want_occ), free(wv);
    mesh_free(&box);
}

/* ---- when an object ray needs no check ------------------------------------- */

/* M^-1 (rows 0-2 of inv) and -M^-1 T (column 3) in double, as the scene
 * computes them; 0 for a singular M. */
static int inverse_of(const float xfm[12], double inv[12])
{
    double m[3][3], c[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            m[i][j] = xfm[4 * i + j];
    for (int j = 0; j < 3; j++) {
        const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        c[0][j] = m[1][j1] * m[2][j2] - m[2][j1] * m[1][j2];
        c[1][j] = m[2][j1] * m[0][j2] - m[0][j1] * m[2][j2];
        c[2][j] = m[0][j1] * m[1][j2] - m[1][j1] * m[0][j2];
    }
    const double det = m[0][0] * c[0][0] + m[1][0] * c[1][0] + m[2][0] * c[2][0];
    if (!(fabs(det) > 0) || !isfinite(det))
        return 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (!isfinite(inv[4 * i + j] = c[j][i] / det))
                return 0;
    for (int i = 0; i < 3; i++)
        inv[4 * i + 3] = -(inv[4 * i] * xfm[3] + inv[4 * i + 1] * xfm[7] + inv[4 * i + 2] * xfm[11]);
    return 1;
}

/* sc_top_valid_bounds: a world ray inside the bounds must give a valid
 * object ray (sc_ray_valid), so the walks may skip the check. The rays
 * are aimed at each bound from both sides (0.25x to 4x of it): origins
 * along the row of M^-1 with the largest absolute sum, directions along
 * it (the largest object direction) and along M x for the sign vector x of
 * M's largest row (the smallest). Transforms of scales 2^-80 to 2^80, of
 * condition up to about 2^40, translated up to 1e22, in both MXCSR modes
 * (test registration). Each bound made 8 times looser fails: a boundary
 * ray then gives an origin beyond 1e18 or an infinite direction, and (in
 * the FTZ|DAZ run, where a subnormal component reads as 0) a direction
 * that rounds to 0. */
static void test_object_ray_bounds(void **state)
{
    (void)state;
    size_t fast = 0, near_vo = 0, near_vdhi = 0, near_vdlo = 0;
    for (int trial = 0; trial < 3000; trial++) {
        float xfm[12];
        const double scale = ldexp(1, (int)rnd_in(-80, 80));
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++)
                xfm[4 * i + j] = (float)(scale * rnd_in(-1, 1) * (trial % 3 == 0 ? ldexp(1, (int)rnd_in(0, 40)) : 1));
            xfm[4 * i + 3] = (float)(rnd_in(-1, 1) * pow(10, rnd_in(-5, 22)));
        }
        double inv[12];
        if (!inverse_of(xfm, inv))
            continue;
        sc_top_item it;
        memset(&it, 0, sizeof it);
        sc_top_valid_bounds(inv, xfm, &it.vo, &it.vdlo, &it.vdhi);
        /* the rows with the largest absolute sums: of M^-1, and of M */
        int ia = 0, im = 0;
        double best_a = -1, best_m = -1;
        for (int i = 0; i < 3; i++) {
            const double a = fabs(inv[4 * i]) + fabs(inv[4 * i + 1]) + fabs(inv[4 * i + 2]);
            const double f = fabs((double)xfm[4 * i]) + fabs((double)xfm[4 * i + 1]) + fabs((double)xfm[4 * i + 2]);
            if (a > best_a)
                best_a = a, ia = i;
            if (f > best_m)
                best_m = f, im = i;
        }
        for (int j = 0; j < 96; j++) {
            const int kind = j % 3;
            const double f = pow(2, rnd_in(-2, 2));
            sc_ray w;
            w.tmin = 0, w.tmax = INFINITY;
            float d0[3];
            random_dir(d0);
            if (kind == 0) {
                /* the largest object origin: o_k = om sign(inv[ia][k]) */
                const double om = it.vo * f;
                for (int k = 0; k < 3; k++)
                    w.org[k] = (float)copysign(om, inv[4 * ia + k]), w.dir[k] = d0[k];
            } else if (kind == 1) {
                /* the largest object direction */
                const double dm = it.vdhi * f;
                for (int k = 0; k < 3; k++)
                    w.org[k] = 0, w.dir[k] = (float)copysign(dm, inv[4 * ia + k]);
            } else {
                /* the smallest: d = c M x, x the signs of M's largest row,
                 * so M^-1 d = c x and max |d_k| = c F */
                double x[3], d[3], mx = 0;
                for (int k = 0; k < 3; k++)
                    x[k] = copysign(1, (double)xfm[4 * im + k]);
                for (int i = 0; i < 3; i++) {
                    d[i] = xfm[4 * i] * x[0] + xfm[4 * i + 1] * x[1] + xfm[4 * i + 2] * x[2];
                    mx = fmax(mx, fabs(d[i]));
                }
                const double c = (double)it.vdlo * f / mx;
                for (int k = 0; k < 3; k++)
                    w.org[k] = 0, w.dir[k] = (float)(c * d[k]);
            }
            if (!sc_ray_valid(&w))
                continue;
            float om, dm;
            sc_top_ray_extent(&w, &om, &dm);
            if (!sc_top_surely_valid(&it, om, dm))
                continue;
            sc_ray o;
            sc_top_object_ray(inv, &w, &o);
            if (!sc_ray_valid(&o))
                fail_msg("trial %d kind %d: world ray o (%a %a %a) d (%a %a %a) inside the bounds (vo %a vdlo %a "
                         "vdhi %a) gives an invalid object ray o (%a %a %a) d (%a %a %a)",
                         trial, kind, w.org[0], w.org[1], w.org[2], w.dir[0], w.dir[1], w.dir[2], it.vo, it.vdlo,
                         it.vdhi, o.org[0], o.org[1], o.org[2], o.dir[0], o.dir[1], o.dir[2]);
            fast++;
            near_vo += kind == 0 && om > it.vo * 0.5f;
            near_vdhi += kind == 1 && dm > it.vdhi * 0.5f;
            near_vdlo += kind == 2 && dm < it.vdlo * 2.0f;
        }
    }
    print_message("%zu object rays inside the bounds; within 2x of vo %zu, of vdhi %zu, of vdlo %zu\n", fast, near_vo,
                  near_vdhi, near_vdlo);
    assert_true(near_vo > 1000 && near_vdhi > 1000 && near_vdlo > 1000);
}

/* ---- object rays the tracer refuses ----------------------------------------- */

/* An instance scaled by 2^-70: a world ray from farther than about 1e-3 of
 * it has an object-space origin beyond 1e18, which the tracer refuses, so
 * the ray misses that instance (sc_accel.h), while rays from next to it
 * hit it. Packets of 8 and 16, closest and any, on every ISA level, must
 * answer as the single rays do, and the refused rays must miss it. */
static void test_refused_object_rays(void **state)
{
    (void)state;
    mesh tor;
    const double o0[3] = { 0, 0, 0 };
    torus(&tor, 36, 18, o0, 1.0);
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    sc_accel *obj, *world;
    assert_int_equal(sc_accel_new(&cfg, &obj), SC_OK);
    const sc_mesh_view vt = { tor.pos, tor.nv, tor.idx, tor.nt, 0, 0 };
    assert_int_equal(sc_accel_attach_mesh(obj, &vt, SC_ACCEL_SHARED, NULL), SC_OK);
    assert_int_equal(sc_accel_commit(obj), SC_OK);
    assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
    const float s = 0x1p-70f;
    const float tiny[12] = { s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0 };
    const float beside[12] = { 1, 0, 0, 4, 0, 1, 0, 0, 0, 0, 1, 0 };
    uint32_t id_tiny, id_beside;
    assert_int_equal(sc_accel_attach_instance(world, obj, tiny, &id_tiny), SC_OK);
    assert_int_equal(sc_accel_attach_instance(world, obj, beside, &id_beside), SC_OK);
    assert_int_equal(sc_accel_commit(world), SC_OK);
    enum { N = 1024 };
    sc_ray *rays = calloc(N, sizeof *rays);
    sc_hitrec *want = calloc(N, sizeof *want);
    int32_t *want_occ = calloc(N, sizeof *want_occ);
    assert_non_null(rays), assert_non_null(want), assert_non_null(want_occ);
    size_t refused = 0, tiny_hits = 0, beside_hits = 0;
    for (size_t i = 0; i < N; i++) {
        sc_ray *r = &rays[i];
        /* a point on the torus's ring to aim at, in object space */
        const double u = rnd_in(0, 6.283185307179586);
        const double ring[3] = { cos(u), sin(u), rnd_in(-0.3, 0.3) };
        float aim[3];
        switch (i % 4) {
        case 0:   /* from afar, through the tiny instance: refused */
            for (int k = 0; k < 3; k++)
                r->org[k] = (float)rnd_in(-1, 1), aim[k] = (float)(s * ring[k]);
            break;
        case 1:   /* from next to it, with a direction of 1e18 times its
                   * length: a non-finite object direction, refused */
        case 2:   /* from next to it: an object ray it takes */
            for (int k = 0; k < 3; k++)
                r->org[k] = (float)(s * rnd_in(-2, 2)), aim[k] = (float)(s * ring[k]);
            break;
        default:  /* at the other instance */
            for (int k = 0; k < 3; k++)
                r->org[k] = (float)(rnd_in(-1, 1) + (k == 0 ? 4 : 0) + (k == 2 ? 3 : 0)),
                aim[k] = (float)(ring[k] + (k == 0 ? 4 : 0));
            break;
        }
        double len = 0;
        for (int k = 0; k < 3; k++)
            len += ((double)aim[k] - r->org[k]) * ((double)aim[k] - r->org[k]);
        for (int k = 0; k < 3; k++)
            r->dir[k] = i % 4 == 1 ? (float)(((double)aim[k] - r->org[k]) / sqrt(len) * 1e18) : aim[k] - r->org[k];
        r->tmin = 0, r->tmax = INFINITY;
        assert_int_equal(sc_accel_closest(world, r, &want[i], NULL), SC_OK);
        assert_int_equal(sc_accel_any(world, r, &want_occ[i], NULL), SC_OK);
        sc_ray o;
        assert_int_equal(sc_accel_instance_ray(world, id_tiny, r, &o), SC_OK);
        int taken = (o.dir[0] != 0) | (o.dir[1] != 0) | (o.dir[2] != 0);
        for (int k = 0; k < 3; k++)
            taken &= (fabsf(o.org[k]) < 1e18f) & (fabsf(o.dir[k]) <= FLT_MAX);
        if (!taken) {
            refused++;
            assert_int_not_equal(want[i].inst, id_tiny);
        }
        tiny_hits += want[i].inst == id_tiny;
        beside_hits += want[i].inst == id_beside;
    }
    print_message("%zu of %d rays refused by the tiny instance; hits: tiny %zu, beside %zu\n", refused, N, tiny_hits,
                  beside_hits);
    assert_true(refused >= N / 4);
    assert_true(tiny_hits >= N / 16);
    assert_true(beside_hits >= N / 16);
    const sc_isa start = sc_isa_active();
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        for (size_t base = 0; base < N; base += 16) {
            sc_ray_packet16 p16;
            sc_ray_packet8 p8[2];
            int32_t valid[16], o16[16], o8[16];
            pack_rays(rays + base, &p16, p8, valid);
            sc_hit_packet16 h16;
            sc_hit_packet8 h8[2];
            assert_int_equal(sc_accel_closest16(world, valid, &p16, &h16, NULL), SC_OK);
            assert_int_equal(sc_accel_any16(world, valid, &p16, o16, NULL), SC_OK);
            for (unsigned j = 0; j < 2; j++) {
                assert_int_equal(sc_accel_closest8(world, valid, &p8[j], &h8[j], NULL), SC_OK);
                assert_int_equal(sc_accel_any8(world, valid, &p8[j], o8 + 8 * j, NULL), SC_OK);
            }
            for (unsigned i = 0; i < 16; i++) {
                const sc_hitrec *w = &want[base + i];
                const sc_hit_packet8 *g8 = &h8[i / 8];
                const unsigned l = i % 8;
                if (h16.prim[i] != w->prim || h16.inst[i] != w->inst || memcmp(&h16.t[i], &w->t, sizeof w->t) ||
                    o16[i] != want_occ[base + i] || g8->prim[l] != w->prim || g8->inst[l] != w->inst ||
                    memcmp(&g8->t[l], &w->t, sizeof w->t) || o8[i] != want_occ[base + i])
                    fail_msg("%s ray %zu: packet16 inst %u prim %u t %a occluded %d, packet8 inst %u prim %u "
                             "occluded %d; single inst %u prim %u t %a occluded %d",
                             sc_isa_name((sc_isa)isa), base + i, h16.inst[i], h16.prim[i], h16.t[i], o16[i],
                             g8->inst[l], g8->prim[l], o8[i], w->inst, w->prim, w->t, want_occ[base + i]);
            }
        }
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    sc_accel_release(world);
    sc_accel_release(obj);
    free(rays), free(want), free(want_occ);
    mesh_free(&tor);
}

static void test_errors(void **state)
{
    (void)state;
    mesh tor;
    const double o0[3] = { 0, 0, 0 };
    torus(&tor, 8, 6, o0, 1.0);
    const sc_mesh_view v = { tor.pos, tor.nv, tor.idx, tor.nt, 0, 0 };
    sc_accel *a, *b, *c;
    assert_int_equal(sc_accel_new(NULL, NULL), SC_ERR_INVALID_ARGUMENT);
    sc_bvh_config bad;
    sc_bvh_config_default(&bad);
    bad.leaf_size = 99;
    assert_int_equal(sc_accel_new(&bad, &a), SC_OK);   /* the config is checked at the build */
    assert_int_equal(sc_accel_attach_mesh(a, &v, SC_ACCEL_SHARED, NULL), SC_OK);
    assert_int_equal(sc_accel_commit(a), SC_ERR_INVALID_ARGUMENT);
    sc_accel_release(a);
    assert_int_equal(sc_accel_new(NULL, &a), SC_OK);
    assert_int_equal(sc_accel_new(NULL, &b), SC_OK);
    assert_int_equal(sc_accel_new(NULL, &c), SC_OK);
    sc_mesh_view w = v;
    w.vertex_stride = 5;
    assert_int_equal(sc_accel_attach_mesh(a, &w, 0, NULL), SC_ERR_INVALID_ARGUMENT);
    w = v;
    w.vertex_count = 3;   /* indices out of range */
    assert_int_equal(sc_accel_attach_mesh(a, &w, 0, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_attach_mesh(a, &v, 7, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_attach_mesh(a, &v, SC_ACCEL_COPY, NULL), SC_OK);
    assert_int_equal(sc_accel_update_vertices(a, 1, tor.pos, 0), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_update_vertices(a, 0, tor.pos, 7), SC_ERR_INVALID_ARGUMENT);
    const float id[12] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0 };
    float sing[12] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0 }, nan[12];
    memcpy(nan, id, sizeof nan);
    nan[3] = NAN;
    assert_int_equal(sc_accel_attach_instance(b, a, id, NULL), SC_ERR_INVALID_ARGUMENT);   /* a not committed */
    assert_int_equal(sc_accel_commit(a), SC_OK);
    assert_int_equal(sc_accel_attach_instance(b, a, sing, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_attach_instance(b, a, nan, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_attach_instance(b, b, id, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_attach_instance(b, a, id, NULL), SC_OK);
    assert_int_equal(sc_accel_set_transform(b, 1, id), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_set_transform(b, 0, sing), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_commit(b), SC_OK);
    assert_int_equal(sc_accel_attach_instance(c, b, id, NULL), SC_ERR_INVALID_ARGUMENT);   /* two levels only */
    /* aimed at the centre of triangle 0 */
    float cen[3] = { 0, 0, 0 };
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 3; j++)
            cen[k] += tor.pos[3 * tor.idx[j] + (uint32_t)k] / 3;
    sc_ray ray = { { 0, 0, 5 }, 0, { cen[0], cen[1], cen[2] - 5 }, INFINITY }, o;
    assert_int_equal(sc_accel_instance_ray(b, 1, &ray, &o), SC_ERR_INVALID_ARGUMENT);
    sc_hitrec h;
    assert_int_equal(sc_accel_closest(b, &ray, &h, NULL), SC_OK);
    assert_int_equal(h.inst, 0);
    ray.dir[0] = ray.dir[1] = ray.dir[2] = 0;
    assert_int_equal(sc_accel_closest(b, &ray, &h, NULL), SC_ERR_INVALID_ARGUMENT);
    /* an instanced scene changed: the top must be committed again */
    assert_int_equal(sc_accel_attach_mesh(a, &v, SC_ACCEL_SHARED, NULL), SC_OK);
    assert_int_equal(sc_accel_commit(b), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_accel_commit(a), SC_OK);
    assert_int_equal(sc_accel_commit(b), SC_OK);
    /* an empty scene: every ray misses */
    ray.dir[2] = -1;
    assert_int_equal(sc_accel_closest(b, &ray, &h, NULL), SC_OK);
    assert_int_equal(sc_accel_commit(c), SC_OK);
    assert_int_equal(sc_accel_closest(c, &ray, &h, NULL), SC_OK);
    assert_int_equal(h.prim, SC_HITREC_MISS);
    assert_int_equal(h.inst, SC_INVALID_ID);
    sc_accel_release(a);
    sc_accel_release(c);
    sc_accel_release(b);
    sc_accel_release(NULL);
    mesh_free(&tor);
}

/* ---- packets and streams through instances ------------------------------- */

/* Camera rays in 4x4 pixel tiles (16 consecutive rays, the packets and
 * the streams' coherent runs), then rays from make_rays (incoherent). */
static void packet_rays(sc_ray *rays, size_t ncam, size_t n, const float *aim, size_t naim)
{
    const float eye[3] = { 0.5f, 0.5f, 11 };
    const int side = 4 * (int)sqrt((double)ncam / 16);
    size_t r = 0;
    for (int ty = 0; ty < side; ty += 4)
        for (int tx = 0; tx < side; tx += 4)
            for (int j = 0; j < 16 && r < ncam; j++, r++) {
                /* the first half wide (the packet is wide next to each
                 * instance), the second narrow (a packet through them) */
                const float fov = r < ncam / 2 ? 0.9f : 0.06f;
                /* every other tile shifted by 2.5 pixels: the tiles in the
                 * middle column then straddle x = 0 (lanes in two octants),
                 * the others have a lane with d_x = 0 (parallel to an axis) */
                const float sh = (r / 16) % 2 ? 2.5f : 0.0f;
                const float px = ((float)(tx + j % 4) + sh) / (float)side - 0.5f,
                            py = (float)(ty + j / 4) / (float)side - 0.5f;
                sc_ray q = { { eye[0], eye[1], eye[2] }, 0, { fov * px, fov * py, -1 }, INFINITY };
                if (r % 23 == 5)
                    q.tmax = 10;   /* ends inside the scene */
                if (r % 29 == 7)
                    q.tmin = 9;
                rays[r] = q;
            }
    const float lo[3] = { -8, -8, -8 }, hi[3] = { 8, 8, 8 };
    make_rays(rays + r, n - r, lo, hi, aim, naim);
}

static void test_packets(void **state)
{
    (void)state;
    mesh tor, box, ground;
    const double o0[3] = { 0, 0, 0 };
    torus(&tor, 20, 10, o0, 1.0);
    grid_box(&box, 4, 0);
    grid_box(&ground, 8, 0);
    const size_t NCAM = 1024, N = 2048;
    sc_ray *rays = malloc(N * sizeof *rays);
    packet_rays(rays, NCAM, N, tor.pos, tor.nv);
    sc_hitrec *want = malloc(N * sizeof *want), *got = malloc(2 * N * sizeof *got);
    int32_t *want_occ = malloc(N * sizeof *want_occ), *got_occ = malloc(3 * N * sizeof *got_occ);
    const sc_isa start = sc_isa_active();
    for (int cfgi = 0; cfgi < 3; cfgi++) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.tri_test = cfgi == 1 ? SC_TRI_EXACT : SC_TRI_WATERTIGHT;
        cfg.prefilter = cfgi == 2 ? SC_PREFILTER_CIRCUM : cfgi == 1 ? SC_PREFILTER_COMPACT : SC_PREFILTER_OFF;
        sc_accel *obj, *world, *flat, *obj1, *world1;
        assert_int_equal(sc_accel_new(&cfg, &obj), SC_OK);
        const sc_mesh_view vt = { tor.pos, tor.nv, tor.idx, tor.nt, 0, 0 }, vb = { box.pos, box.nv, box.idx, box.nt, 0, 0 },
                           vg = { ground.pos, ground.nv, ground.idx, ground.nt, 0, 0 };
        assert_int_equal(sc_accel_attach_mesh(obj, &vt, SC_ACCEL_COPY, NULL), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(obj, &vb, SC_ACCEL_COPY, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(obj), SC_OK);
        assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
        /* the same instances of a BVH of one mesh (the torus): its packets'
         * hits merge in vectors (top_pk_merge), not lane by lane */
        assert_int_equal(sc_accel_new(&cfg, &obj1), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(obj1, &vt, SC_ACCEL_COPY, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(obj1), SC_OK);
        assert_int_equal(sc_accel_new(&cfg, &world1), SC_OK);
        float x0[12];
        for (int i = 0; i < NINST; i++) {
            float x[12];
            if (i % 4 == 2)
                aligned_xfm(x, rnd_in(0.3, 2), i % 8 == 2, 6);
            else
                random_xfm(x, rnd_in(0.3, 2), i % 3 ? 1 : 3, i % 4 == 1, 6);
            if (i == 0)
                x[3] = x[7] = 0, memcpy(x0, x, sizeof x);   /* in front of the camera */
            assert_int_equal(sc_accel_attach_instance(world, obj, x, NULL), SC_OK);
            assert_int_equal(sc_accel_attach_instance(world1, obj1, x, NULL), SC_OK);
        }
        /* two more copies of instance 0: every hit on it is a three-way
         * tie at equal t, which instance 0 wins whatever the order of visits */
        for (int i = 0; i < 2; i++) {
            assert_int_equal(sc_accel_attach_instance(world, obj, x0, NULL), SC_OK);
            assert_int_equal(sc_accel_attach_instance(world1, obj1, x0, NULL), SC_OK);
        }
        assert_int_equal(sc_accel_attach_mesh(world, &vg, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(world), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(world1, &vg, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(world1), SC_OK);
        /* a scene without instances, of two meshes: the packet kernels with ids mapped */
        assert_int_equal(sc_accel_new(&cfg, &flat), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(flat, &vg, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(flat, &vt, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(flat), SC_OK);
        sc_accel *scenes[3] = { world, flat, world1 };
        for (int sc = 0; sc < 3; sc++) {
            const sc_accel *a = scenes[sc];
            size_t hits = 0, inst_hits = 0, ties = 0;
            for (size_t r = 0; r < N; r++) {
                int o;
                assert_int_equal(sc_accel_closest(a, &rays[r], &want[r], NULL), SC_OK);
                assert_int_equal(sc_accel_any(a, &rays[r], &o, NULL), SC_OK);
                want_occ[r] = o;
                hits += want[r].prim != SC_HITREC_MISS;
                inst_hits += want[r].inst != SC_INVALID_ID;
                ties += want[r].inst == 0;
                if (!(want[r].inst == SC_INVALID_ID || want[r].inst < NINST))
                    fail_msg("cfg %d ray %zu: inst %u t %a prim %u", cfgi, r, want[r].inst, want[r].t, want[r].prim);
            }
            print_message("cfg %d scene %d: %zu of %zu rays hit, %zu through instances, %zu on the three coincident\n",
                          cfgi, sc, hits, N, inst_hits, ties);
            if (sc != 1)
                assert_true(ties > N / 64);
            assert_true(hits > (sc == 1 ? N / 16 : N / 4));
            if (sc != 1)
                assert_true(inst_hits > N / 4);
            for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
                if (!sc_isa_supported((sc_isa)isa))
                    continue;
                assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
                /* packets of 16 and 8; in every third packet some lanes
                 * invalid, holding NaN (never read) */
                for (size_t base = 0; base + 16 <= N; base += 16) {
                    sc_ray_packet16 p16;
                    sc_ray_packet8 p8[2];
                    int32_t valid[16];
                    for (unsigned i = 0; i < 16; i++) {
                        const sc_ray *q = &rays[base + i];
                        valid[i] = (base / 16) % 3 != 1 || (i * 7 + base / 16) % 5 != 0;
                        const float f[8] = { q->org[0], q->org[1], q->org[2], q->tmin,
                                             q->dir[0], q->dir[1], q->dir[2], q->tmax };
                        for (unsigned k = 0; k < 8; k++) {
                            const float v = valid[i] ? f[k] : NAN;
                            (&p16.ox[0])[16 * k + i] = v;
                            (&p8[i / 8].ox[0])[8 * k + i % 8] = v;
                        }
                    }
                    sc_hit_packet16 h16;
                    sc_hit_packet8 h8[2];
                    int32_t o16[16], o8[16];
                    sc_trace_stats ts;
                    memset(&ts, 0, sizeof ts);
                    assert_int_equal(sc_accel_closest16(a, valid, &p16, &h16, (base / 16) % 2 ? &ts : NULL), SC_OK);
                    assert_int_equal(sc_accel_any16(a, valid, &p16, o16, (base / 16) % 2 ? &ts : NULL), SC_OK);
                    for (unsigned h = 0; h < 2; h++) {
                        assert_int_equal(sc_accel_closest8(a, valid + 8 * h, &p8[h], &h8[h], NULL), SC_OK);
                        assert_int_equal(sc_accel_any8(a, valid + 8 * h, &p8[h], o8 + 8 * h, NULL), SC_OK);
                    }
                    unsigned nvalid = 0;
                    for (unsigned i = 0; i < 16; i++) {
                        if (!valid[i])
                            continue;
                        nvalid++;
                        const size_t r = base + i;
                        const sc_hitrec a16 = { h16.t[i], h16.u[i], h16.v[i], h16.prim[i],
                                                { h16.ng_x[i], h16.ng_y[i], h16.ng_z[i] }, h16.geom[i], h16.inst[i] };
                        const sc_hit_packet8 *e = &h8[i / 8];
                        const unsigned j = i % 8;
                        const sc_hitrec a8 = { e->t[j], e->u[j], e->v[j], e->prim[j],
                                               { e->ng_x[j], e->ng_y[j], e->ng_z[j] }, e->geom[j], e->inst[j] };
                        if (memcmp(&a16, &want[r], sizeof a16) || memcmp(&a8, &want[r], sizeof a8))
                            fail_msg("cfg %d scene %d %s ray %zu: packet (t %a prim %u geom %u inst %u) / (t %a prim %u) "
                                     "against single (t %a prim %u geom %u inst %u)", cfgi, sc,
                                     sc_isa_name((sc_isa)isa), r, a16.t, a16.prim, a16.geom, a16.inst, a8.t, a8.prim,
                                     want[r].t, want[r].prim, want[r].geom, want[r].inst);
                        assert_int_equal(o16[i], want_occ[r]);
                        assert_int_equal(o8[i], want_occ[r]);
                    }
                    if ((base / 16) % 2)
                        assert_int_equal(ts.rays, 2 * nvalid);
                }
                /* streams: strided, the camera tiles as packets and the rest one by one */
                const size_t hs = sizeof(sc_hitrec) * 2, os = 12;
                assert_int_equal(sc_accel_closest_n(a, rays, sizeof *rays, got, hs, N, 0, NULL), SC_OK);
                assert_int_equal(sc_accel_any_n(a, rays, sizeof *rays, got_occ, os, N, 0, NULL), SC_OK);
                for (size_t r = 0; r < N; r++) {
                    const sc_hitrec *g = (const sc_hitrec *)(const void *)((const char *)got + r * hs);
                    if (memcmp(g, &want[r], sizeof *g))
                        fail_msg("cfg %d scene %d %s stream ray %zu: t %a prim %u against t %a prim %u", cfgi, sc,
                                 sc_isa_name((sc_isa)isa), r, g->t, g->prim, want[r].t, want[r].prim);
                    assert_int_equal(*(const int32_t *)(const void *)((const char *)got_occ + r * os), want_occ[r]);
                }
                /* a refused ray in the stream: an error, its answer untouched
                 * (also in a scene of meshes, whose hits' ids are mapped
                 * after the BVH's stream), the others answered as before */
                const sc_ray keep = rays[N / 2 + 3];
                rays[N / 2 + 3].dir[2] = NAN;
                memset(got, 0x5a, 2 * N * sizeof *got);
                memset(got_occ, 0x5a, 3 * N * sizeof *got_occ);
                assert_int_equal(sc_accel_closest_n(a, rays, sizeof *rays, got, hs, N, 0, NULL),
                                 SC_ERR_INVALID_ARGUMENT);
                assert_int_equal(sc_accel_any_n(a, rays, sizeof *rays, got_occ, os, N, 0, NULL),
                                 SC_ERR_INVALID_ARGUMENT);
                rays[N / 2 + 3] = keep;
                for (size_t r = 0; r < N; r++) {
                    const sc_hitrec *g = (const sc_hitrec *)(const void *)((const char *)got + r * hs);
                    const int32_t o = *(const int32_t *)(const void *)((const char *)got_occ + r * os);
                    if (r == N / 2 + 3) {
                        assert_int_equal(g->prim, 0x5a5a5a5au);
                        assert_int_equal((uint32_t)o, 0x5a5a5a5au);
                    } else {
                        assert_memory_equal(g, &want[r], sizeof *g);
                        assert_int_equal(o, want_occ[r]);
                    }
                }
                /* single rays after 16 world rays of one octant (the object
                 * rays take the octant kernels) and after 16 of changing
                 * octants (the one-body kernels): the same answers */
                for (int hist = 0; hist < 2; hist++)
                    for (size_t r = 0; r < N; r += 5) {
                        for (unsigned w = 0; w < 16; w++) {
                            const sc_ray warm = sc_test_warm_ray(hist, w);
                            sc_hitrec wh;
                            assert_int_equal(sc_accel_closest(a, &warm, &wh, NULL), SC_OK);
                        }
                        sc_hitrec one;
                        assert_int_equal(sc_accel_closest(a, &rays[r], &one, NULL), SC_OK);
                        if (memcmp(&one, &want[r], sizeof one))
                            fail_msg("cfg %d scene %d %s ray %zu after %s rays: t %a prim %u inst %u against t %a "
                                     "prim %u inst %u", cfgi, sc, sc_isa_name((sc_isa)isa), r,
                                     hist ? "incoherent" : "coherent", one.t, one.prim, one.inst, want[r].t,
                                     want[r].prim, want[r].inst);
                    }
            }
            assert_int_equal(sc_isa_force(start), SC_OK);
        }
        /* no valid lane: nothing read (all NaN here), nothing written */
        {
            sc_ray_packet16 none;
            int32_t novalid[16] = { 0 }, occ_none[16];
            sc_hit_packet16 h_none;
            memset(&none, 0xff, sizeof none);
            memset(&h_none, 0x5a, sizeof h_none);
            memset(occ_none, 0x5a, sizeof occ_none);
            sc_hit_packet16 h_want;
            memcpy(&h_want, &h_none, sizeof h_want);
            for (int sc = 0; sc < 2; sc++) {
                assert_int_equal(sc_accel_closest16(scenes[sc], novalid, &none, &h_none, NULL), SC_OK);
                assert_int_equal(sc_accel_any16(scenes[sc], novalid, &none, occ_none, NULL), SC_OK);
                assert_memory_equal(&h_none, &h_want, sizeof h_want);
                for (int i = 0; i < 16; i++)
                    assert_int_equal(occ_none[i], 0x5a5a5a5a);
            }
        }
        /* refused: a misaligned packet, a valid lane with a bad ray, an uncommitted scene */
        _Alignas(64) unsigned char buf[sizeof(sc_ray_packet16) + 64];
        /* rows written as floats: no member of a misaligned packet is ever accessed */
        float rows[8 * 16];
        int32_t valid[16], occ[16];
        sc_hit_packet16 h16;
        for (unsigned i = 0; i < 16; i++) {
            valid[i] = 1;
            for (unsigned k = 0; k < 8; k++)
                rows[16 * k + i] = k == 6 || k == 7 ? 1.0f : 0.0f;
        }
        memcpy(buf + 4, rows, sizeof rows);
        assert_int_equal(sc_accel_closest16(world, valid, (const sc_ray_packet16 *)(const void *)(buf + 4), &h16, NULL),
                         SC_ERR_INVALID_ARGUMENT);
        sc_ray_packet16 good;
        memcpy(&good, rows, sizeof good);
        assert_int_equal(sc_accel_closest16(world, valid, &good, &h16, NULL), SC_OK);
        good.dx[3] = NAN;
        assert_int_equal(sc_accel_closest16(world, valid, &good, &h16, NULL), SC_ERR_INVALID_ARGUMENT);
        assert_int_equal(sc_accel_any16(world, valid, &good, occ, NULL), SC_ERR_INVALID_ARGUMENT);
        valid[3] = 0;
        assert_int_equal(sc_accel_any16(world, valid, &good, occ, NULL), SC_OK);
        sc_accel *fresh;
        assert_int_equal(sc_accel_new(&cfg, &fresh), SC_OK);
        assert_int_equal(sc_accel_any16(fresh, valid, &good, occ, NULL), SC_ERR_INVALID_ARGUMENT);
        assert_int_equal(sc_accel_commit(fresh), SC_OK);
        assert_int_equal(sc_accel_closest16(fresh, valid, &good, &h16, NULL), SC_OK);
        assert_int_equal(h16.prim[0], SC_HITREC_MISS);
        assert_true(h16.t[0] == 1.0f);
        sc_accel_release(fresh);
        sc_accel_release(world);
        sc_accel_release(flat);
        sc_accel_release(obj);
        sc_accel_release(world1);
        sc_accel_release(obj1);
    }
    free(rays), free(want), free(got), free(want_occ), free(got_occ);
    mesh_free(&tor), mesh_free(&box), mesh_free(&ground);
}

/* An any-hit ray first tries the instance that last occluded one on its
 * thread (traverse_top_bvh8.h), single rays and packets; the answers must
 * not depend on that. A unit quad instanced 64 times at z = 1 (an 8 x 8
 * grid, 2 apart, gaps between; instance 41 over [2, 3] x [10, 11]), once
 * more at z = 5 over instance 41 (instance 64), and once scaled over
 * [-4, 8]^2 at z = 3 (65); rays go up from z = 0, so every answer is known
 * from the geometry. After rays blocked by 41 and 64, a ray they block
 * visits fewer nodes than after rays blocked by instance 7 (the
 * remembered one is tried first: one top node, its box's), and each case
 * runs with it tried first: a gap (65 blocks, or nothing), 41 beyond tmax,
 * 41 before tmin (64 blocks), both before tmin, pointing away, another
 * instance; as single rays and in packets of 16 (one narrow enough to walk
 * the top tree together, whose lanes 41 alone or 64 alone blocks, one
 * not). Then a scene of 2 instances, perhaps at the same address: a
 * remembered index of 7 or more is out of its range and must not be read
 * (AddressSanitizer would see it). On every level. */
static sc_ray up(double x, double y, float tmin, float tmax, float dz)
{
    return (sc_ray){ { (float)x, (float)y, 0 }, tmin, { 0, 0, dz }, tmax };
}

static void warm(const sc_accel *a, double x, double y)
{
    for (int w = 0; w < 24; w++) {
        const sc_ray r = up(x + 0.01 * w, y, 0, INFINITY, 1);
        int occ = -1;
        assert_int_equal(sc_accel_any(a, &r, &occ, NULL), SC_OK);
        assert_int_equal(occ, 1);
    }
}

static void test_occluder_memory(void **state)
{
    (void)state;
    const float quad_pos[12] = { 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0 };
    const uint32_t quad_idx[6] = { 0, 1, 2, 0, 2, 3 };
    const sc_mesh_view quad = { quad_pos, 4, quad_idx, 2, 0, 0 };
    const struct {
        sc_ray ray;
        int blocked;
    } cases[] = {
        { up(1.5, 1.5, 0, INFINITY, 1), 1 },     /* a gap under the large quad */
        { up(9.5, 10.5, 0, INFINITY, 1), 0 },    /* a gap beside it */
        { up(2.5, 10.5, 0, 0.5f, 1), 0 },        /* 41 beyond tmax */
        { up(2.5, 10.5, 1.5f, INFINITY, 1), 1 }, /* 41 before tmin: 64 */
        { up(2.5, 10.5, 5.5f, INFINITY, 1), 0 }, /* both before tmin */
        { up(14.5, 0.5, 0, INFINITY, 1), 1 },    /* instance 7 */
        { up(2.5, 10.5, 0, INFINITY, -1), 0 },   /* away */
    };
    const size_t ncases = sizeof cases / sizeof cases[0];
    /* 16 lanes within 1.1 of each other (narrow), tilted off the axes
     * (a lane parallel to one goes alone), then 16 of the cases. Lanes
     * whose tmin and tmax let 41 and 64 block them, 64 only, 41 only, or
     * neither: whichever is remembered, some lanes need the walk. */
    sc_ray narrow[16], wide[16];
    int32_t narrow_want[16], wide_want[16];
    for (int l = 0; l < 16; l++) {
        const float tmin[4] = { 0, 1.5f, 0, 0 }, tmax[4] = { INFINITY, INFINITY, 3, 0.5f };
        narrow[l] = up(1.86 + 0.07 * l, 10.2 + 0.03 * l, tmin[l % 4], tmax[l % 4], 1);
        narrow[l].dir[0] = 0.01f, narrow[l].dir[1] = 0.013f;
        narrow_want[l] = 0;
        for (int z = 1; z <= 5; z += 4) {   /* 41 at z = 1, 64 at z = 5, both over [2, 3] x [10, 11] */
            const double x = narrow[l].org[0] + z * (double)narrow[l].dir[0];
            const double y = narrow[l].org[1] + z * (double)narrow[l].dir[1];
            assert_true(fabs(x - 2) > 1e-3 && fabs(x - 3) > 1e-3 && fabs(y - 10) > 1e-3 && fabs(y - 11) > 1e-3);
            if (x > 2 && x < 3 && y > 10 && y < 11 && z >= narrow[l].tmin && z <= narrow[l].tmax)
                narrow_want[l] = 1;
        }
        wide[l] = cases[l % ncases].ray;
        wide_want[l] = cases[l % ncases].blocked;
    }
    const sc_isa start = sc_isa_active();
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        sc_accel *obj, *world;
        assert_int_equal(sc_accel_new(&cfg, &obj), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(obj, &quad, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(obj), SC_OK);
        assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
        for (int i = 0; i < 64; i++) {
            const float x[12] = { 1, 0, 0, (float)(2 * (i % 8)), 0, 1, 0, (float)(2 * (i / 8)), 0, 0, 1, 1 };
            assert_int_equal(sc_accel_attach_instance(world, obj, x, NULL), SC_OK);
        }
        const float above41[12] = { 1, 0, 0, 2, 0, 1, 0, 10, 0, 0, 1, 5 };
        const float big[12] = { 12, 0, 0, -4, 0, 12, 0, -4, 0, 0, 1, 3 };
        assert_int_equal(sc_accel_attach_instance(world, obj, above41, NULL), SC_OK);
        assert_int_equal(sc_accel_attach_instance(world, obj, big, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(world), SC_OK);

        /* tried first: fewer nodes, single rays and a packet */
        const sc_ray r41 = up(2.5, 10.5, 0, INFINITY, 1);
        sc_ray_packet16 p16;
        int32_t valid[16], o16[16];
        sc_ray all41[16];
        for (int l = 0; l < 16; l++) {
            all41[l] = up(2.1 + 0.05 * l, 10.5, 0, INFINITY, 1);
            all41[l].dir[0] = 0.01f, all41[l].dir[1] = 0.013f;
        }
        pack_rays(all41, &p16, NULL, valid);
        sc_trace_stats cold = { 0 }, hot = { 0 }, pcold = { 0 }, phot = { 0 };
        int occ = -1;
        warm(world, 14.3, 0.5);
        assert_int_equal(sc_accel_any(world, &r41, &occ, &cold), SC_OK);
        assert_int_equal(occ, 1);
        warm(world, 14.3, 0.5);
        assert_int_equal(sc_accel_any16(world, valid, &p16, o16, &pcold), SC_OK);
        warm(world, 2.3, 10.5);
        assert_int_equal(sc_accel_any(world, &r41, &occ, &hot), SC_OK);
        assert_int_equal(occ, 1);
        warm(world, 2.3, 10.5);
        assert_int_equal(sc_accel_any16(world, valid, &p16, o16, &phot), SC_OK);
        for (int l = 0; l < 16; l++)
            assert_int_equal(o16[l], 1);
        assert_true(hot.nodes < cold.nodes);
        assert_true(phot.nodes < pcold.nodes);

        for (size_t k = 0; k < ncases; k++) {
            for (int c = 0; c < 2; c++) {
                warm(world, 2.3, 10.5);
                assert_int_equal(sc_accel_any(world, &cases[k].ray, &occ, c ? &hot : NULL), SC_OK);
                if (occ != cases[k].blocked)
                    print_message("%s: case %zu occluded %d\n", sc_isa_name((sc_isa)isa), k, occ);
                assert_int_equal(occ, cases[k].blocked);
            }
        }
        for (int c = 0; c < 2; c++) {
            const sc_ray *set = c ? wide : narrow;
            const int32_t *want = c ? wide_want : narrow_want;
            pack_rays(set, &p16, NULL, valid);
            warm(world, 2.3, 10.5);
            assert_int_equal(sc_accel_any16(world, valid, &p16, o16, NULL), SC_OK);
            for (int l = 0; l < 16; l++) {
                if (o16[l] != want[l])
                    print_message("%s: %s packet lane %d occluded %d\n", sc_isa_name((sc_isa)isa),
                                  c ? "wide" : "narrow", l, o16[l]);
                assert_int_equal(o16[l], want[l]);
                warm(world, 2.3, 10.5);
                assert_int_equal(sc_accel_any(world, &set[l], &occ, NULL), SC_OK);
                assert_int_equal(occ, want[l]);
            }
        }
        sc_accel_release(world);

        /* two instances: the remembered index is out of range */
        assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
        const float x0[12] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1 };
        assert_int_equal(sc_accel_attach_instance(world, obj, x0, NULL), SC_OK);
        assert_int_equal(sc_accel_attach_instance(world, obj, above41, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(world), SC_OK);
        const sc_ray r1 = up(2.5, 10.5, 0, 4, 1), r2 = up(2.5, 10.5, 0, INFINITY, 1);
        assert_int_equal(sc_accel_any(world, &r1, &occ, NULL), SC_OK);
        assert_int_equal(occ, 0);
        assert_int_equal(sc_accel_any(world, &r2, &occ, NULL), SC_OK);
        assert_int_equal(occ, 1);
        sc_accel_release(world);
        sc_accel_release(obj);
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
}

/* The same on rays where a float triangle test is least sure: instances
 * of a torus, rays aimed at its vertices, ending or starting at (and one
 * float either side of) the closest hit's t. Each variant is traced right
 * after its full ray has been traced until the instance that blocks it is
 * remembered and tried first, then again with the memory on another scene
 * (not tried): the two answers must be the same, for each triangle test.
 * The remembered instance is tried only where the ray passes its box, so
 * the walk would have reached it; without that test a float test's hit a
 * little outside a triangle, in an instance the walk culls, could differ
 * (as it did for a leaf memory in the BVH walk, docs/compare.md). */
static void test_occluder_memory_random(void **state)
{
    (void)state;
    mesh tor;
    const double o0[3] = { 0, 0, 0 };
    torus(&tor, 24, 12, o0, 1.0);
    const sc_mesh_view vt = { tor.pos, tor.nv, tor.idx, tor.nt, 0, 0 };
    const float quad_pos[12] = { -9, -9, 0, 9, -9, 0, 9, 9, 0, -9, 9, 0 };
    const uint32_t quad_idx[6] = { 0, 1, 2, 0, 2, 3 };
    const sc_mesh_view quad = { quad_pos, 4, quad_idx, 2, 0, 0 };
    const sc_ray to_quad = { { 0, 0, -1 }, 0, { 0.01f, 0.013f, 1 }, INFINITY };
    size_t variants = 0;
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.tri_test = (sc_tri_test)tt;
        sc_accel *obj, *world, *other;
        assert_int_equal(sc_accel_new(&cfg, &obj), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(obj, &vt, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(obj), SC_OK);
        assert_int_equal(sc_accel_new(&cfg, &world), SC_OK);
        enum { NI = 8 };
        float x[NI][12];
        for (int i = 0; i < NI; i++) {
            random_xfm(x[i], rnd_in(0.5, 1.5), 1, i % 2, 2);
            assert_int_equal(sc_accel_attach_instance(world, obj, x[i], NULL), SC_OK);
        }
        assert_int_equal(sc_accel_commit(world), SC_OK);
        assert_int_equal(sc_accel_new(&cfg, &other), SC_OK);
        assert_int_equal(sc_accel_attach_instance(other, obj, x[0], NULL), SC_OK);
        assert_int_equal(sc_accel_attach_mesh(other, &quad, SC_ACCEL_SHARED, NULL), SC_OK);
        assert_int_equal(sc_accel_commit(other), SC_OK);
        float *aim = world_vertices(&tor, x, NI);
        const float lo[3] = { -6, -6, -6 }, hi[3] = { 6, 6, 6 };
        const size_t n = 1500;
        sc_ray *rays = malloc(n * sizeof *rays);
        make_rays(rays, n, lo, hi, aim, (size_t)tor.nv * NI);
        for (size_t i = 0; i < n; i++) {
            sc_ray r = rays[i];
            r.tmax = INFINITY;
            sc_hitrec h;
            assert_int_equal(sc_accel_closest(world, &r, &h, NULL), SC_OK);
            if (h.prim == SC_HITREC_MISS)
                continue;
            const float t = h.t;
            const float ends[5][2] = { { 0, nextafterf(t, 0) }, { 0, t }, { 0, nextafterf(t, INFINITY) },
                                       { t, INFINITY }, { nextafterf(t, INFINITY), INFINITY } };
            for (int v = 0; v < 5; v++) {
                sc_ray q = r;
                q.tmin = ends[v][0], q.tmax = ends[v][1];
                int occ = -1, warm = -1, cold = -1;
                for (int w = 0; w < 12; w++) {
                    assert_int_equal(sc_accel_any(world, &r, &occ, NULL), SC_OK);
                    assert_int_equal(occ, 1);
                }
                assert_int_equal(sc_accel_any(world, &q, &warm, NULL), SC_OK);
                assert_int_equal(sc_accel_any(other, &to_quad, &occ, NULL), SC_OK);
                assert_int_equal(occ, 1);
                assert_int_equal(sc_accel_any(world, &q, &cold, NULL), SC_OK);
                if (warm != cold)
                    print_message("%s ray %zu variant %d: %d with the memory, %d without\n",
                                  sc_tri_test_name((sc_tri_test)tt), i, v, warm, cold);
                assert_int_equal(warm, cold);
                variants++;
            }
        }
        free(rays), free(aim);
        sc_accel_release(other);
        sc_accel_release(world);
        sc_accel_release(obj);
    }
    print_message("%zu variants\n", variants);
    assert_true(variants > 1000);
    mesh_free(&tor);
}

int main(void)
{
    (void)each_shared_scene;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_meshes),
        cmocka_unit_test(test_instances),
        cmocka_unit_test(test_no_holes),
        cmocka_unit_test(test_packets),
        cmocka_unit_test(test_growth),
        cmocka_unit_test(test_object_ray_bounds),
        cmocka_unit_test(test_refused_object_rays),
        cmocka_unit_test(test_refit),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_occluder_memory),
        cmocka_unit_test(test_occluder_memory_random),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

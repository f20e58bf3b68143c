/* Packets (sc_trace_closest8/16, sc_trace_any8/16) against the single-ray
 * calls: every valid lane must return the single ray's hit bit for bit
 * (t, u, v, prim) and the same occlusion, on every ISA level, prefilter
 * mode, leaf size and triangle test, and invalid lanes must stay untouched.
 *
 * The packets are the hard cases for a packet tracer and for the
 * circumsphere cone culling (which only runs on packets with one origin):
 *   camera    one origin, a 4x4 (2x4) tile of directions around a target,
 *             pixel sizes from 1e-5 to 1e-1 of the scene;
 *   edges     one origin, every ray aimed at a vertex, an edge point or just
 *             outside an edge of one triangle: grazing a narrow cone's
 *             spheres exactly where the triangles meet;
 *   far       a camera packet from 1e4 scene sizes away;
 *   wide      one origin, directions over the whole sphere (no cone);
 *   shadow    origins on the surface, all aimed at one light point;
 *   mixed     unrelated rays (mixed octants and shear axes), random tmin,
 *             tmax, and random valid masks.
 * The single-ray answers are themselves checked against an exact oracle by
 * test_bvh.c; here the claim is identity. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include "bvh_test_util.h"
#include "sc_ftz.h"
#include "sc_test_warm.h"
#include "bvh/bvh_internal.h"
#include "isa/isa_dispatch.h"
#include "trace/stream_gather.h"
#include "trace/tri_exact.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_trace.h"

#define NPACK 600   /* packets per kind and scene */

enum { K_CAMERA, K_EDGES, K_FAR, K_WIDE, K_SHADOW, K_MIXED, K_COUNT };
static const char *kind_name[K_COUNT] = { "camera", "edges", "far", "wide", "shadow", "mixed" };

typedef struct packets {
    sc_ray *rays;         /* NPACK * 16 per kind */
    int32_t *valid;
    size_t n;             /* rays */
} packets;

static void packets_free(packets *p)
{
    free(p->rays), free(p->valid);
}

static void bounds(const tmesh *m, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
    for (size_t i = 0; i < m->nv; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], m->pos[3 * i + k]);
            hi[k] = fmax(hi[k], m->pos[3 * i + k]);
        }
}

static void vtx(const tmesh *m, size_t t, int j, double p[3])
{
    for (int k = 0; k < 3; k++)
        p[k] = m->pos[3 * m->idx[3 * t + j] + k];
}

static void set_ray(sc_ray *r, const double o[3], const double d[3], float tmin, float tmax)
{
    for (int k = 0; k < 3; k++)
        r->org[k] = (float)o[k], r->dir[k] = (float)d[k];
    if (r->dir[0] == 0 && r->dir[1] == 0 && r->dir[2] == 0)
        r->dir[2] = 1;
    r->tmin = tmin, r->tmax = tmax;
}

/* A point of triangle t, or just outside it (out > 0). */
static void tri_point(const tmesh *m, size_t t, double a, double b, double p[3])
{
    double v0[3], v1[3], v2[3];
    vtx(m, t, 0, v0), vtx(m, t, 1, v1), vtx(m, t, 2, v2);
    for (int k = 0; k < 3; k++)
        p[k] = v0[k] + a * (v1[k] - v0[k]) + b * (v2[k] - v0[k]);
}

static void make_packets(const tmesh *m, int kind, uint64_t seed, packets *out)
{
    double lo[3], hi[3], c[3], ext = 0;
    bounds(m, lo, hi);
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (lo[k] + hi[k]), ext = fmax(ext, hi[k] - lo[k]);
    sc_rng r;
    sc_rng_seed(&r, seed);
    out->n = (size_t)NPACK * 16;
    out->rays = malloc(out->n * sizeof(sc_ray));
    out->valid = malloc(out->n * sizeof(int32_t));
    for (size_t p = 0; p < NPACK; p++) {
        sc_ray *pr = &out->rays[16 * p];
        double o[3], tgt[3], d[3];
        size_t t = (size_t)(sc_rng_uniform(&r) * (double)m->nt);
        double dist = kind == K_FAR ? 1e4 * ext : sc_rng_range(&r, 0.6, 3) * ext;
        double z = sc_rng_range(&r, -1, 1), ph = sc_rng_range(&r, 0, 6.283185307179586), s = sqrt(1 - z * z);
        tri_point(m, t, 0.3, 0.3, tgt);
        for (int k = 0; k < 3; k++)
            o[k] = tgt[k] + dist * (k == 0 ? s * cos(ph) : k == 1 ? s * sin(ph) : z);
        /* tile axes perpendicular to the view direction */
        double f[3] = { tgt[0] - o[0], tgt[1] - o[1], tgt[2] - o[2] }, up[3] = { 0, 0, 1 }, ux[3], uy[3];
        if (fabs(f[2]) > 0.9 * sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]))
            up[0] = 1, up[2] = 0;
        ux[0] = f[1] * up[2] - f[2] * up[1], ux[1] = f[2] * up[0] - f[0] * up[2], ux[2] = f[0] * up[1] - f[1] * up[0];
        uy[0] = f[1] * ux[2] - f[2] * ux[1], uy[1] = f[2] * ux[0] - f[0] * ux[2], uy[2] = f[0] * ux[1] - f[1] * ux[0];
        double lx = sqrt(ux[0] * ux[0] + ux[1] * ux[1] + ux[2] * ux[2]),
               ly = sqrt(uy[0] * uy[0] + uy[1] * uy[1] + uy[2] * uy[2]);
        double pix = ext * exp(sc_rng_range(&r, log(1e-5), log(1e-1)));
        double light[3];
        for (int k = 0; k < 3; k++)
            light[k] = c[k] + sc_rng_range(&r, -2, 2) * ext;
        for (int i = 0; i < 16; i++) {
            sc_ray *ray = &pr[i];
            switch (kind) {
            case K_CAMERA:
            case K_FAR:
                for (int k = 0; k < 3; k++)
                    d[k] = f[k] + pix * ((i % 4 - 1.5) * ux[k] / lx + (i / 4 - 1.5) * uy[k] / ly);
                set_ray(ray, o, d, 0, INFINITY);
                break;
            case K_EDGES: {
                /* vertices, edge points and just outside the edges */
                static const double ab[16][2] = { { 0, 0 }, { 1, 0 }, { 0, 1 }, { 0.5, 0 }, { 0, 0.5 },
                                                  { 0.5, 0.5 }, { 1.0 / 3, 1.0 / 3 }, { 0.25, 0 },
                                                  { -1e-7, 0.5 }, { 0.5, -1e-7 }, { 0.5000001, 0.5 },
                                                  { 1.0000001, 0 }, { 0, 1.0000001 }, { -1e-7, -1e-7 },
                                                  { 0.7, 0.3 }, { 0.3, 0.7 } };
                tri_point(m, t, ab[i][0], ab[i][1], tgt);
                for (int k = 0; k < 3; k++)
                    d[k] = tgt[k] - o[k];
                set_ray(ray, o, d, 0, INFINITY);
                break;
            }
            case K_WIDE: {
                double zz = sc_rng_range(&r, -1, 1), pp = sc_rng_range(&r, 0, 6.283185307179586),
                       ss = sqrt(1 - zz * zz);
                d[0] = ss * cos(pp), d[1] = ss * sin(pp), d[2] = zz;
                set_ray(ray, c, d, 0, INFINITY);
                break;
            }
            case K_SHADOW: {
                size_t tt = (t + (size_t)i) % m->nt;
                double a = sc_rng_uniform(&r), b = sc_rng_uniform(&r);
                if (a + b > 1)
                    a = 1 - a, b = 1 - b;
                tri_point(m, tt, a, b, tgt);
                for (int k = 0; k < 3; k++)
                    d[k] = light[k] - tgt[k];
                set_ray(ray, tgt, d, 1e-4f, 1.0f);
                break;
            }
            default: {
                double zz = sc_rng_range(&r, -1, 1), pp = sc_rng_range(&r, 0, 6.283185307179586),
                       ss = sqrt(1 - zz * zz);
                for (int k = 0; k < 3; k++)
                    o[k] = c[k] + sc_rng_range(&r, -1, 1) * ext;
                if (i % 2) {
                    size_t tt = (size_t)(sc_rng_uniform(&r) * (double)m->nt);
                    tri_point(m, tt, 0.2, 0.3, tgt);
                    for (int k = 0; k < 3; k++)
                        d[k] = tgt[k] - o[k];
                } else {
                    d[0] = ss * cos(pp), d[1] = ss * sin(pp), d[2] = zz;
                }
                float tmin = i % 3 == 0 ? (float)sc_rng_range(&r, 0, 0.8) : 0;
                float tmax = i % 5 == 0 ? (float)sc_rng_range(&r, 0.2, 1.5) : INFINITY;
                if (i == 7)                      /* a parallel ray: traced singly inside the packet */
                    d[0] = 0;
                set_ray(ray, o, d, tmin, tmax);
            }
            }
            out->valid[16 * p + (size_t)i] = kind == K_MIXED ? sc_rng_uniform(&r) < 0.7 : 1;
        }
    }
}

static void to_packet16(const sc_ray *r, sc_ray_packet16 *p)
{
    for (int i = 0; i < 16; i++) {
        p->ox[i] = r[i].org[0], p->oy[i] = r[i].org[1], p->oz[i] = r[i].org[2], p->tmin[i] = r[i].tmin;
        p->dx[i] = r[i].dir[0], p->dy[i] = r[i].dir[1], p->dz[i] = r[i].dir[2], p->tmax[i] = r[i].tmax;
    }
}

static void to_packet8(const sc_ray *r, sc_ray_packet8 *p)
{
    for (int i = 0; i < 8; i++) {
        p->ox[i] = r[i].org[0], p->oy[i] = r[i].org[1], p->oz[i] = r[i].org[2], p->tmin[i] = r[i].tmin;
        p->dx[i] = r[i].dir[0], p->dy[i] = r[i].dir[1], p->dz[i] = r[i].dir[2], p->tmax[i] = r[i].tmax;
    }
}

static int same_bits(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

/* Lane i of a hit packet of width W (8 or 16) holds, bit for bit, the
 * single-ray record: t, u, v, prim, the normal, geometry and instance. */
#define SAME_LANE(hp, i, ref)                                                                        \
    ((hp)->prim[i] == (ref).prim && same_bits((hp)->t[i], (ref).t) && same_bits((hp)->u[i], (ref).u) && \
     same_bits((hp)->v[i], (ref).v) && same_bits((hp)->ng_x[i], (ref).ng[0]) &&                     \
     same_bits((hp)->ng_y[i], (ref).ng[1]) && same_bits((hp)->ng_z[i], (ref).ng[2]) &&              \
     (hp)->geom[i] == (ref).geom && (hp)->inst[i] == (ref).inst)

/* Packets of 16 and of 8 (each 16 split in two) against single rays.
 * Returns the number of lanes that differ; adds the statistics. */
static size_t check(const sc_bvh *b, const packets *pk, sc_trace_stats *st)
{
    size_t bad = 0;
    sc_ray_packet16 *p16 = aligned_alloc(64, sizeof *p16);
    sc_ray_packet8 *p8 = aligned_alloc(64, sizeof *p8);
    sc_hit_packet16 *h16 = aligned_alloc(64, sizeof *h16);
    sc_hit_packet8 *h8 = aligned_alloc(32, sizeof *h8);     /* 288 bytes: a multiple of its alignment, 32 */
    for (size_t p = 0; p < pk->n / 16; p++) {
        const sc_ray *r = &pk->rays[16 * p];
        const int32_t *valid = &pk->valid[16 * p];
        sc_hitrec ref[16];
        int occ_ref[16];
        for (int i = 0; i < 16; i++) {
            assert_int_equal(sc_trace_closest(b, &r[i], &ref[i], NULL), SC_OK);
            assert_int_equal(sc_trace_any(b, &r[i], &occ_ref[i], NULL), SC_OK);
        }
        to_packet16(r, p16);
        memset(h16, 0x5a, sizeof *h16);
        assert_int_equal(sc_trace_closest16(b, valid, p16, h16, st), SC_OK);
        int32_t occ[16];
        memset(occ, 0x5a, sizeof occ);
        assert_int_equal(sc_trace_any16(b, valid, p16, occ, NULL), SC_OK);
        for (int i = 0; i < 16; i++) {
            if (!valid[i]) {
                bad += h16->prim[i] != 0x5a5a5a5au || occ[i] != 0x5a5a5a5a;
                continue;
            }
            int ok = SAME_LANE(h16, i, ref[i]) && occ[i] == occ_ref[i];
            if (!ok && bad < 5)
                print_message("lane %d: packet prim %u t %a occ %d, single prim %u t %a occ %d\n", i,
                              h16->prim[i], (double)h16->t[i], occ[i], ref[i].prim, (double)ref[i].t, occ_ref[i]);
            bad += !ok;
        }
        for (int half = 0; half < 2; half++) {
            to_packet8(r + 8 * half, p8);
            memset(h8, 0x5a, sizeof *h8);
            assert_int_equal(sc_trace_closest8(b, valid + 8 * half, p8, h8, NULL), SC_OK);
            memset(occ, 0x5a, sizeof occ);
            assert_int_equal(sc_trace_any8(b, valid + 8 * half, p8, occ, NULL), SC_OK);
            for (int i = 0; i < 8; i++) {
                int j = 8 * half + i;
                if (!valid[j]) {
                    bad += h8->prim[i] != 0x5a5a5a5au || occ[i] != 0x5a5a5a5a;
                    continue;
                }
                bad += !(SAME_LANE(h8, i, ref[j]) && occ[i] == occ_ref[j]);
            }
        }
    }
    free(p16), free(p8), free(h16), free(h8);
    return bad;
}

static sc_bvh *build(const tmesh *m, int leaf, sc_prefilter_mode mode, sc_tri_test tt)
{
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.leaf_size = leaf;
    cfg.prefilter = mode;
    cfg.tri_test = tt;
    sc_bvh *bvh = NULL;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ m->pos, m->nv, m->idx, m->nt, 0, 0 }, &cfg, &bvh), SC_OK);
    return bvh;
}

/* Every kind, ISA level, prefilter mode and leaf size, watertight test. */
static void run_scene(const char *name, const tmesh *m, const int *leaves, int nleaves)
{
    packets pk[K_COUNT];
    for (int k = 0; k < K_COUNT; k++)
        make_packets(m, k, 100 + (uint64_t)k, &pk[k]);
    uint64_t culled_camera = 0;
    const sc_isa start = sc_isa_active();
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        for (int li = 0; li < nleaves; li++)
            for (int mode = 0; mode < SC_PREFILTER_MODE_COUNT; mode++) {
                sc_bvh *b = build(m, leaves[li], (sc_prefilter_mode)mode, SC_TRI_WATERTIGHT);
                for (int k = 0; k < K_COUNT; k++) {
                    sc_trace_stats st;
                    memset(&st, 0, sizeof st);
                    size_t bad = check(b, &pk[k], &st);
                    if (bad)
                        print_message("%s %s leaf %d %s %s: %zu lanes differ\n", name, kind_name[k], leaves[li],
                                      sc_prefilter_mode_name((sc_prefilter_mode)mode), sc_isa_name((sc_isa)isa),
                                      bad);
                    assert_int_equal(bad, 0);
                    if (k == K_CAMERA && isa == SC_ISA_AVX512 && mode == SC_PREFILTER_CIRCUM)
                        culled_camera += st.sphere_rejects;
                }
                sc_bvh_free(b);
            }
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    /* the cone culls something on camera packets (else this test would not
     * exercise it) */
    if (sc_isa_supported(SC_ISA_AVX512))
        assert_true(culled_camera > 0);
    for (int k = 0; k < K_COUNT; k++)
        packets_free(&pk[k]);
}

static void test_icosphere(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0.1, -0.2, 0.3 };
    scene_icosphere(&m, 3, 1.0, c);
    const int leaves[] = { 1, 4, 8, 16 };
    run_scene("icosphere", &m, leaves, 4);
    tmesh_free(&m);
}

static void test_soup_slivers(void **state)
{
    (void)state;
    tmesh m = { 0 };
    scene_soup(&m, 1500, 0, 5);
    scene_slivers(&m, 800, 6);
    const int leaves[] = { 4, 16 };
    run_scene("soup", &m, leaves, 2);
    tmesh_free(&m);
}

/* The other triangle tests run lane by lane: still the single answers. */
static void test_other_tests(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 2, 1.0, c);
    packets pk;
    make_packets(&m, K_EDGES, 7, &pk);
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++) {
        sc_bvh *b = build(&m, 4, SC_PREFILTER_CIRCUM, (sc_tri_test)tt);
        assert_int_equal(check(b, &pk, NULL), 0);
        sc_bvh_free(b);
    }
    packets_free(&pk);
    tmesh_free(&m);
}

static void test_api(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 1, 1.0, c);
    sc_bvh *b = build(&m, 4, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT);
    unsigned char *mem = aligned_alloc(64, 4096);
    sc_ray_packet16 *p16 = (sc_ray_packet16 *)(void *)mem;
    sc_hit_packet16 *h16 = (sc_hit_packet16 *)(void *)(mem + 1024);
    memset(mem, 0, 4096);
    int32_t valid[16], occ[16];
    for (int i = 0; i < 16; i++) {
        valid[i] = -1;
        p16->oz[i] = -5, p16->dz[i] = 1, p16->tmax[i] = INFINITY;
    }
    assert_int_equal(sc_trace_closest16(b, valid, p16, h16, NULL), SC_OK);
    for (int i = 0; i < 16; i++)
        assert_true(h16->prim[i] != SC_HITREC_MISS);
    assert_int_equal(sc_trace_closest16(NULL, valid, p16, h16, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_closest16(b, NULL, p16, h16, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_any16(b, valid, p16, NULL, NULL), SC_ERR_INVALID_ARGUMENT);
    /* misaligned packets and hits */
    assert_int_equal(sc_trace_closest16(b, valid, (const sc_ray_packet16 *)(const void *)(mem + 32), h16, NULL),
                     SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_closest16(b, valid, p16, (sc_hit_packet16 *)(void *)(mem + 1024 + 32), NULL),
                     SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_closest8(b, valid, (const sc_ray_packet8 *)(const void *)(mem + 16),
                                       (sc_hit_packet8 *)(void *)(mem + 1024), NULL),
                     SC_ERR_INVALID_ARGUMENT);
    /* a refused ray in a valid lane: an error and nothing written */
    p16->dx[3] = NAN;
    memset(h16, 0x5a, sizeof *h16);
    assert_int_equal(sc_trace_closest16(b, valid, p16, h16, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(h16->prim[0], 0x5a5a5a5au);
    memset(occ, 0x5a, sizeof occ);
    assert_int_equal(sc_trace_any16(b, valid, p16, occ, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(occ[0], 0x5a5a5a5a);
    /* ... but in an invalid lane it is never read */
    valid[3] = 0;
    assert_int_equal(sc_trace_closest16(b, valid, p16, h16, NULL), SC_OK);
    assert_int_equal(h16->prim[3], 0x5a5a5a5au);
    assert_int_equal(sc_trace_any16(b, valid, p16, occ, NULL), SC_OK);
    assert_int_equal(occ[0], 1);
    assert_int_equal(occ[3], 0x5a5a5a5a);
    free(mem);
    sc_bvh_free(b);
    tmesh_free(&m);
}

/* The scalar specification's single-ray answers for n rays (closest hits
 * into ref; any-hit answers into ref_occ unless NULL), checking that the
 * set has both hits and misses. The caller has forced the scalar level. */
static void scalar_reference(const sc_bvh *bvh, const sc_ray *rays, size_t n, sc_hitrec *ref, int *ref_occ)
{
    size_t hits = 0;
    for (size_t i = 0; i < n; i++) {
        assert_int_equal(sc_trace_closest(bvh, &rays[i], &ref[i], NULL), SC_OK);
        if (ref_occ)
            assert_int_equal(sc_trace_any(bvh, &rays[i], &ref_occ[i], NULL), SC_OK);
        hits += ref[i].prim != SC_HITREC_MISS;
    }
    assert_true(hits > n / 8 && hits < n);      /* both answers occur */
}

/* Incoherent runs of a stream go one by one through sc_trace_closest's
 * kernel (which takes the one body after rays of changing octants) and
 * any_incoherent (no octant branch): on every ISA level and triangle test
 * they answer bit for bit as the scalar specification's single-ray kernel
 * does. */
static void test_streams_incoherent(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 3, 1.0, c);
    packets b;
    make_packets(&m, K_MIXED, 23, &b);
    const size_t n = b.n;
    sc_hitrec *ref = malloc(n * sizeof *ref), *h = malloc(n * sizeof *h);
    int *ref_occ = malloc(n * sizeof *ref_occ);
    int32_t *occ = malloc(n * sizeof *occ);
    const sc_isa start = sc_isa_active();
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++) {
        assert_int_equal(sc_isa_force(SC_ISA_SCALAR), SC_OK);
        sc_bvh *bvh = build(&m, 8, SC_PREFILTER_OFF, (sc_tri_test)tt);
        scalar_reference(bvh, b.rays, n, ref, ref_occ);
        for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
            if (!sc_isa_supported((sc_isa)isa))
                continue;
            assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
            /* the rays the stream cannot group one by one, and (as in a
             * tree larger than the caches) interleaved */
            for (int il = 0; il < 2; il++) {
                bvh->interleave = il;
                memset(h, 0x5a, n * sizeof *h);
                memset(occ, 0x5a, n * sizeof *occ);
                assert_int_equal(sc_trace_closest_n(bvh, b.rays, sizeof *b.rays, h, sizeof *h, n, 0, NULL), SC_OK);
                assert_int_equal(sc_trace_any_n(bvh, b.rays, sizeof *b.rays, occ, sizeof *occ, n, 0, NULL), SC_OK);
                size_t bad = 0;
                for (size_t i = 0; i < n; i++)
                    bad += memcmp(&h[i], &ref[i], sizeof ref[i]) != 0 || occ[i] != ref_occ[i];
                if (bad)
                    print_message("%s %s%s: %zu of %zu rays differ from the scalar kernel\n",
                                  sc_tri_test_name((sc_tri_test)tt), sc_isa_name((sc_isa)isa),
                                  il ? " interleaved" : "", bad, n);
                assert_int_equal(bad, 0);
            }
            bvh->interleave = 0;
            /* sc_trace_closest picks its kernel from the thread's recent
             * rays (traverse_adaptive): after 16 rays of one octant it
             * takes the octant kernels, after 16 whose octant changes
             * every time the one body; both must answer as the scalar
             * kernel does */
            for (int hist = 0; hist < 2; hist++)
                for (size_t i = 0; i < n; i++) {
                    for (unsigned w = 0; w < 16; w++) {
                        const sc_ray warm = sc_test_warm_ray(hist, w);
                        sc_hitrec wh;
                        assert_int_equal(sc_trace_closest(bvh, &warm, &wh, NULL), SC_OK);
                    }
                    sc_hitrec one;
                    assert_int_equal(sc_trace_closest(bvh, &b.rays[i], &one, NULL), SC_OK);
                    if (memcmp(&one, &ref[i], sizeof one))
                        fail_msg("%s %s ray %zu after %s rays: not the scalar kernel's answer",
                                 sc_tri_test_name((sc_tri_test)tt), sc_isa_name((sc_isa)isa), i,
                                 hist ? "incoherent" : "coherent");
                }
        }
        sc_bvh_free(bvh);
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    free(ref), free(h), free(ref_occ), free(occ);
    packets_free(&b);
    tmesh_free(&m);
}

/* Streams: byte strides, coherent runs (camera packets) and incoherent ones
 * (mixed) in one call, a tail shorter than 16, a refused ray: every other
 * ray still gets its single-ray answer. */
typedef struct padded_ray {
    sc_ray r;
    float pad[3];
} padded_ray;
typedef struct padded_hit {
    sc_hitrec h;
    int32_t occ, pad;
} padded_hit;

static void test_streams(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 3, 1.0, c);
    packets a, b;
    make_packets(&m, K_CAMERA, 21, &a);
    make_packets(&m, K_MIXED, 22, &b);
    const size_t n = a.n + b.n - 5;
    padded_ray *r = malloc(n * sizeof *r);
    padded_hit *h = malloc(n * sizeof *h);
    for (size_t i = 0; i < n; i++) {
        /* alternate 16 camera rays and 16 mixed ones */
        size_t blk = i / 16, j = (blk / 2) * 16 + i % 16;
        r[i].r = (blk & 1) ? b.rays[j % b.n] : a.rays[j % a.n];
    }
    sc_bvh *bvh = build(&m, 4, SC_PREFILTER_CIRCUM, SC_TRI_WATERTIGHT);
    sc_trace_stats st;
    memset(&st, 0, sizeof st);
    /* pass 0 with the incoherent rays interleaved (streams do that in trees
     * larger than the caches), 1 one by one with statistics, 2 one by one */
    for (int pass = 0; pass < 3; pass++) {
        bvh->interleave = pass == 0;
        memset(h, 0x5a, n * sizeof *h);
        assert_int_equal(sc_trace_closest_n(bvh, &r[0].r, sizeof *r, &h[0].h, sizeof *h, n,
                                            0, pass == 1 ? &st : NULL),
                         SC_OK);
        assert_int_equal(sc_trace_any_n(bvh, &r[0].r, sizeof *r, &h[0].occ, sizeof *h, n,
                                        0, pass == 1 ? &st : NULL),
                         SC_OK);
        size_t bad = 0;
        for (size_t i = 0; i < n; i++) {
            sc_hitrec ref;
            int occ;
            assert_int_equal(sc_trace_closest(bvh, &r[i].r, &ref, NULL), SC_OK);
            assert_int_equal(sc_trace_any(bvh, &r[i].r, &occ, NULL), SC_OK);
            bad += !(memcmp(&h[i].h, &ref, sizeof ref) == 0 && h[i].occ == occ);
        }
        assert_int_equal(bad, 0);
    }
    assert_int_equal(st.rays, 2 * n);      /* every ray counted once, closest and any */
    /* a refused ray: an error, no answer for it, the rest answered, by
     * the rays traced alone a run at a time and by the interleaved kernel */
    r[20].r.dir[1] = NAN;
    for (int il = 0; il < 2; il++) {
        bvh->interleave = il;
        memset(h, 0x5a, n * sizeof *h);
        assert_int_equal(sc_trace_closest_n(bvh, &r[0].r, sizeof *r, &h[0].h, sizeof *h, n, 0, NULL),
                         SC_ERR_INVALID_ARGUMENT);
        assert_int_equal(h[20].h.prim, 0x5a5a5a5au);
        assert_int_equal(sc_trace_any_n(bvh, &r[0].r, sizeof *r, &h[0].occ, sizeof *h, n, 0, NULL),
                         SC_ERR_INVALID_ARGUMENT);
        assert_int_equal((uint32_t)h[20].occ, 0x5a5a5a5au);
        for (size_t i = 0; i < n; i++) {
            sc_hitrec ref;
            int occ;
            if (i == 20)
                continue;
            assert_int_equal(sc_trace_closest(bvh, &r[i].r, &ref, NULL), SC_OK);
            assert_memory_equal(&h[i].h, &ref, sizeof ref);
            assert_int_equal(sc_trace_any(bvh, &r[i].r, &occ, NULL), SC_OK);
            assert_int_equal(h[i].occ, occ);
        }
    }
    assert_int_equal(sc_trace_closest_n(bvh, &r[0].r, 8, &h[0].h, sizeof *h, n, 0, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_trace_closest_n(bvh, &r[0].r, sizeof *r, &h[0].h, sizeof *h, n, 4, NULL),
                     SC_ERR_INVALID_ARGUMENT);
    sc_bvh_free(bvh);
    free(r), free(h);
    packets_free(&a), packets_free(&b);
    tmesh_free(&m);
}

/* Bounce runs: 16 rays from points close together on a sphere (inside and
 * outside, as a tile's bounces off a closed mesh), in directions spread over
 * the hemisphere of the normal. The gather calls them SC_GATHER_NEAR (near
 * origins, directions not narrow), and a closest-hit stream sends each such
 * run as a packet or one by one, whichever its thread has timed faster; its
 * first two such runs on a BVH and ISA level take one path each, and later
 * ones either, as the timings fall (sc_stream_run): whatever the timings,
 * on every ISA level, over calls that carry the history from one to the
 * next, every ray gets the single-ray kernel's answer. */
static void bounce_run(sc_ray *r, sc_rng *g, int inside)
{
    double p[3], len = 0;
    for (int k = 0; k < 3; k++)
        p[k] = sc_rng_range(g, -1, 1), len += p[k] * p[k];
    len = sqrt(len);
    for (int i = 0; i < 16; i++) {
        double o[3], n[3], d[3], dn = 0;
        for (int k = 0; k < 3; k++) {
            n[k] = (inside ? -1 : 1) * p[k] / len;
            o[k] = p[k] / len * (inside ? 0.999 : 1.001) + 0.01 * sc_rng_range(g, -1, 1);
            d[k] = sc_rng_range(g, -1, 1);
            dn += d[k] * n[k];
        }
        for (int k = 0; k < 3; k++)
            d[k] += (dn < 0 ? 2 * -dn : 0) * n[k] + 0.05 * n[k];   /* into the normal's hemisphere */
        set_ray(&r[i], o, d, 0, INFINITY);
    }
}

static void test_stream_bounces(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 3, 1.0, c);
    enum { RUNS = 96, N = 16 * RUNS };
    sc_ray *r = malloc(N * sizeof *r);
    sc_hitrec *ref = malloc(N * sizeof *ref), *h = malloc(N * sizeof *h);
    sc_rng g;
    sc_rng_seed(&g, 41);
    const float lo[3] = { -1, -1, -1 }, hi[3] = { 1, 1, 1 };
    size_t near = 0;
    for (int run = 0; run < RUNS; run++) {
        bounce_run(r + 16 * run, &g, run % 3 == 0);
        sc_ray_packet16 p __attribute__((aligned(64)));
        near += sc_stream_gather16_ref((const char *)(r + 16 * run), sizeof *r, lo, hi, &p) == SC_GATHER_NEAR;
    }
    assert_int_equal(near, RUNS);   /* every run is a bounce run */
    const sc_isa start = sc_isa_active();
    for (int tt = 0; tt < SC_TRI_TEST_COUNT; tt++) {
        assert_int_equal(sc_isa_force(SC_ISA_SCALAR), SC_OK);
        sc_bvh *bvh = build(&m, 8, SC_PREFILTER_OFF, (sc_tri_test)tt);
        scalar_reference(bvh, r, N, ref, NULL);
        for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
            if (!sc_isa_supported((sc_isa)isa))
                continue;
            assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
            /* whole, then in calls of 5 runs and a part, the history going on */
            for (int pass = 0; pass < 2; pass++) {
                memset(h, 0x5a, N * sizeof *h);
                const size_t step = pass ? 16 * 5 + 7 : N;
                for (size_t b = 0; b < N; b += step)
                    assert_int_equal(sc_trace_closest_n(bvh, r + b, sizeof *r, h + b, sizeof *h,
                                                        N - b < step ? N - b : step, 0, NULL),
                                     SC_OK);
                size_t bad = 0;
                for (size_t i = 0; i < N; i++)
                    bad += memcmp(&h[i], &ref[i], sizeof ref[i]) != 0;
                if (bad)
                    fail_msg("%s %s pass %d: %zu of %d bounce rays differ from the single-ray kernel",
                             sc_tri_test_name((sc_tri_test)tt), sc_isa_name((sc_isa)isa), pass, bad, N);
            }
        }
        sc_bvh_free(bvh);
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    free(r), free(ref), free(h);
    tmesh_free(&m);
}

/* Coherent any-hit streams go four 16-ray packets at a time through the
 * level's group kernel (any_stream64, traverse_group_any), which walks the
 * tree once for 64 rays. Shadow-like runs (origins within a small box that
 * straddles two closed spheres' surfaces, one light) in groups whose
 * packets share an octant, groups with a packet of another octant (it walks
 * alone), runs with a parallel lane, tmin 0 and 1e-4, and a tail that is
 * neither 64 nor 16 rays: on every ISA level, with and without statistics,
 * every ray gets the scalar single-ray kernel's answer. Called directly, the
 * group kernel answers the same and visits fewer nodes than its four
 * packets do one by one (the walk is shared). */
static void shadow_run(sc_ray *r, sc_rng *g, const double p[3], const double light_in[3], double w, int kind)
{
    double light[3] = { light_in[0], light_in[1], light_in[2] };
    if (kind == 1)       /* the light through the box's other side: another octant */
        for (int k = 0; k < 3; k++)
            light[k] = 2 * p[k] - light[k];
    if (kind == 2)
        light[0] = p[0];
    for (int i = 0; i < 16; i++) {
        double o[3], d[3];
        for (int k = 0; k < 3; k++) {
            o[k] = p[k] + w * sc_rng_range(g, -1, 1);
            d[k] = light[k] - o[k];
        }
        set_ray(&r[i], o, d, i % 3 ? 1e-4f : 0.0f, 1.0f);
        if (kind == 2 && i == 5)
            r[i].dir[0] = 0;   /* a parallel lane */
    }
}

static void test_stream_groups(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c0[3] = { 0, 0, 0 }, c1[3] = { 0.9, 0.7, -0.4 };
    scene_icosphere(&m, 4, 1.0, c0);
    scene_icosphere(&m, 3, 0.5, c1);
    enum { RUNS = 16 * 40 + 3 };
    const size_t n = 16 * RUNS - 5;
    sc_ray *r = malloc(16 * RUNS * sizeof *r);
    sc_rng g;
    sc_rng_seed(&g, 61);
    double ctr[3] = { 0, 0, 0 }, light[3] = { 0, 0, 0 }, w = 0;
    for (size_t run = 0; run < RUNS; run++) {
        /* four neighbouring tiles a group (one light, origins in four
         * boxes side by side); every fifth group has a packet of another
         * octant, every seventh run a parallel lane */
        if (run % 4 == 0) {
            for (int k = 0; k < 3; k++)
                ctr[k] = sc_rng_range(&g, -1.6, 1.6), light[k] = sc_rng_range(&g, -1, 1) * 6;
            w = sc_rng_range(&g, 0.002, 0.1);
        }
        const double q[3] = { ctr[0] + 2 * w * (double)(run % 2), ctr[1] + 2 * w * (double)(run / 2 % 2), ctr[2] };
        shadow_run(r + 16 * run, &g, q, light, w, run % 20 == 17 ? 1 : run % 7 == 3 ? 2 : 0);
    }
    int *ref = malloc(n * sizeof *ref);
    int32_t *occ = malloc(n * sizeof *occ);
    const sc_isa start = sc_isa_active();
    assert_int_equal(sc_isa_force(SC_ISA_SCALAR), SC_OK);
    sc_bvh *bvh = build(&m, 8, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT);
    size_t occluded = 0;
    for (size_t i = 0; i < n; i++) {
        assert_int_equal(sc_trace_any(bvh, &r[i], &ref[i], NULL), SC_OK);
        occluded += ref[i] != 0;
    }
    assert_true(occluded > n / 8 && occluded < n - n / 8);   /* both answers, often within a run */
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        const sc_trace_kernels *k = &sc_kernels_active()->trace[SC_TRI_WATERTIGHT];
        for (int stats = 0; stats < 2; stats++) {
            sc_trace_stats st;
            memset(&st, 0, sizeof st);
            memset(occ, 0x5a, n * sizeof *occ);
            assert_int_equal(sc_trace_any_n(bvh, r, sizeof *r, occ, sizeof *occ, n, 0, stats ? &st : NULL), SC_OK);
            size_t bad = 0;
            for (size_t i = 0; i < n; i++)
                bad += occ[i] != ref[i];
            if (bad)
                print_message("%s%s: %zu of %zu rays differ from the scalar kernel\n", sc_isa_name((sc_isa)isa),
                              stats ? " (statistics)" : "", bad, n);
            assert_int_equal(bad, 0);
            if (stats)
                assert_int_equal(st.rays, n);
        }
        if (!k->any_stream64)
            continue;
        int grouped = 0;
        /* the group kernel called directly on groups of the stream's
         * runs: the single rays' answers, and a shared walk on the
         * groups of one octant */
        for (size_t run = 0; run + 4 <= RUNS - 1; run += 4) {
            sc_ray_packet16 p[4] __attribute__((aligned(64)));
            const uint32_t lanes[4] = { 0xffff, 0xffff, 0xffff, 0xffff };
            int32_t o64[64];
            for (int j = 0; j < 4; j++)
                to_packet16(r + 16 * (run + (size_t)j), &p[j]);
            sc_trace_stats st, st4;
            memset(&st, 0, sizeof st), memset(&st4, 0, sizeof st4);
            k->any_stream64(bvh, p, lanes, o64, &st);
            for (int j = 0; j < 64; j++)
                if (o64[j] != ref[16 * run + (size_t)j])
                    fail_msg("%s group at run %zu, ray %d: %d, the single ray %d", sc_isa_name((sc_isa)isa), run,
                             j, o64[j], ref[16 * run + (size_t)j]);
            int32_t o16[16];
            for (int j = 0; j < 4; j++)
                assert_int_equal(sc_trace_any16(bvh, (const int32_t[16]){ 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1 },
                                                &p[j], o16, &st4),
                                 SC_OK);
            if (st.nodes < st4.nodes)
                grouped++;
        }
        /* most groups share their walk */
        if (grouped <= (RUNS / 4) / 2)
            fail_msg("%s: %d of %d groups visit fewer nodes than their packets", sc_isa_name((sc_isa)isa), grouped,
                     RUNS / 4);
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    sc_bvh_free(bvh);
    free(r), free(ref), free(occ);
    tmesh_free(&m);
}

/* Kinds of ray sc_ray_valid refuses, made from a valid ray (w: which
 * axis, for some kinds): those before BAD_ALWAYS in every MXCSR mode, the
 * subnormal ones only where DAZ reads them as 0. */
enum { BAD_NONE, BAD_ORG_NAN, BAD_ORG_FAR, BAD_ORG_INF, BAD_DIR_INF, BAD_DIR_NAN, BAD_DIR_ZERO, BAD_TMIN_NEG,
       BAD_TMIN_NAN, BAD_TMAX_NAN, BAD_ALWAYS, BAD_DIR_SUB = BAD_ALWAYS, BAD_TMIN_SUB, BAD_COUNT };

static void spoil_ray(sc_ray *r, int bad, unsigned w)
{
    switch (bad) {
    case BAD_ORG_NAN: r->org[1] = NAN; break;
    case BAD_ORG_FAR: r->org[2] = -1e18f; break;
    case BAD_ORG_INF: r->org[0] = INFINITY; break;
    case BAD_DIR_INF: r->dir[0] = INFINITY; break;
    case BAD_DIR_NAN: r->dir[2 - w % 3] = NAN; break;
    case BAD_DIR_ZERO: r->dir[0] = r->dir[1] = r->dir[2] = -0.0f; break;
    case BAD_TMIN_NEG: r->tmin = -0x1p-126f; break;   /* normal: DAZ reads a subnormal as 0 */
    case BAD_TMIN_NAN: r->tmin = NAN; break;
    case BAD_TMAX_NAN: r->tmax = NAN; break;
    case BAD_DIR_SUB: r->dir[0] = r->dir[1] = 0, r->dir[2] = 0x1p-140f; break;
    case BAD_TMIN_SUB: r->tmin = -0x1p-140f; break;
    default: break;
    }
}

/* The streams' gather of a 16-ray run (stream_gather.h): every ISA level's
 * must give the scalar specification's answer and rows bit for bit, on
 * camera and mixed runs at a byte stride and on runs with one refused ray
 * of each kind at each end and inside; and the specification must give the
 * answers worked out by hand for runs built to be coherent, incoherent or
 * refused. Streams built on it are checked end to end by test_streams. */
static void test_stream_gather(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 2, 1.0, c);
    const float lo[3] = { -1, -1, -1 }, hi[3] = { 1, 1, 1 };
    packets a, b;
    make_packets(&m, K_CAMERA, 31, &a);
    make_packets(&m, K_MIXED, 32, &b);
    padded_ray run[16];
    /* by hand: one ray 16 times is coherent; a refused ray wins over
     * anything; a run of opposite directions from the box's corners is not */
    sc_ray_packet16 ref __attribute__((aligned(64))), got __attribute__((aligned(64)));
    for (int i = 0; i < 16; i++)
        run[i].r = (sc_ray){ { 0.5f, 0.25f, -3 }, 0, { 0.1f, -0.2f, 1 }, INFINITY };
    assert_int_equal(sc_stream_gather16_ref((const char *)run, sizeof *run, lo, hi, &ref), SC_GATHER_COHERENT);
    assert_true(ref.ox[7] == 0.5f && ref.dz[15] == 1 && ref.tmax[3] == INFINITY);
    for (int i = 0; i < 16; i++)
        run[i].r = (sc_ray){ { i & 1 ? -1.0f : 1, 0, 0 }, 0, { i & 1 ? 1.0f : -1, (float)(i & 2), 1 }, 1 };
    assert_int_equal(sc_stream_gather16_ref((const char *)run, sizeof *run, lo, hi, &ref), SC_GATHER_INCOHERENT);
    run[9].r.tmin = -1;
    assert_int_equal(sc_stream_gather16_ref((const char *)run, sizeof *run, lo, hi, &ref), SC_GATHER_REFUSED);

    /* each kind of refused ray (sc_ray_valid) */
    const int where[3] = { 0, 6, 15 };
    const sc_isa start = sc_isa_active();
    size_t runs = 0;
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        const sc_kernels *k = sc_kernels_for((sc_isa)isa);
        if (!k)
            continue;
        for (size_t p = 0; p < NPACK; p++)
            for (int src = 0; src < 2; src++)
                for (int bad = 0; bad < BAD_ALWAYS; bad++)
                    for (int w = 0; w < (bad ? 3 : 1); w++) {
                        const packets *pk = src ? &b : &a;
                        for (int i = 0; i < 16; i++)
                            run[i].r = pk->rays[16 * p + (size_t)i];
                        spoil_ray(&run[where[w]].r, bad, (unsigned)w);
                        memset(&ref, 0x5a, sizeof ref), memset(&got, 0x5a, sizeof got);
                        const int want = sc_stream_gather16_ref((const char *)run, sizeof *run, lo, hi, &ref);
                        const int have = k->trace[0].stream_gather16((const char *)run, sizeof *run, lo, hi, &got);
                        if (want != have || (want != SC_GATHER_REFUSED && memcmp(&ref, &got, sizeof ref) != 0))
                            fail_msg("isa %s, %s run %zu, bad kind %d at %d: gather %d, specification %d",
                                     sc_isa_name((sc_isa)isa), src ? "mixed" : "camera", p, bad, where[w], have,
                                     want);
                        assert_int_equal(want == SC_GATHER_REFUSED, bad != BAD_NONE);
                        runs += want == SC_GATHER_COHERENT;
                    }
    }
    assert_true(runs > 0);   /* the camera runs are coherent */
    assert_int_equal(sc_isa_force(start), SC_OK);
    packets_free(&a), packets_free(&b);
    tmesh_free(&m);
}

/* The packet calls' argument check, each level's packet_valid kernel,
 * against sc_ray_valid lane by lane (sc_packet_valid_ref): every kind of
 * refused ray, in a valid and in an invalid lane, at the first, a middle
 * and the last lane of packets of 8 and 16, in both MXCSR modes. */
static void test_packet_valid(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 1, 1.0, c);
    packets a;
    make_packets(&m, K_MIXED, 33, &a);
    const unsigned csr = _mm_getcsr();
    float rows[8 * 16] __attribute__((aligned(64)));
    int32_t valid[16];
    size_t refused = 0, passed = 0;
    for (int ftz = 0; ftz < 2; ftz++) {
        _mm_setcsr(ftz ? csr | SC_MXCSR_FTZ | SC_MXCSR_DAZ : csr & ~(SC_MXCSR_FTZ | SC_MXCSR_DAZ));
        for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
            const sc_kernels *k = sc_kernels_for((sc_isa)isa);
            if (!k)
                continue;
            for (unsigned W = 8; W <= 16; W += 8)
                for (size_t p = 0; p < 4; p++)
                    for (int bad = 0; bad < BAD_COUNT; bad++)
                        for (unsigned w = 0; w < 3; w++)
                            for (int on = 0; on < 2; on++) {
                                const unsigned where = w == 0 ? 0 : w == 1 ? 5 : W - 1;
                                sc_ray rs[16];
                                for (unsigned i = 0; i < W; i++) {
                                    rs[i] = a.rays[16 * p + i];
                                    valid[i] = a.valid[16 * p + i] ? -1 : 0;
                                }
                                valid[where] = on ? (int32_t)(w + 1) : 0;   /* any nonzero is valid */
                                sc_ray *r = &rs[where];
                                spoil_ray(r, bad, w);
                                for (unsigned i = 0; i < W; i++) {
                                    rows[i] = rs[i].org[0], rows[W + i] = rs[i].org[1];
                                    rows[2 * W + i] = rs[i].org[2], rows[3 * W + i] = rs[i].tmin;
                                    rows[4 * W + i] = rs[i].dir[0], rows[5 * W + i] = rs[i].dir[1];
                                    rows[6 * W + i] = rs[i].dir[2], rows[7 * W + i] = rs[i].tmax;
                                }
                                const int64_t want = sc_packet_valid_ref(valid, rows, W);
                                const int64_t have = k->trace[0].packet_valid(valid, rows, W);
                                if (want != have)
                                    fail_msg("isa %s, W %u, ftz %d, bad kind %d at lane %u (%s): %lld, "
                                             "specification %lld",
                                             sc_isa_name((sc_isa)isa), W, ftz, bad, where, on ? "valid" : "invalid",
                                             (long long)have, (long long)want);
                                /* the specification itself: the lane's own sc_ray_valid decides */
                                assert_int_equal(want < 0, on && !sc_ray_valid(r));
                                refused += want < 0, passed += want >= 0;
                            }
        }
    }
    _mm_setcsr(csr);
    assert_true(refused > 0 && passed > 0);
    packets_free(&a);
    tmesh_free(&m);
}

/* Every ISA level's single rays (closest and any) against the scalar
 * kernel's answers ref / occ_ref, bit for bit, and the level's packets of
 * the same rays (16 at a time, all valid) against its single rays. */
static void levels_match_scalar(const tmesh *m, int leaf, sc_tri_test tt, sc_ray *rays, int32_t *valid, size_t n,
                                const sc_hitrec *ref, const int *occ_ref)
{
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        sc_bvh *b = build(m, leaf, SC_PREFILTER_OFF, tt);
        packets pk = { rays, valid, n };
        size_t bad = 0;
        for (size_t r = 0; r < n; r++) {
            sc_hitrec h;
            int o;
            assert_int_equal(sc_trace_closest(b, &rays[r], &h, NULL), SC_OK);
            assert_int_equal(sc_trace_any(b, &rays[r], &o, NULL), SC_OK);
            bad += !(h.prim == ref[r].prim && same_bits(h.t, ref[r].t) && same_bits(h.u, ref[r].u) &&
                     same_bits(h.v, ref[r].v) && o == occ_ref[r]);
        }
        bad += check(b, &pk, NULL);   /* packets against this level's single rays */
        if (bad)
            print_message("%s leaf %d %s: %zu differ\n", sc_tri_test_name(tt), leaf, sc_isa_name((sc_isa)isa), bad);
        assert_int_equal(bad, 0);
        sc_bvh_free(b);
    }
}

/* Triangles whose sheared vertices coincide: a repeated vertex (every ray),
 * or an edge parallel to the ray (seen end-on). One edge function is then
 * exactly zero, and the optimised kernels skip the double-precision retest
 * for such lanes because it cannot hit (det is exactly 0). The scalar
 * kernel, the specification, still takes the double path: every ISA's
 * single rays and packets must return its answers bit for bit, and no ray
 * may hit a degenerate triangle. The same for the exact test (a triangle
 * with two equal vertices has D.n = 0 exactly). Directions are dyadic (d = (1/2, 1/4, 1)
 * and its mirror images), so an edge along d is seen exactly end-on. */
static void test_repeated_vertices(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double d[3] = { 0.5, 0.25, 1.0 };
    size_t ndeg = 0;
    uint32_t *deg = NULL;
    const int G = 12;
    for (int i = 0; i < G; i++)
        for (int j = 0; j < G; j++) {
            const double x = i * 0.25, y = j * 0.25, z = ((i * 7 + j * 3) % 5) * 0.125;
            uint32_t a = tmesh_vertex(&m, x, y, z), b = tmesh_vertex(&m, x + 0.25, y, z);
            uint32_t c = tmesh_vertex(&m, x, y + 0.25, z + 0.125);
            /* the edge a-e lies along d: end-on to rays of direction d */
            uint32_t e = tmesh_vertex(&m, x + d[0] * 0.125, y + d[1] * 0.125, z + d[2] * 0.125);
            tmesh_tri(&m, a, b, c);             /* an ordinary triangle */
            deg = realloc(deg, (ndeg + 5) * sizeof *deg);
            const uint32_t rep[5][3] = { { a, a, b }, { a, b, b }, { b, a, b }, { c, c, c }, { a, e, b } };
            for (int k = 0; k < 5; k++) {
                if (k < 4)
                    deg[ndeg++] = (uint32_t)m.nt;
                tmesh_tri(&m, rep[k][0], rep[k][1], rep[k][2]);
            }
        }
    /* rays of direction +-d through every vertex, and packets from one
     * origin aimed at the vertices */
    const size_t n = 16 * 40;
    sc_ray *rays = calloc(n, sizeof *rays);
    int32_t *valid = malloc(n * sizeof *valid);
    for (size_t r = 0; r < n; r++) {
        const float *v = &m.pos[3 * ((r * 7) % m.nv)];
        double o[3], dd[3];
        if (r < n / 2) {
            const double sg = (r / 16) % 2 ? -1.0 : 1.0;
            for (int k = 0; k < 3; k++)
                dd[k] = sg * d[k], o[k] = v[k] - 8 * dd[k];
        } else {
            const double eye[3] = { -1.0, -0.5, -3.0 };
            for (int k = 0; k < 3; k++)
                o[k] = eye[k], dd[k] = v[k] - eye[k];
        }
        set_ray(&rays[r], o, dd, 0.0f, INFINITY);
        valid[r] = -1;
    }
    const sc_isa start = sc_isa_active();
    for (int test = 0; test < 2; test++)
    for (int leaf = 4; leaf <= 16; leaf *= 2) {
        const sc_tri_test tt = test ? SC_TRI_EXACT : SC_TRI_WATERTIGHT;
        sc_hitrec ref[16 * 40];
        int occ_ref[16 * 40];
        assert_int_equal(sc_isa_force(SC_ISA_SCALAR), SC_OK);
        sc_bvh *b = build(&m, leaf, SC_PREFILTER_OFF, tt);
        size_t hits = 0;
        for (size_t r = 0; r < n; r++) {
            assert_int_equal(sc_trace_closest(b, &rays[r], &ref[r], NULL), SC_OK);
            assert_int_equal(sc_trace_any(b, &rays[r], &occ_ref[r], NULL), SC_OK);
            for (size_t k = 0; k < ndeg; k++)
                assert_int_not_equal(ref[r].prim, deg[k]);
            hits += ref[r].prim != SC_HITREC_MISS;
        }
        sc_bvh_free(b);
        assert_true(hits > n / 4);
        levels_match_scalar(&m, leaf, tt, rays, valid, n, ref, occ_ref);
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    free(rays), free(valid), free(deg);
    tmesh_free(&m);
}

/* Directions whose components tie in magnitude ((1, 1, 1), (-2, 2, 0),
 * ...): the watertight and exact tests shear along the largest axis, and
 * on a tie sc_shear_axes's rule picks it (the first of the tied axes). The
 * SIMD set-ups choose the axes branch-free (ray_setup_x86.h); a different
 * pick on a tie changes the rounding of t, u and v. Every ISA's single rays
 * and packets must give the scalar kernel's bits. */
static void test_shear_ties(void **state)
{
    (void)state;
    /* the rule itself, worked out by hand: the first of tied largest
     * components is kz; kx, ky follow it cyclically, swapped for d[kz] < 0 */
    const struct { float d[3]; int kx, ky, kz; } want[] = {
        { { 1, 1, 1 }, 1, 2, 0 },  { { -1, 1, 1 }, 2, 1, 0 }, { { 1, 2, 2 }, 2, 0, 1 },
        { { 1, -2, 2 }, 0, 2, 1 }, { { 0, 0, -3 }, 1, 0, 2 }, { { 2, -2, 1 }, 1, 2, 0 },
        { { 0.5f, 0.25f, 1 }, 0, 1, 2 }, { { -0.0f, 0, 1 }, 0, 1, 2 }, { { 3, -1, -3 }, 1, 2, 0 },
    };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        int kx, ky, kz;
        sc_shear_axes(want[i].d, &kx, &ky, &kz);
        if (kx != want[i].kx || ky != want[i].ky || kz != want[i].kz)
            fail_msg("d = (%g, %g, %g): axes %d %d %d, want %d %d %d", want[i].d[0], want[i].d[1], want[i].d[2], kx,
                     ky, kz, want[i].kx, want[i].ky, want[i].kz);
    }
    tmesh m = { 0 };
    const double c[3] = { 0.1, -0.05, 0.02 };
    scene_icosphere(&m, 3, 1.0, c);
    enum { NR = 16 * 64 };
    sc_ray *rays = calloc(NR, sizeof *rays);
    int32_t *valid = malloc(NR * sizeof *valid);
    size_t n = 0;
    sc_rng rng;
    sc_rng_seed(&rng, 41);
    for (int a = -2; a <= 2; a++)
        for (int b = -2; b <= 2; b++)
            for (int e = -2; e <= 2; e++) {
                if (!a && !b && !e)
                    continue;
                const double d[3] = { a, b, e }, len = sqrt((double)(a * a + b * b + e * e));
                for (int k = 0; k < 8 && n < NR; k++) {
                    double o[3];
                    for (int q = 0; q < 3; q++)
                        o[q] = c[q] - 3 * d[q] / len + (sc_rng_uniform(&rng) - 0.5) * 1.2;
                    set_ray(&rays[n], o, d, 0.0f, INFINITY);
                    valid[n++] = -1;
                }
            }
    n -= n % 16;
    const sc_isa start = sc_isa_active();
    for (int test = 0; test < 2; test++) {
        const sc_tri_test tt = test ? SC_TRI_EXACT : SC_TRI_WATERTIGHT;
        sc_hitrec *ref = malloc(n * sizeof *ref);
        int *occ_ref = malloc(n * sizeof *occ_ref);
        assert_int_equal(sc_isa_force(SC_ISA_SCALAR), SC_OK);
        sc_bvh *b = build(&m, 8, SC_PREFILTER_OFF, tt);
        size_t hits = 0;
        for (size_t r = 0; r < n; r++) {
            assert_int_equal(sc_trace_closest(b, &rays[r], &ref[r], NULL), SC_OK);
            assert_int_equal(sc_trace_any(b, &rays[r], &occ_ref[r], NULL), SC_OK);
            hits += ref[r].prim != SC_HITREC_MISS;
        }
        sc_bvh_free(b);
        assert_true(hits > n / 2);
        levels_match_scalar(&m, 8, tt, rays, valid, n, ref, occ_ref);
        free(ref), free(occ_ref);
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    free(rays), free(valid);
    tmesh_free(&m);
}


/* The first hit of ray r on mesh m by brute force with the exact
 * primitives (sc_exact_hit_test, sc_exact_cmp_t), not the traversal: the
 * smallest id at the nearest exact t, or SC_HITREC_MISS. Adds the
 * triangles hit to *hits and those at exactly the same t as the nearest
 * so far to *ties. */
static uint32_t exact_nearest(const tmesh *m, const sc_ray *r, size_t *hits, size_t *ties)
{
    uint32_t want = SC_HITREC_MISS;
    float wt[9];
    for (size_t t = 0; t < m->nt; t++) {
        float tv[9];
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++)
                tv[3 * c + k] = m->pos[3 * m->idx[3 * t + (size_t)c] + k];
        if (!sc_exact_hit_test(r, tv))
            continue;
        ++*hits;
        const int cmp = want == SC_HITREC_MISS ? -1 : sc_exact_cmp_t(r, tv, wt);
        *ties += cmp == 0;
        if (cmp < 0 || (cmp == 0 && t < want)) {
            want = (uint32_t)t;
            memcpy(wt, tv, sizeof wt);
        }
    }
    return want;
}
/* Rays through vertices shared by several triangles: those triangles are
 * hit at exactly the same t, and every kernel must then report the smallest
 * primitive id, whatever order it visits the leaves in. The expected id is
 * found by brute force with the exact primitives (sc_exact_hit_test,
 * sc_exact_cmp_t), for the exact test on every ISA and leaf size. */
static void test_exact_ties(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const int G = 10;
    uint32_t v[11][11];
    for (int i = 0; i <= G; i++)
        for (int j = 0; j <= G; j++)
            v[i][j] = tmesh_vertex(&m, i * 0.25, j * 0.25, ((i * 3 + j * 5) % 4) * 0.0625);
    /* a height field with alternating diagonals: an interior vertex is in
     * 4 or 8 triangles */
    for (int i = 0; i < G; i++)
        for (int j = 0; j < G; j++) {
            if ((i + j) & 1) {
                tmesh_tri(&m, v[i][j], v[i + 1][j], v[i + 1][j + 1]);
                tmesh_tri(&m, v[i][j], v[i + 1][j + 1], v[i][j + 1]);
            } else {
                tmesh_tri(&m, v[i][j], v[i + 1][j], v[i][j + 1]);
                tmesh_tri(&m, v[i + 1][j], v[i + 1][j + 1], v[i][j + 1]);
            }
        }
    enum { NR = 16 * 24 };
    sc_ray rays[NR];
    for (int r = 0; r < NR; r++) {
        const int i = 1 + r % (G - 1), j = 1 + (r / (G - 1)) % (G - 1);
        const float *p = &m.pos[3 * v[i][j]];
        /* dyadic directions: the origin and the vertex lie exactly on the ray */
        const double d[3] = { (r % 3 - 1) * 0.125, ((r / 3) % 3 - 1) * 0.0625, r & 1 ? -1.0 : 1.0 };
        double o[3];
        for (int k = 0; k < 3; k++)
            o[k] = p[k] - 4 * d[k];
        set_ray(&rays[r], o, d, 0.0f, INFINITY);
    }
    uint32_t want[NR];
    size_t ties = 0;
    for (int r = 0; r < NR; r++) {
        size_t hits = 0;
        want[r] = exact_nearest(&m, &rays[r], &hits, &ties);
        assert_true(hits >= 1);
    }
    assert_true(ties > (size_t)NR);   /* most rays meet a fan of several triangles at one t */
    const sc_isa start = sc_isa_active();
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        for (int leaf = 4; leaf <= 16; leaf *= 2) {
            sc_bvh *b = build(&m, leaf, SC_PREFILTER_OFF, SC_TRI_EXACT);
            for (int r = 0; r < NR; r++) {
                sc_hitrec h;
                assert_int_equal(sc_trace_closest(b, &rays[r], &h, NULL), SC_OK);
                if (h.prim != want[r])
                    fail_msg("isa %s leaf %d ray %d: prim %u, the smallest at the nearest exact t is %u",
                             sc_isa_name((sc_isa)isa), leaf, r, h.prim, want[r]);
            }
            sc_bvh_free(b);
        }
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    tmesh_free(&m);
}

static sc_bvh *build_quality(const tmesh *m, int leaf, sc_build_quality q)
{
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.leaf_size = leaf;
    cfg.prefilter = SC_PREFILTER_OFF;
    cfg.tri_test = SC_TRI_EXACT;
    cfg.quality = q;
    sc_bvh *bvh = NULL;
    assert_int_equal(sc_bvh_build(&(sc_mesh_view){ m->pos, m->nv, m->idx, m->nt, 0, 0 }, &cfg, &bvh), SC_OK);
    return bvh;
}

/* Faces stored twice (the same three vertices, rotated or reversed, as in
 * Sponza): a ray that hits one hits both at exactly the same t, and the
 * smaller id wins. What the exact test reports for the winner (t, u, v)
 * must not depend on the order the two were met in, nor on how often one
 * face is met (the high build cuts large faces into several leaves): every
 * ISA, leaf size, build quality, the brute-force scan and packets return
 * the same bits (these rays
 * differed by an ulp or two in t between brute force and the traversal
 * when comparing two hits could overwrite the reported values). The ids
 * are checked against the exact primitives (sc_exact_hit_test,
 * sc_exact_cmp_t). */
static void test_exact_duplicates(void **state)
{
    (void)state;
    tmesh m = { 0 };
    enum { G = 12 };
    uint32_t v[G + 1][G + 1];
    sc_rng g;
    sc_rng_seed(&g, 77);
    for (int i = 0; i <= G; i++)
        for (int j = 0; j <= G; j++)
            v[i][j] = tmesh_vertex(&m, i * 0.3 + 0.01 * sc_rng_uniform(&g), j * 0.3,
                                   0.02 * sc_rng_uniform(&g));
    for (int i = 0; i < G; i++)
        for (int j = 0; j < G; j++) {
            tmesh_tri(&m, v[i][j], v[i + 1][j], v[i + 1][j + 1]);
            tmesh_tri(&m, v[i][j], v[i + 1][j + 1], v[i][j + 1]);
        }
    const size_t nt = m.nt;
    for (size_t t = 0; t < nt; t++) {
        const uint32_t a = m.idx[3 * t], b = m.idx[3 * t + 1], c = m.idx[3 * t + 2];
        if (t & 1)
            tmesh_tri(&m, c, b, a);   /* the other side */
        else
            tmesh_tri(&m, b, c, a);   /* the same side, rotated */
    }
    /* stored once: a large quad under the field and a sliver across it,
     * which the high build cuts into several leaves, so that one face is
     * met more than once (by the brute-force scan, or by a ray through
     * two of its leaves' boxes) */
    const uint32_t q0 = tmesh_vertex(&m, -1.013, -0.971, -0.0517), q1 = tmesh_vertex(&m, 4.61, -1.03, -0.0731);
    const uint32_t q2 = tmesh_vertex(&m, 4.587, 4.633, -0.0417), q3 = tmesh_vertex(&m, -0.989, 4.6, -0.0603);
    tmesh_tri(&m, q0, q1, q2);
    tmesh_tri(&m, q0, q2, q3);
    const uint32_t s0 = tmesh_vertex(&m, -0.5, 0.1, 0.011), s1 = tmesh_vertex(&m, 4.1, 3.3, 0.013);
    const uint32_t s2 = tmesh_vertex(&m, -0.5, 0.9, 0.012);
    tmesh_tri(&m, s0, s1, s2);
    enum { NR = 16 * 64 };
    sc_ray *rays = calloc(NR, sizeof *rays);
    assert_non_null(rays);
    /* half from afar, half from just above the surface (1e-5 to 1e-2 over
     * its highest point): hits so near the origin that the float filter's
     * bound is wide and the report is recomputed (sc_exact_finish) */
    for (int r = 0; r < NR; r++) {
        if (r & 1) {
            const double o[3] = { sc_rng_range(&g, 0.2, 3.4), sc_rng_range(&g, 0.2, 3.4),
                                  0.02 + exp(sc_rng_range(&g, log(1e-5), log(1e-2))) };
            const double d[3] = { sc_rng_range(&g, -0.5, 0.5), sc_rng_range(&g, -0.5, 0.5), -1 };
            set_ray(&rays[r], o, d, 0.0f, INFINITY);
        } else {
            const double o[3] = { sc_rng_range(&g, -1, 4.6), sc_rng_range(&g, -1, 4.6), r & 2 ? 2.5 : -2.0 };
            const double tx = sc_rng_range(&g, 0.2, 3.4), ty = sc_rng_range(&g, 0.2, 3.4);
            const double d[3] = { tx - o[0], ty - o[1], 0.01 - o[2] };
            set_ray(&rays[r], o, d, 0.0f, INFINITY);
        }
    }
    size_t hit = 0;
    uint32_t *want = malloc(NR * sizeof *want);
    assert_non_null(want);
    for (int r = 0; r < NR; r++) {
        size_t hits = 0, ties = 0;
        want[r] = exact_nearest(&m, &rays[r], &hits, &ties);
        hit += want[r] != SC_HITREC_MISS;
        assert_true(want[r] == SC_HITREC_MISS || want[r] < nt || want[r] >= 2 * nt);   /* the first copy wins */
    }
    assert_true(hit > NR / 2);
    /* the reference bits: the scalar brute-force scan of a leaf-4 tree */
    sc_hitrec *ref = malloc(NR * sizeof *ref);
    assert_non_null(ref);
    const sc_isa start = sc_isa_active();
    assert_int_equal(sc_isa_force(SC_ISA_SCALAR), SC_OK);
    sc_bvh *b4 = build_quality(&m, 4, SC_BUILD_QUALITY_MEDIUM);
    for (int r = 0; r < NR; r++) {
        assert_int_equal(sc_trace_closest_brute(b4, &rays[r], &ref[r]), SC_OK);
        assert_int_equal(ref[r].prim, want[r]);
    }
    sc_bvh_free(b4);
    sc_ray_packet16 *p16 = aligned_alloc(64, sizeof *p16);
    sc_hit_packet16 *h16 = aligned_alloc(64, sizeof *h16);
    assert_non_null(p16);
    assert_non_null(h16);
    _Alignas(64) int32_t valid[16];
    for (int i = 0; i < 16; i++)
        valid[i] = -1;
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
        for (int run = 0; run < 6; run++) {
            const int leaf = 4 << (run % 3);
            const sc_build_quality q = run < 3 ? SC_BUILD_QUALITY_MEDIUM : SC_BUILD_QUALITY_HIGH;
            sc_bvh *b = build_quality(&m, leaf, q);
            if (q == SC_BUILD_QUALITY_HIGH)
                assert_true(b->references > b->triangles);   /* faces cut into several leaves */
            size_t bad = 0;
            for (int r = 0; r < NR; r++) {
                sc_hitrec h, hb;
                assert_int_equal(sc_trace_closest(b, &rays[r], &h, NULL), SC_OK);
                assert_int_equal(sc_trace_closest_brute(b, &rays[r], &hb), SC_OK);
                bad += !(h.prim == ref[r].prim && same_bits(h.t, ref[r].t) && same_bits(h.u, ref[r].u) &&
                         same_bits(h.v, ref[r].v));
                bad += !(hb.prim == ref[r].prim && same_bits(hb.t, ref[r].t) && same_bits(hb.u, ref[r].u) &&
                         same_bits(hb.v, ref[r].v));
            }
            for (int r0 = 0; r0 < NR; r0 += 16) {
                to_packet16(&rays[r0], p16);
                assert_int_equal(sc_trace_closest16(b, valid, p16, h16, NULL), SC_OK);
                for (int i = 0; i < 16; i++)
                    bad += !SAME_LANE(h16, i, ref[r0 + i]);
            }
            if (bad)
                fail_msg("isa %s leaf %d %s build: %zu answers differ from the scalar brute-force scan's bits",
                         sc_isa_name((sc_isa)isa), leaf, q == SC_BUILD_QUALITY_HIGH ? "high" : "medium", bad);
            sc_bvh_free(b);
        }
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    free(p16), free(h16), free(ref), free(want), free(rays);
    tmesh_free(&m);
}

/* Every level visits the same nodes and leaves as the scalar kernel, in the
 * same order: the counters of closest-hit traversals (which cull by the
 * best t so far, so the order of the leaves shows in them) must be equal.
 * The AVX-512 level orders three or more hit children by a sorting network
 * (traverse_bvh8_x86.h) that must give sc_order_children's order. (A
 * check on the whole: an order wrong only for near-equal distances may
 * still visit the same nodes here.) */
static void test_same_visits(void **state)
{
    (void)state;
    tmesh m = { 0 };
    const double c[3] = { 0, 0, 0 };
    scene_icosphere(&m, 4, 1.0, c);
    packets a, b;
    make_packets(&m, K_CAMERA, 51, &a);
    make_packets(&m, K_MIXED, 52, &b);
    const sc_isa start = sc_isa_active();
    for (int tt = 0; tt < 2; tt++) {
        sc_trace_stats want[2];
        for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
            if (!sc_isa_supported((sc_isa)isa))
                continue;
            assert_int_equal(sc_isa_force((sc_isa)isa), SC_OK);
            sc_bvh *bvh = build(&m, 4, SC_PREFILTER_OFF, tt ? SC_TRI_EXACT : SC_TRI_WATERTIGHT);
            for (int k = 0; k < 2; k++) {
                const packets *pk = k ? &b : &a;
                sc_trace_stats st;
                memset(&st, 0, sizeof st);
                for (size_t r = 0; r < pk->n; r++) {
                    sc_hitrec h;
                    assert_int_equal(sc_trace_closest(bvh, &pk->rays[r], &h, &st), SC_OK);
                }
                assert_true(st.nodes > 2 * st.rays);
                if (isa == SC_ISA_SCALAR)
                    want[k] = st;
                else if (st.nodes != want[k].nodes || st.leaves != want[k].leaves || st.tri_tests != want[k].tri_tests)
                    fail_msg("%s, %s rays, %s: %llu nodes %llu leaves %llu triangles; scalar %llu %llu %llu",
                             tt ? "exact" : "watertight", k ? "mixed" : "camera", sc_isa_name((sc_isa)isa),
                             (unsigned long long)st.nodes, (unsigned long long)st.leaves,
                             (unsigned long long)st.tri_tests, (unsigned long long)want[k].nodes,
                             (unsigned long long)want[k].leaves, (unsigned long long)want[k].tri_tests);
            }
            sc_bvh_free(bvh);
        }
    }
    assert_int_equal(sc_isa_force(start), SC_OK);
    packets_free(&a), packets_free(&b);
    tmesh_free(&m);
}

static void test_bunny(void **state)
{
    (void)state;
    const char *dir = getenv("SC_TEST_SCENES");
    char path[4096];
    tmesh m = { 0 };
    snprintf(path, sizeof path, "%s/bunny.obj", dir ? dir : ".");
    if (!dir || tmesh_read_obj(&m, path) != 0) {
        print_message("bunny.obj not found: skipped\n");
        skip();
    }
    const int leaves[] = { 4 };
    run_scene("bunny", &m, leaves, 1);
    tmesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_api),
        cmocka_unit_test(test_exact_duplicates),
        cmocka_unit_test(test_other_tests),
        cmocka_unit_test(test_streams),
        cmocka_unit_test(test_streams_incoherent),
        cmocka_unit_test(test_stream_bounces),
        cmocka_unit_test(test_stream_groups),
        cmocka_unit_test(test_stream_gather),
        cmocka_unit_test(test_packet_valid),
        cmocka_unit_test(test_icosphere),
        cmocka_unit_test(test_soup_slivers),
        cmocka_unit_test(test_repeated_vertices),
        cmocka_unit_test(test_shear_ties),
        cmocka_unit_test(test_exact_ties),
        cmocka_unit_test(test_same_visits),
        cmocka_unit_test(test_bunny),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

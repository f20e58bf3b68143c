/* The compact sphere summary (prefilter "compact", src/bvh/leaf_block.h):
 * every decoded sphere contains its triangle exactly (MPFR), in both MXCSR
 * modes the decode gives the same bits, leaves the builder cannot encode
 * never reject, and the summary does reject rays on an ordinary mesh.
 *
 * Meshes: random triangles at unit scale, near the bottom of the normal
 * range (coordinates about 2^-100, where q * s would underflow without the
 * builder's floors), near the top (about 2^60: r2 of larger triangles
 * overflows float), far from the origin with small triangles (coarse
 * quantisation steps relative to the box), slivers
 * and repeated vertices, and a height-field grid. */
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
#include "common/sc_rng.h"
#include "sc_ftz.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_trace.h"

typedef struct {
    float *v;
    uint32_t *idx;
    size_t nv, nt;
} tmesh;

static void mesh_alloc(tmesh *m, size_t nt)
{
    m->nt = nt, m->nv = 3 * nt;
    m->v = malloc(m->nv * 3 * sizeof *m->v);
    m->idx = malloc(m->nt * 3 * sizeof *m->idx);
    assert_non_null(m->v);
    assert_non_null(m->idx);
    for (size_t i = 0; i < 3 * nt; i++)
        m->idx[i] = (uint32_t)i;
}

/* Random triangles of size about `size` in a cube of side `span` at
 * `offset`; kind 1: slivers and repeated vertices among them. */
static void random_mesh(tmesh *m, size_t nt, double offset, double span, double size, int kind, uint64_t seed)
{
    unsigned saved = sc_test_ftz_off();
    mesh_alloc(m, nt);
    sc_rng rng;
    sc_rng_seed(&rng, seed);
    for (size_t t = 0; t < nt; t++) {
        double c[3];
        for (int k = 0; k < 3; k++)
            c[k] = offset + span * sc_rng_range(&rng, 0, 1);
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                m->v[(3 * t + j) * 3 + k] = (float)(c[k] + size * sc_rng_range(&rng, -1, 1));
        if (kind == 1 && t % 3 == 0) {   /* a repeated vertex */
            memcpy(&m->v[(3 * t + 2) * 3], &m->v[(3 * t + 1) * 3], 3 * sizeof(float));
        } else if (kind == 1 && t % 3 == 1) {   /* a sliver: the third vertex on the first edge */
            for (int k = 0; k < 3; k++) {
                double a = m->v[3 * t * 3 + k], b = m->v[(3 * t + 1) * 3 + k];
                m->v[(3 * t + 2) * 3 + k] = (float)(a + 0.37 * (b - a));
            }
        }
    }
    sc_test_ftz_restore(saved);
}

/* A 96 x 96 height field on [0, 1]^2. */
static void grid_mesh(tmesh *m)
{
    const int n = 96;
    mesh_alloc(m, (size_t)2 * n * n);
    size_t t = 0;
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            double p[4][3];
            for (int c = 0; c < 4; c++) {
                double u = (double)(x + (c & 1)) / n, w = (double)(y + (c >> 1)) / n;
                p[c][0] = u, p[c][1] = w, p[c][2] = 0.1 * sin(7 * u) * cos(5 * w);
            }
            const int tri[2][3] = { { 0, 1, 2 }, { 1, 3, 2 } };
            for (int h = 0; h < 2; h++, t++)
                for (int j = 0; j < 3; j++)
                    for (int k = 0; k < 3; k++)
                        m->v[(3 * t + j) * 3 + k] = (float)p[tri[h][j]][k];
        }
}

static sc_bvh *build(const tmesh *m, int leaf)
{
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.leaf_size = leaf;
    cfg.prefilter = SC_PREFILTER_COMPACT;
    sc_mesh_view view = { m->v, m->nv, m->idx, m->nt, 0, 0 };
    sc_bvh *bvh = NULL;
    assert_int_equal(sc_bvh_build(&view, &cfg, &bvh), SC_OK);
    return bvh;
}

typedef struct {
    size_t leaves, encoded, spheres;
    double max_growth;    /* largest r / (half the longest edge), encoded leaves */
} walk_result;

/* Every leaf of the tree: the decoded spheres against their triangles. */
static void walk(const sc_bvh *bvh, const tmesh *m, walk_result *res)
{
    mpfr_t d, s, r2;
    mpfr_inits2(1024, d, s, r2, (mpfr_ptr)0);
    memset(res, 0, sizeof *res);
    for (size_t ni = 0; ni < bvh->node_count; ni++) {
        for (int c = 0; c < SC_BVH_N; c++) {
            const uint64_t ref = bvh->nodes[ni].child[c];
            if (!ref || !sc_ref_is_leaf(ref))
                continue;
            res->leaves++;
            assert_true(sc_ref_has_summary(ref));
            assert_false(sc_ref_has_spheres(ref));
            const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
            const float *sum = sc_leaf_block(bvh->leaves, ref);
            const float *rows = sc_leaf_rows(sum, W, ref);
            assert_ptr_equal((const char *)rows, (const char *)sum + sc_leaf_summary_bytes(W));
            _Alignas(64) float blk[64], blk_ftz[64];
            unsigned saved = sc_test_ftz_off();
            sc_leaf_summary_decode(sum, W, blk);
            _mm_setcsr(saved | SC_MXCSR_FTZ | SC_MXCSR_DAZ);
            sc_leaf_summary_decode(sum, W, blk_ftz);
            sc_test_ftz_restore(saved);
            /* the same bits in both MXCSR modes */
            assert_memory_equal(blk, blk_ftz, 4 * W * sizeof(float));
            if (isinf(sum[6])) {
                /* not encodable: every lane must never reject */
                for (unsigned i = 0; i < n; i++)
                    assert_true(isinf(blk[3 * W + i]));
                continue;
            }
            res->encoded++;
            for (unsigned k = 0; k < 7; k++)   /* the frame: no subnormal */
                assert_true(sum[k] == 0 || fabsf(sum[k]) >= FLT_MIN);
            const uint32_t *prims = sc_leaf_prims(rows, W);
            for (unsigned i = 0; i < n; i++) {
                const float *cc[3] = { &blk[i], &blk[W + i], &blk[2 * W + i] };
                const float rr2 = blk[3 * W + i];
                assert_true(rr2 >= FLT_MIN && isfinite(rr2));
                mpfr_set_flt(r2, rr2, MPFR_RNDN);
                double longest = 0;
                for (int j = 0; j < 3; j++) {
                    const float *V = &m->v[m->idx[3 * prims[i] + (uint32_t)j] * 3];
                    mpfr_set_ui(s, 0, MPFR_RNDN);
                    for (int k = 0; k < 3; k++) {
                        mpfr_set_flt(d, V[k], MPFR_RNDN);
                        mpfr_sub_d(d, d, *cc[k], MPFR_RNDN);   /* exact at 1024 bits */
                        mpfr_fma(s, d, d, s, MPFR_RNDN);
                    }
                    /* |V - c|^2 <= r2, exactly */
                    assert_true(mpfr_cmp(s, r2) <= 0);
                    const float *U = &m->v[m->idx[3 * prims[i] + (uint32_t)((j + 1) % 3)] * 3];
                    double e = 0;
                    for (int k = 0; k < 3; k++)
                        e += ((double)U[k] - V[k]) * ((double)U[k] - V[k]);
                    longest = fmax(longest, sqrt(e));
                }
                res->spheres++;
                if (longest > 0)
                    res->max_growth = fmax(res->max_growth, sqrt((double)rr2) / (0.5 * longest));
            }
        }
    }
    mpfr_clears(d, s, r2, (mpfr_ptr)0);
}

typedef struct {
    const char *name;
    double offset, span, size;
    int kind;
} case_def;

static void test_contains(void **state)
{
    (void)state;
    const case_def cases[] = {
        { "unit", 0, 1, 0.02, 0 },
        { "slivers", -3, 2, 0.05, 1 },
        { "tiny", 0, 0x1p-100, 0x1p-107, 0 },
        { "tiny-slivers", -0x1p-100, 0x1p-100, 0x1p-106, 1 },
        { "huge", -0x1p60, 0x1p61, 0x1p55, 0 },   /* r2 of bigger triangles overflows float */
        { "far", 1e6, 64, 0.01, 0 },
        { "far-slivers", -3e7, 1000, 0.3, 1 },
    };
    const int leaves[] = { 1, 4, 8, 16 };
    for (size_t ci = 0; ci < sizeof cases / sizeof cases[0]; ci++) {
        tmesh m;
        random_mesh(&m, 3000, cases[ci].offset, cases[ci].span, cases[ci].size, cases[ci].kind, 77 + ci);
        for (size_t li = 0; li < sizeof leaves / sizeof leaves[0]; li++) {
            sc_bvh *bvh = build(&m, leaves[li]);
            walk_result r;
            walk(bvh, &m, &r);
            print_message("%-13s leaf %2d: %zu leaves, %zu encoded, %zu spheres, r <= %.2f x half the longest edge\n",
                          cases[ci].name, leaves[li], r.leaves, r.encoded, r.spheres, r.max_growth);
            assert_true(r.leaves > 0);
            /* Every leaf of these meshes can be encoded: a summary that
             * gives up is correct but useless. */
            assert_int_equal(r.encoded, r.leaves);
            sc_bvh_free(bvh);
        }
        free(m.v);
        free(m.idx);
    }
}

/* A leaf the builder cannot encode (a box whose extent overflows) gets the
 * never-rejecting summary, and the tracer still finds its hits. */
static void test_unencodable(void **state)
{
    (void)state;
    tmesh m;
    mesh_alloc(&m, 2);
    /* a huge triangle out of the ray's way, and the one it hits */
    const float v[18] = { -2e38f, 10, 50, 2e38f, 10, 50, 0, 11, 50,   0, -1, 5, 1, -1, 5, 0, 1, 5 };
    memcpy(m.v, v, sizeof v);
    sc_bvh *bvh = build(&m, 8);
    walk_result r;
    walk(bvh, &m, &r);
    assert_int_equal(r.leaves, 1);
    assert_int_equal(r.encoded, 0);
    sc_ray ray = { { 0.1f, -0.5f, 0 }, 0, { 0, 0, 1 }, INFINITY };
    sc_hitrec h;
    assert_int_equal(sc_trace_closest(bvh, &ray, &h, NULL), SC_OK);
    assert_int_equal(h.prim, 1);
    assert_true(h.t == 5.0f);
    sc_bvh_free(bvh);
    free(m.v);
    free(m.idx);
}

/* On an ordinary mesh the summary removes triangle tests (a summary that
 * never rejects would pass every other test), and hits are those of the
 * tree without it. */
static void test_rejects(void **state)
{
    (void)state;
    tmesh m;
    grid_mesh(&m);
    sc_bvh *bvh = build(&m, 8);
    walk_result r;
    walk(bvh, &m, &r);
    assert_int_equal(r.encoded, r.leaves);
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    sc_mesh_view view = { m.v, m.nv, m.idx, m.nt, 0, 0 };
    sc_bvh *off = NULL;
    assert_int_equal(sc_bvh_build(&view, &cfg, &off), SC_OK);
    sc_rng rng;
    sc_rng_seed(&rng, 5);
    sc_trace_stats st = { 0 }, st_off = { 0 };
    for (int i = 0; i < 20000; i++) {
        sc_ray ray = { { (float)sc_rng_range(&rng, -0.5, 1.5), (float)sc_rng_range(&rng, -0.5, 1.5), 1 }, 0,
                       { (float)sc_rng_range(&rng, -1, 1), (float)sc_rng_range(&rng, -1, 1), -1 }, INFINITY };
        sc_hitrec a, b;
        assert_int_equal(sc_trace_closest(bvh, &ray, &a, &st), SC_OK);
        assert_int_equal(sc_trace_closest(off, &ray, &b, &st_off), SC_OK);
        assert_int_equal(a.prim, b.prim);
        assert_memory_equal(&a.t, &b.t, sizeof a.t);
        assert_memory_equal(&a.u, &b.u, sizeof a.u);
        assert_memory_equal(&a.v, &b.v, sizeof a.v);
    }
    print_message("grid: %zu leaves; triangle tests per ray %.2f (off) -> %.2f (compact); %.0f %% of spheres rejected\n",
                  r.leaves, (double)st_off.tri_tests / (double)st_off.rays, (double)st.tri_tests / (double)st.rays,
                  100.0 * (double)st.sphere_rejects / (double)st.sphere_tests);
    assert_true(st.sphere_rejects > st.sphere_tests / 4);
    assert_true(st.tri_tests < st_off.tri_tests);
    sc_bvh_free(bvh);
    sc_bvh_free(off);
    free(m.v);
    free(m.idx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_contains),
        cmocka_unit_test(test_unencodable),
        cmocka_unit_test(test_rejects),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

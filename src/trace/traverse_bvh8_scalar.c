/* The portable traversal: the specification every SIMD kernel must match
 * bit for bit (same operations, same order, no FMA where none is written),
 * and the kernels of CPUs without AVX2 (the scalar and SSE4.1 levels). */
#include "bvh/bvh_internal.h"
#include "node_bvh8_slab.h"
#include "ray_setup.h"
#include "simd/sphere_kernels.h"
#include "stream_gather.h"
#include "tri_exact.h"
#include "tri_moller.h"
#include "traverse_stack.h"
#include "tri_watertight.h"

#define SC_TARGET

typedef struct trace_ctx { sc_ray_pre pre; } trace_ctx;

static inline void ctx_init(trace_ctx *c, const sc_ray_pre *p) { c->pre = *p; }
/* Non-parallel rays: here the same set-up as any other. */
static inline void ctx_init_fast(trace_ctx *c, const sc_ray *r, const sc_bvh *bvh, const int TEST)
{
    (void)TEST;
    sc_ray_precompute(r, &c->pre, bvh->root_lo, bvh->root_hi);
}
/* sc_ray_precompute has set the near and far rows already. */
static inline void ctx_set_rows(trace_ctx *c, const sc_ray *r)
{
    (void)c, (void)r;
}
static inline void ctx_set_rows_signs(trace_ctx *c, unsigned signs)
{
    (void)c, (void)signs;
}

static inline unsigned node_test(const trace_ctx *c, const sc_bvh_node8 *node, float tmin, float tmax,
                                 float *dist, const int OCT, const int WANT_DIST)
{
    (void)OCT, (void)WANT_DIST;
    return sc_slab(&c->pre, node, tmin, tmax, dist);
}

static inline unsigned node_test_par(const trace_ctx *c, const sc_bvh_node8 *node, float tmin, float tmax,
                                     float *dist)
{
    return sc_slab_par(&c->pre, node, tmin, tmax, dist);
}

static int64_t packet_valid(const int32_t *valid, const float *rows, unsigned K)
{
    return sc_packet_valid_ref(valid, rows, K);
}

static int stream_gather16(const char *rays, size_t ray_stride, const float *lo, const float *hi,
                           sc_ray_packet16 *p)
{
    return sc_stream_gather16_ref(rays, ray_stride, lo, hi, p);
}

/* The sphere kernels of the scalar level (the specification, lane by lane). */
static inline uint32_t sphere_reject(const sc_ray *ray, const float *blk, unsigned W)
{
    const sc_sphere_kernels *k = &sc_sphere_kernels_scalar;
    if (W == 4)
        return k->reject4(ray, (const sc_sphere_block4 *)(const void *)blk);
    if (W == 8)
        return k->reject8(ray, (const sc_sphere_block8 *)(const void *)blk);
    return k->reject16(ray, (const sc_sphere_block16 *)(const void *)blk);
}

/* A leaf's compact summary (leaf_block.h): decoded, then the same test. */
static inline uint32_t summary_reject(const sc_ray *ray, const float *sum, unsigned W)
{
    _Alignas(64) float blk[4 * 16];
    sc_leaf_summary_decode(sum, W, blk);
    return sphere_reject(ray, blk, W);
}

static inline unsigned leaf_test(const trace_ctx *c, const float *rows, unsigned W, unsigned live,
                                 float tmin, float tmax, int test, float *t, float *te, float *un,
                                 float *vn, float *den)
{
    const sc_ray_pre *p = &c->pre;
    unsigned hm = 0;
    for (unsigned m = live; m; m &= m - 1) {
        unsigned i = (unsigned)__builtin_ctz(m);
        int h = test == SC_TRI_MOLLER ? sc_tri_moller(p, rows, W, i, tmin, tmax, &t[i], &un[i], &vn[i], &den[i])
                : test == SC_TRI_EXACT
                    ? sc_tri_exact_filter(p, rows, W, i, tmin, tmax, &t[i], &te[i], &un[i], &vn[i], &den[i])
                    : sc_tri_watertight(p, rows, W, i, tmin, tmax, &t[i], &un[i], &vn[i], &den[i]);
        hm |= (unsigned)h << i;
    }
    return hm;
}

#define SC_TOP_TABLE sc_trace_kernels_scalar
#include "traverse_bvh8_single.h"

const sc_trace_kernels sc_trace_kernels_scalar[SC_TRI_TEST_COUNT] = SC_TRACE_KERNEL_TABLE;

/* Every leaf, no box tests, no prefilter: a same-arithmetic oracle for the
 * traversal (of equal t the smaller id, as the traversal, for every test). */
sc_status sc_trace_closest_brute(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit)
{
    if (!bvh || !ray || !hit || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    sc_ray_pre p;
    sc_ray_precompute(ray, &p, bvh->root_lo, bvh->root_hi);
    trace_ctx c;
    ctx_init(&c, &p);
    float tmax = ray->tmax;
    hit->prim = SC_HITREC_MISS;
    hit->t = ray->tmax;
    hit->u = hit->v = 0;
    sc_hit_ids_normal(hit, NULL, 0, 0);
    if (!bvh->has_root)
        return SC_OK;
    const int test = bvh->cfg.tri_test;
    sc_exact_hit xb;
    xb.have = 0;
    for (size_t ni = 0; ni < bvh->node_count; ni++) {
        const sc_bvh_node8 *node = &bvh->nodes[ni];
        for (int s = 0; s < SC_BVH_N; s++) {
            uint64_t ref = node->child[s];
            if (!sc_ref_is_leaf(ref))
                continue;
            const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
            const float *rows = sc_leaf_rows(sc_leaf_block(bvh->leaves, ref), W, ref);
            float t[16], te[16], un[16], vn[16], den[16];
            unsigned hm = leaf_test(&c, rows, W, (1u << n) - 1, ray->tmin, tmax, test, t, te, un, vn, den);
            if (!hm)
                continue;
            if (test == SC_TRI_EXACT) {
                sc_exact_resolve(ray, rows, W, hm, t, te, un, vn, den, 0, &xb);
                if (xb.have) {
                    tmax = xb.hi;
                    sc_exact_finish(ray, &xb);
                    hit->prim = xb.prim;
                    hit->t = xb.t;
                    hit->u = xb.u;
                    hit->v = xb.v;
                    sc_hit_ids_normal(hit, xb.rows, xb.W, xb.lane);
                }
                continue;
            }
            const uint32_t *prims = sc_leaf_prims(rows, W);
            const unsigned bi = sc_nearest_lane(hm, t, prims);
            if (t[bi] < tmax || prims[bi] < hit->prim) {
                tmax = t[bi];
                hit->t = t[bi];
                hit->prim = prims[bi];
                hit->u = un[bi] / den[bi];
                hit->v = vn[bi] / den[bi];
                sc_hit_ids_normal(hit, rows, W, bi);
            }
        }
    }
    return SC_OK;
}

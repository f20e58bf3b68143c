/* Pieces every traversal kernel shares, so that all ISAs produce
 * bit-identical hits: the per-ray set-up, the slab-test padding, the
 * watertight test's double-precision fallback and the child ordering.
 *
 * The arithmetic of every kernel is fixed by this file and by
 * traverse_scalar.c (the specification): no FMA (-ffp-contract=off, and the
 * SIMD kernels use separate multiplies and subtracts), operations in the
 * same order, max(a,b) = a > b ? a : b like (v)maxps.
 */
#ifndef SPHERECULL_TRACE_COMMON_H
#define SPHERECULL_TRACE_COMMON_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "bvh/bvh_internal.h"
#include "exact_tri.h"

/* Robust slab test with one FMA per plane and no padding in the loop.
 * A slab distance is computed as t = fl(p rd - b) with rd = fl(1/d), one
 * rounding (FMA); the padding sits in b, per ray and per axis. With
 * r = 1/d, tau = (p - o) r the exact distance and M >= |p - o| for every
 * plane p of the BVH (the root box bounds every node box):
 *     p rd - b = tau + (p - o)(rd - r) + (o rd - b),   |rd - r| <= u |r|,
 * and the FMA adds at most u |p rd - b| + 2^-150. So with
 *     b_near >= o rd + D,  b_far <= o rd - D,  D >= 2u |r| M (1 + 2u) + tiny,
 * a near distance is never above tau and a far distance never below: the
 * computed interval contains the exact one, and a ray that truly meets a box
 * (whose float bounds are exact min/max of float vertices) is never culled.
 * That takes the two padding FMAs of Ize 2013 off the chain of dependent
 * operations that every node visit waits on (load, slab, max, compare,
 * child load), 5-8 % of shadow-ray time. D is absolute: about 2^-23 of the
 * root box's extent in t, so a box is kept only when it misses the ray by
 * less than that. sc_ray_precompute computes b in double and rounds outward. */
/* Directions below this magnitude are replaced by it (with their sign), as
 * Embree does, so 1/d is finite and no slab distance is 0 * inf = NaN.
 * That is not conservative for a ray (nearly) parallel to a slab that runs
 * in or next to its plane: with d_y = 0 and o_y exactly on a box face the
 * substituted ray leaves the slab at t = 0. Such rays ("parallel": some
 * |d_k| < SC_MIN_RCP_INPUT) take the node test sc_slab_par below instead. */
#define SC_MIN_RCP_INPUT 1e-18f
/* |o| * 1/SC_MIN_RCP_INPUT must stay finite in float. */
#define SC_MAX_ORIGIN 1e18f

/* Everything the kernels call per ray or per node is forced inline: the
 * kernels are compiled for AVX2/AVX-512 by target attribute, and a call to a
 * function compiled for the baseline ISA costs a vzeroupper and the spill of
 * every live ymm register (the ray's broadcasts). A non-inlined
 * sc_ray_pre_exact (since folded into sc_ray_precompute) cost 8 % of
 * shadow-ray time. */
#define SC_TRACE_INLINE static inline __attribute__((always_inline))

SC_TRACE_INLINE float sc_fmax(float a, float b) { return a > b ? a : b; }
SC_TRACE_INLINE float sc_fmin(float a, float b) { return a < b ? a : b; }

typedef struct sc_ray_pre {
    float org[3], dir[3], tmin, tmax;
    float rd[3];
    float ord_near[3], ord_far[3]; /* b of the slab distances fl(p rd - b), padded outward */
    float rdp[3];                  /* 1/d in IEEE (+-inf for d = +-0): parallel rays only */
    int parallel;
    int near_row[3], far_row[3];   /* rows of sc_bvh_node8.b */
    int kx, ky, kz;                /* watertight: kz = axis of largest |d| */
    float Sx, Sy, Sz;
    float xK, xc0;                 /* exact test: edge bound E = xK (hP + hQ) + xc0 */
} sc_ray_pre;

static inline int sc_ray_valid(const sc_ray *r)
{
    for (int k = 0; k < 3; k++)
        if (!(fabsf(r->org[k]) < SC_MAX_ORIGIN) || !isfinite(r->dir[k]))
            return 0;
    if (r->dir[0] == 0 && r->dir[1] == 0 && r->dir[2] == 0)
        return 0;
    return r->tmin >= 0 && !isnan(r->tmax);
}

/* 1 iff the ray must take the parallel node test. */
SC_TRACE_INLINE int sc_ray_parallel(const sc_ray *r)
{
    return !(fabsf(r->dir[0]) >= SC_MIN_RCP_INPUT && fabsf(r->dir[1]) >= SC_MIN_RCP_INPUT &&
             fabsf(r->dir[2]) >= SC_MIN_RCP_INPUT);
}

/* The exact test's per-ray bound constants (derivation in exact_tri.c) from
 * m_k = fl(max |root box - o| along axis k): S = fl(m_0 + m_1 + m_2) is at
 * least (1 - 3u) times the largest L1 distance of a vertex from the origin,
 * and K and c0 carry the factor (1 + 2^-10) of the derivation plus 0.07 %
 * for the float roundings here. An overflow to +inf only sends every lane to
 * the double/exact path. The SIMD set-up computes the same operations. */
#define SC_X_KS (6.11f * 0x1p-24f)
#define SC_X_CS (34.1f * 0x1p-48f)
SC_TRACE_INLINE void sc_exact_consts(const float m[3], float *xK, float *xc0)
{
    float S = (m[0] + m[1]) + m[2];
    *xK = fmaf(S, SC_X_KS, 0x1p-123f);    /* floors normal: FTZ|DAZ (exact_tri.c) */
    *xc0 = fmaf(S * S, SC_X_CS, 0x1p-121f);
}

/* Woop et al.'s axes: kz = the largest |d| component, kx and ky the other
 * two, swapped for d[kz] < 0 to keep the winding (matters only for
 * one-sided tests). */
SC_TRACE_INLINE void sc_shear_axes(const float d[3], int *kx_out, int *ky_out, int *kz_out)
{
    int kz = 0;
    if (fabsf(d[1]) > fabsf(d[kz])) kz = 1;
    if (fabsf(d[2]) > fabsf(d[kz])) kz = 2;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0) {
        int t = kx;
        kx = ky;
        ky = t;
    }
    *kx_out = kx, *ky_out = ky, *kz_out = kz;
}

/* root_lo/root_hi: the BVH's root box (ignored when it has none). */
SC_TRACE_INLINE void sc_ray_precompute(const sc_ray *r, sc_ray_pre *p, const float root_lo[3],
                                     const float root_hi[3])
{
    float mk[3];
    p->parallel = sc_ray_parallel(r);
    for (int k = 0; k < 3; k++) {
        p->rdp[k] = p->parallel ? 1.0f / r->dir[k] : 0.0f;
        p->org[k] = r->org[k];
        p->dir[k] = r->dir[k];
        float d = r->dir[k];
        if (fabsf(d) < SC_MIN_RCP_INPUT)
            d = copysignf(SC_MIN_RCP_INPUT, d);
        p->rd[k] = 1.0f / d;
        /* The pad, in float and mostly off the divide's path: with
         * m >= M(1 - u) and 5 % slack for the roundings of these few
         * operations, E >= 2u |r| M (1 + 3u) + 2.02u |fl(o rd)| + tiny, and
         * then fl(fl(o rd) + E) >= o rd + 2u |r| M (1 + 3u) + tiny. The tiny
         * terms are normal numbers (MIN = 2^-126) so that they hold with
         * gradual underflow and with MXCSR FTZ|DAZ (subnormal results and
         * operands read as 0) alike:
         *  - 2^-123 = 8 MIN in g, multiplied by |rd| (up to 1e18): a plane
         *    or origin coordinate that DAZ reads as 0 (< MIN each), and g's
         *    own underflow (< MIN), each shift a distance by < MIN |rd|;
         *  - m 2^-124: an rd that underflows (|d| > 2^126) is off by < M 2^-126
         *    in distance, flushed to 0 by FTZ entirely (|tau| <= M 2^-126);
         *  - 2^-122 = 16 MIN: underflow of o rd, of the pad, of fl(o rd) + E
         *    and of the slab FMA itself, < MIN each.
         * (tests/test_slab.c checks it against MPFR in both modes, on
         * coordinates near 1e-40.) */
        float m = sc_fmax(fabsf(root_lo[k] - p->org[k]), fabsf(root_hi[k] - p->org[k]));
        mk[k] = m;
        float g = fmaf(fabsf(p->org[k]), 0x1.0cp-23f, fmaf(m, 0x1.0cp-23f, 0x1p-123f));
        float pad = fmaf(fabsf(p->rd[k]), g, fmaf(m, 0x1p-124f, 0x1p-122f));
        float ord = p->org[k] * p->rd[k];
        p->ord_near[k] = ord + pad;
        p->ord_far[k] = ord - pad;
        int neg = signbit(p->rd[k]) != 0;
        p->near_row[k] = 2 * k + neg;
        p->far_row[k] = 2 * k + 1 - neg;
    }
    sc_exact_consts(mk, &p->xK, &p->xc0);
    p->tmin = r->tmin;
    p->tmax = r->tmax;
    const float *d = r->dir;
    int kx, ky, kz;
    sc_shear_axes(d, &kx, &ky, &kz);
    p->kx = kx, p->ky = ky, p->kz = kz;
    p->Sx = d[kx] / d[kz];
    p->Sy = d[ky] / d[kz];
    /* 1/d[kz] is rd[kz] unless that was clamped: one divide fewer */
    p->Sz = fabsf(d[kz]) >= SC_MIN_RCP_INPUT ? p->rd[kz] : 1.0f / d[kz];
}

/* The node test of non-parallel rays, the specification of the SIMD ones
 * (padding: sc_ray_precompute). Near distances are lower and far distances
 * upper bounds of the exact ones, so dist[i] is a lower bound of box i's
 * exact entry distance. */
SC_TRACE_INLINE unsigned sc_slab(const sc_ray_pre *p, const sc_bvh_node8 *node, float tmin, float tmax,
                                 float *dist)
{
    unsigned mask = 0;
    for (int i = 0; i < SC_BVH_N; i++) {
        float tn[3], tf[3];
        for (int k = 0; k < 3; k++) {
            tn[k] = fmaf(node->b[p->near_row[k]][i], p->rd[k], -p->ord_near[k]);
            tf[k] = fmaf(node->b[p->far_row[k]][i], p->rd[k], -p->ord_far[k]);
        }
        float a = sc_fmax(sc_fmax(tn[0], tn[1]), sc_fmax(tn[2], tmin));
        float b = sc_fmin(sc_fmin(tf[0], tf[1]), sc_fmin(tf[2], tmax));
        dist[i] = a;
        mask |= (unsigned)(a <= b) << i;
    }
    return mask;
}

/* The node test of parallel rays (Ize 2013 with IEEE infinities): a slab
 * distance is (p - o) * (1/d) with 1/d = +-inf for d = +-0; a ray in the
 * plane of a face gives 0 * inf = NaN, which the running max/min below
 * ignore (max(a, b) = a > b ? a : b returns b when a is NaN, like (v)maxps),
 * so the closed slab contains the ray, as it should. Rounding: the distance
 * carries three roundings (difference, 1/d, product), within the 2^-21
 * relative padding; SC_SLAB_PAR_EPS covers underflow. Empty slots
 * (lo = +inf, hi = -inf) still give an empty interval. */
#define SC_SLAB_DOWN (1.0f - 0x1p-21f)
#define SC_SLAB_UP (1.0f + 0x1p-21f)
#define SC_SLAB_PAR_EPS 0x1p-122f   /* normal: survives DAZ (16 MIN of underflow) */
SC_TRACE_INLINE unsigned sc_slab_par(const sc_ray_pre *p, const sc_bvh_node8 *node, float tmin, float tmax,
                                   float *dist)
{
    unsigned mask = 0;
    for (int i = 0; i < SC_BVH_N; i++) {
        float a = tmin, b = tmax;
        for (int k = 0; k < 3; k++) {
            float tn = (node->b[p->near_row[k]][i] - p->org[k]) * p->rdp[k];
            float tf = (node->b[p->far_row[k]][i] - p->org[k]) * p->rdp[k];
            a = sc_fmax(tn, a);
            b = sc_fmin(tf, b);
        }
        a = fmaf(a, SC_SLAB_DOWN, -SC_SLAB_PAR_EPS);
        b = fmaf(b, SC_SLAB_UP, SC_SLAB_PAR_EPS);
        dist[i] = a;
        mask |= (unsigned)(a <= b) << i;
    }
    return mask;
}

/* Woop et al. 2013, section 4: when an edge function is exactly zero in
 * float, all three are recomputed in double from the same float inputs. The
 * products of floats are exact in double, so U(a,b) = -U(b,a) still holds
 * and a neighbouring triangle sees the same decision. Returns 1 on a hit in
 * [tmin, tmax] and writes t and the barycentrics. */
static inline int sc_watertight_double(float Ax, float Ay, float Bx, float By, float Cx, float Cy,
                                       float Az, float Bz, float Cz, float tmin, float tmax,
                                       float *t, float *u, float *v)
{
    double U = (double)Cx * By - (double)Cy * Bx;
    double V = (double)Ax * Cy - (double)Ay * Cx;
    double W = (double)Bx * Ay - (double)By * Ax;
    if ((U < 0 || V < 0 || W < 0) && (U > 0 || V > 0 || W > 0))
        return 0;
    double det = U + V + W;
    if (det == 0)
        return 0;
    double T = U * Az + V * Bz + W * Cz;
    float tt = (float)(T / det);
    if (!(tt >= tmin && tt <= tmax))
        return 0;
    *t = tt;
    *u = (float)(V / det);
    *v = (float)(W / det);
    return 1;
}

typedef struct sc_stack_entry {
    uint64_t ref;
    float dist;
} sc_stack_entry;

/* Near-first order: the hit children sorted by entry distance (ties by slot),
 * all but the nearest pushed far-to-near; returns the nearest. The caller
 * passes at least two hit children. */
SC_TRACE_INLINE uint64_t sc_order_children(const sc_bvh_node8 *node, unsigned mask, const float *dist,
                                         sc_stack_entry *stack, int *sp)
{
    /* Two hit children are the most common case (primary and shadow rays
     * alike): one compare, no sort loop and its mispredicted exits. */
    const unsigned rest = mask & (mask - 1);
    if ((rest & (rest - 1)) == 0) {
        int a = __builtin_ctz(mask), b = __builtin_ctz(rest);
        if (dist[b] < dist[a]) {
            int t = a;
            a = b;
            b = t;
        }
        stack[*sp].ref = node->child[b];
        stack[*sp].dist = dist[b];
        (*sp)++;
        return node->child[a];
    }
    uint64_t ref[SC_BVH_N];
    float d[SC_BVH_N];
    int k = 0;
    while (mask) {
        int i = __builtin_ctz(mask);
        mask &= mask - 1;
        float di = dist[i];
        int j = k++;
        while (j > 0 && d[j - 1] > di) {
            d[j] = d[j - 1];
            ref[j] = ref[j - 1];
            j--;
        }
        d[j] = di;
        ref[j] = node->child[i];
    }
    for (int j = k - 1; j > 0; j--) {
        stack[*sp].ref = ref[j];
        stack[*sp].dist = d[j];
        (*sp)++;
    }
    return ref[0];
}

#endif

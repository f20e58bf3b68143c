/* The per-ray set-up every traversal kernel shares, so that all ISAs see
 * the same bits: validity, the clamped reciprocal direction and the slab
 * padding folded into per-ray constants (node_bvh8_slab.h says why it is
 * conservative), the watertight test's shear and the exact test's bound
 * constants.
 *
 * The arithmetic of every kernel is fixed by the scalar specification
 * (this file, node_bvh8_slab.h and the tri_*.h lane tests): no FMA where
 * the code does not write one (-ffp-contract=off), operations in the same
 * order, max(a,b) = a > b ? a : b like (v)maxps.
 */
#ifndef SPHERECULL_TRACE_RAY_SETUP_H
#define SPHERECULL_TRACE_RAY_SETUP_H

#include <float.h>
#include <math.h>
#include <stdint.h>

#include "spherecull/sc_prefilter.h"

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
 * every live ymm register (the ray's broadcasts). (docs/compare.md
 * measured 8 % of shadow-ray time for one such call). */
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

/* Without branches (& and | on the compares, |x| <= FLT_MAX for finite):
 * the top level checks every object ray it makes, one per instance visit.
 * Scalar on purpose: the rays it checks were mostly just written a float
 * at a time (object rays, a caller's ray), and one 16-byte load of them
 * would wait for those stores (docs/compare.md, twenty-second session). */
static inline int sc_ray_valid(const sc_ray *r)
{
    int ok = (r->tmin >= 0) & (r->tmax == r->tmax);
    for (int k = 0; k < 3; k++)
        ok &= (fabsf(r->org[k]) < SC_MAX_ORIGIN) & (fabsf(r->dir[k]) <= FLT_MAX);
    return ok & ((r->dir[0] != 0) | (r->dir[1] != 0) | (r->dir[2] != 0));
}

/* The valid lanes of a K-lane packet (K = 8 or 16; rows ox oy oz tmin dx
 * dy dz tmax, K floats each) as a mask; -1 if a valid lane's ray is
 * refused (sc_ray_valid). The specification of the levels' packet_valid
 * kernels. */
static inline int64_t sc_packet_valid_ref(const int32_t *valid, const float *rows, unsigned K)
{
    uint32_t lanes = 0, bad = 0;
    for (unsigned i = 0; i < K; i++) {
        const sc_ray r = { { rows[i], rows[K + i], rows[2 * K + i] }, rows[3 * K + i],
                           { rows[4 * K + i], rows[5 * K + i], rows[6 * K + i] }, rows[7 * K + i] };
        const uint32_t v = valid[i] != 0;
        lanes |= v << i;
        bad |= (v & (uint32_t)!sc_ray_valid(&r)) << i;
    }
    return bad ? (int64_t)-1 : (int64_t)lanes;
}

#if defined(__SSE2__)
#include <emmintrin.h>
/* sc_ray_valid on the ray's two halves in two registers (its own compares,
 * the same answers: test_slab), for the public single-ray calls: a
 * quarter of the instructions, and the kernel loads the same two halves
 * right after, so a ray just stored a float at a time makes no second
 * wait. */
static inline int sc_ray_valid_sse(const sc_ray *r)
{
    const __m128 a = _mm_loadu_ps(r->org), b = _mm_loadu_ps(r->dir);   /* org, tmin; dir, tmax */
    const __m128 sgn = _mm_set1_ps(-0.0f), zero = _mm_setzero_ps();
    const int org = _mm_movemask_ps(_mm_cmplt_ps(_mm_andnot_ps(sgn, a), _mm_set1_ps(SC_MAX_ORIGIN))) & 7;
    const int tmin = _mm_movemask_ps(_mm_cmpge_ps(a, zero)) & 8;
    const int dir = _mm_movemask_ps(_mm_cmple_ps(_mm_andnot_ps(sgn, b), _mm_set1_ps(FLT_MAX))) & 7;
    const int tmax = _mm_movemask_ps(_mm_cmpord_ps(b, b)) & 8;
    const int nonzero = _mm_movemask_ps(_mm_cmpneq_ps(b, zero)) & 7;
    return ((org | tmin) == 15) & ((dir | tmax) == 15) & (nonzero != 0);
}
#else
#define sc_ray_valid_sse sc_ray_valid
#endif

/* The direction's sign bits, bit k for d_k (-0 included): the ray's
 * octant, read as three floats. */
SC_TRACE_INLINE unsigned sc_ray_signs(const sc_ray *r)
{
    return (unsigned)(signbit(r->dir[0]) != 0) | (unsigned)(signbit(r->dir[1]) != 0) << 1 |
           (unsigned)(signbit(r->dir[2]) != 0) << 2;
}

/* 1 iff the ray must take the parallel node test. */
SC_TRACE_INLINE int sc_ray_parallel(const sc_ray *r)
{
    return !(fabsf(r->dir[0]) >= SC_MIN_RCP_INPUT && fabsf(r->dir[1]) >= SC_MIN_RCP_INPUT &&
             fabsf(r->dir[2]) >= SC_MIN_RCP_INPUT);
}

/* The exact test's per-ray bound constants (derivation in tri_exact.c) from
 * m_k = fl(max |root box - o| along axis k): S = fl(m_0 + m_1 + m_2) is at
 * least (1 - 3u) times the largest L1 distance of a vertex from the origin,
 * and K and c0 carry the factor (1 + 2^-10) of the derivation plus 0.07 %
 * for the float roundings here. An overflow to +inf only sends every lane to
 * the double/exact path. The SIMD set-up computes the same operations. */
#define SC_EXACT_KS (6.11f * 0x1p-24f)
#define SC_EXACT_CS (34.1f * 0x1p-48f)
/* K and c0 from S; the floors are normal: FTZ|DAZ (tri_exact.c). */
SC_TRACE_INLINE float sc_exact_k(float S) { return fmaf(S, SC_EXACT_KS, 0x1p-123f); }
SC_TRACE_INLINE float sc_exact_c0(float S) { return fmaf(S * S, SC_EXACT_CS, 0x1p-121f); }
SC_TRACE_INLINE void sc_exact_consts(const float m[3], float *xK, float *xc0)
{
    float S = (m[0] + m[1]) + m[2];
    *xK = sc_exact_k(S);
    *xc0 = sc_exact_c0(S);
}

/* The traversal's OCT parameter: 0..7 a non-parallel ray of that octant
 * (the near and far rows of the node test are constants), SC_OCT_ANY a
 * non-parallel ray of any octant (rows read per ray), -2 a parallel ray,
 * -1 decided per ray (the counting kernels). */
#define SC_OCT_ANY 8

/* Woop et al.'s axes: kz = the largest |d| component (the first of tied
 * ones), kx and ky the other two, swapped for d[kz] < 0 to keep the winding
 * (matters only for one-sided tests). For incoherent rays the axes are
 * random, so there must be no branch on them: the choice goes through
 * tables indexed by the compare bits. (Selects were not enough: the
 * compiler turned them, with the loads at the chosen axes that follow, into
 * one branch per case.) ray_setup_x86.h makes the same choice in vectors. */
/* kz from the compare bits a1 > a0 (bit 0), a2 > a0 (bit 1), a2 > a1 (bit 2) */
static const unsigned char sc_shear_kz_of[8] = { 0, 1, 2, 1, 0, 2, 2, 2 };
/* [2 kz + (d[kz] < 0)]: kx, ky, kz, and 3 (a permute control for the SIMD
 * set-up, whose lane 3 is not used) */
static const int32_t sc_shear_axes_of[6][4] __attribute__((aligned(16))) = {
    { 1, 2, 0, 3 }, { 2, 1, 0, 3 }, { 2, 0, 1, 3 }, { 0, 2, 1, 3 }, { 0, 1, 2, 3 }, { 1, 0, 2, 3 },
};

SC_TRACE_INLINE void sc_shear_axes(const float d[3], int *kx_out, int *ky_out, int *kz_out)
{
    const float a0 = fabsf(d[0]), a1 = fabsf(d[1]), a2 = fabsf(d[2]);
    const unsigned gt = (unsigned)(a1 > a0) | (unsigned)(a2 > a0) << 1 | (unsigned)(a2 > a1) << 2;
    const int kz = sc_shear_kz_of[gt];
    const int32_t *ax = sc_shear_axes_of[2 * kz + (d[kz] < 0)];
    *kx_out = ax[0];
    *ky_out = ax[1];
    *kz_out = kz;
}

/* What the watertight and Moller lane tests read (origin, direction, range,
 * shear); on its own for callers that test triangles without a BVH (the
 * Embree user-geometry back end), and the first step of sc_ray_precompute. */
SC_TRACE_INLINE void sc_ray_precompute_shear(const sc_ray *r, sc_ray_pre *p)
{
    for (int k = 0; k < 3; k++)
        p->org[k] = r->org[k], p->dir[k] = r->dir[k];
    p->tmin = r->tmin;
    p->tmax = r->tmax;
    const float *d = r->dir;
    int kx, ky, kz;
    sc_shear_axes(d, &kx, &ky, &kz);
    p->kx = kx, p->ky = ky, p->kz = kz;
    p->Sx = d[kx] / d[kz];
    p->Sy = d[ky] / d[kz];
    p->Sz = 1.0f / d[kz];
}

/* The padded offsets b of the FMA slab test (node_bvh8_slab.h) on one
 * axis: origin o, rd = fl(1/d), m at least (1 - u) times the largest
 * |plane - o| of the tree on that axis (M). The pad is in float and mostly
 * off the divide's path: with 5 % slack for the roundings of these few
 * operations, E >= 2u |r| M (1 + 3u) + 2.02u |fl(o rd)| + tiny, and then
 * fl(fl(o rd) + E) >= o rd + 2u |r| M (1 + 3u) + tiny. The tiny terms are
 * normal numbers (MIN = 2^-126) so that they hold with gradual underflow
 * and with MXCSR FTZ|DAZ (subnormal results and operands read as 0) alike:
 *  - 2^-123 = 8 MIN in g, multiplied by |rd| (up to 1e18): a plane or
 *    origin coordinate that DAZ reads as 0 (< MIN each), and g's own
 *    underflow (< MIN), each shift a distance by < MIN |rd|;
 *  - m 2^-124: an rd that underflows (|d| > 2^126) is off by < M 2^-126 in
 *    distance, flushed to 0 by FTZ entirely (|tau| <= M 2^-126);
 *  - 2^-122 = 16 MIN: underflow of o rd, of the pad, of fl(o rd) + E and
 *    of the slab FMA itself, < MIN each.
 * (tests/test_slab.c checks it against MPFR in both modes, on coordinates
 * near 1e-40.) The SIMD set-ups compute the same operations. */
SC_TRACE_INLINE void sc_slab_offsets(float o, float rd, float m, float *near, float *far)
{
    const float g = fmaf(fabsf(o), 0x1.0cp-23f, fmaf(m, 0x1.0cp-23f, 0x1p-123f));
    const float pad = fmaf(fabsf(rd), g, fmaf(m, 0x1p-124f, 0x1p-122f));
    const float ord = o * rd;
    *near = ord + pad;
    *far = ord - pad;
}

/* root_lo/root_hi: the BVH's root box (ignored when it has none). */
SC_TRACE_INLINE void sc_ray_precompute(const sc_ray *r, sc_ray_pre *p, const float root_lo[3],
                                     const float root_hi[3])
{
    float mk[3];
    sc_ray_precompute_shear(r, p);
    p->parallel = sc_ray_parallel(r);
    for (int k = 0; k < 3; k++) {
        p->rdp[k] = p->parallel ? 1.0f / r->dir[k] : 0.0f;
        float d = r->dir[k];
        if (fabsf(d) < SC_MIN_RCP_INPUT)
            d = copysignf(SC_MIN_RCP_INPUT, d);
        p->rd[k] = 1.0f / d;
        const float m = sc_fmax(fabsf(root_lo[k] - p->org[k]), fabsf(root_hi[k] - p->org[k]));
        mk[k] = m;
        sc_slab_offsets(p->org[k], p->rd[k], m, &p->ord_near[k], &p->ord_far[k]);
        int neg = signbit(p->rd[k]) != 0;
        p->near_row[k] = 2 * k + neg;
        p->far_row[k] = 2 * k + 1 - neg;
    }
    sc_exact_consts(mk, &p->xK, &p->xc0);
}

#endif

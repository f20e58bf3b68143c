/* The 8-wide node test on 8 lanes in one ymm register: the operations of
 * node_bvh8_slab.h (sc_slab with the padding folded into the per-ray
 * constants, one FMA per plane; sc_slab_par for parallel rays).
 * Part of an x86 traversal translation unit (traverse_bvh8_x86.h), which
 * defines SC_TARGET (the ISA's target attribute) and SC_X86_AVX512 first.
 */
#ifndef SPHERECULL_TRACE_NODE_BVH8_SLAB_X86_H
#define SPHERECULL_TRACE_NODE_BVH8_SLAB_X86_H

#include "node_bvh8_slab.h"
#include "ray_setup_x86.h"

SC_X86_INLINE unsigned
node_test(const trace_ctx *c, const sc_bvh_node8 *node, float tmin, float tmax, float *dist,
               const int OCT, const int WANT_DIST)
{
    const char *nb = (const char *)node;
    /* With the ray octant known at compile time (0 <= OCT < SC_OCT_ANY) the
     * near and far rows are fixed offsets: no per-ray offsets in registers. */
#define ROWB(row) ((size_t)(row) * SC_BVH_N * sizeof(float))
#define FIXED (OCT >= 0 && OCT < SC_OCT_ANY)
#define NEAR(k) (FIXED ? ROWB(2 * (k) + ((OCT >> (k)) & 1)) : c->near_off[k])
#define FAR(k) (FIXED ? ROWB(2 * (k) + 1 - ((OCT >> (k)) & 1)) : c->far_off[k])
#define ROW(off) _mm256_load_ps((const float *)(const void *)(nb + (off)))
    __m256 tnx = _mm256_fmsub_ps(ROW(NEAR(0)), c->rd[0], c->ordn[0]);
    __m256 tny = _mm256_fmsub_ps(ROW(NEAR(1)), c->rd[1], c->ordn[1]);
    __m256 tnz = _mm256_fmsub_ps(ROW(NEAR(2)), c->rd[2], c->ordn[2]);
    __m256 tfx = _mm256_fmsub_ps(ROW(FAR(0)), c->rd[0], c->ordf[0]);
    __m256 tfy = _mm256_fmsub_ps(ROW(FAR(1)), c->rd[1], c->ordf[1]);
    __m256 tfz = _mm256_fmsub_ps(ROW(FAR(2)), c->rd[2], c->ordf[2]);
#undef ROW
#undef NEAR
#undef FAR
#undef FIXED
#undef ROWB
    (void)tmin;
    /* The maximum and minimum as signed integers (one cycle each, against
     * four for maxps/minps, on the path from a node's loads to its child's),
     * as Embree does; ctx_set_slab says why that gives the float test's
     * answer. The compare stays a float compare. */
#define I(x) _mm256_castps_si256(x)
    const __m256i tmaxi = I(_mm256_set1_ps(tmax + 0.0f));   /* -0 as +0 */
    const __m256 tn = _mm256_castsi256_ps(
        _mm256_max_epi32(_mm256_max_epi32(I(tnx), I(tny)), _mm256_max_epi32(I(tnz), I(c->tmin))));
    const __m256 tf = _mm256_castsi256_ps(_mm256_min_epi32(_mm256_min_epi32(I(tfx), I(tfy)), _mm256_min_epi32(I(tfz), tmaxi)));
#undef I
    if (WANT_DIST)
        _mm256_store_ps(dist, tn);
#if SC_X86_AVX512
    return (unsigned)_mm256_cmp_ps_mask(tn, tf, _CMP_LE_OQ);
#else
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ));
#endif
}

/* sc_slab_par on 8 children: (v)maxps/(v)minps return the second operand
 * when the first is NaN, as sc_fmax/sc_fmin do. */
SC_X86_INLINE unsigned
node_test_par(const trace_ctx *c, const sc_bvh_node8 *node, float tmin, float tmax, float *dist)
{
    const char *nb = (const char *)node;
    __m256 a = c->tmin, b = _mm256_set1_ps(tmax);
    (void)tmin;
    for (int k = 0; k < 3; k++) {
        __m256 n = _mm256_load_ps((const float *)(const void *)(nb + c->near_off[k]));
        __m256 f = _mm256_load_ps((const float *)(const void *)(nb + c->far_off[k]));
        a = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(n, c->org[k]), c->rdp[k]), a);
        b = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(f, c->org[k]), c->rdp[k]), b);
    }
    a = _mm256_fmsub_ps(a, _mm256_set1_ps(SC_SLAB_DOWN), _mm256_set1_ps(SC_SLAB_PAR_EPS));
    b = _mm256_fmadd_ps(b, _mm256_set1_ps(SC_SLAB_UP), _mm256_set1_ps(SC_SLAB_PAR_EPS));
    _mm256_store_ps(dist, a);
#if SC_X86_AVX512
    return (unsigned)_mm256_cmp_ps_mask(a, b, _CMP_LE_OQ);
#else
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ));
#endif
}


#endif

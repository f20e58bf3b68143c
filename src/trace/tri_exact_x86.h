/* The exact test's float filter (tri_exact.h) on 8 lanes of a leaf block,
 * the operations of sc_tri_exact_filter.
 * Part of an x86 traversal translation unit (traverse_bvh8_x86.h), which
 * defines SC_TARGET (the ISA's target attribute) and SC_X86_AVX512 first.
 */
#ifndef SPHERECULL_TRACE_TRI_EXACT_X86_H
#define SPHERECULL_TRACE_TRI_EXACT_X86_H

#include "tri_exact.h"
#include "tri_watertight_x86.h"

/* The exact test's float filter on 8 lanes, the operations of sc_tri_exact_filter:
 * returns the lanes left to sc_exact_resolve; te = -1 where the edges are not
 * all certain. */
SC_X86_INLINE unsigned
tri_exact8(const trace_ctx *c, const float *rows, unsigned W, unsigned h, unsigned live,
            float tmin, float tmax, float *t, float *te, float *un, float *vn, float *den)
{
    const __m256 Sz = c->Sz;
    tri_sheared8 sh;
    tri_shear8(c, rows, W, h, &sh);
    const __m256 Ax = sh.Ax, Ay = sh.Ay, Bx = sh.Bx, By = sh.By, Cx = sh.Cx, Cy = sh.Cy;
    const __m256 Akz = sh.Akz, Bkz = sh.Bkz, Ckz = sh.Ckz;
    const __m256 U = sh.U, V = sh.V, Wv = sh.W;
    const __m256 sgn = _mm256_set1_ps(-0.0f);
#define ABS(x) _mm256_andnot_ps(sgn, (x))
    __m256 hA = _mm256_add_ps(ABS(Ax), ABS(Ay));
    __m256 hB = _mm256_add_ps(ABS(Bx), ABS(By));
    __m256 hC = _mm256_add_ps(ABS(Cx), ABS(Cy));
    const __m256 hsum = _mm256_add_ps(_mm256_add_ps(hA, hB), hC);
    __m256 E1 = _mm256_fmadd_ps(c->xK, hsum, c->xc0);
    __m256 nE1 = _mm256_xor_ps(E1, sgn);
#if SC_X86_AVX512
    __mmask8 pU = _mm256_cmp_ps_mask(U, E1, _CMP_GT_OQ), nU = _mm256_cmp_ps_mask(U, nE1, _CMP_LT_OQ);
    __mmask8 pV = _mm256_cmp_ps_mask(V, E1, _CMP_GT_OQ), nV = _mm256_cmp_ps_mask(V, nE1, _CMP_LT_OQ);
    __mmask8 pW = _mm256_cmp_ps_mask(Wv, E1, _CMP_GT_OQ), nW = _mm256_cmp_ps_mask(Wv, nE1, _CMP_LT_OQ);
    unsigned miss = (unsigned)((pU | pV | pW) & (nU | nV | nW));
    unsigned inside = (unsigned)((pU & pV & pW) | (nU & nV & nW));
#else
    __m256 pU = _mm256_cmp_ps(U, E1, _CMP_GT_OQ), nU = _mm256_cmp_ps(U, nE1, _CMP_LT_OQ);
    __m256 pV = _mm256_cmp_ps(V, E1, _CMP_GT_OQ), nV = _mm256_cmp_ps(V, nE1, _CMP_LT_OQ);
    __m256 pW = _mm256_cmp_ps(Wv, E1, _CMP_GT_OQ), nW = _mm256_cmp_ps(Wv, nE1, _CMP_LT_OQ);
    unsigned miss = mask8(_mm256_and_ps(_mm256_or_ps(_mm256_or_ps(pU, pV), pW),
                                             _mm256_or_ps(_mm256_or_ps(nU, nV), nW)));
    unsigned inside = mask8(_mm256_or_ps(_mm256_and_ps(_mm256_and_ps(pU, pV), pW),
                                              _mm256_and_ps(_mm256_and_ps(nU, nV), nW)));
#endif
    live &= ~miss;
    unsigned open = live & ~inside;
    unsigned in = live & inside;
    unsigned sure = 0;
    if (in) {
        __m256 Az = _mm256_mul_ps(Sz, Akz), Bz = _mm256_mul_ps(Sz, Bkz), Cz = _mm256_mul_ps(Sz, Ckz);
        __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), Wv);
        __m256 T = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(U, Az), _mm256_mul_ps(V, Bz)), _mm256_mul_ps(Wv, Cz));
        /* one division: tt and the bound both use 1/det */
        __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
        __m256 tt = _mm256_mul_ps(T, inv);
        __m256 zmax = _mm256_max_ps(_mm256_max_ps(Az, Bz), Cz), zmin = _mm256_min_ps(_mm256_min_ps(Az, Bz), Cz);
        __m256 Z = _mm256_max_ps(zmax, _mm256_xor_ps(zmin, sgn));
        __m256 R = _mm256_mul_ps(_mm256_sub_ps(zmax, zmin), _mm256_set1_ps(0.5f));
        const __m256 zt = _mm256_fmadd_ps(Z, _mm256_set1_ps(SC_EXACT_K15U),
                                          _mm256_fmadd_ps(ABS(tt), _mm256_set1_ps(SC_EXACT_K3U),
                                                          _mm256_set1_ps(SC_EXACT_FLOOR_T)));
        const __m256 k202 = _mm256_set1_ps(SC_EXACT_K202), floor_n = _mm256_set1_ps(SC_EXACT_FLOOR_N);
        /* sc_exact_local_bound */
        const __m256 sxy = _mm256_add_ps(_mm256_add_ps(_mm256_set1_ps(1.0f), ABS(c->Sx)), ABS(c->Sy));
        const __m256 S = _mm256_max_ps(
            _mm256_max_ps(_mm256_fmadd_ps(sxy, ABS(Akz), hA), _mm256_fmadd_ps(sxy, ABS(Bkz), hB)),
            _mm256_fmadd_ps(sxy, ABS(Ckz), hC));
        const __m256 K =
            _mm256_min_ps(_mm256_fmadd_ps(S, _mm256_set1_ps(SC_EXACT_KS), _mm256_set1_ps(0x1p-123f)), c->xK);
        const __m256 c0 = _mm256_min_ps(
            _mm256_fmadd_ps(_mm256_mul_ps(S, S), _mm256_set1_ps(SC_EXACT_CS), _mm256_set1_ps(0x1p-121f)), c->xc0);
        const __m256 El = _mm256_fmadd_ps(_mm256_add_ps(K, K), hsum, _mm256_mul_ps(c0, _mm256_set1_ps(3.0f)));
        const __m256 e = _mm256_fmadd_ps(_mm256_fmadd_ps(R, _mm256_mul_ps(El, k202), floor_n), ABS(inv), zt);
        unsigned fin = mask8(_mm256_and_ps(_mm256_cmp_ps(e, _mm256_set1_ps(INFINITY), _CMP_LT_OQ),
                                           _mm256_cmp_ps(ABS(inv), _mm256_set1_ps(0x1p-126f), _CMP_GE_OQ)));
        unsigned out = mask8(_mm256_or_ps(_mm256_cmp_ps(_mm256_sub_ps(tt, e), _mm256_set1_ps(tmax), _CMP_GT_OQ),
                                               _mm256_cmp_ps(_mm256_add_ps(tt, e), _mm256_set1_ps(tmin), _CMP_LT_OQ)));
        open |= in & ~fin;
        sure = in & fin & ~out;
        if (sure) {
            _mm256_storeu_ps(t + h, tt);
            _mm256_storeu_ps(te + h, e);
            _mm256_storeu_ps(un + h, V);
            _mm256_storeu_ps(vn + h, Wv);
            _mm256_storeu_ps(den + h, inv);
        }
    }
#undef ABS
    /* te = -1 marks the lanes whose edges sc_exact_resolve must settle */
    for (unsigned m = open; m; m &= m - 1)
        te[h + (unsigned)__builtin_ctz(m)] = -1;
    return sure | open;
}


#endif

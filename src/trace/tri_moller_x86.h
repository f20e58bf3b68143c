/* Moller-Trumbore (tri_moller.h) on 8 lanes of a leaf block.
 * Part of an x86 traversal translation unit (traverse_bvh8_x86.h), which
 * defines SC_TARGET (the ISA's target attribute) and SC_X86_AVX512 first.
 */
#ifndef SPHERECULL_TRACE_TRI_MOLLER_X86_H
#define SPHERECULL_TRACE_TRI_MOLLER_X86_H

#include "ray_setup_x86.h"
#include "tri_moller.h"

/* Moller-Trumbore on 8 lanes, the operations of sc_tri_moller. */
SC_X86_INLINE unsigned
tri_moller8(const trace_ctx *c, const float *rows, unsigned W, unsigned h, unsigned live,
             float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
#define LD(j, k) leaf_row8(rows + (3 * (j) + (k)) * W, W, h)
    __m256 v0[3], e1[3], e2[3], s[3], d[3];
    for (int k = 0; k < 3; k++) {
        v0[k] = LD(0, k);
        e1[k] = _mm256_sub_ps(LD(1, k), v0[k]);
        e2[k] = _mm256_sub_ps(LD(2, k), v0[k]);
        s[k] = _mm256_sub_ps(_mm256_set1_ps(c->org_s[k]), v0[k]);
        d[k] = _mm256_set1_ps(c->dir_s[k]);
    }
#undef LD
#define MUL _mm256_mul_ps
#define SUB _mm256_sub_ps
#define ADD _mm256_add_ps
    __m256 px = SUB(MUL(d[1], e2[2]), MUL(d[2], e2[1]));
    __m256 py = SUB(MUL(d[2], e2[0]), MUL(d[0], e2[2]));
    __m256 pz = SUB(MUL(d[0], e2[1]), MUL(d[1], e2[0]));
    __m256 det = ADD(ADD(MUL(e1[0], px), MUL(e1[1], py)), MUL(e1[2], pz));
    __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    __m256 u = MUL(ADD(ADD(MUL(s[0], px), MUL(s[1], py)), MUL(s[2], pz)), inv);
    __m256 qx = SUB(MUL(s[1], e1[2]), MUL(s[2], e1[1]));
    __m256 qy = SUB(MUL(s[2], e1[0]), MUL(s[0], e1[2]));
    __m256 qz = SUB(MUL(s[0], e1[1]), MUL(s[1], e1[0]));
    __m256 v = MUL(ADD(ADD(MUL(d[0], qx), MUL(d[1], qy)), MUL(d[2], qz)), inv);
    __m256 tt = MUL(ADD(ADD(MUL(e2[0], qx), MUL(e2[1], qy)), MUL(e2[2], qz)), inv);
    const __m256 zero = _mm256_setzero_ps();
    __m256 ok = _mm256_and_ps(_mm256_cmp_ps(det, zero, _CMP_NEQ_UQ), _mm256_cmp_ps(u, zero, _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(v, zero, _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(ADD(u, v), _mm256_set1_ps(1.0f), _CMP_LE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(tt, _mm256_set1_ps(tmin), _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(tt, _mm256_set1_ps(tmax), _CMP_LE_OQ));
#undef MUL
#undef SUB
#undef ADD
    unsigned hm = mask8(ok) & live;
    if (hm) {
        _mm256_storeu_ps(t + h, tt);
        _mm256_storeu_ps(un + h, u);
        _mm256_storeu_ps(vn + h, v);
        _mm256_storeu_ps(den + h, _mm256_set1_ps(1.0f));
    }
    return hm;
}


#endif

/* The watertight test (tri_watertight.h) on 8 lanes of a leaf block, with
 * the operations of sc_tri_shear and sc_tri_watertight, so every lane has
 * the bits of the scalar specification.
 * Part of an x86 traversal translation unit (traverse_bvh8_x86.h), which
 * defines SC_TARGET (the ISA's target attribute) and SC_X86_AVX512 first.
 */
#ifndef SPHERECULL_TRACE_TRI_WATERTIGHT_X86_H
#define SPHERECULL_TRACE_TRI_WATERTIGHT_X86_H

#include "ray_setup_x86.h"
#include "tri_watertight.h"

/* Lanes h..h+7 of a leaf block in the ray's sheared frame and their edge
 * functions: the common first half of the watertight and the exact test,
 * which must compute the same bits (the operations of sc_tri_shear). */
typedef struct tri_sheared8 {
    __m256 Ax, Ay, Bx, By, Cx, Cy, Akz, Bkz, Ckz, U, V, W;
} tri_sheared8;

SC_X86_INLINE void
tri_shear8(const trace_ctx *c, const float *rows, unsigned W, unsigned h, tri_sheared8 *s)
{
    const __m256 okx = c->okx, oky = c->oky, okz = c->okz;
    const __m256 Sx = c->Sx, Sy = c->Sy;
    /* The nine rows as two byte offsets each: vertex j's rows start 3W
     * floats apart, axis k's row is k W floats into them. Written as
     * (3j + k) W per row, the run-time width and axes cost an imul and a
     * move per row (35 instructions a leaf); this way three products. */
    const size_t W4 = (size_t)W * sizeof(float);
    const char *v0 = (const char *)(const void *)(rows + h), *v1 = v0 + 3 * W4, *v2 = v1 + 3 * W4;
    const size_t ox = (size_t)c->kx * W4, oy = (size_t)c->ky * W4, oz = (size_t)c->kz * W4;
#define LD(v, o) leaf_row8((const float *)(const void *)((v) + (o)), W, 0)
    __m256 Akz = _mm256_sub_ps(LD(v0, oz), okz);
    __m256 Bkz = _mm256_sub_ps(LD(v1, oz), okz);
    __m256 Ckz = _mm256_sub_ps(LD(v2, oz), okz);
    __m256 Ax = _mm256_sub_ps(_mm256_sub_ps(LD(v0, ox), okx), _mm256_mul_ps(Sx, Akz));
    __m256 Ay = _mm256_sub_ps(_mm256_sub_ps(LD(v0, oy), oky), _mm256_mul_ps(Sy, Akz));
    __m256 Bx = _mm256_sub_ps(_mm256_sub_ps(LD(v1, ox), okx), _mm256_mul_ps(Sx, Bkz));
    __m256 By = _mm256_sub_ps(_mm256_sub_ps(LD(v1, oy), oky), _mm256_mul_ps(Sy, Bkz));
    __m256 Cx = _mm256_sub_ps(_mm256_sub_ps(LD(v2, ox), okx), _mm256_mul_ps(Sx, Ckz));
    __m256 Cy = _mm256_sub_ps(_mm256_sub_ps(LD(v2, oy), oky), _mm256_mul_ps(Sy, Ckz));
#undef LD
    s->Ax = Ax, s->Ay = Ay, s->Bx = Bx, s->By = By, s->Cx = Cx, s->Cy = Cy;
    s->Akz = Akz, s->Bkz = Bkz, s->Ckz = Ckz;
    s->U = _mm256_sub_ps(_mm256_mul_ps(Cx, By), _mm256_mul_ps(Cy, Bx));
    s->V = _mm256_sub_ps(_mm256_mul_ps(Ax, Cy), _mm256_mul_ps(Ay, Cx));
    s->W = _mm256_sub_ps(_mm256_mul_ps(Bx, Ay), _mm256_mul_ps(By, Ax));
}

/* Watertight test of 8 lanes; returns the hit mask (bit 0 = lane h). */
SC_X86_INLINE unsigned
tri_watertight8(const trace_ctx *c, const float *rows, unsigned W, unsigned h, unsigned live,
                 float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
    const __m256 Sz = c->Sz;
    tri_sheared8 sh;
    tri_shear8(c, rows, W, h, &sh);
    const __m256 Ax = sh.Ax, Ay = sh.Ay, Bx = sh.Bx, By = sh.By, Cx = sh.Cx, Cy = sh.Cy;
    const __m256 Akz = sh.Akz, Bkz = sh.Bkz, Ckz = sh.Ckz;
    const __m256 U = sh.U, V = sh.V, Wv = sh.W;
    const __m256 zero = _mm256_setzero_ps();
    __m256 neg = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_LT_OQ), _mm256_cmp_ps(V, zero, _CMP_LT_OQ)),
                              _mm256_cmp_ps(Wv, zero, _CMP_LT_OQ));
    __m256 pos = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_GT_OQ), _mm256_cmp_ps(V, zero, _CMP_GT_OQ)),
                              _mm256_cmp_ps(Wv, zero, _CMP_GT_OQ));
    __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), Wv);
    __m256 ok = _mm256_andnot_ps(_mm256_and_ps(neg, pos), _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ));
    __m256 zr = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_EQ_OQ), _mm256_cmp_ps(V, zero, _CMP_EQ_OQ)),
                             _mm256_cmp_ps(Wv, zero, _CMP_EQ_OQ));
    unsigned zmask = mask8(zr) & live;
    if (__builtin_expect(zmask != 0, 0)) {
        /* two equal sheared vertices: det is exactly 0 in float and in
         * sc_watertight_double alike (traverse_bvh8_packet.h says why), so
         * those lanes cannot hit; CAD meshes have such triangles */
#define EQ2(P, Q) _mm256_and_ps(_mm256_cmp_ps(P##x, Q##x, _CMP_EQ_OQ), _mm256_cmp_ps(P##y, Q##y, _CMP_EQ_OQ))
        zmask &= ~mask8(_mm256_or_ps(_mm256_or_ps(EQ2(A, B), EQ2(B, C)), EQ2(A, C)));
#undef EQ2
    }
    unsigned cand = mask8(ok) & live & ~zmask;
    unsigned hm = 0;
    __m256 Az = _mm256_mul_ps(Sz, Akz), Bz = _mm256_mul_ps(Sz, Bkz), Cz = _mm256_mul_ps(Sz, Ckz);
    if (cand) {
        __m256 T = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(U, Az), _mm256_mul_ps(V, Bz)), _mm256_mul_ps(Wv, Cz));
        __m256 tt = _mm256_div_ps(T, det);
        (void)tmin;
        __m256 in = _mm256_and_ps(_mm256_cmp_ps(tt, c->tmin, _CMP_GE_OQ),
                                  _mm256_cmp_ps(tt, _mm256_set1_ps(tmax), _CMP_LE_OQ));
        hm = mask8(in) & cand;
        if (hm) {
            _mm256_storeu_ps(t + h, tt);
            _mm256_storeu_ps(un + h, V);
            _mm256_storeu_ps(vn + h, Wv);
            _mm256_storeu_ps(den + h, det);
        }
    }
    if (__builtin_expect(zmask != 0, 0)) {
        float ax[8], ay[8], bx[8], by[8], cx[8], cy[8], az[8], bz[8], cz[8];
        _mm256_storeu_ps(ax, Ax), _mm256_storeu_ps(ay, Ay), _mm256_storeu_ps(bx, Bx);
        _mm256_storeu_ps(by, By), _mm256_storeu_ps(cx, Cx), _mm256_storeu_ps(cy, Cy);
        _mm256_storeu_ps(az, Az), _mm256_storeu_ps(bz, Bz), _mm256_storeu_ps(cz, Cz);
        for (unsigned m = zmask; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            float u, v;
            if (sc_watertight_double(ax[i], ay[i], bx[i], by[i], cx[i], cy[i], az[i], bz[i], cz[i],
                                     tmin, tmax, &t[h + i], &u, &v)) {
                un[h + i] = u, vn[h + i] = v, den[h + i] = 1;
                hm |= 1u << i;
            }
        }
    }
    return hm;
}


#endif

/* AVX-512 (F, VL, DQ) kernels: 16 float / 8 double lanes, k-register masks,
 * hardware gathers for the indexed float input. */
#if defined(__x86_64__) || defined(__i386__)
#include <float.h>
#include <math.h>

#define SC_VEC_F32X4
#define SC_VEC_F32X8
#define SC_VEC_F32X16
#define SC_VEC_F64X8
#include "simd_vec.h"
#include "sphere_kernels.h"

#define ATTR SC_ATTR_AVX512

typedef struct { f32x16_t x, y, z; } gather_v3_avx512;

static inline ATTR uint32_t load_indexed_avx512(const sc_tri_source_f *src, size_t first, void *out)
{
    gather_v3_avx512 *P = out;
    const __m512i lane3 = _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 33, 36, 39, 42, 45);
    const __m512i count = _mm512_set1_epi32((int)src->vertex_count);
    __mmask16 bad = 0;
    for (int k = 0; k < 3; k++) {
        __m512i idx = _mm512_i32gather_epi32(lane3, (const int *)(src->indices + 3 * first + (size_t)k), 4);
        __mmask16 ok = _mm512_cmplt_epu32_mask(idx, count);
        bad |= (__mmask16)~ok;
        idx = _mm512_maskz_mov_epi32(ok, idx);
        __m512i idx3 = _mm512_add_epi32(idx, _mm512_add_epi32(idx, idx));
        P[k].x = f32x16_gather3(src->vertices, idx3, 0);
        P[k].y = f32x16_gather3(src->vertices, idx3, 1);
        P[k].z = f32x16_gather3(src->vertices, idx3, 2);
    }
    return bad;
}

/* The same 16 triangles without gathers (slow on current AMD and Intel
 * cores alike): one 16-byte load per vertex (x, y, z and the next float),
 * four vertices to a 512-bit register, then a 4x4 transpose within each
 * 128-bit block. The fourth float read belongs to the next vertex, so this
 * path needs every index <= vertex_count - 2; otherwise the gathers. */
static inline ATTR __attribute__((always_inline)) uint32_t load_indexed_rows_avx512(const sc_tri_source_f *src,
                                                                                    size_t first, void *out)
{
    const uint32_t *ix = src->indices + 3 * first;
    const __m512i last = _mm512_set1_epi32((int)(src->vertex_count - 1));
    __mmask16 inner = _mm512_cmplt_epu32_mask(_mm512_loadu_si512(ix), last) &
                      _mm512_cmplt_epu32_mask(_mm512_loadu_si512(ix + 16), last) &
                      _mm512_cmplt_epu32_mask(_mm512_loadu_si512(ix + 32), last);
    if (__builtin_expect(inner != 0xffff, 0))
        return load_indexed_avx512(src, first, out);
    gather_v3_avx512 *P = out;
    const float *v = src->vertices;
    for (int k = 0; k < 3; k++) {
        __m512 R[4];
        for (int j = 0; j < 4; j++) {
            /* Block b of R[j]: vertex k of triangle 4b + j. */
            __m512 r = _mm512_castps128_ps512(_mm_loadu_ps(v + 3 * (size_t)ix[3 * j + k]));
            r = _mm512_insertf32x4(r, _mm_loadu_ps(v + 3 * (size_t)ix[3 * (4 + j) + k]), 1);
            r = _mm512_insertf32x4(r, _mm_loadu_ps(v + 3 * (size_t)ix[3 * (8 + j) + k]), 2);
            R[j] = _mm512_insertf32x4(r, _mm_loadu_ps(v + 3 * (size_t)ix[3 * (12 + j) + k]), 3);
        }
        __m512 t0 = _mm512_unpacklo_ps(R[0], R[1]), t1 = _mm512_unpackhi_ps(R[0], R[1]);
        __m512 t2 = _mm512_unpacklo_ps(R[2], R[3]), t3 = _mm512_unpackhi_ps(R[2], R[3]);
        P[k].x = _mm512_shuffle_ps(t0, t2, 0x44);
        P[k].y = _mm512_shuffle_ps(t0, t2, 0xee);
        P[k].z = _mm512_shuffle_ps(t1, t3, 0x44);
    }
    return 0;
}

#define VP f32x16
#define REAL float
#define REAL_U (FLT_EPSILON / 2)
#define REAL_MIN FLT_MIN
#define FUNC spheres_f_avx512
#define SOURCE sc_tri_source_f
#define SOA sc_spheres_soaf
#define LOAD_INDEXED(src, first, P) load_indexed_rows_avx512(src, first, P)
#include "sphere_batch_template.h"
#undef LOAD_INDEXED
#undef VP
#undef REAL
#undef REAL_U
#undef REAL_MIN
#undef FUNC
#undef SOURCE
#undef SOA

#define VP f64x8
#define REAL double
#define REAL_U (DBL_EPSILON / 2)
#define REAL_MIN DBL_MIN
#define FUNC spheres_d_avx512
#define SOURCE sc_tri_source_d
#define SOA sc_spheres_soad
#include "sphere_batch_template.h"
#undef VP

#define VP f32x4
#define W 4
#define RFUNC reject4_avx512
#include "reject_template.h"
#undef VP
#undef W
#undef RFUNC
#define VP f32x8
#define W 8
#define RFUNC reject8_avx512
#define PFUNC packet8_avx512
#include "reject_template.h"
#undef VP
#undef W
#undef RFUNC
#undef PFUNC
#define VP f32x16
#define W 16
#define RFUNC reject16_avx512
#define PFUNC packet16_avx512
#include "reject_template.h"

const sc_sphere_kernels sc_sphere_kernels_avx512 = {
    spheres_f_avx512, spheres_d_avx512, reject4_avx512, reject8_avx512,
    reject16_avx512, packet8_avx512, packet16_avx512,
};
#endif

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
#include "sc_kernels.h"

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

#define VP f32x16
#define REAL float
#define REAL_U (FLT_EPSILON / 2)
#define REAL_TRUE_MIN FLT_TRUE_MIN
#define FUNC spheres_f_avx512
#define SOURCE sc_tri_source_f
#define SOA sc_spheres_soaf
#define LOAD_INDEXED(src, first, P) load_indexed_avx512(src, first, P)
#include "sphere_batch_template.h"
#undef LOAD_INDEXED
#undef VP
#undef REAL
#undef REAL_U
#undef REAL_TRUE_MIN
#undef FUNC
#undef SOURCE
#undef SOA

#define VP f64x8
#define REAL double
#define REAL_U (DBL_EPSILON / 2)
#define REAL_TRUE_MIN DBL_TRUE_MIN
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

const sc_kernels sc_kernels_avx512 = {
    SC_ISA_AVX512, spheres_f_avx512, spheres_d_avx512, reject4_avx512, reject8_avx512,
    reject16_avx512, packet8_avx512, packet16_avx512,
};
#endif

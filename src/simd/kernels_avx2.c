/* AVX2 + FMA kernels: 8 float / 4 double lanes, hardware gathers for the
 * indexed float input. */
#if defined(__x86_64__) || defined(__i386__)
#include <float.h>
#include <math.h>

#define SC_VEC_F32X4
#define SC_VEC_F32X8
#define SC_VEC_F64X4
#include "simd_vec.h"
#include "sc_kernels.h"

#define ATTR SC_ATTR_AVX2

typedef struct { f32x8_t x, y, z; } gather_v3_avx2;

/* 8 triangles starting at `first`: indices with stride 3, then the three
 * coordinates of each vertex. Out-of-range indices are clamped to vertex 0
 * and reported. */
static inline ATTR uint32_t load_indexed_avx2(const sc_tri_source_f *src, size_t first, void *out)
{
    gather_v3_avx2 *P = out;
    const __m256i lane3 = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
    const __m256i last = _mm256_set1_epi32((int)(src->vertex_count - 1));
    __m256i badv = _mm256_setzero_si256();
    for (int k = 0; k < 3; k++) {
        __m256i idx = _mm256_i32gather_epi32((const int *)(src->indices + 3 * first + (size_t)k), lane3, 4);
        __m256i clamped = _mm256_min_epu32(idx, last);
        badv = _mm256_or_si256(badv, _mm256_xor_si256(_mm256_cmpeq_epi32(idx, clamped), _mm256_set1_epi32(-1)));
        clamped = _mm256_and_si256(clamped, _mm256_cmpeq_epi32(idx, clamped));
        __m256i idx3 = _mm256_add_epi32(clamped, _mm256_add_epi32(clamped, clamped));
        P[k].x = f32x8_gather3(src->vertices, idx3, 0);
        P[k].y = f32x8_gather3(src->vertices, idx3, 1);
        P[k].z = f32x8_gather3(src->vertices, idx3, 2);
    }
    return (uint32_t)_mm256_movemask_ps(_mm256_castsi256_ps(badv));
}

#define VP f32x8
#define REAL float
#define REAL_U (FLT_EPSILON / 2)
#define REAL_TRUE_MIN FLT_TRUE_MIN
#define FUNC spheres_f_avx2
#define SOURCE sc_tri_source_f
#define SOA sc_spheres_soaf
#define LOAD_INDEXED(src, first, P) load_indexed_avx2(src, first, P)
#include "sphere_batch_template.h"
#undef LOAD_INDEXED
#undef VP
#undef REAL
#undef REAL_U
#undef REAL_TRUE_MIN
#undef FUNC
#undef SOURCE
#undef SOA

#define VP f64x4
#define REAL double
#define REAL_U (DBL_EPSILON / 2)
#define REAL_TRUE_MIN DBL_TRUE_MIN
#define FUNC spheres_d_avx2
#define SOURCE sc_tri_source_d
#define SOA sc_spheres_soad
#include "sphere_batch_template.h"
#undef VP

#define VP f32x4
#define W 4
#define RFUNC reject4_avx2
#include "reject_template.h"
#undef VP
#undef W
#undef RFUNC
#define VP f32x8
#define W 8
#define RFUNC reject8_avx2
#define PFUNC packet8_avx2
#include "reject_template.h"
#undef W
#undef RFUNC
#undef PFUNC
#define W 16
#define RFUNC reject16_avx2
#define PFUNC packet16_avx2
#include "reject_template.h"

const sc_kernels sc_kernels_avx2 = {
    SC_ISA_AVX2, spheres_f_avx2, spheres_d_avx2, reject4_avx2, reject8_avx2, reject16_avx2,
    packet8_avx2, packet16_avx2,
};
#endif

/* AVX2 + FMA kernels: 8 float / 4 double lanes, hardware gathers for the
 * indexed float input. */
#if defined(__x86_64__) || defined(__i386__)
#include <float.h>
#include <math.h>

#define SC_VEC_F32X4
#define SC_VEC_F32X8
#define SC_VEC_F64X4
#include "simd_vec.h"
#include "sphere_kernels.h"

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

/* The same 8 triangles without gathers: one 16-byte load per vertex,
 * two vertices to a 256-bit register, a 4x4 transpose per 128-bit half.
 * The fourth float read belongs to the next vertex, so every index must be
 * <= vertex_count - 2; otherwise the gathers. */
static inline ATTR __attribute__((always_inline)) uint32_t load_indexed_rows_avx2(const sc_tri_source_f *src,
                                                                                  size_t first, void *out)
{
    const uint32_t *ix = src->indices + 3 * first;
    const __m256i lim = _mm256_set1_epi32((int)(src->vertex_count - 2));
    __m256i over = _mm256_setzero_si256();
    for (int q = 0; q < 3; q++) {
        __m256i idx = _mm256_loadu_si256((const __m256i *)(ix + 8 * q));
        over = _mm256_or_si256(over, _mm256_xor_si256(_mm256_max_epu32(idx, lim), lim));
    }
    if (__builtin_expect(!_mm256_testz_si256(over, over) || src->vertex_count < 2, 0))
        return load_indexed_avx2(src, first, out);
    gather_v3_avx2 *P = out;
    const float *v = src->vertices;
    for (int k = 0; k < 3; k++) {
        __m256 R[4];
        for (int j = 0; j < 4; j++) {
            /* Half h of R[j]: vertex k of triangle 4h + j. */
            __m256 r = _mm256_castps128_ps256(_mm_loadu_ps(v + 3 * (size_t)ix[3 * j + k]));
            R[j] = _mm256_insertf128_ps(r, _mm_loadu_ps(v + 3 * (size_t)ix[3 * (4 + j) + k]), 1);
        }
        __m256 t0 = _mm256_unpacklo_ps(R[0], R[1]), t1 = _mm256_unpackhi_ps(R[0], R[1]);
        __m256 t2 = _mm256_unpacklo_ps(R[2], R[3]), t3 = _mm256_unpackhi_ps(R[2], R[3]);
        P[k].x = _mm256_shuffle_ps(t0, t2, 0x44);
        P[k].y = _mm256_shuffle_ps(t0, t2, 0xee);
        P[k].z = _mm256_shuffle_ps(t1, t3, 0x44);
    }
    return 0;
}

#define VP f32x8
#define REAL float
#define REAL_U (FLT_EPSILON / 2)
#define REAL_MIN FLT_MIN
#define FUNC spheres_f_avx2
#define SOURCE sc_tri_source_f
#define SOA sc_spheres_soaf
#define LOAD_INDEXED(src, first, P) load_indexed_rows_avx2(src, first, P)
#include "sphere_batch_template.h"
#undef LOAD_INDEXED
#undef VP
#undef REAL
#undef REAL_U
#undef REAL_MIN
#undef FUNC
#undef SOURCE
#undef SOA

#define VP f64x4
#define REAL double
#define REAL_U (DBL_EPSILON / 2)
#define REAL_MIN DBL_MIN
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

const sc_sphere_kernels sc_sphere_kernels_avx2 = {
    spheres_f_avx2, spheres_d_avx2, reject4_avx2, reject8_avx2, reject16_avx2,
    packet8_avx2, packet16_avx2,
};
#endif

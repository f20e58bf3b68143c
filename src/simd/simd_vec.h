/* Thin vector vocabulary for the kernel templates: one set of names per
 * vector shape, prefixed by the shape (f32x4_add, f64x8_sel, ...).
 *
 * A translation unit defines the SC_VEC_* shapes it needs before including
 * this header; each helper carries the target attribute of the narrowest ISA
 * that has it, so it inlines into any kernel compiled for that ISA or a
 * wider one. Masks are vectors for 128/256-bit shapes and k-registers for
 * 512-bit shapes; templates only use them through the *_m ops below.
 *
 * fmadd(a, b, c) = a*b + c. On shapes without FMA (SSE4.1) it is a multiply
 * then an add, in the same order as the scalar specification, so those
 * kernels round exactly like src/sphere.
 *
 * pow2pair(m, &down, &up): powers of two with m*down in [1, 2) for normal
 * m in [2^-126, 2^127) (double: [2^-1022, 2^1023)), clamped outside that
 * range; down*up == 1 exactly. Built from the exponent bits, no libm.
 */
#ifndef SPHERECULL_SIMD_VEC_H
#define SPHERECULL_SIMD_VEC_H

#include <immintrin.h>
#include <stdint.h>

#define SC_ATTR_SSE4   __attribute__((target("sse4.1")))
#define SC_ATTR_AVX2   __attribute__((target("avx2,fma")))
#define SC_ATTR_AVX512 __attribute__((target("avx512f,avx512vl,avx512dq,avx2,fma")))

#define SC_VI static inline

/* Orders the streaming stores before whatever follows. */
SC_VI void sc_store_fence(void) { _mm_sfence(); }

/* ---------------- 128-bit: f32x4, f64x2 (SSE4.1) ---------------------- */
#ifdef SC_VEC_F32X4
typedef __m128 f32x4_t;
typedef __m128 f32x4_m;
enum { f32x4_N = 4 };
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_set1(float x) { return _mm_set1_ps(x); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_load(const float *p) { return _mm_loadu_ps(p); }
SC_VI SC_ATTR_SSE4 void f32x4_store(float *p, f32x4_t v) { _mm_storeu_ps(p, v); }
SC_VI SC_ATTR_SSE4 void f32x4_stream(float *p, f32x4_t v) { _mm_stream_ps(p, v); }   /* p aligned to the vector */
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_add(f32x4_t a, f32x4_t b) { return _mm_add_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_sub(f32x4_t a, f32x4_t b) { return _mm_sub_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_mul(f32x4_t a, f32x4_t b) { return _mm_mul_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_div(f32x4_t a, f32x4_t b) { return _mm_div_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_fmadd(f32x4_t a, f32x4_t b, f32x4_t c) { return _mm_add_ps(_mm_mul_ps(a, b), c); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_fmsub(f32x4_t a, f32x4_t b, f32x4_t c) { return _mm_sub_ps(_mm_mul_ps(a, b), c); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_max(f32x4_t a, f32x4_t b) { return _mm_max_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_min(f32x4_t a, f32x4_t b) { return _mm_min_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_abs(f32x4_t a) { return _mm_andnot_ps(_mm_set1_ps(-0.0f), a); }
/* -a by its sign bit: no arithmetic, so no flush of a subnormal a */
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_neg(f32x4_t a) { return _mm_xor_ps(_mm_set1_ps(-0.0f), a); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_lt(f32x4_t a, f32x4_t b) { return _mm_cmplt_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_le(f32x4_t a, f32x4_t b) { return _mm_cmple_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_gt(f32x4_t a, f32x4_t b) { return _mm_cmpgt_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_ge(f32x4_t a, f32x4_t b) { return _mm_cmpge_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_eq(f32x4_t a, f32x4_t b) { return _mm_cmpeq_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_finite(f32x4_t a) { return _mm_cmpeq_ps(_mm_sub_ps(a, a), _mm_setzero_ps()); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_and(f32x4_m a, f32x4_m b) { return _mm_and_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_or(f32x4_m a, f32x4_m b) { return _mm_or_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_andnot(f32x4_m a, f32x4_m b) { return _mm_andnot_ps(a, b); }
SC_VI SC_ATTR_SSE4 f32x4_t f32x4_sel(f32x4_m m, f32x4_t a, f32x4_t b) { return _mm_blendv_ps(b, a, m); }
SC_VI SC_ATTR_SSE4 uint32_t f32x4_bits(f32x4_m m) { return (uint32_t)_mm_movemask_ps(m); }
SC_VI SC_ATTR_SSE4 f32x4_m f32x4_mask_from_bits(uint32_t bits)
{
    __m128i b = _mm_set1_epi32((int)bits), sel = _mm_setr_epi32(1, 2, 4, 8);
    return _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(b, sel), sel));
}
SC_VI SC_ATTR_SSE4 void f32x4_pow2pair(f32x4_t m, f32x4_t *down, f32x4_t *up)
{
    m = _mm_min_ps(_mm_max_ps(m, _mm_set1_ps(0x1p-126f)), _mm_set1_ps(0x1p126f));
    __m128i e = _mm_and_si128(_mm_castps_si128(m), _mm_set1_epi32(0x7f800000));
    *up = _mm_castsi128_ps(e);
    *down = _mm_castsi128_ps(_mm_sub_epi32(_mm_set1_epi32(254 << 23), e));
}
#endif

#ifdef SC_VEC_F64X2
typedef __m128d f64x2_t;
typedef __m128d f64x2_m;
enum { f64x2_N = 2 };
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_set1(double x) { return _mm_set1_pd(x); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_load(const double *p) { return _mm_loadu_pd(p); }
SC_VI SC_ATTR_SSE4 void f64x2_store(double *p, f64x2_t v) { _mm_storeu_pd(p, v); }
SC_VI SC_ATTR_SSE4 void f64x2_stream(double *p, f64x2_t v) { _mm_stream_pd(p, v); }   /* p aligned to the vector */
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_add(f64x2_t a, f64x2_t b) { return _mm_add_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_sub(f64x2_t a, f64x2_t b) { return _mm_sub_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_mul(f64x2_t a, f64x2_t b) { return _mm_mul_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_div(f64x2_t a, f64x2_t b) { return _mm_div_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_fmadd(f64x2_t a, f64x2_t b, f64x2_t c) { return _mm_add_pd(_mm_mul_pd(a, b), c); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_fmsub(f64x2_t a, f64x2_t b, f64x2_t c) { return _mm_sub_pd(_mm_mul_pd(a, b), c); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_max(f64x2_t a, f64x2_t b) { return _mm_max_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_min(f64x2_t a, f64x2_t b) { return _mm_min_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_abs(f64x2_t a) { return _mm_andnot_pd(_mm_set1_pd(-0.0), a); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_lt(f64x2_t a, f64x2_t b) { return _mm_cmplt_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_le(f64x2_t a, f64x2_t b) { return _mm_cmple_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_gt(f64x2_t a, f64x2_t b) { return _mm_cmpgt_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_ge(f64x2_t a, f64x2_t b) { return _mm_cmpge_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_eq(f64x2_t a, f64x2_t b) { return _mm_cmpeq_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_finite(f64x2_t a) { return _mm_cmpeq_pd(_mm_sub_pd(a, a), _mm_setzero_pd()); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_and(f64x2_m a, f64x2_m b) { return _mm_and_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_or(f64x2_m a, f64x2_m b) { return _mm_or_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_andnot(f64x2_m a, f64x2_m b) { return _mm_andnot_pd(a, b); }
SC_VI SC_ATTR_SSE4 f64x2_t f64x2_sel(f64x2_m m, f64x2_t a, f64x2_t b) { return _mm_blendv_pd(b, a, m); }
SC_VI SC_ATTR_SSE4 uint32_t f64x2_bits(f64x2_m m) { return (uint32_t)_mm_movemask_pd(m); }
SC_VI SC_ATTR_SSE4 f64x2_m f64x2_mask_from_bits(uint32_t bits)
{
    __m128i b = _mm_set1_epi64x(bits), sel = _mm_set_epi64x(2, 1);
    return _mm_castsi128_pd(_mm_cmpeq_epi64(_mm_and_si128(b, sel), sel));
}
SC_VI SC_ATTR_SSE4 void f64x2_pow2pair(f64x2_t m, f64x2_t *down, f64x2_t *up)
{
    m = _mm_min_pd(_mm_max_pd(m, _mm_set1_pd(0x1p-1022)), _mm_set1_pd(0x1p1022));
    __m128i e = _mm_and_si128(_mm_castpd_si128(m), _mm_set1_epi64x(0x7ff0000000000000ll));
    *up = _mm_castsi128_pd(e);
    *down = _mm_castsi128_pd(_mm_sub_epi64(_mm_set1_epi64x(2046ll << 52), e));
}
#endif

/* ---------------- 256-bit: f32x8, f64x4 (AVX2 + FMA) ------------------ */
#ifdef SC_VEC_F32X8
typedef __m256 f32x8_t;
typedef __m256 f32x8_m;
enum { f32x8_N = 8 };
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_set1(float x) { return _mm256_set1_ps(x); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_load(const float *p) { return _mm256_loadu_ps(p); }
SC_VI SC_ATTR_AVX2 void f32x8_store(float *p, f32x8_t v) { _mm256_storeu_ps(p, v); }
/* Stores the lanes set in bits only; the others of p are not touched
 * (vmaskmovps: no fault and no write where a lane is off). */
SC_VI SC_ATTR_AVX2 void f32x8_store_lanes(float *p, uint32_t bits, f32x8_t v)
{
    const __m256i b = _mm256_set1_epi32((int)bits), sel = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    _mm256_maskstore_ps(p, _mm256_cmpeq_epi32(_mm256_and_si256(b, sel), sel), v);
}
/* A lane of bit pattern x (an id, a NaN payload) in every lane. */
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_set1_bits(uint32_t x) { return _mm256_castsi256_ps(_mm256_set1_epi32((int)x)); }
/* Lanes whose bit patterns are equal (ids, where a float compare would see NaNs). */
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_eq_bits(f32x8_t a, f32x8_t b)
{
    return _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_castps_si256(a), _mm256_castps_si256(b)));
}
SC_VI SC_ATTR_AVX2 void f32x8_stream(float *p, f32x8_t v) { _mm256_stream_ps(p, v); }   /* p aligned to the vector */
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_add(f32x8_t a, f32x8_t b) { return _mm256_add_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_sub(f32x8_t a, f32x8_t b) { return _mm256_sub_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_mul(f32x8_t a, f32x8_t b) { return _mm256_mul_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_div(f32x8_t a, f32x8_t b) { return _mm256_div_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_fmadd(f32x8_t a, f32x8_t b, f32x8_t c) { return _mm256_fmadd_ps(a, b, c); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_fmsub(f32x8_t a, f32x8_t b, f32x8_t c) { return _mm256_fmsub_ps(a, b, c); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_max(f32x8_t a, f32x8_t b) { return _mm256_max_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_min(f32x8_t a, f32x8_t b) { return _mm256_min_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_abs(f32x8_t a) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_neg(f32x8_t a) { return _mm256_xor_ps(_mm256_set1_ps(-0.0f), a); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_sqrt(f32x8_t a) { return _mm256_sqrt_ps(a); }
/* 1/sqrt(a) within 1.5 * 2^-12 relative (rsqrtps): inf for 0, NaN below. */
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_rsqrt(f32x8_t a) { return _mm256_rsqrt_ps(a); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_lt(f32x8_t a, f32x8_t b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_le(f32x8_t a, f32x8_t b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_gt(f32x8_t a, f32x8_t b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_ge(f32x8_t a, f32x8_t b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_eq(f32x8_t a, f32x8_t b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_finite(f32x8_t a) { return _mm256_cmp_ps(_mm256_sub_ps(a, a), _mm256_setzero_ps(), _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_and(f32x8_m a, f32x8_m b) { return _mm256_and_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_or(f32x8_m a, f32x8_m b) { return _mm256_or_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_andnot(f32x8_m a, f32x8_m b) { return _mm256_andnot_ps(a, b); }
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_sel(f32x8_m m, f32x8_t a, f32x8_t b) { return _mm256_blendv_ps(b, a, m); }
SC_VI SC_ATTR_AVX2 uint32_t f32x8_bits(f32x8_m m) { return (uint32_t)_mm256_movemask_ps(m); }
/* The smallest lane (no NaN lanes). */
SC_VI SC_ATTR_AVX2 float f32x8_hmin(f32x8_t v)
{
    __m128 m = _mm_min_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    m = _mm_min_ps(m, _mm_movehl_ps(m, m));
    m = _mm_min_ss(m, _mm_shuffle_ps(m, m, 1));
    return _mm_cvtss_f32(m);
}
/* The smallest lane of each of eight vectors (no NaN lanes): lane i of
 * the result is f32x8_hmin(v[i]). A transposing tree, each level halving
 * the vectors with one shuffle pair and one min: about 20 operations where
 * eight f32x8_hmin take about 50. */
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_hmin8(const f32x8_t v[8])
{
    __m256 a[4], b[2];
    /* per 128-bit half, both vectors' lanes 0^2 and 1^3 */
    for (int i = 0; i < 4; i++)
        a[i] = _mm256_min_ps(_mm256_unpacklo_ps(v[2 * i], v[2 * i + 1]), _mm256_unpackhi_ps(v[2 * i], v[2 * i + 1]));
    /* per half: the half's minimum of four vectors */
    for (int i = 0; i < 2; i++)
        b[i] = _mm256_min_ps(_mm256_shuffle_ps(a[2 * i], a[2 * i + 1], 0x44),
                             _mm256_shuffle_ps(a[2 * i], a[2 * i + 1], 0xee));
    return _mm256_min_ps(_mm256_permute2f128_ps(b[0], b[1], 0x20), _mm256_permute2f128_ps(b[0], b[1], 0x31));
}
SC_VI SC_ATTR_AVX2 f32x8_m f32x8_mask_from_bits(uint32_t bits)
{
    __m256i b = _mm256_set1_epi32((int)bits), sel = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    return _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(b, sel), sel));
}
SC_VI SC_ATTR_AVX2 void f32x8_pow2pair(f32x8_t m, f32x8_t *down, f32x8_t *up)
{
    m = _mm256_min_ps(_mm256_max_ps(m, _mm256_set1_ps(0x1p-126f)), _mm256_set1_ps(0x1p126f));
    __m256i e = _mm256_and_si256(_mm256_castps_si256(m), _mm256_set1_epi32(0x7f800000));
    *up = _mm256_castsi256_ps(e);
    *down = _mm256_castsi256_ps(_mm256_sub_epi32(_mm256_set1_epi32(254 << 23), e));
}
/* Lane i = base[idx[i] * 3 + axis], idx already clamped in range. */
SC_VI SC_ATTR_AVX2 f32x8_t f32x8_gather3(const float *base, __m256i idx3, int axis)
{
    return _mm256_i32gather_ps(base + axis, idx3, 4);
}
#endif

#ifdef SC_VEC_F64X4
typedef __m256d f64x4_t;
typedef __m256d f64x4_m;
enum { f64x4_N = 4 };
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_set1(double x) { return _mm256_set1_pd(x); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_load(const double *p) { return _mm256_loadu_pd(p); }
SC_VI SC_ATTR_AVX2 void f64x4_store(double *p, f64x4_t v) { _mm256_storeu_pd(p, v); }
SC_VI SC_ATTR_AVX2 void f64x4_stream(double *p, f64x4_t v) { _mm256_stream_pd(p, v); }   /* p aligned to the vector */
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_add(f64x4_t a, f64x4_t b) { return _mm256_add_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_sub(f64x4_t a, f64x4_t b) { return _mm256_sub_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_mul(f64x4_t a, f64x4_t b) { return _mm256_mul_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_div(f64x4_t a, f64x4_t b) { return _mm256_div_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_fmadd(f64x4_t a, f64x4_t b, f64x4_t c) { return _mm256_fmadd_pd(a, b, c); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_fmsub(f64x4_t a, f64x4_t b, f64x4_t c) { return _mm256_fmsub_pd(a, b, c); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_max(f64x4_t a, f64x4_t b) { return _mm256_max_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_min(f64x4_t a, f64x4_t b) { return _mm256_min_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_abs(f64x4_t a) { return _mm256_andnot_pd(_mm256_set1_pd(-0.0), a); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_lt(f64x4_t a, f64x4_t b) { return _mm256_cmp_pd(a, b, _CMP_LT_OQ); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_le(f64x4_t a, f64x4_t b) { return _mm256_cmp_pd(a, b, _CMP_LE_OQ); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_gt(f64x4_t a, f64x4_t b) { return _mm256_cmp_pd(a, b, _CMP_GT_OQ); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_ge(f64x4_t a, f64x4_t b) { return _mm256_cmp_pd(a, b, _CMP_GE_OQ); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_eq(f64x4_t a, f64x4_t b) { return _mm256_cmp_pd(a, b, _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_finite(f64x4_t a) { return _mm256_cmp_pd(_mm256_sub_pd(a, a), _mm256_setzero_pd(), _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_and(f64x4_m a, f64x4_m b) { return _mm256_and_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_or(f64x4_m a, f64x4_m b) { return _mm256_or_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_andnot(f64x4_m a, f64x4_m b) { return _mm256_andnot_pd(a, b); }
SC_VI SC_ATTR_AVX2 f64x4_t f64x4_sel(f64x4_m m, f64x4_t a, f64x4_t b) { return _mm256_blendv_pd(b, a, m); }
SC_VI SC_ATTR_AVX2 uint32_t f64x4_bits(f64x4_m m) { return (uint32_t)_mm256_movemask_pd(m); }
SC_VI SC_ATTR_AVX2 f64x4_m f64x4_mask_from_bits(uint32_t bits)
{
    __m256i b = _mm256_set1_epi64x(bits), sel = _mm256_setr_epi64x(1, 2, 4, 8);
    return _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(b, sel), sel));
}
SC_VI SC_ATTR_AVX2 void f64x4_pow2pair(f64x4_t m, f64x4_t *down, f64x4_t *up)
{
    m = _mm256_min_pd(_mm256_max_pd(m, _mm256_set1_pd(0x1p-1022)), _mm256_set1_pd(0x1p1022));
    __m256i e = _mm256_and_si256(_mm256_castpd_si256(m), _mm256_set1_epi64x(0x7ff0000000000000ll));
    *up = _mm256_castsi256_pd(e);
    *down = _mm256_castsi256_pd(_mm256_sub_epi64(_mm256_set1_epi64x(2046ll << 52), e));
}
#endif

/* ---------------- 512-bit: f32x16, f64x8 (AVX-512 F/VL/DQ) ------------ */
#ifdef SC_VEC_F32X16
typedef __m512 f32x16_t;
typedef __mmask16 f32x16_m;
enum { f32x16_N = 16 };
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_set1(float x) { return _mm512_set1_ps(x); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_load(const float *p) { return _mm512_loadu_ps(p); }
SC_VI SC_ATTR_AVX512 void f32x16_store(float *p, f32x16_t v) { _mm512_storeu_ps(p, v); }
SC_VI SC_ATTR_AVX512 void f32x16_store_lanes(float *p, uint32_t bits, f32x16_t v) { _mm512_mask_storeu_ps(p, (__mmask16)bits, v); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_set1_bits(uint32_t x) { return _mm512_castsi512_ps(_mm512_set1_epi32((int)x)); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_eq_bits(f32x16_t a, f32x16_t b)
{
    return _mm512_cmpeq_epi32_mask(_mm512_castps_si512(a), _mm512_castps_si512(b));
}
/* The smallest lane of each of 16 vectors, as f32x8_hmin8 (no NaN lanes). */
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_hmin16(const f32x16_t v[16])
{
    __m512 a[8], b[4];
    /* pairs: per 128-bit chunk, both vectors' lanes 0^2 and 1^3 */
    for (int i = 0; i < 8; i++)
        a[i] = _mm512_min_ps(_mm512_unpacklo_ps(v[2 * i], v[2 * i + 1]), _mm512_unpackhi_ps(v[2 * i], v[2 * i + 1]));
    /* per chunk: the chunk's minimum of four vectors */
    for (int i = 0; i < 4; i++)
        b[i] = _mm512_min_ps(_mm512_shuffle_ps(a[2 * i], a[2 * i + 1], 0x44),
                             _mm512_shuffle_ps(a[2 * i], a[2 * i + 1], 0xee));
    /* across the chunks: pairs of chunks, then all four */
    const __m512 c0 = _mm512_min_ps(_mm512_shuffle_f32x4(b[0], b[1], 0x88), _mm512_shuffle_f32x4(b[0], b[1], 0xdd));
    const __m512 c1 = _mm512_min_ps(_mm512_shuffle_f32x4(b[2], b[3], 0x88), _mm512_shuffle_f32x4(b[2], b[3], 0xdd));
    return _mm512_min_ps(_mm512_shuffle_f32x4(c0, c1, 0x88), _mm512_shuffle_f32x4(c0, c1, 0xdd));
}
SC_VI SC_ATTR_AVX512 void f32x16_stream(float *p, f32x16_t v) { _mm512_stream_ps(p, v); }   /* p aligned to the vector */
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_add(f32x16_t a, f32x16_t b) { return _mm512_add_ps(a, b); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_sub(f32x16_t a, f32x16_t b) { return _mm512_sub_ps(a, b); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_mul(f32x16_t a, f32x16_t b) { return _mm512_mul_ps(a, b); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_div(f32x16_t a, f32x16_t b) { return _mm512_div_ps(a, b); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_fmadd(f32x16_t a, f32x16_t b, f32x16_t c) { return _mm512_fmadd_ps(a, b, c); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_fmsub(f32x16_t a, f32x16_t b, f32x16_t c) { return _mm512_fmsub_ps(a, b, c); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_max(f32x16_t a, f32x16_t b) { return _mm512_max_ps(a, b); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_min(f32x16_t a, f32x16_t b) { return _mm512_min_ps(a, b); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_abs(f32x16_t a) { return _mm512_abs_ps(a); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_neg(f32x16_t a) { return _mm512_xor_ps(_mm512_set1_ps(-0.0f), a); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_sqrt(f32x16_t a) { return _mm512_sqrt_ps(a); }
/* 1/sqrt(a) within 2^-14 relative (vrsqrt14ps): inf for 0, NaN below. */
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_rsqrt(f32x16_t a) { return _mm512_rsqrt14_ps(a); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_lt(f32x16_t a, f32x16_t b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_le(f32x16_t a, f32x16_t b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_gt(f32x16_t a, f32x16_t b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_ge(f32x16_t a, f32x16_t b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_eq(f32x16_t a, f32x16_t b) { return _mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_finite(f32x16_t a) { return _mm512_cmp_ps_mask(_mm512_sub_ps(a, a), _mm512_setzero_ps(), _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_and(f32x16_m a, f32x16_m b) { return (f32x16_m)(a & b); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_or(f32x16_m a, f32x16_m b) { return (f32x16_m)(a | b); }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_andnot(f32x16_m a, f32x16_m b) { return (f32x16_m)(~a & b); }
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_sel(f32x16_m m, f32x16_t a, f32x16_t b) { return _mm512_mask_blend_ps(m, b, a); }
SC_VI SC_ATTR_AVX512 uint32_t f32x16_bits(f32x16_m m) { return (uint32_t)m; }
SC_VI SC_ATTR_AVX512 f32x16_m f32x16_mask_from_bits(uint32_t bits) { return (f32x16_m)bits; }
SC_VI SC_ATTR_AVX512 float f32x16_hmin(f32x16_t v) { return _mm512_reduce_min_ps(v); }
SC_VI SC_ATTR_AVX512 void f32x16_pow2pair(f32x16_t m, f32x16_t *down, f32x16_t *up)
{
    m = _mm512_min_ps(_mm512_max_ps(m, _mm512_set1_ps(0x1p-126f)), _mm512_set1_ps(0x1p126f));
    __m512i e = _mm512_and_si512(_mm512_castps_si512(m), _mm512_set1_epi32(0x7f800000));
    *up = _mm512_castsi512_ps(e);
    *down = _mm512_castsi512_ps(_mm512_sub_epi32(_mm512_set1_epi32(254 << 23), e));
}
SC_VI SC_ATTR_AVX512 f32x16_t f32x16_gather3(const float *base, __m512i idx3, int axis)
{
    return _mm512_i32gather_ps(idx3, base + axis, 4);
}
#endif

#ifdef SC_VEC_F64X8
typedef __m512d f64x8_t;
typedef __mmask8 f64x8_m;
enum { f64x8_N = 8 };
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_set1(double x) { return _mm512_set1_pd(x); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_load(const double *p) { return _mm512_loadu_pd(p); }
SC_VI SC_ATTR_AVX512 void f64x8_store(double *p, f64x8_t v) { _mm512_storeu_pd(p, v); }
SC_VI SC_ATTR_AVX512 void f64x8_stream(double *p, f64x8_t v) { _mm512_stream_pd(p, v); }   /* p aligned to the vector */
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_add(f64x8_t a, f64x8_t b) { return _mm512_add_pd(a, b); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_sub(f64x8_t a, f64x8_t b) { return _mm512_sub_pd(a, b); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_mul(f64x8_t a, f64x8_t b) { return _mm512_mul_pd(a, b); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_div(f64x8_t a, f64x8_t b) { return _mm512_div_pd(a, b); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_fmadd(f64x8_t a, f64x8_t b, f64x8_t c) { return _mm512_fmadd_pd(a, b, c); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_fmsub(f64x8_t a, f64x8_t b, f64x8_t c) { return _mm512_fmsub_pd(a, b, c); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_max(f64x8_t a, f64x8_t b) { return _mm512_max_pd(a, b); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_min(f64x8_t a, f64x8_t b) { return _mm512_min_pd(a, b); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_abs(f64x8_t a) { return _mm512_abs_pd(a); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_lt(f64x8_t a, f64x8_t b) { return _mm512_cmp_pd_mask(a, b, _CMP_LT_OQ); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_le(f64x8_t a, f64x8_t b) { return _mm512_cmp_pd_mask(a, b, _CMP_LE_OQ); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_gt(f64x8_t a, f64x8_t b) { return _mm512_cmp_pd_mask(a, b, _CMP_GT_OQ); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_ge(f64x8_t a, f64x8_t b) { return _mm512_cmp_pd_mask(a, b, _CMP_GE_OQ); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_eq(f64x8_t a, f64x8_t b) { return _mm512_cmp_pd_mask(a, b, _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_finite(f64x8_t a) { return _mm512_cmp_pd_mask(_mm512_sub_pd(a, a), _mm512_setzero_pd(), _CMP_EQ_OQ); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_and(f64x8_m a, f64x8_m b) { return (f64x8_m)(a & b); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_or(f64x8_m a, f64x8_m b) { return (f64x8_m)(a | b); }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_andnot(f64x8_m a, f64x8_m b) { return (f64x8_m)(~a & b); }
SC_VI SC_ATTR_AVX512 f64x8_t f64x8_sel(f64x8_m m, f64x8_t a, f64x8_t b) { return _mm512_mask_blend_pd(m, b, a); }
SC_VI SC_ATTR_AVX512 uint32_t f64x8_bits(f64x8_m m) { return (uint32_t)m; }
SC_VI SC_ATTR_AVX512 f64x8_m f64x8_mask_from_bits(uint32_t bits) { return (f64x8_m)bits; }
SC_VI SC_ATTR_AVX512 void f64x8_pow2pair(f64x8_t m, f64x8_t *down, f64x8_t *up)
{
    m = _mm512_min_pd(_mm512_max_pd(m, _mm512_set1_pd(0x1p-1022)), _mm512_set1_pd(0x1p1022));
    __m512i e = _mm512_and_si512(_mm512_castpd_si512(m), _mm512_set1_epi64(0x7ff0000000000000ll));
    *up = _mm512_castsi512_pd(e);
    *down = _mm512_castsi512_pd(_mm512_sub_epi64(_mm512_set1_epi64(2046ll << 52), e));
}
#endif

#endif

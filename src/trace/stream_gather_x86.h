/* stream_gather.h's gather of a 16-ray run on 8 lanes: each half of the run
 * is eight 32-byte rays (org, tmin, dir, tmax) transposed 8x8 into eight
 * rows, checked and reduced as sc_stream_gather16_ref does, with the same
 * answers: the checks are sc_ray_valid's compares, and the coherence bounds
 * are the same minima and maxima of the same products (1 / L1 by a division).
 * Part of an x86 traversal translation unit (traverse_bvh8_x86.h), after
 * simd_vec.h with its 8-lane shape. */
#ifndef SPHERECULL_TRACE_STREAM_GATHER_X86_H
#define SPHERECULL_TRACE_STREAM_GATHER_X86_H

#include <float.h>
#include <immintrin.h>

#include "stream_gather.h"

/* Rows r[0..7] of eight 8-float records to their eight columns. */
SC_X86_INLINE void transpose8x8(__m256 r[8])
{
    const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
    const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
    const __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
    const __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
    const __m256 s0 = _mm256_shuffle_ps(t0, t2, 0x44), s1 = _mm256_shuffle_ps(t0, t2, 0xee);
    const __m256 s2 = _mm256_shuffle_ps(t1, t3, 0x44), s3 = _mm256_shuffle_ps(t1, t3, 0xee);
    const __m256 s4 = _mm256_shuffle_ps(t4, t6, 0x44), s5 = _mm256_shuffle_ps(t4, t6, 0xee);
    const __m256 s6 = _mm256_shuffle_ps(t5, t7, 0x44), s7 = _mm256_shuffle_ps(t5, t7, 0xee);
    r[0] = _mm256_permute2f128_ps(s0, s4, 0x20), r[4] = _mm256_permute2f128_ps(s0, s4, 0x31);
    r[1] = _mm256_permute2f128_ps(s1, s5, 0x20), r[5] = _mm256_permute2f128_ps(s1, s5, 0x31);
    r[2] = _mm256_permute2f128_ps(s2, s6, 0x20), r[6] = _mm256_permute2f128_ps(s2, s6, 0x31);
    r[3] = _mm256_permute2f128_ps(s3, s7, 0x20), r[7] = _mm256_permute2f128_ps(s3, s7, 0x31);
}

/* Whether the spread of a bound (the largest of hi's lanes minus the
 * smallest of lo's) is at most limit, in every lane: each lane compares
 * fl(hi_i - min lo), and the largest of those is fl(max hi - min lo) since
 * rounding is monotone, so this is the specification's test without taking
 * either extreme out to a scalar. (The minimum broadcast from f32x8_hmin's
 * scalar instead of this in-register reduction ran camera-ray streams
 * 1-3 % slower on fast scenes.) */
SC_X86_INLINE __m256 spread_within8(__m256 lo, __m256 hi, float limit)
{
    lo = _mm256_min_ps(lo, _mm256_permute2f128_ps(lo, lo, 1));
    lo = _mm256_min_ps(lo, _mm256_shuffle_ps(lo, lo, 0x4e));
    lo = _mm256_min_ps(lo, _mm256_shuffle_ps(lo, lo, 0xb1));
    return _mm256_cmp_ps(_mm256_sub_ps(hi, lo), _mm256_set1_ps(limit), _CMP_LE_OQ);
}

static SC_TARGET int stream_gather16(const char *rays, size_t ray_stride, const float *lo, const float *hi,
                                     sc_ray_packet16 *p)
{
    const __m256 sgn = _mm256_set1_ps(-0.0f), one = _mm256_set1_ps(1.0f);
    float *soa = p->ox;
    __m256 dlo[3], dhi[3], olo[3], ohi[3], ok = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    for (unsigned h = 0; h < 16; h += 8) {
        __m256 r[8];
        for (unsigned j = 0; j < 8; j++)
            r[j] = _mm256_loadu_ps((const float *)(const void *)(rays + (h + j) * ray_stride));
        transpose8x8(r);   /* ox oy oz tmin dx dy dz tmax */
        for (unsigned k = 0; k < 8; k++)
            _mm256_store_ps(soa + k * 16 + h, r[k]);
        ok = _mm256_and_ps(ok, rays_ok8(r));
        const __m256 l1 = _mm256_add_ps(_mm256_add_ps(_mm256_andnot_ps(sgn, r[4]), _mm256_andnot_ps(sgn, r[5])),
                                        _mm256_andnot_ps(sgn, r[6]));
        const __m256 inv = _mm256_div_ps(one, l1);
        for (int a = 0; a < 3; a++) {
            const __m256 u = _mm256_mul_ps(r[4 + a], inv);
            dlo[a] = h ? _mm256_min_ps(dlo[a], u) : u, dhi[a] = h ? _mm256_max_ps(dhi[a], u) : u;
            olo[a] = h ? _mm256_min_ps(olo[a], r[a]) : r[a], ohi[a] = h ? _mm256_max_ps(ohi[a], r[a]) : r[a];
        }
    }
    if (_mm256_movemask_ps(ok) != 0xff)
        return SC_GATHER_REFUSED;
    __m256 narrow = _mm256_castsi256_ps(_mm256_set1_epi32(-1)), near = narrow;
    for (int a = 0; a < 3; a++) {
        narrow = _mm256_and_ps(narrow, spread_within8(dlo[a], dhi[a], SC_STREAM_SPREAD));
        near = _mm256_and_ps(near, spread_within8(olo[a], ohi[a], SC_STREAM_ORIGINS * (hi[a] - lo[a])));
    }
    return _mm256_movemask_ps(narrow) == 0xff ? SC_GATHER_COHERENT
           : _mm256_movemask_ps(near) == 0xff ? SC_GATHER_NEAR
                                              : SC_GATHER_INCOHERENT;
}

#endif

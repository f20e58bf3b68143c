/* The x86 traversal: 8-wide box tests in ymm registers; leaf blocks of 4
 * and 8 lanes in one ymm pass, 16 lanes in two (the tests are written for
 * 8 lanes); the sphere reject kernel of the same ISA inlined. Included by
 * traverse_bvh8_avx2.c and traverse_bvh8_avx512.c, which define
 *   SC_TARGET       the ISA's target attribute
 *   SC_X86_AVX512   1 for mask-register compares (AVX-512VL), else 0
 * The arithmetic is the scalar specification's (traverse_bvh8_scalar.c),
 * operation for operation. */
#include <float.h>
#include <math.h>

#include "node_bvh8_slab_x86.h"
#include "ray_setup_x86.h"
#include "tri_exact_x86.h"
#include "tri_moller_x86.h"
#include "tri_watertight_x86.h"
#include "traverse_stack.h"

/* The reject kernels of src/simd, the same template the sphere kernel table
 * is built from, compiled here so that they inline into the traversal. */
#define SC_VEC_F32X4
#define SC_VEC_F32X8
#if SC_X86_AVX512
#define SC_VEC_F32X16
#endif
#include "simd/simd_vec.h"
#include "stream_gather_x86.h"
#define ATTR SC_TARGET
#define RQUAL SC_X86_INLINE
#define VP f32x4
#define W 4
#define RFUNC sphere_reject4
#include "simd/reject_template.h"
#undef VP
#undef W
#undef RFUNC
#define VP f32x8
#define W 8
#define RFUNC sphere_reject8
#include "simd/reject_template.h"
#undef VP
#undef W
#undef RFUNC
#if SC_X86_AVX512
#define VP f32x16
#else
#define VP f32x8
#endif
#define W 16
#define RFUNC sphere_reject16
#include "simd/reject_template.h"
#undef VP
#undef W
#undef RFUNC
#undef RQUAL
#undef ATTR

/* Out of line, like summary_reject: leaves with spheres are the exception
 * (auto mode), and inlined into each octant's copy of the single-ray kernel
 * the three widths of the reject kernel took closest_watertight from 50 KB of
 * code to 71 KB (the instruction cache holds 32 KB). */
static SC_TARGET __attribute__((noinline)) uint32_t sphere_reject(const sc_ray *ray, const float *blk, unsigned W)
{
    if (W == 4)
        return sphere_reject4(ray, (const sc_sphere_block4 *)(const void *)blk);
    if (W == 8)
        return sphere_reject8(ray, (const sc_sphere_block8 *)(const void *)blk);
    return sphere_reject16(ray, (const sc_sphere_block16 *)(const void *)blk);
}

/* A leaf's compact summary decoded into a sphere block with the
 * operations of sc_leaf_summary_decode (the same bits), then the same
 * reject kernel. */
SC_X86_INLINE __m256 summary_u8x8(const unsigned char *p)
{
    return _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)(const void *)p)));
}
SC_X86_INLINE void summary_decode(const float *sum, unsigned W, float *blk)
{
    const unsigned char *q = (const unsigned char *)(sum + 8);
    if (W == 4) {
        for (unsigned k = 0; k < 4; k++) {
            int32_t b;
            __builtin_memcpy(&b, q + 4 * k, 4);
            __m128 x = _mm_cvtepi32_ps(_mm_cvtepu8_epi32(_mm_cvtsi32_si128(b)));
            x = k < 3 ? _mm_add_ps(_mm_set1_ps(sum[k]), _mm_mul_ps(x, _mm_set1_ps(sum[3 + k])))
                      : _mm_mul_ps(x, _mm_set1_ps(sum[6]));
            _mm_store_ps(blk + 4 * k, k < 3 ? x : _mm_mul_ps(x, x));
        }
        return;
    }
    for (unsigned h = 0; h < W; h += 8) {
        for (unsigned k = 0; k < 3; k++)
            _mm256_store_ps(blk + k * W + h, _mm256_add_ps(_mm256_set1_ps(sum[k]),
                                                           _mm256_mul_ps(summary_u8x8(q + k * W + h),
                                                                         _mm256_set1_ps(sum[3 + k]))));
        const __m256 r = _mm256_mul_ps(summary_u8x8(q + 3 * W + h), _mm256_set1_ps(sum[6]));
        _mm256_store_ps(blk + 3 * W + h, _mm256_mul_ps(r, r));
    }
}
static SC_TARGET __attribute__((noinline)) uint32_t summary_reject(const sc_ray *ray, const float *sum, unsigned W)
{
    _Alignas(64) float blk[4 * 16];
    summary_decode(sum, W, blk);
    return sphere_reject(ray, blk, W);
}

SC_X86_INLINE unsigned
leaf_test(const trace_ctx *c, const float *rows, unsigned W, unsigned live, float tmin, float tmax,
               int test, float *t, float *te, float *un, float *vn, float *den)
{
    unsigned hm;
    if (test == SC_TRI_EXACT) {
        hm = tri_exact8(c, rows, W, 0, live & 0xff, tmin, tmax, t, te, un, vn, den);
        if (W == 16 && (live >> 8))
            hm |= tri_exact8(c, rows, W, 8, live >> 8, tmin, tmax, t, te, un, vn, den) << 8;
    } else if (test == SC_TRI_MOLLER) {
        hm = tri_moller8(c, rows, W, 0, live & 0xff, tmin, tmax, t, un, vn, den);
        if (W == 16 && (live >> 8))
            hm |= tri_moller8(c, rows, W, 8, live >> 8, tmin, tmax, t, un, vn, den) << 8;
    } else {
        hm = tri_watertight8(c, rows, W, 0, live & 0xff, tmin, tmax, t, un, vn, den);
        if (W == 16 && (live >> 8))
            hm |= tri_watertight8(c, rows, W, 8, live >> 8, tmin, tmax, t, un, vn, den) << 8;
    }
    return hm;
}


/* the packet kernels below, for the kernel table */
#if SC_X86_AVX512
#define SC_TRACE_PACKETS_WATERTIGHT                                                                   \
    , .closest_p8 = closest_packet8, .any_p8 = any_packet8, .closest_p16 = closest_packet16,           \
    .any_p16 = any_packet16, .any_stream64 = any_stream64_p16
#else
#define SC_TRACE_PACKETS_WATERTIGHT                                                                   \
    , .closest_p8 = closest_packet8, .any_p8 = any_packet8, .any_stream64 = any_stream64_p8
#endif
#if SC_X86_AVX512
/* sc_order_children with three or more hit children as a sorting network
 * instead of an insertion sort, whose exits incoherent rays mispredict
 * (random rays 5-20 % faster; camera rays, whose order the insertion sort's
 * branches predict, up to 6 % slower: docs/compare.md, fifteenth session;
 * so the kernels of one octant keep the insertion sort: push_children).
 * The keys are 64 bits, the distance's bits above the slot, so the order is
 * sc_order_children's exactly (ties by slot; -0 as 0), and the traversal
 * visits leaves in the same order on every ISA level (the exact test's
 * reported t, u, v can depend on it). Hits are sorted descending (misses
 * -1, last) in one zmm register, the child references permuted into that
 * order, all eight stack entries stored, and the stack pointer moved past
 * the hits but the nearest, which is returned. */
SC_X86_INLINE __m512i sort8_desc_step(__m512i v, __m512i p, const __mmask8 take_max)
{
    return _mm512_mask_blend_epi64(take_max, _mm512_min_epi64(v, p), _mm512_max_epi64(v, p));
}

SC_X86_INLINE uint64_t order_children(const sc_bvh_node8 *node, unsigned mask, const float *dist,
                                      sc_stack_entry *stack, int *sp)
{
    const unsigned rest = mask & (mask - 1);
    if ((rest & (rest - 1)) == 0)
        return sc_order_children(node, mask, dist, stack, sp);
    const __m256i bits = _mm256_max_epi32(_mm256_load_si256((const __m256i *)(const void *)dist),
                                          _mm256_setzero_si256());   /* -0 -> 0; hits are >= 0 */
    __m512i v = _mm512_or_si512(_mm512_slli_epi64(_mm512_cvtepu32_epi64(bits), 32),
                                _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 6, 7));
    v = _mm512_mask_blend_epi64((__mmask8)mask, _mm512_set1_epi64(-1), v);
    /* bitonic network; partners i ^ 1, i ^ 2, i ^ 4 */
#define P1(x) _mm512_shuffle_epi32((x), (_MM_PERM_ENUM)0x4e)
#define P2(x) _mm512_permutex_epi64((x), 0x4e)
#define P4(x) _mm512_shuffle_i64x2((x), (x), 0x4e)
    v = sort8_desc_step(v, P1(v), 0x99);
    v = sort8_desc_step(v, P2(v), 0xc3);
    v = sort8_desc_step(v, P1(v), 0xa5);
    v = sort8_desc_step(v, P4(v), 0x0f);
    v = sort8_desc_step(v, P2(v), 0x33);
    v = sort8_desc_step(v, P1(v), 0x55);
#undef P1
#undef P2
#undef P4
    const __m512i refs = _mm512_permutexvar_epi64(_mm512_and_si512(v, _mm512_set1_epi64(7)),
                                                  _mm512_load_si512((const void *)node->child));
    const __m512i dq = _mm512_srli_epi64(v, 32);   /* the distance, and 0 as the entry's padding */
    sc_stack_entry *s = stack + *sp;               /* sc_stack_entry: ref, dist, 4 bytes of padding */
    _mm512_storeu_si512((void *)s, _mm512_permutex2var_epi64(refs, _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11), dq));
    _mm512_storeu_si512((void *)(s + 4),
                        _mm512_permutex2var_epi64(refs, _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15), dq));
    const int near = __builtin_popcount(mask) - 1;
    *sp += near;
    return (uint64_t)_mm_cvtsi128_si64(
        _mm512_castsi512_si128(_mm512_permutexvar_epi64(_mm512_set1_epi64(near), refs)));
}
#define SC_ORDER_CHILDREN order_children
#endif
/* The top level's packet rows (traverse_top_packet.h) in ymm registers on
 * both levels. On AVX-512 the same code in zmm registers (f32x16, and the
 * transforms in __m512d) cut the instructions of 16-ray packets through
 * 1,000 instances as much, but its bounce-ray packets ran 6 % slower: they
 * leave the packet at the root for single rays, so only the set-up ran in
 * zmm, and with it the whole run was slower on the Xeon measured (a lower
 * clock for 512-bit arithmetic is the likely cause; that VM has no counters
 * to show it). docs/scenes.md, twenty-eighth session. */
#define SC_TOP_VP f32x8

/* The object rays of a top-level packet's 16 lanes: sc_top_object_ray's
 * operations (in double, in the same order, rounded once to float) four
 * lanes at a time, so every lane has the single-ray walk's bits. out: rows
 * ox oy oz, -, dx dy dz (row 3 is not written). */
SC_X86_INLINE void top_xfm16(const double *inv, const float o[3][16], const float d[3][16], float out[8][16])
{
    for (int h = 0; h < 16; h += 4) {
#define LD(p) _mm256_cvtps_pd(_mm_load_ps(p))
        const __m256d ox = LD(o[0] + h), oy = LD(o[1] + h), oz = LD(o[2] + h);
        const __m256d dx = LD(d[0] + h), dy = LD(d[1] + h), dz = LD(d[2] + h);
#undef LD
        for (int i = 0; i < 3; i++) {
            const double *row = inv + 4 * i;
            const __m256d r0 = _mm256_set1_pd(row[0]), r1 = _mm256_set1_pd(row[1]), r2 = _mm256_set1_pd(row[2]);
            /* row[0] x + row[1] y + row[2] z (+ row[3]), left to right */
            __m256d p = _mm256_add_pd(_mm256_mul_pd(r0, ox), _mm256_mul_pd(r1, oy));
            p = _mm256_add_pd(_mm256_add_pd(p, _mm256_mul_pd(r2, oz)), _mm256_set1_pd(row[3]));
            __m256d q = _mm256_add_pd(_mm256_mul_pd(r0, dx), _mm256_mul_pd(r1, dy));
            q = _mm256_add_pd(q, _mm256_mul_pd(r2, dz));
            _mm_store_ps(out[i] + h, _mm256_cvtpd_ps(p));
            _mm_store_ps(out[4 + i] + h, _mm256_cvtpd_ps(q));
        }
    }
}
#define SC_TOP_XFM16 top_xfm16
#include "traverse_bvh8_single.h"
#undef SC_TOP_VP
#undef SC_TOP_XFM16

/* Packets of 8 rays in ymm registers, and on AVX-512 of 16 in zmm. */
#define VP f32x8
#define PK 8
#include "traverse_bvh8_packet.h"
#undef VP
#undef PK
#if SC_X86_AVX512
#define VP f32x16
#define PK 16
#include "traverse_bvh8_packet.h"
#undef VP
#undef PK
#endif

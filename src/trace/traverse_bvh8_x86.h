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
 * -1, last) in two ymm registers, keys 0-3 and 4-7 (the partner i ^ 4 is
 * the other register), the child references permuted into that order, all
 * eight stack entries stored, and the stack pointer moved past the hits
 * but the nearest, which is returned. The same network in one zmm register
 * ran 0-4 % slower on diffuse rays (docs/compare.md, thirty-fourth
 * session): the single-ray kernels keep to 256-bit registers.
 * sort4_step: one compare-exchange step within a register, each key against
 * its partner, the larger kept where take_max says. */
SC_X86_INLINE __m256i sort4_step(__m256i v, __m256i p, const __mmask8 take_max)
{
    return _mm256_mask_blend_epi64(take_max, _mm256_min_epi64(v, p), _mm256_max_epi64(v, p));
}

SC_X86_INLINE uint64_t order_children(const sc_bvh_node8 *node, unsigned mask, const float *dist,
                                      sc_stack_entry *stack, int *sp)
{
    const unsigned rest = mask & (mask - 1);
    if ((rest & (rest - 1)) == 0)
        return sc_order_children(node, mask, dist, stack, sp);
    /* one load of the 8 distances, the size of the node test's store, so
     * that the compiler can take them from the register it stored */
    const __m256i bits = _mm256_max_epi32(_mm256_load_si256((const __m256i *)(const void *)dist),
                                          _mm256_setzero_si256());   /* -0 -> 0; hits are >= 0 */
    const __m128i d0 = _mm256_castsi256_si128(bits), d1 = _mm256_extracti128_si256(bits, 1);
    __m256i a = _mm256_or_si256(_mm256_slli_epi64(_mm256_cvtepu32_epi64(d0), 32), _mm256_setr_epi64x(0, 1, 2, 3));
    __m256i b = _mm256_or_si256(_mm256_slli_epi64(_mm256_cvtepu32_epi64(d1), 32), _mm256_setr_epi64x(4, 5, 6, 7));
    a = _mm256_mask_blend_epi64((__mmask8)(mask & 15), _mm256_set1_epi64x(-1), a);
    b = _mm256_mask_blend_epi64((__mmask8)(mask >> 4), _mm256_set1_epi64x(-1), b);
#define P1(x) _mm256_shuffle_epi32((x), (_MM_PERM_ENUM)0x4e)
#define P2(x) _mm256_permute4x64_epi64((x), 0x4e)
    a = sort4_step(a, P1(a), 0x9), b = sort4_step(b, P1(b), 0x9);
    a = sort4_step(a, P2(a), 0x3), b = sort4_step(b, P2(b), 0xc);
    a = sort4_step(a, P1(a), 0x5), b = sort4_step(b, P1(b), 0xa);
    {
        const __m256i hi = _mm256_max_epi64(a, b);
        b = _mm256_min_epi64(a, b);
        a = hi;
    }
    a = sort4_step(a, P2(a), 0x3), b = sort4_step(b, P2(b), 0x3);
    a = sort4_step(a, P1(a), 0x5), b = sort4_step(b, P1(b), 0x5);
#undef P1
#undef P2
    const __m256i c0 = _mm256_load_si256((const __m256i *)(const void *)node->child);
    const __m256i c1 = _mm256_load_si256((const __m256i *)(const void *)(node->child + 4));
    const __m256i ra = _mm256_permutex2var_epi64(c0, a, c1), rb = _mm256_permutex2var_epi64(c0, b, c1);
    const __m256i qa = _mm256_srli_epi64(a, 32), qb = _mm256_srli_epi64(b, 32);
    sc_stack_entry *s = stack + *sp;               /* sc_stack_entry: ref, dist, 4 bytes of padding */
    const __m256i lo = _mm256_setr_epi64x(0, 4, 1, 5), hi = _mm256_setr_epi64x(2, 6, 3, 7);
    _mm256_storeu_si256((__m256i *)(void *)s, _mm256_permutex2var_epi64(ra, lo, qa));
    _mm256_storeu_si256((__m256i *)(void *)(s + 2), _mm256_permutex2var_epi64(ra, hi, qa));
    _mm256_storeu_si256((__m256i *)(void *)(s + 4), _mm256_permutex2var_epi64(rb, lo, qb));
    _mm256_storeu_si256((__m256i *)(void *)(s + 6), _mm256_permutex2var_epi64(rb, hi, qb));
    const int near = __builtin_popcount(mask) - 1;
    *sp += near;
    return (uint64_t)_mm_cvtsi128_si64(
        _mm256_castsi256_si128(_mm256_permutex2var_epi64(ra, _mm256_set1_epi64x(near), rb)));
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

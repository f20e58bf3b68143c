/* Boxes in four lanes (x, y, z, unused) for the builders' inner loops:
 * two min/max instead of six compares per grow. Every operation gives the
 * bits of its box3.h counterpart lane by lane (vbox_grow is box_grow's
 * compare, since (v)minps(a, b) = a < b ? a : b), so a tree has the same
 * bits on the SSE2 path and the portable one (their bins differ only for a
 * bin product of 2^31 or more, which the builders' finite boxes never give:
 * a centre is at most its range's extent from the range's low end). */
#ifndef SPHERECULL_BVH_VBOX_H
#define SPHERECULL_BVH_VBOX_H

#include "box3.h"

#if defined(__SSE2__)
#include <emmintrin.h>
typedef struct vbox { __m128 lo, hi; } vbox;
typedef __m128 vpoint;   /* x, y, z, unused */
static inline vbox vbox_empty(void) { return (vbox){ _mm_set1_ps(INFINITY), _mm_set1_ps(-INFINITY) }; }
/* lanes lo0 lo1 lo2 hi0 and lo2 hi0 hi1 hi2: two loads inside the box */
static inline vbox vbox_load(const box3 *b)
{
    const __m128 t = _mm_loadu_ps(&b->lo[2]);
    return (vbox){ _mm_loadu_ps(b->lo), _mm_shuffle_ps(t, t, _MM_SHUFFLE(3, 3, 2, 1)) };
}
static inline void vbox_grow(vbox *b, vbox o) { b->lo = _mm_min_ps(o.lo, b->lo), b->hi = _mm_max_ps(o.hi, b->hi); }
static inline void vbox_grow_point(vbox *b, __m128 p) { b->lo = _mm_min_ps(p, b->lo), b->hi = _mm_max_ps(p, b->hi); }
/* grows b by p if `take` (0 or 1), without a branch: the point not taken
 * becomes an empty box's corner (+inf, -inf), which changes nothing */
static inline void vbox_grow_point_if(vbox *b, __m128 p, int take)
{
    const __m128 m = _mm_castsi128_ps(_mm_set1_epi32(-take));
    b->lo = _mm_min_ps(_mm_or_ps(_mm_and_ps(m, p), _mm_andnot_ps(m, _mm_set1_ps(INFINITY))), b->lo);
    b->hi = _mm_max_ps(_mm_or_ps(_mm_and_ps(m, p), _mm_andnot_ps(m, _mm_set1_ps(-INFINITY))), b->hi);
}
static inline __m128 vbox_centre(vbox b)
{
    return _mm_add_ps(_mm_mul_ps(_mm_set1_ps(0.5f), b.lo), _mm_mul_ps(_mm_set1_ps(0.5f), b.hi));
}
static inline box3 vbox_box(vbox b)
{
    float lo[4], hi[4];
    _mm_storeu_ps(lo, b.lo), _mm_storeu_ps(hi, b.hi);
    return (box3){ { lo[0], lo[1], lo[2] }, { hi[0], hi[1], hi[2] } };
}
/* box_area's bits: (v)maxps(d, 0) is its d > 0 ? d : 0 */
static inline float vbox_area(vbox b)
{
    float d[4];
    _mm_storeu_ps(d, _mm_max_ps(_mm_sub_ps(b.hi, b.lo), _mm_setzero_ps()));
    return 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
}
/* the bin of centre c on each axis, clamped to [0, nb), without a branch
 * (a negative, NaN or out-of-range product converts to INT_MIN: bin 0) */
static inline void vbin(__m128 c, __m128 lo, __m128 scale, int nb, int k[4])
{
    __m128i b = _mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(c, lo), scale));
    b = _mm_andnot_si128(_mm_srai_epi32(b, 31), b);
    const __m128i top = _mm_set1_epi32(nb - 1), over = _mm_cmpgt_epi32(b, top);
    _mm_storeu_si128((__m128i *)(void *)k, _mm_or_si128(_mm_and_si128(over, top), _mm_andnot_si128(over, b)));
}
/* one coordinate's bin: vbin's lane, the same conversion (cvttss2si, whose
 * out-of-range and NaN result is INT_MIN, i.e. bin 0), defined for every
 * input */
static inline int vbin1(float c, float lo, float scale, int nb)
{
    const int b = _mm_cvttss_si32(_mm_set_ss((c - lo) * scale));
    return b < 0 ? 0 : b >= nb ? nb - 1 : b;
}
static inline __m128 v3(const float *p) { return _mm_setr_ps(p[0], p[1], p[2], 0); }
#else
typedef struct vbox { box3 b; } vbox;
typedef struct { float v[3]; } v3f;
typedef v3f vpoint;
static inline vbox vbox_empty(void) { vbox b; box_empty(&b.b); return b; }
static inline vbox vbox_load(const box3 *b) { return (vbox){ *b }; }
static inline void vbox_grow(vbox *b, vbox o) { box_grow(&b->b, &o.b); }
static inline void vbox_grow_point(vbox *b, v3f p)
{
    box3 c = { { p.v[0], p.v[1], p.v[2] }, { p.v[0], p.v[1], p.v[2] } };
    box_grow(&b->b, &c);
}
static inline void vbox_grow_point_if(vbox *b, v3f p, int take)
{
    if (take)
        vbox_grow_point(b, p);
}
static inline v3f vbox_centre(vbox b)
{
    v3f c;
    for (int k = 0; k < 3; k++)
        c.v[k] = 0.5f * b.b.lo[k] + 0.5f * b.b.hi[k];
    return c;
}
static inline box3 vbox_box(vbox b) { return b.b; }
static inline float vbox_area(vbox b) { return box_area(&b.b); }
/* one coordinate's bin, clamped to [0, nb); NaN goes to bin 0, and no
 * out-of-range value reaches the conversion */
static inline int vbin1(float c, float lo, float scale, int nb)
{
    const float x = (c - lo) * scale;
    return x >= 0 ? (x < (float)nb ? (int)x : nb - 1) : 0;
}
static inline void vbin(v3f c, v3f lo, v3f scale, int nb, int k[4])
{
    for (int a = 0; a < 3; a++)
        k[a] = vbin1(c.v[a], lo.v[a], scale.v[a], nb);
}
static inline v3f v3(const float *p) { return (v3f){ { p[0], p[1], p[2] } }; }
#endif

/* A primitive's centre on one axis: the bits of vbox_centre's lane. */
static inline float centre_of(const box3 *b, int axis) { return 0.5f * b->lo[axis] + 0.5f * b->hi[axis]; }

#endif

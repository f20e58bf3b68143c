/* The per-ray set-up in ymm registers: the broadcasts every node and leaf
 * test of one ray reuses, computed as ray_setup.h computes them.
 * Part of an x86 traversal translation unit (traverse_bvh8_x86.h), which
 * defines SC_TARGET (the ISA's target attribute) and SC_X86_AVX512 first.
 */
#ifndef SPHERECULL_TRACE_RAY_SETUP_X86_H
#define SPHERECULL_TRACE_RAY_SETUP_X86_H

#include <float.h>
#include <immintrin.h>

#include "bvh/bvh_internal.h"
#include "ray_setup.h"

#define SC_X86_INLINE static inline __attribute__((always_inline)) SC_TARGET

typedef struct {
    __m256 ordn[3], ordf[3], rd[3];
    size_t near_off[3], far_off[3];      /* byte offsets of rows in a node */
    __m256 okx, oky, okz, Sx, Sy, Sz, tmin;   /* broadcast once per ray, not per leaf */
    __m256 xK, xc0;                           /* exact test's edge bound */
    __m256 org[3], rdp[3];                    /* parallel rays' node test */
    float org_s[3], dir_s[3];
    int kx, ky, kz;
} trace_ctx;

/* Per axis in xmm lanes, the larger distance of o from a box's planes
 * (lo and hi: three floats each, a fourth readable). */
SC_X86_INLINE __m128 box_reach4(const float *lo, const float *hi, __m128 o)
{
    const __m128 sgn = _mm_set1_ps(-0.0f);
    return _mm_max_ps(_mm_andnot_ps(sgn, _mm_sub_ps(_mm_loadu_ps(lo), o)),
                      _mm_andnot_ps(sgn, _mm_sub_ps(_mm_loadu_ps(hi), o)));
}

/* sc_slab_offsets on the axes in xmm lanes. */
SC_X86_INLINE void slab_offsets4(__m128 o, __m128 rd, __m128 m, __m128 *ordn, __m128 *ordf)
{
    const __m128 sgn = _mm_set1_ps(-0.0f);
    const __m128 g = _mm_fmadd_ps(_mm_andnot_ps(sgn, o), _mm_set1_ps(0x1.0cp-23f),
                                  _mm_fmadd_ps(m, _mm_set1_ps(0x1.0cp-23f), _mm_set1_ps(0x1p-123f)));
    const __m128 pad = _mm_fmadd_ps(_mm_andnot_ps(sgn, rd), g,
                                    _mm_fmadd_ps(m, _mm_set1_ps(0x1p-124f), _mm_set1_ps(0x1p-122f)));
    const __m128 ord = _mm_mul_ps(o, rd);
    *ordn = _mm_add_ps(ord, pad);
    *ordf = _mm_sub_ps(ord, pad);
}

/* The node test's per-ray constants from the three axes in xmm lanes 0-2,
 * the only place they are set (ctx_init comes through here too).
 * node_test takes the largest entry and the smallest exit distance as
 * signed integers, which order floats as floats do except the negative
 * ones (in reverse, and -0 below every other). With tmin >= +0 among the
 * entries, a negative entry never wins, so the entry is the float maximum
 * (up to the sign of a zero). An exit is the float minimum when none is
 * negative, and some negative otherwise, which fails the float test
 * entry <= exit as the true minimum does: unless it is -0 and the entry
 * +0. So no exit distance may be -0: tmin and tmax are taken as +0 for -0
 * (x + 0.0f), and a far offset of +0 as -0, so that fl(p rd - ordf) is +0
 * where the product is -0 (an exact zero difference is +0 anyway). */
SC_X86_INLINE void ctx_set_slab(trace_ctx *c, __m128 rd, __m128 ordn, __m128 ordf, float tmin)
{
    ordf = _mm_or_ps(ordf, _mm_and_ps(_mm_cmpeq_ps(ordf, _mm_setzero_ps()), _mm_set1_ps(-0.0f)));
    tmin += 0.0f;
#define BC(v, k) _mm256_broadcastss_ps(_mm_permute_ps((v), (k) * 0x55))
    c->rd[0] = BC(rd, 0), c->rd[1] = BC(rd, 1), c->rd[2] = BC(rd, 2);
    c->ordn[0] = BC(ordn, 0), c->ordn[1] = BC(ordn, 1), c->ordn[2] = BC(ordn, 2);
    c->ordf[0] = BC(ordf, 0), c->ordf[1] = BC(ordf, 1), c->ordf[2] = BC(ordf, 2);
#undef BC
    c->tmin = _mm256_set1_ps(tmin);
}

/* The whole context from sc_ray_precompute's constants (the generic and
 * counting kernels); its node-test rows through ctx_set_slab. */
SC_X86_INLINE void ctx_init(trace_ctx *c, const sc_ray_pre *p)
{
#define XYZ(v) _mm_setr_ps((v)[0], (v)[1], (v)[2], 0.0f)
    ctx_set_slab(c, XYZ(p->rd), XYZ(p->ord_near), XYZ(p->ord_far), p->tmin);
#undef XYZ
    for (int k = 0; k < 3; k++) {
        c->near_off[k] = (size_t)p->near_row[k] * SC_BVH_N * sizeof(float);
        c->far_off[k] = (size_t)p->far_row[k] * SC_BVH_N * sizeof(float);
        c->org_s[k] = p->org[k];
        c->org[k] = _mm256_set1_ps(p->org[k]);
        c->rdp[k] = _mm256_set1_ps(p->rdp[k]);
        c->dir_s[k] = p->dir[k];
    }
    c->kx = p->kx, c->ky = p->ky, c->kz = p->kz;
    c->okx = _mm256_set1_ps(p->org[p->kx]);
    c->oky = _mm256_set1_ps(p->org[p->ky]);
    c->okz = _mm256_set1_ps(p->org[p->kz]);
    c->Sx = _mm256_set1_ps(p->Sx);
    c->Sy = _mm256_set1_ps(p->Sy);
    c->Sz = _mm256_set1_ps(p->Sz);
    c->xK = _mm256_set1_ps(p->xK);
    c->xc0 = _mm256_set1_ps(p->xc0);
}

/* The set-up of a non-parallel ray (every kernel with a known octant):
 * sc_ray_precompute's arithmetic with the three axes in one xmm register,
 * one divide instead of three and no stores and reloads of the struct. The
 * per-ray set-up is a visible part of a ray that visits only a node or two
 * (primary rays, and bounce rays that leave the scene). Lane k computes
 * exactly what the scalar code computes for axis k (maxps(a, b) = a > b ?
 * a : b = sc_fmax), so every ISA still sees the same bits. Lane 3 holds
 * tmin/tmax/root_hi[0] and is ignored. The triangle tests' shear is set
 * up here, not at the first leaf: here its divides overlap the first node
 * tests (docs/compare.md, seventh session); the exact test's edge bound
 * only for the exact test. */
SC_X86_INLINE void ctx_init_fast(trace_ctx *c, const sc_ray *r, const sc_bvh *bvh, const int TEST)
{
    const __m128 sgn = _mm_set1_ps(-0.0f);
    const __m128 o = _mm_loadu_ps(r->org), d = _mm_loadu_ps(r->dir);
    const __m128 rd = _mm_div_ps(_mm_set1_ps(1.0f), d);
    const __m128 m = box_reach4(bvh->root_lo, bvh->root_hi, o);
    __m128 ordn, ordf;
    slab_offsets4(o, rd, m, &ordn, &ordf);
    ctx_set_slab(c, rd, ordn, ordf, r->tmin);
    if (TEST == SC_TRI_EXACT) {
        const float mk[3] = { m[0], m[1], m[2] };
        float xK, xc0;
        sc_exact_consts(mk, &xK, &xc0);
        c->xK = _mm256_set1_ps(xK);
        c->xc0 = _mm256_set1_ps(xc0);
    }
    /* The shear of the watertight test, as sc_ray_precompute_shear, without
     * a branch (random directions would mispredict it): the axes from the
     * compare bits through sc_shear_axes's tables, and the values at them by
     * a variable permute. */
    const __m128 ad = _mm_andnot_ps(sgn, d);
    const __m128 ad_yzz = _mm_shuffle_ps(ad, ad, _MM_SHUFFLE(3, 2, 2, 1));   /* |d1| |d2| |d2| */
    const __m128 ad_xxy = _mm_shuffle_ps(ad, ad, _MM_SHUFFLE(3, 1, 0, 0));   /* |d0| |d0| |d1| */
    const int gt = _mm_movemask_ps(_mm_cmpgt_ps(ad_yzz, ad_xxy)) & 7;        /* d1>d0, d2>d0, d2>d1 */
    const int kz = sc_shear_kz_of[gt];
    const int neg = (_mm_movemask_ps(d) >> kz) & 1;
    const int32_t *ax = sc_shear_axes_of[2 * kz + neg];
    const __m128i ctl = _mm_load_si128((const __m128i *)(const void *)ax);
    c->kx = ax[0], c->ky = ax[1], c->kz = kz;
    const __m128 ds = _mm_permutevar_ps(d, ctl), os = _mm_permutevar_ps(o, ctl);   /* at kx, ky, kz */
    const __m128 sxy = _mm_div_ps(ds, _mm_permute_ps(ds, 0xaa));                 /* d[kx] / d[kz], d[ky] / d[kz] */
    const __m128 sz = _mm_permutevar_ps(rd, ctl);                                /* 1 / d[kz], already divided */
#define BC(v, k) _mm256_broadcastss_ps(_mm_permute_ps((v), (k) * 0x55))
    c->okx = BC(os, 0), c->oky = BC(os, 1), c->okz = BC(os, 2);
    c->Sx = BC(sxy, 0), c->Sy = BC(sxy, 1), c->Sz = BC(sz, 2);
#undef BC
    for (int k = 0; k < 3; k++)
        c->org_s[k] = r->org[k], c->dir_s[k] = r->dir[k];
}

/* The byte offsets of the near and far rows in a node (as
 * sc_ray_precompute's near_row/far_row) for each octant: axis k's near row
 * is 2k + 1 when the direction's k-th sign bit is set (its hi plane is met
 * first), else 2k. */
#define SC_ROWB(row) ((size_t)(row) * SC_BVH_N * sizeof(float))
#define SC_ROWS_OF(o)                                                                                 \
    { SC_ROWB(0 + ((o) & 1)), SC_ROWB(2 + ((o) >> 1 & 1)), SC_ROWB(4 + ((o) >> 2 & 1)),                \
      SC_ROWB(1 - ((o) & 1)), SC_ROWB(3 - ((o) >> 1 & 1)), SC_ROWB(5 - ((o) >> 2 & 1)) }
static const size_t sc_rows_of_octant[8][6] = { SC_ROWS_OF(0), SC_ROWS_OF(1), SC_ROWS_OF(2), SC_ROWS_OF(3),
                                                SC_ROWS_OF(4), SC_ROWS_OF(5), SC_ROWS_OF(6), SC_ROWS_OF(7) };
#undef SC_ROWS_OF
#undef SC_ROWB

/* The near and far rows of a non-parallel ray whose octant is not a
 * compile-time constant, from its direction's sign bits (bit k: d_k, -0
 * included; ray_octant's answer): a table row. */
SC_X86_INLINE void ctx_set_rows_signs(trace_ctx *c, unsigned signs)
{
    const size_t *rows = sc_rows_of_octant[signs & 7];
    for (int k = 0; k < 3; k++)
        c->near_off[k] = rows[k], c->far_off[k] = rows[3 + k];
}

/* The same from the ray, its signs read as three floats: the top level's
 * object rays were just stored a float at a time, and a 16-byte load would
 * wait for those stores before the first node's rows are known (instanced
 * bounce rays lost 2 % that way: docs/compare.md, twenty-sixth session). */
SC_X86_INLINE void ctx_set_rows(trace_ctx *c, const sc_ray *r)
{
    ctx_set_rows_signs(c, sc_ray_signs(r));
}

/* ray_octant (traverse_bvh8_single.h) on the direction in one register:
 * sc_ray_parallel's test (|d_k| >= SC_MIN_RCP_INPUT on every axis, false
 * for NaN) as one compare, the octant as the sign bits; the scalar form
 * took 35 instructions a ray. */
SC_X86_INLINE int ray_octant(const sc_ray *r)
{
    const __m128 d = _mm_loadu_ps(r->dir);
    const __m128 ad = _mm_andnot_ps(_mm_set1_ps(-0.0f), d);
    if ((_mm_movemask_ps(_mm_cmpge_ps(ad, _mm_set1_ps(SC_MIN_RCP_INPUT))) & 7) != 7)
        return -2;
    return _mm_movemask_ps(d) & 7;
}
#define SC_HAVE_RAY_OCTANT 1

/* Lanes [h, h+8) of a block of width W (h = 0 for W = 4). On AVX-512 one
 * masked load for every width (a block of 4's upper lanes zeroed): a
 * masked load costs what a load costs, where a branch on W, which a tree
 * mixing leaves of 4 and 8 mispredicts, made the compiler keep two copies
 * of each leaf test. On AVX2 (whose masked load costs more) a block of 4's
 * upper lanes are undefined: every result is masked by `live` (< 16), and
 * float garbage cannot trap (exceptions are masked). */
SC_X86_INLINE __m256 leaf_row8(const float *row, unsigned W, unsigned h)
{
#if SC_X86_AVX512
    return _mm256_maskz_loadu_ps(W == 4 ? 0x0f : 0xff, row + h);
#else
    if (W == 4)
        return _mm256_castps128_ps256(_mm_load_ps(row));
    return _mm256_load_ps(row + h);
#endif
}

SC_X86_INLINE unsigned
mask8(__m256 m)
{
    return (unsigned)_mm256_movemask_ps(m);
}

/* sc_ray_valid on eight rays in rows r[0..8) (ox oy oz tmin dx dy dz tmax)
 * as a lane mask, with its compares: isfinite(d) as |d| <= FLT_MAX, which
 * NaN fails. packet_valid and stream_gather16 check their rays with it. */
SC_X86_INLINE __m256 rays_ok8(const __m256 r[8])
{
    const __m256 sgn = _mm256_set1_ps(-0.0f), omax = _mm256_set1_ps(SC_MAX_ORIGIN), fmax = _mm256_set1_ps(FLT_MAX),
                 zero = _mm256_setzero_ps();
    __m256 ok = _mm256_and_ps(_mm256_cmp_ps(r[3], zero, _CMP_GE_OQ), _mm256_cmp_ps(r[7], r[7], _CMP_ORD_Q));
    __m256 nz = zero;
    for (int a = 0; a < 3; a++) {
        ok = _mm256_and_ps(ok, _mm256_cmp_ps(_mm256_andnot_ps(sgn, r[a]), omax, _CMP_LT_OQ));
        ok = _mm256_and_ps(ok, _mm256_cmp_ps(_mm256_andnot_ps(sgn, r[4 + a]), fmax, _CMP_LE_OQ));
        nz = _mm256_or_ps(nz, _mm256_cmp_ps(r[4 + a], zero, _CMP_NEQ_UQ));
    }
    return _mm256_and_ps(ok, nz);
}

/* sc_packet_valid_ref eight lanes at a time. The public packet calls check
 * every packet: lane by lane in SSE this was about 330 instructions a
 * 16-ray packet, a tenth of tracing a camera packet. */
static SC_TARGET int64_t packet_valid(const int32_t *valid, const float *rows, unsigned K)
{
    uint32_t lanes = 0, bad = 0;
    for (unsigned i = 0; i < K; i += 8) {
        __m256 r[8];
        for (unsigned f = 0; f < 8; f++)
            r[f] = _mm256_loadu_ps(rows + f * K + i);
        const __m256i v = _mm256_loadu_si256((const __m256i *)(const void *)(valid + i));
        const uint32_t vm =
            (uint32_t)_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(v, _mm256_setzero_si256()))) ^ 0xffu;
        lanes |= vm << i;
        bad |= (vm & ~(uint32_t)_mm256_movemask_ps(rays_ok8(r))) << i;
    }
    return bad ? (int64_t)-1 : (int64_t)lanes;
}

#endif

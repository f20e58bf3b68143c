/* Public entry points: argument checks, then the traversal kernels of the
 * active ISA level (src/isa) for the BVH's triangle test. A NULL stats
 * pointer selects the kernel compiled without counters. */
#include <float.h>
#include <string.h>
#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "bvh/bvh_internal.h"
#include "isa/isa_dispatch.h"
#include "ray_setup.h"
#include "trace_packet.h"

sc_status sc_trace_closest(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *stats)
{
    if (!bvh || !ray || !hit || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    if (stats)
        k->closest_stats(bvh, ray, hit, stats);
    else
        k->closest(bvh, ray, hit);
    return SC_OK;
}

sc_status sc_trace_any(const sc_bvh *bvh, const sc_ray *ray, int *occluded, sc_trace_stats *stats)
{
    if (!bvh || !ray || !occluded || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    *occluded = stats ? k->any_stats(bvh, ray, stats) : k->any(bvh, ray);
    return SC_OK;
}

/* ---- packets ---------------------------------------------------------------
 * One body per width: the argument checks, then the level's packet kernel,
 * or lane by lane where it has none. */

/* The valid lanes as a mask; -1 if a valid lane's ray is refused. The
 * conditions of sc_ray_valid four lanes at a time (SSE2, the x86-64
 * baseline): isfinite(d) as |d| <= FLT_MAX, which NaN fails. */
static int64_t packet_valid_lanes(const int32_t *valid, const float *rows, unsigned K)
{
    const float *ox = rows, *oy = rows + K, *oz = rows + 2 * K, *tmin = rows + 3 * K, *dx = rows + 4 * K,
                *dy = rows + 5 * K, *dz = rows + 6 * K, *tmax = rows + 7 * K;
    uint32_t lanes = 0, bad = 0;
#if defined(__SSE2__)
    const __m128 sgn = _mm_set1_ps(-0.0f), omax = _mm_set1_ps(SC_MAX_ORIGIN), fmax = _mm_set1_ps(FLT_MAX),
                 zero = _mm_setzero_ps();
    for (unsigned i = 0; i < K; i += 4) {
#define ABS(p) _mm_andnot_ps(sgn, _mm_loadu_ps((p) + i))
        __m128 ok = _mm_and_ps(_mm_and_ps(_mm_cmplt_ps(ABS(ox), omax), _mm_cmplt_ps(ABS(oy), omax)),
                               _mm_cmplt_ps(ABS(oz), omax));
        ok = _mm_and_ps(ok, _mm_and_ps(_mm_and_ps(_mm_cmple_ps(ABS(dx), fmax), _mm_cmple_ps(ABS(dy), fmax)),
                                       _mm_cmple_ps(ABS(dz), fmax)));
        __m128 nz = _mm_or_ps(_mm_or_ps(_mm_cmpneq_ps(_mm_loadu_ps(dx + i), zero),
                                        _mm_cmpneq_ps(_mm_loadu_ps(dy + i), zero)),
                              _mm_cmpneq_ps(_mm_loadu_ps(dz + i), zero));
        ok = _mm_and_ps(_mm_and_ps(ok, nz), _mm_cmpge_ps(_mm_loadu_ps(tmin + i), zero));
        ok = _mm_and_ps(ok, _mm_cmpord_ps(_mm_loadu_ps(tmax + i), _mm_loadu_ps(tmax + i)));
#undef ABS
        __m128i v = _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)(const void *)(valid + i)), _mm_setzero_si128());
        uint32_t vm = (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(v)) ^ 15u;
        lanes |= vm << i;
        bad |= (vm & ~(uint32_t)_mm_movemask_ps(ok)) << i;
    }
#else
    for (unsigned i = 0; i < K; i++) {
        const sc_ray r = { { ox[i], oy[i], oz[i] }, tmin[i], { dx[i], dy[i], dz[i] }, tmax[i] };
        const uint32_t v = valid[i] != 0;
        lanes |= v << i;
        bad |= (v & (uint32_t)!sc_ray_valid(&r)) << i;
    }
#endif
    return bad ? (int64_t)-1 : (int64_t)lanes;
}
static int aligned_to(const void *p, uintptr_t a) { return ((uintptr_t)p & (a - 1)) == 0; }

/* One body for the four packet calls. rays: the packet's rows (ox oy oz
 * tmin dx dy dz tmax, W floats each); out: the hit packet (closest) or the
 * int32_t occlusion array (any). The level's kernel of that width; a
 * 16-ray packet on a level with 8-lane kernels as two halves; lane by lane
 * through the single-ray kernels where the level or test has none. */
void sc_trace_packet_lanes(const sc_bvh *bvh, uint32_t lanes, const float *rows, unsigned W, void *out, int any,
                           sc_trace_stats *stats)
{
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    if (W == 16 && (any ? k->any_p16 != NULL : k->closest_p16 != NULL)) {
        if (any)
            k->any_p16(bvh, (const sc_ray_packet16 *)(const void *)rows, lanes, out, stats);
        else
            k->closest_p16(bvh, (const sc_ray_packet16 *)(const void *)rows, lanes, out, stats);
        return;
    }
    if (any ? k->any_p8 != NULL : k->closest_p8 != NULL) {
        /* 8 lanes, or each half of 16 as a packet of 8 */
        for (unsigned h = 0; h < W / 8; h++) {
            const uint32_t hl = (lanes >> (8 * h)) & 0xff;
            if (!hl)
                continue;
            sc_ray_packet8 r8 __attribute__((aligned(32)));
            for (unsigned f = 0; f < 8; f++)
                memcpy(r8.ox + 8 * f, rows + f * W + 8 * h, 8 * sizeof(float));
            if (any) {
                k->any_p8(bvh, &r8, hl, (int32_t *)out + 8 * h, stats);
            } else if (W == 8) {
                k->closest_p8(bvh, &r8, hl, out, stats);
            } else {
                sc_hit_packet8 h8 __attribute__((aligned(32)));
                sc_hit_packet16 *h16 = out;
                k->closest_p8(bvh, &r8, hl, &h8, stats);
                for (uint32_t e = hl; e; e &= e - 1) {
                    const unsigned i = (unsigned)__builtin_ctz(e);
                    sc_hitrec one;
                    sc_hit_lane_get(&h8, 8, i, &one);
                    sc_hit_lane_put(h16, 16, 8 * h + i, &one);
                }
            }
        }
        return;
    }
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned i = (unsigned)__builtin_ctz(e);
        const sc_ray r = { { rows[i], rows[W + i], rows[2 * W + i] }, rows[3 * W + i],
                           { rows[4 * W + i], rows[5 * W + i], rows[6 * W + i] }, rows[7 * W + i] };
        if (any) {
            ((int32_t *)out)[i] = stats ? k->any_stats(bvh, &r, stats) : k->any(bvh, &r);
            continue;
        }
        sc_hitrec h;
        if (stats)
            k->closest_stats(bvh, &r, &h, stats);
        else
            k->closest(bvh, &r, &h);
        sc_hit_lane_put(out, W, i, &h);
    }
}

int64_t sc_packet_checked_lanes(const int32_t *valid, const float *rows, unsigned W, const void *out, int any)
{
    const uintptr_t align = W * 4;
    if (!valid || !rows || !out || !aligned_to(rows, align) || (!any && !aligned_to(out, align)))
        return -1;
    return packet_valid_lanes(valid, rows, W);
}

static sc_status trace_packet(const sc_bvh *bvh, const int32_t *valid, const float *rows, unsigned W, void *out,
                              int any, sc_trace_stats *stats)
{
    const int64_t lanes = bvh ? sc_packet_checked_lanes(valid, rows, W, out, any) : -1;
    if (lanes < 0)
        return SC_ERR_INVALID_ARGUMENT;
    sc_trace_packet_lanes(bvh, (uint32_t)lanes, rows, W, out, any, stats);
    return SC_OK;
}

sc_status sc_trace_closest8(const sc_bvh *bvh, const int32_t valid[8], const sc_ray_packet8 *rays,
                            sc_hit_packet8 *hits, sc_trace_stats *stats)
{
    return trace_packet(bvh, valid, (const float *)(const void *)rays, 8, hits, 0, stats);
}

sc_status sc_trace_closest16(const sc_bvh *bvh, const int32_t valid[16], const sc_ray_packet16 *rays,
                             sc_hit_packet16 *hits, sc_trace_stats *stats)
{
    return trace_packet(bvh, valid, (const float *)(const void *)rays, 16, hits, 0, stats);
}

sc_status sc_trace_any8(const sc_bvh *bvh, const int32_t valid[8], const sc_ray_packet8 *rays,
                        int32_t occluded[8], sc_trace_stats *stats)
{
    return trace_packet(bvh, valid, (const float *)(const void *)rays, 8, occluded, 1, stats);
}

sc_status sc_trace_any16(const sc_bvh *bvh, const int32_t valid[16], const sc_ray_packet16 *rays,
                         int32_t occluded[16], sc_trace_stats *stats)
{
    return trace_packet(bvh, valid, (const float *)(const void *)rays, 16, occluded, 1, stats);
}

/* ---- streams ---------------------------------------------------------------
 * A run of 16 consecutive rays goes as one packet when it looks coherent,
 * else ray by ray. Coherent: directions within a narrow box once scaled to
 * unit L1 length (camera tiles, shadow rays of a tile to one light), or
 * origins within 1/16 of the scene's extent (the bounces of one pixel tile:
 * the packet kernel hands lanes that part ways to the single-ray kernel).
 * Random rays (origins and directions all over) pass neither and go one by
 * one, which measured 1.4x faster for them than packets (docs/compare.md,
 * "Packets and streams"). */
#define SC_STREAM_SPREAD 0.2f
#define SC_STREAM_ORIGINS (1.0f / 16)

#if defined(__SSE2__)
/* The smallest (largest) of four lanes by shuffles: fminf and fmaxf are
 * calls at the baseline ISA level this file is built for. */
static inline float lanes_min4(__m128 v)
{
    v = _mm_min_ps(v, _mm_movehl_ps(v, v));
    return _mm_cvtss_f32(_mm_min_ss(v, _mm_shuffle_ps(v, v, 1)));
}

static inline float lanes_max4(__m128 v)
{
    v = _mm_max_ps(v, _mm_movehl_ps(v, v));
    return _mm_cvtss_f32(_mm_max_ss(v, _mm_shuffle_ps(v, v, 1)));
}
#endif

static int packet_coherent(const sc_ray_packet16 *p, const float *lo, const float *hi)
{
    float dlo[3], dhi[3], olo[3], ohi[3];
    const float *org[3] = { p->ox, p->oy, p->oz }, *dir[3] = { p->dx, p->dy, p->dz };
#if defined(__SSE2__)
    const __m128 sgn = _mm_set1_ps(-0.0f), one = _mm_set1_ps(1.0f);
    __m128 vdlo[3], vdhi[3], volo[3], vohi[3];
    for (unsigned i = 0; i < 16; i += 4) {
        const __m128 d[3] = { _mm_load_ps(p->dx + i), _mm_load_ps(p->dy + i), _mm_load_ps(p->dz + i) };
        const __m128 inv = _mm_div_ps(one, _mm_add_ps(_mm_add_ps(_mm_andnot_ps(sgn, d[0]), _mm_andnot_ps(sgn, d[1])),
                                                     _mm_andnot_ps(sgn, d[2])));
        for (int a = 0; a < 3; a++) {
            const __m128 u = _mm_mul_ps(d[a], inv), o = _mm_load_ps(org[a] + i);
            vdlo[a] = i ? _mm_min_ps(vdlo[a], u) : u, vdhi[a] = i ? _mm_max_ps(vdhi[a], u) : u;
            volo[a] = i ? _mm_min_ps(volo[a], o) : o, vohi[a] = i ? _mm_max_ps(vohi[a], o) : o;
        }
    }
    for (int a = 0; a < 3; a++) {
        dlo[a] = lanes_min4(vdlo[a]), dhi[a] = lanes_max4(vdhi[a]);
        olo[a] = lanes_min4(volo[a]), ohi[a] = lanes_max4(vohi[a]);
    }
#else
    for (int a = 0; a < 3; a++)
        dlo[a] = olo[a] = INFINITY, dhi[a] = ohi[a] = -INFINITY;
    for (unsigned i = 0; i < 16; i++) {
        float inv = 1 / (fabsf(p->dx[i]) + fabsf(p->dy[i]) + fabsf(p->dz[i]));
        for (int a = 0; a < 3; a++) {
            float u = dir[a][i] * inv, o = org[a][i];
            dlo[a] = fminf(dlo[a], u), dhi[a] = fmaxf(dhi[a], u);
            olo[a] = fminf(olo[a], o), ohi[a] = fmaxf(ohi[a], o);
        }
    }
#endif
    (void)dir;
    int narrow = 1, near = 1;
    for (int a = 0; a < 3; a++) {
        narrow &= dhi[a] - dlo[a] <= SC_STREAM_SPREAD;
        near &= ohi[a] - olo[a] <= SC_STREAM_ORIGINS * (hi[a] - lo[a]);
    }
    return narrow || near;
}

/* A quick "no" before the transpose: the first and the last ray of a run
 * (opposite corners of a pixel tile) already differ more in direction and
 * in origin than a coherent run may. Random rays leave here. */
static int pair_incoherent(const sc_ray *a, const sc_ray *b, const float *lo, const float *hi)
{
    float la = fabsf(a->dir[0]) + fabsf(a->dir[1]) + fabsf(a->dir[2]);
    float lb = fabsf(b->dir[0]) + fabsf(b->dir[1]) + fabsf(b->dir[2]);
    int dir_far = 0, org_far = 0;
    for (int k = 0; k < 3; k++) {
        dir_far |= fabsf(a->dir[k] * lb - b->dir[k] * la) > SC_STREAM_SPREAD * la * lb;
        org_far |= fabsf(a->org[k] - b->org[k]) > SC_STREAM_ORIGINS * (hi[k] - lo[k]);
    }
    return dir_far && org_far;
}

/* Rays [base, base + cnt) (cnt <= 16) as one packet; on a refused ray, one
 * by one (which answers the others). */
static sc_status stream_packet(const sc_stream_target *T, const char *rays, size_t ray_stride, char *out,
                               size_t out_stride, size_t base, unsigned cnt, sc_trace_stats *stats, int any)
{
#define RAY(j) ((const sc_ray *)(const void *)(rays + (base + (j)) * ray_stride))
#define OUT(j) (out + (base + (j)) * out_stride)
    sc_ray_packet16 p __attribute__((aligned(64)));
    int32_t valid[16];
    float *soa = p.ox;
    if (cnt == 16 && pair_incoherent(RAY(0), RAY(15), T->lo, T->hi))
        goto one_by_one;
#if defined(__SSE2__)
    if (cnt == 16) {
        /* rows ox oy oz tmin dx dy dz tmax: 4x4 transposes of the rays'
         * two halves (sc_ray is org, tmin, dir, tmax) */
        for (unsigned i = 0; i < 16; i += 4)
            for (unsigned h = 0; h < 8; h += 4) {
                __m128 r0 = _mm_loadu_ps(RAY(i)->org + h), r1 = _mm_loadu_ps(RAY(i + 1)->org + h);
                __m128 r2 = _mm_loadu_ps(RAY(i + 2)->org + h), r3 = _mm_loadu_ps(RAY(i + 3)->org + h);
                _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
                _mm_store_ps(soa + (h + 0) * 16 + i, r0);
                _mm_store_ps(soa + (h + 1) * 16 + i, r1);
                _mm_store_ps(soa + (h + 2) * 16 + i, r2);
                _mm_store_ps(soa + (h + 3) * 16 + i, r3);
            }
        for (unsigned i = 0; i < 16; i++)
            valid[i] = 1;
    } else
#endif
    {
        for (unsigned i = 0; i < 16; i++) {
            const sc_ray *r = RAY(i < cnt ? i : cnt - 1);
            valid[i] = i < cnt;
            p.ox[i] = r->org[0], p.oy[i] = r->org[1], p.oz[i] = r->org[2], p.tmin[i] = r->tmin;
            p.dx[i] = r->dir[0], p.dy[i] = r->dir[1], p.dz[i] = r->dir[2], p.tmax[i] = r->tmax;
        }
    }
    if (cnt == 16 && !packet_coherent(&p, T->lo, T->hi))
        goto one_by_one;
    if (any) {
        int32_t occ[16];
        if (T->packet16(T->obj, valid, &p, occ, 1, stats) == SC_OK) {
            for (unsigned i = 0; i < cnt; i++)
                *(int32_t *)(void *)OUT(i) = occ[i];
            return SC_OK;
        }
    } else {
        sc_hit_packet16 h __attribute__((aligned(64)));
        if (T->packet16(T->obj, valid, &p, &h, 0, stats) == SC_OK) {
            for (unsigned i = 0; i < cnt; i++) {
                sc_hitrec one;
                sc_hit_lane_get(&h, 16, i, &one);
                memcpy(OUT(i), &one, sizeof one);
            }
            return SC_OK;
        }
    }
one_by_one:;
    /* rays the coherence tests sent alone, or a packet with a refused ray
     * (whose others are answered here) */
    sc_status status = SC_OK;
    for (unsigned i = 0; i < cnt; i++)
        if (T->single(T->obj, RAY(i), OUT(i), any, 1, stats) != SC_OK)
            status = SC_ERR_INVALID_ARGUMENT;
    return status;
#undef RAY
#undef OUT
}

sc_status sc_stream_run(const sc_stream_target *T, const sc_ray *rays, size_t ray_stride, void *out,
                        size_t out_stride, size_t n, sc_trace_stats *stats, int any)
{
    sc_status status = SC_OK;
    for (size_t base = 0; base < n; base += 16) {
        const unsigned cnt = n - base < 16 ? (unsigned)(n - base) : 16;
        sc_status st = stream_packet(T, (const char *)rays, ray_stride, (char *)out, out_stride, base, cnt,
                                     stats, any);
        if (st != SC_OK)
            status = st;
    }
    return status;
}

/* A BVH as a stream's target. Rays that failed the coherence tests go to
 * the kernels without the octant branch, which random directions
 * mispredict (not with statistics, which have one generic kernel anyway). */
static sc_status bvh_packet16(const void *obj, const int32_t valid[16], const sc_ray_packet16 *rays, void *out,
                              int any, sc_trace_stats *stats)
{
    return any ? sc_trace_any16(obj, valid, rays, out, stats) : sc_trace_closest16(obj, valid, rays, out, stats);
}

static sc_status bvh_single(const void *obj, const sc_ray *ray, void *out, int any, int incoherent,
                            sc_trace_stats *stats)
{
    const sc_bvh *bvh = obj;
    if (incoherent && !stats && sc_ray_valid(ray)) {
        const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
        if (any)
            *(int32_t *)out = k->any_incoherent(bvh, ray);
        else
            k->closest_incoherent(bvh, ray, out);
        return SC_OK;
    }
    if (!any)
        return sc_trace_closest(bvh, ray, out, stats);
    int o = 0;
    const sc_status st = sc_trace_any(bvh, ray, &o, stats);
    if (st == SC_OK)
        *(int32_t *)out = o;
    return st;
}

static sc_status stream(const sc_bvh *bvh, const sc_ray *rays, size_t ray_stride, void *out, size_t out_stride,
                        size_t n, unsigned flags, sc_trace_stats *stats, int any)
{
    if (!bvh || (n && (!rays || !out)) || ray_stride < sizeof(sc_ray) ||
        out_stride < (any ? sizeof(int32_t) : sizeof(sc_hitrec)) || flags != 0)
        return SC_ERR_INVALID_ARGUMENT;
    const sc_stream_target T = { bvh, bvh->root_lo, bvh->root_hi, bvh_packet16, bvh_single };
    return sc_stream_run(&T, rays, ray_stride, out, out_stride, n, stats, any);
}

sc_status sc_trace_closest_n(const sc_bvh *bvh, const sc_ray *rays, size_t ray_stride, sc_hitrec *hits,
                             size_t hit_stride, size_t n, unsigned flags, sc_trace_stats *stats)
{
    return stream(bvh, rays, ray_stride, hits, hit_stride, n, flags, stats, 0);
}

sc_status sc_trace_any_n(const sc_bvh *bvh, const sc_ray *rays, size_t ray_stride, int32_t *occluded,
                         size_t occluded_stride, size_t n, unsigned flags, sc_trace_stats *stats)
{
    return stream(bvh, rays, ray_stride, occluded, occluded_stride, n, flags, stats, 1);
}

/* Public entry points: argument checks, then the traversal kernels of the
 * active ISA level (src/isa) for the BVH's triangle test. A NULL stats
 * pointer selects the kernel compiled without counters. */
#include <stddef.h>
#include <string.h>
#if defined(__SSE2__)
#include <immintrin.h>
#endif
#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#endif

#include "bvh/bvh_internal.h"
#include "common/sc_clock.h"
#include "isa/isa_dispatch.h"
#include "ray_setup.h"
#include "stream_gather.h"
#include "trace_packet.h"

sc_status sc_trace_closest(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *stats)
{
    if (!bvh || !ray || !hit || !sc_ray_valid_sse(ray))
        return SC_ERR_INVALID_ARGUMENT;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    if (stats)
        k->closest_stats(bvh, ray, hit, stats);
    else
        k->closest_adaptive(bvh, ray, hit);
    return SC_OK;
}

sc_status sc_trace_any(const sc_bvh *bvh, const sc_ray *ray, int *occluded, sc_trace_stats *stats)
{
    if (!bvh || !ray || !occluded || !sc_ray_valid_sse(ray))
        return SC_ERR_INVALID_ARGUMENT;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    *occluded = stats ? k->any_stats(bvh, ray, stats) : k->any(bvh, ray);
    return SC_OK;
}

/* ---- packets ---------------------------------------------------------------
 * One body per width: the argument checks, then the level's packet kernel,
 * or lane by lane where it has none. */

static int aligned_to(const void *p, uintptr_t a) { return ((uintptr_t)p & (a - 1)) == 0; }

/* A quick "no" before the gather: the first and the last ray of a run
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

/* Lane l of a packet's rows as a ray. */
static sc_ray packet_ray(const float *rows, unsigned W, unsigned l)
{
    return (sc_ray){ { rows[l], rows[W + l], rows[2 * W + l] }, rows[3 * W + l],
                     { rows[4 * W + l], rows[5 * W + l], rows[6 * W + l] }, rows[7 * W + l] };
}

/* Lanes `lanes` of a packet one by one through the single-ray kernels:
 * those without the octant branch when the rays are incoherent. */
static void packet_lanes_single(const sc_bvh *bvh, uint32_t lanes, const float *rows, unsigned W, void *out, int any,
                                sc_trace_stats *stats, int incoherent)
{
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    for (uint32_t e = lanes; e; e &= e - 1) {
        const unsigned i = (unsigned)__builtin_ctz(e);
        const sc_ray r = packet_ray(rows, W, i);
        if (any) {
            ((int32_t *)out)[i] = stats ? k->any_stats(bvh, &r, stats)
                                        : incoherent ? k->any_incoherent(bvh, &r) : k->any(bvh, &r);
            continue;
        }
        sc_hitrec h;
        if (stats)
            k->closest_stats(bvh, &r, &h, stats);
        else if (incoherent)
            k->closest_incoherent(bvh, &r, &h);
        else
            k->closest(bvh, &r, &h);
        sc_hit_lane_put(out, W, i, &h);
    }
}

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
            /* a packet of 8 is already one (aligned as the caller checked) */
            sc_ray_packet8 r8 __attribute__((aligned(32)));
            const sc_ray_packet8 *p8 = (const sc_ray_packet8 *)(const void *)rows;
            if (W == 16) {
                for (unsigned f = 0; f < 8; f++)
                    memcpy(r8.ox + 8 * f, rows + f * W + 8 * h, 8 * sizeof(float));
                p8 = &r8;
            }
            if (any) {
                k->any_p8(bvh, p8, hl, (int32_t *)out + 8 * h, stats);
            } else if (W == 8) {
                k->closest_p8(bvh, p8, hl, out, stats);
            } else {
                sc_hit_packet8 h8 __attribute__((aligned(32)));
                sc_hit_packet16 *h16 = out;
                k->closest_p8(bvh, p8, hl, &h8, stats);
                if (hl == 0xff) {
                    /* a full half (camera rays): its nine rows whole, not
                     * 72 fields one by one */
                    const float *src = (const float *)(const void *)&h8;   /* as sc_hit_lane_get reads it */
                    float *dst = (float *)(void *)h16;
                    for (unsigned f = 0; f < 9; f++)
                        memcpy(dst + 16 * f + 8 * h, src + 8 * f, 8 * sizeof(float));
                    continue;
                }
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
    packet_lanes_single(bvh, lanes, rows, W, out, any, stats, 0);
}

int64_t sc_packet_checked_lanes(const int32_t *valid, const float *rows, unsigned W, const void *out, int any)
{
    const uintptr_t align = W * 4;
    if (!valid || !rows || !out || !aligned_to(rows, align) || (!any && !aligned_to(out, align)))
        return -1;
    return sc_kernels_active()->trace[0].packet_valid(valid, rows, W);
}

/* A packet whose first and last lanes already differ in origin and in
 * direction more than a stream's coherent run may (pair_incoherent):
 * random rays, bounce rays from scattered hits. Its lanes take the
 * single-ray kernels without the octant branch, as a stream's incoherent
 * rays do; the packet kernel ran such packets slower than the single rays
 * (docs/compare.md, thirty-seventh session), where Embree's hybrid
 * kernel, told the rays are incoherent, leaves a packet for single rays
 * as soon as two of its 16 lanes are done. The answers are the same. */
static int packet_incoherent(const sc_bvh *bvh, uint32_t lanes, const float *rows, unsigned W)
{
    if (!lanes || !bvh->has_root)
        return 0;
    const sc_ray a = packet_ray(rows, W, (unsigned)__builtin_ctz(lanes));
    const sc_ray b = packet_ray(rows, W, 31u - (unsigned)__builtin_clz(lanes));
    return pair_incoherent(&a, &b, bvh->root_lo, bvh->root_hi);
}

static sc_status trace_packet(const sc_bvh *bvh, const int32_t *valid, const float *rows, unsigned W, void *out,
                              int any, sc_trace_stats *stats)
{
    const int64_t lanes = bvh ? sc_packet_checked_lanes(valid, rows, W, out, any) : -1;
    if (lanes < 0)
        return SC_ERR_INVALID_ARGUMENT;
    if (!stats && packet_incoherent(bvh, (uint32_t)lanes, rows, W))
        packet_lanes_single(bvh, (uint32_t)lanes, rows, W, out, any, NULL, 1);
    else
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
 * A run of 16 consecutive rays goes as one packet when it looks coherent
 * (stream_gather.h), else ray by ray. */

/* Lanes [0, cnt) of a 16-lane hit packet to the hit records at out, each
 * field stored straight into its record: a record filled field by field in
 * a local and then copied whole stalled every ray on store forwarding (four
 * small stores read back by one wide load). With SSE2, four lanes at a time:
 * 4x4 transposes of the rows t u v prim and ng_x ng_y ng_z geom are the
 * records' first 32 bytes (sc_hitrec's layout), then inst. */
static void hit_rows_to_records(const sc_hit_packet16 *h, unsigned cnt, char *out, size_t out_stride)
{
    _Static_assert(offsetof(sc_hitrec, ng) == 16 && offsetof(sc_hitrec, inst) == 32, "sc_hitrec's layout");
    const float *f = h->t;
    unsigned i = 0;
#if defined(__SSE2__)
    for (; i + 4 <= cnt; i += 4)
        for (unsigned half = 0; half < 8; half += 4) {
            __m128 r0 = _mm_load_ps(f + (half + 0) * 16 + i), r1 = _mm_load_ps(f + (half + 1) * 16 + i);
            __m128 r2 = _mm_load_ps(f + (half + 2) * 16 + i), r3 = _mm_load_ps(f + (half + 3) * 16 + i);
            _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
            _mm_storeu_ps((float *)(void *)(out + (i + 0) * out_stride) + half, r0);
            _mm_storeu_ps((float *)(void *)(out + (i + 1) * out_stride) + half, r1);
            _mm_storeu_ps((float *)(void *)(out + (i + 2) * out_stride) + half, r2);
            _mm_storeu_ps((float *)(void *)(out + (i + 3) * out_stride) + half, r3);
        }
    for (unsigned j = 0; j < i; j++)
        memcpy(out + j * out_stride + offsetof(sc_hitrec, inst), &h->inst[j], sizeof h->inst[j]);
#endif
    /* the rest field by field, into the record (which the one-by-one path
     * writes as an sc_hitrec too) */
    for (; i < cnt; i++)
        sc_hit_lane_get(h, 16, i, (sc_hitrec *)(void *)(out + i * out_stride));
}

/* The incoherent rays of a stream waiting for the target's batch kernel:
 * the more rays it has in hand, the longer its slots stay full. */
#define SC_STREAM_QUEUE 256
typedef struct stream_queue {
    unsigned n;
    const sc_ray *ray[SC_STREAM_QUEUE];
    void *out[SC_STREAM_QUEUE];
} stream_queue;

static void queue_flush(const sc_stream_target *T, stream_queue *q, int any)
{
    if (q->n)
        T->batch(T->obj, q->ray, q->out, q->n, any);
    q->n = 0;
}

#define RAY(j) ((const sc_ray *)(const void *)(rays + (base + (j)) * ray_stride))
#define OUT(j) (out + (base + (j)) * out_stride)

/* Rays [base, base + cnt) (cnt <= 16) into the packet p with its lanes:
 * SC_GATHER_COHERENT or SC_GATHER_NEAR if they may go as a packet (the
 * tail of a stream is always a coherent packet), else SC_GATHER_INCOHERENT
 * (one by one: the coherence tests failed, or a ray is refused). */
static int stream_gather(const sc_stream_target *T, const char *rays, size_t ray_stride, size_t base, unsigned cnt,
                         sc_ray_packet16 *p, uint32_t *lanes)
{
    if (cnt == 16) {
        if (pair_incoherent(RAY(0), RAY(15), T->lo, T->hi))
            return SC_GATHER_INCOHERENT;
        const int g = sc_kernels_active()->trace[0].stream_gather16(rays + base * ray_stride, ray_stride, T->lo,
                                                                      T->hi, p);
        *lanes = 0xffff;
        return g == SC_GATHER_REFUSED ? SC_GATHER_INCOHERENT : g;
    }
    /* the tail of the stream; the unused lanes repeat its last ray */
    for (unsigned i = 0; i < 16; i++) {
        const sc_ray *r = RAY(i < cnt ? i : cnt - 1);
        if (i < cnt && !sc_ray_valid(r))
            return SC_GATHER_INCOHERENT;
        p->ox[i] = r->org[0], p->oy[i] = r->org[1], p->oz[i] = r->org[2], p->tmin[i] = r->tmin;
        p->dx[i] = r->dir[0], p->dy[i] = r->dir[1], p->dz[i] = r->dir[2], p->tmax[i] = r->tmax;
    }
    *lanes = (1u << cnt) - 1;
    return SC_GATHER_COHERENT;
}

/* Rays [base, base + cnt) one by one: rays the coherence tests sent alone,
 * or a run with a refused ray (whose others are answered here); into the
 * queue q when the target has a batch kernel and no statistics are asked
 * for, else the whole run through the target's alone hook when it has one
 * and no statistics are asked for, else ray by ray through single. */
static sc_status stream_alone(const sc_stream_target *T, const char *rays, size_t ray_stride, char *out,
                              size_t out_stride, size_t base, unsigned cnt, sc_trace_stats *stats, int any,
                              stream_queue *q)
{
    if (!q && !stats && T->alone)
        return T->alone(T->obj, rays + base * ray_stride, ray_stride, OUT(0), out_stride, cnt, any);
    sc_status status = SC_OK;
    for (unsigned i = 0; i < cnt; i++) {
        if (q && sc_ray_valid(RAY(i))) {
            q->ray[q->n] = RAY(i), q->out[q->n] = OUT(i);
            q->n++;
        } else if (T->single(T->obj, RAY(i), OUT(i), any, 1, stats) != SC_OK) {
            status = SC_ERR_INVALID_ARGUMENT;
        }
    }
    return status;
}

/* The packet p (rays [base, base + cnt)) traced, its answers stored. */
static void stream_packet(const sc_stream_target *T, const sc_ray_packet16 *p, uint32_t lanes, char *out,
                          size_t out_stride, size_t base, unsigned cnt, sc_trace_stats *stats, int any)
{
    if (any) {
        int32_t occ[16];
        T->packet16(T->obj, lanes, p, occ, 1, stats);
        for (unsigned i = 0; i < cnt; i++)
            memcpy(OUT(i), &occ[i], sizeof occ[i]);
    } else {
        sc_hit_packet16 h __attribute__((aligned(64)));
        T->packet16(T->obj, lanes, p, &h, 0, stats);
        hit_rows_to_records(&h, cnt, OUT(0), out_stride);
    }
}
#undef RAY
#undef OUT

/* Up to four gathered any-hit packets waiting to be traced as a group. */
typedef struct stream_group {
    unsigned n;
    sc_ray_packet16 p[4] __attribute__((aligned(64)));
    uint32_t lanes[4];
    size_t base[4];
    unsigned cnt[4];
} stream_group;

static void group_flush(const sc_stream_target *T, stream_group *g, char *out, size_t out_stride,
                        sc_trace_stats *stats)
{
    if (g->n == 1) {
        stream_packet(T, &g->p[0], g->lanes[0], out, out_stride, g->base[0], g->cnt[0], stats, 1);
    } else if (g->n) {
        int32_t occ[64];
        for (unsigned i = g->n; i < 4; i++)
            g->lanes[i] = 0;
        T->group64(T->obj, g->p, g->lanes, occ, stats);
        for (unsigned i = 0; i < g->n; i++)
            for (unsigned j = 0; j < g->cnt[i]; j++)
                memcpy(out + (g->base[i] + j) * out_stride, &occ[16 * i + j], sizeof occ[0]);
    }
    g->n = 0;
}

/* Closest-hit runs with near origins and spread directions (SC_GATHER_NEAR:
 * a tile's bounces) go as a packet or one by one, whichever this thread has
 * timed faster on this target. Neither wins everywhere: as packets such
 * runs were 1.3-1.65x our single rays inside Sponza and off fandisk's flat
 * faces, where the lanes share their first nodes, and 0.87-0.90x off the
 * scanned meshes, where they part at once (docs/compare.md, forty-third
 * session). Once every SC_NEAR_PROBE NEAR runs (4 or 16 times as seldom
 * once one path is 1.25x or 2x ahead) two neighbouring runs, which cost
 * about the same, take one path each and are timed (the time-stamp counter;
 * the monotonic clock off x86); a decayed mean of the pairs' log ratios
 * picks the path of the other runs. Pairs, because a run's cost changes
 * across an image more than between the paths: a mean cost per path, from
 * runs of other parts of the image, picked the wrong one. Both paths give
 * the same hits; only the speed depends on the history. Not with
 * statistics (counts should not depend on timing), nor in trees whose
 * lone rays wait for the interleaved batch (a run cannot be timed there),
 * nor for any-hit runs, which keep the packets' grouping. Thread-local,
 * initial-exec, as the octant history (traverse_bvh8_single.h); reset when
 * the target or the ISA level changes. */
#define SC_NEAR_PROBE 16
typedef struct near_history {
    const void *obj, *isa;   /* the target and the kernel table the history is of */
    uint32_t runs;       /* NEAR runs since it was reset */
    float score;         /* decayed mean of log2(packet time / alone time) over probe pairs: > 0, one by one */
    float first;         /* the pair's first run: its log2 time, negated if it ran alone */
    int open;            /* the pair's first run is in, the second not yet */
} near_history;
static _Thread_local __attribute__((tls_model("initial-exec"))) near_history sc_near_history;

static inline uint64_t stream_ticks(void)
{
#if defined(__x86_64__) || defined(__i386__)
    return __rdtsc();
#else
    return (uint64_t)(sc_now_seconds() * 1e9);
#endif
}

/* This NEAR run's path: bit 0, as a packet; bit 1, timed (a probe). */
static int near_path(near_history *h, const void *obj)
{
    const void *isa = sc_kernels_active();
    if (h->obj != obj || h->isa != isa)
        h->obj = obj, h->isa = isa, h->runs = 0, h->score = 0, h->open = 0;
    /* the further apart the paths, the rarer the probes (2^0.32 = 1.25, 2^1 = 2) */
    const float gap = fabsf(h->score);
    const uint32_t period = gap < 0.32f ? SC_NEAR_PROBE : gap < 1 ? 4 * SC_NEAR_PROBE : 16 * SC_NEAR_PROBE;
    const uint32_t k = h->runs++ % period;
    if (k < 2)
        /* a pair: packet then alone on even pairs, alone then packet on odd ones */
        return 2 | (k ^ ((h->runs / period) & 1) ^ 1);
    return h->score <= 0;
}

/* A probe's time (ticks) into the history: the first of a pair waits for
 * the second. One pair moves the score by at most 1/8 of 2 (a factor of 4). */
static void near_learn(near_history *h, int path, uint64_t ticks)
{
    const float l = log2f((float)ticks + 1), signed_l = (path & 1) ? l : -l;
    h->open = !h->open;
    if (h->open) {
        h->first = signed_l;
        return;
    }
    float r = h->first + signed_l;   /* log2(packet time) - log2(alone time) */
    r = r > 2 ? 2 : r < -2 ? -2 : r;
    h->score += (r - h->score) * 0.125f;
}

sc_status sc_stream_run(const sc_stream_target *T, const sc_ray *rays, size_t ray_stride, void *out,
                        size_t out_stride, size_t n, sc_trace_stats *stats, int any)
{
    sc_status status = SC_OK;
    stream_queue queue, *q = T->batch && !stats ? &queue : NULL;
    queue.n = 0;
    stream_group group, *grp = any && T->group64 ? &group : NULL;
    group.n = 0;
    for (size_t base = 0; base < n; base += 16) {
        const unsigned cnt = n - base < 16 ? (unsigned)(n - base) : 16;
        sc_ray_packet16 p __attribute__((aligned(64)));
        sc_ray_packet16 *pp = grp ? &grp->p[grp->n] : &p;
        uint32_t lanes;
        const int g = stream_gather(T, (const char *)rays, ray_stride, base, cnt, pp, &lanes);
        near_history *nh = g == SC_GATHER_NEAR && !any && !stats && !q ? &sc_near_history : NULL;
        const int path = nh ? near_path(nh, T->obj) : g != SC_GATHER_INCOHERENT;
        const uint64_t t0 = path & 2 ? stream_ticks() : 0;
        if (path & 1) {
            if (grp) {
                grp->lanes[grp->n] = lanes, grp->base[grp->n] = base, grp->cnt[grp->n] = cnt;
                if (++grp->n == 4)
                    group_flush(T, grp, out, out_stride, stats);
            } else {
                stream_packet(T, pp, lanes, out, out_stride, base, cnt, stats, any);
            }
        } else {
            sc_status st = stream_alone(T, (const char *)rays, ray_stride, (char *)out, out_stride, base, cnt,
                                        stats, any, q);
            if (st != SC_OK)
                status = st;
        }
        if (path & 2)
            near_learn(nh, path, stream_ticks() - t0);
        if (q && q->n > SC_STREAM_QUEUE - 16)
            queue_flush(T, q, any);
    }
    if (grp)
        group_flush(T, grp, out, out_stride, stats);
    if (q)
        queue_flush(T, q, any);
    return status;
}

/* A BVH as a stream's target. Rays that failed the coherence tests:
 * closest-hit rays take sc_trace_closest's kernel, whose octant history
 * sends rays of changing octant to the one body with its rows from the
 * direction's signs in a register, so a stream's random rays run as fast as
 * single rays (closest_incoherent, which reads the signs as three floats
 * for the top level's freshly stored object rays, was measurably slower
 * here: docs/compare.md, thirtieth session); any-hit rays take the kernel
 * without the octant branch, which random directions mispredict (not with
 * statistics, which have one generic kernel anyway). */
static void bvh_packet16(const void *obj, uint32_t lanes, const sc_ray_packet16 *rays, void *out, int any,
                         sc_trace_stats *stats)
{
    sc_trace_packet_lanes(obj, lanes, rays->ox, 16, out, any, stats);
}

static sc_status bvh_single(const void *obj, const sc_ray *ray, void *out, int any, int incoherent,
                            sc_trace_stats *stats)
{
    const sc_bvh *bvh = obj;
    if (any && incoherent && !stats && sc_ray_valid(ray)) {
        *(int32_t *)out = sc_kernels_active()->trace[bvh->cfg.tri_test].any_incoherent(bvh, ray);
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

/* bvh_single's choices for a run of rays, with the kernels looked up once. */
static sc_status bvh_alone(const void *obj, const char *rays, size_t ray_stride, char *out, size_t out_stride,
                           unsigned cnt, int any)
{
    const sc_bvh *bvh = obj;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    sc_status status = SC_OK;
    for (unsigned i = 0; i < cnt; i++) {
        const sc_ray *r = (const sc_ray *)(const void *)(rays + i * ray_stride);
        void *o = out + i * out_stride;
        if (!sc_ray_valid_sse(r))
            status = SC_ERR_INVALID_ARGUMENT;
        else if (any)
            *(int32_t *)o = k->any_incoherent(bvh, r);
        else
            k->closest_adaptive(bvh, r, o);
    }
    return status;
}

static void bvh_batch(const void *obj, const sc_ray *const *rays, void *const *outs, unsigned n, int any)
{
    const sc_bvh *bvh = obj;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    if (any)
        k->any_interleaved(bvh, rays, outs, n);
    else
        k->closest_interleaved(bvh, rays, outs, n);
}

static void bvh_group64(const void *obj, const sc_ray_packet16 *rays, const uint32_t *lanes, int32_t *occluded,
                        sc_trace_stats *stats)
{
    const sc_bvh *bvh = obj;
    sc_kernels_active()->trace[bvh->cfg.tri_test].any_stream64(bvh, rays, lanes, occluded, stats);
}

static sc_status stream(const sc_bvh *bvh, const sc_ray *rays, size_t ray_stride, void *out, size_t out_stride,
                        size_t n, unsigned flags, sc_trace_stats *stats, int any)
{
    if (!bvh || (n && (!rays || !out)) || ray_stride < sizeof(sc_ray) ||
        out_stride < (any ? sizeof(int32_t) : sizeof(sc_hitrec)) || flags != 0)
        return SC_ERR_INVALID_ARGUMENT;
    const sc_stream_target T = { bvh, bvh->root_lo, bvh->root_hi, bvh_packet16, bvh_single, bvh_alone,
                                 bvh->interleave ? bvh_batch : NULL,
                                 sc_kernels_active()->trace[bvh->cfg.tri_test].any_stream64 ? bvh_group64 : NULL };
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

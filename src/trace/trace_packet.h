/* The packet and stream machinery behind sc_trace.h's packet and stream
 * calls, for the scene handle (src/accel) to reuse: lane-level packet
 * tracing without the argument checks, the hit packet's lanes, and the
 * stream loop over any target that can trace a packet and a ray. */
#ifndef SPHERECULL_TRACE_TRACE_PACKET_H
#define SPHERECULL_TRACE_TRACE_PACKET_H

#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_bvh.h"
#include "spherecull/sc_hit.h"
#include "spherecull/sc_ray.h"
#include "spherecull/sc_trace.h"

/* The argument checks of a W-lane packet call (rows: ox oy oz tmin dx dy
 * dz tmax, W floats each, W * 4-byte aligned; out: the hit packet, as
 * aligned, or for any the int32_t array): the valid lanes as a mask, or
 * -1 for a NULL pointer, a misaligned packet or a valid lane's ray that
 * sc_trace_closest refuses. */
int64_t sc_packet_checked_lanes(const int32_t *valid, const float *rows, unsigned W, const void *out, int any);

/* Lanes `lanes` (checked rays) of a W-lane packet (W = 8 or 16) against
 * bvh: the level's packet kernel of that width, 16 lanes as two 8-lane
 * halves where the level has only those, else lane by lane. out: the hit
 * packet (closest) or W int32_t (any); lanes not in `lanes` are not
 * written. The rows need W * 4-byte alignment, the hit packet too. */
void sc_trace_packet_lanes(const sc_bvh *bvh, uint32_t lanes, const float *rows, unsigned W, void *out, int any,
                           sc_trace_stats *stats);

/* Lane i of a W-lane hit packet (rows t, u, v, prim, ng_x, ng_y, ng_z,
 * geom, inst) to and from a hit record; inline, since streams call them
 * for every ray. */
static inline void sc_hit_lane_put(void *packet, unsigned W, unsigned i, const sc_hitrec *h)
{
    float *f = packet;
    uint32_t *u = packet;
    f[i] = h->t, f[W + i] = h->u, f[2 * W + i] = h->v;
    u[3 * W + i] = h->prim;
    f[4 * W + i] = h->ng[0], f[5 * W + i] = h->ng[1], f[6 * W + i] = h->ng[2];
    u[7 * W + i] = h->geom, u[8 * W + i] = h->inst;
}

static inline void sc_hit_lane_get(const void *packet, unsigned W, unsigned i, sc_hitrec *h)
{
    const float *f = packet;
    const uint32_t *u = packet;
    h->t = f[i], h->u = f[W + i], h->v = f[2 * W + i];
    h->prim = u[3 * W + i];
    h->ng[0] = f[4 * W + i], h->ng[1] = f[5 * W + i], h->ng[2] = f[6 * W + i];
    h->geom = u[7 * W + i], h->inst = u[8 * W + i];
}

/* What a stream traces: lanes `lanes` of a 16-ray packet (rays already
 * checked as sc_ray_valid; out as for sc_trace_packet_lanes) and single
 * rays (incoherent: a ray the coherence tests sent alone; checked by the
 * callee). lo/hi: the scene's box, the scale of the origin test. */
typedef struct sc_stream_target {
    const void *obj;
    const float *lo, *hi;
    void (*packet16)(const void *obj, uint32_t lanes, const sc_ray_packet16 *rays, void *out, int any,
                     sc_trace_stats *stats);
    sc_status (*single)(const void *obj, const sc_ray *ray, void *out, int any, int incoherent,
                        sc_trace_stats *stats);
    /* Optional (NULL: single, ray by ray): rays [0, cnt) at ray_stride,
     * incoherent, each checked and traced alone without statistics, answers
     * at out_stride; SC_ERR_INVALID_ARGUMENT if it refused one (the others
     * are answered). One call a run, the kernel chosen once: a call through
     * `single` for each random ray cost streams 2-3 % of the single rays'
     * speed. */
    sc_status (*alone)(const void *obj, const char *rays, size_t ray_stride, char *out, size_t out_stride,
                       unsigned cnt, int any);
    /* Optional (NULL: single, ray by ray): incoherent checked rays
     * rays[0..n) -> outs[i], several at a time, without statistics. */
    void (*batch)(const void *obj, const sc_ray *const *rays, void *const *outs, unsigned n, int any);
    /* Optional (NULL: packet by packet): any hit for four coherent 16-ray
     * packets at once (lanes[g]: packet g's checked lanes), answers to
     * occluded[g * 16 + l]. */
    void (*group64)(const void *obj, const sc_ray_packet16 *rays, const uint32_t *lanes, int32_t *occluded,
                    sc_trace_stats *stats);
} sc_stream_target;

/* n rays at ray_stride; results at out_stride (sc_hitrec, or int32_t for
 * any). Runs of 16 coherent rays as packets (any hit: four at a time, when
 * the target has a group kernel), the rest one by one or, when the target
 * has a batch kernel, gathered and traced a batch at a time. The
 * strides and flags are the caller's to check. */
sc_status sc_stream_run(const sc_stream_target *t, const sc_ray *rays, size_t ray_stride, void *out,
                        size_t out_stride, size_t n, sc_trace_stats *stats, int any);

#endif

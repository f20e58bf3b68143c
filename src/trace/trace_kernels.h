/* One traversal kernel set per ISA and triangle test: closest/any, with and
 * without statistics. The ISA dispatch (src/isa) puts the table of its level
 * next to the sphere kernels of the same level. */
#ifndef SPHERECULL_TRACE_TRACE_KERNELS_H
#define SPHERECULL_TRACE_TRACE_KERNELS_H

#include "bvh/leaf_block.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_trace.h"

/* A hit's fields beyond t, u, v and prim: the normal of lane `lane` of the
 * leaf rows it came from (rows NULL: a miss) and the ids of a BVH over one
 * mesh (geometry 0, no instance). */
static inline void sc_hit_ids_normal(sc_hitrec *h, const float *rows, unsigned W, unsigned lane)
{
    if (rows) {
        sc_leaf_normal(rows, W, lane, h->ng);
        h->geom = 0;
    } else {
        h->ng[0] = h->ng[1] = h->ng[2] = 0;
        h->geom = SC_INVALID_ID;
    }
    h->inst = SC_INVALID_ID;
}

struct sc_top;

typedef struct sc_trace_kernels {
    void (*closest)(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit);
    int (*any)(const sc_bvh *bvh, const sc_ray *ray);
    /* The same answers, for rays known to be incoherent: no branch on the
     * ray's octant (traverse_bvh8_single.h). */
    void (*closest_incoherent)(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit);
    /* The same again, choosing between the two by the thread's recent rays
     * (traverse_adaptive): what sc_trace_closest calls. */
    void (*closest_adaptive)(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit);
    int (*any_incoherent)(const sc_bvh *bvh, const sc_ray *ray);
    /* rays[0..n) (checked rays) traced a few at a time, their loads
     * overlapping (traverse_interleaved); outs[i]: an sc_hitrec, or an
     * int32_t for any-hit. The same answers as the calls above. */
    void (*closest_interleaved)(const sc_bvh *bvh, const sc_ray *const *rays, void *const *hits, unsigned n);
    void (*any_interleaved)(const sc_bvh *bvh, const sc_ray *const *rays, void *const *occluded, unsigned n);
    void (*closest_stats)(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st);
    int (*any_stats)(const sc_bvh *bvh, const sc_ray *ray, sc_trace_stats *st);
    /* Packets (lanes: the valid lanes, rays checked; st may be NULL). NULL
     * where a level has no packet kernel for the test: trace_api.c then
     * traces the lanes one by one (the specification). */
    void (*closest_p8)(const sc_bvh *bvh, const sc_ray_packet8 *rays, uint32_t lanes, sc_hit_packet8 *hits,
                       sc_trace_stats *st);
    void (*any_p8)(const sc_bvh *bvh, const sc_ray_packet8 *rays, uint32_t lanes, int32_t *occluded,
                   sc_trace_stats *st);
    void (*closest_p16)(const sc_bvh *bvh, const sc_ray_packet16 *rays, uint32_t lanes, sc_hit_packet16 *hits,
                        sc_trace_stats *st);
    void (*any_p16)(const sc_bvh *bvh, const sc_ray_packet16 *rays, uint32_t lanes, int32_t *occluded,
                    sc_trace_stats *st);
    /* A stream's 64 coherent rays as four 16-ray packets (lanes[g]: the
     * valid lanes of packet g, rays checked), walked together
     * (traverse_group_any); occluded[g * 16 + l]. NULL: packet by packet. */
    void (*any_stream64)(const sc_bvh *bvh, const sc_ray_packet16 *rays, const uint32_t *lanes, int32_t *occluded,
                         sc_trace_stats *st);
    /* The top level of a two-level scene (trace_top.h), the same in every
     * row: hit holds a miss on entry. */
    void (*top_closest)(const struct sc_top *top, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *st);
    int (*top_any)(const struct sc_top *top, const sc_ray *ray, sc_trace_stats *st);
    /* Lanes `lanes` (checked rays) of a W-lane packet (W = 8 or 16; rows
     * as sc_trace_packet_lanes, trace_packet.h) through the top level
     * (traverse_top_packet.h); out: the hit packet or W int32_t. */
    void (*top_packet)(const struct sc_top *top, uint32_t lanes, const float *rows, unsigned W, void *out, int any,
                       sc_trace_stats *st);
    /* A stream's run of 16 rays into a packet, checked, and whether it is
     * coherent (stream_gather.h), the same in every row. */
    int (*stream_gather16)(const char *rays, size_t ray_stride, const float *lo, const float *hi,
                           sc_ray_packet16 *packet);
    /* The valid lanes of a W-lane packet (W = 8 or 16, rows as above) as
     * a mask, or -1 if a valid lane's ray is refused: sc_packet_valid_ref,
     * the same in every row. */
    int64_t (*packet_valid)(const int32_t *valid, const float *rows, unsigned W);
} sc_trace_kernels;

/* [sc_tri_test]. The x86 tables exist only in x86 builds. */
extern const sc_trace_kernels sc_trace_kernels_scalar[SC_TRI_TEST_COUNT];
extern const sc_trace_kernels sc_trace_kernels_avx2[SC_TRI_TEST_COUNT];
extern const sc_trace_kernels sc_trace_kernels_avx512[SC_TRI_TEST_COUNT];

#endif

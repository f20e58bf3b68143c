/* One traversal kernel set per ISA and triangle test: closest/any, with and
 * without statistics. The ISA dispatch (src/isa) puts the table of its level
 * next to the sphere kernels of the same level. */
#ifndef SPHERECULL_TRACE_TRACE_KERNELS_H
#define SPHERECULL_TRACE_TRACE_KERNELS_H

#include "spherecull/sc_bvh.h"
#include "spherecull/sc_trace.h"

typedef struct sc_trace_kernels {
    void (*closest)(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit);
    int (*any)(const sc_bvh *bvh, const sc_ray *ray);
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
} sc_trace_kernels;

/* [sc_tri_test]. The x86 tables exist only in x86 builds. */
extern const sc_trace_kernels sc_trace_kernels_scalar[SC_TRI_TEST_COUNT];
extern const sc_trace_kernels sc_trace_kernels_avx2[SC_TRI_TEST_COUNT];
extern const sc_trace_kernels sc_trace_kernels_avx512[SC_TRI_TEST_COUNT];

#endif

/* spherecull — single-ray queries against an sc_bvh.
 *
 *   sc_ray ray = { {ox, oy, oz}, 0.0f, {dx, dy, dz}, INFINITY };
 *   sc_hitrec hit;
 *   sc_trace_closest(bvh, &ray, &hit, NULL);      // hit.prim == SC_HITREC_MISS on a miss
 *   int blocked;
 *   sc_trace_any(bvh, &ray, &blocked, NULL);      // occlusion (shadow rays)
 *
 * Semantics (as Embree's rtcIntersect1 / rtcOccluded1): a hit has
 * tmin <= t <= tmax; both faces are hit; the direction need not be unit
 * length. hit.t is the ray parameter, hit.u and hit.v the barycentric weights
 * of the triangle's second and third vertex (P = (1-u-v) V0 + u V1 + v V2),
 * hit.prim the triangle's index in the build input.
 *
 * Traversal is robust (Ize 2013: conservative slab tests on exact float
 * boxes), so with the watertight triangle test a ray through a shared edge or
 * vertex of a closed mesh never slips through.
 *
 * Statistics: pass a non-NULL sc_trace_stats to have the counters of this
 * ray ADDED to it (so one struct can sum a whole ray set). With NULL, a
 * separately compiled kernel without any counting runs: no cost.
 */
#ifndef SPHERECULL_SC_TRACE_H
#define SPHERECULL_SC_TRACE_H

#include <stdint.h>

#include "sc_bvh.h"
#include "sc_prefilter.h"
#include "sc_rays.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sc_trace_stats {
    uint64_t rays;
    uint64_t nodes;           /* inner nodes visited (box tests of 8 children) */
    uint64_t leaves;          /* leaves visited */
    uint64_t sphere_tests;    /* valid sphere lanes tested */
    uint64_t sphere_rejects;  /* of those, rejected */
    uint64_t tri_tests;       /* exact triangle tests (survivors of the prefilter) */
    uint64_t tri_hits;        /* exact tests that found an intersection in [tmin, tmax] */
} sc_trace_stats;

/* Closest hit. Errors: INVALID_ARGUMENT for NULL pointers or a ray with a
 * NaN/infinite direction, a zero direction, an origin coordinate of
 * magnitude >= 1e18 (or NaN), tmin < 0 or NaN, or NaN tmax. */
sc_status sc_trace_closest(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit,
                           sc_trace_stats *stats);

/* Any hit in [tmin, tmax]: *occluded = 1 if one exists, else 0. */
sc_status sc_trace_any(const sc_bvh *bvh, const sc_ray *ray, int *occluded,
                       sc_trace_stats *stats);

/* Brute force over all triangles with the BVH's own triangle test and
 * precision: no tree, for debugging and as a same-arithmetic cross-check. */
sc_status sc_trace_closest_brute(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit);

#ifdef __cplusplus
}
#endif
#endif

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
 * hit.prim the triangle's index in the build input, hit.ng its geometric
 * normal (V1 - V0) x (V2 - V0) and hit.geom / hit.inst its geometry (0) and
 * instance (none) ids (sc_hit.h). Of hits at equal t the
 * one with the smaller index is reported (SC_TRI_WATERTIGHT, SC_TRI_MOLLER),
 * so the answer does not depend on the order the tree is walked in: the
 * packet and stream calls below return the same bits.
 *
 * Traversal is robust (Ize 2013: conservative slab tests on exact float
 * boxes), so with the watertight triangle test a ray through a shared edge or
 * vertex of a closed mesh never slips through.
 *
 * Triangle tests (sc_bvh_config.tri_test):
 *   SC_TRI_WATERTIGHT  Woop, Benthin, Wald 2013. Watertight, but decided on a
 *                      ray moved by float rounding: next to an edge or vertex
 *                      it may report the neighbour, miss a touch, or hit a
 *                      ray that misses by an ulp.
 *   SC_TRI_EXACT       every decision is exact for the float ray and float
 *                      vertices: hit/miss (signs of D.((P-O) x (Q-O)), both
 *                      faces, edges and vertices included, a ray in the
 *                      triangle's plane never hits), tmin <= t <= tmax, and
 *                      the closest hit (smallest exact t = (A-O).n / D.n; of
 *                      exact ties the smallest primitive id). A float filter with
 *                      rigorous error bounds decides almost every lane; the
 *                      rest fall back to double and then to exact integer
 *                      arithmetic (libc/libm only). t, u, v stay rounded.
 *                      2-18 % slower on ordinary rays (median 7-10 %).
 *   SC_TRI_MOLLER      Moller-Trumbore 1997, not watertight, for comparison.
 *
 * Kernels: those of the library's ISA level (sc_isa.h); every level returns
 * bit-identical hits.
 *
 * Statistics: pass a non-NULL sc_trace_stats to have the counters of this
 * ray ADDED to it (so one struct can sum a whole ray set). With NULL, a
 * separately compiled kernel without any counting runs: no cost.
 *
 * Threads. A built sc_bvh is read-only: any number of threads may trace it
 * at once (sc_trace_closest, sc_trace_any, sc_trace_closest_brute), each with
 * its own hit record and its own sc_trace_stats (one stats struct shared by
 * two threads is a data race: the counters are plain adds). Freeing a BVH
 * while a thread traces it is not allowed. Each call reads the process-wide
 * ISA level once (sc_isa.h); sc_isa_force may run concurrently, and since
 * every level returns the same hits, a call never sees a mixed answer.
 * tests/test_threads.c runs 4 tracers on one BVH while 2 threads build and
 * free their own, every ISA, and once more while another thread switches
 * the ISA level, under ThreadSanitizer (scripts/test.sh --tsan).
 *
 * MXCSR modes. Every guarantee above (conservative box tests, watertight
 * and exact triangle tests, the prefilter never rejecting a hit) holds with
 * gradual underflow and with flush-to-zero / denormals-are-zero set in the
 * tracing thread: the error bounds use normal-range floors, and a lane the
 * float filter cannot certify there (e.g. |fl(1/det)| < 2^-126) goes on to
 * the double and exact stages, which never see a subnormal (products of at
 * most three floats stay above 2^-1022) or read the floats' bits. The
 * watertight test's float edge functions flush symmetrically (U(a,b) =
 * -U(b,a) still holds) and a flushed zero takes the double fallback. With
 * DAZ, a subnormal ray or vertex coordinate is read as 0 by the float
 * stages; SC_TRI_EXACT's exact stage still decides for the given bits.
 * Both modes are tested (tests registered as <name>_ftz). Two corners are
 * not covered under DAZ (docs/numerics.md): a ray with some |d_k| < 1e-18
 * whose origin or box coordinate on that axis is subnormal, and a ray whose
 * largest direction component is below 2^-95 with another one subnormal.
 */
#ifndef SPHERECULL_SC_TRACE_H
#define SPHERECULL_SC_TRACE_H

#include <stddef.h>
#include <stdint.h>

#include "sc_api.h"
#include "sc_bvh.h"
#include "sc_hit.h"
#include "sc_ray.h"
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
 * magnitude >= 1e18 (or NaN), tmin < 0 or NaN, or NaN tmax. The kernel it
 * runs is chosen from the calling thread's recent rays (whether their
 * direction octants keep changing, as random and diffuse rays do): that
 * changes the speed only, never the hit. */
SC_API sc_status sc_trace_closest(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit,
                                  sc_trace_stats *stats);

/* Any hit in [tmin, tmax]: *occluded = 1 if one exists, else 0. */
SC_API sc_status sc_trace_any(const sc_bvh *bvh, const sc_ray *ray, int *occluded,
                              sc_trace_stats *stats);

/* Brute force over all triangles with the BVH's own triangle test and
 * precision: no tree, for debugging and as a same-arithmetic cross-check.
 * (With SC_TRI_EXACT the same triangle as sc_trace_closest; its rounded t, u
 * and v may differ in the last bits.) */
SC_API sc_status sc_trace_closest_brute(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit);

/* ---- packets ---------------------------------------------------------------
 *
 *   sc_ray_packet16 rays;      // SoA, 64-byte aligned (sc_ray.h): lane i is a ray
 *   sc_hit_packet16 hits;      // 64-byte aligned
 *   int32_t valid[16];         // non-zero: trace lane i (like rtcIntersect16)
 *   sc_trace_closest16(bvh, valid, &rays, &hits, NULL);
 *   int32_t occluded[16];
 *   sc_trace_any16(bvh, valid, &rays, occluded, NULL);   // 1 or 0 per valid lane
 *
 * Lane i of the result is bit for bit what sc_trace_closest / sc_trace_any
 * returns for ray i (t, u, v, prim; of hits at equal t the smaller prim),
 * whatever the other lanes hold, on every ISA level; invalid lanes are
 * neither read nor written. The rays of a packet need not be coherent, but
 * they pay only when they are (camera rays of a pixel tile, shadow rays of
 * it to one light): the lanes walk the tree together, each triangle is
 * tested against all rays of the packet in one vector pass, and when the
 * rays share their origin the leaf's circumspheres cull triangles for the
 * whole packet (a sphere outside the packet's bounding cone). Packet kernels
 * exist for SC_TRI_WATERTIGHT; with the other tests (and on the scalar and
 * SSE4.1 levels) the lanes are traced one by one. 16-ray packets on the
 * AVX2 level run as two 8-ray packets.
 *
 * Errors (nothing written): INVALID_ARGUMENT for NULL pointers, a packet
 * or hit not aligned to its size's alignment (32 bytes for 8 lanes, 64 for
 * 16), or a valid lane whose ray sc_trace_closest would refuse.
 * Statistics: nodes and leaves count the packet's visits; rays, sphere and
 * triangle counters count per ray, as for single rays (a triangle tested
 * against 16 active lanes is 16 tests, a sphere culled for them 16 rejects).
 * Threads: as the single-ray calls. */
SC_API sc_status sc_trace_closest8(const sc_bvh *bvh, const int32_t valid[8], const sc_ray_packet8 *rays,
                                   sc_hit_packet8 *hits, sc_trace_stats *stats);
SC_API sc_status sc_trace_closest16(const sc_bvh *bvh, const int32_t valid[16], const sc_ray_packet16 *rays,
                                    sc_hit_packet16 *hits, sc_trace_stats *stats);
SC_API sc_status sc_trace_any8(const sc_bvh *bvh, const int32_t valid[8], const sc_ray_packet8 *rays,
                               int32_t occluded[8], sc_trace_stats *stats);
SC_API sc_status sc_trace_any16(const sc_bvh *bvh, const int32_t valid[16], const sc_ray_packet16 *rays,
                                int32_t occluded[16], sc_trace_stats *stats);

/* ---- streams ---------------------------------------------------------------
 *
 *   sc_trace_closest_n(bvh, rays, sizeof(sc_ray), hits, sizeof(sc_hitrec), n, 0, NULL);
 *
 * n rays at byte stride ray_stride (>= sizeof(sc_ray)), results at
 * hit_stride (>= sizeof(sc_hitrec); for any: occluded_stride >= 4, an
 * int32_t 1/0 per ray), like rtcIntersect1M / rtcOccluded1M. A run of 16
 * consecutive rays whose directions are close (camera tiles, shadow rays to
 * one light) is traced as one packet (sc_trace_closest16; for any hit, four
 * such packets of one octant walk the tree together, a node tested once per
 * 64 rays); a run whose origins are close (a pixel tile's bounces) too,
 * except that closest-hit runs in a tree below 6 MiB go as a packet or ray
 * by ray, whichever the calling thread has timed faster on such runs of
 * this BVH (it tries both now and then: the speed, never the result,
 * depends on the history);
 * other runs ray by ray, or, in a tree
 * larger than the caches (6 MiB of nodes and leaves), several rays at a
 * time with their memory loads overlapping. Keep neighbours in the array
 * neighbours in space, and hand over many rays per call, to gain. Results
 * are those of the single-ray calls, bit for bit.
 * flags: 0 (reserved). A ray sc_trace_closest would refuse gets no result
 * and makes the call return INVALID_ARGUMENT after tracing the others. */
SC_API sc_status sc_trace_closest_n(const sc_bvh *bvh, const sc_ray *rays, size_t ray_stride, sc_hitrec *hits,
                                    size_t hit_stride, size_t n, unsigned flags, sc_trace_stats *stats);
SC_API sc_status sc_trace_any_n(const sc_bvh *bvh, const sc_ray *rays, size_t ray_stride, int32_t *occluded,
                                size_t occluded_stride, size_t n, unsigned flags, sc_trace_stats *stats);

#ifdef __cplusplus
}
#endif
#endif

/* spherecull — Embree 3 back end for side-by-side comparisons.
 *
 * Built only when CMake finds Embree 3 (target spherecull_embree, which
 * defines SC_HAVE_EMBREE for its consumers). The same float triangles go into
 * an RTCScene in one of four modes:
 *
 *   SC_EMBREE_DEFAULT         native triangles, Embree's default flags
 *   SC_EMBREE_ROBUST          native triangles, RTC_SCENE_FLAG_ROBUST
 *   SC_EMBREE_USER_PREFILTER  the drop-in: RTC_GEOMETRY_TYPE_USER whose every
 *                             primitive is a cluster of up to 8 or 16 spatially
 *                             coherent triangles (leaves of a median split) with
 *                             their conservative spheres in an sc_sphere_block8/16;
 *                             the callback runs sc_reject8/16 and tests only the
 *                             surviving triangles with a watertight test
 *   SC_EMBREE_USER_PLAIN      the same clusters without the sphere test: the
 *                             "prefilter off" baseline inside Embree
 *
 * The user modes set RTC_SCENE_FLAG_ROBUST and pad the cluster boxes by 2^-16
 * of their size and distance from the origin: Embree's box culling is not
 * conservative for user geometry, and a ray through a vertex on a box face
 * would otherwise never reach the callback (docs/compare.md).
 *
 * One cluster per user primitive rather than one triangle: Embree calls a
 * user primitive only after its own box was hit, and a per-triangle sphere
 * behind a per-triangle box rejects under 1% of the calls.
 *
 * Hits report the original triangle index in prim. All query functions may be
 * called concurrently from several threads on disjoint ray ranges, each with
 * its own counters (or NULL: no counting).
 */
#ifndef SPHERECULL_SC_EMBREE_H
#define SPHERECULL_SC_EMBREE_H

#include "sc_api.h"
#include <stddef.h>
#include <stdint.h>

#include "sc_circumsphere.h"
#include "sc_prefilter.h"
#include "sc_rays.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sc_embree_mode {
    SC_EMBREE_DEFAULT = 0,
    SC_EMBREE_ROBUST,
    SC_EMBREE_USER_PREFILTER,
    SC_EMBREE_USER_PLAIN,
    SC_EMBREE_COMPACT,         /* native triangles, RTC_SCENE_FLAG_COMPACT: Embree's memory-lean layout */
    SC_EMBREE_MODE_COUNT
} sc_embree_mode;

typedef enum sc_embree_quality {
    SC_EMBREE_QUALITY_MEDIUM = 0,
    SC_EMBREE_QUALITY_HIGH,
    SC_EMBREE_QUALITY_COUNT
} sc_embree_quality;

typedef struct sc_embree_config {
    sc_embree_mode mode;
    sc_embree_quality quality;
    int cluster_size;          /* user modes: 2..16; <= 8 uses sc_reject8, else sc_reject16 */
    sc_sphere_kind sphere;     /* user modes: circumsphere or minimal sphere centres */
    int build_threads;         /* Embree's thread count for the build; 0 = its default */
} sc_embree_config;

/* DEFAULT mode, medium quality, clusters of 8, minimal spheres, default threads. */
SC_API void sc_embree_config_default(sc_embree_config *cfg);

/* Which Embree this process runs: "MAJOR.MINOR.PATCH PATH" (the version a
 * device reports, rtcGetDeviceProperty, and the shared object the symbols
 * came from, dladdr), so every figure can name its yardstick. Writes at most
 * n bytes (NUL-terminated); SC_ERR_UNSUPPORTED if no device can be made. */
SC_API sc_status sc_embree_version(char *buf, size_t n);

typedef struct sc_embree sc_embree;

/* Work done inside the user-geometry callbacks (zero for native modes). */
typedef struct sc_embree_counters {
    uint64_t rays;
    uint64_t cluster_calls;    /* callback invocations (per ray) */
    uint64_t sphere_tests;
    uint64_t sphere_rejects;
    uint64_t tri_tests;        /* watertight tests run */
    uint64_t tri_hits;         /* of those, hits inside the current [tnear, tfar] */
    uint64_t false_positives;  /* sphere passed, triangle test missed */
} sc_embree_counters;

typedef struct sc_embree_info {
    uint32_t triangles;
    uint32_t clusters;             /* user modes */
    double mean_cluster_size;
    double mean_cluster_diag;      /* mean cluster box diagonal / scene diagonal */
    size_t embree_bytes;           /* bytes Embree holds after the commit (memory monitor) */
    size_t embree_peak_bytes;      /* peak during the build */
    size_t ours_bytes;             /* cluster storage of the user modes */
} sc_embree_info;

/* Builds and commits the scene from a mesh that passed sc_mesh_check (it is
 * trusted, not checked again). SC_ERR_INVALID_ARGUMENT for a NULL mesh or a
 * bad config, SC_ERR_UNSUPPORTED if Embree refuses the device (old CPU),
 * SC_ERR_OUT_OF_MEMORY. The mesh is copied; it need not outlive the call. */
SC_API sc_status sc_embree_create(const sc_checked_mesh *mesh, const sc_embree_config *cfg,
                                  sc_embree **out);
/* One instance for sc_embree_create_instanced: objects[object] placed by
 * a 3x4 row-major object-to-world transform (RTC_FORMAT_FLOAT3X4_ROW_MAJOR,
 * as sc_accel_attach_instance). */
typedef struct sc_embree_instance {
    uint32_t object;
    float xfm[12];
} sc_embree_instance;

/* The scene an Embree user builds for instances: one scene per object (a
 * triangle geometry each), and a top scene of RTC_GEOMETRY_TYPE_INSTANCE
 * geometries plus, if own has triangles, one mesh of its own (own may be
 * NULL). Hits report inst (the instance's index, or SC_INVALID_ID for own's
 * triangles), geom 0 and prim (in the object, or in own). Native modes only
 * (DEFAULT, ROBUST, COMPACT; else SC_ERR_UNSUPPORTED); the flags and build
 * quality apply to every scene. Meshes are copied; info.triangles counts
 * the instanced triangles. */
SC_API sc_status sc_embree_create_instanced(const sc_checked_mesh *own, const sc_checked_mesh *objects,
                                            size_t num_objects, const sc_embree_instance *instances,
                                            size_t num_instances, const sc_embree_config *cfg, sc_embree **out);
SC_API void sc_embree_destroy(sc_embree *e);
SC_API sc_status sc_embree_get_info(const sc_embree *e, sc_embree_info *info);

/* rtcIntersect1 per ray: closest hit in [tmin, tmax]. */
SC_API sc_status sc_embree_intersect1(sc_embree *e, const sc_ray *rays, size_t n, sc_hitrec *hits,
                                      sc_embree_counters *counters);

/* rtcOccluded1 per ray: occluded[i] = 1 if anything is hit in [tmin, tmax]. */
SC_API sc_status sc_embree_occluded1(sc_embree *e, const sc_ray *rays, size_t n, uint8_t *occluded,
                                     sc_embree_counters *counters);

/* rtcIntersect8 / rtcIntersect16 over consecutive groups of width rays (the
 * last group partly valid), with RTC_INTERSECT_CONTEXT_FLAG_COHERENT
 * (coherent != 0: camera tiles, shadow rays to one light) or _INCOHERENT
 * (bounce and random rays), as an application tells Embree: the flag sets
 * how soon its hybrid traversal leaves a thinning packet for single rays
 * (at 2 active rays of 16, or at 14). width is 8 or 16. */
SC_API sc_status sc_embree_intersect_packets(sc_embree *e, int width, const sc_ray *rays, size_t n,
                                             sc_hitrec *hits, int coherent, sc_embree_counters *counters);
/* rtcIntersect1M / rtcOccluded1M (Embree's streams) over the rays in chunks
 * of 256, with RTC_INTERSECT_CONTEXT_FLAG_COHERENT (coherent != 0) or
 * _INCOHERENT. */
SC_API sc_status sc_embree_intersect_stream(sc_embree *e, const sc_ray *rays, size_t n, sc_hitrec *hits, int coherent,
                                            sc_embree_counters *counters);
SC_API sc_status sc_embree_occluded_stream(sc_embree *e, const sc_ray *rays, size_t n, uint8_t *occluded, int coherent,
                                           sc_embree_counters *counters);

/* rtcOccluded8 / rtcOccluded16 likewise. */
SC_API sc_status sc_embree_occluded_packets(sc_embree *e, int width, const sc_ray *rays, size_t n, uint8_t *occluded,
                                            int coherent, sc_embree_counters *counters);

#ifdef __cplusplus
}
#endif
#endif

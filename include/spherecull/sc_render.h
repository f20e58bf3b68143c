/* spherecull — a small renderer over the BVH tracer (or any back end with a
 * closest-hit and an occlusion query), OpenMP over 16x16 tiles. Two
 * integrators:
 *
 *   SC_RENDER_DIRECT  Lambert shading, hard shadows from any-hit shadow rays,
 *                     optional ambient occlusion, and the debug views; one
 *                     ray per pixel centre; encoded with gamma 1/2.2.
 *   SC_RENDER_PATH    a path tracer: Lambert surfaces (the mesh colour),
 *                     emissive meshes (sc_scene_view.mesh_emission, from
 *                     the front side), the background as a constant environment,
 *                     cosine-weighted bounces, next-event estimation to the
 *                     point, directional and emissive-triangle lights, the
 *                     emitters combined with the bounce rays by multiple
 *                     importance sampling (power heuristic), Russian
 *                     roulette from rr_depth on. spp jittered samples per
 *                     pixel (box filter), radiance accumulated in float,
 *                     then tone mapped: x 2^exposure, clamped to [0, 1],
 *                     sRGB transfer curve (IEC 61966-2-1).
 *
 * Light units are those of the direct integrator in both: a point light of
 * colour C at distance d lights a white surface facing it to radiance C / d^2
 * (directional: C), i.e. its irradiance is pi C / d^2. An emissive mesh of
 * emission E seen directly has radiance E.
 *
 * Path length: --bounces B scatters at the first B surface hits (next-event
 * estimation and a bounce ray at each); the last bounce ray only collects
 * what it sees (emission, background). B = 0 shows emitters and background,
 * B = 1 direct lighting, as pbrt's maxdepth.
 *
 * Deterministic: every random number is drawn from a stream seeded by (seed,
 * pixel, sample) (xoshiro256** seeded by splitmix64), so the image does not
 * depend on the thread count, the order tiles finish in or the back end's
 * batching. The path tracer recomputes each hit point from the primitive the
 * back end reports (ray-plane intersection in double), so two back ends that
 * report the same primitives produce the same image bit for bit; they can
 * differ only where some ray of a pixel's paths passes close to a triangle
 * edge, which sc_render_options.edge reports.
 *
 * Threads: sc_render may run on several scenes and BVHs at once; one call
 * uses opt->threads OpenMP threads and calls the back end from all of them.
 */
#ifndef SPHERECULL_SC_RENDER_H
#define SPHERECULL_SC_RENDER_H

#include "sc_api.h"
#include <stdint.h>

#include "sc_accel.h"
#include "sc_bvh.h"
#include "sc_image.h"
#include "sc_scene.h"
#include "sc_status.h"
#include "sc_trace.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sc_render_debug {
    SC_RENDER_SHADED = 0,
    SC_RENDER_NORMALS,   /* geometric normal facing the camera, 0.5 n + 0.5 */
    SC_RENDER_DEPTH,     /* distance, near white to far dark, misses black */
    SC_RENDER_ID,        /* a colour per triangle id, misses black, hits never black */
    SC_RENDER_HEAT,      /* sphere tests per primary ray (triangle tests when the
                          * BVH has no spheres), blue to red, scaled to the max */
    SC_RENDER_DEBUG_COUNT
} sc_render_debug;

typedef enum sc_render_integrator {
    SC_RENDER_DIRECT = 0,
    SC_RENDER_PATH,
    SC_RENDER_INTEGRATOR_COUNT
} sc_render_integrator;

/* The queries a renderer needs, over a batch of n rays (up to a tile's
 * 256): closest hits (prim = SC_HITREC_MISS for a miss) and occlusion
 * (1 if anything lies in [tmin, tmax]). coherent is 1 for camera rays in
 * tile order, 0 for bounce and shadow rays. Called from every render thread
 * at once, so both must be thread-safe. Both back ends of `spherecull render
 * --tracer` are one of these. */
typedef struct sc_render_backend {
    sc_status (*closest)(void *ctx, const sc_ray *rays, size_t n, sc_hitrec *hits, int coherent);
    sc_status (*occluded)(void *ctx, const sc_ray *rays, size_t n, uint8_t *occluded, int coherent);
    void *ctx;
} sc_render_backend;

typedef struct sc_render_stats sc_render_stats;

/* Optional: which tiles this process renders, and how the partial images of
 * several processes meet (the MPI driver of `spherecull render` is one;
 * NULL: every tile here). Tiles are 16 x 16 pixels, row-major, numbered from
 * 0. next returns the next tile to render, or -1 when none is left; it is
 * called from every render thread, so it must be thread-safe. combine is
 * called exactly once per sc_render call that passed its argument checks,
 * also after a failure or a cancel (local_status says which; a failure
 * before the loop passes NULL buffers), from one thread, with this process's
 * accumulators: pixels * 3 floats of colour and pixels floats of the
 * per-pixel value of the depth and heat views; pixels of tiles rendered
 * elsewhere hold 0 in both. It must leave in them the sum over the processes
 * (exact: every pixel is nonzero in one process at most) and in *stats the
 * summed counters, and return the status agreed by all (SC_OK only if every
 * process succeeded). The image is then the one a single process renders,
 * bit for bit. opt->edge is filled for this process's tiles only. */
typedef struct sc_render_tiles {
    int (*next)(void *ctx);
    sc_status (*combine)(void *ctx, sc_status local_status, float *color, float *value, size_t pixels,
                         sc_render_stats *stats);
    void *ctx;
} sc_render_tiles;

typedef struct sc_render_options {
    sc_render_debug debug;   /* DIRECT only */
    int ao_samples;          /* 0: constant ambient term */
    uint64_t seed;
    int threads;             /* 0: OpenMP's default */
    int shadows;             /* 1: shadow rays (default), 0: none */
    int trace_stats;         /* 1: per-ray traversal counters (slower kernels) */
    /* Called from one thread with the fraction of tiles done and the rays
     * traced in them so far; may be NULL. */
    void (*progress)(void *ctx, double fraction, uint64_t rays);
    void *progress_ctx;

    sc_render_integrator integrator;
    int spp;                 /* PATH: samples per pixel, 1..65536 */
    int bounces;             /* PATH: scatterings per path, 0..64 (see the top) */
    int rr_depth;            /* PATH: Russian roulette from this bounce on, >= 1 */
    double exposure;         /* PATH: stops, radiance x 2^exposure before the tone map */
    /* NULL: bvh through sc_trace_closest_n / sc_trace_any_n. Otherwise bvh
     * may be NULL (trace_stats and the heat view need bvh). */
    const sc_render_backend *backend;
    /* Polled between tiles (set it from a signal handler): nonzero stops
     * the render, which returns SC_ERR_CANCELLED and no image. May be NULL. */
    const volatile int *cancel;
    /* PATH, optional (may be NULL), width x height entries, row-major:
     * radiance the mean linear radiance per pixel, 3 floats; edge 1 where a
     * hit of some path of the pixel had a barycentric coordinate below
     * SC_RENDER_EDGE_BARY (a back end may legitimately report the
     * neighbouring triangle there, or miss an open edge), else 0. With edge
     * the shadow rays are traced as closest-hit queries, so their nearest
     * blockers count too: the same image, more time. */
    float *radiance;
    uint8_t *edge;
    /* Distributed rendering (see sc_render_tiles above); NULL: all tiles. */
    const sc_render_tiles *tiles;
} sc_render_options;

#define SC_RENDER_EDGE_BARY 1e-5

struct sc_render_stats {
    uint64_t primary_rays, shadow_rays, ao_rays;
    uint64_t bounce_rays;    /* PATH: rays after the camera ray */
    double seconds;          /* wall time of the render loop */
    sc_trace_stats trace;    /* summed over all rays; zero unless opt->trace_stats */
};

/* Defaults: direct, shaded, no AO, seed 1, all threads, shadows on; for
 * the path tracer 16 spp, 4 bounces, roulette from 3, exposure 0. */
SC_API void sc_render_options_init(sc_render_options *opt);

/* "shaded", "normals", "depth", "id", "heat". */
SC_API const char *sc_render_debug_name(sc_render_debug debug);
SC_API sc_status sc_render_debug_from_name(const char *name, sc_render_debug *out);

/* "direct", "path". */
SC_API const char *sc_render_integrator_name(sc_render_integrator integrator);
SC_API sc_status sc_render_integrator_from_name(const char *name, sc_render_integrator *out);

/* A scene view traced through sc_accel.h: one tree per instanced object and
 * a top level over the instances (scenes/README.md, "instances"), beside
 * one tree over the rest, so instances are built once, not once per copy.
 * Hits come back as indices into view->mesh (an instance's triangle t is
 * view->mesh's first_triangle + t), so sc_render shades them as it shades
 * the flattened mesh; the hits themselves are those of the rounded
 * object-space rays (sc_accel.h), so a pixel on an edge may differ from a
 * render of the flattened mesh. cfg NULL: sc_bvh_config_default. The view's
 * arrays must outlive it. Threads: the backend may be called from any
 * number of threads. */
typedef struct sc_scene_accel sc_scene_accel;
/* The triangles of view->mesh that no instance owns, as one mesh beside
 * the instances: *indices (3 per triangle, into view->mesh's vertices) and
 * *prims (each one's index in view->mesh), *count of them; free both. */
SC_API sc_status sc_scene_view_own_triangles(const sc_scene_view *view, uint32_t **indices, uint32_t **prims,
                                             size_t *count);
SC_API sc_status sc_scene_accel_build(const sc_scene_view *view, const sc_bvh_config *cfg, sc_scene_accel **out);
SC_API void sc_scene_accel_free(sc_scene_accel *accel);
/* *out calls the scene accel; it stays valid while accel lives. */
SC_API void sc_scene_accel_backend(sc_scene_accel *accel, sc_render_backend *out);
/* What the backend does, with the tracer's statistics (stats may be NULL;
 * added to): closest hits as view->mesh indices, or occluded[i] = 0/1. */
SC_API sc_status sc_scene_accel_closest(const sc_scene_accel *accel, const sc_ray *rays, size_t n, sc_hitrec *hits,
                                        sc_trace_stats *stats);
SC_API sc_status sc_scene_accel_any(const sc_scene_accel *accel, const sc_ray *rays, size_t n, uint8_t *occluded,
                                    sc_trace_stats *stats);
/* A hit of the top-level scene (sc_scene_accel_world: inst, geom, prim)
 * as the view->mesh triangle it stands for (prim; geom 0, inst
 * SC_INVALID_ID), for callers that trace the world scene themselves
 * (packets). A miss, or ids the scene does not have, are left as they are. */
SC_API void sc_scene_accel_flat_hit(const sc_scene_accel *accel, sc_hitrec *hit);
/* The top-level scene: its instance i is view->instances[i]
 * (sc_accel_instance_ray gives the object-space ray a hit is exact for). */
SC_API const sc_accel *sc_scene_accel_world(const sc_scene_accel *accel);
/* The top-level scene's info (bytes: the top level and the rest's tree),
 * and the bytes and build seconds of everything (objects included). */
SC_API sc_status sc_scene_accel_info(const sc_scene_accel *accel, sc_accel_info *world, size_t *total_bytes,
                                     double *build_seconds);

/* Renders view (camera, lights, colours, emission) traced through bvh (or
 * opt->backend), which must have been built from view's mesh (hit.prim
 * indexes it). out is allocated here (free with sc_image_free). stats may
 * be NULL. */
SC_API sc_status sc_render(const sc_scene_view *view, const sc_bvh *bvh, const sc_render_options *opt,
                           sc_image *out, sc_render_stats *stats);

#ifdef __cplusplus
}
#endif
#endif

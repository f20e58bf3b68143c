/* spherecull — a small renderer over the BVH tracer: pinhole camera, Lambert
 * shading, hard shadows from any-hit shadow rays, optional ambient
 * occlusion, and debug views. OpenMP over 16x16 tiles.
 *
 * Deterministic: every random number (AO directions) is drawn from a stream
 * seeded by (seed, pixel), so the image does not depend on the thread count
 * or the order tiles finish in.
 *
 * Colours are linear; the image is encoded with gamma 1/2.2.
 */
#ifndef SPHERECULL_SC_RENDER_H
#define SPHERECULL_SC_RENDER_H

#include "sc_api.h"
#include <stdint.h>

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

typedef struct sc_render_options {
    sc_render_debug debug;
    int ao_samples;          /* 0: constant ambient term */
    uint64_t seed;
    int threads;             /* 0: OpenMP's default */
    int shadows;             /* 1: shadow rays (default), 0: none */
    int trace_stats;         /* 1: per-ray traversal counters (slower kernels) */
    /* Called from one thread with the fraction done; may be NULL. */
    void (*progress)(void *ctx, double fraction);
    void *progress_ctx;
} sc_render_options;

typedef struct sc_render_stats {
    uint64_t primary_rays, shadow_rays, ao_rays;
    double seconds;          /* wall time of the render loop */
    sc_trace_stats trace;    /* summed over all rays; zero unless opt->trace_stats */
} sc_render_stats;

/* Defaults: shaded, no AO, seed 1, all threads, shadows on. */
SC_API void sc_render_options_init(sc_render_options *opt);

/* "shaded", "normals", "depth", "id", "heat". */
SC_API const char *sc_render_debug_name(sc_render_debug debug);
SC_API sc_status sc_render_debug_from_name(const char *name, sc_render_debug *out);

/* Renders view (camera, lights, colours) traced through bvh, which must have
 * been built from view's positions and indices (hit.prim indexes them).
 * out is allocated here (free with sc_image_free). stats may be NULL. */
SC_API sc_status sc_render(const sc_scene_view *view, const sc_bvh *bvh, const sc_render_options *opt,
                           sc_image *out, sc_render_stats *stats);

#ifdef __cplusplus
}
#endif
#endif

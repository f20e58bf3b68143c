/* Private to src/render: what the tile loop (render.c) shares with the
 * integrators (render.c's direct shading, path.c's path tracer). */
#ifndef SPHERECULL_RENDER_INTERNAL_H
#define SPHERECULL_RENDER_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_render.h"

#define SC_RENDER_TILE 16

typedef struct sc_render_ctx {
    const sc_scene_view *v;
    const sc_bvh *bvh;
    const sc_render_options *o;
    sc_camera_frame frame;
    double eps;           /* offset of secondary ray origins along the normal */
    double ao_len;
    int collect;          /* count traversal statistics (our BVH only) */

    /* Path tracer: the emissive triangles, chosen for next-event estimation
     * in proportion to area x mean emitted radiance. */
    uint32_t *emit_prims;
    double *emit_cdf;     /* inclusive prefix sums of the weights */
    size_t num_emit;
    double emit_total;    /* sum of the weights */
    int num_light_choices;   /* the point/directional lights, + 1 for all emitters */
} sc_render_ctx;

/* Occlusion as bytes through a stream call that writes int32 flags
 * (sc_trace_any_n, sc_accel_any_n, behind a thunk), in chunks on the
 * stack; a refused ray keeps what the caller put. */
typedef sc_status (*sc_render_any_n)(const void *scene, const sc_ray *rays, int32_t *occluded, size_t n,
                                     sc_trace_stats *stats);
sc_status sc_render_occluded_bytes(sc_render_any_n any_n, const void *scene, const sc_ray *rays, size_t n,
                                   uint8_t *occluded, sc_trace_stats *stats);

/* The back end's queries (opt->backend, else our BVH's stream calls). */
sc_status sc_render_closest(const sc_render_ctx *c, const sc_ray *rays, size_t n, sc_hitrec *hits,
                            int coherent, sc_trace_stats *stats);
sc_status sc_render_occluded(const sc_render_ctx *c, const sc_ray *rays, size_t n, uint8_t *occluded,
                             int coherent, sc_trace_stats *stats);

/* path.c */
sc_status sc_path_prepare(sc_render_ctx *c);
void sc_path_release(sc_render_ctx *c);
typedef struct sc_path_work sc_path_work;   /* one per thread: a tile's paths and rays */
sc_path_work *sc_path_work_new(void);
void sc_path_work_free(sc_path_work *w);
/* Traces every sample of the pixels [x0, x1) x [y0, y1) (at most one tile)
 * and writes their mean radiance into accum (3 floats per image pixel) and,
 * if edge is not NULL, the edge flags. */
void sc_path_tile(const sc_render_ctx *c, sc_path_work *w, int x0, int y0, int x1, int y1, float *accum,
                  uint8_t *edge, sc_render_stats *st);

#endif

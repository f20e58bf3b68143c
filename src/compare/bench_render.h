/* The frame-time benchmark behind 'spherecull bench-render': one path-traced
 * frame of a scene rendered by sc_render on several back ends (our BVH and
 * Embree's builds), same rays, same seeds, same options. Timings are paired:
 * each repeat renders the frame once per back end, rotating which goes
 * first, and the ratio is the median of the per-repeat ratios. The images
 * are compared pixel by pixel with the first back end's. */
#ifndef SPHERECULL_COMPARE_BENCH_RENDER_H
#define SPHERECULL_COMPARE_BENCH_RENDER_H

#include "bench.h"
#include "spherecull/sc_image.h"
#include "spherecull/sc_render.h"

enum { SC_BENCH_RENDER_MAX_TRACERS = 4 };

typedef struct sc_bench_render_options {
    int spp, bounces, repeats;
    uint64_t seed;
    double exposure;
    int threads[SC_BENCH_MAX_LIST], nthreads;
    /* tracers[0] is the reference image and the numerator of the ratio:
     * "spherecull" (our BVH built with bvh) or any name of the tracer table;
     * the others are compared with it. Embree rows are traced with MXCSR
     * FTZ|DAZ, as Embree asks. */
    const char *tracers[SC_BENCH_RENDER_MAX_TRACERS];
    int ntracers;
    sc_bvh_config bvh;
    /* A pixel differs when a channel's radiance differs by more than
     * tolerance x max(|a|, |b|, 1e-3). */
    double tolerance;
} sc_bench_render_options;

/* 16 spp, 4 bounces, 5 repeats, seed 1, threads 1,2, tracers spherecull,
 * embree, embree-high, embree-robust (Embree when built; the robust build is
 * watertight like ours, so its image must match ours away from edges, where
 * the default builds' may not: a ray slipping through a shared edge is not
 * near the triangle it then reports), the default BVH with every CPU
 * building, tolerance 1e-4. */
void sc_bench_render_options_default(sc_bench_render_options *o);

typedef struct sc_bench_render_row {
    const char *tracer;
    int threads;
    double build_s;              /* of the tracer, every CPU */
    double frame_s;              /* median render time (rendering only) */
    uint64_t rays;               /* per frame: camera, bounce and shadow rays */
    double mrays;                /* rays / frame_s */
    /* On tracers[0]'s row: the median paired ratio of the best Embree's
     * frame time (the Embree row with the lower median) over ours, > 1 when
     * we are faster, and which it was; NaN / NULL without an Embree row. */
    double x_best_embree;
    const char *best_embree;
    /* Against tracers[0]'s image (zero on its own row): pixels where some
     * path passed within SC_RENDER_EDGE_BARY of a triangle edge in either
     * image, and the differing pixels there and elsewhere. */
    size_t pixels, edge_pixels, differ_edge, differ_elsewhere;
    double max_rel_diff_elsewhere;
    const sc_image *image;       /* the frame, valid during the sink call */
} sc_bench_render_row;

typedef struct sc_bench_render_sink {
    void (*row)(void *ctx, const sc_bench_render_row *r);
    void *ctx;
} sc_bench_render_sink;

/* Benchmarks one scene (its camera, lights, emission). Rows go to sink per
 * thread count in tracer order, once all of that count are measured. On
 * error err holds one line. */
sc_status sc_bench_render_run(const sc_scene_view *scene, const sc_bench_render_options *o,
                              const sc_bench_render_sink *sink, char *err, size_t errlen);

#endif

/* The tracer benchmark behind 'spherecull bench': our BVH per prefilter
 * mode x leaf size x thread count against Embree on the same rays, in the
 * same run. Before any timing, every configuration's hits are checked
 * against brute force over all triangles (a sample of rays: a difference is
 * an error) and against Embree (all rays: counted). Timings are paired:
 * each repeat times Embree and us back to back (alternating who goes
 * first) and the ratio is the median of the per-repeat ratios, so load
 * from other processes hits both sides alike. With 1 thread, user-mode
 * cycles are read as well when the kernel allows perf events. */
#ifndef SPHERECULL_COMPARE_BENCH_H
#define SPHERECULL_COMPARE_BENCH_H

#include "spherecull/sc_isa.h"
#include "tracer.h"

/* The ray sets (sc_rays.h): primary rays from the camera; shadow rays (any
 * hit) from their hits to the light; diffuse bounce rays from the same
 * hits; random rays from the mesh's bounding box. All but the shadow rays
 * are closest-hit queries. Adversarial rays are compare's, not timed here. */
enum { SC_BENCH_MAX_LIST = 16, SC_BENCH_MAX_REPEATS = 64, SC_BENCH_KINDS = SC_RAYS_ADVERSARIAL };

typedef struct sc_bench_options {
    sc_rayset_kind kinds[SC_BENCH_KINDS];          /* SC_RAYS_PRIMARY .. SC_RAYS_RANDOM */
    int nkinds;
    int threads[SC_BENCH_MAX_LIST], nthreads;
    int leaves[SC_BENCH_MAX_LIST], nleaves;
    int modes[SC_BENCH_MAX_LIST], nmodes;          /* sc_prefilter_mode */
    int width, height, repeats;
    int count;                                     /* random rays */
    int embree_robust;
    float trav_cost;                               /* < 0: the builder's default */
    sc_tri_test tri;
    int packet;                                    /* 0: single rays; 8, 16: packets (Embree's too) */
    int flatten;                                   /* 1: a scene with instances as its flattened mesh */
    /* Optional: called around every timed block (1 before, 0 after), as
     * sc_cmp_options.timing; NULL: nothing. */
    void (*timing)(void *ctx, int begin);
    void *timing_ctx;
} sc_bench_options;

void sc_bench_options_default(sc_bench_options *o);

/* What one scene's rays are. */
typedef struct sc_bench_scene {
    size_t triangles;
    size_t instances;                    /* traced through this many (0: the flat mesh) */
    float lo[3], hi[3], light[3];
    sc_camera camera;
    size_t primary, primary_hits, shadow, shadow_blocked, diffuse, diffuse_hits, random, random_hits;
    double embree_bpt, embree_bvh_bpt;   /* NaN without Embree */
} sc_bench_scene;

/* One measurement. */
typedef struct sc_bench_row {
    sc_rayset_kind kind;
    int threads, leaf;
    sc_prefilter_mode prefilter;
    sc_isa isa;                                       /* the active level (sc_isa.h) */
    size_t rays;
    double bytes_per_tri, sphere_leaf_pct;
    double mrays, embree_mrays, ratio, cycle_ratio;   /* NaN when not measured */
    sc_tracer_counters work;                          /* of the checking run */
    size_t leaf_count, leaves_with_spheres;
    double build_ms;
    size_t diff_embree, diff_brute;
} sc_bench_row;

typedef struct sc_bench_sink {
    void (*scene)(void *ctx, const sc_bench_scene *s);
    void (*row)(void *ctx, const sc_bench_row *r);
    void *ctx;
} sc_bench_sink;

/* User-mode cycle counter of the calling thread: a file descriptor, or -1
 * when perf events are not allowed. */
int sc_bench_cycles_open(void);

/* Runs the benchmark on one mesh; rows go to sink as they are measured.
 * instances (may be NULL): a scene view with instances whose flattened
 * mesh is `mesh`: unless o->flatten, both tracers run through the instances
 * (sc_tracer_build_scene), the brute-force check runs every instance's
 * object ray through its object, and packets are refused. cycles_fd:
 * sc_bench_cycles_open's or -1. On error err holds one line. */
sc_status sc_bench_run(const sc_mesh_view *mesh, const sc_scene_view *instances, const sc_camera *camera,
                       const sc_light *lights, size_t nlights, const sc_bench_options *o, int cycles_fd,
                       const sc_bench_sink *sink, char *err, size_t errlen);

#endif

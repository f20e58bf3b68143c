/* The side-by-side comparison behind 'spherecull compare': one scene, the
 * seeded ray sets, every tracer, the exact oracle, and one row of metrics per
 * ray set x tracer x thread count. The tracers are tracer.h's table.
 * Private to src/compare and the CLI. */
#ifndef SPHERECULL_COMPARE_COMPARE_H
#define SPHERECULL_COMPARE_COMPARE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "spherecull/sc_camera.h"
#include "spherecull/sc_rays.h"
#include "spherecull/sc_scene.h"

enum { SC_CMP_MAX_THREADS = 8, SC_CMP_MAX_TRACERS = 32, SC_CMP_MAX_REPEATS = 64 };

typedef struct sc_cmp_options {
    unsigned ray_kinds;                 /* bit per sc_rayset_kind */
    const char *tracers[SC_CMP_MAX_TRACERS];
    int ntracers;                       /* 0: every available tracer */
    int threads[SC_CMP_MAX_THREADS];
    int nthreads;
    size_t oracle_rays;                 /* oracle sample per set (0: no oracle) */
    int repeats;                        /* timed rounds (1..SC_CMP_MAX_REPEATS): each times every
                                           tracer once; medians are reported */
    int width, height;                  /* primary rays (the scene camera's aspect is kept) */
    size_t random_rays, adversarial_rays;
    uint64_t seed;
    int oracle_threads;
    double min_seconds;                 /* each timed repeat runs its set until this long (>= 0) */
    int ftz;                            /* 1: FTZ|DAZ in every timed thread, ours and Embree's */
    int flatten;                        /* 1: trace a scene with instances as its flattened mesh */
    const char *embree_build;           /* the Embree in use ("3.13.5 /path"), copied to rows; may be NULL */
    /* Optional: called around every timed block of runs, with 1 before and 0
     * after (the MPI driver keeps the other ranks on the node quiet then);
     * NULL: nothing. */
    void (*timing)(void *ctx, int begin);
    void *timing_ctx;
} sc_cmp_options;

void sc_cmp_options_default(sc_cmp_options *o);

typedef struct sc_cmp_row {
    char scene[64];
    uint32_t triangles;
    size_t instances;                   /* traced through this many instances (0: the flat mesh) */
    int closed;
    sc_rayset_kind rays;
    size_t nrays;
    char tracer[40];
    int threads;
    double mrays_per_s;
    double speed_vs_embree;             /* the median over the rounds of embree's time / this
                                           row's, at the same threads; NaN if none */
    double best_embree;                 /* the same against the faster (by median) Embree of its
                                           kind (single rays: embree or embree-high); NaN if none */
    char best_embree_tracer[40];        /* which one that was ("" if none) */
    char embree_build[128];             /* the Embree the run used ("" without Embree) */
    int ftz;                            /* the MXCSR mode it was timed in */
    int loops;                          /* runs of the set per timed repeat (min_seconds) */
    int rounds;                         /* timed rounds, and each one's seconds for one run of
                                           the set: the rows of one set and thread count were
                                           timed in the same rounds, so round i pairs them */
    double round_s[SC_CMP_MAX_REPEATS];
    size_t oracle_rays;
    size_t hit_miss_disagree, primid_disagree;
    size_t holes, hole_rays;            /* vertex/edge rays that cross the surface: missed / all */
    size_t grazes_missed, graze_rays;   /* rays whose first hit only touches the surface: unreported / all */
    double t_err_median, t_err_max;
    double sphere_tests_per_ray, sphere_reject_rate, false_positive_rate, tri_tests_per_ray;
    double bytes_per_tri;
    double build_s;                     /* the tracer's build on every CPU, seconds */
    int has_prefilter_stats;
} sc_cmp_row;

typedef struct sc_cmp_rows {
    sc_cmp_row *rows;
    size_t count, cap;
} sc_cmp_rows;

void sc_cmp_rows_free(sc_cmp_rows *r);

/* Runs everything for one scene and appends rows. The shadow rays go to
 * sc_light_point of the scene's lights (tracer.h). instances (may be NULL):
 * a scene view with instances whose flattened mesh is `mesh`; then every
 * tracer that can is built through the instances (sc_tracer_build_scene),
 * the others are skipped, and the oracle decides each instance's rounded
 * object-space ray (sc_oracle_run_scene). log (may be NULL) gets progress
 * lines. On error err holds one line. */
sc_status sc_cmp_scene(const char *scene_name, const sc_mesh_view *mesh, const sc_scene_view *instances,
                       const sc_camera *camera, const sc_light *lights, size_t nlights, const sc_cmp_options *opt,
                       sc_cmp_rows *out, FILE *log, char *err, size_t errlen);

/* Output helpers (0 on success). */
int sc_cmp_write_csv(const sc_cmp_rows *rows, FILE *f);
int sc_cmp_write_json(const sc_cmp_rows *rows, FILE *f);
void sc_cmp_print_table(const sc_cmp_rows *rows, FILE *f);
/* gnuplot PNGs (with their data and scripts) into DIR, created if missing:
 * Mrays/s per ray set, and speed against oracle disagreements. */
int sc_cmp_write_plots(const sc_cmp_rows *rows, const char *dir);

#endif

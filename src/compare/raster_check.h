/* raster-check's work: primary-ray hits of our tracer (and Embree when
 * built in) against the OSMesa triangle-ID buffer of the same camera, every
 * disagreeing pixel classified (sc_raster_classify: at an edge, a depth
 * tie, or elsewhere, which is a bug). Built only with the raster reference. */
#ifndef SPHERECULL_COMPARE_RASTER_CHECK_H
#define SPHERECULL_COMPARE_RASTER_CHECK_H

#include "spherecull/sc_raster.h"
#include "tracer.h"

typedef struct sc_rcheck_tracer {
    const char *name;            /* "ours", "embree" */
    uint32_t *ids;               /* per pixel, the raster's encoding: prim + 1, 0 = background */
    double seconds;              /* tracing the primary rays */
    size_t agree, kinds[SC_RASTER_DIFF_COUNT];
    double max_edge_px;          /* over at-edge disagreements */
    uint8_t *cls;                /* per pixel: 0 agree, 1 + sc_raster_diff */
} sc_rcheck_tracer;

typedef struct sc_rcheck {
    sc_rcheck_tracer tr[2];
    int ntr;
    size_t rays;
    double build_seconds;        /* our BVH */
    uint32_t *tests;             /* ours: sphere tests per pixel, when asked for */
    sc_tracer_counters work;     /* ours, when tests were asked for */
} sc_rcheck;

/* Traces, classifies; on error err holds one line and *out is freed. */
sc_status sc_rcheck_run(const sc_mesh_view *mesh, const sc_camera *cam, const sc_raster_image *img,
                        sc_prefilter_mode prefilter, int with_embree, int want_tests, sc_rcheck *out, char *err,
                        size_t errlen);
void sc_rcheck_free(sc_rcheck *c);

/* The target ours must meet: >= 99.5 % of pixels agree, none elsewhere. */
int sc_rcheck_target_met(const sc_rcheck *c, size_t pixels);

#endif

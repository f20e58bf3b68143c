/* The tracers the tools compare, by name: our BVH in any configuration and
 * Embree in its modes, built from one mesh, run over one ray array (closest
 * hit or occlusion) on one or more threads, with the work counters each
 * side can report. 'compare', 'bench' and 'raster-check' all run their
 * tracers through here, so "ours against Embree on these rays" means the
 * same thing everywhere. */
#ifndef SPHERECULL_COMPARE_TRACER_H
#define SPHERECULL_COMPARE_TRACER_H

#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_bvh.h"
#include "spherecull/sc_rays.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"

enum { SC_TRACER_MAX_THREADS = 256 };
enum { SC_TRACER_STREAM = 1 };   /* sc_tracer_def.packet: our stream calls */
enum { SC_TRACER_COHERENT = 1, SC_TRACER_INCOHERENT = 2 };   /* sc_tracer_def.coherence */

typedef enum sc_tracer_family { SC_TRACER_OURS, SC_TRACER_EMBREE } sc_tracer_family;

/* One row of the tracer table, or a configuration built on the fly. */
typedef struct sc_tracer_def {
    const char *name;
    sc_tracer_family family;
    int mode;          /* sc_prefilter_mode (ours) or sc_embree_mode */
    int quality;       /* sc_tri_test (ours) or sc_embree_quality */
    int cluster;       /* Embree user modes: triangles per cluster; 0 = default */
    int packet;        /* 0 (single rays), 8 or 16; ours also SC_TRACER_STREAM */
    int build;         /* ours: sc_build_quality */
    int coherence;     /* Embree packets: 0 = the flag of the ray set (sc_tracer.incoherent),
                        * else SC_TRACER_COHERENT or SC_TRACER_INCOHERENT whatever the rays */
} sc_tracer_def;

/* Work counted inside a tracer; Embree counts only in its user modes. */
typedef struct sc_tracer_counters {
    uint64_t rays, nodes, leaves, sphere_tests, sphere_rejects, tri_tests, tri_hits, false_positives;
} sc_tracer_counters;

void sc_tracer_counters_add(sc_tracer_counters *to, const sc_tracer_counters *c);

typedef struct sc_tracer {
    sc_tracer_def def;
    void *handle;            /* sc_bvh * or sc_embree * */
    double bytes_per_tri;    /* everything the tracer holds, its mesh copy included */
    double build_seconds;    /* wall time of sc_tracer_build / sc_tracer_build_bvh */
    int prefilter;           /* reports sphere tests */
    int counted;             /* reports triangle tests */
    int fp_exact;            /* false positives are counted exactly */
    int incoherent;          /* Embree's stream and packet flag for the next runs: the rays are
                              * incoherent (sc_tracer_set_incoherent); set by the caller */
    int ftz;                 /* sc_tracer_run_threads sets MXCSR flush-to-zero and
                              * denormals-are-zero in every thread it runs this tracer
                              * on (and restores it): Embree asks for it; set by the caller */
    int instanced;           /* built by sc_tracer_build_scene through instances */
    void *aux;               /* Embree through instances: the map back to flat triangles */
} sc_tracer;

/* The ray sets Embree's streams and packets are told are incoherent (bounce
 * and random rays); camera and shadow rays are coherent. */
static inline int sc_tracer_set_incoherent(sc_rayset_kind k) { return k == SC_RAYS_DIFFUSE || k == SC_RAYS_RANDOM; }

/* The named tracers of this build, in table order (NULL-terminated). */
const char *const *sc_tracer_names(int *count);
const sc_tracer_def *sc_tracer_find(const char *name);

/* Builds a table tracer. */
sc_status sc_tracer_build(sc_tracer *t, const sc_tracer_def *def, const sc_checked_mesh *mesh);
/* A table tracer over a scene with instances, traced through them: ours
 * through sc_scene_accel (sc_render.h), Embree through instances of one
 * scene per object (sc_embree_create_instanced); the triangles no instance
 * owns form one mesh beside them. Hits come back as view->mesh indices,
 * like the flat tracers'; ours as single rays, packets (sc_accel_closest16)
 * or streams, as the definition says. SC_ERR_UNSUPPORTED for Embree's
 * packets, streams and user geometry (tracer.c says why). */
sc_status sc_tracer_build_scene(sc_tracer *t, const sc_tracer_def *def, const sc_scene_view *view);
/* Ours through the instances with any configuration (bench's sweep). */
sc_status sc_tracer_build_scene_bvh(sc_tracer *t, const char *name, const sc_bvh_config *cfg,
                                    const sc_scene_view *view);
/* Our BVH with any configuration (bench sweeps leaf size, ISA, ...). */
sc_status sc_tracer_build_bvh(sc_tracer *t, const char *name, const sc_bvh_config *cfg,
                              const sc_checked_mesh *mesh);
void sc_tracer_free(sc_tracer *t);

/* Our BVH behind t, NULL for Embree. */
const sc_bvh *sc_tracer_bvh(const sc_tracer *t);

/* Closest hits into hits[0..n) (occ == NULL) or occlusion into occ[0..n),
 * on the calling thread. ctr (may be NULL) is added to. */
sc_status sc_tracer_run(const sc_tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                        sc_tracer_counters *ctr);

/* The same on 1..SC_TRACER_MAX_THREADS threads (chunks of rays handed out
 * dynamically; the calling thread is one of them); *seconds (may be NULL)
 * gets the wall time. */
sc_status sc_tracer_run_threads(const sc_tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits,
                                uint8_t *occ, int threads, double *seconds);

/* The renderer's back end over t (our BVH or Embree, any table mode):
 * batches run on the calling render thread through sc_tracer_run, Embree's
 * stream flag following the batch's coherence, MXCSR FTZ|DAZ while t runs
 * when t->ftz. b->backend is valid while b and t's handle live. */
typedef struct sc_tracer_backend {
    sc_render_backend backend;
    sc_tracer coherent, incoherent;
} sc_tracer_backend;
void sc_tracer_render_backend(const sc_tracer *t, sc_tracer_backend *b);

/* Same primitive, or (an edge or a tie) the same distance within rel. */
int sc_same_hit(const sc_hitrec *a, const sc_hitrec *b, float rel);

/* The point light for shadow rays: the scene's first point light, else a
 * point two box diagonals back along its first directional light, else
 * one above the box. */
void sc_light_point(const sc_light *lights, size_t nlights, const float lo[3], const float hi[3],
                    float out[3]);

#endif

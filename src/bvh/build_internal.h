/* What the steps of one BVH build share: the binary tree from the SAH
 * step, the triangles for leaf encoding, and the counters of the two
 * collapse passes (measure, then write). */
#ifndef SPHERECULL_BVH_BUILD_INTERNAL_H
#define SPHERECULL_BVH_BUILD_INTERNAL_H

#include "build_binned_sah.h"
#include "bvh_internal.h"

/* The 8-wide nodes at depth 3 (the root is 1): at most 8 x 8 of them. */
#define SC_COLLAPSE_JOB_DEPTH 3
#define SC_COLLAPSE_JOBS (SC_BVH_N * SC_BVH_N)

typedef struct bvh_builder {
    const sc_bvh_config *cfg;
    const sc_mesh_view *meshes;  /* the build input: one or more meshes */
    size_t mesh_count;
    const uint32_t *first;       /* mesh_count + 1: triangle t of mesh g is global id first[g] + t */
    const uint32_t *ids;     /* triangle ids, leaves are contiguous ranges */
    const sc_bnode *bn;      /* the binary tree */
    int dry;                 /* 1: only measure */
    size_t node_used, leaf_used, sphere_used, leaves_emitted, leaves_spheres;
    uint8_t *auto_use;       /* per binary node: auto decision (leaves only) */
    sc_bvh *bvh;
    int max_depth;
    double sah;
    float root_area;
    /* Subtrees as jobs (a tree of SC_SAH_PARALLEL_MIN primitives or more,
     * whatever the thread count): every subtree whose 8-wide node lies at
     * depth SC_COLLAPSE_JOB_DEPTH is recorded by a first walk of the top
     * levels (record: its binary children, nothing below), measured on
     * the threads from zero counters (sc_collapse_measure_jobs), placed by
     * a second walk (defer: its nodes next in the node order, its leaves
     * from the next 64-byte boundary, so that their alignment is the one
     * measured, and its figures added in tree order), and written on the
     * threads at those places (sc_collapse_jobs). */
    int record, defer;
    size_t njobs, next_job;
    /* SC_COLLAPSE_JOBS of them, the caller's: not in this struct, which
     * the workers copy while others write their jobs' figures */
    struct collapse_job *jobs;
} bvh_builder;

struct collapse_job {
    uint32_t kids[2];
    int nk;
    size_t node_in, leaf_in;      /* where it is placed */
    /* measured from zero: */
    size_t nodes, leaf_bytes, sphere_used, leaves_emitted, leaves_spheres;
    double sah;
    int max_depth;
};

/* Runs fn(arg) on the calling thread and on up to threads - 1 (and at most
 * extra) POSIX threads of its own, and joins them: the build steps' shared
 * pool. fn takes work from arg until none is left; if a thread cannot be
 * started the others do its share. */
void sc_build_run_workers(void *(*fn)(void *), void *arg, int threads, size_t extra);
/* A configuration's thread count: 0 becomes the online CPUs (at most SC_BVH_MAX_THREADS). */
int sc_build_threads(int cfg_threads);

/* SC_BUILD_QUALITY_AUTO's choice for the triangle boxes pbox[0..n). */
sc_build_quality sc_build_auto_quality(const box3 *pbox, size_t n);

/* Measures the recorded subtrees, then writes them where the placing walk
 * put them, each on up to `threads` threads. */
void sc_collapse_measure_jobs(bvh_builder *B, int threads);
void sc_collapse_jobs(bvh_builder *B, int threads);

static inline const float *vtx(const bvh_builder *B, uint32_t tri, int corner)
{
    const sc_mesh_view *m = B->meshes;
    if (B->mesh_count > 1) {
        size_t g = sc_mesh_of(B->first, B->mesh_count, tri);
        m += g;
        tri -= B->first[g];
    }
    return sc_mesh_vertex(m, sc_mesh_triangle(m, tri)[corner]);
}

/* Writes (or, dry, measures) the 8-wide node over binary nodes kids[0..nk)
 * and everything below it; returns its reference. */
uint64_t sc_collapse_bvh8(bvh_builder *B, const uint32_t *kids, int nk, int depth);
/* Writes (or measures) the leaf block of binary leaf bi; returns its reference. */
uint64_t sc_leaf_emit(bvh_builder *B, uint32_t bi);

/* Refit: rewrites the leaf block of reference ref (its vertex rows and its
 * spheres or summary) from B's meshes, the triangles it holds unchanged, and
 * returns the box of its triangles in *box. */
void sc_leaf_refit(const bvh_builder *B, uint64_t ref, box3 *box);

#endif

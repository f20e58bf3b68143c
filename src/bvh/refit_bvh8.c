/* Refit: the tree of a build kept, every box, vertex row and sphere
 * recomputed from the meshes' current vertices, bottom-up. The leaves hold
 * the same triangles, so a tree fitted to the new vertices is exactly as
 * conservative as a fresh build (exact float min/max boxes, spheres padded
 * as the builder pads them); only its SAH cost can grow, which sah_cost
 * reports against built_sah_cost. */
#include <math.h>
#include <stdatomic.h>
#include <string.h>

#include "build_internal.h"

/* The tree is refitted in two parts: the subtrees below the top
 * REFIT_SPLIT_DEPTH levels as jobs on the build's threads, then the top
 * levels over their boxes. The split is the same for any thread count and
 * the SAH terms are summed in the same order (each job's own sum, then the
 * jobs' sums in tree order), so the result does not depend on the threads. */
#define REFIT_SPLIT_DEPTH 2
#define REFIT_PARALLEL_MIN 65536   /* triangles: below, one thread (the same sums) */

typedef struct refit_job {
    size_t offset;       /* the subtree's root node */
    box3 box;
    double sah;          /* its terms, not yet divided by the root's area */
} refit_job;

/* 8-wide nodes at depth REFIT_SPLIT_DEPTH (the root is 0): at most 8 x 8 */
#define REFIT_MAX_JOBS (SC_BVH_N * SC_BVH_N)
_Static_assert(REFIT_SPLIT_DEPTH == 2, "REFIT_MAX_JOBS counts the nodes at depth 2");

typedef struct refit_ctx {
    bvh_builder B;
    refit_job jobs[REFIT_MAX_JOBS];
    size_t njobs, next;  /* collected by the first walk, consumed in the same order by the second */
    atomic_size_t claim; /* the workers' next job */
} refit_ctx;

static void refit_store(sc_bvh_node8 *node, int i, const box3 *b)
{
    for (int k = 0; k < 3; k++) {
        node->b[2 * k][i] = b->lo[k];
        node->b[2 * k + 1][i] = b->hi[k];
    }
}

/* One walk of the tree from a node at `depth`: below REFIT_SPLIT_DEPTH
 * everything is refitted here (split < 0: no split); at it, the first
 * walk of the top levels records the subtree as a job (collect, nothing
 * refitted) and the second takes the job's box and SAH terms. */
typedef struct refit_walker {
    refit_ctx *R;
    int split, collect;
    double sah;
} refit_walker;

static box3 refit_walk(refit_walker *w, size_t offset, int depth)
{
    refit_ctx *R = w->R;
    box3 all;
    box_empty(&all);
    if (depth == w->split) {
        if (w->collect) {
            R->jobs[R->njobs++].offset = offset;
        } else {
            all = R->jobs[R->next].box;
            w->sah += R->jobs[R->next].sah;
            R->next++;
        }
        return all;
    }
    sc_bvh_node8 *node = (sc_bvh_node8 *)(void *)((unsigned char *)R->B.bvh->nodes + offset);
    for (int i = 0; i < SC_BVH_N; i++) {
        const uint64_t c = node->child[i];
        box3 b;
        box_empty(&b);
        if (c && sc_ref_is_leaf(c)) {
            if (!w->collect) {
                sc_leaf_refit(&R->B, c, &b);
                w->sah += (double)box_area(&b) * leaf_blocks(sc_ref_count(c));
            }
        } else if (c) {
            b = refit_walk(w, sc_ref_offset(c), depth + 1);
        }
        if (!w->collect) {
            refit_store(node, i, &b);
            box_grow(&all, &b);
        }
    }
    if (!w->collect)
        w->sah += (double)R->B.cfg->traversal_cost * box_area(&all);
    return all;
}

static void *refit_work(void *arg)
{
    refit_ctx *R = arg;
    for (;;) {
        const size_t i = atomic_fetch_add(&R->claim, 1);
        if (i >= R->njobs)
            return NULL;
        refit_job *j = &R->jobs[i];
        refit_walker w = { R, -1, 0, 0 };
        j->box = refit_walk(&w, j->offset, REFIT_SPLIT_DEPTH);
        j->sah = w.sah;
    }
}

sc_status sc_bvh_refit_set(sc_bvh *bvh, const sc_mesh_view *meshes, size_t mesh_count)
{
    if (!bvh || !meshes || mesh_count != bvh->mesh_count)
        return SC_ERR_INVALID_ARGUMENT;
    /* Everything is checked before anything is written: a refit that
     * fails leaves the tree as it was. */
    for (size_t g = 0; g < mesh_count; g++) {
        const sc_mesh_view *m = &meshes[g];
        if (sc_bvh_check_mesh(m) != SC_OK || m->triangle_count != (size_t)(bvh->first[g + 1] - bvh->first[g]))
            return SC_ERR_INVALID_ARGUMENT;
        for (size_t t = 0; t < m->triangle_count; t++) {
            const uint32_t *ix = sc_mesh_triangle(m, t);
            for (int corner = 0; corner < 3; corner++) {
                const float *p = sc_mesh_vertex(m, ix[corner]);
                if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
                    return SC_ERR_NONFINITE;
            }
        }
    }
    /* A triangle left out of the build (non-finite then) has no leaf to go
     * back into: only a rebuild can add it. */
    if (bvh->skipped)
        return SC_ERR_NONFINITE;
    if (!bvh->has_root)
        return SC_OK;
    refit_ctx R = { .B = { .cfg = &bvh->cfg, .meshes = meshes, .mesh_count = mesh_count, .first = bvh->first,
                           .bvh = bvh } };
    refit_walker collect = { &R, REFIT_SPLIT_DEPTH, 1, 0 }, fit = { &R, REFIT_SPLIT_DEPTH, 0, 0 };
    refit_walk(&collect, 0, 0);
    atomic_init(&R.claim, 0);
    const size_t tris = (size_t)bvh->first[mesh_count];
    sc_build_run_workers(refit_work, &R, tris >= REFIT_PARALLEL_MIN ? sc_build_threads(bvh->cfg.threads) : 1,
                         R.njobs);
    const box3 root = refit_walk(&fit, 0, 0);   /* fit.sah: not yet divided by the root's area */
    float area = box_area(&root);
    if (!(area > 0))
        area = 1;
    for (int k = 0; k < 3; k++)
        bvh->root_lo[k] = root.lo[k], bvh->root_hi[k] = root.hi[k];
    bvh->sah_cost = fit.sah / area;
    return SC_OK;
}

sc_status sc_bvh_refit(sc_bvh *bvh, const sc_mesh_view *mesh)
{
    if (!mesh)
        return SC_ERR_INVALID_ARGUMENT;
    return sc_bvh_refit_set(bvh, mesh, 1);
}

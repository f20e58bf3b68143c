/* Collapse of the binary SAH tree into the 8-wide layout (node_bvh8.h) by
 * repeatedly opening the child with the largest surface area, as Embree's
 * BVH8 builder does. Runs twice with the same order: once to measure
 * (B->dry), once to write. */
#include <math.h>
#include <stdatomic.h>
#include <string.h>

#include "build_internal.h"

static uint64_t collapse_node(bvh_builder *B, const uint32_t *kids_in, int nk_in, int depth);

uint64_t sc_collapse_bvh8(bvh_builder *B, const uint32_t *kids_in, int nk_in, int depth)
{
    if (depth == SC_COLLAPSE_JOB_DEPTH && B->record) {
        /* the first walk: the subtree is a job, measured later */
        struct collapse_job *j = &B->jobs[B->njobs++];
        memcpy(j->kids, kids_in, sizeof(uint32_t) * (size_t)nk_in);
        j->nk = nk_in;
        return 0;
    }
    if (depth == SC_COLLAPSE_JOB_DEPTH && B->defer) {
        /* the placing walks: the measured subtree goes here */
        struct collapse_job *j = &B->jobs[B->next_job++];
        j->node_in = B->node_used;
        j->leaf_in = (B->leaf_used + 63) / 64 * 64;
        B->node_used += j->nodes;
        B->leaf_used = j->leaf_in + j->leaf_bytes;
        B->sphere_used += j->sphere_used;
        B->leaves_emitted += j->leaves_emitted;
        B->leaves_spheres += j->leaves_spheres;
        B->sah += j->sah;
        if (j->max_depth > B->max_depth)
            B->max_depth = j->max_depth;
        return (uint64_t)(j->node_in * sizeof(sc_bvh_node8));
    }
    return collapse_node(B, kids_in, nk_in, depth);
}

static uint64_t collapse_node(bvh_builder *B, const uint32_t *kids_in, int nk_in, int depth)
{
    uint32_t kids[SC_BVH_N];
    int nk = nk_in;
    memcpy(kids, kids_in, sizeof(uint32_t) * (size_t)nk);
    while (nk < SC_BVH_N) {
        int best = -1;
        float best_area = -1;
        for (int i = 0; i < nk; i++) {
            const sc_bnode *c = &B->bn[kids[i]];
            if (!c->leaf && box_area(&c->box) > best_area) {
                best_area = box_area(&c->box);
                best = i;
            }
        }
        if (best < 0)
            break;
        const sc_bnode *c = &B->bn[kids[best]];
        kids[best] = c->a;
        kids[nk++] = c->b;
    }
    /* Children by decreasing surface area: an any-hit query visits them in
     * slot order, and a larger box is more likely to hold an occluder. */
    for (int i = 1; i < nk; i++) {
        uint32_t k = kids[i];
        float a = box_area(&B->bn[k].box);
        int j = i;
        while (j > 0 && box_area(&B->bn[kids[j - 1]].box) < a) {
            kids[j] = kids[j - 1];
            j--;
        }
        kids[j] = k;
    }
    size_t my = B->node_used++;
    if (depth > B->max_depth)
        B->max_depth = depth;
    box3 all;
    box_empty(&all);
    for (int i = 0; i < nk; i++)
        box_grow(&all, &B->bn[kids[i]].box);
    B->sah += B->cfg->traversal_cost * (double)box_area(&all) / B->root_area;
    uint64_t refs[SC_BVH_N] = { 0 };
    for (int i = 0; i < nk; i++) {
        const sc_bnode *c = &B->bn[kids[i]];
        if (c->leaf) {
            refs[i] = sc_leaf_emit(B, kids[i]);
        } else {
            uint32_t two[2] = { c->a, c->b };
            refs[i] = sc_collapse_bvh8(B, two, 2, depth + 1);
        }
    }
    if (!B->dry) {
        sc_bvh_node8 *node = &B->bvh->nodes[my];
        for (int i = 0; i < SC_BVH_N; i++) {
            const box3 *b = i < nk ? &B->bn[kids[i]].box : NULL;
            for (int k = 0; k < 3; k++) {
                node->b[2 * k][i] = b ? b->lo[k] : INFINITY;
                node->b[2 * k + 1][i] = b ? b->hi[k] : -INFINITY;
            }
            node->child[i] = refs[i];
        }
    }
    return (uint64_t)(my * sizeof(sc_bvh_node8));
}


typedef struct collapse_worker {
    bvh_builder *B;
    atomic_size_t *next;
    int measure;
} collapse_worker;

static void *collapse_work(void *arg)
{
    collapse_worker *w = arg;
    for (;;) {
        size_t k = atomic_fetch_add(w->next, 1);
        if (k >= w->B->njobs)
            return NULL;
        struct collapse_job *j = &w->B->jobs[k];
        /* a private builder over the subtree: from zero counters to
         * measure it, from its place to write it (the same bytes, as its
         * leaves start on a 64-byte boundary either way) */
        bvh_builder L = *w->B;
        L.defer = L.record = 0;
        L.dry = w->measure;
        L.node_used = w->measure ? 0 : j->node_in;
        L.leaf_used = w->measure ? 0 : j->leaf_in;
        L.sphere_used = L.leaves_emitted = L.leaves_spheres = 0;
        L.sah = 0;
        L.max_depth = 0;
        sc_collapse_bvh8(&L, j->kids, j->nk, SC_COLLAPSE_JOB_DEPTH);
        if (w->measure) {
            j->nodes = L.node_used, j->leaf_bytes = L.leaf_used;
            j->sphere_used = L.sphere_used, j->leaves_emitted = L.leaves_emitted;
            j->leaves_spheres = L.leaves_spheres;
            j->sah = L.sah, j->max_depth = L.max_depth;
        }
    }
}

static void run_jobs(bvh_builder *B, int threads, int measure)
{
    atomic_size_t next;
    atomic_init(&next, 0);
    collapse_worker w = { B, &next, measure };
    sc_build_run_workers(collapse_work, &w, threads, B->njobs ? B->njobs - 1 : 0);
}

void sc_collapse_measure_jobs(bvh_builder *B, int threads)
{
    run_jobs(B, threads, 1);
}

void sc_collapse_jobs(bvh_builder *B, int threads)
{
    run_jobs(B, threads, 0);
}

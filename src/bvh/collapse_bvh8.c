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
    if (depth == SC_COLLAPSE_JOB_DEPTH && B->defer && B->next_job < B->njobs) {
        /* the subtree the measuring pass recorded as this one */
        const struct collapse_job *j = &B->jobs[B->next_job++];
        B->node_used = j->node_out, B->leaf_used = j->leaf_out;
        return (uint64_t)(j->node_in * sizeof(sc_bvh_node8));
    }
    if (depth == SC_COLLAPSE_JOB_DEPTH && B->record && B->njobs < SC_COLLAPSE_JOBS) {
        struct collapse_job *j = &B->jobs[B->njobs++];
        memcpy(j->kids, kids_in, sizeof(uint32_t) * (size_t)nk_in);
        j->nk = nk_in;
        j->node_in = B->node_used, j->leaf_in = B->leaf_used;
        const uint64_t ref = collapse_node(B, kids_in, nk_in, depth);
        j->node_out = B->node_used, j->leaf_out = B->leaf_used;
        return ref;
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
} collapse_worker;

static void *collapse_work(void *arg)
{
    collapse_worker *w = arg;
    for (;;) {
        size_t k = atomic_fetch_add(w->next, 1);
        if (k >= w->B->njobs)
            return NULL;
        /* a private builder: its counters start where the measuring pass
         * found this subtree's, so it writes the nodes and leaves it wrote */
        bvh_builder L = *w->B;
        L.defer = L.record = 0;
        L.node_used = L.jobs[k].node_in, L.leaf_used = L.jobs[k].leaf_in;
        sc_collapse_bvh8(&L, L.jobs[k].kids, L.jobs[k].nk, SC_COLLAPSE_JOB_DEPTH);
    }
}

void sc_collapse_jobs(bvh_builder *B, int threads)
{
    atomic_size_t next;
    atomic_init(&next, 0);
    collapse_worker w = { B, &next };
    sc_build_run_workers(collapse_work, &w, threads, B->njobs ? B->njobs - 1 : 0);
}
